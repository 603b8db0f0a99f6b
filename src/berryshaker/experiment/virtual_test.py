"""The study's L9 field test run through the virtual harvest and analysed exactly like field data."""

from __future__ import annotations

from berryshaker.config import PAIR_NAMES, Machine
from berryshaker.experiment.clearance_rows import CLEARANCE_LEVELS_MM
from berryshaker.experiment.designs import orthogonal_array

STUDY_RECOMMENDED = {"A": 1, "B": 1, "C": 1, "F": 3}  # A1B1C1F3 [study]
SENSES = {"efficiency": True, "unripe": False, "damage": False}
DEFAULT_WEIGHTS = {"efficiency": 0.5, "damage": 0.3, "unripe": 0.2}  # the study's priority Y1 > Y3 > Y2


def l9_runs() -> list[dict[str, float]]:
    """Clearance sets (m) of the nine L9 runs with the study's levels (factor order A, B, C, F)."""
    a = orthogonal_array("L9")
    return [{p: CLEARANCE_LEVELS_MM[p][a[i, j]] * 1e-3 for j, p in enumerate(PAIR_NAMES)} for i in range(9)]


def virtual_orthogonal_test(machine: Machine, runner=None) -> dict:
    """Run the study's L9 through the virtual harvest and analyse it like field data.

    ``runner`` is a :class:`berryshaker.runs.runner.SweepRunner` (default: local processes, cached).
    """
    from berryshaker.study.pipeline import virtual_l9
    from berryshaker.runs.runner import SweepRunner

    return virtual_l9(machine, runner or SweepRunner(progress=False))
