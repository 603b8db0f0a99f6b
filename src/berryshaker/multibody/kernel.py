"""A compact planar multibody engine with clearance joints (the open counterpart of the study's ADAMS run).

Formulation (docs/multibody.md): absolute coordinates q = (x, y, phi) per body; ideal joints and
prescribed-speed drivers are constraints Phi(q, t) = 0 enforced with Lagrange multipliers,

    M q'' = Q(q, q', t) - Phi_q^T lambda,     Phi_q q'' = gamma,

solved for lambda through the Schur complement (Phi_q M^-1 Phi_q^T) lambda = Phi_q M^-1 Q - gamma (M is
diagonal); clearance joints are force elements with any normal law of ``berryshaker.contact`` plus
Coulomb friction.  Time integration: adaptive Dormand-Prince 5(4); after every accepted step the
positions and velocities are projected back onto the constraint manifold (mass-weighted), and contact
onset is located (the step is cut back until the penetration at its end is below 1 nm) so that the
hysteresis laws get the true impact velocity.  Everything in the loop is numba-compiled (cache on).

long module: the compiled core (constraints, forces, accelerations, projection, integrator with event location) must live in one numba module so the functions inline and cache together.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from berryshaker.contact.friction import coulomb_friction_kernel
from berryshaker.contact.pair_law import LUBRICATED_RESTITUTION_VELOCITY
from berryshaker.kinematics.cam import _follower_svaj_scalar
from berryshaker.multibody.integrators import DOPRI_A, DOPRI_C, DOPRI_D, DOPRI_E

CON_REVOLUTE, CON_PRISMATIC, CON_POINT_LINE, CON_CAM_ROLLER, CON_DRIVER = 1, 2, 3, 4, 5
CON_ROWS = {CON_REVOLUTE: 2, CON_PRISMATIC: 2, CON_POINT_LINE: 1, CON_CAM_ROLLER: 1, CON_DRIVER: 1}
FRC_REV_CL, FRC_SLOT_CL, FRC_GROOVE_CL, FRC_ROT_SD, FRC_TORQUE, FRC_BRANCH = 11, 12, 13, 20, 21, 30
FRC_FORCE = 22  # constant force (FF_UX, FF_UY components, N) at body point FF_SIX, FF_SIY
# powered drives (docs/multibody.md "Powered drives"): a torque-speed source on body i (reaction on body j or
# ground), T = table(w_i - w_j) with linear interpolation and end values held; and a geared torsional
# spring-damper from body i (input) to body j (output) with ratio r = w_i / w_j, efficiencies by the direction of
# power flow, belt creep and a slip cap, whose windup psi is an element state (an auxiliary coordinate)
FRC_TORQUE_SPEED, FRC_GEAR_SD = 23, 24
GEAR_W_EPS = 1e-3  # rad/s: below this output speed the mesh loss torque is scaled down linearly (no chatter)

# float parameters of a constraint row block
CF_SIX, CF_SIY, CF_SJX, CF_SJY, CF_UX, CF_UY, CF_PHI0, CF_SPEED, CF_MU, CF_XIG, CF_XIH = range(11)
N_CF = 12
# float parameters of a force element
(FF_SIX, FF_SIY, FF_SJX, FF_SJY, FF_UX, FF_UY, FF_GAP, FF_K, FF_N, FF_E, FF_C, FF_D, FF_MU, FF_RPIN,
 FF_PHI0, FF_TORQUE) = range(16)
# powered-drive parameters (appended): ratio, efficiencies forward / back-driven, creep compliance (1/(N m)),
# slip torque (N m, 0: none), number of table points; the torque-speed table follows (speeds, then torques)
FF_RATIO, FF_ETA_F, FF_ETA_B, FF_CREEP, FF_SLIP, FF_NTAB = range(16, 22)
MAX_TABLE = 64  # most points of a torque-speed table
FF_TAB = 22
# Integer arguments between compiled functions are passed as np.int64 (not literals such as 3): numba compiles a
# separate specialisation for every literal value (project was compiled twice, _write_sample three times), time the
# first run on a fresh install pays.
#: entries of integrate's ``info``; a longer array gets the step-size histogram (STEP_* below)
N_INFO = 6
#: layout of integrate's optional ``resume`` array (a run in chunks): the step count at which to pause (<= 0:
#: none), started flag, then the loop's state (time, step size, the size to resume with after an onset cut, the
#: PI controller's last error, last step rejected, accepted / rejected / cut steps, largest constraint residual,
#: next output sample), then the state y, the derivative at y (k[0]) and per force element the penetration, force
#: and penetration rate at the last accepted step; :func:`resume_size` entries in all
(RS_LIMIT, RS_STARTED, RS_T, RS_H, RS_H_RESUME, RS_ERR_OLD, RS_LAST_REJ, RS_ACC, RS_REJ, RS_CUTS, RS_MAX_RES,
 RS_IO) = range(12)
N_RESUME = 12
#: columns of integrate's ``first``: first onset time, its impact velocity, the first episode's peak force, done
#: flag (0 not yet, 1 in the first episode, 2 after it), impacts counted over the statistics window
N_FIRST = 5
#: approach speed (m/s) from which a located contact onset counts as an impact (``first[:, 4]``): the greased
#: pairs' impact-velocity floor (contact.pair_law.LUBRICATED_RESTITUTION_VELOCITY).  Slower closings are a pin
#: settling into its bore (down to 1 um/s): their number depends on the tolerance and on how the chatter of a
#: loaded roller is resolved, the faster ones' does not (benchmarks/HISTORY.md sec. 16)
IMPACT_COUNT_SPEED = LUBRICATED_RESTITUTION_VELOCITY
STEP_HIST_LOG10_MIN = -9.0
STEP_BINS_PER_DECADE = 20.0
N_FF = FF_TAB + 2 * MAX_TABLE
# a modal-body contact (FRC_BRANCH) reuses two slots it has no other use for: the contact's own position along
# the row (m, added to the body's start distance: a bush of branches at different places) and the multiple of the
# contact force that acts back on the striking body (1: two-way; 0: the body is driven, the mechanism feels
# nothing; w: the contact stands for w like branches of a sampled population)
FF_ROW, FF_REACT = FF_SJX, FF_SJY
# a contact's law does not decrease as the penetration or its rate grows (1.0; registry flag ``monotone``): the
# slot of FRC_TORQUE, which no contact uses
FF_MONOTONE = FF_TORQUE
# relative margin of the interior-peak skip (integrate: a monotone law's step bound below every maximum it feeds)
PEAK_BOUND_MARGIN = 0.01
# element outputs
EO_FN, EO_PEN, EO_PENDOT, EO_FT = range(4)
N_EO = 4

# Reference counting (benchmarks/HISTORY.md sec. 10).  Every function of this module but ``integrate`` is compiled
# with ``_nrt=False``: none of them allocates, and without the numba runtime a call no longer increments and
# decrements the reference count of every array it receives (an atomic operation each; ``accelerations`` takes
# the 31 arrays of the model, state and work tuples and passes most of them on to ``constraints`` and
# ``forces``): ~1/3 of the cost of a right-hand side.  Arrays stay owned by ``integrate`` (or the Python caller)
# for the whole call, so nothing is freed early.  Such a function must not allocate (np.empty, copies, array
# expressions) or return an array: numba refuses to compile it without the runtime.


@njit(cache=True, _nrt=False)
def _point(q, qd, b, sx, sy):
    """Global position, velocity and rotated offset A s of body point s; ground if b < 0."""
    if b < 0:
        return sx, sy, 0.0, 0.0, sx, sy, 0.0
    c = math.cos(q[3 * b + 2])
    s = math.sin(q[3 * b + 2])
    ax = c * sx - s * sy
    ay = s * sx + c * sy
    w = qd[3 * b + 2]
    return q[3 * b] + ax, q[3 * b + 1] + ay, qd[3 * b] - w * ay, qd[3 * b + 1] + w * ax, ax, ay, w


@njit(cache=True, _nrt=False)
def _body_origin(q, qd, b):
    if b < 0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    return q[3 * b], q[3 * b + 1], qd[3 * b], qd[3 * b + 1], q[3 * b + 2], qd[3 * b + 2]


@njit(cache=True, _nrt=False)
def _pitch_jet(psi, cam):
    """Pitch curve P and its first three derivatives of a cam (cam = [law, h, rise, far, ret, s0, e]) at psi.

    P = R(psi) (rho, e), rho = s0 + s(psi), R the rotation by psi (docs/multibody.md, "Cam groove");
    dR/dpsi v = R (-v_y, v_x), so dP = R (s1 - e, rho), d2P = R (s2 - rho, 2 s1 - e) and
    d3P = R (s3 - 3 s1 + e, 3 s2 - rho), with s1, s2, s3 the follower law's derivatives."""
    s, s1, s2, s3 = _follower_svaj_scalar(psi, int(cam[0]), cam[1], cam[2], cam[3], cam[4])
    rho = cam[5] + s
    e = cam[6]
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
    """Pitch curve P, P', P'' of a cam (cam = [law, h, rise, far, ret, s0, e]) at parameter psi."""
    px, py, p1x, p1y, p2x, p2y, p3x, p3y = _pitch_jet(psi, cam)
    return px, py, p1x, p1y, p2x, p2y


#: Newton steps (rad) below which :func:`pitch_foot` finishes by a Taylor expansion instead of evaluating the
#: curve again: the parameter error after such a step is ~ step^2 |g''/2g'| ~ 1e-14 rad for the study's cams
#: (the old stopping rule, a step below 1e-14 rad, took two more curve evaluations to reach the same psi)
FOOT_TAYLOR_STEP = 1e-7


@njit(cache=True, _nrt=False)
def pitch_foot(lx, ly, cam, guess):
    """Closest point of the pitch curve to (lx, ly) in the cam frame (:func:`pitch_foot_speed` without |P'|).

    Returns psi, foot (2), outward unit normal (2), signed distance, signed curvature."""
    psi, px, py, nx, ny, dist, kappa, speed = pitch_foot_speed(lx, ly, cam, guess)
    return psi, px, py, nx, ny, dist, kappa


@njit(cache=True, _nrt=False)
def pitch_foot_speed(lx, ly, cam, guess):
    """Closest point of the pitch curve to (lx, ly) in the cam frame (Newton on the curve parameter).

    Newton on g(psi) = (P - L) . dP = 0, g' = |dP|^2 + (P - L) . d2P.  Once a step h is below
    :data:`FOOT_TAYLOR_STEP` the curve at the final psi is the third-order Taylor expansion of the last
    evaluation (P, dP, d2P with errors O(h^4), O(h^3), O(h^2) of the curve's scale: round-off for
    h < 1e-7) instead of a new evaluation.

    Returns psi, foot (2), outward unit normal (2), signed distance, signed curvature, |P'| (m/rad)."""
    if math.isnan(guess):
        psi = math.atan2(ly, lx)
        for _ in range(3):
            s, s1, s2, s3 = _follower_svaj_scalar(psi, int(cam[0]), cam[1], cam[2], cam[3], cam[4])
            psi = math.atan2(ly, lx) - math.atan2(cam[6], cam[5] + s)
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
#: (benchmarks/HISTORY.md sec. 17)
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


@njit(cache=True, _nrt=False)
def constraints(t, q, qd, ctype, cint, cflt, crow, cams, psi_mem, phi, jac, nu, gam):
    """Fill Phi (phi), its Jacobian (jac), nu = -Phi_t and gamma for all constraints at (t, q, qd).

    Sparsity (relied on by :func:`accelerations` and :func:`project`): the rows of constraint block k touch
    only the coordinates of its two bodies ``cint[k, 0]`` and ``cint[k, 1]``; only those columns are zeroed
    and written here, every other entry of ``jac`` stays zero from its allocation.
    """
    m = phi.shape[0]
    for k in range(ctype.shape[0]):
        r = crow[k]
        bi, bj = cint[k, 0], cint[k, 1]
        typ = ctype[k]
        block_start(r, _block_end(crow, k, m), bi, bj, jac, nu, gam)
        if typ == CON_REVOLUTE:
            revolute_rows(k, r, bi, bj, q, qd, cflt, phi, jac, nu, gam)
        elif typ == CON_PRISMATIC or typ == CON_POINT_LINE:
            line_rows(k, typ, r, bi, bj, q, qd, cflt, phi, jac, nu, gam)
        elif typ == CON_CAM_ROLLER:
            cam_roller_rows(k, r, bi, bj, q, qd, cint, cflt, cams, psi_mem, phi, jac, nu, gam)
        elif typ == CON_DRIVER:
            driver_rows(k, r, bi, t, q, cflt, phi, jac, nu)


@njit(cache=True, _nrt=False, inline="always")
def block_start(r, r_end, bi, bj, jac, nu, gam):
    """Zero the Jacobian columns of bodies bi and bj in rows r .. r_end - 1, and nu and gamma of row r.

    This and the ``*_rows`` functions below are a constraint block's part of :func:`constraints` (the formulas of
    docs/multibody.md, "Formulation"), inlined where they are called: the generic loop passes each block's
    entries of the structure arrays, the mechanism-specialised kernels (:mod:`berryshaker.multibody.specialised`)
    pass them as literals, so that the compiler folds the branches on the ground and the column arithmetic."""
    for a in range(r, r_end):
        if bi >= 0:
            jac[a, 3 * bi] = 0.0
            jac[a, 3 * bi + 1] = 0.0
            jac[a, 3 * bi + 2] = 0.0
        if bj >= 0:
            jac[a, 3 * bj] = 0.0
            jac[a, 3 * bj + 1] = 0.0
            jac[a, 3 * bj + 2] = 0.0
    nu[r] = 0.0
    gam[r] = 0.0


@njit(cache=True, _nrt=False, inline="always")
def revolute_rows(k, r, bi, bj, q, qd, cflt, phi, jac, nu, gam):
    """A revolute joint (block k, rows r and r + 1): the two points coincide."""
    pix, piy, vix, viy, aix, aiy, wi = _point(q, qd, bi, cflt[k, CF_SIX], cflt[k, CF_SIY])
    pjx, pjy, vjx, vjy, ajx, ajy, wj = _point(q, qd, bj, cflt[k, CF_SJX], cflt[k, CF_SJY])
    phi[r] = pix - pjx
    phi[r + 1] = piy - pjy
    nu[r + 1] = 0.0
    if bi >= 0:
        jac[r, 3 * bi] = 1.0
        jac[r + 1, 3 * bi + 1] = 1.0
        jac[r, 3 * bi + 2] = -aiy
        jac[r + 1, 3 * bi + 2] = aix
    if bj >= 0:
        jac[r, 3 * bj] = -1.0
        jac[r + 1, 3 * bj + 1] = -1.0
        jac[r, 3 * bj + 2] = ajy
        jac[r + 1, 3 * bj + 2] = -ajx
    gam[r] = aix * wi * wi - ajx * wj * wj
    gam[r + 1] = aiy * wi * wi - ajy * wj * wj


@njit(cache=True, _nrt=False, inline="always")
def line_rows(k, typ, r, bi, bj, q, qd, cflt, phi, jac, nu, gam):
    """A prismatic joint (rows r, r + 1: no relative turn, point on the line) or a point-on-line joint (row r)."""
    if typ == CON_PRISMATIC:
        # line on body i (axis in its frame) through s_i; slider j's point s_j on it; no relative turn
        lb, pb = bi, bj
        slx, sly, spx, spy = cflt[k, CF_SIX], cflt[k, CF_SIY], cflt[k, CF_SJX], cflt[k, CF_SJY]
        rr = r + 1
        phi[r] = (q[3 * bj + 2] if bj >= 0 else 0.0) - (q[3 * bi + 2] if bi >= 0 else 0.0) - cflt[k, CF_PHI0]
        if bj >= 0:
            jac[r, 3 * bj + 2] = 1.0
        if bi >= 0:
            jac[r, 3 * bi + 2] = -1.0
        nu[rr] = 0.0
        gam[rr] = 0.0
    else:
        # pin of body i in a slot of body j (axis in body j's frame)
        lb, pb = bj, bi
        slx, sly, spx, spy = cflt[k, CF_SJX], cflt[k, CF_SJY], cflt[k, CF_SIX], cflt[k, CF_SIY]
        rr = r
    plx, ply, vlx, vly, alx, aly, wl = _point(q, qd, lb, slx, sly)
    ppx, ppy, vpx, vpy, apx, apy, wp = _point(q, qd, pb, spx, spy)
    ux, uy = cflt[k, CF_UX], cflt[k, CF_UY]
    if lb >= 0:
        c, s = math.cos(q[3 * lb + 2]), math.sin(q[3 * lb + 2])
        gux, guy = c * ux - s * uy, s * ux + c * uy
    else:
        gux, guy = ux, uy
    nx, ny = -guy, gux
    dx, dy = ppx - plx, ppy - ply
    ddx, ddy = vpx - vlx, vpy - vly
    phi[rr] = nx * dx + ny * dy
    if pb >= 0:
        jac[rr, 3 * pb] += nx
        jac[rr, 3 * pb + 1] += ny
        jac[rr, 3 * pb + 2] += nx * (-apy) + ny * apx
    if lb >= 0:
        jac[rr, 3 * lb] -= nx
        jac[rr, 3 * lb + 1] -= ny
        # d(n.d)/dphi_L = rot90(n).d - n.rot90(A_L s_L)
        jac[rr, 3 * lb + 2] += (-ny * dx + nx * dy) - (nx * (-aly) + ny * alx)
    gam[rr] = ((nx * dx + ny * dy) * wl * wl - 2.0 * wl * (-ny * ddx + nx * ddy)
               + nx * (apx * wp * wp - alx * wl * wl) + ny * (apy * wp * wp - aly * wl * wl))


@njit(cache=True, _nrt=False, inline="always")
def cam_roller_rows(k, r, bi, bj, q, qd, cint, cflt, cams, psi_mem, phi, jac, nu, gam):
    """A roller follower on a cam's pitch curve (row r; its closest point by Newton from ``psi_mem[k]``)."""
    pix, piy, vix, viy, aix, aiy, wi = _point(q, qd, bi, cflt[k, CF_SIX], cflt[k, CF_SIY])
    ojx, ojy, vjx, vjy, phj, wj = _body_origin(q, qd, bj)
    wx, wy = pix - ojx, piy - ojy
    wdx, wdy = vix - vjx, viy - vjy
    c, s = math.cos(phj), math.sin(phj)
    lx, ly = c * wx + s * wy, -s * wx + c * wy
    cam = cams[cint[k, 2]]
    psi, fx, fy, nlx, nly, dist, kap = pitch_foot(lx, ly, cam, psi_mem[k])
    psi_mem[k] = psi
    nx, ny = c * nlx - s * nly, s * nlx + c * nly
    tx, ty = -ny, nx
    phi[r] = dist
    if bi >= 0:
        jac[r, 3 * bi] += nx
        jac[r, 3 * bi + 1] += ny
        jac[r, 3 * bi + 2] += nx * (-aiy) + ny * aix
    if bj >= 0:
        jac[r, 3 * bj] -= nx
        jac[r, 3 * bj + 1] -= ny
        jac[r, 3 * bj + 2] -= nx * (-wy) + ny * wx
    gx, gy = wdx - wj * (-wy), wdy - wj * wx
    tg = tx * gx + ty * gy
    rest = (nx * (-aix * wi * wi - 2.0 * wj * (-wdy) - wj * wj * wx)
            + ny * (-aiy * wi * wi - 2.0 * wj * wdx - wj * wj * wy) + kap * tg * tg)
    gam[r] = -rest


@njit(cache=True, _nrt=False, inline="always")
def driver_rows(k, r, bi, t, q, cflt, phi, jac, nu):
    """An angle driver of body bi (row r): its angle = phi0 + speed t."""
    phi[r] = q[3 * bi + 2] - cflt[k, CF_PHI0] - cflt[k, CF_SPEED] * t
    jac[r, 3 * bi + 2] = 1.0
    nu[r] = cflt[k, CF_SPEED]


@njit(cache=True, _nrt=False)
def _law(laws, law, pen, pen_dot, v_imp, k, n, e, c, d):
    """Normal force of registered law number ``law`` (berryshaker.contact.laws), 0 when open."""
    if pen <= 0.0:
        return 0.0
    return laws[law](pen, pen_dot, v_imp, k, n, e, c, d)


@njit(cache=True, _nrt=False)
def _apply(Q, b, fx, fy, armx, army):
    if b >= 0:
        Q[3 * b] += fx
        Q[3 * b + 1] += fy
        Q[3 * b + 2] += armx * fy - army * fx


@njit(cache=True, _nrt=False)
def table_torque(fflt, k, w):
    """Torque of the torque-speed table of force element k at relative speed w: linear interpolation between
    the points (speeds increasing), end values held outside (as numpy.interp)."""
    nt = int(fflt[k, FF_NTAB])
    if w <= fflt[k, FF_TAB]:
        return fflt[k, FF_TAB + MAX_TABLE]
    if w >= fflt[k, FF_TAB + nt - 1]:
        return fflt[k, FF_TAB + MAX_TABLE + nt - 1]
    lo, hi = 0, nt - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if fflt[k, FF_TAB + mid] <= w:
            lo = mid
        else:
            hi = mid
    x0, x1 = fflt[k, FF_TAB + lo], fflt[k, FF_TAB + hi]
    y0, y1 = fflt[k, FF_TAB + MAX_TABLE + lo], fflt[k, FF_TAB + MAX_TABLE + hi]
    return y0 + (y1 - y0) * (w - x0) / (x1 - x0)


@njit(cache=True, _nrt=False)
def accumulator_start(ftype, n_base, n_all):
    """First energy-accumulator coordinate, or -1 when the run has none.

    Auxiliary coordinates follow the bodies and modal coordinates (``n_base`` = 3 bodies + modes): first one
    windup state per geared spring-damper (element order), then, when the energy audit is on, one accumulator
    per force element plus two (prismatic guide friction, modal-body internal forces).  An accumulator's
    velocity slot is the work done on the mechanism so far (J): its rate (the generalised-force slot, unit mass)
    is the element's power sum_i dQ_i q'_i, so the Runge-Kutta stages integrate it with the state."""
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
    """Generalised applied forces Q: gravity, clearance contacts (normal + friction), spring-dampers,
    motor torques, guide friction of prismatic joints (from the previous step's multipliers), and the
    modal forces of a flexible branch (its own stiffness and damping plus the comb contacts)."""
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
        bi, bj = fint[k, 0], fint[k, 1]
        eout[k, EO_FN] = 0.0
        eout[k, EO_FT] = 0.0
        if typ == FRC_REV_CL or typ == FRC_SLOT_CL or typ == FRC_GROOVE_CL:
            pix, piy, vix, viy, aix, aiy, wi = _point(q, qd, bi, fflt[k, FF_SIX], fflt[k, FF_SIY])
            oix, oiy, _a, _b, _c, _d = _body_origin(q, qd, bi)
            ojx, ojy, vjx, vjy, phj, wj = _body_origin(q, qd, bj)
            rpin = fflt[k, FF_RPIN]
            if typ == FRC_REV_CL:
                pjx, pjy, vpjx, vpjy, ajx, ajy, wj2 = _point(q, qd, bj, fflt[k, FF_SJX], fflt[k, FF_SJY])
                ex, ey = pix - pjx, piy - pjy
                mag = math.sqrt(ex * ex + ey * ey)
                if mag > 0.0:
                    nx, ny = ex / mag, ey / mag
                else:
                    nx, ny = 1.0, 0.0
                pen = mag - fflt[k, FF_GAP]
                # velocities of the contact points of pin (radius rpin) and bore (radius rpin + c)
                rb = rpin + fflt[k, FF_GAP]
                vcix, vciy = vix - wi * rpin * ny, viy + wi * rpin * nx
                vcjx, vcjy = vpjx - wj * rb * ny, vpjy + wj * rb * nx
                relx, rely = vcix - vcjx, vciy - vcjy
                pen_dot = nx * (vix - vpjx) + ny * (viy - vpjy)
                cpx, cpy = pix + rpin * nx, piy + rpin * ny
            else:
                if typ == FRC_SLOT_CL:
                    pjx, pjy, vpjx, vpjy, ajx, ajy, wj2 = _point(q, qd, bj, fflt[k, FF_SJX], fflt[k, FF_SJY])
                    c, s = math.cos(phj) if bj >= 0 else 1.0, math.sin(phj) if bj >= 0 else 0.0
                    ux, uy = fflt[k, FF_UX], fflt[k, FF_UY]
                    gx, gy = c * ux - s * uy, s * ux + c * uy
                    n0x, n0y = -gy, gx
                    d = n0x * (pix - pjx) + n0y * (piy - pjy)
                else:
                    c, s = (math.cos(phj), math.sin(phj)) if bj >= 0 else (1.0, 0.0)
                    wx, wy = pix - ojx, piy - ojy
                    lx, ly = c * wx + s * wy, -s * wx + c * wy
                    # Newton starts from the last foot carried to this time by its rate (FOOT_MEMORY)
                    nfm = ftype.shape[0]
                    guess = psi_mem_f[k]
                    move = psi_mem_f[nfm + k] * (t - psi_mem_f[2 * nfm + k])
                    if abs(move) < FOOT_PREDICTION_MAX:  # (NaN guess: stays NaN, the first-call start)
                        guess += move
                    psi, fx, fy, nlx, nly, d, kap, speed = pitch_foot_speed(lx, ly, cams[fint[k, 2]], guess)
                    # the pin's velocity in the cam frame: R(-phi) (v_pin - v_cam) + phi' (ly, -lx)
                    dlx = c * (vix - vjx) + s * (viy - vjy) + wj * ly
                    dly = -s * (vix - vjx) + c * (viy - vjy) - wj * lx
                    psi_mem_f[k] = psi
                    psi_mem_f[nfm + k] = _foot_rate(nlx, nly, d, kap, speed, dlx, dly)
                    psi_mem_f[2 * nfm + k] = t
                    n0x, n0y = c * nlx - s * nly, s * nlx + c * nly
                side = 1.0 if d >= 0.0 else -1.0
                nx, ny = side * n0x, side * n0y
                pen = abs(d) - 0.5 * fflt[k, FF_GAP]
                # velocity of the body-j material point under the pin
                vmx = vjx - wj * (piy - ojy)
                vmy = vjy + wj * (pix - ojx)
                relx, rely = vix - vmx, viy - vmy
                pen_dot = nx * relx + ny * rely
                cpx, cpy = pix, piy
            eout[k, EO_PEN] = pen
            eout[k, EO_PENDOT] = pen_dot
            if pen > 0.0:
                vi = v_imp[k] if in_contact[k] else pen_dot
                fn = _law(laws, fint[k, 3], pen, pen_dot, vi, fflt[k, FF_K], fflt[k, FF_N], fflt[k, FF_E],
                          fflt[k, FF_C], fflt[k, FF_D])
                tx, ty = -ny, nx
                vt = tx * relx + ty * rely
                ft = 0.0
                if fflt[k, FF_MU] > 0.0:
                    ft = coulomb_friction_kernel(vt, fn, fflt[k, FF_MU], 1e-4, 1e-3)
                fxi, fyi = -fn * nx + ft * tx, -fn * ny + ft * ty
                _apply(Q, bi, fxi, fyi, cpx - oix, cpy - oiy)
                _apply(Q, bj, -fxi, -fyi, cpx - ojx, cpy - ojy)
                eout[k, EO_FN] = fn
                eout[k, EO_FT] = ft
        elif typ == FRC_ROT_SD:
            phii = q[3 * bi + 2] if bi >= 0 else 0.0
            wi = qd[3 * bi + 2] if bi >= 0 else 0.0
            phij = q[3 * bj + 2] if bj >= 0 else 0.0
            wj = qd[3 * bj + 2] if bj >= 0 else 0.0
            tq = -fflt[k, FF_K] * (phii - phij - fflt[k, FF_PHI0]) - fflt[k, FF_C] * (wi - wj)
            if bi >= 0:
                Q[3 * bi + 2] += tq
            if bj >= 0:
                Q[3 * bj + 2] -= tq
            eout[k, EO_FN] = tq
        elif typ == FRC_TORQUE:
            Q[3 * bi + 2] += fflt[k, FF_TORQUE]
            eout[k, EO_FN] = fflt[k, FF_TORQUE]
        elif typ == FRC_FORCE:
            pix, piy, vix, viy, aix, aiy, wi = _point(q, qd, bi, fflt[k, FF_SIX], fflt[k, FF_SIY])
            _apply(Q, bi, fflt[k, FF_UX], fflt[k, FF_UY], aix, aiy)
            eout[k, EO_FN] = math.hypot(fflt[k, FF_UX], fflt[k, FF_UY])
        elif typ == FRC_BRANCH:
            # comb finger point on body bi striking the branch at the station of phi_tab row fint[k, 1]
            pix, piy, vix, viy, aix, aiy, wi = _point(q, qd, bi, fflt[k, FF_SIX], fflt[k, FF_SIY])
            oix, oiy, _a, _b, _c, _d = _body_origin(q, qd, bi)
            ax, ay = fflt[k, FF_UX], fflt[k, FF_UY]
            side = fflt[k, FF_RPIN]
            row = fint[k, 1]
            u = 0.0
            ud = 0.0
            m0, m1 = fint[k, 2], fint[k, 4]  # the row's nonzero columns (its member's block): the same sums
            for m in range(m0, m1):
                u += phi_tab[row, m] * q[n0 + m]
                ud += phi_tab[row, m] * qd[n0 + m]
            xlat = ax * pix + ay * piy
            vlat = ax * vix + ay * viy
            pen = side * (xlat - fflt[k, FF_PHI0]) + fflt[k, FF_GAP] - side * u
            pen_dot = side * vlat - side * ud
            # the plant enters and leaves the comb as the machine drives past: reach ramps in and out
            xrel = plant_p[1] + plant_p[0] * t - fflt[k, FF_ROW]
            half, ramp = plant_p[2], plant_p[3]
            dist = half - abs(xrel)
            if dist <= 0.0:
                reach = 0.0
            elif dist >= ramp:
                reach = 1.0
            else:
                s_ = dist / ramp
                reach = s_ * s_ * (3.0 - 2.0 * s_)
            pen -= (1.0 - reach) * plant_p[4]
            eout[k, EO_PEN] = pen
            eout[k, EO_PENDOT] = pen_dot
            if pen > 0.0:
                fn = _law(laws, fint[k, 3], pen, pen_dot, v_imp[k] if in_contact[k] else pen_dot, fflt[k, FF_K],
                          fflt[k, FF_N], fflt[k, FF_E], fflt[k, FF_C], fflt[k, FF_D])
                for m in range(m0, m1):
                    Q[n0 + m] += side * fn * phi_tab[row, m]
                react = fflt[k, FF_REACT]
                _apply(Q, bi, -react * side * fn * ax, -react * side * fn * ay, pix - oix, piy - oiy)
                eout[k, EO_FN] = fn
        elif typ == FRC_TORQUE_SPEED:
            wrel = (qd[3 * bi + 2] if bi >= 0 else 0.0) - (qd[3 * bj + 2] if bj >= 0 else 0.0)
            tq = table_torque(fflt, k, wrel)
            if bi >= 0:
                Q[3 * bi + 2] += tq
            if bj >= 0:
                Q[3 * bj + 2] -= tq
            eout[k, EO_FN] = tq
        elif typ == FRC_GEAR_SD:
            wi = qd[3 * bi + 2] if bi >= 0 else 0.0
            wj = qd[3 * bj + 2] if bj >= 0 else 0.0
            st = fint[k, 2]  # coordinate of the windup state psi (its velocity slot holds psi)
            psi = qd[st]
            ratio = fflt[k, FF_RATIO]
            t_el = fflt[k, FF_K] * psi
            # windup rate: kinematic mismatch less elastic creep (Reynolds) ...
            rate = wi - ratio * wj - wi * fflt[k, FF_CREEP] * t_el
            # ... and no further stretch while the element slips at its cap (gross slip)
            slip = fflt[k, FF_SLIP]
            if slip > 0.0 and abs(t_el) >= slip and rate * t_el > 0.0:
                rate = 0.0
            ts = t_el + fflt[k, FF_C] * rate  # torque at the input (N m)
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
        if acc0 >= 0:
            Q[acc0 + k] = _power(Q, qd, n_phys) - p_before
    if acc0 >= 0:
        p_before = _power(Q, qd, n_phys)
    # guide friction of prismatic joints, normal forces from the last accepted step's multipliers
    for k in range(ctype.shape[0]):
        if ctype[k] != CON_PRISMATIC or cflt[k, CF_MU] <= 0.0:
            continue
        bi, bj = cint[k, 0], cint[k, 1]
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
    if acc0 >= 0:
        Q[acc0 + ftype.shape[0]] = _power(Q, qd, n_phys) - p_before


@njit(cache=True, _nrt=False)
def _block_end(crow, k, m):
    """One past the last row of constraint block k (blocks are numbered in row order)."""
    return crow[k + 1] if k + 1 < crow.shape[0] else m


@njit(cache=True, _nrt=False)
def _row_dot_at(jac, a, bi, bj, v, off):
    """Phi_q[a] . v[off:off + n] over the columns of bodies bi and bj (the only nonzero ones of row a)."""
    acc = 0.0
    if bi >= 0:
        c = 3 * bi
        acc += jac[a, c] * v[off + c] + jac[a, c + 1] * v[off + c + 1] + jac[a, c + 2] * v[off + c + 2]
    if bj >= 0 and bj != bi:
        c = 3 * bj
        acc += jac[a, c] * v[off + c] + jac[a, c + 1] * v[off + c + 1] + jac[a, c + 2] * v[off + c + 2]
    return acc


@njit(cache=True, _nrt=False)
def _body_term(jac, a, b, body, minv):
    """sum_c Phi_q[a, c] M^-1_c Phi_q[b, c] over the three coordinates c of one body."""
    i = 3 * body
    return (jac[a, i] * minv[i] * jac[b, i] + jac[a, i + 1] * minv[i + 1] * jac[b, i + 1]
            + jac[a, i + 2] * minv[i + 2] * jac[b, i + 2])


@njit(cache=True, _nrt=False)
def _schur(plan, jac, minv, W, m):
    """W = Phi_q M^-1 Phi_q^T (M diagonal) over the rows left after the driven bodies: the structurally nonzero
    entries of its upper triangle (a <= b).

    ``plan`` (:func:`berryshaker.multibody.sparsity.solve_plan`) lists them with the bodies they sum over (driven
    bodies left out: their accelerations are known, :func:`_constrained_solve`); each entry costs one or two 3-term
    sums (modal coordinates of a flexible body never enter a constraint).  A driven body's own rows get a unit
    diagonal (bodies -2), so the factorisation passes their right-hand side through.  The rest of the upper
    triangle stays zero from its allocation; :func:`_spd_solve` reads its input there and writes the factor into
    the lower triangle.
    """
    for e in range(m, m + plan[0, 3]):
        a, b, b1, b2 = plan[e, 0], plan[e, 1], plan[e, 2], plan[e, 3]
        if b1 == -2:
            W[a, b] = 1.0
            continue
        acc = 0.0
        if b1 >= 0:
            acc += _body_term(jac, a, b, b1, minv)
        if b2 >= 0:
            acc += _body_term(jac, a, b, b2, minv)
        W[a, b] = acc


@njit(cache=True, _nrt=False)
def _add_jac_t(cint, crow, jac, x, scale, minv, out, off, m):
    """out[off + c] += scale M^-1_c (Phi_q^T x)_c over the body columns of every row (sparse Phi_q^T x).

    Body by body: the three sums of a body are kept in registers while the rows of the blocks that touch it are
    added in row order (the order of a row-by-row sweep, so the sums are bitwise those of one)."""
    nc = crow.shape[0]
    nb = 0
    for k in range(nc):
        if cint[k, 0] >= nb:
            nb = cint[k, 0] + 1
        if cint[k, 1] >= nb:
            nb = cint[k, 1] + 1
    for b in range(nb):
        c = 3 * b
        o0 = out[off + c]
        o1 = out[off + c + 1]
        o2 = out[off + c + 2]
        m0 = minv[c]
        m1 = minv[c + 1]
        m2 = minv[c + 2]
        for k in range(nc):
            if cint[k, 0] != b and cint[k, 1] != b:
                continue
            for a in range(crow[k], _block_end(crow, k, m)):
                xa = scale * x[a]
                o0 += m0 * jac[a, c] * xa
                o1 += m1 * jac[a, c + 1] * xa
                o2 += m2 * jac[a, c + 2] * xa
        out[off + c] = o0
        out[off + c + 1] = o1
        out[off + c + 2] = o2


@njit(cache=True, _nrt=False)
def _spd_solve(plan, W, b, m):
    """Solve W x = b in place (b <- x) for the symmetric positive definite W of :func:`_schur`, by L D L^T.

    Factorisation row by row (left-looking) over each row's envelope ``plan[i, 0]`` .. i (George & Liu, Computer
    Solution of Large Sparse Positive Definite Systems, 1981, ch. 4; Golub & Van Loan, Matrix Computations, 4th
    ed., 2013, sec. 4.1), reading W from the upper triangle and writing the unit lower factor L below the diagonal
    and the pivots' reciprocals 1/d_i on it (so the assembly never has to clear anything): row i first forms
    c_ij = L_ij d_j = W_ji - sum_k c_ik L_jk, then L_ij = c_ij / d_j and d_i = W_ii - sum_j c_ij L_ij.  One
    division per row and no square root: the chain of dependent long-latency operations is about a third of the
    Cholesky factorisation's it replaced (benchmarks/HISTORY.md sec. 24).  Each row's forward substitution
    (L z = b) runs as soon as the row is factored (split into two passes the harvester's integration was ~4 %
    slower); back substitution L^T x = D^-1 z over each column's extent i .. ``plan[i, 1]``.  A pivot that is not
    positive (a singular constraint set) is replaced by 1e-300.  No scratch array (no allocation).
    """
    for i in range(m):
        lo = plan[i, 0]
        for j in range(lo, i):
            s = W[j, i]
            k0 = lo if lo > plan[j, 0] else plan[j, 0]  # L[j, k] = 0 left of row j's envelope
            for k in range(k0, j):
                s -= W[i, k] * W[j, k]
            W[i, j] = s  # c_ij, scaled to L_ij below
        d = W[i, i]
        for k in range(lo, i):
            c = W[i, k]
            lik = c * W[k, k]
            W[i, k] = lik
            d -= c * lik
        if d <= 0.0:
            d = 1e-300
        W[i, i] = 1.0 / d
        s = b[i]
        for k in range(lo, i):
            s -= W[i, k] * b[k]
        b[i] = s
    for i in range(m - 1, -1, -1):
        s = b[i] * W[i, i]
        for k in range(i + 1, plan[i, 1] + 1):
            if plan[k, 0] <= i:  # inside row k's envelope (outside it L[k, i] = 0, never written)
                s -= W[k, i] * b[k]
        b[i] = s


@njit(cache=True, _nrt=False, inline="always")
def _constrained_solve(plan, mass, inertia, cint, crow, jac, minv, W, rhs, u, off, g, lam, m):
    """x = u - M^-1 Phi_q^T lambda with Phi_q x = g, in place (u[off:off + n] <- x), lambda into ``lam``.

    The accelerations (u = M^-1 Q, g = gamma), the position correction of the projection (u = 0, g = -Phi) and
    its velocity correction (u = q', g = nu) are all this problem: the KKT system
    [M Phi_q^T; Phi_q 0] [x; lambda] = [M u; g] (docs/multibody.md, "Formulation").

    A **driven body** (``plan``'s last rows ``[body, r, d, 0]``: a revolute to the ground in rows r, r + 1 and an
    angle driver in row d) has its three coordinates fixed by its own rows: J_bb x_b = g_b, with
    J_bb = [[s, 0, j_r], [0, s, j_r1], [0, 0, 1]] and s = +-1 (kernel ``constraints``), solved by substitution
    (multiplying by s is dividing by it).  Eliminating these rows from the KKT system leaves exactly the Schur
    system of the other bodies, W_o lambda_o = Phi_o x' - g_o with W_o = Phi_oo M_o^-1 Phi_oo^T (the coupling
    terms J_ob M_b^-1 J_ob^T cancel identically, George & Liu's block elimination), where x' is u with the driven
    bodies' x_b in place; the driven rows' multipliers then follow from the driven body's equations of motion,
    J_bb^T lambda_b = M_b (u_b - x_b) - J_ob^T lambda_o.  For the slider-crank (crank pinned and driven) W's dense
    5 x 5 block becomes the rod's 2 x 2 block (the slider's two rows stay 1 x 1 blocks).  ``rhs`` and ``W`` are
    work arrays.
    """
    ne = plan[0, 3]
    for e in range(m + ne, plan.shape[0]):
        b, r, d = plan[e, 0], plan[e, 1], plan[e, 2]
        c = off + 3 * b
        cj = 3 * b
        x2 = g[d]
        x0 = (g[r] - jac[r, cj + 2] * x2) * jac[r, cj]
        x1 = (g[r + 1] - jac[r + 1, cj + 2] * x2) * jac[r + 1, cj + 1]
        lam[r] = u[c] - x0  # kept for the multipliers below
        lam[r + 1] = u[c + 1] - x1
        lam[d] = u[c + 2] - x2
        u[c] = x0
        u[c + 1] = x1
        u[c + 2] = x2
    for k in range(crow.shape[0]):
        bi, bj = cint[k, 0], cint[k, 1]
        for a in range(crow[k], _block_end(crow, k, m)):
            # (a driven body's own rows too: their unit rows of the factor pass any finite value through
            # untouched, multiplied by exact zeros everywhere else, and it is overwritten below)
            rhs[a] = _row_dot_at(jac, a, bi, bj, u, off) - g[a]
    _schur(plan, jac, minv, W, m)
    _spd_solve(plan, W, rhs, m)
    for e in range(m + ne, plan.shape[0]):
        b, r, d = plan[e, 0], plan[e, 1], plan[e, 2]
        cj = 3 * b
        t0 = mass[b] * lam[r]
        t1 = mass[b] * lam[r + 1]
        t2 = inertia[b] * lam[d]
        for k in range(crow.shape[0]):
            if cint[k, 0] != b and cint[k, 1] != b:
                continue
            for a in range(crow[k], _block_end(crow, k, m)):
                if plan[a, 2] == 0:
                    t0 -= jac[a, cj] * rhs[a]
                    t1 -= jac[a, cj + 1] * rhs[a]
                    t2 -= jac[a, cj + 2] * rhs[a]
        lr = t0 * jac[r, cj]
        lr1 = t1 * jac[r + 1, cj + 1]
        rhs[r] = lr
        rhs[r + 1] = lr1
        rhs[d] = t2 - jac[r, cj + 2] * lr - jac[r + 1, cj + 2] * lr1
        c = off + cj
        lam[r] = u[c]  # x_b, put back after the other bodies' update below
        lam[r + 1] = u[c + 1]
        lam[d] = u[c + 2]
    _add_jac_t(cint, crow, jac, rhs, -1.0, minv, u, off, m)
    for e in range(m + ne, plan.shape[0]):
        b, r, d = plan[e, 0], plan[e, 1], plan[e, 2]
        c = off + 3 * b
        u[c] = lam[r]
        u[c + 1] = lam[r + 1]
        u[c + 2] = lam[d]
    for a in range(m):
        lam[a] = rhs[a]


@njit(cache=True, _nrt=False)
def accelerations(t, y, model, state, work, dy):
    """q'' and lambda at state y = (q, q'); fills dy = (q', q'') and work arrays."""
    (mass, inertia, gravity, ctype, cint, cflt, crow, ftype, fint, fflt, cams, modal_w, modal_z, phi_tab,
     plant_p, laws, plan) = model
    (in_contact, v_imp, psi_c, psi_f, lam_prev) = state
    (phi, jac, nu, gam, Q, eout, lam, minv, W, rhs) = work
    n = y.shape[0] // 2
    q = y[:n]
    qd = y[n:]
    constraints(t, q, qd, ctype, cint, cflt, crow, cams, psi_c, phi, jac, nu, gam)
    forces(t, q, qd, mass, gravity, ftype, fint, fflt, cams, in_contact, v_imp, psi_f,
           ctype, cint, cflt, crow, lam_prev, modal_w, modal_z, phi_tab, plant_p, Q, eout, laws)
    m = phi.shape[0]
    for i in range(n):
        dy[i] = y[n + i]
        dy[n + i] = minv[i] * Q[i]  # unconstrained accelerations M^-1 Q
    if m > 0:
        _constrained_solve(plan, mass, inertia, cint, crow, jac, minv, W, rhs, dy, n, gam, lam, m)


@njit(cache=True, _nrt=False)
def project(t, y, model, state, work, iters):
    """Mass-weighted projection of positions (Newton) and velocities onto Phi = 0, Phi_q q' = nu.

    Each Newton step is the smallest correction dq in the M-norm with Phi_q dq = -Phi (:func:`_constrained_solve`
    with u = 0, accumulated in the work array Q, which the projection does not otherwise use); the velocities
    are replaced by the nearest ones in the M-norm with Phi_q q' = nu.  ``lam`` and ``gam`` are overwritten."""
    (mass, inertia, gravity, ctype, cint, cflt, crow, ftype, fint, fflt, cams, modal_w, modal_z, phi_tab,
     plant_p, laws, plan) = model
    (in_contact, v_imp, psi_c, psi_f, lam_prev) = state
    (phi, jac, nu, gam, Q, eout, lam, minv, W, rhs) = work
    m = phi.shape[0]
    if m == 0:
        return 0.0
    n = y.shape[0] // 2
    q = y[:n]
    qd = y[n:]
    res = 0.0
    for it in range(iters + 1):
        constraints(t, q, qd, ctype, cint, cflt, crow, cams, psi_c, phi, jac, nu, gam)
        res = 0.0
        for a in range(m):
            res = max(res, abs(phi[a]))
        if it == iters or res < 1e-13:
            break
        for a in range(m):
            gam[a] = -phi[a]
        for i in range(n):
            Q[i] = 0.0
        _constrained_solve(plan, mass, inertia, cint, crow, jac, minv, W, rhs, Q, np.int64(0), gam, lam, m)
        for i in range(n):
            q[i] += Q[i]
    # velocities (jac from the final positions)
    _constrained_solve(plan, mass, inertia, cint, crow, jac, minv, W, rhs, qd, np.int64(0), nu, lam, m)
    return res


@njit(cache=True, _nrt=False)
def _interior_peak(model, j, v_imp, h, p0, d0, p1, d1):
    """Largest contact force inside a step from a cubic Hermite interpolation of the penetration
    (p0, d0) -> (p1, d1) over h (O(h^4) in the penetration, O(h^3) in its rate), sampled at 15 interior
    points, and the fraction of the step where it occurs (refined by a parabola through the samples around
    the largest).  :func:`integrate` re-evaluates the force at that fraction from the dense output."""
    fint, fflt = model[8], model[9]
    best = 0.0
    s_best = 0
    f_prev = 0.0
    f_left = 0.0
    f_right = 0.0
    for s in range(1, 16):
        u = s / 16.0
        h00 = 2 * u**3 - 3 * u**2 + 1
        h10 = u**3 - 2 * u**2 + u
        h01 = -2 * u**3 + 3 * u**2
        h11 = u**3 - u**2
        pen = h00 * p0 + h10 * h * d0 + h01 * p1 + h11 * h * d1
        dh00 = (6 * u**2 - 6 * u) / h
        dh10 = 3 * u**2 - 4 * u + 1
        dh01 = (-6 * u**2 + 6 * u) / h
        dh11 = 3 * u**2 - 2 * u
        pd = dh00 * p0 + dh10 * d0 + dh01 * p1 + dh11 * d1
        f = 0.0
        if pen > 0.0:
            f = _law(model[15], fint[j, 3], pen, pd, v_imp, fflt[j, FF_K], fflt[j, FF_N], fflt[j, FF_E], fflt[j, FF_C],
                     fflt[j, FF_D])
        if s == s_best + 1 and s_best > 0:
            f_right = f
        if f > best:
            best = f
            s_best = s
            f_left = f_prev
            f_right = 0.0
        f_prev = f
    u_best = s_best / 16.0
    if 1 < s_best < 15:
        den = f_left - 2.0 * best + f_right
        if den < 0.0:
            shift = 0.5 * (f_left - f_right) / den
            if -1.0 < shift < 1.0:
                u_best += shift / 16.0
    return best, u_best


@njit(cache=True, _nrt=False)
def _step_force_bound(model, j, v_imp, h, p0, d0, p1, d1):
    """Upper bound (N) of a monotone law's force over a step: the law at the largest penetration and the largest
    rate that the cubic Hermite interpolation of :func:`_interior_peak` reaches inside the step.

    p(u) = a u^3 + b u^2 + c u + p0 on u in [0, 1] with c = h d0, b = 3 (p1 - p0) - h (2 d0 + d1),
    a = 2 (p0 - p1) + h (d0 + d1); its largest value is at an end or at a root of p'(u) = 3 a u^2 + 2 b u + c,
    and the largest rate p'(u) / h at an end or, where a < 0, at the vertex u = -b / (3 a).  Valid only where
    the force does not decrease with the penetration or its rate (registry flag ``monotone``)."""
    p_max = p0 if p0 > p1 else p1
    d_max = d0 if d0 > d1 else d1
    # the cubic's coefficients in units of its largest term (no underflow of b^2 for tiny penetrations)
    sc = max(abs(p0), abs(p1), h * abs(d0), h * abs(d1))
    if sc > 0.0:
        q0 = p0 / sc
        c = h * d0 / sc
        b = (3.0 * (p1 - p0) - h * (2.0 * d0 + d1)) / sc
        a = (2.0 * (p0 - p1) + h * (d0 + d1)) / sc
        if a != 0.0:
            disc = b * b - 3.0 * a * c
            if disc >= 0.0:
                r = math.sqrt(disc)
                for u in ((-b + r) / (3.0 * a), (-b - r) / (3.0 * a)):
                    if 0.0 < u < 1.0:
                        pu = sc * (((a * u + b) * u + c) * u + q0)
                        if pu > p_max:
                            p_max = pu
            if a < 0.0:
                u = -b / (3.0 * a)
                if 0.0 < u < 1.0:
                    du = sc * ((3.0 * a * u + 2.0 * b) * u + c) / h
                    if du > d_max:
                        d_max = du
        elif b != 0.0:
            u = -c / (2.0 * b)
            if 0.0 < u < 1.0:
                pu = sc * ((b * u + c) * u + q0)
                if pu > p_max:
                    p_max = pu
    fint, fflt = model[8], model[9]
    return _law(model[15], fint[j, 3], p_max, d_max, v_imp, fflt[j, FF_K], fflt[j, FF_N], fflt[j, FF_E],
                fflt[j, FF_C], fflt[j, FF_D])


_C, _A, _E, _D = DOPRI_C, DOPRI_A, DOPRI_E, DOPRI_D


@njit(cache=True, _nrt=False)
def _write_sample(io, y, eout, lam, out_y, out_e, out_lam):
    """Output sample io: state, element outputs, multipliers (element-wise loops: a slice assignment would
    compile numpy's broadcasting and its error messages into the integrator, seconds of cold start)."""
    for i in range(y.shape[0]):
        out_y[io, i] = y[i]
    for j in range(eout.shape[0]):
        for c in range(eout.shape[1]):
            out_e[io, j, c] = eout[j, c]
    for a in range(lam.shape[0]):
        out_lam[io, a] = lam[a]


@njit(cache=True, _nrt=False)
def _dense_state(th, h, k, y1, y0, bspl, rc5, out):
    """State at t0 + th h inside an accepted DOPRI5 step y0 -> y1 (continuous extension of order 4;
    bspl = h k1 - (y1 - y0), rc5 = h sum_i D_i k_i; Hairer, Norsett & Wanner sec. II.6)."""
    th1 = 1.0 - th
    for i in range(out.shape[0]):
        yd = y1[i] - y0[i]
        out[i] = y0[i] + th * (yd + th1 * (bspl[i] + th * (yd - h * k[6, i] - bspl[i] + th1 * rc5[i])))


@njit(cache=True, _nrt=False)
def _hermite_crossing(p0, d0, p1, d1, h, target, iterations):
    """Bracket (lo, hi), as fractions of a step of length h, of the first upward crossing of ``target`` by the
    cubic Hermite interpolant of a penetration with values p0, p1 and rates d0, d1 at the step's ends (error
    O(h^4), as in :func:`_interior_peak`): bracketed on 16 sub-intervals, refined by at most ``iterations``
    bisections (or until the bracket is shorter than 1e-16 s).  The one home of the onset search of
    :func:`_onset_fraction` and :func:`_crossing_rate`."""
    lo = 0.0
    hi = 1.0
    prev = p0 - target
    for s in range(1, 17):
        u = s / 16.0
        v = (2 * u**3 - 3 * u**2 + 1) * p0 + (u**3 - 2 * u**2 + u) * h * d0 + (-2 * u**3 + 3 * u**2) * p1 \
            + (u**3 - u**2) * h * d1 - target
        if v > 0.0 and prev <= 0.0:
            lo = u - 1.0 / 16.0
            hi = u
            break
        prev = v
    for _ in range(iterations):
        u = 0.5 * (lo + hi)
        v = (2 * u**3 - 3 * u**2 + 1) * p0 + (u**3 - 2 * u**2 + u) * h * d0 + (-2 * u**3 + 3 * u**2) * p1 \
            + (u**3 - u**2) * h * d1 - target
        if v > 0.0:
            hi = u
        else:
            lo = u
        if (hi - lo) * h < 1e-16:
            break
    return lo, hi


@njit(cache=True, _nrt=False)
def _onset_fraction(p0, d0, p1, d1, h):
    """Fraction of a step of length h at which a contact's penetration reaches EVENT_TOL / 2 (the onset).

    The penetration over the step is the cubic Hermite interpolant of its values p0 <= 0, p1 > EVENT_TOL
    and rates d0, d1 at the ends (:func:`_hermite_crossing`); the end of its bracket of the first crossing of
    EVENT_TOL / 2.  A step that ends there takes the onset with a penetration inside (0, EVENT_TOL], so the
    impact velocity is that at first contact.  (A straight line through p0 and p1 lags the crossing of a
    converging contact, so the cut step ends short of it and the next tries again: several wasted steps per
    impact.)
    """
    return _hermite_crossing(p0, d0, p1, d1, h, 0.5 * EVENT_TOL, np.int64(40))[1]


@njit(cache=True, _nrt=False)
def _crossing_rate(p0, d0, p1, d1, h):
    """Penetration rate at the first zero of a contact's penetration inside a step of length h (the impact
    velocity of the normal laws, docs/contact.md: the approach speed at first contact, penetration 0).

    The penetration over the step is the cubic Hermite interpolant of its values p0 <= 0 < p1 and rates d0, d1
    at the ends; its first upward crossing of 0 (:func:`_hermite_crossing`) and the interpolant's derivative
    there, dp/dt = [6(u^2 - u)(p0 - p1) / h + (3u^2 - 4u + 1) d0 + (3u^2 - 2u) d1].  The step that takes an
    onset ends at a penetration of up to EVENT_TOL (1 nm); for a slow approach that is decelerated by the load
    (a graze, v^2 ~ 2 a EVENT_TOL) the rate there is well below the rate at first contact, and the hysteresis
    laws, whose damping is ~ 1 / v_imp, would take a far too small impact velocity.
    """
    lo, hi = _hermite_crossing(p0, d0, p1, d1, h, 0.0, np.int64(50))
    u = 0.5 * (lo + hi)
    return ((6 * u**2 - 6 * u) * p0 + (6 * u**2 - 6 * u) * -p1) / h + (3 * u**2 - 4 * u + 1) * d0 \
        + (3 * u**2 - 2 * u) * d1


EVENT_TOL = 1e-9  # m: contact onset is located to within this penetration
SAFETY = 0.9  # step-size safety factor
BETA = 0.04  # PI step-size control: weight of the previous step's error (Hairer & Wanner's DOPRI5 default)
EXPO1 = 0.2 - 0.75 * BETA


def resume_size(ny: int, nf: int) -> int:
    """Length of integrate's ``resume`` array for ``ny`` states and ``nf`` force elements."""
    return N_RESUME + 2 * ny + 3 * nf


@njit(cache=True)
def integrate(y0, t_out, model, state, work, rtol, atol, h_max, stats_from, out_y, out_e, out_lam, peaks,
              first, info):
    """Adaptive DOPRI5 with contact-onset location and constraint projection.

    peaks[k]: max normal force of element k over accepted steps with t >= stats_from.
    first[k] = [onset time, impact velocity, peak force of the first contact episode, done flag, impacts with
    t >= stats_from]: the last counts the separated -> in-contact transitions of contact k on accepted steps
    whose approach speed is at least :data:`IMPACT_COUNT_SPEED` (located onsets: the count does not depend on the
    output grid).
    info = [accepted, rejected, event cuts, t_fail, status (0 ok, 1 step underflow, 2 non-finite,
    3 projection failed, 4 step budget spent, 5 paused at a chunk's end: ``resume``), max constraint residual]; an
    ``info`` longer than :data:`N_INFO` also receives the
    histogram of accepted step sizes, bin b counting h in 10^(STEP_HIST_LOG10_MIN + b / STEP_BINS_PER_DECADE) .. the
    next bin (the first and last bins take what falls outside).

    One call of :func:`integrate_resumable` without a ``resume`` array.
    """
    integrate_resumable(y0, t_out, model, state, work, rtol, atol, h_max, stats_from, out_y, out_e, out_lam, peaks,
                        first, info, None)


@njit(cache=True)
def integrate_resumable(y0, t_out, model, state, work, rtol, atol, h_max, stats_from, out_y, out_e, out_lam, peaks,
                        first, info, resume):
    """:func:`integrate`, resumable.

    ``resume`` (None, or :func:`resume_size` entries, layout ``RS_*``) runs the integration in chunks, so that a
    long run returns to Python (where Ctrl-C is seen) now and then: with ``resume[RS_LIMIT] > 0`` the call returns
    with status 5 once that many steps (accepted + rejected, from the run's start) are taken, its whole loop state
    saved in ``resume``; the next call with the same arguments (``info[0]`` the budget again) continues from it
    exactly as an uninterrupted run would (the same step sequence, bitwise).  ``y0`` is read at the start only.
    """
    (in_contact, v_imp, psi_c, psi_f, lam_prev) = state
    (phi, jac, nu, gam, Q, eout, lam, minv, W, rhs) = work
    (mass, inertia, gravity, ctype_m, cint_m, cflt, crow_m, ftype, fint, fflt, cams, modal_w, modal_z, phi_tab,
     plant_p, laws, plan) = model
    ny = y0.shape[0]
    n_q = ny // 2
    nf = eout.shape[0]
    k = np.zeros((7, ny))
    ytmp = np.empty(ny)
    y = y0.copy()
    t = t_out[0]
    pen_start = np.empty(nf)
    f_start = np.empty(nf)  # |normal force| of each element at the step's start (the last accepted state)
    pdot_start = np.empty(nf)
    y_old = np.empty(ny)
    y_out = np.empty(ny)
    k_out = np.empty(ny)
    bspl = np.empty(ny)
    rc5 = np.empty(ny)
    e_vec = np.empty(ny)  # error estimate, then the dense output's fifth coefficient, per state
    e_save = np.empty((nf, N_EO))
    # the cam foot-point memories (Newton's starting guesses) as they stand after each accepted step: the
    # evaluations for output samples and interior peaks start from them and leave them as they were, so the
    # trajectory does not depend on the output grid (a guess moves the converged foot point by round-off,
    # which the chaotic contact dynamics would amplify)
    psi_c_keep = np.empty(psi_c.shape[0])
    psi_f_keep = np.empty(psi_f.shape[0])
    resumed = False
    if resume is not None:
        resumed = resume[RS_STARTED] > 0.0
    if not resumed:
        accelerations(t, y, model, state, work, k[0])
        for j in range(lam.shape[0]):
            lam_prev[j] = lam[j]
        for j in range(nf):
            pen_start[j] = eout[j, EO_PEN]
            f_start[j] = abs(eout[j, EO_FN])
            pdot_start[j] = eout[j, EO_PENDOT]
        _write_sample(np.int64(0), y, eout, lam, out_y, out_e, out_lam)
    h = min(h_max, 1e-6)
    budget = info[0]  # on entry: the step budget (accepted + rejected steps; <= 0: none)
    stop = budget  # the step count at which the loop stops: the budget, or a chunk's end before it
    acc = 0
    rej = 0
    cuts = 0
    max_res = 0.0
    h_resume = 0.0  # step size before a contact-onset cut (0: no cut pending)
    err_old = 1e-4  # error of the last accepted step (PI controller)
    last_rejected = False
    n_out = t_out.shape[0]
    t_end = t_out[n_out - 1]
    io = np.int64(1)
    if resume is not None:
        if resume[RS_LIMIT] > 0.0 and (budget <= 0.0 or resume[RS_LIMIT] < budget):
            stop = resume[RS_LIMIT]
        if resumed:
            t = resume[RS_T]
            h = resume[RS_H]
            h_resume = resume[RS_H_RESUME]
            err_old = resume[RS_ERR_OLD]
            last_rejected = resume[RS_LAST_REJ] > 0.5
            acc = int(resume[RS_ACC])
            rej = int(resume[RS_REJ])
            cuts = int(resume[RS_CUTS])
            max_res = resume[RS_MAX_RES]
            io = np.int64(resume[RS_IO])
            for i in range(ny):
                y[i] = resume[N_RESUME + i]
                k[0, i] = resume[N_RESUME + ny + i]
            for j in range(nf):
                pen_start[j] = resume[N_RESUME + 2 * ny + j]
                f_start[j] = resume[N_RESUME + 2 * ny + nf + j]
                pdot_start[j] = resume[N_RESUME + 2 * ny + 2 * nf + j]
    while io < n_out:
        if t >= t_end - 1e-15:  # only reached with t_end within 1e-15 s: the remaining samples are the state
            for i in range(ny):
                y_out[i] = y[i]
            accelerations(t, y_out, model, state, work, k_out)
            _write_sample(io, y_out, eout, lam, out_y, out_e, out_lam)
            io += 1
            continue
        if stop > 0.0 and acc + rej >= stop:
            info[0] = acc
            info[1] = rej
            info[2] = cuts
            info[3] = t
            info[4] = 4
            if resume is not None:
                if stop < budget or budget <= 0.0:  # a chunk's end: save the loop's state (status 5)
                    info[4] = 5
                    resume[RS_STARTED] = 1.0
                    resume[RS_T] = t
                    resume[RS_H] = h
                    resume[RS_H_RESUME] = h_resume
                    resume[RS_ERR_OLD] = err_old
                    resume[RS_LAST_REJ] = 1.0 if last_rejected else 0.0
                    resume[RS_ACC] = acc
                    resume[RS_REJ] = rej
                    resume[RS_CUTS] = cuts
                    resume[RS_MAX_RES] = max_res
                    resume[RS_IO] = io
                    for i in range(ny):
                        resume[N_RESUME + i] = y[i]
                        resume[N_RESUME + ny + i] = k[0, i]
                    for j in range(nf):
                        resume[N_RESUME + 2 * ny + j] = pen_start[j]
                        resume[N_RESUME + 2 * ny + nf + j] = f_start[j]
                        resume[N_RESUME + 2 * ny + 2 * nf + j] = pdot_start[j]
            return
        h_try = h if h < t_end - t else t_end - t
        # the stages' states, state index innermost (contiguous rows of k: the loops vectorise); each element
        # sums its terms in stage order, as a loop over stages per element would
        for s in range(1, 7):
            for i in range(ny):
                ytmp[i] = y[i]
            for mm in range(s):
                a_h = h_try * _A[s, mm]
                for i in range(ny):
                    ytmp[i] += a_h * k[mm, i]
            accelerations(t + _C[s] * h_try, ytmp, model, state, work, k[s])
        for i in range(ny):
            e_vec[i] = 0.0
        for mm in range(7):
            e_m = _E[mm]
            for i in range(ny):
                e_vec[i] += e_m * k[mm, i]
        err = 0.0
        for i in range(ny):
            ei = e_vec[i] * h_try
            sc = atol[i] + rtol * max(abs(y[i]), abs(ytmp[i]))
            err += (ei / sc) ** 2
        err = math.sqrt(err / ny)
        if not math.isfinite(err):
            info[3] = t
            info[4] = 2
            return
        # contact onset inside the step: cut the step back to the crossing (before the error test: a step across
        # an onset is cut whatever its error, and rejecting it first would only shrink it blindly)
        frac = 2.0
        for j in range(nf):
            pe = eout[j, EO_PEN]
            if (not in_contact[j]) and pen_start[j] <= 0.0 and pe > EVENT_TOL and fint_is_contact(model, j):
                f = _onset_fraction(pen_start[j], pdot_start[j], pe, eout[j, EO_PENDOT], h_try)
                if f < frac:
                    frac = f
        if frac < 1.5 and h_try > 1e-13:
            cuts += 1
            if h_resume == 0.0:
                # the size to resume with once the onset is taken (what the error test allows)
                h_resume = h_try if err <= 1.0 else h_try * max(0.2, SAFETY * err ** (-EXPO1))
            h_new = h_try * frac + 1e-15
            if h_new >= h_try:
                h_new = 0.5 * h_try
            h = h_new  # retry a step that ends just past the crossing
            continue
        if err > 1.0:
            rej += 1
            h = h_try * max(0.2, SAFETY * err ** (-EXPO1))
            last_rejected = True
            if h < 1e-14:
                info[3] = t
                info[4] = 1
                return
            continue
        # accept
        t_old = t
        t += h_try
        for i in range(ny):
            y_old[i] = y[i]
            y[i] = ytmp[i]
        dense = io < n_out and t_out[io] < t - 1e-15
        # DOPRI5 continuous extension (Hairer, Norsett & Wanner, sec. II.6, dense output of order 4), before
        # k[0] is overwritten: output samples and interior force peaks inside the step
        for i in range(ny):
            bspl[i] = h_try * k[0, i] - (ytmp[i] - y_old[i])
            e_vec[i] = 0.0
        for mm in range(7):
            d_m = _D[mm]
            for i in range(ny):
                e_vec[i] += d_m * k[mm, i]
        for i in range(ny):
            rc5[i] = h_try * e_vec[i]
        acc += 1
        if info.shape[0] > N_INFO:  # optional histogram of accepted step sizes (benchmarks/HISTORY.md sec. 6)
            hb = int(STEP_BINS_PER_DECADE * (math.log10(h_try) - STEP_HIST_LOG10_MIN))
            info[N_INFO + min(max(hb, 0), info.shape[0] - N_INFO - 1)] += 1.0
        # constraint residuals at the new state are in the work arrays (last stage was at ytmp)
        res_p = 0.0
        res_v = 0.0
        m_rows = phi.shape[0]
        for kc in range(ctype_m.shape[0]):
            bi, bj = cint_m[kc, 0], cint_m[kc, 1]
            for a in range(crow_m[kc], _block_end(crow_m, kc, m_rows)):
                if abs(phi[a]) > res_p:
                    res_p = abs(phi[a])
                vr = _row_dot_at(jac, a, bi, bj, y, n_q) - nu[a]
                if abs(vr) > res_v:
                    res_v = abs(vr)
        if res_p > max_res:
            max_res = res_p
        if res_p > 1e-11 or res_v > 1e-9:
            res = project(t, y, model, state, work, np.int64(3))
            if not math.isfinite(res) or res > 1e-6:
                info[3] = t
                info[4] = 3
                info[5] = res
                return
            accelerations(t, y, model, state, work, k[0])
        else:
            for i in range(ny):
                k[0, i] = k[6, i]
        for j in range(lam.shape[0]):
            lam_prev[j] = lam[j]
        for i in range(psi_c.shape[0]):
            psi_c_keep[i] = psi_c[i]
        for i in range(psi_f.shape[0]):
            psi_f_keep[i] = psi_f[i]
        onset = False
        for j in range(nf):
            pe = eout[j, EO_PEN]
            fn = eout[j, EO_FN]
            if pe > 0.0:
                if not in_contact[j]:
                    onset = True
                    in_contact[j] = True
                    vi = eout[j, EO_PENDOT]
                    if pen_start[j] <= 0.0 and fint_is_contact(model, j):
                        # the approach rate at first contact (penetration 0), not at the step's end (up to
                        # EVENT_TOL deep: for a slow approach decelerated by the load, far below it)
                        vi = _crossing_rate(pen_start[j], pdot_start[j], pe, vi, h_try)
                    v_imp[j] = vi if vi > 1e-6 else 1e-6
                    if t >= stats_from and vi >= IMPACT_COUNT_SPEED and fint_is_contact(model, j):
                        first[j, 4] += 1.0
                    if first[j, 3] == 0.0:
                        first[j, 0] = t
                        first[j, 1] = vi
                        first[j, 3] = 1.0
            else:
                if in_contact[j] and first[j, 3] == 1.0:
                    first[j, 3] = 2.0  # first episode finished
                in_contact[j] = False
            # the interior-peak search only feeds peaks (t >= stats_from) and the first episode's peak: skipped
            # elsewhere (its force evaluation leaves the integration state and the output samples alone: psi restored)
            search = in_contact[j] and pen_start[j] > 0.0 and fint_is_contact(model, j) and (
                t >= stats_from or first[j, 3] == 1.0)
            if search and fflt[j, FF_MONOTONE] > 0.0:
                # nothing inside the step can raise a maximum it feeds when even the bound of a monotone law
                # stays a margin below them (the margin covers the gap between the interpolated penetration and
                # the dense-output state the search evaluates the force at)
                low = np.inf
                if first[j, 3] == 1.0:
                    low = first[j, 2]
                if t >= stats_from and peaks[j] < low:
                    low = peaks[j]
                if (1.0 + PEAK_BOUND_MARGIN) * _step_force_bound(model, j, v_imp[j], h_try, pen_start[j],
                                                                 pdot_start[j], pe, eout[j, EO_PENDOT]) <= low:
                    search = False
            if search:
                fi, u_pk = _interior_peak(model, j, v_imp[j], h_try, pen_start[j], pdot_start[j], pe,
                                          eout[j, EO_PENDOT])
                # worth the force evaluation only above both ends of the step: the start's force is already in
                # every maximum the step feeds (the first episode's peak: the contact was closed at the start;
                # peaks: when the step started inside the statistics window), so a force falling through the
                # step (the interior samples above the end, below the start) cannot raise them
                f_thr = abs(fn)
                if (t < stats_from or t_old >= stats_from) and f_start[j] > f_thr:
                    f_thr = f_start[j]
                if fi > f_thr:
                    # the peak is inside the step: the force there, from the dense-output state (the
                    # interpolated penetration only locates it); the step-end element values are kept
                    _dense_state(u_pk, h_try, k, ytmp, y_old, bspl, rc5, y_out)
                    for jj in range(nf):
                        for c in range(N_EO):
                            e_save[jj, c] = eout[jj, c]
                    forces(t_old + u_pk * h_try, y_out[:n_q], y_out[n_q:], mass, gravity, ftype, fint, fflt, cams,
                           in_contact, v_imp, psi_f, ctype_m, cint_m, cflt, crow_m, lam_prev, modal_w, modal_z,
                           phi_tab, plant_p, Q, eout, laws)
                    f_in = abs(eout[j, EO_FN])
                    for jj in range(nf):
                        for c in range(N_EO):
                            eout[jj, c] = e_save[jj, c]
                    for i in range(psi_f.shape[0]):
                        psi_f[i] = psi_f_keep[i]
                    if f_in > abs(fn):
                        fn = f_in
            if first[j, 3] == 1.0 and abs(fn) > first[j, 2]:
                first[j, 2] = abs(fn)
            if t >= stats_from and abs(fn) > peaks[j]:
                peaks[j] = abs(fn)
            pen_start[j] = pe
            f_start[j] = abs(eout[j, EO_FN])
            pdot_start[j] = eout[j, EO_PENDOT]
        # PI step-size control (Gustafsson; Hairer & Wanner's DOPRI5: err^-(0.2 - 0.75 beta) err_old^beta)
        e_acc = max(err, 1e-10)
        grow = min(5.0, max(0.1, SAFETY * e_acc ** (-EXPO1) * err_old ** BETA))
        err_old = max(err, 1e-4)
        if last_rejected and grow > 1.0:
            grow = 1.0  # no growth right after a rejection
        last_rejected = False
        h = min(h_max, h_try * grow)
        if onset and h_resume > 0.0:
            # the step that took the onset was cut short on purpose, not for accuracy: go on with the size
            # that passed the error test before the cut (the controller shrinks it if contact needs less)
            if h < h_resume:
                h = min(h_max, h_resume)
            h_resume = 0.0
        # output samples inside the step: interpolated state, forces and multipliers evaluated there
        while io < n_out and t_out[io] < t - 1e-15:
            _dense_state((t_out[io] - t_old) / h_try, h_try, k, ytmp, y_old, bspl, rc5, y_out)
            accelerations(t_out[io], y_out, model, state, work, k_out)
            _write_sample(io, y_out, eout, lam, out_y, out_e, out_lam)
            io += 1
        if io < n_out and t_out[io] <= t + 1e-15:
            # a sample at the step's end: the accepted (projected) state itself
            if dense:
                accelerations(t, y, model, state, work, k_out)
            _write_sample(io, y, eout, lam, out_y, out_e, out_lam)
            io += 1
        for i in range(psi_c.shape[0]):
            psi_c[i] = psi_c_keep[i]
        for i in range(psi_f.shape[0]):
            psi_f[i] = psi_f_keep[i]
    info[0] = acc
    info[1] = rej
    info[2] = cuts
    info[4] = 0
    info[5] = max_res


@njit(cache=True, _nrt=False)
def fint_is_contact(model, j):
    """True where force element ``j`` is a contact (clearance joint or modal-body contact)."""
    ftype = model[7]
    t = ftype[j]
    return t == FRC_REV_CL or t == FRC_SLOT_CL or t == FRC_GROOVE_CL or t == FRC_BRANCH
