"""Running any drive's mechanism through the generic multibody engine and summarising it the same way for
every drive (collision force per clearance pair, comb load moments, drive moment)."""

from __future__ import annotations

import math

import numpy as np

from berryshaker.drives import drive_of
from berryshaker.drives.base import HARVESTER_RTOL
from berryshaker.errors import ConfigError
from berryshaker.multibody.engine import MultibodyResult, simulate_mechanism


def _stats_rows(series: list[np.ndarray], sel: np.ndarray, peaks: list[float]) -> list[dict]:
    """Peak (at least ``peaks``), mean, RMS and 95th percentile of |series| over ``sel``, for several series in
    one pass (one row each: every reduction runs along a contiguous row, so the values are those of one series
    at a time, bit for bit)."""
    y = np.abs(np.stack([s[sel] for s in series]))
    top, mean, rms, p95 = y.max(axis=1), y.mean(axis=1), np.sqrt(np.mean(y**2, axis=1)), np.percentile(y, 95, axis=1)
    return [{"peak": float(max(pk, top[i])), "mean": float(mean[i]), "rms": float(rms[i]), "p95": float(p95[i])}
            for i, pk in enumerate(peaks)]


def drive_moment(result: MultibodyResult) -> np.ndarray:
    """Moment on the drive shaft in its direction of rotation (clockwise), N m: the imposed-speed driver's, or with
    a powered driveline the mesh's (drives/powered.py).

    Parameters
    ----------
    result : MultibodyResult
        A harvester run (:func:`simulate_multibody`).

    Returns
    -------
    ndarray
        The moment at each written sample (N m).
    """
    if "drive" in result.compiled.con_names:
        return -result.reaction("drive")
    return -result.element_force("mesh")


def multibody_summary(machine, result: MultibodyResult) -> dict:
    """The JSON of ``simulate --model multibody``: collision force per pair (N), comb load moments (N m), drive
    moment (N m), contact onsets, integrator statistics.  A clearance pair's collision force has, beside the
    statistics of its written series (``peak``: the run's single largest force over every step, an extreme;
    ``mean``, ``rms``, ``p95`` of the samples), the sizing loads of its impacts (:func:`impact_loads_of`:
    ``static_equivalent``, ``fatigue_equivalent``).

    Statistics are over revolutions 2..N (the first is the start-up from the centred joints).  A pair with zero
    clearance reports its ideal joint's reaction force, not a collision force (``pair_state`` says which).
    ``drive_moment_Nm``: the moment the drive applies to its shaft in the direction of rotation; ``mean`` is its
    signed mean over revolutions 2..N (mean drive power / speed), ``mean_abs`` the mean of its magnitude, as in
    the MLSD summary; ``design`` and ``fatigue_equivalent`` the sizing torques (:func:`drive_torque_loads`),
    ``peak`` the run's single largest moment (an extreme).  ``contact_onsets``: impacts per pair (:func:`contact_onsets`), ``contact_onsets_located``
    their total; ``event_cuts``: integrator steps cut back to an onset (the whole run).

    Parameters
    ----------
    machine : MachineBase
        The machine description the run was made from.
    result : MultibodyResult
        The run.

    Returns
    -------
    dict
        The summary (JSON-ready; units in the key names: ``_N``, ``_Nm``, ``_mm``).
    """
    cm = result.compiled
    sel = result.t >= result.stats_from - 1e-12
    n_rev = int(round(result.t[-1] * machine.drive_speed / (2 * math.pi)))
    out = {"model": "multibody", "drive": machine.DRIVE,
           "clearance_mm": {p: v * 1e3 for p, v in machine.clearance_sizes().items()},
           "collision_force_N": {}, "pair_state": {}, "load_moment_Nm": {}, "drive_moment_Nm": {}}
    rows, peaks, where = [], [], []  # every series' statistics in one pass
    for p in machine.pair_names:
        if p in cm.frc_names:
            k = cm.frc_names.index(p)
            rows.append(result.elements[:, k, 0])
            peaks.append(result.peaks[k])
            out["pair_state"][p] = "clearance"
        else:
            rows.append(result.reaction(p))
            peaks.append(0.0)
            out["pair_state"][p] = "ideal joint (reaction force)"
        where.append(("collision_force_N", p))
    for side, name in (("left", "bush_left"), ("right", "bush_right")):
        if name in cm.frc_names:
            rows.append(result.elements[:, cm.frc_names.index(name), 0])
            peaks.append(0.0)
            where.append(("load_moment_Nm", side))
    torque = drive_moment(result)
    rows.append(torque)
    peaks.append(0.0)
    where.append(("drive_moment_Nm", None))
    for (group, name), st in zip(where, _stats_rows(rows, sel, peaks)):
        if name is None:
            out[group] = st
        else:
            out[group][name] = st
    for p in machine.pair_names:
        if out["pair_state"][p] == "clearance":
            out["collision_force_N"][p].update(impact_loads_of(result, p))
    if out["load_moment_Nm"]:  # a run without a plant: the comb's load is the aggregate model (docs/plant.md)
        out["load_model"] = "aggregate (no plant in this run)"
    out["drive_moment_Nm"]["mean_abs"] = out["drive_moment_Nm"]["mean"]
    out["drive_moment_Nm"]["mean"] = float(np.mean(torque[sel]))
    out["drive_moment_Nm"].update(drive_torque_loads(machine, result, torque))
    onsets = contact_onsets(result, machine.pair_names)
    out.update(steps=int(result.info[0]), rejected_steps=int(result.info[1]),
               contact_onsets=onsets, contact_onsets_located=int(sum(onsets.values())),
               event_cuts=int(result.info[2]), wall_time_s=result.wall_time_s,
               revolutions=n_rev, statistics_over=f"revolutions 2..{n_rev}")
    if "mesh" in cm.frc_names and cm.acc_start >= 0:
        from berryshaker.drives.powered import driveline_summary

        shaft = cm.spec.bodies[int(cm.model.fint[cm.frc_names.index("mesh"), 1])].name
        out.update(driveline_summary(result, shaft))
    return out


def drive_torque_loads(machine, result: MultibodyResult, torque: np.ndarray) -> dict[str, float]:
    """The drive shaft's sizing torques over the run's statistics window (:mod:`berryshaker.multibody.drive_loads`):
    ``design`` (the p95 of the per-revolution peaks of |M|) and ``fatigue_equivalent`` ((mean |M|^3)^(1/3)), both
    N m; NaN for a run shorter than one revolution after the start-up.

    Parameters
    ----------
    machine : MachineBase
        The machine description the run was made from (its drive speed, rad/s, sets the revolution).
    result : MultibodyResult
        The run.
    torque : numpy.ndarray
        The drive moment at the run's samples (N m), :func:`drive_moment`.

    Returns
    -------
    dict
        ``design``, ``fatigue_equivalent`` (N m).
    """
    from berryshaker.multibody.drive_loads import design_torque, fatigue_equivalent_torque, revolution_peaks

    sel = result.t >= result.stats_from - 1e-12
    peaks = revolution_peaks(result.t, torque, result.stats_from, 2 * math.pi / machine.drive_speed)
    return {"design": design_torque(peaks), "fatigue_equivalent": fatigue_equivalent_torque(torque[sel])}


def impact_loads_of(result: MultibodyResult, pair: str) -> dict[str, float]:
    """The sizing loads of a clearance pair from its impacts over the run's statistics window
    (:func:`berryshaker.multibody.impacts.impact_loads`): ``static_equivalent`` (the p95 of the impact peaks) and
    ``fatigue_equivalent`` (ISO 281's mean equivalent load of the impact peaks, exponent 3), both N; NaN for a run
    without impacts.

    Parameters
    ----------
    result : MultibodyResult
        The run.
    pair : str
        A clearance pair with its clearance element in the run.

    Returns
    -------
    dict of str to float
        The two loads (N).
    """
    from berryshaker.multibody.impacts import impact_loads

    il = impact_loads([result.contact_episodes(pair)])
    return {"static_equivalent": il.static_equivalent_N, "fatigue_equivalent": il.fatigue_equivalent_N}


def contact_onsets(result: MultibodyResult, pairs) -> dict[str, int]:
    """Impacts per clearance pair over the statistics window (:meth:`MultibodyResult.contact_onsets`): the
    integrator's located contact onsets closing at 1 mm/s or faster, counted on every accepted step, so
    independent of ``output_step``; not the engine's count of step cut-backs to an onset (``event_cuts``), which
    counts every refinement.  An ideal joint (zero clearance) has none.

    Parameters
    ----------
    result : MultibodyResult
        The run.
    pairs : iterable of str
        Clearance pair names.

    Returns
    -------
    dict pair -> int
        Impacts per pair.
    """
    return result.contact_onsets(list(pairs))


def simulate_multibody(machine, clearance: dict[str, float] | None = None, revolutions: int = 2,
                       rtol: float = HARVESTER_RTOL, output_step: float = 1e-4,
                       driveline: str | None = None, initial_perturbation=None,
                       series: str = "whole", specialised: bool | None = None) -> tuple[MultibodyResult, dict]:
    """Simulate a machine's drive in the multibody engine.

    Parameters
    ----------
    machine : MachineBase
        Any drive's machine description.
    clearance : dict, optional
        Clearance size (m) per pair (:doc:`/nomenclature`); a pair left out keeps the description's.
    revolutions : int
        Drive-shaft revolutions (>= 2; statistics exclude the first).
    rtol : float
        Relative tolerance of the integrator (default :data:`berryshaker.drives.base.HARVESTER_RTOL`, chosen by
        convergence of the summary's statistics).
    output_step : float
        Spacing of the written series (s); peaks are taken over every step.
    driveline : {"imposed", "powered"}, optional
        Override of ``[driveline] mode``: "powered" turns the drive shaft through the driveline
        (drives/powered.py; the summary then has cam speed, ripple, input power and energy lost per revolution
        in each joint); default: as the machine description says (imposed speed without a ``[driveline]``).
    initial_perturbation : InitialPerturbation or RandomInitialPerturbation, optional
        Start the mechanism off its centred, unturned state (berryshaker.multibody.perturbation): the
        replicates whose spread measures how much of a difference is impact-sequence noise.
    series : {"whole", "statistics"}
        What the result's written series cover (:func:`berryshaker.multibody.engine.simulate_mechanism`):
        "statistics" skips the first revolution's samples, which no statistic reads; the summary is the same
        bitwise.  Sweeps and the study's runs, which keep only the summary, use it.
    specialised : bool, optional
        Integrate with the kernel specialised to the mechanism's structure (bitwise the same results, ~1/4 less
        time per harvester run, ~10-20 s of compilation once per structure and machine;
        :mod:`berryshaker.multibody.specialised`); False: the generic kernel; None (default): the specialised
        one when this machine has compiled it for the structure already.

    Returns
    -------
    (MultibodyResult, dict)
        The full result and :func:`multibody_summary`.
    """
    if revolutions < 2:
        raise ConfigError("--revolutions must be >= 2 (statistics exclude the first revolution)")
    from berryshaker.drives.powered import with_driveline_mode

    machine = with_driveline_mode(machine.with_clearances(clearance), driveline)
    spec = drive_of(machine).mechanism(machine, revolutions=revolutions)
    result = simulate_mechanism(spec, rtol=rtol, output_step=output_step, initial_perturbation=initial_perturbation,
                                series=series, specialised=specialised)
    return result, multibody_summary(machine, result)
