"""A cam's pitch curve in the compiled core: its points and derivatives, and the closest point (foot) of a roller
centre (docs/multibody.md, "Formulation" and "Cam groove").

A cam is a row of the ``cams`` array (``layout.CAM_*``: follower law, stroke, rise, far-dwell and return angles, s0,
offset).  The cam-roller constraint (:mod:`berryshaker.multibody.constraint_rows`) and the roller-in-groove contact
(:mod:`berryshaker.multibody.force_elements`) measure the signed distance of the roller centre to the pitch curve
from its foot.
"""

from __future__ import annotations

import math

from numba import njit

from berryshaker.kinematics.cam import follower_svaj_scalar
from berryshaker.multibody.layout import CAM_FAR, CAM_LAW, CAM_OFFSET, CAM_RETURN, CAM_RISE, CAM_S0, CAM_STROKE


@njit(cache=True, _nrt=False)
def _pitch_jet(psi, cam):
    """Pitch curve P and its first three derivatives of a cam (cam = [law, h, rise, far, ret, s0, e]) at psi.

    P = R(psi) (rho, e), rho = s0 + s(psi), R the rotation by psi (docs/multibody.md, "Cam groove");
    dR/dpsi v = R (-v_y, v_x), so dP = R (s1 - e, rho), d2P = R (s2 - rho, 2 s1 - e) and
    d3P = R (s3 - 3 s1 + e, 3 s2 - rho), with s1, s2, s3 the follower law's derivatives."""
    s, s1, s2, s3 = follower_svaj_scalar(psi, int(cam[CAM_LAW]), cam[CAM_STROKE], cam[CAM_RISE], cam[CAM_FAR],
                                          cam[CAM_RETURN])
    rho = cam[CAM_S0] + s
    e = cam[CAM_OFFSET]
    c, sn = math.cos(psi), math.sin(psi)
    px, py = c * rho - sn * e, sn * rho + c * e
    ux, uy = s1 - e, rho
    p1x, p1y = c * ux - sn * uy, sn * ux + c * uy
    vx, vy = s2 - rho, 2.0 * s1 - e
    p2x, p2y = c * vx - sn * vy, sn * vx + c * vy
    wx, wy = s3 - 3.0 * s1 + e, 3.0 * s2 - rho
    p3x, p3y = c * wx - sn * wy, sn * wx + c * wy
    return px, py, p1x, p1y, p2x, p2y, p3x, p3y


@njit(cache=True, _nrt=False)
def pitch_point(psi, cam):
    """Pitch curve P, P', P'' of a cam (cam = [law, h, rise, far, ret, s0, e]) at parameter psi.

    Parameters
    ----------
    psi : float
        Cam curve angle (rad).
    cam : numpy.ndarray
        The cam's row (``layout.CAM_*``; lengths m, angles rad).
    """
    px, py, p1x, p1y, p2x, p2y, p3x, p3y = _pitch_jet(psi, cam)
    return px, py, p1x, p1y, p2x, p2y


#: Newton steps (rad) below which :func:`pitch_foot` finishes by a Taylor expansion instead of evaluating the
#: curve again: the parameter error after such a step is ~ step^2 |g''/2g'| ~ 1e-14 rad for the study's cams
#: (the old stopping rule, a step below 1e-14 rad, took two more curve evaluations to reach the same psi)
FOOT_TAYLOR_STEP = 1e-7


@njit(cache=True, _nrt=False)
def pitch_foot(lx, ly, cam, guess):
    """Closest point of the pitch curve to (lx, ly) in the cam frame (:func:`pitch_foot_speed` without |P'|).

    Returns psi, foot (2), outward unit normal (2), signed distance, signed curvature.

    Parameters
    ----------
    lx, ly : float
        Roller centre in the cam's frame (m).
    cam : numpy.ndarray
        The cam's row (``layout.CAM_*``; lengths m, angles rad).
    guess : float
        Starting foot angle of Newton's iteration (rad; NaN: none).
    """
    psi, px, py, nx, ny, dist, kappa, speed = pitch_foot_speed(lx, ly, cam, guess)
    return psi, px, py, nx, ny, dist, kappa


@njit(cache=True, _nrt=False)
def pitch_foot_speed(lx, ly, cam, guess):
    """Closest point of the pitch curve to (lx, ly) in the cam frame (Newton on the curve parameter).

    Newton on g(psi) = (P - L) . dP = 0, g' = |dP|^2 + (P - L) . d2P.  Once a step h is below
    :data:`FOOT_TAYLOR_STEP` the curve at the final psi is the third-order Taylor expansion of the last
    evaluation (P, dP, d2P with errors O(h^4), O(h^3), O(h^2) of the curve's scale: round-off for
    h < 1e-7) instead of a new evaluation.

    Returns psi, foot (2), outward unit normal (2), signed distance, signed curvature, |P'| (m/rad).

    Parameters
    ----------
    lx, ly : float
        Roller centre in the cam's frame (m).
    cam : numpy.ndarray
        The cam's row (``layout.CAM_*``; lengths m, angles rad).
    guess : float
        Starting foot angle of Newton's iteration (rad; NaN: none).
    """
    if math.isnan(guess):
        psi = math.atan2(ly, lx)
        for _ in range(3):
            s, s1, s2, s3 = follower_svaj_scalar(psi, int(cam[CAM_LAW]), cam[CAM_STROKE], cam[CAM_RISE],
                                                  cam[CAM_FAR], cam[CAM_RETURN])
            psi = math.atan2(ly, lx) - math.atan2(cam[CAM_OFFSET], cam[CAM_S0] + s)
    else:
        psi = guess
    px, py, p1x, p1y, p2x, p2y, p3x, p3y = _pitch_jet(psi, cam)
    for _ in range(30):
        dx, dy = px - lx, py - ly
        g = dx * p1x + dy * p1y
        gp = p1x * p1x + p1y * p1y + dx * p2x + dy * p2y
        if gp <= 0.0:
            gp = p1x * p1x + p1y * p1y
        step = g / gp
        if step > 0.2:
            step = 0.2
        elif step < -0.2:
            step = -0.2
        psi -= step
        if abs(step) < FOOT_TAYLOR_STEP:
            h = -step
            h2 = 0.5 * h * h
            h3 = h2 * h / 3.0
            px, py = px + h * p1x + h2 * p2x + h3 * p3x, py + h * p1y + h2 * p2y + h3 * p3y
            p1x, p1y = p1x + h * p2x + h2 * p3x, p1y + h * p2y + h2 * p3y
            p2x, p2y = p2x + h * p3x, p2y + h * p3y
            break
        px, py, p1x, p1y, p2x, p2y, p3x, p3y = _pitch_jet(psi, cam)
    norm = math.sqrt(p1x * p1x + p1y * p1y)
    nx, ny = p1y / norm, -p1x / norm
    dist = nx * (lx - px) + ny * (ly - py)
    kappa = (p1x * p2y - p1y * p2x) / norm**3
    return psi, px, py, nx, ny, dist, kappa, norm


#: the groove contacts' foot memory (state ``psi_f``, 3 nf long): per force element k the last foot parameter
#: psi (rad; NaN: none yet) at [k], its rate psi' (rad/s) at [nf + k] and the time it was found (s) at [2 nf + k].
#: Newton starts from psi + psi' (t - t_found): one curve evaluation instead of two to three from psi alone
FOOT_MEMORY = 3


#: largest predicted move of the foot (rad) taken as Newton's start; a larger one (a foot near the pitch curve's
#: centre of curvature, where psi' is ill-conditioned) starts from the last foot itself, as without prediction
FOOT_PREDICTION_MAX = 1e-2


@njit(cache=True, _nrt=False)
def _foot_rate(nx, ny, dist, kappa, speed, dlx, dly):
    """Rate of the closest pitch-curve parameter psi (rad/s) of a point L moving at dL/dt (cam frame), from the
    foot's outward normal n, signed distance, curvature and |P'| (:func:`pitch_foot_speed`).

    The foot satisfies g(psi, L) = (P(psi) - L) . P'(psi) = 0; along the motion dg/dt = 0 gives
    psi' = (P' . dL/dt) / (|P'|^2 + (P - L) . P'').  With P - L = -dist n, P' = |P'| (-n_y, n_x) and
    n . P'' = -kappa |P'|^2: psi' = ((-n_y, n_x) . dL/dt) / (|P'| (1 + kappa dist)).  Used only to predict
    Newton's starting guess (0 where the foot is not unique, 1 + kappa dist <= 0)."""
    den = speed * (1.0 + kappa * dist)
    if den <= 0.0:
        return 0.0
    return (-ny * dlx + nx * dly) / den
