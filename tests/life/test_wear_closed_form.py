"""Clearance growth by Archard wear against numbers worked out by hand (not by the functions under test).

The worked example used throughout (SI units)
---------------------------------------------
Pair "steel-on-bronze-greased": k = 1e-6 (dimensionless), H = 1.0e9 Pa.  Constant normal force F = 400 N and
sliding speed v = 0.05 m/s.  Pin diameter d = 20 mm, bush length L = 30 mm.

Archard (1953): worn volume V = k F s / H with s = v t the sliding distance, so

    dV/dt = k F v / H = 1e-6 * 400 * 0.05 / 1e9 = 2.0e-14 m^3/s          (7.2e-11 m^3 per operating hour)

Pin in a bore, load fixed in direction (the model's documented equation, contact/wear.py): the pin sinks by
delta into the bore, removing the local depth delta cos(theta) over the loaded half |theta| < pi/2.  With the
local law dh/dt = k p v / H this needs p = p_max cos(theta); the load balance

    F = int_{-pi/2}^{pi/2} p_max cos(theta) cos(theta) (d/2) L dtheta = p_max (d/2) L (pi/2) = p_max pi d L / 4

gives p_max = 4 F / (pi d L), so the radial clearance grows at

    d(delta)/dt = k p_max v / H = 4 (dV/dt) / (pi d L).

pi d L = pi * 0.020 * 0.030 = 1.884956e-3 m^2, so 4 / (pi d L) = 2122.066 1/m^2 and

    d(delta)/dt = 2122.066 * 2.0e-14 = 4.244132e-11 m/s = 0.1527887 um per operating hour.

Load rotating over the whole circumference: the volume is spread over the bore surface pi d L, a quarter of the
above: 1.061033e-11 m/s = 0.03819719 um/h.

Roller in a groove (joint_loads.py): the volume is taken from the roller rim, circumference pi d over its width
w = L, uniformly: the radius falls by V / (pi d w), the diameter by 2 V / (pi d w), and the free travel grows by the
same: 2 * 2.0e-14 / 1.884956e-3 = 2.122066e-11 m/s = 0.07639437 um/h.

Using the radius for the diameter anywhere in these (pi r L for pi d L, or a sliding speed omega d for omega d/2)
doubles each rate, which every test below sees.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.integrate import quad

from berryshaker.contact.wear import archard_wear_volume, material_pair, pin_in_bore_clearance_growth
from berryshaker.life.joint_loads import JointGeometry, joint_wear_model, sliding_speed
from berryshaker.life.wear import JointWear, wear_life

PAIR = "steel-on-bronze-greased"
K, HARD = 1e-6, 1.0e9
F, V = 400.0, 0.05
D, L = 0.020, 0.030

VOLUME_RATE = 2.0e-14              # m^3/s, k F v / H
FIXED_RATE = 4.244132e-11          # m/s, 4 (dV/dt) / (pi d L)
ROTATING_RATE = 1.061033e-11       # m/s, (dV/dt) / (pi d L)
ROLLER_RATE = 2.122066e-11         # m/s, 2 (dV/dt) / (pi d w)
UM_PER_H = 1e6 * 3600.0


def _constant(seconds: float = 0.5, n: int = 51):
    t = np.linspace(0.0, seconds, n)
    return t, np.full(n, F), np.full(n, V)


def test_the_worked_example_numbers():
    """The literals above, recomputed from their definitions: the pair's data, the load balance integral (done
    numerically here, not with the package's 4/(pi d L)) and the unit conversions."""
    pair = material_pair(PAIR)
    assert (pair.wear_coefficient, pair.hardness) == (K, HARD)
    assert K * F * V / HARD == pytest.approx(VOLUME_RATE, rel=1e-12)
    # load balance with p = cos(theta) (p_max = 1 Pa): F per unit p_max over the loaded half of the bore
    force_per_pmax, _ = quad(lambda th: math.cos(th) ** 2 * (D / 2) * L, -math.pi / 2, math.pi / 2)
    p_max = F / force_per_pmax
    assert K * p_max * V / HARD == pytest.approx(FIXED_RATE, rel=1e-6)
    assert VOLUME_RATE / (math.pi * D * L) == pytest.approx(ROTATING_RATE, rel=1e-6)
    assert 2 * VOLUME_RATE / (math.pi * D * L) == pytest.approx(ROLLER_RATE, rel=1e-6)
    assert FIXED_RATE * UM_PER_H == pytest.approx(0.1527887, rel=1e-6)
    assert ROTATING_RATE * UM_PER_H == pytest.approx(0.03819719, rel=1e-6)
    assert ROLLER_RATE * UM_PER_H == pytest.approx(0.07639437, rel=1e-6)


@pytest.mark.parametrize("direction, rate", [("fixed", FIXED_RATE), ("rotating", ROTATING_RATE)])
def test_pin_in_bore_clearance_growth_over_an_hour(direction, rate):
    t = np.linspace(0.0, 3600.0, 7)
    growth = pin_in_bore_clearance_growth(np.full(7, F), np.full(7, V), t, K, HARD, D, L, direction)
    np.testing.assert_allclose(growth, rate * t, rtol=1e-6)


@pytest.mark.parametrize("direction, rate, per_volume", [("fixed", FIXED_RATE, 2122.066),
                                                          ("rotating", ROTATING_RATE, 530.5165)])
def test_joint_wear_pin_growth_rate(direction, rate, per_volume):
    joint = JointWear(PAIR, pin_diameter=D, bearing_length=L, load_direction=direction)
    assert joint.depth_per_volume == pytest.approx(per_volume, rel=1e-6)
    assert joint.growth_rate(*_constant()) == pytest.approx(rate, rel=1e-6)


def test_joint_wear_model_of_a_pin_and_of_a_roller():
    """The geometry the life commands build from ``[clearance.<pair>]``: d and L of a pin, d and width of a roller."""
    pin = JointGeometry("C", "pin-in-bore", D, L, PAIR, None, ())
    roller = JointGeometry("A", "roller-in-groove", D, L, PAIR, None, ())
    assert joint_wear_model(pin).growth_rate(*_constant()) == pytest.approx(FIXED_RATE, rel=1e-6)
    assert joint_wear_model(pin, "rotating").growth_rate(*_constant()) == pytest.approx(ROTATING_RATE, rel=1e-6)
    model = joint_wear_model(roller)
    assert model.wear_area == pytest.approx(9.424778e-4, rel=1e-6)  # pi d w / 2
    assert model.growth_rate(*_constant()) == pytest.approx(ROLLER_RATE, rel=1e-6)


def test_wear_life_grows_the_clearance_at_the_hand_rate():
    """100 operating hours at constant load: the radial clearance of the fixed-load pin grows by
    100 * 0.1527887 um = 15.27887 um, of the rotating-load pin by 3.819719 um, the roller's free travel by
    7.639437 um; the recorded growth rates are the hand rates in m per operating hour."""
    joints = {"C": JointWear(PAIR, pin_diameter=D, bearing_length=L),
              "F": JointWear(PAIR, pin_diameter=D, bearing_length=L, load_direction="rotating"),
              "A": joint_wear_model(JointGeometry("A", "roller-in-groove", D, L, PAIR, None, ()))}
    c0 = {"C": 20e-6, "F": 15e-6, "A": 0.2e-3}

    def simulate(c):
        return {j: _constant() for j in joints}, {}

    res = wear_life(None, 100.0, simulate=simulate, joints=joints, initial_clearances=c0)
    assert res.completed and res.hours[-1] == pytest.approx(100.0)
    grown = {j: (res.clearance[j][-1] - c0[j]) * 1e6 for j in joints}
    assert grown == pytest.approx({"C": 15.27887, "F": 3.819719, "A": 7.639437}, rel=1e-6)
    for j, rate in (("C", FIXED_RATE), ("F", ROTATING_RATE), ("A", ROLLER_RATE)):
        np.testing.assert_allclose(res.growth_rate[j], rate * 3600.0, rtol=1e-6)


def test_pin_sliding_speed_is_relative_spin_times_pin_radius():
    """|omega_i - omega_j| d / 2: a pin of d = 20 mm turning at 12 rad/s relative to its bore slides at 0.12 m/s."""
    n_t = 5
    t = np.linspace(0.0, 0.01, n_t)
    y = np.zeros((n_t, 6))  # one body: (x, y, angle) then (vx, vy, omega)
    y[:, 5] = np.array([12.0, -12.0, 0.0, 3.0, 12.0])
    joint = SimpleNamespace(name="C", type="revolute_clearance", body_i="arm", body_j="ground")
    compiled = SimpleNamespace(spec=SimpleNamespace(joints=[joint]), body_index={"arm": 0}, n=3)
    result = SimpleNamespace(t=t, y=y, compiled=compiled)
    np.testing.assert_allclose(sliding_speed(result, "C", D), [0.12, 0.12, 0.0, 0.03, 0.12], rtol=1e-12)


def test_growth_rate_over_a_window_that_starts_late_on_an_uneven_grid():
    """The life loop reads a run after its first revolution, so the window does not start at t = 0.  A window from
    2.0 to 2.5 s, sampled unevenly, with the force ramping linearly from 200 to 600 N (mean 400 N; the trapezoid
    rule is exact for it) at 0.05 m/s wears at the hand rate of the worked example, 4.244132e-11 m/s; the worn
    volume over the window is 0.5 s * 2.0e-14 m^3/s = 1.0e-14 m^3."""
    t = np.array([2.0, 2.01, 2.05, 2.2, 2.21, 2.4, 2.5])
    force = 200.0 + 400.0 * (t - 2.0) / 0.5
    joint = JointWear(PAIR, pin_diameter=D, bearing_length=L)
    assert joint.growth_rate(t, force, np.full(t.size, V)) == pytest.approx(FIXED_RATE, rel=1e-6)
    volume = archard_wear_volume(force, np.full(t.size, V), t, K, HARD)
    assert volume[0] == 0.0 and volume[-1] == pytest.approx(0.5 * VOLUME_RATE, rel=1e-12)
