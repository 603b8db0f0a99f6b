"""The typed results of the orthogonal-test analyses (berryshaker.experiment.analysis_records, .replicated_records):
a real analysis reads back from its JSON and writes the same text, key for key and in order (ints stay ints); every
record refuses a key it does not have, a missing field and a value of the wrong type, naming the field."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pydantic
import pytest

from berryshaker.experiment import analysis_records as A
from berryshaker.experiment import replicated_records as R
from berryshaker.experiment.analysis import analyze
from berryshaker.experiment.designs import orthogonal_array
from berryshaker.experiment.field_results import analyze_sheet
from berryshaker.experiment.replicates import analyze_replicated

L9 = orthogonal_array("L9") + 1
NAMES = list("ABCF")
MINITAB = Path(__file__).parents[1] / "data" / "minitab_l9_replicated.csv"


def _replicated(fallback: bool = True, blocks: bool = True) -> R.ReplicatedAnalysis:
    rng = np.random.default_rng(3)
    y = {"efficiency": 3.0 + 0.3 * L9[:, [0]] + 0.05 * rng.standard_normal((9, 3)),
         "damage": 2.5 + 0.1 * L9[:, [1]] + 0.05 * rng.standard_normal((9, 3)),
         "load": 10.0 + L9[:, [2]] + 0.1 * rng.standard_normal((9, 3))}
    return analyze_replicated(L9, L9 * 0.25, NAMES, y, {"efficiency": True, "damage": False, "load": False},
                              {"efficiency": 0.6, "damage": 0.4}, fallback_weights={"load": 1.0} if fallback else None,
                              level_values={f: (0.25, 0.5, 0.75) for f in NAMES}, units={f: "mm" for f in NAMES},
                              blocks=blocks)


def _unreplicated() -> A.DoeAnalysis:
    y = {"efficiency": 3.0 + 0.3 * L9[:, 0] - 0.1 * L9[:, 1] + 0.01 * L9[:, 2] ** 2,
         "damage": 2.5 + 0.2 * L9[:, 3] + 0.05 * L9[:, 0]}
    return analyze(L9, L9 * 0.25, NAMES, y, {"efficiency": True, "damage": False}, {"efficiency": 2, "damage": 1},
                   level_values={"A": (0.25, 0.5, 0.75)}, units={"A": "mm"})


def _round_trip(rec):
    data = json.loads(json.dumps(rec.to_json()))  # as read from a file
    back = type(rec).from_json(data)
    assert json.dumps(back.to_json()) == json.dumps(rec.to_json())
    assert back == rec or json.dumps(back.to_json()) == json.dumps(data)  # NaN != NaN: compare the text
    return data


def test_range_analysis_is_typed_and_reads_back_as_written():
    res = _unreplicated()
    assert isinstance(res, A.DoeAnalysis)
    ra = res.responses["efficiency"]
    assert isinstance(ra, A.RangeAnalysis) and isinstance(ra.factors["A"], A.FactorEffect)
    assert isinstance(ra.anova, A.Anova) and isinstance(ra.anova.error, A.ErrorTerm) and ra.anova.pooled
    assert isinstance(ra.regression.main_effects_quadratic, A.MainQuadratic)
    assert isinstance(res.composite, A.CompositeScore) and isinstance(res.optimum, A.RangeOptimum)
    assert res.factors["B"].values is None and res.factors["A"].labels == ["0.25 mm", "0.5 mm", "0.75 mm"]
    data = _round_trip(res)
    assert list(data) == ["responses", "weights", "factors", "composite", "optimum"]  # the sheet's fields left out
    assert list(data["responses"]["efficiency"]) == ["factors", "ranking", "maximize", "best_levels", "anova",
                                                     "regression"]
    assert list(data["responses"]["efficiency"]["anova"]) == ["factors", "error", "pooled", "ss_all", "total_ss"]
    assert "kind" not in data["responses"]["efficiency"]["anova"]["error"]  # an optional field left out
    # ints stay ints
    assert type(data["responses"]["efficiency"]["factors"]["A"]["best_level"]) is int
    assert type(data["responses"]["efficiency"]["anova"]["error"]["df"]) is int
    assert type(data["responses"]["efficiency"]["regression"]["full_model_rank"]) is int


@pytest.mark.parametrize("fallback", [True, False])
def test_replicated_analysis_is_typed_and_reads_back_as_written(fallback):
    res = _replicated(fallback)
    assert isinstance(res, R.ReplicatedAnalysis) and isinstance(res.optimum, R.ReplicatedOptimum)
    ra = res.responses["efficiency"]
    assert isinstance(ra, R.ReplicatedResponse) and isinstance(ra.factors["A"], R.ReplicatedEffect)
    assert isinstance(ra.anova, R.ReplicatedAnova) and isinstance(ra.anova.blocks, R.BlockVariance)
    assert isinstance(ra.factors["A"].paired[0], R.PairedDifference)
    assert isinstance(res.optimum.choices["A"], R.Choice) and res.optimum.choices["A"].level == 3
    data = _round_trip(res)
    opt = data["optimum"]
    if fallback:
        assert list(opt) == ["levels", "settings", "choices", "values", "intervals", "weights", "fallback_weights",
                             "method", "prediction", "primary", "fallback"]
        assert isinstance(res.optimum.primary, R.TierChoices) and "tier" in opt["choices"]["A"]
    else:
        assert list(opt) == ["levels", "settings", "choices", "values", "intervals", "weights", "method",
                             "prediction"]
        assert "tier" not in opt["choices"]["A"] and "fallback_weights" not in data
    assert type(data["responses"]["efficiency"]["anova"]["lack_of_fit"]["df"]) is int
    assert type(data["responses"]["efficiency"]["factors"]["A"]["paired"][0]["levels"][0]) is int


def test_an_unblocked_analysis_writes_its_empty_blocks_and_paired_as_null():
    data = _round_trip(_replicated(blocks=False))
    ra = data["responses"]["efficiency"]
    assert ra["anova"]["blocks"] is None and ra["factors"]["A"]["paired"] is None


@pytest.mark.parametrize("replicated", [True, False])
def test_a_sheets_analysis_reads_back_as_written(replicated, tmp_path):
    if replicated:
        _, res = analyze_sheet(MINITAB, {"efficiency": True, "damage": False})
        assert isinstance(res, R.SheetReplicatedAnalysis) and res.block_column is None
        data = _round_trip(res)
        assert list(data)[-6:] == ["notes", "block_column", "text", "weights_given", "response_units",
                                   "runs_identified_by"]
        assert data["block_column"] is None  # written as null, not left out
    else:
        sheet = tmp_path / "sheet.csv"
        rows = ["run,A_level,B_level,efficiency_kg_min"] + [f"{i + 1},{a},{b},{3 + 0.1 * a + 0.01 * b * b}"
                                                            for i, (a, b) in enumerate(L9[:, :2])]
        sheet.write_text("\n".join(rows) + "\n")
        _, res = analyze_sheet(sheet, {"efficiency": True})
        assert isinstance(res, A.DoeAnalysis)
        data = _round_trip(res)
        assert list(data)[-4:] == ["replicates", "weights_given", "response_units", "runs_identified_by"]
        assert data["replicates"] == 1 and data["weights_given"] is False


def _parts() -> list[tuple[type, dict]]:
    """(record type, a real JSON form of it) for every record type."""
    un = _unreplicated().to_json()
    rep = _replicated().to_json()
    _, sheet = analyze_sheet(MINITAB, {"efficiency": True, "damage": False})
    ra, rr = un["responses"]["efficiency"], rep["responses"]["efficiency"]
    return [(A.DoeAnalysis, un), (A.RangeAnalysis, ra), (A.FactorEffect, ra["factors"]["A"]),
            (A.Anova, ra["anova"]), (A.AnovaTerm, next(iter(ra["anova"]["factors"].values()))),
            (A.ErrorTerm, ra["anova"]["error"]), (A.Regression, ra["regression"]),
            (A.CodedRange, ra["regression"]["coded_factors"]["A"]),
            (A.MainQuadratic, ra["regression"]["main_effects_quadratic"]),
            (A.RidgeQuadratic, ra["regression"]["ridge_full_quadratic"]), (A.CompositeScore, un["composite"]),
            (A.RangeOptimum, un["optimum"]), (A.FactorLevels, un["factors"]["A"]),
            (R.ReplicatedAnalysis, rep), (R.ReplicatedResponse, rr), (R.ReplicatedEffect, rr["factors"]["A"]),
            (R.PairedDifference, rr["factors"]["A"]["paired"][0]), (R.ReplicatedAnova, rr["anova"]),
            (R.BlockVariance, rr["anova"]["blocks"]), (R.ReplicatedOptimum, rep["optimum"]),
            (R.Choice, rep["optimum"]["choices"]["A"]), (R.TierChoices, rep["optimum"]["primary"]),
            (R.SheetReplicatedAnalysis, sheet.to_json())]


PARTS = _parts()


@pytest.mark.parametrize("record_type,data", PARTS, ids=[t.__name__ for t, _ in PARTS])
def test_every_record_refuses_an_unknown_key_a_missing_field_and_a_wrong_type(record_type, data):
    assert json.dumps(record_type.from_json(data).to_json()) == json.dumps(data)
    with pytest.raises(pydantic.ValidationError, match="colour"):
        record_type.from_json({**data, "colour": "red"})
    first = next(iter(data))
    with pytest.raises(pydantic.ValidationError, match=first):
        record_type.from_json({k: v for k, v in data.items() if k != first})
    with pytest.raises(pydantic.ValidationError, match=first):
        record_type.from_json({**data, first: object()})


def test_the_sheet_record_is_the_replicated_one_with_the_sheets_fields():
    assert [f for f in R.SheetReplicatedAnalysis.__dataclass_fields__][:len(R.ReplicatedAnalysis.__dataclass_fields__)] \
        == list(R.ReplicatedAnalysis.__dataclass_fields__)
