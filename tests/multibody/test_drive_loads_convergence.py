"""The design drive torque converges where a run's single maximum does not have to (the suite's share of
benchmarks/studies/drive_torque_study.py, whose stored result benchmarks/studies/results/drive_torque.json has 24
starts): the design torque (p95 of the per-revolution peaks, multibody.drive_loads.design_torque), the RMS torque and
the fatigue-equivalent torque of the reference harvester's starts as the virtual L9 runs them (three branch
classes' drive-pasts pooled), at the default solver tolerance and bush modes against a tighter rtol and twice the
modes.

Start means +- SE: a refinement is converged when its difference from the default is inside 2 SE of the difference,
or, resolved, inside 5 % with that band (the criterion of test_impacts_convergence.py).  4 starts at each setting:
36 drive-pasts, about 25 CPU-s.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

STARTS = 4
TOLERANCE = 0.05


@functools.cache
def _rows(rtol, modes):
    from berryshaker.config import load_machine, machine_from_dict
    from berryshaker.harvest.virtual import stem_force_envelope_run
    from berryshaker.multibody.drive_loads import design_torque, fatigue_equivalent_torque, revolution_peaks
    from berryshaker.multibody.perturbation import RandomInitialPerturbation

    d = load_machine(None).model_dump()
    d["plant"]["contact"]["n_modes"] = modes
    m = machine_from_dict(d)
    h, rows = m.harvest, []
    for k in range(STARTS):  # one start of the L9: its branch classes' drive-pasts pooled
        peaks, moments = [], []
        for scale in h.branch_classes:
            pert = RandomInitialPerturbation((h.seed + 1000 * k, 0), h.initial_eccentricity, h.start_phase_spread)
            _, res = stem_force_envelope_run(m, m.clearance_sizes(), scale, pert, rtol)
            sel = res.t >= res.stats_from - 1e-12
            moments.append(res.reaction("drive")[sel])
            peaks.append(revolution_peaks(res.t[sel], moments[-1], res.stats_from, 2 * math.pi / m.drive_speed))
        p, mm = np.concatenate(peaks), np.concatenate(moments)
        rows.append({"design": design_torque(p), "rms": float(np.sqrt(np.mean(mm**2))),
                     "fatigue_equivalent": fatigue_equivalent_torque(mm), "revolutions": int(p.size)})
    return rows


def _mean_se(v):
    v = np.asarray(v, float)
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(v.size))


def test_revolution_peaks_and_equivalent_torque():
    from berryshaker.multibody.drive_loads import design_torque, fatigue_equivalent_torque, revolution_peaks

    t = np.arange(0.0, 2.2, 1e-3)
    m = np.where(np.isclose(t % 0.5, 0.25, atol=1e-4), -(10.0 + t), 1.0)  # one pulse per revolution
    p = revolution_peaks(t, m, 0.5, 0.5)
    assert p == pytest.approx([10.75, 11.25, 11.75])  # whole revolutions only: 2.0..2.2 is left out
    assert design_torque(p) == pytest.approx(np.quantile(p, 0.95))
    assert fatigue_equivalent_torque(np.full(10, -3.0)) == pytest.approx(3.0)
    assert math.isnan(design_torque(np.zeros(0)))


@pytest.mark.parametrize("refined", [(1e-6, 8), (1e-5, 16)], ids=["tighter_rtol", "more_modes"])
def test_design_torque_is_converged_in_rtol_and_modes(refined):
    from berryshaker.config import load_machine
    from berryshaker.harvest.spec import COUPLED_RTOL

    m = load_machine(None)
    assert COUPLED_RTOL == 1e-5 and m.plant.contact.n_modes == 8  # the defaults this test chooses
    base, fine = _rows(COUPLED_RTOL, 8), _rows(*refined)
    assert min(r["revolutions"] for r in base) >= 9  # a start's 9 whole revolutions, as in the L9
    for stat in ("design", "rms", "fatigue_equivalent"):
        (m0, s0), (m1, s1) = (_mean_se([r[stat] for r in rows]) for rows in (base, fine))
        d, se = m1 - m0, math.hypot(s0, s1)
        assert abs(d) < 2 * se or abs(d) + 2 * se < TOLERANCE * m0, (stat, m0, m1, se)
        assert s0 < 0.05 * m0  # known to a few per cent from 4 starts
