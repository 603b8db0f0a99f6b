"""The published record (harvest/published/record.toml, issue #43): it parses, every number has a unit that
reads through berryshaker.units, a citation (or declared gaps) and a confidence, ids are unique, ranges are
consistent, and the loader refuses a broken file.  Expected values below are the numbers as printed in the
sources (docs/published_record.md), not results of a run.
"""

from __future__ import annotations

import math
import shutil
import tomllib
from pathlib import Path

import pytest

from berryshaker.errors import ConfigError
from berryshaker.harvest.published_record import (
    CITATION_FIELDS,
    COLUMNS,
    CONFIDENCE,
    TOPICS,
    default_path,
    load_record,
    load_sources,
)


@pytest.fixture(scope="module")
def record():
    return load_record()


@pytest.fixture(scope="module")
def raw():
    with open(default_path(), "rb") as handle:
        return tomllib.load(handle)


def test_file_is_packaged_and_parses(record):
    assert default_path().name == "record.toml"
    assert default_path().is_file()
    assert list(record.columns) == list(COLUMNS)
    assert len(record) >= 30


def test_ids_unique(record, raw):
    ids = [entry["id"] for entry in raw["entry"]]
    assert len(ids) == len(set(ids))
    assert record.index.is_unique


def test_every_entry_has_unit_dimension_confidence_and_known_source(record, raw):
    sources = raw["sources"]
    for row in record.itertuples():
        assert row.quantity.strip()
        assert row.topic in TOPICS
        assert row.confidence in CONFIDENCE
        assert row.source in sources
        assert row.where.strip(), row.id
        assert row.si_unit != "?", row.id
        # every dimensional number carries a unit; only dimensionless ratios may have none
        if row.dimension != "dimensionless":
            assert row.unit.strip(), row.id


def test_every_citation_is_complete_or_declares_its_gaps(raw):
    for key, source in raw["sources"].items():
        gaps = " ".join(source.get("citation_gaps", []))
        for field in CITATION_FIELDS:
            value = source.get(field)
            if value in (None, "", 0):
                assert field in gaps, f"{key}: {field} empty and not declared"
        assert source.get("doi") or source.get("url") or "url" in gaps, key
        assert source.get("read", "").strip(), f"{key}: say what was read"


def test_citations_are_full_where_peer_reviewed_sources_were_seen():
    sources = load_sources()
    for key in ("kong2014", "brown1996", "malladi2013", "zhou2016", "tu2024", "moggia2017"):
        src = sources[key]
        assert src["authors"] and src["year"] and src["title"] and src["journal"], key
        assert src["citation"].count(".") >= 3


def test_values_and_ranges_consistent(record):
    for row in record.itertuples():
        has_value = not math.isnan(row.value)
        has_range = not math.isnan(row.range_low) and not math.isnan(row.range_high)
        assert has_value or has_range, row.id
        if not math.isnan(row.range_low) and not math.isnan(row.range_high):
            assert row.range_low <= row.range_high, row.id
        if has_value and not math.isnan(row.range_low):
            assert row.range_low <= row.value, row.id
        if has_value and not math.isnan(row.range_high):
            assert row.value <= row.range_high, row.id
        if not math.isnan(row.sd):
            assert row.sd >= 0
        if row.n is not None:
            assert isinstance(row.n, int) and row.n >= 1


def test_si_values_follow_the_units(record):
    # closed forms: 1 % = 0.01, 1 kg/min = 1/60 kg/s, 1 lb = 0.45359237 kg, 1 mm = 1e-3 m
    assert record.loc["machine.gyl062.hunau2014.green_drop", "value_si"] == pytest.approx(0.056)
    assert record.loc["machine.gyl062.hunau2014.efficiency", "value_si"] == pytest.approx(7.17 / 60)
    assert record.loc["yield.highbush.bush_season.extension2013", "value_si"] == pytest.approx(5 * 0.45359237)
    assert record.loc["bruise.drop_threshold.hard.brown1996", "value_si"] == pytest.approx(0.150)
    assert record.loc["freq.bluecrop.suitable.hunau2014", "value_si"] == pytest.approx(24.0)
    assert record.loc["freq.bluecrop.suitable.hunau2014", "si_unit"] == "rad/s"


def test_bond_forces_as_printed(record):
    pull = record.loc["bond.ripe.tensile.kong2014.blue5d"]
    shear = record.loc["bond.ripe.shear.kong2014.blue5d"]
    assert (pull.value, pull.range_low, pull.range_high) == (0.47, 0.44, 0.53)
    assert (shear.value, shear.range_low, shear.range_high) == (0.23, 0.22, 0.25)
    assert pull.conditions["loading_mode"] == "tensile" and shear.conditions["loading_mode"] == "shear"
    unripe = record.loc["bond.unripe.lyu2024.Fb"]
    assert (unripe.range_low, unripe.range_high) == (1.0, 3.6)
    # the unripe bracket lies above every ripe number
    ripe = record[(record.topic == "bond_force") & (record.si_unit == "N") & ~record.index.str.contains("unripe")]
    assert ripe[["value_si", "range_high_si"]].max().max() < unripe.range_low_si


def test_secondary_and_unverified_say_where_from(record):
    for row in record.itertuples():
        if row.confidence == "secondary":
            assert row.quoted_by.strip(), row.id
        if row.confidence == "unverified":
            assert row.note.strip(), row.id


def test_each_topic_present(record):
    assert set(record.topic) == set(TOPICS)


def _copy(tmp_path: Path) -> Path:
    target = tmp_path / "record.toml"
    shutil.copyfile(default_path(), target)
    return target


def test_loader_refuses_inconsistent_range(tmp_path):
    path = _copy(tmp_path)
    text = path.read_text(encoding="utf-8").replace("value = 0.47\nrange_low = 0.44", "value = 0.40\nrange_low = 0.44")
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError, match="value 0.4 < range_low 0.44"):
        load_record(path)


def test_loader_refuses_wrong_unit(tmp_path):
    path = _copy(tmp_path)
    text = path.read_text(encoding="utf-8").replace('unit = "mm"\ndimension = "length"\nstatistic = "threshold"',
                        'unit = "N"\ndimension = "length"\nstatistic = "threshold"')
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError, match="bruise.drop_threshold.hard.brown1996"):
        load_record(path)


def test_loader_refuses_duplicate_id_and_missing_source(tmp_path):
    path = _copy(tmp_path)
    text = path.read_text(encoding="utf-8")
    text = text.replace('id = "bond.ripe.shear.kong2014.blue5d"', 'id = "bond.ripe.tensile.kong2014.blue5d"')
    text = text.replace('source = "zhou2016"\nwhere = "abstract"\nconfidence = "checked"\nnote = "Eighteen',
                        'source = "nobody2099"\nwhere = "abstract"\nconfidence = "checked"\nnote = "Eighteen')
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError) as info:
        load_record(path)
    assert "duplicate id" in str(info.value) and "nobody2099" in str(info.value)


def test_loader_refuses_undeclared_citation_gap(tmp_path):
    path = _copy(tmp_path)
    text = path.read_text(encoding="utf-8").replace('journal = "Biosystems Engineering"', 'journal = ""')
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError, match="zhou2016: journal is empty"):
        load_sources(path)


def test_loader_refuses_unknown_confidence_and_schema(tmp_path):
    path = _copy(tmp_path)
    text = path.read_text(encoding="utf-8").replace('confidence = "unverified"', 'confidence = "probably"', 1)
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError, match="probably"):
        load_record(path)
    path.write_text(text.replace("schema = 1", "schema = 2"), encoding="utf-8")
    with pytest.raises(ConfigError, match="schema"):
        load_record(path)
