"""Reading the user's input files (machine descriptions, field sheets): only a regular file of bounded size, read
in one bounded call that never blocks.

A FIFO, a device (``/dev/zero``, a terminal), a socket or a folder given where a description or a sheet belongs
is refused before a byte is read, with one :class:`~berryshaker.errors.ConfigError` naming the file and the fix;
so is a file larger than its bound (and one that grows past it while being read: ``/proc`` files report size 0).
Every reader of a user's file calls :func:`read_input_file`.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from berryshaker.errors import ConfigError


def _kind(mode: int) -> str:
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def _size(n: int) -> str:
    return f"{n / 1e6:.3g} MB" if n >= 1_000_000 else f"{n:,} bytes"


def read_input_file(path: str | Path, what: str, max_bytes: int,
                    fix: str = "save its content to a file and give that file") -> bytes:
    """The bytes of the user's file ``path``, read only if it is a regular file of at most ``max_bytes``.

    The file is opened without blocking (``O_NONBLOCK``: a FIFO without a writer does not hang the open) and
    without becoming the controlling terminal, checked with ``fstat`` on the open descriptor (no race between the
    check and the read), and read with at most ``max_bytes + 1`` bytes asked for.

    Parameters
    ----------
    path : str or Path
        The file the user named.
    what : str
        What it should be, for the messages: ``"config file"``, ``"results file"``.
    max_bytes : int
        The largest file accepted (bytes).
    fix : str
        What to do instead of a FIFO, a device or a socket, for the message.

    Returns
    -------
    bytes
        The file's content.

    Raises
    ------
    ConfigError
        Missing, a folder, a FIFO, a device or a socket, not readable, or larger than ``max_bytes``; the message
        names the file and what to do.
    """
    p = Path(path)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
    try:
        fd = os.open(p, flags)
    except FileNotFoundError:
        raise ConfigError(f"{what} not found: {p}; check the path") from None
    except PermissionError:
        raise ConfigError(f"{what} {p}: no permission to read it; check its permissions") from None
    except OSError as exc:
        try:
            mode = os.stat(p).st_mode
        except OSError:
            mode = stat.S_IFREG
        if not stat.S_ISREG(mode):  # a socket cannot even be opened
            raise ConfigError(f"{what} {p} is {_kind(mode)}, not a regular file; {fix}") from None
        raise ConfigError(f"{what} {p} cannot be opened ({exc.strerror or exc}); give a regular file") from None
    try:
        st = os.fstat(fd)
        if stat.S_ISDIR(st.st_mode):
            raise ConfigError(f"{what} {p} is a folder, not a file; give the file inside it")
        if not stat.S_ISREG(st.st_mode):
            raise ConfigError(f"{what} {p} is {_kind(st.st_mode)}, not a regular file; {fix}")
        if st.st_size > max_bytes:
            raise ConfigError(f"{what} {p}: {_size(st.st_size)}, more than the {_size(max_bytes)} a {what} may have; "
                              "is this the right file?")
        chunks, total = [], 0
        while total <= max_bytes:
            try:
                block = os.read(fd, min(1 << 20, max_bytes + 1 - total))
            except OSError as exc:
                raise ConfigError(f"{what} {p} cannot be read ({exc.strerror or exc})") from None
            if not block:
                break
            chunks.append(block)
            total += len(block)
        if total > max_bytes:
            raise ConfigError(f"{what} {p}: more than the {_size(max_bytes)} a {what} may have (it grew while read); "
                              "is this the right file?")
        return b"".join(chunks)
    finally:
        os.close(fd)


__all__ = ["read_input_file"]
