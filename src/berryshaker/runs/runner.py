"""One sweep runner for every multi-run step: local processes by default, a Dask distributed cluster when
a scheduler address is given.

Every finished run is cached on disk under the hash of what computed it -- the function's dotted name, its
resolved arguments and a fingerprint of the berryshaker source code (:func:`code_fingerprint`) -- so an
interrupted study resumes where it stopped, a repeated one is instant, and a changed model is never served a
stale result (:mod:`berryshaker.runs.cache`).  Failed runs are recorded with their error (and not cached, so they
are retried); a lost Dask scheduler is no run's failure but the map's: one error naming the runs that did not
finish, the finished ones cached, so the same command resumes.  Run functions must be module-level (so they pickle) and return JSON-compatible values (dicts, lists,
numbers, strings, and numpy arrays of floats, integers or booleans, stored as their bytes: runs.cache.run_value).

:class:`SweepRunner` composes the cache with one of three backends sharing one small interface (``run(ctx, finish)``,
:mod:`berryshaker.runs.jobs`): in this process (one worker), a local process pool kept across maps
(:mod:`berryshaker.runs.local_pool`; chunking, interruption, orphan-proof workers, runs started ahead and warm-ups)
or a Dask cluster (:mod:`berryshaker.runs.dask_backend`).  The names of those modules that callers used from here
are importable from here too.
"""

from __future__ import annotations

import multiprocessing
import os
import sys
import time
import weakref
from concurrent.futures import Future
from pathlib import Path
from typing import Callable

from berryshaker.outputs import code_fingerprint
from berryshaker.runs import dask_backend
from berryshaker.runs.cache import (  # noqa: F401  (re-exported: the runner's public names)
    CACHE_SCHEMA,
    cache_entry_path,
    cache_entry_present,
    default_cache_dir,
    function_name,
    read_cache_entry,
    run_cache_dir,
    run_key,
    write_cache_entry,
)
from berryshaker.runs.dask_backend import SCHEDULER_TIMEOUT_S, DaskBackend, SchedulerLost, check_scheduler_address  # noqa: F401
from berryshaker.runs.jobs import (  # noqa: F401
    CHUNKS_PER_WORKER,
    InProcess,
    RunResult,
    execute_job,
    run_jobs,
)
from berryshaker.runs.local_pool import (  # noqa: F401
    _BLAS_BEFORE,
    BLAS_THREAD_VARIABLES,
    DEFAULT_START_METHOD,
    WORKER_DEATH,
    LocalPool,
    one_blas_thread,
    usable_cores,
)
from berryshaker.runs.main_guard import SCRIPT_IDIOM, leave_if_bootstrapping, unguarded_main_line


def _say_through(ref: weakref.ref) -> Callable[[str], None]:
    """A ``say(msg)`` for the local pool that prints through the runner ``ref`` refers to, if it still exists."""
    def say(msg: str) -> None:
        runner = ref()
        if runner is not None:
            runner._say(msg)
    return say


def max_workers() -> int:
    """The most local worker processes a runner starts: 4 per usable core, at least 16 (a count beyond it is a slip
    of the number: starting 100 million processes would take the machine down).

    Returns
    -------
    int
        The bound.
    """
    return max(16, 4 * usable_cores())


def _ranges(rows: list[int]) -> str:
    """``[1, 2, 3, 7, 9, 10]`` -> ``"1-3, 7, 9-10"``."""
    spans: list[list[int]] = []
    for r in rows:
        if spans and r == spans[-1][1] + 1:
            spans[-1][1] = r
        else:
            spans.append([r, r])
    return ", ".join(str(a) if a == b else f"{a}-{b}" for a, b in spans)


class SweepRunner:
    """Runs ``fn(**kwargs)`` for many argument sets with caching, parallelism and a progress bar.

    ``stats`` counts runs, cached, computed, failed, ``compute_s`` (compute seconds spent now),
    ``cached_compute_s`` (the stored compute seconds of runs served by the cache) and ``cold_compute_s``
    (their sum: what the runs cost from a cold cache), ``elapsed_s`` (wall time inside :meth:`map`).
    ``warnings`` lists the one-line warnings printed (invalid cache entries...).

    Parameters
    ----------
    workers : int, optional
        Local worker processes (default: all cores); must be >= 1 and at most :func:`max_workers`.
    scheduler : str, optional
        Dask scheduler address; runs go to that cluster instead of local processes.
    cache_dir : path, optional
        Cache folder (default :func:`default_cache_dir`); checked by the one cache policy
        (:func:`~berryshaker.runs.cache.run_cache_dir`: a private folder of this user, never ``""``).
    use_cache : bool
        Read and write the cache.
    progress : bool
        Show a progress bar (rich) on ``console`` or stderr.
    console : rich.console.Console, optional
        Where the progress bar and messages go (default stderr).
    start_method : str, optional
        ``forkserver``, ``spawn`` or ``fork`` (default :data:`DEFAULT_START_METHOD`).
    """

    def __init__(self, workers: int | None = None, scheduler: str | None = None, cache_dir: Path | str | None = None,
                 use_cache: bool = True, progress: bool = True, console=None, start_method: str | None = None):
        from berryshaker.errors import ConfigError

        leave_if_bootstrapping()  # a worker importing a script that starts runs at its top level (runs.main_guard)
        if workers is None:
            self.workers = usable_cores()
        else:
            try:
                ok = not isinstance(workers, bool) and int(workers) == workers
            except (TypeError, ValueError):
                ok = False
            if not ok or workers < 1:
                raise ConfigError(f"--workers must be >= 1 (got {workers!r}); omit it to use all cores")
            most = max_workers()
            if workers > most:
                raise ConfigError(f"--workers {workers:,}: at most {most} local processes here (4 per core, or 16; "
                                  f"this process may run on {usable_cores()} cores: runs are computation, more "
                                  "processes than cores only share them); omit it to use all cores")
            self.workers = int(workers)
        self.scheduler = check_scheduler_address(scheduler) if scheduler is not None else None
        self.scheduler_timeout_s = SCHEDULER_TIMEOUT_S
        self.cache_dir = run_cache_dir(cache_dir)  # one policy for --cache, $BERRYSHAKER_CACHE and the default
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
        # the local backend, kept across maps with the runs started ahead; its messages go through a weak reference
        # (no cycle: a runner dropped ends its pool at once, by the pool's finalizer)
        self._local = LocalPool(self.workers, self.start_method, _say_through(weakref.ref(self)))

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
        """One line for a report: runs, cached, failed, compute now and cold cost.

        Returns
        -------
        str
            E.g. ``"40 runs (12 from the cache, 0 failed): 8.1 s now; cold cost 30.2 s of compute"``.
        """
        s = self.stats
        return (f"{s['runs']} runs ({s['cached']} from the cache, {s['failed']} failed): "
                f"{s['elapsed_s']:.1f} s now; cold cost {s['cold_compute_s']:.1f} s of compute")


    # ---- dask ----------------------------------------------------------------------------------------
    def connect(self):
        """A client of the Dask scheduler (:func:`berryshaker.runs.dask_backend.connect`).

        Returns
        -------
        distributed.Client
            Connected within ``scheduler_timeout_s``.

        Raises
        ------
        ConfigError
            No scheduler given or none answered.
        """
        return dask_backend.connect(self.scheduler, self.scheduler_timeout_s)

    def check_scheduler(self) -> None:
        """Connect once to the scheduler (if any) and disconnect: call before any work to fail early."""
        if self.scheduler is not None:
            self.connect().close()

    # ---- running -------------------------------------------------------------------------------------
    def map(self, fn: Callable, kwargs_list: list[dict], label: str = "runs") -> list[RunResult]:
        """Run ``fn(**kw)`` for every ``kw`` (cached, in parallel); results in input order, failures recorded.

        Ctrl-C stops within about a second: pending runs are cancelled, the workers terminated, runs that
        finished stay in the cache, a one-line message says so, and ``KeyboardInterrupt`` is raised again.

        Parameters
        ----------
        fn : callable
            A module-level run function returning a JSON-compatible value.
        kwargs_list : list of dict
            The runs' arguments (JSON-compatible).
        label : str
            Label of the progress bar.

        Returns
        -------
        list of RunResult
            One per input, in input order.
        """
        t_start = time.perf_counter()
        kwargs_list = list(kwargs_list)
        n = len(kwargs_list)
        results: list[RunResult | None] = [None] * n
        fp = code_fingerprint()
        cache = str(self.cache_dir) if self.use_cache else None
        todo: dict[str, list[int]] = {}
        jobs: dict[str, dict] = {}
        self._local.drop_broken_ahead()
        ahead = self._local.ahead_keys()
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
                self._backend(todo, ahead).run(ctx, lambda out, advance=True: self._finish(ctx, out, advance))
        except SchedulerLost as lost:
            if bar is not None:
                bar[0].stop()
                bar = None
            raise self._scheduler_lost(ctx, n, lost.reason) from None
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

    def _scheduler_lost(self, ctx: dict, n: int, reason: str):
        """The one-line error of a map whose Dask scheduler went away: the runs (rows, from 1) not finished, and
        where the finished ones are kept."""
        from berryshaker.errors import SimulationError

        rows = sorted(i + 1 for k, idx in ctx["todo"].items() if k not in ctx["done"] for i in idx)
        where = (f"the {n - len(rows)} finished are in the cache {self.cache_dir}: run the same command again to "
                 "resume" if ctx["cache"] else "nothing was cached (no cache): run the same command again")
        return SimulationError(f"the Dask scheduler {self.scheduler} was lost ({reason}); {len(rows)} of {n} runs "
                               f"did not finish (rows {_ranges(rows)}); {where}")

    def values(self, fn: Callable, kwargs_list: list[dict], label: str = "runs") -> list:
        """Like :meth:`map`, but raise on the first failed run (for steps that cannot do without every run).

        Parameters
        ----------
        fn : callable
            A module-level run function.
        kwargs_list : list of dict
            The runs' arguments.
        label : str
            Label of the progress bar and of the error.

        Returns
        -------
        list
            The runs' values, in input order.

        Raises
        ------
        SimulationError
            A run failed; the message names it and its error.
        """
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
        self._local.taken(key)
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
            bar, tid = ctx["bar"]
            if out["cached"]:  # served by the cache (another process stored it): not a run of this rate
                task = next(t for t in bar.tasks if t.id == tid)
                bar.update(tid, cached=task.fields.get("cached", 0) + len(idx))
            bar.advance(tid, len(idx))

    def _backend(self, todo: dict, ahead: set):
        """Where a map's runs go: the Dask cluster when a scheduler is given; this process with one worker, or for a
        lone run not started ahead (a pool would cost more than it saves); else the local pool."""
        if self.scheduler:
            return DaskBackend(self.connect)
        if self.workers <= 1 or (len(todo) == 1 and not ahead.intersection(todo)) or not self._pool_safe():
            return InProcess()
        return self._local

    def _pool_safe(self) -> bool:
        """Whether local worker processes can start without running the main script's calls again
        (:func:`berryshaker.runs.main_guard.unguarded_main_line`); if not, warn once: the runs go in this process."""
        where = unguarded_main_line(self.start_method)
        if where is None:
            return True
        if "script" not in self._warned:
            self._warned.add("script")
            self._warn(f"{where[0]}:{where[1]} starts runs outside `if __name__ == \"__main__\":`, and every worker "
                       f"process ('{self.start_method}' start method) would run the script again: the runs go in "
                       f"this process, one at a time ({SCRIPT_IDIOM} to run them on {self.workers} cores)")
        return False

    # ---- the local pool --------------------------------------------------------------------------------
    @property
    def _executor(self):
        """The local pool's process pool, None when none runs (for tests and diagnostics)."""
        return self._local._executor

    def close(self) -> None:
        """End the local worker processes (a later :meth:`map` starts new ones); runs started ahead
        (:meth:`prefetch`) that are not finished are dropped."""
        self._local.close()

    def abort(self, close_queue: bool = True) -> None:
        """End the local workers now: queued runs are dropped, running ones cancelled (finished runs stay in the
        cache).  For Ctrl-C or an error while runs started ahead (:meth:`prefetch`) may still be running; a later
        :meth:`map` starts new workers.

        Parameters
        ----------
        close_queue : bool
            Close the workers' progress queue too.
        """
        self._local.abort(close_queue)

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
        if self.scheduler or self.workers <= 1 or not self._pool_safe():
            return 0
        return self._local.prefetch(fn, kwargs_list, str(self.cache_dir) if self.use_cache else None,
                                    code_fingerprint(), chunks)

    def all_cached(self, fn: Callable, kwargs_list: list[dict]) -> bool:
        """Whether every run of ``fn`` with these arguments is in the cache (for this code): a :meth:`map` of them
        would start no worker.  The entries' files are looked for, not read (a damaged one is met, and run again,
        by the map).

        Parameters
        ----------
        fn : callable
            The run function.
        kwargs_list : list of dict
            The runs' arguments.

        Returns
        -------
        bool
            True when all are cached (or there are none); False without a cache.
        """
        if not self.use_cache:
            return not kwargs_list
        cache = str(self.cache_dir)  # the key holds the code fingerprint: an entry present is this code's
        return all(cache_entry_present(cache_entry_path(cache, run_key(fn, kw))) for kw in kwargs_list)

    def warm_up(self, fn: Callable, kwargs: dict | None = None) -> Future | None:
        """Call ``fn(**kwargs)`` in a pool worker now, for its side effects (e.g. compiling kernels into numba's
        on-disk cache while this process compiles others); nothing is cached or counted.

        It takes a worker like a chunk of runs started ahead (:meth:`prefetch`), so queued runs wait for another
        worker.

        Parameters
        ----------
        fn : callable
            A module-level function.
        kwargs : dict, optional
            Its arguments.

        Returns
        -------
        Future or None
            The call's future (its exception, if any, is the caller's to look at), or None with one worker or a Dask
            scheduler (nothing to run beside this process).
        """
        if self.scheduler or self.workers <= 1 or not self._pool_safe():
            return None
        return self._local.warm_up(fn, kwargs)

    def start_workers(self, prime: Callable | None = None) -> int:
        """Start every local worker process now (they are otherwise started with the first runs that need them),
        each calling ``prime()`` once it has started, e.g. to import the modules its runs will need while this
        process is still busy on its own.  Workers started later (a pool started again after a crash) call it too.

        A start-up optimisation only: a prime that fails is ignored (the runs meet the same error themselves).

        Parameters
        ----------
        prime : callable, optional
            A module-level function of no arguments.

        Returns
        -------
        int
            The workers started: 0 with one worker (its runs run in this process), a Dask scheduler or a pool running
            already.
        """
        if self.scheduler or self.workers <= 1 or self._executor is not None or not self._pool_safe():
            return 0
        return self._local.start_workers(prime)

    def __enter__(self) -> SweepRunner:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

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

                # the runs simulated now over the time since the bar started: runs served by the cache are not
                # counted (they made the rate read "577611.77 runs/s"); nothing in the first second or before the
                # first simulated run; "s/run" below one run a second
                simulated = task.completed - task.fields.get("cached", 0)
                elapsed = task.finished_time if task.finished else task.elapsed
                if not elapsed or elapsed < 1.0 or simulated <= 0:
                    return Text("")
                rate = simulated / elapsed
                return Text(f"{rate:.2f} runs/s" if rate >= 1.0 else f"{1.0 / rate:.1f} s/run")

        p = Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), RateColumn(),
                     TextColumn("ETA"), TimeRemainingColumn(), console=self.console or Console(stderr=True),
                     transient=False)
        p.start()
        tid = p.add_task(label + (f" ({done} cached)" if done else ""), total=total, completed=done, cached=done)
        return p, tid
