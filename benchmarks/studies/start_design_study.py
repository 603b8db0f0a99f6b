"""How a virtual start samples the drive phase: independent phases per branch class, or phases spread evenly?

The study behind docs/harvest.md "Replicates" (why each branch class of a start keeps a drive phase of its own).
The study runs one coupled drive-past per branch class and start (the virtual harvest's ``study.runs.replicate_run``
carries the classes as probes of one run, each at its own class's phase); the phase
at which the comb meets the branch dominates the spread of the harvest indexes.  Two designs of the same cost
(one run per class and start, the same clearance eccentricities, the same population per start):

* ``independent`` (the package's): class c of start k draws its phase uniformly in +-``harvest.start_phase_spread``
  (``RandomInitialPerturbation((seed_k, c), ...)``, the phases ``study.l9.replicate_jobs`` gives its classes);
* ``systematic``: start k draws one phase u_k uniformly and class c runs at u_k + 2 pi c / C (wrapped): a
  stratified design within the start; starts stay independent, so the usual standard errors hold.

For each design the per-start mean and SD (ddof 1) of efficiency, damage and unripe rate over ``--starts`` starts
at the configured clearances, the SD's standard error s / sqrt(2 (n - 1)), and the ratio of variances.
Writes benchmarks/studies/results/start_design.json (~3 CPU-min on the reference machine with 24 starts).

Usage::

    .venv/bin/python benchmarks/studies/start_design_study.py [--starts 24] [--workers 2] [--out PATH]
"""

from __future__ import annotations

import argparse
import math
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np
from _results import default_out, write_results

from berryshaker.config import reference_machine
from berryshaker.harvest.virtual import replicate_starts, start_responses, stem_force_envelope_run
from berryshaker.multibody.perturbation import InitialPerturbation, RandomInitialPerturbation

KEYS = ("efficiency", "damage", "unripe")


@dataclass(frozen=True)
class PhaseAt:
    """The clearance eccentricities of ``RandomInitialPerturbation(seed, eccentricity_fraction)`` with every driver
    started at ``phase`` (rad) instead of a drawn one."""

    seed: tuple
    eccentricity_fraction: float
    phase: float

    def for_spec(self, spec):
        drawn = RandomInitialPerturbation(self.seed, self.eccentricity_fraction, 0.0).for_spec(spec)
        return InitialPerturbation(dict(drawn.joint_offsets), {d.name: self.phase for d in spec.drivers}).for_spec(spec)


def start_indexes(design: str, seed: int) -> dict:
    """Harvest indexes of one start under ``design`` at the reference machine's clearances."""
    m = reference_machine()
    h = m.harvest
    classes = h.branch_classes
    u = float(np.random.default_rng((seed, 99)).uniform(-h.start_phase_spread, h.start_phase_spread))
    tables = []
    for c, scale in enumerate(classes):
        if design == "independent":
            pert = RandomInitialPerturbation((seed, c), h.initial_eccentricity, h.start_phase_spread)
        else:
            pert = PhaseAt((seed, c), h.initial_eccentricity,
                           (u + 2 * math.pi * c / len(classes) + math.pi) % (2 * math.pi) - math.pi)
        tables.append(stem_force_envelope_run(m, None, scale, pert)[0])
    idx = start_responses(m, tables, seed)["expected"]
    return {k: float(idx[k]) for k in KEYS}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--starts", type=int, default=24)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=str(default_out("start_design")))
    a = ap.parse_args()
    seeds = replicate_starts(reference_machine(), a.starts)
    data = {}
    with ProcessPoolExecutor(a.workers) as pool:
        for design in ("independent", "systematic"):
            each = list(pool.map(start_indexes, [design] * len(seeds), seeds))
            data[design] = {"starts": each}
            for k in KEYS:
                v = np.array([e[k] for e in each])
                s = float(np.std(v, ddof=1))
                data[design][k] = {"mean": float(v.mean()), "se": s / math.sqrt(v.size), "sd": s,
                                   "se_sd": s / math.sqrt(2 * (v.size - 1))}
    data["variance_ratio_systematic_over_independent"] = {
        k: (data["systematic"][k]["sd"] / data["independent"][k]["sd"]) ** 2 for k in KEYS}
    for design in ("independent", "systematic"):
        print(design, {k: f"{data[design][k]['mean']:.3f} (SD {data[design][k]['sd']:.3f} "
                          f"+- {data[design][k]['se_sd']:.3f})" for k in KEYS})
    print("variance ratio", {k: round(v, 2) for k, v in data["variance_ratio_systematic_over_independent"].items()})
    write_results(a.out, "start_design", vars(a), data)


if __name__ == "__main__":
    main()
