"""The responses of replicated coupled drive-pasts at one clearance set, as the virtual L9
(:mod:`berryshaker.study.l9`), the calibration, the validation and the harvest-response step read them.

The responses: the harvest responses of the one table (:data:`HARVEST_RESPONSES`,
berryshaker.harvest.virtual.responses) and the machine loads (:func:`load_responses`); their units
(:func:`response_units`).  Each start is one virtual field test: its cell holds every harvest response's counted
field result (the plain name), the model's expectation (``<name>_expected``) and the counting SD of the test
(``<name>_count_sd``), and the machine loads.  A clearance set's replicate jobs (:func:`replicate_jobs`: for every start
seed, one :func:`berryshaker.study.runs.replicate_run`, the drive-past carrying every branch class), each start's
responses from its output (:func:`start_cells`, :func:`cells_from_outputs`; one start's: ``_cell``), the replicates'
stem-force envelopes (:func:`replicate_envelopes`) and a run's mean with its 95 % interval (:func:`interval`).
"""

from __future__ import annotations

import math

import numpy as np

from berryshaker.harvest.spec import COUPLED_RTOL
from berryshaker.harvest.virtual import RESPONSES as HARVEST_RESPONSES
from berryshaker.study.runs import replicate_run

#: suffixes of a start's cell: the model's expectation and the counting SD of its field test (the plain name is the
#: counted field result)
EXPECTED, COUNT_SD = "_expected", "_count_sd"
#: relative tolerance of the coupled runs (their default; the solver-tolerance check re-runs at a tighter one)
RTOL_RUN = COUPLED_RTOL
#: confidence of the replicated L9's intervals and comparisons
CONFIDENCE = 0.95


def load_responses(pairs) -> list[str]:
    """Names of the machine-load responses: the static-equivalent collision force per pair (the p95 of the impact
    peaks of a start's drive-past, :func:`berryshaker.multibody.impacts.static_equivalent_load`), the design drive
    torque (the p95 of the per-revolution peaks of the start's drive-past,
    :func:`berryshaker.multibody.drive_loads.design_torque`) and the RMS drive torque.

    Parameters
    ----------
    pairs : iterable of str
        The machine's clearance pairs.

    Returns
    -------
    list of str
        ``design_force_<pair>`` per pair, then ``drive_torque_design`` and ``drive_torque_rms``.
    """
    return [f"design_force_{p}" for p in pairs] + ["drive_torque_design", "drive_torque_rms"]


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
    return {**{k: v.unit for k, v in HARVEST_RESPONSES.items()}, **{f"design_force_{p}": "N" for p in pairs},
            "drive_torque_design": "N m", "drive_torque_rms": "N m"}


def _cell(machine, out: dict, start: int, digest: str | None = None) -> dict[str, float]:
    """One start's responses from its :func:`~berryshaker.study.runs.replicate_run` output ``out``: each harvest
    response's counted field result, its expectation and counting SD (module docstring) from its branch classes'
    tables, and the loads of its drive-past.

    Static-equivalent force (``design_force_<pair>``): the p95 of the run's impact peaks
    (berryshaker.multibody.impacts; a run's single largest force is an extreme, not a response); design torque
    (``drive_torque_design``): the p95 of the per-revolution peaks of the drive moment
    (berryshaker.multibody.drive_loads; the single largest moment is an extreme, not a response); RMS torque: the
    run's RMS.

    The harvest responses are those the run keeps when they are of this description (``digest``,
    :func:`berryshaker.runs.cache.value_digest` of ``machine``'s JSON), start and response table
    (:func:`berryshaker.study.runs.stored_harvest`), else computed from the tables here.
    """
    from berryshaker.harvest.virtual import start_responses
    from berryshaker.multibody.impacts import static_equivalent_load
    from berryshaker.study.runs import stored_harvest

    r = None if digest is None else stored_harvest(out, digest, start)
    if r is None:
        r = start_responses(machine, [np.array(e) for e in out["envelopes"]], start)
    cell = dict(r["field"])
    cell.update({n + EXPECTED: v for n, v in r["expected"].items()})
    cell.update({n + COUNT_SD: v for n, v in r["count_sd"].items()})
    for p in machine.pair_names:
        if p in out.get("impact_peaks_N", {}):
            cell[f"design_force_{p}"] = static_equivalent_load(np.asarray(out["impact_peaks_N"][p], float))
    tq = out.get("drive_torque_Nm")
    if tq is not None:
        from berryshaker.multibody.drive_loads import design_torque

        if "revolution_peaks" in tq:
            cell["drive_torque_design"] = design_torque(np.asarray(tq["revolution_peaks"], float))
        cell["drive_torque_rms"] = float(tq["rms"])
    return cell


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
    """Keyword arguments of :func:`berryshaker.study.runs.replicate_run` for one clearance set: for every seed, one
    coupled drive-past carrying every branch class (seed ``[seed, MACHINE]``; class c starts from ``[seed, MACHINE,
    c]``).  ``data``: the machine as JSON (``machine.model_dump(mode="json")``) when the caller already has it
    (identical jobs are shared through the runner's cache).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest] (its branch classes).
    clearance : dict
        Clearance size (m) per pair.
    seeds : list of int
        Start numbers (class c of start k meets the comb at the drive phase of spawn key (k, MACHINE, c)).
    rtol : float
        Relative integrator tolerance (dimensionless).
    data : dict, optional
        The machine as JSON, if the caller has it.

    Returns
    -------
    list of dict
        One keyword-argument dict per start, in ``seeds`` order.
    """
    data = machine.model_dump(mode="json") if data is None else data
    from berryshaker.harvest.virtual import MACHINE

    return [dict(machine_data=data, clearance=clearance, seed=[sd, MACHINE], rtol=rtol) for sd in seeds]


def replicate_envelopes(machine, outs: list, seeds: list[int]) -> list[tuple[list[np.ndarray], int]]:
    """(stem-force envelopes of every branch class, start number) per replicate from the outputs of
    :func:`replicate_jobs` (in their order), the ``replicates`` of
    :func:`berryshaker.harvest.virtual.calibrate_harvest`; a replicate with a failed run (None) is left out.

    Parameters
    ----------
    machine : Machine
        Machine description.
    outs : list
        Outputs of :func:`replicate_run` in :func:`replicate_jobs`' order, one per start (None for a failed run).
    seeds : list of int
        The start seeds of those jobs.

    Returns
    -------
    list of (list of numpy.ndarray, int)
        Per finished replicate: its envelopes, one per branch class (N, dimensionless load ratios), and seed.
    """
    return [([np.array(e) for e in o["envelopes"]], sd) for o, sd in zip(outs, seeds) if o is not None]


def start_cells(machine, runner, clearance: dict, seeds: list[int], data: dict | None = None, label: str = "starts",
                rtol: float = RTOL_RUN, outputs: list | None = None) -> list[dict[str, float]]:
    """Every response (:func:`_cell`: harvest indexes, machine loads) of one clearance set at each start seed: one
    coupled drive-past per start carrying every branch class, through the runner (cached), the start's own field
    test.  ``outputs``: a list that receives each start's run output (:func:`replicate_run`).

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
        Receives each start's run output.

    Returns
    -------
    list of dict
        Per start: every response (harvest indexes in their units, peak forces N, torques N m).
    """
    o = runner.values(replicate_run, replicate_jobs(machine, clearance, seeds, rtol, data), label)
    if outputs is not None:
        outputs.extend(o)
    return cells_from_outputs(machine, o, seeds)


def cells_from_outputs(machine, outs: list, seeds: list[int]) -> list[dict[str, float]]:
    """:func:`_cell` of each start from the outputs of :func:`replicate_jobs` (one per start).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    outs : list
        Outputs of :func:`replicate_run`, one per start.
    seeds : list of int
        The starts' numbers (each start's field test draws from its own stream).

    Returns
    -------
    list of dict
        Per start: every response (harvest responses in their units with their expectations and counting SDs, peak
        forces N, torques N m).
    """
    from berryshaker.runs.cache import value_digest

    digest = value_digest(machine.model_dump(mode="json"))
    return [_cell(machine, o, sd, digest) for o, sd in zip(outs, seeds)]
