"""The ladder behind the suite's Exudyn comparison (test_exudyn.py): berryshaker's multibody engine vs Exudyn with
its BUILT-IN C++ contact, every setting of both, errors and costs, and the matched-accuracy tables.  Not collected
by pytest (no ``test_`` prefix): rerun it when the engine's accuracy per rtol changes, and set
``test_exudyn.MATCHED`` from its ladders.

Run:  .venv/bin/python benchmarks/suite/exudyn_contact_ladder.py [--quick]   (~4 min; --quick ~30 s)

Model: the clearance slider-crank of examples/slider_crank_clearance.toml with the contact law switched
from Lankarani-Nikravesh to Hunt-Crossley (e = 0.9, n = 1.5, Hertz pin-in-bore stiffness), because that
is the hysteresis law Exudyn's ``ObjectContactSphereSphere`` (``impactModel = 1``) implements; the
journal-in-bore is a sphere in a hollow sphere (``isHollowSphere1``), planar bodies are Exudyn's
``RigidBody2D``, joints ``JointRevolute2D`` / ``JointPrismatic2D``, the crank speed a velocity-level
``CoordinateConstraint`` - no Python user function runs during Exudyn's solve (see exudyn_models.py).

Exudyn solver: implicit generalised-alpha (spectral radius 0.9, modified Newton), fixed step h, the
discontinuous-iteration defaults except useRecommendedStepSize = False (with it Exudyn aborts at the first
impact of this model); these are the settings of Exudyn's own contact examples.  Ours: adaptive DOPRI5
at relative tolerance rtol, output every 10 us (the example's output step).

Accuracy measures, each relative to a reference solution (ours at rtol 1e-12, checked against Exudyn at
its finest step, see the printout):
  (a) the first-impact peak contact force;
  (b) over the first two crank revolutions (24 ms): mean and RMS of the contact force sampled on the
      10 us output grid, and the impulse (trapezoid on that grid) of revolution 1 and of revolution 2.
Cost: wall time (time.perf_counter) and CPU time (time.process_time, robust on a shared machine) of the
two-revolution run, best of 3 (Exudyn runs over 5 s: one), after a warm-up call; numba compilation and
Exudyn's import are excluded; ours is the whole simulate_mechanism call including the model compilation
and assembly, Exudyn's is SolveDynamic only, model building excluded.
Matched accuracy: for each engine, time versus error (running best, i.e. the cheapest setting reaching
an error) is interpolated in log-log at the accuracy level; ratio = Exudyn time / our time.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(Path(__file__).resolve().parent))  # exudyn_models beside this file

from berryshaker.multibody.engine import initial_state, simulate_mechanism  # noqa: E402
from berryshaker.multibody.spec import load_mechanism, mechanism_from_dict  # noqa: E402

OUTPUT_STEP = 1e-5
LEVELS = (1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6)
METRICS = ("first_peak", "mean", "rms", "impulse_rev1", "impulse_rev2")
LABELS = {"first_peak": "(a) first-impact peak force", "mean": "(b) mean contact force, 2 revolutions",
          "rms": "(b) RMS contact force, 2 revolutions", "impulse_rev1": "(b) impulse of revolution 1",
          "impulse_rev2": "(b) impulse of revolution 2"}


def hunt_crossley_slider_crank():
    """The example slider-crank with the Hunt-Crossley law at the clearance joint (Exudyn's built-in law)."""
    data = load_mechanism(ROOT / "examples" / "slider_crank_clearance.toml").model_dump()
    for j in data["joints"]:
        if j["name"] == "rod_slider":
            j["contact"]["law"] = "hunt_crossley"
    return mechanism_from_dict(data, "slider-crank (Hunt-Crossley)")


def grid_statistics(t, f, period):
    """Mean, RMS (10 us grid) over [0, 2 period] and the impulse of each revolution (N, N, N s)."""
    g = np.linspace(0.0, 2 * period, int(round(2 * period / OUTPUT_STEP)) + 1)
    fg = np.interp(g, t, f)
    i1 = int(np.searchsorted(g, period))
    return {"mean": float(fg.mean()), "rms": float(np.sqrt(np.mean(fg**2))),
            "impulse_rev1": float(np.trapezoid(fg[:i1 + 1], g[:i1 + 1])),
            "impulse_rev2": float(np.trapezoid(fg[i1:], g[i1:]))}


def exudyn_first_peak(t, f):
    """Largest force of the first contact episode in Exudyn's per-step record."""
    on = np.flatnonzero(f > 0)
    if on.size == 0:
        return 0.0
    i0 = on[0]
    off = np.flatnonzero(f[i0:] == 0)
    i1 = i0 + (off[0] if off.size else f.size - i0)
    return float(f[i0:i1].max())


def run_ours(spec, rtol, period, repeats):
    """Metrics, best-of-``repeats`` wall and CPU times (s) and steps of our two-revolution run."""
    best, best_cpu = math.inf, math.inf
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        r = simulate_mechanism(spec, duration=2 * period, rtol=rtol, output_step=OUTPUT_STEP)
        best, best_cpu = min(best, time.perf_counter() - t0), min(best_cpu, time.process_time() - c0)
    m = grid_statistics(r.t, r.element_force("rod_slider"), period)
    m["first_peak"] = r.summary()["joints"]["rod_slider"]["first_impact"]["peak_force_N"]
    return m, best, best_cpu, int(r.info[0])


def run_exu(spec, y0, h, period, repeats):
    """Metrics, best-of-``repeats`` SolveDynamic wall and CPU times (s) of Exudyn's two-revolution run
    (metrics None if the solver fails).  Runs over 5 s are not repeated."""
    import exudyn
    from exudyn_models import run_exudyn

    best, best_cpu = math.inf, math.inf
    for i in range(repeats):
        try:
            out, wall, cpu = run_exudyn(spec, y0, 2 * period, h, output_step=h)
        except exudyn.SolverError:
            return None, math.nan, math.nan
        best, best_cpu = min(best, wall), min(best_cpu, cpu)
        if wall > 5.0:
            break
    t, f = out["rod_slider"]
    m = grid_statistics(t, f, period)
    m["first_peak"] = exudyn_first_peak(t, f)
    return m, best, best_cpu


def cost_at(points, level):
    """Interpolated (log-log) (time, setting) from which on the error stays below ``level``.

    ``points``: list of (setting, error, time), ordered from the loosest to the strictest setting.  The
    error of a setting is taken as the largest error of it and of every stricter setting (a lucky loose
    run does not count: chaotic statistics scatter before they converge).  Returns (time, setting,
    exact) with exact False when the loosest setting already qualifies (the time is then an upper
    bound), or None when no setting reaches the level.
    """
    guaranteed = []
    worst = 0.0
    for s, e, t in reversed(points):
        worst = max(worst, e, 1e-16)
        guaranteed.append((s, worst, t))
    guaranteed.reverse()
    prev = None
    for s, e, t in guaranteed:
        if e <= level:
            if prev is None:
                return t, s, False
            s0, e0, t0 = prev
            w = (math.log(level) - math.log(e0)) / (math.log(e) - math.log(e0))
            return (math.exp(math.log(t0) + w * (math.log(t) - math.log(t0))),
                    math.exp(math.log(s0) + w * (math.log(s) - math.log(s0))), True)
        prev = (s, e, t)
    return None


def _fmt_ratio(e, o):
    if not (e and o):
        return "-"
    r = e[0] / o[0]
    return (">=" if not o[2] else "") + f"{r:.0f}x"


def main(argv=None) -> None:
    """Run the ladders and print the reference check, the ladders and the matched-accuracy tables."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="shorter ladders, one repeat (a smoke run)")
    ap.add_argument("--specialised", action="store_true",
                    help="ours with the kernel specialised to the slider-crank's structure (multibody.specialised)")
    args = ap.parse_args(argv)
    try:
        import exudyn
    except ImportError:
        print("Exudyn is not installed (pip install exudyn): nothing to compare")
        return
    repeats = 1 if args.quick else 3
    spec = hunt_crossley_slider_crank()
    # ours: the generic kernel unless --specialised (not "auto", which would take a compiled specialised one)
    spec = spec.model_copy(update={"simulation": spec.simulation.model_copy(
        update={"specialised": bool(args.specialised)})})
    y0 = initial_state(spec)
    period = 2 * math.pi / abs(spec.drivers[0].speed)
    rtols = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8) if args.quick else \
        (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11)
    steps = (4e-6, 2e-6, 1e-6, 5e-7) if args.quick else \
        (4e-6, 2e-6, 1e-6, 5e-7, 2.5e-7, 1.25e-7, 6.25e-8, 3.125e-8)
    ref_rtol, ref_rtol2 = 1e-12, 1e-11
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else math.nan
    print(f"Exudyn {exudyn.__version__}, {os.cpu_count()} cores (load average {load:.1f} at start), "
          f"{time.strftime('%Y-%m-%d')}; slider-crank (Hunt-Crossley e = 0.9), two crank revolutions = "
          f"{2 * period * 1e3:.1f} ms simulated" + ("; ours specialised" if args.specialised else ""))

    simulate_mechanism(spec, duration=1e-3, rtol=1e-6)  # warm-up: numba compile / cache load
    from exudyn_models import run_exudyn
    run_exudyn(spec, y0, 1e-4, 1e-6)  # warm-up

    ref, _, _, _ = run_ours(spec, ref_rtol, period, 1)
    ref2, _, _, _ = run_ours(spec, ref_rtol2, period, 1)

    print(f"\nladders (relative errors against the reference = ours at rtol {ref_rtol:.0e}; times best of "
          f"{repeats}, wall = time.perf_counter, cpu = time.process_time):")
    cols = "  ".join(f"{k[:12]:>12s}" for k in METRICS)
    print(f"  {'ours rtol':>12s} {'steps':>7s} {'wall ms':>9s} {'cpu ms':>9s}   {cols}")
    ours_pts = {k: [] for k in METRICS}
    ours_cpu = {k: [] for k in METRICS}
    for rtol in rtols:
        m, wall, cpu, nsteps = run_ours(spec, rtol, period, repeats)
        errs = {k: abs(m[k] - ref[k]) / abs(ref[k]) for k in METRICS}
        for k in METRICS:
            ours_pts[k].append((rtol, errs[k], wall))
            ours_cpu[k].append((rtol, errs[k], cpu))
        print(f"  {rtol:12.0e} {nsteps:7d} {wall * 1e3:9.1f} {cpu * 1e3:9.1f}   "
              + "  ".join(f"{errs[k]:12.2e}" for k in METRICS))
    exu_pts = {k: [] for k in METRICS}
    exu_cpu = {k: [] for k in METRICS}
    exu_finest = None
    print(f"  {'Exudyn h (s)':>12s} {'steps':>7s} {'wall ms':>9s} {'cpu ms':>9s}   {cols}")
    for h in steps:
        m, wall, cpu = run_exu(spec, y0, h, period, repeats)
        if m is None:
            print(f"  {h:12.3g}  solver failed")
            continue
        exu_finest = (h, m, wall, cpu)
        errs = {k: abs(m[k] - ref[k]) / abs(ref[k]) for k in METRICS}
        for k in METRICS:
            exu_pts[k].append((h, errs[k], wall))
            exu_cpu[k].append((h, errs[k], cpu))
        print(f"  {h:12.3g} {int(round(2 * period / h)):7d} {wall * 1e3:9.1f} {cpu * 1e3:9.1f}   "
              + "  ".join(f"{errs[k]:12.2e}" for k in METRICS), flush=True)

    h_f, m_f = exu_finest[0], exu_finest[1]
    print(f"\nreference check: ours at rtol {ref_rtol:.0e} vs ours at {ref_rtol2:.0e} (self-convergence) and vs "
          f"Exudyn at its finest step h = {h_f:.3g} s:")
    print(f"  {'metric':40s} {'reference':>12s} {'ours 1e-11':>11s} {'Exudyn':>11s}")
    floor = {}
    for k in METRICS:
        floor[k] = abs(ref2[k] - ref[k]) / abs(ref[k])
        print(f"  {LABELS[k]:40s} {ref[k]:12.6g} {floor[k]:11.1e} {abs(m_f[k] - ref[k]) / abs(ref[k]):11.1e}")

    print("\nmatched accuracy: time from which on every stricter setting stays below the error level, "
          "log-log interpolated;\n'<=' the loosest setting already qualifies (time an upper bound); 'not "
          "reached': Exudyn's finest step does not get there\n(ratio then a lower bound, '>'); levels below 3x "
          "the reference's self-convergence are not shown.")
    for k in METRICS:
        print(f"\n  {LABELS[k]}")
        print(f"  {'error':>7s}  {'Exudyn h':>10s} {'wall ms':>9s}  {'ours rtol':>10s} {'wall ms':>8s}  "
              f"{'ratio':>7s} {'ratio cpu':>9s}")
        for level in LEVELS:
            if level < 3 * floor[k]:
                continue
            e, o = cost_at(exu_pts[k], level), cost_at(ours_pts[k], level)
            ec, oc = cost_at(exu_cpu[k], level), cost_at(ours_cpu[k], level)
            if o is None:
                continue
            os_ = f"{('' if o[2] else '<=') + format(o[1], '.1e'):>10s} {o[0] * 1e3:8.1f}"
            if e:
                es = f"{e[1]:10.2e} {e[0] * 1e3:9.1f}"
                ratio, ratio_c = _fmt_ratio(e, o), _fmt_ratio(ec, oc)
            else:
                es = f"{'not reached':>20s}"
                wall_f, cpu_f = exu_finest[2], exu_finest[3]
                ratio = f">{wall_f / o[0]:.0f}x"
                ratio_c = f">{cpu_f / oc[0]:.0f}x" if oc else "-"
            print(f"  {level:7.0e}  {es}  {os_}  {ratio:>7s} {ratio_c:>9s}")


if __name__ == "__main__":
    main()
