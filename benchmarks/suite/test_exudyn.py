"""The engine against Exudyn's built-in C++ contact on the clearance slider-crank, at matched accuracy.

Model: ``examples/slider_crank_clearance.toml`` with the Hunt-Crossley law at the rod-slider clearance (Exudyn's
``ObjectContactSphereSphere``, ``impactModel = 1``; the Exudyn model is :mod:`exudyn_models`, built-in items only,
no Python in Exudyn's solve), two crank revolutions (24 ms simulated).  Accuracy: the first-impact peak contact
force relative to the engine at rtol 1e-12.  At each accuracy level the engine runs at the loosest rtol and Exudyn
(implicit generalised-alpha, fixed step) at the largest step of the ladder whose error, and that of every stricter
setting, stays below the level (:data:`MATCHED`, chosen with ``exudyn_contact_ladder.py`` on 2026-11-27: engine
rtol 1e-4 / 1e-5 gave 1.5e-4 / 1.2e-5; Exudyn h = 1e-6 / 4e-7 gave 5.0e-4 / 2.2e-5, h = 5e-7 2.2e-4).  Each case
asserts that its error is below the level, so a change that loses accuracy fails instead of looking faster.

Timed: the engine's whole ``simulate_mechanism`` call (model compilation and assembly included; numba's compilation
or cache load excluded by a warm-up); Exudyn's ``SolveDynamic`` only (``run_exudyn`` returns its wall time; model
building excluded).  The ratio Exudyn / engine at each level is printed after the run (conftest.py).
"""

from __future__ import annotations

import math

import pytest
from exudyn_contact_ladder import exudyn_first_peak, hunt_crossley_slider_crank

#: accuracy level -> (engine rtol, Exudyn fixed step h in s)
MATCHED = {"1e-3": (1e-4, 1e-6), "1e-4": (1e-5, 4e-7)}
OUTPUT_STEP = 1e-5


@pytest.fixture(scope="module")
def case():
    """(spec, y0, two-revolution duration in s, reference first-impact peak in N)."""
    from berryshaker.multibody.engine import initial_state, simulate_mechanism

    spec = hunt_crossley_slider_crank()
    spec = spec.model_copy(update={"simulation": spec.simulation.model_copy(update={"specialised": False})})
    duration = 2 * 2 * math.pi / abs(spec.drivers[0].speed)
    r = simulate_mechanism(spec, duration=duration, rtol=1e-12, output_step=OUTPUT_STEP)
    return spec, initial_state(spec), duration, r.summary()["joints"]["rod_slider"]["first_impact"]["peak_force_N"]


@pytest.mark.parametrize("level", list(MATCHED))
@pytest.mark.parametrize("engine", ["engine", "exudyn"])
def test_exudyn_slider_crank(benchmark, case, engine, level):
    spec, y0, duration, ref = case
    rtol, h = MATCHED[level]
    benchmark.group = f"exudyn slider-crank, first-impact peak to {level}"
    if engine == "engine":
        from berryshaker.multibody.engine import simulate_mechanism

        def run():
            r = simulate_mechanism(spec, duration=duration, rtol=rtol, output_step=OUTPUT_STEP)
            return r.summary()["joints"]["rod_slider"]["first_impact"]["peak_force_N"], int(r.info[0])

        run()  # warm-up: numba compilation or cache load
        peak, steps = benchmark.pedantic(run, rounds=5, iterations=1)
        benchmark.extra_info.update(rtol=rtol)
    else:
        pytest.importorskip("exudyn", reason="Exudyn (the reference engine, test extra) is not installed")
        from exudyn_models import build_exudyn_mechanism, solve_exudyn

        out, keep = {}, []

        def setup():  # a fresh model per round, built outside the timing (kept alive: Exudyn's system container)
            sc, mbs, contacts = build_exudyn_mechanism(spec, y0)
            keep[:] = [sc]
            return (mbs, contacts), {}

        def run(mbs, contacts):
            out["rec"] = solve_exudyn(mbs, contacts, duration, h, output_step=h)

        run(*setup()[0])  # warm-up
        benchmark.pedantic(run, setup=setup, rounds=3, iterations=1)
        t, f = out["rec"][0]["rod_slider"]
        peak, steps = exudyn_first_peak(t, f), int(round(duration / h))
        benchmark.extra_info.update(step_s=h)
    err = abs(peak - ref) / ref
    benchmark.extra_info.update(steps=steps, first_peak_error=err, level=float(level))
    assert err < float(level), f"{engine} missed the accuracy level {level}: error {err:.2e}"
