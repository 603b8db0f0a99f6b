"""Does the per-start spread of the virtual harvest hold for starts the project never draws?

The study behind docs/harvest.md "Replicates" (seed families): at the study's recommended clearances (A1B1C1F3), the
project's own family (``harvest.seed``, starts 0 .. n - 1: the starts the L9 and the recommendation use) against
three families the project never uses (other SeedSequence entropies, the same start numbers), for every harvest
response's model expectation (the model's start-to-start spread) and counted field result (a field test's spread):
each family's SD with its sampling error, the project's SD over the pooled fresh families' with its F interval, and
Levene's test of equal variances (berryshaker.experiment.noise.family_agreement).  Accepted: the ratio within
0.8-1.25 for every response of the expectation.

Writes benchmarks/studies/results/seed_families.json (~128 starts x 3 branch classes: about 6 CPU-min on the
reference machine).

Usage::

    .venv/bin/python benchmarks/studies/seed_families.py [--starts 32] [--workers 2] [--cache DIR] [--out PATH]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import default_out, write_results  # noqa: E402

from berryshaker.config import machine_from_dict, reference_machine  # noqa: E402
from berryshaker.experiment.noise import family_agreement  # noqa: E402
from berryshaker.harvest.virtual import RESPONSES, replicate_starts  # noqa: E402
from berryshaker.runs.runner import SweepRunner  # noqa: E402
from berryshaker.study.replicate_responses import EXPECTED, start_cells  # noqa: E402

#: the study's recommended clearances (A1B1C1F3), m
CLEARANCE = {"A": 0.25e-3, "B": 0.2e-3, "C": 0.1e-3, "F": 0.2e-3}
#: SeedSequence entropies the project never uses
FRESH = (7919, 104729, 1299709)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--starts", type=int, default=32)
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--cache", default=None)
    ap.add_argument("--out", default=str(default_out("seed_families")))
    a = ap.parse_args()
    base = reference_machine()
    names = [n + s for n in RESPONSES for s in (EXPECTED, "")]
    families = {}
    with SweepRunner(workers=a.workers, cache_dir=a.cache) as runner:
        for fam in (base.harvest.seed, *FRESH):
            d = base.model_dump(mode="json")
            d["harvest"]["seed"] = int(fam)
            m = machine_from_dict(d)
            cells = start_cells(m, runner, CLEARANCE, replicate_starts(m, a.starts), d, f"family {fam}")
            families[f"seed {fam}"] = {n: [c[n] for c in cells] for n in names}
    project = next(iter(families))
    pooled = {n: np.concatenate([families[f][n] for f in families if f != project]) for n in names}
    res = family_agreement({project: families[project], "fresh families": pooled})
    fresh_only = family_agreement({f: families[f] for f in families if f != project})
    verdict = {n: bool(0.8 <= res["responses"][n]["ratio"] <= 1.25) for n in names if n.endswith(EXPECTED)}
    for n in names:
        r = res["responses"][n]
        print(f"{n:>24}: project SD {r['sd'][project]:.4g}, fresh {r['sd']['fresh families']:.4g}, ratio "
              f"{r['ratio']:.3f} [{r['ratio_ci'][0]:.2f}, {r['ratio_ci'][1]:.2f}], Levene p {r['levene_p']:.2f}")
    print("within 0.8-1.25 (expectation):", verdict)
    write_results(a.out, "seed_families", {"starts": a.starts, "fresh": list(FRESH), "clearance_m": CLEARANCE},
                  {"project_vs_fresh": res, "fresh_among_themselves": fresh_only, "within_0.8_1.25": verdict,
                   "values": families})


if __name__ == "__main__":
    main()
