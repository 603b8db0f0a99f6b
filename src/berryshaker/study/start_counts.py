"""How many starts a clearance set gets: the mean and spread of every harvest response against the number of
perturbed starts (:func:`start_convergence`, the study that chooses ``harvest.replicates``, docs/harvest.md "How
many starts"), and starts added to one clearance set until every harvest response's mean is known to
``harvest.se_target`` (:func:`sequential_starts`: the virtual L9's recommendation, the calibration).
"""

from __future__ import annotations

import numpy as np

from berryshaker.experiment.noise import CONVERGENCE_COUNTS
from berryshaker.harvest.virtual import replicate_seeds
from berryshaker.study.replicate_responses import HARVEST_RESPONSES, RESPONSE_RESOLUTION, response_units, start_cells


def start_convergence(machine, runner, clearance: dict | None = None, counts=CONVERGENCE_COUNTS,
                      seeds: list[int] | None = None) -> dict:
    """Mean and spread of every harvest response against the number of starts at one clearance set (the
    convergence study that chooses ``harvest.replicates``, docs/harvest.md "How many starts").

    Parameters
    ----------
    machine : Machine
        With ``[plant]`` and ``[harvest]``.
    runner : SweepRunner
        Runs the coupled drive-pasts (cached).
    clearance : dict, optional
        Clearance sizes (m); default the machine's own.
    counts : sequence of int
        Start counts of the table (nested: the first n starts of the largest count).
    seeds : list of int, optional
        Start seeds (default :func:`replicate_seeds` for the largest count).

    Returns
    -------
    dict
        :func:`berryshaker.experiment.noise.spread_convergence` of the harvest responses (``table``, ``chosen``,
        ``rule``), with ``units``, ``seeds``, ``clearance_mm``, ``configured`` (``harvest.replicates``) and
        ``values`` (every start's responses).
    """
    from berryshaker.experiment.noise import spread_convergence

    cl = machine.clearance_sizes() if clearance is None else {**machine.clearance_sizes(), **clearance}
    n = max(int(c) for c in counts)
    seeds = replicate_seeds(machine, n) if seeds is None else list(seeds)
    cells = start_cells(machine, runner, cl, seeds, label=f"convergence of the spread: {len(seeds)} starts")
    names = [k for k in HARVEST_RESPONSES]
    res = spread_convergence({k: np.array([c[k] for c in cells]) for k in names}, counts,
                             floors={k: RESPONSE_RESOLUTION[k] for k in names})
    units = response_units(machine.pair_names)
    return {**res, "units": {k: units[k] for k in names}, "seeds": seeds,
            "clearance_mm": {p: v * 1e3 for p, v in cl.items()}, "configured": int(machine.harvest.replicates),
            "values": {k: [c[k] for c in cells] for k in names}}


def sequential_starts(machine, runner, clearance: dict, have: list[dict] | None = None, data: dict | None = None,
                      label: str = "sequential starts", have_outputs: list | None = None) -> dict:
    """Starts added at one clearance set until the mean of every harvest response is known to its target.

    Batches of ``harvest.replicates`` starts (the seeds :func:`replicate_seeds` continues) until the standard error
    of every harvest response's mean is at most ``harvest.se_target`` x |mean| (or its
    :data:`RESPONSE_RESOLUTION`), or ``harvest.max_replicates`` starts are reached
    (:func:`berryshaker.experiment.noise.standard_error_reached`).

    Parameters
    ----------
    machine : Machine
        With ``[plant]`` and ``[harvest]`` (``replicates``, ``max_replicates``, ``se_target``).
    runner : SweepRunner
        Runs the coupled drive-pasts (cached).
    clearance : dict
        Clearance sizes (m).
    have : list of dict, optional
        Responses (:func:`start_cells`) of the first starts already run (the seeds' order), reused.
    have_outputs : list, optional
        Their run outputs (per start, one per branch class); with them the result's ``outputs`` is complete.
    data : dict, optional
        ``machine.model_dump(mode="json")`` if the caller has it.
    label : str
        Progress label.

    Returns
    -------
    dict
        ``cells`` (every start's responses), ``outputs`` (every start's run outputs, when ``have_outputs`` is given
        or nothing was), ``seeds``, ``reached`` (per response mean, se, target, met;
        ``all_met``), ``stopped`` ("target met" or "max_replicates reached"), ``target`` (relative), ``max``.
    """
    from berryshaker.experiment.noise import standard_error_reached

    h = machine.harvest
    cells = list(have or [])
    outputs = list(have_outputs) if have_outputs is not None else ([] if not cells else None)
    n = len(cells) or min(int(h.replicates), int(h.max_replicates))
    while True:
        seeds = replicate_seeds(machine, n)
        if len(cells) < n:
            cells += start_cells(machine, runner, clearance, seeds[len(cells):], data,
                                 f"{label}: starts {len(cells) + 1}-{n}", outputs=outputs)
        reached = standard_error_reached({k: np.array([c[k] for c in cells]) for k in HARVEST_RESPONSES},
                                         h.se_target, RESPONSE_RESOLUTION)
        if reached["all_met"] or n >= h.max_replicates:
            break
        n = min(n + int(h.replicates), int(h.max_replicates))
    stopped = "target met" if reached["all_met"] else "max_replicates reached"
    return {"cells": cells, "outputs": outputs, "seeds": seeds, "reached": reached, "stopped": stopped, "target": h.se_target,
            "max": int(h.max_replicates), "statement": (
                f"{len(cells)} starts: " + ("every harvest response's standard error is within " if reached["all_met"]
                                            else "harvest.max_replicates reached before every standard error was "
                                            "within ")
                + f"{100 * h.se_target:g} % of its mean (resolution " + ", ".join(
                    f"{k} {v:g}" for k, v in RESPONSE_RESOLUTION.items()) + "): " + ", ".join(
                    f"{k} SE {v['se']:.3g} (target {v['target']:.3g})" for k, v in reached["responses"].items()))}
