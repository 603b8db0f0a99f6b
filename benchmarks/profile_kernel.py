"""Cost of the compiled kernel's pieces per call (benchmarks/README.md sec. 5 and 10).

numba code is invisible to Python profilers, so every piece is timed in a compiled loop of ``--calls`` calls on a
state taken from a run (a sample with the most closed contacts), CPU time (``time.process_time``) per call, best of
3 after a warm-up.  Pieces: the right-hand side (``accelerations``), its parts (``constraints``, ``forces``,
the multiplier solve ``_constrained_solve``: Schur complement, L D L^T, driven bodies), and the interior-peak
search of one closed contact (``_interior_peak``).

    .venv/bin/python benchmarks/profile_kernel.py [--case slider_crank|harvester|coupled] [--calls 200000]
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np
from numba import njit

from berryshaker.multibody import kernel as mb

ROOT = Path(__file__).resolve().parent.parent


@njit
def _loop_rhs(n_calls, t, y, model, state, work, dy):
    for _ in range(n_calls):
        mb.accelerations(t, y, model, state, work, dy)


@njit
def _loop_constraints(n_calls, t, y, model, state, work):
    (mass, inertia, gravity, ctype, cint, cflt, crow, ftype, fint, fflt, cams, modal_w, modal_z, phi_tab,
     plant_p, laws, plan) = model
    (phi, jac, nu, gam, Q, eout, lam, minv, W, rhs) = work
    n = y.shape[0] // 2
    for _ in range(n_calls):
        mb.constraints(t, y[:n], y[n:], ctype, cint, cflt, crow, cams, state[2], phi, jac, nu, gam)


@njit
def _loop_forces(n_calls, t, y, model, state, work):
    (mass, inertia, gravity, ctype, cint, cflt, crow, ftype, fint, fflt, cams, modal_w, modal_z, phi_tab,
     plant_p, laws, plan) = model
    (in_contact, v_imp, psi_c, psi_f, lam_prev) = state
    (phi, jac, nu, gam, Q, eout, lam, minv, W, rhs) = work
    n = y.shape[0] // 2
    for _ in range(n_calls):
        mb.forces(t, y[:n], y[n:], mass, gravity, ftype, fint, fflt, cams, in_contact, v_imp, psi_f,
                  ctype, cint, cflt, crow, lam_prev, modal_w, modal_z, phi_tab, plant_p, Q, eout, laws)


@njit
def _loop_solve(n_calls, model, work, u0):
    plan = model[16]
    (phi, jac, nu, gam, Q, eout, lam, minv, W, rhs) = work
    m = phi.shape[0]
    u = u0.copy()
    for _ in range(n_calls):
        for i in range(u.shape[0]):
            u[i] = u0[i]
        mb._constrained_solve(plan, model[0], model[1], model[4], model[6], jac, minv, W, rhs, u, 0, gam, lam, m)


@njit
def _loop_peak(n_calls, model, j, v_imp, h, p0, d0, p1, d1):
    s = 0.0
    for _ in range(n_calls):
        f, u = mb._interior_peak(model, j, v_imp, h, p0, d0, p1 + s * 1e-30, d1)
        s += f * 1e-300
    return s


def _time(fn, *args):
    fn(10, *args[1:])
    best = math.inf
    for _ in range(3):
        c0 = time.process_time()
        fn(*args)
        best = min(best, time.process_time() - c0)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="slider_crank", choices=("slider_crank", "harvester", "coupled"))
    ap.add_argument("--calls", type=int, default=200_000)
    a = ap.parse_args()
    from berryshaker.multibody.engine import prepare_run, simulate_mechanism
    from berryshaker.multibody.spec import load_mechanism

    if a.case == "slider_crank":
        spec = load_mechanism(ROOT / "examples" / "slider_crank_clearance.toml")
        duration = 2 * 2 * math.pi / abs(spec.drivers[0].speed)
        kw = dict(duration=duration, rtol=1e-7, output_step=1e-5)
    elif a.case == "coupled":  # the study's unit of work: the drive-past run with the bush (harvest.coupled)
        from berryshaker.config import reference_machine
        from berryshaker.harvest.coupled import coupled_mechanism

        spec, _ = coupled_mechanism(reference_machine())
        kw = dict(rtol=1e-5, output_step=1e-4)  # harvest.spec.COUPLED_RTOL
    else:
        from berryshaker.config import reference_machine
        from berryshaker.drives import drive_of

        m = reference_machine()
        spec = drive_of(m).mechanism(m, revolutions=2)
        kw = dict(rtol=1e-5, output_step=1e-4)  # harvest.spec.COUPLED_RTOL
    res = simulate_mechanism(spec, **kw)
    # the sample with the most closed contacts, its state and contact set
    closed = (res.elements[:, :, mb.EO_PEN] > 0).sum(axis=1)
    i = int(np.argmax(closed))
    run = prepare_run(spec, **kw)
    model, state, work = run.cm.model, run.state, run.work
    y = res.y[i].copy()
    t = float(res.t[i])
    pen = res.elements[i, :, mb.EO_PEN]
    state[0][:] = pen > 0
    state[1][:] = np.maximum(np.abs(res.elements[i, :, mb.EO_PENDOT]), 1e-2)
    dy = np.zeros_like(y)
    n = a.calls
    print(f"{a.case}: {y.size // 2} coordinates, {work[0].size} constraint rows, {pen.size} force elements, "
          f"{int(closed[i])} closed at t = {t:.6g} s; ns per call (CPU, best of 3 x {n} calls)")
    for name, fn, args in (("accelerations (one right-hand side)", _loop_rhs, (n, t, y, model, state, work, dy)),
                           ("  constraints", _loop_constraints, (n, t, y, model, state, work)),
                           ("  forces", _loop_forces, (n, t, y, model, state, work)),
                           ("  multiplier solve (Schur, L D L^T, driven bodies)", _loop_solve,
                            (n, model, work, np.ones(y.size // 2)))):
        print(f"  {name:40s} {_time(fn, *args) / n * 1e9:8.1f}")
    j = int(np.argmax(pen))
    if pen[j] > 0:
        pd = float(res.elements[i, j, mb.EO_PENDOT])
        cpu = _time(_loop_peak, n, model, j, 1e-2, 1e-6, float(pen[j]) * 0.9, pd, float(pen[j]), pd)
        print(f"  {'_interior_peak (one closed contact)':40s} {cpu / n * 1e9:8.1f}")


if __name__ == "__main__":
    main()
