"""Archard wear (closed forms, integrals, monotonicity) and the wear-life outer loop (synthetic simulators)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from berryshaker.contact.wear import (
    KGF_PER_MM2,
    MATERIAL_PAIRS,
    archard_wear_depth,
    archard_wear_depth_rate,
    archard_wear_volume,
    archard_wear_volume_rate,
    material_pair,
    pin_in_bore_clearance_growth,
)
from berryshaker.errors import ConfigError, SimulationError
from berryshaker.life.fits import parse_fit
from berryshaker.life.wear import JointWear, clearance_size_from_fit, wear_life

K, H = 1e-6, 1.0e9


# ----------------------------------------------------------------------------------------------- Archard
def test_uniform_pressure_constant_sliding_closed_form():
    t = np.linspace(0.0, 7.0, 15)
    force, speed, area = 200.0, 0.05, 2e-4
    h = archard_wear_depth(np.full_like(t, force), np.full_like(t, speed), t, K, H, area)
    assert h[-1] == pytest.approx(K * (force / area) * speed * 7.0 / H, rel=1e-13)
    assert archard_wear_depth_rate(force / area, speed, K, H) == pytest.approx(K * force / area * speed / H)
    assert archard_wear_volume_rate(force, speed, K, H) == pytest.approx(K * force * speed / H)


def test_volume_equals_integral_of_the_law_for_a_varying_series():
    # F = F0 (1 + 0.5 sin 2 pi t), v = v0 sin 2 pi t (reversing).  Over one period
    # int F |v| dt = F0 v0 int_0^1 (1 + 0.5 sin x)|sin x| dt = F0 v0 * 4 / (2 pi)   (the 0.5 sin|sin| term is odd)
    t = np.linspace(0.0, 1.0, 40001)
    f0, v0 = 300.0, 0.2
    x = 2 * np.pi * t
    vol = archard_wear_volume(f0 * (1 + 0.5 * np.sin(x)), v0 * np.sin(x), t, K, H)
    assert vol[-1] == pytest.approx(K * f0 * v0 * 4 / (2 * np.pi) / H, rel=1e-6)


def test_growth_is_monotone_non_decreasing_for_any_signs():
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(1e-4, 1e-3, 500))
    f = rng.normal(0, 100, 500)  # signs as an engine may report them: magnitudes are used
    v = rng.normal(0, 0.1, 500)
    for y in (archard_wear_volume(f, v, t, K, H), archard_wear_depth(f, v, t, K, H, 1e-4),
              pin_in_bore_clearance_growth(f, v, t, K, H, 0.02, 0.03, "rotating")):
        assert y[0] == 0 and np.all(np.diff(y) >= 0)
    assert archard_wear_depth_rate(-5.0, 1.0, K, H) == 0  # negative pressure: no contact


def test_pin_in_bore_fixed_is_four_times_rotating():
    t = np.linspace(0, 10, 11)
    f, v = np.full(11, 500.0), np.full(11, 0.01)
    d, length = 0.02, 0.03
    fixed = pin_in_bore_clearance_growth(f, v, t, K, H, d, length, "fixed")[-1]
    rot = pin_in_bore_clearance_growth(f, v, t, K, H, d, length, "rotating")[-1]
    assert fixed == pytest.approx(4 * K * 500 * 0.01 * 10 / (math.pi * H * d * length), rel=1e-13)
    assert fixed == pytest.approx(4 * rot, rel=1e-13)
    # the rotating depth is the volume spread over the bore surface pi d L
    assert rot * math.pi * d * length == pytest.approx(archard_wear_volume(f, v, t, K, H)[-1])
    with pytest.raises(ConfigError, match="load_direction"):
        pin_in_bore_clearance_growth(f, v, t, K, H, d, length, "sideways")


def test_input_validation():
    t = np.linspace(0, 1, 5)
    with pytest.raises(ConfigError, match="hardness"):
        archard_wear_volume(t, t, t, K, 0.0)
    with pytest.raises(ConfigError, match="wear coefficient"):
        archard_wear_volume(t, t, t, -1.0, H)
    with pytest.raises(ConfigError, match="strictly increasing"):
        archard_wear_volume(t, t, t[::-1], K, H)
    with pytest.raises(ConfigError, match="same 1-D shape"):
        archard_wear_volume(t[:3], t, t, K, H)
    with pytest.raises(ConfigError, match="known pairs"):
        material_pair("unobtainium")


def test_material_table_is_cited_or_marked_assumed():
    archard = material_pair("mild-steel-dry")
    assert archard.wear_coefficient == 7e-3 and archard.hardness == pytest.approx(186 * KGF_PER_MM2)
    for p in MATERIAL_PAIRS.values():
        lo, hi = p.wear_coefficient_range
        assert lo <= p.wear_coefficient <= hi and p.hardness > 0
        assert ("[assumed]" in p.source) == p.assumed
        assert p.wear_factor == pytest.approx(p.wear_coefficient / p.hardness)


# ----------------------------------------------------------------------------------------------- outer loop
D, L = 0.02, 0.03
PAIR = material_pair("steel-on-bronze-greased")


def _window(force: float, speed: float, n: int = 51, period: float = 0.5):
    t = np.linspace(0.0, period, n)
    return t, np.full(n, force), np.full(n, speed)


def _rate_per_hour(force, speed, joint: JointWear) -> float:
    """Closed form, not the joint's own depth_per_volume: the radial clearance of a pin in a bore grows by
    4 V / (pi d L) with the load fixed in direction and V / (pi d L) with it rotating (contact/wear.py), V = k F s / H
    (worked numbers: tests/life/test_wear_closed_form.py)."""
    factor = 4.0 if joint.load_direction == "fixed" else 1.0
    return factor / (math.pi * D * L) * PAIR.wear_coefficient * force * speed / PAIR.hardness * 3600.0


def test_constant_force_gives_linear_growth_and_exact_interval():
    joints = {"C": JointWear(PAIR, pin_diameter=D, bearing_length=L),
              "F": JointWear(PAIR, pin_diameter=D, bearing_length=L, load_direction="rotating")}
    calls = []

    def simulate(c):
        calls.append(dict(c))
        return {"C": _window(400.0, 0.05), "F": _window(400.0, 0.05)}, {"peak": 400.0 + 1e6 * c["C"]}

    c0 = {"C": 20e-6, "F": 15e-6, "A": 0.1e-3}
    res = wear_life(None, 5000.0, {"clearance:C": 0.25e-3, "peak": 500.0}, simulate=simulate, joints=joints,
                    initial_clearances=c0)
    rc = _rate_per_hour(400.0, 0.05, joints["C"])
    rf = _rate_per_hour(400.0, 0.05, joints["F"])
    assert rf == pytest.approx(rc / 4)
    assert res.completed and res.hours[-1] == 5000.0
    assert np.allclose(res.clearance["C"], c0["C"] + rc * res.hours, rtol=1e-12)
    assert np.allclose(res.clearance["F"], c0["F"] + rf * res.hours, rtol=1e-12)
    assert np.all(res.clearance["A"] == c0["A"])  # not a wearing joint
    # step control: no step grows a clearance by more than 10 % of its value or 0.02 mm (1 um floor)
    for j in ("C", "F"):
        c = res.clearance[j]
        assert np.all(np.diff(c) <= np.clip(0.1 * c[:-1], 1e-6, 0.02e-3) * (1 + 1e-9))
    assert res.limits["clearance:C"]["hours"] == pytest.approx((0.25e-3 - 20e-6) / rc, rel=1e-9)
    assert res.limits["peak"]["hours"] == pytest.approx((100e-6 - 20e-6) / rc, rel=1e-9)
    assert res.maintenance_interval_hours == res.limits["peak"]["hours"] and res.governing_limit == "peak"
    assert len(calls) == len(res.hours)
    json.dumps(res.to_dict())
    assert res.to_dict()["joints"]["C"]["clearance_mm"][0] == pytest.approx(0.02)


def _growing(c_ref: float, f0: float = 300.0, speed: float = 0.05):
    def simulate(c):
        f = f0 * (1.0 + c["C"] / c_ref)
        return {"C": _window(f, speed)}, {"peak_force_N": f}
    return simulate


def test_force_growing_with_clearance_matches_closed_form_and_converges():
    """dc/dh = a (1 + c/c_ref)  =>  c(h) = (c0 + c_ref) exp(a h / c_ref) - c_ref."""
    joint = {"C": JointWear(PAIR, pin_diameter=D, bearing_length=L)}
    c_ref, c0, c_lim = 0.1e-3, 10e-6, 0.5e-3
    a = _rate_per_hour(300.0, 0.05, joint["C"])
    exact = c_ref / a * math.log((c_lim + c_ref) / (c0 + c_ref))
    runs = {}
    for scheme in ("adams-bashforth2", "euler"):
        for refine in (1, 2):
            res = wear_life(None, 3 * exact, {"clearance:C": c_lim}, simulate=_growing(c_ref), joints=joint,
                            initial_clearances={"C": c0}, scheme=scheme, max_growth_fraction=0.1 / refine,
                            max_growth=0.02e-3 / refine, min_growth=1e-6 / refine, stop_at_limits=True)
            assert res.completed and np.all(np.diff(res.clearance["C"]) >= 0)
            runs[scheme, refine] = res.maintenance_interval_hours
            # the force limit is the same event seen through the output: F = f0 (1 + c/c_ref)
    ab1, ab2 = runs["adams-bashforth2", 1], runs["adams-bashforth2", 2]
    assert ab1 == pytest.approx(exact, rel=0.02) and ab2 == pytest.approx(exact, rel=0.02)
    assert ab2 == pytest.approx(ab1, rel=0.02)  # step halved: converged within 2 %
    assert runs["euler", 2] == pytest.approx(runs["euler", 1], rel=0.05)
    assert abs(runs["euler", 2] - exact) < abs(runs["euler", 1] - exact)  # first order: error shrinks


def test_output_limit_min_and_unreached_limits():
    joint = {"C": JointWear(PAIR, pin_diameter=D, bearing_length=L)}

    def simulate(c):
        return {"C": _window(300.0, 0.05)}, {"efficiency": 0.95 - 100.0 * c["C"]}

    res = wear_life(None, 2000.0, {"efficiency": {"min": 0.93}, "peak_force:C": 1e4}, simulate=simulate,
                    joints=joint, initial_clearances={"C": 0.0})
    rate = _rate_per_hour(300.0, 0.05, joint["C"])
    assert res.limits["efficiency"]["hours"] == pytest.approx(0.02 / 100.0 / rate, rel=1e-9)
    assert res.limits["peak_force:C"]["hours"] is None
    assert res.maintenance_interval_hours == res.limits["efficiency"]["hours"]
    none = wear_life(None, 10.0, {"clearance:C": 1.0}, simulate=simulate, joints=joint,
                     initial_clearances={"C": 0.0})
    assert none.maintenance_interval_hours is None and none.governing_limit is None


def test_bounded_steps_and_clear_errors():
    joint = {"C": JointWear(PAIR, pin_diameter=D, bearing_length=L)}
    res = wear_life(None, 1e6, None, simulate=_growing(1e-4), joints=joint, initial_clearances={"C": 1e-5},
                    max_steps=5)
    assert not res.completed and len(res.hours) == 6 and "max_steps" in res.message
    with pytest.raises(ConfigError, match="not an output of the simulator"):
        wear_life(None, 10.0, {"efficency": 0.9}, simulate=_growing(1e-4), joints=joint,
                  initial_clearances={"C": 1e-5})
    with pytest.raises(ConfigError, match="no initial clearance"):
        wear_life(None, 10.0, simulate=_growing(1e-4), joints=joint, initial_clearances={})
    with pytest.raises(SimulationError, match="no load series for joint 'C'"):
        wear_life(None, 10.0, simulate=lambda c: ({}, {}), joints=joint, initial_clearances={"C": 1e-5})
    with pytest.raises(ConfigError, match="pin_diameter"):
        JointWear(PAIR)
    with pytest.raises(ConfigError, match="wear_area"):
        JointWear(PAIR, geometry="area")


def test_area_geometry_and_machine_initial_clearances(machine):
    area = 5e-4
    joints = {"A": JointWear("steel-steel-lubricated", geometry="area", wear_area=area)}
    pair = material_pair("steel-steel-lubricated")

    def simulate(c):
        return {"A": _window(800.0, 0.3)}, {}

    res = wear_life(machine, 100.0, simulate=simulate, joints=joints)
    sizes = machine.clearance_sizes() if hasattr(machine, "clearance_sizes") else machine.clearance.sizes()
    c0 = sizes["A"]
    rate = pair.wear_coefficient * 800.0 * 0.3 / pair.hardness / area * 3600.0
    assert res.clearance["A"][-1] == pytest.approx(c0 + rate * 100.0, rel=1e-12)
    assert set(res.clearance) == set(sizes)


def test_clearance_size_from_fit():
    fit = parse_fit("20 H7/f7")
    assert clearance_size_from_fit(fit, "revolute", "min") == pytest.approx(10e-6)
    assert clearance_size_from_fit(fit, "point-line", "max") == pytest.approx(62e-6)
    assert clearance_size_from_fit(parse_fit("25 H7/p6"), "revolute", "max") == 0.0


# ----------------------------------------------------------------------------------------------- service limit
def test_one_service_limit_rule_for_every_caller():
    """min(largest test level, 2.5 % of the diameter): the reference machine's largest levels (A 0.75, B 0.6, C and F
    0.2 mm) are below 2.5 % of their 30 mm rollers and 20 mm pins; the tolerance design and the study's name for
    the default limits give the same numbers."""
    from berryshaker.config import load_machine
    from berryshaker.life.clearance_response import default_clearance_limits
    from berryshaker.life.service import service_limit, service_limits

    m = load_machine(None)
    lim = service_limits(m)
    assert lim == pytest.approx({"A": 7.5e-4, "B": 6e-4, "C": 2e-4, "F": 2e-4})
    assert default_clearance_limits(m, list(lim)) == lim  # the study's life step calls this name
    assert service_limit(2e-4, 0.02) == 2e-4 and service_limit(8e-4, 0.02) == pytest.approx(5e-4)
    with pytest.raises(ConfigError, match="not a clearance pair"):
        service_limits(m, ["Z"])


def test_machine_wear_is_the_one_loop_and_lists_every_joint_with_its_keys():
    """The library wear loop (``berryshaker wear`` is a thin call to it) defaults to the service limits and gives
    every joint, worn or not, the per-joint keys the terminal table and the plot read (a stub runner stands in
    for the multibody runs: constant 300 N at 0.01 m/s on every joint)."""
    import inspect

    from berryshaker.cli import life as cli_life
    from berryshaker.config import load_machine
    from berryshaker.life.service import machine_wear, service_limits

    class StubRunner:
        stats = {"cached": 0}

        def values(self, fn, jobs, label):
            t = np.linspace(0.0, 0.5, 11)
            return [{"loads": {j: {"t": t.tolist(), "force": [300.0] * 11, "speed": [0.01] * 11}
                               for j in job["clearance"]}, "outputs": {}} for job in jobs]

    assert "wear_life(" not in inspect.getsource(cli_life)  # no second loop in the CLI
    m = load_machine(None)
    res = machine_wear(m, 50.0, runner=StubRunner(), joints=["C"], from_fit=True)
    assert res["limits_si"] == {"clearance:C": service_limits(m, ["C"])["C"]}
    for j, d in res["joints"].items():
        assert {"maintenance_interval_h", "size_convention", "material_pair", "limits"} <= set(d), j
    assert res["joints"]["C"]["clearance_mm"][0] == pytest.approx(0.0235)
    assert res["joints"]["C"]["size_convention"] == "radial" and res["simulations"] >= 2
    with pytest.raises(ConfigError, match=r"clearance\.A\.fit is not set"):
        machine_wear(m, 5.0, runner=StubRunner(), joints=["A"], from_fit=True)
