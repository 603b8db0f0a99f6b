"""Calibrate the reference machine's picking parameters on the statistic the study reports (docs/harvest.md).

Runs the perturbed starts at the configured clearances (A1B1C1F3) sequentially, as the study's calibration step
does (:func:`berryshaker.study.l9.sequential_starts`: batches of ``harvest.replicates`` starts until every harvest
index's standard error is within ``harvest.se_target`` of its mean), prints the indexes at the stored values, fits
``yield_per_bush`` and ``damage_acceleration`` on the converged mean and prints them with their standard errors.
Usage: ``python benchmarks/studies/calibrate_harvest_replicates.py [--workers N] [--cache DIR]``.
"""

from __future__ import annotations

import argparse

import numpy as np

from berryshaker.config import reference_machine
from berryshaker.harvest.virtual import calibrate_harvest
from berryshaker.runs.runner import SweepRunner
from berryshaker.study.l9 import sequential_starts


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--cache", default=None)
    a = ap.parse_args()
    machine = reference_machine()
    h = machine.harvest
    with SweepRunner(workers=a.workers, cache_dir=a.cache) as runner:
        seq = sequential_starts(machine, runner, machine.clearance_sizes(), label="calibration starts")
    reps = [([np.array(v["envelope"]) for v in o], sd) for o, sd in zip(seq["outputs"], seq["seeds"])]
    print(f"clearances (mm): { {p: v * 1e3 for p, v in machine.clearance_sizes().items()} }")
    print(seq["statement"])
    stored = calibrate_harvest(machine, fit=(), replicates=reps)
    print(f"stored: yield_per_bush {h.yield_per_bush:.6g} kg, damage_acceleration {h.damage_acceleration:.6g} m/s^2 "
          f"-> efficiency {stored['check']['efficiency_kg_min']:.4f} kg/min, damage "
          f"{stored['check']['damage_rate_pct']:.4f} %, unripe {stored['check']['unripe_rate_pct']:.4f} %")
    fit = calibrate_harvest(machine, replicates=reps)
    u = fit["uncertainty"]
    print(f"fitted on {fit['replicates']} starts: yield_per_bush {fit['yield_per_bush_kg']:.6g} +- "
          f"{u['yield_per_bush_kg']:.2g} kg, damage_acceleration {fit['damage_acceleration_m_s2']:.6g} +- "
          f"{u['damage_acceleration_m_s2']:.2g} m/s^2 (SE; {u['method']})")
    for key in ("efficiency_kg_min", "damage_rate_pct", "unripe_rate_pct"):
        print(f"  refit values, mean over the starts {key}: {fit['check'][key]:.4f}")


if __name__ == "__main__":
    main()
