"""Many independent simulations in parallel across processes (each process compiles or loads the numba
cache once).  Failed runs are returned with their error instead of stopping the others."""

from __future__ import annotations

from typing import Any, Callable, Iterable


def run_many(fn: Callable[..., Any], kwargs_list: Iterable[dict], workers: int | None = None):
    """Call ``fn(**kwargs)`` for every entry in ``workers`` processes (default: all cores), uncached.

    A thin front of :class:`berryshaker.runs.runner.SweepRunner` (the one runner every multi-run step uses);
    returns its :class:`~berryshaker.runs.runner.RunResult` list in input order (``.value`` or ``.error``).
    ``fn`` must be a module-level function returning JSON-compatible values.
    """
    from berryshaker.runs.runner import SweepRunner

    return SweepRunner(workers=workers, use_cache=False, progress=False).map(fn, list(kwargs_list))


def mlsd_summary(machine_data: dict, clearance: dict[str, float], revolutions: int = 3) -> dict:
    """Picklable worker: MLSD summary for a machine given as a plain dict (SI)."""
    from berryshaker.config import machine_from_dict
    from berryshaker.drives.groove_cam.mlsd import simulate_mlsd

    return simulate_mlsd(machine_from_dict(machine_data), clearance, revolutions=revolutions).summary()


def multibody_summary(machine_data: dict, clearance: dict[str, float], revolutions: int = 2) -> dict:
    """Picklable worker: multibody harvester summary for a machine given as a plain dict (SI)."""
    from berryshaker.config import machine_from_dict
    from berryshaker.drives.groove_cam.mechanism import simulate_harvester_multibody

    return simulate_harvester_multibody(machine_from_dict(machine_data), clearance, revolutions=revolutions)[1]
