"""The typed results of the study steps fruit_force, harvest_response, validation, clearance_life and powered_drive
(study/fruit_force_records.py, study/harvest_records.py, study/life_drive_records.py): a reference study's data
read back write the same JSON (keys, order, types), a key no record has is refused naming it, and the readers
(report sections, claims, tables) read the records by attribute."""

from __future__ import annotations

import json
from pathlib import Path

import pydantic
import pytest

from berryshaker.study.fruit_force_records import DrivePast, FruitForceStep, FruitPosition
from berryshaker.study.harvest_records import HarvestResponse, Validation
from berryshaker.study.life_drive_records import ClearanceLife, PoweredDrive
from berryshaker.study.step_result import StudyResults
from berryshaker.study.tables import strip_series

DATA = Path(__file__).parents[1] / "data"
#: a reference study's fruit_force (as summary.json has it: no plotted series) and validation data
HARVEST = json.loads((DATA / "harvest_step_results.json").read_text(encoding="utf-8"))
#: the same study's harvest_response, clearance_life and powered_drive data (the report's fixture)
SECTIONS = json.loads((DATA / "report_sections.json").read_text(encoding="utf-8"))

CASES = [("fruit_force", FruitForceStep, HARVEST), ("validation", Validation, HARVEST),
         ("harvest_response", HarvestResponse, SECTIONS), ("clearance_life", ClearanceLife, SECTIONS),
         ("powered_drive", PoweredDrive, SECTIONS)]


@pytest.mark.parametrize("name,record,source", CASES, ids=[c[0] for c in CASES])
def test_a_real_steps_data_round_trips_key_for_key(name, record, source):
    data = source[name]
    typed = record.from_json(data)
    assert isinstance(typed, record)
    assert json.dumps(typed.to_json()) == json.dumps(data)  # keys, their order and the numbers' types
    assert StudyResults.from_json({name: data}).to_json()[name] == data


@pytest.mark.parametrize("name,record,source", CASES, ids=[c[0] for c in CASES])
def test_an_unknown_key_is_refused_naming_it(name, record, source):
    with pytest.raises(pydantic.ValidationError, match="colour"):
        record.from_json({**source[name], "colour": "red"})


def test_nested_records_refuse_unknown_keys_and_wrong_types():
    ff = HARVEST["fruit_force"]
    pos = ff["chosen"]["summary"]["positions"]["root"]
    with pytest.raises(pydantic.ValidationError, match="shade"):
        FruitPosition.from_json({**pos, "shade": 1})
    with pytest.raises(pydantic.ValidationError, match="z_m"):
        FruitPosition.from_json({k: v for k, v in pos.items() if k != "z_m"})
    bad = json.loads(json.dumps(ff))
    bad["starts"]["chosen"]["positions"]["end"]["mean"] = "large"
    with pytest.raises(pydantic.ValidationError, match="mean"):
        FruitForceStep.from_json(bad)
    row = SECTIONS["powered_drive"]["levels"]["1"]
    with pytest.raises(pydantic.ValidationError, match="median"):
        PoweredDrive.from_json({**SECTIONS["powered_drive"],
                                "levels": {"1": {**row, "cam_speed_rpm": {**row["cam_speed_rpm"], "median": 1.0}}}})
    with pytest.raises(pydantic.ValidationError, match="summary"):
        Validation.from_json({k: v for k, v in HARVEST["validation"].items() if k != "summary"})


def test_the_plotted_series_are_optional_and_stripped_from_the_summary():
    """A drive-past's distance and force series are kept in the record (the figures read them) and left out of
    summary.json by strip_series, from which the record reads back without them."""
    chosen = HARVEST["fruit_force"]["chosen"]
    full = DrivePast.from_json({"summary": chosen["summary"], "distance": [-0.3, 0.0, 0.3],
                                "forces": {"root": [0.0, 0.07, 0.0]}, "peaks_exact": chosen["peaks_exact"]})
    assert list(full.to_json()) == ["summary", "distance", "forces", "peaks_exact"]
    step = FruitForceStep.from_json({**HARVEST["fruit_force"], "chosen": full.to_json()})
    res = StudyResults(fruit_force=step)
    saved = strip_series(res.to_json())
    assert "distance" not in saved["fruit_force"]["chosen"] and "forces" not in saved["fruit_force"]["chosen"]
    back = StudyResults.from_json(saved)
    assert back.fruit_force.chosen.distance is None and back.fruit_force.chosen.forces is None
    assert back.fruit_force == FruitForceStep.from_json(HARVEST["fruit_force"])


def test_the_readers_read_the_records(tmp_path):
    """Claims 5-6, the fruit-force table and the five report sections from the typed records."""
    from berryshaker.config import load_machine
    from berryshaker.report.sections import SectionInput
    from berryshaker.study import claims as C
    from berryshaker.study.steps.clearance_life import clearance_life_section
    from berryshaker.study.steps.fruit_force import fruit_force_section
    from berryshaker.study.steps.harvest_response import harvest_response_section
    from berryshaker.study.steps.powered_drive import powered_drive_section
    from berryshaker.study.steps.validation import validation_section
    from berryshaker.study.tables import write_tables

    res = StudyResults.from_json({**HARVEST, **SECTIONS, "rows": {"multibody": {}, "mlsd": {}, "starts": {}}, "l9": None})
    assert C._claim6(res) == ("not reproduced", "root: ripe left on the bush, unripe kept; middle: ripe left on "
                              "the bush, unripe kept; end: ripe picked, unripe kept")
    verdict, detail = C._claim5(res)
    assert verdict == "not reproduced" and detail.startswith("means over 8 perturbed starts (branch class x1)")
    machine = load_machine(None)
    write_tables(machine, res, tmp_path)
    assert (tmp_path / "fruit_force.csv").read_text().splitlines()[1].startswith("root,0.24,0.0735")
    inp = SectionInput(res, machine, tmp_path)
    _, parts = fruit_force_section(inp)
    assert "left on the bush" in parts[0] and "0.25-0.4" in parts[0]
    _, parts = validation_section(inp)
    assert "Held out: 9 numbers: 2 consistent, 5 not reproduced, 0 without a verdict, 2 not comparable" in parts[0] and "hunau2014" in parts[1]
    _, parts = harvest_response_section(inp)
    assert "12 branches (6 simulated members with 2 modes each, seed 12" in parts[0]
    assert any("branch E" in p for p in parts)
    _, parts = clearance_life_section(inp)
    assert "H11/c11" in parts[0]
    _, parts = powered_drive_section(inp)
    assert "+-" in parts[0] and "mean of 4 runs" in parts[1]
