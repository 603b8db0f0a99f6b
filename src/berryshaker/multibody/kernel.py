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
from berryshaker.kinematics.cam import _follower_svaj_scalar
from berryshaker.multibody.integrators import DOPRI_A, DOPRI_C, DOPRI_E

CON_REVOLUTE, CON_PRISMATIC, CON_POINT_LINE, CON_CAM_ROLLER, CON_DRIVER = 1, 2, 3, 4, 5
CON_ROWS = {CON_REVOLUTE: 2, CON_PRISMATIC: 2, CON_POINT_LINE: 1, CON_CAM_ROLLER: 1, CON_DRIVER: 1}
FRC_REV_CL, FRC_SLOT_CL, FRC_GROOVE_CL, FRC_ROT_SD, FRC_TORQUE, FRC_BRANCH = 11, 12, 13, 20, 21, 30
FRC_FORCE = 22  # constant force (FF_UX, FF_UY components, N) at body point FF_SIX, FF_SIY

# float parameters of a constraint row block
CF_SIX, CF_SIY, CF_SJX, CF_SJY, CF_UX, CF_UY, CF_PHI0, CF_SPEED, CF_MU, CF_XIG, CF_XIH = range(11)
N_CF = 12
# float parameters of a force element
(FF_SIX, FF_SIY, FF_SJX, FF_SJY, FF_UX, FF_UY, FF_GAP, FF_K, FF_N, FF_E, FF_C, FF_D, FF_MU, FF_RPIN,
 FF_PHI0, FF_TORQUE) = range(16)
N_FF = 16
# a modal-body contact (FRC_BRANCH) reuses two slots it has no other use for: the contact's own position along
# the row (m, added to the body's start distance: a bush of branches at different places) and the multiple of the
# contact force that acts back on the striking body (1: two-way; 0: the body is driven, the mechanism feels
# nothing; w: the contact stands for w like branches of a sampled population)
FF_ROW, FF_REACT = FF_SJX, FF_SJY
# element outputs
EO_FN, EO_PEN, EO_PENDOT, EO_FT = range(4)
N_EO = 4


@njit(cache=True)
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


@njit(cache=True)
def _body_origin(q, qd, b):
    if b < 0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    return q[3 * b], q[3 * b + 1], qd[3 * b], qd[3 * b + 1], q[3 * b + 2], qd[3 * b + 2]


@njit(cache=True)
def pitch_point(psi, cam):
    """Pitch curve P, P', P'' of a cam (cam = [law, h, rise, far, ret, s0, e]) at parameter psi."""
    s, s1, s2, s3 = _follower_svaj_scalar(psi, int(cam[0]), cam[1], cam[2], cam[3], cam[4])
    rho = cam[5] + s
    e = cam[6]
    c, sn = math.cos(psi), math.sin(psi)
    px, py = c * rho - sn * e, sn * rho + c * e
    ux, uy = s1 - e, rho
    p1x, p1y = c * ux - sn * uy, sn * ux + c * uy
    vx, vy = s2 - rho, 2.0 * s1 - e
    p2x, p2y = c * vx - sn * vy, sn * vx + c * vy
    return px, py, p1x, p1y, p2x, p2y


@njit(cache=True)
def pitch_foot(lx, ly, cam, guess):
    """Closest point of the pitch curve to (lx, ly) in the cam frame (Newton on the curve parameter).

    Returns psi, foot (2), outward unit normal (2), signed distance, signed curvature."""
    if math.isnan(guess):
        psi = math.atan2(ly, lx)
        for _ in range(3):
            s, s1, s2, s3 = _follower_svaj_scalar(psi, int(cam[0]), cam[1], cam[2], cam[3], cam[4])
            psi = math.atan2(ly, lx) - math.atan2(cam[6], cam[5] + s)
    else:
        psi = guess
    for _ in range(30):
        px, py, p1x, p1y, p2x, p2y = pitch_point(psi, cam)
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
        if abs(step) < 1e-14:
            break
    px, py, p1x, p1y, p2x, p2y = pitch_point(psi, cam)
    norm = math.sqrt(p1x * p1x + p1y * p1y)
    nx, ny = p1y / norm, -p1x / norm
    dist = nx * (lx - px) + ny * (ly - py)
    kappa = (p1x * p2y - p1y * p2x) / norm**3
    return psi, px, py, nx, ny, dist, kappa


@njit(cache=True)
def constraints(t, q, qd, ctype, cint, cflt, crow, cams, psi_mem, phi, jac, nu, gam):
    """Fill Phi (phi), its Jacobian (jac), nu = -Phi_t and gamma for all constraints at (t, q, qd)."""
    jac[:, :] = 0.0
    for k in range(ctype.shape[0]):
        r = crow[k]
        bi, bj = cint[k, 0], cint[k, 1]
        typ = ctype[k]
        nu[r] = 0.0
        gam[r] = 0.0
        if typ == CON_REVOLUTE:
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
        elif typ == CON_PRISMATIC or typ == CON_POINT_LINE:
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
        elif typ == CON_CAM_ROLLER:
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
        elif typ == CON_DRIVER:
            phi[r] = q[3 * bi + 2] - cflt[k, CF_PHI0] - cflt[k, CF_SPEED] * t
            jac[r, 3 * bi + 2] = 1.0
            nu[r] = cflt[k, CF_SPEED]


@njit(cache=True)
def _law(laws, law, pen, pen_dot, v_imp, k, n, e, c, d):
    """Normal force of registered law number ``law`` (berryshaker.contact.laws), 0 when open."""
    if pen <= 0.0:
        return 0.0
    return laws[law](pen, pen_dot, v_imp, k, n, e, c, d)


@njit(cache=True)
def _apply(Q, b, fx, fy, armx, army):
    if b >= 0:
        Q[3 * b] += fx
        Q[3 * b + 1] += fy
        Q[3 * b + 2] += armx * fy - army * fx


@njit(cache=True)
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
    for k in range(ftype.shape[0]):
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
                    psi, fx, fy, nlx, nly, d, kap = pitch_foot(lx, ly, cams[fint[k, 2]], psi_mem_f[k])
                    psi_mem_f[k] = psi
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
            for m in range(nm):
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
                for m in range(nm):
                    Q[n0 + m] += side * fn * phi_tab[row, m]
                react = fflt[k, FF_REACT]
                _apply(Q, bi, -react * side * fn * ax, -react * side * fn * ay, pix - oix, piy - oiy)
                eout[k, EO_FN] = fn
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


@njit(cache=True)
def _spd_solve(W, b, m):
    """Solve W x = b in place (b <- x) for a symmetric positive definite W (Cholesky, W overwritten)."""
    for j in range(m):
        s = W[j, j]
        for k in range(j):
            s -= W[j, k] * W[j, k]
        if s <= 0.0:
            s = 1e-300
        d = math.sqrt(s)
        W[j, j] = d
        for i in range(j + 1, m):
            s = W[i, j]
            for k in range(j):
                s -= W[i, k] * W[j, k]
            W[i, j] = s / d
    for i in range(m):
        s = b[i]
        for k in range(i):
            s -= W[i, k] * b[k]
        b[i] = s / W[i, i]
    for i in range(m - 1, -1, -1):
        s = b[i]
        for k in range(i + 1, m):
            s -= W[k, i] * b[k]
        b[i] = s / W[i, i]


@njit(cache=True)
def accelerations(t, y, model, state, work, dy):
    """q'' and lambda at state y = (q, q'); fills dy = (q', q'') and work arrays."""
    (mass, inertia, gravity, ctype, cint, cflt, crow, ftype, fint, fflt, cams, modal_w, modal_z, phi_tab,
     plant_p, laws) = model
    (in_contact, v_imp, psi_c, psi_f, lam_prev) = state
    (phi, jac, nu, gam, Q, eout, lam, minv, W, rhs) = work
    n = y.shape[0] // 2
    q = y[:n]
    qd = y[n:]
    constraints(t, q, qd, ctype, cint, cflt, crow, cams, psi_c, phi, jac, nu, gam)
    forces(t, q, qd, mass, gravity, ftype, fint, fflt, cams, in_contact, v_imp, psi_f,
           ctype, cint, cflt, crow, lam_prev, modal_w, modal_z, phi_tab, plant_p, Q, eout, laws)
    m = phi.shape[0]
    if m > 0:
        for a in range(m):
            acc = 0.0
            for i in range(n):
                acc += jac[a, i] * minv[i] * Q[i]
            rhs[a] = acc - gam[a]
            for b in range(a, m):
                acc = 0.0
                for i in range(n):
                    acc += jac[a, i] * minv[i] * jac[b, i]
                W[a, b] = acc
                W[b, a] = acc
        _spd_solve(W, rhs, m)
        for a in range(m):
            lam[a] = rhs[a]
    for i in range(n):
        dy[i] = qd[i]
        f = Q[i]
        for a in range(m):
            f -= jac[a, i] * lam[a]
        dy[n + i] = minv[i] * f


@njit(cache=True)
def project(t, y, model, state, work, iters):
    """Mass-weighted projection of positions (Newton) and velocities onto Phi = 0, Phi_q q' = nu."""
    (mass, inertia, gravity, ctype, cint, cflt, crow, ftype, fint, fflt, cams, modal_w, modal_z, phi_tab,
     plant_p, laws) = model
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
            for b in range(a, m):
                acc = 0.0
                for i in range(n):
                    acc += jac[a, i] * minv[i] * jac[b, i]
                W[a, b] = acc
                W[b, a] = acc
            rhs[a] = phi[a]
        _spd_solve(W, rhs, m)
        for i in range(n):
            acc = 0.0
            for a in range(m):
                acc += jac[a, i] * rhs[a]
            q[i] -= minv[i] * acc
    # velocities (jac and W from the final positions)
    for a in range(m):
        for b in range(a, m):
            acc = 0.0
            for i in range(n):
                acc += jac[a, i] * minv[i] * jac[b, i]
            W[a, b] = acc
            W[b, a] = acc
        acc = 0.0
        for i in range(n):
            acc += jac[a, i] * qd[i]
        rhs[a] = acc - nu[a]
    _spd_solve(W, rhs, m)
    for i in range(n):
        acc = 0.0
        for a in range(m):
            acc += jac[a, i] * rhs[a]
        qd[i] -= minv[i] * acc
    return res


@njit(cache=True)
def _interior_peak(model, j, v_imp, h, p0, d0, p1, d1):
    """Largest contact force inside a step from a cubic Hermite interpolation of the penetration
    (p0, d0) -> (p1, d1) over h; O(h^4) accurate, needs no extra right-hand-side evaluation."""
    fint, fflt = model[8], model[9]
    best = 0.0
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
        if pen > 0.0:
            f = _law(model[15], fint[j, 3], pen, pd, v_imp, fflt[j, FF_K], fflt[j, FF_N], fflt[j, FF_E], fflt[j, FF_C],
                     fflt[j, FF_D])
            if f > best:
                best = f
    return best


_C, _A, _E = DOPRI_C, DOPRI_A, DOPRI_E

EVENT_TOL = 1e-9  # m: contact onset is located to within this penetration


@njit(cache=True)
def integrate(y0, t_out, model, state, work, rtol, atol, h_max, stats_from, out_y, out_e, out_lam, peaks,
              first, info):
    """Adaptive DOPRI5 with contact-onset location and constraint projection.

    peaks[k]: max normal force of element k over accepted steps with t >= stats_from.
    first[k] = [onset time, impact velocity, peak force of the first contact episode, done flag].
    info = [accepted, rejected, event cuts, t_fail, status (0 ok, 1 step underflow, 2 non-finite,
    3 projection failed), max constraint residual].
    """
    (in_contact, v_imp, psi_c, psi_f, lam_prev) = state
    (phi, jac, nu, gam, Q, eout, lam, minv, W, rhs) = work
    ny = y0.shape[0]
    nf = eout.shape[0]
    k = np.zeros((7, ny))
    ytmp = np.empty(ny)
    y = y0.copy()
    t = t_out[0]
    pen_start = np.empty(nf)
    pdot_start = np.empty(nf)
    accelerations(t, y, model, state, work, k[0])
    for j in range(lam.shape[0]):
        lam_prev[j] = lam[j]
    for j in range(nf):
        pen_start[j] = eout[j, EO_PEN]
        pdot_start[j] = eout[j, EO_PENDOT]
    out_y[0, :] = y
    out_e[0, :, :] = eout
    out_lam[0, :] = lam
    h = min(h_max, 1e-6)
    budget = info[0]  # on entry: the step budget (accepted + rejected steps; <= 0: none)
    acc = 0
    rej = 0
    cuts = 0
    max_res = 0.0
    for io in range(1, t_out.shape[0]):
        t_target = t_out[io]
        while t < t_target - 1e-15:
            if budget > 0.0 and acc + rej >= budget:
                info[0] = acc
                info[1] = rej
                info[2] = cuts
                info[3] = t
                info[4] = 4
                return
            h_try = h if h < t_target - t else t_target - t
            for s in range(1, 7):
                for i in range(ny):
                    a_i = y[i]
                    for mm in range(s):
                        a_i += h_try * _A[s, mm] * k[mm, i]
                    ytmp[i] = a_i
                accelerations(t + _C[s] * h_try, ytmp, model, state, work, k[s])
            err = 0.0
            for i in range(ny):
                ei = 0.0
                for mm in range(7):
                    ei += _E[mm] * k[mm, i]
                ei *= h_try
                sc = atol[i] + rtol * max(abs(y[i]), abs(ytmp[i]))
                err += (ei / sc) ** 2
            err = math.sqrt(err / ny)
            if not math.isfinite(err):
                info[3] = t
                info[4] = 2
                return
            if err > 1.0:
                rej += 1
                fac = max(0.2, 0.9 * err ** (-0.2))
                h = h_try * fac
                if h < 1e-14:
                    info[3] = t
                    info[4] = 1
                    return
                continue
            # contact onset inside the step: cut the step back to the crossing
            frac = 2.0
            for j in range(nf):
                pe = eout[j, EO_PEN]
                if (not in_contact[j]) and pen_start[j] <= 0.0 and pe > EVENT_TOL and fint_is_contact(model, j):
                    f = pen_start[j] / (pen_start[j] - pe)
                    if f < frac:
                        frac = f
            if frac < 1.5 and h_try > 1e-13:
                cuts += 1
                h_new = h_try * frac * (1.0 + 1e-9) + 1e-15
                if h_new >= h_try:
                    h_new = 0.5 * h_try
                h = h_new  # retry a step that ends at the crossing; the controller regrows h afterwards
                continue
            # accept
            t += h_try
            for i in range(ny):
                y[i] = ytmp[i]
            acc += 1
            # constraint residuals at the new state are in the work arrays (last stage was at ytmp)
            n_q = ny // 2
            res_p = 0.0
            res_v = 0.0
            for a in range(phi.shape[0]):
                if abs(phi[a]) > res_p:
                    res_p = abs(phi[a])
                vr = -nu[a]
                for i in range(n_q):
                    vr += jac[a, i] * y[n_q + i]
                if abs(vr) > res_v:
                    res_v = abs(vr)
            if res_p > max_res:
                max_res = res_p
            if res_p > 1e-11 or res_v > 1e-9:
                res = project(t, y, model, state, work, 3)
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
            for j in range(nf):
                pe = eout[j, EO_PEN]
                fn = eout[j, EO_FN]
                if pe > 0.0:
                    if not in_contact[j]:
                        in_contact[j] = True
                        vi = eout[j, EO_PENDOT]
                        v_imp[j] = vi if vi > 1e-6 else 1e-6
                        if first[j, 3] == 0.0:
                            first[j, 0] = t
                            first[j, 1] = vi
                            first[j, 3] = 1.0
                else:
                    if in_contact[j] and first[j, 3] == 1.0:
                        first[j, 3] = 2.0  # first episode finished
                    in_contact[j] = False
                if in_contact[j] and pen_start[j] > 0.0 and fint_is_contact(model, j):
                    fi = _interior_peak(model, j, v_imp[j], h_try, pen_start[j], pdot_start[j], pe,
                                        eout[j, EO_PENDOT])
                    if fi > abs(fn):
                        fn = fi
                if first[j, 3] == 1.0 and abs(fn) > first[j, 2]:
                    first[j, 2] = abs(fn)
                if t >= stats_from and abs(fn) > peaks[j]:
                    peaks[j] = abs(fn)
                pen_start[j] = pe
                pdot_start[j] = eout[j, EO_PENDOT]
            fac = 5.0 if err < 1e-10 else min(5.0, 0.9 * err ** (-0.2))
            h = min(h_max, max(h_try, h) * fac) if fac > 1.0 else h_try * fac
        out_y[io, :] = y
        out_e[io, :, :] = eout
        out_lam[io, :] = lam
    info[0] = acc
    info[1] = rej
    info[2] = cuts
    info[4] = 0
    info[5] = max_res


@njit(cache=True)
def fint_is_contact(model, j):
    """True where force element ``j`` is a contact (clearance joint or modal-body contact)."""
    ftype = model[7]
    t = ftype[j]
    return t == FRC_REV_CL or t == FRC_SLOT_CL or t == FRC_GROOVE_CL or t == FRC_BRANCH
