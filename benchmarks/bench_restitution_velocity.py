"""The restitution velocity of the hysteresis contact laws: cost and statistics of harvester runs before/after.

Run:  .venv/bin/python benchmarks/bench_restitution_velocity.py [--sets 6] [--repeat 3]

"Before" is the published Lankarani-Nikravesh law (restitution velocity 0 on every pair: e at every impact speed,
the engine's floor of 1e-6 m/s on v_imp), "after" the pairs' default (their materials' yield velocity,
docs/contact.md sec. 6.4); both in this process, CPU time (``time.process_time``), best of ``--repeat`` after a
warm-up.  Each run: the reference machine, 2 cam revolutions, multibody, rtol 1e-6, output every 0.1 ms; the
reference clearances and ``--sets`` sets drawn uniformly 0.8-1.25x around them (seed 2).

Prints per run: accepted / rejected steps, steps at the old stability limit (h in 5.6-6.7 us, the band of
benchmarks/README.md sec. 5), the most frequent step size, CPU, and per pair the mean / RMS / 95th percentile of
the collision force over revolution 2 and the mean drive moment; then the impact-velocity distribution of the
reference run (onsets read on a 5 us output grid, v_imp interpolated to the zero of the penetration).
"""

from __future__ import annotations

import os

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from cpu_timing import best_cpu_time  # benchmarks/ (the script's own folder) is on sys.path

# the generic kernel unless the caller sets BERRYSHAKER_KERNEL (a run left to choose would take a specialised
# one once compiled on this machine: multibody.specialised)
os.environ.setdefault("BERRYSHAKER_KERNEL", "generic")

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

N_BINS = 140  # 20 per decade from 1e-9 s


def with_restitution_velocity(machine, v_ref):
    """The machine with ``restitution_velocity`` = v_ref (m/s) on every pair (None: the pair's default)."""
    cl = {p: machine.clearance[p].model_copy(update={"restitution_velocity": v_ref}) for p in machine.pair_names}
    return machine.model_copy(update={"clearance": cl})


def run(machine, clearance, rtol=1e-6, output_step=1e-4):
    """One harvester run with the step-size histogram: (result, summary, histogram of accepted h)."""
    import berryshaker.multibody.kernel as mb
    from berryshaker.drives.simulation import drive_of, multibody_summary
    from berryshaker.multibody.engine import finish_run, prepare_run

    m = machine.with_clearances(clearance)
    spec = drive_of(m).mechanism(m, revolutions=2)
    pr = prepare_run(spec, None, rtol, output_step, None, None, None, None)
    info = np.zeros(mb.N_INFO + N_BINS)
    info[0] = pr.budget
    t0 = time.perf_counter()
    mb.integrate(pr.y, pr.t_out, pr.cm.model, pr.state, pr.work, pr.rtol, pr.atol, pr.max_step, pr.stats_from,
                 pr.out_y, pr.out_e, pr.out_lam, pr.peaks, pr.first, info)
    pr.info[:] = info[:mb.N_INFO]
    res = finish_run(pr, time.perf_counter() - t0)
    return res, multibody_summary(m, res), info[mb.N_INFO:]


def bin_edges():
    import berryshaker.multibody.kernel as mb

    return 10.0 ** (mb.STEP_HIST_LOG10_MIN + np.arange(N_BINS + 1) / mb.STEP_BINS_PER_DECADE)




def impact_velocities(machine, output_step=5e-6):
    """Approach speeds at the contact onsets of every pair (m/s), from a run written every ``output_step``."""
    import berryshaker.multibody.kernel as mb
    from berryshaker.drives.simulation import simulate_multibody

    res, _ = simulate_multibody(machine, dict(machine.clearance_sizes()), revolutions=2, output_step=output_step)
    out = {}
    for p in machine.pair_names:
        k = res.compiled.frc_names.index(p)
        pen, pd = res.elements[:, k, mb.EO_PEN], res.elements[:, k, mb.EO_PENDOT]
        on = np.where((pen[:-1] <= 0) & (pen[1:] > 0))[0]
        w = -pen[on] / (pen[on + 1] - pen[on])
        out[p] = pd[on] + w * (pd[on + 1] - pd[on])
    return out


def main(argv=None) -> None:
    from berryshaker.config import reference_machine

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=6)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--rtol", type=float, default=1e-6)
    args = ap.parse_args(argv)
    m0 = reference_machine()
    ref = dict(m0.clearance_sizes())
    rng = np.random.default_rng(2)
    sets = [ref] + [{k: float(v * rng.uniform(0.8, 1.25)) for k, v in ref.items()} for _ in range(args.sets)]
    models = {"before (v_ref = 0)": with_restitution_velocity(m0, 0.0), "after (yield velocity)": m0}
    edges = bin_edges()
    limit = (edges[:-1] >= 5.6e-6) & (edges[1:] <= 6.8e-6)
    print("pairs' restitution velocity (after): "
          + ", ".join(f"{p} {m0.pair_contact(p).restitution_velocity * 1e3:.1f} mm/s" for p in m0.pair_names))
    totals = {name: [] for name in models}
    for i, c in enumerate(sets):
        print(f"set {i} ({'reference' if i == 0 else 'drawn'}): "
              + " ".join(f"{k} {v * 1e3:.3f} mm" for k, v in c.items()))
        for name, m in models.items():
            (res, s, hist), cpu = best_cpu_time(lambda m=m, c=c: run(m, c, rtol=args.rtol), args.repeat)
            mode = edges[int(np.argmax(hist))]
            st = s["collision_force_N"]
            totals[name].append((cpu, s["steps"]))
            print(f"  {name:24s} steps {s['steps']:6d} / {s['rejected_steps']:5d} rej, at 5.6-6.7 us "
                  f"{int(hist[limit].sum()):6d}, most frequent h {mode * 1e6:6.2f} us, CPU {cpu * 1e3:6.0f} ms | "
                  + " ".join(f"{p} {st[p]['mean']:.0f}/{st[p]['rms']:.0f}/{st[p]['p95']:.0f}" for p in st)
                  + f" | drive {s['drive_moment_Nm']['mean']:.3f} N m", flush=True)
    for name, v in totals.items():
        cpu, steps = np.array(v).T
        print(f"{name:24s} mean over {len(v)} sets: CPU {cpu.mean() * 1e3:.0f} ms (range {cpu.min() * 1e3:.0f}-"
              f"{cpu.max() * 1e3:.0f}), steps {steps.mean():.0f}")
    for name, m in models.items():
        v = impact_velocities(m)
        allv = np.concatenate(list(v.values()))
        q = np.percentile(allv, [5, 10, 25, 50, 75, 90, 95])
        print(f"impact velocities, reference run, {name}: {len(allv)} onsets "
              + " ".join(f"{p} {len(x)}" for p, x in v.items()))
        print("  percentiles 5/10/25/50/75/90/95 (mm/s): " + " / ".join(f"{x * 1e3:.3g}" for x in q)
              + f"; max {allv.max() * 1e3:.0f}")
        print("  fraction below 0.1 / 1 / 10 / 18 / 51 / 100 mm/s: " + " / ".join(
            f"{np.mean(allv < x):.2f}" for x in (1e-4, 1e-3, 1e-2, 0.018, 0.051, 0.1)))


if __name__ == "__main__":
    main()
