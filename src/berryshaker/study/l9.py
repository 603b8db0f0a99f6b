"""The study's L9 field test run through the virtual harvest and analysed exactly like field data."""

from __future__ import annotations

import numpy as np

from berryshaker.experiment.clearance_sets import l9_runs, level_code
from berryshaker.reference_study import CHOSEN_CODE, CHOSEN_LEVELS, PRIORITY_WEIGHTS, SENSES
from berryshaker.study.runs import envelope_run


def virtual_l9(machine, runner) -> dict:
    """The L9 over the machine's clearance pairs through the virtual harvest (envelopes via the sweep runner),
    analysed like field data; the recommended combination is run through the virtual harvest itself."""
    from berryshaker.experiment.analysis import analyze
    from berryshaker.experiment.designs import orthogonal_array
    from berryshaker.harvest.virtual import harvest_indexes, sample_population

    pairs = list(machine.pair_names)
    runs, _codes = l9_runs(machine)
    levels_m = machine.clearance_levels()
    classes = machine.harvest.branch_classes
    data = machine.model_dump(mode="json")
    jobs = [dict(machine_data=data, clearance=c, scale=s) for c in runs for s in classes]
    env = runner.values(envelope_run, jobs, "virtual L9: coupled runs")
    pop = sample_population(machine)
    results = []
    for i in range(len(runs)):
        e = [np.array(env[i * len(classes) + k]) for k in range(len(classes))]
        results.append(harvest_indexes(machine, e, pop))
    a = orthogonal_array("L9")[:, :len(pairs)] + 1
    values = np.array([[r[p] * 1e3 for p in pairs] for r in runs])
    responses = {"efficiency": np.array([r["efficiency_kg_min"] for r in results]),
                 "unripe": np.array([r["unripe_rate_pct"] for r in results]),
                 "damage": np.array([r["damage_rate_pct"] for r in results])}
    an = analyze(a, values, pairs, responses, SENSES, PRIORITY_WEIGHTS)
    an["runs"] = [{"run": i + 1, "levels": {p: int(a[i, j]) for j, p in enumerate(pairs)},
                   "clearance_mm": {p: float(values[i, j]) for j, p in enumerate(pairs)},
                   **{k: float(v[i]) for k, v in responses.items()}} for i in range(9)]
    opt = an["optimum"]["levels"]
    an["recommended"] = {"levels": opt, "code": level_code(opt),
                         "clearance_mm": {p: levels_m[p][opt[p] - 1] * 1e3 for p in pairs},
                         "study": {"code": CHOSEN_CODE}, "same_as_study": opt == CHOSEN_LEVELS}
    best_cl = {p: levels_m[p][opt[p] - 1] for p in pairs}
    jobs = [dict(machine_data=data, clearance=best_cl, scale=s) for s in classes]
    e_best = [np.array(v) for v in runner.values(envelope_run, jobs, "virtual harvest at the optimum")]
    an["recommended"]["virtual_harvest"] = harvest_indexes(machine, e_best, pop)
    an["replicated"] = replicated_l9(machine, env, classes, a, values, pairs, levels_m)
    return an


#: population seeds per L9 run for the replicate error (the sampling noise of the virtual harvest)
REPLICATES = 5


def replicated_l9(machine, env, classes, a, values, pairs, levels_m) -> dict:
    """The L9 analysed against its own noise: each run's harvest indexes for ``REPLICATES`` population seeds
    (the same simulated envelopes, independently sampled bushes and fruit), range analysis and ANOVA against the
    replicate (pure) error, effects with 95 % intervals, and a choice per factor that is "no meaningful
    difference" where the factor's effect is not significant (:func:`berryshaker.experiment.replicates.
    analyze_replicated`)."""
    from berryshaker.experiment.replicates import analyze_replicated, describe_replicated
    from berryshaker.harvest.virtual import harvest_indexes, sample_population

    seeds = [machine.harvest.seed + 1000 * k for k in range(REPLICATES)]
    pops = [sample_population(machine, seed=s) for s in seeds]
    y = {"efficiency": np.zeros((9, REPLICATES)), "unripe": np.zeros((9, REPLICATES)),
         "damage": np.zeros((9, REPLICATES))}
    for i in range(9):
        e = [np.array(env[i * len(classes) + k]) for k in range(len(classes))]
        for r, pop in enumerate(pops):
            h = harvest_indexes(machine, e, pop)
            y["efficiency"][i, r] = h["efficiency_kg_min"]
            y["unripe"][i, r] = h["unripe_rate_pct"]
            y["damage"][i, r] = h["damage_rate_pct"]
    res = analyze_replicated(a, values, pairs, y, SENSES, PRIORITY_WEIGHTS,
                             level_values={p: tuple(v * 1e3 for v in levels_m[p]) for p in pairs},
                             units={p: "mm" for p in pairs})
    res["seeds"] = seeds
    res["text"] = describe_replicated(res)
    return res
