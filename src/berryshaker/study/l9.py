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
    return an
