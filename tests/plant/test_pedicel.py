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
from berryshaker.plant.pedicel import (
    MINER_EXPONENTS,
    damping_ratio,
    force_transmissibility,
    fruit_branch_modes,
    modal_mass_ratio,
    natural_frequency,
    peak_stem_force,
    peak_stem_loads,
    stem_response,
    two_way_stem_force_frf,
)

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


@pytest.mark.parametrize("r", [0.5, 1.0, 4.0])
def test_peak_stem_force_matches_the_closed_form_transmissibility(r):
    """The virtual harvest's compiled peak pass (peak_stem_force) under harmonic lateral base motion Y sin(w t)
    brought in by a slow smooth ramp (quintic smoothstep over 0.4 s, many stem periods: no transient worth the
    name), no axial motion, no weight: the peak over the run is m0 w^2 Y times the closed-form transmissibility
    (Thomson, base excitation)."""
    zeta = damping_ratio(M0, K, C)
    wn = 2 * math.pi * natural_frequency(M0, K)
    w = r * wn
    t = np.arange(0.0, 1.2, 2e-5)
    y_amp = 1e-3
    s = np.clip(t / 0.4, 0.0, 1.0)
    ramp, dramp = s**3 * (10 - 15 * s + 6 * s * s), np.where(t < 0.4, 30 * s * s * (1 - s) ** 2 / 0.4, 0.0)
    y = y_amp * ramp * np.sin(w * t)
    v = y_amp * (dramp * np.sin(w * t) + ramp * w * np.cos(w * t))
    zero = np.zeros_like(y)
    peak = peak_stem_force(t, (y[None], v[None]), (zero[None], zero[None]), [M0], K, C, weight=False)
    assert peak.shape == (1, 1)
    assert peak[0, 0] / (M0 * w * w * y_amp) == pytest.approx(force_transmissibility(r, zeta), rel=5e-3)


def test_peak_stem_force_is_the_peak_of_stem_response():
    """The table of peaks of the virtual harvest (peak_stem_force: positions x masses in one compiled state-space
    pass) equals the peak over time of hypot(lateral stem force, axial stem force + m0 g) from stem_response
    (second-order sections) to round-off, for an irregular lateral and axial base motion (measured 1e-12;
    4.6e-11 on a coupled run's branch motion)."""
    t = np.arange(0.0, 0.4, 2e-5)
    rng = np.random.default_rng(3)
    rows = []
    for _ in range(4):
        f1, f2, tc = rng.uniform(3, 40), rng.uniform(3, 40), rng.uniform(0.05, 0.35)
        a = (rng.uniform(5, 60) * np.sin(2 * math.pi * f1 * t) + rng.uniform(50, 400) * np.exp(-((t - tc) / 8e-4) ** 2)
             + rng.uniform(5, 60) * np.cos(2 * math.pi * f2 * t))
        v = integrate.cumulative_trapezoid(a, t, initial=0.0)
        rows.append((integrate.cumulative_trapezoid(v, t, initial=0.0), v))
    y, v = np.array([r[0] for r in rows]), np.array([r[1] for r in rows])
    ya, va = 0.05 * y[::-1], 0.05 * v[::-1]
    masses = np.array([0.7, 1.0, 2.2]) * M0
    for weight in (True, False):
        table = peak_stem_force(t, (y, v), (ya, va), masses, K, C, weight=weight)
        for j, m in enumerate(masses):
            _, f_lat = stem_response(t, y, v, mass=m, stiffness=K, damping=C)
            _, f_ax = stem_response(t, ya, va, mass=m, stiffness=K, damping=C)
            ref = np.max(np.hypot(f_lat, f_ax + (m * 9.80665 if weight else 0.0)), axis=1)
            np.testing.assert_allclose(table[:, j], ref, rtol=1e-9)
    with pytest.raises(ConfigError, match="shape"):
        peak_stem_force(t, (y, v), (ya[:, :-1], va[:, :-1]), masses, K, C)
    # the pull-shear load ratios of the same pass: the peak over time of sqrt((max(F_ax + m g, 0)/P)^2 + (F_lat/S)^2)
    # from the same series, for two (P, S) pairs; the axial motion is made large enough to compress the pedicel
    from berryshaker.plant.pedicel import peak_stem_loads

    strengths = [(0.47, 0.23), (2.3, 1.1)]
    ya, va = 3.0 * y[::-1], 3.0 * v[::-1]
    loads = peak_stem_loads(t, (y, v), (ya, va), masses, K, C, True, strengths)
    assert loads.shape == (4, 3, 3)
    for j, m in enumerate(masses):
        _, f_lat = stem_response(t, y, v, mass=m, stiffness=K, damping=C)
        _, f_ax = stem_response(t, ya, va, mass=m, stiffness=K, damping=C)
        pull = f_ax + m * 9.80665
        assert np.any(pull < 0)  # compression occurs and must not count as pull
        np.testing.assert_allclose(loads[:, j, 0], np.max(np.hypot(f_lat, pull), axis=1), rtol=1e-9)
        for s_, (p_, sh) in enumerate(strengths):
            ref = np.max(np.hypot(np.maximum(pull, 0.0) / p_, f_lat / sh), axis=1)
            np.testing.assert_allclose(loads[:, j, 1 + s_], ref, rtol=1e-9)
    with pytest.raises(ConfigError, match="strengths"):
        peak_stem_loads(t, (y, v), (ya, va), masses, K, C, True, [(0.47, 0.0)])


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


def test_remembered_discretisation_is_scipys_and_cannot_be_corrupted():
    """discretise_foh returns cont2discrete's matrices, fresh arrays on every call (a caller that writes into
    them must not change what the next replicate run gets)."""
    from scipy import signal

    from berryshaker.plant.pedicel import discretise_foh

    a = np.array([[0.0, 1.0], [-K / M0, -C / M0]])
    b = np.array([[0.0, 0.0], [K / M0, C / M0]])
    c, d = np.array([[-K, -C]]), np.array([[K, C]])
    ref = signal.cont2discrete((a, b, c, d), 1e-4, method="foh")[:4]
    first = discretise_foh(a, b, c, d, 1e-4)
    for x, r in zip(first, ref):
        assert np.array_equal(x, r)
        x[...] = 0.0
    assert all(np.array_equal(x, r) for x, r in zip(discretise_foh(a, b, c, d, 1e-4), ref))
    assert not np.array_equal(discretise_foh(a, b, c, d, 2e-4)[0], ref[0])  # the step is part of the key


def _base_motion(n_z=3, n_t=6000, h=1e-4, rest=1500):
    """Branch displacement and velocity at n_z positions: at rest for ``rest`` samples, then two harmonics (12 and
    31 Hz, a different amplitude per position) in both directions."""
    t = np.arange(n_t) * h
    tau = np.maximum(np.arange(n_t) - rest, 0) * h
    amp = np.linspace(2e-3, 6e-3, n_z)[:, None]
    w1, w2 = 2 * math.pi * 12.0, 2 * math.pi * 31.0
    y = amp * (np.sin(w1 * tau) + 0.4 * np.sin(w2 * tau))
    v = amp * (w1 * np.cos(w1 * tau) + 0.4 * w2 * np.cos(w2 * tau)) * (np.arange(n_t) >= rest)
    return t, (y, v), (0.3 * y, 0.3 * v)


def test_a_stiffer_pedicel_is_a_lighter_fruit_scaled():
    """The identity behind reading a stem-load table at another pedicel stiffness
    (berryshaker.harvest.virtual.stem_force_tables): with its damping scaled alike, a pedicel a times stiffer carries
    a times the loads of a fruit a times lighter on the described pedicel -- the force with its weight, the peak
    pull-shear ratios and their Miner-Basquin sums -- to round-off; a stiffness scaled without its damping does not
    (the identity can fail)."""
    t, lat, ax = _base_motion()
    mass = np.array([1.0e-3, 1.8e-3, 3.0e-3])
    st = [(0.47, 0.23), (2.05, 1.0)]
    for a in (0.4, 2.5):
        stiff = peak_stem_loads(t, lat, ax, mass, a * 10.0, a * 0.027, True, st, MINER_EXPONENTS)
        light = peak_stem_loads(t, lat, ax, mass / a, 10.0, 0.027, True, st, MINER_EXPONENTS)
        assert stiff == pytest.approx(a * light, rel=1e-12, abs=0)
        undamped = peak_stem_loads(t, lat, ax, mass, a * 10.0, 0.027, True, st, MINER_EXPONENTS)
        assert not np.allclose(undamped, a * light, rtol=1e-3)


def test_samples_of_rest_before_the_branch_moves_change_nothing():
    """The pass starts at the last sample before the branch moves: a longer rest before it gives the same peaks and
    Miner-Basquin sums, bit for bit."""
    t, lat, ax = _base_motion(rest=1500)
    t2, lat2, ax2 = _base_motion(n_t=6000 + 2500, rest=4000)
    mass = np.array([1.8e-3])
    st = [(0.47, 0.23)]
    assert np.array_equal(peak_stem_loads(t, lat, ax, mass, 10.0, 0.027, True, st, MINER_EXPONENTS),
                          peak_stem_loads(t2, lat2, ax2, mass, 10.0, 0.027, True, st, MINER_EXPONENTS))
