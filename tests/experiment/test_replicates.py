"""Replicated orthogonal tests: effects judged against pure error, weighted choice that ignores noise,
trade-off table with dominance beyond noise.  Synthetic data with known truth."""

import numpy as np
import pytest
from scipy import stats

from berryshaker.errors import ConfigError
from berryshaker.experiment.designs import orthogonal_array
from berryshaker.experiment.error_terms import pure_error
from berryshaker.experiment.replicates import analyze_replicated, describe_replicated, replicated_anova
from berryshaker.experiment.tradeoff import mark_dominated, tradeoff_table

L9 = orthogonal_array("L9") + 1
NAMES = list("ABCF")
EFFECT_A = np.array([0.0, 0.5, 1.0])  # +1.0 from level 1 to level 3; B, C, F: no effect


def _data(seed, r=3, sd=0.1):
    rng = np.random.default_rng(seed)
    eff = 3.0 + EFFECT_A[L9[:, 0] - 1][:, None] + sd * rng.standard_normal((9, r))
    dmg = 2.5 + sd * rng.standard_normal((9, r))  # pure noise
    return {"efficiency": eff, "damage": dmg}


SENSES = {"efficiency": True, "damage": False}


def test_real_effect_is_significant_and_picked_noise_is_not():
    res = analyze_replicated(L9, L9.astype(float), NAMES, _data(1), SENSES, {"efficiency": 0.1, "damage": 0.9})
    e = res.responses["efficiency"].factors["A"]
    assert e.significant and e.p < 1e-6 and e.best_level == 3
    assert e.range_ci[0] < 1.0 < e.range_ci[1]
    a = res.optimum.choices["A"]
    # damage carries 90 % of the weight but is noise: it must not steer the choice of A
    assert a.level == 3 and a.significant_responses == ["efficiency"] and "damage: no significant" in a.reason
    assert "p < 0.05" in res.significance_rule
    assert "Significance rule" in describe_replicated(res)


def test_zero_effects_are_no_difference_at_least_90_percent_of_the_time():
    hits = {f: 0 for f in "BCF"}
    seeds = range(50)
    for s in seeds:
        res = analyze_replicated(L9, L9.astype(float), NAMES, {"efficiency": _data(s)["efficiency"]},
                                 {"efficiency": True})
        for f in "BCF":
            c = res.optimum.choices[f]
            hits[f] += c.level is None and c.status == "no meaningful difference"
        assert res.optimum.choices["A"].level == 3
    assert all(h >= 45 for h in hits.values()), hits


@pytest.mark.parametrize("r", [2, 3, 5])
def test_pure_error_degrees_of_freedom(r):
    y = _data(3, r=r)["efficiency"]
    ss, dof = pure_error(y)
    assert dof == 9 * (r - 1)
    assert ss == pytest.approx(sum(np.sum((row - row.mean()) ** 2) for row in y))
    an = replicated_anova(L9, y, NAMES)
    assert an["pure_error"]["df"] == 9 * (r - 1) and an["lack_of_fit"]["df"] == 0  # saturated L9


def test_anova_f_against_hand_computation():
    """SS_A = sum_l N_l (ybar_l - ybar)^2 over all N_l = 3 r observations at level l; F = (SS_A / 2) /
    (SS_PE / 9 (r - 1)); p from the F(2, 9 (r - 1)) distribution (textbook one-way formulas)."""
    r = 4
    y = _data(7, r=r)["efficiency"]
    an = replicated_anova(L9, y, NAMES)
    ybar = y.mean()
    ss_pe = np.sum((y - y.mean(axis=1, keepdims=True)) ** 2)
    for j, f in enumerate(NAMES):
        ss = sum(3 * r * (y[L9[:, j] == lv].mean() - ybar) ** 2 for lv in (1, 2, 3))
        F = (ss / 2) / (ss_pe / (9 * (r - 1)))
        assert an["factors"][f]["ss"] == pytest.approx(ss, rel=1e-9)
        assert an["factors"][f]["f"] == pytest.approx(F, rel=1e-9)
        assert an["factors"][f]["p"] == pytest.approx(stats.f.sf(F, 2, 9 * (r - 1)), rel=1e-9)
        # level-mean interval: t quantile x sqrt(MS_PE / (3 r))
        se = np.sqrt(ss_pe / (9 * (r - 1)) / (3 * r))
        lo, hi = an["factors"][f]["level_ci"][0]
        assert (hi - lo) / 2 == pytest.approx(stats.t.ppf(0.975, 9 * (r - 1)) * se, rel=1e-9)


def test_lack_of_fit_is_separated_when_the_design_has_room():
    """Three factors in an L9 leave 2 between-run dof: residual = lack of fit + pure error."""
    y = _data(2)["efficiency"]
    an = replicated_anova(L9[:, :3], y, NAMES[:3])
    between = 3 * np.sum((y.mean(axis=1) - y.mean()) ** 2)
    assert an["lack_of_fit"]["df"] == 2 and an["pure_error"]["df"] == 18
    assert an["lack_of_fit"]["ss"] == pytest.approx(between - sum(an["factors"][f]["ss"] for f in "ABC"))


def test_level_mean_intervals_cover_the_truth():
    """95 % intervals of A's level means cover the true means about 95 % of the time (Monte Carlo)."""
    cover, total = 0, 0
    for s in range(80):
        an = replicated_anova(L9, _data(100 + s, r=2)["efficiency"], NAMES)
        for (lo, hi), mu in zip(an["factors"]["A"]["level_ci"], 3.0 + EFFECT_A):
            cover += lo <= mu <= hi
            total += 1
    assert 0.9 <= cover / total <= 0.99


def test_input_errors_and_identical_replicates():
    d = _data(0)
    with pytest.raises(ConfigError, match="at least 2 replicates"):
        analyze_replicated(L9, L9, NAMES, {"efficiency": d["efficiency"][:, :1]}, {"efficiency": True})
    with pytest.raises(ConfigError, match="finite number > 0"):
        analyze_replicated(L9, L9, NAMES, d, SENSES, {"efficiency": 0.0})
    with pytest.raises(ConfigError, match="valid: efficiency, damage"):
        analyze_replicated(L9, L9, NAMES, d, SENSES, {"yield": 1.0})
    same = np.repeat((3.0 + EFFECT_A[L9[:, 0] - 1])[:, None], 3, axis=1)
    res = analyze_replicated(L9, L9, NAMES, {"efficiency": same}, {"efficiency": True})
    assert res.optimum.choices["A"].level == 3 and res.optimum.choices["B"].level is None
    assert "identical" in res.notes[0]


def test_tradeoff_table_and_dominance_beyond_noise():
    def cand(name, eff, half, force, torque):
        return {"name": name, "clearance_mm": {"A": 0.25, "B": 0.2},
                "harvest": {"efficiency": {"mean": eff, "ci": [eff - half, eff + half]},
                            "damage": {"mean": 2.8, "ci": [2.7, 2.9]}},
                "peak_force_N": {"A": force, "B": 50.0}, "drive_torque_Nm": torque, "energy_lost_J": 1.0}

    cands = [cand("worse", 3.5, 0.05, 120.0, 10.0),     # dominated by best: lower efficiency beyond noise
             cand("best", 3.9, 0.05, 100.0, 10.0),
             cand("close", 3.85, 0.05, 100.0, 10.05),   # within noise of best everywhere
             cand("strong", 4.5, 0.05, 300.0, 10.0)]    # best harvest, but far larger collision force
    t = tradeoff_table(cands)
    assert list(t["name"]) == ["strong", "best", "close", "worse"]
    assert t.set_index("name").loc["worse", "dominated_by"] == "best; close"
    assert not t.set_index("name").loc[["best", "close", "strong"], "dominated"].any()
    assert {"efficiency_lo", "peak_force_N:A", "clearance_mm:B", "drive_torque_Nm"} <= set(t.columns)
    # with wide intervals nothing is beyond noise
    wide = mark_dominated(tradeoff_table([cand("x", 3.5, 0.5, 100.0, 10.0), cand("y", 3.9, 0.5, 100.0, 10.0)]))
    assert not wide["dominated"].any()
    with pytest.raises(ConfigError, match="does not contain"):
        tradeoff_table([{"name": "bad", "harvest": {"efficiency": {"mean": 5.0, "ci": [3.0, 4.0]}}}])
