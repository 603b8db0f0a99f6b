"""Tolerance design: cost model, life integral against closed forms, NSGA-II front against exhaustive
enumeration, determinism, and a tiny real run."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from berryshaker.config import load_machine
from berryshaker.life.clearance_response import ClearanceResponse
from berryshaker.life.fits import parse_fit
from berryshaker.life.tolerance import (
    compromise_index,
    evaluate_designs,
    fit_cost,
    joint_candidates,
    non_dominated,
    nsga2_front,
    tolerance_cost,
    tolerance_design,
)


def test_cost_model():
    assert tolerance_cost(20.0) == pytest.approx(2.0)
    assert tolerance_cost(10.0) > tolerance_cost(20.0) > tolerance_cost(130.0) > 1.0
    assert fit_cost(parse_fit("H7/f7", 20)) == pytest.approx(2 * (1 + 20 / 21))


def test_hours_to_limit_closed_forms():
    const = ClearanceResponse("C", np.array([0.0, 1e-3]), np.array([1.0, 1.0]), np.array([5e-8, 5e-8]))
    assert const.hours_to(1e-4, 3e-4) == pytest.approx(2e-4 / 5e-8, rel=1e-9)
    # r = a + b c  ->  h = ln((a + b c1) / (a + b c0)) / b
    a, b = 2e-8, 1e-4
    c = np.linspace(0, 1e-3, 200)
    lin = ClearanceResponse("C", c, np.ones_like(c), a + b * c)
    assert lin.hours_to(1e-4, 8e-4) == pytest.approx(math.log((a + b * 8e-4) / (a + b * 1e-4)) / b, rel=1e-4)
    h = np.array([0.0, 1000.0, 5000.0])
    assert lin.grow(1e-4, h) == pytest.approx((1e-4 + a / b) * np.exp(b * h) - a / b, rel=1e-6)
    assert lin.hours_to(5e-4, 4e-4) == 0.0


def _synthetic(joints):
    m = load_machine(None)
    cands = joint_candidates(m, joints)
    lim = {j: max(m.clearance_levels()[j]) for j in joints}  # synthetic: the front's size is fixed by these
    resp = {j: ClearanceResponse(j, np.array([2.5e-5, 1e-4, lim[j]]), np.array([2000.0, 2400.0 + 100 * k, 3500.0]),
                                 np.array([4e-8, 6e-8, 9e-8 + 1e-8 * k]))
            for k, j in enumerate(joints)}
    return cands, resp, lim


def test_front_is_non_dominated_and_matches_enumeration():
    joints = ["C", "F"]
    cands, resp, lim = _synthetic(joints)
    x, f = nsga2_front(joints, cands, resp, lim, pop_size=30, generations=40, seed=3)
    assert non_dominated(f).all()
    allx = np.array(list(itertools.product(range(6), repeat=2)))
    fa = evaluate_designs(allx, joints, cands, resp, lim)
    true = {tuple(np.round(r, 6)) for r in fa[non_dominated(fa)]}
    assert {tuple(np.round(r, 6)) for r in f} == true  # 36 designs: NSGA-II finds the whole front
    k = compromise_index(f)
    assert 0 <= k < len(f)


def test_deterministic_with_seed():
    joints = ["A", "B", "C", "F"]
    cands, resp, lim = _synthetic(joints)
    x1, f1 = nsga2_front(joints, cands, resp, lim, pop_size=30, generations=20, seed=7)
    x2, f2 = nsga2_front(joints, cands, resp, lim, pop_size=30, generations=20, seed=7)
    assert np.array_equal(x1, x2) and np.array_equal(f1, f2)
    assert non_dominated(f1).all()


def test_tiny_real_design(tmp_path):
    from berryshaker.runs.runner import SweepRunner

    m = load_machine(None)
    with SweepRunner(workers=1, cache_dir=tmp_path, progress=False) as runner:
        d = tolerance_design(m, runner, joints=["C"], fits=["H7/f7", "H11/c11"], n_points=2, pop_size=8,
                             generations=5, seed=1, starts=2)
    res = d.to_dict()
    assert res["simulations"] == 4  # 2 clearances x 2 perturbed starts: the force is a mean, never one run's peak
    sur = res["surrogate"]["C"]
    assert sur["starts"] == 2 and len(sur["design_force_se_N"]) == 2 and all(v >= 0 for v in sur["design_force_se_N"])
    f = np.array([[p["cost"], p["design_force_N"], -p["life_h"]] for p in res["front"]])
    assert non_dominated(f).all()
    rec = res["recommended"]
    assert rec["fits"] in [p["fits"] for p in res["front"]]
    j = rec["joints"]["C"]
    assert j["maintenance_interval_h"] > 0 and j["size_convention"] == "radial"
    fit = parse_fit(j["fit"], 20)
    assert j["size_mm"] == pytest.approx(fit.clearance_mean / 2 * 1e3)
