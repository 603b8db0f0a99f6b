"""Output destinations checked before any work: :func:`prepare_output_dir` (a new or empty folder, or one holding
a previous berryshaker output whose files of this command are unchanged) and :func:`check_output_file` (a new
file, or an existing one with ``--force``), each refusal an :class:`berryshaker.errors.OutputError` with the
reason and what to do.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path
from typing import Iterable

from berryshaker.outputs.atomic_files import _absolute
from berryshaker.outputs.marker import MARKER_NAME, _changed_own_files, read_output_marker, unverified_reason


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
            why = unverified_reason(marker, kind, changed) or " (or became a link or another kind of file)"
            raise OutputError(f"{kind} output {p}: {_shown(changed)} changed since berryshaker wrote "
                              f"{'it' if len(changed) == 1 else 'them'}{why}; "
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
