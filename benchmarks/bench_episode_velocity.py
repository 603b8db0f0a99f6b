"""Before / after of the episode impact velocity (benchmarks/README.md sec. 8): plain harvester runs of the
reference machine (2 cam revolutions, rtol 1e-6) over the reference clearances and 8 clearance sets drawn
0.5-1.5x around them (seed 1, as ``bench_sweep_throughput.py``).

CPU time (``time.process_time``) per run after a warm-up; ``--compare OLD_SRC`` runs the same sets with another
source tree in alternating child processes (``PYTHONPATH``), so that both versions share one machine load:

    .venv/bin/python benchmarks/bench_episode_velocity.py --compare /tmp/episode_old/src
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


def run_sets(n_sets: int) -> list[dict]:
    """Warm up, then run the reference clearances and ``n_sets`` drawn sets in this process."""
    from berryshaker.config import reference_machine
    from berryshaker.drives.simulation import simulate_multibody

    m = reference_machine()
    ref = m.clearance_sizes()
    rng = np.random.default_rng(1)
    sets = [None] + [{k: float(v * rng.uniform(0.5, 1.5)) for k, v in ref.items()} for _ in range(n_sets)]
    simulate_multibody(m, sets[1])  # warm-up (compile or cache load)
    out = []
    for i, c in enumerate(sets):
        c0 = time.process_time()
        _, s = simulate_multibody(m, c)
        cpu = time.process_time() - c0
        out.append({"set": i, "cpu_s": cpu, "steps": s["steps"], "rejected": s["rejected_steps"],
                    "pairs": {p: {q: v[q] for q in ("mean", "rms", "p95", "peak")}
                              for p, v in s["collision_force_N"].items()},
                    "drive_mean_Nm": s["drive_moment_Nm"]["mean"]})
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=8)
    ap.add_argument("--compare", default=None, help="source tree of the 'before' version (its src directory)")
    ap.add_argument("--json", action="store_true", help="print the results as JSON (child mode)")
    args = ap.parse_args()
    if args.compare is None:
        res = run_sets(args.sets)
        print(json.dumps(res) if args.json else "\n".join(map(str, res)))
        return
    here = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "src")
    cmd = [sys.executable, os.path.abspath(__file__), "--sets", str(args.sets), "--json"]
    result = {}
    for label, src in (("before", args.compare), ("after", here)):
        env = dict(os.environ, PYTHONPATH=src)
        p = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
        result[label] = json.loads(p.stdout.strip().splitlines()[-1])
    print(json.dumps(result))


if __name__ == "__main__":
    main()
