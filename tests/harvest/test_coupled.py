"""Coupled drive-past with fruit on stems: convergence with the number of branch modes (the issue
"A fruit force that converges"), two-way against one-way coupling for a light fruit, and the
virtual-harvest helpers built on the stem force."""

import numpy as np
import pytest

from berryshaker.config import machine_from_dict

#: plant lines proposed for the reference TOML (docs/plant.md); a no-op once the TOML carries them
PROPOSED_PLANT = {"contact": {"stiffness": None, "exponent": None}, "branch": {"elastic_modulus": 0.83e9}}


def proposed(machine, **fruit):
    d = machine.model_dump()
    for section, values in PROPOSED_PLANT.items():
        d["plant"][section].update(values)
    d["plant"]["fruit"].update(fruit)
    return machine_from_dict(d)


@pytest.fixture(scope="module")
def convergence(machine):
    """The reference machine as described (the bush as the combs' load): replicate means over the calibration's
    perturbed starts (harvest.replicates, same seeds for every mode count), every mode count a probe of the same
    run, so the rows differ by their modal truncation only (docs/plant.md, "Convergence with modes")."""
    from berryshaker.harvest.convergence import fruit_force_convergence

    assert machine.combs.load_model == "branches"
    return fruit_force_convergence(machine, modes=(4, 8, 16, 32))


def test_stem_force_converges_with_branch_modes(convergence):
    """16 vs 32 modes within 3 % of the replicate mean at root, middle and end, beyond the noise of the
    difference (measured: < 0.1 %, its SE < 0.05 %), and the default of 8 modes is the smallest count from
    which on every count is converged; 4 modes is not (middle -5 %, end -2 to -22 % per replicate)."""
    from berryshaker.harvest.convergence import smallest_converged_modes
    from berryshaker.plant.spec import CombContactSpec

    assert convergence["load_model"] == "branches" and convergence["replicates"] >= 3
    by_n = {r["n_modes"]: r for r in convergence["rows"]}
    for name in ("root", "middle", "end"):
        assert by_n[16][f"{name}_stem_N"] == pytest.approx(by_n[32][f"{name}_stem_N"], rel=0.03)
        assert by_n[16][f"{name}_verdict"] == "converged"
        # the replicate mean carries the spread of the starts (the drive phase at the bush's arrival): its SE
        # is far above the truncation error, which is why the difference is judged against its own noise
        assert by_n[16][f"{name}_stem_se_N"] > 0
    assert by_n[4]["verdict"] != "converged"
    assert smallest_converged_modes(convergence) == CombContactSpec().n_modes == 8


def test_the_rigid_fruit_force_does_not_converge(convergence):
    """The study's eq. 16 (m0 x branch acceleration) keeps changing with modes: the direct response to
    the finger impulses (docs/plant.md).  This is what the stem model fixes."""
    by_n = {r["n_modes"]: r for r in convergence["rows"]}
    assert abs(by_n[16]["end_rigid_N"] / by_n[32]["end_rigid_N"] - 1) > 0.2


def test_two_way_equals_one_way_for_a_light_fruit(machine):
    """A fruit 100 times lighter (same stem frequency and damping ratio) hardly loads the branch: the
    fruit-branch modes (two-way) and the base-excited post-processing (one-way) give the same peak stem
    force to a few percent, with the bush as the load.  Both fruit models are probes of the same run, so they
    see the same comb motion (as two separate runs the clearance chain's sensitivity to the step sequence
    alone moved the peaks by several per cent); a probe identical to the run's own branch gives identical
    forces.  What is left is the two-way model's damping approximation (plant.pedicel.fruit_branch_modes:
    off-diagonal modal damping dropped), which depends on the comb motion, the same under either load --
    measured (docs/plant.md), two-way / one-way - 1 at root / middle / end: this run -5.4 / -2.8 / -0.3 %,
    the three replicate starts up to 6.5 % (aggregate load: up to 6.7 %), their means -0.3 / -1.7 / +3.1 %;
    hence 7 % on one run (a replicate mean costs 40 s here: one start takes 1e6 steps)."""
    from berryshaker.harvest.coupled import simulate_fruit_force

    ped = {"stiffness": 0.1, "damping": 2.7e-4, "include_weight": False}
    two, one = (proposed(machine, mass=1.8e-5, pedicel=dict(ped, coupling=c)) for c in ("two_way", "one_way"))
    assert two.combs.load_model == "branches"
    r = simulate_fruit_force(two, probes=(one, two))
    peaks = [{n: float(np.max(np.abs(v))) for n, v in res.stem_lateral.items()} for res in (r, *r.probes)]
    assert peaks[2] == peaks[0]
    for name in ("root", "middle", "end"):
        assert peaks[0][name] == pytest.approx(peaks[1][name], rel=0.07), name


def test_fruit_peak_force_from_envelopes():
    from berryshaker.harvest.virtual import MASS_FACTORS, Z_GRID, fruit_peak_force

    m0 = 1.8e-3
    acc = np.linspace(10, 100, len(Z_GRID))
    z = np.array([0.0, 0.5, 1.0])
    mass = np.array([m0, 2 * m0, 0.5 * m0])
    np.testing.assert_allclose(fruit_peak_force(acc, z, mass, m0), mass * np.interp(z, Z_GRID, acc))
    col = np.linspace(0.1, 0.4, len(Z_GRID))
    table = np.outer(col, 2 + np.log(MASS_FACTORS))  # linear in log mass: interpolated exactly
    np.testing.assert_allclose(fruit_peak_force(table, z, mass, m0), np.interp(z, Z_GRID, col) * (2 + np.log(mass / m0)))


def test_removal_at_speed_refuses_bad_input(machine):
    from berryshaker.errors import ConfigError
    from berryshaker.harvest.virtual import removal_at_speed

    with pytest.raises(ConfigError, match="cam speed must be > 0"):
        removal_at_speed(machine.model_dump(mode="json"), -10.0)


def test_convergence_command_refuses_bad_mode_counts():
    from typer.testing import CliRunner

    from berryshaker.cli import app

    res = CliRunner().invoke(app, ["plant", "--convergence", "--convergence-modes", "8"])
    assert res.exit_code == 2 and "two or more mode counts" in res.output
    res = CliRunner().invoke(app, ["plant", "--convergence", "--convergence-modes", "8,x"])
    assert res.exit_code == 2 and "whole numbers" in res.output


def test_axial_foreshortening_is_the_double_sum_over_mode_pairs(machine):
    """BranchMotion.axial sums the mode pairs i <= j of the symmetric G (half the products): it must equal
    u = -1/2 eta^T G(z) eta and u' = -eta^T G(z) eta' summed over every pair, G from its definition
    G_ij(z) = int_0^z phi_i' phi_j' ds."""
    from scipy import integrate

    from berryshaker.harvest.coupled_branch import BranchMotion, plant_modes

    modes, _ = plant_modes(machine)
    nm = len(modes.omega)
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 0.1, 501)
    eta, etad = rng.normal(size=(len(t), nm)) * 1e-3, rng.normal(size=(len(t), nm)) * 1e-2
    motion = BranchMotion(t, modes, eta, etad, np.zeros_like(eta), {})
    z = np.array([0.0, 0.13, 0.5, 0.77, 1.0]) * modes.branch.length
    slope = np.array([np.gradient(s, modes.z) for s in modes.shapes])
    g = np.empty((nm, nm, len(z)))
    for i in range(nm):
        for j in range(nm):
            g[i, j] = np.interp(z, modes.z, integrate.cumulative_trapezoid(slope[i] * slope[j], modes.z, initial=0.0))
    u, v = motion.axial(z)
    u_ref = -0.5 * np.einsum("ti,ijz,tj->zt", eta, g, eta)
    v_ref = -np.einsum("ti,ijz,tj->zt", eta, g, etad)
    assert np.allclose(u, u_ref, rtol=1e-12, atol=1e-12 * np.abs(u_ref).max())
    assert np.allclose(v, v_ref, rtol=1e-12, atol=1e-12 * np.abs(v_ref).max())


@pytest.mark.parametrize("n_t, n_z", [(3 * 64 + 1, 41), (3 * 64 + 1, 1), (2 * 64 + 30, 5), (1, 3)])
def test_axial_blocks_give_the_unblocked_numbers_bit_for_bit(machine, monkeypatch, n_t, n_z):
    """BranchMotion.axial works in blocks of AXIAL_BLOCK samples (cache-sized pair products): every sample must
    come out bit for bit as from one product over the whole series, also with a tail of one sample (kept in the
    last block: alone it would be a matrix-vector product, summed in another order) and for one position."""
    from berryshaker.harvest import coupled_branch
    from berryshaker.harvest.coupled_branch import BranchMotion, plant_modes

    modes, _ = plant_modes(machine)
    nm = len(modes.omega)
    rng = np.random.default_rng(5)
    eta, etad = rng.normal(size=(n_t, nm)) * 1e-3, rng.normal(size=(n_t, nm)) * 1e-2
    z = np.linspace(0.05, 1.0, n_z) * modes.branch.length
    motion = BranchMotion(np.arange(n_t) * 1e-4, modes, eta, etad, np.zeros_like(eta), {})
    monkeypatch.setattr(coupled_branch, "AXIAL_BLOCK", 64)
    u, v = motion.axial(z)
    monkeypatch.setattr(coupled_branch, "AXIAL_BLOCK", 10**9)
    u1, v1 = motion.axial(z)
    assert np.array_equal(u, u1) and np.array_equal(v, v1)
