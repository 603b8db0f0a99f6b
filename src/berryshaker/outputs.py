"""Safe output: a file appears complete or not at all, and nothing the user made is ever overwritten or removed.

* :func:`check_output_file` and :func:`prepare_output_dir` check a destination *before* any work and raise
  :class:`berryshaker.errors.OutputError` with the reason and what to do.
* A folder of outputs is filled in a hidden staging folder beside it (:func:`staged_directory`) and moved into
  place only when everything succeeded.  The finished folder carries a marker file
  (``.berryshaker-output.json``: kind, version, time, the files written), so a later run may replace exactly
  those files -- and never a file the user put there.
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
    """Write ``text`` to ``path`` via a temporary file in the same folder and an atomic rename."""
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
    """Write ``obj`` as indented JSON to ``path`` atomically (see :func:`write_text_atomic`)."""
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


def _safe_relpaths(names: Iterable) -> set[str]:
    """Marker entries that are plain relative paths inside the folder (a hand-edited marker cannot point
    outside it)."""
    out = set()
    for n in names:
        if not isinstance(n, str) or not n:
            continue
        p = PurePosixPath(n)
        if p.is_absolute() or ".." in p.parts or n == MARKER_NAME or "\\" in n:
            continue
        out.add(p.as_posix())
    return out


def read_output_marker(folder: str | Path) -> dict | None:
    """The marker of a previous berryshaker output in ``folder`` (kind, version, written, files), or ``None``
    when there is none or it is not a valid berryshaker marker."""
    p = Path(folder) / MARKER_NAME
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or data.get("package") != "berryshaker" or not isinstance(data.get("files"), list):
        return None
    return data


def prepare_output_dir(path: str | Path, kind: str = "study") -> Path:
    """Check an output folder before any work; return it as an absolute path (nothing is created).

    Allowed: a path that does not exist (its parent must be creatable), an empty folder, or a folder
    holding a previous berryshaker output (it has the marker file :data:`MARKER_NAME`; only the files that
    marker lists will be replaced).  Refused with :class:`berryshaker.errors.OutputError`: an existing file,
    a folder with anything else in it (for example ``--out .`` in a folder with your files), a folder that
    cannot be written.

    Parameters
    ----------
    path : str or Path
        Destination folder.
    kind : str
        What will be written (``"study"``, ``"sweep"``, ``"plots"``...), used in messages.
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
    if read_output_marker(p) is not None:
        return p
    shown = ", ".join(entries[:3]) + (f" and {len(entries) - 3} more" if len(entries) > 3 else "")
    why = (f"holds a damaged {MARKER_NAME}" if MARKER_NAME in entries
           else "is not empty and was not written by berryshaker")
    raise OutputError(f"{kind} output {p} {why} ({shown}); refusing to write there so none of your files is "
                      "overwritten, and nothing was written. Choose a new folder (or an empty one)")


def check_output_file(path: str | Path, allowed_suffixes: Iterable[str] | None = None,
                      overwrite: bool = False) -> Path:
    """Check an output file before any work; return it as an absolute path (nothing is created).

    Refused with :class:`berryshaker.errors.OutputError`: a folder, a suffix not in ``allowed_suffixes``
    (case-insensitive, e.g. ``[".csv", ".parquet"]``), an existing file unless ``overwrite`` (the CLI's
    ``--force``), anything that is not a regular file, a parent folder that cannot be created.
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
        return p
    if p.parent.exists():
        if not p.parent.is_dir():
            raise OutputError(f"output {p}: {p.parent} is a file, not a folder; choose another location")
        if not os.access(p.parent, os.W_OK | os.X_OK):
            raise OutputError(f"output {p}: no permission to write in {p.parent}; choose another location")
    else:
        _check_creatable(p.parent)
    return p


# ---- staging ------------------------------------------------------------------------------------------
def _host_tag() -> str:
    return hashlib.sha256(socket.gethostname().encode()).hexdigest()[:6]


def pid_alive(pid: int) -> bool:
    """True while process ``pid`` exists and is not a zombie (a killed process its parent has not reaped yet);
    used for stale staging folders here and for the sweep runner's parent watch."""
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


def _marker(kind: str, files: Iterable[str]) -> dict:
    return {"package": "berryshaker", "kind": kind, "version": __version__,
            "written": datetime.now(timezone.utc).isoformat(timespec="seconds"), "files": sorted(files)}


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
    if not final.exists() or (final.is_dir() and not any(final.iterdir())):
        write_json_atomic(stage / MARKER_NAME, _marker(kind, new))
        try:
            os.rename(stage, final)  # one atomic step; POSIX replaces an empty folder
            return
        except OSError:
            (stage / MARKER_NAME).unlink(missing_ok=True)
            if final.exists() and not final.is_dir():
                raise OutputError(f"{kind} output {final} appeared as a file while running; results not written. "
                                  "Choose a new folder") from None
            final.mkdir(parents=True, exist_ok=True)
    marker = read_output_marker(final) if any(final.iterdir()) else {"files": []}
    if marker is None:
        raise OutputError(f"{kind} output {final} received files not written by berryshaker while running; "
                          "nothing was changed there. Choose a new folder")
    old = _safe_relpaths(marker["files"])
    conflicts = []
    for rel in new:
        target = final / rel
        blocked = [a for a in target.relative_to(final).parents if a != Path(".") and
                   ((final / a).is_symlink() or (final / a).exists() and not (final / a).is_dir())]
        if blocked or (target.is_symlink() or target.exists()) and (rel not in old or target.is_dir()):
            conflicts.append(rel)
    if conflicts:
        shown = ", ".join(conflicts[:3]) + (f" and {len(conflicts) - 3} more" if len(conflicts) > 3 else "")
        raise OutputError(f"{kind} output {final} holds files berryshaker did not write with the names of new "
                          f"outputs ({shown}); nothing was changed there. Choose a new folder")
    # the marker lists old and new files while they are moved, so an interruption loses no record
    write_json_atomic(final / MARKER_NAME, _marker(kind, old | set(new)))
    for rel in new:
        target = final / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        os.replace(stage / rel, target)
    for rel in sorted(old - set(new)):
        target = final / rel
        if target.is_symlink() or target.is_file():
            target.unlink()
            _remove_empty_parents(target, final)
    write_json_atomic(final / MARKER_NAME, _marker(kind, new))


@contextlib.contextmanager
def staged_directory(final: str | Path, kind: str = "output") -> Iterator[Path]:
    """Yield a hidden staging folder beside ``final``; on success its files are moved into ``final``.

    ``final`` is checked first with :func:`prepare_output_dir` (refused before any work if it holds files
    berryshaker did not write).  On success: a new or empty ``final`` is replaced by the staging folder in
    one atomic rename; a previous berryshaker output gets the new files by atomic per-file renames, and the
    files its marker listed that this run did not write are removed -- other files are never touched (a
    user file with the name of a new output stops the commit with :class:`~berryshaker.errors.OutputError`).
    The marker :data:`MARKER_NAME` is written last.  On any error or ``KeyboardInterrupt`` the staging
    folder is removed and ``final`` is unchanged.  Staging folders of earlier killed runs are cleaned up
    (:func:`clean_stale_staging`).
    """
    final = _absolute(final)
    prepare_output_dir(final, kind)
    parent = final.parent
    parent.mkdir(parents=True, exist_ok=True)
    clean_stale_staging(parent)
    stage = Path(tempfile.mkdtemp(prefix=f".{final.name}{STAGING_TAG}{_host_tag()}-{os.getpid()}.", dir=parent))
    try:
        os.chmod(stage, 0o777 & ~_umask())  # mkdtemp makes 0700; the output is an ordinary folder
        yield stage
        _commit(stage, final, kind)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


# ---- provenance ---------------------------------------------------------------------------------------
def provenance(machine=None, **extra) -> dict:
    """Package version, code fingerprint and resolved config (SI) recorded with every output."""
    out = {"package": "berryshaker", "version": __version__, "code_sha256": code_fingerprint()}
    if machine is not None:
        out["machine_si"] = machine.model_dump(mode="json")
    out.update(extra)
    return out


def write_provenance(folder: str | Path, machine=None, **extra) -> None:
    """``provenance.json`` (package version, resolved config in SI, extra inputs) beside outputs."""
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
