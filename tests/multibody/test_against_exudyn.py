"""Regression tests of issue "never compute on a misread input" (items 3-5): every value a simulation would
refuse is refused when the description is loaded or validated, with the field named; plausibility warnings;
the run-size caps and the multibody step budget; sweep value lists with the key's dimension."""

from __future__ import annotations

import json
import math
import re

import pytest
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.config import load_machine, machine_warnings, reference_toml_text, validate_machine
from berryshaker.errors import ConfigError, SimulationError

runner = CliRunner()


def set_value(text: str, section: str, key: str, value: str) -> str:
    """The TOML text with ``key`` of ``[section]`` set to the TOML literal ``value`` (added if absent)."""
    out, current, done = [], None, False
    lines = text.splitlines()
    for i, line in enumerate(lines):
        m = re.match(r"^\[([^\]]+)\]", line)
        if m:
            if current == section and not done:
                out.append(f"{key} = {value}")
                done = True
            current = m.group(1)
        if current == section and re.match(rf"^{re.escape(key)}\s*=", line):
            line, done = f"{key} = {value}", True
        out.append(line)
    if current == section and not done:
        out.append(f"{key} = {value}")
        done = True
    assert done, (section, key)
    return "\n".join(out) + "\n"


def mutated(tmp_path, section, key, value, drive="groove_cam"):
    p = tmp_path / "machine.toml"
    p.write_text(set_value(reference_toml_text(drive), section, key, value), encoding="utf-8")
    return p


def refused(tmp_path, section, key, value, drive="groove_cam") -> str:
    """load + validate must raise ConfigError/GeometryError; `config validate` must exit 2 without a traceback;
    returns the message."""
    from berryshaker.errors import BerryshakerError

    p = mutated(tmp_path, section, key, value, drive)
    with pytest.raises(BerryshakerError) as exc:
        validate_machine(load_machine(p))
    r = runner.invoke(app, ["config", "validate", str(p)])
    assert r.exit_code == 2, r.output
    assert "Traceback" not in r.output
    return str(exc.value)


# ---- item 1: validation is complete ---------------------------------------------------------------------
@pytest.mark.parametrize("value", ["inf", "-inf", "nan", '"inf N/m"', '"1e400 N/m"'])
def test_infinite_stiffness_is_refused(tmp_path, value):
    assert "clearance.A.stiffness" in refused(tmp_path, "clearance.A", "stiffness", value)


@pytest.mark.parametrize("section,key", [
    ("clearance.A", "stiffness"),  # quantity
    ("push_rod", "friction_coefficient"),  # dimensionless quantity
    ("clearance.A", "exponent"),  # plain float
    ("harvest", "seed"),  # int
    ("harvest", "bushes"),  # int with a bound
    ("harvest", "damage_acceleration"),  # float(v) before-validator
    ("plant.contact", "stiffness"),  # optional float(v)
    ("plant.contact", "n_modes"),  # int
    ("four_bar", "branch"),  # Literal[-1, 1]: true == 1 in Python
    ("harvest", "fruit_mass_cv"),
])
def test_true_is_not_a_number(tmp_path, section, key):
    msg = refused(tmp_path, section, key, "true")
    assert f"{section}.{key}" in msg and ("bool" in msg)


def test_true_inside_a_list_of_numbers(tmp_path):
    msg = refused(tmp_path, "harvest", "branch_classes", "[1.0, true]")
    assert "harvest.branch_classes" in msg and "item 2" in msg


@pytest.mark.parametrize("value", ["[1, 2]", "{ a = 1 }", "[]", '"forty"'])
@pytest.mark.parametrize("section,key", [("cam", "stroke"), ("harvest", "damage_acceleration"),
                                         ("clearance.C", "restitution"), ("harvest", "bushes")])
def test_list_or_table_where_a_number_belongs(tmp_path, section, key, value):
    assert f"{section}.{key}" in refused(tmp_path, section, key, value)


@pytest.mark.parametrize("value", ["[]", "[-1.0, 1.0]", "[0.0]"])
def test_branch_classes_empty_or_not_positive(tmp_path, value):
    assert "harvest.branch_classes" in refused(tmp_path, "harvest", "branch_classes", value)


def test_negative_seed(tmp_path):
    assert "harvest.seed" in refused(tmp_path, "harvest", "seed", "-5")


def test_fruit_zone_reversed(tmp_path):
    assert "harvest.fruit_zone" in refused(tmp_path, "harvest", "fruit_zone", "[0.9, 0.1]")


@pytest.mark.parametrize("drive,pair", [("groove_cam", "A"), ("groove_cam", "C"), ("crank_rocker", "crank_pin")])
def test_clearance_larger_than_the_geometry_allows(tmp_path, drive, pair):
    msg = refused(tmp_path, f"clearance.{pair}", "size", '"50 mm"', drive)
    assert f"clearance.{pair}.size" in msg and "larger than the geometry allows" in msg
    assert "(top level)" not in msg
    r = runner.invoke(app, ["config", "validate", str(tmp_path / "machine.toml")])
    assert f"clearance.{pair}.size" in r.output


@pytest.mark.parametrize("value", ['"1e-30 mm"', '"1e-12 mm"', '"5 mm"'])
def test_shaft_D_on_the_roller_path_is_named(tmp_path, value):
    """A drop of 1e-30 mm divided by zero in the kinematics; closer than the roller radius is refused."""
    assert "rocker.shaft_D_drop" in refused(tmp_path, "rocker", "shaft_D_drop", value)


@pytest.mark.parametrize("value", ['"1e9 rpm"', '"1e-6 rpm"', '"0.5 rpm"', '"2e5 rpm"', "1e-300"])
def test_extreme_drive_speeds(tmp_path, value):
    assert "cam.speed" in refused(tmp_path, "cam", "speed", value)


@pytest.mark.parametrize("value", ['"1e9 rpm"', '"1e-6 rpm"'])
def test_extreme_crank_speeds(tmp_path, value):
    assert "crank.speed" in refused(tmp_path, "crank", "speed", value, drive="crank_rocker")


def test_speed_limits_keep_the_reference_speeds():
    for drive in ("groove_cam", "crank_rocker"):
        assert validate_machine(load_machine(None, drive)) == [], drive  # no refusal and no warning


def test_non_utf8_file_is_a_config_error(tmp_path):
    p = tmp_path / "latin1.toml"
    p.write_bytes(reference_toml_text().replace("reference harvester", "Erntemaschine für Heidelbeeren")
                  .encode("latin-1"))
    with pytest.raises(ConfigError, match="not UTF-8"):
        load_machine(p)
    r = runner.invoke(app, ["config", "validate", str(p)])
    assert r.exit_code == 2 and "UTF-8" in r.output


def test_output_samples_are_capped_before_allocating():
    from berryshaker.multibody.engine import MAX_OUTPUT_SAMPLES, check_output_samples

    assert check_output_samples(1.5, 1e-4) == 15001
    # simulate -n 100000000 at 120 rpm: 5e7 s of output every 0.1 ms (3.6 TiB)
    with pytest.raises(ConfigError, match="fewer --revolutions") as exc:
        check_output_samples(1e8 * 0.5, 1e-4, "use fewer --revolutions")
    assert f"{MAX_OUTPUT_SAMPLES:,}" in str(exc.value)
    for bad in (math.inf, math.nan, 0.0, -1.0, True):
        with pytest.raises(ConfigError):
            check_output_samples(bad, 1e-4)


def test_mechanism_cli_with_a_huge_duration_is_refused():
    r = runner.invoke(app, ["simulate", "--mechanism", "examples/slider_crank_clearance.toml", "--duration", "1e9"])
    assert r.exit_code == 2 and "output samples" in r.output, r.output


# ---- item 2: plausibility warnings and the step budget ---------------------------------------------------
def test_reference_machines_have_no_warnings():
    for drive in ("groove_cam", "crank_rocker"):
        assert machine_warnings(load_machine(None, drive)) == []


@pytest.mark.parametrize("section,key,value,field", [
    ("clearance.A", "damping", '"2e9 N*s/m"', "clearance.A.damping"),  # x 1e6
    ("cam", "base_radius", '"80 km"', "cam.base_radius"),  # x 1e6
    ("combs", "left_mass", '"6 t"', None),  # 6000 kg: in range, no warning
    ("clearance.C", "stiffness", '"5e7 kN/mm"', "clearance.C.stiffness"),
])
def test_implausible_values_warn_or_are_refused(tmp_path, section, key, value, field):
    from berryshaker.errors import BerryshakerError

    p = mutated(tmp_path, section, key, value)
    try:
        m = load_machine(p)
        warnings = validate_machine(m)
    except BerryshakerError as exc:  # refused outright is fine too, with the field named
        assert field is not None and field in str(exc)
        return
    if field is None:
        assert warnings == []
        return
    assert any(w.startswith(field) for w in warnings), warnings
    with pytest.raises(ConfigError, match="--strict"):
        validate_machine(m, strict=True)


def test_step_budget_stops_a_run_with_a_clear_error():
    from berryshaker.multibody.engine import default_step_budget, simulate_mechanism
    from berryshaker.multibody.spec import load_mechanism

    spec = load_mechanism("examples/slider_crank_clearance.toml")
    with pytest.raises(SimulationError, match="max_steps") as exc:
        simulate_mechanism(spec, duration=0.2, max_steps=50)
    assert "budget of 50" in str(exc.value)
    assert default_step_budget(1.5) == 1_500_000 and default_step_budget(1e-3) == 200_000


def test_step_budget_does_not_touch_a_sound_run():
    from berryshaker.multibody.engine import simulate_mechanism
    from berryshaker.multibody.spec import load_mechanism

    spec = load_mechanism("examples/slider_crank_clearance.toml")
    r = simulate_mechanism(spec, duration=0.05)
    assert r.info[4] == 0 and r.info[0] > 0 and len(r.t) == round(0.05 / spec.simulation.output_step) + 1


# ---- item 3: sweeps --------------------------------------------------------------------------------------
def test_sweep_values_take_the_dimension_of_the_key():
    from berryshaker.config import reference_machine
    from berryshaker.runs.sweep import parse_param

    m = reference_machine()
    with pytest.raises(ConfigError, match="wrong kind of unit"):
        parse_param("cam.speed=100,120kg", m)
    p = parse_param("cam.speed=100,120rpm", m)
    assert p.kind == "levels" and p.unit == "rpm" and p.values == (100.0, 120.0)
    assert p.factor == pytest.approx(2 * math.pi / 60)
    p = parse_param("clearance.A.size=0.25mm+-0.05mm", m)
    assert (p.kind, p.values, p.unit) == ("normal", (0.25, 0.05), "mm")
    p = parse_param("clearance.A.size=0.1mm..0.3mm", m)
    assert (p.kind, p.values, p.factor) == ("range", (0.1, 0.3), 1e-3)
    assert parse_param("cam.speed=2Hz,3Hz", m).factor == pytest.approx(2 * math.pi)  # Hz = rev/s
    with pytest.raises(ConfigError, match="no unit"):
        parse_param("cam.rise_angle=100,120", m)  # angles need units
    assert parse_param("push_rod.friction_coefficient=0.05,0.1", m).unit == ""
    for bad, what in [("cam.nope=1", "no 'nope'"), ("clearance.Z.size=1mm", "clearance.Z"),
                      ("machine.name=1", "cannot be swept"), ("harvest.branch_classes=1,2", "cannot be swept"),
                      ("cam.speed", "expected"), ("clearance.A.size=0.3..0.1mm", "LO < HI")]:
        with pytest.raises(ConfigError, match=re.escape(what)):
            parse_param(bad, m)


def test_sweep_refuses_a_key_twice_and_zero_workers():
    r = runner.invoke(app, ["sweep", "--param", "cam.speed=100,120rpm", "--param", "cam.speed=130rpm"])
    assert r.exit_code == 2 and "twice" in r.output
    r = runner.invoke(app, ["sweep", "--param", "cam.speed=100,120rpm", "--workers", "0"])
    assert r.exit_code == 2 and "--workers" in r.output
    r = runner.invoke(app, ["sweep", "--param", "cam.speed=100,120kg"])
    assert r.exit_code == 2 and "cam.speed" in r.output
    for kernel in ("--specialised", "--generic"):  # default --model mlsd
        r = runner.invoke(app, ["sweep", "--param", "cam.speed=100,120rpm", kernel])
        assert r.exit_code == 2 and "--model multibody" in r.output


def test_a_bad_kernel_choice_in_the_environment_is_named_before_any_work(monkeypatch):
    import berryshaker.runs.runner as rr

    monkeypatch.setattr(rr.SweepRunner, "map", lambda *a, **k: pytest.fail("the runner must not start"))
    monkeypatch.setenv("BERRYSHAKER_KERNEL", "fastest")
    r = runner.invoke(app, ["sweep", "--param", "cam.speed=100,120rpm"])
    assert r.exit_code == 2 and "BERRYSHAKER_KERNEL='fastest'" in r.output and "unset it" in r.output


def test_sweep_validates_every_point_before_running(monkeypatch):
    import berryshaker.runs.runner as rr

    def no_run(*a, **k):
        raise AssertionError("the runner must not start")

    monkeypatch.setattr(rr.SweepRunner, "map", no_run)
    r = runner.invoke(app, ["sweep", "--param", "clearance.A.size=0.1,50mm", "--param", "cam.speed=1e-6,120rpm"])
    assert r.exit_code == 2, r.output
    assert "nothing was run" in r.output and "clearance.A.size" in r.output and "cam.speed" in r.output
    r = runner.invoke(app, ["sweep", "--param", "clearance.A.size=0.1..0.2mm", "--points", "1000",
                            "--param", "clearance.B.size=0.1..0.2mm"])
    assert r.exit_code == 2 and "100,000" in r.output


def test_sweep_table_headers_are_not_truncated(tmp_path):
    r = runner.invoke(app, ["sweep", "--param", "clearance.A.size=0.1mm", "--revolutions", "2",
                            "--cache", str(tmp_path / "c")])
    assert r.exit_code == 0, r.output
    assert "…" not in r.output  # folded, not cut
    assert "[mm]" in r.output  # not eaten as rich markup
    r = runner.invoke(app, ["sweep", "--param", "clearance.A.size=0.1mm", "--revolutions", "2", "--json",
                            "--cache", str(tmp_path / "c")])
    assert json.loads(r.stdout)["columns"][1] == "clearance.A.size[mm]"


# ---- wiring in the command line (cli/machine.py and cli/simulate.py): each fails if its wiring is removed ----
def test_config_validate_prints_warnings_and_strict_refuses(tmp_path):
    p = mutated(tmp_path, "clearance.A", "damping", '"2e9 N*s/m"')
    r = runner.invoke(app, ["config", "validate", str(p)])
    assert r.exit_code == 0 and "clearance.A.damping" in r.output and "warning" in r.output
    r = runner.invoke(app, ["config", "validate", "--strict", str(p)])
    assert r.exit_code == 2 and "clearance.A.damping" in r.output
    r = runner.invoke(app, ["config", "validate", "--json", str(p)])
    assert r.exit_code == 0 and json.loads(r.stdout)["warnings"]


def test_simulate_with_absurd_revolutions_is_refused_before_allocating():
    r = runner.invoke(app, ["simulate", "-n", "100000000"])
    assert r.exit_code == 2 and "fewer --revolutions" in r.output
