"""Clearance-pair contact from geometry and materials (docs/contact.md sec. 6-7): resolution, the legacy springs,
what both drive models run with, rtol convergence with steel contact, and the honest run-summary keys."""

import inspect
import math

import numpy as np
import pytest

from berryshaker.config import load_machine, pair_contact_rows, reference_machine
from berryshaker.contact.conformal import hysteresis_factor, line_contact_approach
from berryshaker.contact.pair_law import FIT_FORCE_RANGE, pair_geometry, resolve_pair_contact
from berryshaker.contact.pin_in_bore import pin_in_bore_law
from berryshaker.drives.groove_cam.mlsd import simulate_mlsd
from berryshaker.drives.simulation import simulate_multibody
from berryshaker.errors import ConfigError

ZERO = dict(A=0.0, B=0.0, C=0.0, F=0.0)


def test_reference_pairs_get_steel_line_contact(machine):
    """Every pair of both reference machines resolves to Johnson's line-contact law of its geometry: the fitted
    K delta^n reproduces Johnson's delta(F) within the reported fit error, and the equivalent linear stiffness
    at 1 kN is that of steel (about 1e9 N/m for the pins, 4-5e8 N/m for the rollers; docs/contact.md sec. 5)."""
    for m in (machine, reference_machine("crank_rocker")):
        for p in m.pair_names:
            c = m.pair_contact(p)
            assert c.law == "lankarani_nikravesh" and c.tags["stiffness"] == "derived"
            g = c.geometry
            assert 1.05 < c.exponent < 1.25
            f = np.geomspace(*c.fit_force_range, 50)
            from berryshaker.contact.pair_law import _materials
            from berryshaker.contact.stiffness import effective_modulus

            (e1, n1), (e2, n2) = _materials(g)
            dr = g.size if g.kind == "pin-in-bore" else (g.diameter if math.isinf(g.wall_radius)
                                                          else g.diameter / 2 + g.wall_radius)
            d = line_contact_approach(f, g.length, dr, effective_modulus(e1, n1, e2, n2))
            err = np.max(np.abs(c.stiffness * d**c.exponent - f) / f)
            assert err == pytest.approx(c.fit_error, rel=0.05)
            assert err < 0.1
            lo, hi = (8e8, 1.3e9) if g.kind == "pin-in-bore" else (3.5e8, 5.5e8)
            assert lo < c.secant_stiffness < hi, (p, c.secant_stiffness)


def test_pin_law_is_the_conformal_module_law():
    """The pair resolution hands the engine exactly pin_in_bore.pin_in_bore_law's fit (no second formula)."""
    g = pair_geometry("pin-in-bore", 0.15e-3, 0.020, 0.025, "steel-on-bronze-greased")
    c = resolve_pair_contact("lankarani_nikravesh", g)
    ref = pin_in_bore_law(0.010, 0.15e-3, 0.025, "steel", "bronze", FIT_FORCE_RANGE)
    assert c.stiffness == pytest.approx(ref.fit.stiffness, rel=1e-12)
    assert c.exponent == pytest.approx(ref.fit.exponent, rel=1e-12)
    # the linear law by name gets the secant stiffness at the operating load
    lin = resolve_pair_contact("mlsd", g, damping=2000.0)
    assert lin.exponent == 1.0 and lin.stiffness == pytest.approx(float(ref.secant_stiffness(1e3)), rel=1e-9)


def test_old_files_keep_their_linear_springs():
    """A 0.1.0 description gives K_i and C_i and no law: it keeps the IMPACT law with exponent 1."""
    m = load_machine("tests/data/machine_0_1_0_units.toml")
    for p, k in (("A", 1e8), ("B", 1e8), ("C", 5e7), ("F", 5e7)):
        c = m.pair_contact(p)
        assert (c.law, c.stiffness, c.exponent, c.damping, c.damping_depth) == ("impact", k, 1.0, 2000.0, 1e-5)


def test_missing_damping_and_lone_exponent_are_named():
    g = pair_geometry("pin-in-bore", 0.1e-3)
    with pytest.raises(ConfigError, match="clearance.C.damping"):
        resolve_pair_contact("impact", g, field_prefix="clearance.C")
    with pytest.raises(ConfigError, match="clearance.C.exponent is set but stiffness is not"):
        resolve_pair_contact("lankarani_nikravesh", g, exponent=1.5, field_prefix="clearance.C")
    with pytest.raises(ConfigError, match="polymer bush"):
        resolve_pair_contact("lankarani_nikravesh", pair_geometry("pin-in-bore", 0.1e-3, material_pair="steel-on-nylon-dry"))


def test_config_show_rows_state_law_stiffness_damping_and_ramp(machine):
    rows = {k: (v, t) for k, v, t in pair_contact_rows(machine)}
    v, tag = rows["(resolved) contact C stiffness"]
    assert tag == "derived" and "N/m^1.1" in v and "Johnson line contact" in v
    assert "hysteresis (lankarani_nikravesh), restitution e = 0.9" in rows["(resolved) contact C damping"][0]
    assert f"{float(hysteresis_factor(0.9, 'lankarani_nikravesh')):.4g}" in rows["(resolved) contact C damping"][0]
    assert rows["(resolved) contact C damping ramp"][0].startswith("none")
    old = {k: v for k, v, _ in pair_contact_rows(load_machine("tests/data/machine_0_1_0_units.toml"))}
    assert old["(resolved) contact A damping ramp"] == "full damping at 0.01 mm"


def test_both_models_run_the_same_resolved_law(machine):
    """The MLSD links and the multibody clearance joints get the same K, n and hysteresis factor."""
    from berryshaker.drives.groove_cam.mechanism import harvester_mechanism
    from berryshaker.drives.groove_cam.mlsd import N_PAIR, P_PAIR0, PAIR_NAMES, parameter_vector

    p = parameter_vector(machine)
    spec = harvester_mechanism(machine)
    joints = {j.name: j for j in spec.joints}
    for k, name in enumerate(PAIR_NAMES):
        b = P_PAIR0 + N_PAIR * k
        c = joints[name].contact
        assert (p[b + 1], p[b + 3]) == (c.stiffness, c.exponent)
        assert p[b + 5] == pytest.approx(float(hysteresis_factor(c.restitution, c.law)))


def test_steel_contact_converges_in_rtol(machine):
    """Default accuracy with steel contact on the first impact of every joint, which is deterministic: at the
    default rtol (1e-5) within 2 % of rtol 1e-7, at 1e-6 within 0.5 %.  The statistics over many impacts are
    chaotic and are checked over ensembles of perturbed starts in tests/multibody/test_perturbation.py, which
    chooses the default (a single run's RMS and peak move by +-4 % and +-8 % with any change of the tolerance)."""
    default = inspect.signature(simulate_multibody).parameters["rtol"].default
    assert default == 1e-5
    runs = {rt: simulate_multibody(machine, revolutions=2, rtol=rt) for rt in (1e-5, 1e-6, 1e-7)}
    for p in machine.pair_names:
        k = runs[1e-6][0].compiled.frc_names.index(p)
        first = {rt: r.first[k, 2] for rt, (r, _) in runs.items()}
        assert first[1e-6] == pytest.approx(first[1e-7], rel=5e-3), (p, first)
        assert first[1e-5] == pytest.approx(first[1e-7], rel=2e-2), (p, first)


def test_onsets_count_impacts_not_refinements(machine):
    """contact_onsets counts separated -> in-contact transitions; on the MLSD's written series it misses at most
    a few of the transitions seen on every integrator step.  The multibody engine counts its impacts (onsets
    closing at >= 1 mm/s) in the integrator, fewer than its step cut-backs."""
    r = simulate_mlsd(machine, revolutions=3)
    s = r.summary()
    for p in "ABCF":
        every, series = s["contact_onsets_every_step"][p], s["contact_onsets"][p]
        assert 0 < series <= every and series >= 0.85 * every, (p, series, every)
    _, mb = simulate_multibody(machine, revolutions=3)
    assert mb["contact_onsets_located"] == sum(mb["contact_onsets"].values())
    assert 0 < mb["contact_onsets_located"] < mb["event_cuts"]
    # the two models see the same number of impacts within a factor 1.5 at the pins A, B; the chattering
    # rollers C, F re-impact chaotically, and their counts move with the tolerance (multibody impacts of one
    # start, A / B / C / F: 41 / 43 / 140 / 120 at rtol 1e-5, 53 / 62 / 182 / 141 at 1e-7; MLSD's series
    # 44 / 47 / 125 / 117): within a factor 2
    for p, factor in (("A", 1.5), ("B", 1.5), ("C", 2.0), ("F", 2.0)):
        a, b = mb["contact_onsets"][p], s["contact_onsets"][p]
        assert max(a, b) / min(a, b) < factor, (p, a, b)


def test_drive_moment_mean_means_the_same_in_both_models(machine):
    """drive_moment_Nm.mean: signed, direction of rotation, revolutions 2..N, in both summaries: at zero clearance
    (ideal mechanism) they agree to 0.1 %, and mean * speed is the MLSD's mean drive power."""
    s = simulate_mlsd(machine, ZERO, revolutions=3).summary()
    _, mb = simulate_multibody(machine, ZERO, revolutions=3)
    assert s["drive_moment_Nm"]["mean"] == pytest.approx(mb["drive_moment_Nm"]["mean"], rel=1e-3)
    assert s["drive_moment_Nm"]["mean"] * machine.cam.speed == pytest.approx(s["drive_moment_Nm"]["mean_power_W"])
    assert s["drive_moment_Nm"]["mean"] > 0
