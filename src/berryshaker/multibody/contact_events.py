"""Contact events inside an integrator step: onsets located on the interpolated penetration (the step is cut back
to them so that the hysteresis laws get the true impact velocity), and the per-step record of every contact: the
contact state and impact velocity, first impacts, counted impacts and peak forces, interior peaks included
(docs/multibody.md, "Impacts" and "Peaks").

Each contact's penetration over a step is the cubic Hermite interpolant of its values and rates at the step's ends
(error O(h^4)); the force at an interior peak is evaluated from the step's dense output.

:func:`record_contacts` locates the interior peaks and :func:`interior_peak_forces` evaluates the forces there
(``force_elements.forces``), inlined into the loop by numba (``inline="always"``): a compiled function of its own
that evaluated the forces would carry a compilation of every force element and contact law of its own (numba
compiles a callee's code again into every compiled caller; :mod:`berryshaker.multibody.dopri`), about 2.5 s of one
core on a fresh cache.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from berryshaker.contact.pair_law import LUBRICATED_RESTITUTION_VELOCITY
from berryshaker.multibody.dopri import _dense_state
from berryshaker.multibody.force_elements import _law, fint_is_contact, forces
from berryshaker.multibody.layout import (
    EO_FN,
    EO_PEN,
    EO_PENDOT,
    EP_DURATION,
    EP_IMPULSE,
    EP_PEAK,
    EP_T0,
    EP_V,
    FF_C,
    FF_D,
    FF_E,
    FF_K,
    FF_MONOTONE,
    FF_N,
    FI_LAW,
    FIRST_DONE,
    FIRST_EP_COUNT,
    FIRST_EP_IMPULSE,
    FIRST_EP_OPEN,
    FIRST_EP_PEAK,
    FIRST_EP_T0,
    FIRST_EP_V,
    FIRST_IMPACTS,
    FIRST_LOG,
    FIRST_PEAK,
    FIRST_TIME,
    FIRST_V_IMP,
    N_EO,
    N_EP,
)

EVENT_TOL = 1e-9  # m: contact onset is located to within this penetration
#: approach speed (m/s) from which a located contact onset counts as an impact (``first[:, FIRST_IMPACTS]``): the
#: greased pairs' impact-velocity floor (contact.pair_law.LUBRICATED_RESTITUTION_VELOCITY).  Slower closings are a
#: pin settling into its bore (down to 1 um/s): their number depends on the tolerance and on how the chatter of a
#: loaded roller is resolved, the faster ones' does not
IMPACT_COUNT_SPEED = LUBRICATED_RESTITUTION_VELOCITY
# relative margin of the interior-peak skip (record_contacts: a monotone law's step bound below every maximum it
# feeds)
PEAK_BOUND_MARGIN = 0.01


@njit(cache=True, _nrt=False)
def _interior_peak(model, j, v_imp, h, p0, d0, p1, d1):
    """Largest contact force inside a step from a cubic Hermite interpolation of the penetration
    (p0, d0) -> (p1, d1) over h (O(h^4) in the penetration, O(h^3) in its rate), sampled at 15 interior
    points, and the fraction of the step where it occurs (refined by a parabola through the samples around
    the largest).  :func:`record_contacts` re-evaluates the force at that fraction from the dense output."""
    fint, fflt = model.fint, model.fflt
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
            f = _law(model.laws, fint[j, FI_LAW], pen, pd, v_imp, fflt[j, FF_K], fflt[j, FF_N], fflt[j, FF_E], fflt[j, FF_C],
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
    fint, fflt = model.fint, model.fflt
    return _law(model.laws, fint[j, FI_LAW], p_max, d_max, v_imp, fflt[j, FF_K], fflt[j, FF_N], fflt[j, FF_E],
                fflt[j, FF_C], fflt[j, FF_D])


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


@njit(cache=True, _nrt=False)
def first_onset_fraction(model, state, work, pen_start, pdot_start, h):
    """Fraction of a step of length h at which the first contact closes that was open at its start and is deeper
    than EVENT_TOL at its end (:func:`_onset_fraction`), or 2.0 when there is none.  The element outputs in the
    work arrays are those at the step's end.

    Parameters
    ----------
    model, state, work : tuple
        The compiled mechanism's arrays, the state carried between evaluations and the work arrays
        (:mod:`berryshaker.multibody.dynamics`).
    pen_start, pdot_start : numpy.ndarray
        Per force element at the step's start: penetration (m) and its rate (m/s).
    h : float
        Size of the step tried (s).
    """
    in_contact = state[0]
    eout = work[5]
    frac = 2.0
    for j in range(eout.shape[0]):
        pe = eout[j, EO_PEN]
        if (not in_contact[j]) and pen_start[j] <= 0.0 and pe > EVENT_TOL and fint_is_contact(model, j):
            f = _onset_fraction(pen_start[j], pdot_start[j], pe, eout[j, EO_PENDOT], h)
            if f < frac:
                frac = f
    return frac


@njit(cache=True, _nrt=False)
def record_contacts(t, t_old, h, stats_from, model, state, work, pen_start, f_start, pdot_start, peaks, first,
                    u_peak):
    """Record every force element's contact state at the end t of an accepted step of size h from t_old; returns
    True when a contact closed (an onset).

    A closing contact gets its impact velocity (the approach rate at first contact, :func:`_crossing_rate`) and
    may start its first episode or count as an impact (``first``); ``peaks`` (over t >= stats_from) and the first
    episode's peak take the step-end force.  Where a peak inside the step may raise them (:func:`_interior_peak`
    on the interpolated penetration above the force at both ends; skipped where a monotone law's bound shows that
    nothing inside the step can), ``u_peak`` gets the fraction of the step where it is (else -1), and
    :func:`interior_peak_forces` evaluates the force there.  The penetrations, forces and rates at the step's end
    become the next step's start values (``pen_start``, ``f_start``, ``pdot_start``).

    A ``first`` wider than ``layout.N_FIRST`` also logs every contact episode of a contact element that closes at
    t >= stats_from (``layout.FIRST_EP_*``, the log from ``layout.FIRST_LOG``): its onset time and approach speed,
    its peak force (step ends and the interior peaks, whose search then also runs where a step may raise the open
    episode's peak), its impulse (the trapezoid rule over its accepted steps, from zero force at the located onset)
    and its duration; an episode is logged when it opens again (an episode still open at the run's end is not).
    The log changes no step: the extra interior-peak evaluations leave the state as it was.

    Parameters
    ----------
    t : float
        Time at the step's end (s).
    t_old : float
        Time at the step's start (s).
    h : float
        Step size (s).
    stats_from : float
        Start of the statistics window (s).
    model, state, work : tuple
        The compiled mechanism's arrays, the state carried between evaluations and the work arrays
        (:mod:`berryshaker.multibody.dynamics`).
    pen_start, f_start, pdot_start : numpy.ndarray
        Per force element at the step's start: penetration (m), |normal force| (N), penetration rate (m/s).
    peaks : numpy.ndarray
        Largest |normal force| of each element over the statistics window (N), updated.
    first : numpy.ndarray
        First contact of each element (``layout.FIRST_*``: time s, impact velocity m/s, peak force N, flag, impact
        count), updated.
    u_peak : numpy.ndarray
        Written: per force element, the fraction of the step at which its force is to be evaluated, or -1.
    """
    fflt = model.fflt
    (in_contact, v_imp, psi_c, psi_f, lam_prev) = state
    eout = work[5]
    nf = eout.shape[0]
    onset = False
    log = first.shape[1] > FIRST_LOG
    cap = (first.shape[1] - FIRST_LOG) // N_EP
    for j in range(nf):
        u_peak[j] = -1.0
        pe = eout[j, EO_PEN]
        fn = eout[j, EO_FN]
        if log and first[j, FIRST_EP_OPEN] > 0.0:
            # the open episode's impulse over this step (trapezoid; the force at a located onset is zero)
            first[j, FIRST_EP_IMPULSE] += 0.5 * (f_start[j] + abs(fn)) * h
            if abs(fn) > first[j, FIRST_EP_PEAK]:
                first[j, FIRST_EP_PEAK] = abs(fn)
            if pe <= 0.0:
                n = int(first[j, FIRST_EP_COUNT])
                if n < cap:
                    c = FIRST_LOG + N_EP * n
                    first[j, c + EP_T0] = first[j, FIRST_EP_T0]
                    first[j, c + EP_V] = first[j, FIRST_EP_V]
                    first[j, c + EP_PEAK] = first[j, FIRST_EP_PEAK]
                    first[j, c + EP_IMPULSE] = first[j, FIRST_EP_IMPULSE]
                    first[j, c + EP_DURATION] = t - first[j, FIRST_EP_T0]
                first[j, FIRST_EP_COUNT] = n + 1.0
                first[j, FIRST_EP_OPEN] = 0.0
        if pe > 0.0:
            if not in_contact[j]:
                onset = True
                in_contact[j] = True
                vi = eout[j, EO_PENDOT]
                if pen_start[j] <= 0.0 and fint_is_contact(model, j):
                    # the approach rate at first contact (penetration 0), not at the step's end (up to
                    # EVENT_TOL deep: for a slow approach decelerated by the load, far below it)
                    vi = _crossing_rate(pen_start[j], pdot_start[j], pe, vi, h)
                v_imp[j] = vi if vi > 1e-6 else 1e-6
                if t >= stats_from and vi >= IMPACT_COUNT_SPEED and fint_is_contact(model, j):
                    first[j, FIRST_IMPACTS] += 1.0
                if log and t >= stats_from and fint_is_contact(model, j):
                    first[j, FIRST_EP_OPEN] = 1.0
                    first[j, FIRST_EP_T0] = t
                    first[j, FIRST_EP_V] = vi
                    first[j, FIRST_EP_PEAK] = abs(fn)
                    first[j, FIRST_EP_IMPULSE] = 0.5 * (f_start[j] + abs(fn)) * h
                if first[j, FIRST_DONE] == 0.0:
                    first[j, FIRST_TIME] = t
                    first[j, FIRST_V_IMP] = vi
                    first[j, FIRST_DONE] = 1.0
        else:
            if in_contact[j] and first[j, FIRST_DONE] == 1.0:
                first[j, FIRST_DONE] = 2.0  # first episode finished
            in_contact[j] = False
        # the interior-peak search only feeds peaks (t >= stats_from) and the first episode's peak: skipped
        # elsewhere (its force evaluation leaves the integration state and the output samples alone: psi restored)
        search = in_contact[j] and pen_start[j] > 0.0 and fint_is_contact(model, j) and (
            t >= stats_from or first[j, FIRST_DONE] == 1.0)
        if search and fflt[j, FF_MONOTONE] > 0.0:
            # nothing inside the step can raise a maximum it feeds when even the bound of a monotone law
            # stays a margin below them (the margin covers the gap between the interpolated penetration and
            # the dense-output state the search evaluates the force at)
            low = np.inf
            if first[j, FIRST_DONE] == 1.0:
                low = first[j, FIRST_PEAK]
            if t >= stats_from and peaks[j] < low:
                low = peaks[j]
            if log and first[j, FIRST_EP_OPEN] > 0.0 and first[j, FIRST_EP_PEAK] < low:
                low = first[j, FIRST_EP_PEAK]
            if (1.0 + PEAK_BOUND_MARGIN) * _step_force_bound(model, j, v_imp[j], h, pen_start[j],
                                                             pdot_start[j], pe, eout[j, EO_PENDOT]) <= low:
                search = False
        if search:
            fi, u_pk = _interior_peak(model, j, v_imp[j], h, pen_start[j], pdot_start[j], pe, eout[j, EO_PENDOT])
            # worth the force evaluation only above both ends of the step: the start's force is already in
            # every maximum the step feeds (the first episode's peak: the contact was closed at the start;
            # peaks: when the step started inside the statistics window), so a force falling through the
            # step (the interior samples above the end, below the start) cannot raise them
            f_thr = abs(fn)
            if (t < stats_from or t_old >= stats_from) and f_start[j] > f_thr:
                f_thr = f_start[j]
            if fi > f_thr:
                # the peak is inside the step: the force there is evaluated from the dense-output state (the
                # interpolated penetration only locates it)
                u_peak[j] = u_pk
        if first[j, FIRST_DONE] == 1.0 and abs(fn) > first[j, FIRST_PEAK]:
            first[j, FIRST_PEAK] = abs(fn)
        if t >= stats_from and abs(fn) > peaks[j]:
            peaks[j] = abs(fn)
        pen_start[j] = pe
        f_start[j] = abs(eout[j, EO_FN])
        pdot_start[j] = eout[j, EO_PENDOT]
    return onset


@njit(cache=True, _nrt=False, inline="always")
def interior_peak_forces(t, t_old, h, stats_from, model, state, work, k, ytmp, y_old, bspl, rc5, y_out, e_save,
                         psi_f_keep, u_peak, peaks, first):
    """The forces at the peaks inside an accepted step that :func:`record_contacts` located (``u_peak``): each
    from the dense-output state there (``k``, ``ytmp``, ``y_old``, ``bspl``, ``rc5``), raising ``peaks`` (over
    t >= stats_from) and the first episode's peak where it is larger.  Each evaluation leaves the element outputs
    and the groove contacts' foot memory as they were at the step's end (``e_save``, ``psi_f_keep``: work space and
    the memory after the step).  An element's force depends on its own contact state alone, so this is the value
    that an evaluation inside :func:`record_contacts`' loop would give; a maximum is the same in any order.

    Parameters
    ----------
    t : float
        Time at the step's end (s).
    t_old : float
        Time at the step's start (s).
    h : float
        Step size (s).
    stats_from : float
        Start of the statistics window (s).
    model, state, work : tuple
        The compiled mechanism's arrays, the state carried between evaluations and the work arrays
        (:mod:`berryshaker.multibody.dynamics`).
    k : numpy.ndarray
        Stage derivatives of the step (7 rows; m/s, rad/s; m/s^2, rad/s^2).
    ytmp : numpy.ndarray
        The step's 5th-order solution (m, rad; m/s, rad/s).
    y_old : numpy.ndarray
        State at the step's start (m, rad; m/s, rad/s).
    bspl, rc5 : numpy.ndarray
        The step's dense-output coefficients h k1 - (y1 - y0) and h sum_i D_i k_i (m, rad; m/s, rad/s).
    y_out : numpy.ndarray
        Work space: an interpolated state (m, rad; m/s, rad/s).
    e_save : numpy.ndarray
        Work space for the element outputs (``layout.EO_*``, SI).
    psi_f_keep : numpy.ndarray
        Foot memory of the groove contacts after the accepted step (rad, rad/s, s).
    u_peak : numpy.ndarray
        Per force element, the fraction of the step at which to evaluate its force, or -1 (none).
    peaks : numpy.ndarray
        Largest |normal force| of each element over the statistics window (N), updated.
    first : numpy.ndarray
        First contact of each element (``layout.FIRST_*``: time s, impact velocity m/s, peak force N, flag, impact
        count), its first episode's peak updated.
    """
    mass, gravity, cams, laws = model.mass, model.gravity, model.cams, model.laws
    ctype, cint, cflt, crow = model.ctype, model.cint, model.cflt, model.crow
    ftype, fint, fflt = model.ftype, model.fint, model.fflt
    modal_w, modal_z, phi_tab, plant_p = model.modal_w, model.modal_z, model.phi_tab, model.plant_p
    (in_contact, v_imp, psi_c, psi_f, lam_prev) = state
    Q, eout = work[4], work[5]
    nf = eout.shape[0]
    n_q = y_out.shape[0] // 2
    for j in range(nf):
        if u_peak[j] < 0.0:
            continue
        u_pk = u_peak[j]
        _dense_state(u_pk, h, k, ytmp, y_old, bspl, rc5, y_out)
        for jj in range(nf):
            for c in range(N_EO):
                e_save[jj, c] = eout[jj, c]
        forces(t_old + u_pk * h, y_out[:n_q], y_out[n_q:], mass, gravity, ftype, fint, fflt, cams,
               in_contact, v_imp, psi_f, ctype, cint, cflt, crow, lam_prev, modal_w, modal_z,
               phi_tab, plant_p, Q, eout, laws)
        f_in = abs(eout[j, EO_FN])
        for jj in range(nf):
            for c in range(N_EO):
                eout[jj, c] = e_save[jj, c]
        for i in range(psi_f.shape[0]):
            psi_f[i] = psi_f_keep[i]
        if first[j, FIRST_DONE] == 1.0 and f_in > first[j, FIRST_PEAK]:
            first[j, FIRST_PEAK] = f_in
        if t >= stats_from and f_in > peaks[j]:
            peaks[j] = f_in
        if first.shape[1] > FIRST_LOG and first[j, FIRST_EP_OPEN] > 0.0 and f_in > first[j, FIRST_EP_PEAK]:
            first[j, FIRST_EP_PEAK] = f_in
