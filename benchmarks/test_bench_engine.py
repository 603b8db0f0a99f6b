"""pytest-benchmark harness for the multibody engine (not part of the test suite: tests/ is the suite).

Run:  .venv/bin/python -m pytest benchmarks/ --benchmark-only
      .venv/bin/python benchmarks/test_bench_engine.py          (prints the per-step and per-run figures)

Every benchmark is warmed up once (numba compilation / cache load excluded), then timed over several
rounds; ``extra_info`` carries the accepted steps, so that us per step = time / steps.  Cases:

* slider-crank (examples/slider_crank_clearance.toml, 2 crank revolutions, rtol 1e-7, output 10 us):
  the engine's cost per accepted step;
* the same slider-crank reduced by hand to its two free coordinates (benchmarks/reduced_slider_crank.py),
  same DOPRI5, tolerances and onset location: the floor per step an engine could approach;
* the engine's generic kernel and the kernel written for the mechanism's structure
  (``multibody/specialised.py``) side by side (``kernel`` parameter; bitwise the same results);
* the harvester (reference machine, all four clearances A, B, C, F at their reference sizes, 2 cam
  revolutions) in the multibody engine and in the MLSD model: runs per second on one core = 1 / time.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(ROOT / "benchmarks"))

RTOL = 1e-7
OUTPUT_STEP = 1e-5
ROUNDS = 5


def slider_crank():
    """The example clearance slider-crank and its two-revolution duration (s)."""
    from berryshaker.multibody.spec import load_mechanism

    spec = load_mechanism(ROOT / "examples" / "slider_crank_clearance.toml")
    return spec, 2 * 2 * math.pi / abs(spec.drivers[0].speed)


def harvester_runner(specialised: bool = False):
    """(run(), machine): one multibody harvester run of 2 revolutions with the four reference clearances.

    Uses ``berryshaker.drives.simulation.simulate_multibody`` (or the older
    ``drives.groove_cam.mechanism.simulate_harvester_multibody``), whichever the package provides.
    """
    from berryshaker.config import reference_machine

    machine = reference_machine()
    sizes = machine.clearance_sizes() if hasattr(machine, "clearance_sizes") else machine.clearance.sizes()
    try:
        from berryshaker.drives.simulation import simulate_multibody
    except ImportError:  # older layout
        from berryshaker.drives.groove_cam.mechanism import simulate_harvester_multibody as simulate_multibody
    # explicit either way: a run left to choose takes the specialised kernel once it is compiled on this machine
    return (lambda: simulate_multibody(machine, dict(sizes), revolutions=2, specialised=specialised)), machine


def mlsd_runner():
    """run(): one MLSD harvester run of 2 revolutions with the four reference clearances."""
    from berryshaker.config import reference_machine
    from berryshaker.drives.groove_cam.mlsd import simulate_mlsd

    machine = reference_machine()
    return lambda: simulate_mlsd(machine, None, revolutions=2)


def _steps_engine(result):
    return int(result.info[0])


@pytest.fixture(scope="module")
def sc():
    return slider_crank()


KERNELS = pytest.mark.parametrize("kernel", ["generic", "specialised"])


@KERNELS
def test_engine_slider_crank_per_step(benchmark, sc, kernel):
    from berryshaker.multibody.engine import simulate_mechanism

    spec, duration = sc
    specialised = kernel == "specialised"
    run = lambda: simulate_mechanism(spec, duration=duration, rtol=RTOL, output_step=OUTPUT_STEP,  # noqa: E731
                                     specialised=specialised)
    r = run()  # warm-up (compile; the specialised kernel of this structure once per machine)
    benchmark.extra_info.update(steps=_steps_engine(r), simulated_s=duration, rtol=RTOL, kernel=kernel)
    result = benchmark.pedantic(run, rounds=ROUNDS, iterations=1)
    benchmark.extra_info["us_per_step_integrator_only"] = result.wall_time_s / _steps_engine(result) * 1e6
    assert _steps_engine(result) > 0


def test_reduced_slider_crank_per_step(benchmark, sc):
    from reduced_slider_crank import simulate_reduced_slider_crank

    spec, duration = sc
    run = lambda: simulate_reduced_slider_crank(spec, duration, RTOL, OUTPUT_STEP)  # noqa: E731
    r = run()
    benchmark.extra_info.update(steps=r["steps"], simulated_s=duration, rtol=RTOL)
    result = benchmark.pedantic(run, rounds=ROUNDS, iterations=1)
    benchmark.extra_info["us_per_step_integrator_only"] = result["wall_time_s"] / result["steps"] * 1e6
    assert result["steps"] > 0


@KERNELS
def test_harvester_multibody_run(benchmark, kernel):
    run, _ = harvester_runner(specialised=kernel == "specialised")
    res, summary = run()
    benchmark.extra_info.update(steps=_steps_engine(res), revolutions=2, kernel=kernel)
    benchmark.pedantic(run, rounds=3, iterations=1)


def test_harvester_mlsd_run(benchmark):
    run = mlsd_runner()
    run()
    benchmark.pedantic(run, rounds=ROUNDS, iterations=1)


def main() -> None:
    """Print us per step (engine vs hand-reduced) and harvester runs per second per core."""
    import time

    from berryshaker.multibody.engine import simulate_mechanism
    from reduced_slider_crank import simulate_reduced_slider_crank

    spec, duration = slider_crank()

    def best(fn, n=5, inner=None):
        fn()
        out, wall, cpu, wall_in = None, math.inf, math.inf, math.inf
        for _ in range(n):
            t0, c0 = time.perf_counter(), time.process_time()
            out = fn()
            wall, cpu = min(wall, time.perf_counter() - t0), min(cpu, time.process_time() - c0)
            if inner:
                wall_in = min(wall_in, inner(out))
        return out, wall, cpu, wall_in

    print(f"slider-crank, {duration * 1e3:.0f} ms (2 crank revolutions), output every {OUTPUT_STEP * 1e6:g} us; "
          "best of 5 after a warm-up.\nus per accepted step: 'cpu' = CPU time of the whole call / steps; 'marginal' "
          "= (CPU of the 24 ms run - CPU of a 0.1 ms run) / (difference in steps), i.e. without fixed set-up costs")
    print(f"  {'rtol':>6s} {'engine steps':>12s} {'cpu':>6s} {'marginal':>8s}   {'reduced steps':>13s} {'cpu':>6s} "
          f"{'marginal':>8s}   marginal ratio")
    for rtol in (1e-5, 1e-7, 1e-9):
        def eng(d, rtol=rtol):
            return simulate_mechanism(spec, duration=d, rtol=rtol, output_step=OUTPUT_STEP, specialised=False)

        def red(d, rtol=rtol):
            return simulate_reduced_slider_crank(spec, d, rtol, OUTPUT_STEP)

        r, _, cpu, _ = best(lambda: eng(duration))
        r0, _, cpu0, _ = best(lambda: eng(1e-4))
        q, _, cpu_q, _ = best(lambda: red(duration))
        q0, _, cpu_q0, _ = best(lambda: red(1e-4))
        n, nq = _steps_engine(r), q["steps"]
        marg = (cpu - cpu0) / (n - _steps_engine(r0)) * 1e6
        marg_q = (cpu_q - cpu_q0) / (nq - q0["steps"]) * 1e6
        print(f"  {rtol:6.0e} {n:12d} {cpu / n * 1e6:6.2f} {marg:8.2f}   {nq:13d} {cpu_q / nq * 1e6:6.2f} "
              f"{marg_q:8.2f}   {marg / marg_q:5.1f}x")
    run, _ = harvester_runner(specialised=False)
    (res, _s), wall, cpu, _ = best(run, 3)
    print(f"harvester multibody, 2 cam revolutions, clearances A B C F: {wall * 1e3:.0f} ms wall "
          f"({cpu * 1e3:.0f} ms CPU), {_steps_engine(res)} steps = {1 / cpu:.1f} runs/s per core (CPU)")
    _, wall, cpu, _ = best(mlsd_runner(), 5)
    print(f"harvester MLSD, 2 cam revolutions: {wall * 1e3:.1f} ms wall ({cpu * 1e3:.1f} ms CPU) = "
          f"{1 / cpu:.0f} runs/s per core (CPU)")


def test_reduced_model_matches_engine(sc):
    """Not timed: the hand-reduced model and the engine agree on the first impact (independent formulations)."""
    from berryshaker.multibody.engine import simulate_mechanism
    from reduced_slider_crank import simulate_reduced_slider_crank

    spec, _ = sc
    r = simulate_mechanism(spec, duration=1e-3, rtol=1e-10, output_step=OUTPUT_STEP)
    fi = r.summary()["joints"]["rod_slider"]["first_impact"]
    q = simulate_reduced_slider_crank(spec, 1e-3, 1e-11, OUTPUT_STEP)
    assert q["first_time_s"] == pytest.approx(fi["time_s"], abs=1e-8)
    # the reduced model takes the peak at step ends only (the engine interpolates inside the step)
    assert q["first_peak_N"] == pytest.approx(fi["peak_force_N"], rel=2e-4)


if __name__ == "__main__":
    main()
