"""The engine's own benchmarks: cost per step against the hand-reduced slider-crank, one harvester run, one coupled
drive-past, sweep throughput (benchmarks/README.md).

Every case is warmed up once (numba compilation or cache load, the specialised kernel's compilation on a fresh
machine: outside the timing), then timed over a few rounds (``benchmark.pedantic``); ``extra_info["steps"]`` holds
the accepted steps, so time per step = median / steps.  Cases:

* slider-crank (examples/slider_crank_clearance.toml, Lankarani-Nikravesh, 2 crank revolutions, rtol 1e-7, output
  every 10 us) in the engine, with its generic kernel and with the kernel written for the mechanism's structure
  (``multibody/specialised.py``; bitwise the same results), and reduced by hand to its two free coordinates
  (reduced_slider_crank.py: same DOPRI5, tolerances, output stepping and onset location): the floor per step an
  engine could approach.  The ratio per step is printed after the run; the two take different numbers of steps at
  the same rtol (the engine's error norm runs over 18 states, 10 of them exact), so per run they are not compared;
* the harvester (reference machine, clearances A B C F at their reference sizes, 2 cam revolutions, the drives'
  default rtol) in the multibody engine (``drives.simulation.simulate_multibody``) and in the MLSD model;
* one coupled drive-past (the reference machine driven past its bush, ``harvest.coupled.simulate_fruit_force``
  at the coupled runs' default rtol: the run the virtual harvest repeats per replicate and branch class);
* the perturbed assembly of 8 drive-past starts (the coupled mechanism, each start's clearance joints off centre
  and its drive turned by up to 180 deg: up to 16 continuation steps, ``multibody.perturbation``), as every
  replicate drive-past assembles its start;
* sweep throughput: 8 harvester runs over clearance sets drawn 0.5-1.5x around the reference (seed 1), one by one
  as ``berryshaker sweep --model multibody`` runs them;
* reading one replicate start's run-cache entry (``runs.cache.read_cache_entry``: arrays as their bytes, the
  checksum over the text) beside the same value as decimal JSON whose checksum is checked by re-encoding it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
RTOL = 1e-7
OUTPUT_STEP = 1e-5
SWEEP_SETS = 8


def slider_crank():
    """The example clearance slider-crank and its two-revolution duration (s)."""
    from berryshaker.multibody.spec import load_mechanism

    spec = load_mechanism(ROOT / "examples" / "slider_crank_clearance.toml")
    return spec, 2 * 2 * math.pi / abs(spec.drivers[0].speed)


@pytest.fixture(scope="module")
def sc():
    return slider_crank()


@pytest.fixture(scope="module")
def machine():
    from berryshaker.config import reference_machine

    return reference_machine()


@pytest.mark.parametrize("kernel", ["generic", "specialised"])
def test_slider_crank_per_step(benchmark, sc, kernel):
    from berryshaker.multibody.engine import simulate_mechanism

    spec, duration = sc
    benchmark.group = "slider-crank per step"

    def run():
        return simulate_mechanism(spec, duration=duration, rtol=RTOL, output_step=OUTPUT_STEP,
                                  specialised=kernel == "specialised")

    run()  # warm-up (compile; the specialised kernel of this structure once per machine)
    r = benchmark.pedantic(run, rounds=10, iterations=1)
    benchmark.extra_info.update(steps=int(r.info[0]), simulated_s=duration, rtol=RTOL, kernel=kernel)


def test_reduced_slider_crank_per_step(benchmark, sc):
    from reduced_slider_crank import simulate_reduced_slider_crank

    spec, duration = sc
    benchmark.group = "slider-crank per step"
    run = lambda: simulate_reduced_slider_crank(spec, duration, RTOL, OUTPUT_STEP)  # noqa: E731
    run()
    r = benchmark.pedantic(run, rounds=10, iterations=1)
    benchmark.extra_info.update(steps=int(r["steps"]), simulated_s=duration, rtol=RTOL)


def test_reduced_model_matches_engine(sc):
    """Not timed: the hand-reduced model and the engine agree on the first impact (independent formulations)."""
    from reduced_slider_crank import simulate_reduced_slider_crank

    from berryshaker.multibody.engine import simulate_mechanism

    spec, _ = sc
    r = simulate_mechanism(spec, duration=1e-3, rtol=1e-10, output_step=OUTPUT_STEP)
    fi = r.summary()["joints"]["rod_slider"]["first_impact"]
    q = simulate_reduced_slider_crank(spec, 1e-3, 1e-11, OUTPUT_STEP)
    assert q["first_time_s"] == pytest.approx(fi["time_s"], abs=1e-8)
    # the reduced model takes the peak at step ends only (the engine interpolates inside the step)
    assert q["first_peak_N"] == pytest.approx(fi["peak_force_N"], rel=2e-4)


@pytest.mark.parametrize("model", ["multibody", "mlsd"])
def test_harvester_run(benchmark, machine, model):
    benchmark.group = "harvester run, 2 cam revolutions"
    if model == "multibody":
        from berryshaker.drives.simulation import simulate_multibody

        sizes = machine.clearance_sizes()
        run = lambda: simulate_multibody(machine, dict(sizes), revolutions=2, specialised=False)  # noqa: E731
        run()
        res, _ = benchmark.pedantic(run, rounds=5, iterations=1)
        benchmark.extra_info.update(steps=int(res.info[0]))
    else:
        from berryshaker.drives.groove_cam.mlsd import simulate_mlsd

        run = lambda: simulate_mlsd(machine, None, revolutions=2)  # noqa: E731
        run()
        benchmark.pedantic(run, rounds=10, iterations=1)


def test_coupled_drive_past(benchmark, machine):
    from berryshaker.harvest.coupled import simulate_fruit_force

    benchmark.group = "coupled drive-past"
    run = lambda: simulate_fruit_force(machine)  # noqa: E731
    run()
    benchmark.pedantic(run, rounds=3, iterations=1)


@pytest.fixture(scope="module")
def drive_past_motion(machine):
    """The reference machine's coupled drive-past (centred start) as the stem-force table's inputs."""
    from berryshaker.harvest.coupled import drive_past
    from berryshaker.harvest.virtual import ENVELOPE_OUTPUT_STEP, MASS_FACTORS, Z_GRID, bond_strengths

    _, mo = drive_past(machine, None, output_step=ENVELOPE_OUTPUT_STEP)
    z = Z_GRID * machine.plant.branch.length
    y, v, _ = mo.lateral(z, acceleration=False)
    ped = machine.plant.fruit.pedicel
    return (mo.t, (y, v), mo.axial(z), MASS_FACTORS * machine.plant.fruit.mass, ped.stiffness, ped.damping,
            ped.include_weight, bond_strengths(machine))


@pytest.mark.parametrize("channels", ["peaks", "miner"])
def test_stem_force_table(benchmark, drive_past_motion, channels):
    """The stem-force table's compiled pass (41 positions x 33 masses x 2 fruit classes over a 2.2-s drive-past):
    peaks only, and with the Miner-Basquin sums at berryshaker.plant.pedicel.MINER_EXPONENTS (the harvest's)."""
    from berryshaker.plant.pedicel import MINER_EXPONENTS, peak_stem_loads

    benchmark.group = "stem-force table"
    ex = MINER_EXPONENTS if channels == "miner" else ()
    run = lambda: peak_stem_loads(*drive_past_motion, ex)  # noqa: E731
    run()
    benchmark.pedantic(run, rounds=10, iterations=1)


def test_perturbed_assembly(benchmark, machine):
    from berryshaker.harvest.coupled import coupled_mechanism
    from berryshaker.multibody.perturbation import RandomInitialPerturbation

    benchmark.group = "perturbed assembly, 8 drive-past starts"
    spec, _ = coupled_mechanism(machine)
    starts = [RandomInitialPerturbation((k, 1, 0), 1.0, math.pi).for_spec(spec) for k in range(8)]
    turned = [(p, p.shifted_drivers(spec)) for p in starts]
    run = lambda: [p.assemble(s) for p, s in turned]  # noqa: E731
    run()
    benchmark.pedantic(run, rounds=10, iterations=1)
    benchmark.extra_info.update(starts=len(starts))


def test_sweep_throughput(benchmark, machine):
    from berryshaker.drives.simulation import simulate_multibody

    benchmark.group = f"sweep of {SWEEP_SETS} harvester runs"
    rng = np.random.default_rng(1)
    ref = machine.clearance_sizes()
    sets = [{k: float(v * rng.uniform(0.5, 1.5)) for k, v in ref.items()} for _ in range(SWEEP_SETS)]
    run = lambda: [simulate_multibody(machine, c, specialised=False)[1] for c in sets]  # noqa: E731
    run()
    benchmark.pedantic(run, rounds=3, iterations=1)
    benchmark.extra_info.update(runs=SWEEP_SETS)


def _replicate_value():
    """A value the size of one replicate start's (study.runs.replicate_record): its three branch classes' stem-load
    tables and its impact peaks (seeded numbers of the same shapes)."""
    from berryshaker.harvest.virtual import MASS_FACTORS, Z_GRID

    rng = np.random.default_rng(5)
    return {"envelopes": [rng.random((Z_GRID.size, MASS_FACTORS.size, 15)) for _ in range(3)],
            "impact_peaks_N": {p: rng.random(400) * 1e3 for p in "ABCF"}, "peak_force_N": {p: 1e3 for p in "ABCF"}}


@pytest.mark.parametrize("form", ["bytes", "decimal"])
def test_cache_entry_read(benchmark, tmp_path, form):
    """One replicate start's cache entry read back: as written (``bytes``), and the same value as decimal JSON
    checked by re-encoding (``decimal``, what an entry read cost before arrays were stored as their bytes)."""
    import hashlib
    import json

    from berryshaker.runs.cache import _canonical, _jsonable, read_cache_entry, run_value, write_cache_entry

    benchmark.group = "run-cache entry read"
    value = run_value(_replicate_value())
    if form == "bytes":
        path = write_cache_entry(tmp_path, "k" * 64, "bench", {}, value, 1.0, "f")
        run = lambda: read_cache_entry(path, "k" * 64, "f")[0]["value"]  # noqa: E731
    else:
        text = json.dumps(_jsonable(value))
        digest = hashlib.sha256(_canonical(json.loads(text)).encode()).hexdigest()

        def run():
            v = json.loads(text)
            assert hashlib.sha256(_canonical(v).encode()).hexdigest() == digest
            return v
    run()
    benchmark.pedantic(run, rounds=10, iterations=1)
