"""The sweep runner's local backend: a process pool kept across maps, with runs started ahead.

Local runs go to a process pool (``forkserver``, see :data:`DEFAULT_START_METHOD`) in chunks (a few chunks per
worker, so inter-process overhead does not dominate short runs), with progress reported per run.  Workers ignore
Ctrl-C (the parent cancels and terminates them) and exit by themselves when the parent process dies (``kill -9``);
the pool is kept across :meth:`~berryshaker.runs.runner.SweepRunner.map` calls until
:meth:`~berryshaker.runs.runner.SweepRunner.close`.  A worker that dies (a segfault, an out-of-memory kill) breaks
the pool: the runs in flight with it run again (:meth:`LocalPool.run`), and only a run that kills its worker on its
own is recorded as failed (:data:`WORKER_DEATH`).

Runs can be started ahead of the map that needs them (:meth:`LocalPool.prefetch`): they wait in a queue that a
background thread feeds to the pool while fewer chunks than workers are in flight, so a map's own runs go first.

long module: the pool, its workers' initialisation, the runs started ahead and the crash retries share one lock
and one set of futures in flight.
"""

from __future__ import annotations

import contextlib
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
from typing import Callable

from berryshaker.outputs import pid_alive
from berryshaker.runs import jobs as _jobs
from berryshaker.runs.cache import cache_entry_path, cache_entry_present, read_cache_entry, run_key
from berryshaker.runs.jobs import chunk_size, failed_outcome, run_jobs
from berryshaker.runs.main_guard import WorkerStartError, worker_start_message

#: Process start method of the local pool (override with ``BERRYSHAKER_START_METHOD``): ``forkserver``
#: where available (Linux, macOS), else ``spawn``.  Workers never inherit the parent's threads or locks
#: (``fork`` with a running progress-bar or Dask thread can deadlock, and Python 3.12+ warns about it),
#: yet after the fork server's one-time start a worker costs a fork, not a fresh interpreter (``spawn``
#: costs about 0.4 s more per worker).  Numba's on-disk cache serves compiled kernels under every method;
#: the pool is kept across maps so workers stay warm.
DEFAULT_START_METHOD = "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
#: the error of a run that ended its worker process when it ran alone (a segfault, an out-of-memory kill): the
#: runs in flight with it when a worker dies run again (LocalPool.run)
WORKER_DEATH = ("the worker process died while running it, also when it ran alone in a pool of its own (a crash of "
                "compiled code or an out-of-memory kill); run it alone, outside the pool, to see the crash's message")
#: Arm the Linux parent-death signal in pool workers (the polling thread works without it, more slowly).
_USE_PDEATHSIG = True


def usable_cores() -> int:
    """The CPU cores this process may run on (its affinity mask where the OS has one, e.g. a container pinned to
    some of the host's cores; else every core): the default number of local workers.

    Returns
    -------
    int
        At least 1.
    """
    try:
        return len(os.sched_getaffinity(0)) or 1
    except (AttributeError, OSError):
        return os.cpu_count() or 1


@dataclass
class _Chunk:
    """Runs of one function that go to one pool worker together (queued by :meth:`LocalPool.prefetch`)."""

    fn: Callable
    jobs: list  # (key, kwargs)
    cache: str | None
    fingerprint: str



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
    threads per worker and 109-113 s with one.  Dask's nanny does the same for its
    workers (``distributed.nanny.pre-spawn-environ``).  A thread count the user set in the environment
    (:data:`BLAS_THREAD_VARIABLES`) is kept: ``OPENBLAS_NUM_THREADS`` or ``MKL_NUM_THREADS`` leaves the BLAS
    libraries alone, ``OMP_NUM_THREADS`` the OpenMP ones.

    The unset variables are set first (they stay set for any subprocess a job starts), so a library loaded later in
    the worker starts with one thread; scipy's own OpenBLAS is loaded here (``scipy.linalg``) and the loaded
    libraries are then limited at run time (threadpoolctl), numpy's included, which the fork server may have loaded
    before the variables were set.

    Returns
    -------
    dict
        ``{"<api> <library path>": threads}`` before the limit (for tests and diagnostics).
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


def _worker_init(progress, parent_pid: int, start_method: str, pdeathsig: bool, prime=None, started=None) -> None:
    """Pool-worker initializer: count this worker in ``started`` (a shared counter: a pool none of whose workers
    got here died while starting, :meth:`LocalPool.run`), report progress through ``progress``, one BLAS thread (:func:`one_blas_thread`),
    leave Ctrl-C to the parent (it cancels and terminates the pool), and exit when the parent is gone (Linux: a
    kernel death signal; everywhere: a thread polling the parent pid).  With ``forkserver`` the parent is the
    fork server, which exits when the main process dies.  Then ``prime()``, if given
    (:meth:`LocalPool.start_workers`; an error in it is ignored: the runs meet it themselves)."""
    import signal

    if started is not None:
        with started.get_lock():
            started.value += 1
    _jobs._PROGRESS = progress
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
    """Nothing: a call that makes :meth:`LocalPool.start_workers`'s pool start a process."""


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


class LocalPool:
    """The local backend: worker processes kept across maps, and the runs started ahead of the maps that need
    them.  A worker calls the ``prime`` given to :meth:`start_workers` once it has started.

    Parameters
    ----------
    workers : int
        Worker processes.
    start_method : str
        ``forkserver``, ``spawn`` or ``fork``.
    say : callable
        Prints a one-line message (a worker that died).
    """

    def __init__(self, workers: int, start_method: str, say: Callable[[str], None]):
        self.workers = workers
        self.start_method = start_method
        self._say = say
        self._executor = self._progress_queue = self._finalizer = None
        self._started = None  # the shared count of the current pool's workers that started (_worker_init)
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

    # ---- the pool ------------------------------------------------------------------------------------
    def pool(self):
        """The process pool, started on first use and kept for later maps (workers keep their imports and compiled
        kernels); ended by :meth:`close`, on garbage collection or at exit.

        Returns
        -------
        pool : ProcessPoolExecutor
            The running pool.
        progress : multiprocessing.Queue
            Where its workers report each finished run.
        """
        with self._lock:
            return self._pool_locked()

    def _pool_locked(self):
        if self._executor is not None and not getattr(self._executor, "_broken", False):
            return self._executor, self._progress_queue
        self._close_pool_only()
        self.drop_broken_ahead()
        mp = multiprocessing.get_context(self.start_method)
        progress, self._started = mp.Queue(), mp.Value("i", 0)
        pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=mp, initializer=_worker_init,
                                   initargs=(progress, os.getpid(), self.start_method, _USE_PDEATHSIG, self._prime,
                                             self._started))
        self._executor, self._progress_queue = pool, progress
        self._finalizer = weakref.finalize(self, _close_pool, pool, progress)
        return pool, progress

    def close(self) -> None:
        """End the worker processes (a later map starts new ones); runs started ahead that are not finished are
        dropped."""
        self._forget_ahead()
        self._close_pool_only()

    def abort(self, close_queue: bool = True) -> None:
        """End the workers now: queued runs are dropped, running ones cancelled (finished runs stay in the cache).

        Parameters
        ----------
        close_queue : bool
            Close the progress queue too (False while a map still drains it).
        """
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
    def prefetch(self, fn: Callable, kwargs_list: list[dict], cache: str | None, fp: str,
                 chunks: int | None = None) -> int:
        """Queue the runs of ``fn`` not in the cache, queued or started yet (see
        :meth:`berryshaker.runs.runner.SweepRunner.prefetch`).

        Parameters
        ----------
        fn : callable
            The run function.
        kwargs_list : list of dict
            The runs' arguments.
        cache : str or None
            The cache folder; None: no cache.
        fp : str
            The code fingerprint.
        chunks : int, optional
            Send them in this many chunks.

        Returns
        -------
        int
            The number of runs queued.
        """
        jobs: dict[str, dict] = {}
        with self._lock:
            known = self.ahead_keys()
            for kw in kwargs_list:
                key = run_key(fn, kw)
                if key in jobs or key in known:
                    continue
                if cache and cache_entry_present(cache_entry_path(cache, key)):  # read by the map
                    continue
                jobs[key] = kw
            keys = list(jobs)
            if not keys:
                return 0
            size = chunk_size(len(keys), min(self.workers, len(keys)))
            if chunks is not None:
                size = max(1, math.ceil(len(keys) / max(1, int(chunks))))
            self._queued += [_Chunk(fn, [(k, jobs[k]) for k in keys[k0:k0 + size]], cache, fp)
                             for k0 in range(0, len(keys), size)]
            if self._feeder is None or not self._feeder.is_alive():
                self._feeder = threading.Thread(target=self._feed, name="berryshaker-prefetch", daemon=True)
                self._feeder.start()
        return len(keys)

    def warm_up(self, fn: Callable, kwargs: dict | None = None) -> Future | None:
        """Call ``fn(**kwargs)`` in a worker now, taking it like a chunk started ahead.

        Parameters
        ----------
        fn : callable
            A module-level function.
        kwargs : dict, optional
            Its arguments.

        Returns
        -------
        Future or None
            The call's future, or None when the pool cannot take work.
        """
        with self._lock:
            try:
                pool, _ = self._pool_locked()
                fut = pool.submit(fn, **(kwargs or {}))
            except RuntimeError:  # the pool broke: a warm-up is only ever an optimisation
                return None
            self._live.append(fut)
        return fut

    def start_workers(self, prime: Callable | None = None) -> int:
        """Start every worker now, each calling ``prime()`` once started.

        Parameters
        ----------
        prime : callable, optional
            A module-level function of no arguments.

        Returns
        -------
        int
            The workers started: 0 when the pool runs already or cannot start.
        """
        if self._executor is not None:
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

    def drop_broken_ahead(self) -> None:
        """Forget runs started ahead whose chunk a crashed or ended pool took down (a worker crash breaks every
        chunk in flight, also other steps' runs): the map that needs them runs them again (or finds them in the
        cache if they finished before the crash)."""
        with self._lock:
            for k, f in list(self._ahead.items()):
                if f.done() and (f.cancelled() or isinstance(f.exception(), BrokenProcessPool)):
                    del self._ahead[k]

    def ahead_keys(self) -> set[str]:
        """Keys of the runs started or queued ahead.

        Returns
        -------
        set of str
            Their keys.
        """
        with self._lock:
            return set(self._ahead).union(k for c in self._queued for k, _ in c.jobs)

    def taken(self, key: str) -> None:
        """A map recorded a run: it is not started ahead any more.

        Parameters
        ----------
        key : str
            The run's key.
        """
        with self._lock:
            self._ahead.pop(key, None)
            self._reported.discard(key)

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

    # ---- running a map -----------------------------------------------------------------------------------
    def run(self, ctx: dict, finish: Callable) -> None:
        """Run every job of the map in the pool; the runs a dying worker took down run again.

        A worker process that dies (a segfault, an out-of-memory kill) breaks the whole pool, and every run in
        flight in it fails with it, not only the one that killed it.  Those runs (not already in the cache) run
        again on a new pool, one per chunk; those lost a second time run one at a time, each in a pool of its own
        (runs started ahead for later maps keep the shared pool busy meanwhile, and one of them dying must not be
        blamed on the lone run), so that only a run that kills its worker on its own is recorded as failed
        (:data:`WORKER_DEATH`, with the pool's error).  After three such deaths in a row with nothing finishing,
        the workers die whatever they run (an environment that cannot start them): the rest fail at once.  A pool
        that broke before any of its workers started (they died importing the main script,
        :mod:`berryshaker.runs.main_guard`) raises :class:`~berryshaker.runs.main_guard.WorkerStartError` at once.

        Parameters
        ----------
        ctx : dict
            The map's state (see :mod:`berryshaker.runs.jobs`).
        finish : callable
            Called as ``finish(outcome, advance)`` for each run (``advance``: move the progress bar).

        Raises
        ------
        WorkerStartError
            No worker of the pool started.
        """
        lost = self._run_local(ctx, finish)
        if lost and self._started is not None and self._started.value == 0:
            raise WorkerStartError(worker_start_message(self.start_method, len(lost)))
        for attempt in (1, 2):
            if not lost:
                return
            for key in lost:  # their futures broke with the pool: not started ahead any more
                self.taken(key)
            how = "one at a time" if attempt == 2 else "on a new pool"
            self._say(f"a worker process died; {len(lost)} run(s) in flight with it run again {how}")
            if attempt == 1:
                lost = self._run_chunks(ctx, finish, [[k] for k in lost], {}, set())
                continue
            deaths = 0
            for i, key in enumerate(lost):
                if deaths >= 3:
                    for rest in lost[i:]:
                        finish(failed_outcome(rest, f"{WORKER_DEATH} (and the {deaths} runs before it too: the "
                                                    f"workers may not start at all; {ctx['death'].get(rest, '')})"))
                    break
                if self._run_alone(ctx, finish, key):
                    deaths += 1
                    finish(failed_outcome(key, f"{WORKER_DEATH} ({ctx['death'].get(key, '')})"))
                else:
                    deaths = 0
            lost = []

    def _run_alone(self, ctx: dict, finish: Callable, key: str) -> bool:
        """Run one run in a pool of its own (one worker); True if its worker died."""
        mp = multiprocessing.get_context(self.start_method)
        progress = mp.Queue()
        pool = ProcessPoolExecutor(max_workers=1, mp_context=mp, initializer=_worker_init,
                                   initargs=(progress, os.getpid(), self.start_method, _USE_PDEATHSIG, self._prime))
        try:
            return bool(self._run_chunks(ctx, finish, [[key]], {}, set(), (pool, progress)))
        finally:
            _close_pool(pool, progress)

    def _run_local(self, ctx: dict, finish: Callable) -> list[str]:
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
        size = chunk_size(len(own), min(self.workers, max(1, len(own))))
        return self._run_chunks(ctx, finish, [own[k:k + size] for k in range(0, len(own), size)], ahead, reported)

    def _run_chunks(self, ctx: dict, finish: Callable, chunks: list[list[str]], ahead: dict, reported: set,
                    own_pool=None) -> list[str]:
        """Submit ``chunks`` to the pool (``own_pool``: (pool, progress queue) of :meth:`_run_alone`, else the
        shared one), collect them and the runs started ahead (``ahead``: key -> future); returns the keys lost to a
        broken pool (:meth:`_run_local`), their pool's error in ``ctx["death"]``."""
        shared = own_pool is None
        pool, progress = self.pool() if shared else own_pool
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
            # the map's chunks are sent and counted in flight in one step under the lock: the prefetch feeder, which
            # sends a queued chunk whenever fewer chunks than workers are in flight, cannot slip one in between (it
            # would run before the map's own runs)
            with self._lock if shared else contextlib.nullcontext():
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
                                lost.append(k)  # the pool broke under it: run again (run)
                                ctx["death"][k] = err
                            else:
                                outs.append(failed_outcome(k, err))
                    for out in outs:
                        if out["key"] in ctx["todo"]:  # a chunk started ahead may hold runs of later maps
                            finish(out, out["key"] not in advanced)
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
