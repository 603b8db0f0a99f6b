"""One sweep runner for every multi-run step: local processes by default, a Dask distributed cluster when
a scheduler address is given.

Every finished run is cached on disk under the hash of what computed it -- the function's dotted name, its
resolved arguments and a fingerprint of the berryshaker source code (:func:`code_fingerprint`) -- so an
interrupted study resumes where it stopped, a repeated one is instant, and a changed model is never served a
stale result.  Failed runs are recorded with their error (and not cached, so they are retried).

Cache entries are JSON files written atomically (no pickle) as each run finishes; each holds its key, the
code fingerprint, the function name, a hash of the arguments, the value, the run's wall time and a checksum
of the value.  An entry that fails validation (truncated, hand-edited, ``{}``) is recomputed and
overwritten, with a one-line warning naming it.  Run functions must be module-level (so they pickle) and
return JSON-compatible values (dicts, lists, numbers, strings).

Local runs go to a process pool (``forkserver``, see :data:`DEFAULT_START_METHOD`) in chunks (a few chunks
per worker, so inter-process overhead does not dominate short runs), with progress reported per run.
Workers ignore Ctrl-C (the parent cancels and terminates them) and exit by themselves when the parent
process dies (``kill -9``); the pool is kept across :meth:`SweepRunner.map` calls until
:meth:`SweepRunner.close`.

long module: the cache (keys, fingerprint, validated entries), the local pool (chunking, interruption, orphan-proof workers) and the Dask backend are one runner; they share the job protocol.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import multiprocessing
import os
import queue as queue_mod
import sys
import threading
import time
import weakref
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable
from urllib.parse import urlsplit

from berryshaker import __version__
from berryshaker.outputs import code_fingerprint, pid_alive

#: Version of the cache-entry layout; part of every key.
CACHE_SCHEMA = 2
#: Seconds to wait for a Dask scheduler before giving up with a ConfigError.
SCHEDULER_TIMEOUT_S = 5.0
#: Process start method of the local pool (override with ``BERRYSHAKER_START_METHOD``): ``forkserver``
#: where available (Linux, macOS), else ``spawn``.  Workers never inherit the parent's threads or locks
#: (``fork`` with a running progress-bar or Dask thread can deadlock, and Python 3.12+ warns about it),
#: yet after the fork server's one-time start a worker costs a fork, not a fresh interpreter (``spawn``
#: costs about 0.4 s more per worker).  Numba's on-disk cache serves compiled kernels under every method;
#: the pool is kept across :meth:`SweepRunner.map` calls so workers stay warm.
DEFAULT_START_METHOD = "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
#: Local jobs are sent to the pool in about this many chunks per worker (fewer round trips for short runs,
#: still balanced across workers when run times differ).
CHUNKS_PER_WORKER = 4
#: the error of a run that ended its worker process when it ran alone (a segfault, an out-of-memory kill): the
#: runs in flight with it when a worker dies run again (SweepRunner._run_local_retrying)
WORKER_DEATH = ("the worker process died while running it, also when it ran alone in a pool of its own (a crash of "
                "compiled code or an out-of-memory kill); run it alone, outside the pool, to see the crash's message")
_DASK_SCHEMES = ("tcp", "tls", "ucx", "ws", "wss", "inproc")


# ---- keys ------------------------------------------------------------------------------------------
def usable_cores() -> int:
    """The CPU cores this process may run on (its affinity mask where the OS has one, e.g. a container pinned to
    some of the host's cores; else every core): the default number of local workers."""
    try:
        return len(os.sched_getaffinity(0)) or 1
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def default_cache_dir() -> Path:
    """``runs/`` in the package's cache folder (:func:`berryshaker.compiled_cache.cache_home`:
    ``$BERRYSHAKER_CACHE``, else ``$XDG_CACHE_HOME/berryshaker``, ``~/.cache/berryshaker``), created private (mode
    0700; :func:`berryshaker.compiled_cache.private_folder`).

    Raises
    ------
    ConfigError
        The folder is not private (another user owns it or may write it) or cannot be created; ``--cache`` names
        another.
    """
    from berryshaker.compiled_cache import cache_home, private_folder
    from berryshaker.errors import ConfigError

    top = cache_home()
    try:
        return private_folder(top / "runs", top)
    except OSError as exc:
        raise ConfigError(f"run cache {top / 'runs'}: {exc.strerror or exc}; it must be a folder of yours that "
                          "nobody else can write (give another with --cache or BERRYSHAKER_CACHE)") from None


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


def _canonical(obj) -> str:
    """Canonical JSON text of ``obj`` (sorted keys, no spaces): the input of every hash here."""
    try:  # fast path: json walks dicts and lists itself, numpy values go through _not_json
        return json.dumps(obj, sort_keys=True, separators=(",", ":"), default=_not_json)
    except TypeError:  # e.g. keys of mixed types: normalise first
        return json.dumps(_jsonable(obj), sort_keys=True, separators=(",", ":"), default=_not_json)


def _sha256(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


@functools.lru_cache(maxsize=None)
def _file_sha256(path: str) -> str:
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError:
        return ""


def function_name(fn: Callable) -> str:
    """Dotted name ``module.qualname`` of a run function."""
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
    the same either way), so a run computed one way is found in the cache when asked for the other way."""
    ignored = getattr(fn, "cache_key_ignores", ())
    if ignored:
        kwargs = {k: v for k, v in kwargs.items() if k not in ignored}
    payload = {"fn": function_name(fn), "kwargs": kwargs, "code": code_fingerprint(),
               "module": _outside_source(fn), "schema": CACHE_SCHEMA}
    return _sha256(_canonical(payload))


def cache_entry_path(cache_dir: str | Path, key: str) -> Path:
    """Where the cache entry of ``key`` lives: ``cache_dir/ab/abcdef....json``."""
    return Path(cache_dir) / key[:2] / f"{key}.json"


_ENTRY_TYPES = {"schema": int, "key": str, "fingerprint": str, "fn": str, "kwargs_sha256": str,
                "value_sha256": str, "wall_s": (int, float)}


def read_cache_entry(path: str | Path, key: str, fingerprint: str | None = None) -> tuple[dict | None, str | None]:
    """Read and validate one cache entry.

    Returns ``(entry, None)`` for a valid entry, ``(None, None)`` when there is none, and
    ``(None, reason)`` when the file exists but must not be used (not JSON, wrong schema, wrong key or
    code fingerprint, value checksum mismatch).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        return None, None
    except (OSError, UnicodeDecodeError) as exc:
        return None, f"unreadable ({type(exc).__name__})"
    try:
        entry = json.loads(text)
    except ValueError:
        return None, "not valid JSON (truncated or edited)"
    if not isinstance(entry, dict):
        return None, "not a JSON object"
    for name, typ in _ENTRY_TYPES.items():
        if not isinstance(entry.get(name), typ) or isinstance(entry.get(name), bool):
            return None, f"field {name!r} missing or of the wrong type"
    if "value" not in entry:
        return None, "field 'value' missing"
    if entry["schema"] != CACHE_SCHEMA:
        return None, f"schema {entry['schema']} (expected {CACHE_SCHEMA})"
    if entry["key"] != key:
        return None, "key does not match its file name"
    if fingerprint is not None and entry["fingerprint"] != fingerprint:
        return None, "written by other code"
    if not math.isfinite(entry["wall_s"]) or entry["wall_s"] < 0:
        return None, "impossible wall time"
    try:
        ok = _sha256(_canonical(entry["value"])) == entry["value_sha256"]
    except (TypeError, ValueError):
        ok = False
    if not ok:
        return None, "value checksum mismatch (edited or damaged)"
    return entry, None


def write_cache_entry(cache_dir: str | Path, key: str, fn_name: str, kwargs: dict, value, wall_s: float,
                      fingerprint: str) -> Path:
    """Write one cache entry atomically (temporary file and rename); return its path."""
    from berryshaker.outputs import write_text_atomic

    entry = {"schema": CACHE_SCHEMA, "key": key, "fingerprint": fingerprint, "fn": fn_name,
             "kwargs_sha256": _sha256(_canonical(kwargs)), "version": __version__,
             "written": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "wall_s": float(wall_s),
             "value_sha256": _sha256(_canonical(value)), "value": value}
    path = cache_entry_path(cache_dir, key)
    write_text_atomic(path, json.dumps(entry, separators=(",", ":")))
    return path


# ---- executing (in this process, in pool workers, on Dask workers) -----------------------------------
@dataclass
class _Chunk:
    """Runs of one function that go to one pool worker together (queued by :meth:`SweepRunner.prefetch`)."""

    fn: Callable
    jobs: list  # (key, kwargs)
    cache: str | None
    fingerprint: str


@dataclass
class RunResult:
    """One run of a sweep: its position, cache key, value or error, whether it came from the cache, and the
    seconds of compute it took (for a cached run: when it was computed)."""

    index: int
    key: str
    value: Any = None
    error: str | None = None
    cached: bool = False
    wall_s: float = 0.0


def execute_job(fn: Callable, kwargs: dict) -> dict:
    """Run one job and wrap the outcome ``{"value", "error", "wall_s"}``; module-level so processes and
    Dask workers can import it.  A value that is not JSON-compatible is an error of the run."""
    t0 = time.perf_counter()
    try:
        raw = fn(**kwargs)
        wall = time.perf_counter() - t0
        value = _jsonable(raw)
        _canonical(value)
        return {"value": value, "error": None, "wall_s": wall}
    except Exception as exc:  # noqa: BLE001 - recorded per run, reported by the caller
        return {"value": None, "error": f"{type(exc).__name__}: {exc}", "wall_s": time.perf_counter() - t0}


_PROGRESS = None  # a multiprocessing queue in pool workers: the key of every finished run
#: Most runs one batched call takes (a run function with a ``batch`` twin, see :func:`run_jobs`); bounds the
#: memory of the stacked output series and keeps the progress bar moving.
BATCH_SIZE = 16


def batch_threads() -> int:
    """Threads of a batched compiled call: ``BERRYSHAKER_BATCH_THREADS`` (default 1: the local pool's worker
    processes, or Dask's worker threads, already use every core)."""
    try:
        return max(1, int(os.environ.get("BERRYSHAKER_BATCH_THREADS", "1")))
    except ValueError:
        return 1


def execute_batch(fn: Callable, kwargs_list: list[dict]) -> list[dict]:
    """Run jobs through ``fn.batch`` (one call for all; it returns per job a value or the exception the job
    raised) and wrap each outcome like :func:`execute_job`; the call's wall time is shared out equally.  If
    the batched call itself fails, the jobs are run one by one."""
    import numba

    numba.set_num_threads(min(batch_threads(), numba.config.NUMBA_NUM_THREADS))
    t0 = time.perf_counter()
    try:
        raws = fn.batch(kwargs_list)
        if len(raws) != len(kwargs_list):
            raise ValueError(f"batch returned {len(raws)} results for {len(kwargs_list)} runs")
    except Exception:  # noqa: BLE001 - fall back to single runs, which record their own errors
        return [execute_job(fn, kw) for kw in kwargs_list]
    wall = (time.perf_counter() - t0) / max(len(kwargs_list), 1)
    outs = []
    for raw in raws:
        if isinstance(raw, BaseException):
            outs.append({"value": None, "error": f"{type(raw).__name__}: {raw}", "wall_s": wall})
            continue
        try:
            value = _jsonable(raw)
            _canonical(value)
            outs.append({"value": value, "error": None, "wall_s": wall})
        except Exception as exc:  # noqa: BLE001 - as in execute_job
            outs.append({"value": None, "error": f"{type(exc).__name__}: {exc}", "wall_s": wall})
    return outs


def _chunk_size(fn: Callable, n: int, workers: int) -> int:
    """Runs per chunk of a local sweep of ``n`` runs: about :data:`CHUNKS_PER_WORKER` chunks per worker, at most
    :data:`BATCH_SIZE` for a batchable run function."""
    size = max(1, math.ceil(n / (CHUNKS_PER_WORKER * max(1, workers))))
    return min(size, BATCH_SIZE) if batchable(fn) else size


def batchable(fn: Callable) -> bool:
    """True when ``fn`` has a batched twin ``fn.batch(kwargs_list) -> list`` (e.g.
    :func:`berryshaker.runs.sweep.model_run`, :func:`berryshaker.study.runs.multibody_row`)."""
    return callable(getattr(fn, "batch", None))


def run_jobs(fn: Callable, jobs: list[tuple[str, dict]], cache_dir: str | None, fingerprint: str,
             store: bool) -> list[dict]:
    """Run a chunk of jobs ``(key, kwargs)``; module-level so pool and Dask workers can import it.

    Right before each job the cache is read again (another sweep sharing the cache may have finished it);
    a computed run is stored at once when ``store`` (local workers share the parent's disk).  Returns one
    outcome per job: key, value, error, wall_s, cached, stored, problem (why an existing entry was unusable).
    """
    batched: dict[str, dict] = {}
    if batchable(fn) and len(jobs) > 1:
        # a run function with a batched twin: the chunk's runs not in the cache go through one call
        todo = [(key, kw) for key, kw in jobs if not (cache_dir and read_cache_entry(
            cache_entry_path(cache_dir, key), key, fingerprint)[0] is not None)]
        if len(todo) > 1:
            batched = dict(zip([k for k, _ in todo], execute_batch(fn, [kw for _, kw in todo])))
    outs = []
    for key, kw in jobs:
        out = None
        problem = None
        if cache_dir and key not in batched:
            entry, problem = read_cache_entry(cache_entry_path(cache_dir, key), key, fingerprint)
            if entry is not None:
                out = {"key": key, "value": entry["value"], "error": None, "wall_s": entry["wall_s"],
                       "cached": True, "stored": True, "problem": None}
        if out is None:
            res = batched[key] if key in batched else execute_job(fn, kw)
            out = {"key": key, **res, "cached": False, "stored": False, "problem": problem}
            if store and cache_dir and res["error"] is None:
                try:
                    write_cache_entry(cache_dir, key, function_name(fn), kw, res["value"], res["wall_s"],
                                      fingerprint)
                    out["stored"] = True
                except OSError as exc:
                    out["store_error"] = f"{type(exc).__name__}: {exc}"
        outs.append(out)
        if _PROGRESS is not None:
            try:
                _PROGRESS.put((key, out["error"] is None))
            except (OSError, ValueError):
                pass
    return outs


def _watch_parent(ppid: int, parent_pid: int, interval: float = 0.5) -> None:
    while True:
        # re-parented (the process that started this worker is gone), or, under a fork server, the main
        # process is gone (the fork server lives on while any of its children does)
        if os.getppid() != ppid or (ppid != parent_pid and not pid_alive(parent_pid)):
            os._exit(1)
        time.sleep(interval)


#: Environment variables that set the thread count of the BLAS / OpenMP libraries numpy and scipy load.
BLAS_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
#: In a pool worker: the BLAS / OpenMP libraries' thread counts before :func:`one_blas_thread` limited them.
_BLAS_BEFORE: dict[str, int] = {}


def one_blas_thread() -> dict[str, int]:
    """Limit this process's BLAS and OpenMP libraries to one thread each; return ``{library: threads before}``.

    A pool worker is one process per core, so a BLAS call that fans out over every core (OpenBLAS's default)
    oversubscribes the machine, and OpenBLAS's idle threads busy-wait after each call, taking CPU from the
    other workers' runs.  Measured on the 2-core machine: the study's runs took 153 s of CPU with two BLAS
    threads per worker and 109-113 s with one (benchmarks/HISTORY.md sec. 18).  Dask's nanny does the same for its
    workers (``distributed.nanny.pre-spawn-environ``).  A thread count the user set in the environment
    (:data:`BLAS_THREAD_VARIABLES`) is kept: ``OPENBLAS_NUM_THREADS`` or ``MKL_NUM_THREADS`` leaves the BLAS
    libraries alone, ``OMP_NUM_THREADS`` the OpenMP ones.

    The unset variables are set first (they stay set for any subprocess a job starts), so a library loaded later in
    the worker starts with one thread; scipy's own OpenBLAS is loaded here (``scipy.linalg``) and the loaded
    libraries are then limited at run time (threadpoolctl), numpy's included, which the fork server may have loaded
    before the variables were set.  Returns the thread counts before the limit (for tests and diagnostics).
    """
    user = {v for v in BLAS_THREAD_VARIABLES if v in os.environ}
    for v in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(v, "1")
    import scipy.linalg  # noqa: F401  (loads scipy's BLAS now, so that the limit below reaches it)
    from threadpoolctl import threadpool_info, threadpool_limits

    before = {f"{i['internal_api']} {i['filepath']}": int(i["num_threads"]) for i in threadpool_info()}
    if not user & {"OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"}:
        threadpool_limits(limits=1, user_api="blas")
    if "OMP_NUM_THREADS" not in user:
        threadpool_limits(limits=1, user_api="openmp")
    return before


def _worker_init(progress, parent_pid: int, start_method: str, pdeathsig: bool, prime=None) -> None:
    """Pool-worker initializer: report progress through ``progress``, one BLAS thread (:func:`one_blas_thread`),
    leave Ctrl-C to the parent (it cancels and terminates the pool), and exit when the parent is gone (Linux: a
    kernel death signal; everywhere: a thread polling the parent pid).  With ``forkserver`` the parent is the
    fork server, which exits when the main process dies.  Then ``prime()``, if given
    (:meth:`SweepRunner.start_workers`; an error in it is ignored: the runs meet it themselves)."""
    global _PROGRESS
    import signal

    _PROGRESS = progress
    _BLAS_BEFORE.update(one_blas_thread())
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if pdeathsig and sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass
    ppid = os.getppid()
    if start_method != "forkserver" and ppid != parent_pid:  # the parent died before the watch was armed
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(ppid, parent_pid), name="berryshaker-parent-watch",
                     daemon=True).start()
    if prime is not None:
        try:
            prime()
        except Exception:  # noqa: BLE001 - an optimisation only: a failing initializer would break the pool
            pass


def _no_prime() -> None:
    """Nothing: a call that makes :meth:`SweepRunner.start_workers`'s pool start a process."""


# ---- the runner ----------------------------------------------------------------------------------------
def check_scheduler_address(address: str) -> str:
    """Validate a Dask scheduler address without connecting (``tcp://host:port``, ``host:port``, ``tls://``,
    ``inproc://...``); return it normalised or raise :class:`~berryshaker.errors.ConfigError`."""
    from berryshaker.errors import ConfigError

    addr = (address or "").strip()
    hint = "give the scheduler as tcp://HOST:PORT (e.g. tcp://10.0.0.5:8786), or omit --scheduler to run locally"
    if not addr:
        raise ConfigError(f"--scheduler is empty; {hint}")
    full = addr if "://" in addr else f"tcp://{addr}"
    try:
        parts = urlsplit(full)
        port = parts.port
    except ValueError:
        raise ConfigError(f"--scheduler {address!r} is not a valid address; {hint}") from None
    if parts.scheme not in _DASK_SCHEMES:
        raise ConfigError(f"--scheduler {address!r}: unknown protocol {parts.scheme!r} "
                          f"(use one of {', '.join(_DASK_SCHEMES)}); {hint}")
    if parts.scheme != "inproc" and (not parts.hostname or port is None or parts.path not in ("", "/")
                                     or parts.query or parts.fragment):
        raise ConfigError(f"--scheduler {address!r} needs a host and a port; {hint}")
    return full


class SweepRunner:
    """Runs ``fn(**kwargs)`` for many argument sets with caching, parallelism and a progress bar.

    Parameters
    ----------
    workers : int, optional
        Local worker processes (default: all cores); must be >= 1.
    scheduler : str, optional
        Dask scheduler address; runs go to that cluster instead of local processes.
    cache_dir : path, optional
        Cache folder (default :func:`default_cache_dir`).
    use_cache : bool
        Read and write the cache.
    progress : bool
        Show a progress bar (rich) on ``console`` or stderr.
    start_method : str, optional
        ``forkserver``, ``spawn`` or ``fork`` (default :data:`DEFAULT_START_METHOD`).

    ``stats`` counts runs, cached, computed, failed, ``compute_s`` (compute seconds spent now),
    ``cached_compute_s`` (the stored compute seconds of runs served by the cache) and ``cold_compute_s``
    (their sum: what the runs cost from a cold cache), ``elapsed_s`` (wall time inside :meth:`map`).
    ``warnings`` lists the one-line warnings printed (invalid cache entries...).
    """

    def __init__(self, workers: int | None = None, scheduler: str | None = None, cache_dir: Path | str | None = None,
                 use_cache: bool = True, progress: bool = True, console=None, start_method: str | None = None):
        from berryshaker.errors import ConfigError

        if workers is None:
            self.workers = usable_cores()
        else:
            try:
                ok = not isinstance(workers, bool) and int(workers) == workers
            except (TypeError, ValueError):
                ok = False
            if not ok or workers < 1:
                raise ConfigError(f"--workers must be >= 1 (got {workers!r}); omit it to use all cores")
            self.workers = int(workers)
        self.scheduler = check_scheduler_address(scheduler) if scheduler is not None else None
        self.scheduler_timeout_s = SCHEDULER_TIMEOUT_S
        self.cache_dir = Path(cache_dir) if cache_dir else default_cache_dir()
        self.use_cache = use_cache
        self.progress = progress
        self.console = console
        self.start_method = start_method or os.environ.get("BERRYSHAKER_START_METHOD") or DEFAULT_START_METHOD
        if self.start_method not in multiprocessing.get_all_start_methods():
            raise ConfigError(f"start method {self.start_method!r} is not available here; use one of "
                              f"{', '.join(multiprocessing.get_all_start_methods())}")
        self.stats = {"runs": 0, "cached": 0, "computed": 0, "failed": 0, "compute_s": 0.0,
                      "cached_compute_s": 0.0, "cold_compute_s": 0.0, "elapsed_s": 0.0}
        self.warnings: list[str] = []
        self._warned: set[str] = set()
        self._executor = self._progress_queue = self._finalizer = None
        # runs started ahead of the map that needs them (:meth:`prefetch`): chunks waiting for an idle worker,
        # the future of every submitted run's chunk, the futures in flight (the feeder keeps at most one chunk
        # per worker in flight, so a map's own runs go first), and runs the workers reported finished
        self._lock = threading.RLock()
        self._queued: list[_Chunk] = []
        self._ahead: dict[str, Future] = {}
        self._live: list[Future] = []
        self._reported: set[str] = set()
        self._feeder: threading.Thread | None = None
        self._prime: Callable | None = None  # what every worker calls once it has started (start_workers)

    # ---- messages ----------------------------------------------------------------------------------
    def _say(self, msg: str) -> None:
        if self.console is not None:
            self.console.print(msg, markup=False, highlight=False, soft_wrap=True)
        else:
            print(msg, file=sys.stderr, flush=True)

    def _warn(self, msg: str) -> None:
        self.warnings.append(msg)
        self._say(f"warning: {msg}")

    def _entry_problem(self, key: str, problem: str | None) -> None:
        if problem and key not in self._warned:
            self._warned.add(key)
            self._warn(f"cache entry {cache_entry_path(self.cache_dir, key)} is invalid ({problem}); recomputing it")

    def summary_line(self) -> str:
        """One line for a report: runs, cached, failed, compute now and cold cost."""
        s = self.stats
        return (f"{s['runs']} runs ({s['cached']} from the cache, {s['failed']} failed): "
                f"{s['elapsed_s']:.1f} s now; cold cost {s['cold_compute_s']:.1f} s of compute")

    # ---- dask ----------------------------------------------------------------------------------------
    def connect(self):
        """A :class:`distributed.Client` for the scheduler; a :class:`~berryshaker.errors.ConfigError` within
        ``scheduler_timeout_s`` when it cannot be reached."""
        from berryshaker.errors import ConfigError

        if self.scheduler is None:
            raise ConfigError("no --scheduler given")
        try:
            from distributed import Client
        except ImportError:
            raise ConfigError("--scheduler needs dask.distributed (pip install 'dask[distributed]')") from None
        import logging

        quiet = [logging.getLogger(n) for n in ("distributed.client", "distributed.comm.core", "distributed.core")]
        levels = [lg.level for lg in quiet]
        for lg in quiet:
            lg.setLevel(logging.CRITICAL)
        try:
            return Client(self.scheduler, timeout=f"{self.scheduler_timeout_s}s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise ConfigError(f"--scheduler {self.scheduler}: no Dask scheduler answered within "
                              f"{self.scheduler_timeout_s:g} s ({type(exc).__name__}); check that `dask scheduler` "
                              "runs there and the host and port, or omit --scheduler to run locally") from None
        finally:
            for lg, lv in zip(quiet, levels):
                lg.setLevel(lv)

    def check_scheduler(self) -> None:
        """Connect once to the scheduler (if any) and disconnect: call before any work to fail early."""
        if self.scheduler is not None:
            self.connect().close()

    # ---- running -------------------------------------------------------------------------------------
    def map(self, fn: Callable, kwargs_list: list[dict], label: str = "runs") -> list[RunResult]:
        """Run ``fn(**kw)`` for every ``kw`` (cached, in parallel); results in input order, failures recorded.

        Ctrl-C stops within about a second: pending runs are cancelled, the workers terminated, runs that
        finished stay in the cache, a one-line message says so, and ``KeyboardInterrupt`` is raised again.
        """
        t_start = time.perf_counter()
        kwargs_list = list(kwargs_list)
        n = len(kwargs_list)
        results: list[RunResult | None] = [None] * n
        fp = code_fingerprint()
        cache = str(self.cache_dir) if self.use_cache else None
        todo: dict[str, list[int]] = {}
        jobs: dict[str, dict] = {}
        self._drop_broken_ahead()
        ahead = self._ahead_keys()
        for i, kw in enumerate(kwargs_list):
            key = run_key(fn, kw)
            if key in todo:
                todo[key].append(i)
                continue
            if cache and key not in ahead:  # a run started ahead is this sweep's own, not a cached one
                entry, problem = read_cache_entry(cache_entry_path(cache, key), key, fp)
                self._entry_problem(key, problem)
                if entry is not None:
                    results[i] = RunResult(i, key, entry["value"], None, True, float(entry["wall_s"]))
                    continue
            todo[key] = [i]
            jobs[key] = kw
        self.stats["runs"] += n
        pre_cached = sum(1 for r in results if r is not None)
        self.stats["cached"] += pre_cached
        self.stats["cached_compute_s"] += sum(r.wall_s for r in results if r is not None)
        bar = self._bar(label, n, pre_cached)
        ctx = {"fn": fn, "results": results, "todo": todo, "jobs": jobs, "bar": bar, "fp": fp, "cache": cache,
               "done": set(), "ok_elsewhere": set()}
        try:
            if todo:
                if self.scheduler:
                    self._run_dask(ctx)
                elif self.workers <= 1 or (len(todo) == 1 and not ahead.intersection(todo)):
                    keys = list(jobs)
                    size = BATCH_SIZE if batchable(fn) else 1
                    for k0 in range(0, len(keys), size):
                        for out in run_jobs(fn, [(k, jobs[k]) for k in keys[k0:k0 + size]], cache, fp, True):
                            self._finish(ctx, out)
                else:
                    self._run_local_retrying(ctx)
        except KeyboardInterrupt:
            if bar is not None:
                bar[0].stop()
                bar = None
            finished = sum(1 for r in results if r is not None and r.error is None) + sum(
                len(ctx["todo"][k]) for k in ctx["ok_elsewhere"] - ctx["done"])
            where = f"; they are cached in {self.cache_dir}, run the same command again to resume" if cache else ""
            self._say(f"interrupted: {finished} of {n} runs had finished{where}")
            raise
        finally:
            if bar is not None:
                bar[0].stop()
            self.stats["failed"] += sum(1 for r in results if r is not None and r.error)
            self.stats["cold_compute_s"] = self.stats["compute_s"] + self.stats["cached_compute_s"]
            self.stats["elapsed_s"] += time.perf_counter() - t_start
        return results  # type: ignore[return-value]

    def values(self, fn: Callable, kwargs_list: list[dict], label: str = "runs") -> list:
        """Like map, but raise on the first failed run (for steps that cannot do without every run)."""
        from berryshaker.errors import SimulationError

        out = self.map(fn, kwargs_list, label)
        bad = [r for r in out if r.error]
        if bad:
            raise SimulationError(f"{label}: run {bad[0].index + 1} of {len(out)} failed: {bad[0].error}")
        return [r.value for r in out]

    def _finish(self, ctx, out: dict, advance: bool = True) -> None:
        """Record one outcome (for every input index with its key), store it if the worker did not."""
        key = out["key"]
        if key in ctx["done"]:
            return
        ctx["done"].add(key)
        with self._lock:
            self._ahead.pop(key, None)
            self._reported.discard(key)
        self._entry_problem(key, out.get("problem"))
        if out.get("store_error"):
            self._warn(f"could not write the cache entry of a run ({out['store_error']})")
        elif ctx["cache"] and out["error"] is None and not out.get("stored"):
            try:
                write_cache_entry(ctx["cache"], key, function_name(ctx["fn"]), ctx["jobs"][key], out["value"],
                                  out["wall_s"], ctx["fp"])
            except OSError as exc:
                self._warn(f"could not write the cache entry of a run ({type(exc).__name__}: {exc})")
        idx = ctx["todo"][key]
        for i in idx:
            ctx["results"][i] = RunResult(i, key, out["value"], out["error"], bool(out["cached"]), float(out["wall_s"]))
        if out["cached"]:
            self.stats["cached"] += len(idx)
            self.stats["cached_compute_s"] += float(out["wall_s"]) * len(idx)
        else:
            self.stats["computed"] += 1
            self.stats["compute_s"] += float(out["wall_s"])
            self.stats["cached"] += len(idx) - 1  # duplicates in this sweep
        if advance and ctx["bar"] is not None:
            ctx["bar"][0].advance(ctx["bar"][1], len(idx))

    def _failed(self, key: str, error: str) -> dict:
        return {"key": key, "value": None, "error": error, "wall_s": 0.0, "cached": False, "stored": False}

    def _pool(self):
        """The local process pool, started on first use and kept for later :meth:`map` calls (workers keep
        their imports and compiled kernels); ended by :meth:`close`, on garbage collection or at exit."""
        with self._lock:
            return self._pool_locked()

    def _pool_locked(self):
        if self._executor is not None and not getattr(self._executor, "_broken", False):
            return self._executor, self._progress_queue
        self._close_pool_only()
        self._drop_broken_ahead()
        mp = multiprocessing.get_context(self.start_method)
        progress = mp.Queue()
        pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=mp, initializer=_worker_init,
                                   initargs=(progress, os.getpid(), self.start_method, _USE_PDEATHSIG, self._prime))
        self._executor, self._progress_queue = pool, progress
        self._finalizer = weakref.finalize(self, _close_pool, pool, progress)
        return pool, progress

    def close(self) -> None:
        """End the local worker processes (a later :meth:`map` starts new ones); runs started ahead
        (:meth:`prefetch`) that are not finished are dropped."""
        self._forget_ahead()
        self._close_pool_only()

    def abort(self, close_queue: bool = True) -> None:
        """End the local workers now: queued runs are dropped, running ones cancelled (finished runs stay in the
        cache).  For Ctrl-C or an error while runs started ahead (:meth:`prefetch`) may still be running; a
        later :meth:`map` starts new workers."""
        self._forget_ahead()
        pool, progress = self._executor, self._progress_queue
        self._executor = self._progress_queue = None
        if self._finalizer is not None:
            self._finalizer.detach()
            self._finalizer = None
        if pool is not None:
            _abort_pool(pool)
            if close_queue and progress is not None:
                _close_queue(progress)

    def _close_pool_only(self) -> None:
        if self._finalizer is not None:
            self._finalizer()
        self._executor = self._progress_queue = self._finalizer = None

    # ---- runs started ahead ------------------------------------------------------------------------------
    def prefetch(self, fn: Callable, kwargs_list: list[dict], chunks: int | None = None) -> int:
        """Start runs in idle pool workers ahead of the :meth:`map` that will ask for them.

        The runs wait in a queue and go to a worker whenever fewer chunks than workers are in flight, so the
        runs a :meth:`map` sends itself always go first, and this process is free meanwhile (to compile, plot,
        analyse).  A later :meth:`map` of the same function and arguments takes their results instead of
        running them again (queued runs it needs are sent at once); a run is counted (computed, failed) when a
        map takes it.  Runs already in the cache, queued or started are skipped.  Does nothing with one worker
        or a Dask scheduler (their maps run as before).

        Parameters
        ----------
        fn, kwargs_list
            As for :meth:`map`.
        chunks : int, optional
            Send the runs in this many chunks (default: as :meth:`map` does).  ``1`` keeps them in one worker,
            e.g. while this process compiles on another core.

        Returns
        -------
        int
            The number of runs queued.
        """
        if self.scheduler or self.workers <= 1:
            return 0
        fp = code_fingerprint()
        cache = str(self.cache_dir) if self.use_cache else None
        jobs: dict[str, dict] = {}
        with self._lock:
            known = self._ahead_keys()
            for kw in kwargs_list:
                key = run_key(fn, kw)
                if key in jobs or key in known:
                    continue
                if cache and read_cache_entry(cache_entry_path(cache, key), key, fp)[0] is not None:
                    continue
                jobs[key] = kw
            keys = list(jobs)
            if not keys:
                return 0
            size = _chunk_size(fn, len(keys), min(self.workers, len(keys)))
            if chunks is not None:
                size = max(1, math.ceil(len(keys) / max(1, int(chunks))))
                size = min(size, BATCH_SIZE) if batchable(fn) else size
            self._queued += [_Chunk(fn, [(k, jobs[k]) for k in keys[k0:k0 + size]], cache, fp)
                             for k0 in range(0, len(keys), size)]
            if self._feeder is None or not self._feeder.is_alive():
                self._feeder = threading.Thread(target=self._feed, name="berryshaker-prefetch", daemon=True)
                self._feeder.start()
        return len(keys)

    def all_cached(self, fn: Callable, kwargs_list: list[dict]) -> bool:
        """True when every run of ``fn`` with these arguments is in the cache (for this code): a :meth:`map` of
        them would start no worker."""
        if not self.use_cache:
            return not kwargs_list
        fp = code_fingerprint()
        cache = str(self.cache_dir)
        for kw in kwargs_list:
            key = run_key(fn, kw)
            if read_cache_entry(cache_entry_path(cache, key), key, fp)[0] is None:
                return False
        return True

    def warm_up(self, fn: Callable, kwargs: dict | None = None) -> Future | None:
        """Call ``fn(**kwargs)`` in a pool worker now, for its side effects (e.g. compiling kernels into numba's
        on-disk cache while this process compiles others); nothing is cached or counted.

        It takes a worker like a chunk of runs started ahead (:meth:`prefetch`), so queued runs wait for another
        worker.  Returns the call's future (its exception, if any, is the caller's to look at), or None with one
        worker or a Dask scheduler (nothing to run beside this process).
        """
        if self.scheduler or self.workers <= 1:
            return None
        with self._lock:
            try:
                pool, _ = self._pool_locked()
                fut = pool.submit(fn, **(kwargs or {}))
            except RuntimeError:  # the pool broke: a warm-up is only ever an optimisation
                return None
            self._live.append(fut)
        return fut

    def start_workers(self, prime: Callable | None = None) -> int:
        """Start every local worker process now (they are otherwise started with the first runs that need them),
        each calling ``prime()`` once it has started, e.g. to import the modules its runs will need while this
        process is still busy on its own.  Workers started later (a pool started again after a crash) call it
        too.  Returns the workers started: 0 with one worker (its runs run in this process), a Dask scheduler or
        a pool running already.

        A start-up optimisation only: a prime that fails is ignored (the runs meet the same error themselves)."""
        if self.scheduler or self.workers <= 1 or self._executor is not None:
            return 0
        with self._lock:
            self._prime = prime
            try:
                pool, _ = self._pool_locked()
                # one call per worker, all submitted at once: none is idle yet, so each submit starts a process
                futs = [pool.submit(_no_prime) for _ in range(self.workers)]
            except RuntimeError:
                return 0
            self._live.extend(futs)
        return self.workers

    def _drop_broken_ahead(self) -> None:
        """Forget runs started ahead whose chunk a crashed or ended pool took down (a worker crash breaks every
        chunk in flight, also other steps' runs): the map that needs them runs them again (or finds them in the
        cache if they finished before the crash)."""
        with self._lock:
            for k, f in list(self._ahead.items()):
                if f.done() and (f.cancelled() or isinstance(f.exception(), BrokenProcessPool)):
                    del self._ahead[k]

    def _ahead_keys(self) -> set[str]:
        """Keys of the runs started or queued ahead."""
        with self._lock:
            return set(self._ahead).union(k for c in self._queued for k, _ in c.jobs)

    def _submit_chunk(self, chunk: _Chunk) -> Future | None:
        """Send a queued chunk to the pool (under the lock); None when the pool cannot take work."""
        try:
            pool, _ = self._pool_locked()
            fut = pool.submit(run_jobs, chunk.fn, chunk.jobs, chunk.cache, chunk.fingerprint, True)
        except RuntimeError:  # the pool was shut down or broke: the map that needs these runs sends them again
            return None
        fut.berryshaker_keys = [k for k, _ in chunk.jobs]
        self._live.append(fut)
        for k, _ in chunk.jobs:
            self._ahead[k] = fut
        return fut

    def _feed(self) -> None:
        """Background thread: send queued chunks while fewer chunks than workers are in flight."""
        while True:
            with self._lock:
                self._live = [f for f in self._live if not f.done()]
                while self._queued and len(self._live) < self.workers:
                    if self._submit_chunk(self._queued.pop(0)) is None:
                        self._queued.clear()
                if not self._queued:
                    self._feeder = None
                    return
                live = list(self._live)
            wait(live, timeout=0.5, return_when=FIRST_COMPLETED)

    def _forget_ahead(self) -> None:
        """Drop the queued runs and forget the started ones (the pool is being ended)."""
        with self._lock:
            self._queued.clear()
            self._ahead.clear()
            self._live.clear()
            self._reported.clear()

    def __enter__(self) -> SweepRunner:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _run_local_retrying(self, ctx) -> None:
        """:meth:`_run_local`, and again for the runs a dying worker took down.

        A worker process that dies (a segfault, an out-of-memory kill) breaks the whole pool, and every run in
        flight in it fails with it, not only the one that killed it.  Those runs (not already in the cache) run
        again on a new pool, one per chunk; those lost a second time run one at a time, each in a pool of its own
        (runs started ahead for later maps keep the shared pool busy meanwhile, and one of them dying must not be
        blamed on the lone run), so that only a run that kills its worker on its own is recorded as failed
        (:data:`WORKER_DEATH`, with the pool's error).  After three such deaths in a row with nothing finishing,
        the workers die whatever they run (an environment that cannot start them): the rest fail at once."""
        lost = self._run_local(ctx)
        for attempt in (1, 2):
            if not lost:
                return
            with self._lock:  # their futures broke with the pool: not started ahead any more
                for key in lost:
                    self._ahead.pop(key, None)
                    self._reported.discard(key)
            how = "one at a time" if attempt == 2 else "on a new pool"
            self._say(f"a worker process died; {len(lost)} run(s) in flight with it run again {how}")
            if attempt == 1:
                lost = self._run_chunks(ctx, [[k] for k in lost], {}, set())
                continue
            deaths = 0
            for i, key in enumerate(lost):
                if deaths >= 3:
                    for rest in lost[i:]:
                        self._finish(ctx, self._failed(rest, f"{WORKER_DEATH} (and the {deaths} runs before it "
                                                             f"too: the workers may not start at all; "
                                                             f"{ctx['death'].get(rest, '')})"))
                    break
                if self._run_alone(ctx, key):
                    deaths += 1
                    self._finish(ctx, self._failed(key, f"{WORKER_DEATH} ({ctx['death'].get(key, '')})"))
                else:
                    deaths = 0
            lost = []

    def _run_alone(self, ctx, key: str) -> bool:
        """Run one run in a pool of its own (one worker); True if its worker died."""
        mp = multiprocessing.get_context(self.start_method)
        progress = mp.Queue()
        pool = ProcessPoolExecutor(max_workers=1, mp_context=mp, initializer=_worker_init,
                                   initargs=(progress, os.getpid(), self.start_method, _USE_PDEATHSIG, self._prime))
        try:
            return bool(self._run_chunks(ctx, [[key]], {}, set(), (pool, progress)))
        finally:
            _close_pool(pool, progress)

    def _run_local(self, ctx) -> list[str]:
        """Run every run of the map in the local pool, with the chunks of them started ahead; returns the keys a
        broken pool took down before they finished (not in the cache; not recorded yet)."""
        keys = list(ctx["jobs"])
        with self._lock:
            # queued runs (prefetch) this map needs are sent now, ahead of the rest of the queue
            need = set(keys)
            take = [c for c in self._queued if any(k in need for k, _ in c.jobs)]
            self._queued = [c for c in self._queued if all(k not in need for k, _ in c.jobs)]
            for c in take:
                self._submit_chunk(c)
            ahead = {k: self._ahead[k] for k in keys if k in self._ahead}
            reported = {k for k in keys if k in self._reported}
        own = [k for k in keys if k not in ahead]
        size = _chunk_size(ctx["fn"], len(own), min(self.workers, max(1, len(own))))
        return self._run_chunks(ctx, [own[k:k + size] for k in range(0, len(own), size)], ahead, reported)

    def _run_chunks(self, ctx, chunks: list[list[str]], ahead: dict, reported: set, own_pool=None) -> list[str]:
        """Submit ``chunks`` to the pool (``own_pool``: (pool, progress queue) of :meth:`_run_alone`, else the
        shared one), collect them and the runs started ahead (``ahead``: key -> future); returns the keys lost to a
        broken pool (:meth:`_run_local`), their pool's error in ``ctx["death"]``."""
        shared = own_pool is None
        pool, progress = self._pool() if shared else own_pool
        lost: list[str] = []
        ctx.setdefault("death", {})
        advanced: set[str] = ctx.setdefault("advanced", set())  # runs the bar counted (across retries)
        for key in reported:  # finished in a worker before this map began (its chunk may still be running)
            if key not in ctx["done"]:
                advanced.add(key)
                if ctx["bar"] is not None:
                    ctx["bar"][0].advance(ctx["bar"][1], len(ctx["todo"][key]))

        def drain():
            while True:
                try:
                    key, ok = progress.get_nowait()
                except (queue_mod.Empty, OSError, ValueError, EOFError, TypeError):
                    return
                if key not in ctx["todo"]:  # a run started ahead for a later map (or a late message: ignored)
                    with self._lock:
                        if key in self._ahead:
                            self._reported.add(key)
                    continue
                if ok:
                    ctx["ok_elsewhere"].add(key)
                if key not in advanced and key not in ctx["done"]:
                    advanced.add(key)
                    if ctx["bar"] is not None:
                        ctx["bar"][0].advance(ctx["bar"][1], len(ctx["todo"][key]))

        clean = False
        try:
            futs = {}
            for chunk in chunks:
                try:
                    fut = pool.submit(run_jobs, ctx["fn"], [(k, ctx["jobs"][k]) for k in chunk], ctx["cache"],
                                      ctx["fp"], True)
                except BrokenProcessPool as exc:  # it broke under runs sent before (or started ahead)
                    for k in chunk:
                        ctx["death"][k] = f"{type(exc).__name__}: {exc}"
                    lost += chunk
                    continue
                futs[fut] = chunk
            if shared:
                with self._lock:
                    self._live = [f for f in self._live if not f.done()] + list(futs)
            for fut in set(ahead.values()):
                futs[fut] = [k for k in fut.berryshaker_keys if k in ctx["todo"]]
            pending = set(futs)
            while pending:
                done, pending = wait(pending, timeout=0.1, return_when=FIRST_COMPLETED)
                gone = {f for f in pending if f.cancelled()}  # wait() never reports a cancelled future as done
                done, pending = done | gone, pending - gone
                drain()
                for fut in done:
                    chunk = futs[fut]
                    try:
                        outs = fut.result()
                    except Exception as exc:  # noqa: BLE001 - a crashed worker process
                        err = f"{type(exc).__name__}: {exc}"
                        outs = []
                        for k in chunk:  # runs of the chunk that finished before the crash are in the cache
                            entry, _ = read_cache_entry(cache_entry_path(ctx["cache"], k), k, ctx["fp"]) \
                                if ctx["cache"] else (None, None)
                            if entry:
                                outs.append({"key": k, "value": entry["value"], "error": None,
                                             "wall_s": entry["wall_s"], "cached": False, "stored": True})
                            elif isinstance(exc, BrokenProcessPool) and k in ctx["todo"] and k not in ctx["done"]:
                                lost.append(k)  # the pool broke under it: run again (_run_local_retrying)
                                ctx["death"][k] = err
                            else:
                                outs.append(self._failed(k, err))
                    for out in outs:
                        if out["key"] in ctx["todo"]:  # a chunk started ahead may hold runs of later maps
                            self._finish(ctx, out, advance=out["key"] not in advanced)
            clean = True
        finally:
            if not clean:  # Ctrl-C or an error in this process: cancel, end the workers now
                if not shared:
                    _abort_pool(pool)
                self.abort(close_queue=False)
                drain()  # runs that finished before the interruption (for the message)
                if shared:
                    _close_queue(progress)
            elif shared and getattr(pool, "_broken", False) and self._executor is pool:
                self._close_pool_only()
        return lost

    def _run_dask(self, ctx) -> None:
        from distributed import as_completed

        client = self.connect()
        futs = {}
        try:
            keys = list(ctx["jobs"])
            # a run function with a batched twin: chunks of runs per task (one compiled call each)
            size = 1
            if batchable(ctx["fn"]):
                size = min(BATCH_SIZE, max(1, math.ceil(len(keys) / (CHUNKS_PER_WORKER * self._dask_cores(client)))))
            for k0 in range(0, len(keys), size):
                chunk = keys[k0:k0 + size]
                f = client.submit(run_jobs, ctx["fn"], [(k, ctx["jobs"][k]) for k in chunk], ctx["cache"], ctx["fp"],
                                  False, key=f"berryshaker-{chunk[0]}-{len(chunk)}", pure=False, retries=3)
                futs[f] = chunk
            for f in as_completed(list(futs)):
                chunk = futs[f]
                try:
                    outs = f.result()
                except Exception as exc:  # noqa: BLE001 - lost beyond its retries
                    outs = [self._failed(k, f"{type(exc).__name__}: {exc}") for k in chunk]
                for out in outs:
                    self._finish(ctx, out)
        except BaseException:
            try:
                client.cancel(list(futs), force=True)
            except Exception:  # noqa: BLE001 - best effort while stopping
                pass
            raise
        finally:
            client.close(timeout=2)

    @staticmethod
    def _dask_cores(client) -> int:
        """Threads across the cluster's workers (at least 1)."""
        try:
            return max(1, sum(w.get("nthreads", 1) for w in client.scheduler_info()["workers"].values()))
        except Exception:  # noqa: BLE001 - a scheduler that does not say: assume one
            return 1

    def _bar(self, label, total, done):
        if not self.progress:
            return None
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

        class RateColumn(TextColumn):
            def __init__(self):
                super().__init__("")

            def render(self, task):
                from rich.text import Text

                speed = task.finished_speed or task.speed
                return Text(f"{speed:.2f} runs/s" if speed else "")

        p = Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), RateColumn(),
                     TextColumn("ETA"), TimeRemainingColumn(), console=self.console or Console(stderr=True),
                     transient=False)
        p.start()
        tid = p.add_task(label + (f" ({done} cached)" if done else ""), total=total, completed=done)
        return p, tid


#: Arm the Linux parent-death signal in pool workers (the polling thread works without it, more slowly).
_USE_PDEATHSIG = True


def _close_queue(progress) -> None:
    try:
        progress.close()
        progress.cancel_join_thread()
    except (OSError, ValueError):
        pass


def _close_pool(pool: ProcessPoolExecutor, progress) -> None:
    """End an idle pool (its workers finish nothing more) and its progress queue."""
    pool.shutdown(wait=True, cancel_futures=True)
    _close_queue(progress)


def _abort_pool(pool: ProcessPoolExecutor) -> None:
    """Cancel pending work and end the worker processes now (Ctrl-C or an error in the parent)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        if p.is_alive():
            p.terminate()
    deadline = time.monotonic() + 1.0
    for p in procs:
        p.join(max(0.0, deadline - time.monotonic()))
        if p.is_alive():
            p.kill()
            p.join(0.5)
