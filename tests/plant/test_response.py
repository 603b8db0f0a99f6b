"""Branch model (eq. 13-17): analytic modes against classical limits and FE, Duhamel response, fruit force,
harvest condition, and the coupled drive-past run."""

import math

import numpy as np
import pytest
from scipy import integrate

from berryshaker.config import machine_from_dict
from berryshaker.errors import ConfigError
from berryshaker.plant.branch import Branch, taper_coefficient
from berryshaker.plant.modes import analytic_modes, fe_modes
from berryshaker.plant.response import deflection, fruit_force, harvest_verdict, modal_response

REF = Branch(0.012, 0.004, 1.2, 1.1e9, 850.0, 0.07)


def _lambda(branch, omega):
    """beta_i l referred to the root section: omega = (beta l)^2 sqrt(E I0 / (rho A0 l^4))."""
    s = math.sqrt(branch.elastic_modulus * branch.second_moment(0) / (branch.density * branch.area(0) * branch.length**4))
    return np.sqrt(np.asarray(omega) / s)


def test_taper_coefficient_eq13():
    assert taper_coefficient(0.012, 0.004) == pytest.approx(2 / 3)


def test_nearly_uniform_branch_gives_the_uniform_cantilever():
    """beta l = 1.8751, 4.6941, 7.8548 (uniform clamped-free beam; e.g. Blevins, Formulas for Natural
    Frequency and Mode Shape, 1979, Table 8-1)."""
    b = Branch(0.012, 0.012 * (1 - 1e-5), 1.2, 1.1e9, 850.0)
    lam = _lambda(b, analytic_modes(b, 3).omega)
    np.testing.assert_allclose(lam, [1.87510, 4.69409, 7.85476], rtol=2e-5)


def test_cone_limit_matches_the_classical_cone():
    """A branch tapering almost to a point tends to the cantilevered cone, omega l^2 sqrt(rho A0/E I0) =
    8.719, 21.15, 38.45 (Kirchhoff 1879; Conway, Becker & Dubil, J. Appl. Mech. 31 (1964) 329-331)."""
    b = Branch(0.012, 0.012 * 1e-4, 1.2, 1.1e9, 850.0)
    lam2 = _lambda(b, analytic_modes(b, 3).omega) ** 2
    np.testing.assert_allclose(lam2, [8.719, 21.15, 38.45], rtol=1.5e-3)


@pytest.mark.parametrize("tip", [0.004, 0.006, 0.0011])
def test_analytic_and_finite_element_modes_agree(tip):
    b = Branch(0.012, tip, 1.2, 1.1e9, 850.0)
    a, f = analytic_modes(b, 4), fe_modes(b, 4)
    np.testing.assert_allclose(f.omega, a.omega, rtol=1e-3)  # issue target 0.1 %; reached: ~1e-6
    np.testing.assert_allclose(f.omega, a.omega, rtol=2e-5)
    for i in range(4):
        np.testing.assert_allclose(f.shapes[i], a.shapes[i], atol=1e-4 * np.abs(a.shapes[i]).max())


def test_reference_branch_first_mode_near_the_drive_frequency():
    # docs/study.md sec. 6: the reference plant is chosen so that the first mode is about 2 Hz
    assert analytic_modes(REF, 1).frequency_hz[0] == pytest.approx(2.009, abs=2e-3)


def test_modes_are_orthonormal_with_respect_to_the_mass_distribution():
    m = analytic_modes(REF, 4)
    z = m.z
    gram = np.array([[integrate.simpson(REF.density * REF.area(z) * m.shapes[i] * m.shapes[j], x=z)
                      for j in range(4)] for i in range(4)])
    np.testing.assert_allclose(gram, np.eye(4), atol=1e-6)


def test_duhamel_step_response_settles_on_the_static_deflection():
    """Unit step force at the tip: the damped modal response ends on the static deflection computed
    independently by the unit-load method, w(z) = int_0^z (z - s)(z_F - s) / EI(s) ds."""
    m = analytic_modes(REF, 8)
    t = np.linspace(0, 25, 50001)
    q, qd, qdd = modal_response(m, t, np.ones_like(t), 1.2)
    zf = 1.2

    def static(z):
        return integrate.quad(lambda s: (z - s) * (zf - s) / (REF.elastic_modulus * REF.second_moment(s)),
                              0, min(z, zf), epsrel=1e-12)[0]

    w = deflection(m, q[:, -1:], [0.6, 1.2])[:, 0]
    np.testing.assert_allclose(w, [static(0.6), static(1.2)], rtol=2e-3)


def test_duhamel_matches_direct_integration_for_a_harmonic_load():
    m = analytic_modes(REF, 3)
    t = np.linspace(0, 3, 30001)
    f = 0.5 * np.sin(2 * np.pi * 2.2 * t)
    q, qd, qdd = modal_response(m, t, f, 0.84)
    phi = m.shape_at(0.84)
    w, xi = m.omega[0], REF.damping_ratio
    sol = integrate.solve_ivp(lambda tt, y: [y[1], phi[0] * 0.5 * np.sin(2 * np.pi * 2.2 * tt) - 2 * xi * w * y[1] - w * w * y[0]],
                              [0, 3], [0, 0], t_eval=t, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(q[0], sol.y[0], atol=1e-6 * np.abs(sol.y[0]).max())


def test_fruit_force_and_harvest_condition_hand_values():
    m = analytic_modes(REF, 2)
    qdd = np.zeros((2, 3))
    qdd[0] = [0.0, 1.0, -2.0]
    f = fruit_force(m, qdd, [1.02], 0.0018)
    assert f[0, 1] == pytest.approx(0.0018 * m.shape_at(1.02)[0])
    v = harvest_verdict(0.5)
    assert (v.ripe, v.unripe, v.meets_eq17) == ("picked", "kept", True)
    assert harvest_verdict(0.2).ripe == "left on the bush"
    assert harvest_verdict(0.28).ripe == "partly picked"
    assert harvest_verdict(1.5).unripe == "partly shed"
    assert harvest_verdict(4.0).unripe == "shed" and not harvest_verdict(4.0).meets_eq17


def test_bad_branches_are_refused(machine):
    with pytest.raises(ConfigError, match="tip diameter .* larger than the root"):
        Branch(0.004, 0.012, 1.2, 1.1e9, 850.0)
    with pytest.raises(ConfigError, match="length must be > 0"):
        Branch(0.012, 0.004, 0.0, 1.1e9, 850.0)
    with pytest.raises(ConfigError, match="elastic modulus must be > 0"):
        Branch(0.012, 0.004, 1.2, -1.0, 850.0)
    with pytest.raises(ConfigError, match="outside the branch"):
        analytic_modes(REF, 1).shape_at(1.5)
    d = machine.model_dump()
    d["plant"]["fruit"]["positions"] = [0.2, 1.3, 0.5]
    with pytest.raises(ConfigError, match="fruit position 1.3 is outside the branch"):
        machine_from_dict(d)
    d = machine.model_dump()
    d["plant"]["branch"]["tip_diameter"] = 0.02
    with pytest.raises(ConfigError, match="tip_diameter 20 mm is larger than root_diameter"):
        machine_from_dict(d)


#: plant lines proposed for the reference TOML (docs/plant.md): finger-derived contact, branch modulus
#: inside the cited range.  Once the TOML carries them, applying them is a no-op.
PROPOSED_PLANT = {"contact": {"stiffness": None, "exponent": None}, "branch": {"elastic_modulus": 0.83e9}}


def proposed_machine(machine):
    d = machine.model_dump()
    for section, values in PROPOSED_PLANT.items():
        d["plant"][section].update(values)
    return machine_from_dict(d)


@pytest.fixture(scope="module")
def drive_past(machine):
    from berryshaker.harvest.coupled import simulate_fruit_force

    return simulate_fruit_force(proposed_machine(machine))


def test_reference_fruit_force_rises_from_root_to_end(drive_past):
    """Study claim 5: fruit force rises from root to end.  With the fruit on compliant stems the study's
    ranges (0.25-0.4, 0.65-0.9, 0.8-1.2 N, eq. 16) are held out: reported beside ours, not fitted."""
    s = drive_past.summary()
    p = s["positions"]
    assert s["fruit_model"] == "pedicel" and s["pedicel"]["natural_frequency_hz"] == pytest.approx(11.86, abs=0.01)
    assert s["rises_root_to_end"]
    for name in ("root", "middle", "end"):
        assert p[name]["rigid_peak_force_N"] > 0
        assert p[name]["study_range_N"] == list(s["study_ranges_N"][name])
        assert "within_study_range" in p[name] and p[name]["eq17"]["ripe"]
    # the comb pushes the branch: the fruit follows, with deflection growing towards the tip
    d = drive_past.deflection
    assert np.abs(d["root"]).max() < np.abs(d["middle"]).max() < np.abs(d["end"]).max()
    # branch pushes back on the combs: contact forces exist on both sides
    assert s["contact"]["comb_left"]["impacts"] > 5 and s["contact"]["comb_right"]["impacts"] > 5


@pytest.mark.slow
def test_coupled_run_converges_with_step_tolerance(machine, drive_past):
    from berryshaker.harvest.coupled import simulate_fruit_force

    tight = simulate_fruit_force(proposed_machine(machine), rtol=1e-7).summary()["positions"]
    loose = drive_past.summary()["positions"]
    for name in ("root", "middle", "end"):
        # a peak over a chaotic 2 s response: agreement to 15 % between tolerances 1e-6 and 1e-7
        assert tight[name]["peak_force_N"] == pytest.approx(loose[name]["peak_force_N"], rel=0.15)
        assert tight[name]["rms_force_N"] == pytest.approx(loose[name]["rms_force_N"], rel=0.05)
