"""The responses of replicated coupled drive-pasts at one clearance set, as the virtual L9
(:mod:`berryshaker.study.l9`), the calibration, the validation and the harvest-response step read them.

The responses (:data:`HARVEST_RESPONSES`, :func:`load_responses`, :func:`response_units`): harvest indexes and
machine loads.  A clearance set's replicate jobs (:func:`replicate_jobs`: for every start seed, one
:func:`berryshaker.study.runs.replicate_run` per branch class), each start's responses from their outputs
(:func:`start_cells`, :func:`cells_from_outputs`; one start's: ``_cell``), the replicates' stem-force envelopes
(:func:`replicate_envelopes`) and a run's mean with its 95 % interval (:func:`interval`).
"""

from __future__ import annotations

import math

import numpy as np

from berryshaker.harvest.spec import COUPLED_RTOL
from berryshaker.study.runs import replicate_run

#: harvest responses: name -> (key of harvest_indexes, factor to the reported unit, unit, larger is better)
HARVEST_RESPONSES = {
    "efficiency": ("efficiency_kg_min", 1.0, "kg/min", True),
    "ripe_removal": ("ripe_picked_fraction", 100.0, "%", True),
    "unripe": ("unripe_rate_pct", 1.0, "%", False),
    "unripe_shed": ("unripe_shed_fraction", 100.0, "%", False),
    "damage": ("damage_rate_pct", 1.0, "%", False),
}
#: resolution of each harvest response (its reported unit): a mean this small is "none" (sequential replication does
#: not chase a relative target below it; the convergence table calls a response below it negligible)
RESPONSE_RESOLUTION = {"efficiency": 0.01, "ripe_removal": 0.05, "unripe": 0.05, "unripe_shed": 0.05, "damage": 0.05}
#: relative tolerance of the coupled runs (their default; the solver-tolerance check re-runs at a tighter one)
RTOL_RUN = COUPLED_RTOL
#: confidence of the replicated L9's intervals and comparisons
CONFIDENCE = 0.95


def load_responses(pairs) -> list[str]:
    """Names of the machine-load responses: the static-equivalent collision force per pair (the p95 of the impact
    peaks of a start's drive-pasts, :func:`berryshaker.multibody.impacts.static_equivalent_load`), drive torque
    peak and RMS.

    Parameters
    ----------
    pairs : iterable of str
        The machine's clearance pairs.

    Returns
    -------
    list of str
        ``design_force_<pair>`` per pair, then ``drive_torque_peak`` and ``drive_torque_rms``.
    """
    return [f"design_force_{p}" for p in pairs] + ["drive_torque_peak", "drive_torque_rms"]


def response_units(pairs) -> dict[str, str]:
    """Unit of every response of the replicated L9.

    Parameters
    ----------
    pairs : iterable of str
        The machine's clearance pairs.

    Returns
    -------
    dict of str to str
        Response name -> unit: the harvest responses' ("kg/min", "%"), "N" for forces, "N m" for torques.
    """
    return {**{k: v[2] for k, v in HARVEST_RESPONSES.items()}, **{f"design_force_{p}": "N" for p in pairs},
            "drive_torque_peak": "N m", "drive_torque_rms": "N m"}


def _cell(machine, outs: list[dict], pop) -> dict[str, float]:
    """One run's replicate: harvest indexes from its branch classes' envelopes, loads over its drive-pasts.

    Static-equivalent force (``design_force_<pair>``): the p95 of the impact peaks of all the start's drive-pasts
    together (berryshaker.multibody.impacts; a run's single largest force is an extreme, not a response); peak
    torque: the largest over the branch classes' drive-pasts; RMS torque: the RMS over all of them (equal
    durations).
    """
    from berryshaker.multibody.impacts import static_equivalent_load

    from berryshaker.harvest.virtual import harvest_indexes

    h = harvest_indexes(machine, [np.array(o["envelope"]) for o in outs], pop)
    out = {name: scale * float(h[key]) for name, (key, scale, _, _) in HARVEST_RESPONSES.items()}
    for p in machine.pair_names:
        if all(p in o.get("impact_peaks_N", {}) for o in outs):
            out[f"design_force_{p}"] = static_equivalent_load(np.concatenate(
                [np.asarray(o["impact_peaks_N"][p], float) for o in outs]))
    if all("drive_torque_Nm" in o for o in outs):
        out["drive_torque_peak"] = max(o["drive_torque_Nm"]["peak"] for o in outs)
        out["drive_torque_rms"] = math.sqrt(float(np.mean([o["drive_torque_Nm"]["rms"] ** 2 for o in outs])))
    return out


def interval(y, pooled: tuple[float, int] | None = None) -> dict:
    """Mean, replicate standard deviation and 95 % t-interval of the mean of one run's replicates (clipped at 0
    when no replicate is negative: every response of the L9 is a rate, a mass or a magnitude).

    ``pooled`` = (pure-error mean square, its dof) of the whole test: the interval is then
    t(dof) sqrt(MS_PE / n), the error model of the ANOVA (the run's own SD, with n - 1 dof, is still
    reported as ``sd``); without it t(n - 1) sd / sqrt(n).

    Parameters
    ----------
    y : array_like
        The run's replicate values (the response's unit).
    pooled : (float, int), optional
        Pure-error mean square (the response's unit squared) and its degrees of freedom.

    Returns
    -------
    dict
        ``mean``, ``sd``, ``ci`` ([lo, hi], the response's unit), ``n`` and ``interval_from`` (which error).
    """
    from scipy import stats

    y = np.asarray(y, float)
    m, sd = float(np.mean(y)), float(np.std(y, ddof=1))
    s, dof = (sd, y.size - 1) if pooled is None else (math.sqrt(pooled[0]), int(pooled[1]))
    hw = float(stats.t.ppf(0.5 + CONFIDENCE / 2, dof)) * s / math.sqrt(y.size)
    lo = m - hw if np.any(y < 0) else max(m - hw, 0.0)  # a response that cannot be negative (a rate, a force peak)
    return {"mean": m, "sd": sd, "ci": [lo, m + hw], "n": int(y.size), "interval_from": (
        f"pooled replicate error ({dof} dof)" if pooled is not None else f"this run's replicates ({dof} dof)")}


def replicate_jobs(machine, clearance: dict, seeds: list[int], rtol: float = RTOL_RUN, data: dict | None = None
                   ) -> list[dict]:
    """Keyword arguments of :func:`berryshaker.study.runs.replicate_run` for one clearance set: for every seed,
    one coupled drive-past per branch class (seed ``[seed, class index]``), replicate-major.  ``data``: the
    machine as JSON (``machine.model_dump(mode="json")``) when the caller already has it (identical jobs are
    shared through the runner's cache).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest] (its branch classes).
    clearance : dict
        Clearance size (m) per pair.
    seeds : list of int
        Start seeds.
    rtol : float
        Relative integrator tolerance (dimensionless).
    data : dict, optional
        The machine as JSON, if the caller has it.

    Returns
    -------
    list of dict
        One keyword-argument dict per (seed, branch class), seed-major.
    """
    data = machine.model_dump(mode="json") if data is None else data
    return [dict(machine_data=data, clearance=clearance, scale=s, seed=[sd, c], rtol=rtol)
            for sd in seeds for c, s in enumerate(machine.harvest.branch_classes)]


def replicate_envelopes(machine, outs: list, seeds: list[int]) -> list[tuple[list[np.ndarray], int]]:
    """(stem-force envelopes of every branch class, population seed) per replicate from the outputs of
    :func:`replicate_jobs` (in their order), the ``replicates`` of
    :func:`berryshaker.harvest.virtual.calibrate_harvest`; a replicate with a failed run (None) is left out.

    Parameters
    ----------
    machine : Machine
        Machine description (its number of branch classes).
    outs : list
        Outputs of :func:`replicate_run` in :func:`replicate_jobs`' order (None for a failed run).
    seeds : list of int
        The start seeds of those jobs.

    Returns
    -------
    list of (list of numpy.ndarray, int)
        Per complete replicate: its envelopes (N, dimensionless load ratios) and seed.
    """
    nc = len(machine.harvest.branch_classes)
    out = []
    for k, sd in enumerate(seeds):
        o = outs[k * nc:(k + 1) * nc]
        if all(v is not None for v in o):
            out.append(([np.array(v["envelope"]) for v in o], sd))
    return out


def start_cells(machine, runner, clearance: dict, seeds: list[int], data: dict | None = None, label: str = "starts",
                rtol: float = RTOL_RUN, outputs: list | None = None) -> list[dict[str, float]]:
    """Every response (:func:`_cell`: harvest indexes, machine loads) of one clearance set at each start seed: one
    coupled drive-past per branch class and start through the runner (cached), the start's own population.
    ``outputs``: a list that receives each start's run outputs (one per branch class, :func:`replicate_run`).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    runner : SweepRunner
        Runs the coupled drive-pasts (cached).
    clearance : dict
        Clearance size (m) per pair.
    seeds : list of int
        Start seeds.
    data : dict, optional
        The machine as JSON, if the caller has it.
    label : str
        Progress label.
    rtol : float
        Relative integrator tolerance (dimensionless).
    outputs : list, optional
        Receives each start's run outputs.

    Returns
    -------
    list of dict
        Per start: every response (harvest indexes in their units, peak forces N, torques N m).
    """
    nc = len(machine.harvest.branch_classes)
    o = runner.values(replicate_run, replicate_jobs(machine, clearance, seeds, rtol, data), label)
    if outputs is not None:
        outputs.extend(o[k * nc:(k + 1) * nc] for k in range(len(seeds)))
    return cells_from_outputs(machine, o, seeds)


def cells_from_outputs(machine, outs: list, seeds: list[int]) -> list[dict[str, float]]:
    """:func:`_cell` of each start from the outputs of :func:`replicate_jobs` (start-major, one per branch class).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    outs : list
        Outputs of :func:`replicate_run`, start-major.
    seeds : list of int
        The starts' seeds (each start's population is seeded with its seed).

    Returns
    -------
    list of dict
        Per start: every response (harvest indexes in their units, peak forces N, torques N m).
    """
    from berryshaker.harvest.virtual import sample_population

    nc = len(machine.harvest.branch_classes)
    return [_cell(machine, outs[k * nc:(k + 1) * nc], sample_population(machine, seed=sd))
            for k, sd in enumerate(seeds)]
