"""Cost of coupled drive-past runs from perturbed starts, and of one plain harvester run (benchmarks/README.md
sec. 7).

Each case runs once after a warm-up (numba compile or cache load outside the timing); CPU time by
``time.process_time``.  ``--compare OLD_SRC`` runs the same cases with another source tree (e.g. a ``git archive``
of the previous commit's ``src``) in alternating child processes, so that before and after share one machine load:

    .venv/bin/python benchmarks/bench_step_blowup.py --replicates 0 1 2 --compare /tmp/blowup_old/src
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

# the generic kernel unless the caller sets BERRYSHAKER_KERNEL (a run left to choose would take a specialised
# one once compiled on this machine: multibody.specialised)
os.environ.setdefault("BERRYSHAKER_KERNEL", "generic")


def coupled_case(n_modes: int, k: int, rtol: float) -> dict:
    """Coupled drive-past run of the reference machine from replicate k's perturbed start."""
    from berryshaker.config import machine_from_dict, reference_machine
    from berryshaker.harvest.coupled import simulate_fruit_force
    from berryshaker.multibody.perturbation import RandomInitialPerturbation

    m0 = reference_machine()
    h = m0.harvest
    d = m0.model_dump()
    d["plant"]["contact"]["n_modes"] = n_modes
    m = machine_from_dict(d)
    pert = RandomInitialPerturbation((h.seed + 1000 * k, 1), h.initial_eccentricity, h.start_phase_spread)
    c0 = time.process_time()
    r = simulate_fruit_force(m, None, initial_perturbation=pert, rtol=rtol)
    cpu = time.process_time() - c0
    s = r.result.summary()
    return {"case": f"coupled n_modes {n_modes} k {k} rtol {rtol:g}", "cpu_s": cpu, "steps": s["steps"],
            "rejected": s["rejected_steps"], "event_cuts": s["event_cuts"],
            "fruit_force_peak_N": {f: float(np.max(np.abs(v))) for f, v in r.fruit_force.items()}}


def harvester_case() -> dict:
    """The plain harvester run (``berryshaker simulate --model multibody`` of the reference machine)."""
    from berryshaker.config import reference_machine
    from berryshaker.drives.simulation import simulate_multibody

    c0 = time.process_time()
    res, _ = simulate_multibody(reference_machine())
    cpu = time.process_time() - c0
    s = res.summary()
    return {"case": "harvester multibody (reference)", "cpu_s": cpu, "steps": s["steps"],
            "rejected": s["rejected_steps"], "event_cuts": s["event_cuts"],
            "joints_peak_N": {n: round(float(p), 3) for n, p in zip(res.compiled.frc_names, res.peaks) if p > 0},
            "joints_rms_N": {n: round(j["force_N"]["rms"], 3) for n, j in s["joints"].items()}}


def run_cases(args) -> list[dict]:
    """Warm up, then run every case of ``args`` in this process."""
    coupled_case(args.modes, 0, 1e-3)  # compile / load the cache
    out = []
    if args.harvester:
        harvester_case()
        out.append(harvester_case())
    for k in args.replicates:
        out.append(coupled_case(args.modes, k, args.rtol))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--modes", type=int, default=8)
    ap.add_argument("--rtol", type=float, default=1e-6, help="sec. 7 was measured at 1e-6; the coupled runs use 1e-5 since sec. 21")
    ap.add_argument("--replicates", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--harvester", action="store_true", help="also time the plain harvester run")
    ap.add_argument("--compare", default=None, help="source tree of the 'before' version (its src directory)")
    ap.add_argument("--json", action="store_true", help="print the results as JSON (child mode)")
    a = ap.parse_args()
    if a.compare is None:
        res = run_cases(a)
        print(json.dumps(res) if a.json else "\n".join(str(r) for r in res))
        return
    here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src")
    base = [sys.executable, os.path.abspath(__file__), "--modes", str(a.modes), "--rtol", str(a.rtol), "--json",
            "--replicates", *map(str, a.replicates)] + (["--harvester"] if a.harvester else [])
    results = {}
    for label, src in (("before", a.compare), ("after", here)):
        env = dict(os.environ, PYTHONPATH=os.path.abspath(src))
        out = subprocess.run(base, env=env, capture_output=True, text=True, check=True).stdout
        results[label] = json.loads(out.strip().splitlines()[-1])
    for b, af in zip(results["before"], results["after"]):
        print(f"{b['case']:<40} before {b['cpu_s']:7.2f} s {b['steps']:>9,} steps | after {af['cpu_s']:7.2f} s "
              f"{af['steps']:>9,} steps")
        print(f"    before {b}\n    after  {af}")


if __name__ == "__main__":
    main()
