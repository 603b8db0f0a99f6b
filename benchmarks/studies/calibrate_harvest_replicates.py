"""Calibrate the reference machine's picking parameters on the virtual L9's statistic (docs/harvest.md).

Runs the replicated drive-pasts at the configured clearances (A1B1C1F3; ``harvest.replicates`` replicates,
the L9's seeds and perturbation), prints the replicate-mean indexes with the stored values, fits
``yield_per_bush`` and ``damage_acceleration`` on the replicate mean, and prints the refit indexes and the CPU
time.  Usage: ``python benchmarks/studies/calibrate_harvest_replicates.py [replicates]``.

The default it chooses: the reference machine's ``harvest.yield_per_bush`` and ``harvest.damage_acceleration``,
stored in src/berryshaker/drives/groove_cam/reference.toml (which cites this script) and checked by
tests/test_experiment.py; every earlier fit is listed in docs/harvest.md.  It prints the fit (no JSON written).
"""

from __future__ import annotations

import sys
import time

import numpy as np

from berryshaker.config import reference_machine
from berryshaker.harvest.virtual import calibrate_harvest, harvest_indexes, sample_population
from berryshaker.study.l9 import replicate_envelopes, replicate_jobs, replicate_seeds
from berryshaker.study.runs import replicate_run


def main(replicates: int | None = None) -> None:
    machine = reference_machine()
    seeds = replicate_seeds(machine, replicates)
    t0 = time.process_time()
    outs = [replicate_run(**job) for job in replicate_jobs(machine, machine.clearance_sizes(), seeds)]
    t_runs = time.process_time() - t0
    reps = replicate_envelopes(machine, outs, seeds)
    before = [harvest_indexes(machine, env, sample_population(machine, seed=sd)) for env, sd in reps]
    h = machine.harvest
    print(f"clearances (mm): { {p: v * 1e3 for p, v in machine.clearance_sizes().items()} }")
    print(f"{len(reps)} replicates (seeds {seeds}), {len(outs)} coupled runs, CPU {t_runs:.1f} s")
    print(f"stored: yield_per_bush {h.yield_per_bush:.6g} kg, damage_acceleration {h.damage_acceleration:.6g} m/s^2")
    for key in ("efficiency_kg_min", "damage_rate_pct", "unripe_rate_pct"):
        v = [b[key] for b in before]
        print(f"  stored values, replicate mean {key}: {np.mean(v):.4f}  (per replicate {np.round(v, 4).tolist()})")
    t1 = time.process_time()
    fit = calibrate_harvest(machine, replicates=reps)
    print(f"fit CPU {time.process_time() - t1:.1f} s")
    print(f"fitted: yield_per_bush {fit['yield_per_bush_kg']:.6g} kg, damage_acceleration "
          f"{fit['damage_acceleration_m_s2']:.6g} m/s^2")
    for key in ("efficiency_kg_min", "damage_rate_pct", "unripe_rate_pct"):
        print(f"  refit values, replicate mean {key}: {fit['check'][key]:.4f}")


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("replicates", nargs="?", type=int, default=None,
                    help="replicates (default: the reference machine's harvest.replicates)")
    main(ap.parse_args(sys.argv[1:]).replicates)
