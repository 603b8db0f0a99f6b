"""Files written in pairs (a sheet and its printable copy, ``doe plan``): the HTML page stamped with the sha256 of
itself and of its companions (:func:`stamp_html`, :func:`read_html_stamp`), so that ``--force`` replaces the
other file of the pair only when it is the command's own unchanged output (:func:`check_forced_pair`).
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

from berryshaker.outputs.atomic_files import _absolute, file_sha256

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
