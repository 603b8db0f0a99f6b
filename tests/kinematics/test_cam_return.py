"""Cam follower laws with UNEQUAL rise and return angles and unequal far and near dwells (study eq. 1, corrected).

Every other cam test and every built-in machine uses rise = return, so a return segment normalised by the rise
angle instead of the return angle passes them all.  Here rise = 100 deg, far dwell = 40 deg, return = 150 deg and
near dwell = 70 deg, and the return segment is checked against closed forms written out in this file:

    u = (phi - rise - far) / return,   s = h (1 - P(u)),
    ds/dphi = -h P'(u) / return,  d2s/dphi2 = -h P''(u) / return^2,  d3s/dphi3 = -h P'''(u) / return^3,

with the normalised laws (Norton, Cam Design and Manufacturing Handbook, 2nd ed., 2009, ch. 3)

    3-4-5      P = 10u^3 - 15u^4 + 6u^5
    cycloidal  P = u - sin(2 pi u) / (2 pi)
    4-5-6-7    P = 35u^4 - 84u^5 + 70u^6 - 20u^7
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from berryshaker.kinematics.cam import follower_svaj

LAWS = ["3-4-5", "cycloidal", "4-5-6-7"]
H = 0.025  # stroke, m
RISE, FAR, RET = math.radians(100), math.radians(40), math.radians(150)
NEAR = 2 * math.pi - RISE - FAR - RET  # 70 deg
RET_START, RET_END = RISE + FAR, RISE + FAR + RET


def _p(u, law):
    """P, P', P'', P''' of the normalised law, written out by hand (independent of the package's kernel)."""
    u = np.asarray(u, float)
    if law == "3-4-5":
        return (10 * u**3 - 15 * u**4 + 6 * u**5,
                30 * u**2 - 60 * u**3 + 30 * u**4,
                60 * u - 180 * u**2 + 120 * u**3,
                60 - 360 * u + 360 * u**2)
    if law == "cycloidal":
        w = 2 * math.pi
        return u - np.sin(w * u) / w, 1 - np.cos(w * u), w * np.sin(w * u), w * w * np.cos(w * u)
    return (35 * u**4 - 84 * u**5 + 70 * u**6 - 20 * u**7,
            140 * u**3 - 420 * u**4 + 420 * u**5 - 140 * u**6,
            420 * u**2 - 1680 * u**3 + 2100 * u**4 - 840 * u**5,
            840 * u - 5040 * u**2 + 8400 * u**3 - 4200 * u**4)


def _svaj(phi, law):
    return follower_svaj(phi, H, RISE, FAR, RET, law)


def test_the_layout_is_asymmetric():
    # the point of this file: a return normalised by the rise angle (or a dwell swapped) must show
    assert RISE != RET and FAR != NEAR and NEAR > 0
    assert math.degrees(NEAR) == pytest.approx(70.0)


@pytest.mark.parametrize("law", LAWS)
def test_return_segment_matches_its_closed_form(law):
    u = np.linspace(0.0, 1.0, 61)[1:-1]
    phi = RET_START + u * RET
    s, s1, s2, s3 = _svaj(phi, law)
    p, p1, p2, p3 = _p(u, law)
    np.testing.assert_allclose(s, H * (1 - p), rtol=0, atol=1e-12 * H, err_msg=f"{law}: s on the return")
    np.testing.assert_allclose(s1, -H * p1 / RET, rtol=1e-9, atol=1e-12 * H / RET,
                               err_msg=f"{law}: ds/dphi on the return")
    np.testing.assert_allclose(s2, -H * p2 / RET**2, rtol=1e-9, atol=1e-9 * H / RET**2,
                               err_msg=f"{law}: d2s/dphi2 on the return")
    np.testing.assert_allclose(s3, -H * p3 / RET**3, rtol=1e-9, atol=1e-9 * H / RET**3,
                               err_msg=f"{law}: d3s/dphi3 on the return")


@pytest.mark.parametrize("law", LAWS)
def test_rise_segment_matches_its_closed_form(law):
    u = np.linspace(0.0, 1.0, 61)[1:-1]
    s, s1, s2, s3 = _svaj(u * RISE, law)
    p, p1, p2, p3 = _p(u, law)
    np.testing.assert_allclose(s, H * p, rtol=0, atol=1e-12 * H)
    np.testing.assert_allclose(s1, H * p1 / RISE, rtol=1e-9, atol=1e-12 * H / RISE)
    np.testing.assert_allclose(s2, H * p2 / RISE**2, rtol=1e-9, atol=1e-9 * H / RISE**2)
    np.testing.assert_allclose(s3, H * p3 / RISE**3, rtol=1e-9, atol=1e-9 * H / RISE**3)


@pytest.mark.parametrize("law", LAWS)
def test_return_takes_exactly_the_return_angle(law):
    """Full stroke at the start of the return, half stroke at its middle (every law is point-symmetric:
    P(1/2) = 1/2), zero at start + return angle; the far dwell holds h and the near dwell holds 0."""
    s = _svaj([RET_START, RET_START + RET / 2, RET_END], law)[0]
    np.testing.assert_allclose(s, [H, H / 2, 0.0], atol=1e-12 * H)
    far = _svaj(np.linspace(RISE, RET_START, 9)[1:-1], law)
    near = _svaj(np.linspace(RET_END, 2 * math.pi, 9)[1:-1], law)
    np.testing.assert_allclose(far[0], H, rtol=1e-15)
    np.testing.assert_array_equal(far[1:], 0.0)
    np.testing.assert_array_equal(near, 0.0)


def test_peak_return_velocity_and_acceleration_of_3_4_5():
    """3-4-5: max |P'| = 15/8 at u = 1/2 and max |P''| = 10/sqrt(3) at u = 1/2 -+ sqrt(3)/6, so on a return of
    150 deg: max |ds/dphi| = 0.025 * 1.875 / 2.618 = 0.017905 m/rad and max |d2s/dphi2| =
    0.025 * 5.7735 / 6.8539 = 0.021059 m/rad^2 (on the 100 deg rise: 0.026857 m/rad and 0.047383 m/rad^2)."""
    phi = np.linspace(RET_START, RET_END, 30001)
    s1, s2 = _svaj(phi, "3-4-5")[1:3]
    assert np.abs(s1).max() == pytest.approx(0.017905, rel=1e-4)
    assert phi[np.argmin(s1)] == pytest.approx(RET_START + RET / 2, abs=1e-4)
    assert np.abs(s2).max() == pytest.approx(0.021059, rel=1e-4)
    rise = np.linspace(0.0, RISE, 30001)
    r1, r2 = _svaj(rise, "3-4-5")[1:3]
    assert r1.max() == pytest.approx(0.026857, rel=1e-4)
    assert np.abs(r2).max() == pytest.approx(0.047383, rel=1e-4)


@pytest.mark.parametrize("law", LAWS)
def test_zero_velocity_and_acceleration_at_the_ends_of_each_move(law):
    ends = [0.0, RISE, RET_START, RET_END]
    s1, s2 = _svaj(ends, law)[1:3]
    np.testing.assert_allclose(s1, 0.0, atol=1e-12 * H / RET)
    np.testing.assert_allclose(s2, 0.0, atol=1e-9 * H / RET**2)


@pytest.mark.parametrize("law", LAWS)
def test_continuity_at_every_boundary_of_the_asymmetric_cycle(law):
    """s, s', s'' (and s''' for 4-5-6-7) continuous where the rise, far dwell, return and near dwell meet and at the
    2 pi wrap, each checked against the scale of the move that starts or ends there."""
    eps = 1e-9
    n = 4 if law == "4-5-6-7" else 3
    for b, move in ((0.0, RISE), (RISE, RISE), (RET_START, RET), (RET_END, RET), (2 * math.pi, RISE)):
        left = _svaj([b - eps], law)[:, 0]
        right = _svaj([b + eps], law)[:, 0]
        scale = np.array([H, H / move, H / move**2, H / move**3])
        np.testing.assert_allclose(left[:n] / scale[:n], right[:n] / scale[:n], atol=1e-6,
                                   err_msg=f"{law} discontinuous at {math.degrees(b):.0f} deg")


@pytest.mark.parametrize("law", LAWS)
def test_derivatives_are_the_derivatives_of_s_on_the_return(law):
    """Central differences of s, s', s'' in phi reproduce s', s'', s''' on the return (the chain rule's 1/return
    factors, not 1/rise)."""
    phi = np.linspace(RET_START, RET_END, 20001)
    s = _svaj(phi, law)
    for k in range(3):
        fd = np.gradient(s[k], phi)[5:-5]
        scale = np.abs(s[k + 1]).max()
        np.testing.assert_allclose(fd, s[k + 1][5:-5], atol=1e-5 * scale, err_msg=f"{law}: d^{k + 1}s")
