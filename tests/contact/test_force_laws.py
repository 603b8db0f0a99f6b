"""Contact force laws, friction, stiffness helpers and clearance-joint geometry."""

import math

import numpy as np
import pytest
from numba import njit
from scipy.integrate import solve_ivp

from berryshaker.contact import (
    adams_step,
    closest_point_on_curve,
    coulomb_friction,
    flores,
    hertz,
    hunt_crossley,
    impact,
    lankarani_nikravesh,
    mlsd,
    pin_in_bore_stiffness,
    point_line_clearance,
    revolute_clearance,
    roller_on_flat_stiffness,
    viscous_friction,
)
from berryshaker.contact.force_laws import hertz_kernel, impact_kernel, mlsd_kernel


def test_hand_values():
    assert hertz(1e-5, 1e9) == pytest.approx(1e9 * 1e-5**1.5)  # 31.6228 N
    assert mlsd(2e-5, 0.01, 1e8, 2000.0) == pytest.approx(1e8 * 2e-5 + 2000 * 0.01)  # 2020 N
    assert mlsd(2e-5, -5.0, 1e8, 2000.0) == 0.0  # would pull: clamped
    # LN at onset velocity, penetration 1e-5, K = 1e9, e = 0.8, v = 1 (delta_dot = v):
    # F = K d^1.5 (1 + 3(1 - 0.64)/4) = 31.6228 * 1.27
    assert lankarani_nikravesh(1e-5, 1.0, 1.0, 1e9, 0.8) == pytest.approx(31.6227766 * 1.27)
    assert flores(1e-5, 1.0, 1.0, 1e9, 0.8) == pytest.approx(31.6227766 * (1 + 8 * 0.2 / 4.0))
    assert hunt_crossley(1e-5, 1.0, 1e9, 0.8, impact_velocity=1.0) == pytest.approx(31.6227766 * 1.3)
    with pytest.raises(ValueError, match="impact_velocity"):
        hunt_crossley(1e-5, 1.0, 1e9, 0.8)
    with pytest.raises(ValueError, match="restitution"):
        flores(1e-5, 1.0, 1.0, 1e9, 1.5)


def test_negative_penetration_gives_zero_and_dissipative_laws_never_pull():
    rng = np.random.default_rng(1)
    d = rng.uniform(-1e-4, 1e-4, 2000)
    dd = rng.uniform(-5, 5, 2000)
    for f in (mlsd(d, dd, 1e8, 5e3), hertz(d, 1e9), lankarani_nikravesh(d, dd, 1.0, 1e9, 0.5),
              flores(d, dd, 1.0, 1e9, 0.3), hunt_crossley(d, dd, 1e9, 0.5, impact_velocity=1.0)):
        assert np.all(f >= 0)
        assert np.all(f[d <= 0] == 0)


def test_adams_step_and_impact_match_their_documented_definitions():
    # STEP: h0 below x0, h1 above x1, mean value at the midpoint, cubic 3D^2-2D^3 in between
    assert adams_step(-1.0, 0.0, 2.0, 1.0, 5.0) == 2.0
    assert adams_step(2.0, 0.0, 2.0, 1.0, 5.0) == 5.0
    assert adams_step(0.5, 0.0, 2.0, 1.0, 5.0) == pytest.approx(3.5)
    assert adams_step(0.25, 0.0, 2.0, 1.0, 5.0) == pytest.approx(2.0 + 3.0 * (0.0625 * 2.5))
    # IMPACT(x, x_dot, x1, k, e, cmax, d)
    k, e, cmax, d, x1 = 1e5, 1.5, 100.0, 1e-4, 1.0
    assert impact(1.0, -0.1, x1, k, e, cmax, d) == 0.0  # x >= x1
    assert impact(1.1, -0.1, x1, k, e, cmax, d) == 0.0
    x = x1 - d / 2  # half-way into the damping ramp: damping coefficient cmax/2
    assert impact(x, -0.1, x1, k, e, cmax, d) == pytest.approx(k * (d / 2) ** e + cmax / 2 * 0.1)
    x = x1 - 3 * d  # beyond the ramp: full damping
    assert impact(x, -0.1, x1, k, e, cmax, d) == pytest.approx(k * (3 * d) ** e + cmax * 0.1)
    assert impact(x, 50.0, x1, k, e, cmax, d) == 0.0  # separating fast: never negative


def test_kernels_are_callable_from_compiled_code():
    @njit
    def f(x):
        return hertz_kernel(x, 1e9, 1.5) + mlsd_kernel(x, 0.0, 1e8, 0.0) + impact_kernel(1.0 - x, 0.0, 1.0, 1e9, 1.5, 0.0, 1e-4)

    assert f(1e-5) == pytest.approx(2 * 31.6227766 + 1e3)


def _single_impact(law, e=1.0, k=1e9, m=1.0, v=1.0):
    """Mass m hits a wall at v; returns the rebound-to-impact velocity ratio (effective restitution)."""
    def rhs(t, y):
        d, dd = y
        if law == "hertz":
            f = hertz(d, k)
        elif law == "ln":
            f = lankarani_nikravesh(d, dd, v, k, e)
        elif law == "flores":
            f = flores(d, dd, v, k, e)
        else:
            f = hunt_crossley(d, dd, k, e, impact_velocity=v)
        return [dd, -float(f) / m]

    out = lambda t, y: y[0] + 1e-12  # noqa: E731
    out.terminal, out.direction = True, -1
    sol = solve_ivp(rhs, [0, 1e-2], [0.0, v], rtol=1e-10, atol=1e-14, events=out, max_step=1e-6)
    return -sol.y[1, -1] / v


def test_hertz_elastic_impact_conserves_energy():
    assert _single_impact("hertz") == pytest.approx(1.0, abs=1e-6)


def test_effective_restitution_behaves_as_in_the_literature():
    """Flores et al. (2011), Multibody Syst. Dyn. 25:357-375, sec. 5 and Fig. 9: Lankarani-Nikravesh and
    Hunt-Crossley reproduce the target e only near e = 1 and dissipate too little for lower e; the
    Flores model follows the target over the whole range."""
    for law in ("ln", "flores", "hc"):
        assert _single_impact(law, 0.9) == pytest.approx(0.9, abs=0.02)
    e_ln, e_fl, e_hc = (_single_impact(law, 0.5) for law in ("ln", "flores", "hc"))
    assert e_fl == pytest.approx(0.5, abs=0.05)
    assert e_ln > 0.65 and e_hc > 0.6  # far above the target 0.5


def test_stiffness_helpers():
    # Flores & Ambrosio (2004) benchmark joint: journal 10 mm, bearing 10.5 mm, steel 207 GPa, 0.3
    k = pin_in_bore_stiffness(207e9, 0.3, 207e9, 0.3, 0.010, 0.0105)
    estar = 207e9 / (2 * (1 - 0.09))
    assert k == pytest.approx(4 / 3 * estar * math.sqrt(0.010 * 0.0105 / 0.0005), rel=1e-12)
    with pytest.raises(ValueError):
        pin_in_bore_stiffness(207e9, 0.3, 207e9, 0.3, 0.011, 0.0105)
    # Palmgren: delta(mm) = 3.84e-5 Q^0.9 / l^0.8 -> at Q = 1000 N, l = 20 mm
    kk, n = roller_on_flat_stiffness(0.020)
    delta_mm = 3.84e-5 * 1000**0.9 / 20**0.8
    assert kk * (delta_mm * 1e-3) ** n == pytest.approx(1000.0, rel=1e-9)


def test_friction():
    assert coulomb_friction(1.0, 100.0, 0.3) == pytest.approx(-30.0)
    assert coulomb_friction(-1.0, 100.0, 0.3) == pytest.approx(30.0)
    assert coulomb_friction(5e-5, 100.0, 0.3) == 0.0
    assert coulomb_friction(5.5e-4, 100.0, 0.3) == pytest.approx(-0.3 * 100 * 0.5)
    assert viscous_friction(2.0, 3.0) == -6.0


def test_revolute_geometry_and_rates():
    c = 0.5e-3
    t = np.linspace(0, 1e-2, 1001)
    pin = np.stack([0.6e-3 * np.cos(50 * t), 0.6e-3 * np.sin(80 * t) + 1e-4 * t], axis=-1)
    vpin = np.stack([-0.03 * np.sin(50 * t), 0.048 * np.cos(80 * t) + 1e-4], axis=-1)
    k = revolute_clearance(pin, vpin, np.zeros_like(pin), np.zeros_like(pin), c)
    np.testing.assert_allclose(k.penetration, np.linalg.norm(pin, axis=1) - c)
    np.testing.assert_allclose(np.linalg.norm(k.normal, axis=1), 1.0)
    np.testing.assert_allclose(np.gradient(k.penetration, t)[1:-1], k.normal_velocity[1:-1], atol=1e-6)
    with pytest.raises(ValueError):
        revolute_clearance(pin, vpin, pin, vpin, -1e-4)


def test_point_line_both_walls():
    gap = 0.2e-3
    pts = np.array([[0.0, 0.15e-3], [0.0, -0.12e-3], [0.0, 0.05e-3]])
    k = point_line_clearance(pts, np.zeros_like(pts), np.zeros(2), np.array([1.0, 0.0]), np.zeros(2), 0.0, gap)
    np.testing.assert_allclose(k.penetration, [0.05e-3, 0.02e-3, -0.05e-3], atol=1e-15)
    np.testing.assert_allclose(k.normal[:, 1], [1.0, -1.0, 1.0])


def test_closest_point_on_pitch_like_curve():
    th = np.linspace(0, 2 * np.pi, 20001)
    curve = np.stack([0.08 * np.cos(th), 0.08 * np.sin(th)], axis=1)
    q = np.array([[0.09, 0.0], [0.0, 0.07], [-0.05, -0.05]])
    foot, normal, dist, _ = closest_point_on_curve(q, curve)
    np.testing.assert_allclose(dist, np.hypot(q[:, 0], q[:, 1]) - 0.08, atol=1e-8)
    np.testing.assert_allclose(np.hypot(foot[:, 0], foot[:, 1]), 0.08, atol=1e-8)
