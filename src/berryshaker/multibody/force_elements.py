"""The force elements of the compiled core: one compiled function per element type, called from the dispatcher
:func:`forces` (docs/multibody.md, "Formulation" and "Powered drives").

A force element is a row of ``ftype`` / ``fint`` / ``fflt``: its type (``layout.FRC_*``) and its record (the named
slots of :data:`berryshaker.multibody.layout.FORCE_RECORDS`).  Each element function reads its own record, adds its
generalised forces to ``Q`` and writes its outputs (``eout``: normal force or torque, penetration, its rate,
tangential force or input torque).  The element functions are inlined into :func:`forces` by numba
(``inline="always"``), so :func:`forces` compiles to one switch: called as functions, their many array arguments
cost ~6 % of a harvester run (a call per element and right-hand side).  Clearance joints are contacts with any
normal law of ``berryshaker.contact`` (the laws reach the core as a tuple of first-class functions, ``laws``) plus
Coulomb friction; the modal-body contact strikes the plant's modes; the rest are springs, loads and the powered
drives.  :func:`forces` adds gravity, the modal forces and the prismatic guides' friction, and with the energy
audit on integrates every element's power (:func:`accumulator_start`).

long module: the element functions are inlined into the one switch :func:`forces` (``inline="always"``) and share
its helpers; over 550 lines with their numpydoc sections (the code is about 400).
"""

from __future__ import annotations

import math

from numba import njit

from berryshaker.contact.friction import coulomb_friction_kernel
from berryshaker.multibody.body_points import _apply, _body_origin, _point
from berryshaker.multibody.cam_pitch import FOOT_PREDICTION_MAX, _foot_rate, pitch_foot_speed

# isort: off
from berryshaker.multibody.layout import (CF_MU, CF_SIX, CF_SIY, CF_SJX, CF_SJY, CF_UX, CF_UY, CF_XIG, CF_XIH,
                                          CI_BODY_I, CI_BODY_J, CON_PRISMATIC, EO_FN, EO_FT, EO_PEN, EO_PENDOT,
                                          FF_BORE_X, FF_BORE_Y, FF_BRANCH_UX, FF_BRANCH_UY, FF_C, FF_CLEARANCE,
                                          FF_CREEP, FF_D, FF_E, FF_ENGAGEMENT, FF_ETA_B, FF_ETA_F, FF_FINGER_X,
                                          FF_FINGER_Y, FF_FORCE_X, FF_FORCE_Y, FF_GEAR_C, FF_GEAR_K, FF_K,
                                          FF_MID_LATERAL, FF_MU, FF_N, FF_PIN_RADIUS, FF_PIN_X, FF_PIN_Y, FF_POINT_X,
                                          FF_POINT_Y, FF_RATIO, FF_REACTION, FF_ROW_OFFSET, FF_RSD_ANGLE0, FF_RSD_C,
                                          FF_RSD_K, FF_SIDE, FF_SLIP, FF_SLOT_UX, FF_SLOT_UY, FF_SLOT_X, FF_SLOT_Y,
                                          FF_TABLE_N, FF_TABLE_SPEEDS, FF_TABLE_TORQUES, FF_TORQUE, FI_BODY_I,
                                          FI_BODY_J, FI_BRANCH_MODE0, FI_BRANCH_MODE_END, FI_BRANCH_ROW, FI_CAM,
                                          FI_LAW, FI_WINDUP, FRC_BRANCH, FRC_FORCE, FRC_GEAR_SD, FRC_GROOVE_CL,
                                          FRC_REV_CL, FRC_ROT_SD, FRC_SLOT_CL, FRC_TORQUE, FRC_TORQUE_SPEED,
                                          PLANT_HALF_SPAN, PLANT_RAMP, PLANT_RAMP_DEPTH, PLANT_SPEED, PLANT_START)
# isort: on

GEAR_W_EPS = 1e-3  # rad/s: below this output speed the mesh loss torque is scaled down linearly (no chatter)


@njit(cache=True, _nrt=False)
def _law(laws, law, pen, pen_dot, v_imp, k, n, e, c, d):
    """Normal force of registered law number ``law`` (berryshaker.contact.laws), 0 when open."""
    if pen <= 0.0:
        return 0.0
    return laws[law](pen, pen_dot, v_imp, k, n, e, c, d)


@njit(cache=True, _nrt=False, inline="always")
def _contact_force(k, bi, bj, q, qd, fint, fflt, mu, nx, ny, pen, pen_dot, relx, rely, cpx, cpy, in_contact, v_imp,
                   laws, Q, eout):
    """A clearance joint's contact force: the normal law at penetration ``pen`` (rate ``pen_dot``) along the unit
    normal (nx, ny) from body j to body i, Coulomb friction (coefficient ``mu``) against the relative sliding
    velocity (relx, rely), both acting at the contact point (cpx, cpy) on body i and reversed on body j."""
    eout[k, EO_PEN] = pen
    eout[k, EO_PENDOT] = pen_dot
    if pen > 0.0:
        vi = v_imp[k] if in_contact[k] else pen_dot
        fn = _law(laws, fint[k, FI_LAW], pen, pen_dot, vi, fflt[k, FF_K], fflt[k, FF_N], fflt[k, FF_E],
                  fflt[k, FF_C], fflt[k, FF_D])
        tx, ty = -ny, nx
        vt = tx * relx + ty * rely
        ft = 0.0
        if mu > 0.0:
            ft = coulomb_friction_kernel(vt, fn, mu, 1e-4, 1e-3)
        fxi, fyi = -fn * nx + ft * tx, -fn * ny + ft * ty
        oix, oiy, _a, _b, _c, _d = _body_origin(q, qd, bi)
        ojx, ojy, _e, _f, _g, _h = _body_origin(q, qd, bj)
        _apply(Q, bi, fxi, fyi, cpx - oix, cpy - oiy)
        _apply(Q, bj, -fxi, -fyi, cpx - ojx, cpy - ojy)
        eout[k, EO_FN] = fn
        eout[k, EO_FT] = ft


@njit(cache=True, _nrt=False, inline="always")
def pin_in_bore(k, q, qd, fint, fflt, in_contact, v_imp, laws, Q, eout):
    """Pin of body i in a bore of body j (``FRC_REV_CL``): penetration |e| - c along the line of centres, friction
    from the relative velocity of the contact points of pin (radius r) and bore (radius r + c).

    Parameters
    ----------
    k : int
        The element's row.
    q, qd : numpy.ndarray
        Positions (m, rad) and velocities (m/s, rad/s).
    fint, fflt : numpy.ndarray
        The force elements' records (``layout.FI_*``, ``layout.FF_*``; SI).
    in_contact, v_imp : numpy.ndarray
        Each contact closed at the last accepted step; its impact velocity (m/s).
    laws : tuple
        The registered contact laws' compiled functions.
    Q, eout : numpy.ndarray
        Generalised forces (N, N m), added to; element outputs (``layout.EO_*``, SI), written.
    """
    bi, bj = fint[k, FI_BODY_I], fint[k, FI_BODY_J]
    pix, piy, vix, viy, aix, aiy, wi = _point(q, qd, bi, fflt[k, FF_PIN_X], fflt[k, FF_PIN_Y])
    ojx, ojy, vjx, vjy, phj, wj = _body_origin(q, qd, bj)
    rpin = fflt[k, FF_PIN_RADIUS]
    pjx, pjy, vpjx, vpjy, ajx, ajy, wj2 = _point(q, qd, bj, fflt[k, FF_BORE_X], fflt[k, FF_BORE_Y])
    ex, ey = pix - pjx, piy - pjy
    mag = math.sqrt(ex * ex + ey * ey)
    if mag > 0.0:
        nx, ny = ex / mag, ey / mag
    else:
        nx, ny = 1.0, 0.0
    pen = mag - fflt[k, FF_CLEARANCE]
    # velocities of the contact points of pin (radius rpin) and bore (radius rpin + c)
    rb = rpin + fflt[k, FF_CLEARANCE]
    vcix, vciy = vix - wi * rpin * ny, viy + wi * rpin * nx
    vcjx, vcjy = vpjx - wj * rb * ny, vpjy + wj * rb * nx
    relx, rely = vcix - vcjx, vciy - vcjy
    pen_dot = nx * (vix - vpjx) + ny * (viy - vpjy)
    cpx, cpy = pix + rpin * nx, piy + rpin * ny
    _contact_force(k, bi, bj, q, qd, fint, fflt, fflt[k, FF_MU], nx, ny, pen, pen_dot, relx, rely, cpx, cpy,
                   in_contact, v_imp, laws, Q, eout)


@njit(cache=True, _nrt=False, inline="always")
def _wall_contact(k, bi, bj, q, qd, fint, fflt, d, n0x, n0y, pix, piy, vix, viy, ojx, ojy, vjx, vjy, wj, in_contact,
                  v_imp, laws, Q, eout):
    """A pin (roller) centred d along the unit normal (n0x, n0y) of a slot's (groove's) centre line, free travel c:
    penetration |d| - c / 2 against the nearer wall, sliding velocity relative to body j's material point under the
    pin, contact at the pin's centre."""
    side = 1.0 if d >= 0.0 else -1.0
    nx, ny = side * n0x, side * n0y
    pen = abs(d) - 0.5 * fflt[k, FF_CLEARANCE]
    # velocity of the body-j material point under the pin
    vmx = vjx - wj * (piy - ojy)
    vmy = vjy + wj * (pix - ojx)
    relx, rely = vix - vmx, viy - vmy
    pen_dot = nx * relx + ny * rely
    _contact_force(k, bi, bj, q, qd, fint, fflt, fflt[k, FF_MU], nx, ny, pen, pen_dot, relx, rely, pix, piy,
                   in_contact, v_imp, laws, Q, eout)


@njit(cache=True, _nrt=False, inline="always")
def pin_in_slot(k, q, qd, fint, fflt, in_contact, v_imp, laws, Q, eout):
    """Pin of body i in a straight slot of body j (``FRC_SLOT_CL``): its distance from the slot's centre line.

    Parameters
    ----------
    k : int
        The element's row.
    q, qd : numpy.ndarray
        Positions (m, rad) and velocities (m/s, rad/s).
    fint, fflt : numpy.ndarray
        The force elements' records (``layout.FI_*``, ``layout.FF_*``; SI).
    in_contact, v_imp : numpy.ndarray
        Each contact closed at the last accepted step; its impact velocity (m/s).
    laws : tuple
        The registered contact laws' compiled functions.
    Q, eout : numpy.ndarray
        Generalised forces (N, N m), added to; element outputs (``layout.EO_*``, SI), written.
    """
    bi, bj = fint[k, FI_BODY_I], fint[k, FI_BODY_J]
    pix, piy, vix, viy, aix, aiy, wi = _point(q, qd, bi, fflt[k, FF_PIN_X], fflt[k, FF_PIN_Y])
    ojx, ojy, vjx, vjy, phj, wj = _body_origin(q, qd, bj)
    pjx, pjy, vpjx, vpjy, ajx, ajy, wj2 = _point(q, qd, bj, fflt[k, FF_SLOT_X], fflt[k, FF_SLOT_Y])
    c, s = math.cos(phj) if bj >= 0 else 1.0, math.sin(phj) if bj >= 0 else 0.0
    ux, uy = fflt[k, FF_SLOT_UX], fflt[k, FF_SLOT_UY]
    gx, gy = c * ux - s * uy, s * ux + c * uy
    n0x, n0y = -gy, gx
    d = n0x * (pix - pjx) + n0y * (piy - pjy)
    _wall_contact(k, bi, bj, q, qd, fint, fflt, d, n0x, n0y, pix, piy, vix, viy, ojx, ojy, vjx, vjy, wj, in_contact,
                  v_imp, laws, Q, eout)


@njit(cache=True, _nrt=False, inline="always")
def roller_in_groove(k, t, q, qd, fint, fflt, cams, in_contact, v_imp, psi_mem_f, laws, Q, eout):
    """Roller of body i in the groove of cam body j (``FRC_GROOVE_CL``): its signed distance from the cam's pitch
    curve at the foot point, found by Newton from the last foot carried to time t by its rate (``psi_mem_f``,
    :data:`berryshaker.multibody.cam_pitch.FOOT_MEMORY`), which it updates.

    Parameters
    ----------
    k : int
        The element's row.
    t : float
        Time (s).
    q, qd : numpy.ndarray
        Positions (m, rad) and velocities (m/s, rad/s).
    fint, fflt : numpy.ndarray
        The force elements' records (``layout.FI_*``, ``layout.FF_*``; SI).
    cams : numpy.ndarray
        A row per cam (``layout.CAM_*``; lengths m, angles rad).
    in_contact, v_imp : numpy.ndarray
        Each contact closed at the last accepted step; its impact velocity (m/s).
    psi_mem_f : numpy.ndarray
        Foot memory of the groove contacts (foot angle rad, its rate rad/s, time s;
        :data:`~berryshaker.multibody.cam_pitch.FOOT_MEMORY`), updated.
    laws : tuple
        The registered contact laws' compiled functions.
    Q, eout : numpy.ndarray
        Generalised forces (N, N m), added to; element outputs (``layout.EO_*``, SI), written.
    """
    bi, bj = fint[k, FI_BODY_I], fint[k, FI_BODY_J]
    pix, piy, vix, viy, aix, aiy, wi = _point(q, qd, bi, fflt[k, FF_PIN_X], fflt[k, FF_PIN_Y])
    ojx, ojy, vjx, vjy, phj, wj = _body_origin(q, qd, bj)
    c, s = (math.cos(phj), math.sin(phj)) if bj >= 0 else (1.0, 0.0)
    wx, wy = pix - ojx, piy - ojy
    lx, ly = c * wx + s * wy, -s * wx + c * wy
    # Newton starts from the last foot carried to this time by its rate (FOOT_MEMORY)
    nfm = fint.shape[0]
    guess = psi_mem_f[k]
    move = psi_mem_f[nfm + k] * (t - psi_mem_f[2 * nfm + k])
    if abs(move) < FOOT_PREDICTION_MAX:  # (NaN guess: stays NaN, the first-call start)
        guess += move
    psi, fx, fy, nlx, nly, d, kap, speed = pitch_foot_speed(lx, ly, cams[fint[k, FI_CAM]], guess)
    # the pin's velocity in the cam frame: R(-phi) (v_pin - v_cam) + phi' (ly, -lx)
    dlx = c * (vix - vjx) + s * (viy - vjy) + wj * ly
    dly = -s * (vix - vjx) + c * (viy - vjy) - wj * lx
    psi_mem_f[k] = psi
    psi_mem_f[nfm + k] = _foot_rate(nlx, nly, d, kap, speed, dlx, dly)
    psi_mem_f[2 * nfm + k] = t
    n0x, n0y = c * nlx - s * nly, s * nlx + c * nly
    _wall_contact(k, bi, bj, q, qd, fint, fflt, d, n0x, n0y, pix, piy, vix, viy, ojx, ojy, vjx, vjy, wj, in_contact,
                  v_imp, laws, Q, eout)


@njit(cache=True, _nrt=False, inline="always")
def branch_contact(k, t, q, qd, n0, fint, fflt, in_contact, v_imp, phi_tab, plant_p, laws, Q, eout):
    """A point of body i striking the modal body (``FRC_BRANCH``) at the station of its mode-shape row: penetration
    along the contact's axis less the branch's modal deflection there, ramped in and out as the machine drives past
    the plant (``plant_p``); the force drives the modes (coordinates from ``n0``) and, times the reaction weight,
    acts back on body i.

    Parameters
    ----------
    k : int
        The element's row.
    t : float
        Time (s).
    q, qd : numpy.ndarray
        Positions (m, rad) and velocities (m/s, rad/s).
    n0 : int
        First modal coordinate (3 x number of bodies).
    fint, fflt : numpy.ndarray
        The force elements' records (``layout.FI_*``, ``layout.FF_*``; SI).
    in_contact, v_imp : numpy.ndarray
        Each contact closed at the last accepted step; its impact velocity (m/s).
    phi_tab : numpy.ndarray
        Mode shapes at the contacts' stations (m per unit modal coordinate).
    plant_p : numpy.ndarray
        The drive-past (``layout.PLANT_*``: speed m/s, start m, half span m, ramp m, ramp depth m).
    laws : tuple
        The registered contact laws' compiled functions.
    Q, eout : numpy.ndarray
        Generalised forces (N, N m), added to; element outputs (``layout.EO_*``, SI), written.
    """
    # comb finger point on body bi striking the branch at the station of phi_tab row fint[k, FI_BRANCH_ROW]
    bi = fint[k, FI_BODY_I]
    pix, piy, vix, viy, aix, aiy, wi = _point(q, qd, bi, fflt[k, FF_FINGER_X], fflt[k, FF_FINGER_Y])
    oix, oiy, _a, _b, _c, _d = _body_origin(q, qd, bi)
    ax, ay = fflt[k, FF_BRANCH_UX], fflt[k, FF_BRANCH_UY]
    side = fflt[k, FF_SIDE]
    row = fint[k, FI_BRANCH_ROW]
    u = 0.0
    ud = 0.0
    m0, m1 = fint[k, FI_BRANCH_MODE0], fint[k, FI_BRANCH_MODE_END]  # the row's nonzero columns: the same sums
    for m in range(m0, m1):
        u += phi_tab[row, m] * q[n0 + m]
        ud += phi_tab[row, m] * qd[n0 + m]
    xlat = ax * pix + ay * piy
    vlat = ax * vix + ay * viy
    pen = side * (xlat - fflt[k, FF_MID_LATERAL]) + fflt[k, FF_ENGAGEMENT] - side * u
    pen_dot = side * vlat - side * ud
    # the plant enters and leaves the comb as the machine drives past: reach ramps in and out
    xrel = plant_p[PLANT_START] + plant_p[PLANT_SPEED] * t - fflt[k, FF_ROW_OFFSET]
    half, ramp = plant_p[PLANT_HALF_SPAN], plant_p[PLANT_RAMP]
    dist = half - abs(xrel)
    if dist <= 0.0:
        reach = 0.0
    elif dist >= ramp:
        reach = 1.0
    else:
        s_ = dist / ramp
        reach = s_ * s_ * (3.0 - 2.0 * s_)
    pen -= (1.0 - reach) * plant_p[PLANT_RAMP_DEPTH]
    eout[k, EO_PEN] = pen
    eout[k, EO_PENDOT] = pen_dot
    if pen > 0.0:
        fn = _law(laws, fint[k, FI_LAW], pen, pen_dot, v_imp[k] if in_contact[k] else pen_dot, fflt[k, FF_K],
                  fflt[k, FF_N], fflt[k, FF_E], fflt[k, FF_C], fflt[k, FF_D])
        for m in range(m0, m1):
            Q[n0 + m] += side * fn * phi_tab[row, m]
        react = fflt[k, FF_REACTION]
        _apply(Q, bi, -react * side * fn * ax, -react * side * fn * ay, pix - oix, piy - oiy)
        eout[k, EO_FN] = fn


@njit(cache=True, _nrt=False, inline="always")
def rotational_spring_damper(k, q, qd, fint, fflt, Q, eout):
    """Torsional spring-damper between bodies i and j (``FRC_ROT_SD``): T = -k (phi_i - phi_j - phi0) -
    c (w_i - w_j) on body i, -T on body j.

    Parameters
    ----------
    k : int
        The element's row.
    q, qd : numpy.ndarray
        Positions (m, rad) and velocities (m/s, rad/s).
    fint, fflt : numpy.ndarray
        The force elements' records (``layout.FI_*``, ``layout.FF_*``; SI).
    Q, eout : numpy.ndarray
        Generalised forces (N, N m), added to; element outputs (``layout.EO_*``, SI), written.
    """
    bi, bj = fint[k, FI_BODY_I], fint[k, FI_BODY_J]
    phii = q[3 * bi + 2] if bi >= 0 else 0.0
    wi = qd[3 * bi + 2] if bi >= 0 else 0.0
    phij = q[3 * bj + 2] if bj >= 0 else 0.0
    wj = qd[3 * bj + 2] if bj >= 0 else 0.0
    tq = -fflt[k, FF_RSD_K] * (phii - phij - fflt[k, FF_RSD_ANGLE0]) - fflt[k, FF_RSD_C] * (wi - wj)
    if bi >= 0:
        Q[3 * bi + 2] += tq
    if bj >= 0:
        Q[3 * bj + 2] -= tq
    eout[k, EO_FN] = tq


@njit(cache=True, _nrt=False, inline="always")
def constant_torque(k, fint, fflt, Q, eout):
    """A constant torque on body i (``FRC_TORQUE``).

    Parameters
    ----------
    k : int
        The element's row.
    fint, fflt : numpy.ndarray
        The force elements' records (``layout.FI_*``, ``layout.FF_*``; SI).
    Q, eout : numpy.ndarray
        Generalised forces (N, N m), added to; element outputs (``layout.EO_*``, SI), written.
    """
    bi = fint[k, FI_BODY_I]
    Q[3 * bi + 2] += fflt[k, FF_TORQUE]
    eout[k, EO_FN] = fflt[k, FF_TORQUE]


@njit(cache=True, _nrt=False, inline="always")
def constant_force(k, q, qd, fint, fflt, Q, eout):
    """A constant force (fixed direction in the plane) at a point of body i (``FRC_FORCE``).

    Parameters
    ----------
    k : int
        The element's row.
    q, qd : numpy.ndarray
        Positions (m, rad) and velocities (m/s, rad/s).
    fint, fflt : numpy.ndarray
        The force elements' records (``layout.FI_*``, ``layout.FF_*``; SI).
    Q, eout : numpy.ndarray
        Generalised forces (N, N m), added to; element outputs (``layout.EO_*``, SI), written.
    """
    bi = fint[k, FI_BODY_I]
    pix, piy, vix, viy, aix, aiy, wi = _point(q, qd, bi, fflt[k, FF_POINT_X], fflt[k, FF_POINT_Y])
    _apply(Q, bi, fflt[k, FF_FORCE_X], fflt[k, FF_FORCE_Y], aix, aiy)
    eout[k, EO_FN] = math.hypot(fflt[k, FF_FORCE_X], fflt[k, FF_FORCE_Y])


@njit(cache=True, _nrt=False)
def table_torque(fflt, k, w):
    """Torque of the torque-speed table of force element k at relative speed w: linear interpolation between
    the points (speeds increasing), end values held outside (as numpy.interp).

    Parameters
    ----------
    fflt : numpy.ndarray
        Float records of the force elements (``layout.FF_*``, SI).
    k : int
        The force element's row.
    w : float
        Relative speed (rad/s).
    """
    nt = int(fflt[k, FF_TABLE_N])
    if w <= fflt[k, FF_TABLE_SPEEDS]:
        return fflt[k, FF_TABLE_TORQUES]
    if w >= fflt[k, FF_TABLE_SPEEDS + nt - 1]:
        return fflt[k, FF_TABLE_TORQUES + nt - 1]
    lo, hi = 0, nt - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if fflt[k, FF_TABLE_SPEEDS + mid] <= w:
            lo = mid
        else:
            hi = mid
    x0, x1 = fflt[k, FF_TABLE_SPEEDS + lo], fflt[k, FF_TABLE_SPEEDS + hi]
    y0, y1 = fflt[k, FF_TABLE_TORQUES + lo], fflt[k, FF_TABLE_TORQUES + hi]
    return y0 + (y1 - y0) * (w - x0) / (x1 - x0)


@njit(cache=True, _nrt=False, inline="always")
def torque_speed_source(k, qd, fint, fflt, Q, eout):
    """A motor (``FRC_TORQUE_SPEED``): the torque of its table at the speed of body i relative to body j, on body i,
    its reaction on body j.

    Parameters
    ----------
    k : int
        The element's row.
    qd : numpy.ndarray
        Velocities (m/s, rad/s).
    fint, fflt : numpy.ndarray
        The force elements' records (``layout.FI_*``, ``layout.FF_*``; SI).
    Q, eout : numpy.ndarray
        Generalised forces (N, N m), added to; element outputs (``layout.EO_*``, SI), written.
    """
    bi, bj = fint[k, FI_BODY_I], fint[k, FI_BODY_J]
    wrel = (qd[3 * bi + 2] if bi >= 0 else 0.0) - (qd[3 * bj + 2] if bj >= 0 else 0.0)
    tq = table_torque(fflt, k, wrel)
    if bi >= 0:
        Q[3 * bi + 2] += tq
    if bj >= 0:
        Q[3 * bj + 2] -= tq
    eout[k, EO_FN] = tq


@njit(cache=True, _nrt=False, inline="always")
def geared_spring_damper(k, qd, fint, fflt, Q, eout):
    """A geared torsional spring-damper from body i (input) to body j (output) (``FRC_GEAR_SD``): its windup psi
    is an auxiliary coordinate whose rate it writes; input torque k psi + c psi' on body i, the output torque less
    the mesh loss on body j (docs/multibody.md, "Powered drives").

    Parameters
    ----------
    k : int
        The element's row.
    qd : numpy.ndarray
        Velocities (m/s, rad/s).
    fint, fflt : numpy.ndarray
        The force elements' records (``layout.FI_*``, ``layout.FF_*``; SI).
    Q, eout : numpy.ndarray
        Generalised forces (N, N m), added to; element outputs (``layout.EO_*``, SI), written.
    """
    bi, bj = fint[k, FI_BODY_I], fint[k, FI_BODY_J]
    wi = qd[3 * bi + 2] if bi >= 0 else 0.0
    wj = qd[3 * bj + 2] if bj >= 0 else 0.0
    st = fint[k, FI_WINDUP]  # coordinate of the windup state psi (its velocity slot holds psi)
    psi = qd[st]
    ratio = fflt[k, FF_RATIO]
    t_el = fflt[k, FF_GEAR_K] * psi
    # windup rate: kinematic mismatch less elastic creep (Reynolds) ...
    rate = wi - ratio * wj - wi * fflt[k, FF_CREEP] * t_el
    # ... and no further stretch while the element slips at its cap (gross slip)
    slip = fflt[k, FF_SLIP]
    if slip > 0.0 and abs(t_el) >= slip and rate * t_el > 0.0:
        rate = 0.0
    ts = t_el + fflt[k, FF_GEAR_C] * rate  # torque at the input (N m)
    Q[st] = rate
    # mesh loss: a friction torque against the output speed, of size (1 - eta_f)|r ts| while power flows
    # into the output (T_out = eta_f r ts) and (1/eta_b - 1)|r ts| while the output drives back
    # (T_out = r ts / eta_b); sign(w_j) is regularised over |w_j| < GEAR_W_EPS so that it is continuous
    t_o = ratio * ts
    if t_o * wj >= 0.0:
        loss = (1.0 - fflt[k, FF_ETA_F]) * abs(t_o)
    else:
        loss = (1.0 / fflt[k, FF_ETA_B] - 1.0) * abs(t_o)
    sat = wj / GEAR_W_EPS
    if sat > 1.0:
        sat = 1.0
    elif sat < -1.0:
        sat = -1.0
    tj = t_o - loss * sat
    if bi >= 0:
        Q[3 * bi + 2] -= ts
    if bj >= 0:
        Q[3 * bj + 2] += tj
    eout[k, EO_FN] = tj
    eout[k, EO_FT] = ts


@njit(cache=True, _nrt=False, inline="always")
def prismatic_guide_friction(k, q, qd, cint, cflt, crow, lam_prev, Q):
    """Coulomb friction of prismatic joint k (constraint block) along its axis, its normal forces the reactions of
    its two supports from the last accepted step's multipliers (lagged by one step).

    Parameters
    ----------
    k : int
        The prismatic joint's constraint block.
    q, qd : numpy.ndarray
        Positions (m, rad) and velocities (m/s, rad/s).
    cint, cflt : numpy.ndarray
        The constraint blocks' records (``layout.CI_*``, ``layout.CF_*``; SI).
    crow : numpy.ndarray of int
        First row of each constraint block.
    lam_prev : numpy.ndarray
        Multipliers of the last accepted step (N, N m).
    Q : numpy.ndarray
        Generalised forces, added to (N, N m; an auxiliary coordinate: its rate in its own unit per s).
    """
    bi, bj = cint[k, CI_BODY_I], cint[k, CI_BODY_J]
    r = crow[k]
    plx, ply, vlx, vly, alx, aly, wl = _point(q, qd, bi, cflt[k, CF_SIX], cflt[k, CF_SIY])
    ppx, ppy, vpx, vpy, apx, apy, wp = _point(q, qd, bj, cflt[k, CF_SJX], cflt[k, CF_SJY])
    ux, uy = cflt[k, CF_UX], cflt[k, CF_UY]
    if bi >= 0:
        c, s = math.cos(q[3 * bi + 2]), math.sin(q[3 * bi + 2])
        ux, uy = c * ux - s * uy, s * ux + c * uy
    axial = ux * (ppx - plx) + uy * (ppy - ply)
    xig = cflt[k, CF_XIG] - axial
    xih = cflt[k, CF_XIH] - axial
    l1, l2 = lam_prev[r], lam_prev[r + 1]
    # R_G + R_H = -l2 ; R_G xi_G + R_H xi_H = -l1
    rg = (-l1 + l2 * xih) / (xig - xih)
    rh = -l2 - rg
    v_rel = ux * (vpx - vlx) + uy * (vpy - vly)
    ff = coulomb_friction_kernel(v_rel, abs(rg) + abs(rh), cflt[k, CF_MU], 1e-4, 1e-3)
    oix, oiy, _a, _b, _c, _d = _body_origin(q, qd, bi)
    ojx, ojy, _e, _f, _g, _h = _body_origin(q, qd, bj)
    _apply(Q, bj, ff * ux, ff * uy, ppx - ojx, ppy - ojy)
    _apply(Q, bi, -ff * ux, -ff * uy, ppx - oix, ppy - oiy)


@njit(cache=True, _nrt=False)
def accumulator_start(ftype, n_base, n_all):
    """First energy-accumulator coordinate, or -1 when the run has none.

    Auxiliary coordinates follow the bodies and modal coordinates (``n_base`` = 3 bodies + modes): first one
    windup state per geared spring-damper (element order), then, when the energy audit is on, one accumulator
    per force element plus two (prismatic guide friction, modal-body internal forces).  An accumulator's
    velocity slot is the work done on the mechanism so far (J): its rate (the generalised-force slot, unit mass)
    is the element's power sum_i dQ_i q'_i, so the Runge-Kutta stages integrate it with the state.

    Parameters
    ----------
    ftype : numpy.ndarray of int
        Type of each force element (``layout.FRC_*``).
    n_base : int
        Coordinates of the bodies and modes (where the auxiliary coordinates begin).
    n_all : int
        All coordinates.
    """
    nf = ftype.shape[0]
    ns = 0
    for k in range(nf):
        if ftype[k] == FRC_GEAR_SD:
            ns += 1
    if n_all - n_base - ns == nf + 2:
        return n_base + ns
    return -1


@njit(cache=True, _nrt=False)
def _power(Q, qd, n):
    """sum_i Q_i q'_i over the first n coordinates (rate of work of the forces accumulated in Q so far)."""
    p = 0.0
    for i in range(n):
        p += Q[i] * qd[i]
    return p


@njit(cache=True, _nrt=False)
def forces(t, q, qd, mass, gravity, ftype, fint, fflt, cams, in_contact, v_imp, psi_mem_f,
           ctype, cint, cflt, crow, lam_prev, modal_w, modal_z, phi_tab, plant_p, Q, eout, laws):
    """Generalised applied forces Q: gravity, the modal body's own stiffness and damping, every force element
    (clearance contacts, spring-dampers, loads, powered drives, modal-body contacts: one function per type), and
    the guide friction of prismatic joints (from the previous step's multipliers); with the energy audit on, the
    rates of the energy accumulators.

    Parameters
    ----------
    t : float
        Time (s).
    q, qd : numpy.ndarray
        Positions (m, rad) and velocities (m/s, rad/s).
    mass : numpy.ndarray
        The bodies' masses (kg).
    gravity : numpy.ndarray
        Gravity, x and y (m/s^2).
    ftype : numpy.ndarray of int
        Type of each force element (``layout.FRC_*``).
    fint, fflt : numpy.ndarray
        The force elements' records (``layout.FI_*``, ``layout.FF_*``; SI).
    cams : numpy.ndarray
        A row per cam (``layout.CAM_*``; lengths m, angles rad).
    in_contact, v_imp : numpy.ndarray
        Each contact closed at the last accepted step; its impact velocity (m/s).
    psi_mem_f : numpy.ndarray
        Foot memory of the groove contacts (foot angle rad, its rate rad/s, time s;
        :data:`~berryshaker.multibody.cam_pitch.FOOT_MEMORY`), updated.
    ctype, cint, cflt, crow : numpy.ndarray
        The constraint blocks: types (``layout.CON_*``), integer and float records (``layout.CI_*``,
        ``layout.CF_*``; SI), first rows.
    lam_prev : numpy.ndarray
        Multipliers of the last accepted step (N, N m).
    modal_w, modal_z : numpy.ndarray
        Natural angular frequency (rad/s) and damping ratio (dimensionless) of each mode.
    phi_tab : numpy.ndarray
        Mode shapes at the contacts' stations (m per unit modal coordinate).
    plant_p : numpy.ndarray
        The drive-past (``layout.PLANT_*``: speed m/s, start m, half span m, ramp m, ramp depth m).
    Q : numpy.ndarray
        Written: the generalised forces (N, N m; an auxiliary coordinate: its rate).
    eout : numpy.ndarray
        Element outputs, written (``layout.EO_*``: normal force N or torque N m, penetration m, its rate m/s,
        tangential force N or input torque N m).
    laws : tuple
        The registered contact laws' compiled functions.
    """
    nb = mass.shape[0]
    for b in range(nb):
        Q[3 * b] = mass[b] * gravity[0]
        Q[3 * b + 1] = mass[b] * gravity[1]
        Q[3 * b + 2] = 0.0
    n0 = 3 * nb
    nm = modal_w.shape[0]
    for k in range(nm):
        Q[n0 + k] = -modal_w[k] * modal_w[k] * q[n0 + k] - 2.0 * modal_z[k] * modal_w[k] * qd[n0 + k]
    # powered drives: auxiliary coordinates (element states, energy accumulators) after the modal ones
    n_phys = n0 + nm
    for i in range(n_phys, q.shape[0]):
        Q[i] = 0.0
    acc0 = accumulator_start(ftype, n_phys, q.shape[0])
    if acc0 >= 0:
        Q[acc0 + ftype.shape[0] + 1] = _power(Q, qd, n_phys) - _power(Q, qd, n0)  # modal stiffness + damping
    p_before = 0.0
    for k in range(ftype.shape[0]):
        if acc0 >= 0:
            p_before = _power(Q, qd, n_phys)
        typ = ftype[k]
        eout[k, EO_FN] = 0.0
        eout[k, EO_FT] = 0.0
        if typ == FRC_REV_CL:
            pin_in_bore(k, q, qd, fint, fflt, in_contact, v_imp, laws, Q, eout)
        elif typ == FRC_SLOT_CL:
            pin_in_slot(k, q, qd, fint, fflt, in_contact, v_imp, laws, Q, eout)
        elif typ == FRC_GROOVE_CL:
            roller_in_groove(k, t, q, qd, fint, fflt, cams, in_contact, v_imp, psi_mem_f, laws, Q, eout)
        elif typ == FRC_ROT_SD:
            rotational_spring_damper(k, q, qd, fint, fflt, Q, eout)
        elif typ == FRC_TORQUE:
            constant_torque(k, fint, fflt, Q, eout)
        elif typ == FRC_FORCE:
            constant_force(k, q, qd, fint, fflt, Q, eout)
        elif typ == FRC_BRANCH:
            branch_contact(k, t, q, qd, n0, fint, fflt, in_contact, v_imp, phi_tab, plant_p, laws, Q, eout)
        elif typ == FRC_TORQUE_SPEED:
            torque_speed_source(k, qd, fint, fflt, Q, eout)
        elif typ == FRC_GEAR_SD:
            geared_spring_damper(k, qd, fint, fflt, Q, eout)
        if acc0 >= 0:
            Q[acc0 + k] = _power(Q, qd, n_phys) - p_before
    if acc0 >= 0:
        p_before = _power(Q, qd, n_phys)
    # guide friction of prismatic joints, normal forces from the last accepted step's multipliers
    for k in range(ctype.shape[0]):
        if ctype[k] != CON_PRISMATIC or cflt[k, CF_MU] <= 0.0:
            continue
        prismatic_guide_friction(k, q, qd, cint, cflt, crow, lam_prev, Q)
    if acc0 >= 0:
        Q[acc0 + ftype.shape[0]] = _power(Q, qd, n_phys) - p_before


@njit(cache=True, _nrt=False)
def fint_is_contact(model, j):
    """True where force element ``j`` is a contact (clearance joint or modal-body contact).

    Parameters
    ----------
    model : tuple
        The compiled mechanism's arrays (:mod:`berryshaker.multibody.dynamics`).
    j : int
        The force element's row.
    """
    ftype = model.ftype
    t = ftype[j]
    return t == FRC_REV_CL or t == FRC_SLOT_CL or t == FRC_GROOVE_CL or t == FRC_BRANCH
