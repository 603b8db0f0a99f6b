"""Contact laws from geometry and materials: checks against derivable limits and independent sources."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from berryshaker.contact import force_laws
from berryshaker.contact.conformal import (
    fit_power_law,
    hysteresis_damping_coefficient,
    hysteresis_factor,
    line_contact_approach,
    line_contact_force,
    line_contact_load_limit,
    linear_damping_for_restitution,
    material_constants,
    pereira_power_law,
    restitution_of_linear_damping,
    roller_on_wall_law,
)
from berryshaker.contact.pin_in_bore import pin_in_bore_law, pin_in_bore_stiffness
from berryshaker.contact.stiffness import effective_modulus, roller_on_flat_stiffness
from berryshaker.errors import ConfigError

ES = effective_modulus(207e9, 0.3, 207e9, 0.3)


def test_existing_helpers_unchanged():
    assert pin_in_bore_stiffness(207e9, 0.3, 207e9, 0.3, 0.010, 0.0105) == pytest.approx(6.9e10, rel=0.01)
    assert roller_on_flat_stiffness(0.02)[1] == pytest.approx(10 / 9)


def test_dimensional_homogeneity():
    """Same physics in (m, N, Pa) and (mm, N, MPa): the approach must come out in the length unit used."""
    f = np.array([10.0, 1e3, 1e4])
    d_si = line_contact_approach(f, 0.025, 0.15e-3, ES)
    d_mm = line_contact_approach(f, 25.0, 0.15, ES * 1e-6)
    np.testing.assert_allclose(d_mm, d_si * 1e3, rtol=1e-12)


def test_stiffness_rises_as_clearance_falls():
    kt = [pin_in_bore_law(0.010, c, 0.025).tangent_stiffness(1e3) for c in (0.05e-3, 0.1e-3, 0.2e-3, 0.5e-3)]
    assert np.all(np.diff(kt) < 0)


def test_conformal_tends_to_external_contact_for_a_large_bore():
    """A pin in a huge bore sees a nearly flat wall, as a pin on a huge convex cylinder does."""
    r1, f, length = 0.010, np.geomspace(10, 1e4, 5), 0.025
    for r2 in (1.0, 10.0):
        internal = line_contact_approach(f, length, r2 - r1, ES)
        external = line_contact_approach(f, length, r2 + r1, ES)
        np.testing.assert_allclose(internal / external, 1.0, atol=3 * r1 / r2)


def test_inverse_is_exact():
    f = np.geomspace(1.0, 2e4, 40)
    d = line_contact_approach(f, 0.02, 0.1e-3, ES)
    np.testing.assert_allclose(line_contact_force(d, 0.02, 0.1e-3, ES), f, rtol=1e-10)
    assert line_contact_force(np.array([-1e-6, 0.0]), 0.02, 0.1e-3, ES).tolist() == [0.0, 0.0]


def test_power_law_fit_reproduces_the_model_within_its_reported_error():
    law = pin_in_bore_law(0.010, 0.15e-3, 0.025, force_range=(10.0, 1e4))
    rng = np.random.default_rng(1)
    f = np.exp(rng.uniform(math.log(10.0), math.log(1e4), 500))
    d = law.approach(f)
    err = np.max(np.abs(law.fit.force(d) - f) / f)
    assert err <= law.fit.max_relative_error * 1.001
    assert law.fit.max_relative_error < 0.10  # a single power law is an adequate engine input here
    assert 1.0 < law.fit.exponent < 1.5


@pytest.mark.parametrize("clearance", [0.1e-3, 0.2e-3, 0.5e-3])
def test_pereira_law_agrees_with_johnson_it_was_fitted_to(clearance):
    """An independent closed form (Pereira et al. 2011) against Johnson's relation: a wrong constant fails."""
    k, n = pereira_power_law(clearance, 0.025, ES)
    f = np.geomspace(1e3, 2e4, 30)
    d = line_contact_approach(f, 0.025, clearance, ES)
    np.testing.assert_allclose(k * d**n / f, 1.0, atol=0.15)


def test_roller_on_flat_matches_palmgren():
    """Palmgren's empirical roller-raceway law (steel) vs Johnson with the flat's reference depth 2 R."""
    law = roller_on_wall_law(0.015, 0.020)
    k, n = roller_on_flat_stiffness(0.020)
    f = np.geomspace(100.0, 1e4, 10)
    np.testing.assert_allclose((f / k) ** (1 / n) / law.approach(f), 1.0, atol=0.08)


def test_roller_wall_types():
    """Convex, concave and flat walls all give usable laws; in 2-D they differ only through ln dR
    (the reference points of the compression), so within +-10 % at 1 kN for the reference roller."""
    f = 1e3
    d = [roller_on_wall_law(0.015, 0.02, r).approach(f) for r in (0.05, math.inf, -0.1)]
    assert max(d) / min(d) < 1.10
    assert roller_on_wall_law(0.015, 0.02, 0.05).pereira is not None
    with pytest.raises(ConfigError):
        roller_on_wall_law(0.015, 0.02, -0.010)


def test_conformal_limit_is_refused():
    with pytest.raises(ConfigError, match="conformal"):
        pin_in_bore_law(0.010, 0.01e-3, 0.020, "nylon", "nylon", force_range=(10.0, 1e4))


def test_materials():
    assert material_constants("Steel") == (207e9, 0.3)
    with pytest.raises(ConfigError, match="unknown|not known"):
        material_constants("unobtainium")
    soft = pin_in_bore_law(0.010, 0.15e-3, 0.025, "steel", "nylon", force_range=(1.0, 500.0))
    hard = pin_in_bore_law(0.010, 0.15e-3, 0.025, "steel", "bronze")
    assert soft.tangent_stiffness(100.0) < hard.tangent_stiffness(100.0)


@settings(max_examples=60, deadline=None)
@given(c=st.floats(0.02e-3, 1e-3), length=st.floats(0.005, 0.05),
       d1=st.floats(1e-9, 3e-6), d2=st.floats(1e-9, 3e-6))
def test_force_monotone_in_penetration(c, length, d1, d2):
    lo, hi = sorted((d1, d2))
    f_lo, f_hi = line_contact_force(np.array([lo, hi]), length, c, ES)
    assert f_hi >= f_lo
    assert 0 < f_hi < line_contact_load_limit(length, c, ES)


def test_fit_rejects_bad_range():
    with pytest.raises(ConfigError):
        fit_power_law(lambda f: f, (10.0, 1.0))


# ------------------------------------------------------------------------------------------------
def test_hysteresis_factors_match_force_laws():
    k, n, e, v0, delta = 1e9, 1.5, 0.7, 0.3, 1e-6
    for model, law in (("flores", force_laws.flores), ("lankarani_nikravesh", force_laws.lankarani_nikravesh)):
        f = law(delta, v0, v0, k, e, n)
        assert f == pytest.approx(k * delta**n * (1 + hysteresis_factor(e, model)))
        chi = hysteresis_damping_coefficient(k, e, v0, model)
        assert f == pytest.approx(k * delta**n + chi * delta**n * v0)
    with pytest.raises(ConfigError):
        hysteresis_factor(0.0)


@pytest.mark.parametrize("e", [0.3, 0.7, 0.95])
def test_linear_damping_gives_the_restitution(e):
    """Integrate a linear spring-dashpot impact (separation at delta = 0) and measure e."""
    from scipy.integrate import solve_ivp

    k, m, v0 = 5e7, 2.0, 0.5
    c = linear_damping_for_restitution(k, m, e)
    assert restitution_of_linear_damping(k, m, c) == pytest.approx(e, rel=1e-12)

    def leave(t, y):
        return y[0] if t > 0 else 1.0

    leave.terminal, leave.direction = True, -1
    sol = solve_ivp(lambda t, y: [y[1], -(k * y[0] + c * y[1]) / m], (0, 1.0), [0.0, v0],
                    events=leave, rtol=1e-11, atol=1e-15, max_step=1e-5)
    v_out = sol.y_events[0][0][1]
    assert -v_out / v0 == pytest.approx(e, rel=1e-6)


def test_effective_modulus_of_unlike_bodies_by_hand():
    """Steel pin (E1 = 207 GPa, nu1 = 0.30) on a bronze bush (E2 = 110 GPa, nu2 = 0.34), Johnson (1985) eq. 4.22:

        (1 - 0.30^2) / 207e9 = 0.91 / 207e9   = 4.396135e-12 1/Pa
        (1 - 0.34^2) / 110e9 = 0.8844 / 110e9 = 8.040000e-12 1/Pa
        E* = 1 / 1.2436135e-11                 = 80.41083 GPa

    and the Flores-Ambrosio pin (R = 10 mm in a 10.5 mm bore, R* = 0.21 m) with it:
    K = 4/3 * 80.41083e9 * sqrt(0.21) = 4.913183e10 N/m^1.5.  Every other test pairs like materials
    (nu1 = nu2, E1 = E2), which cannot tell nu1 from nu2 or E1 from E2."""
    assert effective_modulus(207e9, 0.30, 110e9, 0.34) == pytest.approx(80.41083e9, rel=1e-6)
    assert effective_modulus(110e9, 0.34, 207e9, 0.30) == pytest.approx(80.41083e9, rel=1e-6)  # either body first
    assert pin_in_bore_stiffness(207e9, 0.30, 110e9, 0.34, 0.010, 0.0105) == pytest.approx(4.913183e10, rel=1e-6)
    # a rigid counterpart (E2 -> infinity): E* = E1 / (1 - nu1^2) = 207e9 / 0.91 = 227.4725 GPa, whatever nu2 is
    assert effective_modulus(207e9, 0.30, 1e30, 0.0) == pytest.approx(227.4725e9, rel=1e-6)
    assert effective_modulus(207e9, 0.30, 1e30, 0.45) == pytest.approx(227.4725e9, rel=1e-6)
