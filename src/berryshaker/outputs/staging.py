"""A folder of outputs filled in a hidden staging folder beside it and moved into place only when everything
succeeded (:func:`staged_directory`): a new or empty folder in one atomic rename, a previous berryshaker output
file by file under its marker's rules; staging folders left by killed runs are cleaned up
(:func:`clean_stale_staging`).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import shutil
import socket
import tempfile
import time
from pathlib import Path
from typing import Iterator

from berryshaker.outputs.atomic_files import (
    WRITE_ERRNOS,
    _absolute,
    current_umask,
    file_sha256,
    write_error,
    write_json_atomic,
)
from berryshaker.outputs.destinations import _shown, prepare_output_dir
from berryshaker.outputs.marker import (
    MARKER_NAME,
    _entry_state,
    _inside,
    _marker,
    marker_owners,
    read_output_marker,
    unverified_reason,
)

#: Staging folders are ``.<final name>.berryshaker-staging.<host>-<pid>.<random>`` beside the destination.
STAGING_TAG = ".berryshaker-staging."
#: A staging folder of a dead process on this host, or any staging folder older than this, is removed.
STALE_STAGING_HOURS = 6.0
#: Staging folders from another host (shared disks) are only removed after this long.
STALE_FOREIGN_STAGING_HOURS = 7 * 24.0

_STAGING_RE = re.compile(r"^\..*\.berryshaker-staging\.([0-9a-f]{6})-(\d+)\.[A-Za-z0-9_]+$")


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
    removed: list = []
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
    mine = owners.get(kind, {})
    state = {rel: _entry_state(final, rel, d) for rel, d in mine.items()}
    changed = sorted(rel for rel, s in state.items() if s in ("changed", "unverified"))
    if changed:
        raise OutputError(f"{kind} output {final}: {_shown(changed)} changed since berryshaker wrote "
                          f"{'it' if len(changed) == 1 else 'them'}{unverified_reason(marker, kind, changed)}; "
                          "nothing was changed there. Move "
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
        if _entry_state(final, rel, mine[rel]) == "ours":  # checked again right before removal
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
    and ``final`` is unchanged; a full disk (:data:`~berryshaker.outputs.WRITE_ERRNOS`) is one
    :class:`~berryshaker.errors.WriteError` naming the folder.  Staging folders of earlier killed runs are cleaned up
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
        os.chmod(stage, 0o777 & ~current_umask())  # mkdtemp makes 0700; the output is an ordinary folder
        yield stage
        _commit(stage, final, kind)
    except OSError as exc:  # a full disk while the outputs were written or moved in: one error naming the folder
        if exc.errno not in WRITE_ERRNOS:
            raise
        raise write_error(f"{kind} output {final}", exc) from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)
