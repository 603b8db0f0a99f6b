"""The branch classes of a replicate start as one-way probes of one drive-past
(:func:`berryshaker.harvest.virtual.class_tables_run`): each class's probe stands where it meets the comb at its own
class's drive phase, the combs' motion does not depend on the probes, and each probe's table is what a separate
drive-past of that class from its own start gives.

Exact where the machine is not chaotic: with every clearance closed the harvester is a kinematic chain (the drive
prescribes the combs), so the probe run and a separate run of a class differ by the integrator's tolerance and the
probe's phase rounding to an output step (omega x 0.1 ms / 2 = 6e-4 rad) only.  Measured on the reference machine,
starts 0 and 1: comb angles within 3.3e-10 rad, tables within 4.5e-4 of each channel's largest value.  With
clearances the run is chaotic (the probes change the integrator's step sequence: their contact onsets are events,
though their states are out of its error norm), so a class's table differs from its separate run's as another draw of the
same start would; the design was measured against one run per class on 16 starts x 3 classes (every harvest index's
mean paired difference within 0.04 replicate SD and 1.7 SE; CHANGELOG.md, 0.2.0).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from berryshaker.config import reference_machine
from berryshaker.harvest.virtual import (
    ENVELOPE_OUTPUT_STEP,
    MACHINE,
    class_phase_offsets,
    class_starts,
    class_tables_run,
    machine_start,
    stem_force_envelope_run,
)

#: each channel of a probe's table against a separate run of its class: within this fraction of the channel's
#: largest value (measured 4.5e-4 at most)
TABLE_TOL = 2e-3
#: comb angles of the probe run against a run without probes (rad; measured 3.3e-10)
ANGLE_TOL = 1e-8


@pytest.fixture(scope="module")
def closed():
    """The reference machine with every clearance closed, and its start 0's class starts."""
    m = reference_machine()
    return m, {p: 0.0 for p in m.pair_names}, class_starts(m, (0, MACHINE))


@pytest.fixture(scope="module")
def probe_run(closed):
    m, cl, starts = closed
    return class_tables_run(m, cl, starts)


def test_each_probe_meets_the_comb_at_its_class_phase(closed):
    m, cl, starts = closed
    from berryshaker.drives import drive_of

    first, offsets, drawn = class_phase_offsets(m, cl, starts)
    omega = drive_of(m).mechanism(m, revolutions=2).drivers[0].speed  # signed: the angle turns by omega t
    assert abs(omega) == pytest.approx(m.drive_speed)
    v = m.operation.walking_speed
    period = 2 * math.pi / abs(omega)
    assert len(offsets) == len(m.harvest.branch_classes) == 3 and offsets[first] == 0.0
    phase = [d.driver_phases["drive"] for d in drawn]
    assert len(set(phase)) == 3  # every class its own draw
    for c, d in enumerate(offsets):
        assert 0.0 <= d < v * period
        assert round(d / v / ENVELOPE_OUTPUT_STEP, 9).is_integer()  # a passage starts on a sample of the run
        turned = omega * d / v  # the drive's further turn when the probe arrives
        gap = (turned - (phase[c] - phase[first])) % (2 * math.pi)
        assert min(gap, 2 * math.pi - gap) <= abs(omega) * ENVELOPE_OUTPUT_STEP / 2 + 1e-12
    # the run starts from the class that makes it the shortest
    spans = [max(v * (((p - p0) / omega) % period) for p in phase) for p0 in phase]
    assert max(offsets) <= min(spans) + v * ENVELOPE_OUTPUT_STEP


def test_the_combs_move_as_without_the_probes(closed, probe_run):
    """The first class alone from its own start (no probes): the same comb motion over its whole run."""
    m, cl, starts = closed
    first, _, _ = class_phase_offsets(m, cl, starts)
    _, res = probe_run
    _, alone = stem_force_envelope_run(m, cl, m.harvest.branch_classes[first], starts[first])
    assert res.t[-1] > alone.t[-1]  # lengthened to cover every probe's passage
    n = len(alone.t)
    assert np.array_equal(res.t[:n], alone.t) or np.allclose(res.t[:n], alone.t, rtol=0, atol=1e-12)
    names = [b.name for b in alone.compiled.spec.bodies]
    for body in ("left_comb", "right_comb"):
        i = 3 * names.index(body) + 2
        assert np.max(np.abs(res.y[:n, i] - alone.y[:, i])) < ANGLE_TOL, body


def test_each_probe_table_is_its_class_run(closed, probe_run):
    """Each class's table is a separate drive-past of that class from its own machine start (its own phase)."""
    m, cl, starts = closed
    tables, _ = probe_run
    for c, scale in enumerate(m.harvest.branch_classes):
        ref, _ = stem_force_envelope_run(m, cl, scale, starts[c])
        assert tables[c].shape == ref.shape
        rel = np.max(np.abs(tables[c] - ref), axis=(0, 1)) / np.max(np.abs(ref), axis=(0, 1))
        assert np.all(rel < TABLE_TOL), (c, rel)
    # the classes differ (the probes are not one branch read three times)
    assert not np.allclose(tables[0], tables[2], rtol=0.05)


def test_one_class_is_the_class_run(small_harvest_machine):
    """With one branch class there is no probe: the run and its table are the class's own drive-past, bit for bit
    (the eccentricities and the phase drawn as the engine draws them on the coupled mechanism)."""
    m = small_harvest_machine
    cl = m.clearance_sizes()
    start = machine_start(m, (0, MACHINE, 0))
    (table,), res = class_tables_run(m, cl, [start])
    ref, ref_res = stem_force_envelope_run(m, cl, 1.0, start)
    assert np.array_equal(res.y, ref_res.y)
    assert np.array_equal(table, ref)


def test_a_start_needs_one_machine_start_per_class(closed):
    m, cl, starts = closed
    with pytest.raises(ValueError, match="3 branch classes"):
        class_tables_run(m, cl, starts[:2])


def test_probe_offsets_lengthen_the_run_and_centre_the_bush():
    """coupled_mechanism: a probe at d passes d / v later, the run covers every passage, the bush stands centred."""
    from berryshaker.harvest.coupled import coupled_mechanism
    from berryshaker.harvest.virtual import branch_class_machine

    m = reference_machine()
    base, _ = coupled_mechanism(m)
    other = branch_class_machine(m, 1.15)
    spec, _ = coupled_mechanism(m, probes=(other,), probe_offsets=(0.1,))
    v = m.operation.walking_speed
    assert spec.simulation.duration == pytest.approx(base.simulation.duration + 0.1 / v)
    assert spec.plant.start_distance == base.plant.start_distance
    by = {c.name: c for c in spec.plant.contacts}
    was = {c.name: c for c in base.plant.contacts}
    assert by["comb_left_probe1"].row_offset == 0.1 and by["comb_left"].row_offset == 0.0
    members = [n for n in was if n.startswith("bush_")]
    assert members and all(by[n].row_offset == pytest.approx(was[n].row_offset + 0.05) for n in members)
    # the probe is struck through its own branch's contact stiffness (thicker: stiffer), acting back on nothing
    assert by["comb_left_probe1"].contact.stiffness > spec.plant.contact.stiffness
    assert by["comb_left_probe1"].reaction_weight == 0.0
    with pytest.raises(Exception, match="probe offsets"):
        coupled_mechanism(m, probes=(other,), probe_offsets=(0.1, 0.2))


def test_branch_class_probes_leave_the_error_norm_and_must_not_act_back():
    """The branch classes' probe modes are out of the integrator's step-size control (plant.probe_modes: atol 1e300
    on their positions and velocities, rtol and atol rescaled by sqrt(controlled / all)); a comparison of modal
    models keeps them in; a probe contact that acts back, or more probe modes than the body has, is refused."""
    from berryshaker.errors import ConfigError
    from berryshaker.harvest.coupled import coupled_mechanism, plant_modes
    from berryshaker.multibody.compiled import compile_mechanism
    from berryshaker.multibody.engine import prepare_run
    from berryshaker.multibody.spec import mechanism_from_dict

    m = reference_machine()
    probe = m  # one more branch of the same class
    kept, _ = coupled_mechanism(m, probes=(probe,))
    out, _ = coupled_mechanism(m, probes=(probe,), probes_in_error_norm=False)
    k = len(plant_modes(probe)[0].omega)
    assert kept.plant.probe_modes == 0 and out.plant.probe_modes == k
    cm = compile_mechanism(out)
    run = prepare_run(out, rtol=1e-5)
    n, n0 = cm.n, cm.n_base
    assert np.all(run.atol[n0 - k:n0] > 1e299) and np.all(run.atol[n + n0 - k:n + n0] > 1e299)
    controlled = np.count_nonzero(run.atol < 1e299)
    assert controlled == 2 * n - 2 * k - 2 * (n - n0) + len(cm.state_windup0)
    assert run.rtol == pytest.approx(1e-5 * math.sqrt(controlled / (2 * n)))
    d = out.model_dump(mode="json")
    d["plant"]["contacts"][-1]["reaction_weight"] = 1.0
    with pytest.raises(ConfigError, match="reaction_weight"):
        mechanism_from_dict(d)
    d = out.model_dump(mode="json")
    d["plant"]["probe_modes"] = len(d["plant"]["omega"]) + 1
    with pytest.raises(ConfigError, match="probe_modes"):
        mechanism_from_dict(d)
