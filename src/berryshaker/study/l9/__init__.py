"""The study's L9 field test run through the virtual harvest, replicated, and analysed against its own noise.

Replicates (docs/harvest.md, "Replicates"): start k of every run is one virtual field test, one coupled drive-past
carrying every branch class (random eccentricity inside every clearance, and for each class a random drive phase when
the comb reaches its branch: :class:`berryshaker.multibody.perturbation.RandomInitialPerturbation`) and the bushes
and fruit the test counts, each from its own stream of the seed family ``harvest.seed``
(berryshaker.harvest.virtual.seeds).  ``harvest.replicates`` starts (chosen by :func:`start_convergence`) are drawn
once and used for every run (common random numbers), and the analysis treats start k as block k
(:func:`berryshaker.experiment.replicates.analyze_replicated` with ``blocks=True``): start-to-start luck shared by
every run cancels, each factor is tested against its own interaction with the starts, and its levels are compared by
paired differences with their standard errors (one verdict per factor).

Every response (harvest indexes and machine loads) carries its mean, per-start standard deviation and 95 %
interval per run (from its own starts); range analysis and ANOVA use the blocked error; the recommended set's
starts are then extended until every harvest response's mean is known to ``harvest.se_target`` of itself
(:func:`sequential_starts`), and its intervals and SDs come from all of them.  The recommendation is tiered
(:data:`berryshaker.experiment.replicates.TIERED_RULE`): harvest indexes first, machine loads where the
harvest indexes do not differ, and the configured clearance where nothing differs.  The tiered choice is then
confirmed against the trade-off table of the runs (:data:`CONFIRMATION_RULE`), whose dominance test uses the
ANOVA's error (blocked) with Tukey-Kramer simultaneous margins, so the table cannot call a noise-sized difference
dominance that the ANOVA calls no effect; a tested run that still dominates the choice becomes the
recommendation.

The L9 is one package: this module runs it (:func:`l9_jobs`, :func:`virtual_l9`: a
:class:`~berryshaker.study.l9.records.VirtualL9` record, :mod:`berryshaker.study.l9.records`) and holds what only it
reads (:func:`fitted_here`, :func:`paired_summary`); the names of its parts are importable from here: the responses
of one start and a clearance set's replicate jobs (:mod:`berryshaker.study.replicate_responses`, which the other
steps, validation, the explorer and the calibration read too), the start counts
(:mod:`berryshaker.study.l9.start_counts`: convergence and sequential starts), the confirmation against the trade-off
table (:mod:`berryshaker.study.l9.confirmation`) and the solver-tolerance check
(:mod:`berryshaker.study.l9.tolerance_check`).
"""

from __future__ import annotations

import math

import numpy as np

from berryshaker.experiment.clearance_sets import l9_runs, level_code
from berryshaker.experiment.replicated_records import ReplicatedAnalysis
from berryshaker.harvest.virtual import replicate_starts  # one home; re-exported here
from berryshaker.records import fields_of
from berryshaker.reference_study import CHOSEN_CODE, CHOSEN_LEVELS, PRIORITY_WEIGHTS, SENSES
from berryshaker.report.design import level_set_name
from berryshaker.study.l9.confirmation import (
    CONFIRMATION_RULE,
    TRADEOFF_SENSES,
    confirm_recommendation,
    tradeoff_records,
)
from berryshaker.study.l9.records import (
    Confirmation,
    Estimate,
    FieldDetectability,
    L9Optimum,
    L9Recommendation,
    L9Run,
    PairedDifference,
    Perturbation,
    ReplicatedL9,
    SequentialStarts,
    TieredChoice,
    VirtualL9,
)
from berryshaker.study.l9.start_counts import sequential_starts, start_convergence
from berryshaker.study.l9.tolerance_check import RTOL_CHECK, check_solver_tolerance, tolerance_verdict
from berryshaker.study.replicate_responses import (
    CONFIDENCE,
    EXPECTED,
    HARVEST_RESPONSES,
    RTOL_RUN,
    cells_from_outputs,
    interval,
    load_responses,
    replicate_envelopes,
    replicate_jobs,
    response_units,
    start_cells,
)
from berryshaker.study.runs import replicate_run

#: the names callers import from here: the L9's own and its parts'
__all__ = [
    "CONFIDENCE", "CONFIRMATION_RULE", "HARVEST_RESPONSES", "RTOL_CHECK", "RTOL_RUN",
    "TRADEOFF_SENSES", "cells_from_outputs", "check_solver_tolerance", "confirm_recommendation",
    "fitted_here", "interval", "l9_jobs", "load_responses", "paired_summary", "replicate_envelopes", "replicate_jobs",
    "replicate_starts", "response_units", "sequential_starts", "start_cells", "start_convergence", "tolerance_verdict",
    "tradeoff_records", "virtual_l9",
]


def _configured_level(machine, p: str) -> int:
    """Level (1-based) nearest to the clearance the machine description gives for pair p."""
    size = machine.clearance_sizes()[p]
    lv = machine.clearance_levels()[p]
    return int(np.argmin([abs(v - size) for v in lv])) + 1


def l9_jobs(machine, replicates: int | None = None, data: dict | None = None) -> tuple[list[dict], str]:
    """The replicated L9's coupled drive-pasts: keyword arguments of
    :func:`berryshaker.study.runs.replicate_run` (run-major, then :func:`replicate_jobs`' order) and the label
    of their sweep; what :func:`virtual_l9` runs first (the study starts them ahead, ``SweepRunner.prefetch``).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    replicates : int, optional
        Replicates per run (>= 2; default ``harvest.replicates``).
    data : dict, optional
        The machine as JSON, if the caller has it.

    Returns
    -------
    jobs : list of dict
        Keyword arguments of :func:`replicate_run`.
    label : str
        Label of the sweep.

    Raises
    ------
    ConfigError
        Fewer than 2 replicates.
    """
    from berryshaker.errors import ConfigError

    runs, _codes = l9_runs(machine)
    r = int(machine.harvest.replicates if replicates is None else replicates)
    if r < 2:
        raise ConfigError(f"replicates={r}: the replicated L9 needs at least 2 replicates per run")
    seeds = replicate_starts(machine, r)
    data = machine.model_dump(mode="json") if data is None else data
    jobs = [j for cl in runs for j in replicate_jobs(machine, cl, seeds, RTOL_RUN, data)]
    return jobs, f"virtual L9: {len(runs)} runs x {r} replicates, coupled runs"


def virtual_l9(machine, runner, replicates: int | None = None) -> VirtualL9:
    """The L9 over the machine's clearance pairs through the virtual harvest, replicated (module docstring).

    Parameters
    ----------
    machine : Machine
        With a ``[plant]`` and ``[harvest]`` block.
    runner : SweepRunner
        Runs the coupled drive-pasts (cached).
    replicates : int, optional
        Replicates per run (>= 2); default ``harvest.replicates``.

    Returns
    -------
    VirtualL9
        The record (:mod:`berryshaker.study.l9.records`): ``responses`` (range analysis of the replicate means, as
        the study's Table 8), ``runs`` (:class:`~berryshaker.study.l9.records.L9Run`: levels, clearances mm,
        replicate means of efficiency kg/min, unripe and damage %, and ``replicates``: every response's mean, sd,
        ci), ``replicated`` (:func:`berryshaker.experiment.replicates.analyze_replicated`: ANOVA against the
        blocked error, intervals, tiered optimum), ``optimum`` (the tiered optimum with the levels actually
        recommended and ``tiered_levels``, the tiered rule's), ``recommended`` (levels, code, clearances, mean
        indexes, per-response intervals, ``basis`` per factor, ``rule``, ``statement``, ``check``: the
        confirmation against the trade-off table, :func:`confirm_recommendation`), ``tolerance_check``,
        ``tradeoff`` (records of the trade-off table), ``tradeoff_columns``, ``paired`` and ``observations``.
    """
    from berryshaker.experiment.analysis import analyze
    from berryshaker.experiment.designs import orthogonal_array
    from berryshaker.experiment.replicates import analyze_replicated, describe_replicated

    pairs = list(machine.pair_names)
    runs, _codes = l9_runs(machine)
    levels_m = machine.clearance_levels()
    h = machine.harvest
    data = machine.model_dump(mode="json")
    jobs, label = l9_jobs(machine, replicates, data)
    r = int(h.replicates if replicates is None else replicates)
    seeds = replicate_starts(machine, r)

    def jobs_for(cl, seeds_, rtol=RTOL_RUN):
        return replicate_jobs(machine, cl, seeds_, rtol, data)

    def cells(outs, seeds_):
        return cells_from_outputs(machine, outs, seeds_)

    outs = runner.values(replicate_run, jobs, label)
    per = len(seeds)
    run_cells = [cells(outs[i * per:(i + 1) * per], seeds) for i in range(len(runs))]
    finite = lambda n: all(n in c and np.isfinite(c[n]) for rc in run_cells for c in rc)  # noqa: E731
    harvest = [n for n in HARVEST_RESPONSES if finite(n)]
    loads = [n for n in load_responses(pairs) if finite(n)]
    names = harvest + loads
    y = {n: np.array([[c[n] for c in rc] for rc in run_cells]) for n in names}
    expected = {n: np.array([[c[n + EXPECTED] for c in rc] for rc in run_cells]) for n in harvest}
    a = orthogonal_array("L9")[:, :len(pairs)] + 1
    values = np.array([[rr[p] * 1e3 for p in pairs] for rr in runs])
    units = response_units(pairs)
    # range analysis of the replicate means, laid out as the study's Table 8 (its optimum is not used: it would
    # rank differences of any size; the recommendation is the replicated, tiered one below)
    study_idx = ("efficiency", "unripe", "damage")
    an = analyze(a, values, pairs, {n: y[n].mean(axis=1) for n in study_idx}, SENSES, PRIORITY_WEIGHTS)
    senses = {n: HARVEST_RESPONSES[n].maximize if n in HARVEST_RESPONSES else False for n in names}
    rep = analyze_replicated(a, values, pairs, y, senses, PRIORITY_WEIGHTS, confidence=CONFIDENCE,
                             level_values={p: tuple(v * 1e3 for v in levels_m[p]) for p in pairs},
                             units={p: "mm" for p in pairs},
                             fallback_weights={n: 1.0 for n in loads} or None, blocks=True)
    perturbation = Perturbation(
        initial_eccentricity=h.initial_eccentricity, start_phase_spread_rad=h.start_phase_spread,
        what=("start k (block k of every run) is one virtual field test: one coupled drive-past carrying every "
              f"branch class, from streams of seed family {h.seed} (clearance eccentricities uniform over the disc "
              f"of {h.initial_eccentricity:g} x each free radius; each class's drive phase when the comb meets its "
              f"branch uniform in +-{math.degrees(h.start_phase_spread):.0f} deg, from the class's own stream) and "
              "the bushes and fruit the test counts from another"))
    rep = ReplicatedL9(**fields_of(rep), seeds=seeds, units=units, perturbation=perturbation,
                       text=describe_replicated(rep))
    run_recs = [L9Run(run=i + 1, levels={p: int(a[i, j]) for j, p in enumerate(pairs)},
                      clearance_mm={p: float(values[i, j]) for j, p in enumerate(pairs)},
                      name=level_set_name({p: float(values[i, j]) for j, p in enumerate(pairs)}),
                      **{n: float(y[n][i].mean()) for n in study_idx},
                      replicates={n: Estimate(**interval(y[n][i])) for n in names},
                      expected={n: Estimate(**interval(expected[n][i])) for n in harvest}) for i in range(len(runs))]
    # comparisons between runs (they share the starts) use the blocked error; a run's own interval, its own starts
    err = {n: (rep.responses[n].anova.error.ms, rep.responses[n].anova.error.df) for n in names}

    # recommendation: the tiered optimum; a factor where nothing differs keeps the configured clearance
    opt = rep.optimum
    rec_levels, basis = {}, {}
    for p in pairs:
        c = opt.choices[p]
        if c.level is None:
            rec_levels[p] = _configured_level(machine, p)
            basis[p] = (f"no response differs significantly between the levels of {p}: kept at the configured "
                        f"clearance (level {rec_levels[p]})")
        else:
            rec_levels[p] = int(c.level)
            basis[p] = {"primary": "harvest indexes", "fallback": "machine loads (harvest indexes do not differ)",
                        "primary + fallback": "harvest indexes, tie among their indistinguishable levels broken by "
                        "machine loads"}[c.tier] + f": {c.status}"
    harvest_sig = {n: rep.responses[n].significant_factors for n in HARVEST_RESPONSES if n in rep.responses}
    if not any(harvest_sig.values()):
        differing = [f"{n} ({', '.join(rep.responses[n].significant_factors)})" for n in loads
                     if rep.responses[n].significant_factors]
        statement = (f"No harvest index differs between clearance levels beyond the replicate noise (p >= {rep.alpha:g}); "
                     "the choice rests on the machine loads that do (static-equivalent collision forces, p95 of the "
                     "impact peaks, and drive torque: " + ("; ".join(differing) or "none differs")
                     + ") and on the configured clearance where nothing differs.")
    else:
        statement = ("Harvest indexes that differ beyond the replicate noise: " + "; ".join(
            f"{n}: {', '.join(f) or 'none'}" for n, f in harvest_sig.items())
            + ". Other factors are decided on machine loads where those differ, else kept as configured.")
    tiered_levels = dict(rec_levels)

    def rec_cells_at(levels: dict[str, int]):
        cl = {p: levels_m[p][levels[p] - 1] for p in pairs}
        i = next((i for i, rr in enumerate(runs) if all(abs(rr[p] - cl[p]) < 1e-12 for p in pairs)), None)
        if i is not None:
            return i, cl, run_cells[i]
        o = runner.values(replicate_run, jobs_for(cl, seeds), "virtual harvest at the recommendation")
        return None, cl, cells(o, seeds)

    row, best_cl, rec_cells = rec_cells_at(rec_levels)
    rec_y = {n: np.array([c[n] for c in rec_cells]) for n in names}
    check = confirm_recommendation([r.levels for r in run_recs], runs, y, rec_levels, best_cl,
                                   None if row is not None else rec_y, err, pairs)
    tradeoff, tradeoff_columns = check.pop("records"), check.pop("columns")
    check = Confirmation(**{**check, "tiered": TieredChoice(**check["tiered"])})
    if check.moved:
        row = check.l9_run - 1
        rec_levels = dict(run_recs[row].levels)
        best_cl, rec_cells = runs[row], run_cells[row]
        rec_y = {n: y[n][row] for n in names}
        for p in pairs:
            if rec_levels[p] != tiered_levels[p]:
                # decided on measured evidence, not kept for want of it (claim 8 reads the basis)
                basis[p] = (f"tested L9 run {row + 1} ({run_recs[row].name}) dominates the tiered choice "
                            f"{check.tiered.name} beyond the noise: level {rec_levels[p]} (the tiered rule "
                            f"gave level {tiered_levels[p]})")
    statement = statement + " " + check.statement
    # the recommended set's starts extended until every harvest response's mean is known to its target; its
    # intervals and SDs come from all of them (the first are the L9's: the same seeds)
    from berryshaker.errors import SimulationError

    try:
        seq = sequential_starts(machine, runner, best_cl, have=list(rec_cells), data=data,
                                label="virtual harvest at the recommendation")
    except SimulationError as exc:  # a further start failed: the recommendation's numbers rest on the L9's starts
        seq = {"cells": list(rec_cells), "reached": None, "stopped": f"a further start failed ({exc})",
               "target": machine.harvest.se_target, "max": machine.harvest.max_replicates,
               "statement": f"{len(rec_cells)} starts (the L9's): a further start failed, so the recommendation's "
                            f"intervals rest on these ({exc})"}
    rec_all = {n: np.array([c[n] for c in seq["cells"]]) for n in names}
    vh = {HARVEST_RESPONSES[n].column: float(np.nanmean([c[n + EXPECTED] for c in seq["cells"]])) for n in harvest}
    # the optimum as recommended: its levels, their settings and the recommended set's own values, one set
    own = {n: interval(rec_all[n]) for n in names}
    labels = {p: rep.factors[p].labels[rep.factors[p].level_numbers.index(rec_levels[p])] for p in pairs}
    opt = L9Optimum(**{**fields_of(opt), "levels": dict(rec_levels), "settings": labels,
                       "values": {n: v["mean"] for n, v in own.items()},
                       "intervals": {n: v["ci"] for n, v in own.items()},
                       "prediction": (f"the recommended set's own {len(seq['cells'])} starts: mean and 95 % interval of "
                                      "the mean (counted field results for the harvest responses)")},
                    decided_levels=opt.levels, tiered_levels=tiered_levels)
    recommended = L9Recommendation(
        levels=rec_levels, code=level_code(rec_levels), name=level_set_name({p: best_cl[p] * 1e3 for p in pairs}),
        clearance_mm={p: best_cl[p] * 1e3 for p in pairs}, l9_run=None if row is None else row + 1,
        study={"code": CHOSEN_CODE}, same_as_study=rec_levels == CHOSEN_LEVELS, virtual_harvest=vh,
        replicates={n: Estimate(**interval(rec_all[n])) for n in names}, starts=len(seq["cells"]),
        sequential=SequentialStarts(**{k: seq[k] for k in ("reached", "stopped", "target", "max", "statement")}),
        fitted=fitted_here(machine, best_cl), basis=basis,
        rule=(rep.optimum.method + "; a factor with no significant difference keeps the configured clearance; "
              + CONFIRMATION_RULE), statement=statement, check=check)
    checked = [n + EXPECTED for n in harvest] + loads  # the expectation: the solver's effect without counting noise
    tolerance = check_solver_tolerance(machine, runner, jobs_for, cells, best_cl, seeds, rec_cells,
                                       {n: float(np.std([c[n] for c in seq["cells"]], ddof=1)) for n in checked},
                                       checked)
    # the range analysis' keys first (its optimum replaced by the tiered one), then the study's, in that order
    return VirtualL9(responses=an.responses, weights=an.weights, factors=an.factors, composite=an.composite,
                     optimum=opt, runs=run_recs, replicated=rep, response_units=units,
                     tradeoff=tradeoff, tradeoff_columns=tradeoff_columns, recommended=recommended,
                     tolerance_check=tolerance, paired=paired_summary(rep, pairs),
                     observations={n: np.asarray(y[n]).tolist() for n in names},  # per run and start: the figures' data
                     detectability=detectability(a, pairs, expected, y, rep))


def detectability(levels: np.ndarray, pairs, expected: dict[str, np.ndarray], field: dict[str, np.ndarray],
                  rep: ReplicatedAnalysis, alpha: float = 0.05, power: float = 0.8
                  ) -> dict[str, dict[str, FieldDetectability]]:
    """Per harvest response and factor, the model's effect (range of the expectation's level means) and the field
    tests per level that a two-sided two-sample t test at ``alpha`` needs to see it with ``power``
    (statsmodels ``TTestIndPower.solve_power``; Cohen 1988), against the SD of one field test (the pooled within-run
    SD of the counted field results).

    Parameters
    ----------
    levels : numpy.ndarray
        (runs, factors) 1-based levels of the L9 (dimensionless).
    pairs : list of str
        The factors.
    expected : dict of str to numpy.ndarray
        Per harvest response, (runs, starts) model expectations (its unit).
    field : dict of str to numpy.ndarray
        The same responses' counted field results.
    rep : ReplicatedAnalysis
        The replicated analysis of the field results (its pure error: the field test's spread).
    alpha, power : float
        Significance level and power of the test a field trial would make (dimensionless).

    Returns
    -------
    dict of str to dict of str to FieldDetectability
        Response -> factor -> the effect, its SE, the field SD and the tests it takes.
    """
    from statsmodels.stats.power import TTestIndPower

    solver = TTestIndPower()
    out = {}
    for n, e in expected.items():
        field_sd = float(math.sqrt(rep.responses[n].anova.pure_error.ms)) if n in rep.responses else float("nan")
        per = {}
        for j, p in enumerate(pairs):
            ks = sorted(int(v) for v in np.unique(levels[:, j]))
            by_start = np.array([e[levels[:, j] == k].mean(axis=0) for k in ks])  # (levels, starts)
            means = by_start.mean(axis=1)
            hi, lo = int(np.argmax(means)), int(np.argmin(means))
            d = by_start[hi] - by_start[lo]
            effect = float(d.mean())
            se = float(d.std(ddof=1) / math.sqrt(d.size)) if d.size > 1 else float("nan")
            n_tests = None
            if effect > 0 and field_sd > 0:
                es = effect / field_sd
                try:
                    n_tests = float(solver.solve_power(effect_size=es, alpha=alpha, power=power, ratio=1.0))
                except (ValueError, RuntimeError):  # an effect far below the noise: beyond the solver's bracket
                    n_tests = float("inf")
                n_tests = max(n_tests, 2.0)
            per[p] = FieldDetectability(effect=effect, effect_se=se, field_sd=field_sd, tests_per_level=n_tests,
                                        l9_replicates=None if n_tests is None else n_tests / 3.0)
        out[n] = per
    return out


def fitted_here(machine, clearance: dict) -> list[str]:
    """The harvest responses (names of :data:`HARVEST_RESPONSES`) whose value at ``clearance`` was fitted: the
    description's calibrated parameters (``harvest.yield_per_bush`` -> efficiency, ``harvest.damage_acceleration``
    -> damage, ``harvest.unripe_fraction`` -> unripe) were fitted at the configured clearances, so their indexes
    there reproduce the calibration target and are not evidence.

    Parameters
    ----------
    machine : Machine
        Machine description (its clearances and the provenance tags of its harvest parameters).
    clearance : dict
        Clearance size (m) per pair.

    Returns
    -------
    list of str
        The responses fitted at ``clearance`` (empty when it is not the configured set).
    """
    from berryshaker.config import value_tag

    own = machine.clearance_sizes()
    if any(abs(own[p] - clearance.get(p, own[p])) > 1e-12 for p in own):
        return []
    tagged = {"efficiency": "harvest.yield_per_bush", "damage": "harvest.damage_acceleration",
              "unripe": "harvest.unripe_fraction"}
    return [n for n, key in tagged.items() if value_tag(machine, key) == "calibrated"]


def paired_summary(rep: ReplicatedAnalysis, pairs) -> dict[str, dict[str, PairedDifference]]:
    """Per response and factor, the paired difference of its extreme levels (last minus first, e.g. A3 - A1) over
    the blocks, with its standard error and p (:func:`berryshaker.experiment.error_terms.paired_differences`);
    ``beyond_noise`` is the factor's one verdict (its F test against its own interaction with the starts), so the
    JSON never says a factor differs in one place and not in another.

    Parameters
    ----------
    rep : ReplicatedAnalysis
        The replicated analysis (:func:`berryshaker.experiment.replicates.analyze_replicated`).
    pairs : iterable of str
        The factors (clearance pairs).

    Returns
    -------
    dict of str to dict of str to PairedDifference
        Response -> pair -> ``levels``, ``difference``, ``se``, ``ci`` (the response's unit), ``p`` and
        ``beyond_noise``.
    """
    out = {}
    for n, ra in rep.responses.items():
        per = {}
        for p in pairs:
            pd_ = ra.factors[p].paired or []
            if pd_:
                q = max(pd_, key=lambda q: q.levels[1] - q.levels[0])
                per[p] = PairedDifference(**{**fields_of(q), "beyond_noise": bool(ra.factors[p].significant)})
        out[n] = per
    return out
