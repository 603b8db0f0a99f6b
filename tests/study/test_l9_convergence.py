"""Honest noise: the replicate count is chosen by the convergence of the spread itself, the spread reported at the
recommendation agrees with fresh starts, blocked analyses see what pure error hides, and the statistics behind
them (SE of an SD, paired differences, the run x block error, sequential stopping) against independent checks."""

from __future__ import annotations

import numpy as np
import pytest

from berryshaker.experiment.designs import orthogonal_array
from berryshaker.experiment.error_terms import block_error, block_variance, paired_differences
from berryshaker.experiment.noise import sd_standard_error, spread_convergence, standard_error_reached
from berryshaker.experiment.replicates import analyze_replicated

L9 = orthogonal_array("L9")[:, :4] + 1


# ---- the statistics, against closed forms and simulation ------------------------------------------------------
@pytest.mark.parametrize("dist,g2,lo,hi", [("normal", 0.0, 0.94, 1.06), ("uniform", -1.2, 0.94, 1.06),
                                           ("laplace", 3.0, 1.0, 1.2)])
def test_sd_standard_error_matches_the_simulated_spread_of_s(dist, g2, lo, hi):
    """SE(s) = s/2 sqrt(2/(n-1) + g2/n) against the spread of s over 40 000 simulated samples of n = 8: within 6 %
    for light tails; for heavy tails (Laplace) the first-order formula errs on the safe side (it overstates the
    error by up to 20 % at n = 8, so a count chosen with it is, if anything, too large)."""
    rng = np.random.default_rng(3)
    n = 8
    draw = {"normal": lambda: rng.normal(0, 1, (40000, n)), "uniform": lambda: rng.uniform(-1, 1, (40000, n)),
            "laplace": lambda: rng.laplace(0, 1, (40000, n))}[dist]()
    s = draw.std(axis=1, ddof=1)
    sigma = {"normal": 1.0, "uniform": 1 / np.sqrt(3), "laplace": np.sqrt(2.0)}[dist]
    x = sigma * np.ones(n)  # the formula at s = sigma with the population's kurtosis
    x[: n // 2] *= -1
    predicted = sd_standard_error(x * np.sqrt((n - 1) / n), kurtosis=g2)  # sample SD of x is sigma
    assert lo <= predicted / s.std() <= hi


def test_spread_convergence_picks_the_first_stable_count_and_skips_rare_and_constant_responses():
    rng = np.random.default_rng(5)
    samples = {"eff": rng.normal(3.6, 0.6, 32), "const": np.zeros(32), "rare": np.r_[np.zeros(31), 0.02]}
    res = spread_convergence(samples, (4, 8, 16, 32), floors={"rare": 0.05})
    assert res["constant"] == ["const"] and res["negligible"] == ["rare"]
    assert res["table"]["eff"]["rows"][4]["sd_relative_error"] > 0.30  # four starts do not know their SD
    assert res["chosen"] == min(n for n in (4, 8, 16, 32) if res["table"]["eff"]["rows"][n]["stable"])
    assert res["chosen"] in (8, 16)
    # without the floor the rare response is judged, and it never converges at these counts
    assert spread_convergence(samples, (4, 8, 16, 32))["chosen"] is None


def test_block_error_is_the_residual_of_runs_plus_blocks():
    """The run x block interaction equals the residual of OLS y ~ C(run) + C(block) (statsmodels)."""
    import pandas as pd
    import statsmodels.formula.api as smf

    rng = np.random.default_rng(1)
    y = rng.normal(0, 1, (9, 5)) + rng.normal(0, 2, 5)[None, :]
    ss, df = block_error(y)
    long = pd.DataFrame({"y": y.ravel(), "run": np.repeat(np.arange(9), 5), "block": np.tile(np.arange(5), 9)})
    fit = smf.ols("y ~ C(run) + C(block)", data=long).fit()
    assert ss == pytest.approx(fit.ssr, rel=1e-10) and df == int(fit.df_resid) == 32
    bv = block_variance(y)
    assert bv["df_block"] == 4 and bv["var_block"] > 1.0  # the blocks' spread (SD 2) is seen


def test_blocks_find_an_effect_that_pure_error_hides_and_paired_differences_cover_the_truth():
    """A 0.1 effect of A under a start-to-start spread of 0.6 (shared by every run) and 0.05 of run noise: the
    unblocked analysis calls it noise, the blocked one finds it, and the paired A3 - A1 interval covers 0.1 in
    about 95 % of 400 repeats."""
    from berryshaker.experiment.replicates import replicated_anova

    rng = np.random.default_rng(11)
    r, cover, found, hidden = 8, 0, 0, 0
    for i in range(1000):
        y = 3.5 + 0.05 * (L9[:, :1] - 2) + rng.normal(0, 0.6, r)[None, :] + rng.normal(0, 0.05, (9, r))
        pd_ = paired_differences(L9[:, 0], y)
        a31 = next(q for q in pd_ if q["levels"] == [1, 3])
        cover += a31["ci"][0] <= 0.1 <= a31["ci"][1]
        if i < 40:
            found += replicated_anova(L9, y, list("ABCF"), blocks=True)["factors"]["A"]["significant"]
            hidden += not replicated_anova(L9, y, list("ABCF"), blocks=False)["factors"]["A"]["significant"]
    assert 0.93 <= cover / 1000 <= 0.97
    assert found / 40 > 0.95 and hidden / 40 > 0.8


def test_a_factor_is_judged_against_its_own_interaction_with_the_starts():
    """A factor with no mean effect whose effect varies from start to start (each start its own random A slope, the
    others none): against the pooled run x start error, which the three quiet factors dilute, A is "significant" in
    far more than 5 % of tests (the anti-conservative verdict of a pooled error); against its own A x start
    interaction, Greenhouse-Geisser corrected, it keeps the nominal rate (uncorrected it was 11.5 %: the slope lives
    in one of A's two contrasts, a sphericity violation).  In a saturated L9 the four factors' own interactions add
    up to the pooled one exactly."""
    from scipy import stats

    from berryshaker.experiment.error_terms import block_error, factor_block_error
    from berryshaker.experiment.replicates import replicated_anova

    rng = np.random.default_rng(21)
    r, own, pooled, tests = 6, 0, 0, 400
    for _ in range(tests):
        slope = rng.normal(0, 0.5, r)[None, :]  # A's effect in each start: zero on average
        y = rng.normal(0, 1.0, r)[None, :] + (L9[:, :1] - 2) * slope + rng.normal(0, 0.1, (9, r))
        own += replicated_anova(L9, y, list("ABCF"), blocks=True)["factors"]["A"]["significant"]
        ss_a = sum(3 * r * (y[L9[:, 0] == k].mean() - y.mean()) ** 2 for k in (1, 2, 3))
        ss_e, df_e = block_error(y)
        pooled += stats.f.sf((ss_a / 2) / (ss_e / df_e), 2, df_e) < 0.05
        assert sum(factor_block_error(L9[:, j], y)[0] for j in range(4)) == pytest.approx(ss_e, rel=1e-10)
    assert own / tests < 0.09, own / tests
    assert pooled / tests > 0.15, pooled / tests


def test_blocked_null_factors_stay_no_difference_at_the_nominal_rate():
    from berryshaker.experiment.replicates import replicated_anova

    rng = np.random.default_rng(12)
    sig = 0
    for _ in range(100):
        y = rng.normal(0, 0.6, 6)[None, :] + rng.normal(0, 0.05, (9, 6))
        sig += replicated_anova(L9, y, list("ABCF"), blocks=True)["factors"]["B"]["significant"]
    assert sig / 100 < 0.12
    # the whole analysis on one such test: blocked, and the paired differences travel with each factor
    b = analyze_replicated(L9, L9.astype(float), list("ABCF"), {"y": y}, {"y": True}, blocks=True)
    assert b.blocks and b.responses["y"].anova.error.df == 8 * 5
    assert b.responses["y"].anova.factors["A"].error.df == 2 * 5  # A against A x start
    assert len(b.responses["y"].factors["A"].paired) == 3


def test_standard_error_target_uses_the_floor_near_zero():
    r = standard_error_reached({"eff": np.array([3.0, 3.2, 2.8, 3.1]), "unripe": np.array([0, 0, 0.01, 0])}, 0.05,
                               {"unripe": 0.05})
    assert r["responses"]["eff"]["met"] and r["responses"]["unripe"]["met"] and r["all_met"]
    r = standard_error_reached({"eff": np.array([3.0, 4.2, 2.0, 3.9])}, 0.05)
    assert not r["all_met"]


def test_calibrated_yield_carries_the_relative_error_of_the_efficiency_mean(machine):
    """The efficiency is proportional to the yield per bush, so SE(yield) / yield = SE(eff) / eff exactly; the
    damage scale's SE (Weibull damage only) is the damage SE over the slope.  The impact damage has no scale to fit:
    asking for it is an error naming the model that has one."""
    from berryshaker.config import machine_from_dict
    from berryshaker.errors import ConfigError
    from berryshaker.harvest.virtual import MASS_FACTORS, Z_GRID, calibrate_harvest, start_responses

    rng = np.random.default_rng(4)
    base = np.outer(np.linspace(0.1, 0.5, Z_GRID.size), np.ones(MASS_FACTORS.size))
    reps = [([base * rng.uniform(0.8, 1.2) for _ in machine.harvest.branch_classes], 100 + k) for k in range(6)]
    with pytest.raises(ConfigError, match="stem_acceleration"):
        calibrate_harvest(machine, fit=("efficiency", "damage"), replicates=reps)
    d = machine.model_dump()
    d["harvest"]["damage_model"] = "stem_acceleration"
    weibull = machine_from_dict(d)
    fit = calibrate_harvest(weibull, fit=("efficiency", "damage"), replicates=reps)
    unc = fit["uncertainty"]
    d["harvest"].update(yield_per_bush=fit["yield_per_bush_kg"], damage_acceleration=fit["damage_acceleration_m_s2"])
    fitted = machine_from_dict(d)
    eff = [start_responses(fitted, e, s)["expected"]["efficiency"] for e, s in reps]
    rel = np.std(eff, ddof=1) / np.sqrt(len(eff)) / np.mean(eff)
    assert unc["yield_per_bush_kg"] / fit["yield_per_bush_kg"] == pytest.approx(rel, rel=1e-9)
    assert unc["damage_acceleration_m_s2"] > 0
    assert calibrate_harvest(machine, replicates=reps)["fitted"] == {}  # by default nothing is fitted


# ---- the virtual harvest's own spread ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def spread_runner(tmp_path_factory):
    from berryshaker.runs.runner import SweepRunner

    with SweepRunner(workers=2, cache_dir=tmp_path_factory.mktemp("spread-cache"), progress=False) as r:
        yield r


@pytest.fixture(scope="module")
def convergence(machine, spread_runner):
    from berryshaker.study.l9 import start_convergence

    return start_convergence(machine, spread_runner, counts=(4, 8, 16, 32), families=())


def test_the_default_number_of_starts_is_where_the_spread_converges(machine, convergence):
    """32 starts at the reference machine's clearances: the smallest count at which the SD of every harvest
    response's expectation is known to 30 % and neither it nor the mean leaves its 2-SE band is where the numbers
    an engineer acts on are taken: the recommended set's starts run on to ``harvest.max_replicates``, which must
    reach it.  The L9's per-run count ``harvest.replicates`` (8, the field's default) is below it: its blocked
    error pools the runs (docs/harvest.md "How many starts").  4 starts are not enough."""
    from berryshaker.harvest.spec import HarvestSpec

    assert convergence["chosen"] is not None
    assert machine.harvest.max_replicates >= convergence["chosen"]
    assert machine.harvest.replicates == HarvestSpec.model_fields["replicates"].default
    t = convergence["table"]
    assert not all(t[k]["rows"][4]["stable"] for k in t if not (t[k]["constant"] or t[k]["negligible"]))
    for name in ("efficiency", "efficiency_expected"):  # a field test's spread, and the model's own
        eff = t[name]["rows"]
        assert eff[32]["sd"] > 0.3  # the noise is real: a start's efficiency varies by far more than 3 starts showed
        assert abs(eff[8]["sd"] / eff[32]["sd"] - 1) < 2 * eff[8]["sd_relative_error"]
    # a field test scatters more than the model's expectation: the counting noise of its few bushes comes on top
    assert t["efficiency"]["rows"][32]["sd"] > t["efficiency_expected"]["rows"][32]["sd"]


def test_the_spread_at_the_recommendation_agrees_with_fresh_starts(machine, convergence, spread_runner):
    """The per-start SD the sequential replication reports at a set (its starts reuse the convergence's runs)
    against an independent estimate from 24 starts of a seed family the project never uses (another SeedSequence
    entropy): consistent within their joint sampling error (variance-ratio F test, two-sided p >= 0.001) and within
    a factor of 2, for the model's expectation and the counted field results.  (The full check, 96 fresh starts in
    three families against the project's 32, is benchmarks/studies/seed_families.py.)

    Why not a fixed band of 0.67-1.5: the damage rate is right-skewed (a start whose phase misses the bond picks
    little and bruises the few it picks), and its 24-start SD itself varies from 0.20 to 0.36 between independent
    draws (measured over two fresh sets of 24 and the study's 32); the F test carries that sampling error, and a
    2x understatement of the spread (the defect this guards against was 5-7x) fails it at these counts."""
    from scipy import stats

    from berryshaker.study.l9 import sequential_starts, start_cells

    cl = machine.clearance_sizes()
    seq = sequential_starts(machine, spread_runner, cl)
    assert seq["reached"]["all_met"] or len(seq["cells"]) == machine.harvest.max_replicates
    from berryshaker.config import machine_from_dict

    d = machine.model_dump(mode="json")
    d["harvest"]["seed"] = 7919
    fresh = start_cells(machine_from_dict(d), spread_runner, cl, list(range(24)), d)
    for n in ("efficiency", "damage", "efficiency_expected", "damage_expected"):
        a = np.array([c[n] for c in seq["cells"]])
        b = np.array([c[n] for c in fresh])
        f = a.var(ddof=1) / b.var(ddof=1)
        p = 2 * min(stats.f.sf(f, a.size - 1, b.size - 1), stats.f.cdf(f, a.size - 1, b.size - 1))
        assert 0.5 <= np.sqrt(f) <= 2.0 and p >= 1e-3, (n, np.sqrt(f), p)


def test_doe_analyze_blocks_on_a_block_column(tmp_path):
    """A field sheet with a 'Blocks' column (a field day shared by every run): the analysis is blocked, finds the
    small effect of A that a day-to-day spread hides from the pure error, and reports its paired difference."""
    import json

    import pandas as pd
    from typer.testing import CliRunner

    from berryshaker.cli import app

    rng = np.random.default_rng(8)
    day = rng.normal(0, 0.5, 4)
    rows = []
    for b in range(4):
        for i, lv in enumerate(L9):
            rows.append({"run": i + 1, "Blocks": b + 1, "A": (0.25, 0.5, 0.75)[lv[0] - 1], "B": lv[1], "C": lv[2],
                         "efficiency_kg_min": 3.5 + 0.06 * (lv[0] - 2) + day[b] + rng.normal(0, 0.03)})
    p = tmp_path / "sheet.csv"
    pd.DataFrame(rows).to_csv(p, index=False)
    r = CliRunner().invoke(app, ["doe", "analyze", str(p), "--maximize", "efficiency", "--json"])
    assert r.exit_code == 0, r.output
    res = json.loads(r.stdout)
    assert res["block_column"] == "Blocks" and res["blocks"] is True
    fa = res["responses"]["efficiency"]["factors"]["A"]
    assert fa["significant"]
    a31 = next(q for q in fa["paired"] if q["levels"] == [1, 3])
    assert a31["ci"][0] <= 0.12 <= a31["ci"][1] and a31["beyond_noise"]


def test_tolerance_flags_a_force_that_falls_with_clearance_beyond_the_noise():
    from berryshaker.life.tolerance import ClearanceResponse, force_fall_notes

    c = np.array([0.025, 0.083, 0.142]) * 1e-3
    rng = np.random.default_rng(3)
    start = rng.normal(0, 1500, 8)  # the start-to-start spread, shared by every grid point (the same starts)

    def resp(name, means, run_sd):
        peaks = np.array([m + start + rng.normal(0, run_sd, 8) for m in means])
        return ClearanceResponse(name, c, peaks.mean(axis=1), np.ones(3), peaks.std(axis=1, ddof=1) / np.sqrt(8),
                                 np.percentile(peaks, 95, axis=1), 8, peaks)

    falls = resp("C", [17700.0, 14200, 14500], 300)  # 3500 N down, far beyond the paired noise
    noise = resp("A", [9000.0, 8950, 9500], 300)  # 50 N down: inside it
    single = ClearanceResponse("B", c, np.array([19000.0, 14000, 15000]), np.ones(3))
    assert [f["from_mm"] for f in falls.force_falls()] == [0.025]
    assert noise.force_falls() == [] and single.force_falls() == []  # within the noise; one run cannot tell
    (note,) = force_fall_notes({"C": falls, "A": noise, "B": single})
    assert note.startswith("C: the mean static-equivalent force falls by 3") and "stiffens" in note and "paired" in note


def test_nothing_is_fitted_to_the_study_and_its_values_are_held_out(machine, convergence, spread_runner):
    """The reference description's harvest parameters come from published data (docs/harvest.md): no value is
    tagged [calibrated], the study's three field values are held-out predictions at A1B1C1F3 (their verdicts are
    in ``berryshaker validate``), and the recommendation labels nothing "fitted"."""
    from berryshaker.config import value_tag
    from berryshaker.harvest.virtual import calibrate_harvest
    from berryshaker.study.l9 import fitted_here, replicate_envelopes, sequential_starts

    assert not [k for k in ("harvest.yield_per_bush", "harvest.damage_acceleration", "harvest.unripe_fraction")
                if value_tag(machine, k) == "calibrated"]
    assert fitted_here(machine, machine.clearance_sizes()) == []
    seq = sequential_starts(machine, spread_runner, machine.clearance_sizes())
    reps = replicate_envelopes(machine, seq["outputs"], seq["seeds"])
    r = calibrate_harvest(machine, replicates=reps)
    assert r["fitted"] == {} and set(r["held_out"]) == {"efficiency_kg_min", "unripe_rate_pct", "damage_rate_pct"}
    assert all(np.isfinite(v["model"]) for v in r["held_out"].values())
