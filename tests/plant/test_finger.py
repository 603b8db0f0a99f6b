"""Comb fingers with their own compliance (berryshaker.plant.finger) and the contact description."""

import math

import pytest
from scipy import integrate

from berryshaker.config import machine_from_dict
from berryshaker.errors import ConfigError
from berryshaker.plant.finger import cantilever_stiffness, finger_contact, hertz_crossed_cylinders
from berryshaker.plant.spec import CombContactSpec, FingerSpec


def test_cantilever_stiffness_against_the_unit_load_method():
    """k = 3 E I / L^3 against the tip deflection by the unit-load method, delta = int_0^L M m / (E I) dx
    with M = F (L - x), m = (L - x), integrated numerically."""
    e, d, length = 2.5e9, 0.012, 0.2
    i = math.pi * d**4 / 64
    delta = integrate.quad(lambda x: (length - x) ** 2 / (e * i), 0, length)[0]  # per unit force
    assert cantilever_stiffness(e, d, length) == pytest.approx(1 / delta, rel=1e-10)
    with pytest.raises(ConfigError, match="free_length"):
        cantilever_stiffness(e, d, 0.0)


def test_hertz_crossed_equal_cylinders_is_sphere_on_flat():
    """Equal cylinders crossed at 90 deg = sphere of the same radius on a flat (Johnson 1985, sec. 4.2):
    K = (4/3) E* sqrt(R); for two equal materials E* = E / (2 (1 - nu^2))."""
    e, nu, d = 2.0e11, 0.3, 0.02
    assert hertz_crossed_cylinders(e, nu, d, e, nu, d) == pytest.approx(
        4 / 3 * e / (2 * (1 - nu**2)) * math.sqrt(d / 2))


def test_finger_contact_is_dominated_by_the_cantilever():
    fc = finger_contact(FingerSpec(), 0.0064)
    assert fc["cantilever_N_m"] == pytest.approx(954.26, rel=1e-4)
    assert fc["hertz_linear_N_m"] > 50 * fc["cantilever_N_m"]
    assert fc["series_stiffness_N_m"] == pytest.approx(
        1 / (1 / fc["cantilever_N_m"] + 1 / fc["hertz_linear_N_m"]))
    assert fc["first_mode_hz"] > 30  # massless-finger assumption: well above drive and stem frequencies


def test_explicit_stiffness_still_wins_and_finger_default_is_linear():
    assert CombContactSpec(stiffness=3e4).impact_stiffness(0.006) == (3e4, 1.5)
    assert CombContactSpec(stiffness=3e4, exponent=1.2).impact_stiffness(0.006) == (3e4, 1.2)
    k, n = CombContactSpec().impact_stiffness(0.0064)
    assert n == 1.0 and k == pytest.approx(finger_contact(FingerSpec(), 0.0064)["series_stiffness_N_m"])
    with pytest.raises(ValueError, match="exponent 1.5 given without stiffness"):
        CombContactSpec(exponent=1.5)


def test_machine_description_accepts_finger_geometry(machine):
    d = machine.model_dump()
    d["plant"]["contact"].update(stiffness=None, exponent=None, finger={"diameter": "10 mm", "free_length": "150 mm"})
    m = machine_from_dict(d)
    assert m.plant.contact.finger.diameter == pytest.approx(0.010)
    k, n = m.plant.contact.impact_stiffness(0.0064)
    assert n == 1.0 and k == pytest.approx(cantilever_stiffness(2.5e9, 0.010, 0.15), rel=0.02)
