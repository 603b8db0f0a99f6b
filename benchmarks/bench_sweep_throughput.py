"""Harvester runs per second per core: one by one, batched (one compiled call over parameter sets), and
through the sweep runner (``berryshaker.runs.sweep.model_run``, as ``berryshaker sweep --model multibody``).

Run:  .venv/bin/python benchmarks/bench_sweep_throughput.py [--sets 16]

Each run: the reference machine, 2 cam revolutions, multibody, clearances A B C F drawn uniformly from
0.5-1.5x their reference sizes (seed 1).  CPU time (``time.process_time``) after a warm-up, so numba
compilation is excluded; the batched call is timed on one thread (CPU per run) and, if the machine has
more cores, on all of them (wall).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))


def main(argv=None) -> None:
    import numba

    from berryshaker.config import reference_machine
    from berryshaker.drives.simulation import simulate_multibody, simulate_multibody_batch
    from berryshaker.runs.sweep import model_run

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sets", type=int, default=16)
    p.add_argument("--restitution-velocity", type=float, default=None,
                   help="m/s on every clearance pair (default: the pairs' own; 0: before benchmarks/README.md sec. 6)")
    args = p.parse_args(argv)
    # the generic kernel for every run not marked specialised below (the default "auto" would take the specialised
    # one when compiled on this machine); the in-process sweep runner and its runs read it
    os.environ["BERRYSHAKER_KERNEL"] = "generic"
    m = reference_machine()
    if args.restitution_velocity is not None:
        cl = {k: m.clearance[k].model_copy(update={"restitution_velocity": args.restitution_velocity})
              for k in m.pair_names}
        m = m.model_copy(update={"clearance": cl})
    ref = m.clearance_sizes()
    rng = np.random.default_rng(1)
    sets = [{k: float(v * rng.uniform(0.5, 1.5)) for k, v in ref.items()} for _ in range(args.sets)]
    machines = [m] * len(sets)

    simulate_multibody(m, sets[0])  # warm-up
    simulate_multibody_batch(machines[:2], sets[:2])
    c0 = time.process_time()
    single = [simulate_multibody(m, c)[1] for c in sets]
    cpu_single = (time.process_time() - c0) / len(sets)
    numba.set_num_threads(1)
    c0 = time.process_time()
    batched = simulate_multibody_batch(machines, sets)
    cpu_batch = (time.process_time() - c0) / len(sets)
    same = all(b[1]["collision_force_N"] == s["collision_force_N"] for b, s in zip(batched, single))
    steps = np.mean([s["steps"] for s in single])
    print(f"harvester, 2 cam revolutions, {len(sets)} clearance sets, {steps:.0f} accepted steps per run on average")
    print(f"  one by one     : {cpu_single * 1e3:6.1f} ms CPU per run = {1 / cpu_single:5.2f} runs/s/core "
          f"= {60 / cpu_single:5.0f} runs/min/core")
    print(f"  batched, 1 thr : {cpu_batch * 1e3:6.1f} ms CPU per run = {1 / cpu_batch:5.2f} runs/s/core "
          f"= {60 / cpu_batch:5.0f} runs/min/core  (results identical: {same})")
    nthr = numba.config.NUMBA_NUM_THREADS
    if nthr > 1:
        numba.set_num_threads(nthr)
        t0 = time.perf_counter()
        simulate_multibody_batch(machines, sets)
        wall = (time.perf_counter() - t0) / len(sets)
        print(f"  batched, {nthr} thr : {wall * 1e3:6.1f} ms wall per run = {1 / wall:5.2f} runs/s on {nthr} cores")
        numba.set_num_threads(1)
    data = m.model_dump(mode="json")
    jobs = [dict(machine_data=data, overrides={f"clearance.{k}.size": v for k, v in c.items()}, model="multibody",
                 revolutions=2) for c in sets]
    try:
        model_run(**jobs[0])
    except Exception as exc:  # noqa: BLE001 - the override keys may differ by drive: say so and stop
        print(f"  sweep runner   : skipped ({type(exc).__name__}: {exc})")
        return
    time_sweep_runner(jobs, "sweep runner, 1 worker (batched chunks of <= 16)")
    # the kernel specialised to the harvester's structure (berryshaker sweep --specialised; multibody.specialised):
    # compiled (or loaded) by the warm-up, outside the timing
    c0 = time.process_time()
    simulate_multibody(m, sets[0], specialised=True)
    print(f"  specialised kernel: compiled or loaded in {time.process_time() - c0:.1f} s CPU")
    c0 = time.process_time()
    single_s = [simulate_multibody(m, c, specialised=True)[1] for c in sets]
    cpu_s = (time.process_time() - c0) / len(sets)
    same = all(a["collision_force_N"] == b["collision_force_N"] for a, b in zip(single, single_s))
    print(f"  one by one, specialised: {cpu_s * 1e3:6.1f} ms CPU per run = {60 / cpu_s:5.0f} runs/min/core "
          f"(results identical: {same})")
    time_sweep_runner([dict(j, specialised=True) for j in jobs], "sweep runner, 1 worker, --specialised",
                      warm_up=True)


def time_sweep_runner(jobs: list[dict], label: str, warm_up: bool = False) -> None:
    """Print the CPU per run of ``jobs`` through a one-worker :class:`SweepRunner` (the main process's CPU: the
    runner's local path runs in-process); ``warm_up`` runs the first job once before timing (kernel load)."""
    from berryshaker.runs.runner import SweepRunner
    from berryshaker.runs.sweep import model_run

    with SweepRunner(workers=1, use_cache=False, progress=False) as runner:
        if warm_up:
            runner.map(model_run, jobs[:1])
        c0 = time.process_time()
        out = runner.map(model_run, jobs)
        cpu = (time.process_time() - c0) / len(jobs)
    ok = sum(r.error is None for r in out)
    print(f"  {label}: {cpu * 1e3:6.1f} ms CPU per run = {60 / cpu:5.0f} runs/min/core ({ok}/{len(out)} ok)")


if __name__ == "__main__":
    main()
