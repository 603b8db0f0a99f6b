"""The integrator's step-size control: the PI controller of an accepted step, the cut of a rejected step and of a
step that crosses a contact onset, the step-size histogram, and the loop state saved between the chunks of a run
(the ``resume`` array, layout ``layout.RS_*``).

The step itself (stages, error estimate, dense output) is :mod:`berryshaker.multibody.dopri`; the loop that uses
both is :func:`berryshaker.multibody.kernel.integrate_resumable`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from berryshaker.multibody.layout import (
    N_INFO,
    N_RESUME,
    RS_ACC,
    RS_CUTS,
    RS_ERR_OLD,
    RS_H,
    RS_H_RESUME,
    RS_IO,
    RS_LAST_REJ,
    RS_MAX_RES,
    RS_REJ,
    RS_STARTED,
    RS_T,
)

SAFETY = 0.9  # step-size safety factor
BETA = 0.04  # PI step-size control: weight of the previous step's error (Hairer & Wanner's DOPRI5 default)
EXPO1 = 0.2 - 0.75 * BETA
#: the step-size histogram (an ``info`` longer than N_INFO): bin b counts h in
#: 10^(STEP_HIST_LOG10_MIN + b / STEP_BINS_PER_DECADE) .. the next bin
STEP_HIST_LOG10_MIN = -9.0
STEP_BINS_PER_DECADE = 20.0


@njit(cache=True, _nrt=False)
def rejected_step_size(h, err):
    """The size to retry a step of size h whose error ``err`` (> 1) failed the test: shrunk by at most 5x.

    Parameters
    ----------
    h : float
        Step size (s).
    err : float
        Error norm of the step (dimensionless; <= 1 passes).
    """
    return h * max(0.2, SAFETY * err ** (-EXPO1))


@njit(cache=True, _nrt=False)
def onset_cut_size(h, frac):
    """The size of a step cut back to a contact onset at fraction ``frac`` of a step of size h: just past the
    crossing (half the step if that would not shrink it).

    Parameters
    ----------
    h : float
        Step size (s).
    frac : float
        Fraction of the step at which the onset lies (dimensionless).
    """
    h_new = h * frac + 1e-15
    if h_new >= h:
        h_new = 0.5 * h
    return h_new


@njit(cache=True, _nrt=False)
def next_step_size(h, err, err_old, last_rejected, h_max):
    """The size of the step after an accepted one of size h and error ``err``, and the error the controller keeps
    for the next: PI step-size control (Gustafsson; Hairer & Wanner's DOPRI5: err^-(0.2 - 0.75 beta) err_old^beta),
    growth between 0.1x and 5x, none right after a rejection, at most h_max.

    Parameters
    ----------
    h : float
        Step size (s).
    err : float
        Error norm of the step (dimensionless; <= 1 passes).
    err_old : float
        Error norm of the last accepted step (dimensionless).
    last_rejected : bool
        Whether the step before was rejected.
    h_max : float
        Largest step (s).
    """
    e_acc = max(err, 1e-10)
    grow = min(5.0, max(0.1, SAFETY * e_acc ** (-EXPO1) * err_old ** BETA))
    err_old = max(err, 1e-4)
    if last_rejected and grow > 1.0:
        grow = 1.0  # no growth right after a rejection
    return min(h_max, h * grow), err_old


@njit(cache=True, _nrt=False)
def record_step_size(info, h):
    """Count an accepted step of size h in the histogram after the first N_INFO entries of ``info``
    (the first and last bins take what falls outside).

    Parameters
    ----------
    info : numpy.ndarray
        The integrator's statistics (``layout.INFO_*``: counts, time s, status, residual m or rad); a longer array
        also gets the histogram of step sizes (counts).
    h : float
        Step size (s).
    """
    hb = int(STEP_BINS_PER_DECADE * (math.log10(h) - STEP_HIST_LOG10_MIN))
    info[N_INFO + min(max(hb, 0), info.shape[0] - N_INFO - 1)] += 1.0


@njit(cache=True, _nrt=False)
def save_resume(resume, t, h, h_resume, err_old, last_rejected, acc, rej, cuts, max_res, io, y, k0, pen_start,
                f_start, pdot_start):
    """Save the integration loop's state in ``resume`` (layout ``RS_*``), marked as started.

    Parameters
    ----------
    resume : numpy.ndarray
        Written: the loop state (``layout.RS_*``: times s, step sizes s, counts, the state in SI).
    t : float
        Time (s).
    h : float
        Step size (s).
    h_resume : float
        Step size to resume with after an onset cut (s; 0: none pending).
    err_old : float
        Error norm of the last accepted step (dimensionless).
    last_rejected : bool
        Whether the step before was rejected.
    acc, rej, cuts : int
        Accepted, rejected and onset-cut steps so far.
    max_res : float
        Largest constraint residual so far (m, rad).
    io : int
        Index of the next output sample.
    y : numpy.ndarray
        State: positions, then velocities (m, rad; m/s, rad/s).
    k0 : numpy.ndarray
        Derivative at y (m/s, rad/s; m/s^2, rad/s^2).
    pen_start, f_start, pdot_start : numpy.ndarray
        Per force element at the step's start: penetration (m), |normal force| (N), penetration rate (m/s).
    """
    ny = y.shape[0]
    nf = pen_start.shape[0]
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
        resume[N_RESUME + ny + i] = k0[i]
    for j in range(nf):
        resume[N_RESUME + 2 * ny + j] = pen_start[j]
        resume[N_RESUME + 2 * ny + nf + j] = f_start[j]
        resume[N_RESUME + 2 * ny + 2 * nf + j] = pdot_start[j]


@njit(cache=True, _nrt=False)
def load_resume(resume, y, k0, pen_start, f_start, pdot_start):
    """The loop state saved by :func:`save_resume`: the arrays filled in place, and (t, h, h_resume, err_old,
    last_rejected, accepted, rejected, cuts, max_res, io) returned.

    Parameters
    ----------
    resume : numpy.ndarray
        The saved loop state (``layout.RS_*``: times s, step sizes s, counts, the state in SI).
    y : numpy.ndarray
        Filled: the state (m, rad; m/s, rad/s).
    k0 : numpy.ndarray
        Filled: the derivative at y (m/s, rad/s; m/s^2, rad/s^2).
    pen_start, f_start, pdot_start : numpy.ndarray
        Filled, per force element at the step's start: penetration (m), |normal force| (N), penetration rate (m/s).
    """
    ny = y.shape[0]
    nf = pen_start.shape[0]
    for i in range(ny):
        y[i] = resume[N_RESUME + i]
        k0[i] = resume[N_RESUME + ny + i]
    for j in range(nf):
        pen_start[j] = resume[N_RESUME + 2 * ny + j]
        f_start[j] = resume[N_RESUME + 2 * ny + nf + j]
        pdot_start[j] = resume[N_RESUME + 2 * ny + 2 * nf + j]
    return (resume[RS_T], resume[RS_H], resume[RS_H_RESUME], resume[RS_ERR_OLD], resume[RS_LAST_REJ] > 0.5,
            int(resume[RS_ACC]), int(resume[RS_REJ]), int(resume[RS_CUTS]), resume[RS_MAX_RES],
            np.int64(resume[RS_IO]))
