"""Energy audit of a multibody run: work of every force element against the change of kinetic and stored energy.

With ``simulation.energy_audit`` on, the compiled core integrates the power of every force element with the
state (``force_elements.accumulator_start``): element k's work W_k(t) = int sum_i dQ_i q'_i dt is an auxiliary coordinate,
so it is the Runge-Kutta quadrature of the same stage values that advance the motion (5th order, no trapezoid over
output samples).  Between two output samples, the balance

    W_in = dKE + dV_gravity + sum_k dU_k + sum_k D_k,     D_k = -dW_k - dU_k  (passive elements)

holds exactly for the continuous equations (ideal, time-independent constraints do no work), where W_in is the
work of the sources (torque-speed and constant-torque drivers), U_k the energy an element stores (spring windup
1/2 k psi^2, a bush's 1/2 k dphi^2, a contact's elastic energy int_0^delta F(p, 0) dp, modal strain energy) and
D_k what it dissipates (contact damping and friction, bush damping, belt damping, creep and slip, mesh losses,
guide friction).  The residual of the balance measures the integration and projection error.  An imposed-speed
(``angle``) driver is a constraint that does work: with one, the residual is that driver's work, reported as such.
"""

from __future__ import annotations

import math

import numpy as np

from berryshaker.multibody import layout as L

#: Gauss-Legendre nodes and weights on [0, 1] for a contact's elastic energy int_0^delta F(p, 0) dp
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
_GL_X, _GL_W = 0.5 * (_GL_X + 1.0), 0.5 * _GL_W

_CONTACTS = L.CONTACT_TYPES
_SOURCES = (L.FRC_TORQUE, L.FRC_TORQUE_SPEED)


def kinetic_energy(cm, y: np.ndarray) -> np.ndarray:
    """Kinetic energy (J) of the bodies (about their centres of mass) and of the modal coordinates, per sample.

    Parameters
    ----------
    cm : CompiledMechanism
        The compiled mechanism.
    y : ndarray
        States (n_samples, 2n; m, rad; m/s, rad/s).

    Returns
    -------
    ndarray
        Kinetic energy per sample (J): sum_b (m_b (x'^2 + y'^2) + I_b phi'^2) / 2 + sum_k eta_k'^2 / 2 (mass-normalised modes).
    """
    mass, inertia = cm.model.mass, cm.model.inertia
    n, nb = cm.n, len(mass)
    v = y[:, n:n + 3 * nb].reshape(len(y), nb, 3)
    ke = 0.5 * (mass * (v[:, :, 0] ** 2 + v[:, :, 1] ** 2) + inertia * v[:, :, 2] ** 2).sum(axis=1)
    nm = len(cm.model.modal_w)
    if nm:
        ke = ke + 0.5 * np.sum(y[:, n + 3 * nb:n + 3 * nb + nm] ** 2, axis=1)
    return ke


def _elastic_contact_energy(cm, k: int, pen: float) -> float:
    """int_0^pen F(p, 0) dp of contact element k (its law at zero penetration rate: the elastic part of every
    registered law), 8-point Gauss-Legendre."""
    if pen <= 0.0:
        return 0.0
    fint, fflt, laws = cm.model.fint, cm.model.fflt, cm.model.laws
    law = laws[int(fint[k, L.FI_LAW])]
    p = fflt[k]
    f = [law(float(pen * x), 0.0, 1.0, p[L.FF_K], p[L.FF_N], p[L.FF_E], p[L.FF_C], p[L.FF_D]) for x in _GL_X]
    return float(pen * np.dot(_GL_W, f))


def stored_energy(cm, y: np.ndarray, elements: np.ndarray) -> tuple[dict[str, float], float, float]:
    """Energy stored at one sample: per force element, in the modal body's strain, and gravity's potential.

    Parameters
    ----------
    cm : CompiledMechanism
        The compiled mechanism.
    y : ndarray
        One state (2n,; m, rad; m/s, rad/s).
    elements : ndarray
        Element outputs at that sample (nf, N_EO; ``layout.EO_*``, SI).

    Returns
    -------
    (per_element, modal, gravity) : (dict, float, float)
        U_k (J) by element name: bush 1/2 k (phi_i - phi_j - phi0)^2, geared spring-damper 1/2 k psi^2, contact
        int_0^delta F(p, 0) dp, constant force -F.r_P; sources store nothing.  Modal strain 1/2 sum omega_k^2
        eta_k^2; gravity -sum_b m_b g.r_b.
    """
    md = cm.model
    mass, gravity, ftype, fint, fflt = md.mass, md.gravity, md.ftype, md.fint, md.fflt
    n, nb = cm.n, len(mass)
    q = y[:n]
    ang = lambda b: q[3 * b + 2] if b >= 0 else 0.0
    out = {}
    for k, name in enumerate(cm.frc_names):
        typ, bi, bj = ftype[k], fint[k, L.FI_BODY_I], fint[k, L.FI_BODY_J]
        u = 0.0
        if typ == L.FRC_ROT_SD:
            u = 0.5 * fflt[k, L.FF_RSD_K] * (ang(bi) - ang(bj) - fflt[k, L.FF_RSD_ANGLE0]) ** 2
        elif typ == L.FRC_GEAR_SD:
            u = 0.5 * fflt[k, L.FF_GEAR_K] * y[n + fint[k, L.FI_WINDUP]] ** 2
        elif typ in _CONTACTS:
            u = _elastic_contact_energy(cm, k, float(elements[k, L.EO_PEN]))
        elif typ == L.FRC_FORCE:
            c, s = math.cos(q[3 * bi + 2]), math.sin(q[3 * bi + 2])
            sx, sy = fflt[k, L.FF_POINT_X], fflt[k, L.FF_POINT_Y]
            px, py = q[3 * bi] + c * sx - s * sy, q[3 * bi + 1] + s * sx + c * sy
            u = -(fflt[k, L.FF_FORCE_X] * px + fflt[k, L.FF_FORCE_Y] * py)
        out[name] = float(u)
    w = cm.model.modal_w
    modal = float(0.5 * np.sum((w * q[3 * nb:3 * nb + len(w)]) ** 2)) if len(w) else 0.0
    grav = float(-np.sum(mass * (gravity[0] * q[0:3 * nb:3] + gravity[1] * q[1:3 * nb:3])))
    return out, modal, grav


def energy_audit(result, t_from: float | None = None, t_to: float | None = None) -> dict:
    """Energy balance of a run between two output samples (default: the statistics window).

    Parameters
    ----------
    result : MultibodyResult
        A run with ``simulation.energy_audit`` on.
    t_from, t_to : float, optional
        Window (s), snapped to output samples; default ``result.stats_from`` to the end.

    Returns
    -------
    dict
        ``input_work_J`` (sources), ``kinetic_change_J``, ``potential_change_J`` (gravity + stored), and
        ``dissipated_J`` per element (plus ``guide friction`` and ``modal damping``), ``residual_J`` =
        input - kinetic - potential - dissipated, ``relative_residual`` (of the input work), ``window_s``.  With an
        imposed-speed driver the residual is that driver's work (``imposed_driver_work_J``) and no closure is
        claimed.

    Raises
    ------
    ValueError
        The run had no energy accumulators.
    """
    cm = result.compiled
    if cm.acc_start < 0:
        raise ValueError("this run has no energy accumulators; set simulation.energy_audit = true")
    t = result.t
    t0 = result.stats_from if t_from is None else t_from
    t1 = t[-1] if t_to is None else t_to
    i0 = int(np.argmin(np.abs(t - t0)))
    i1 = int(np.argmin(np.abs(t - t1)))
    n, a0, nf = cm.n, cm.acc_start, len(cm.frc_names)
    ftype = cm.model.ftype
    d_w = result.y[i1, n + a0:n + a0 + nf + 2] - result.y[i0, n + a0:n + a0 + nf + 2]
    u0, m0, g0 = stored_energy(cm, result.y[i0], result.elements[i0])
    u1, m1, g1 = stored_energy(cm, result.y[i1], result.elements[i1])
    ke = kinetic_energy(cm, result.y[[i0, i1]])
    w_in = 0.0
    dissipated = {}
    for k, name in enumerate(cm.frc_names):
        if ftype[k] in _SOURCES:
            w_in += float(d_w[k])
        else:
            dissipated[name] = float(-d_w[k] - (u1[name] - u0[name]))
    cflt = cm.model.cflt
    if np.any((cm.model.ctype == L.CON_PRISMATIC) & (cflt[:, L.CF_MU] > 0)):
        dissipated["guide friction"] = float(-d_w[nf])  # prismatic joints' Coulomb friction (all of them)
    if len(cm.model.modal_w):
        dissipated["modal damping"] = float(-d_w[nf + 1] - (m1 - m0))
    d_pot = (g1 - g0) + sum(u1.values()) - sum(u0.values()) + (m1 - m0)
    d_ke = float(ke[1] - ke[0])
    residual = w_in - d_ke - d_pot - sum(dissipated.values())
    imposed = any(typ == L.CON_DRIVER for typ in cm.model.ctype)
    out = {"window_s": [float(t[i0]), float(t[i1])], "input_work_J": w_in, "kinetic_change_J": d_ke,
           "potential_change_J": float(d_pot), "dissipated_J": dissipated}
    if imposed:
        out["imposed_driver_work_J"] = float(-residual)
        out["note"] = "imposed-speed drivers do work as constraints: their work closes the balance"
    else:
        out["residual_J"] = float(residual)
        out["relative_residual"] = float(abs(residual) / max(abs(w_in), 1e-300))
    return out


def element_work(result, name: str) -> np.ndarray:
    """Work (J) done on the mechanism by force element ``name`` since the start, at every output sample (its
    energy accumulator; a source's is its input work, a passive element's is minus what it stored and dissipated).

    Parameters
    ----------
    result : MultibodyResult
        A run with ``simulation.energy_audit`` on.
    name : str
        The force element.

    Returns
    -------
    numpy.ndarray
        Work done on the mechanism at every output sample (J).


    Raises
    ------
    ValueError
        The run had no energy accumulators, or there is no such element.
    """
    cm = result.compiled
    if cm.acc_start < 0:
        raise ValueError("this run has no energy accumulators; set simulation.energy_audit = true")
    if name not in cm.frc_names:
        raise ValueError(f"no force element {name!r}; elements: {', '.join(cm.frc_names)}")
    return result.y[:, cm.n + cm.acc_start + cm.frc_names.index(name)]
