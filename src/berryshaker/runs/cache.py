"""The sweep runner's on-disk cache: every finished run stored under the hash of what computed it.

A run's key (:func:`run_key`) is the sha256 of the run function's dotted name, its resolved arguments and a
fingerprint of the berryshaker source code (:func:`~berryshaker.outputs.code_fingerprint`), so an interrupted study
resumes where it stopped, a repeated one is instant, and a changed model is never served a stale result.

Cache entries are text files written atomically (no pickle) as each run finishes (:func:`write_cache_entry`): a
first line of JSON holding the key, the code fingerprint, the function name, a hash of the arguments, the run's wall
time and the sha256 of the value's text, then the value's JSON text (:func:`value_text`; a numeric numpy array is
written as its bytes in base64 and read back bit for bit, so a run's tables cost no decimal conversion either way).
An entry that fails validation (:func:`read_cache_entry`: truncated, hand-edited, ``{}``) is not used: the runner
recomputes and overwrites it, with a one-line warning naming it.
"""

from __future__ import annotations

import base64
import functools
import hashlib
import json
import math
import os
import stat
import sys
import time
from pathlib import Path
from typing import Callable

from berryshaker import __version__
from berryshaker.outputs import code_fingerprint

#: Version of the cache-entry layout; part of every key.
CACHE_SCHEMA = 3

#: the key that marks a numpy array in a value's text (:func:`value_text`), and the dtypes written so
ARRAY_TAG = "__ndarray__"
_ARRAY_DTYPES = {"f": "<f8", "i": "<i8", "b": "|b1"}


def default_cache_dir() -> Path:
    """``runs/`` in the package's cache folder (:func:`berryshaker.compiled_cache.cache_home`:
    ``$BERRYSHAKER_CACHE``, else ``$XDG_CACHE_HOME/berryshaker``, ``~/.cache/berryshaker``), created private (mode
    0700; :func:`berryshaker.compiled_cache.private_folder`).

    Returns
    -------
    Path
        The run cache folder, absolute.

    Raises
    ------
    ConfigError
        The folder is not private (another user owns it or may write it) or cannot be created; ``--cache`` names
        another.
    """
    from berryshaker.compiled_cache import UnsafeCacheFolder, cache_home, private_folder
    from berryshaker.errors import ConfigError

    top = cache_home()
    try:
        return private_folder(top / "runs", top)
    except OSError as exc:
        why = str(exc) if isinstance(exc, UnsafeCacheFolder) else exc.strerror or str(exc)
        raise ConfigError(f"run cache {top / 'runs'}: {why}; it must be a folder of yours that nobody else can write "
                          "(give another with --cache or BERRYSHAKER_CACHE)") from None


def run_cache_dir(chosen: str | Path | None = None) -> Path:
    """The run cache folder, by one policy whichever way it was chosen: ``--cache`` (``chosen``), else
    ``$BERRYSHAKER_CACHE``, else the default (:func:`default_cache_dir`).  It must be a real folder of this user that
    nobody else can write, in a folder others cannot swap it in (:func:`berryshaker.compiled_cache.private_folder`;
    a new one is created with mode 0700): cached results are served without being recomputed, so a folder another
    user can write would let them forge a result.

    Parameters
    ----------
    chosen : str or Path, optional
        The folder given with ``--cache`` (or to :class:`~berryshaker.runs.runner.SweepRunner`); None for the
        environment or the default.

    Returns
    -------
    Path
        The folder, absolute.

    Raises
    ------
    ConfigError
        Empty, not a folder (a file, a FIFO, ``/dev/null``), a symlink, another user's, writable by group or
        others, or inside a folder others may write; the message names it and the fix.
    """
    from berryshaker.compiled_cache import UnsafeCacheFolder, private_folder
    from berryshaker.errors import ConfigError

    if chosen is None:
        return default_cache_dir()
    text = str(chosen)
    if not text.strip():
        raise ConfigError("--cache is empty; give a folder of yours (it is created if missing), or leave --cache out "
                          "for the default (~/.cache/berryshaker/runs, or $BERRYSHAKER_CACHE)")
    folder = Path(text).expanduser().resolve()  # as $BERRYSHAKER_CACHE is read (compiled_cache.cache_home)
    try:
        return private_folder(folder, folder)
    except UnsafeCacheFolder as exc:
        raise ConfigError(f"run cache {folder}: {exc}; it must be a folder of yours that nobody else can write "
                          "(a shared folder would let another user forge a cached result). Give another with "
                          "--cache") from None
    except OSError as exc:
        raise ConfigError(f"run cache {folder}: {exc.strerror or exc}; give a folder of yours with --cache") from None


def _jsonable(obj):
    import numpy as np

    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, (np.floating, np.integer, np.bool_)):
        return obj.item()
    return obj


def _not_json(obj):
    import numpy as np

    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"{type(obj).__name__} is not JSON-compatible (use numbers, strings, lists, dicts)")


def run_value(obj):
    """A run's return value in the form the cache stores: dicts with string keys, lists, numbers, strings, None,
    and numpy arrays of floats, integers or booleans kept as arrays (float64, int64, bool); other arrays become lists.

    Parameters
    ----------
    obj : object
        What the run function returned.

    Returns
    -------
    object
        The value; its arrays are C-contiguous copies.

    Raises
    ------
    TypeError
        A dict of the value uses the array tag :data:`ARRAY_TAG` as a key (it would be read back as an array).
    """
    import numpy as np

    if isinstance(obj, dict):
        if ARRAY_TAG in obj:
            raise TypeError(f"a run's value may not use the key {ARRAY_TAG!r}")
        return {str(k): run_value(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [run_value(v) for v in obj]
    if isinstance(obj, np.ndarray):
        dt = _ARRAY_DTYPES.get(obj.dtype.kind)
        return np.array(obj, dtype=dt, order="C") if dt else run_value(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def _array_text(obj):
    import numpy as np

    if isinstance(obj, np.ndarray) and obj.dtype.str in _ARRAY_DTYPES.values():
        return {ARRAY_TAG: obj.dtype.str, "shape": list(obj.shape),
                "data": base64.b64encode(np.ascontiguousarray(obj).tobytes()).decode("ascii")}
    raise TypeError(f"{type(obj).__name__} is not JSON-compatible (use numbers, strings, lists, dicts, arrays)")


def value_text(value) -> str:
    """The JSON text of a run's value (:func:`run_value`) as a cache entry holds it: a numpy array as
    ``{"__ndarray__": dtype, "shape": [...], "data": base64 of its bytes}``.

    Parameters
    ----------
    value : object
        The value.

    Returns
    -------
    str
        Its text (compact JSON).

    Raises
    ------
    TypeError
        Part of the value is not JSON-compatible.
    """
    return json.dumps(value, separators=(",", ":"), default=_array_text)


def _array_of(d: dict):
    """Object hook of :func:`read_value`: a tagged dict back to its array (ValueError when malformed)."""
    if ARRAY_TAG not in d:
        return d
    import numpy as np

    dt, shape, data = d.get(ARRAY_TAG), d.get("shape"), d.get("data")
    if (set(d) != {ARRAY_TAG, "shape", "data"} or dt not in _ARRAY_DTYPES.values() or not isinstance(data, str)
            or not isinstance(shape, list) or not all(isinstance(n, int) and n >= 0 for n in shape)):
        raise ValueError("malformed array")
    raw = base64.b64decode(data, validate=True)
    return np.frombuffer(raw, dtype=dt).reshape(shape).copy()


def read_value(text: str):
    """A run's value from its text (:func:`value_text`), arrays restored bit for bit.

    Parameters
    ----------
    text : str
        The value's text.

    Returns
    -------
    object
        The value.

    Raises
    ------
    ValueError
        Not JSON, or an array tag that does not hold an array.
    """
    return json.loads(text, object_hook=_array_of)


def _canonical(obj) -> str:
    """Canonical JSON text of ``obj`` (sorted keys, no spaces): the input of every hash here."""
    try:  # fast path: json walks dicts and lists itself, numpy values go through _not_json
        return json.dumps(obj, sort_keys=True, separators=(",", ":"), default=_not_json)
    except TypeError:  # e.g. keys of mixed types: normalise first
        return json.dumps(_jsonable(obj), sort_keys=True, separators=(",", ":"), default=_not_json)


def _sha256(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def value_digest(obj) -> str:
    """sha256 of a JSON-compatible value's canonical text (sorted keys, no spaces), as run keys are taken.

    Parameters
    ----------
    obj : object
        The value (dicts, lists, numbers, strings, numpy values).

    Returns
    -------
    str
        64 hex digits.
    """
    return _sha256(_canonical(obj))


@functools.lru_cache(maxsize=None)
def _file_sha256(path: str) -> str:
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError:
        return ""


def function_name(fn: Callable) -> str:
    """Dotted name ``module.qualname`` of a run function.

    Parameters
    ----------
    fn : callable
        The run function.

    Returns
    -------
    str
        Its module and qualified name, ``?`` for what it lacks.
    """
    return f"{getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', repr(fn))}"


def _outside_source(fn: Callable) -> str:
    """Content hash of the module file of a run function that lives outside the berryshaker package (its
    code is not covered by :func:`code_fingerprint`); empty for berryshaker's own functions."""
    mod = sys.modules.get(getattr(fn, "__module__", "") or "")
    return _module_file_sha256(getattr(mod, "__file__", None) or "")


@functools.lru_cache(maxsize=None)
def _module_file_sha256(path: str) -> str:
    import berryshaker

    if not path:
        return ""
    root = Path(berryshaker.__file__).resolve().parent
    p = Path(path).resolve()
    return "" if root in p.parents else _file_sha256(str(p))


def run_key(fn: Callable, kwargs: dict) -> str:
    """sha256 of the function's dotted name, its resolved arguments and the code that computes the run
    (:func:`code_fingerprint`, plus the module file of a function outside the package).

    Arguments a run function names in its ``cache_key_ignores`` attribute (a tuple of names) are left out: they
    choose how the value is computed, not the value (the multibody kernel of ``runs.sweep.model_run``, bitwise
    the same either way), so a run computed one way is found in the cache when asked for the other way.

    Parameters
    ----------
    fn : callable
        The run function.
    kwargs : dict
        Its arguments (JSON-compatible).

    Returns
    -------
    str
        The key, 64 hex digits.
    """
    ignored = getattr(fn, "cache_key_ignores", ())
    if ignored:
        kwargs = {k: v for k, v in kwargs.items() if k not in ignored}
    payload = {"fn": function_name(fn), "kwargs": kwargs, "code": code_fingerprint(),
               "module": _outside_source(fn), "schema": CACHE_SCHEMA}
    return value_digest(payload)


def cache_entry_path(cache_dir: str | Path, key: str) -> Path:
    """Where the cache entry of ``key`` lives: ``cache_dir/ab/abcdef....json``.

    Parameters
    ----------
    cache_dir : str or Path
        The cache folder.
    key : str
        A run's key (:func:`run_key`).

    Returns
    -------
    Path
        The entry's file (it may not exist).
    """
    return Path(cache_dir) / key[:2] / f"{key}.json"


#: the largest cache entry read (bytes); a run's result is far smaller
MAX_ENTRY_BYTES = 256_000_000


def _foreign(st: os.stat_result) -> str | None:
    """Why an entry's file is not this user's own (never served), or None.  (Its mode matters less: the folders
    above it are private, :func:`run_cache_dir`, so nobody else can reach it to write it.)"""
    if not stat.S_ISREG(st.st_mode):
        return "not a regular file"
    if hasattr(os, "geteuid") and st.st_uid != os.geteuid():
        return f"owned by another user (uid {st.st_uid}): never served"
    return None


def cache_entry_present(path: str | Path) -> bool:
    """Whether an entry's file is there to be read: a regular file of this user's (a symlink is not followed).  Its
    content is not read or checked; :func:`read_cache_entry` does that where the value is used.

    Parameters
    ----------
    path : str or Path
        The entry's file (:func:`cache_entry_path`).

    Returns
    -------
    bool
        True when the file is there and this user's own.
    """
    try:
        st = os.lstat(path)
    except OSError:
        return False
    return _foreign(st) is None


def read_own_file(path: str | Path, max_bytes: int) -> tuple[bytes | None, str | None]:
    """The bytes of a cache's file under the caches' one rule: a regular file of this user's, opened without
    following a symlink, at most ``max_bytes`` long.  The run cache's entries, the study's kept figures
    (:mod:`berryshaker.report.plots.figure_cache`) and page PNGs (:func:`berryshaker.report.html_blocks.page_figure_cache`)
    are all read through it.

    Parameters
    ----------
    path : str or Path
        The file.
    max_bytes : int
        The most bytes a valid file has.

    Returns
    -------
    data : bytes or None
        The content; None when there is no file or it must not be used.
    problem : str or None
        Why an existing file must not be used (a symlink, not a regular file, another user's, unreadable, too
        large); None when it was read or there is none.
    """
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        return None, None
    except OSError as exc:
        return None, f"unreadable or a symlink ({type(exc).__name__})"
    try:
        foreign = _foreign(os.fstat(fd))
        if foreign:
            return None, foreign
        with os.fdopen(os.dup(fd), "rb") as fh:
            data = fh.read(max_bytes + 1)
    except OSError as exc:
        return None, f"unreadable ({type(exc).__name__})"
    finally:
        os.close(fd)
    if len(data) > max_bytes:
        return None, "larger than any valid entry"
    return data, None


_ENTRY_TYPES = {"schema": int, "key": str, "fingerprint": str, "fn": str, "kwargs_sha256": str,
                "value_sha256": str, "wall_s": (int, float)}


def read_cache_entry(path: str | Path, key: str, fingerprint: str | None = None) -> tuple[dict | None, str | None]:
    """Read and validate one cache entry.

    Parameters
    ----------
    path : str or Path
        The entry's file (:func:`cache_entry_path`).
    key : str
        The key it must hold.
    fingerprint : str, optional
        The code fingerprint it must have been written by; None accepts any.

    Returns
    -------
    entry : dict or None
        The entry when valid.
    problem : str or None
        None when the entry is valid or there is none; else why the existing file must not be used (a symlink, not
        a regular file, another user's, not JSON, wrong schema, wrong key or code
        fingerprint, value checksum mismatch).
    """
    data, problem = read_own_file(path, MAX_ENTRY_BYTES)
    if data is None:
        return None, problem
    head, sep, body = data.partition(b"\n")
    try:
        entry = json.loads(head.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError):
        return None, "not a valid entry (truncated or edited)"
    if not isinstance(entry, dict) or not sep:
        return None, "not a valid entry (truncated or edited)"
    for name, typ in _ENTRY_TYPES.items():
        if not isinstance(entry.get(name), typ) or isinstance(entry.get(name), bool):
            return None, f"field {name!r} missing or of the wrong type"
    if entry["schema"] != CACHE_SCHEMA:
        return None, f"schema {entry['schema']} (expected {CACHE_SCHEMA})"
    if entry["key"] != key:
        return None, "key does not match its file name"
    if fingerprint is not None and entry["fingerprint"] != fingerprint:
        return None, "written by other code"
    try:
        bad_wall = not math.isfinite(entry["wall_s"]) or entry["wall_s"] < 0
    except OverflowError:  # an integer too large for a float
        bad_wall = True
    if bad_wall:
        return None, "impossible wall time"
    if hashlib.sha256(body).hexdigest() != entry["value_sha256"]:
        return None, "value checksum mismatch (edited or damaged)"
    try:
        entry["value"] = read_value(body.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, TypeError, RecursionError):
        return None, "value unreadable (edited or damaged)"
    return entry, None


def write_cache_entry(cache_dir: str | Path, key: str, fn_name: str, kwargs: dict, value, wall_s: float,
                      fingerprint: str) -> Path:
    """Write one cache entry atomically (temporary file and rename).

    Parameters
    ----------
    cache_dir : str or Path
        The cache folder.
    key : str
        The run's key (:func:`run_key`).
    fn_name : str
        The run function's dotted name (:func:`function_name`).
    kwargs : dict
        The run's arguments (stored as their hash).
    value : object
        The run's value (:func:`run_value`).
    wall_s : float
        Seconds of compute the run took (s).
    fingerprint : str
        The code fingerprint that computed it.

    Returns
    -------
    Path
        The entry's file.
    """
    from berryshaker.outputs import write_text_atomic

    body = value_text(value)
    head = {"schema": CACHE_SCHEMA, "key": key, "fingerprint": fingerprint, "fn": fn_name,
            "kwargs_sha256": _sha256(_canonical(kwargs)), "version": __version__,
            "written": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "wall_s": float(wall_s), "value_sha256": _sha256(body)}
    path = cache_entry_path(cache_dir, key)
    write_text_atomic(path, json.dumps(head, separators=(",", ":")) + "\n" + body)
    return path
