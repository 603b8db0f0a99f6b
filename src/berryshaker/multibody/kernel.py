"""The compiled integrator of the planar multibody engine with clearance joints (the open counterpart of the
study's ADAMS run): :func:`integrate`, the loop that steps a mechanism's equations of motion through time.

Formulation (docs/multibody.md): absolute coordinates q = (x, y, phi) per body; ideal joints and prescribed-speed
drivers are constraints Phi(q, t) = 0 enforced with Lagrange multipliers,

    M q'' = Q(q, q', t) - Phi_q^T lambda,     Phi_q q'' = gamma,

solved for lambda through the Schur complement (Phi_q M^-1 Phi_q^T) lambda = Phi_q M^-1 Q - gamma (M is
diagonal); clearance joints are force elements with any normal law of ``berryshaker.contact`` plus Coulomb
friction.  Time integration: adaptive Dormand-Prince 5(4); after every accepted step the positions and velocities
are projected back onto the constraint manifold (mass-weighted), and contact onset is located (the step is cut
back until the penetration at its end is below 1 nm) so that the hysteresis laws get the true impact velocity.
Everything in the loop is numba-compiled (cache on).

The compiled core, by idea: the array layout (:mod:`~berryshaker.multibody.layout`), body points
(:mod:`~berryshaker.multibody.body_points`), the cam pitch curve (:mod:`~berryshaker.multibody.cam_pitch`), the
constraint rows (:mod:`~berryshaker.multibody.constraint_rows`), the force elements
(:mod:`~berryshaker.multibody.force_elements`), the linear solves (:mod:`~berryshaker.multibody.linear_solve`), the
equations of motion and the projection (:mod:`~berryshaker.multibody.dynamics`), the integrator's step
(:mod:`~berryshaker.multibody.dopri`), its step-size control (:mod:`~berryshaker.multibody.step_control`), contact
events (:mod:`~berryshaker.multibody.contact_events`), output samples (:mod:`~berryshaker.multibody.sampling`) and
this loop, which ties them together.  The loop is the one compiled function besides ``dynamics.accelerations``
that evaluates the right-hand side (the step's stages, the output samples): numba compiles a callee's code again
into every compiled caller, so each function of its own that called it would compile the forces, constraint rows
and solve once more (:mod:`~berryshaker.multibody.dopri`).  The mechanism-specialised kernels
(:mod:`berryshaker.multibody.specialised`) compile this module's source, and that of ``accelerations``, with their
own constraint rows and multiplier solve.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from berryshaker.multibody.contact_events import first_onset_fraction, interior_peak_forces, record_contacts
from berryshaker.multibody.dopri import _dense_state, dense_coefficients, error_norm, stage_state
from berryshaker.multibody.dynamics import accelerations, constraint_residuals, project
from berryshaker.multibody.layout import (
    EO_FN,
    EO_PEN,
    EO_PENDOT,
    INFO_ACCEPTED,
    INFO_CUTS,
    INFO_MAX_RESIDUAL,
    INFO_REJECTED,
    INFO_STATUS,
    INFO_T_FAIL,
    N_EO,
    N_INFO,
    RS_LIMIT,
    RS_STARTED,
    STATUS_BUDGET,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_PAUSED,
    STATUS_PROJECTION,
    STATUS_UNDERFLOW,
)
from berryshaker.multibody.sampling import _write_sample, sample_at_end, sample_inside
from berryshaker.multibody.step_control import (
    load_resume,
    next_step_size,
    onset_cut_size,
    record_step_size,
    rejected_step_size,
    save_resume,
)


@njit(cache=True)
def integrate(y0, t_out, model, state, work, rtol, atol, h_max, stats_from, out_y, out_e, out_lam, peaks,
              first, info):
    """Adaptive DOPRI5 with contact-onset location and constraint projection.

    peaks[k]: max normal force of element k over accepted steps with t >= stats_from.
    first[k] = [onset time, impact velocity, peak force of the first contact episode, done flag, impacts with
    t >= stats_from] (``layout.FIRST_*``): the last counts the separated -> in-contact transitions of contact k on
    accepted steps whose approach speed is at least
    :data:`~berryshaker.multibody.contact_events.IMPACT_COUNT_SPEED` (located onsets: the count does not depend
    on the output grid).
    info = [accepted, rejected, event cuts, t_fail, status (0 ok, 1 step underflow, 2 non-finite,
    3 projection failed, 4 step budget spent, 5 paused at a chunk's end: ``resume``), max constraint residual]
    (``layout.INFO_*``, ``layout.STATUS_*``); an ``info`` longer than ``layout.N_INFO`` also receives the histogram
    of accepted step sizes (:func:`~berryshaker.multibody.step_control.record_step_size`).

    One call of :func:`integrate_resumable` without a ``resume`` array.

    Parameters
    ----------
    y0 : numpy.ndarray
        Initial state (m, rad; m/s, rad/s).
    t_out : numpy.ndarray
        Output times (s).
    model, state, work : tuple
        The compiled mechanism's arrays, the state carried between evaluations and the work arrays
        (:mod:`berryshaker.multibody.dynamics`).
    rtol : float
        Relative tolerance (dimensionless).
    atol : numpy.ndarray
        Absolute tolerance per state (m, rad; m/s, rad/s).
    h_max : float
        Largest step (s).
    stats_from : float
        Start of the statistics window (s).
    out_y, out_e, out_lam : numpy.ndarray
        The written series: states (m, rad; m/s, rad/s), element outputs (``layout.EO_*``, SI), multipliers (N, N
        m).
    peaks : numpy.ndarray
        Largest |normal force| of each element over the statistics window (N), updated.
    first : numpy.ndarray
        First contact of each element (``layout.FIRST_*``: time s, impact velocity m/s, peak force N, flag, impact
        count), updated.
    info : numpy.ndarray
        On entry ``info[0]`` the step budget (accepted plus rejected steps; <= 0: none); written: the integrator's
        statistics (``layout.INFO_*``: counts, time s, status, residual m or rad); a longer array also gets the
        histogram of step sizes (counts).
    """
    integrate_resumable(y0, t_out, model, state, work, rtol, atol, h_max, stats_from, out_y, out_e, out_lam, peaks,
                        first, info, None)


@njit(cache=True)
def integrate_resumable(y0, t_out, model, state, work, rtol, atol, h_max, stats_from, out_y, out_e, out_lam, peaks,
                        first, info, resume):
    """:func:`integrate`, resumable.

    ``resume`` (None, or :func:`~berryshaker.multibody.layout.resume_size` entries, layout ``RS_*``) runs the
    integration in chunks, so that a long run returns to Python (where Ctrl-C is seen) now and then: with
    ``resume[RS_LIMIT] > 0`` the call returns with status 5 once that many steps (accepted + rejected, from the
    run's start) are taken, its whole loop state saved in ``resume``; the next call with the same arguments
    (``info[0]`` the budget again) continues from it exactly as an uninterrupted run would (the same step
    sequence, bitwise).  ``y0`` is read at the start only.

    Each try of a step (its stages :func:`~berryshaker.multibody.dopri.stage_state`, its error
    :func:`~berryshaker.multibody.dopri.error_norm`) is cut back to a contact onset inside it
    (:func:`~berryshaker.multibody.contact_events.first_onset_fraction`), rejected on its error or accepted; an
    accepted step is projected onto the constraints when it drifted, its contacts recorded
    (:func:`~berryshaker.multibody.contact_events.record_contacts`, the forces at peaks inside the step
    :func:`~berryshaker.multibody.contact_events.interior_peak_forces`), the next size chosen
    (:mod:`~berryshaker.multibody.step_control`) and the output samples in it written
    (:mod:`~berryshaker.multibody.sampling`, :func:`~berryshaker.multibody.dopri._dense_state`).

    Parameters
    ----------
    y0 : numpy.ndarray
        Initial state (m, rad; m/s, rad/s).
    t_out : numpy.ndarray
        Output times (s).
    model, state, work : tuple
        The compiled mechanism's arrays, the state carried between evaluations and the work arrays
        (:mod:`berryshaker.multibody.dynamics`).
    rtol : float
        Relative tolerance (dimensionless).
    atol : numpy.ndarray
        Absolute tolerance per state (m, rad; m/s, rad/s).
    h_max : float
        Largest step (s).
    stats_from : float
        Start of the statistics window (s).
    out_y, out_e, out_lam : numpy.ndarray
        The written series: states (m, rad; m/s, rad/s), element outputs (``layout.EO_*``, SI), multipliers (N, N
        m).
    peaks : numpy.ndarray
        Largest |normal force| of each element over the statistics window (N), updated.
    first : numpy.ndarray
        First contact of each element (``layout.FIRST_*``: time s, impact velocity m/s, peak force N, flag, impact
        count), updated.
    info : numpy.ndarray
        On entry ``info[0]`` the step budget (accepted plus rejected steps; <= 0: none); written: the integrator's
        statistics (``layout.INFO_*``: counts, time s, status, residual m or rad); a longer array also gets the
        histogram of step sizes (counts).
    resume : numpy.ndarray or None
        The loop state of a run in chunks (``layout.RS_*``: times s, step sizes s, counts, the state in SI).
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
    f_start = np.empty(nf)  # |normal force| of each element at the step's start (the last accepted state)
    pdot_start = np.empty(nf)
    y_old = np.empty(ny)
    y_out = np.empty(ny)
    k_out = np.empty(ny)
    bspl = np.empty(ny)
    rc5 = np.empty(ny)
    e_vec = np.empty(ny)  # error estimate, then the dense output's fifth coefficient, per state
    e_save = np.empty((nf, N_EO))
    u_peak = np.empty(nf)  # where in the step each element's force peaks (fraction; -1: nowhere to evaluate)
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
    budget = info[INFO_ACCEPTED]  # on entry: the step budget (accepted + rejected steps; <= 0: none)
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
            (t, h, h_resume, err_old, last_rejected, acc, rej, cuts, max_res,
             io) = load_resume(resume, y, k[0], pen_start, f_start, pdot_start)
    while io < n_out:
        if t >= t_end - 1e-15:  # only reached with t_end within 1e-15 s: the remaining samples are the state
            for i in range(ny):
                y_out[i] = y[i]
            accelerations(t, y_out, model, state, work, k_out)
            _write_sample(io, y_out, eout, lam, out_y, out_e, out_lam)
            io += 1
            continue
        if stop > 0.0 and acc + rej >= stop:
            info[INFO_ACCEPTED] = acc
            info[INFO_REJECTED] = rej
            info[INFO_CUTS] = cuts
            info[INFO_T_FAIL] = t
            info[INFO_STATUS] = STATUS_BUDGET
            if resume is not None:
                if stop < budget or budget <= 0.0:  # a chunk's end: save the loop's state (status 5)
                    info[INFO_STATUS] = STATUS_PAUSED
                    save_resume(resume, t, h, h_resume, err_old, last_rejected, acc, rej, cuts, max_res, io, y, k[0],
                                pen_start, f_start, pdot_start)
            return
        h_try = h if h < t_end - t else t_end - t
        # the step's stages k[1] .. k[6]: the last one's state is the 5th-order solution ytmp, its derivative
        # k[6] (first same as last), and it leaves the work arrays at (t + h_try, ytmp)
        for s in range(1, 7):
            t_s = stage_state(s, t, h_try, y, k, ytmp)
            accelerations(t_s, ytmp, model, state, work, k[s])
        err = error_norm(h_try, y, ytmp, k, e_vec, rtol, atol)
        if not math.isfinite(err):
            info[INFO_T_FAIL] = t
            info[INFO_STATUS] = STATUS_NONFINITE
            return
        # contact onset inside the step: cut the step back to the crossing (before the error test: a step across
        # an onset is cut whatever its error, and rejecting it first would only shrink it blindly)
        frac = first_onset_fraction(model, state, work, pen_start, pdot_start, h_try)
        if frac < 1.5 and h_try > 1e-13:
            cuts += 1
            if h_resume == 0.0:
                # the size to resume with once the onset is taken (what the error test allows)
                h_resume = h_try if err <= 1.0 else rejected_step_size(h_try, err)
            h = onset_cut_size(h_try, frac)  # retry a step that ends just past the crossing
            continue
        if err > 1.0:
            rej += 1
            h = rejected_step_size(h_try, err)
            last_rejected = True
            if h < 1e-14:
                info[INFO_T_FAIL] = t
                info[INFO_STATUS] = STATUS_UNDERFLOW
                return
            continue
        # accept
        t_old = t
        t += h_try
        for i in range(ny):
            y_old[i] = y[i]
            y[i] = ytmp[i]
        dense = sample_inside(io, t_out, t)
        # DOPRI5 continuous extension, before k[0] is overwritten: output samples and interior force peaks inside
        # the step
        dense_coefficients(h_try, k, y_old, ytmp, bspl, rc5, e_vec)
        acc += 1
        if info.shape[0] > N_INFO:  # optional histogram of accepted step sizes
            record_step_size(info, h_try)
        # constraint residuals at the new state are in the work arrays (last stage was at ytmp)
        res_p, res_v = constraint_residuals(model, work, y)
        if res_p > max_res:
            max_res = res_p
        if res_p > 1e-11 or res_v > 1e-9:
            res = project(t, y, model, state, work, np.int64(3))
            if not math.isfinite(res) or res > 1e-6:
                info[INFO_T_FAIL] = t
                info[INFO_STATUS] = STATUS_PROJECTION
                info[INFO_MAX_RESIDUAL] = res
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
        onset = record_contacts(t, t_old, h_try, stats_from, model, state, work, pen_start, f_start, pdot_start,
                                peaks, first, u_peak)
        interior_peak_forces(t, t_old, h_try, stats_from, model, state, work, k, ytmp, y_old, bspl, rc5, y_out,
                             e_save, psi_f_keep, u_peak, peaks, first)
        h, err_old = next_step_size(h_try, err, err_old, last_rejected, h_max)
        last_rejected = False
        if onset and h_resume > 0.0:
            # the step that took the onset was cut short on purpose, not for accuracy: go on with the size
            # that passed the error test before the cut (the controller shrinks it if contact needs less)
            if h < h_resume:
                h = min(h_max, h_resume)
            h_resume = 0.0
        # output samples inside the step: the dense output's state, forces and multipliers evaluated there
        while sample_inside(io, t_out, t):
            _dense_state((t_out[io] - t_old) / h_try, h_try, k, ytmp, y_old, bspl, rc5, y_out)
            accelerations(t_out[io], y_out, model, state, work, k_out)
            _write_sample(io, y_out, eout, lam, out_y, out_e, out_lam)
            io += 1
        if sample_at_end(io, t_out, t):
            # a sample at the step's end: the accepted (projected) state itself, evaluated again only when a
            # sample inside the step moved the work arrays
            if dense:
                accelerations(t, y, model, state, work, k_out)
            _write_sample(io, y, eout, lam, out_y, out_e, out_lam)
            io += 1
        for i in range(psi_c.shape[0]):
            psi_c[i] = psi_c_keep[i]
        for i in range(psi_f.shape[0]):
            psi_f[i] = psi_f_keep[i]
    info[INFO_ACCEPTED] = acc
    info[INFO_REJECTED] = rej
    info[INFO_CUTS] = cuts
    info[INFO_STATUS] = STATUS_OK
    info[INFO_MAX_RESIDUAL] = max_res
