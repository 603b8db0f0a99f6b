"""The integrator's output samples: the state, element outputs and multipliers written at the times of the output
grid (``t_out``).  A sample inside a step is the step's dense output, with the forces and multipliers evaluated
there; a sample at a step's end is the accepted (projected) state itself.  The steps do not depend on the grid: a
sample's evaluation leaves the integration state as it found it (the loop restores the foot memories), so every
sample in a window is bitwise that of a run on any other grid.
"""

from __future__ import annotations

from numba import njit

from berryshaker.multibody.dopri import _dense_state
from berryshaker.multibody.dynamics import accelerations


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
def write_state_sample(io, t, y, model, state, work, y_out, k_out, out_y, out_e, out_lam):
    """Output sample io at the state (t, y) itself: the forces and multipliers evaluated there (``y_out`` and
    ``k_out`` are work space).  Returns the next sample's index.

    Parameters
    ----------
    io : int
        Index of the next output sample.
    t : float
        Time (s).
    y : numpy.ndarray
        The state to write (m, rad; m/s, rad/s).
    model, state, work : tuple
        The compiled mechanism's arrays, the state carried between evaluations and the work arrays
        (:mod:`berryshaker.multibody.dynamics`).
    y_out, k_out : numpy.ndarray
        Work space: an interpolated state (m, rad; m/s, rad/s) and its derivative (m/s, rad/s; m/s^2, rad/s^2).
    out_y, out_e, out_lam : numpy.ndarray
        The written series: states (m, rad; m/s, rad/s), element outputs (``layout.EO_*``, SI), multipliers (N, N
        m).
    """
    lam, eout = work[6], work[5]
    for i in range(y.shape[0]):
        y_out[i] = y[i]
    accelerations(t, y_out, model, state, work, k_out)
    _write_sample(io, y_out, eout, lam, out_y, out_e, out_lam)
    return io + 1


@njit(cache=True, _nrt=False)
def write_step_samples(io, t_out, t_old, t, h, dense, k, ytmp, y_old, bspl, rc5, y, model, state, work, y_out,
                       k_out, out_y, out_e, out_lam):
    """The output samples io, io + 1, ... that fall in the accepted step (t_old, t] of size h: inside it the dense
    output (``k``, ``ytmp``, ``y_old``, ``bspl``, ``rc5``: :func:`berryshaker.multibody.dopri._dense_state`), at its
    end the accepted (projected) state ``y``, evaluated again only when ``dense`` (a sample inside the step moved
    the work arrays).  Returns the next sample's index.

    Parameters
    ----------
    io : int
        Index of the next output sample.
    t_out : numpy.ndarray
        Output times (s).
    t_old : float
        Time at the step's start (s).
    t : float
        Time at the step's end (s).
    h : float
        Step size (s).
    dense : bool
        Whether output samples lie inside the step.
    k : numpy.ndarray
        Stage derivatives of the step (7 rows; m/s, rad/s; m/s^2, rad/s^2).
    ytmp : numpy.ndarray
        The step's end state as the step computed it (m, rad; m/s, rad/s).
    y_old : numpy.ndarray
        State at the step's start (m, rad; m/s, rad/s).
    bspl, rc5 : numpy.ndarray
        The step's dense-output coefficients h k1 - (y1 - y0) and h sum_i D_i k_i (m, rad; m/s, rad/s).
    y : numpy.ndarray
        State at the step's end (m, rad; m/s, rad/s).
    model, state, work : tuple
        The compiled mechanism's arrays, the state carried between evaluations and the work arrays
        (:mod:`berryshaker.multibody.dynamics`).
    y_out, k_out : numpy.ndarray
        Work space: an interpolated state (m, rad; m/s, rad/s) and its derivative (m/s, rad/s; m/s^2, rad/s^2).
    out_y, out_e, out_lam : numpy.ndarray
        The written series: states (m, rad; m/s, rad/s), element outputs (``layout.EO_*``, SI), multipliers (N, N
        m).
    """
    lam, eout = work[6], work[5]
    n_out = t_out.shape[0]
    while io < n_out and t_out[io] < t - 1e-15:
        _dense_state((t_out[io] - t_old) / h, h, k, ytmp, y_old, bspl, rc5, y_out)
        accelerations(t_out[io], y_out, model, state, work, k_out)
        _write_sample(io, y_out, eout, lam, out_y, out_e, out_lam)
        io += 1
    if io < n_out and t_out[io] <= t + 1e-15:
        # a sample at the step's end: the accepted (projected) state itself
        if dense:
            accelerations(t, y, model, state, work, k_out)
        _write_sample(io, y, eout, lam, out_y, out_e, out_lam)
        io += 1
    return io
