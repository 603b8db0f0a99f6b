"""The output marker (:data:`MARKER_NAME`, ``.berryshaker-output.json``) that says "berryshaker wrote this folder":
per command -- ``kind``, e.g. ``"kinematics --plot"`` -- the files it wrote with their sha256.  Read back
(:func:`read_output_marker`, :func:`marker_owners`), written (``_marker``), and each entry's state in the folder
now: missing, berryshaker's own unchanged file, unverified (an older marker without checksums) or changed (modified,
a symlink, reached through a symlink or resolving outside the folder); only its own unchanged file is ever replaced
or removed.
"""

from __future__ import annotations

import json
import os
import re
import stat
from datetime import datetime, timezone
from pathlib import Path, PurePosixPath
from typing import Iterable

from berryshaker import __version__
from berryshaker.outputs.atomic_files import file_sha256

#: Name of the marker file that says "berryshaker wrote this folder" and lists the files it wrote.
MARKER_NAME = ".berryshaker-output.json"


def _safe_relpaths(names: Iterable) -> set[str]:
    """Marker entries that are plain relative paths inside the folder (a hand-edited marker cannot point
    outside it)."""
    out = set()
    for n in names:
        if not isinstance(n, str) or not n:
            continue
        p = PurePosixPath(n)
        if p.is_absolute() or ".." in p.parts or "." in n.split("/") or n == MARKER_NAME or "\\" in n or "\0" in n:
            continue
        out.add(p.as_posix())
    return out


def read_output_marker(folder: str | Path) -> dict | None:
    """The marker of a previous berryshaker output in ``folder`` (kind, version, written, files, outputs), or
    ``None`` when there is none or it is not a valid berryshaker marker.

    Parameters
    ----------
    folder : str or Path
        The output folder.

    Returns
    -------
    dict or None
        The marker.
    """
    p = Path(folder) / MARKER_NAME
    try:
        if p.is_symlink() or not p.is_file():
            return None
        data = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or data.get("package") != "berryshaker" or not isinstance(data.get("files"), list):
        return None
    if "outputs" in data and not isinstance(data["outputs"], dict):
        return None
    return data


def marker_owners(marker: dict | None) -> dict[str, dict[str, str | None]]:
    """Who wrote what, from a marker: ``{command: {relative path: sha256 or None}}``.

    A marker of this version records each command's files with their sha256 (``outputs``); an older marker
    (``kind`` and ``files`` only) gives its files without digests (``None``): such a file is never replaced or
    removed (a file's time is no evidence that the user left it alone).
    Entries that are not plain relative paths inside the folder are dropped.

    Parameters
    ----------
    marker : dict or None
        A marker (:func:`read_output_marker`).

    Returns
    -------
    dict
        Command -> {relative path: sha256 or None}.
    """
    if not marker:
        return {}
    owners: dict[str, dict[str, str | None]] = {}
    outputs = marker.get("outputs")
    if isinstance(outputs, dict):
        for kind, entry in outputs.items():
            files = entry.get("files") if isinstance(entry, dict) else None
            if not isinstance(kind, str) or not isinstance(files, dict):
                continue
            ok = _safe_relpaths(files)
            owners[kind] = {rel: (d if isinstance(d, str) and re.fullmatch(r"[0-9a-f]{64}", d) else None)
                            for rel, d in files.items() if rel in ok}
        return owners
    kind = marker.get("kind") if isinstance(marker.get("kind"), str) else "output"
    owners[kind] = {rel: None for rel in _safe_relpaths(marker["files"])}
    return owners


def _inside(folder: Path, rel: str) -> Path | None:
    """``folder / rel`` if no folder on the way to it is a symlink or a non-folder and it resolves inside
    ``folder``; else ``None`` (such an entry is never replaced or removed)."""
    target = folder / rel
    d = folder
    for part in PurePosixPath(rel).parts[:-1]:
        d = d / part
        try:
            st_ = os.lstat(d)
        except FileNotFoundError:
            break  # nothing further exists: the target cannot either
        except OSError:
            return None
        if not stat.S_ISDIR(st_.st_mode):
            return None
    real_folder = os.path.realpath(folder)
    if not os.path.realpath(target.parent).startswith(real_folder.rstrip(os.sep) + os.sep) and \
            os.path.realpath(target.parent) != real_folder:
        return None
    return target


def _entry_state(folder: Path, rel: str, digest: str | None) -> str:
    """``"missing"``, ``"ours"`` (the file berryshaker wrote, unchanged: its sha256 is the marker's),
    ``"unverified"`` (listed by an older marker without checksums: nothing tells whether the user changed it, so
    it is never replaced or removed) or ``"changed"`` (modified, replaced by a symlink or something else, or
    reached through a symlink: never touched).  The marker's date is no evidence: a file's time can be anything."""
    target = _inside(folder, rel)
    if target is None:
        return "changed"
    try:
        st_ = os.lstat(target)
    except FileNotFoundError:
        return "missing"
    except OSError:
        return "changed"
    if not stat.S_ISREG(st_.st_mode):
        return "changed"
    if digest is None:  # an older marker without checksums: file times prove nothing
        return "unverified"
    return "ours" if file_sha256(target) == digest else "changed"


def _changed_own_files(folder: Path, marker: dict | None, kind: str) -> list[str]:
    """Files ``kind`` wrote into ``folder`` earlier that were changed since, or that an older marker lists without
    a checksum (never replaced or removed)."""
    owners = marker_owners(marker)
    return sorted(rel for rel, d in owners.get(kind, {}).items()
                  if _entry_state(folder, rel, d) in ("changed", "unverified"))


def unverified_reason(marker: dict | None, kind: str, names: list[str]) -> str:
    """Why files listed by ``kind`` in ``marker`` are refused: changed, or (for an older marker) recorded without
    checksums.

    Parameters
    ----------
    marker : dict or None
        The marker (:func:`read_output_marker`).
    kind : str
        The command.
    names : list of str
        The refused files.

    Returns
    -------
    str
        "" when they changed; else the clause saying that the marker holds no checksum for them.
    """
    owners = marker_owners(marker).get(kind, {})
    if any(owners.get(n, "") is None for n in names):
        return (" (an earlier berryshaker listed them without checksums, so it cannot tell whether you changed "
                "them)")
    return ""


def _marker(kind: str, owners: dict[str, dict[str, str | None]], previous: dict | None = None) -> dict:
    """The marker: ``outputs`` holds each command's files with their sha256; ``files`` (every file listed, for
    readers of older versions) and ``kind`` (the last writer) are kept as before."""
    now = datetime.now(timezone.utc).isoformat(timespec="seconds")
    prev_outputs = (previous or {}).get("outputs") if isinstance((previous or {}).get("outputs"), dict) else {}
    outputs = {}
    for k, files in sorted(owners.items()):
        if not files and k != kind:
            continue
        old = prev_outputs.get(k) if isinstance(prev_outputs.get(k), dict) else {}
        outputs[k] = {"version": __version__ if k == kind else old.get("version"),
                      "written": now if k == kind else old.get("written"),
                      "files": dict(sorted(files.items()))}
    every = sorted({rel for files in owners.values() for rel in files})
    return {"package": "berryshaker", "kind": kind, "version": __version__, "written": now, "files": every,
            "outputs": outputs}
