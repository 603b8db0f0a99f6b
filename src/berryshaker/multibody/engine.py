"""Running a mechanism description through the compiled multibody core (:mod:`berryshaker.multibody.kernel`):
the run's set-up and limits, the choice of the compiled integrator (generic or specialised to the structure), the
integration in chunks and its result, and the compilation of the core ahead of a run.

The description is compiled into the core's arrays by :mod:`berryshaker.multibody.compiled`, its initial state
assembled by :mod:`berryshaker.multibody.assembly` (perturbed starts: :mod:`berryshaker.multibody.perturbation`),
compiled functions called through :mod:`berryshaker.multibody.dispatch`, and the result is a
:class:`~berryshaker.multibody.result.MultibodyResult`.

long module: a run's limits, set-up, kernel choice, chunked integration and result are one path that every run
takes; over 550 lines with their numpydoc sections.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass

import numpy as np
from numba import typeof

from berryshaker.compiled_cache import kernel_choice
from berryshaker.errors import ConfigError, SimulationError
from berryshaker.multibody import kernel
from berryshaker.multibody import layout as L
from berryshaker.multibody.assembly import initial_state
from berryshaker.multibody.compiled import CompiledMechanism, _state_and_work, compile_mechanism
from berryshaker.multibody.contact_events import (
    _crossing_rate,
    _interior_peak,
    _onset_fraction,
    _step_force_bound,
    first_onset_fraction,
    record_contacts,
)
from berryshaker.multibody.dispatch import _type_key, call_compiled
from berryshaker.multibody.dopri import _dense_state
from berryshaker.multibody.dynamics import accelerations, project
from berryshaker.multibody.force_elements import fint_is_contact, forces
from berryshaker.multibody.perturbation import InitialPerturbation, RandomInitialPerturbation
from berryshaker.multibody.result import MultibodyResult
from berryshaker.multibody.sampling import _write_sample
from berryshaker.multibody.spec import MechanismSpec
from berryshaker.multibody.specialised import is_compiled, mark_compiled, specialised_integrator
from berryshaker.multibody.step_control import (
    load_resume,
    next_step_size,
    onset_cut_size,
    record_step_size,
    rejected_step_size,
    save_resume,
)

#: what the written series of a run may cover (:func:`simulate_mechanism`'s ``series``)
SERIES = {"whole": "every output sample of the run",
          "statistics": "the initial state and the samples of the statistics window (driver revolutions 2..N) "
                        "with the one before it"}


#: length (m) below which a position's error is held absolutely: atol = rtol x POSITION_SCALE for the
#: positions (the velocities' scale is the spec's ``simulation.velocity_scale``)
POSITION_SCALE = 1e-3


#: most output samples one run may write (the series are held in memory: about 0.7 kB per sample for the
#: harvester drives, so 1.4 GB at the cap); a longer run must use a coarser ``output_step`` or be shorter
MAX_OUTPUT_SAMPLES = 2_000_000


#: default step budget: one integrator step (accepted or rejected) per STEP_BUDGET_DT of simulated time.  The
#: harvester drives take about one step per 50 us (27 000 steps for 3 revolutions at 120 rpm), so the budget
#: is some 50 times what a sound run needs; a run that needs more is stiffer than any description here
#: should be (a contact stiffness or damping off by orders of magnitude) and would run for many minutes.
STEP_BUDGET_DT = 1e-6


#: the budget is never below this many steps (short runs with many contact onsets)
MIN_STEP_BUDGET = 200_000


#: integrator steps per compiled call of a run (:func:`integrate_in_chunks`): between two chunks the run is back
#: in Python, where Ctrl-C is seen; ~0.15 s of a harvester run's steps (7-8 us each), so a 2-revolution run is
#: one chunk.  The results do not depend on it: a chunk resumes the step sequence exactly (bitwise)
CHUNK_STEPS = 20_000


def check_output_samples(duration: float, output_step: float,
                         fix: str = "simulate a shorter time or write a coarser output_step") -> int:
    """Number of output samples of a run, refused above :data:`MAX_OUTPUT_SAMPLES` before anything is allocated.

    Parameters
    ----------
    duration, output_step : float
        Simulated time and spacing of the written series (s).
    fix : str
        What the user should change, quoted in the message (e.g. "use fewer --revolutions").

    Returns
    -------
    int
        The number of output samples.


    Raises
    ------
    ConfigError
        Non-finite or non-positive times, or too many samples (the message gives the longest allowed time).
    """
    for name, v in (("duration", duration), ("output_step", output_step)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not v > 0:
            raise ConfigError(f"{name} must be a finite time > 0 s, got {v!r}")
    n_samples = duration / output_step + 1
    if n_samples > MAX_OUTPUT_SAMPLES:
        raise ConfigError(f"a run of {duration:.6g} s written every {output_step:.3g} s needs {n_samples:.3g} output "
                          f"samples, more than the {MAX_OUTPUT_SAMPLES:,} one run may hold in memory (at most "
                          f"{(MAX_OUTPUT_SAMPLES - 1) * output_step:.4g} s of simulated time); {fix}")
    return max(2, int(round(duration / output_step)) + 1)


def _auxiliary_tolerances(cm: CompiledMechanism, rtol: float, atol: np.ndarray,
                          probe_modes: int = 0) -> tuple[float, np.ndarray]:
    """Error weights with auxiliary coordinates: a windup state (velocity slot) is weighted like a position,
    the integral slots, the energy accumulators and the modes of one-way probes (the last ``probe_modes`` modes,
    ``plant.probe_modes``: the mechanism's motion does not depend on them) are left out of the step-size control
    (atol 1e300), and rtol and atol are scaled by sqrt(n_controlled / 2n) so that the integrator's RMS error norm,
    which divides by all 2n components, asks the same accuracy of the controlled state as a run without the
    others."""
    n, n0 = cm.n, cm.n_base
    atol = atol.copy()
    atol[n0:n] = 1e300
    n_states = len(cm.state_windup0)
    atol[n + n0:n + n0 + n_states] = atol[0]
    atol[n + n0 + n_states:] = 1e300
    if probe_modes:
        atol[n0 - probe_modes:n0] = 1e300
        atol[n + n0 - probe_modes:n + n0] = 1e300
    f = math.sqrt(np.count_nonzero(atol < 1e299) / (2 * n))
    return rtol * f, atol * f


def default_step_budget(duration: float) -> int:
    """The step budget of a run of ``duration`` seconds: ``max(MIN_STEP_BUDGET, duration / STEP_BUDGET_DT)``.

    Parameters
    ----------
    duration : float
        Simulated time (s).

    Returns
    -------
    int
        Accepted plus rejected steps allowed.
    """
    return int(max(MIN_STEP_BUDGET, math.ceil(duration / STEP_BUDGET_DT)))


#: the argument types (:func:`_argument_types`) the compiled integrator has been called with in this process
_WARM: set = set()


def _argument_types(run: "PreparedRun") -> tuple:
    """What decides which compiled specialisation of ``kernel.integrate`` a run calls (:func:`_type_key` of its
    arguments).  A run whose key is in :data:`_WARM` needs no warm-up call to keep compilation out of its
    ``wall_time_s``."""
    return _type_key((run.y, run.cm.model, run.state, run.work, run.atol, run.out_y, run.out_e, run.out_lam,
                      run.peaks, run.first, run.info))


#: the parts of the compiled core :func:`compile_engine` compiles (in the order kernel.integrate needs them)
ENGINE_PARTS = ("projection", "forces", "right_hand_side", "step_events", "step_forces")


def compile_engine(spec: MechanismSpec, parts: tuple[str, ...] = ENGINE_PARTS) -> dict[str, float]:
    """Compile (or load from numba's on-disk cache) parts of the compiled core for the argument types of
    ``spec``'s runs, without running anything.

    The integrator (``kernel.integrate``) calls a chain of ~50 compiled functions, compiled one after the other
    on first use: about 16 s of one core on a fresh install.  Compiling a part
    compiles the callees it needs that are not compiled yet and writes everything to the cache, so two processes
    can share the work: one compiles ``"forces"`` and ``"step_forces"`` (which share the contact laws' calls and
    only small geometry helpers with the rest) while the other compiles ``"projection"`` and ``"step_events"``,
    then ``"right_hand_side"`` once the first is done; a run then compiles only the integrator itself and loads
    the rest.  (About 3.5 + 0.7 s against 2.8 + 0.9 s of one core; with ``"step"`` whole on the projection's side
    the forces' process idled ~3 s.)

    Parameters
    ----------
    spec : MechanismSpec
        Any mechanism: the argument types (not the values) decide what is compiled, and every mechanism the
        engine builds (the groove-cam and crank-rocker drives, with a modal plant, with the powered driveline;
        the slider-crank of the validation cases) has the same ones.
    parts : tuple of str
        Any of :data:`ENGINE_PARTS`: ``"projection"`` (``dynamics.project``: the constraint equations, their
        Jacobian and the multiplier solve), ``"forces"`` (``force_elements.forces``: every force element and
        contact law), ``"right_hand_side"`` (``dynamics.accelerations``: the forces, the constraints and the
        multiplier solve of one right-hand side, compiling the other two first if they are not; only the loop
        itself calls it), ``"step_events"`` (the integrator's helpers for contact onsets, dense output, output
        samples and step-size control), ``"step_forces"`` (its helpers that evaluate the contact laws inside a
        step: the force bound, the interior force peak and ``contact_events.record_contacts``).  The functions that
        numba inlines into the loop (``inline="always"``: the step's stages, its error and dense-output
        coefficients, the constraint residuals, the output samples' tests, the forces at interior peaks) are no part: the loop compiles
        their code itself, and a compilation of their own would be used by nothing.

    Returns
    -------
    dict
        CPU seconds per part (about 0.01 s when it was in the cache).

    Raises
    ------
    ConfigError
        An unknown part.
    """
    bad = [p for p in parts if p not in ENGINE_PARTS]
    if bad:
        raise ConfigError(f"compile_engine: unknown part(s) {', '.join(map(repr, bad))}; the parts are "
                          f"{', '.join(map(repr, ENGINE_PARTS))}")
    cm = compile_mechanism(spec)
    state, work = _state_and_work(cm)
    y = np.zeros(2 * cm.n)
    md = cm.model
    (in_contact, v_imp, psi_c, psi_f, lam_prev) = state
    q_arg = y[:cm.n]  # dynamics.accelerations passes views of y: C-contiguous 1-D arrays, as these
    # the types kernel.integrate passes: a contact index from range() (int64), step counts and the next sample's
    # index (int64), flags (bool), floats, C arrays (its own, the run's and k[0]: a row of the C array k)
    nf, ny = len(cm.frc_names), y.shape[0]
    k, vec, pen = np.zeros((7, ny)), np.zeros(ny), np.zeros(nf)
    out_y, out_e, out_lam = np.zeros((2, ny)), np.zeros((2, nf, L.N_EO)), np.zeros((2, cm.m))
    i0, f0, yes = np.int64(0), 0.0, True
    calls = {"projection": [(project, (f0, y, cm.model, state, work, np.int64(3)))],
             "forces": [(forces, (f0, q_arg, y[cm.n:], md.mass, md.gravity, md.ftype, md.fint, md.fflt, md.cams,
                                  in_contact, v_imp, psi_f, md.ctype, md.cint, md.cflt, md.crow, lam_prev,
                                  md.modal_w, md.modal_z, md.phi_tab, md.plant_p, work[4], work[5], md.laws))],
             "right_hand_side": [(accelerations, (f0, y, cm.model, state, work, np.zeros_like(y)))],
             "step_events": [(fint_is_contact, (cm.model, i0)),
                             (_onset_fraction, (f0,) * 5), (_crossing_rate, (f0,) * 5),
                             (first_onset_fraction, (cm.model, state, work, pen, pen, f0)),
                             (_dense_state, (f0, f0, k, y, y, y, y, y)),
                             (_write_sample, (i0, y, work[5], work[6], out_y, out_e, out_lam)),
                             (rejected_step_size, (f0, f0)), (onset_cut_size, (f0, f0)),
                             (next_step_size, (f0, f0, f0, yes, f0)), (record_step_size, (np.zeros(7), f0)),
                             (save_resume, (vec, f0, f0, f0, f0, yes, i0, i0, i0, f0, i0, vec, k[0], pen, pen, pen)),
                             (load_resume, (vec, vec, k[0], pen, pen, pen))],
             "step_forces": [(_step_force_bound, (cm.model, i0) + (f0,) * 6),
                             (_interior_peak, (cm.model, i0) + (f0,) * 6),
                             (record_contacts, (f0, f0, f0, f0, cm.model, state, work, pen, pen, pen, pen,
                                                np.zeros((nf, L.N_FIRST)), pen))]}
    out = {}
    for part in parts:
        c0 = time.process_time()
        for fn, args in calls[part]:
            fn.compile(tuple(typeof(a) for a in args))
        out[part] = time.process_time() - c0
    return out


def simulate_mechanism(spec: MechanismSpec, duration: float | None = None, rtol: float | None = None,
                       output_step: float | None = None, max_step: float | None = None,
                       y0: np.ndarray | None = None, max_steps: int | None = None,
                       initial_perturbation: "InitialPerturbation | RandomInitialPerturbation | None" = None,
                       series: str = "whole", specialised: bool | None = None) -> MultibodyResult:
    """Simulate a mechanism description; statistics over whole driver revolutions after the first.

    Parameters
    ----------
    spec : MechanismSpec
        The mechanism; ``spec.simulation`` gives the defaults of the arguments below.
    duration, rtol, output_step, max_step : float, optional
        Simulated time (s), relative tolerance, spacing of the written series (s), largest step (s).
    y0 : ndarray, optional
        Initial state (positions then velocities; m, rad; m/s, rad/s); default: assembled with the clearance
        joints centred.
    max_steps : int, optional
        Step budget of the run (accepted + rejected integrator steps); default
        :func:`default_step_budget` (``duration / 1e-6 s``, at least 200 000).  The run stops with a
        :class:`~berryshaker.errors.SimulationError` when it is spent (checked by the compiled integrator at
        every step).
    initial_perturbation : InitialPerturbation or RandomInitialPerturbation, optional
        Start from a perturbed state: clearance joints off centre, drivers turned (with ``y0`` only the
        driver turn applies).  A random one is drawn for ``spec`` from its seed.
    series : {"whole", "statistics"}
        What the written series cover (:data:`SERIES`): the whole run, or only the statistics window (the
        initial state, then the samples of the whole grid from ``stats_from`` on; the first revolution's
        start-up is not written).  The trajectory, peaks, impact counts and every sample in the window are
        bitwise those of a "whole" run (the steps do not depend on the output grid), so the statistics are too;
        a sweep that keeps only the summary saves the start-up's samples (about 4 % of a harvester run).
    specialised : bool, optional
        Integrate with the kernel specialised to this mechanism's structure
        (:func:`berryshaker.multibody.specialised.specialised_integrator`): bitwise the same results, about a
        third less time per step (a quarter per harvester run), and 10-20 s of compilation the first time a
        structure is run on a machine (cached on disk after that); False: the generic kernel.  Default:
        ``spec.simulation.specialised``, whose default (None) takes the specialised kernel when this machine has
        compiled it for the structure already (:func:`integrator`).

    Returns
    -------
    MultibodyResult
        The run: written series (SI), peaks (N), first impacts, statistics.


    Raises
    ------
    ConfigError
        Non-positive duration or output step, more than :data:`MAX_OUTPUT_SAMPLES` output samples, or an
        unknown ``series``.
    SimulationError
        The integrator gave up, or the step budget was spent.
    """
    run = prepare_run(spec, duration, rtol, output_step, max_step, y0, max_steps, initial_perturbation, series)
    cm, nf = run.cm, len(run.cm.frc_names)
    integrate = resumable(integrator(cm, run.specialised if specialised is None else specialised))
    key = _argument_types(run)
    if key is not None:
        key = (integrate, key)
    if key is None or key not in _WARM:  # None: types this process cannot key; warm up every time
        # compile (or load from the numba cache) outside the timed region: once per process and argument types
        s2, w2 = _state_and_work(cm)
        call_compiled(integrate, run.y.copy(), run.t_out[:2] * 1e-9, cm.model, s2, w2, run.rtol, run.atol,
                      run.max_step, 0.0, np.zeros((2, 2 * cm.n)), np.zeros((2, nf, L.N_EO)), np.zeros((2, cm.m)),
                      np.zeros(nf), np.zeros((nf, L.N_FIRST)), np.zeros(L.N_INFO),
                      np.zeros(L.resume_size(2 * cm.n, nf)))
        if key is not None:
            _WARM.add(key)
    t0 = time.perf_counter()
    integrate_in_chunks(integrate, run)
    wall = time.perf_counter() - t0
    if integrate is not kernel.integrate_resumable:
        mark_compiled(cm.model, cm.n, integrate)  # compiled and cached: later runs of the structure take it
    return finish_run(run, wall)


def resumable(integrate):
    """The resumable form of a compiled integrator (``kernel.integrate`` or a specialised module's): the
    ``integrate_resumable`` beside it, which :func:`integrate_in_chunks` calls.

    Parameters
    ----------
    integrate : numba dispatcher
        ``kernel.integrate`` or a specialised module's ``integrate``.

    Returns
    -------
    numba dispatcher
        Its ``integrate_resumable``.
    """
    return getattr(integrate, "py_func", integrate).__globals__["integrate_resumable"]


def integrate_in_chunks(integrate, run: "PreparedRun", chunk_steps: int | None = None) -> None:
    """Run the compiled integrator ``integrate`` (``kernel.integrate_resumable`` or a specialised module's,
    :func:`resumable`) on ``run``'s arrays in chunks of ``chunk_steps`` steps (its ``resume`` argument), back in Python between them, so that Ctrl-C
    (KeyboardInterrupt) stops a long run within a chunk's time instead of after the whole run (numba's compiled
    code does not see signals).  The step sequence, and so every result, is bitwise that of one call; the step
    budget (``run.budget``, status 4) counts over the whole run.  Leaves the final status in ``run.info``.
    ``chunk_steps``: default :data:`CHUNK_STEPS`.

    Parameters
    ----------
    integrate : numba dispatcher
        The integrator (:func:`integrator`).
    run : PreparedRun
        A run set up by :func:`~berryshaker.multibody.engine.prepare_run`.
    chunk_steps : int, optional
        Steps per compiled call (default :data:`CHUNK_STEPS`).
    """
    cm = run.cm
    chunk_steps = CHUNK_STEPS if chunk_steps is None else int(chunk_steps)
    resume = np.zeros(L.resume_size(run.y.shape[0], len(cm.frc_names)))
    while True:
        run.info[L.INFO_ACCEPTED] = run.budget  # the kernel stops (status 4) when accepted + rejected steps reach it
        run.info[L.INFO_T_FAIL] = 0.0  # written by a failure (and by a pause, which is none)
        resume[L.RS_LIMIT] = resume[L.RS_ACC] + resume[L.RS_REJ] + chunk_steps
        call_compiled(integrate, run.y, run.t_out, cm.model, run.state, run.work, run.rtol, run.atol, run.max_step,
                      run.stats_from, run.out_y, run.out_e, run.out_lam, run.peaks, run.first, run.info, resume)
        if int(run.info[L.INFO_STATUS]) != L.STATUS_PAUSED:  # a chunk's end, resumable
            return


def integrator(cm: CompiledMechanism, specialised: bool | None = None):
    """The compiled integrator of ``cm``'s runs: the generic ``kernel.integrate``, or with ``specialised`` the one
    written for its structure (:mod:`berryshaker.multibody.specialised`; same signature, bitwise the same
    results).  ``specialised=None`` (a run left to choose): as the environment variable ``BERRYSHAKER_KERNEL`` says
    (:func:`berryshaker.compiled_cache.kernel_choice`),
    by default ("auto") the structure's own when this machine has compiled it already
    (:func:`berryshaker.multibody.specialised.is_compiled`; a load, not a compilation), else the generic one.

    Parameters
    ----------
    cm : CompiledMechanism
        The compiled mechanism.
    specialised : bool, optional
        The kernel specialised to the structure (True), the generic one (False), or as
        :func:`berryshaker.compiled_cache.resolve_kernel` decides (None).

    Returns
    -------
    numba dispatcher
        The compiled ``integrate`` to call.
    """
    if specialised is None:
        choice = kernel_choice()
        specialised = is_compiled(cm.model, cm.n) if choice == "auto" else choice == "specialised"
    if not specialised:
        return kernel.integrate

    try:
        return specialised_integrator(cm.model, cm.n, cm.m)
    except OSError as exc:  # no writable folder for the generated source: the generic kernel, same results
        warnings.warn(f"berryshaker: the specialised kernel could not be written ({exc}); running the generic one "
                      "(the same results, slower)", RuntimeWarning, stacklevel=2)
        return kernel.integrate


@dataclass
class PreparedRun:
    """Everything one compiled integration needs (:func:`prepare_run`) and fills (outputs, peaks, info).

    Attributes
    ----------
    cm : CompiledMechanism
        The compiled mechanism.
    state, work : tuple
        The carried state and the work arrays (:mod:`berryshaker.multibody.dynamics`).
    y : numpy.ndarray
        Initial state (m, rad; m/s, rad/s).
    t_out : numpy.ndarray
        Output times (s).
    rtol : float
        Relative tolerance (dimensionless).
    atol : numpy.ndarray
        Absolute tolerance per state (m, rad; m/s, rad/s).
    max_step : float
        Largest step (s).
    stats_from : float
        Start of the statistics window (s).
    budget : int
        Step budget (accepted plus rejected steps).
    duration : float
        Simulated time (s).
    out_y, out_e, out_lam : numpy.ndarray
        The written series: states (SI), element outputs (``layout.EO_*``, SI), multipliers (N, N m).
    peaks : numpy.ndarray
        Largest |normal force| of each element (N).
    first : numpy.ndarray
        First contact of each element (``layout.FIRST_*``: s, m/s, N, flag, count).
    info : numpy.ndarray
        The integrator's statistics (``layout.INFO_*``: counts, time s, status, residual m).
    specialised : bool or None
        The kernel asked for (None: specialised when compiled).
    """

    cm: CompiledMechanism
    state: tuple
    work: tuple
    y: np.ndarray
    t_out: np.ndarray
    rtol: float
    atol: np.ndarray
    max_step: float
    stats_from: float
    budget: int
    duration: float
    out_y: np.ndarray
    out_e: np.ndarray
    out_lam: np.ndarray
    peaks: np.ndarray
    first: np.ndarray
    info: np.ndarray
    specialised: bool | None = None  # spec.simulation.specialised: the structure's own kernel (None: if compiled)


def prepare_run(spec: MechanismSpec, duration: float | None = None, rtol: float | None = None,
                output_step: float | None = None, max_step: float | None = None, y0: np.ndarray | None = None,
                max_steps: int | None = None,
                initial_perturbation: "InitialPerturbation | RandomInitialPerturbation | None" = None,
                series: str = "whole") -> PreparedRun:
    """Check the arguments of :func:`simulate_mechanism` (same meaning and defaults), compile the description,
    assemble the initial state and allocate the arrays of one integration.

    Parameters
    ----------
    spec : MechanismSpec
        The mechanism description.
    duration : float, optional
        Simulated time (s).
    rtol : float, optional
        Relative tolerance (dimensionless).
    output_step : float, optional
        Spacing of the written series (s).
    max_step : float, optional
        Largest step (s).
    y0 : numpy.ndarray, optional
        Initial state (m, rad; m/s, rad/s).
    max_steps : int, optional
        Step budget (accepted plus rejected steps).
    initial_perturbation : InitialPerturbation or RandomInitialPerturbation, optional
        A perturbed start.
    series : {'whole', 'statistics'}
        What the written series cover.

    Returns
    -------
    PreparedRun
        The compiled mechanism, initial state and allocated arrays (SI).
    """
    if series not in SERIES:
        raise ConfigError(f"series must be one of {', '.join(repr(k) for k in SERIES)} (what the written series "
                          f"cover), got {series!r}")
    sim = spec.simulation
    duration = sim.duration if duration is None else duration
    rtol = sim.rtol if rtol is None else rtol
    output_step = sim.output_step if output_step is None else output_step
    max_step = sim.max_step if max_step is None else max_step
    n_out = check_output_samples(duration, output_step,
                                 "simulate a shorter time (fewer revolutions) or write a coarser output_step")
    budget = default_step_budget(duration) if max_steps is None else int(max_steps)
    if budget < 1:
        raise ConfigError(f"max_steps must be >= 1, got {max_steps}")
    pert = None if initial_perturbation is None else initial_perturbation.for_spec(spec)
    if pert is not None:
        spec = pert.shifted_drivers(spec)
    cm = compile_mechanism(spec)
    state, work = _state_and_work(cm)
    if y0 is not None:
        y = np.array(y0, float)
    else:
        y = initial_state(spec) if pert is None else pert.assemble(spec)
    t_out = np.linspace(0.0, duration, n_out)
    nf = len(cm.frc_names)
    # absolute tolerances: positions rtol x 1 mm, velocities rtol x the spec's velocity scale (SimulationSpec)
    atol = np.concatenate([np.full(cm.n, POSITION_SCALE * rtol), np.full(cm.n, sim.velocity_scale * rtol)])
    probe_modes = spec.plant.probe_modes if spec.plant is not None else 0
    if cm.n > cm.n_base or probe_modes:
        rtol, atol = _auxiliary_tolerances(cm, rtol, atol, probe_modes)
    stats_from = 0.0
    if cm.period is not None and duration >= 2 * cm.period:
        stats_from = cm.period
    if series == "statistics" and stats_from > 0.0:
        # the start state (the kernel writes sample 0 before the first step), then the whole run's grid from the
        # sample before the first one the statistics select (the same points, so the same samples; the one before
        # keeps a window snapped to the nearest sample, as the energy audit's, where a whole run has it)
        i0 = max(1, int(np.searchsorted(t_out, stats_from - 1e-12)) - 1)
        t_out = np.concatenate([t_out[:1], t_out[i0:]])
        n_out = t_out.shape[0]
    return PreparedRun(cm, state, work, y, t_out, float(rtol), atol, float(max_step), stats_from, budget,
                       float(duration), np.zeros((n_out, 2 * cm.n)), np.zeros((n_out, nf, L.N_EO)),
                       np.zeros((n_out, cm.m)), np.zeros(nf), np.zeros((nf, L.first_columns(duration - stats_from))),
                       np.zeros(L.N_INFO),
                       sim.specialised)


def finish_run(run: PreparedRun, wall: float) -> MultibodyResult:
    """The result of an integration of :func:`prepare_run`'s arrays, or the SimulationError its status means.

    Parameters
    ----------
    run : PreparedRun
        A run set up by :func:`~berryshaker.multibody.engine.prepare_run`.
    wall : float
        Wall time of the integration (s).

    Returns
    -------
    MultibodyResult
        The result.
    """
    info, duration, budget = run.info, run.duration, run.budget
    if int(info[L.INFO_STATUS]) == L.STATUS_BUDGET:
        raise SimulationError(
            f"multibody simulation stopped at t = {info[L.INFO_T_FAIL]:.6g} s of {duration:.6g} s: it used "
            f"{int(info[L.INFO_ACCEPTED] + info[L.INFO_REJECTED]):,} integrator steps, over its budget of {budget:,} "
            f"(mean step {info[L.INFO_T_FAIL] / max(info[L.INFO_ACCEPTED], 1):.3g} s). The mechanism jams (a guide whose friction self-locks, a joint driven "
            "into a toggle) or the model is far stiffer than intended: check friction coefficients, contact stiffness "
            "and damping (and their units), or simulate fewer revolutions; to allow a longer run pass max_steps")
    status = int(info[L.INFO_STATUS])
    if status != 0:
        why = {L.STATUS_UNDERFLOW: "the step size fell below 1e-14 s (contact too stiff for the tolerance, or a "
                  "singular configuration)",
               L.STATUS_NONFINITE: "the state became non-finite (the constraint matrix is singular: a redundant or "
                  "locked joint?)",
               L.STATUS_PROJECTION: "the constraints could not be satisfied after the step (residual "
                                    f"{info[L.INFO_MAX_RESIDUAL]:.3g})"}[status]
        raise SimulationError(f"multibody simulation gave up at t = {info[L.INFO_T_FAIL]:.6g} s: {why}")
    return MultibodyResult(run.t_out, run.out_y, run.out_e, run.out_lam, run.peaks, run.first, info, wall,
                           run.stats_from, run.cm)
