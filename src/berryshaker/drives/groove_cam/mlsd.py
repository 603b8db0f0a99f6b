"""The study's MLSD (massless link + spring + damper) clearance model of the harvester drive, eq. 4-12,
in the consistent form derived in ``docs/mlsd.md``.

Summary of the formulation (details, symbols and departures from the printed equations in the doc):

* The cam turns at constant speed omega (phi = omega t).  The driven chain has four generalised
  coordinates q = (x, theta_D, u, theta_E): push-rod displacement (m), left comb angle (rad), axial
  displacement of the connecting rod from its ideal position (m), right comb angle (rad).
* Each clearance is a massless link along the line of action of its joint force (the study's
  assumption that the force direction is that of the clearance-free mechanism, refs. 50-52): the
  groove normal for A, the slot normal for B, the coupler axis CF for C and F.  The link's signed
  length d_i(q, t) is an exact function of the coordinates; the joint is open while |d_i| <= c_i and
  the spring-damper of eq. 8 acts on the deformation |d_i| - c_i beyond it (compression only).
  c_i = half the free travel for point-line pairs (size / 2) and the radial clearance for revolute pairs.
* Equations of motion: M q'' = sum_i f_i dd_i/dq - (friction, comb load moments), with
  M = diag(m2, m3 l3^2/3, m4, m5 l5^2/3); integrated with an adaptive Dormand-Prince 5(4) scheme
  compiled with numba.  Bearing reactions F_G, F_H, the friction in the push-rod guide, the cam drive
  moment M(t) and the comb load moments T_l, T_r follow from the same forces (eq. 9-12).
* Contact law of each link: the pair's resolved law (:meth:`~berryshaker.drives.base.MachineBase.pair_contact`),
  the same K, n and hysteresis damping as the multibody model (onsets located, see :func:`integrate`); the
  viscous laws (``mlsd``, and ``impact`` as 0.1.0 files give it) are the eq. 8 spring-damper K r^n + C r'.
* With zero clearance the links are stiff springs and the model tends to the ideal mechanism's inverse
  dynamics as they stiffen (tested against an independent Newton-Euler calculation); at finite stiffness
  the chain rings after the cam law's jerk steps (docs/mlsd.md sec. 4).

The compiled core (layouts, link forces, equations of motion, integrator) is
:mod:`berryshaker.drives.groove_cam.mlsd_kernel`; its public names are importable from here too.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from berryshaker.drives.groove_cam.kinematics import (
    G_OMEGA,
    geometry_vector,
    ideal_state,
    require_buildable,
)
from berryshaker.drives.groove_cam.machine import GrooveCamMachine as Machine
from berryshaker.drives.groove_cam.mlsd_kernel import (  # noqa: F401  (the kernel's names, importable from here)
    EVENT_TOL,
    FORM_HERTZ,
    FORM_HYSTERESIS,
    FORM_SPRING_DAMPER,
    IDEAL_LINK_DAMPING,
    LAW_FORMS,
    N_P,
    N_PAIR,
    N_R,
    N_S,
    P_PAIR0,
    PAIR_NAMES,
    R_DA,
    R_FA,
    R_FB,
    R_FC,
    R_FF,
    R_M,
    R_RG,
    R_RH,
    R_TL,
    R_TR,
    RESULT_COLUMNS,
    S_Y,
    _backlash,
    evaluate,
    integrate,
    parameter_vector,
)
from berryshaker.errors import ConfigError, SimulationError

#: integrator steps (accepted + rejected) per call of the compiled kernel (:func:`integrate`): the run returns to
#: Python between chunks, where Ctrl-C and the step budget are seen; ~0.1-0.2 s of a quiet core, and a
#: reference run (3 revolutions, ~40 000 steps) is one chunk.  Chunking does not change the step sequence.
CHUNK_STEPS = 50_000
#: default step budget per second of simulated motion (accepted + rejected steps): a mean step of 1 us, as the
#: multibody engine's.  The reference machine needs ~27 000 per second (mean step 37 us), zero clearance ~23 000
STEPS_PER_SECOND = 1_000_000
#: a run is never refused a budget below this many steps
MIN_STEP_BUDGET = 200_000


@dataclass
class MLSDResult:
    """Time series and statistics of one MLSD simulation (SI).

    Attributes
    ----------
    t : ndarray
        (n,) output times (s).
    state : ndarray
        (n, 8) x (m), theta_D (rad), u (m), theta_E (rad) and their rates (m/s, rad/s).
    results : ndarray
        (n, N_R) results at the output times (SI; :data:`RESULT_COLUMNS`).
    peaks : ndarray
        (N_R,) max |.| over accepted steps after the first revolution (SI).
    clearance : dict
        Clearance size (m) per pair (:doc:`/nomenclature`).
    revolutions : int
        Cam revolutions simulated.
    steps : int
        Accepted integrator steps.
    rejected : int
        Rejected integrator steps.
    wall_time_s : float
        Wall time of the integration (s).
    stats_from : float
        Time from which statistics are taken (s): the end of the first revolution.
    machine : GrooveCamMachine
        The machine simulated, its clearances set.
    onsets : dict
        Contact onsets per pair after the first revolution, on every accepted step.
    event_cuts : int
        Integrator steps cut back to a contact onset (every revolution).
    """

    t: np.ndarray
    state: np.ndarray  # (n, 8): x, theta_D, u, theta_E and their rates
    results: np.ndarray  # (n, N_R)
    peaks: np.ndarray  # max |.| over accepted steps after the first revolution
    clearance: dict[str, float]
    revolutions: int
    steps: int
    rejected: int
    wall_time_s: float
    stats_from: float
    machine: Machine = field(repr=False)
    onsets: dict = field(default_factory=dict)  # contact onsets per pair after the first revolution
    event_cuts: int = 0  # integrator steps cut back to a contact onset (every revolution)

    def series(self, name: str) -> np.ndarray:
        """One written time series.

        Parameters
        ----------
        name : str
            A key of :data:`RESULT_COLUMNS`.

        Returns
        -------
        ndarray
            (n,) its values, in the unit :data:`RESULT_COLUMNS` gives (SI).
        """
        return self.results[:, RESULT_COLUMNS[name][0]]

    def series_onsets(self) -> dict[str, int]:
        """Contact onsets per pair over revolutions 2..N: transitions of the written series from |d_i| <= c_i
        (open) to |d_i| > c_i (in contact); a lower bound (an episode between two samples is missed).  The multibody
        summary counts impacts in its integrator instead (:func:`berryshaker.drives.simulation.contact_onsets`).

        Returns
        -------
        dict
            Onsets per pair name.
        """
        sel = self.t >= self.stats_from - 1e-12
        out = {}
        for k, name in enumerate(PAIR_NAMES):
            pair = self.machine.clearance[name]
            c = pair.size * (0.5 if pair.kind != "pin-in-bore" else 1.0)
            touch = np.abs(self.results[sel, R_DA + k]) > c
            out[name] = int(np.count_nonzero(touch[1:] & ~touch[:-1]))
        return out

    def summary(self) -> dict:
        """The JSON of ``berryshaker simulate --model mlsd`` (statistics over revolutions 2..N).

        ``drive_moment_Nm``: the moment the drive applies to the cam in its direction of rotation, eq. 9;
        ``mean`` its signed mean over revolutions 2..N (as the multibody summary), ``mean_abs`` the mean of its
        magnitude.  ``contact_onsets``: impacts per pair on the written series (:meth:`series_onsets`).

        Returns
        -------
        dict
            JSON-compatible: forces in N, moments in N m, clearances in mm, power in W, counts.
        """
        sel = self.t >= self.stats_from - 1e-12
        pk = self.peaks

        def stats(idx):
            y = np.abs(self.results[sel, idx])
            return {"peak": float(max(pk[idx], y.max())), "mean": float(y.mean()),
                    "rms": float(np.sqrt(np.mean(y**2))), "p95": float(np.percentile(y, 95))}

        out = {
            "model": "mlsd",
            "clearance_mm": {k: v * 1e3 for k, v in self.clearance.items()},
            "revolutions": self.revolutions,
            "statistics_over": f"revolutions 2..{self.revolutions}",
            "collision_force_N": {n: stats(i) for n, i in zip(PAIR_NAMES, (R_FA, R_FB, R_FC, R_FF))},
            "load_moment_Nm": {},
            "drive_moment_Nm": {},
            "bearing_reaction_N": {"G": stats(R_RG), "H": stats(R_RH)},
            "steps": self.steps,
            "rejected_steps": self.rejected,
            "wall_time_s": self.wall_time_s,
        }
        for side, idx in (("left", R_TL), ("right", R_TR)):
            s = stats(idx)
            out["load_moment_Nm"][side] = {"peak": s["peak"], "rms": s["rms"], "mean": s["mean"]}
        s = stats(R_M)
        # drive moment: the moment the drive applies to the cam in its direction of rotation (N m), statistics
        # over revolutions 2..N; ``mean`` is signed (the mean drive power / speed), as in the multibody summary
        m_series = self.results[sel, R_M]
        out["drive_moment_Nm"] = {"peak": s["peak"], "rms": s["rms"], "mean": float(np.mean(m_series)),
                                  "mean_abs": s["mean"]}
        out["drive_moment_Nm"]["mean_power_W"] = float(np.mean(m_series) * self.machine.cam.speed)
        # impacts per pair on the written series: transitions from open to
        # in contact over revolutions 2..N (a lower bound: an episode between two samples is missed) ...
        out["contact_onsets"] = self.series_onsets()
        out["contact_onsets_located"] = int(sum(out["contact_onsets"].values()))
        # ... and on every accepted integrator step (what the written series misses)
        out["contact_onsets_every_step"] = dict(self.onsets)
        out["event_cuts"] = self.event_cuts
        return out


#: a chunk of :data:`CHUNK_STEPS` steps whose mean step is below this (s) has a collapsed step size (the reference
#: machine's mean step is ~37 us); with the push rod stuck behind its cam (:func:`_jammed`) the drive is jammed
JAM_MEAN_STEP = 1e-7
#: the push rod is stuck behind its cam when it lags the cam's position by more than the clearance at A plus this
#: (m; far beyond a steel contact's deflection, ~0.02 mm at the reference's peak force) ...
JAM_LAG = 1e-4
#: ... and moves at less than this fraction of the speed the cam drives it at
JAM_SPEED_RATIO = 0.1


def default_step_budget(duration: float) -> int:
    """The step budget (accepted + rejected steps) of an MLSD run: :data:`STEPS_PER_SECOND` per second of
    motion, at least :data:`MIN_STEP_BUDGET`.

    Parameters
    ----------
    duration : float
        Seconds of motion (s).

    Returns
    -------
    int
        The budget (steps).
    """
    return max(MIN_STEP_BUDGET, int(math.ceil(STEPS_PER_SECOND * duration)))


def _jammed(st: np.ndarray, g: np.ndarray, p: np.ndarray, t: float) -> tuple[bool, float, float, float]:
    """(stuck, lag (m), push-rod speed (m/s), the cam's speed (m/s)) at the saved state ``st`` at time ``t``:
    stuck when the push rod lags the cam beyond the clearance at A by more than :data:`JAM_LAG` and moves at less
    than :data:`JAM_SPEED_RATIO` of the cam's speed while the cam moves it."""
    _ok, s, v, *_rest = ideal_state(g[G_OMEGA] * t, g)
    x, xd = st[S_Y], st[S_Y + 4]
    lag = s - x
    stuck = abs(lag) > p[P_PAIR0] + JAM_LAG and abs(v) > 1e-3 and abs(xd) < JAM_SPEED_RATIO * abs(v)
    return stuck, lag, xd, v


def _stalled_message(machine: Machine, st: np.ndarray, g: np.ndarray, p: np.ndarray, info: np.ndarray,
                     t_start: float, t_end: float, budget: int, why: str) -> str:
    """The message of a run stopped for its step budget (``why="budget"``) or for a jammed drive (``"jam"``):
    what happened, where the drive stood, and what to change."""
    from berryshaker.drives.groove_cam.kinematics import self_locking_limit

    t = float(info[2])
    done = t - t_start
    taken = int(info[0] + info[1])
    stuck, lag, xd, v = _jammed(st, g, p, t)
    if why == "budget":
        head = (f"MLSD simulation stopped at t = {done:.6g} s of {t_end:.6g} s: the integrator needed more than "
                f"{budget:,} steps (mean step {done / max(taken, 1):.3g} s; the budget is {STEPS_PER_SECOND:,} steps "
                "per second of motion)")
    else:
        head = (f"MLSD simulation stopped at t = {done:.6g} s of {t_end:.6g} s: the step size collapsed (the last "
                f"{CHUNK_STEPS:,} steps advanced less than {JAM_MEAN_STEP * CHUNK_STEPS:.3g} s)")
    if stuck:
        lock = self_locking_limit(machine)
        mu = machine.push_rod.friction_coefficient
        return (f"{head}.  The drive jams: the push rod lags its cam by {abs(lag) * 1e3:.3g} mm (clearance at A "
                f"{p[P_PAIR0] * 1e3:.3g} mm) and moves at {xd:.3g} m/s where the cam drives it at {v:.3g} m/s.  "
                f"push_rod.friction_coefficient = {mu:g}, the self-locking limit of this geometry "
                f"{lock.mu_limit:.3g} (pressure angle {math.degrees(lock.pressure_angle):.1f} deg at cam angle "
                f"{math.degrees(lock.cam_angle):.1f} deg): lower the guide friction, lengthen the guide "
                "(push_rod.bearing_G_x, bearing_H_x) or reduce the pressure angle (a larger base circle, a longer rise "
                "or return angle)")
    return (f"{head}: the drive jams or the tolerance is too tight for its contacts.  Check the contact stiffness "
            "and damping (and their units), loosen rtol or simulate fewer revolutions; to allow a longer run pass "
            "max_steps")


def simulate_mlsd(machine: Machine, clearance: dict[str, float] | None = None, revolutions: int = 3,
                  output_step: float = 1e-4, rtol: float = 1e-7, h_max: float = 2e-4,
                  start_angle: float = 0.0, max_steps: int | None = None) -> MLSDResult:
    """Simulate the MLSD clearance model of the harvester drive.

    Parameters
    ----------
    machine : Machine
        The groove-cam machine.
    clearance : dict, optional
        Clearance size (m) per pair (:doc:`/nomenclature`); a pair left out keeps the machine's (validated by
        :meth:`~berryshaker.drives.base.MachineBase.with_clearances`).
    revolutions : int
        Cam revolutions to simulate (>= 2); statistics use revolutions 2..N (the first is start-up).
    output_step : float
        Time step of the written series (s); peaks are taken over every integrator step.
    rtol : float
        Relative tolerance of the adaptive integrator (1).
    h_max : float
        Largest integrator step (s).
    start_angle : float
        Cam angle at the start (rad; the mechanism starts there in its ideal state, joints centred): a turned
        start, the MLSD's replicate (the impact sequence is chaotic, so its statistics are one draw).  The run
        covers ``revolutions`` whole revolutions from there (times from start_angle / omega, taken mod one
        revolution), the statistics the last ``revolutions - 1``.
    max_steps : int, optional
        Step budget of the run (accepted + rejected integrator steps); default :func:`default_step_budget`.

    Returns
    -------
    MLSDResult
        The time series, peaks and statistics of the run.

    Raises
    ------
    SimulationError
        The integrator gave up; the step budget was spent; or the drive jammed (a chunk of :data:`CHUNK_STEPS`
        steps advanced less than :data:`JAM_MEAN_STEP` per step with the push rod stuck behind its cam).  The message says which and,
        for a drive that does not follow its cam, how far the push rod lags and the self-locking limit of the
        guide (:func:`~berryshaker.drives.groove_cam.kinematics.self_locking_limit`).
    """
    if not math.isfinite(start_angle):
        raise ConfigError(f"start_angle={start_angle!r}: give a finite cam angle (rad)")
    if revolutions < 2:
        raise ConfigError("--revolutions must be >= 2 (statistics exclude the first revolution)")
    machine = machine.with_clearances(clearance)
    sizes = machine.clearance_sizes()
    require_buildable(machine)
    g = geometry_vector(machine)
    p = parameter_vector(machine)
    period = 2 * math.pi / machine.cam.speed
    t_end = revolutions * period
    n_out = int(round(t_end / output_step)) + 1
    phi0 = start_angle % (2 * math.pi)
    t_start = phi0 / machine.cam.speed  # the kernels take the cam angle as omega t
    t_out = t_start + np.linspace(0.0, t_end, n_out)
    # start at cam angle phi0 on the ideal mechanism, joints centred, ideal velocities
    ok, s, v, a, thd, wd, ad, th4, w4, a4, the, we, ae = ideal_state(phi0, g)
    y0 = np.array([s, thd, 0.0, the, v, wd, 0.0, we])
    atol = np.array([1e-10, 1e-9, 1e-10, 1e-9, 1e-6, 1e-5, 1e-6, 1e-5])
    out_y = np.zeros((n_out, 8))
    out_r = np.zeros((n_out, N_R))
    peaks = np.zeros(N_R)
    info = np.zeros(5)
    onsets = np.zeros(4)
    budget = default_step_budget(t_end) if max_steps is None else int(max_steps)
    if budget < 1:
        raise ConfigError(f"max_steps must be >= 1, got {max_steps}")
    # compile (cached on disk after the first run) before timing
    st = np.zeros(N_S)
    st[S_Y:S_Y + 8] = y0
    integrate(t_out[:2], g, p, rtol, atol, h_max, 0.0, np.zeros((2, 8)), np.zeros((2, N_R)), np.zeros(N_R),
              np.zeros(5), np.zeros(4), st.copy(), CHUNK_STEPS)
    t0 = time.perf_counter()
    t_chunk = t_start
    while True:
        # chunks of CHUNK_STEPS steps: Ctrl-C (KeyboardInterrupt) is raised here, between two chunks
        integrate(t_out, g, p, rtol, atol, h_max, t_start + period, out_y, out_r, peaks, info, onsets, st,
                  min(budget, int(info[0] + info[1]) + CHUNK_STEPS))
        if int(info[3]) != 5:
            break
        taken = int(info[0] + info[1])
        if taken >= budget:
            raise SimulationError(_stalled_message(machine, st, g, p, info, t_start, t_end, budget, "budget"))
        if info[2] - t_chunk < JAM_MEAN_STEP * CHUNK_STEPS and _jammed(st, g, p, info[2])[0]:
            raise SimulationError(_stalled_message(machine, st, g, p, info, t_start, t_end, budget, "jam"))
        t_chunk = info[2]
    wall = time.perf_counter() - t0
    status = int(info[3])
    if status != 0:
        why = {1: "the step size fell below 1e-13 s (contact too stiff for the tolerance?)",
               2: "the state became non-finite",
               3: "the linkage cannot assemble"}[status]
        raise SimulationError(f"MLSD simulation gave up at t = {info[2]:.6g} s: {why}")
    return MLSDResult(t=t_out, state=out_y, results=out_r, peaks=peaks, clearance=sizes,
                      revolutions=revolutions, steps=int(info[0]), rejected=int(info[1]),
                      wall_time_s=wall, stats_from=t_start + period, machine=machine,
                      onsets={n: int(v) for n, v in zip(PAIR_NAMES, onsets)}, event_cuts=int(info[4]))
