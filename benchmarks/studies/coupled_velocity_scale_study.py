"""The convergence study behind ``harvest.spec.COUPLED_VELOCITY_SCALE`` (1 m/s), the velocity scale of every coupled
machine-plant run's error control.  Cited by ``src/berryshaker/harvest/spec.py`` (``COUPLED_VELOCITY_SCALE``),
docs/harvest.md ("Solver tolerance of the coupled runs") and tests/harvest/test_coupled_tolerance.py.  Writes benchmarks/studies/results/coupled_velocity_scale.json (``--out``).

The coupled machine-plant runs (the virtual L9's replicates, the calibration, the harvest against frequency) hold
a velocity's error absolutely below rtol x the velocity scale.  For each candidate scale, 16 replicates of the
recommended clearances (A1B1C1F3, the L9's seeds and perturbed starts, 3 branch classes each) are run at
``COUPLED_RTOL`` and compared with the same replicates at rtol 1e-7 and the engine's 0.1 m/s, response by
response, as in tests/harvest/test_coupled_tolerance.py: the mean of the paired differences in replicate SDs (pooled
over the two settings) and its standard error.  Responses: what a replicate reports (harvest indexes, peak force
of every clearance pair, drive torque peak and RMS) and, finer than the indexes, the mean of each branch
class's peak stem-force table.  Printed per scale: step attempts and CPU per replicate job, the responses beyond
2 SE (a systematic shift) and beyond the test's bound (1 SD).

    .venv/bin/python benchmarks/studies/coupled_velocity_scale_study.py [--replicates 16] [--scales 0.1 1 3 10]  # ~6 min
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import time

import numpy as np
from _results import default_out, write_results  # benchmarks/studies/ (the script's own folder) is on sys.path

from berryshaker.config import reference_machine
from berryshaker.harvest import coupled
from berryshaker.harvest.spec import COUPLED_RTOL
from berryshaker.harvest.virtual import class_starts, class_tables_run, replicate_starts
from berryshaker.study.replicate_responses import _cell, replicate_jobs
from berryshaker.study.runs import replicate_record

# the generic kernel unless the caller sets BERRYSHAKER_KERNEL (a run left to choose would take a specialised
# one once compiled on this machine: multibody.specialised)
os.environ.setdefault("BERRYSHAKER_KERNEL", "generic")

CLEARANCE = {"A": 0.25e-3, "B": 0.2e-3, "C": 0.1e-3, "F": 0.2e-3}  # A1B1C1F3, m
REFERENCE = (1e-7, 0.1)  # rtol, velocity scale (m/s)


def _job(args):
    """One replicate job (one start's drive-past carrying every branch class) at (rtol, scale): the replicate's
    output as ``study.runs.replicate_run`` gives it, each class's table mean, step attempts and CPU seconds."""
    rtol, scale, job = args
    coupled.COUPLED_VELOCITY_SCALE = scale  # read when the coupled mechanism is built (a forked worker's copy)
    machine = reference_machine()
    c0 = time.process_time()
    tables, res = class_tables_run(machine, job["clearance"], class_starts(machine, job["seed"]), rtol)
    cpu = time.process_time() - c0
    return (replicate_record(machine, tables, res), [float(np.mean(t)) for t in tables],
            float(res.info[0] + res.info[1] + res.info[2]), cpu)


def responses(pool, rtol: float, scale: float, replicates: int):
    """Every response of each replicate (name -> array over replicates), mean attempts and CPU per job."""
    machine = reference_machine()
    seeds = replicate_starts(machine, replicates)
    jobs = replicate_jobs(machine, CLEARANCE, seeds, rtol=rtol)
    res = pool.map(_job, [(rtol, scale, j) for j in jobs], chunksize=1)
    cells = []
    for r, sd in zip(res, seeds):
        c = _cell(machine, r[0], sd)
        for ci, mean in enumerate(r[1]):
            c[f"stem_force_table_mean_class{ci + 1}"] = mean
        cells.append(c)
    return ({n: np.array([c[n] for c in cells]) for n in cells[0]}, float(np.mean([r[2] for r in res])),
            float(np.mean([r[3] for r in res])))


def paired(loose: dict, ref: dict) -> dict[str, tuple[float, float]]:
    """Per response: mean paired difference and its SE, in replicate SDs pooled over the two settings."""
    out = {}
    for n, b in ref.items():
        d = loose[n] - b
        sd = float(np.sqrt((np.var(loose[n], ddof=1) + np.var(b, ddof=1)) / 2))
        if sd == 0.0:
            out[n] = (0.0, 0.0) if np.all(d == 0.0) else (np.inf, 0.0)
            continue
        out[n] = (float(np.mean(d)) / sd, float(np.std(d, ddof=1) / np.sqrt(d.size)) / sd)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--replicates", type=int, default=16)
    ap.add_argument("--scales", type=float, nargs="+", default=[0.1, 1.0, 3.0, 10.0], help="m/s")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=str(default_out("coupled_velocity_scale")), help="JSON of the results")
    a = ap.parse_args()
    data = {"clearance_m": CLEARANCE, "coupled_rtol": COUPLED_RTOL, "reference": {"rtol": REFERENCE[0],
            "velocity_scale_m_s": REFERENCE[1]}, "scales": []}
    with multiprocessing.get_context("fork").Pool(a.workers) as pool:
        ref, ref_att, ref_cpu = responses(pool, *REFERENCE, a.replicates)
        print(f"reference rtol {REFERENCE[0]:g}, {REFERENCE[1]:g} m/s: {ref_att:.0f} attempts, {ref_cpu:.3f} s CPU "
              f"per job; {a.replicates} replicates")
        data["reference"].update(attempts_per_job=ref_att, cpu_s_per_job=ref_cpu)
        for scale in a.scales:
            cur, att, cpu = responses(pool, COUPLED_RTOL, scale, a.replicates)
            v = paired(cur, ref)
            shifted = {n: f"{m:+.2f} +- {se:.2f}" for n, (m, se) in v.items() if abs(m) > 2 * se and m != 0.0}
            beyond = sorted(n for n, (m, se) in v.items() if abs(m) > 1.0 or se > 0.5)
            print(f"\nrtol {COUPLED_RTOL:g}, {scale:g} m/s: {att:.0f} attempts, {cpu:.3f} s CPU per job")
            for n, (m, se) in v.items():
                rel = float(np.mean(cur[n]) / np.mean(ref[n]) - 1.0) if np.mean(ref[n]) else 0.0
                print(f"  {n:34s} {m:+.2f} +- {se:.2f} SD  (means {100 * rel:+.2f} %)")
            print(f"  beyond 2 SE: {shifted or 'none'}; beyond the test's bound (1 SD, SE 0.5): {beyond or 'none'}")
            data["scales"].append({"velocity_scale_m_s": scale, "attempts_per_job": att, "cpu_s_per_job": cpu,
                                   "paired_difference_sd": {n: {"mean": m, "se": se} for n, (m, se) in v.items()},
                                   "beyond_2se": sorted(shifted), "beyond_test_bound": beyond})
    write_results(a.out, "coupled_velocity_scale", vars(a), data)


if __name__ == "__main__":
    main()
