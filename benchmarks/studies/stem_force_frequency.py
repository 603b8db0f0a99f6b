"""How the stem force grows with the shaking frequency in the model (docs/harvest.md, "Trends"): the reference machine
at its configured clearances, driven past the reference branch at 60-180 r/min (1-3 Hz), the same perturbed starts
at every speed (paired).  Per start and fruit position, the exponent n of F ~ f^n is the least-squares slope of
ln F against ln f over the five speeds, for the peak stem force and for the RMS of its fluctuation while the branch
is inside the comb; the table gives the starts' mean slope and its standard error.  Writes
benchmarks/studies/results/stem_force_frequency.json.
Usage: ``python benchmarks/studies/stem_force_frequency.py [--starts N]``.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from berryshaker.config import machine_from_dict, reference_machine
from berryshaker.harvest.coupled import simulate_fruit_force
from berryshaker.harvest.virtual import with_drive_speed
from berryshaker.multibody.perturbation import RandomInitialPerturbation

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import default_out, write_results  # noqa: E402

SPEEDS_RPM = (60, 90, 120, 150, 180)
#: the starts' seed family (RandomInitialPerturbation seeds first_seed .. first_seed + starts - 1)
FIRST_SEED = 1000


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--starts", type=int, default=8)
    ap.add_argument("--out", type=Path, default=default_out("stem_force_frequency"))
    args = ap.parse_args(argv)
    machine = reference_machine()
    data = machine.model_dump(mode="json")
    names = list(machine.plant.fruit.names)
    peak = np.zeros((args.starts, len(SPEEDS_RPM), len(names)))
    fluct = np.zeros_like(peak)
    for j, rpm in enumerate(SPEEDS_RPM):
        m = machine_from_dict(with_drive_speed(data, rpm * 2 * math.pi / 60))
        for i in range(args.starts):
            r = simulate_fruit_force(m, initial_perturbation=RandomInitialPerturbation(FIRST_SEED + i))
            inside = np.abs(r.distance) <= r.result.compiled.spec.plant.half_span
            for k, n in enumerate(names):
                f = r.fruit_force[n]
                peak[i, j, k] = np.max(np.abs(f))
                fluct[i, j, k] = np.std(f[inside])
        print(f"{rpm} r/min done", file=sys.stderr)
    lnf = np.log(np.array(SPEEDS_RPM) / 60.0)
    out = {}
    for label, arr in (("peak", peak), ("fluctuation_rms", fluct)):
        out[label] = {}
        for k, n in enumerate(names):
            slopes = np.array([np.polyfit(lnf, np.log(arr[i, :, k]), 1)[0] for i in range(args.starts)])
            out[label][n] = {"exponent_mean": float(slopes.mean()),
                             "exponent_se": float(slopes.std(ddof=1) / math.sqrt(args.starts)),
                             "mean_N_by_speed": [float(v) for v in arr[:, :, k].mean(axis=0)]}
            print(f"{label:16s} {n:7s} n = {slopes.mean():.2f} +- {slopes.std(ddof=1) / math.sqrt(args.starts):.2f}")
    write_results(args.out, "stem_force_frequency", {"starts": args.starts, "first_seed": FIRST_SEED,
                                                     "speeds_rpm": list(SPEEDS_RPM)}, out)
    return out


if __name__ == "__main__":
    main()
