"""One sweep runner for every multi-run step: local processes by default, a Dask distributed cluster when
a scheduler address is given; every finished run is cached on disk under the hash of its resolved
inputs (function, arguments, package version), so an interrupted study resumes where it stopped and a
repeated one is instant.  Failed runs are recorded with their error (and not cached, so they are retried).

Cache entries are JSON files written atomically (no pickle); run functions must return JSON-compatible
values (dicts, lists, numbers, strings).
"""

from __future__ import annotations

import hashlib
import json
import os
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from berryshaker import __version__
from berryshaker.report.files import write_text_atomic


def default_cache_dir() -> Path:
    base = os.environ.get("BERRYSHAKER_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME", os.path.expanduser("~/.cache")), "berryshaker")
    return Path(base) / "runs"


def _jsonable(obj):
    import numpy as np

    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer, np.bool_)):
        return obj.item()
    return obj


def run_key(fn: Callable, kwargs: dict) -> str:
    """sha256 of the function's dotted name, its resolved arguments and the package version."""
    payload = json.dumps({"fn": f"{fn.__module__}.{fn.__qualname__}", "kwargs": _jsonable(kwargs),
                          "version": __version__}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(payload.encode()).hexdigest()


@dataclass
class RunResult:
    index: int
    key: str
    value: Any = None
    error: str | None = None
    cached: bool = False


def execute_job(fn: Callable, kwargs: dict) -> dict:
    """Run one job and wrap the outcome; module-level so processes and Dask workers can import it."""
    try:
        return {"value": _jsonable(fn(**kwargs)), "error": None}
    except Exception as exc:  # noqa: BLE001 - recorded per run, reported by the caller
        return {"value": None, "error": f"{type(exc).__name__}: {exc}"}


class SweepRunner:
    """Runs ``fn(**kwargs)`` for many argument sets with caching, parallelism and a progress bar."""

    def __init__(self, workers: int | None = None, scheduler: str | None = None, cache_dir: Path | str | None = None,
                 use_cache: bool = True, progress: bool = True, console=None):
        self.workers = workers or os.cpu_count() or 1
        self.scheduler = scheduler
        self.cache_dir = Path(cache_dir) if cache_dir else default_cache_dir()
        self.use_cache = use_cache
        self.progress = progress
        self.console = console
        self.stats = {"runs": 0, "cached": 0, "failed": 0}

    # ---- cache ---------------------------------------------------------------------------------
    def _path(self, key: str) -> Path:
        return self.cache_dir / key[:2] / f"{key}.json"

    def _load(self, key: str):
        p = self._path(key)
        if self.use_cache and p.is_file():
            try:
                return json.loads(p.read_text())
            except (OSError, json.JSONDecodeError):
                return None
        return None

    def _store(self, key: str, fn: Callable, kwargs: dict, value) -> None:
        if self.use_cache:
            write_text_atomic(self._path(key), json.dumps(
                {"fn": f"{fn.__module__}.{fn.__qualname__}", "version": __version__, "value": value}))

    # ---- running -------------------------------------------------------------------------------
    def map(self, fn: Callable, kwargs_list: list[dict], label: str = "runs") -> list[RunResult]:
        kwargs_list = list(kwargs_list)
        results: list[RunResult | None] = [None] * len(kwargs_list)
        todo = []
        for i, kw in enumerate(kwargs_list):
            key = run_key(fn, kw)
            hit = self._load(key)
            if hit is not None:
                results[i] = RunResult(i, key, hit["value"], None, True)
            else:
                todo.append((i, key, kw))
        self.stats["runs"] += len(kwargs_list)
        self.stats["cached"] += len(kwargs_list) - len(todo)
        bar = self._bar(label, len(kwargs_list), len(kwargs_list) - len(todo))
        try:
            if todo:
                if self.scheduler:
                    self._run_dask(fn, todo, results, bar)
                elif self.workers <= 1 or len(todo) == 1:
                    for i, key, kw in todo:
                        self._finish(results, i, key, fn, kw, execute_job(fn, kw), bar)
                else:
                    self._run_local(fn, todo, results, bar)
        finally:
            if bar is not None:
                bar[0].stop()
        self.stats["failed"] += sum(1 for r in results if r.error)
        return results  # type: ignore[return-value]

    def values(self, fn: Callable, kwargs_list: list[dict], label: str = "runs") -> list:
        """Like map, but raise on the first failed run (for steps that cannot do without every run)."""
        from berryshaker.errors import SimulationError

        out = self.map(fn, kwargs_list, label)
        bad = [r for r in out if r.error]
        if bad:
            raise SimulationError(f"{label}: run {bad[0].index + 1} of {len(out)} failed: {bad[0].error}")
        return [r.value for r in out]

    def _finish(self, results, i, key, fn, kw, outcome, bar):
        results[i] = RunResult(i, key, outcome["value"], outcome["error"], False)
        if outcome["error"] is None:
            self._store(key, fn, kw, outcome["value"])
        if bar is not None:
            bar[0].advance(bar[1])

    def _run_local(self, fn, todo, results, bar):
        with ProcessPoolExecutor(max_workers=min(self.workers, len(todo))) as pool:
            pending = {pool.submit(execute_job, fn, kw): (i, key, kw) for i, key, kw in todo}
            while pending:
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    i, key, kw = pending.pop(fut)
                    try:
                        outcome = fut.result()
                    except Exception as exc:  # noqa: BLE001 - a crashed worker process
                        outcome = {"value": None, "error": f"{type(exc).__name__}: {exc}"}
                    self._finish(results, i, key, fn, kw, outcome, bar)

    def _run_dask(self, fn, todo, results, bar):
        from distributed import Client, as_completed

        with Client(self.scheduler, timeout="20s") as client:
            futs = {}
            for i, key, kw in todo:
                f = client.submit(execute_job, fn, kw, key=f"berryshaker-{key}", pure=False, retries=3)
                futs[f] = (i, key, kw)
            for f in as_completed(list(futs)):
                i, key, kw = futs[f]
                try:
                    outcome = f.result()
                except Exception as exc:  # noqa: BLE001 - lost beyond its retries
                    outcome = {"value": None, "error": f"{type(exc).__name__}: {exc}"}
                self._finish(results, i, key, fn, kw, outcome, bar)

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


# ---- parameter sweeps over the machine description ------------------------------------------------
