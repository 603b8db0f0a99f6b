"""Files that appear complete or not at all: text and JSON written through a temporary file in the same folder
and an atomic rename, several files together or none of them (:func:`write_files_atomic`), a failed write as one
:class:`~berryshaker.errors.WriteError` naming the file and the reason (a full disk: :func:`write_error`), JSON
always strict (no NaN: :func:`strict_json_text`), and the sha256 of a regular file read without following a symlink
or blocking on a FIFO (what the output marker records).
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import math
import os
import stat
import tempfile
from pathlib import Path
from typing import Mapping

from berryshaker.errors import WriteError


def current_umask() -> int:
    """The process's file-mode creation mask (read without changing it).

    Returns
    -------
    int
        The umask: a file written atomically gets mode 0o666 & ~umask, as an ``open`` would give it.
    """
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
        The content (UTF-8, line ends as given).

    Raises
    ------
    WriteError
        It cannot be written (:func:`write_files_atomic`); nothing was.
    """
    write_bytes_atomic(path, text.encode("utf-8"))


def write_bytes_atomic(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` via a temporary file in the same folder and an atomic rename: the file appears
    complete or not at all, with the mode an ordinary file gets (0o666 & ~umask).

    Parameters
    ----------
    path : str or Path
        The file (its folder is created).
    data : bytes
        The content.

    Raises
    ------
    WriteError
        It cannot be written (:func:`write_files_atomic`); nothing was.
    """
    write_files_atomic({path: data})


#: errors of a write the user can act on (full disk, quota, read-only disk, file too large, a failing disk)
WRITE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EFBIG, errno.EIO})
_WHY = {errno.ENOSPC: "the disk is full", errno.EDQUOT: "the disk quota is exceeded",
        errno.EROFS: "the disk is read-only", errno.EACCES: "no permission", errno.EPERM: "not permitted",
        errno.EFBIG: "the file is too large for the disk", errno.EIO: "the disk reported an input/output error"}


def write_error(path: str | Path, exc: OSError, what: str = "") -> WriteError:
    """The :class:`~berryshaker.errors.WriteError` of a write of ``path`` that failed with ``exc`` (an
    :class:`OSError`, or a :class:`WriteError` of a file inside ``path`` to name ``path`` instead): one line naming
    it, the reason in words (``the disk is full (ENOSPC)``) and what to do.

    Parameters
    ----------
    path : str or Path
        The file (or folder) being written.
    exc : OSError
        The error.
    what : str
        What else the message should say was not written (default: nothing was written there).

    Returns
    -------
    WriteError
        The error to raise (its ``errno`` is ``exc``'s).
    """
    code = errno.errorcode.get(exc.errno or 0, "")
    why = _WHY.get(exc.errno or 0, exc.strerror or str(exc) or type(exc).__name__)
    out = WriteError(f"cannot write {path}: {why}{f' ({code})' if code else ''}; "
                     f"{what or 'nothing was written there'}. Free space or choose another location")
    out.errno = exc.errno
    return out


def _fill(fd: int, data: bytes) -> None:
    """Write ``data`` to the new file ``fd`` and close it (where a full disk shows: ENOSPC on a write or the close)."""
    with os.fdopen(fd, "wb") as fh:
        fh.write(data)


def write_files_atomic(files: Mapping[str | Path, bytes]) -> None:
    """Write several files so that they appear together, complete, or not at all (a sheet and its printable copy,
    a table's CSV and workbook, a figure's PNG and SVG).

    Every file is first written in full to a temporary file beside it (where a full disk shows); only then are
    they renamed into place, each replacing any earlier file of its name; if a rename fails, those already made
    are undone (an earlier file is restored from a hard link kept until the end).  Each gets the mode an
    ordinary file gets (0o666 & ~umask).

    Parameters
    ----------
    files : mapping of path to bytes
        Each file (its folder is created) and its content.

    Raises
    ------
    WriteError
        A file cannot be written (full disk, read-only disk, no permission): the message names it and the
        reason; none of the files was changed.
    """
    staged: list[tuple[str, Path]] = []
    moved: list[tuple[Path, str | None]] = []
    made: list[Path] = []  # folders created for the files, removed again if nothing is written
    path: str | Path = ""  # the file being staged, named by an error
    try:
        for path, data in files.items():
            path = Path(path)
            missing = [d for d in (path.parent, *path.parent.parents) if not os.path.lexists(d)]
            path.parent.mkdir(parents=True, exist_ok=True)
            made += missing
            fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
            staged.append((tmp, path))
            _fill(fd, data)
            os.chmod(tmp, 0o666 & ~current_umask())  # mkstemp makes 0600; outputs are ordinary files
        for tmp, path in staged:
            backup = None
            if os.path.lexists(path) and len(staged) > 1:  # kept until all are in place, to undo with
                backup = f"{tmp}.old"
                try:
                    os.link(path, backup, follow_symlinks=False)
                except OSError:  # no hard links here: the earlier file is moved aside instead
                    os.rename(path, backup)
            os.replace(tmp, path)
            moved.append((path, backup))
    except BaseException as exc:
        for done, backup in reversed(moved):  # undo: the earlier file back, or none
            with contextlib.suppress(OSError):
                os.replace(backup, done) if backup else os.unlink(done)
        for tmp, _ in staged:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        for d in made:  # deepest first: each is empty again
            with contextlib.suppress(OSError):
                os.rmdir(d)
        if isinstance(exc, OSError):
            others = len(files) > 1
            raise write_error(path, exc, "none of its files was written" if others else "") from None
        raise
    finally:
        for _, backup in moved:
            if backup:
                with contextlib.suppress(OSError):
                    os.unlink(backup)


def finite_json(obj, path: str = "", nulls: dict[str, str] | None = None):
    """``obj`` with every NaN or infinity replaced by None (JSON's null), its JSON path and value recorded in
    ``nulls``.

    Parameters
    ----------
    obj : object
        A JSON-compatible value (dicts, lists, tuples, numbers, strings, None).
    path : str
        Its JSON path (for the record), "" at the top.
    nulls : dict, optional
        Filled with JSON path -> the value's repr for every value replaced.

    Returns
    -------
    object
        The value with no non-finite number in it.
    """
    nulls = {} if nulls is None else nulls
    if isinstance(obj, float) and not math.isfinite(obj):
        nulls[path or "(the result)"] = repr(obj)
        return None
    if isinstance(obj, dict):
        return {k: finite_json(v, f"{path}.{k}" if path else str(k), nulls) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite_json(v, f"{path}[{i}]", nulls) for i, v in enumerate(obj)]
    return obj


def strict_json_text(obj, indent: int | None = 2) -> str:
    """``obj`` as strict JSON (RFC 8259: never ``NaN`` or ``Infinity``, which strict parsers refuse): each such
    value is written as null and, when ``obj`` is an object, its JSON path listed with the reason under
    ``"null_values"``.

    Parameters
    ----------
    obj : object
        A JSON-serialisable value.
    indent : int or None
        Indentation (None: one line).

    Returns
    -------
    str
        The JSON text.

    Raises
    ------
    BerryshakerError
        ``obj`` itself is not a finite number, or a non-finite value sits in a list at the top (no place to say why).
    """
    from berryshaker.errors import BerryshakerError

    nulls: dict[str, str] = {}
    clean = finite_json(obj, "", nulls)
    if nulls:
        if not isinstance(clean, dict):
            first = next(iter(nulls))
            raise BerryshakerError(f"result {first} is not a finite number ({nulls[first]})")
        clean["null_values"] = {**(clean.get("null_values") or {}),
                                **{k: f"not a finite number ({v}): written as null" for k, v in nulls.items()}}
    return json.dumps(clean, indent=indent, allow_nan=False)


def write_json_atomic(path: str | Path, obj) -> None:
    """Write ``obj`` as indented, strict JSON to ``path`` atomically (:func:`strict_json_text`: a NaN or infinity is
    null, listed under ``"null_values"``; :func:`write_text_atomic`).

    Parameters
    ----------
    path : str or Path
        The file.
    obj : Any
        A JSON-serialisable object.

    Raises
    ------
    WriteError
        It cannot be written; nothing was.
    """
    write_text_atomic(path, strict_json_text(obj) + "\n")


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
