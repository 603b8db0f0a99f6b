"""Fruit on a compliant stem (berryshaker.plant.pedicel): closed-form transmissibility, the rigid-stem
limit (study eq. 16), the two-way fruit-branch modes against the exact frequency response, and the
finger contact (berryshaker.plant.finger)."""

import math

import numpy as np
import pytest
from scipy import integrate

from berryshaker.errors import ConfigError
from berryshaker.plant.branch import Branch
from berryshaker.plant.modes import analytic_modes
from berryshaker.plant.pedicel import (damping_ratio, force_transmissibility, fruit_branch_modes, modal_mass_ratio,
                                       natural_frequency, stem_response, two_way_stem_force_frf)

M0, K, C = 1.8e-3, 82.3, 0.077
BRANCH = Branch(0.012, 0.004, 1.2, 0.83e9, 850.0, 0.07)


def test_natural_frequency_and_damping_ratio():
    assert natural_frequency(M0, K) == pytest.approx(math.sqrt(K / M0) / (2 * math.pi))
    assert damping_ratio(M0, K, C) == pytest.approx(C / (2 * math.sqrt(K * M0)))
    with pytest.raises(ConfigError, match="pedicel stiffness"):
        natural_frequency(M0, -1.0)


@pytest.mark.parametrize("r", [0.3, 0.8, 1.0, 1.5, 3.0, 8.0])
def test_steady_stem_force_matches_the_closed_form_transmissibility(r):
    """Harmonic base motion Y sin(w t): after the transient, |F| / (m0 w^2 Y) is the displacement
    transmissibility sqrt(1 + (2 zeta r)^2) / sqrt((1 - r^2)^2 + (2 zeta r)^2) (Thomson, Theory of
    Vibration with Applications, base excitation).  Both input forms (acceleration; displacement and
    velocity) are checked."""
    zeta = damping_ratio(M0, K, C)
    wn = 2 * math.pi * natural_frequency(M0, K)
    w = r * wn
    t = np.arange(0.0, 1.2, 2e-5)  # transient decays as exp(-zeta wn t): e^-17 at 0.8 s
    y_amp = 1e-3
    y, v, a = y_amp * np.sin(w * t), y_amp * w * np.cos(w * t), -y_amp * w * w * np.sin(w * t)
    tail = t > 0.8
    expected = force_transmissibility(r, zeta)
    for u, f in (stem_response(t, base_acceleration=a, mass=M0, stiffness=K, damping=C),
                 stem_response(t, y, v, mass=M0, stiffness=K, damping=C)):
        assert np.max(np.abs(f[tail])) / (M0 * w * w * y_amp) == pytest.approx(expected, rel=2e-3)
        # relative displacement amplitude: r^2 / sqrt((1 - r^2)^2 + (2 zeta r)^2) Y
        assert np.max(np.abs(u[tail])) / y_amp == pytest.approx(
            r * r / math.sqrt((1 - r * r) ** 2 + (2 * zeta * r) ** 2), rel=2e-3)


def test_rigid_stem_limit_is_the_study_eq16():
    """k -> inf: the stem force tends to m0 x base acceleration (study eq. 16), for an arbitrary
    (non-harmonic) base motion."""
    t = np.arange(0.0, 0.5, 1e-5)
    a = 40.0 * np.sin(2 * math.pi * 3 * t) + 25.0 * np.exp(-((t - 0.2) / 0.004) ** 2)
    for k, tol in ((1e7, 2e-3), (1e9, 2e-5)):
        c = 2 * 0.1 * math.sqrt(k * M0)
        _, f = stem_response(t, base_acceleration=a, mass=M0, stiffness=k, damping=c)
        assert np.max(np.abs(f - M0 * a)) < tol * np.max(np.abs(M0 * a))


def test_stem_force_is_independent_of_the_input_form_for_consistent_motion():
    """Displacement/velocity form against the acceleration form for a base motion with an impulsive
    acceleration pulse (both exact discretisations of the same equation)."""
    t = np.arange(0.0, 0.3, 1e-5)
    a = 300.0 * np.exp(-((t - 0.05) / 5e-4) ** 2) - 50 * np.sin(2 * math.pi * 7 * t)
    v = integrate.cumulative_trapezoid(a, t, initial=0.0)
    y = integrate.cumulative_trapezoid(v, t, initial=0.0)
    _, f1 = stem_response(t, base_acceleration=a, mass=M0, stiffness=K, damping=C)
    _, f2 = stem_response(t, y, v, mass=M0, stiffness=K, damping=C)
    assert np.max(np.abs(f1 - f2)) < 2e-3 * np.max(np.abs(f1))


def test_rows_with_their_own_parameters():
    t = np.arange(0.0, 0.4, 1e-4)
    a = np.vstack([np.sin(2 * math.pi * 5 * t), np.sin(2 * math.pi * 9 * t)])
    u, f = stem_response(t, base_acceleration=a, mass=[M0, 2 * M0], stiffness=K, damping=C)
    _, f1 = stem_response(t, base_acceleration=a[1], mass=2 * M0, stiffness=K, damping=C)
    np.testing.assert_allclose(f[1], f1)
    with pytest.raises(ConfigError, match="uniformly sampled"):
        stem_response(np.array([0.0, 0.1, 0.3]), base_acceleration=np.zeros(3))
    with pytest.raises(ConfigError, match="base_acceleration, or both"):
        stem_response(t, base_displacement=a[0])


def test_mass_ratio_criterion_fails_at_the_thin_end_of_the_reference_branch():
    """mu_k = m0 phi_k(z)^2: 1.8 g against the effective modal mass at the fruit.  The branch weighs
    56 g, but near its 4.6 mm end the first mode's effective mass is under 10 g: mu_1 ~ 0.2, so the
    fruit cannot be one-way coupled there (documented; the coupled run puts it in the modal model)."""
    modes = analytic_modes(BRANCH, 8)
    assert BRANCH.mass == pytest.approx(0.0555, rel=0.01)
    assert modal_mass_ratio(modes, 0.24, M0).max() < 0.05
    assert modal_mass_ratio(modes, 1.02, M0)[0] > 0.15
    # the one-way error is as large as the criterion says: stem-force peaks differ by tens of percent
    f = np.linspace(0.5, 30, 300)
    one, two = two_way_stem_force_frf(modes, 0.84, [0.24, 0.6, 1.02], M0, K, C, f)
    assert np.abs(one[2]).max() / np.abs(two[2]).max() - 1 > 0.2


def test_fruit_branch_modes_reproduce_the_exact_two_way_response():
    """Combined modes (Rayleigh-Ritz) against the exact two-way frequency response of the same branch
    modes + fruit on stems, solved directly (undamped: the combined modes' damping is modal, a stated
    departure, so the identity is checked without damping)."""
    b = Branch(0.012, 0.004, 1.2, 0.83e9, 850.0, 0.0)
    modes = analytic_modes(b, 16)
    z = np.array([0.24, 0.6, 1.02])
    fb = fruit_branch_modes(modes, z, M0, K, 0.0)
    assert len(fb.modes.omega) == 19
    # attached fruit lower the first branch mode (Rayleigh quotient): 1.745 -> 1.575 Hz
    assert fb.modes.frequency_hz[0] < 0.95 * modes.frequency_hz[0]
    f = np.linspace(0.7, 45, 500)
    _, exact = two_way_stem_force_frf(modes, 0.84, z, M0, K, 0.0, f)
    pf = fb.modes.shape_at(np.array([0.84]))[:, 0]
    rel = fb.modes.shape_at(z) - fb.fruit
    wk = fb.modes.omega
    modal = np.array([K * (rel.T @ (pf / (wk**2 - (2 * math.pi * x) ** 2))) for x in f]).T
    np.testing.assert_allclose(modal, exact, atol=1e-8 * np.abs(exact).max())
    # the stem force from the combined modal coordinates: k (y - x) + c (y' - x')
    eta = np.zeros((2, 19))
    eta[1, 0] = 1.0
    fs = fruit_branch_modes(modes, z, M0, K, 0.05).stem_force(eta, np.zeros_like(eta))
    np.testing.assert_allclose(fs[:, 1], K * (fb.modes.shape_at(z)[0] - fb.fruit[0]))
