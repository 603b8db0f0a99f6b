"""The equations of motion of the compiled core: the accelerations and multipliers at a state (the integrator's
right-hand side), and the projection of a state onto the constraint manifold (docs/multibody.md, "Formulation").

The model, state and work tuples (built by :mod:`berryshaker.multibody.compiled`):

* model (:class:`~berryshaker.multibody.model.MechanismModel`, read by name): mass, inertia, gravity, ctype, cint,
  cflt, crow, ftype, fint, fflt, cams, modal_w, modal_z, phi_tab, plant_p, laws, plan;
* state (carried between evaluations): in_contact, v_imp, psi_c (cam-roller foot memory), psi_f (groove contacts'
  foot memory), lam_prev (the last accepted step's multipliers);
* work: phi, jac, nu, gam, Q, eout, lam, minv, W, rhs.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from berryshaker.multibody.constraint_rows import _block_end, constraints
from berryshaker.multibody.force_elements import forces
from berryshaker.multibody.layout import CI_BODY_I, CI_BODY_J
from berryshaker.multibody.linear_solve import _constrained_solve, _row_dot_at


@njit(cache=True, _nrt=False)
def accelerations(t, y, model, state, work, dy):
    """q'' and lambda at state y = (q, q'); fills dy = (q', q'') and work arrays.

    Parameters
    ----------
    t : float
        Time (s).
    y : numpy.ndarray
        State: positions, then velocities (m, rad; m/s, rad/s).
    model, state, work : tuple
        The compiled mechanism's arrays, the state carried between evaluations and the work arrays
        (:mod:`berryshaker.multibody.dynamics`).
    dy : numpy.ndarray
        Written: the derivative (q', q'') (m/s, rad/s; m/s^2, rad/s^2).
    """
    mass, inertia, gravity, cams = model.mass, model.inertia, model.gravity, model.cams
    laws, plan = model.laws, model.plan
    ctype, cint, cflt, crow = model.ctype, model.cint, model.cflt, model.crow
    ftype, fint, fflt = model.ftype, model.fint, model.fflt
    modal_w, modal_z, phi_tab, plant_p = model.modal_w, model.modal_z, model.phi_tab, model.plant_p
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
    are replaced by the nearest ones in the M-norm with Phi_q q' = nu.  ``lam`` and ``gam`` are overwritten.

    Parameters
    ----------
    t : float
        Time (s).
    y : numpy.ndarray
        State, projected in place (m, rad; m/s, rad/s).
    model, state, work : tuple
        The compiled mechanism's arrays, the state carried between evaluations and the work arrays
        (:mod:`berryshaker.multibody.dynamics`).
    iters : int
        Newton iterations at most.
    """
    mass, inertia, cams, plan = model.mass, model.inertia, model.cams, model.plan
    ctype, cint, cflt, crow = model.ctype, model.cint, model.cflt, model.crow
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


@njit(cache=True, _nrt=False, inline="always")
def constraint_residuals(model, work, y):
    """Largest |Phi| and largest |Phi_q q' - nu| at state y = (q, q'), from the constraint rows in the work arrays
    (which must have been evaluated at y's positions: the integrator's last stage is at the step's end).

    Parameters
    ----------
    model, work : tuple
        The compiled mechanism's arrays and the work arrays (:mod:`berryshaker.multibody.dynamics`).
    y : numpy.ndarray
        State whose positions the work arrays' rows were evaluated at (m, rad; m/s, rad/s).
    """
    ctype, cint, crow = model.ctype, model.cint, model.crow
    phi, jac, nu = work[0], work[1], work[2]
    n_q = y.shape[0] // 2
    res_p = 0.0
    res_v = 0.0
    m_rows = phi.shape[0]
    for kc in range(ctype.shape[0]):
        bi, bj = cint[kc, CI_BODY_I], cint[kc, CI_BODY_J]
        for a in range(crow[kc], _block_end(crow, kc, m_rows)):
            if abs(phi[a]) > res_p:
                res_p = abs(phi[a])
            vr = _row_dot_at(jac, a, bi, bj, y, n_q) - nu[a]
            if abs(vr) > res_v:
                res_v = abs(vr)
    return res_p, res_v
