"""Figures kept between studies: a figure drawn before by the same call is copied instead of drawn again.

A warm study (every run cached) spent ~46 of its ~51 s redrawing its figures.  :func:`draw_cached` draws a figure
function's call (``fn(*args, **kwargs)``, what :meth:`berryshaker.study.step_context.StudyContext.draw` is given) and
keeps the files it wrote (PNG, SVG) in a folder of the run cache; the same call later copies them into the figure
folder, the same bytes a fresh draw writes (:func:`berryshaker.report.style.finish` saves with fixed metadata and
SVG ids, so a figure's files depend only on its call).

The key (:func:`figure_key`) is the sha256 of the function's dotted name, the package's code fingerprint (every
``.py`` file of the package, the figure functions and their style included:
:func:`berryshaker.outputs.code_fingerprint`), the pickled arguments (the figure folder's paths in them relative),
the figure output settings (:func:`berryshaker.report.plots.figure_files.figure_output`) and the versions of
berryshaker, matplotlib, its FreeType and NumPy.  A call whose arguments do not pickle, or a function outside the
package, is drawn every time.

An entry is one file, ``folder/ab/abcdef....fig``: a JSON header line (schema, key, function, each file's name, size
and sha256) and the files' bytes, written atomically; it is read under the run cache's one rule (a regular file of
this user's, never through a symlink: :func:`berryshaker.runs.cache.read_own_file`), and its checksums must hold, or
the figure is drawn again.  The folder is the study's run cache's (``<cache>/figures``), private to this user as
the whole cache is (:func:`berryshaker.runs.cache.run_cache_dir`).
"""

from __future__ import annotations

import hashlib
import json
import pickle
from pathlib import Path
from typing import Callable

#: version of an entry's layout; another version is a miss
FIGURE_CACHE_SCHEMA = 1
#: the largest entry read (bytes): a study's largest figure pair is a few MB
MAX_FIGURE_BYTES = 64_000_000
_FIGS = "<figures>"


def _relative(value, figs: Path):
    """``value`` with a path inside ``figs`` written relative to it (the figure folder is a new staging folder in
    every study); anything else unchanged."""
    if isinstance(value, (str, Path)):
        try:
            rel = Path(value).resolve().relative_to(figs)
        except (ValueError, OSError):
            return value
        return (_FIGS, rel.as_posix())
    return value


def figure_key(fn: Callable, args: tuple, kwargs: dict, figs: str | Path) -> str | None:
    """The cache key of a figure call, or None when it cannot be kept (arguments that do not pickle, a function
    outside the package).

    Parameters
    ----------
    fn : callable
        The figure function.
    args : tuple
        Its positional arguments.
    kwargs : dict
        Its keyword arguments.
    figs : str or Path
        The figure folder the call writes into.

    Returns
    -------
    str or None
        64 hex digits.
    """
    import matplotlib
    import numpy as np
    from matplotlib import ft2font

    from berryshaker import __version__
    from berryshaker.outputs import code_fingerprint
    from berryshaker.report.plots.figure_files import _OUTPUT

    name = f"{getattr(fn, '__module__', '')}.{getattr(fn, '__qualname__', '')}"
    if not name.startswith("berryshaker."):
        return None
    figs = Path(figs).resolve()
    try:
        call = pickle.dumps((tuple(_relative(a, figs) for a in args),
                             sorted((k, _relative(v, figs)) for k, v in kwargs.items())), protocol=5)
    except Exception:  # noqa: BLE001 - whatever does not pickle is drawn every time
        return None
    head = json.dumps([FIGURE_CACHE_SCHEMA, name, code_fingerprint(), list(_OUTPUT.get()), __version__,
                       matplotlib.__version__, getattr(ft2font, "__freetype_version__", ""), np.__version__])
    return hashlib.sha256(head.encode() + b"\0" + hashlib.sha256(call).digest()).hexdigest()


def figure_entry_path(folder: str | Path, key: str) -> Path:
    """Where the entry of ``key`` lives: ``folder/ab/abcdef....fig``.

    Parameters
    ----------
    folder : str or Path
        The figure cache folder.
    key : str
        The key (:func:`figure_key`).

    Returns
    -------
    Path
        The entry's file (it may not exist).
    """
    return Path(folder) / key[:2] / f"{key}.fig"


def read_figure_entry(folder: str | Path, key: str) -> dict[str, bytes] | None:
    """The files of a kept figure (name relative to the figure folder -> bytes), or None when there is no valid
    entry (none, another user's, a symlink, truncated, damaged).

    Parameters
    ----------
    folder : str or Path
        The figure cache folder.
    key : str
        The key (:func:`figure_key`).

    Returns
    -------
    dict of str to bytes or None
        The files.
    """
    from berryshaker.runs.cache import read_own_file

    data, _ = read_own_file(figure_entry_path(folder, key), MAX_FIGURE_BYTES)
    if data is None:
        return None
    line, sep, body = data.partition(b"\n")
    try:
        head = json.loads(line)
        if not sep or head["schema"] != FIGURE_CACHE_SCHEMA or head["key"] != key:
            return None
        files, at = {}, 0
        for f in head["files"]:
            name, size = str(f["name"]), int(f["size"])
            part = body[at:at + size]
            if len(part) != size or hashlib.sha256(part).hexdigest() != f["sha256"] or Path(name).is_absolute() \
                    or ".." in Path(name).parts:
                return None
            files[name] = part
            at += size
    except (ValueError, KeyError, TypeError):
        return None
    return files if files and at == len(body) else None


def write_figure_entry(folder: str | Path, key: str, fn_name: str, files: dict[str, bytes]) -> Path:
    """Keep a figure's files (one file, written atomically).

    Parameters
    ----------
    folder : str or Path
        The figure cache folder.
    key : str
        The key (:func:`figure_key`).
    fn_name : str
        The figure function's dotted name (for a reader of the folder).
    files : dict of str to bytes
        The files, by name relative to the figure folder.

    Returns
    -------
    Path
        The entry's file.
    """
    from berryshaker.outputs import write_bytes_atomic

    head = {"schema": FIGURE_CACHE_SCHEMA, "key": key, "fn": fn_name,
            "files": [{"name": n, "size": len(b), "sha256": hashlib.sha256(b).hexdigest()} for n, b in files.items()]}
    path = figure_entry_path(folder, key)
    path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
    write_bytes_atomic(path, json.dumps(head, separators=(",", ":")).encode() + b"\n" + b"".join(files.values()))
    return path


def restore_figure(folder: str | Path | None, fn: Callable, args: tuple, kwargs: dict, figs: str | Path) -> bool:
    """Copy a kept figure of this call into ``figs``; False (nothing written) when there is none.

    Parameters
    ----------
    folder : str or Path or None
        The figure cache folder; None: no cache.
    fn : callable
        The figure function.
    args : tuple
        Its positional arguments.
    kwargs : dict
        Its keyword arguments.
    figs : str or Path
        The figure folder.

    Returns
    -------
    bool
        Whether the figure's files were copied.
    """
    from berryshaker.outputs import write_files_atomic

    key = None if folder is None else figure_key(fn, args, kwargs, figs)
    files = None if folder is None or key is None else read_figure_entry(folder, key)
    if not files:
        return False
    write_files_atomic({Path(figs) / name: data for name, data in files.items()})
    return True


def draw_cached(folder: str | Path | None, fn: Callable, args: tuple, kwargs: dict, figs: str | Path) -> None:
    """Draw ``fn(*args, **kwargs)``, or copy its kept files into ``figs`` (:func:`restore_figure`); a figure drawn
    here is kept in ``folder`` when every file it wrote lies in ``figs`` (a figure not kept is drawn again next time:
    a folder that cannot be written costs only the time).

    Parameters
    ----------
    folder : str or Path or None
        The figure cache folder; None: draw, keep nothing.
    fn : callable
        The figure function (e.g. of :mod:`berryshaker.report.plots`).
    args : tuple
        Its positional arguments.
    kwargs : dict
        Its keyword arguments.
    figs : str or Path
        The figure folder the call writes into.
    """
    from berryshaker.report.style import recording_written

    key = None if folder is None else figure_key(fn, args, kwargs, figs)
    if folder is None or key is None:
        fn(*args, **kwargs)
        return
    files = read_figure_entry(folder, key)
    if files:
        from berryshaker.outputs import write_files_atomic

        write_files_atomic({Path(figs) / name: data for name, data in files.items()})
        return
    with recording_written() as written:
        fn(*args, **kwargs)
    root = Path(figs).resolve()
    kept: dict[str, bytes] = {}
    try:
        for p in written:
            kept[Path(p).resolve().relative_to(root).as_posix()] = Path(p).read_bytes()
    except (ValueError, OSError):
        return  # a file outside the figure folder, or gone: not kept
    if kept:
        try:
            write_figure_entry(folder, key, f"{fn.__module__}.{fn.__qualname__}", kept)
        except OSError:
            pass
