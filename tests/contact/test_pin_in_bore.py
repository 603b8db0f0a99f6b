"""The one home of pin-in-bore contact stiffness (berryshaker.contact.pin_in_bore): both models live there, the
formulas they share are computed once, and every caller gets the numbers it got before the move (exact floats of
the previous implementations in stiffness.py and conformal.py)."""

from __future__ import annotations

import inspect
import math

import pytest

import berryshaker.contact as contact_pkg
from berryshaker.contact import conformal, pair_law, pin_in_bore, stiffness
from berryshaker.contact.pin_in_bore import (
    ARC_LIMIT,
    arc_limit_load,
    conformal_radius,
    pin_in_bore_law,
    pin_in_bore_stiffness,
)
from berryshaker.contact.stiffness import effective_modulus
from berryshaker.errors import ConfigError


def test_one_home_and_the_old_import_path_is_the_same_function():
    assert not hasattr(stiffness, "pin_in_bore_stiffness")
    assert contact_pkg.pin_in_bore_stiffness is pin_in_bore_stiffness
    assert not hasattr(conformal, "pin_in_bore_law")
    assert pair_law.pin_in_bore_law is pin_in_bore_law
    for module in (stiffness, conformal, pair_law):  # no second implementation of either model or the arc limit
        src = inspect.getsource(module)
        assert "def pin_in_bore" not in src and "0.35**2" not in src, module.__name__
    with pytest.raises(AttributeError):
        stiffness.no_such_name  # noqa: B018


def test_hertz_model_numbers_are_the_previous_ones():
    # exact floats of the previous stiffness.pin_in_bore_stiffness (Flores & Ambrosio pin, steel and steel-bronze)
    assert pin_in_bore_stiffness(207e9, 0.3, 207e9, 0.3, 0.010, 0.0105) == 69494005044.38522
    assert pin_in_bore_stiffness(207e9, 0.3, 110e9, 0.34, 0.010, 0.0105) == 49131830718.01868
    es = effective_modulus(207e9, 0.3, 207e9, 0.3)
    assert pin_in_bore_stiffness(207e9, 0.3, 207e9, 0.3, 0.010, 0.0105) == 4.0 / 3.0 * es * math.sqrt(
        conformal_radius(0.010, 0.0105))
    assert conformal_radius(0.010, 0.0105) == pytest.approx(0.21, rel=1e-12)


def test_line_model_numbers_are_the_previous_ones():
    # the previous conformal.pin_in_bore_law's numbers: the closed forms exactly, the least-squares fit to 1e-12
    # (its last digits follow the LAPACK build)
    law = pin_in_bore_law(0.010, 1.5e-4, 0.02)
    assert (law.fit.stiffness, law.fit.exponent) == pytest.approx((6704083635.230729, 1.1382338507220864), rel=1e-12)
    assert law.pereira == (14082333776.08193, 1.1951232058504722)
    law = pin_in_bore_law(0.010, 1.5e-4, 0.025, "steel", "bronze", (100.0, 2e4))
    assert (law.fit.stiffness, law.fit.exponent) == pytest.approx((9910411163.539024, 1.1756549007633146), rel=1e-12)
    assert law.e_star == 80410833320.38472


def test_reference_pin_pair_numbers_are_the_previous_ones():
    """Pair C of the reference machine (20 mm pin, c = 0.1 mm, 25 mm, steel on greased bronze): the fit range's top
    is the arc limit, so this also pins :func:`arc_limit_load`."""
    g = pair_law.pair_geometry("pin-in-bore", 1e-4, 0.02, 0.025, "steel-on-bronze-greased")
    assert pair_law.fit_range_for(g) == (100.0, 19130.4266585878)
    law = pair_law.geometric_contact_law(g)
    assert (law.fit.stiffness, law.fit.exponent) == (12716813138.094248, 1.188618428417474)


def test_the_arc_limit_is_one_formula_for_the_law_and_the_fit_range():
    r, c, length = 0.010, 0.01e-3, 0.020
    es = effective_modulus(207e9, 0.3, 2.8e9, 0.39)
    f_arc = arc_limit_load(r, c, length, es)
    # the half-width a^2 = 4 F R* / (pi L E*) is ARC_LIMIT * R_pin at F_arc
    assert math.sqrt(4 * f_arc * conformal_radius(r, r + c) / (math.pi * length * es)) == pytest.approx(
        ARC_LIMIT * r, rel=1e-12)
    with pytest.raises(ConfigError, match="half-width .* 0.35 of the pin radius|half-width .* of the pin radius"):
        pin_in_bore_law(r, c, length, "steel", "nylon", force_range=(1.0, 1.001 * f_arc))
    pin_in_bore_law(r, c, length, "steel", "nylon", force_range=(0.01 * f_arc, 0.999 * f_arc))
    assert pin_in_bore.ARC_LIMIT == 0.35
