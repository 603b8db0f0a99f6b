"""The compiled core of the MLSD clearance model (:mod:`berryshaker.drives.groove_cam.mlsd`, ``docs/mlsd.md``): the
parameter, result and integrator-state layouts, the massless links' forces (eq. 8), the equations of motion
(eq. 4-12, :func:`evaluate`) and the resumable Dormand-Prince integrator with contact-onset location
(:func:`integrate`).  They share the layouts and compile into one numba module; the Python driver, the result and
the jam diagnosis are in :mod:`berryshaker.drives.groove_cam.mlsd`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from berryshaker.contact.force_laws import hertz_kernel, hysteresis_kernel, mlsd_kernel
from berryshaker.contact.friction import coulomb_friction_kernel
from berryshaker.drives.groove_cam.kinematics import (
    G_E,
    G_GAMMA,
    G_LAB,
    G_LCD,
    G_LCF,
    G_LFE,
    G_OMEGA,
    G_S0,
    G_XD,
    G_XE,
    G_YD,
    G_YE,
    ideal_state,
    mid_stroke_angles,
)
from berryshaker.drives.groove_cam.machine import GrooveCamMachine as Machine
from berryshaker.errors import ConfigError
from berryshaker.multibody.integrators import DOPRI_A, DOPRI_C, DOPRI_E

PAIR_NAMES = ("A", "B", "C", "F")  # the MLSD model's pairs, in its state/result layout

# dynamic parameter vector
P_M2, P_J3, P_M4, P_J5, P_MU2, P_V0, P_V1, P_XG, P_XH, P_KP, P_CP, P_TD0, P_TE0 = range(13)
P_PAIR0 = 13  # then (c, K, C or v_ref of a hysteresis law, n, law form, hysteresis factor) for A, B, C, F
N_PAIR = 6
N_P = P_PAIR0 + 4 * N_PAIR
#: how the MLSD model realises a pair's law (the ``law form`` parameter)
FORM_SPRING_DAMPER, FORM_HERTZ, FORM_HYSTERESIS = 0, 1, 2
#: laws the MLSD model can run and the form it gives them: the viscous laws (mlsd, and impact, which the study's
#: ADAMS run used beside its MLSD eq. 8) are the eq. 8 spring-damper K r^n + C r'; the hysteresis laws are
#: the same law as the multibody engine's, with the impact velocity located at contact onset
LAW_FORMS = {"mlsd": FORM_SPRING_DAMPER, "impact": FORM_SPRING_DAMPER, "hertz": FORM_HERTZ,
             "hunt_crossley": FORM_HYSTERESIS, "lankarani_nikravesh": FORM_HYSTERESIS, "flores": FORM_HYSTERESIS}
EVENT_TOL = 1e-9  # m: contact onset is located to within this penetration (as the multibody engine)

# result vector
(R_FA, R_FB, R_FC, R_FF, R_DA, R_DB, R_DC, R_DF, R_RG, R_RH, R_FRIC, R_M, R_TL, R_TR,
 R_XDD, R_TDDD, R_UDD, R_TEDD, R_RAX, R_RAY, R_RBX, R_RBY, R_RCX, R_RCY, R_RFX, R_RFY, R_OK,
 R_PA, R_PB, R_PC, R_PF) = range(31)  # R_P*: rates of the link lengths d_i (m/s)
N_R = 31

RESULT_COLUMNS = {
    # name: (index, unit) of the time series written by --out
    "F_A_N": (R_FA, "N"), "F_B_N": (R_FB, "N"), "F_C_N": (R_FC, "N"), "F_F_N": (R_FF, "N"),
    "d_A_m": (R_DA, "m"), "d_B_m": (R_DB, "m"), "d_C_m": (R_DC, "m"), "d_F_m": (R_DF, "m"),
    "F_G_N": (R_RG, "N"), "F_H_N": (R_RH, "N"), "guide_friction_N": (R_FRIC, "N"),
    "drive_moment_Nm": (R_M, "N m"), "T_l_Nm": (R_TL, "N m"), "T_r_Nm": (R_TR, "N m"),
    "r_A_x_m": (R_RAX, "m"), "r_A_y_m": (R_RAY, "m"), "r_B_x_m": (R_RBX, "m"), "r_B_y_m": (R_RBY, "m"),
    "r_C_x_m": (R_RCX, "m"), "r_C_y_m": (R_RCY, "m"), "r_F_x_m": (R_RFX, "m"), "r_F_y_m": (R_RFY, "m"),
}


def parameter_vector(machine: Machine) -> np.ndarray:
    """Dynamic parameters (SI) of the MLSD model for the compiled kernels.

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine, its clearances set.

    Returns
    -------
    ndarray
        (:data:`N_P`,), SI values in the layout ``P_*`` (masses kg, inertias kg m^2, lengths m, per pair its
        clearance, K, C or v_ref, n, law form and hysteresis factor).

    Raises
    ------
    ConfigError
        A pair's law is not one the MLSD model runs (:data:`LAW_FORMS`).
    """
    p = np.zeros(N_P)
    p[P_M2] = machine.push_rod.mass
    p[P_J3] = machine.combs.left_inertia
    p[P_M4] = machine.four_bar.coupler_mass
    p[P_J5] = machine.combs.right_inertia
    p[P_MU2] = machine.push_rod.friction_coefficient
    p[P_V0], p[P_V1] = 1e-4, 1e-3
    p[P_XG], p[P_XH] = machine.push_rod.bearing_G_x, machine.push_rod.bearing_H_x
    p[P_KP], p[P_CP] = machine.combs.load_stiffness, machine.combs.load_damping
    p[P_TD0], p[P_TE0] = mid_stroke_angles(machine)
    for k, name in enumerate(PAIR_NAMES):
        pair = machine.clearance[name]
        half = 0.5 if pair.kind != "pin-in-bore" else 1.0  # roller pairs: free travel across the groove or slot
        b = P_PAIR0 + N_PAIR * k
        p[b] = pair.size * half
        if pair.size > 0:
            law = machine.pair_contact(name)
        else:  # an ideal joint: the eq. 8 link stiffened to a near-rigid spring (docs/mlsd.md sec. 4)
            law = _ideal_link(machine, name)
        if law.law not in LAW_FORMS:
            raise ConfigError(f"clearance.{name}.law = {law.law!r}: the MLSD model runs the built-in laws "
                              f"{', '.join(LAW_FORMS)}; use the multibody model for a registered law")
        p[b + 1], p[b + 2], p[b + 3] = law.stiffness, law.damping, law.exponent
        p[b + 4] = LAW_FORMS[law.law]
        if p[b + 4] == FORM_HYSTERESIS:
            from berryshaker.contact.conformal import hysteresis_factor

            p[b + 5] = float(hysteresis_factor(law.restitution, law.law))
            p[b + 2] = law.restitution_velocity  # the C slot of a hysteresis pair holds v_ref (m/s)
    return p


#: viscous damping of a zero-clearance MLSD link whose description gives none (N s/m) [assumed]: the study's C_i
IDEAL_LINK_DAMPING = 2000.0


def _ideal_link(machine: Machine, name: str):
    """The law of a zero-clearance link of the MLSD model (docs/mlsd.md sec. 4).

    A zero-clearance link is a joint spring, not a contact: it is always loaded and its force changes side
    without an impact, so a restitution (hysteresis) law does not apply (its damping f(e) K / v0, with v0 the
    tiny rate at which the link passes through zero load, would make the model stiff without physical
    meaning).  The link is the eq. 8 spring-damper with the pair's resolved K and n (for a pin: the law at a
    clearance of 0.1 mm, since Johnson's relation needs c > 0) and the pair's viscous damping, or
    :data:`IDEAL_LINK_DAMPING` where it gives none.
    """
    from dataclasses import replace

    pair = machine.clearance[name]
    if pair.stiffness is not None:
        law = pair.contact()
    else:
        info = next(p for p in machine.PAIRS if p.name == name)
        wall = info.wall_radius(machine) if info.wall_radius is not None else math.inf
        law = pair.model_copy(update={"size": 1e-4}).contact(wall)
    c = law.damping if law.damping > 0 else (pair.damping if pair.damping is not None else IDEAL_LINK_DAMPING)
    return replace(law, law="mlsd", damping=c)


@njit(cache=True)
def _backlash(d, dd, c, k, cdamp):
    """Signed restoring force of a massless link with free play +-c (study eq. 8, consistent reading)."""
    if d > c:
        return -mlsd_kernel(d - c, dd, k, cdamp)
    if d < -c:
        return mlsd_kernel(-d - c, -dd, k, cdamp)
    return 0.0


@njit(cache=True)
def _pair_force(d, dd, p, k, cst):
    """Signed restoring force of pair k (0..3) with the law form of its parameters; ``cst`` holds the contact
    state [in contact (1/0) x 4, impact velocity (m/s) x 4] the hysteresis laws read.  Callers pass ``k`` as
    np.int64: a literal 0..3 would make numba compile four specialisations (0.5 s of a fresh install's first run)."""
    b = P_PAIR0 + N_PAIR * k
    c, kk, cd, n, form = p[b], p[b + 1], p[b + 2], p[b + 3], p[b + 4]
    if d > c:
        pen, pd, sgn = d - c, dd, -1.0
    elif d < -c:
        pen, pd, sgn = -d - c, -dd, 1.0
    else:
        return 0.0
    if form == FORM_SPRING_DAMPER:
        if n == 1.0:
            f = mlsd_kernel(pen, pd, kk, cd)
        else:
            f = kk * pen**n + cd * pd
            f = f if f > 0.0 else 0.0
    elif form == FORM_HERTZ:
        f = hertz_kernel(pen, kk, n)
    else:
        v0 = cst[4 + k] if cst[k] > 0.5 else pd
        if v0 < cd:  # below the restitution velocity v_ref: the damping of an impact at v_ref (docs/contact.md 6.4)
            v0 = cd
        f = hysteresis_kernel(pen, pd, v0, kk, p[b + 5], n)
    return sgn * f


@njit(cache=True)
def evaluate(t, y, g, p, res, cst):
    """Forces, moments and accelerations of the MLSD model at one time and state (eq. 4-12).

    Parameters
    ----------
    t : float
        Time (s); the cam angle is omega t.
    y : ndarray
        (8,) state: x (m), theta_D (rad), u (m), theta_E (rad) and their rates (m/s, rad/s).
    g : ndarray
        Geometry vector of the drive (SI; :func:`berryshaker.drives.groove_cam.kinematics.geometry_vector`).
    p : ndarray
        Dynamic parameters (SI; :func:`parameter_vector`).
    res : ndarray
        (:data:`N_R`,) filled with the results in the layout ``R_*`` (forces N, moments N m, lengths m, rates m/s,
        accelerations m/s^2 or rad/s^2).
    cst : ndarray
        (8,) contact state: in contact (1) x 4, impact velocity (m/s) x 4 (see :func:`_pair_force`).
    """
    w = g[G_OMEGA]
    phi = w * t
    ok, s, v, a, thd_i, wd_i, ad_i, th4, w4, a4, the_i, we_i, ae_i = ideal_state(phi, g)
    res[R_OK] = 1.0 if ok else 0.0
    x, thd, u, the = y[0], y[1], y[2], y[3]
    xd, thdd, ud, thed = y[4], y[5], y[6], y[7]
    s0, e, lab = g[G_S0], g[G_E], g[G_LAB]
    s1 = v / w
    s2 = a / (w * w)
    # ---- pair A: roller in the cam groove; normal n_A = (cos al, -sin al) at pressure angle al
    rho = s0 + s
    q = s1 - e
    al = math.atan2(q, rho)
    dal = (s2 * rho - q * s1) / (rho * rho + q * q) * w
    ca, sa = math.cos(al), math.sin(al)
    dxa = x - s
    d_a = dxa * ca
    dd_a = (xd - v) * ca - dxa * sa * dal
    f_a = _pair_force(d_a, dd_a, p, np.int64(0), cst)
    # ---- pair B: roller B in the slot through D; normal n_B = (-sin thD, cos thD)
    xb = s0 + x + lab
    yb = e
    rx, ry = xb - g[G_XD], yb - g[G_YD]
    cd, sd = math.cos(thd), math.sin(thd)
    d_b = cd * ry - sd * rx
    along = cd * rx + sd * ry
    dd_b = -sd * xd - thdd * along
    f_b = _pair_force(d_b, dd_b, p, np.int64(1), cst)
    # ---- pairs C and F: pins on the combs, bores in the connecting rod (axial line e4)
    c4, s4 = math.cos(th4), math.sin(th4)
    lcd, gam, lfe = g[G_LCD], g[G_GAMMA], g[G_LFE]
    thc_i = thd_i + gam
    thc = thd + gam
    # ideal and actual pin C
    cix, ciy = g[G_XD] + lcd * math.cos(thc_i), g[G_YD] + lcd * math.sin(thc_i)
    ccx, ccy = g[G_XD] + lcd * math.cos(thc), g[G_YD] + lcd * math.sin(thc)
    vcix, vciy = -lcd * wd_i * math.sin(thc_i), lcd * wd_i * math.cos(thc_i)
    vccx, vccy = -lcd * thdd * math.sin(thc), lcd * thdd * math.cos(thc)
    d_c = u + c4 * (cix - ccx) + s4 * (ciy - ccy)
    dd_c = ud + c4 * (vcix - vccx) + s4 * (vciy - vccy) + w4 * (-s4 * (cix - ccx) + c4 * (ciy - ccy))
    f_c = _pair_force(d_c, dd_c, p, np.int64(2), cst)
    dd_c_dthd = -(c4 * (-lcd * math.sin(thc)) + s4 * (lcd * math.cos(thc)))
    # ideal and actual pin F
    fix, fiy = g[G_XE] + lfe * math.cos(the_i), g[G_YE] + lfe * math.sin(the_i)
    fcx, fcy = g[G_XE] + lfe * math.cos(the), g[G_YE] + lfe * math.sin(the)
    vfix, vfiy = -lfe * we_i * math.sin(the_i), lfe * we_i * math.cos(the_i)
    vfcx, vfcy = -lfe * thed * math.sin(the), lfe * thed * math.cos(the)
    d_f = u + c4 * (fix - fcx) + s4 * (fiy - fcy)
    dd_f = ud + c4 * (vfix - vfcx) + s4 * (vfiy - vfcy) + w4 * (-s4 * (fix - fcx) + c4 * (fiy - fcy))
    f_f = _pair_force(d_f, dd_f, p, np.int64(3), cst)
    dd_f_dthe = -(c4 * (-lfe * math.sin(the)) + s4 * (lfe * math.cos(the)))
    # ---- push rod: guide reactions (eq. 10) and friction
    fay = -f_a * sa
    fax = f_a * ca
    fbx = -f_b * sd
    fby = f_b * cd
    xa = s0 + x
    xg, xh = p[P_XG], p[P_XH]
    r_g = -((xa - xh) * fay + (xb - xh) * fby) / (xg - xh)
    r_h = -fay - fby - r_g
    fric = coulomb_friction_kernel(xd, abs(r_g) + abs(r_h), p[P_MU2], p[P_V0], p[P_V1])
    # ---- comb load moments from the bush (viscoelastic reaction about each shaft)
    t_l = p[P_KP] * (thd - p[P_TD0]) + p[P_CP] * thdd
    t_r = p[P_KP] * (the - p[P_TE0]) + p[P_CP] * thed
    # ---- generalised forces and accelerations
    qx = fax + fbx + fric
    qthd = -f_b * along + f_c * dd_c_dthd
    qu = f_c + f_f
    qthe = f_f * dd_f_dthe
    # ideal axial acceleration of the connecting rod's centre
    acx = lcd * (-wd_i * wd_i * math.cos(thc_i) - ad_i * math.sin(thc_i))
    acy = lcd * (-wd_i * wd_i * math.sin(thc_i) + ad_i * math.cos(thc_i))
    a_axial = acx * c4 + acy * s4 - 0.5 * g[G_LCF] * w4 * w4
    res[R_XDD] = qx / p[P_M2]
    res[R_TDDD] = (qthd - t_l) / p[P_J3]
    res[R_UDD] = qu / p[P_M4] - a_axial + u * w4 * w4
    res[R_TEDD] = (qthe - t_r) / p[P_J5]
    # ---- outputs
    res[R_FA], res[R_FB], res[R_FC], res[R_FF] = f_a, f_b, f_c, f_f
    res[R_DA], res[R_DB], res[R_DC], res[R_DF] = d_a, d_b, d_c, d_f
    res[R_RG], res[R_RH], res[R_FRIC] = r_g, r_h, fric
    # cam drive moment in the direction of rotation (clockwise): M = -(x_A F_Ay - y_A F_Ax)   (eq. 9)
    res[R_M] = -(xa * fay - e * fax)
    res[R_TL], res[R_TR] = t_l, t_r
    # clearance vectors (eq. 4): roller A minus pitch point; B minus its foot on the slot line;
    # rod bores minus comb pins at C and F
    res[R_RAX], res[R_RAY] = dxa, 0.0
    res[R_RBX], res[R_RBY] = -sd * d_b, cd * d_b
    res[R_RCX], res[R_RCY] = cix + u * c4 - ccx, ciy + u * s4 - ccy
    res[R_RFX], res[R_RFY] = fix + u * c4 - fcx, fiy + u * s4 - fcy
    res[R_PA], res[R_PB], res[R_PC], res[R_PF] = dd_a, dd_b, dd_c, dd_f


@njit(cache=True)
def _penetration(res, p, k):
    """(penetration beyond the clearance, its rate) of pair k from the result vector; penetration <= 0 open."""
    d, dd = res[R_DA + k], res[R_PA + k]
    c = p[P_PAIR0 + N_PAIR * k]
    if d >= 0.0:
        return d - c, dd
    return -d - c, -dd


@njit(cache=True)
def _rhs(t, y, g, p, res, dy, cst):
    evaluate(t, y, g, p, res, cst)
    dy[0] = y[4]
    dy[1] = y[5]
    dy[2] = y[6]
    dy[3] = y[7]
    dy[4] = res[R_XDD]
    dy[5] = res[R_TDDD]
    dy[6] = res[R_UDD]
    dy[7] = res[R_TEDD]


_C, _A, _E = DOPRI_C, DOPRI_A, DOPRI_E


#: layout of the integrator's resumable state (:func:`integrate`): time, step size, next output sample, steps
#: accepted / rejected / cut at onsets, then the state y (8), the derivative at y (the FSAL stage k0, 8), the
#: contact state (in contact x 4, impact velocity x 4) and the penetrations at the last accepted step (4)
S_T, S_H, S_IO, S_ACC, S_REJ, S_CUTS = range(6)
S_Y = 6
S_K0 = S_Y + 8
S_CST = S_K0 + 8
S_PEN = S_CST + 8
N_S = S_PEN + 4


@njit(cache=True)
def integrate(t_out, g, p, rtol, atol, h_max, stats_from, out_y, out_r, peaks, info, onsets, st, step_limit):
    """Adaptive Dormand-Prince 5(4) from t_out[0] through every output time (landing on each exactly), with
    contact-onset location as in the multibody engine; resumable, so that a long run returns to Python in chunks.

    ``st`` (:data:`N_S`) holds the integrator's whole state (layout ``S_*``): a call with ``st[S_IO] == 0``
    starts at t_out[0] from the state in ``st[S_Y:S_Y + 8]``; a call returns with status 5 when the steps taken
    (accepted + rejected, counted from the run's start) reach ``step_limit``, having saved the state in ``st``, and
    the next call continues from it exactly as an uninterrupted run would (the same step sequence, bitwise).

    Fills out_y (n_out, 8) and out_r (n_out, N_R); peaks[k] = max |res[k]| over every accepted step
    with t >= stats_from; info = [accepted steps, rejected steps, t_fail, status, event cuts] (status 0 ok,
    1 step size underflow, 2 non-finite state, 3 linkage cannot assemble, 5 step limit reached, resumable);
    onsets[k] = contact onsets of pair k (transitions from open to in contact over accepted steps) with
    t >= stats_from.  A step in which a pair's penetration goes from <= 0 to more than EVENT_TOL is cut back to
    the crossing, so the hysteresis laws get the impact velocity at first touch.

    Parameters
    ----------
    t_out : ndarray
        Output times (s), increasing.
    g : ndarray
        Geometry vector (SI).
    p : ndarray
        Dynamic parameters (SI; :func:`parameter_vector`).
    rtol : float
        Relative tolerance (1).
    atol : ndarray
        (8,) absolute tolerances of the state, in its units (m, rad, m/s, rad/s).
    h_max : float
        Largest step (s).
    stats_from : float
        Time from which peaks and onsets are counted (s).
    out_y : ndarray
        (n_out, 8) filled with the state at each output time (its units).
    out_r : ndarray
        (n_out, N_R) filled with the results at each output time (SI, layout ``R_*``).
    peaks : ndarray
        (N_R,) running max of |res| (SI).
    info : ndarray
        (5,) filled as above (counts, t_fail in s, status).
    onsets : ndarray
        (4,) contact onsets per pair: counts (1), as floats.
    st : ndarray
        (N_S,) the resumable integrator state (SI; layout ``S_*``).
    step_limit : int
        Steps taken from the run's start at which the call returns (status 5).
    """
    n = 8
    k = np.zeros((7, n))
    ytmp = np.empty(n)
    ynew = np.empty(n)
    res = np.zeros(N_R)
    cst = np.zeros(8)  # in contact x 4, impact velocity x 4
    pen0 = np.zeros(4)
    y = np.empty(n)
    for i in range(n):
        y[i] = st[S_Y + i]
    io0 = int(st[S_IO])
    if io0 == 0:
        t = t_out[0]
        _rhs(t, y, g, p, res, k[0], cst)
        for j in range(4):
            pe, pd = _penetration(res, p, j)
            pen0[j] = pe
            if pe > 0.0:
                cst[j] = 1.0
                cst[4 + j] = pd if pd > 1e-6 else 1e-6
        for j in range(N_R):
            out_r[0, j] = res[j]
        for i in range(n):
            out_y[0, i] = y[i]
        h = min(h_max, 1e-5)
        acc = 0
        rej = 0
        cuts = 0
        io0 = 1
    else:
        t = st[S_T]
        h = st[S_H]
        acc = int(st[S_ACC])
        rej = int(st[S_REJ])
        cuts = int(st[S_CUTS])
        for i in range(n):
            k[0, i] = st[S_K0 + i]
        for j in range(8):
            cst[j] = st[S_CST + j]
        for j in range(4):
            pen0[j] = st[S_PEN + j]
    for io in range(io0, t_out.shape[0]):
        t_target = t_out[io]
        while t < t_target - 1e-15:
            if acc + rej >= step_limit:
                # save the whole state and return: the next call resumes here (before this step)
                st[S_T] = t
                st[S_H] = h
                st[S_IO] = io
                st[S_ACC] = acc
                st[S_REJ] = rej
                st[S_CUTS] = cuts
                for i in range(n):
                    st[S_Y + i] = y[i]
                    st[S_K0 + i] = k[0, i]
                for j in range(8):
                    st[S_CST + j] = cst[j]
                for j in range(4):
                    st[S_PEN + j] = pen0[j]
                info[0] = acc
                info[1] = rej
                info[2] = t
                info[3] = 5
                info[4] = cuts
                return
            if h > t_target - t:
                h_try = t_target - t
            else:
                h_try = h
            for s in range(1, 7):
                for i in range(n):
                    acc_i = y[i]
                    for m in range(s):
                        acc_i += h_try * _A[s, m] * k[m, i]
                    ytmp[i] = acc_i
                _rhs(t + _C[s] * h_try, ytmp, g, p, res, k[s], cst)
            # stage 7 is evaluated at the 5th-order solution (FSAL)
            for i in range(n):
                ynew[i] = ytmp[i]
            err = 0.0
            for i in range(n):
                ei = 0.0
                for m in range(7):
                    ei += _E[m] * k[m, i]
                ei *= h_try
                sc = atol[i] + rtol * max(abs(y[i]), abs(ynew[i]))
                err += (ei / sc) ** 2
            err = math.sqrt(err / n)
            if not math.isfinite(err):
                info[0] = acc
                info[1] = rej
                info[2] = t
                info[3] = 2
                return
            if err <= 1.0:
                # contact onset inside the step: cut the step back to the crossing
                frac = 2.0
                for j in range(4):
                    pe, pd = _penetration(res, p, j)
                    if cst[j] < 0.5 and pen0[j] <= 0.0 and pe > EVENT_TOL:
                        f = pen0[j] / (pen0[j] - pe)
                        if f < frac:
                            frac = f
                if frac < 1.5 and h_try > 1e-13:
                    cuts += 1
                    h_new = h_try * frac * (1.0 + 1e-9) + 1e-15
                    h = h_new if h_new < h_try else 0.5 * h_try
                    continue
                t += h_try
                for i in range(n):
                    y[i] = ynew[i]
                    k[0, i] = k[6, i]
                acc += 1
                if res[R_OK] < 0.5:
                    info[0] = acc
                    info[1] = rej
                    info[2] = t
                    info[3] = 3
                    return
                for j in range(4):
                    pe, pd = _penetration(res, p, j)
                    if pe > 0.0:
                        if cst[j] < 0.5:
                            cst[j] = 1.0
                            cst[4 + j] = pd if pd > 1e-6 else 1e-6
                            if t >= stats_from:
                                onsets[j] += 1
                    else:
                        cst[j] = 0.0
                    pen0[j] = pe
                if t >= stats_from:
                    for j in range(N_R):
                        if abs(res[j]) > peaks[j]:
                            peaks[j] = abs(res[j])
                fac = 0.9 * err ** (-0.2) if err > 1e-10 else 5.0
                if fac > 5.0:
                    fac = 5.0
                if h_try == h or fac < 1.0:
                    h = min(h_max, h_try * fac)
            else:
                rej += 1
                fac = 0.9 * err ** (-0.2)
                if fac < 0.2:
                    fac = 0.2
                h = h_try * fac
                if h < 1e-13:
                    info[0] = acc
                    info[1] = rej
                    info[2] = t
                    info[3] = 1
                    return
        for i in range(n):
            out_y[io, i] = y[i]
        for j in range(N_R):
            out_r[io, j] = res[j]
    info[0] = acc
    info[1] = rej
    info[2] = t
    info[3] = 0
    info[4] = cuts

