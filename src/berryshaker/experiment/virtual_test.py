"""The study's L9 field test run through the virtual harvest and analysed exactly like field data."""

from __future__ import annotations

import numpy as np

from ..config import PAIR_NAMES, Machine
from .analysis import analyze
from .clearance_rows import CLEARANCE_LEVELS_MM
from .designs import orthogonal_array

STUDY_RECOMMENDED = {"A": 1, "B": 1, "C": 1, "F": 3}  # A1B1C1F3 [study]
SENSES = {"efficiency": True, "unripe": False, "damage": False}
DEFAULT_WEIGHTS = {"efficiency": 0.5, "damage": 0.3, "unripe": 0.2}  # the study's priority Y1 > Y3 > Y2


def l9_runs() -> list[dict[str, float]]:
    """Clearance sets (m) of the nine L9 runs with the study's levels (factor order A, B, C, F)."""
    a = orthogonal_array("L9")
    return [{p: CLEARANCE_LEVELS_MM[p][a[i, j]] * 1e-3 for j, p in enumerate(PAIR_NAMES)} for i in range(9)]


def _run_one(machine_data: dict, clearance: dict) -> dict:
    from ..config import machine_from_dict
    from ..harvest.virtual import virtual_harvest

    return virtual_harvest(machine_from_dict(machine_data), clearance)


def virtual_orthogonal_test(machine: Machine, workers: int | None = None, runner=None,
                            weights: dict | None = None) -> dict:
    """Run the L9 through the virtual harvest and analyse it (range analysis, ANOVA, regression, optimum).

    ``runner(fn, kwargs_list)`` may replace the default process-parallel runner (the study's cached,
    resumable sweep runner passes itself here).
    """
    from ..dynamics.parallel import run_many

    runs = l9_runs()
    jobs = [dict(machine_data=machine.model_dump(), clearance=c) for c in runs]
    if runner is None:
        outcomes = run_many(_run_one, jobs, workers)
        failures = [o for o in outcomes if o.error]
        if failures:
            from ..errors import SimulationError

            raise SimulationError(f"virtual L9 run {failures[0].index + 1} failed: {failures[0].error}")
        results = [o.value for o in outcomes]
    else:
        results = runner(_run_one, jobs)
    a = orthogonal_array("L9") + 1
    values = np.array([[r[p] * 1e3 for p in PAIR_NAMES] for r in runs])
    responses = {
        "efficiency": np.array([r["efficiency_kg_min"] for r in results]),
        "unripe": np.array([r["unripe_rate_pct"] for r in results]),
        "damage": np.array([r["damage_rate_pct"] for r in results]),
    }
    analysis = analyze(a, values, list(PAIR_NAMES), responses, SENSES, weights or DEFAULT_WEIGHTS)
    opt = analysis["optimum"]["levels"]
    analysis["runs"] = [{"run": i + 1, "levels": {p: int(a[i, j]) for j, p in enumerate(PAIR_NAMES)},
                         "clearance_mm": {p: float(values[i, j]) for j, p in enumerate(PAIR_NAMES)},
                         **{k: float(v[i]) for k, v in responses.items()}} for i in range(9)]
    analysis["recommended"] = {
        "levels": opt,
        "code": "".join(f"{p}{opt[p]}" for p in PAIR_NAMES),
        "clearance_mm": {p: CLEARANCE_LEVELS_MM[p][opt[p] - 1] for p in PAIR_NAMES},
        "study": {"code": "A1B1C1F3", "clearance_mm": {p: CLEARANCE_LEVELS_MM[p][STUDY_RECOMMENDED[p] - 1]
                                                          for p in PAIR_NAMES}},
        "same_as_study": opt == STUDY_RECOMMENDED,
    }
    return analysis
