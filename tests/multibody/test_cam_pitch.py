"""The groove cam's pitch curve and foot point in the compiled engine (multibody/cam_pitch.py).

* ``pitch_point``'s derivatives P', P'' (and the third, ``_pitch_jet``) agree with central differences on every
  follower law and on the rise, dwell and return of the cycle;
* ``pitch_foot`` (Newton on the curve parameter) finds the closest point of the curve: the
  same parameter as a bounded minimisation of the distance (scipy), a foot whose normal is perpendicular to the
  tangent, a foot and curvature equal to the curve's at the returned parameter (its Taylor finish is exact to
  round-off), and the same foot from near and far starting guesses.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from berryshaker.kinematics.cam import FOLLOWER_LAWS
from berryshaker.multibody import cam_pitch as mb

RISE, FAR, RET = 2.0943951, 1.04719755, 2.0943951


def cam_row(law: str) -> np.ndarray:
    """[law, stroke, rise, far, return, base radius, offset] (m, rad): the reference groove's proportions."""
    return np.array([FOLLOWER_LAWS[law], 0.04, RISE, FAR, RET, 0.0794, 0.01])


ANGLES = [0.3, 1.0, 1.9, 2.5, 3.0, 3.5, 4.4, 5.6, 6.0]  # rise, dwell, return, rest (rad)


@pytest.mark.parametrize("law", sorted(FOLLOWER_LAWS))
def test_pitch_point_derivatives_agree_with_differences(law):
    cam = cam_row(law)
    d = 1e-5
    for psi in ANGLES:
        v = np.array(mb.pitch_point(psi, cam))
        vp = np.array(mb.pitch_point(psi + d, cam))
        vm = np.array(mb.pitch_point(psi - d, cam))
        fd = (vp - vm) / (2 * d)  # d/dpsi of (P, P')
        for k in range(2):
            exact = v[2 * k + 2:2 * k + 4]
            scale = max(1.0, float(np.abs(exact).max()))
            assert np.allclose(fd[2 * k:2 * k + 2], exact, rtol=0, atol=1e-6 * scale), (law, psi, k)
        # the third derivative, which pitch_foot's Taylor finish uses
        j = np.array(mb._pitch_jet(psi, cam))
        fd3 = (np.array(mb._pitch_jet(psi + d, cam))[4:6] - np.array(mb._pitch_jet(psi - d, cam))[4:6]) / (2 * d)
        assert np.allclose(j[:6], v) and np.allclose(fd3, j[6:8], rtol=0, atol=1e-6 * max(1.0, np.abs(j[6:8]).max()))


def _closest(lx, ly, cam, psi0):
    """The parameter of the closest curve point near psi0 by a bounded scalar minimisation (Brent)."""
    def dist2(psi):
        px, py = mb.pitch_point(psi, cam)[:2]
        return (px - lx) ** 2 + (py - ly) ** 2
    r = minimize_scalar(dist2, bounds=(psi0 - 0.05, psi0 + 0.05), method="bounded",
                        options={"xatol": 1e-13, "maxiter": 500})
    return r.x


@pytest.mark.parametrize("law", sorted(FOLLOWER_LAWS))
def test_pitch_foot_is_the_closest_point(law):
    cam = cam_row(law)
    rng = np.random.default_rng(7)
    for psi in ANGLES:
        px, py, p1x, p1y = mb.pitch_point(psi, cam)[:4]
        norm = math.hypot(p1x, p1y)
        nx, ny = p1y / norm, -p1x / norm
        off = float(rng.uniform(-2e-4, 2e-4))  # a pin inside the groove's clearance, either side
        lx, ly = px + off * nx, py + off * ny
        ref = _closest(lx, ly, cam, psi)
        feet = []
        for guess in (psi + 1e-2, psi + 1e-4, psi - 1e-6, psi + 1e-9, math.nan):
            f_psi, fx, fy, fnx, fny, dist, kappa = mb.pitch_foot(lx, ly, cam, guess)
            if math.isnan(guess):
                f_psi = f_psi + 2 * math.pi * round((psi - f_psi) / (2 * math.pi))
            feet.append((f_psi, fx, fy, dist))
            assert abs(f_psi - ref) < 1e-7, (law, psi, guess)
            assert abs(dist - off) < 1e-12, (law, psi, guess)  # signed distance along the outward normal
            t = mb.pitch_point(f_psi, cam)
            assert abs(fnx * t[2] + fny * t[3]) < 1e-12 * math.hypot(t[2], t[3])  # normal _|_ tangent
            assert math.hypot(fx - t[0], fy - t[1]) < 1e-15  # the foot is the curve's point at f_psi
            tn = math.hypot(t[2], t[3])
            k_at = (t[2] * t[5] - t[3] * t[4]) / tn**3  # curvature evaluated at f_psi, not Taylor-expanded
            assert abs(kappa - k_at) < 1e-9 * max(1.0, abs(k_at)), (law, psi, guess)
        for f in feet[1:]:
            assert abs(f[0] - feet[0][0]) < 1e-13 and abs(f[3] - feet[0][3]) < 1e-15


@pytest.mark.parametrize("law", sorted(FOLLOWER_LAWS))
def test_foot_rate_is_the_feet_derivative_along_a_motion(law):
    """``_foot_rate`` (the engine's prediction of Newton's start, psi' = t . dL/dt / (|P'| (1 + kappa dist)))
    equals the central difference of the foot along a moving point, off the curve by up to 5 mm so that the
    curvature term (kappa dist ~ 5 %) is tested; a wrong sign of that term fails by ~10 %."""
    cam = cam_row(law)
    rng = np.random.default_rng(11)
    d = 1e-7  # s
    for psi in ANGLES:
        px, py, p1x, p1y = mb.pitch_point(psi, cam)[:4]
        norm = math.hypot(p1x, p1y)
        nx, ny = p1y / norm, -p1x / norm
        off = float(rng.uniform(-5e-3, 5e-3))
        lx, ly = px + off * nx, py + off * ny
        dlx, dly = rng.uniform(-0.5, 0.5, 2)  # m/s
        f = mb.pitch_foot_speed(lx, ly, cam, psi)
        rate = mb._foot_rate(f[3], f[4], f[5], f[6], f[7], dlx, dly)
        ahead = mb.pitch_foot(lx + dlx * d, ly + dly * d, cam, psi)[0]
        behind = mb.pitch_foot(lx - dlx * d, ly - dly * d, cam, psi)[0]
        fd = (ahead - behind) / (2 * d)
        assert abs(rate - fd) <= 1e-5 * max(1.0, abs(fd)), (law, psi, rate, fd)
        t = mb.pitch_point(f[0], cam)
        assert abs(f[7] - math.hypot(t[2], t[3])) < 1e-12 * f[7]  # |P'| at the foot
