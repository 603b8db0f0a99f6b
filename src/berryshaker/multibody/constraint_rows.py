"""The constraint rows of the compiled core: Phi, its Jacobian Phi_q, nu = -Phi_t and gamma of every ideal joint and
driver (docs/multibody.md, "Formulation").

A constraint block is a row of ``ctype`` / ``cint`` / ``cflt`` (its record, :data:`berryshaker.multibody.layout.
CONSTRAINT_RECORDS`) and its first row ``crow``; blocks are numbered in row order.  :func:`constraints` loops over
the blocks and calls each block type's ``*_rows`` function; the mechanism-specialised kernels
(:mod:`berryshaker.multibody.specialised`) call the same functions with each block's entries as literals, so each
formula has one home.
"""

from __future__ import annotations

import math

from numba import njit

from berryshaker.multibody.body_points import _body_origin, _point
from berryshaker.multibody.cam_pitch import pitch_foot
from berryshaker.multibody.layout import (
    CF_ANGLE0,
    CF_REL_ANGLE,
    CF_SIX,
    CF_SIY,
    CF_SJX,
    CF_SJY,
    CF_SPEED,
    CF_UX,
    CF_UY,
    CI_BODY_I,
    CI_BODY_J,
    CI_CAM,
    CON_CAM_ROLLER,
    CON_DRIVER,
    CON_POINT_LINE,
    CON_PRISMATIC,
    CON_REVOLUTE,
)


@njit(cache=True, _nrt=False)
def _block_end(crow, k, m):
    """One past the last row of constraint block k (blocks are numbered in row order)."""
    return crow[k + 1] if k + 1 < crow.shape[0] else m


@njit(cache=True, _nrt=False)
def constraints(t, q, qd, ctype, cint, cflt, crow, cams, psi_mem, phi, jac, nu, gam):
    """Fill Phi (phi), its Jacobian (jac), nu = -Phi_t and gamma for all constraints at (t, q, qd).

    Sparsity (relied on by :func:`accelerations` and :func:`project`): the rows of constraint block k touch
    only the coordinates of its two bodies ``cint[k, 0]`` and ``cint[k, 1]``; only those columns are zeroed
    and written here, every other entry of ``jac`` stays zero from its allocation.

    Parameters
    ----------
    t : float
        Time (s).
    q, qd : numpy.ndarray
        Positions (m, rad) and velocities (m/s, rad/s).
    ctype, cint, cflt, crow : numpy.ndarray
        The constraint blocks: types (``layout.CON_*``), integer and float records (``layout.CI_*``,
        ``layout.CF_*``; SI), first rows.
    cams : numpy.ndarray
        A row per cam (``layout.CAM_*``; lengths m, angles rad).
    psi_mem : numpy.ndarray
        Last foot angle of each cam-roller block (rad; NaN: none yet), updated.
    phi, jac, nu, gam : numpy.ndarray
        Written, per row: Phi (m, rad), its Jacobian Phi_q (dimensionless, m), nu = -Phi_t (m/s, rad/s) and gamma
        (m/s^2, rad/s^2).
    """
    m = phi.shape[0]
    for k in range(ctype.shape[0]):
        r = crow[k]
        bi, bj = cint[k, CI_BODY_I], cint[k, CI_BODY_J]
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
    pass them as literals, so that the compiler folds the branches on the ground and the column arithmetic.

    Parameters
    ----------
    r, r_end : int
        The block's first row and the row after it.
    bi, bj : int
        Bodies i and j (-1: ground).
    jac : numpy.ndarray
        Written: the constraint Jacobian Phi_q (dimensionless, m).
    nu : numpy.ndarray
        Written: nu = -Phi_t (m/s, rad/s).
    gam : numpy.ndarray
        Written: gamma, the acceleration right-hand side (m/s^2, rad/s^2).
    """
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
    """A revolute joint (block k, rows r and r + 1): the two points coincide.

    Parameters
    ----------
    k : int
        The block's index.
    r : int
        The block's first row.
    bi, bj : int
        Bodies i and j (-1: ground).
    q, qd : numpy.ndarray
        Positions (m, rad) and velocities (m/s, rad/s).
    cflt : numpy.ndarray
        Float records of the constraint blocks (``layout.CF_*``, SI).
    phi, jac, nu, gam : numpy.ndarray
        Written, per row: Phi (m, rad), its Jacobian Phi_q (dimensionless, m), nu = -Phi_t (m/s, rad/s) and gamma
        (m/s^2, rad/s^2).
    """
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
    """A prismatic joint (rows r, r + 1: no relative turn, point on the line) or a point-on-line joint (row r).

    Parameters
    ----------
    k : int
        The block's index.
    typ : int
        The block's type (``layout.CON_PRISMATIC`` or ``layout.CON_POINT_LINE``).
    r : int
        The block's first row.
    bi, bj : int
        Bodies i and j (-1: ground).
    q, qd : numpy.ndarray
        Positions (m, rad) and velocities (m/s, rad/s).
    cflt : numpy.ndarray
        Float records of the constraint blocks (``layout.CF_*``, SI).
    phi, jac, nu, gam : numpy.ndarray
        Written, per row: Phi (m, rad), its Jacobian Phi_q (dimensionless, m), nu = -Phi_t (m/s, rad/s) and gamma
        (m/s^2, rad/s^2).
    """
    if typ == CON_PRISMATIC:
        # line on body i (axis in its frame) through s_i; slider j's point s_j on it; no relative turn
        lb, pb = bi, bj
        slx, sly, spx, spy = cflt[k, CF_SIX], cflt[k, CF_SIY], cflt[k, CF_SJX], cflt[k, CF_SJY]
        rr = r + 1
        phi[r] = (q[3 * bj + 2] if bj >= 0 else 0.0) - (q[3 * bi + 2] if bi >= 0 else 0.0) - cflt[k, CF_REL_ANGLE]
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
    """A roller follower on a cam's pitch curve (row r; its closest point by Newton from ``psi_mem[k]``).

    Parameters
    ----------
    k : int
        The block's index.
    r : int
        The block's first row.
    bi, bj : int
        Bodies i and j (-1: ground).
    q, qd : numpy.ndarray
        Positions (m, rad) and velocities (m/s, rad/s).
    cint, cflt : numpy.ndarray
        The constraint blocks' records (``layout.CI_*``, ``layout.CF_*``; SI).
    cams : numpy.ndarray
        A row per cam (``layout.CAM_*``; lengths m, angles rad).
    psi_mem : numpy.ndarray
        Last foot angle of each cam-roller block (rad; NaN: none yet), updated.
    phi, jac, nu, gam : numpy.ndarray
        Written, per row: Phi (m, rad), its Jacobian Phi_q (dimensionless, m), nu = -Phi_t (m/s, rad/s) and gamma
        (m/s^2, rad/s^2).
    """
    pix, piy, vix, viy, aix, aiy, wi = _point(q, qd, bi, cflt[k, CF_SIX], cflt[k, CF_SIY])
    ojx, ojy, vjx, vjy, phj, wj = _body_origin(q, qd, bj)
    wx, wy = pix - ojx, piy - ojy
    wdx, wdy = vix - vjx, viy - vjy
    c, s = math.cos(phj), math.sin(phj)
    lx, ly = c * wx + s * wy, -s * wx + c * wy
    cam = cams[cint[k, CI_CAM]]
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
    """An angle driver of body bi (row r): its angle = phi0 + speed t.

    Parameters
    ----------
    k : int
        The block's index.
    r : int
        The block's first row.
    bi : int
        The driven body.
    t : float
        Time (s).
    q : numpy.ndarray
        Positions (m, rad; x, y, phi per body, then the modal and auxiliary coordinates).
    cflt : numpy.ndarray
        Float records of the constraint blocks (``layout.CF_*``, SI).
    phi, jac, nu : numpy.ndarray
        Written, per row: Phi (rad), its Jacobian Phi_q (dimensionless) and nu = -Phi_t (rad/s).
    """
    phi[r] = q[3 * bi + 2] - cflt[k, CF_ANGLE0] - cflt[k, CF_SPEED] * t
    jac[r, 3 * bi + 2] = 1.0
    nu[r] = cflt[k, CF_SPEED]
