"""The desirability optimiser of `doe analyze --desirability` (issue 58 item 4): Derringer and Suich's (1980)
desirabilities, goals read strictly with their units, and the optimum of a sheet against a brute-force search over
level means computed here with pandas."""

import itertools

import numpy as np
import pytest

from berryshaker.errors import ConfigError
from berryshaker.experiment.analysis_records import Goal
from berryshaker.experiment.desirability import individual_desirability, parse_desirability
from berryshaker.experiment.field_results import analyze_sheet
from berryshaker.experiment.field_sheet import parse_factor, plan_table

UNITS = {"efficiency": "kg/min", "damage": "%", "x": ""}


def test_derringer_suich_desirabilities():
    """Eq. 1-3 of Derringer and Suich (1980) with the shape exponents 1: linear between the limits, 0 and 1 beyond."""
    up = Goal("maximize", 2.0, 5.0, None, "kg/min")
    np.testing.assert_allclose(individual_desirability([1.0, 2.0, 3.5, 5.0, 9.0], up), [0, 0, 0.5, 1, 1])
    down = Goal("minimize", 0.0, 4.0, None, "%")
    np.testing.assert_allclose(individual_desirability([-1.0, 0.0, 1.0, 4.0, 6.0], down), [1, 1, 0.75, 0, 0])
    tgt = Goal("target", 1.0, 4.0, 2.0, "%")
    np.testing.assert_allclose(individual_desirability([0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0], tgt),
                               [0, 0, 0.5, 1, 0.5, 0, 0])


def test_goals_are_read_strictly_with_their_units():
    g = parse_desirability("efficiency=max:120..300kg/h, damage=min:0..5%", list(UNITS), UNITS)
    assert g["efficiency"] == Goal("maximize", pytest.approx(2.0), pytest.approx(5.0), None, "kg/min")
    assert g["damage"] == Goal("minimize", 0.0, 5.0, None, "%")
    assert parse_desirability("damage=target:1..2..4%", list(UNITS), UNITS)["damage"].target == 2.0
    assert parse_desirability("x=max:1..2", list(UNITS), UNITS)["x"].unit == ""
    for text, message in [
        ("efficiency=max:2..5", r"give the limits' unit \(the sheet's response is in kg/min\), e.g. "
                                r"efficiency=max:2..5kg/min"),
        ("efficiency=max:2..5mm", r"unit 'mm' cannot be read as 'kg/min'"),
        ("damage=min:0..5kg/min", r"cannot be read as '%'"),
        ("x=max:1..2mm", "gives this response no unit"),
        ("efficiency=max:5..2kg/min", "the limits must increase"),
        ("damage=target:1..4%", "a target needs LOW..TARGET..HIGH"),
        ("damage=target:1..5..4%", "the limits must increase"),
        ("efficiency=best:2..5kg/min", "expected max:LOW..HIGH"),
        ("efficiency=max:2..5kg/min,efficiency=max:1..2kg/min", "has a goal already"),
        ("yield=max:1..2", r"'yield' is not an analysed response"),
        ("efficiency=max:1e999..2kg/min", "finite"),
        ("", "expected NAME=max"),
    ]:
        with pytest.raises(ConfigError, match=message):
            parse_desirability(text, list(UNITS), UNITS)


def _sheet():
    """L9 x 2 blocks: efficiency rises with A, damage rises with A and falls with B: the goals trade off."""
    specs = ["A=0.25,0.5,0.75mm", "B=0.2,0.4,0.6mm", "C=0.1,0.15,0.2mm"]
    df = plan_table("L9", [parse_factor(s) for s in specs], replicates=2)
    noise = np.random.default_rng(3).normal(0.0, 0.05, len(df))
    df["efficiency_kg_min"] = 2.0 + 4.0 * df["A_mm"] + noise
    df["damage_rate_pct"] = 1.0 + 6.0 * df["A_mm"] - 3.0 * df["B_mm"] + noise[::-1]
    return df


def test_the_optimum_is_the_best_level_set_of_the_significant_effects():
    """Brute force here: predictions from the level means (pandas group-bys) of the factors whose effect is
    significant, d by the closed forms, D the geometric mean; the optimiser finds the same level set and D, leaves C
    (no effect) at None and reports the interval of each prediction."""
    df = _sheet()
    goals = "efficiency=max:3..5kg/min,damage=min:1..4%"
    _, res = analyze_sheet(df.to_csv(index=False), {"efficiency": True, "damage": False}, desirability=goals)
    d = res.desirability
    sig = {r: [f for f in "ABC" if res.responses[r].factors[f].significant] for r in ("efficiency", "damage")}
    assert sig == {"efficiency": ["A"], "damage": ["A", "B"]}
    cols = {"efficiency": "efficiency_kg_min", "damage": "damage_rate_pct"}
    g = parse_desirability(goals, ["efficiency", "damage"], {"efficiency": "kg/min", "damage": "%"})
    best = None
    for a, b in itertools.product((1, 2, 3), repeat=2):
        pred = {}
        for r, col in cols.items():
            grand = df[col].mean()
            pred[r] = grand + sum(df.groupby(f"{f}_level")[col].mean()[k] - grand
                                  for f, k in (("A", a), ("B", b)) if f in sig[r])
        D = float(np.sqrt(np.prod([individual_desirability(pred[r], g[r]) for r in cols])))
        if best is None or D > best[0] + 1e-12:
            best = (D, a, b, pred)
    assert d.levels == {"A": best[1], "B": best[2], "C": None}
    assert d.overall == pytest.approx(best[0], rel=1e-9)
    for r in cols:
        assert d.values[r] == pytest.approx(best[3][r], rel=1e-9)
        lo, hi = d.intervals[r]
        assert lo < d.values[r] < hi
    assert d.candidates[0].overall == pytest.approx(d.overall) and d.candidates[1].overall <= d.overall
    assert res.optimum.levels["A"] == 3  # the weighted optimum beside it weighs the goals otherwise
    far = analyze_sheet(df.to_csv(index=False), {"efficiency": True}, desirability="efficiency=max:9..10kg/min")[1]
    assert far.desirability.overall == 0 and set(far.desirability.levels.values()) == {None}
    assert "no level set brings every goal's prediction inside its limits" in far.desirability.note
