"""Figures kept between studies: a figure drawn before by the same call is copied instead of drawn again.

A warm study (every run cached) spent ~46 of its ~51 s redrawing its figures.  :func:`draw_cached` draws a figure
function's call (``fn(*args, **kwargs)``, what :meth:`berryshaker.study.step_context.StudyContext.draw` is given) and
keeps the files it wrote (PNG, SVG) in a folder of the run cache; the same call later copies them into the figure
folder, the same bytes a fresh draw writes (:func:`berryshaker.report.style.finish` saves with fixed metadata and
SVG ids, so a figure's files depend only on its call).

The key (:func:`figure_key`) is the sha256 of the function's dotted name, the package's code fingerprint (every
``.py`` file of the package, the figure functions and their style included:
:func:`berryshaker.outputs.code_fingerprint`), the arguments (by what they hold, the figure folder's paths in them
relative: :func:`_digest`), the figure output settings (:func:`berryshaker.report.plots.figure_files.figure_output`) and the versions of
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
import os
import pickle
from pathlib import Path
from typing import Callable

#: version of an entry's layout; another version is a miss
FIGURE_CACHE_SCHEMA = 1
#: the largest entry read (bytes): a study's largest figure pair is a few MB
MAX_FIGURE_BYTES = 64_000_000


def _digest(value, figs: Path, h) -> None:
    """Feed ``value`` into the hash ``h`` by what it holds, not by how its objects are shared: a pickle writes a
    string met twice once and then a reference to it, so the same numbers read from the run cache (JSON) and
    returned by a worker pickled differently.  Containers keep their order (a figure draws in it); a path
    inside ``figs`` (the figure folder, a new staging folder in every study) counts relative to it; what this
    does not know is pickled on its own."""
    import dataclasses
    import enum

    import numpy as np

    def put(tag: bytes, data: bytes) -> None:
        h.update(tag + len(data).to_bytes(8, "little") + data)

    if isinstance(value, (str, Path)):
        rel = None
        if os.path.isabs(value):  # (a relative path, or any other text, is not in the figure folder)
            try:
                rel = Path(value).resolve().relative_to(figs)
            except (ValueError, OSError):
                rel = None
        if rel is not None:
            put(b"F", rel.as_posix().encode())
        elif isinstance(value, Path):
            put(b"P", str(value).encode("utf-8", "surrogatepass"))
        else:
            put(b"s", value.encode("utf-8", "surrogatepass"))
    elif value is None or isinstance(value, (bool, int, float, complex, bytes, enum.Enum)):
        put(b"v", f"{type(value).__qualname__}:{value!r}".encode())
    elif isinstance(value, (list, tuple)):
        put(b"l" if isinstance(value, list) else b"t", str(len(value)).encode())
        for v in value:
            _digest(v, figs, h)
    elif isinstance(value, dict):
        put(b"d", str(len(value)).encode())
        for k, v in value.items():
            _digest(k, figs, h)
            _digest(v, figs, h)
    elif isinstance(value, (set, frozenset)):
        parts = []
        for v in value:
            sub = hashlib.sha256()
            _digest(v, figs, sub)
            parts.append(sub.digest())
        put(b"S", b"".join(sorted(parts)))
    elif isinstance(value, np.ndarray) and value.dtype != object:
        put(b"a", f"{value.dtype.str}{value.shape}".encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, np.ndarray):
        put(b"A", str(value.shape).encode())
        _digest(value.tolist(), figs, h)
    elif isinstance(value, np.generic):
        put(b"g", value.dtype.str.encode() + value.tobytes())
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        put(b"c", f"{type(value).__module__}.{type(value).__qualname__}".encode())
        _digest({f.name: getattr(value, f.name) for f in dataclasses.fields(value)}, figs, h)
    elif callable(value) and "<" not in getattr(value, "__qualname__", "<"):  # a module-level function or class
        put(b"f", f"{getattr(value, '__module__', '')}.{value.__qualname__}".encode())
    else:
        put(b"p", pickle.dumps(value, protocol=5))


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
    call = hashlib.sha256()
    try:
        _digest((args, dict(sorted(kwargs.items()))), Path(figs).resolve(), call)
    except Exception:  # noqa: BLE001 - whatever does not pickle is drawn every time
        return None
    head = json.dumps([FIGURE_CACHE_SCHEMA, name, code_fingerprint(), list(_OUTPUT.get()), __version__,
                       matplotlib.__version__, getattr(ft2font, "__freetype_version__", ""), np.__version__])
    return hashlib.sha256(head.encode() + b"\0" + call.digest()).hexdigest()


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


def restore_figure(folder: str | Path | None, key: str | None, figs: str | Path) -> bool:
    """Copy the kept figure ``key`` into ``figs``; False (nothing written) when there is none.

    Parameters
    ----------
    folder : str or Path or None
        The figure cache folder; None: no cache.
    key : str or None
        The figure call's key (:func:`figure_key`); None: a call that is not kept.
    figs : str or Path
        The figure folder.

    Returns
    -------
    bool
        Whether the figure's files were copied.
    """
    from berryshaker.outputs import write_files_atomic

    files = None if folder is None or key is None else read_figure_entry(folder, key)
    if not files:
        return False
    write_files_atomic({Path(figs) / name: data for name, data in files.items()})
    return True


def draw_cached(folder: str | Path | None, fn: Callable, args: tuple, kwargs: dict, figs: str | Path,
                key: str | None = None) -> None:
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
    key : str, optional
        The call's key as the caller computed it (:func:`figure_key`; a pool worker is given the study's, since a
        call pickled again after its trip to the worker may give other bytes); default: computed here.
    """
    from berryshaker.report.style import recording_written

    if folder is not None and key is None:
        key = figure_key(fn, args, kwargs, figs)
    if folder is None or key is None:
        fn(*args, **kwargs)
        return
    if restore_figure(folder, key, figs):
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
