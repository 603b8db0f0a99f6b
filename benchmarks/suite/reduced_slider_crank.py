"""Hand-reduced slider-crank with a rod-slider clearance: the per-step cost floor for the multibody engine.

The clearance slider-crank of ``examples/slider_crank_clearance.toml`` has two free coordinates once
the crank angle is prescribed (phi = phi0 + omega t): the rod angle beta and the slider position x
(the slider slides on y = 0 without rotating; the rod-slider clearance joint is a force element).
Lagrange's equations in these minimal coordinates (no constraints, no multipliers, no projection):

    (m2 L^2/4 + J2) beta'' = L F_P . e_perp(beta) - m2 (L/2) a_A . e_perp(beta)
    m3 x''                 = -F_P,x

with e = (cos beta, sin beta), e_perp = (-sin beta, cos beta), A the crank pin (acceleration
a_A = -a omega^2 (cos phi, sin phi)), P = r_A + L e the journal on the rod, the bore centre at (x, 0),
d = P - (x, 0), penetration delta = |d| - c, n = d/|d| and F_P = -F_n n the contact force on the journal
(F_n from the same law as the engine: Hunt-Crossley, Lankarani-Nikravesh or Hertz, the formula of
:func:`berryshaker.contact.force_laws.hysteresis_kernel`, inlined).  L is the rod length (crank pin to journal),
m2, J2 the rod mass and centroidal inertia, m3 the slider mass.

Integrator: the engine's adaptive Dormand-Prince 5(4) with the engine's features (same tableau, same mixed
error norm, same atol = 1e-3 rtol on positions and 1e-1 rtol on velocities, PI step-size control, steps that
do not stop at output times with samples from the continuous extension, one right-hand side per sample, the
same contact-onset location: a step that starts out of contact and ends with more than 1 nm of penetration is
cut back to the crossing of the cubic Hermite interpolant of the penetration, before the error test, and
the step size is resumed afterwards; the approach velocity there is the impact velocity of the hysteresis
law).  So the steps per simulated second are comparable and the cost per step is the floor an engine
evaluating the same physics could approach.

Reference: the engine formulation is docs/multibody.md; the minimal-coordinate reduction is the
textbook Lagrange form (e.g. P. E. Nikravesh, Computer-Aided Analysis of Mechanical Systems, 1988,
ch. 13 on joint-coordinate formulations).  This file is a benchmark aid, not a model of the package.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit

from berryshaker.multibody.contact_events import EVENT_TOL, _onset_fraction
from berryshaker.multibody.integrators import DOPRI_A, DOPRI_C, DOPRI_D, DOPRI_E
from berryshaker.multibody.step_control import BETA, EXPO1, SAFETY

_A = np.asarray(DOPRI_A, float)
_C = np.asarray(DOPRI_C, float)
_E = np.asarray(DOPRI_E, float)
_D = np.asarray(DOPRI_D, float)

# parameter vector layout
P_A, P_L, P_M2, P_J2, P_M3, P_OM, P_PHI0, P_C, P_K, P_N, P_FAC = range(11)
N_P = 11


@njit(cache=True)
def _contact(t, y, p, v_imp, in_contact):
    """Penetration, its rate, normal force and the force components on the journal at state y."""
    a, ln = p[P_A], p[P_L]
    phi = p[P_PHI0] + p[P_OM] * t
    om = p[P_OM]
    beta, x, bd, xd = y[0], y[1], y[2], y[3]
    cb, sb = math.cos(beta), math.sin(beta)
    px = a * math.cos(phi) + ln * cb
    py = a * math.sin(phi) + ln * sb
    vx = -a * om * math.sin(phi) - ln * bd * sb
    vy = a * om * math.cos(phi) + ln * bd * cb
    dx, dy = px - x, py
    dist = math.sqrt(dx * dx + dy * dy)
    pen = dist - p[P_C]
    if dist > 0.0:
        nx, ny = dx / dist, dy / dist
    else:
        nx, ny = 1.0, 0.0
    pen_dot = nx * (vx - xd) + ny * vy
    fn = 0.0
    if pen > 0.0 and in_contact:
        # hysteresis law F = K delta^n (1 + factor delta'/delta'(-)) >= 0, as
        # berryshaker.contact.force_laws.hysteresis_kernel (written out here: the floor model stands alone)
        v0 = abs(v_imp)
        if v0 < 1e-12:
            v0 = 1e-12
        fn = p[P_K] * pen ** p[P_N] * (1.0 + p[P_FAC] * pen_dot / v0)
        if fn < 0.0:
            fn = 0.0
    return pen, pen_dot, fn, -fn * nx, -fn * ny


@njit(cache=True)
def _rhs(t, y, p, v_imp, in_contact, dy):
    a, ln, m2, j2, m3, om = p[P_A], p[P_L], p[P_M2], p[P_J2], p[P_M3], p[P_OM]
    phi = p[P_PHI0] + om * t
    beta = y[0]
    cb, sb = math.cos(beta), math.sin(beta)
    pen, pen_dot, fn, fx, fy = _contact(t, y, p, v_imp, in_contact)
    # crank pin acceleration (constant speed)
    aax = -a * om * om * math.cos(phi)
    aay = -a * om * om * math.sin(phi)
    q_beta = ln * (-fx * sb + fy * cb) - m2 * 0.5 * ln * (-aax * sb + aay * cb)
    dy[0] = y[2]
    dy[1] = y[3]
    dy[2] = q_beta / (m2 * 0.25 * ln * ln + j2)
    dy[3] = -fx / m3
    return fn


@njit(cache=True)
def _dense(th, h, k, y1, y0, bspl, rc5, out):
    """DOPRI5 continuous extension (as berryshaker.multibody.dopri._dense_state)."""
    th1 = 1.0 - th
    for i in range(out.shape[0]):
        yd = y1[i] - y0[i]
        out[i] = y0[i] + th * (yd + th1 * (bspl[i] + th * (yd - h * k[6, i] - bspl[i] + th1 * rc5[i])))


@njit(cache=True)
def integrate_reduced(y0, p, t_out, rtol, h_max, out_f, info):
    """DOPRI5 over the output times; out_f gets the normal force, info = [steps, rejected, onsets,
    first-impact peak, first-impact time, overall peak].

    The integrator features are the engine's (berryshaker.multibody.kernel.integrate): steps do not stop at
    output times (samples from the continuous extension of order 4), a step across a contact onset is cut back
    to the crossing located on the cubic Hermite interpolant of the penetration (contact_events._onset_fraction)
    before the error test and the step size is then resumed, PI step-size control with no growth after a
    rejection."""
    ny = 4
    atol = np.empty(ny)
    atol[0] = 1e-3 * rtol
    atol[1] = 1e-3 * rtol
    atol[2] = 1e-1 * rtol
    atol[3] = 1e-1 * rtol
    k = np.zeros((7, ny))
    ytmp = np.empty(ny)
    y_old = np.empty(ny)
    y_s = np.empty(ny)
    d_s = np.empty(ny)
    bspl = np.empty(ny)
    rc5 = np.empty(ny)
    y = y0.copy()
    t = t_out[0]
    in_contact = False
    v_imp = 0.0
    pen0, pd0, fn, fx, fy = _contact(t, y, p, v_imp, in_contact)
    if pen0 > 0.0:
        in_contact = True
        v_imp = max(pd0, 1e-6)
    out_f[0] = _rhs(t, y, p, v_imp, in_contact, k[0])
    h = min(h_max, 1e-6)
    acc = 0
    rej = 0
    onsets = 0
    first_peak = 0.0
    first_t = -1.0
    first_open = True
    peak = 0.0
    err_old = 1e-4
    last_rejected = False
    h_resume = 0.0
    n_out = t_out.shape[0]
    t_end = t_out[n_out - 1]
    io = 1
    while t < t_end - 1e-15:
        h_try = h if h < t_end - t else t_end - t
        for s in range(1, 7):
            for i in range(ny):
                a_i = y[i]
                for mm in range(s):
                    a_i += h_try * _A[s, mm] * k[mm, i]
                ytmp[i] = a_i
            _rhs(t + _C[s] * h_try, ytmp, p, v_imp, in_contact, k[s])
        err = 0.0
        for i in range(ny):
            ei = 0.0
            for mm in range(7):
                ei += _E[mm] * k[mm, i]
            ei *= h_try
            sc = atol[i] + rtol * max(abs(y[i]), abs(ytmp[i]))
            err += (ei / sc) ** 2
        err = math.sqrt(err / ny)
        # contact onset inside the step: cut back to the crossing (before the error test), as the engine
        pen1, pd1, f1, _, _ = _contact(t + h_try, ytmp, p, v_imp, in_contact)
        if not in_contact and pen0 <= 0.0 and pen1 > EVENT_TOL and h_try > 1e-13:
            if h_resume == 0.0:
                h_resume = h_try if err <= 1.0 else h_try * max(0.2, SAFETY * err ** (-EXPO1))
            h_new = h_try * _onset_fraction(pen0, pd0, pen1, pd1, h_try) + 1e-15
            h = h_new if h_new < h_try else 0.5 * h_try
            continue
        if err > 1.0:
            rej += 1
            h = h_try * max(0.2, SAFETY * err ** (-EXPO1))
            last_rejected = True
            continue
        t_old = t
        t += h_try
        for i in range(ny):
            y_old[i] = y[i]
            y[i] = ytmp[i]
            bspl[i] = h_try * k[0, i] - (ytmp[i] - y_old[i])
            acc5 = 0.0
            for mm in range(7):
                acc5 += _D[mm] * k[mm, i]
            rc5[i] = h_try * acc5
        acc += 1
        onset = False
        if not in_contact and pen1 > 0.0:
            in_contact = True
            v_imp = pd1 if pd1 > 1e-6 else 1e-6
            onsets += 1
            onset = True
        elif in_contact and pen1 <= 0.0:
            in_contact = False
            if first_t >= 0.0:
                first_open = False
        f_end = _rhs(t, y, p, v_imp, in_contact, k[0])  # FSAL re-evaluated with the new contact state
        pen0, pd0 = pen1, pd1
        if f_end > peak:
            peak = f_end
        if in_contact and first_open:
            if first_t < 0.0:
                first_t = t
            if f_end > first_peak:
                first_peak = f_end
        grow = min(5.0, max(0.1, SAFETY * max(err, 1e-10) ** (-EXPO1) * err_old ** BETA))
        err_old = max(err, 1e-4)
        if last_rejected and grow > 1.0:
            grow = 1.0
        last_rejected = False
        h = min(h_max, h_try * grow)
        if onset and h_resume > 0.0:
            if h < h_resume:
                h = min(h_max, h_resume)
            h_resume = 0.0
        # output samples inside the step from the continuous extension (one right-hand side each, as the engine)
        while io < n_out and t_out[io] <= t + 1e-15:
            if t_out[io] < t - 1e-15:
                _dense((t_out[io] - t_old) / h_try, h_try, k, ytmp, y_old, bspl, rc5, y_s)
                out_f[io] = _rhs(t_out[io], y_s, p, v_imp, in_contact, d_s)
            else:
                out_f[io] = f_end
            io += 1
    while io < n_out:
        out_f[io] = _rhs(t, y, p, v_imp, in_contact, d_s)
        io += 1
    info[0] = acc
    info[1] = rej
    info[2] = onsets
    info[3] = first_peak
    info[4] = first_t
    info[5] = peak


def reduced_parameters(spec) -> tuple[np.ndarray, np.ndarray]:
    """Parameter vector and initial state (beta, x, beta', x') of the reduced model from the spec.

    Parameters
    ----------
    spec : MechanismSpec
        The clearance slider-crank (bodies crank, rod, slider; joints crank_rod, rod_slider; one angle
        driver on the crank).

    Returns
    -------
    tuple of ndarray
        (p, y0): p in the layout P_A..P_FAC (SI), y0 from the engine's assembled initial state.
    """
    from berryshaker.contact.pin_in_bore import pin_in_bore_stiffness
    from berryshaker.multibody.engine import initial_state

    joints = {j.name: j for j in spec.joints}
    bodies = {b.name: b for b in spec.bodies}
    crank_rod, cl = joints["crank_rod"], joints["rod_slider"]
    a = math.hypot(*crank_rod.point_i) + math.hypot(*joints["crank_ground"].point_j)
    ln = math.hypot(cl.point_i[0] - crank_rod.point_j[0], cl.point_i[1] - crank_rod.point_j[1])
    c = cl.contact
    k = c.stiffness
    if k == "hertz":
        k = pin_in_bore_stiffness(c.elastic_modulus, c.poisson_ratio, c.elastic_modulus, c.poisson_ratio,
                                  cl.pin_radius, cl.pin_radius + cl.clearance)
    fac = {"hertz": 0.0, "hunt_crossley": 1.5 * (1.0 - c.restitution),
           "lankarani_nikravesh": 0.75 * (1.0 - c.restitution**2)}[c.law]
    y = initial_state(spec)
    nb = len(spec.bodies)
    names = [b.name for b in spec.bodies]
    ir, js = names.index("rod"), names.index("slider")
    drv = spec.drivers[0]
    p = np.zeros(N_P)
    p[P_A], p[P_L], p[P_M2], p[P_J2], p[P_M3] = a, ln, bodies["rod"].mass, bodies["rod"].inertia, bodies["slider"].mass
    p[P_OM], p[P_PHI0] = drv.speed, y[3 * names.index("crank") + 2]
    p[P_C], p[P_K], p[P_N], p[P_FAC] = cl.clearance, k, c.exponent, fac
    y0 = np.array([y[3 * ir + 2], y[3 * js], y[3 * nb + 3 * ir + 2], y[3 * nb + 3 * js]])
    return p, y0


def simulate_reduced_slider_crank(spec, duration: float, rtol: float, output_step: float = 1e-5,
                                  max_step: float = 5e-5) -> dict:
    """Run the reduced model; returns t, normal force F_n (N), steps, rejected, onsets, first-impact
    peak (N) and time (s), overall peak (N) and the wall time of the integration (s, time.perf_counter).

    The first call compiles (numba, cached on disk); time later calls.
    """
    p, y0 = reduced_parameters(spec)
    t_out = np.linspace(0.0, duration, max(2, int(round(duration / output_step)) + 1))
    out_f = np.zeros(t_out.size)
    info = np.zeros(6)
    t0 = time.perf_counter()
    integrate_reduced(y0, p, t_out, rtol, max_step, out_f, info)
    wall = time.perf_counter() - t0
    return {"t": t_out, "force": out_f, "steps": int(info[0]), "rejected": int(info[1]), "onsets": int(info[2]),
            "first_peak_N": float(info[3]), "first_time_s": float(info[4]), "peak_N": float(info[5]),
            "wall_time_s": wall}
