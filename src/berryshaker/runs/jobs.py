"""The job protocol of the sweep runner: how one run, or a chunk of runs, is executed in this process, in a local
pool worker or on a Dask worker, and what comes back.

A run function is module-level (so it pickles) and returns a JSON-compatible value (dicts, lists, numbers,
strings); :func:`run_jobs` executes a chunk of ``(key, kwargs)`` jobs against the cache (:mod:`berryshaker.runs.cache`)
and returns one outcome per job: a dict with ``key``, ``value``, ``error``, ``wall_s``, ``cached``, ``stored`` and
``problem`` (why an existing cache entry was unusable).

Every backend of :class:`berryshaker.runs.runner.SweepRunner` has one method, ``run(ctx, finish)``: it runs the jobs
of one map and calls ``finish(outcome)`` (``finish(outcome, advance)`` for the local pool, which moves the progress
bar itself) once per outcome.  ``ctx`` is the map's state, a dict: ``fn``, ``jobs`` (key -> kwargs of the runs to
compute), ``todo`` (key -> input positions), ``done`` (keys recorded), ``ok_elsewhere`` (keys a worker reported
finished), ``bar`` (``(rich progress, task)`` or None), ``cache`` (folder or None), ``fp`` (code fingerprint).
Backends: :class:`InProcess` (here), :class:`berryshaker.runs.local_pool.LocalPool`,
:class:`berryshaker.runs.dask_backend.DaskBackend`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable

from berryshaker.runs.cache import (
    cache_entry_path,
    function_name,
    read_cache_entry,
    run_value,
    value_text,
    write_cache_entry,
)

#: Local jobs are sent to the pool in about this many chunks per worker (fewer round trips for short runs,
#: still balanced across workers when run times differ).
CHUNKS_PER_WORKER = 4


@dataclass
class RunResult:
    """One run of a sweep: its position, cache key, value or error, whether it came from the cache, and the
    seconds of compute it took (for a cached run: when it was computed).

    Attributes
    ----------
    index : int
        Its position in the map's input.
    key : str
        Its cache key (:func:`berryshaker.runs.cache.run_key`).
    value : object
        What the run function returned (JSON-compatible); None for a failed run.
    error : str or None
        ``"ExceptionType: message"`` of a failed run, else None.
    cached : bool
        Served by the cache.
    wall_s : float
        Seconds of compute it took (s).
    """

    index: int
    key: str
    value: Any = None
    error: str | None = None
    cached: bool = False
    wall_s: float = 0.0


def execute_job(fn: Callable, kwargs: dict) -> dict:
    """Run one job and wrap the outcome; module-level so processes and Dask workers can import it.  A value
    that is not JSON-compatible (:func:`berryshaker.runs.cache.run_value`) is an error of the run.

    Parameters
    ----------
    fn : callable
        The run function.
    kwargs : dict
        Its arguments.

    Returns
    -------
    dict
        ``{"value", "error", "wall_s"}``: the JSON-compatible value (None on error), ``"ExceptionType: message"`` or
        None, and the seconds it took (s).
    """
    t0 = time.perf_counter()
    try:
        raw = fn(**kwargs)
        wall = time.perf_counter() - t0
        value = run_value(raw)
        value_text(value)  # not JSON-compatible: an error of the run
        return {"value": value, "error": None, "wall_s": wall}
    except Exception as exc:  # noqa: BLE001 - recorded per run, reported by the caller
        return {"value": None, "error": f"{type(exc).__name__}: {exc}", "wall_s": time.perf_counter() - t0}


def failed_outcome(key: str, error: str) -> dict:
    """The outcome of a run that did not finish (its worker or task was lost): ``error`` and no value.

    Parameters
    ----------
    key : str
        The run's key.
    error : str
        Why it did not finish.

    Returns
    -------
    dict
        An outcome as :func:`run_jobs` gives them.
    """
    return {"key": key, "value": None, "error": error, "wall_s": 0.0, "cached": False, "stored": False}


_PROGRESS = None  # a multiprocessing queue in pool workers: the key of every finished run


def chunk_size(n: int, workers: int) -> int:
    """Runs per chunk of a local sweep: about :data:`CHUNKS_PER_WORKER` chunks per worker.

    Parameters
    ----------
    n : int
        Runs to send.
    workers : int
        Workers sharing them.

    Returns
    -------
    int
        At least 1.
    """
    return max(1, math.ceil(n / (CHUNKS_PER_WORKER * max(1, workers))))


def run_jobs(fn: Callable, jobs: list[tuple[str, dict]], cache_dir: str | None, fingerprint: str,
             store: bool) -> list[dict]:
    """Run a chunk of jobs; module-level so pool and Dask workers can import it.

    Right before each job the cache is read again (another sweep sharing the cache may have finished it); a computed
    run is stored at once when ``store`` (local workers share the parent's disk).

    Parameters
    ----------
    fn : callable
        The run function.
    jobs : list of (str, dict)
        ``(key, kwargs)`` of each run.
    cache_dir : str or None
        The cache folder; None: no cache.
    fingerprint : str
        The code fingerprint of the keys.
    store : bool
        Write each computed run's cache entry here.

    Returns
    -------
    list of dict
        One outcome per job: key, value, error, wall_s (s), cached, stored, problem (why an existing entry was
        unusable), and store_error when the entry could not be written.
    """
    outs = []
    for key, kw in jobs:
        out = None
        problem = None
        if cache_dir:
            entry, problem = read_cache_entry(cache_entry_path(cache_dir, key), key, fingerprint)
            if entry is not None:
                out = {"key": key, "value": entry["value"], "error": None, "wall_s": entry["wall_s"],
                       "cached": True, "stored": True, "problem": None}
        if out is None:
            res = execute_job(fn, kw)
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


class InProcess:
    """The backend of one worker: runs in this process, one by one."""

    def run(self, ctx: dict, finish: Callable) -> None:
        """Run every job of the map here.

        Parameters
        ----------
        ctx : dict
            The map's state (see the module docstring).
        finish : callable
            Called with each outcome.
        """
        for k, kw in ctx["jobs"].items():
            for out in run_jobs(ctx["fn"], [(k, kw)], ctx["cache"], ctx["fp"], True):
                finish(out)
