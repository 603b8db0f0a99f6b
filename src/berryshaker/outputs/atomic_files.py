"""Files that appear complete or not at all: text and JSON written through a temporary file in the same folder
and an atomic rename, and the sha256 of a regular file read without following a symlink or blocking on a FIFO
(what the output marker records).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import stat
import tempfile
from pathlib import Path


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
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, 0o666 & ~current_umask())  # mkstemp makes 0600; outputs are ordinary files
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
