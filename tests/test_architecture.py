"""The layout's promises (docs/architecture.md): public functions documented, a contact law is one function and
one registry entry, drives are plug-ins, 0.1.0 machine files still load, modules stay readable in one sitting."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from pathlib import Path

import numpy as np
import pytest

import berryshaker

SRC = Path(berryshaker.__file__).parent


def _modules():
    for info in pkgutil.walk_packages(berryshaker.__path__, "berryshaker."):
        yield importlib.import_module(info.name)


def test_every_public_function_and_class_has_a_docstring():
    missing = []
    for mod in _modules():
        for name, obj in vars(mod).items():
            if name.startswith("_"):
                continue
            target = getattr(obj, "py_func", obj)  # numba dispatchers
            if not (inspect.isfunction(target) or inspect.isclass(target)):
                continue
            if getattr(target, "__module__", None) != mod.__name__:
                continue
            if not (target.__doc__ or "").strip():
                missing.append(f"{mod.__name__}.{name}")
    assert not missing, "public functions/classes without a docstring:\n  " + "\n  ".join(sorted(missing))


def test_modules_stay_readable_or_say_why():
    long = []
    for path in SRC.rglob("*.py"):
        text = path.read_text("utf-8")
        n = text.count("\n")
        if n > 550 and "long module:" not in text[:3000]:
            long.append(f"{path.relative_to(SRC)} ({n} lines)")
    assert not long, "modules over ~500 lines need a 'long module:' reason in their docstring: " + ", ".join(long)


def test_a_new_contact_law_is_one_function_and_one_registry_entry():
    """Register a law in the test; the description validation and the compiled engine pick it up."""
    from numba import njit

    from berryshaker.contact.laws import LAW_SIGNATURE, register_law, unregister_law
    from berryshaker.multibody.engine import simulate_mechanism
    from berryshaker.multibody.spec import load_mechanism

    @njit(LAW_SIGNATURE)
    def doubled_hertz(pen, pen_dot, v_imp, k, n, e, c, d):
        return 2.0 * k * pen**n

    spec = load_mechanism(Path(__file__).parents[1] / "examples" / "slider_crank_clearance.toml")
    data = spec.model_dump()
    for j in data["joints"]:
        if j.get("contact"):
            j["contact"].update(law="hertz", stiffness=1e9, exponent=1.5)
    from berryshaker.multibody.spec import mechanism_from_dict

    base = simulate_mechanism(mechanism_from_dict(data), duration=0.02)
    register_law("doubled_hertz", doubled_hertz, ("stiffness", "exponent"), "2 k delta^n (test)")
    try:
        for j in data["joints"]:
            if j.get("contact"):
                j["contact"]["law"] = "doubled_hertz"
                j["contact"]["stiffness"] = 0.5e9  # 2 * 0.5e9 = the base law's 1e9
        twin = simulate_mechanism(mechanism_from_dict(data), duration=0.02)
    finally:
        unregister_law("doubled_hertz")
    np.testing.assert_allclose(twin.elements[:, :, 0], base.elements[:, :, 0], rtol=1e-9, atol=1e-6)
    from berryshaker.errors import ConfigError

    with pytest.raises(ConfigError, match="unknown contact law 'doubled_hertz'"):
        data["joints"][-1]["contact"]["law"] = "doubled_hertz"
        mechanism_from_dict(data)


def test_drives_are_plug_ins_with_their_own_pairs():
    from berryshaker.config import reference_machine
    from berryshaker.drives import DRIVE_PACKAGES, get_drive

    for name in DRIVE_PACKAGES:
        drive = get_drive(name)
        m = reference_machine(name)
        assert m.DRIVE == name and m.pair_names == tuple(p.name for p in drive.pairs)
        kin = drive.check(m)
        summary = drive.kinematics_summary(m, kin)
        assert summary["combs"]["left"]["swing_deg"]["max"] > 0
    assert reference_machine("crank_rocker").pair_names == ("crank_pin", "rocker_pin", "C", "F")


def test_the_two_reference_drives_swing_the_combs_alike():
    """The crank-rocker reference machine is built to compare with the groove cam: same swing, same speed."""
    from berryshaker.config import reference_machine
    from berryshaker.drives import get_drive

    out = {}
    for name in ("groove_cam", "crank_rocker"):
        m = reference_machine(name)
        d = get_drive(name)
        out[name] = d.kinematics_summary(m, d.check(m))
    for side in ("left", "right"):
        a = out["groove_cam"]["combs"][side]["swing_deg"]
        b = out["crank_rocker"]["combs"][side]["swing_deg"]
        assert b["max"] - b["min"] == pytest.approx(a["max"] - a["min"], rel=2e-3)
    assert out["crank_rocker"]["drive"]["comb_frequency_hz"] == out["groove_cam"]["drive"]["comb_frequency_hz"]


def test_machine_files_of_version_0_1_0_get_the_unit_message_then_load():
    """A 0.1.0 file with a bare dimensional number is not read as SI: loading names the field and the fix;
    with the unit given as the message says, the rest of the old file (kinds, sizes, springs) still loads."""
    from berryshaker.config import load_machine, reference_machine
    from berryshaker.errors import ConfigError

    with pytest.raises(ConfigError, match=r'harvest.damage_acceleration: 6012 is a bare number; give a unit, '
                                          r'e.g. damage_acceleration = "6012 m/s\^2"'):
        load_machine(Path(__file__).parent / "data" / "machine_0_1_0.toml")
    old = load_machine(Path(__file__).parent / "data" / "machine_0_1_0_units.toml")
    new = reference_machine()
    assert old.clearance["A"].kind == "roller-in-groove" and old.clearance["C"].kind == "pin-in-bore"
    assert old.clearance_sizes() == new.clearance_sizes()


def test_clearances_are_validated_where_the_machine_is_built():
    from berryshaker.config import reference_machine
    from berryshaker.errors import ConfigError

    m = reference_machine()
    with pytest.raises(ConfigError, match="clearance.A.size = 5 mm is larger than the geometry allows"):
        m.with_clearances({"A": 5e-3})
    with pytest.raises(ConfigError, match="unknown clearance pair 'Q'"):
        m.with_clearances({"Q": 1e-4})
    with pytest.raises(ConfigError, match="finite length >= 0"):
        m.with_clearances({"B": float("nan")})


def test_two_machine_files_side_by_side(tmp_path):
    """compare-machines puts the groove cam beside the crank-rocker (different pairs, same comb swing)."""
    import json

    from typer.testing import CliRunner

    from berryshaker.cli import app

    crank = Path(__file__).parents[1] / "examples" / "crank_rocker_harvester.toml"
    r = CliRunner().invoke(app, ["compare-machines", "reference", str(crank), "--no-fruit-force", "-n", "2", "--json"])
    assert r.exit_code == 0, r.output
    res = json.loads(r.stdout)["machines"]
    ref, cr = res["reference"], res["crank_rocker_harvester"]
    assert list(cr["collision_force_N"]) == ["crank_pin", "rocker_pin", "C", "F"]
    assert cr["comb_swing_deg"]["left"] == pytest.approx(ref["comb_swing_deg"]["left"], rel=2e-3)
    assert ref["drive_moment_Nm"]["peak"] > 0 and cr["drive_moment_Nm"]["peak"] > 0
