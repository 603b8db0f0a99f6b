"""Batched runs (berryshaker.multibody.batch): one compiled call over many parameter sets gives, set by set,
bitwise the result of the run on its own; a bad set is reported without stopping the others."""

from pathlib import Path

import numpy as np
import pytest

from berryshaker.errors import ConfigError
from berryshaker.multibody.batch import simulate_mechanisms
from berryshaker.multibody.engine import simulate_mechanism
from berryshaker.multibody.spec import load_mechanism, mechanism_from_dict

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "slider_crank_clearance.toml"


def _with_clearance(spec, c):
    data = spec.model_dump()
    for j in data["joints"]:
        if j["name"] == "rod_slider":
            j["clearance"] = c
    return mechanism_from_dict(data)


def test_batch_equals_one_by_one_bitwise():
    spec = load_mechanism(EXAMPLE)
    sizes = [0.1e-3, 0.25e-3, 0.5e-3, 0.03]  # the last does not fit the pin: a ConfigError for that set only
    specs = [_with_clearance(spec, c) for c in sizes]
    import numba

    threads = numba.get_num_threads()
    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))  # the prange path where there are 2 cores
    try:
        batch = simulate_mechanisms(specs, duration=4e-3, output_step=2e-5)
        numba.set_num_threads(1)  # the serial path
        serial = simulate_mechanisms(specs, duration=4e-3, output_step=2e-5)
    finally:
        numba.set_num_threads(threads)
    for a, b in zip(batch[:3], serial[:3]):
        np.testing.assert_array_equal(a.elements, b.elements)
    assert isinstance(batch[3], ConfigError) and "does not fit a pin" in str(batch[3])
    for s, b in zip(specs[:3], batch[:3]):
        one = simulate_mechanism(s, duration=4e-3, output_step=2e-5)
        assert b.info[0] > 50 and b.info[2] >= 1  # steps taken, contact onsets located
        for name in ("y", "elements", "multipliers", "peaks", "first"):
            np.testing.assert_array_equal(getattr(b, name), getattr(one, name), err_msg=name)
        np.testing.assert_array_equal(b.info[:6], one.info[:6])
    # different clearances do give different runs (the sets are not mixed up)
    assert batch[0].peaks[0] != pytest.approx(batch[2].peaks[0], rel=1e-3)


def test_sweep_runner_batches_multibody_rows(tmp_path):
    """The runner sends chunks of a run function with a batched twin (study.runs.multibody_row) through one
    compiled call; each run's summary equals the single run's, a bad point fails alone, and the cache holds
    the batched runs like single ones."""
    from berryshaker.config import reference_machine
    from berryshaker.runs.runner import SweepRunner, batchable, execute_job
    from berryshaker.study.runs import multibody_row

    assert batchable(multibody_row)
    data = reference_machine().model_dump(mode="json")
    jobs = [dict(machine_data=data, clearance={"A": a}, revolutions=2) for a in (0.2e-3, 0.4e-3)]
    jobs.append(dict(machine_data=data, clearance={"A": -1.0}, revolutions=2))
    runner = SweepRunner(workers=1, cache_dir=tmp_path, progress=False)
    out = runner.map(multibody_row, jobs)
    assert out[2].error and "finite length >= 0" in out[2].error
    single = execute_job(multibody_row, jobs[1])["value"]
    for key in ("collision_force_N", "load_moment_Nm", "drive_moment_Nm", "steps", "rejected_steps"):
        assert out[1].value[key] == single[key], key
    again = SweepRunner(workers=1, cache_dir=tmp_path, progress=False).map(multibody_row, jobs[:2])
    assert all(r.cached for r in again) and again[0].value == out[0].value
