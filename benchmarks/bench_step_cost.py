"""Engine cost per accepted step against the hand-reduced slider-crank, and one harvester run, before / after.

Figures (benchmarks/README.md sec. 10), all CPU time (``time.process_time``), best of ``--repeat`` after a warm-up
call (numba compilation or cache load excluded):

* slider-crank (examples/slider_crank_clearance.toml, 2 crank revolutions, output every 10 us) at rtol 1e-5, 1e-7,
  1e-9: marginal us per accepted step = (CPU of the 24 ms run - CPU of a 0.1 ms run) / (difference in steps),
  for the engine and for the hand-reduced model (``reduced_slider_crank.py``), and their ratio; also CPU per run
  and its ratio (at the same rtol, not at matched accuracy: the engine's error norm runs over 18 states, 10 of
  them exact, so it takes fewer steps, benchmarks/README.md sec. 27);
* harvester (reference machine, clearances A B C F, 2 cam revolutions, ``drives.simulation.simulate_multibody``):
  CPU per run and accepted steps;
* coupled (the reference machine driven past its bush, ``harvest.coupled.coupled_mechanism``, rtol 1e-5, output
  every 0.1 ms as the study's replicate runs): CPU of the compiled integration alone (no post-processing) and
  accepted steps;
* replicate (``study.runs.replicate_run``, the study's unit of work: the coupled run from a perturbed start, its
  post-processing and the stem-force table of one branch class): CPU per call.

``--compare OLD_SRC`` runs the same figures with another source tree (a ``git archive`` of the starting commit's
``src``) and this one in alternating child processes (``--rounds`` pairs), so that both share the machine's load,
and prints the best of every figure over the rounds:

    .venv/bin/python benchmarks/bench_step_cost.py --compare /tmp/lean_base/src --rounds 3

``--kernels`` does the same with this tree's generic kernel and the kernel specialised to each mechanism's
structure (``--specialised`` alone measures only the latter; benchmarks/README.md sec. 29).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

from cpu_timing import best_cpu_time  # benchmarks/ (the script's own folder) is on sys.path

ROOT = Path(__file__).resolve().parent.parent
RTOLS = (1e-5, 1e-7, 1e-9)
OUTPUT_STEP = 1e-5




def figures(repeat: int, specialised: bool = False) -> dict:
    """The figures of the module docstring, measured in this process (``specialised``: the engine's runs with the
    kernel specialised to each mechanism's structure, multibody.specialised; the replicate job stays generic)."""
    sk = {"specialised": True} if specialised else {}
    # runs left to choose (the replicate job, and every run of the generic side) take the generic kernel; the
    # specialised side asks for its kernel explicitly (an older tree ignores this)
    os.environ["BERRYSHAKER_KERNEL"] = "generic"
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from reduced_slider_crank import simulate_reduced_slider_crank

    from berryshaker.config import reference_machine
    from berryshaker.drives.simulation import simulate_multibody
    from berryshaker.multibody.engine import simulate_mechanism
    from berryshaker.multibody.spec import load_mechanism

    spec = load_mechanism(ROOT / "examples" / "slider_crank_clearance.toml")
    duration = 2 * 2 * math.pi / abs(spec.drivers[0].speed)
    out: dict = {}
    for rtol in RTOLS:
        r, cpu = best_cpu_time(lambda: simulate_mechanism(spec, duration=duration, rtol=rtol, output_step=OUTPUT_STEP,
                                                                 **sk), repeat)
        r0, cpu0 = best_cpu_time(lambda: simulate_mechanism(spec, duration=1e-4, rtol=rtol, output_step=OUTPUT_STEP,
                                                            **sk), repeat)
        q, cpu_q = best_cpu_time(lambda: simulate_reduced_slider_crank(spec, duration, rtol, OUTPUT_STEP), repeat)
        q0, cpu_q0 = best_cpu_time(lambda: simulate_reduced_slider_crank(spec, 1e-4, rtol, OUTPUT_STEP), repeat)
        n, n0 = int(r.info[0]), int(r0.info[0])
        out[f"{rtol:.0e}"] = {"engine_steps": n, "engine_us": (cpu - cpu0) / (n - n0) * 1e6,
                              "reduced_steps": q["steps"],
                              "reduced_us": (cpu_q - cpu_q0) / (q["steps"] - q0["steps"]) * 1e6,
                              "engine_run_ms": cpu * 1e3, "reduced_run_ms": cpu_q * 1e3}
    m = reference_machine()
    (res, summ), cpu = best_cpu_time(lambda: simulate_multibody(m, dict(m.clearance_sizes()), revolutions=2, **sk),
                                    repeat)
    out["harvester"] = {"cpu_s": cpu, "steps": summ["steps"]}
    out["coupled"] = _coupled(repeat, specialised)
    out["replicate"] = _replicate(repeat)
    return out


def _replicate(repeat: int) -> dict:
    """CPU of one replicate job of the study's virtual L9 (reference machine, middle branch class, seed (1, 0))."""
    from berryshaker.config import reference_machine
    from berryshaker.study.runs import replicate_run

    m = reference_machine()
    data, cl = m.model_dump(mode="json"), dict(m.clearance_sizes())
    scale = m.harvest.branch_classes[len(m.harvest.branch_classes) // 2]
    _, cpu = best_cpu_time(lambda: replicate_run(data, cl, scale, [1, 0]), repeat)
    return {"cpu_s": cpu}


def _coupled(repeat: int, specialised: bool = False) -> dict:
    """CPU of the compiled integration of the study's coupled drive-past run (prepared arrays, no post-processing)."""

    from berryshaker.config import reference_machine
    from berryshaker.harvest.coupled import coupled_mechanism
    from berryshaker.multibody import kernel as mb
    from berryshaker.multibody.engine import prepare_run

    spec, _ = coupled_mechanism(reference_machine())
    integrate = mb.integrate
    if specialised:
        from berryshaker.multibody.engine import integrator

        integrate = integrator(prepare_run(spec, duration=1e-3).cm, True)

    def one():
        r = prepare_run(spec, rtol=1e-5, output_step=1e-4)  # harvest.spec.COUPLED_RTOL (a literal: --compare runs older trees)
        r.info[0] = r.budget
        c0 = time.process_time()
        integrate(r.y, r.t_out, r.cm.model, r.state, r.work, r.rtol, r.atol, r.max_step, r.stats_from, r.out_y,
                     r.out_e, r.out_lam, r.peaks, r.first, r.info)
        return time.process_time() - c0, int(r.info[0])

    one()  # warm-up
    runs = [one() for _ in range(repeat)]
    return {"cpu_s": min(c for c, _ in runs), "steps": runs[0][1]}


def _print(label: str, f: dict) -> None:
    print(f"{label}: harvester {f['harvester']['cpu_s'] * 1e3:.0f} ms CPU, {f['harvester']['steps']} steps; coupled "
          f"drive-past (integration) {f['coupled']['cpu_s'] * 1e3:.0f} ms CPU, {f['coupled']['steps']} steps; "
          f"replicate job {f['replicate']['cpu_s'] * 1e3:.0f} ms CPU")
    for rtol in RTOLS:
        g = f[f"{rtol:.0e}"]
        run = ""
        if "engine_run_ms" in g:  # (older trees measured with --compare record no run figures)
            run = (f" | per run {g['engine_run_ms']:.2f} / {g['reduced_run_ms']:.2f} ms = "
                   f"{g['engine_run_ms'] / g['reduced_run_ms']:.2f}x")
        print(f"  rtol {rtol:.0e}: engine {g['engine_steps']:5d} steps {g['engine_us']:6.2f} us/step | reduced "
              f"{g['reduced_steps']:5d} steps {g['reduced_us']:5.2f} us/step | ratio {g['engine_us'] / g['reduced_us']:4.2f}x"
              + run)


def _min_over(runs: list[dict]) -> dict:
    best = json.loads(json.dumps(runs[0]))
    for f in runs[1:]:
        for case in ("harvester", "coupled", "replicate"):
            best[case]["cpu_s"] = min(best[case]["cpu_s"], f[case]["cpu_s"])
        for rtol in RTOLS:
            for key in ("engine_us", "reduced_us", "engine_run_ms", "reduced_run_ms"):
                if key in f[f"{rtol:.0e}"]:
                    best[f"{rtol:.0e}"][key] = min(best[f"{rtol:.0e}"][key], f[f"{rtol:.0e}"][key])
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--compare", default=None, help="src directory of the 'before' version")
    ap.add_argument("--json", action="store_true", help="print the figures as JSON (child mode)")
    ap.add_argument("--specialised", action="store_true",
                    help="measure the engine with the kernel specialised to each structure (multibody.specialised)")
    ap.add_argument("--kernels", action="store_true",
                    help="this tree's generic and specialised kernels side by side in alternating child processes")
    a = ap.parse_args()
    if a.compare is None and not a.kernels:
        f = figures(a.repeat, a.specialised)
        print(json.dumps(f)) if a.json else _print("this tree" + (", specialised" if a.specialised else ""), f)
        return
    here = str(ROOT / "src")
    sides = ((("generic", here, []), ("specialised", here, ["--specialised"])) if a.kernels else
             (("before", a.compare, []), ("after", here, [])))
    runs: dict = {label: [] for label, _, _ in sides}
    for _ in range(a.rounds):
        for label, src, extra in sides:
            env = dict(os.environ, PYTHONPATH=os.path.abspath(src))
            cmd = [sys.executable, os.path.abspath(__file__), "--json", "--repeat", str(a.repeat)] + extra
            out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True).stdout
            runs[label].append(json.loads(out.strip().splitlines()[-1]))
    for label in runs:
        _print(f"{label} (best of {a.rounds} child processes x {a.repeat})", _min_over(runs[label]))


if __name__ == "__main__":
    main()
