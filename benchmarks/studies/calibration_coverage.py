"""Do the calibration's 90 % intervals cover the truth when the sheets carry a field's noise?

Simulation-based calibration (Talts et al. 2018) at the command's sizes: the one-class harvest machine, a 2 x 2 sheet
(clearance C 0.1 / 0.2 mm x drive speed 100 / 150 r/min) with 3 replicates, parameters drawn from the prior; every
replicate a distinct fresh machine start with its own bushes and counted fruit (berryshaker.harvest.virtual
.field_test), times a further multiplicative field noise of CV 0.15 that the likelihood models only as an additive
field-noise term.  The simulator (``harvest.replicates`` training starts per setting), the emulator (40 Latin-hypercube
points per setting) and the sampler (until 50 autocorrelation times) are the command's; the emulator is trained once,
as every sheet has the same settings.  Accepted: at least 85 % of the parameter checks inside their 90 % intervals.

Writes benchmarks/studies/results/calibration_coverage.json (``--sheets 6``: 36 checks, about 15 CPU-min).

Usage::

    .venv/bin/python benchmarks/studies/calibration_coverage.py [--sheets 6] [--workers 2] [--cache DIR] [--out PATH]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import default_out, write_results  # noqa: E402

from berryshaker.config import load_machine, machine_from_dict  # noqa: E402
from berryshaker.experiment.field_sheet import parse_factor  # noqa: E402
from berryshaker.runs.runner import SweepRunner  # noqa: E402
from berryshaker.study import field_calibration as fc  # noqa: E402

FACTORS = ("C=0.1,0.2mm", "speed=100,150rpm")
REPLICATES = 3
FIELD_NOISE = 0.15


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sheets", type=int, default=6)
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--cache", default=None)
    ap.add_argument("--out", default=str(default_out("calibration_coverage")))
    a = ap.parse_args()
    d = load_machine(None).model_dump()
    d["harvest"]["branch_classes"] = (1.0,)
    machine = machine_from_dict(d)
    r_sim = machine.harvest.replicates
    params = fc.parameters_for(machine)
    rng = np.random.default_rng(2026)
    with SweepRunner(workers=a.workers, cache_dir=a.cache) as runner:
        plan = fc.synthetic_sheet(machine, runner, [parse_factor(f) for f in FACTORS], array="L4",
                                  replicates=REPLICATES)
        sheet0 = fc.read_sheet(plan.to_csv(index=False), machine)
        sim = fc.Simulator(machine, sheet0.targets)
        idx = [sim.setting_index(x) for x in sheet0.settings_si]
        settings = sorted(set(idx))
        starts = fc.training_starts(machine, r_sim)
        sim.run(runner, settings, starts, "coverage: training starts")
        responses = list(sheet0.observations)
        emulator = fc.Emulator(sheet0.targets, responses, 0, r_sim)
        u = fc.latin_hypercube(40, 1)
        emulator.fit([sim.settings[i] for i in settings], u, *fc._train(sim, responses, settings, starts, u, params))
        check = fc._emulator_check(sim, emulator, settings, starts, fc.latin_hypercube(8, 2), params)
        for gps in emulator.local:
            for r in responses:
                gps[r].mse_log_mean = check[r].mse_log_mean
        pool = fc.fresh_starts(len(settings) * REPLICATES * a.sheets)
        jobs = [(s, pool[(i * len(settings) + j) * REPLICATES + k]) for i in range(a.sheets)
                for j, s in enumerate(settings) for k in range(REPLICATES)]
        sim.run_starts(runner, jobs, "coverage: fresh starts")
        sig = np.sqrt(np.log1p(FIELD_NOISE**2))
        sheets, covered, total = [], 0, 0
        for i in range(a.sheets):
            theta = fc.theta_of(rng.uniform(0.02, 0.98, (1, len(params))), params)[0]
            th = dict(zip(fc.PARAMETER_NAMES, theta))
            obs = {r: np.zeros((len(idx), REPLICATES)) for r in responses}
            for row, s in enumerate(idx):
                ks = [k for s2, k in jobs[i * len(settings) * REPLICATES:(i + 1) * len(settings) * REPLICATES]
                      if s2 == s]
                res = sim.field_results(s, ks, th, responses)
                res = np.nan_to_num(res) * np.exp(-0.5 * sig**2 + sig * rng.standard_normal(res.shape))
                for col, r in enumerate(responses):
                    obs[r][row] = res[:, col]
            stats = fc.SheetStatistics.of(emulator, sheet0.settings_si, obs)
            post = fc.sample_posterior(emulator, stats, params, r_sim, i, responses)
            lo, hi = np.quantile(post["theta"], [0.05, 0.95], axis=0)
            inside = (lo <= theta) & (theta <= hi)
            covered += int(inside.sum())
            total += len(params)
            sheets.append({"theta": th, "lo90": dict(zip(fc.PARAMETER_NAMES, lo)),
                           "hi90": dict(zip(fc.PARAMETER_NAMES, hi)), "inside": dict(zip(fc.PARAMETER_NAMES,
                                                                                      inside.tolist())),
                           "steps": post["steps"], "converged": post["converged"]})
            print(f"sheet {i + 1}: {int(inside.sum())} of {len(params)} inside ({post['steps']} steps)")
    per = {n: sum(s["inside"][n] for s in sheets) for n in fc.PARAMETER_NAMES}
    print(f"coverage {covered} / {total} = {covered / total:.3f}; per parameter {per}")
    write_results(a.out, "calibration_coverage", {"sheets": a.sheets, "replicates": REPLICATES,
                                                  "field_noise_cv": FIELD_NOISE, "factors": FACTORS, "r_sim": r_sim},
                  {"covered": covered, "total": total, "fraction": covered / total, "per_parameter": per,
                   "accepted": covered >= 0.85 * total, "sheets": sheets})


if __name__ == "__main__":
    main()
