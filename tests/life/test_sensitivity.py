"""Sobol sensitivity: the SALib plumbing against the Ishigami function's closed-form indices, and a tiny real
run through the cached runner."""

from __future__ import annotations

import math

import numpy as np
import pytest

from berryshaker.errors import ConfigError
from berryshaker.life.sensitivity import (
    SobolParameter,
    machine_sobol,
    parse_sensitivity_param,
    sobol_indices,
    sobol_sample,
)

A, B = 7.0, 0.1


def ishigami(x):
    """Ishigami & Homma (1990): sin x1 + a sin^2 x2 + b x3^4 sin x1, x_i ~ U(-pi, pi)."""
    return np.sin(x[:, 0]) + A * np.sin(x[:, 1]) ** 2 + B * x[:, 2] ** 4 * np.sin(x[:, 0])


def ishigami_exact():
    """Closed-form variances (Sobol' & Levitan 1999; Saltelli et al. 2008, Global Sensitivity Analysis, ch. 4)."""
    v = A**2 / 8 + B * math.pi**4 / 5 + B**2 * math.pi**8 / 18 + 0.5
    v1 = 0.5 * (1 + B * math.pi**4 / 5) ** 2
    v2 = A**2 / 8
    v13 = 8 * B**2 * math.pi**8 / 225
    return {"x1": (v1 / v, (v1 + v13) / v), "x2": (v2 / v, v2 / v), "x3": (0.0, v13 / v)}


@pytest.mark.parametrize("seed", [0, 1])
def test_ishigami_indices_within_confidence_interval(seed):
    problem = {"num_vars": 3, "names": ["x1", "x2", "x3"], "bounds": [[-math.pi, math.pi]] * 3}
    est = sobol_indices(ishigami, problem, 1024, seed)
    for name, (s1, st) in ishigami_exact().items():
        e = est[name]
        assert abs(e["S1"] - s1) <= e["S1_conf"], (name, e, s1)
        assert abs(e["ST"] - st) <= e["ST_conf"], (name, e, st)
        assert 0 < e["S1_conf"] < 0.1 and 0 < e["ST_conf"] < 0.1


def test_confidence_narrows_with_samples():
    problem = {"num_vars": 3, "names": ["x1", "x2", "x3"], "bounds": [[-math.pi, math.pi]] * 3}
    small = sobol_indices(ishigami, problem, 256, 0)
    large = sobol_indices(ishigami, problem, 2048, 0)
    assert large["x2"]["S1_conf"] < small["x2"]["S1_conf"]


def test_inputs_are_checked():
    with pytest.raises(ConfigError, match="range"):
        parse_sensitivity_param("clearance.A.size=0.1,0.2mm")
    p = parse_sensitivity_param("clearance.A.size=0.1..0.8mm")
    assert p.lo == pytest.approx(1e-4) and p.hi == pytest.approx(8e-4)
    problem = {"num_vars": 1, "names": ["x"], "bounds": [[0, 1]]}
    with pytest.raises(ConfigError, match="power of two"):
        sobol_sample(problem, 10)


def test_tiny_machine_run_completes_and_is_cached(tmp_path):
    from berryshaker.config import load_machine
    from berryshaker.runs.runner import SweepRunner

    m = load_machine(None)
    params = [SobolParameter("clearance.A.size", 0.25e-3, 0.75e-3, "mm", 1e-3),
              SobolParameter("clearance.C.size", 0.10e-3, 0.20e-3, "mm", 1e-3)]
    with SweepRunner(workers=1, cache_dir=tmp_path, progress=False) as runner:
        res = machine_sobol(m, params, ["collision_force_A_peak", "collision_force_C_peak"], 8, runner, "mlsd")
        assert res["runs"] == 8 * (2 + 2)
        again = machine_sobol(m, params, ["collision_force_A_peak"], 8, runner, "mlsd")
        assert runner.stats["cached"] >= 32
    for o in ("collision_force_A_peak", "collision_force_C_peak"):
        for p in ("clearance.A.size", "clearance.C.size"):
            assert np.isfinite(res["indices"][o][p]["ST"])
        assert res["output_unit"][o] == "N"
        rz = res["resolution"][o]  # N = 8 resolves nothing useful: it says so and what N to try
        assert rz["unresolved"] and rz["suggested_samples"] > 8
    for p in ("clearance.A.size", "clearance.C.size"):  # the same runs (cached), the same estimates
        for k in ("S1", "ST"):
            assert again["indices"]["collision_force_A_peak"][p][k] == res["indices"]["collision_force_A_peak"][p][k]
    with SweepRunner(workers=1, cache_dir=tmp_path, progress=False) as runner:
        with pytest.raises(ConfigError, match="unknown output"):
            machine_sobol(m, params, ["no_such_output"], 8, runner, "mlsd")


def test_bootstrap_intervals_do_not_depend_on_numpys_global_state():
    """Seed 0 is a seed: SALib ignores a falsy seed and draws its bootstrap from numpy's global generator, which made
    the intervals (and test_ishigami_indices_within_confidence_interval[0]) depend on the tests that ran before."""
    from berryshaker.life.sensitivity import sobol_analyze

    problem = {"num_vars": 3, "names": ["x1", "x2", "x3"], "bounds": [[-math.pi, math.pi]] * 3}
    y = ishigami(sobol_sample(problem, 256, 0))
    out = []
    for state in (1, 2):
        np.random.seed(state)
        out.append(sobol_analyze(problem, y, seed=0))
    assert out[0] == out[1]


def test_unresolved_and_negative_indices_are_named_with_the_n_to_try():
    from berryshaker.life.sensitivity import output_unit, resolution

    ind = {"a": {"S1": -0.3, "S1_conf": 0.2, "ST": 0.5, "ST_conf": 0.04},   # S1 below 0 beyond its interval
           "b": {"S1": 0.4, "S1_conf": 0.2, "ST": 0.45, "ST_conf": 0.05},   # interval too wide
           "c": {"S1": -0.01, "S1_conf": 0.03, "ST": 0.02, "ST_conf": 0.01}}  # negative, but 0 within its interval
    r = resolution(ind, 32)
    assert [u.split(":")[0] for u in r["unresolved"]] == ["S1 of a", "S1 of b"]
    assert r["negative_within_noise"] == ["S1 of c: -0.010 +- 0.030"]
    assert r["suggested_samples"] == 512  # widest 0.2 -> 32 (0.2 / 0.05)^2 = 512
    ok = resolution({"a": {"S1": 0.5, "S1_conf": 0.02, "ST": 0.6, "ST_conf": 0.03}}, 1024)
    assert ok["unresolved"] == [] and ok["suggested_samples"] is None
    assert [output_unit(n) for n in ("collision_force_A_peak", "load_moment_left_rms", "sliding_speed_C_mean",
                                     "comb_swing_left_deg", "efficiency")] == ["N", "N m", "m/s", "deg", ""]
