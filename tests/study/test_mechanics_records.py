"""The mechanism steps' typed results (berryshaker.study.mechanics_records): a real study's step data read back
write the same JSON, key for key and in order; a key no record has is refused, naming it; the steps' pieces made
by the lower layers (berryshaker.experiment.agreement) read as the records."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pydantic
import pytest

from berryshaker.experiment.agreement import model_check, summary_statistics_agreement
from berryshaker.study.mechanics_records import (
    ClearanceRows,
    ModelAgreement,
    ModelCheck,
    MultibodyRow,
    RowAgreement,
    RowStarts,
)
from berryshaker.study.steps.clearance_rows import row_start_statistics

#: a reference study's ``agreement``, ``kinematics`` and ``rows`` (rows 1 and 2 of each part), from summary.json
DATA = json.loads((Path(__file__).parents[1] / "data" / "mechanics_steps.json").read_text(encoding="utf-8"))


@pytest.mark.parametrize("cls,key", [(ClearanceRows, "rows"), (ModelAgreement, "agreement")])
def test_a_real_steps_data_round_trip(cls, key):
    rec = cls.from_json(DATA[key])
    assert json.dumps(rec.to_json()) == json.dumps(DATA[key])  # values, types and the keys' order


def test_the_readers_attributes_hold_the_numbers():
    rows = ClearanceRows.from_json(DATA["rows"])
    mb = DATA["rows"]["multibody"]["2"]
    assert rows.multibody["2"].collision_force_N["A"].peak == mb["collision_force_N"]["A"]["peak"]
    assert rows.multibody["2"].load_moment_Nm["left"].rms == mb["load_moment_Nm"]["left"]["rms"]
    assert rows.mlsd["1"].load_moment_Nm["right"].mean == DATA["rows"]["mlsd"]["1"]["load_moment_Nm"]["right"]["mean"]
    assert rows.starts["1"].pairs["B"].peak.values == DATA["rows"]["starts"]["1"]["pairs"]["B"]["peak"]["values"]
    assert rows.model_check.pairs["C"].a["p95"].n == 8 and rows.model_check.starts.multibody == 8
    assert rows.agreement["2"]["C"].verdict == DATA["rows"]["agreement"]["2"]["C"]["verdict"]
    ag = ModelAgreement.from_json(DATA["agreement"])
    assert ag.pairs["A"].peak_N.reduced == DATA["agreement"]["pairs"]["A"]["peak_N"]["reduced"]


@pytest.mark.parametrize("path", [("rows", "wrong"), ("rows", "multibody", "1", "wrong"),
                                  ("rows", "multibody", "1", "collision_force_N", "A", "wrong"),
                                  ("rows", "starts", "2", "pairs", "A", "peak", "wrong"),
                                  ("rows", "model_check", "pairs", "F", "wrong"),
                                  ("rows", "agreement", "1", "A", "wrong"),
                                  ("agreement", "pairs", "B", "statistics", "wrong")])
def test_an_unknown_key_is_refused_naming_it(path):
    data = copy.deepcopy(DATA)
    d = data
    for k in path[:-1]:
        d = d[k]
    d[path[-1]] = 1.0
    cls = ClearanceRows if path[0] == "rows" else ModelAgreement
    with pytest.raises(pydantic.ValidationError, match=path[-1]):
        cls.from_json(data[path[0]])


def test_a_missing_field_or_a_wrong_type_is_refused():
    row = copy.deepcopy(DATA["rows"]["multibody"]["1"])
    del row["pair_state"]
    with pytest.raises(pydantic.ValidationError, match="pair_state"):
        MultibodyRow.from_json(row)
    row = copy.deepcopy(DATA["rows"]["multibody"]["1"])
    row["steps"] = "many"
    with pytest.raises(pydantic.ValidationError, match="steps"):
        MultibodyRow.from_json(row)


def test_a_drive_without_a_reduced_model_writes_no_model_check_nor_agreement():
    rows = ClearanceRows.from_json({k: DATA["rows"][k] for k in ("multibody", "starts")} | {"mlsd": {}})
    assert rows.model_check is None and rows.agreement is None
    assert list(rows.to_json()) == ["multibody", "mlsd", "starts"]


def _runs(scale, n=4):
    return [{"collision_force_N": {p: {k: v * scale * (1 + 0.01 * i) for k, v in
                                       {"peak": 900.0, "mean": 100.0, "rms": 200.0, "p95": 400.0}.items()}
                                   for p in "AB"}} for i in range(n)]


def test_the_lower_layers_dicts_read_as_the_records():
    """What berryshaker.experiment.agreement and row_start_statistics give the step reads back unchanged."""
    check = {"level": 2, **model_check(_runs(1.0), _runs(1.05), ("A", "B"))}
    assert ModelCheck.from_json(check).to_json() == check
    a, b = {"mean": 100.0, "rms": 200.0, "p95": 400.0}, {"mean": 101.0, "rms": 230.0, "p95": 400.0}
    for noise in (None, {"mean": 0.01, "rms": 0.02, "p95": 0.1}):
        ag = summary_statistics_agreement(a, b, noise=noise)
        assert RowAgreement.from_json(ag).to_json() == ag
    assert "noise" not in RowAgreement.from_json(summary_statistics_agreement(a, b)).to_json()
    runs = _runs(1.0, n=6)
    runs[4] = None  # a failed start: None in its row's values
    st = row_start_statistics(runs, ("A", "B"), [1, 2], 3)
    assert all(isinstance(v, RowStarts) for v in st.values())
    assert st["2"].pairs["A"].peak.values[1] is None and st["2"].starts == 2
    assert RowStarts.from_json(st["1"].to_json()) == st["1"]
