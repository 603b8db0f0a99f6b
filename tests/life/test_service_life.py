"""A joint's service life by mechanism (berryshaker.life.service_life) on surrogates with closed forms, and the
service limit of a joint's function (berryshaker.life.service)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from berryshaker.config import load_machine
from berryshaker.life.clearance_response import ClearanceResponse
from berryshaker.life.joint_loads import joint_geometry
from berryshaker.life.service import service_limits
from berryshaker.life.service_life import ABRASIVE_WEAR, DESIGN_LIFE_H, joint_life, reads

RATE = 1e-7  # m/h at the nominal k: 0.1 um/h


def _response(force=5000.0, rate=RATE, rolling=None, turns=None):
    c = np.array([0.02e-3, 0.3e-3, 0.8e-3])
    return ClearanceResponse("C", c, np.full(3, force), np.full(3, rate),
                             rolling_load=None if rolling is None else np.full(3, rolling),
                             roller_rev_per_h=None if turns is None else np.full(3, turns))


def test_wear_by_mode_with_constant_rate():
    """Constant growth r: lubricated hours (c_limit - c0) / r at the pair's k; abrasive hours scale by
    k / k_abrasive; the interval is each mode's k range; the faster (abrasive) governs and names its k."""
    m = load_machine(None)
    g = joint_geometry(m, "C")  # greased bronze: k 1e-6 (1e-7 .. 1e-5)
    life = joint_life(_response(), g, 0.03e-3, 0.2e-3, "test")
    mild, abrasive = life.mechanisms[0], life.mechanisms[1]
    h = (0.2e-3 - 0.03e-3) / RATE
    assert mild.hours == pytest.approx(h, rel=1e-3) and mild.lo == pytest.approx(h / 10, rel=1e-3)
    ka, (ka_lo, ka_hi) = ABRASIVE_WEAR
    assert abrasive.hours == pytest.approx(h * 1e-6 / ka, rel=1e-3)
    assert abrasive.lo == pytest.approx(h * 1e-6 / ka_hi, rel=1e-3)
    assert life.governing == "abrasive wear" and "Archard k" in life.uncertainty
    assert life.hours == pytest.approx(abrasive.hours) and life.reads.startswith(f"{abrasive.hours:,.0f} h")


def test_no_interval_beyond_the_design_life():
    """A joint that wears slowly reads "> 20,000 h: no wear-out in the machine's life", never a number past it."""
    m = load_machine(None)
    life = joint_life(_response(rate=1e-12), joint_geometry(m, "C"), 0.03e-3, 0.2e-3, "test")
    assert life.hours is None and life.reads == f"> {DESIGN_LIFE_H:,.0f} h: no wear-out in the machine's life"
    assert reads(5000.0, 1000.0, 50000.0) == "5,000 h [1,000 .. > 20,000]"
    for text in (reads(3e5, 3e4, 3e6), reads(1e4, 3e3, 3e4), reads(None, None, None)):
        numbers = [float(x.replace(",", "")) for x in __import__("re").findall(r"[\d,]+(?:\.\d+)?", text)]
        assert all(x <= DESIGN_LIFE_H for x in numbers), text


def test_contact_fatigue_governs_where_the_pressure_passes_the_shakedown_limit():
    """The clearance-impact-wear loop on a roller: its static-equivalent load grows from 10 to 15 kN over the first
    grid step (the engine's loads re-evaluated as the clearance grows); Hertz's p0 = sqrt(F E* / (pi L R)) reaches
    steel's shakedown limit 4 (H/3)/sqrt(3) at F = p^2 pi L R / E*, i.e. at the clearance where the interpolated
    load is that force: the life ends there, at the abrasive wear's hours to it, before the service limit."""
    from berryshaker.life.contact_fatigue import pair_modulus, shakedown_pressure

    m = load_machine(None)
    g = joint_geometry(m, "A")  # 30 x 15 mm roller, hardened steel
    c = np.array([0.02e-3, 0.3e-3, 0.8e-3])
    resp = ClearanceResponse("A", c, np.array([10e3, 15e3, 20e3]), np.full(3, RATE))
    life = joint_life(resp, g, 0.02e-3, 0.75e-3, "test")
    p = shakedown_pressure(2.0e9)
    f_lim = p**2 * math.pi * g.bearing_length * (g.diameter / 2) / pair_modulus(g.material_pair)
    c_f = 0.02e-3 + 0.28e-3 * (f_lim - 10e3) / 5e3
    fat = next(x for x in life.mechanisms if x.mechanism == "contact fatigue")
    assert life.governing == "contact fatigue"
    assert fat.hours == pytest.approx((c_f - 0.02e-3) / (RATE * ABRASIVE_WEAR[0] / 1e-7), rel=1e-2)
    assert life.endurance_MPa == pytest.approx(p / 1e6)


def test_iso_281_of_a_rolling_bearing_roller():
    """A roller on a bearing of C = 20 kN at a constant 5 kN and 60,000 rev/h: L10h = 4^(10/3) 10^6 / 60,000 h."""
    m = load_machine(None)
    g = joint_geometry(m, "A")
    life = joint_life(_response(rate=1e-12, rolling=5000.0, turns=6e4), g, 0.1e-3, 0.75e-3, "test", rating=20e3)
    iso = next(x for x in life.mechanisms if x.mechanism.startswith("rolling-bearing"))
    assert iso.hours == pytest.approx(4 ** (10 / 3) * 1e6 / 6e4, rel=1e-2)
    assert life.governing.startswith("rolling-bearing") and iso.hi == pytest.approx(3.38 * iso.hours, rel=0.01)


def test_a_looser_build_never_gets_a_later_limit():
    """The limit is a property of the joint's function: building C looser (0.15 instead of 0.1 mm) leaves every
    limit where it was, and the life from a looser start is shorter, never longer."""
    m = load_machine(None)
    looser = m.with_clearances({"C": 0.15e-3, "F": 0.19e-3})
    assert service_limits(looser) == service_limits(m)
    g = joint_geometry(m, "C")
    lives = [joint_life(_response(), g, c, 0.2e-3, "test").hours for c in (0.02e-3, 0.05e-3, 0.1e-3, 0.15e-3)]
    assert all(a > b for a, b in zip(lives, lives[1:]))
    assert joint_life(_response(), g, 0.2e-3, 0.2e-3, "test").hours == 0.0
    assert math.isfinite(lives[0])


def test_config_validate_bounds_clearances_and_checks_fits(tmp_path):
    """12 mm radial clearance on a 20 mm pin is refused naming the field; a fit whose smallest clearance is above
    the described size is refused; a size above the fit's range is a worn state of it (a note)."""
    from fast_machine import with_values
    from typer.testing import CliRunner

    from berryshaker.cli import app

    run = CliRunner()
    p = tmp_path / "m.toml"
    assert run.invoke(app, ["config", "init", str(p)]).exit_code == 0
    text = p.read_text()
    r = run.invoke(app, ["config", "validate", str(p), "--json"])
    notes = __import__("json").loads(r.stdout)["notes"]
    assert r.exit_code == 0 and any("C: size 0.1 mm is a worn state of the fit H8/f7" in n for n in notes)
    for size, msg in (("12 mm", "clearance.C.size = 12 mm is larger than the geometry allows (10% of the 20 mm pin "
                                "diameter = 2 mm)"),
                      ("0.005 mm", "clearance.C.fit = 'H8/f7' gives 0.01 .. 0.037 mm (radial)")):
        p.write_text(with_values(text, {"clearance.C.size": f'"{size}"'}))
        r = run.invoke(app, ["config", "validate", str(p)])
        assert r.exit_code == 2 and msg in " ".join(r.output.split()), r.output
        assert "Traceback" not in r.output
