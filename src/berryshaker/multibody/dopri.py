"""The integrator's step: one Dormand-Prince 5(4) step of the equations of motion, its error estimate and its
continuous extension (Hairer, Norsett & Wanner, *Solving Ordinary Differential Equations I*, 2nd ed., sec. II.4-6;
the tableau is :mod:`berryshaker.multibody.integrators`).

What to do with a step (accept or reject it, cut it back to a contact onset, choose the next size) is the step
control's (:mod:`berryshaker.multibody.step_control`, :mod:`berryshaker.multibody.kernel`), as SciPy separates
``rk_step`` from its controller (``scipy/integrate/_ivp/rk.py``).  The state y = (q, q') and the stage
derivatives ``k`` (7 rows, state index innermost: contiguous rows, the loops vectorise) are the loop's arrays.

Nothing here calls the right-hand side (``dynamics.accelerations``): the loop evaluates it at each stage's state
(:func:`stage_state`).  Numba links a compiled callee's whole code into every compiled caller and optimises it
there again, so each separately compiled function that calls the right-hand side adds a compilation of the
forces, constraint rows and solve (a step function of its own cost ~2.5 s of one core on a fresh cache).
:func:`stage_state`, :func:`error_norm` and :func:`dense_coefficients` are inlined into the loop by numba
(``inline="always"``; so is ``dynamics.constraint_residuals``): called as functions they cost 2-4 % of a harvester
run, which LLVM did not inline on its own.
"""

from __future__ import annotations

import math

from numba import njit

from berryshaker.multibody.integrators import DOPRI_A, DOPRI_C, DOPRI_D, DOPRI_E

_C, _A, _E, _D = DOPRI_C, DOPRI_A, DOPRI_E, DOPRI_D


@njit(cache=True, _nrt=False, inline="always")
def stage_state(s, t, h, y, k, ytmp):
    """Stage s (1 .. 6) of a DOPRI5 step of size h from (t, y) with k[0] = f(t, y): its state
    y + h sum_{m < s} A[s, m] k[m] into ``ytmp``; returns its time t + C[s] h.  The loop evaluates the right-hand
    side there into k[s] (:mod:`berryshaker.multibody.kernel`); after stage 6 ``ytmp`` is the 5th-order solution,
    whose derivative is k[6] (first same as last), and the work arrays (constraint rows, element outputs,
    multipliers) are at (t + h, ytmp).  The step's error is :func:`error_norm`'s (the controller's, as SciPy's
    solver estimates it apart from ``rk_step``).

    Parameters
    ----------
    s : int
        The stage (1 .. 6).
    t : float
        Time at the step's start (s).
    h : float
        Step size (s).
    y : numpy.ndarray
        State at the step's start (m, rad; m/s, rad/s).
    k : numpy.ndarray
        Stage derivatives (7 rows; m/s, rad/s; m/s^2, rad/s^2); rows 0 .. s - 1 read.
    ytmp : numpy.ndarray
        Written: the stage's state (m, rad; m/s, rad/s).

    Returns
    -------
    float
        The stage's time (s).
    """
    ny = y.shape[0]
    # state index innermost (contiguous rows of k: the loops vectorise); each element sums its terms in stage
    # order, as a loop over stages per element would
    for i in range(ny):
        ytmp[i] = y[i]
    for mm in range(s):
        a_h = h * _A[s, mm]
        for i in range(ny):
            ytmp[i] += a_h * k[mm, i]
    return t + _C[s] * h


@njit(cache=True, _nrt=False, inline="always")
def error_norm(h, y, ytmp, k, e_vec, rtol, atol):
    """The error of a step of size h from y to ytmp with stages k (:func:`rk_step`): the RMS over the states of
    h sum_i E_i k_i (the difference of the 5th- and 4th-order solutions, into ``e_vec``) scaled by
    atol + rtol max(|y|, |ytmp|); <= 1 passes.

    Parameters
    ----------
    h : float
        Step size (s).
    y : numpy.ndarray
        State at the step's start (m, rad; m/s, rad/s).
    ytmp : numpy.ndarray
        The step's 5th-order solution (m, rad; m/s, rad/s).
    k : numpy.ndarray
        Stage derivatives of the step (7 rows; m/s, rad/s; m/s^2, rad/s^2).
    e_vec : numpy.ndarray
        Work space (one entry per state, SI).
    rtol : float
        Relative tolerance (dimensionless).
    atol : numpy.ndarray
        Absolute tolerance per state (m, rad; m/s, rad/s).
    """
    ny = y.shape[0]
    for i in range(ny):
        e_vec[i] = 0.0
    for mm in range(7):
        e_m = _E[mm]
        for i in range(ny):
            e_vec[i] += e_m * k[mm, i]
    err = 0.0
    for i in range(ny):
        ei = e_vec[i] * h
        sc = atol[i] + rtol * max(abs(y[i]), abs(ytmp[i]))
        err += (ei / sc) ** 2
    return math.sqrt(err / ny)


@njit(cache=True, _nrt=False, inline="always")
def dense_coefficients(h, k, y0, y1, bspl, rc5, e_vec):
    """The continuous extension's coefficients of an accepted step y0 -> y1 of size h (before k[0] is replaced by
    the derivative at y1): bspl = h k1 - (y1 - y0) and rc5 = h sum_i D_i k_i (``e_vec`` is work space).

    Parameters
    ----------
    h : float
        Step size (s).
    k : numpy.ndarray
        Stage derivatives of the step (7 rows; m/s, rad/s; m/s^2, rad/s^2).
    y0 : numpy.ndarray
        State at the step's start (m, rad; m/s, rad/s).
    y1 : numpy.ndarray
        State at the step's end (m, rad; m/s, rad/s).
    bspl : numpy.ndarray
        Written: h k1 - (y1 - y0) (m, rad; m/s, rad/s).
    rc5 : numpy.ndarray
        Written: h sum_i D_i k_i (m, rad; m/s, rad/s).
    e_vec : numpy.ndarray
        Work space (one entry per state, SI).
    """
    ny = y0.shape[0]
    for i in range(ny):
        bspl[i] = h * k[0, i] - (y1[i] - y0[i])
        e_vec[i] = 0.0
    for mm in range(7):
        d_m = _D[mm]
        for i in range(ny):
            e_vec[i] += d_m * k[mm, i]
    for i in range(ny):
        rc5[i] = h * e_vec[i]


@njit(cache=True, _nrt=False)
def _dense_state(th, h, k, y1, y0, bspl, rc5, out):
    """State at t0 + th h inside an accepted DOPRI5 step y0 -> y1 (continuous extension of order 4;
    bspl = h k1 - (y1 - y0), rc5 = h sum_i D_i k_i; Hairer, Norsett & Wanner sec. II.6)."""
    th1 = 1.0 - th
    for i in range(out.shape[0]):
        yd = y1[i] - y0[i]
        out[i] = y0[i] + th * (yd + th1 * (bspl[i] + th * (yd - h * k[6, i] - bspl[i] + th1 * rc5[i])))
