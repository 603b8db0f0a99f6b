"""Why the harvester run takes ~20 000 steps: the explicit step limit of its stiffest modes (benchmarks/README.md
sec. 14).

Integrates the reference harvester (2 cam revolutions, clearances A B C F, rtol 1e-6) window by window (the
compiled integrator on consecutive slices of the output grid, its state carried over) and, at the end of each
window, linearises the engine's right-hand side y' = f(y) (positions, velocities; constraint forces solved as in
the run) by central differences.  Per window it prints the mean accepted step, the eigenvalue lambda of largest
modulus, the body whose coordinates move most in its mode, and h_stab = r(theta) / |lambda|, where r(theta) is
where the ray at lambda's angle leaves DOPRI5's stability region |R(z)| <= 1,
R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24 + z^5/120 + z^6/600 (Hairer & Wanner, *Solving ODEs II*, sec. IV.2).
A step near h_stab is set by stability, not by the error tolerance; then only an implicit treatment of those
modes makes the steps longer.  It also prints the accepted steps at rtol 1e-3 ... 1e-8 (the floor they approach).

    .venv/bin/python benchmarks/stiffness_modes.py [--window 0.05]
"""

from __future__ import annotations

import argparse

import numpy as np

from berryshaker.config import reference_machine
from berryshaker.drives import drive_of
from berryshaker.multibody import kernel as mb
from berryshaker.multibody.engine import prepare_run, simulate_mechanism
from diagnose_step_blowup import integrate_windows  # benchmarks/ (the script's own folder) is on sys.path

DOPRI5_R = np.array([1.0, 1.0, 1 / 2, 1 / 6, 1 / 24, 1 / 120, 1 / 600])


def stability_radius(theta: float) -> float:
    """Distance from 0 at which the ray z = r e^(i theta) leaves DOPRI5's stability region (bisection)."""
    def stable(r):
        z = r * np.exp(1j * theta)
        return abs(np.polyval(DOPRI5_R[::-1], z)) <= 1.0
    lo, hi = 1e-3, 10.0
    if not stable(lo):
        return 0.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


def linearise(t, y, cm, state, work):
    """Jacobian df/dy of the engine's right-hand side at (t, y) by central differences (state arrays copied)."""
    ny = y.shape[0]
    jac = np.zeros((ny, ny))
    f_p, f_m = np.zeros(ny), np.zeros(ny)
    for i in range(ny):
        d = 1e-7 * max(1e-3, abs(y[i]))
        for sign, out in ((1.0, f_p), (-1.0, f_m)):
            yy = y.copy()
            yy[i] += sign * d
            st = tuple(a.copy() for a in state)
            wk = tuple(a.copy() for a in work)
            mb.accelerations(t, yy, cm.model, st, wk, out)
        jac[:, i] = (f_p - f_m) / (2 * d)
    return jac


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--window", type=float, default=0.05, help="window length (s)")
    ap.add_argument("--rtol", type=float, default=1e-6)
    a = ap.parse_args(argv)
    machine = reference_machine()
    spec = drive_of(machine).mechanism(machine, revolutions=2)
    run = prepare_run(spec, rtol=a.rtol, output_step=1e-4)
    cm = run.cm
    bodies = [b.name for b in spec.bodies]
    total = 0
    limited = 0
    print(f"harvester, 2 cam revolutions, rtol {a.rtol:g}, windows of {a.window * 1e3:g} ms")
    print(f"{'t (ms)':>14} {'steps':>6} {'mean h (us)':>11} | {'lambda (1/s)':>22} {'h_stab (us)':>11} "
          f"{'h/h_stab':>8}  mode mostly in")
    for t_w, info, oy, _oe in integrate_windows(run, 1e-4, a.window, n_bins=0):
        y = oy[-1].copy()
        steps = int(info[0])
        total += steps
        lam, vec = np.linalg.eig(linearise(t_w[-1], y, cm, run.state, run.work))
        k = int(np.argmax(np.abs(lam)))
        h_stab = stability_radius(float(np.angle(lam[k]))) / abs(lam[k])
        h_mean = (t_w[-1] - t_w[0]) / max(steps, 1)
        nq = cm.n
        amp = np.abs(vec[:nq, k])[:3 * len(bodies)].reshape(len(bodies), 3).sum(axis=1)
        who = bodies[int(np.argmax(amp))]
        if h_mean > 0.5 * h_stab:
            limited += steps
        print(f"{t_w[0] * 1e3:6.0f}..{t_w[-1] * 1e3:<6.0f} {steps:6d} {h_mean * 1e6:11.1f} | "
              f"{lam[k].real:10.0f} {lam[k].imag:+10.0f}j {h_stab * 1e6:11.1f} {h_mean / h_stab:8.2f}  {who}")
    print(f"{total} accepted steps; {limited} ({100 * limited / total:.0f} %) in windows whose mean step exceeds "
          "half the stability limit")
    print("accepted steps by rtol (the same run whole):")
    for rt in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8):
        r = simulate_mechanism(spec, rtol=rt, output_step=1e-4)
        print(f"  rtol {rt:7.0e}: {int(r.info[0]):6d} accepted, {int(r.info[1]):5d} rejected, {int(r.info[2]):5d} "
              "onset cuts")


if __name__ == "__main__":
    main()
