"""Safe output: a file appears complete or not at all, and nothing the user made is ever overwritten or removed.

* :func:`check_output_file` and :func:`prepare_output_dir` check a destination *before* any work and raise
  :class:`berryshaker.errors.OutputError` with the reason and what to do.
* A folder of outputs is filled in a hidden staging folder beside it (:func:`staged_directory`) and moved into
  place only when everything succeeded.  The finished folder carries a marker file
  (``.berryshaker-output.json``: per command -- ``kind``, e.g. ``"kinematics --plot"`` -- the files it wrote with
  their sha256), so a later run of the same command may replace exactly those files while they are unchanged --
  and never a file the user put there or changed, a file another command wrote, or anything reached through a
  symlink.

long module: destination checks, staging, the marker's ownership and digests and the atomic writers are one
protocol; split, each part would need the others' private rules.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import os
import re
import shutil
import socket
import stat
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path, PurePosixPath
from typing import Iterable, Iterator

from berryshaker import __version__

#: Name of the marker file that says "berryshaker wrote this folder" and lists the files it wrote.
MARKER_NAME = ".berryshaker-output.json"
#: Staging folders are ``.<final name>.berryshaker-staging.<host>-<pid>.<random>`` beside the destination.
STAGING_TAG = ".berryshaker-staging."
#: A staging folder of a dead process on this host, or any staging folder older than this, is removed.
STALE_STAGING_HOURS = 6.0
#: Staging folders from another host (shared disks) are only removed after this long.
STALE_FOREIGN_STAGING_HOURS = 7 * 24.0

_STAGING_RE = re.compile(r"^\..*\.berryshaker-staging\.([0-9a-f]{6})-(\d+)\.[A-Za-z0-9_]+$")


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _absolute(path: str | Path) -> Path:
    return Path(os.path.abspath(Path(path).expanduser()))


def write_text_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` via a temporary file in the same folder and an atomic rename.

    Parameters
    ----------
    path : str or Path
        The file (its folder is created).
    text : str
        The content (UTF-8).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; outputs are ordinary files
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def write_json_atomic(path: str | Path, obj) -> None:
    """Write ``obj`` as indented JSON to ``path`` atomically (see :func:`write_text_atomic`).

    Parameters
    ----------
    path : str or Path
        The file.
    obj : Any
        A JSON-serialisable object.
    """
    write_text_atomic(path, json.dumps(obj, indent=2, sort_keys=False) + "\n")


# ---- destination checks ---------------------------------------------------------------------------
def _check_creatable(path: Path) -> None:
    """Raise OutputError unless ``path`` (absent) can be created: its nearest existing ancestor must be a
    writable folder."""
    from berryshaker.errors import OutputError

    anc = path.parent
    while not anc.exists() and anc != anc.parent:
        if anc.is_symlink():
            raise OutputError(f"cannot create {path}: {anc} is a broken link; choose another location")
        anc = anc.parent
    if not anc.is_dir():
        raise OutputError(f"cannot create {path}: {anc} is a file, not a folder; choose another location")
    if not os.access(anc, os.W_OK | os.X_OK):
        raise OutputError(f"cannot create {path}: no permission to write in {anc}; choose another location")
    _probe(anc, f"cannot create {path}")


def _probe(folder: Path, what: str) -> None:
    """Raise OutputError unless a file can really be created in ``folder`` (``os.access`` says yes for root in
    /proc, on a read-only mount...): a hidden empty file is created and removed at once."""
    from berryshaker.errors import OutputError

    try:
        fd, tmp = tempfile.mkstemp(prefix=".berryshaker-probe.", dir=folder)
    except OSError as exc:
        raise OutputError(f"{what}: files cannot be created in {folder} ({exc.strerror or exc}); choose another "
                          "location") from None
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(tmp)


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
    (``kind`` and ``files`` only) gives its files without digests (``None``): such a file is replaced or
    removed only by the same kind of output and only when it was not modified after the marker was written.
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


def file_sha256(path: str | Path) -> str | None:
    """sha256 (hex) of the regular file ``path``, or ``None`` if it is not one (a symlink, FIFO, device, folder
    or nothing); never follows a symlink and never blocks on a FIFO.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    str or None
        The digest.
    """
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    try:
        fd = os.open(path, flags)
    except OSError:
        return None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return None
        h = hashlib.sha256()
        with os.fdopen(fd, "rb", closefd=False) as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
        return h.hexdigest()
    except OSError:
        return None
    finally:
        os.close(fd)


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


def _entry_state(folder: Path, rel: str, digest: str | None, written: float | None) -> str:
    """``"missing"``, ``"ours"`` (the file berryshaker wrote, unchanged) or ``"changed"`` (modified, replaced by
    a symlink or something else, or reached through a symlink: never touched)."""
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
    if digest is not None:
        return "ours" if file_sha256(target) == digest else "changed"
    # an older marker without digests: trust the file only if nobody touched it after the marker was written
    return "ours" if written is not None and st_.st_mtime <= written + 2.0 else "changed"


def _written_time(marker: dict | None) -> float | None:
    try:
        return datetime.fromisoformat(marker["written"]).timestamp()
    except (KeyError, TypeError, ValueError):
        return None


def _changed_own_files(folder: Path, marker: dict | None, kind: str) -> list[str]:
    """Files ``kind`` wrote into ``folder`` earlier that were changed since (never replaced or removed)."""
    owners = marker_owners(marker)
    written = _written_time(marker)
    return sorted(rel for rel, d in owners.get(kind, {}).items() if _entry_state(folder, rel, d, written) == "changed")


def _shown(names: list[str]) -> str:
    return ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")


def prepare_output_dir(path: str | Path, kind: str = "study") -> Path:
    """Check an output folder before any work; return it as an absolute path (nothing is created).

    Allowed: a path that does not exist (its parent must be creatable), an empty folder, or a folder
    holding a previous berryshaker output (it has the marker file :data:`MARKER_NAME`; only the files that
    marker lists *for this command* will be replaced, those of other commands and the user's are kept).
    Refused with :class:`berryshaker.errors.OutputError`: an existing file, a folder with anything else in it
    (for example ``--out .`` in a folder with your files), a folder that cannot be written, and a folder where
    a file this command wrote earlier was changed since (named in the message).

    Parameters
    ----------
    path : str or Path
        Destination folder.
    kind : str
        The command and flag that write there (``"study"``, ``"kinematics --plot"``...): the marker records it,
        and messages name it.

    Returns
    -------
    Path
        The folder as an absolute path.
    """
    from berryshaker.errors import OutputError

    p = _absolute(path)
    if p.is_symlink() and not p.exists():
        raise OutputError(f"{kind} output {p} is a broken link; choose a new folder")
    if not p.exists():
        _check_creatable(p)
        return p
    if not p.is_dir():
        raise OutputError(f"{kind} output {p} is an existing file, not a folder; nothing was written. "
                          "Choose a new folder name")
    if not os.access(p, os.W_OK | os.X_OK):
        raise OutputError(f"{kind} output {p}: no permission to write in this folder; choose another folder")
    try:
        entries = sorted(e.name for e in p.iterdir())
    except OSError as exc:
        raise OutputError(f"{kind} output {p} cannot be read ({exc.strerror}); choose another folder") from None
    if not entries:
        return p
    marker = read_output_marker(p)
    if marker is not None:
        changed = _changed_own_files(p, marker, kind)
        if changed:
            raise OutputError(f"{kind} output {p}: {_shown(changed)} changed since berryshaker wrote "
                              f"{'it' if len(changed) == 1 else 'them'} (or became a link or another kind of file); "
                              "refusing to replace or remove it, and nothing was written. Move it away or choose a "
                              "new folder")
        return p
    why = (f"holds a damaged {MARKER_NAME}" if MARKER_NAME in entries
           else "is not empty and was not written by berryshaker")
    raise OutputError(f"{kind} output {p} {why} ({_shown(entries)}); refusing to write there so none of your files "
                      "is overwritten, and nothing was written. Choose a new folder (or an empty one)")


def check_output_file(path: str | Path, allowed_suffixes: Iterable[str] | None = None,
                      overwrite: bool = False) -> Path:
    """Check an output file before any work; return it as an absolute path (nothing is created).

    Refused with :class:`berryshaker.errors.OutputError`: a folder, a suffix not in ``allowed_suffixes``
    (case-insensitive, e.g. ``[".csv", ".parquet"]``), an existing file unless ``overwrite`` (the CLI's
    ``--force``), anything that is not a regular file, a parent folder that cannot be created.

    Parameters
    ----------
    path : str or Path
        The file.
    allowed_suffixes : iterable of str, optional
        The suffixes accepted (default any).
    overwrite : bool
        An existing file may be replaced.

    Returns
    -------
    Path
        The file as an absolute path.
    """
    from berryshaker.errors import OutputError

    p = _absolute(path)
    allowed = [s.lower() if s.startswith(".") else "." + s.lower() for s in (allowed_suffixes or [])]
    if p.is_dir():
        example = p / ("results" + (allowed[0] if allowed else ".csv"))
        raise OutputError(f"output {p} is a folder; give a file name inside it, e.g. {example}")
    if allowed:
        if not any(p.name.lower().endswith(s) and len(p.name) > len(s) for s in allowed):
            raise OutputError(f"output {p}: expected a file ending in {' or '.join(allowed)} "
                              f"(got {p.suffix or 'no suffix'}); change the name or the format")
    if p.is_symlink() or p.exists():
        if not p.is_file():
            raise OutputError(f"output {p} exists and is not a regular file; choose another name")
        if not overwrite:
            raise OutputError(f"output {p} already exists; choose another name or pass --force to replace it")
        if not os.access(p.parent, os.W_OK | os.X_OK):
            raise OutputError(f"output {p}: no permission to write in {p.parent}; choose another location")
        _probe(p.parent, f"output {p}")
        return p
    if p.parent.exists():
        if not p.parent.is_dir():
            raise OutputError(f"output {p}: {p.parent} is a file, not a folder; choose another location")
        if not os.access(p.parent, os.W_OK | os.X_OK):
            raise OutputError(f"output {p}: no permission to write in {p.parent}; choose another location")
        _probe(p.parent, f"output {p}")
    else:
        _check_creatable(p.parent)
    return p


# ---- files written in pairs (a sheet and its printable copy) ------------------------------------------------
_STAMP_RE = re.compile(r"<!-- berryshaker ([a-z -]+): sha256=([0-9a-f]{64})((?: [a-z0-9_]+=[0-9a-f]{64})*) -->\n?\Z")


def stamp_html(html: str, kind: str, companions: dict[str, str]) -> str:
    """``html`` with a last line (an HTML comment) recording the command that wrote it, the sha256 of the page above
    that line and the sha256 of the files written with it (``companions``: key -> sha256), so that a later
    ``--force`` can tell its own unchanged outputs from files the user made or changed (:func:`check_forced_pair`).

    Parameters
    ----------
    html : str
        The page.
    kind : str
        The command that writes it.
    companions : dict
        Key -> sha256 of the files written with it.

    Returns
    -------
    str
        The stamped page.
    """
    body = html if html.endswith("\n") else html + "\n"
    own = hashlib.sha256(body.encode("utf-8")).hexdigest()
    extra = "".join(f" {k}={d}" for k, d in sorted(companions.items()))
    return body + f"<!-- berryshaker {kind}: sha256={own}{extra} -->\n"


def read_html_stamp(path: str | Path, kind: str) -> dict[str, str] | None:
    """The companions' sha256 recorded by :func:`stamp_html` in the regular file ``path`` written by ``kind``, when
    the page is unchanged since; else ``None`` (absent, not a regular file, another writer, or edited).

    Parameters
    ----------
    path : str or Path
        The page.
    kind : str
        The command expected to have written it.

    Returns
    -------
    dict or None
        Key -> sha256 of its companions.
    """
    if file_sha256(path) is None:
        return None
    try:
        with open(path, "rb") as fh:
            data = fh.read(64 << 20)
        text = data.decode("utf-8")
    except (OSError, UnicodeDecodeError):
        return None
    body, sep, last = text.rstrip("\n").rpartition("\n")
    m = _STAMP_RE.match(last)
    if not sep or not m or m.group(1) != kind:
        return None
    if hashlib.sha256((body + "\n").encode("utf-8")).hexdigest() != m.group(2):
        return None
    return dict(item.split("=", 1) for item in m.group(3).split())


def check_forced_pair(named: Path, csv_path: Path, html_path: Path, kind: str) -> None:
    """``--force`` of a command that writes a CSV and a stamped HTML beside it (``doe plan``): the file the user
    named may be replaced, the other one only if it is this command's own earlier output, unchanged (by sha256,
    :func:`read_html_stamp`).  Raises :class:`~berryshaker.errors.OutputError` naming the file otherwise (a filled
    field sheet is never replaced because its printable copy was named).

    Parameters
    ----------
    named : Path
        The file the user named with ``--out``.
    csv_path, html_path : Path
        The pair of files the command writes.
    kind : str
        The command.
    """
    from berryshaker.errors import OutputError

    named_csv = _absolute(named).suffix.lower() not in (".html", ".htm")
    other = html_path if named_csv else csv_path
    if not (other.exists() or other.is_symlink()):
        return
    stamp = read_html_stamp(html_path, kind)
    ours = stamp is not None if named_csv else (stamp is not None and stamp.get("csv") == file_sha256(csv_path))
    if not ours:
        raise OutputError(f"{other} exists and is not the unchanged output of an earlier `{kind}` (a filled sheet?); "
                          f"--force replaces only {_absolute(named).name}. Move {other.name} away or choose another "
                          "name; nothing was written")


# ---- staging ------------------------------------------------------------------------------------------
def _host_tag() -> str:
    return hashlib.sha256(socket.gethostname().encode()).hexdigest()[:6]


def pid_alive(pid: int) -> bool:
    """True while process ``pid`` exists and is not a zombie (a killed process its parent has not reaped yet);
    used for stale staging folders here and for the sweep runner's parent watch.

    Parameters
    ----------
    pid : int
        The process id.

    Returns
    -------
    bool
        Whether it runs.
    """
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:  # a killed parent not yet reaped is a zombie
        with open(f"/proc/{pid}/stat", "rb") as fh:
            return fh.read().rsplit(b")", 1)[1].split()[0] != b"Z"
    except (OSError, IndexError):
        return True


def clean_stale_staging(parent: str | Path, max_age_hours: float = STALE_STAGING_HOURS) -> list[Path]:
    """Remove staging folders left in ``parent`` by earlier killed runs; return what was removed.

    Only hidden folders named by :func:`staged_directory` (``.<name>.berryshaker-staging.<host>-<pid>.<x>``)
    are considered: from this host, when their process is gone or they are older than ``max_age_hours``;
    from another host (a shared disk), when older than :data:`STALE_FOREIGN_STAGING_HOURS`.

    Parameters
    ----------
    parent : str or Path
        The folder to clean.
    max_age_hours : float
        Age (h) beyond which a staging folder of this host is stale even if its process runs.

    Returns
    -------
    list of Path
        The folders removed.
    """
    parent = Path(parent)
    removed = []
    try:
        entries = list(parent.iterdir())
    except OSError:
        return removed
    now = time.time()
    host = _host_tag()
    for e in entries:
        m = _STAGING_RE.match(e.name)
        if not m or e.is_symlink() or not e.is_dir():
            continue
        try:
            age_h = (now - e.stat().st_mtime) / 3600.0
        except OSError:
            continue
        same_host, pid = m.group(1) == host, int(m.group(2))
        if same_host:
            stale = (pid != os.getpid() and not pid_alive(pid)) or age_h > max_age_hours
        else:
            stale = age_h > STALE_FOREIGN_STAGING_HOURS
        if stale:
            shutil.rmtree(e, ignore_errors=True)
            removed.append(e)
    return removed


def _staged_files(stage: Path) -> list[str]:
    out = []
    for item in stage.rglob("*"):
        if item.is_file() or item.is_symlink():
            rel = item.relative_to(stage).as_posix()
            if rel != MARKER_NAME:
                out.append(rel)
    return sorted(out)


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


def _remove_empty_parents(path: Path, top: Path) -> None:
    d = path.parent
    while d != top and top in d.parents:
        try:
            d.rmdir()
        except OSError:
            return
        d = d.parent


def _commit(stage: Path, final: Path, kind: str) -> None:
    """Move the staged files into ``final`` (see :func:`staged_directory`)."""
    from berryshaker.errors import OutputError

    new = _staged_files(stage)
    digests = {rel: file_sha256(stage / rel) for rel in new}
    if not final.exists() or (final.is_dir() and not final.is_symlink() and not any(final.iterdir())):
        write_json_atomic(stage / MARKER_NAME, _marker(kind, {kind: digests}))
        try:
            os.rename(stage, final)  # one atomic step; POSIX replaces an empty folder
            return
        except OSError:
            (stage / MARKER_NAME).unlink(missing_ok=True)
            if final.exists() and not final.is_dir():
                raise OutputError(f"{kind} output {final} appeared as a file while running; results not written. "
                                  "Choose a new folder") from None
            try:
                final.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise OutputError(f"{kind} output {final} cannot be created ({exc.strerror}); choose another "
                                  "folder") from None
    marker = read_output_marker(final) if any(final.iterdir()) else {"files": [], "outputs": {}}
    if marker is None:
        raise OutputError(f"{kind} output {final} received files not written by berryshaker while running; "
                          "nothing was changed there. Choose a new folder")
    owners = marker_owners(marker)
    written = _written_time(marker)
    mine = owners.get(kind, {})
    state = {rel: _entry_state(final, rel, d, written) for rel, d in mine.items()}
    changed = sorted(rel for rel, s in state.items() if s == "changed")
    if changed:
        raise OutputError(f"{kind} output {final}: {_shown(changed)} changed since berryshaker wrote "
                          f"{'it' if len(changed) == 1 else 'them'}; nothing was changed there. Move "
                          f"{'it' if len(changed) == 1 else 'them'} away or choose a new folder")
    others = {rel: k for k, files in owners.items() if k != kind for rel in files}
    taken, conflicts = [], []
    for rel in new:
        target = _inside(final, rel)
        exists = target is not None and (target.is_symlink() or target.exists())
        if rel in others and exists:
            taken.append(f"{rel} ({others[rel]})")
        elif target is None or exists and (state.get(rel) != "ours" or target.is_dir()):
            conflicts.append(rel)
    if taken:
        raise OutputError(f"{kind} output {final} holds outputs of another command with the names of new outputs "
                          f"({_shown(taken)}); they are kept and nothing was changed there. Choose a new folder "
                          "(or give each command its own)")
    if conflicts:
        raise OutputError(f"{kind} output {final} holds files berryshaker did not write with the names of new "
                          f"outputs ({_shown(conflicts)}); nothing was changed there. Choose a new folder")
    # the marker lists old and new files while they are moved, so an interruption loses no record
    owners[kind] = {**mine, **digests}
    write_json_atomic(final / MARKER_NAME, _marker(kind, owners, marker))
    for rel in new:
        target = final / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        os.replace(stage / rel, target)
    for rel in sorted(set(mine) - set(new)):
        if _entry_state(final, rel, mine[rel], written) == "ours":  # checked again right before removal
            target = final / rel
            target.unlink()
            _remove_empty_parents(target, final)
    owners[kind] = digests
    write_json_atomic(final / MARKER_NAME, _marker(kind, owners, marker))


@contextlib.contextmanager
def staged_directory(final: str | Path, kind: str = "output") -> Iterator[Path]:
    """Yield a hidden staging folder beside ``final``; on success its files are moved into ``final``.

    ``final`` is checked first with :func:`prepare_output_dir` (refused before any work if it holds files
    berryshaker did not write, or files this kind of output wrote that were changed since).  On success: a new
    or empty ``final`` is replaced by the staging folder in one atomic rename; a previous berryshaker output
    gets the new files by atomic per-file renames, and the files its marker listed *for this kind* (``kind``:
    the command and flag, recorded in the marker) that this run did not write are removed if unchanged (by
    sha256) -- other commands' files, changed files and the user's files are never touched (a file of another
    command or of the user with the name of a new output stops the commit with
    :class:`~berryshaker.errors.OutputError`; so does a changed file of this kind).  A marker entry reached
    through a symlink or resolving outside ``final`` is never replaced or removed.  The marker
    :data:`MARKER_NAME` is written last.  On any error or ``KeyboardInterrupt`` the staging folder is removed
    and ``final`` is unchanged.  Staging folders of earlier killed runs are cleaned up
    (:func:`clean_stale_staging`).

    Parameters
    ----------
    final : str or Path
        The output folder.
    kind : str
        The command and flag that write there.

    Yields
    ------
    Path
        The staging folder to write the files in.
    """
    from berryshaker.errors import OutputError

    final = _absolute(final)
    prepare_output_dir(final, kind)
    parent = final.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
        clean_stale_staging(parent)
        stage = Path(tempfile.mkdtemp(prefix=f".{final.name}{STAGING_TAG}{_host_tag()}-{os.getpid()}.", dir=parent))
    except OSError as exc:
        raise OutputError(f"{kind} output {final}: cannot write in {parent} ({exc.strerror or exc}); choose another "
                          "folder") from None
    try:
        os.chmod(stage, 0o777 & ~_umask())  # mkdtemp makes 0700; the output is an ordinary folder
        yield stage
        _commit(stage, final, kind)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


# ---- provenance ---------------------------------------------------------------------------------------
def provenance(machine=None, **extra) -> dict:
    """Package version, code fingerprint and resolved config (SI) recorded with every output.

    Parameters
    ----------
    machine : MachineBase, optional
        The machine description the output was made from.
    **extra
        Further inputs to record.

    Returns
    -------
    dict
        The provenance (JSON-ready).
    """
    out = {"package": "berryshaker", "version": __version__, "code_sha256": code_fingerprint()}
    if machine is not None:
        out["machine_si"] = machine.model_dump(mode="json")
    out.update(extra)
    return out


def write_provenance(folder: str | Path, machine=None, **extra) -> None:
    """``provenance.json`` (package version, resolved config in SI, extra inputs) beside outputs.

    Parameters
    ----------
    folder : str or Path
        Where to write it.
    machine : MachineBase, optional
        The machine description the outputs were made from.
    **extra
        Further inputs to record.
    """
    write_json_atomic(Path(folder) / "provenance.json", provenance(machine, **extra))


@functools.lru_cache(maxsize=None)
def code_fingerprint() -> str:
    """sha256 over every ``.py`` file of the installed berryshaker package (relative path and content,
    sorted by path); computed once per process.  Any edit to the code gives new cache keys."""
    import berryshaker

    root = Path(berryshaker.__file__).resolve().parent
    h = hashlib.sha256()
    for p in sorted(root.rglob("*.py"), key=lambda q: q.relative_to(root).as_posix()):
        if "__pycache__" in p.parts:
            continue
        h.update(p.relative_to(root).as_posix().encode() + b"\0")
        h.update(p.read_bytes() + b"\0")
    return h.hexdigest()
