"""Is calibrate's 4000-step cap long enough for the posterior's 90 % intervals?

On the reference machine's L9 sheet (``synthetic_sheet`` at the study's clearance levels, ``ripe_pull`` 0.40 N and
``yield_per_bush`` 0.6 kg, 3 replicates; the command's simulator, 48-point emulator and its held-out check), the
sampler runs twice at its default (until 50 autocorrelation times, at most 4000 steps) and twice at 8000 fixed steps,
two seeds each.  Compared: the 5 %, 50 % and 95 % posterior quantiles of every parameter in the prior's unit cube,
capped against long chain of the same seed, and seed against seed at each length (the sampler's own noise).

Writes benchmarks/studies/results/sampler_chain_length.json (about 6 CPU-min of sampling after the runs).

Usage::

    .venv/bin/python benchmarks/studies/sampler_chain_length.py [--workers 2] [--cache DIR] [--out PATH]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import default_out, write_results  # noqa: E402

from berryshaker.config import reference_machine  # noqa: E402
from berryshaker.experiment.field_sheet import parse_factor  # noqa: E402
from berryshaker.runs.runner import SweepRunner  # noqa: E402
from berryshaker.study import field_calibration as fc  # noqa: E402
from berryshaker.study.field_calibration.workflow import _emulator_check, _train  # noqa: E402

FACTORS = ("A=0.25,0.5,0.75mm", "B=0.2,0.4,0.6mm", "C=0.1,0.15,0.2mm", "F=0.1,0.15,0.2mm")
THETA = {"ripe_pull": 0.40, "yield_per_bush": 0.6}
CHAINS = (("capped", 3, None), ("capped", 4, None), ("8000", 3, 8000), ("8000", 4, 8000))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--cache", default=None)
    ap.add_argument("--out", default=str(default_out("sampler_chain_length")))
    a = ap.parse_args()
    m = reference_machine()
    with SweepRunner(workers=a.workers, cache_dir=a.cache) as runner:
        plan = fc.synthetic_sheet(m, runner, [parse_factor(f) for f in FACTORS], theta=THETA, array="L9",
                                  replicates=3)
        sheet = fc.read_sheet(plan.to_csv(index=False), m)
        params = fc.parameters_for(m)
        responses = [r for r in fc.calibrated_responses() if r in sheet.observations]
        r_sim = m.harvest.replicates
        sim = fc.Simulator(m, sheet.targets)
        unique = sorted({sim.setting_index(x) for x in sheet.settings_si})
        starts = fc.training_starts(m, r_sim)
        sim.run(runner, unique, starts, "sampler study: simulator starts")
    emulator = fc.Emulator(sheet.targets, responses, 0, r_sim)
    u_train = fc.latin_hypercube(48, 1)
    emulator.fit([sim.settings[i] for i in unique], u_train, *_train(sim, responses, unique, starts, u_train, params))
    held = _emulator_check(sim, emulator, unique, starts, fc.latin_hypercube(8, 2), params)
    for gps in emulator.local:
        for r in responses:
            gps[r].mse_log_mean = held[r].mse_log_mean
    stats = fc.SheetStatistics.of(emulator, sheet.settings_si, sheet.observations)
    chains = {}
    for length, seed, steps in CHAINS:
        t = time.process_time()
        post = fc.sample_posterior(emulator, stats, params, r_sim, seed, responses, steps=steps)
        q = np.quantile(post["u"], [0.05, 0.5, 0.95], axis=0)
        chains[f"{length}_seed{seed}"] = {"quantiles_u": q.tolist(), "steps": post["steps"],
                                          "tau_max": max(post["autocorrelation_steps"]),
                                          "converged": post["converged"], "draws": len(post["u"]),
                                          "cpu_s": time.process_time() - t}
        print(f"{length} seed {seed}: {post['steps']} steps, tau {chains[f'{length}_seed{seed}']['tau_max']:.0f}, "
              f"converged {post['converged']}")
    names = [p.name for p in params]

    def gap(x, y):
        d = np.abs(np.array(chains[x]["quantiles_u"]) - np.array(chains[y]["quantiles_u"]))
        return {"q05": float(d[0].max()), "q50": float(d[1].max()), "q95": float(d[2].max()),
                "worst": names[int(d.max(axis=0).argmax())]}

    gaps = {"capped_vs_8000_seed3": gap("capped_seed3", "8000_seed3"),
            "capped_vs_8000_seed4": gap("capped_seed4", "8000_seed4"),
            "seed3_vs_seed4_capped": gap("capped_seed3", "capped_seed4"),
            "seed3_vs_seed4_8000": gap("8000_seed3", "8000_seed4")}
    for k, v in gaps.items():
        print(f"{k}: max |dq| {v['q05']:.3f} / {v['q50']:.3f} / {v['q95']:.3f} ({v['worst']})")
    cap = max(max(gaps[k][q] for q in ("q05", "q50", "q95")) for k in gaps if k.startswith("capped_vs"))
    noise = max(max(gaps[k][q] for q in ("q05", "q50", "q95")) for k in gaps if k.startswith("seed3"))
    write_results(a.out, "sampler_chain_length", {"factors": FACTORS, "theta": THETA, "chains": CHAINS},
                  {"chains": chains, "gaps": gaps, "cap_shift": cap, "seed_noise": noise,
                   "cap_inside_noise": cap <= noise})


if __name__ == "__main__":
    main()
