"""A field sheet that lost plots is analysed, not refused (issue 58 item 2), and a sheet too small to analyse is
refused with the reason (issue 59 item 5).  Expected values come from the balanced analysis of the same data, from
Yates' (1933) missing-value estimate and from statsmodels' Type II ANOVA of the formula model."""

import json
import re
import warnings

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from berryshaker.errors import ConfigError
from berryshaker.experiment.designs import orthogonal_array
from berryshaker.experiment.field_results import analyze_sheet
from berryshaker.experiment.field_sheet import parse_factor, plan_table
from berryshaker.experiment.replicates import analyze_replicated
from berryshaker.experiment.unbalanced import analyze_unbalanced

L9 = orthogonal_array("L9") + 1
NAMES = ["fa", "fb", "fc", "fd"]  # formula-safe ('C' is patsy's)
SENSES = {"eff": True, "dmg": False}


def _data(seed=1):
    """A blocked L9 x 3: efficiency grows with fa, damage falls with fb, block shifts, noise of known SD."""
    rng = np.random.default_rng(seed)
    block = np.array([0.0, 0.3, -0.2])
    eff = 3 + 0.4 * L9[:, [0]] + block + rng.normal(0, 0.2, (9, 3))
    dmg = 2 - 0.1 * L9[:, [1]] + block / 3 + rng.normal(0, 0.1, (9, 3))
    return {"eff": eff, "dmg": dmg}


def test_a_complete_sheet_gives_the_balanced_numbers():
    """With every plot present the least-squares analysis is the randomised complete block analysis, number for
    number: ANOVA rows, least-squares level means and their comparison intervals, Tukey margins, run means, block
    variance, the weighted optimum and its intervals."""
    reps = _data()
    a = analyze_replicated(L9, L9.astype(float), NAMES, reps, SENSES, blocks=True)
    b, info = analyze_unbalanced(L9, L9.astype(float), NAMES, reps, SENSES)
    assert info["lost"] == {"eff": [], "dmg": []} and info["lost_df"] == {"eff": 0, "dmg": 0}
    for r in reps:
        A, B = a.responses[r], b.responses[r]
        assert B.anova.error.df == A.anova.error.df == 16
        assert B.anova.error.ss == pytest.approx(A.anova.error.ss, rel=1e-10)
        for f in NAMES:
            for k in ("ss", "df", "ms", "f", "p"):
                assert getattr(B.anova.factors[f], k) == pytest.approx(getattr(A.anova.factors[f], k), rel=1e-9)
            for k in ("level_means", "level_se", "range_ci", "hsd"):
                np.testing.assert_allclose(getattr(B.factors[f], k), getattr(A.factors[f], k), rtol=1e-10)
            assert B.factors[f].best_level == A.factors[f].best_level
        np.testing.assert_allclose(B.run_means, A.run_means, rtol=1e-12)
        for k in ("ms_block", "var_block", "per_start_sd"):
            assert getattr(B.anova.blocks, k) == pytest.approx(getattr(A.anova.blocks, k), rel=1e-10)
    assert b.optimum.levels == a.optimum.levels
    for r in reps:
        assert b.optimum.values[r] == pytest.approx(a.optimum.values[r], rel=1e-12)
        np.testing.assert_allclose(b.optimum.intervals[r], a.optimum.intervals[r], rtol=1e-10)


def test_one_lost_plot_is_yates_missing_value_analysis():
    """One plot lost from a saturated L9 in blocks: inserting Yates' (1933) estimate x = (a T_i + b B_j - G) /
    ((a - 1)(b - 1)) (a runs, b blocks; T_i, B_j, G the totals without the plot) and analysing the complete table
    gives the exact error sum of squares with one degree of freedom less, and the least-squares level means."""
    reps = _data(3)
    y = reps["eff"].copy()
    i, j = 3, 1
    y[i, j] = np.nan
    a, b = y.shape
    x = (a * np.nansum(y[i]) + b * np.nansum(y[:, j]) - np.nansum(y)) / ((a - 1) * (b - 1))
    filled = y.copy()
    filled[i, j] = x
    full = analyze_replicated(L9, L9.astype(float), NAMES, {"eff": filled}, {"eff": True}, blocks=True)
    res, info = analyze_unbalanced(L9, L9.astype(float), NAMES, {"eff": y}, {"eff": True})
    e = res.responses["eff"].anova.error
    assert e.df == 15 and info["error_df"]["eff"] == 15 and info["lost_df"]["eff"] == 1
    assert info["lost"]["eff"] == [[i + 1, j + 1]] and info["present"]["eff"] == 26
    assert e.ss == pytest.approx(full.responses["eff"].anova.error.ss, rel=1e-9)
    for f in NAMES:
        np.testing.assert_allclose(res.responses["eff"].factors[f].level_means,
                                   full.responses["eff"].factors[f].level_means, rtol=1e-10)
    np.testing.assert_allclose(res.responses["eff"].run_means, filled.mean(axis=1), rtol=1e-10)


def _long(y):
    run, blk = np.nonzero(np.isfinite(y))
    return pd.DataFrame({"y": y[run, blk], "blk": blk, "run": run, **{n: L9[run, k] for k, n in enumerate(NAMES)}})


@pytest.mark.parametrize("lost", [[(3, 1)], [(0, 0), (4, 2), (8, 1)]])
def test_type_ii_sums_of_squares_are_statsmodels(lost):
    """Sums of squares of the factors against statsmodels' anova_lm(typ=2) of y ~ C(blk) + C(fa) + ... on the plots
    present (in a saturated L9 the main-effects residual is the run x block interaction), and each factor's F against
    its own interaction with the blocks: the extra sum of squares of C(fa):C(blk) over y ~ C(blk) + C(run) (statsmodels
    OLS) on its degrees of freedom (the Greenhouse-Geisser epsilon from the blocks that kept every run)."""
    import statsmodels.formula.api as smf
    from statsmodels.stats.anova import anova_lm

    y = _data(5)["eff"]
    for i, j in lost:
        y[i, j] = np.nan
    res, _ = analyze_unbalanced(L9, L9.astype(float), NAMES, {"eff": y}, {"eff": True})
    table = anova_lm(smf.ols("y ~ C(blk) + " + " + ".join(f"C({n})" for n in NAMES), _long(y)).fit(), typ=2)
    an = res.responses["eff"].anova
    assert an.error.df == int(table.loc["Residual", "df"]) == 16 - len(lost)
    assert an.error.ss == pytest.approx(table.loc["Residual", "sum_sq"], rel=1e-9)
    base = smf.ols("y ~ C(blk) + C(run)", _long(y)).fit()
    for n in NAMES:
        row = table.loc[f"C({n})"]
        assert an.factors[n].ss == pytest.approx(row["sum_sq"], rel=1e-9)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the interaction's columns are rank-deficient by construction
            inter = smf.ols(f"y ~ C(blk) + C(run) + C({n}):C(blk)", _long(y)).fit()
        ss_own, df_own = base.ssr - inter.ssr, int(round(base.df_resid - inter.df_resid))
        assert an.factors[n].error.df == df_own and an.factors[n].error.ss == pytest.approx(ss_own, rel=1e-9)
        assert an.factors[n].f == pytest.approx((row["sum_sq"] / row["df"]) / (ss_own / df_own), rel=1e-9)


SPECS = ["A=0.25,0.5,0.75mm", "B=0.2,0.4,0.6mm", "C=0.1,0.15,0.2mm", "F=0.1,0.15,0.2mm"]


def _sheet():
    df = plan_table("L9", [parse_factor(s) for s in SPECS], randomize=True, seed=11, replicates=3)
    noise = np.random.default_rng(5).normal(0.0, 0.1, len(df))
    df["efficiency_kg_min"] = 4.0 - 0.8 * df["A_mm"] + noise
    df["unripe_rate_pct"] = 3.0 + noise
    df["damage_rate_pct"] = 2.5 + 2 * df["B_mm"] + noise[::-1]
    return df.sort_values(["run", "replicate"]).reset_index(drop=True)


def test_a_deleted_row_or_a_blank_response_is_analysed_and_the_loss_stated(tmp_path):
    """Before: rc 2, "every run needs replicates 1..3 once each" (a deleted row) or "response is empty" (a blank
    cell).  Now the sheet is analysed on the plots present, and the text, the JSON and the terminal say what was lost
    and which degrees of freedom went with it; a complete sheet keeps the balanced analysis (no lost_plots)."""
    from berryshaker.cli import app

    df = _sheet()
    senses = {"efficiency": True, "damage": False}
    _, complete = analyze_sheet(df.to_csv(index=False), senses)
    assert complete.lost_plots is None and "lost_plots" not in complete.to_json()
    _, deleted = analyze_sheet(df.drop(index=10).to_csv(index=False), senses)  # run 4, replicate 2
    blank = df.copy()
    blank.loc[10, ["efficiency_kg_min", "damage_rate_pct"]] = np.nan
    _, blanked = analyze_sheet(blank.to_csv(index=False), senses)
    assert json.dumps(deleted.to_json()) == json.dumps(blanked.to_json())  # (NaN: no lack-of-fit dof)
    lp = deleted.lost_plots
    assert lp.lost == {"efficiency": [[4, 2]], "damage": [[4, 2]]} and lp.plots == 27
    assert lp.error_df == {"efficiency": 15, "damage": 15} and lp.balanced_error_df == 16
    assert lp.lost_df == {"efficiency": 1, "damage": 1}
    assert deleted.to_json()["lost_plots"]["lost_df"] == {"efficiency": 1, "damage": 1}
    assert ("Lost plots of efficiency: 1 of 27 (run 4 replicate 2); error 15 degrees of freedom instead of 16 (1 "
            "lost)") in deleted.text
    assert deleted.optimum.levels["A"] == complete.optimum.levels["A"] == 1  # the effect is still found
    one = df.copy()
    one.loc[5, "efficiency_kg_min"] = np.nan  # only efficiency lost there: damage keeps all 27 plots
    _, res = analyze_sheet(one.to_csv(index=False), senses)
    assert res.lost_plots.lost == {"efficiency": [[2, 3]], "damage": []} and res.lost_plots.error_df["damage"] == 16
    path = tmp_path / "lost.csv"
    df.drop(index=10).to_csv(path, index=False)
    r = CliRunner().invoke(app, ["doe", "analyze", str(path), "--maximize", "efficiency", "--minimize", "damage"])
    assert r.exit_code == 0, r.output
    assert "error 15 degrees of freedom instead of 16 (1 lost)" in re.sub(r"\s+", " ", r.stdout)


def test_a_run_without_any_plot_or_no_error_left_is_refused():
    df = _sheet()
    gone = df[df["run"] != 4]  # every plot of run 4 deleted
    with pytest.raises(ConfigError, match=r"runs must be numbered 1..9 once each; missing run\(s\) \[4\]"):
        analyze_sheet(gone.to_csv(index=False), {"efficiency": True})
    blank = df.copy()
    blank.loc[blank["run"] == 4, "efficiency_kg_min"] = np.nan
    with pytest.raises(ConfigError, match=r"run 4 has no efficiency value in any replicate \(every plot of it lost\)"):
        analyze_sheet(blank.to_csv(index=False), {"efficiency": True})
    l4 = plan_table("L4", [parse_factor("A=1,2"), parse_factor("B=1,2")], replicates=2)
    l4["efficiency_kg_min"] = [3.0, 3.1, 3.4, 3.3, 2.9, 3.0, 3.6, 3.5]
    l4.loc[[1, 3], "efficiency_kg_min"] = np.nan  # runs 1 and 2 lose replicate 2: 6 plots, 4 runs, 2 blocks
    res = analyze_sheet(l4.to_csv(index=False), {"efficiency": True})[1]
    assert res.lost_plots.error_df["efficiency"] == 1  # still analysable: 6 - 4 - 2 + 1 degrees of freedom left
    l4.loc[[5], "efficiency_kg_min"] = np.nan
    with pytest.raises(ConfigError, match=r"5 plots of 4 runs in 2 blocks leave 0 degrees of freedom for the error"):
        analyze_sheet(l4.to_csv(index=False), {"efficiency": True})


@pytest.mark.parametrize("text, message", [
    # issue 59: one run in two replicates was a ZeroDivisionError traceback
    ("run,replicate,A_level,A_mm,B_level,B_mm,efficiency_kg_min\n1,1,1,0.25,1,0.2,3.1\n1,2,1,0.25,1,0.2,3.3\n",
     r"it holds one run \(A = 0.25 mm, B = 0.2 mm, 2 replicates\), so every factor has one level"),
    # issue 59: a one-row sheet was "analysed" with NaN F and p and numpy warnings
    ("run,A_level,A_mm,B_level,B_mm,efficiency_kg_min\n1,1,0.25,1,0.2,3.1\n",
     r"it holds one run \(A = 0.25 mm, B = 0.2 mm\)"),
    ("run,A,B,efficiency_kg_min\n1,1,1,3.1\n2,2,1,3.2\n3,3,1,3.3\n",
     r"factor 'B' has one level \(1\) in all 3 runs"),
    ("run,A,efficiency_kg_min\n1,1,3.1\n2,2,3.2\n3,3,3.3\n",
     r"3 runs without replicates and factors A using 2 degrees of freedom leave none for the error"),
])
def test_sheets_too_small_to_analyse_are_refused_with_the_reason(tmp_path, text, message):
    from berryshaker.cli import app

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy warning on the way
        with pytest.raises(ConfigError, match=message):
            analyze_sheet(text, {"efficiency": True})
    path = tmp_path / "s.csv"
    path.write_text(text)
    r = CliRunner().invoke(app, ["doe", "analyze", str(path), "--maximize", "efficiency"])
    assert r.exit_code == 2 and "Traceback" not in r.output and "cannot be analysed" in r.output
