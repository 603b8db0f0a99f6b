"""Many independent simulations in parallel across processes (each process compiles or loads the numba
cache once).  Failed runs are returned with their error instead of stopping the others."""

from __future__ import annotations

import os
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any, Callable, Iterable


@dataclass
class RunOutcome:
    index: int
    value: Any = None
    error: str | None = None


def _call(job):
    index, fn, kwargs = job
    try:
        return RunOutcome(index, fn(**kwargs))
    except Exception as exc:  # noqa: BLE001 - recorded, not swallowed: the caller reports it
        return RunOutcome(index, error=f"{type(exc).__name__}: {exc}")


def run_many(fn: Callable[..., Any], kwargs_list: Iterable[dict], workers: int | None = None) -> list[RunOutcome]:
    """Call ``fn(**kwargs)`` for every entry, in ``workers`` processes (default: all cores).

    ``fn`` must be importable (a module-level function) and return picklable values.  Results come back
    in input order.
    """
    jobs = [(i, fn, kw) for i, kw in enumerate(kwargs_list)]
    workers = workers or os.cpu_count() or 1
    if workers <= 1 or len(jobs) <= 1:
        return [_call(j) for j in jobs]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(_call, jobs))


def mlsd_summary(machine_data: dict, clearance: dict[str, float], revolutions: int = 3) -> dict:
    """Picklable worker: MLSD summary for a machine given as a plain dict (SI)."""
    from ..config import machine_from_dict
    from .mlsd import simulate_mlsd

    return simulate_mlsd(machine_from_dict(machine_data), clearance, revolutions=revolutions).summary()


def multibody_summary(machine_data: dict, clearance: dict[str, float], revolutions: int = 2) -> dict:
    """Picklable worker: multibody harvester summary for a machine given as a plain dict (SI)."""
    from ..config import machine_from_dict
    from .harvester import simulate_harvester_multibody

    return simulate_harvester_multibody(machine_from_dict(machine_data), clearance, revolutions=revolutions)[1]
