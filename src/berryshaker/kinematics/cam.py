"""Groove cam: follower laws (study eq. 1), pitch curve and groove walls (eq. 2), pressure angle,
radius of curvature and undercut.

Conventions
-----------
O (cam centre) is the origin; the push rod moves along the line y = e (offset e); the roller centre
sits at (s0 + s(phi), e) in the frame, s0 = sqrt(r0^2 - e^2).  The cam turns clockwise with angle phi
(study Fig. 5); in the cam's own frame the roller centre traces the pitch curve
x = (s0+s) cos phi - e sin phi, y = (s0+s) sin phi + e cos phi (eq. 2 with r_r = 0).

All angles in rad, lengths in m.  The scalar kernels (``_svaj_unit``, ``follower_svaj_scalar``) are
numba-compiled so that the dynamic models can evaluate the cam inside compiled loops.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from berryshaker.errors import GeometryError

#: follower law name -> numeric code used by the compiled kernels
FOLLOWER_LAWS = {"3-4-5": 0, "cycloidal": 1, "4-5-6-7": 2}

TWO_PI = 2.0 * math.pi


@njit(cache=True)
def _svaj_unit(x, law):
    """Normalised rise P(x) and its first three derivatives for x in [0, 1].

    3-4-5:   P = 10x^3 - 15x^4 + 6x^5 (study eq. 1)
    cycloidal: P = x - sin(2 pi x)/(2 pi)
    4-5-6-7: P = 35x^4 - 84x^5 + 70x^6 - 20x^7
    (all three: Norton, *Cam Design and Manufacturing Handbook*, 2nd ed., 2009; their boundary
    conditions and peak coefficients are checked in tests/kinematics/test_cam.py)
    """
    if x <= 0.0:
        x = 0.0
    elif x >= 1.0:
        x = 1.0
    if law == 0:
        x2 = x * x
        x3 = x2 * x
        p = x3 * (10.0 - 15.0 * x + 6.0 * x2)
        p1 = 30.0 * x2 * (1.0 - 2.0 * x + x2)
        p2 = 60.0 * x * (1.0 - 3.0 * x + 2.0 * x2)
        p3 = 60.0 * (1.0 - 6.0 * x + 6.0 * x2)
    elif law == 1:
        w = 2.0 * math.pi
        p = x - math.sin(w * x) / w
        p1 = 1.0 - math.cos(w * x)
        p2 = w * math.sin(w * x)
        p3 = w * w * math.cos(w * x)
    else:
        x2 = x * x
        x3 = x2 * x
        x4 = x3 * x
        p = x4 * (35.0 - 84.0 * x + 70.0 * x2 - 20.0 * x3)
        p1 = x3 * (140.0 - 420.0 * x + 420.0 * x2 - 140.0 * x3)
        p2 = x2 * (420.0 - 1680.0 * x + 2100.0 * x2 - 840.0 * x3)
        p3 = x * (840.0 - 5040.0 * x + 8400.0 * x2 - 4200.0 * x3)
    return p, p1, p2, p3


@njit(cache=True)
def follower_svaj_scalar(phi, law, h, d_rise, d_far, d_ret):
    """Follower lift and its first three derivatives at one cam angle: rise, far dwell, return, near dwell (study
    eq. 1 for the 3-4-5 law; the laws of ``_svaj_unit``, Norton 2009).  Compiled (numba) for the dynamic models'
    loops; :func:`follower_svaj` is the vectorised form.

    Parameters
    ----------
    phi : float
        Cam angle (rad), any real: wrapped to [0, 2 pi).
    law : int
        Motion law: 0 3-4-5 polynomial, 1 cycloidal, 2 4-5-6-7 polynomial.
    h : float
        Lift (m).
    d_rise, d_far, d_ret : float
        Rise, far-dwell and return angles (rad).

    Returns
    -------
    s, s1, s2, s3 : float
        Lift (m) and its derivatives with respect to the cam angle (m/rad, m/rad^2, m/rad^3).
    """
    phi = phi - TWO_PI * math.floor(phi / TWO_PI)
    if phi < d_rise:
        p, p1, p2, p3 = _svaj_unit(phi / d_rise, law)
        return h * p, h * p1 / d_rise, h * p2 / d_rise**2, h * p3 / d_rise**3
    if phi < d_rise + d_far:
        return h, 0.0, 0.0, 0.0
    if phi < d_rise + d_far + d_ret:
        p, p1, p2, p3 = _svaj_unit((phi - d_rise - d_far) / d_ret, law)
        return h * (1.0 - p), -h * p1 / d_ret, -h * p2 / d_ret**2, -h * p3 / d_ret**3
    return 0.0, 0.0, 0.0, 0.0


@njit(cache=True)
def _follower_svaj_array(phi, law, h, d_rise, d_far, d_ret, out):
    for i in range(phi.shape[0]):
        s, s1, s2, s3 = follower_svaj_scalar(phi[i], law, h, d_rise, d_far, d_ret)
        out[0, i] = s
        out[1, i] = s1
        out[2, i] = s2
        out[3, i] = s3


def follower_law(x, law="3-4-5"):
    """Normalised follower rise P(x) and derivatives dP/dx, d2P/dx2, d3P/dx3.

    Parameters
    ----------
    x : array_like
        Fraction of the rise, 0..1 (clipped; dimensionless).
    law : {"3-4-5", "cycloidal", "4-5-6-7"}
        The follower law.

    Returns
    -------
    ndarray, shape (4, ...)
        P, P', P'', P''' (dimensionless).

    Notes
    -----
    3-4-5 polynomial: P = 10x^3 - 15x^4 + 6x^5 (study eq. 1).  Peak values used in tests:
    max P' = 15/8 at x = 1/2, max |P''| = 10/sqrt(3) at x = 1/2 -+ sqrt(3)/6, max |P'''| = 60 at the ends.

    References
    ----------
    R. L. Norton, *Cam Design and Manufacturing Handbook*, 2nd ed., Industrial Press, 2009, ch. 3.
    """
    code = _law_code(law)
    x = np.asarray(x, dtype=float)
    flat = np.clip(x.ravel(), 0.0, 1.0)
    out = np.empty((4, flat.size))
    # reuse the full-cycle kernel with a rise of 1 rad and no dwell/return inside [0, 1)
    for i, xi in enumerate(flat):
        out[:, i] = _svaj_unit(float(xi), code)
    return out.reshape((4,) + x.shape)


def _law_code(law: str) -> int:
    try:
        return FOLLOWER_LAWS[law]
    except KeyError:
        raise GeometryError(f"unknown follower law {law!r}; choose one of {', '.join(FOLLOWER_LAWS)}") from None


def follower_svaj(phi, stroke, rise_angle, far_dwell_angle, return_angle, law="3-4-5"):
    """Push-rod displacement and its cam-angle derivatives over the cycle (study eq. 1, corrected).

    Parameters
    ----------
    phi : array_like
        Cam angle (rad); any real value, taken modulo 2 pi.
    stroke : float
        h, push-rod stroke (m).
    rise_angle, far_dwell_angle, return_angle : float
        delta_0, delta_01, delta_0' (rad); the near dwell fills the rest of the turn.
    law : {"3-4-5", "cycloidal", "4-5-6-7"}

    Returns
    -------
    ndarray, shape (4, n)
        s (m), ds/dphi (m/rad), d2s/dphi2 (m/rad^2), d3s/dphi3 (m/rad^3).  Multiply by omega,
        omega^2, omega^3 for velocity, acceleration and jerk at constant cam speed omega.

    Notes
    -----
    Rise s = h P(phi/delta_0); far dwell s = h; return s = h [1 - P((phi - delta_0 - delta_01)/delta_0')];
    near dwell s = 0.  **Departure from the printed eq. 1:** the study writes the return as
    P(psi - phi) with psi = 2 pi + 2 delta_0 + delta_01, which neither starts at s = h nor uses the
    return angle delta_0'; the form above is continuous in s, s', s'' at every boundary (tested).
    """
    code = _law_code(law)
    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    out = np.empty((4, phi.size))
    _follower_svaj_array(phi.ravel(), code, float(stroke), float(rise_angle), float(far_dwell_angle),
                         float(return_angle), out)
    return out


def pitch_curve(phi, s, ds, s0, e):
    """Pitch curve (roller-centre path) in the cam frame and its tangent (study eq. 2 with r_r = 0).

    Parameters
    ----------
    phi : array_like
        Cam angle (rad).
    s, ds : array_like
        Follower displacement s (m) and ds/dphi (m/rad) at ``phi``.
    s0 : float
        sqrt(r0^2 - e^2) (m).
    e : float
        Offset of the push-rod axis (m).

    Returns
    -------
    x, y, dx, dy : ndarray
        Pitch point (m) and its derivative with respect to phi (m/rad).

    Notes
    -----
    x = (s0+s) cos phi - e sin phi,  y = (s0+s) sin phi + e cos phi (study eq. 2);
    dx/dphi = s' cos phi - (s0+s) sin phi - e cos phi,  dy/dphi = s' sin phi + (s0+s) cos phi - e sin phi.
    """
    phi = np.asarray(phi, float)
    r = s0 + np.asarray(s, float)
    c, sn = np.cos(phi), np.sin(phi)
    x = r * c - e * sn
    y = r * sn + e * c
    dx = ds * c - r * sn - e * c
    dy = ds * sn + r * c - e * sn
    return x, y, dx, dy


def groove_profile(phi, s, ds, s0, e, roller_radius):
    """Inner and outer walls of the cam groove (study eq. 2, corrected).

    Parameters
    ----------
    phi, s, ds : array_like
        Cam angle (rad), follower displacement (m), ds/dphi (m/rad).
    s0, e : float
        sqrt(r0^2 - e^2) and the offset (m).
    roller_radius : float
        r_r (m).

    Returns
    -------
    inner, outer : ndarray, shape (2, n)
        Wall points (m) in the cam frame.

    Notes
    -----
    Wall = pitch point + k r_r n, with n the outward unit normal of the pitch curve,
    n = (dy/dphi, -dx/dphi) / |(dx/dphi, dy/dphi)| (the pitch curve runs counter-clockwise in phi),
    k = -1 for the inner wall and k = +1 for the outer wall.  **Departures from the printed eq. 2:**
    the study's offset term uses the radius vector of the pitch point instead of its normal (so it omits
    ds/dphi and the walls are not parallel to the pitch curve where the follower moves), and it gives
    k = -1 for both walls.  The walls here lie exactly r_r from the pitch curve (tested).
    """
    x, y, dx, dy = pitch_curve(phi, s, ds, s0, e)
    norm = np.hypot(dx, dy)
    nx, ny = dy / norm, -dx / norm
    inner = np.vstack([x - roller_radius * nx, y - roller_radius * ny])
    outer = np.vstack([x + roller_radius * nx, y + roller_radius * ny])
    return inner, outer


def pressure_angle(s, ds, s0, e):
    """Signed pressure angle of an offset translating roller follower (rad).

    Parameters
    ----------
    s, ds : array_like
        Follower displacement (m) and ds/dphi (m/rad).
    s0, e : float
        sqrt(r0^2 - e^2) and the offset (m).

    Returns
    -------
    ndarray
        alpha = atan((ds/dphi - e) / (s0 + s)) (rad): angle between the contact normal and the
        push-rod axis.

    Notes
    -----
    Derived from the pitch-curve tangent: in the follower frame it is (ds/dphi - e, s0 + s), so the
    normal makes the angle above with the x axis (derived here; Norton 2009 gives the same
    result for this sign of offset and rotation).  In a groove cam either wall may drive, so both signs matter.
    """
    return np.arctan2(np.asarray(ds, float) - e, s0 + np.asarray(s, float))


def pitch_curve_curvature(s, ds, d2s, s0, e):
    """Signed curvature of the pitch curve (1/m); positive where it is convex.

    Parameters
    ----------
    s, ds, d2s : array_like
        Follower displacement s (m) and its first and second derivatives with respect to the cam angle,
        s' (m/rad) and s'' (m/rad^2).
    s0 : float
        Distance from the cam centre's foot on the push-rod axis to the roller centre at s = 0 (m).
    e : float
        Offset of the push-rod axis from the cam centre (m).

    Returns
    -------
    ndarray
        Signed curvature kappa of the pitch curve (1/m), the shape of ``s``.

    Notes
    -----
    With v = (s' - e, s0 + s) the tangent in the follower frame, the second derivative is
    (s'' - (s0+s), 2 s' - e), so kappa = [(s' - e)(2 s' - e) - (s0+s)(s'' - (s0+s))] / |v|^3.
    Check: s = const gives kappa = 1/sqrt((s0+s)^2 + e^2), the circle through the roller centre.
    A groove wall has radius of curvature rho - r_r (inner) and rho + r_r (outer) where rho = 1/kappa > 0;
    a wall undercuts (cusp, the cutter cannot follow) wherever |rho| <= r_r (Norton 2009).
    """
    s = np.asarray(s, float)
    r = s0 + s
    a = np.asarray(ds, float) - e
    num = a * (2.0 * np.asarray(ds, float) - e) - r * (np.asarray(d2s, float) - r)
    return num / np.hypot(a, r) ** 3
