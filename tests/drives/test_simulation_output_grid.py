"""Convergence of a harvester run's statistics in the output grid: it chooses the default ``output_step`` of
``berryshaker.drives.simulation.simulate_multibody`` (0.1 ms).

The means, RMS values and 95th percentiles of a run's summary (collision force per pair, load moments, drive
moment) are taken over the written samples, so the spacing of the samples discretises them; the peaks of the
collision forces are found on every integrator step (interior peaks included) and the impacts per pair are
counted by the integrator (``contact_onsets``), so neither depends on the grid.  The steps the integrator takes
do not depend on the grid either (output samples restore the cam's Newton memories; docs/multibody.md), so a
run written at two spacings is one trajectory sampled twice, and the difference of a statistic between the two
is pure sampling error: it is compared per start (paired), over :data:`STARTS` seeded perturbed starts.

Criterion, per statistic: |mean over the starts of the relative difference| <= the tolerance of its kind (the
same tolerances as the solver-tolerance test, tests/multibody/test_perturbation.py, so that the grid adds no
more than the solver is allowed) and the standard error of that mean <= half the tolerance.  The criterion can
fail: a 1 ms grid misses it (:func:`test_a_coarse_grid_fails`).

Measured (groove cam, 6 starts, 2 revolutions, rtol 1e-5) against a 0.025 ms grid, largest mean differences:

=========  ===========================================  ==========================================
grid       largest mean difference (+- SE)              worst single start
=========  ===========================================  ==========================================
0.4 ms     C RMS -6.1 +- 2.8 %, drive peak -2.3 +- 0.7 %  F RMS 25 %, C RMS 14 %
0.2 ms     F RMS -2.3 +- 3.7 %, C RMS +1.3 +- 2.1 %     F RMS 17 %
**0.1 ms** C RMS +0.7 +- 1.2 %, drive peak -0.4 +- 0.1 %  C RMS 4.9 %, others <= 1.5 %
0.05 ms    C RMS -0.5 +- 0.1 %                          0.8 %
=========  ===========================================  ==========================================

The counts of impacts on the written series (the summary's count before it was taken from the integrator)
were 11 % short at 0.1 ms and 37 % short at 0.2 ms.  A run at 0.05 ms costs 11 % more CPU than at 0.1 ms
(10 000 more samples, each a right-hand side), which the differences above do not pay for.
"""

from __future__ import annotations

import inspect

import numpy as np
import pytest
from multibody.test_perturbation import TOL_DRIVE_MEAN, TOLERANCE, summary_statistics

from berryshaker.config import reference_machine
from berryshaker.drives.simulation import simulate_multibody
from berryshaker.multibody.perturbation import RandomInitialPerturbation

REVOLUTIONS = 3
STARTS = 4
DRIVES = ("groove_cam", "crank_rocker")


def _run(drive: str, output_step: float, seed: int) -> tuple[dict[str, float], dict[str, int], int]:
    machine = reference_machine(drive)
    _r, summary = simulate_multibody(machine, dict(machine.clearance_sizes()), revolutions=REVOLUTIONS,
                                     output_step=output_step, initial_perturbation=RandomInitialPerturbation(seed))
    return summary_statistics(summary), summary["contact_onsets"], summary["steps"]


def compare_grids(drive: str, coarse: float, fine: float, starts: int = STARTS) -> dict:
    """Per statistic: mean over the starts of the relative difference coarse - fine (paired: one trajectory), its
    standard error, tolerance and verdict; also whether the steps and the impact counts were equal."""
    runs = [(_run(drive, coarse, s), _run(drive, fine, s)) for s in range(starts)]
    out: dict = {"same_steps": all(a[2] == b[2] for a, b in runs),
                 "same_impacts": all(a[1] == b[1] for a, b in runs), "statistics": {}}
    for key in runs[0][1][0]:
        ref = np.array([b[0][key] for a, b in runs])
        d = (np.array([a[0][key] for a, b in runs]) - ref) / max(abs(float(ref.mean())), 1e-300)
        tol = TOL_DRIVE_MEAN if key == "drive_moment_Nm.mean" else TOLERANCE[key.rsplit(".", 1)[1]]
        m, se = float(d.mean()), float(d.std(ddof=1) / np.sqrt(d.size))
        out["statistics"][key] = {"difference": m, "se": se, "tolerance": tol, "ok": abs(m) <= tol and se <= tol / 2}
    return out


@pytest.fixture(scope="module")
def default_step() -> float:
    return inspect.signature(simulate_multibody).parameters["output_step"].default


def test_default_output_step_is_the_checked_one(default_step):
    assert default_step == 1e-4


@pytest.mark.parametrize("drive", DRIVES)
def test_statistics_converged_in_the_output_grid(drive, default_step):
    res = compare_grids(drive, default_step, default_step / 2)
    # one trajectory, sampled twice: the steps, and the impacts the integrator counts, are the same
    assert res["same_steps"] and res["same_impacts"], res
    bad = {k: v for k, v in res["statistics"].items() if not v["ok"]}
    assert not bad, bad


def test_a_coarse_grid_fails(default_step):
    """A 1 ms grid (10 samples per impact-free stretch of a few ms, far fewer than the contact episodes of the
    rollers) against the default: the RMS and p95 of the chattering pins and the sampled drive-moment peak
    move beyond their tolerances, so the criterion is not one that passes on anything."""
    res = compare_grids("groove_cam", 1e-3, default_step)
    failed = [k for k, v in res["statistics"].items() if not v["ok"]]
    assert len(failed) >= 2, res["statistics"]
