"""Double rocker of the harvester (study eq. 3): left comb driven through the rocker slot, right comb
through the four-bar D-C-F-E.

Frame: O is the cam centre, x along the push rod, y up.  Angles are measured counter-clockwise from +x
(rad).  theta_D is the direction of the slot D->B (the left comb turns with it); theta_C = theta_D +
gamma is the direction of the arm D->C (gamma = ``rocker.arm_angle``); theta_4 is the coupler
direction C->F; theta_E is the direction of the arm E->F (the right comb turns with it).

The scalar kernels are numba-compiled so the dynamic models evaluate the ideal mechanism inside their
compiled loops; the public functions are numpy-vectorised.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def left_comb_scalar(xb, yb, xd, yd, vb, ab):
    """Angle of the rocker slot D->B (the left comb's angle), its rate and its acceleration, for the push-rod pin B
    moving along x (study eq. 3, the slot's direction).  Compiled (numba) for the dynamic models' loops.

    Parameters
    ----------
    xb, yb : float
        Position of the pin B (m).
    xd, yd : float
        Position of the rocker pivot D (m).
    vb, ab : float
        Velocity (m/s) and acceleration (m/s^2) of B along x.

    Returns
    -------
    theta_d, omega_d, alpha_d : float
        theta_D (rad), its rate (rad/s) and acceleration (rad/s^2).
    """
    dx = xb - xd
    dy = yb - yd
    q = dx * dx + dy * dy
    th = math.atan2(dy, dx)
    w = -dy * vb / q
    a = -dy * ab / q + 2.0 * dy * dx * vb * vb / (q * q)
    return th, w, a


@njit(cache=True)
def four_bar_scalar(th_c, w_c, a_c, xd, yd, xe, ye, l_cd, l_cf, l_fe, branch):
    """Position, rates and accelerations of coupler (4) and right arm (E) of the four-bar D-C-F-E; ok=False if it
    cannot assemble.  Compiled (numba) for the dynamic models' loops.

    Position (study eq. 3, corrected): theta_E = arg(C - E) + branch * acos((l_FE^2 + l_CE^2 - l_CF^2)
    / (2 l_FE l_CE)).  Rates from the time derivatives of the loop D + l_CD e^{i th_C} + l_CF e^{i th_4}
    = E + l_FE e^{i th_E}, solved by projection on e^{-i th_E} and e^{-i th_4}.

    Parameters
    ----------
    th_c, w_c, a_c : float
        Angle of the arm D->C (rad), its rate (rad/s) and acceleration (rad/s^2).
    xd, yd, xe, ye : float
        Pivots D and E (m).
    l_cd, l_cf, l_fe : float
        Arm D-C, coupler C-F and arm F-E lengths (m).
    branch : float
        Assembly branch, +1 or -1 (dimensionless).

    Returns
    -------
    ok : bool
        Whether the linkage assembles.
    th_4, w_4, a_4 : float
        Coupler angle (rad), rate (rad/s), acceleration (rad/s^2).
    th_e, w_e, a_e : float
        Right arm's angle (rad), rate (rad/s), acceleration (rad/s^2).
    xf, yf : float
        Position of the joint F (m).
    """
    xc = xd + l_cd * math.cos(th_c)
    yc = yd + l_cd * math.sin(th_c)
    ux = xc - xe
    uy = yc - ye
    l_ce = math.sqrt(ux * ux + uy * uy)
    cosg = (l_fe * l_fe + l_ce * l_ce - l_cf * l_cf) / (2.0 * l_fe * l_ce)
    if cosg > 1.0 or cosg < -1.0 or l_ce == 0.0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    th_e = math.atan2(uy, ux) + branch * math.acos(cosg)
    xf = xe + l_fe * math.cos(th_e)
    yf = ye + l_fe * math.sin(th_e)
    th_4 = math.atan2(yf - yc, xf - xc)
    s4e = math.sin(th_4 - th_e)
    # velocity: l_CF w4 e^{i th4} - l_FE wE e^{i thE} = Q,  Q = -l_CD w_C i e^{i thC} / i ... written as
    # Q = -l_CD w_C e^{i thC} (after dividing the velocity loop by i)
    qx = -l_cd * w_c * math.cos(th_c)
    qy = -l_cd * w_c * math.sin(th_c)
    w4 = (qy * math.cos(th_e) - qx * math.sin(th_e)) / (l_cf * s4e)
    we = -(qy * math.cos(th_4) - qx * math.sin(th_4)) / (l_fe * (-s4e))
    # acceleration: l_CF a4 e^{i th4} - l_FE aE e^{i thE} = -i R,
    # R = -l_CD (i a_C - w_C^2) e^{i thC} + l_CF w4^2 e^{i th4} - l_FE wE^2 e^{i thE}
    c_c, s_c = math.cos(th_c), math.sin(th_c)
    c_4, s_4 = math.cos(th_4), math.sin(th_4)
    c_e, s_e = math.cos(th_e), math.sin(th_e)
    # (i a - w^2) e^{i th} = (-w^2 cos - a sin) + i(-w^2 sin + a cos)
    rx = -l_cd * (-w_c * w_c * c_c - a_c * s_c) + l_cf * w4 * w4 * c_4 - l_fe * we * we * c_e
    ry = -l_cd * (-w_c * w_c * s_c + a_c * c_c) + l_cf * w4 * w4 * s_4 - l_fe * we * we * s_e
    # -i R = ry - i rx
    px = ry
    py = -rx
    a4 = (py * c_e - px * s_e) / (l_cf * s4e)
    ae = -(py * c_4 - px * s_4) / (l_fe * (-s4e))
    return True, th_4, w4, a4, th_e, we, ae, xf, yf


def left_comb_angle(x_b, y_b, x_d, y_d, v_b=0.0, a_b=0.0):
    """Left comb (slot) angle theta_D from the push-rod roller B in the rocker slot (study eq. 3).

    Parameters
    ----------
    x_b, y_b : array_like
        Roller B centre (m); x_B = s0 + s + l_AB, y_B = e.
    x_d, y_d : float
        Shaft D (m).
    v_b, a_b : array_like
        Velocity and acceleration of B along x (m/s, m/s^2).

    Returns
    -------
    theta, omega, alpha : ndarray
        theta_D = atan2(y_B - y_D, x_B - x_D) (rad); d theta_D/dt = -dy v_B / q (rad/s);
        d2 theta_D/dt2 = -dy a_B / q + 2 dy dx v_B^2 / q^2 (rad/s^2), with dx = x_B - x_D,
        dy = y_B - y_D, q = dx^2 + dy^2.

    Notes
    -----
    The study prints theta_D = arccot[(s + l_AB + sqrt(r0^2 - (y_B - y_O)^2) - x_D)/(y_B - y_D)]; with
    y_B - y_O = e the square root is s0 and this is the same angle.  atan2 keeps the quadrant.
    """
    dx = np.asarray(x_b, float) - x_d
    dy = np.asarray(y_b, float) - y_d
    q = dx * dx + dy * dy
    v_b = np.asarray(v_b, float)
    a_b = np.asarray(a_b, float)
    theta = np.arctan2(dy, dx)
    omega = -dy * v_b / q
    alpha = -dy * a_b / q + 2.0 * dy * dx * v_b**2 / q**2
    return theta, omega, alpha


def four_bar_position(theta_c, d, e, l_cd, l_cf, l_fe, branch=1):
    """Coupler and right-arm angles of the double rocker D-C-F-E (study eq. 3, corrected).

    Parameters
    ----------
    theta_c : array_like
        Direction of the left arm D->C (rad).
    d, e : tuple of float
        Shafts D and E (m).
    l_cd, l_cf, l_fe : float
        Left arm, coupler and right arm lengths (m).
    branch : {1, -1}
        Assembly: sign of the rotation from E->C to E->F.

    Returns
    -------
    theta_4, theta_e : ndarray
        Coupler direction C->F and right-arm direction E->F (rad).  NaN where the linkage cannot
        assemble.

    Notes
    -----
    theta_E = arg(C - E) + branch * acos((l_FE^2 + l_CE^2 - l_CF^2) / (2 l_FE l_CE)).  This is the
    study's two-triangle form (triangle D-E-C, then C-E-F); **departure from the printed eq. 3:** its
    second arccos has l_CE where the coupler length l_CF belongs.
    """
    theta_c = np.atleast_1d(np.asarray(theta_c, float))
    xc = d[0] + l_cd * np.cos(theta_c)
    yc = d[1] + l_cd * np.sin(theta_c)
    ux, uy = xc - e[0], yc - e[1]
    l_ce = np.hypot(ux, uy)
    cosg = (l_fe**2 + l_ce**2 - l_cf**2) / (2 * l_fe * l_ce)
    ok = np.abs(cosg) <= 1.0
    g = np.where(ok, np.arccos(np.clip(cosg, -1, 1)), np.nan)
    theta_e = np.arctan2(uy, ux) + branch * g
    xf = e[0] + l_fe * np.cos(theta_e)
    yf = e[1] + l_fe * np.sin(theta_e)
    theta_4 = np.arctan2(yf - yc, xf - xc)
    return theta_4, theta_e


def four_bar_rates(theta_c, omega_c, alpha_c, theta_4, theta_e, l_cd, l_cf, l_fe):
    """Angular velocities and accelerations of coupler and right arm from the loop derivatives.

    Parameters
    ----------
    theta_c, omega_c, alpha_c : array_like
        Left arm angle (rad), rate (rad/s), acceleration (rad/s^2).
    theta_4, theta_e : array_like
        Coupler and right-arm angles from :func:`four_bar_position` (rad).
    l_cd, l_cf, l_fe : float
        Link lengths (m).

    Returns
    -------
    omega_4, omega_e : ndarray
        Angular velocities of coupler and right arm (rad/s).
    alpha_4, alpha_e : ndarray
        Their angular accelerations (rad/s^2).

    Notes
    -----
    Velocity loop (study eq. 7, first two rows, written for the ideal joints):
    l_CD w_C i e^{i th_C} + l_CF w_4 i e^{i th_4} - l_FE w_E i e^{i th_E} = 0, so
    w_4 = -l_CD w_C sin(th_C - th_E) / (l_CF sin(th_4 - th_E)),
    w_E = l_CD w_C sin(th_C - th_4) / (l_FE sin(th_E - th_4)); the acceleration loop is solved the
    same way with the centripetal terms on the right-hand side.
    """
    tc, wc, ac = (np.asarray(v, float) for v in (theta_c, omega_c, alpha_c))
    t4, te = np.asarray(theta_4, float), np.asarray(theta_e, float)
    w4 = -l_cd * wc * np.sin(tc - te) / (l_cf * np.sin(t4 - te))
    we = l_cd * wc * np.sin(tc - t4) / (l_fe * np.sin(te - t4))
    ec, e4, ee = np.exp(1j * tc), np.exp(1j * t4), np.exp(1j * te)
    r = -l_cd * (1j * ac - wc**2) * ec + l_cf * w4**2 * e4 - l_fe * we**2 * ee
    q = -1j * r
    a4 = np.imag(q * np.conj(ee)) / (l_cf * np.sin(t4 - te))
    ae = -np.imag(q * np.conj(e4)) / (l_fe * np.sin(te - t4))
    return w4, we, a4, ae


def transmission_angle(theta_4, theta_e):
    """Transmission angle of the four-bar: the angle at F between coupler F->C and arm F->E (rad, 0..pi).

    Parameters
    ----------
    theta_4, theta_e : array_like
        Coupler and right-arm angles (rad), from :func:`four_bar_position`.

    Returns
    -------
    ndarray
        Transmission angle mu (rad), in 0..pi.

    Notes
    -----
    mu = acos(cos(theta_4 - theta_E)) with the sign dropped, i.e. the angle between the lines CF and
    EF: mu = |th_4 - th_E| folded into 0..pi (the usual definition, e.g. Norton, *Design of Machinery*).
    A design is usually acceptable for 40 deg <= mu <= 140 deg.
    """
    return np.arccos(np.cos(np.asarray(theta_4, float) - np.asarray(theta_e, float)))
