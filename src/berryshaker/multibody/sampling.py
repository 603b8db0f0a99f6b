"""The integrator's output samples: the state, element outputs and multipliers written at the times of the output
grid (``t_out``).  A sample inside a step is the step's dense output (:func:`berryshaker.multibody.dopri._dense_state`),
with the forces and multipliers evaluated there; a sample at a step's end is the accepted (projected) state itself,
evaluated again only when a sample inside the step moved the work arrays.  The steps do not depend on the grid: a
sample's evaluation leaves the integration state as it found it (the loop restores the foot memories), so every
sample in a window is bitwise that of a run on any other grid.

Which samples a step holds (:func:`sample_inside`, :func:`sample_at_end`) and how one is written
(:func:`_write_sample`) are here; the loop (:mod:`berryshaker.multibody.kernel`) evaluates the right-hand side at a
sample's state itself, so that no compiled function here carries the right-hand side's code (numba compiles a
callee's code again into every compiled caller: see :mod:`berryshaker.multibody.dopri`).
"""

from __future__ import annotations

from numba import njit

#: s: an output time within this of a step's end is the step's end state
SAMPLE_TIME_TOL = 1e-15


@njit(cache=True, _nrt=False)
def _write_sample(io, y, eout, lam, out_y, out_e, out_lam):
    """Output sample io: state, element outputs, multipliers (element-wise loops: a slice assignment would
    compile numpy's broadcasting and its error messages into the integrator, seconds of cold start).

    Parameters
    ----------
    io : int
        Index of the sample.
    y : numpy.ndarray
        The state (m, rad; m/s, rad/s).
    eout, lam : numpy.ndarray
        The element outputs (``layout.EO_*``, SI) and multipliers (N, N m) evaluated at ``y``.
    out_y, out_e, out_lam : numpy.ndarray
        The written series: states (m, rad; m/s, rad/s), element outputs (``layout.EO_*``, SI), multipliers (N, N
        m).
    """
    for i in range(y.shape[0]):
        out_y[io, i] = y[i]
    for j in range(eout.shape[0]):
        for c in range(eout.shape[1]):
            out_e[io, j, c] = eout[j, c]
    for a in range(lam.shape[0]):
        out_lam[io, a] = lam[a]


@njit(cache=True, _nrt=False, inline="always")
def sample_inside(io, t_out, t):
    """Whether output sample io lies inside a step that ends at t (the step's dense output gives its state).

    Parameters
    ----------
    io : int
        Index of the next output sample.
    t_out : numpy.ndarray
        Output times (s).
    t : float
        Time at the step's end (s).
    """
    return io < t_out.shape[0] and t_out[io] < t - SAMPLE_TIME_TOL


@njit(cache=True, _nrt=False, inline="always")
def sample_at_end(io, t_out, t):
    """Whether output sample io, none of whose predecessors is left, is at the end t of a step (its state is the
    step's accepted state).

    Parameters
    ----------
    io : int
        Index of the next output sample.
    t_out : numpy.ndarray
        Output times (s).
    t : float
        Time at the step's end (s).
    """
    return io < t_out.shape[0] and t_out[io] <= t + SAMPLE_TIME_TOL
