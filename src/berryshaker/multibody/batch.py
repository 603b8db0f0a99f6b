"""Many parameter sets of one mechanism structure in one compiled call.

A sweep over clearances, stiffnesses or masses changes only the floating-point parameters of a mechanism;
its structure (which constraints and force elements act between which bodies, the number of output
samples, the tolerances) stays the same.  :func:`simulate_mechanisms` groups the descriptions by that
structure, stacks each group's parameters, state and work arrays along a leading "set" axis and integrates
the group in one numba call that loops over the sets with ``prange`` (:func:`integrate_sets`).  Each set has
its own arrays and runs the same compiled :func:`berryshaker.multibody.kernel.integrate` as
:func:`berryshaker.multibody.engine.simulate_mechanism`, so a set's result is bitwise that of a run on its
own (tests/multibody/test_batch.py).

Threads: the loop runs on numba's current thread count (``numba.set_num_threads``); the sweep runner sets it
from ``BERRYSHAKER_BATCH_THREADS`` (default 1, because its worker processes already use every core).  On one
thread the sets run one after the other through the single-run kernel (no parallel specialisation compiled).
"""

from __future__ import annotations

import time

import numpy as np
from numba import njit, prange

from berryshaker.compiled_cache import kernel_choice
from berryshaker.errors import BerryshakerError
from berryshaker.multibody import engine
from berryshaker.multibody import kernel as mb
from berryshaker.multibody.engine import (
    MultibodyResult,
    PreparedRun,
    finish_run,
    integrate_in_chunks,
    prepare_run,
    resumable,
)
from berryshaker.multibody.model import FLOAT_FIELDS, STRUCTURE_FIELDS, MechanismModel
from berryshaker.multibody.spec import MechanismSpec
from berryshaker.multibody.specialised import mark_compiled


@njit(cache=True, parallel=True)
def integrate_sets(y0, t_out, mass, inertia, gravity, ctype, cint, cflt, crow, ftype, fint, fflt, cams, modal_w,
                   modal_z, phi_tab, plant_p, laws, solve_plan, in_contact, v_imp, psi_c, psi_f, lam_prev, phi, jac, nu,
                   gam, q_f, eout, lam, minv, w_mat, rhs, rtol, atol, h_max, stats_from, out_y, out_e, out_lam, peaks,
                   first, info):
    """:func:`berryshaker.multibody.kernel.integrate` for every set s (leading axis of each stacked array) in
    parallel; the structure arrays (ctype, cint, crow, ftype, fint, solve_plan), t_out, rtol, h_max and the contact
    laws are shared.

    Parameters
    ----------
    y0 : numpy.ndarray
        Initial state (m, rad; m/s, rad/s).
    t_out : numpy.ndarray
        Output times (s).
    mass, inertia : numpy.ndarray
        The bodies' masses (kg) and moments of inertia (kg m^2).
    gravity : numpy.ndarray
        Gravity, x and y (m/s^2).
    ctype, cint, cflt, crow : numpy.ndarray
        The constraint blocks: types (``layout.CON_*``), integer and float records (``layout.CI_*``,
        ``layout.CF_*``; SI), first rows.
    ftype : numpy.ndarray of int
        Type of each force element (``layout.FRC_*``).
    fint, fflt : numpy.ndarray
        The force elements' records (``layout.FI_*``, ``layout.FF_*``; SI).
    cams : numpy.ndarray
        A row per cam (``layout.CAM_*``; lengths m, angles rad).
    modal_w, modal_z : numpy.ndarray
        Natural angular frequency (rad/s) and damping ratio (dimensionless) of each mode.
    phi_tab : numpy.ndarray
        Mode shapes at the contacts' stations (m per unit modal coordinate).
    plant_p : numpy.ndarray
        The drive-past (``layout.PLANT_*``: speed m/s, start m, half span m, ramp m, ramp depth m).
    laws : tuple
        The registered contact laws' compiled functions.
    solve_plan : numpy.ndarray of int
        The multiplier solve's plan (:func:`berryshaker.multibody.sparsity.solve_plan`).
    in_contact, v_imp : numpy.ndarray
        Each contact closed at the last accepted step; its impact velocity (m/s).
    psi_c : numpy.ndarray
        Cam-roller foot memory per set (rad).
    psi_f : numpy.ndarray
        Groove contacts' foot memory per set (rad, rad/s, s).
    lam_prev : numpy.ndarray
        Multipliers of the last accepted step (N, N m).
    phi, jac, nu, gam : numpy.ndarray
        Written, per row: Phi (m, rad), its Jacobian Phi_q (dimensionless, m), nu = -Phi_t (m/s, rad/s) and gamma
        (m/s^2, rad/s^2).
    q_f : numpy.ndarray
        Work arrays Q per set (N, N m).
    eout : numpy.ndarray
        Element outputs, written (``layout.EO_*``: normal force N or torque N m, penetration m, its rate m/s,
        tangential force N or input torque N m).
    lam : numpy.ndarray
        Work arrays per set: the multipliers (N, N m).
    minv : numpy.ndarray
        Inverse mass of each coordinate (1/kg, 1/(kg m^2)).
    w_mat : numpy.ndarray
        Work arrays W per set (the Schur complement, 1/kg, m/kg).
    rhs : numpy.ndarray
        Work arrays per set (SI).
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
        The integrator's statistics (``layout.INFO_*``: counts, time s, status, residual m or rad); a longer array
        also gets the histogram of step sizes (counts).
    """
    for s in prange(y0.shape[0]):
        model = MechanismModel(mass[s], inertia[s], gravity[s], ctype, cint, cflt[s], crow, ftype, fint, fflt[s],
                               cams[s], modal_w[s], modal_z[s], phi_tab[s], plant_p[s], laws, solve_plan)
        state = (in_contact[s], v_imp[s], psi_c[s], psi_f[s], lam_prev[s])
        work = (phi[s], jac[s], nu[s], gam[s], q_f[s], eout[s], lam[s], minv[s], w_mat[s], rhs[s])
        mb.integrate(y0[s], t_out, model, state, work, rtol, atol[s], h_max, stats_from[s], out_y[s], out_e[s],
                     out_lam[s], peaks[s], first[s], info[s])


def structure_key(run: PreparedRun) -> tuple:
    """What must be equal for two runs to share one batch: the structure arrays, every array's shape, the
    output times, tolerances, largest step and step budget.

    Parameters
    ----------
    run : PreparedRun
        A run set up by :func:`~berryshaker.multibody.engine.prepare_run`.

    Returns
    -------
    tuple
        The key (bytes of the structure arrays, shapes, times s, tolerances, step s, budget).
    """
    model = run.cm.model
    ints = tuple(getattr(model, f).tobytes() for f in STRUCTURE_FIELDS)
    shapes = tuple(np.shape(getattr(model, f)) for f in FLOAT_FIELDS) + tuple(np.shape(a) for a in run.state + run.work)
    return (ints, shapes, run.t_out.tobytes(), run.rtol, run.max_step, run.budget,
            tuple(id(f) for f in model.laws), run.specialised)


def _stack(arrays: list[np.ndarray]) -> np.ndarray:
    return np.ascontiguousarray(np.stack(arrays))


def integrate_prepared(runs: list[PreparedRun]) -> float:
    """Integrate prepared runs of one structure, writing into each run's own arrays; returns the wall time.

    On more than one numba thread: one compiled call, ``prange`` over the sets (:func:`integrate_sets`).  On
    one thread the sets go one after the other through the same compiled integrator as single runs
    (``kernel.integrate``, or the structure's own with ``simulation.specialised``,
    :func:`berryshaker.multibody.engine.integrator`): the result is the same and no second specialisation of the
    integrator is compiled (the parallel one costs some 25 s of cold start, which one thread cannot win back).
    The parallel call runs the generic kernel (so does a run left to choose, ``simulation.specialised`` None).

    Parameters
    ----------
    runs : list of PreparedRun
        Runs of one structure (:func:`structure_key` equal).

    Returns
    -------
    float
        Wall time of the integration (s).
    """
    import numba

    if numba.get_num_threads() == 1 or len(runs) == 1:
        t0 = time.perf_counter()
        for r in runs:
            integrate = resumable(engine.integrator(r.cm, r.specialised))  # looked up at the call (tests patch it)
            integrate_in_chunks(integrate, r)  # in chunks: Ctrl-C stops it (the parallel call below cannot)
            if integrate is not mb.integrate_resumable:
                mark_compiled(r.cm.model, r.cm.n, integrate)  # later runs of the structure take it by default
        return time.perf_counter() - t0
    if any(r.specialised or (r.specialised is None and kernel_choice() == "specialised") for r in runs):
        import warnings

        warnings.warn(f"berryshaker: {numba.get_num_threads()} batch threads run the generic kernel, not the "
                      "specialised one (simulation.specialised or BERRYSHAKER_KERNEL; BERRYSHAKER_BATCH_THREADS=1 runs it)", RuntimeWarning,
                      stacklevel=2)
    first_run = runs[0]
    model = first_run.cm.model
    fl = {f: _stack([getattr(r.cm.model, f) for r in runs]) for f in FLOAT_FIELDS}
    st = [_stack([r.state[i] for r in runs]) for i in range(len(first_run.state))]
    wk = [_stack([r.work[i] for r in runs]) for i in range(len(first_run.work))]
    out_y, out_e, out_lam = (_stack([r.out_y for r in runs]), _stack([r.out_e for r in runs]),
                             _stack([r.out_lam for r in runs]))
    peaks, first, info = (_stack([r.peaks for r in runs]), _stack([r.first for r in runs]),
                          _stack([r.info for r in runs]))
    info[:, 0] = [r.budget for r in runs]
    t0 = time.perf_counter()
    integrate_sets(_stack([r.y for r in runs]), first_run.t_out, fl["mass"], fl["inertia"], fl["gravity"], model.ctype,
                   model.cint, fl["cflt"], model.crow, model.ftype, model.fint, fl["fflt"], fl["cams"], fl["modal_w"],
                   fl["modal_z"], fl["phi_tab"], fl["plant_p"], model.laws, model.plan, *st, *wk,
                   first_run.rtol, _stack([r.atol for r in runs]), first_run.max_step,
                   np.array([r.stats_from for r in runs]), out_y, out_e, out_lam, peaks, first, info)
    wall = time.perf_counter() - t0
    for s, r in enumerate(runs):
        r.out_y, r.out_e, r.out_lam = out_y[s], out_e[s], out_lam[s]
        r.peaks, r.first, r.info = peaks[s], first[s], info[s]
    return wall


def simulate_mechanisms(specs: list[MechanismSpec], duration: float | None = None, rtol: float | None = None,
                        output_step: float | None = None, max_step: float | None = None,
                        max_steps: int | None = None, series: str = "whole") -> list[MultibodyResult | BerryshakerError]:
    """Simulate many descriptions, batching those of one structure into one compiled call.

    Parameters
    ----------
    specs : list of MechanismSpec
        The mechanisms (typically one description with different parameters).
    duration, rtol, output_step, max_step, max_steps, series
        As in :func:`berryshaker.multibody.engine.simulate_mechanism` (each description's own
        ``simulation`` block gives the defaults).

    Returns
    -------
    list
        Per description, in order: its :class:`~berryshaker.multibody.engine.MultibodyResult` (equal to that of
        ``simulate_mechanism``; ``wall_time_s`` is the batch's wall time shared out equally), or the
        :class:`~berryshaker.errors.BerryshakerError` (ConfigError, GeometryError, SimulationError) the run
        raised, so that one bad set does not stop the others.
    """
    out: list = [None] * len(specs)
    groups: dict[tuple, list[int]] = {}
    prepared: dict[int, PreparedRun] = {}
    for i, spec in enumerate(specs):
        try:
            prepared[i] = prepare_run(spec, duration, rtol, output_step, max_step, None, max_steps, series=series)
        except BerryshakerError as exc:
            out[i] = exc
            continue
        groups.setdefault(structure_key(prepared[i]), []).append(i)
    for idx in groups.values():
        runs = [prepared[i] for i in idx]
        wall = integrate_prepared(runs)
        for i, r in zip(idx, runs):
            try:
                out[i] = finish_run(r, wall / len(runs))
            except BerryshakerError as exc:
                out[i] = exc
    return out
