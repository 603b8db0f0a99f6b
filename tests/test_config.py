"""Machine description (units, validation) and the kinematics / config / cam-profile commands."""

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.config import load_machine, machine_from_dict
from berryshaker.errors import ConfigError
from berryshaker.units import parse_quantity

runner = CliRunner()


def test_units_parse_to_si():
    assert parse_quantity("0.25 mm", "length") == pytest.approx(2.5e-4)
    assert parse_quantity("120 rpm", "angular_speed") == pytest.approx(4 * math.pi)
    assert parse_quantity("120 r/min", "angular_speed") == pytest.approx(4 * math.pi)
    assert parse_quantity("1.1 GPa", "pressure") == pytest.approx(1.1e9)
    assert parse_quantity("30 m/min", "speed") == pytest.approx(0.5)
    assert parse_quantity("120 deg", "angle") == pytest.approx(2 * math.pi / 3)
    assert parse_quantity(0.003, "length") == 0.003
    with pytest.raises(ConfigError, match="wrong kind of unit"):
        parse_quantity("0.25 mm", "stiffness")
    with pytest.raises(ConfigError, match="cannot read"):
        parse_quantity("12 parsecs-ish", "length")


def test_reference_machine_values(machine):
    assert machine.cam.base_radius == pytest.approx(0.08)
    assert machine.cam.speed == pytest.approx(4 * math.pi)
    assert machine.cam.inertia == pytest.approx(0.0176)  # [study]
    assert machine.clearance["A"].size == pytest.approx(0.25e-3)


def _kin(args, **kw):
    return runner.invoke(app, args, **kw)


@pytest.mark.parametrize("mutate,needle", [
    (lambda d: d["cam"].pop("stroke"), "cam.stroke: missing value"),
    (lambda d: d["cam"].__setitem__("stroke", "-40 mm"), "cam.stroke: must be > 0"),
    (lambda d: d["cam"].__setitem__("base_radius", "80 bogounits"), "cam.base_radius"),
    (lambda d: d["clearance"]["A"].__setitem__("stiffness", "3 mm"), "clearance.A.stiffness"),
    (lambda d: d["cam"].__setitem__("rise_angle", "100 deg"), "must be 360 deg"),
    (lambda d: d["cam"].__setitem__("colour", "red"), "cam.colour: unknown key"),
])
def test_bad_values_give_one_clear_message(machine_dict, write_toml, tmp_path, mutate, needle):
    mutate(machine_dict)
    p = write_toml(machine_dict)
    with pytest.raises(ConfigError, match="invalid machine description") as exc:
        load_machine(p)
    assert needle in str(exc.value)
    plot_dir = tmp_path / "plots"
    r = _kin(["kinematics", "--config", str(p), "--plot", str(plot_dir)])
    assert r.exit_code == 2
    assert needle in r.stderr
    assert "Traceback" not in r.output + r.stderr
    assert not plot_dir.exists()


def test_linkage_that_cannot_assemble_names_the_cam_angle(machine_dict, write_toml, tmp_path):
    machine_dict["four_bar"]["coupler_CF"] = "1035 mm"  # just too long at part of the cycle
    p = write_toml(machine_dict)
    r = _kin(["kinematics", "--config", str(p), "--plot", str(tmp_path / "out")])
    assert r.exit_code == 2
    assert "cannot assemble at cam angle" in r.stderr
    assert not (tmp_path / "out").exists()


def test_undercutting_cam_names_the_cam_angle(machine_dict, write_toml):
    machine_dict["cam"]["roller_radius"] = "85 mm"
    p = write_toml(machine_dict)
    r = _kin(["kinematics", "--config", str(p)])
    assert r.exit_code == 2 and "undercuts at cam angle" in r.stderr
    r = _kin(["kinematics", "--config", str(p), "--json", "--allow-undercut"])
    assert r.exit_code == 0 and json.loads(r.stdout)["cam"]["undercut"] is True


def test_kinematics_json_matches_closed_form(tmp_path):
    r = _kin(["kinematics", "--json", "--plot", str(tmp_path / "plots")])
    assert r.exit_code == 0, r.output
    s = json.loads(r.stdout)
    h, d, w = 0.04, 2 * math.pi / 3, 4 * math.pi
    # 3-4-5 law peaks (Norton 2009): v = 15/8 h w / d, a = 10/sqrt(3) h w^2/d^2, j = 60 h w^3/d^3
    assert s["cam"]["max_velocity_m_s"] == pytest.approx(15 / 8 * h * w / d, rel=1e-9)
    assert s["cam"]["max_acceleration_m_s2"] == pytest.approx(10 / math.sqrt(3) * h * w**2 / d**2, rel=1e-5)
    assert s["cam"]["max_jerk_m_s3"] == pytest.approx(60 * h * w**3 / d**3, rel=1e-9)
    assert s["cam"]["stroke_mm"] == pytest.approx(40.0)
    assert s["cam"]["undercut"] is False
    assert s["cam"]["min_radius_of_curvature_mm"] > 15
    for side in ("left", "right"):
        sw = s["combs"][side]["swing_deg"]
        assert 8.0 < sw["max"] < 10.0 and -10.0 < sw["min"] < -8.0
        assert s["combs"][side]["max_tip_speed_m_s"] > 0
        assert s["combs"][side]["max_tip_acceleration_m_s2"] > 0
    ta = s["linkage"]["transmission_angle_deg"]
    assert 80 <= ta["min"] and ta["max"] <= 98.5
    assert s["drive"]["cam_speed_rpm"] == pytest.approx(120)
    assert s["drive"]["comb_frequency_hz"] == pytest.approx(2.0)
    for name in ("svaj.png", "groove_profile.png", "comb_angles.png"):
        assert (tmp_path / "plots" / name).stat().st_size > 10_000
    prov = json.loads((tmp_path / "plots" / "provenance.json").read_text())
    assert prov["version"] and prov["machine_si"]["cam"]["stroke"] == pytest.approx(0.04)


def test_cam_profile_exports(tmp_path):
    import ezdxf

    r = _kin(["cam-profile", "--format", "dxf", "--out", str(tmp_path / "g.dxf")])
    assert r.exit_code == 0, r.output
    doc = ezdxf.readfile(tmp_path / "g.dxf")
    polys = {e.dxf.layer: e for e in doc.modelspace().query("LWPOLYLINE")}
    assert set(polys) == {"PITCH", "INNER_WALL", "OUTER_WALL", "INNER_WALL_MIN", "OUTER_WALL_MIN",
                          "INNER_WALL_MAX", "OUTER_WALL_MAX"}
    assert all(p.closed for p in polys.values())
    # the groove carries the running clearance (A = 0.25 mm free travel, no fit: an H8-wide band of 33 um above it)
    note = doc.modelspace().query("MTEXT")[0].text
    assert "running clearance (free travel) 0.250 .. 0.283 mm" in note and "H8" in note
    pitch = np.array(polys["PITCH"].get_points("xy"))
    for tag, width in (("", 30.2665), ("_MIN", 30.25), ("_MAX", 30.283)):
        inner, outer = (np.array(polys[f"{w}_WALL{tag}"].get_points("xy")) for w in ("INNER", "OUTER"))
        assert np.hypot(*(outer - inner).T) == pytest.approx(np.full(len(pitch), width), abs=1e-3)
    r = _kin(["cam-profile", "--format", "csv", "--out", str(tmp_path / "g.csv"), "--points", "361"])
    assert r.exit_code == 0
    lines = (tmp_path / "g.csv").read_text().splitlines()
    assert lines[0].startswith("cam_angle_deg,pitch_x_mm") and len(lines) == 362
    assert lines[0].endswith("width_min_mm,width_max_mm,running_clearance_min_mm,running_clearance_max_mm")
    assert [float(x) for x in lines[1].split(",")[-4:]] == pytest.approx([30.25, 30.283, 0.25, 0.283])
    first, last = lines[1].split(",")[1:], lines[-1].split(",")[1:]
    assert [float(a) for a in first] == pytest.approx([float(b) for b in last], abs=2e-6)  # closed (to 1 nm printed)


def test_cam_profile_groove_from_the_cam_pairs_fit(tmp_path):
    """With clearance.A.fit = "H8/f7" the groove is H8 on the 30 mm roller (0 .. +33 um) and the running clearance
    the fit's: 20 .. 74 um (ISO 286: f7 at 30 mm is -20/-41 um)."""
    from berryshaker.config import load_machine
    from berryshaker.life.drawing import groove_width

    m = load_machine(None)
    cl = dict(m.clearance)
    cl["A"] = cl["A"].model_copy(update={"fit": "H8/f7"})
    w = groove_width(m.model_copy(update={"clearance": cl}))
    assert (w.width_min, w.width_max) == pytest.approx((0.030, 0.030033))
    assert (w.clearance_min, w.clearance_max) == pytest.approx((20e-6, 74e-6))


def test_config_init_show_validate(tmp_path):
    p = tmp_path / "my.toml"
    assert _kin(["config", "init", str(p)]).exit_code == 0
    assert "[assumed]" in p.read_text() and "[study]" in p.read_text()
    assert _kin(["config", "init", str(p)]).exit_code == 2  # no silent overwrite
    r = _kin(["config", "validate", str(p), "--json"])
    assert r.exit_code == 0 and json.loads(r.stdout)["valid"] is True
    r = _kin(["config", "show", "--config", str(p)])
    assert r.exit_code == 0 and "80 mm" in r.stdout and "120 rpm" in r.stdout
    r = _kin(["config", "show", "--json"])
    assert json.loads(r.stdout)["machine_si"]["cam"]["base_radius"] == pytest.approx(0.08)


def test_machine_from_dict_roundtrip(machine):
    again = machine_from_dict(machine.model_dump())
    assert again == machine


def test_rich_tables_and_errors_print_brackets_as_written():
    """Provenance tags and lists are data, not rich markup: "[study]" must survive the terminal table."""
    from rich.console import Console

    from berryshaker.report.tables import rich_table

    con = Console(record=True, width=120)
    con.print(rich_table(["value [mm]", "tag"], [[0.25, "[study]"], [0.1, "[bold]x[/]"]], title="levels [mm]"))
    text = con.export_text()
    assert "[study]" in text and "value [mm]" in text and "[bold]x[/]" in text and "levels [mm]" in text


# ---- issue #42: nothing silently misread -------------------------------------------------------------------
@pytest.mark.parametrize("section,key,value,needle", [
    ("cam", "speed", 120, 'cam.speed: 120 is a bare number; give a unit, e.g. speed = "120 rpm"'),
    ("operation", "walking_speed", 30, 'walking_speed = "30 m/min"'),
    ("plant.fruit", "mass", 1.8, 'plant.fruit.mass: 1.8 is a bare number; give a unit, e.g. mass = "1.8 g"'),
    ("plant.contact", "penetration_depth", 0.1, '"100 mm"'),
    ("driveline.motor", "rated_power", 1.5, 'rated_power = "1.5 kW"'),
    ("driveline.motor", "rated_power", "1,5 kW", "not a comma"),
    ("driveline.motor", "rated_power", "1.5 kW * 1000", "cannot read '1.5 kW * 1000'"),
    ("push_rod", "friction_coefficient", 1e300, "push_rod.friction_coefficient"),
    ("harvest", "replicates", 9_200_000_000_000_000_000, "harvest.replicates: must be <= 1000"),
    ("clearance.C", "diameter", "1e308 m", "clearance.C.diameter: 1e+308 m is too large for a length"),
    ("clearance.C", "fit", "Z99/q1", "clearance.C: fit: tolerance class 'Z99'"),
])
def test_misreadings_are_errors_naming_the_field_and_the_fix(machine_dict, write_toml, section, key, value, needle):
    table = machine_dict
    for part in section.split("."):
        table = table[part]
    table[key] = value
    p = write_toml(machine_dict)
    with pytest.raises(ConfigError) as exc:
        load_machine(p)
    assert needle in str(exc.value)
    r = _kin(["config", "validate", str(p)])
    assert r.exit_code == 2 and needle in r.stderr and "Traceback" not in r.output


def test_bom_deep_nesting_and_huge_values(tmp_path):
    from berryshaker.config import reference_toml_text

    text = reference_toml_text()
    p = tmp_path / "bom.toml"
    p.write_bytes("\ufeff".encode() + text.encode())
    assert load_machine(p) == load_machine(None)
    p.write_text(text.replace('name = "berryshaker reference harvester"', "name = " + "[" * 5000 + "]" * 5000))
    with pytest.raises(ConfigError, match="nested too deeply"):
        load_machine(p)
    p.write_text(text.replace('material_pair = "steel-on-bronze-greased"', 'material_pair = "' + "x" * 100_000 + '"'))
    with pytest.raises(ConfigError) as exc:
        load_machine(p)
    assert len(str(exc.value)) < 1000


def test_json_output_never_writes_nan(capsys):
    from berryshaker.cli.app import _print_json

    _print_json({"a": 1.0, "b": [float("nan"), 2.0], "c": {"d": float("inf")}})
    out = json.loads(capsys.readouterr().out, parse_constant=lambda c: pytest.fail(c))
    assert out["b"] == [None, 2.0] and out["c"]["d"] is None
    assert set(out["null_values"]) == {"b[0]", "c.d"} and "not a finite number" in out["null_values"]["b[0]"]


def test_error_messages_print_user_text_as_written():
    r = _kin(["simulate", "--model", "mlsd", "--clearance",
              ":a:=0.25mm"])
    assert r.exit_code == 2 and ":a:" in r.stderr
