"""Benchmark: berryshaker's multibody engine vs Exudyn on the clearance slider-crank at matched
accuracy, and harvester simulations per second.  Run:  python benchmarks/bench_multibody.py

NOTE: the Exudyn model here computes the contact force in a Python user function (Exudyn has no
Lankarani-Nikravesh element), which slows Exudyn down; the fair comparison against Exudyn's built-in
C++ contact is benchmarks/bench_exudyn_contact.py (see benchmarks/README.md).

Accuracy measure: the first-impact peak force of the rod-slider clearance joint, relative to a
reference computed by berryshaker at rtol = 1e-10 (Exudyn converges to the same value, see the table).
For each engine we take the cheapest setting whose error is below the target, then time the full
0.05 s benchmark (about four crank revolutions) with that setting.
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from berryshaker.config import reference_machine  # noqa: E402
from berryshaker.multibody.engine import initial_state, simulate_mechanism  # noqa: E402
try:
    from berryshaker.drives.simulation import simulate_multibody as simulate_harvester_multibody  # noqa: E402
except ImportError:  # older layout
    from berryshaker.drives.groove_cam.mechanism import simulate_harvester_multibody  # noqa: E402
from berryshaker.multibody.spec import load_mechanism  # noqa: E402
from berryshaker.drives.groove_cam.mlsd import simulate_mlsd  # noqa: E402

# the generic kernel unless the caller sets BERRYSHAKER_KERNEL (a run left to choose would take a specialised
# one once compiled on this machine: multibody.specialised)
os.environ.setdefault("BERRYSHAKER_KERNEL", "generic")

TARGET = 2e-4  # relative error of the first-impact peak
DURATION = 0.05


def first_peak_exudyn(rec):
    f = rec["force"]
    i0 = int(np.argmax(f > 0))
    i1 = i0 + int(np.argmax(f[i0:] == 0))
    return f[i0:i1].max()


def main() -> None:
    spec = load_mechanism(ROOT / "examples" / "slider_crank_clearance.toml")
    ref = simulate_mechanism(spec, duration=2e-3, rtol=1e-10).summary()["joints"]["rod_slider"]["first_impact"][
        "peak_force_N"]
    print(f"reference first-impact peak (berryshaker, rtol 1e-10): {ref:.2f} N; target error {TARGET:.0e}")
    print("\nberryshaker (adaptive DOPRI5):")
    ours = None
    for rtol in (1e-4, 1e-5, 1e-6, 1e-7, 1e-8):
        p = simulate_mechanism(spec, duration=2e-3, rtol=rtol).summary()["joints"]["rod_slider"]["first_impact"][
            "peak_force_N"]
        err = abs(p - ref) / ref
        print(f"  rtol {rtol:.0e}: peak {p:.2f} N, error {err:.2e}")
        if ours is None and err < TARGET:
            ours = rtol
    best = min(simulate_mechanism(spec, duration=DURATION, rtol=ours).wall_time_s for _ in range(3))
    print(f"  -> rtol {ours:.0e}: {DURATION} s simulated in {best * 1e3:.1f} ms")
    try:
        from berryshaker.validation.exudyn_slider_crank import run_exudyn_slider_crank
    except ImportError:
        print("Exudyn is not installed (pip install exudyn): no comparison")
        return
    y0 = initial_state(spec)
    print("\nExudyn (implicit generalised-alpha, fixed step):")
    step = None
    for h in (4e-6, 2e-6, 1e-6, 5e-7, 2.5e-7):
        rec, wall = run_exudyn_slider_crank(spec, y0, duration=1e-3, step=h)
        p = first_peak_exudyn(rec)
        err = abs(p - ref) / ref
        print(f"  step {h:.1e} s: peak {p:.2f} N, error {err:.2e}")
        if step is None and err < TARGET:
            step = h
    if step is None:
        step = 2.5e-7
    _, wall_exu = run_exudyn_slider_crank(spec, y0, duration=DURATION, step=step)
    print(f"  -> step {step:.1e} s: {DURATION} s simulated in {wall_exu * 1e3:.1f} ms")
    print(f"\nspeed-up at matched accuracy (first-impact error < {TARGET:.0e}): {wall_exu / best:.0f}x "
          f"(target >= 50x)")

    m = reference_machine()
    period = 2 * math.pi / m.cam.speed
    simulate_harvester_multibody(m, None, revolutions=2)  # compile / load cache
    walls = [simulate_harvester_multibody(m, None, revolutions=2)[1]["wall_time_s"] for _ in range(3)]
    w_mb = min(walls)
    walls = [simulate_mlsd(m, None, revolutions=2).wall_time_s for _ in range(3)]
    w_ml = min(walls)
    print(f"\nharvester, 2 cam revolutions ({2 * period:.2f} s), four clearances, one core:")
    print(f"  multibody: {w_mb * 1e3:.0f} ms per run = {1 / w_mb:.1f} simulations/s (target < 500 ms)")
    print(f"  MLSD:      {w_ml * 1e3:.0f} ms per run = {1 / w_ml:.1f} simulations/s")
    print(f"  (with {os.cpu_count()} cores, the sweep runner multiplies the rate)")


if __name__ == "__main__":
    main()
