"""Planar multibody engine: closed-form, independent-engine (Exudyn), convergence and energy checks."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.errors import ConfigError, GeometryError, SimulationError
from berryshaker.multibody.engine import initial_state, simulate_mechanism
from berryshaker.multibody.spec import load_mechanism, mechanism_from_dict

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "slider_crank_clearance.toml"
R, L, W = 0.05, 0.12, 5000 * 2 * math.pi / 60


@pytest.fixture(scope="module")
def spec():
    return load_mechanism(EXAMPLE)


def _modify(spec, fn):
    data = spec.model_dump()
    fn(data)
    return mechanism_from_dict(data)


def _ideal(spec):
    def f(d):
        for j in d["joints"]:
            if j["name"] == "rod_slider":
                j["type"] = "revolute"
    return _modify(spec, f)


def slider_crank_closed_form(t):
    """Slider position, rod angle and their derivatives for a crank at constant speed (exact)."""
    th = W * t
    s_b = -R * np.sin(th) / L  # sin(beta), rod angle beta measured from +x (crank on the left)
    beta = np.arcsin(s_b)
    cb = np.cos(beta)
    bd = -R * W * np.cos(th) / (L * cb)
    bdd = (R * W**2 * np.sin(th) / L + bd**2 * s_b) / cb
    x = R * np.cos(th) + L * cb
    xd = -R * W * np.sin(th) - L * s_b * bd
    xdd = -R * W**2 * np.cos(th) - L * (cb * bd**2 + s_b * bdd)
    return th, beta, bd, bdd, x, xd, xdd


def test_ideal_slider_crank_against_closed_form(spec):
    """Kinematics x = r cos(th) + sqrt(l^2 - r^2 sin^2 th) and the rod-slider pin force from Newton-Euler
    of rod and slider by hand (Norton, Design of Machinery, ch. 11: slider-crank dynamic force analysis)."""
    ideal = _ideal(spec)
    r = simulate_mechanism(ideal, duration=0.012, output_step=1e-5)
    th, beta, bd, bdd, x, xd, xdd = slider_crank_closed_form(r.t)
    n = 9
    np.testing.assert_allclose(r.y[:, 6], x, atol=1e-10)
    np.testing.assert_allclose(r.y[:, n + 6], xd, atol=1e-7 * R * W)
    np.testing.assert_allclose(r.y[:, 5], beta, atol=1e-10)
    # pin force on the slider at B: horizontal = m3 * x'' (no friction, no gravity); vertical from the
    # rod's moment balance about the crank pin A
    m2, j2, m3 = 0.21, 2.5e-4, 0.14
    fbx = m3 * xdd
    # rod centre acceleration
    ax_a = -R * W**2 * np.cos(th)
    ay_a = -R * W**2 * np.sin(th)
    gx = ax_a + L / 2 * (-np.cos(beta) * bd**2 - np.sin(beta) * bdd)
    gy = ay_a + L / 2 * (-np.sin(beta) * bd**2 + np.cos(beta) * bdd)
    # moment about A of forces on the rod: force at B on the rod is -F_B; arm A->B = L (cos b, sin b)
    # m2 (rG - rA) x aG + J2 b'' = (rB - rA) x (-F_B)
    lhs = m2 * (L / 2 * np.cos(beta) * gy - L / 2 * np.sin(beta) * gx) + j2 * bdd
    # (L cos b)(-fby) - (L sin b)(-fbx) = lhs
    fby = -(lhs - L * np.sin(beta) * fbx) / (L * np.cos(beta))
    f_hand = np.hypot(fbx, fby)
    f_mb = r.reaction("rod_slider")
    np.testing.assert_allclose(f_mb, f_hand, rtol=1e-6, atol=1e-6 * f_hand.max())


@pytest.fixture(scope="module")
def exudyn_run(spec):
    exudyn = pytest.importorskip("exudyn", reason="Exudyn (independent reference engine) is not installed")
    assert exudyn
    from exudyn_slider_crank import run_exudyn_slider_crank

    y0 = initial_state(spec)
    rec, _ = run_exudyn_slider_crank(spec, y0, duration=1.5e-3, step=2.5e-7)
    return rec


def test_first_impact_and_early_acceleration_match_exudyn(spec, exudyn_run):
    rec = exudyn_run
    f = rec["force"]
    i0 = int(np.argmax(f > 0))
    i1 = i0 + int(np.argmax(f[i0:] == 0))
    peak_exu = f[i0:i1].max()
    r = simulate_mechanism(spec, duration=1.5e-3, output_step=1e-6, rtol=1e-8)
    fi = r.summary()["joints"]["rod_slider"]["first_impact"]
    assert fi["peak_force_N"] == pytest.approx(peak_exu, rel=2e-3)
    assert fi["time_s"] == pytest.approx(rec["t"][i0], abs=1e-6)
    # slider acceleration over the first 1.5 ms (covers the first impacts), ours by differentiating the
    # slider velocity; Exudyn's from its node accelerations
    acc = np.gradient(r.y[:, 9 + 6], r.t)
    t = rec["t"][5:]
    a_exu = rec["slider_acc"][5:]
    a_ours = np.interp(t, r.t, acc)
    rms = np.sqrt(np.mean(a_exu**2))
    assert np.sqrt(np.mean((a_ours - a_exu) ** 2)) < 0.05 * rms


def test_first_impact_converges_as_tolerance_tightens(spec):
    peaks = []
    for rtol in (1e-5, 1e-6, 1e-7, 1e-8, 1e-10):
        r = simulate_mechanism(spec, duration=1e-3, rtol=rtol)
        peaks.append(r.summary()["joints"]["rod_slider"]["first_impact"]["peak_force_N"])
    ref = peaks[-1]
    errors = [abs(p - ref) for p in peaks[:-1]]
    assert errors == sorted(errors, reverse=True)
    assert errors[0] / ref < 1e-3 and errors[-1] / ref < 1e-5


def _energy(r, spec):
    e = np.zeros(len(r.t))
    for i, b in enumerate(spec.bodies):
        vx, vy, w = r.y[:, 9 + 3 * i], r.y[:, 9 + 3 * i + 1], r.y[:, 9 + 3 * i + 2]
        e += 0.5 * b.mass * (vx**2 + vy**2) + 0.5 * b.inertia * w**2
    return e


def _free_running(spec, ideal=True, law="hertz"):
    def f(d):
        d["drivers"][0]["type"] = "torque"
        d["drivers"][0]["torque"] = 0.0
        for j in d["joints"]:
            if j["name"] == "rod_slider":
                if ideal:
                    j["type"] = "revolute"
                else:
                    j["contact"]["law"] = law
    return _modify(spec, f)


def test_energy_is_conserved_with_ideal_joints_and_no_damping(spec):
    free = _free_running(spec)
    r = simulate_mechanism(free, duration=0.03, rtol=1e-9)
    e = _energy(r, free)
    assert np.max(np.abs(e - e[0])) / e[0] < 1e-6
    assert abs(r.y[-1, 9 + 2]) > 100  # it kept running


def test_generic_summary_counts_onsets_as_transitions_not_step_cuts(spec):
    """MultibodyResult.summary(): ``contact_onsets`` are the impacts the integrator counts (located onsets closing
    at >= 1 mm/s over the statistics window); the slider-crank's impacts are fast, so on a 1 us written series
    the separated -> in-contact transitions counted here by hand are the same number; ``event_cuts`` is the
    integrator's count of steps cut back to an onset (info[2]), which counts every refinement, so it is the
    larger."""
    free = _free_running(spec, ideal=False, law="hertz")
    r = simulate_mechanism(free, duration=0.01, rtol=1e-8, output_step=1e-6)
    s = r.summary()
    k = r.compiled.frc_names.index("rod_slider")
    sel = r.t >= r.stats_from - 1e-12
    pen = r.elements[sel, k, 1]
    by_hand = sum(1 for a, b in zip(pen[:-1], pen[1:]) if a <= 0.0 < b)
    assert s["contact_onsets"] == {"rod_slider": by_hand} and by_hand >= 1
    assert s["joints"]["rod_slider"]["contact_onsets"] == by_hand == s["contact_onsets_located"]
    assert s["event_cuts"] == int(r.info[2]) and s["event_cuts"] > by_hand


def test_energy_is_conserved_through_elastic_hertz_impacts(spec):
    """Hertz contact is conservative: kinetic + contact energy K delta^2.5/2.5 stays constant through
    the impacts (checks the force law, the contact-onset location and the integrator together)."""
    free = _free_running(spec, ideal=False, law="hertz")
    r = simulate_mechanism(free, duration=0.01, rtol=1e-10, output_step=1e-6)
    k = r.compiled.model.fflt[0][7]
    pen = np.maximum(r.elements[:, 0, 1], 0.0)
    e = _energy(r, free) + k * pen**2.5 / 2.5
    assert r.summary()["joints"]["rod_slider"]["contact_fraction"] > 0.01
    assert np.max(np.abs(e - e[0])) / e[0] < 1e-4


def test_bad_mechanisms_are_named(spec):
    with pytest.raises(ConfigError, match="unknown body 'cranck'"):
        _modify(spec, lambda d: d["joints"][0].__setitem__("body_j", "cranck"))
    # guide 0.2 m above the crank centre: a 0.12 m rod on a 0.05 m crank cannot reach it
    bad = _modify(spec, lambda d: d["joints"][2].__setitem__("point_i", [0.0, 0.2]))
    with pytest.raises(GeometryError, match=r"cannot assemble: joint '\w+' stays"):
        simulate_mechanism(bad, duration=1e-3)
    too_big = _modify(spec, lambda d: d["joints"][3].__setitem__("clearance", 0.02))
    with pytest.raises(ConfigError, match="does not fit a pin"):
        simulate_mechanism(too_big, duration=1e-3)

    def lock(d):
        d["joints"].append(dict(d["joints"][0], name="second_pin", point_i=[0.01, 0.0], point_j=[-0.015, 0.0]))
    with pytest.raises((SimulationError, GeometryError), match="redundant|locked|cannot assemble|gave up"):
        simulate_mechanism(_modify(spec, lock), duration=1e-3)


def test_velocity_scale_sets_the_velocity_tolerance_in_any_speed_unit(spec):
    """``simulation.velocity_scale`` is a speed (checked dimension, any speed unit) and sets the velocities'
    absolute tolerance rtol x scale; the positions' stays rtol x 1 mm; the engine's default is 0.1 m/s."""
    from berryshaker.multibody.engine import POSITION_SCALE, prepare_run

    assert spec.simulation.velocity_scale == 0.1
    fast = _modify(spec, lambda d: d["simulation"].__setitem__("velocity_scale", "36 km/h"))
    assert fast.simulation.velocity_scale == pytest.approx(10.0)
    run = prepare_run(fast, duration=1e-4, rtol=1e-6)
    n = run.cm.n
    assert np.all(run.atol[:n] == POSITION_SCALE * 1e-6)
    assert np.all(run.atol[n:] == pytest.approx(10.0 * 1e-6))
    with pytest.raises(ConfigError, match="velocity_scale"):
        _modify(spec, lambda d: d["simulation"].__setitem__("velocity_scale", "2 mm"))
    with pytest.raises(ConfigError, match="velocity_scale"):
        _modify(spec, lambda d: d["simulation"].__setitem__("velocity_scale", 0.0))


def test_simulate_mechanism_cli_json(tmp_path):
    r = CliRunner().invoke(app, ["simulate", "--mechanism", str(EXAMPLE), "--duration", "0.03", "--json",
                                 "--out", str(tmp_path / "sc")])
    assert r.exit_code == 0, r.output
    s = json.loads(r.stdout)
    f = s["joints"]["rod_slider"]["force_N"]
    assert f["peak"] >= f["rms"] >= f["mean"] > 0
    assert s["steps"] > 100 and s["wall_time_s"] > 0
    assert s["joints"]["rod_slider"]["first_impact"]["impact_velocity_m_s"] > 1.0
    # onset keys as in the harvester summaries: impacts (separated -> contact on the written series) per
    # clearance joint and their total; the integrator's step cut-backs are event_cuts, a different count
    on = s["contact_onsets"]
    assert on and set(on) == {n for n, j in s["joints"].items() if j["type"].endswith("_clearance")}
    assert s["contact_onsets_located"] == sum(on.values()) > 0
    assert all(s["joints"][n]["contact_onsets"] == v for n, v in on.items())
    assert s["event_cuts"] >= s["contact_onsets_located"]
    assert (tmp_path / "sc" / "timeseries.csv").exists()
    assert json.loads((tmp_path / "sc" / "summary.json").read_text())["provenance"]["version"]


def test_parallel_runs_equal_serial(machine):
    from berryshaker.runs.runner import SweepRunner
    from berryshaker.study.runs import reduced_row

    data = machine.model_dump(mode="json")
    jobs = [dict(machine_data=data, clearance={"A": a}, revolutions=2) for a in (0.0, 0.25e-3, 0.5e-3)]
    jobs.append(dict(machine_data=data, clearance={"A": -1.0}, revolutions=2))
    par = SweepRunner(workers=2, use_cache=False, progress=False).map(reduced_row, jobs)
    ser = SweepRunner(workers=1, use_cache=False, progress=False).map(reduced_row, jobs[:1])
    assert [o.index for o in par] == [0, 1, 2, 3]
    assert par[0].value["collision_force_N"] == ser[0].value["collision_force_N"]
    assert par[3].error and "finite length >= 0" in par[3].error and par[2].value is not None


def test_applied_force_and_gravity_on_a_pendulum():
    """A bar pinned at one end under gravity and a constant horizontal force at its tip settles (with a
    damper) at the static angle tan(theta) = F / (m g / 2 + ...): here m g L/2 sin = F L cos."""
    m, L, g, F = 2.0, 0.5, 9.81, 3.0
    spec = mechanism_from_dict(dict(
        mechanism=dict(name="pendulum", gravity=[0.0, -g]),
        bodies=[dict(name="bar", mass=m, inertia=m * L * L / 12, position=[0.0, -L / 2], angle=-math.pi / 2)],
        joints=[dict(name="pin", type="revolute", body_i="ground", body_j="bar", point_j=[-L / 2, 0.0])],
        forces=[dict(name="push", type="force", body_i="bar", point=[L / 2, 0.0], force=["3 N", "0 N"]),
                dict(name="damper", body_i="bar", damping=0.5)],
        simulation=dict(duration=20.0, output_step=0.01, max_step=0.01)))
    r = simulate_mechanism(spec)
    theta = r.y[-1, 2] + math.pi / 2  # deflection from hanging straight down
    # moments about the pin: F L cos(theta) = m g (L/2) sin(theta)
    assert math.tan(theta) == pytest.approx(F / (m * g / 2), rel=1e-4)
    assert r.reaction("pin")[-1] == pytest.approx(math.hypot(F, m * g), rel=1e-4)


def test_trajectory_does_not_depend_on_the_output_grid(machine):
    """Output samples and interior peaks are evaluated from the dense output and leave the integration state
    alone (the groove cam's foot-point memories included), so a run written every 50 us and one written every
    100 us take the same steps and agree sample for sample: the output grid is not a source of scatter in the
    chaotic clearance dynamics (before: the cam's Newton guesses moved by the samples perturbed the trajectory
    at round-off, and a coupled run took 56 000 or 1 000 000 steps depending on the grid)."""
    from berryshaker.drives import drive_of

    spec = drive_of(machine).mechanism(machine, revolutions=2)
    coarse = simulate_mechanism(spec, duration=0.15, output_step=1e-4)
    fine = simulate_mechanism(spec, duration=0.15, output_step=5e-5)
    assert np.array_equal(coarse.info[:3], fine.info[:3])
    assert np.array_equal(coarse.y, fine.y[::2])
    assert np.array_equal(coarse.peaks, fine.peaks)


@pytest.mark.parametrize("specialised", [False, True])
def test_chunked_integration_is_bitwise_one_call(machine, monkeypatch, specialised):
    """A run integrates in chunks (``engine.integrate_in_chunks``: back in Python between them, where Ctrl-C is
    seen); chunks of any length resume the step sequence exactly, with the generic and the specialised kernel: the
    same trajectory, samples, multipliers, peaks, first contacts and step counts as one uninterrupted call."""
    import berryshaker.multibody.engine as engine
    from berryshaker.drives import drive_of

    monkeypatch.delenv("BERRYSHAKER_KERNEL", raising=False)
    spec = drive_of(machine).mechanism(machine, revolutions=2)
    whole = simulate_mechanism(spec, duration=0.3, specialised=specialised)
    monkeypatch.setattr(engine, "CHUNK_STEPS", 173)  # ends anywhere: after a rejection, inside an onset cut
    parts = simulate_mechanism(spec, duration=0.3, specialised=specialised)
    assert parts.info[0] + parts.info[1] > 10 * 173
    for name in ("y", "elements", "multipliers", "peaks", "first", "info"):
        assert np.array_equal(getattr(whole, name), getattr(parts, name)), name


def test_parameter_records_do_not_overlap_and_cover_every_slot():
    """Each element type's record (multibody/layout.py) holds every slot once: no two of its slots share an index
    (a table slot spans MAX_TABLE), and every named slot belongs to some record."""
    from berryshaker.multibody import layout as lay

    slots = {n for n in vars(lay) if n[:3] in ("FF_", "FI_", "CF_", "CI_")}
    used = set()
    for records in (lay.FORCE_RECORDS, lay.CONSTRAINT_RECORDS):
        for typ, names in records.items():
            assert len(set(names)) == len(names), (typ, names)
            used |= set(names)
            for arr in ("F", "I"):  # the float and the integer row apart
                cells = [c for n in names if n[1] == arr
                         for c in range(getattr(lay, n), getattr(lay, n) + lay.SLOT_WIDTH.get(n, 1))]
                assert len(cells) == len(set(cells)), f"type {typ}: two slots at one index: {names}"
                width = {"FF": lay.N_FF, "FI": lay.N_FI, "CF": lay.N_CF, "CI": lay.N_CI}
                assert all(c < width[n[:2]] for n in names if n[1] == arr for c in cells)
    assert slots == used, slots ^ used
    with pytest.raises(ValueError, match="no slot 'bore_x'"):
        lay.force_record(lay.FRC_SLOT_CL, bore_x=1.0)  # a slot of another element type
    ints, flts = lay.force_record(lay.FRC_TORQUE_SPEED, body_i=2, table_n=2, table_speeds=[1.0, 2.0],
                                 table_torques=[3.0, 4.0])
    assert ints[lay.FI_BODY_I] == 2 and flts[lay.FF_TABLE_TORQUES + 1] == 4.0


def test_each_force_element_reads_only_its_own_record():
    """The compiled element functions (multibody/force_elements.py) read the slots of their own type's record only,
    the helpers they call included: a slot name that another type uses for something else fails here."""
    import types

    from berryshaker.multibody import force_elements as fe
    from berryshaker.multibody import layout as lay

    functions = {lay.FRC_REV_CL: fe.pin_in_bore, lay.FRC_SLOT_CL: fe.pin_in_slot,
                 lay.FRC_GROOVE_CL: fe.roller_in_groove, lay.FRC_BRANCH: fe.branch_contact,
                 lay.FRC_ROT_SD: fe.rotational_spring_damper, lay.FRC_TORQUE: fe.constant_torque,
                 lay.FRC_FORCE: fe.constant_force, lay.FRC_TORQUE_SPEED: fe.torque_speed_source,
                 lay.FRC_GEAR_SD: fe.geared_spring_damper}
    assert set(functions) == set(lay.FORCE_RECORDS)

    def names(fn, seen):
        code = fn.py_func.__code__
        out = set(code.co_names).union(*(c.co_names for c in code.co_consts if isinstance(c, types.CodeType)))
        for n in list(out):
            callee = vars(fe).get(n)
            if hasattr(callee, "py_func") and callee.py_func.__module__ == fe.__name__ and n not in seen:
                seen.add(n)
                out |= names(callee, seen)
        return out

    for typ, fn in functions.items():
        read = {n for n in names(fn, set()) if n[:3] in ("FF_", "FI_")}
        assert read and read <= set(lay.FORCE_RECORDS[typ]), (fn.py_func.__name__, read - set(lay.FORCE_RECORDS[typ]))
