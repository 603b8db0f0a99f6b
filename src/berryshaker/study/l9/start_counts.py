"""How many starts a clearance set gets: the mean and spread of every harvest response against the number of
perturbed starts (:func:`start_convergence`, the study that chooses ``harvest.replicates``, docs/harvest.md "How
many starts"), and starts added to one clearance set until every harvest response's mean is known to
``harvest.se_target`` (:func:`sequential_starts`: the virtual L9's recommendation, the calibration).
"""

from __future__ import annotations

import numpy as np

from berryshaker.experiment.noise import CONVERGENCE_COUNTS
from berryshaker.harvest.virtual import replicate_starts
from berryshaker.study.replicate_responses import EXPECTED, HARVEST_RESPONSES, response_units, start_cells

#: seed families of the convergence study beyond the description's own: independent families (SeedSequence entropy
#: ``harvest.seed + f``), so a spread is shown to hold for starts the study never draws
FAMILY_OFFSETS = (1, 2)


def _resolutions(suffix: str = "") -> dict[str, float]:
    return {n + suffix: r.resolution for n, r in HARVEST_RESPONSES.items()}


def start_convergence(machine, runner, clearance: dict | None = None, counts=CONVERGENCE_COUNTS,
                      seeds: list[int] | None = None, families=FAMILY_OFFSETS) -> dict:
    """Mean and spread of every harvest response against the number of starts at one clearance set (the
    convergence study that chooses ``harvest.replicates``, docs/harvest.md "How many starts"), for the model's
    expectation (``<name>_expected``: the model's start-to-start spread) and the counted field results (the plain
    name: a field test's test-to-test spread), and the same number of starts in further independent seed families,
    whose spreads the description's family must agree with
    (:func:`berryshaker.experiment.noise.family_agreement`).

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
        Start numbers (default :func:`replicate_starts` for the largest count).
    families : sequence of int
        Offsets of the further families' entropy from ``harvest.seed`` (empty: the description's family only).

    Returns
    -------
    dict
        :func:`berryshaker.experiment.noise.spread_convergence` (``table`` of both, ``chosen`` and ``rule`` judged on the
        expectation's responses), with ``units``,
        ``seeds``, ``clearance_mm``, ``configured`` (``harvest.replicates``), ``values`` (every start's responses)
        and ``families`` (:func:`~berryshaker.experiment.noise.family_agreement`, or None without further families).
    """
    from berryshaker.config import machine_from_dict
    from berryshaker.experiment.noise import family_agreement, spread_convergence

    cl = machine.clearance_sizes() if clearance is None else {**machine.clearance_sizes(), **clearance}
    n = max(int(c) for c in counts)
    seeds = replicate_starts(machine, n) if seeds is None else list(seeds)
    names = [k + s for k in HARVEST_RESPONSES for s in (EXPECTED, "")]
    cells = start_cells(machine, runner, cl, seeds, label=f"convergence of the spread: {len(seeds)} starts")
    res = spread_convergence({k: np.array([c[k] for c in cells]) for k in names}, counts,
                             floors={**_resolutions(EXPECTED), **_resolutions()})
    # the count is chosen on the model's spread (the expectation's): a field test's counted unripe rate, one or two
    # berries a test, has a spread no practical count of starts knows to 30 %; it is reported with its sampling error
    model = spread_convergence({k + EXPECTED: res_values for k, res_values in
                                ((k, np.array([c[k + EXPECTED] for c in cells])) for k in HARVEST_RESPONSES)},
                               counts, floors=_resolutions(EXPECTED))
    res = {**res, "chosen": model["chosen"], "rule": model["rule"] + " (judged on the model's expectation, "
           "<name>_expected; the counted field results' spreads are tabulated with their sampling errors)"}
    units = response_units(machine.pair_names)
    fam = None
    if families:
        by_family = {f"seed {machine.harvest.seed}": {k: [c[k] for c in cells] for k in names}}
        for off in families:
            d = machine.model_dump(mode="json")
            d["harvest"]["seed"] = int(machine.harvest.seed) + int(off)
            m = machine_from_dict(d)
            other = start_cells(m, runner, cl, seeds, d, f"convergence: seed family {d['harvest']['seed']}")
            by_family[f"seed {d['harvest']['seed']}"] = {k: [c[k] for c in other] for k in names}
        fam = family_agreement(by_family)
    return {**res, "units": {k: units[k.removesuffix(EXPECTED)] for k in names}, "seeds": seeds,
            "clearance_mm": {p: v * 1e3 for p, v in cl.items()}, "configured": int(machine.harvest.replicates),
            "values": {k: [c[k] for c in cells] for k in names}, "families": fam}


def sequential_starts(machine, runner, clearance: dict, have: list[dict] | None = None, data: dict | None = None,
                      label: str = "sequential starts", have_outputs: list | None = None) -> dict:
    """Starts added at one clearance set until the mean of every harvest response is known to its target.

    Batches of ``harvest.replicates`` starts (the numbers :func:`replicate_starts` continues) until the standard
    error of every harvest response's mean (the model's expectation over the starts) is at most
    ``harvest.se_target`` x |mean| (or its resolution), or ``harvest.max_replicates`` starts are reached
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
        Their run outputs (one per start, :func:`berryshaker.study.runs.replicate_run`); with them the result's
        ``outputs`` is complete.
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
        seeds = replicate_starts(machine, n)
        if len(cells) < n:
            cells += start_cells(machine, runner, clearance, seeds[len(cells):], data,
                                 f"{label}: starts {len(cells) + 1}-{n}", outputs=outputs)
        reached = standard_error_reached({k: np.array([c[k + EXPECTED] for c in cells]) for k in HARVEST_RESPONSES},
                                         h.se_target, _resolutions())
        if reached["all_met"] or n >= h.max_replicates:
            break
        n = min(n + int(h.replicates), int(h.max_replicates))
    stopped = "target met" if reached["all_met"] else "max_replicates reached"
    return {"cells": cells, "outputs": outputs, "seeds": seeds, "reached": reached, "stopped": stopped, "target": h.se_target,
            "max": int(h.max_replicates), "statement": (
                f"{len(cells)} starts: " + ("every harvest response's standard error is within " if reached["all_met"]
                                            else "harvest.max_replicates reached before every standard error was "
                                            "within ")
                + f"{100 * h.se_target:g} % of its expected mean (resolution " + ", ".join(
                    f"{k} {v:g}" for k, v in _resolutions().items()) + "): " + ", ".join(
                    f"{k} SE {v['se']:.3g} (target {v['target']:.3g})" for k, v in reached["responses"].items()))}
