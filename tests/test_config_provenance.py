"""Provenance that tells the truth, and units on every printed value (#58).

A user who copies the template (``config init``) and edits values keeps the template's comments: the values
changed are the user's, not the study's.  The expected tags and printed values here are read from the template's
own text (its values and comments), not from the code that checks them.
"""

import json
import re

import pytest
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.config import load_machine, machine_table, reference_toml_text

runner = CliRunner()


def _set(text: str, section: str, key: str, value: str, comment: str | None = None) -> str:
    """``text`` with ``key`` of ``[section]`` set to ``value`` (its comment kept, or replaced by ``comment``)."""
    start = text.index(f"[{section}]\n")
    m = re.compile(rf"^{key}\s*=\s*(\"[^\"]*\"|\S+)(\s*#.*)?$", re.M).search(text, start)
    assert m, (section, key)
    tail = m.group(2) or "" if comment is None else f"  # {comment}"
    return text[:m.start()] + f'{key} = "{value}"{tail}' + text[m.end():]


def _show(path) -> dict:
    r = runner.invoke(app, ["config", "show", "--config", str(path), "--json"])
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout)["provenance"]


def test_values_edited_in_the_template_are_the_users(tmp_path):
    """#58: after editing my.toml (140 r/min, C 0.15 mm) config show called them [study]."""
    template = reference_toml_text()
    assert re.search(r'^speed = "120 rpm".*\[study', template, re.M)  # the template's tags, as shipped
    text = _set(_set(template, "cam", "speed", "140 rpm"), "clearance.C", "size", "0.15 mm")
    # a value the user changed and tagged with a comment of their own keeps their tag
    text = _set(text, "cam", "stroke", "42 mm", comment="h, measured on our machine [published: our rig, 2024]")
    # a value written again with the template's value keeps the template's tag
    text = _set(text, "clearance.B", "size", "0.2 mm")
    (tmp_path / "my.toml").write_text(text)
    tags = _show(tmp_path / "my.toml")
    assert tags["cam.speed"] == "user" and tags["clearance.C.size"] == "user"
    assert tags["cam.stroke"] == "published"
    assert tags["clearance.B.size"] == "study" and tags["clearance.A.size"] == "study"
    assert [k for k, t in tags.items() if t == "user"] == ["clearance.C.size", "cam.speed"]
    # the terminal table, the report's description table (machine_table) and the explorer say the same
    r = runner.invoke(app, ["config", "show", "--config", str(tmp_path / "my.toml")], env={"COLUMNS": "200"})
    assert re.search(r"cam\.speed\s+│\s+140 rpm\s+│\s+\[user\]", r.stdout)
    assert re.search(r"clearance\.C\.size\s+│\s+0\.15 mm\s+│\s+\[user\]", r.stdout)
    machine = load_machine(tmp_path / "my.toml")
    assert dict((k, t) for k, _v, t in machine_table(machine))["cam.speed"] == "user"
    from berryshaker.explore import model as em

    assert em.provenance_tag(machine, "clearance.C.size", set()) == "user"
    # the unedited template and a shipped example: nothing is the user's
    (tmp_path / "t.toml").write_text(template)
    assert "user" not in _show(tmp_path / "t.toml").values()


def test_every_printed_value_has_its_unit():
    """#58: config show printed clearance.C.diameter 0.02 and the bush's ranges in SI without a unit.  Each value
    is printed as the template writes it (its own unit)."""
    rows = {k: v for k, v, _t in machine_table(load_machine(None))}
    template = reference_toml_text()
    c = template[template.index("[clearance.C]"):]
    assert re.search(r'^diameter = "20 mm"', c, re.M) and rows["clearance.C.diameter"] == "20 mm"
    assert re.search(r'^bearing_length = "25 mm"', c, re.M) and rows["clearance.C.bearing_length"] == "25 mm"
    assert rows["plant.bush.root_diameter"] == "(8, 16) mm" and rows["plant.bush.lean"] == "(0, 30) deg"
    assert rows["cam.speed"] == "120 rpm" and rows["harvest.fruit_zone"] == "(0.1, 0.95)"  # fractions: no unit
    number = re.compile(r"^-?[0-9.e+-]+$")
    bare = [k for k, v in rows.items() if number.match(v) and not _dimensionless(k)]
    assert not bare, f"printed without a unit: {bare}"


def _dimensionless(key: str) -> bool:
    from berryshaker.config import reference_machine
    from berryshaker.quantity_fields import field_display_unit, field_info_at

    try:
        return field_display_unit(field_info_at(type(reference_machine()), key)) in ("1", None)
    except Exception:  # noqa: BLE001 - a key inside a table of sections (clearance.<pair>): its field's unit
        section, _pair, name = key.rsplit(".", 2)
        from berryshaker.drives.base import ClearancePair

        return field_display_unit(ClearancePair.model_fields[name]) in ("1", None)


@pytest.mark.parametrize("drive_file", ["examples/crank_rocker_harvester.toml"])
def test_a_shipped_example_is_tagged_as_written(drive_file):
    from pathlib import Path

    path = Path(__file__).parents[1] / drive_file
    machine = load_machine(path)
    assert "user" not in {t for _k, _v, t in machine_table(machine)}
