"""The study's replicate job is one per (setting, start): :func:`berryshaker.study.runs.replicate_run` runs the start's
one drive-past carrying every branch class (berryshaker.harvest.virtual.class_tables_run) and returns every class's
stem-load table with the run's machine loads; every consumer reads one output per start."""

from __future__ import annotations

import numpy as np
import pytest

from berryshaker.config import reference_machine
from berryshaker.harvest.virtual import MACHINE, class_starts, class_tables_run, start_responses
from berryshaker.study.replicate_responses import (
    _cell,
    cells_from_outputs,
    replicate_envelopes,
    replicate_jobs,
)
from berryshaker.study.runs import replicate_run


@pytest.fixture(scope="module")
def three_classes():
    m = reference_machine()
    assert len(m.harvest.branch_classes) == 3
    cl = m.clearance_sizes()
    jobs = replicate_jobs(m, cl, [0, 5])
    return m, cl, jobs, replicate_run(**jobs[1])


def test_one_job_per_start_carrying_every_class(three_classes):
    m, cl, jobs, _ = three_classes
    assert [j["seed"] for j in jobs] == [[0, MACHINE], [5, MACHINE]]
    assert all("scale" not in j for j in jobs)


def test_the_job_returns_every_class_table_and_the_machine_loads(three_classes):
    m, cl, jobs, out = three_classes
    tables, res = class_tables_run(m, cl, class_starts(m, (5, MACHINE)))
    assert len(out["envelopes"]) == 3
    for got, want in zip(out["envelopes"], tables):
        assert np.array_equal(np.array(got), want)
    assert set(out["peak_force_N"]) == set(m.pair_names) and set(out["impact_peaks_N"]) == set(m.pair_names)
    assert out["drive_torque_Nm"]["rms"] > 0 and len(out["drive_torque_Nm"]["revolution_peaks"]) >= 3


def test_consumers_read_one_output_per_start(three_classes):
    m, _, _, out = three_classes
    reps = replicate_envelopes(m, [None, out], [0, 5])  # a failed start is left out
    assert len(reps) == 1 and reps[0][1] == 5 and len(reps[0][0]) == 3
    cell = _cell(m, out, 5)
    assert cells_from_outputs(m, [out], [5]) == [cell]
    want = start_responses(m, reps[0][0], 5)
    assert cell["efficiency_expected"] == want["expected"]["efficiency"]
    assert {f"design_force_{p}" for p in m.pair_names} | {"drive_torque_design", "drive_torque_rms"} <= set(cell)
    assert cell["drive_torque_rms"] == out["drive_torque_Nm"]["rms"]


def test_the_fruit_force_starts_read_the_reference_class_table(three_classes):
    """The fruit-force step's perturbed starts are the virtual harvest's jobs; it reads the class nearest scale 1."""
    from berryshaker.harvest.virtual import fruit_peak_force
    from berryshaker.study.steps.fruit_force import fruit_start_statistics

    m, _, _, out = three_classes
    stats = fruit_start_statistics(m, [out, out], ["chosen"])["chosen"]
    f = m.plant.fruit
    z, m0 = f.positions[0], f.mass
    want = float(fruit_peak_force(np.array(out["envelopes"][1]), np.array([z]), np.array([m0]), m0)[0])
    assert m.harvest.branch_classes[1] == 1.0
    assert stats["positions"][f.names[0]]["values"] == [want, want] and stats["starts"] == 2


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(x == y or (np.isnan(x) and np.isnan(y)) for x, y in
                                        ((float(a[k]), float(b[k])) for k in a))


def test_the_run_keeps_its_start_harvest_and_a_reader_takes_it_only_for_its_description_and_start(three_classes):
    """A cached run's harvest responses are read, not recomputed, by a study of the same description (a warm study
    reads every run); another description, start or response table computes them from the tables."""
    import copy

    from berryshaker.runs.cache import read_value, run_value, value_digest, value_text
    from berryshaker.study.runs import stored_harvest

    m, _, jobs, out = three_classes
    want = start_responses(m, [np.array(e) for e in out["envelopes"]], 5)
    digest = value_digest(m.model_dump(mode="json"))
    assert digest == value_digest(jobs[1]["machine_data"])  # the reader's description is the job's
    back = read_value(value_text(run_value(out)))  # as the cache keeps it
    kept = stored_harvest(back, digest, 5)
    assert kept is not None and all(_same(kept[k], want[k]) for k in ("expected", "field", "count_sd"))
    assert stored_harvest(back, digest, 0) is None and stored_harvest(back, "0" * 64, 5) is None
    marked = copy.deepcopy(back)
    marked["harvest"]["field"]["efficiency"] = -1.0  # a sentinel: which path the cell took
    assert cells_from_outputs(m, [marked], [5])[0]["efficiency"] == -1.0
    other = m.model_copy(update={"harvest": m.harvest.model_copy(update={"seed": m.harvest.seed + 1})})
    assert cells_from_outputs(other, [marked], [5])[0]["efficiency"] != -1.0
    marked["harvest"]["responses"] = marked["harvest"]["responses"][:-1]  # a table that has changed since
    assert cells_from_outputs(m, [marked], [5])[0]["efficiency"] == want["field"]["efficiency"]


def test_a_setting_summary_takes_the_responses_its_runs_kept(three_classes):
    """``replicate_response`` (the harvest-response step's rows) uses a start's kept responses where given and
    computes the others: with every start's own responses given, the same numbers as computing them all."""
    import copy

    from berryshaker.harvest.virtual import replicate_response
    from berryshaker.runs.cache import value_digest
    from berryshaker.study.runs import stored_harvest

    m, _, jobs, out = three_classes
    reps = replicate_envelopes(m, [out, out], [5, 5])
    kept = stored_harvest(out, value_digest(jobs[1]["machine_data"]), 5)
    assert kept is not None
    computed = replicate_response(m, reps)
    assert replicate_response(m, reps, [kept, None]) == computed == replicate_response(m, reps, [kept, kept])
    marked = copy.deepcopy(kept)
    marked["expected"]["efficiency"] = -1.0  # a sentinel: the given responses are the ones used
    got = replicate_response(m, reps, [marked, marked])
    assert got["efficiency_kg_min"] == -1.0 and computed["efficiency_kg_min"] != -1.0
