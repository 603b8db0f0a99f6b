"""The perturbed assembly compiles its mechanism once and moves the offsets and driver angles in the compiled
records (:class:`berryshaker.multibody.assembly.Assembly`): its state is bitwise the one of the description-level
path, which writes each offset and each continuation step's angles into a new description and assembles it
afresh (:func:`berryshaker.multibody.assembly.initial_state`), for the coupled drive-past (phase turns up to
180 deg: 16 continuation steps), the harvester alone and the powered driveline (torque-driven bodies,
auxiliary coordinates), turned or not."""

from __future__ import annotations

import math

import numpy as np
import pytest

from berryshaker.multibody.assembly import Assembly, initial_state
from berryshaker.multibody.perturbation import PHASE_CONTINUATION_STEP, InitialPerturbation, RandomInitialPerturbation
from berryshaker.multibody.spec import mechanism_from_dict


def _assemble_by_description(pert: InitialPerturbation, spec):
    """The perturbed start through descriptions: the offset joints' points moved in a new description, and one
    description per continuation step with the drivers' angles of that step, each assembled from scratch."""
    data = spec.model_dump()
    for j in data["joints"]:
        if j["name"] in pert.joint_offsets:
            dx, dy = pert.joint_offsets[j["name"]]
            j["point_i"] = [j["point_i"][0] - float(dx), j["point_i"][1] - float(dy)]
    offset = mechanism_from_dict(data, "(perturbed assembly)")
    turn = max((abs(float(v)) for v in pert.driver_phases.values()), default=0.0)
    n = max(1, int(math.ceil(turn / PHASE_CONTINUATION_STEP)))
    q = None
    for k in range(n + 1) if turn > 0 else (n,):
        drivers = [d.model_copy(update={"angle0": d.angle0 - float(pert.driver_phases[d.name]) * (1 - k / n)})
                   if d.name in pert.driver_phases else d for d in offset.drivers]
        y = initial_state(offset.model_copy(update={"drivers": drivers}), q)
        q = y[:len(y) // 2]
    return y


def _check_bitwise(spec, perturbations):
    for p in perturbations:
        pert = p.for_spec(spec)
        turned = pert.shifted_drivers(spec)
        fast = pert.assemble(turned)
        np.testing.assert_array_equal(fast, _assemble_by_description(pert, turned))
        assert fast.tobytes() == _assemble_by_description(pert, turned).tobytes()


def test_coupled_drive_past_assembles_bitwise_as_by_description(machine):
    from berryshaker.harvest.coupled import coupled_mechanism

    spec, _ = coupled_mechanism(machine)
    _check_bitwise(spec, [RandomInitialPerturbation((k, 1, 0), 1.0, math.pi) for k in range(4)])


@pytest.mark.parametrize("driveline", ["imposed", "powered"])
def test_harvester_assembles_bitwise_as_by_description(machine, driveline):
    from berryshaker.drives import drive_of
    from berryshaker.drives.powered import with_driveline_mode

    m = with_driveline_mode(machine, driveline)
    spec = drive_of(m).mechanism(m, revolutions=2)
    phase = 0.0 if driveline == "powered" else 0.7  # the powered study runs turn no driver
    _check_bitwise(spec, [RandomInitialPerturbation((k, 5), 1.0, phase) for k in range(3)])
    if driveline == "powered":  # but a powered start can be turned (one, the description path is slow)
        _check_bitwise(spec, [RandomInitialPerturbation((0, 5), 1.0, 0.2)])


def test_a_powered_start_with_a_turned_drive_assembles_and_runs(machine):
    """A turned start of the powered driveline: each continuation step starts from the last one's positions, which
    carry the driveline's auxiliary coordinates (windups, energy accumulators) the assembly's own mechanism does not
    have all of; they failed to broadcast into its state (after writing past the compiled arrays)."""
    from berryshaker.drives import drive_of
    from berryshaker.drives.powered import with_driveline_mode
    from berryshaker.drives.simulation import simulate_multibody
    from berryshaker.multibody.compiled import compile_mechanism

    m = with_driveline_mode(machine, "powered")
    spec = drive_of(m).mechanism(m, revolutions=2)
    pert = RandomInitialPerturbation((3, 1, 0), 1.0, math.pi).for_spec(spec)
    y = pert.assemble(pert.shifted_drivers(spec))
    assert y.shape == (2 * compile_mechanism(spec).n,) and np.all(np.isfinite(y))
    _, summary = simulate_multibody(m, revolutions=2, initial_perturbation=RandomInitialPerturbation((3, 1, 0), 1.0,
                                                                                                    math.pi))
    assert summary["driveline_mode"] == "powered" and math.isfinite(summary["cam_speed_rpm"]["mean"])


def test_an_unperturbed_assembly_is_initial_state(machine):
    from berryshaker.drives import drive_of

    spec = drive_of(machine).mechanism(machine, revolutions=2)
    assert Assembly(spec).state().tobytes() == initial_state(spec).tobytes()
