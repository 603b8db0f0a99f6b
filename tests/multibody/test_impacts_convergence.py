"""The sizing loads converge where a run's single maximum does not have to (the suite's share of
benchmarks/studies/impact_loads_study.py, whose stored result benchmarks/studies/results/impact_loads.json has 12
starts): the static-equivalent load (p95 of the impact peaks, multibody.impacts.STATIC_FRACTILE) and the
fatigue-equivalent load of every pair of the reference harvester's coupled drive-past, as the virtual L9 runs it,
at the default solver tolerance and bush modes against a tighter rtol and twice the modes.

Replicate means +- SE over perturbed starts (as ``plant --convergence``): a refinement is converged when its
difference from the default is inside 2 SE of the difference, or, resolved, inside 5 % with that band (a sizing load
is read to a standard size step far wider than 5 %).  4 starts of one branch class at each setting: 12 drive-pasts,
about 11 CPU-s (the study's 12 starts take about 40 s).
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

STARTS = 4
TOLERANCE = 0.05


@functools.cache
def _loads(rtol, modes):
    from berryshaker.config import load_machine, machine_from_dict
    from berryshaker.harvest.virtual import stem_force_envelope_run
    from berryshaker.multibody.impacts import impact_loads
    from berryshaker.multibody.perturbation import RandomInitialPerturbation

    d = load_machine(None).model_dump()
    d["plant"]["contact"]["n_modes"] = modes
    m = machine_from_dict(d)
    h = m.harvest
    rows = []
    for k in range(STARTS):
        pert = RandomInitialPerturbation((h.seed + 1000 * k, 0), h.initial_eccentricity, h.start_phase_spread)
        _, res = stem_force_envelope_run(m, m.clearance_sizes(), 1.0, pert, rtol)
        rows.append({p: impact_loads([res.contact_episodes(p)]) for p in m.pair_names})
    return rows


def _mean_se(v):
    v = np.asarray(v, float)
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(v.size))


@pytest.mark.parametrize("refined", [(1e-6, 8), (1e-5, 16)], ids=["tighter_rtol", "more_modes"])
def test_sizing_loads_are_converged_in_rtol_and_modes(refined):
    from berryshaker.config import load_machine
    from berryshaker.harvest.spec import COUPLED_RTOL

    m = load_machine(None)
    assert COUPLED_RTOL == 1e-5 and m.plant.contact.n_modes == 8  # the defaults this test chooses
    base, fine = _loads(COUPLED_RTOL, 8), _loads(*refined)  # the default runs once for both refinements
    for p in m.pair_names:
        assert min(r[p].impacts for r in base) > 100  # hundreds of impacts per drive-past: a p95 of many
        for stat in ("static_equivalent_N", "fatigue_equivalent_N"):
            (m0, s0), (m1, s1) = (_mean_se([getattr(r[p], stat) for r in rows]) for rows in (base, fine))
            d, se = m1 - m0, math.hypot(s0, s1)
            assert abs(d) < 2 * se or abs(d) + 2 * se < TOLERANCE * m0, (p, stat, m0, m1, se)
            assert s0 < 0.05 * m0  # known to a few per cent from 4 starts
