"""Clearance-life commands and joint loads: fits, wear, limits; sliding speeds against finite differences of
the positions; the new ClearancePair fields leave the dynamics unchanged."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.config import load_machine
from berryshaker.errors import ConfigError

cli = CliRunner()


def test_fits_json():
    r = cli.invoke(app, ["fits", "H7/f7", "--diameter", "20mm", "--json"])
    assert r.exit_code == 0, r.output
    s = json.loads(r.stdout)
    assert s["clearance_min_mm"] == pytest.approx(0.020) and s["clearance_max_mm"] == pytest.approx(0.062)
    r = cli.invoke(app, ["fits", "H7/f7"])
    assert r.exit_code == 2


def test_parse_limit():
    from berryshaker.cli.life import parse_limit

    assert parse_limit("peak_force:A=8000N") == ("peak_force:A", 8000.0)
    assert parse_limit("clearance:C=0.5mm") == ("clearance:C", pytest.approx(5e-4))
    with pytest.raises(ConfigError):
        parse_limit("speed:C=3")
    with pytest.raises(ConfigError):
        parse_limit("clearance:C")


def test_wear_json(tmp_path):
    r = cli.invoke(app, ["wear", "--hours", "300", "--joint", "C", "--limit", "clearance:C=0.105mm",
                         "--cache", str(tmp_path), "--json"])
    assert r.exit_code == 0, r.output
    s = json.loads(r.stdout)
    c = s["joints"]["C"]
    assert c["hours"][0] == 0 and c["hours"][-1] == pytest.approx(300)
    assert np.all(np.diff(c["clearance_mm"]) >= 0) and c["clearance_mm"][0] == pytest.approx(0.1)
    assert 0 < c["maintenance_interval_h"] < 300
    assert s["joints"]["A"]["clearance_mm"][0] == s["joints"]["A"]["clearance_mm"][-1]  # A does not wear here
    assert s["simulations"] == len(c["hours"])
    again = json.loads(cli.invoke(app, ["wear", "--hours", "300", "--joint", "C", "--limit", "clearance:C=0.105mm",
                                        "--cache", str(tmp_path), "--json"]).stdout)
    assert again["simulations_from_cache"] == again["simulations"]
    assert again["joints"]["C"]["clearance_mm"] == c["clearance_mm"]


def test_sliding_speeds_match_finite_differences_of_positions():
    from berryshaker.drives.simulation import simulate_multibody
    from berryshaker.life.joint_loads import sliding_speed

    m = load_machine(None)
    res, _ = simulate_multibody(m, {"A": 0.0, "B": 0.0, "C": 0.0, "F": 0.0}, revolutions=2)  # ideal joints
    sel = slice(2000, -2000)
    bi = res.compiled.body_index
    t = res.t
    # pin C: |d/dt (phi_left_comb - phi_coupler)| * d / 2, from positions only
    dphi = np.gradient(res.y[:, 3 * bi["left_comb"] + 2] - res.y[:, 3 * bi["coupler"] + 2], t)
    assert sliding_speed(res, "C", 0.02)[sel] == pytest.approx(np.abs(dphi)[sel] * 0.01, rel=1e-3, abs=1e-5)
    # roller A: speed of the roller centre relative to the cam, in the cam's frame, from positions only
    spec = {j.name: j for j in res.compiled.spec.joints}["A"]
    q = lambda b, k: res.y[:, 3 * bi[b] + k]  # noqa: E731
    ph = q("push_rod", 2)
    px = q("push_rod", 0) + np.cos(ph) * spec.point_i[0] - np.sin(ph) * spec.point_i[1]
    py = q("push_rod", 1) + np.sin(ph) * spec.point_i[0] + np.cos(ph) * spec.point_i[1]
    pc = q("cam", 2)
    lx = np.cos(pc) * (px - q("cam", 0)) + np.sin(pc) * (py - q("cam", 1))
    ly = -np.sin(pc) * (px - q("cam", 0)) + np.cos(pc) * (py - q("cam", 1))
    vrel = np.hypot(np.gradient(lx, t), np.gradient(ly, t))
    assert sliding_speed(res, "A", 0.03, slip=1.0)[sel] == pytest.approx(vrel[sel], rel=1e-3, abs=1e-4)
    assert sliding_speed(res, "A", 0.03, slip=0.05)[sel] == pytest.approx(0.05 * vrel[sel], rel=1e-3, abs=1e-5)


def test_life_fields_do_not_change_the_dynamics():
    """The ISO fit never enters the dynamics; diameter, bearing_length and material_pair enter it only through
    the contact law resolved from them (docs/contact.md sec. 6), so with the stiffness given (here the 0.1.0
    linear springs) removing them changes nothing, and with the default law they set K and n."""
    from conftest import with_linear_springs

    from berryshaker.config import machine_from_dict
    from berryshaker.drives import drive_of

    m = load_machine(None)
    d = drive_of(m)
    no_fit = m.model_dump(mode="json")
    for pair in no_fit["clearance"].values():
        pair.pop("fit", None)
    assert d.mechanism(m, 2).model_dump() == d.mechanism(machine_from_dict(no_fit, "(test)"), 2).model_dump()
    m = with_linear_springs(m)
    data = m.model_dump(mode="json")
    assert data["clearance"]["C"]["fit"] == "H8/f7"
    for pair in data["clearance"].values():
        for k in ("fit", "diameter", "bearing_length", "material_pair"):
            pair.pop(k, None)
    bare = machine_from_dict(data, "(test)")
    assert bare.clearance["C"].diameter is None
    assert d.mechanism(m, 2).model_dump() == d.mechanism(bare, 2).model_dump()
    assert load_machine(None).pair_contact("C").stiffness != with_linear_springs(bare).pair_contact("C").stiffness
    with pytest.raises(ConfigError, match="material_pair"):
        from berryshaker.life.joint_loads import joint_geometry

        data["clearance"]["C"]["material_pair"] = "unobtainium"
        joint_geometry(machine_from_dict(data, "(test)"), "C")


# ---- issue 42: bad input is a message naming the flag, and --plot is a checked, staged destination ---------------
@pytest.mark.parametrize("args, flag", [
    (["wear", "--joint", "Z"], "--joint Z"),
    (["wear", "--joint", "C", "--joint", "C"], "--joint"),
    (["wear", "--hours", "inf"], "--hours"),
    (["sensitivity", "--seed", "-1"], "--seed -1"),
    (["sensitivity", "--samples", str(2**40)], "--samples"),
    (["tolerance", "--pop-size", "0"], "--pop-size 0"),
    (["tolerance", "--generations", "-1"], "--generations -1"),
    (["tolerance", "--points", "1000000000"], "--points"),
    (["tolerance", "--seed", "-5"], "--seed -5"),
])
def test_life_flags_out_of_range_are_one_message(args, flag, tmp_path):
    r = cli.invoke(app, args + ["--cache", str(tmp_path)])
    assert r.exit_code == 2, r.output
    assert r.exception is None or isinstance(r.exception, SystemExit), r.exception
    assert flag in r.output and "Traceback" not in r.output, r.output


def test_wear_from_fit_on_some_joints_prints_the_interval_and_plots(tmp_path):
    machine = tmp_path / "m.toml"
    assert cli.invoke(app, ["config", "init", str(machine)]).exit_code == 0
    plots = tmp_path / "plots"
    args = ["wear", "--config", str(machine), "--from-fit", "--joint", "C", "--hours", "50",
            "--cache", str(tmp_path / "cache")]
    r = cli.invoke(app, args)
    assert r.exit_code == 0, r.output
    assert "maintenance interval" in r.output and "does not wear" in r.output
    r = cli.invoke(app, args + ["--plot", str(plots), "--json"])
    assert r.exit_code == 0, r.output
    s = json.loads(r.stdout)
    assert s["figures"] == [str(plots / "wear_clearance.png")] and (plots / "wear_clearance.png").is_file()
    assert s["joints"]["A"]["maintenance_interval_h"] is None and s["joints"]["C"]["size_convention"] == "radial"
    from berryshaker.outputs import read_output_marker

    assert list(read_output_marker(plots)["outputs"]) == ["wear --plot"]


@pytest.mark.parametrize("command", [["sensitivity", "--samples", "2"], ["tolerance", "--points", "2"],
                                     ["wear", "--hours", "1"]])
def test_life_plots_never_overwrite_the_users_pngs(command, tmp_path):
    folder = tmp_path / "figures"
    folder.mkdir()
    for name in ("sobol_collision_force_A_peak.png", "tolerance_pareto.png", "wear_clearance.png"):
        (folder / name).write_bytes(b"the user's figure")
    r = cli.invoke(app, command + ["--plot", str(folder), "--cache", str(tmp_path / "cache")])
    assert r.exit_code == 2 and "not empty and was not written by berryshaker" in r.output, r.output
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == {
        n: b"the user's figure" for n in ("sobol_collision_force_A_peak.png", "tolerance_pareto.png",
                                          "wear_clearance.png")}


def test_roller_sliding_speed_leaves_out_the_approach_speed():
    """A roller in a groove slides only along the wall: of the roller centre's velocity relative to the wall,
    v_rel = (3, 4) m/s here, the component along the contact normal (the element's penetration rate, 4 m/s) is
    approach, not sliding, so the sliding speed is slip * sqrt(3^2 + 4^2 - 4^2) = slip * 3 m/s (0.15 m/s at
    slip 0.05).  An ideal joint (no contact element) has no approach: slip * 5 m/s.  The multibody check above
    runs ideal joints only, where the normal rate is zero."""
    from types import SimpleNamespace

    from berryshaker.life.joint_loads import sliding_speed

    n_t = 4
    y = np.zeros((n_t, 6))  # one body: (x, y, angle) then (vx, vy, omega)
    y[:, 3], y[:, 4] = 3.0, 4.0
    joint = SimpleNamespace(name="A", type="groove_clearance", body_i="push_rod", body_j="ground", point_i=(0.0, 0.0))
    elements = np.zeros((n_t, 1, 3))  # EO columns: normal force, penetration, penetration rate
    elements[:, 0, 2] = 4.0
    compiled = SimpleNamespace(spec=SimpleNamespace(joints=[joint]), body_index={"push_rod": 0}, n=3,
                               frc_names=["A"])
    result = SimpleNamespace(t=np.linspace(0.0, 0.01, n_t), y=y, compiled=compiled, elements=elements)
    np.testing.assert_allclose(sliding_speed(result, "A", 0.03, slip=0.05), 0.15, rtol=1e-12)
    np.testing.assert_allclose(sliding_speed(result, "A", 0.03, slip=1.0), 3.0, rtol=1e-12)
    ideal = SimpleNamespace(t=result.t, y=y, compiled=SimpleNamespace(**{**vars(compiled), "frc_names": []}),
                            elements=np.zeros((n_t, 0, 3)))
    np.testing.assert_allclose(sliding_speed(ideal, "A", 0.03, slip=0.05), 0.25, rtol=1e-12)
