"""Cam: follower laws (study eq. 1, corrected return), groove (eq. 2, corrected), pressure angle,
curvature, undercut."""

import math

import numpy as np
import pytest

from berryshaker.kinematics.cam import (
    follower_law,
    follower_svaj,
    groove_profile,
    pitch_curve,
    pitch_curve_curvature,
    pressure_angle,
)

LAWS = ["3-4-5", "cycloidal", "4-5-6-7"]
H, RISE, FAR, RET = 0.04, math.radians(120), math.radians(60), math.radians(120)


@pytest.mark.parametrize("law", LAWS)
def test_continuity_at_every_segment_boundary(law):
    """s, s', s'' continuous at rise start/end, return start/end and the 2 pi wrap (Norton 2009,
    'fundamental law of cam design': no infinite jerk).  4-5-6-7 is also jerk-continuous."""
    bounds = [0.0, RISE, RISE + FAR, RISE + FAR + RET, 2 * math.pi]
    eps = 1e-9
    for b in bounds:
        left = follower_svaj([b - eps], H, RISE, FAR, RET, law)[:, 0]
        right = follower_svaj([b + eps], H, RISE, FAR, RET, law)[:, 0]
        scale = np.array([H, H / RISE, H / RISE**2, H / RISE**3])
        n = 4 if law == "4-5-6-7" else 3
        np.testing.assert_allclose(left[:n] / scale[:n], right[:n] / scale[:n], atol=1e-6,
                                   err_msg=f"{law} discontinuous at {math.degrees(b)} deg")


def test_return_starts_at_full_stroke_and_ends_at_zero():
    # the printed eq. 1 (psi = 2 pi + 2 delta_0 + delta_01) fails exactly this
    s = follower_svaj([RISE + FAR, RISE + FAR + RET / 2, RISE + FAR + RET], H, RISE, FAR, RET)[0]
    np.testing.assert_allclose(s, [H, H / 2, 0.0], atol=1e-15)


@pytest.mark.parametrize("law,peaks", [
    # closed-form maxima of P', |P''|, |P'''| of each normalised law (calculus on the polynomials /
    # sinusoid): 3-4-5: 15/8, 10/sqrt(3), 60; cycloidal: 2, 2 pi, 4 pi^2; 4-5-6-7: 35/16,
    # 84 sqrt(5)/25, 105/2 (cf. Norton, Cam Design and Manufacturing Handbook, 2009)
    ("3-4-5", (1.875, 5.7735, 60.0)),
    ("cycloidal", (2.0, 6.2832, 39.478)),
    ("4-5-6-7", (2.1875, 7.5132, 52.5)),
])
def test_normalised_peaks(law, peaks):
    x = np.linspace(0, 1, 200001)
    p = follower_law(x, law)
    assert p[1].max() == pytest.approx(peaks[0], rel=1e-4)
    assert np.abs(p[2]).max() == pytest.approx(peaks[1], rel=1e-4)
    assert np.abs(p[3]).max() == pytest.approx(peaks[2], rel=1e-4)
    # analytic derivatives agree with finite differences of P
    np.testing.assert_allclose(np.gradient(p[0], x)[1:-1], p[1][1:-1], atol=1e-6)


def _pitch(law="3-4-5", n=20001):
    phi = np.linspace(0, 2 * math.pi, n)
    s = follower_svaj(phi, H, RISE, FAR, RET, law)
    s0, e = math.sqrt(0.08**2 - 0.01**2), 0.01
    return phi, s, s0, e


def test_groove_walls_lie_exactly_rr_from_pitch_curve_along_its_normal():
    phi, s, s0, e = _pitch()
    rr = 0.015
    x, y, dx, dy = pitch_curve(phi, s[0], s[1], s0, e)
    inner, outer = groove_profile(phi, s[0], s[1], s0, e, rr)
    for wall, k in ((inner, -1), (outer, 1)):
        d = np.hypot(wall[0] - x, wall[1] - y)
        np.testing.assert_allclose(d, rr, rtol=1e-12)
        # offset vector is perpendicular to the pitch tangent
        dot = (wall[0] - x) * dx + (wall[1] - y) * dy
        np.testing.assert_allclose(dot / (rr * np.hypot(dx, dy)), 0.0, atol=1e-12)
    # and the wall is an offset curve: nearest pitch point of every wall point is r_r away
    from scipy.spatial import cKDTree

    tree = cKDTree(np.column_stack([x, y]))
    dist, _ = tree.query(outer.T[::50])
    np.testing.assert_allclose(dist, rr, rtol=2e-3)
    # inner wall inside, outer wall outside
    assert np.all(np.hypot(*inner) < np.hypot(x, y))
    assert np.all(np.hypot(*outer) > np.hypot(x, y))


def test_pressure_angle_against_geometry():
    """Angle between the pitch-curve normal (finite differences) and the push-rod axis."""
    phi, s, s0, e = _pitch()
    x, y, _, _ = pitch_curve(phi, s[0], s[1], s0, e)
    tx, ty = np.gradient(x, phi), np.gradient(y, phi)
    # rotate the tangent back into the follower frame (cam frame = fixed frame rotated by phi)
    c, sn = np.cos(phi), np.sin(phi)
    fx, fy = c * tx + sn * ty, -sn * tx + c * ty
    alpha_fd = np.arctan2(fx, fy)  # normal (fy, -fx) vs x axis
    alpha = pressure_angle(s[0], s[1], s0, e)
    np.testing.assert_allclose(alpha[5:-5], alpha_fd[5:-5], atol=2e-6)


def test_curvature_base_circle_and_finite_differences():
    phi, s, s0, e = _pitch()
    k = pitch_curve_curvature(s[0], s[1], s[2], s0, e)
    # on the near dwell the pitch curve is the circle of radius r0 through the roller centre
    dwell = phi > RISE + FAR + RET + 0.01
    np.testing.assert_allclose(1 / k[dwell], 0.08, rtol=1e-12)
    x, y, _, _ = pitch_curve(phi, s[0], s[1], s0, e)
    x1, y1 = np.gradient(x, phi), np.gradient(y, phi)
    x2, y2 = np.gradient(x1, phi), np.gradient(y1, phi)
    k_fd = (x1 * y2 - y1 * x2) / np.hypot(x1, y1) ** 3
    np.testing.assert_allclose(k[10:-10], k_fd[10:-10], atol=1e-3 * np.abs(k).max())
