"""Field sheets are never misread: level codings, plain factor columns, checked responses, large sheets,
and the printable sheet."""

import re
import tracemalloc
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from berryshaker.errors import ConfigError
from berryshaker.experiment.analysis import analyze
from berryshaker.experiment.designs import orthogonal_array
from berryshaker.experiment.field_sheet import Factor, parse_factor, plan_html, plan_table, read_results

SPECS = ["A=0.25,0.5,0.75mm", "B=0.2,0.4,0.6mm", "C=0.1,0.15,0.2mm", "F=0.1,0.15,0.2mm"]
L9 = orthogonal_array("L9") + 1


def _filled(randomize=True):
    df = plan_table("L9", [parse_factor(s) for s in SPECS], randomize=randomize, seed=7 if randomize else None)
    df["efficiency_kg_min"] = 4.0 - df["A_mm"]
    df["unripe_rate_pct"] = 3.0
    df["damage_rate_pct"] = 2.5
    return df


def _csv(df):
    return df.to_csv(index=False)


def test_plan_round_trip_gives_levels_values_and_units():
    fr = read_results(_csv(_filled()), ["efficiency"])
    assert np.array_equal(fr.levels, L9)
    assert fr.level_values["A"] == (0.25, 0.5, 0.75) and fr.units["A"] == "mm"
    assert np.allclose(fr.values[:, 0], np.array([0.25, 0.5, 0.75])[L9[:, 0] - 1])
    assert np.allclose(fr.responses["efficiency"], 4.0 - fr.values[:, 0])
    assert fr.factors == ["A_level", "B_level", "C_level", "F_level"]
    assert np.array_equal(fr.table[fr.factors].to_numpy(int), L9)  # what the CLI reads


@pytest.mark.parametrize("coding", ["zero-based", "values", "values with unit"])
def test_level_columns_read_whatever_the_coding(coding):
    df = _filled().astype(object)
    for f in "ABCF":
        lv = df[f"{f}_level"].astype(int)
        if coding == "zero-based":
            df[f"{f}_level"] = lv - 1
        elif coding == "values":
            df[f"{f}_level"] = df[f"{f}_mm"]
            df = df.drop(columns=f"{f}_mm")
        else:
            df[f"{f}_level"] = [f"{v:g} mm" for v in df[f"{f}_mm"]]
            df = df.drop(columns=f"{f}_mm")
    fr = read_results(_csv(df), ["efficiency"])
    assert np.array_equal(fr.levels, L9)
    assert fr.level_values["B"] == (0.2, 0.4, 0.6)


def test_plain_factor_columns_as_statistics_packages_write_them():
    df = _filled(randomize=False)
    plain = pd.DataFrame({"run": df["run"], "A": df["A_mm"], "B": df["B_mm"], "C": df["C_mm"], "F": df["F_mm"],
                          "efficiency_kg_min": df["efficiency_kg_min"], "notes": "dry", "operator": "J. Doe"})
    fr = read_results(_csv(plain), ["efficiency"])
    assert fr.factor_names == list("ABCF") and np.array_equal(fr.levels, L9)
    assert fr.level_values["C"] == (0.1, 0.15, 0.2) and fr.units["C"] == ""
    assert np.allclose(fr.table["A_value"], fr.values[:, 0])


def test_a_value_matching_no_level_names_row_and_column():
    plain = pd.DataFrame({"run": range(1, 10), "A": L9[:, 0], "B": L9[:, 1], "efficiency_kg_min": 3.0})
    plain = plain.astype(object)
    plain.loc[4, "A"] = 1.4
    with pytest.raises(ConfigError, match=r"row 6 \(run 5\), column 'A': 1.4 matches no level \(1, 2, 3"):
        read_results(_csv(plain), ["efficiency"])
    df = _filled(randomize=False).astype(object)
    df.loc[2, "B_level"] = 1.4
    with pytest.raises(ConfigError, match=r"row 4 \(run 3\), column 'B_level': 1.4 matches no level"):
        read_results(_csv(df), ["efficiency"])
    with pytest.raises(ConfigError, match=r"column 'B_level': 1.4 matches no level of factor 'B'"):
        read_results(_csv(df), ["efficiency"], factors=[parse_factor(s) for s in SPECS])


def test_level_and_value_columns_must_agree():
    df = _filled(randomize=False)
    df.loc[3, "A_mm"] = 0.75  # run 4 is A2 = 0.5 mm
    with pytest.raises(ConfigError, match=r"row 5 \(run 4\), column 'A_mm': 0.75 disagrees with level"):
        read_results(_csv(df), ["efficiency"])


def test_ambiguous_coding_is_refused():
    """Levels given as 3, 2, 1: a column of 1/2/3 reads as level numbers and as values, differently."""
    df = pd.DataFrame({"run": range(1, 10), "A_level": L9[:, 0], "B_level": L9[:, 1], "efficiency_kg_min": 3.0})
    with pytest.raises(ConfigError, match="with different meanings"):
        read_results(_csv(df), ["efficiency"], factors=[Factor("A", (3.0, 2.0, 1.0), ""), Factor("B", (1, 2, 3), "")])


def test_factor_named_like_a_response_column_is_refused():
    with pytest.raises(ConfigError, match="reserved field-sheet column"):
        parse_factor("duration=10,20,30s")
    df = pd.DataFrame({"run": range(1, 10), "duration_level": L9[:, 0], "duration_s": 10 * L9[:, 0],
                       "B_level": L9[:, 1], "efficiency_kg_min": 3.0})
    with pytest.raises(ConfigError, match="factor 'duration' would take the column 'duration_s'"):
        read_results(_csv(df), ["efficiency"])
    with pytest.raises(ConfigError, match="factor .A. would take the column .A_mm."):
        read_results(_csv(_filled()), ["A_mm"])


@pytest.mark.parametrize("col,value,message", [
    ("picked_mass_kg", -0.1, "mass must be >= 0"),
    ("duration_s", 0.0, "duration must be > 0"),
    ("picked_mass_kg", float("inf"), "must be a finite number"),
    ("unripe_mass_kg", 0.9, "more than the picked mass"),
])
def test_raw_measurements_are_checked(col, value, message):
    df = _filled(randomize=False)
    df["efficiency_kg_min"] = np.nan
    df["unripe_rate_pct"] = np.nan
    df["duration_s"], df["picked_mass_kg"], df["unripe_mass_kg"], df["damaged_mass_kg"] = 10.0, 0.6, 0.02, 0.01
    df.loc[2, col] = value
    with pytest.raises(ConfigError, match=rf"row 4 \(run 3\), column '{col}'.*{message}"):
        read_results(_csv(df), ["efficiency", "unripe"])


@pytest.mark.parametrize("col,value,message", [
    ("unripe_rate_pct", 120.0, "within 0-100"), ("damage_rate_pct", -1.0, "within 0-100"),
    ("efficiency_kg_min", -3.0, "efficiency must be >= 0")])
def test_indexes_are_checked(col, value, message):
    df = _filled(randomize=False)
    df.loc[6, col] = value
    with pytest.raises(ConfigError, match=rf"row 8 \(run 7\), column '{col}'.*{message}"):
        read_results(_csv(df), ["efficiency", "unripe", "damage"])


def test_duplicate_run_header_only_and_unknown_response():
    df = _filled(randomize=False)
    dup = pd.concat([df, df.iloc[[3]]])
    with pytest.raises(ConfigError, match=r"run 4 appears 2 times \(rows 5, 11\)"):
        read_results(_csv(dup), ["efficiency"])
    with pytest.raises(ConfigError, match="header but no rows"):
        read_results(_csv(df.iloc[:0]) + "\n", ["efficiency"])
    with pytest.raises(ConfigError, match=r"unknown response 'bogus'; valid: efficiency, unripe, damage"):
        read_results(_csv(df), ["bogus"])


def test_decimal_commas():
    df = _filled(randomize=False)
    text = df.to_csv(index=False, sep=";", decimal=",")
    assert "0,25" in text
    fr = read_results(text, ["efficiency"])
    assert np.allclose(fr.responses["efficiency"], 4.0 - fr.values[:, 0])
    assert fr.level_values["A"] == (0.25, 0.5, 0.75)
    bad = df.astype(object)
    bad.loc[3, "efficiency_kg_min"] = "3,9"
    with pytest.raises(ConfigError, match=r"row 5 \(run 4\), column 'efficiency_kg_min': '3,9' is not a number; "
                                          "decimal comma"):
        read_results(_csv(bad), ["efficiency"])


def test_weights_are_checked():
    y = {"efficiency": np.arange(9.0), "damage": np.ones(9) + np.arange(9) % 2}
    senses = {"efficiency": True, "damage": False}
    for w, msg in [({"efficiency": 0.0}, "finite number > 0"), ({"efficiency": -1}, "finite number > 0"),
                   ({"efficiency": float("nan")}, "finite number > 0"), ({"yield": 1.0}, "valid: efficiency, damage")]:
        with pytest.raises(ConfigError, match=re.escape(msg)):
            analyze(L9, L9.astype(float), list("ABCF"), y, senses, w)
    with pytest.raises(ConfigError, match="unknown response"):
        analyze(L9, L9.astype(float), list("ABCF"), y, {**senses, "bogus": True})


def test_unitless_and_code_only_factors_are_reported_honestly():
    plain = pd.DataFrame({"run": range(1, 10), "A": np.array([10.0, 20.0, 30.0])[L9[:, 0] - 1],
                          "B_level": L9[:, 1], "efficiency_kg_min": L9[:, 0] + 0.1 * L9[:, 1]})
    plain = plain.rename(columns={"A": "A_level"})
    fr = read_results(_csv(plain), ["efficiency"])
    res = analyze(fr.levels, fr.values, fr.factor_names, fr.responses, {"efficiency": True},
                  level_values=fr.level_values, units=fr.units)
    assert res.factors["A"].values == [10.0, 20.0, 30.0] and res.factors["A"].labels[0] == "10"
    assert res.factors["B"].values is None and res.factors["B"].labels == ["level 1", "level 2", "level 3"]
    assert res.optimum.settings == {"A": "30", "B": "level 3"}


def test_a_100000_row_sheet_is_analysed_without_an_n_by_n_matrix():
    """L4 repeated 25,000 times.  The ridge LOO used to form the n x n hat matrix (80 GB at this size)."""
    reps = 25_000
    a = np.tile(orthogonal_array("L4") + 1, (reps, 1))
    n = len(a)
    rng = np.random.default_rng(1)
    df = pd.DataFrame({"run": np.arange(1, n + 1), "A_level": a[:, 0], "B_level": a[:, 1], "C_level": a[:, 2],
                       "efficiency_kg_min": 3.0 + 0.2 * a[:, 0] + 0.05 * rng.standard_normal(n)})
    text = _csv(df)
    fr = read_results(text, ["efficiency"])
    tracemalloc.start()  # numpy reports its buffers to tracemalloc
    res = analyze(fr.levels, fr.values, fr.factor_names, fr.responses, {"efficiency": True})
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert res.responses["efficiency"].factors["A"].best_level == 2
    assert peak < 400e6, f"peak {peak / 1e6:.0f} MB"  # the n x n matrix alone would be 80,000 MB


def test_printable_sheet():
    df = _filled()
    df[["efficiency_kg_min", "unripe_rate_pct", "damage_rate_pct"]] = np.nan
    page = plan_html(df, "L9 test")
    assert "@page{size:landscape" in page and "table-layout:fixed" in page
    for word in ("Date", "Operator", "Weather", "Notes", ">notes<"):
        assert word in page
    rows = re.findall(r"<tr>(.*?)</tr>", page)[1:]
    assert len(rows) == 9
    cells = [re.findall(r"<td[^>]*>(.*?)</td>", r) for r in rows]
    assert [c[0] for c in cells] == [str(i) for i in range(1, 10)]  # sorted by order, printed as integers
    assert sorted(int(c[1]) for c in cells) == list(range(1, 10))  # run numbers kept
    by_run = df.set_index("run")
    for c in cells:
        assert by_run.loc[int(c[1]), "order"] == int(c[0])
    assert not any(re.search(r"\d\.0$", x) for c in cells for x in c)
    assert "0.25" in page
    assert list(pd.read_csv(pd.io.common.StringIO(_csv(df))).columns[:5]) == ["run", "replicate", "order", "A_level",
                                                                             "A_mm"]


def _replicated_sheet(r=3, seed=11, sigma=0.1):
    """A randomised L9 sheet with r replicates, filled with efficiency = 4 - 0.8 A[mm] + noise (known SD)."""
    df = plan_table("L9", [parse_factor(s) for s in SPECS], randomize=True, seed=seed, replicates=r)
    noise = np.random.default_rng(5).normal(0.0, sigma, len(df))
    df["efficiency_kg_min"] = 4.0 - 0.8 * df["A_mm"] + noise
    df["unripe_rate_pct"] = 3.0 + noise
    df["damage_rate_pct"] = 2.5
    return df, noise


def test_plan_has_a_replicate_column_and_a_seeded_order_of_all_rows():
    """Rows = runs x replicates, each run with replicates 1..R; the randomised order is a seeded permutation of
    all rows (reproducible; with one replicate the order earlier sheets drew); unrandomised = replicate blocks."""
    factors = [parse_factor(s) for s in SPECS]
    df = plan_table("L9", factors, randomize=True, seed=7, replicates=3)
    assert len(df) == 27 and list(df.columns[:3]) == ["run", "replicate", "order"]
    assert sorted(df["order"]) == list(range(1, 28))
    for run, g in df.groupby("run"):
        assert list(g["replicate"]) == [1, 2, 3]
        assert (g[[f"{f}_level" for f in "ABCF"]].to_numpy() == L9[run - 1]).all()
    again = plan_table("L9", factors, randomize=True, seed=7, replicates=3)
    assert again["order"].tolist() == df["order"].tolist()
    assert plan_table("L9", factors, randomize=True, seed=8, replicates=3)["order"].tolist() != df["order"].tolist()
    one = plan_table("L9", factors, randomize=True, seed=7)
    assert one["order"].tolist() == (np.random.default_rng(7).permutation(9) + 1).tolist()
    blocks = plan_table("L9", factors, replicates=2)
    assert blocks.sort_values("order")[["replicate", "run"]].to_numpy().tolist() == [
        [k, i] for k in (1, 2) for i in range(1, 10)]
    with pytest.raises(ConfigError, match="replicates=0"):
        plan_table("L9", factors, replicates=0)
    page = plan_html(df, "L9 x 3")
    assert len(re.findall(r"<tr>", page)) == 28 and "cate" in page


def test_randomised_plan_keeps_each_replicate_block_together():
    """Issue 58: `doe plan --randomize` drew one order over all runs x replicates while `doe analyze` reads replicate
    k as block k (a field day, a row of bushes).  Now block k is tests (k - 1) n + 1 .. k n, every run once, in a
    random order of its own (a different one per block, seeded); one replicate keeps the earlier order."""
    factors = [parse_factor(s) for s in SPECS]
    df = plan_table("L9", factors, randomize=True, seed=7, replicates=3)
    orders = []
    for k, g in df.groupby("replicate"):
        assert sorted(g["order"]) == list(range(9 * (k - 1) + 1, 9 * k + 1))
        assert sorted(g["run"]) == list(range(1, 10))
        orders.append((g.sort_values("order")["run"]).tolist())
    assert orders[0] != orders[1] != orders[2] and orders[0] != list(range(1, 10))
    one = plan_table("L9", factors, randomize=True, seed=7)
    assert one["order"].tolist() == (np.random.default_rng(7).permutation(9) + 1).tolist()


def test_replicated_sheet_reads_back_into_runs_x_replicates_and_a_pure_error_anova():
    """Read back in any row order: responses as (runs, replicates) in run order, their means per run, and the
    pure-error ANOVA of the virtual L9 on them: MS_PE equals the hand-computed replicate variance, A (an effect
    of 0.4 kg/min per level against sigma = 0.1) is significant, C (no effect) is not."""
    from berryshaker.experiment.error_terms import pure_error
    from berryshaker.experiment.replicates import analyze_replicated

    df, _ = _replicated_sheet()
    shuffled = df.sample(frac=1.0, random_state=3)
    fr = read_results(_csv(shuffled), ["efficiency", "unripe"])
    assert fr.replicates == 3 and np.array_equal(fr.levels, L9)
    y = fr.responses_replicated["efficiency"]
    want = df.sort_values(["run", "replicate"])["efficiency_kg_min"].to_numpy().reshape(9, 3)
    np.testing.assert_allclose(y, want)
    np.testing.assert_allclose(fr.responses["efficiency"], want.mean(axis=1))
    assert fr.table[["run", "replicate"]].to_numpy().tolist() == [[i, k] for i in range(1, 10) for k in (1, 2, 3)]
    res = analyze_replicated(fr.levels, fr.values, fr.factor_names, fr.responses_replicated,
                             {"efficiency": True, "unripe": False})
    pe = res.responses["efficiency"].anova.pure_error
    ss = float(np.sum((want - want.mean(axis=1, keepdims=True)) ** 2))
    assert pe.df == 18 and pe.ss == pytest.approx(ss) and pure_error(want)[0] == pytest.approx(ss)
    eff = res.responses["efficiency"]
    assert eff.factors["A"].significant and not eff.factors["C"].significant
    assert res.optimum.levels["A"] == 1


def test_replicated_sheets_are_checked():
    df, _ = _replicated_sheet()
    df = df.sort_values(["run", "replicate"]).reset_index(drop=True)
    assert read_results(_csv(df.drop(index=10)), ["efficiency"]).lost == {"efficiency": [[4, 2]]}  # a lost plot
    typo = df.copy()
    typo.loc[10, "replicate"] = 4  # replicate 2 of run 4 typed as 4: a block of one row
    with pytest.raises(ConfigError, match=r"row 12 \(run 4, replicate 4\): replicate 4 holds this row only"):
        read_results(_csv(typo), ["efficiency"])
    gap = df.copy()
    gap.loc[gap["replicate"] == 2, "replicate"] = 5
    with pytest.raises(ConfigError, match=r"no row has replicate 2, 4, but replicate 5 exists"):
        read_results(_csv(gap), ["efficiency"])
    dup = df.copy()
    dup.loc[10, "replicate"] = 1
    with pytest.raises(ConfigError, match=r"run 4 appears 2 times \(rows 11, 12\) as replicate 1"):
        read_results(_csv(dup), ["efficiency"])
    moved = df.copy().astype(object)
    moved.loc[10, "B_level"], moved.loc[10, "B_mm"] = 2, 0.4  # replicate 2 of run 4 set to another level of B
    with pytest.raises(ConfigError, match=r"row 12 \(run 4, replicate 2\), column 'B_level': the levels differ from "
                       "replicate 1 of run 4"):
        read_results(_csv(moved), ["efficiency"])
    bad = df.copy().astype(object)
    bad.loc[0, "replicate"] = "x"
    with pytest.raises(ConfigError, match=r"row 2 \(run 1\), column 'replicate': 'x' is not a number"):
        read_results(_csv(bad), ["efficiency"])
    bad.loc[0, "replicate"] = 0
    with pytest.raises(ConfigError, match=r"row 2 \(run 1\), column 'replicate': '0' is not a replicate number"):
        read_results(_csv(bad), ["efficiency"])


# ---- issue #42: nothing silently misread -------------------------------------------------------------------
def test_a_value_column_without_its_level_column_is_an_error():
    """A_level deleted, A_mm kept: factor A is not dropped from the analysis without a word."""
    df = _filled().drop(columns=["A_level"])
    with pytest.raises(ConfigError, match=r"column 'A_mm' holds the values of factor 'A', but its 'A_level' "
                                          r"column is missing"):
        read_results(_csv(df), ["efficiency"])
    # without any level column the value columns are the factors (plain sheets), A included
    fr = read_results(_csv(_filled().drop(columns=[f"{f}_level" for f in "ABCF"])), ["efficiency"])
    assert fr.factor_names == ["A", "B", "C", "F"]


@pytest.mark.parametrize("spec", ["A=1,2,3mm*1000", "A=1,2,3mm**9**9", "A=1,2,3m^99", "A=1,2,3kg/"])
def test_factor_units_are_read_strictly(spec):
    with pytest.raises(ConfigError, match="is not a unit berryshaker reads"):
        parse_factor(spec)
    assert parse_factor("A=1,2,3m/s^2").unit == "m/s^2"


def test_sheet_cells_with_units_use_the_strict_parser():
    df = _filled()
    df["A_mm"] = df["A_mm"].map(lambda v: f"{v / 10:g} cm")
    fr = read_results(_csv(df), ["efficiency"])
    assert fr.level_values["A"] == pytest.approx((0.25, 0.5, 0.75))
    df["A_mm"] = "0.05 cm*5"
    with pytest.raises(ConfigError, match="A_mm"):
        read_results(_csv(df), ["efficiency"])


def test_sheet_writer_and_reader_import_each_other_nowhere_inside_functions():
    """Issue 46: field_sheet forwarded read_results through an import placed inside a function, to dodge the cycle
    with field_results (which imported field_sheet).  The shared columns and records live in field_columns now."""
    import ast

    import berryshaker.experiment.field_results as fr
    import berryshaker.experiment.field_sheet as fs

    for mod in (fs, fr):
        tree = ast.parse(Path(mod.__file__).read_text(encoding="utf-8"))
        for fn in (n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))):
            for node in ast.walk(fn):
                if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("berryshaker.experiment.field"):
                    raise AssertionError(f"{mod.__name__}.{fn.name} imports {node.module} inside the function")
    top = [n.module for n in ast.parse(Path(fr.__file__).read_text(encoding="utf-8")).body
           if isinstance(n, ast.ImportFrom)]
    assert "berryshaker.experiment.field_sheet" not in top
    assert fs.read_results is fr.read_results


# ---- statistics packages' worksheets (issue 45): Minitab's bookkeeping columns, runs told apart by their settings
MINITAB = Path(__file__).parents[1] / "data" / "minitab_l9_replicated.csv"
SENSES = {"efficiency": True, "unripe": False, "damage": False}


def _plan_format_of_minitab(tmp_path) -> Path:
    """The Minitab sheet's numbers written into the plan's field sheet (`doe plan --replicates 3`): replicate k of
    a run is its k-th row in Minitab's standard order (StdOrder)."""
    mt = pd.read_csv(MINITAB)
    factors = [parse_factor(s) for s in ("A=0.25,0.5,0.75mm", "B=0.2,0.4,0.6mm", "C=0.1,0.2,0.3mm",
                                         "F=0.2,0.35,0.5mm")]
    plan = plan_table("L9", factors, replicates=3)
    mt = mt.sort_values("StdOrder")
    mt["k"] = mt.groupby(["A (mm)", "B (mm)", "C (mm)", "F (mm)"]).cumcount() + 1
    for i, row in plan.iterrows():
        hit = mt[(mt["A (mm)"] == row["A_mm"]) & (mt["B (mm)"] == row["B_mm"]) & (mt["C (mm)"] == row["C_mm"])
                 & (mt["F (mm)"] == row["F_mm"]) & (mt["k"] == row["replicate"])]
        assert len(hit) == 1
        for col, src in (("efficiency_kg_min", "Efficiency (kg/min)"), ("unripe_rate_pct", "Unripe (%)"),
                         ("damage_rate_pct", "Damage (%)")):
            plan.loc[i, col] = float(hit[src].iloc[0])
    path = tmp_path / "plan_format.csv"
    plan.to_csv(path, index=False)
    return path


def _assert_same(a, b, where="res"):
    if isinstance(a, dict):
        assert set(a) == set(b), f"{where}: keys {sorted(set(a) ^ set(b))}"
        for k in a:
            _assert_same(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, (list, tuple, np.ndarray)) and not isinstance(a, str):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            _assert_same(x, y, f"{where}[{i}]")
    elif isinstance(a, float):
        assert b == pytest.approx(a, rel=1e-12, abs=1e-12, nan_ok=True), where
    else:
        assert a == b, where


def test_a_minitab_worksheet_is_read_with_its_bookkeeping_columns_units_and_replicates():
    from berryshaker.experiment.field_results import analyze_sheet

    fr, res = analyze_sheet(MINITAB, SENSES)
    # StdOrder, RunOrder, PtType and Blocks are bookkeeping, never factors
    assert fr.factor_names == ["A", "B", "C", "F"]
    assert fr.units == {f: "mm" for f in "ABCF"} and fr.level_values["C"] == (0.1, 0.2, 0.3)
    # repeated settings are the replicates of one run: 9 runs x 3
    assert fr.replicates == 3 and fr.levels.shape == (9, 4) and fr.responses_replicated["efficiency"].shape == (9, 3)
    assert fr.response_units == {"efficiency": "kg/min", "unripe": "%", "damage": "%"}
    assert res.response_units == fr.response_units and "StdOrder" in fr.runs_identified_by
    assert fr.block_column is None  # Minitab's Blocks = 1 everywhere numbers no blocks
    # responses not analysed are measurements (a value per row), not factors
    one = read_results(MINITAB, ["efficiency"])
    assert one.factor_names == ["A", "B", "C", "F"] and {"Unripe", "Damage"} <= set(one.ignored_columns)


def test_plan_format_and_minitab_format_of_the_same_data_give_the_same_analysis(tmp_path):
    from berryshaker.experiment.field_results import analyze_sheet

    fr_p, plan = analyze_sheet(_plan_format_of_minitab(tmp_path), SENSES)
    fr_m, mini = analyze_sheet(MINITAB, SENSES)
    plan, mini = plan.to_json(), mini.to_json()
    np.testing.assert_array_equal(fr_p.levels, fr_m.levels)
    for name in SENSES:
        np.testing.assert_array_equal(fr_p.responses_replicated[name], fr_m.responses_replicated[name])
    for key in ("block_column", "runs_identified_by", "text"):
        plan.pop(key), mini.pop(key)
    _assert_same(plan, mini)
    assert plan["optimum"]["levels"]["C"] == mini["optimum"]["levels"]["C"]


def test_units_from_brackets_or_a_units_row_and_blocks_as_the_block_column():
    from berryshaker.experiment.field_results import analyze_sheet

    text = MINITAB.read_text(encoding="utf-8").splitlines()
    body = [ln.split(",") for ln in text[1:]]
    # Blocks numbered 1..3 by StdOrder (a field day per replicate); units in square brackets
    for row in body:
        row[3] = str((int(row[0]) - 1) // 9 + 1)
    head = "StdOrder,RunOrder,PtType,Blocks,A [mm],B [mm],C [mm],F [mm],Efficiency [kg/min],Unripe [%],Damage [%]"
    fr_b, res_b = analyze_sheet("\n".join([head] + [",".join(r) for r in body]) + "\n", SENSES)
    _, res_m = analyze_sheet(MINITAB, SENSES)
    res_b, res_m = res_b.to_json(), res_m.to_json()
    assert fr_b.block_column == "Blocks" and fr_b.units["A"] == "mm" and fr_b.response_units["efficiency"] == "kg/min"
    for key in ("block_column", "runs_identified_by", "text"):
        res_b.pop(key), res_m.pop(key)
    _assert_same(res_m, res_b)  # the blocks number the repeats as StdOrder did
    # a units row under the header; a factor with a speed unit
    head = "StdOrder,RunOrder,PtType,Blocks,A,B,Speed,F,Efficiency,Unripe,Damage"
    units = ",,,,mm,mm,r/min,mm,kg/min,%,%"
    fr_u = analyze_sheet("\n".join([head, units] + text[1:]) + "\n", SENSES)[0]
    assert fr_u.factor_names == ["A", "B", "Speed", "F"] and fr_u.units["Speed"] == "r/min"
    assert fr_u.response_units == {"efficiency": "kg/min", "unripe": "%", "damage": "%"}


def test_a_worksheet_with_a_missing_replicate_names_both_settings():
    text = MINITAB.read_text(encoding="utf-8").splitlines()
    with pytest.raises(ConfigError, match=r"the settings A = 0.5 mm, B = 0.2 mm, C = 0.2 mm, F = 0.5 mm occur in 2 "
                                          r"row\(s\).* in 3; rows with the same factor settings are replicates"):
        read_results("\n".join(text[:1] + text[2:]) + "\n", list(SENSES))


def test_a_plain_statistics_package_sheet_has_its_runs_told_apart_by_their_settings():
    """No run, order or block column at all: four settings of two factors, each twice (file order numbers the
    repeats); units from the header."""
    text = ("Speed (rpm),Depth [mm],Yield (kg)\n"
            "120,10,5.1\n150,10,5.9\n120,20,4.2\n150,20,6.3\n"
            "120,10,5.3\n150,10,6.1\n120,20,4.0\n150,20,6.6\n")
    fr = read_results(text, ["Yield"])
    assert fr.factor_names == ["Speed", "Depth"] and fr.units == {"Speed": "rpm", "Depth": "mm"}
    assert fr.replicates == 2 and fr.response_units == {"Yield": "kg"}
    np.testing.assert_array_equal(fr.levels, [[1, 1], [1, 2], [2, 1], [2, 2]])  # standard order of the settings
    np.testing.assert_allclose(fr.responses_replicated["Yield"], [[5.1, 5.3], [4.2, 4.0], [5.9, 6.1], [6.3, 6.6]])
    assert fr.runs_identified_by == "factor settings; repeats numbered in the order of the rows"
