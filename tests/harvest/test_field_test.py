"""One virtual field test (berryshaker.harvest.virtual.field_test) against closed forms and its own Monte Carlo, and
the seed streams of a start (berryshaker.harvest.virtual.seeds).  The stem-load tables here are made by hand (no
engine run): a table constant over position and mass is a load every fruit sees alike, for which the expectation has
a closed form.
"""

import math

import numpy as np
import pytest
from scipy import stats

from berryshaker.config import reference_machine
from berryshaker.harvest.virtual import (
    RESPONSES,
    HarvestParameters,
    Tally,
    bushes_per_test,
    expectation,
    expected_tally,
    field_tally,
    load_grid,
    response_values,
)
from berryshaker.harvest.virtual.field_test import MASS_NODES, Z_NODES, _mean_square_fraction, covered_fractions
from berryshaker.harvest.virtual.seeds import FIELD, MACHINE, seed_sequence, stream
from berryshaker.harvest.virtual.stem_force_tables import MASS_FACTORS, Z_GRID


@pytest.fixture(scope="module")
def machine():
    return reference_machine()


def constant_table(ripe: float, unripe: float, force: float = 0.2) -> np.ndarray:
    """A stem-load table (Z_GRID x MASS_FACTORS x channels) with one peak load ratio everywhere."""
    t = np.empty((Z_GRID.size, MASS_FACTORS.size, 3))
    t[..., 0], t[..., 1], t[..., 2] = force, ripe, unripe
    return t


def shaped_table(scale: float = 1.0) -> np.ndarray:
    """A table that grows along the branch and with the fruit mass, as a drive-past's does."""
    z, m = np.meshgrid(Z_GRID, MASS_FACTORS, indexing="ij")
    ripe = scale * (0.3 + 1.4 * z**1.5) * m**0.6
    return np.stack([0.2 * ripe, ripe, 0.25 * ripe], axis=-1)


def test_a_field_test_passes_the_bushes_its_duration_covers(machine):
    """10 s at 30 m/min over 1.5 m spacing: 3.33 bushes; the covered fractions sum to that whatever the start
    offset, and E[sum f^2] over a uniform offset is (n - 1) + 2/3 for a whole number n of spacings (the two end bushes
    share one, u and 1 - u: E[u^2 + (1 - u)^2] = 2/3)."""
    assert bushes_per_test(machine) == pytest.approx(10 * 0.5 / 1.5)
    for u in (0.0, 0.3, 0.999):
        assert covered_fractions(3.3333, u).sum() == pytest.approx(3.3333)
    assert _mean_square_fraction(3.0) == pytest.approx(2 + 2 / 3, rel=1e-5)


def test_expectation_is_the_closed_form_for_a_uniform_load(machine):
    """Every fruit loaded to g: P(off) = P(s <= g), s lognormal with mean 1 and CV c, = Phi((ln g + sigma^2/2) /
    sigma); the test passes B bushes of yield Y: ripe mass B Y (1 - u), efficiency = picked / T."""
    h = machine.harvest
    g_r, g_u = 0.9, 0.5
    t = expected_tally(machine, load_grid(machine, [constant_table(g_r, g_u)] * 3))
    pr = stats.norm.cdf((math.log(g_r) + 0.5 * math.log1p(h.bond_cv**2)) / math.sqrt(math.log1p(h.bond_cv**2)))
    # unripe: green, pink, red by their shares of the unripe mass; stage k's pull P_g^(1-k/3) P_b^(k/3), its load
    # ratio g_u P_g / P_k, its CV linear between green's and blue's (docs/harvest.md, "Ripeness stages")
    pu = 0.0
    for k, c in enumerate(h.unripe_stage_mix):
        p_k = h.unripe_pull ** (1 - k / 3) * h.ripe_pull ** (k / 3)
        cv_k = h.unripe_bond_cv * (1 - k / 3) + h.bond_cv * k / 3
        s_k = math.sqrt(math.log1p(cv_k**2))
        pu += c * stats.norm.cdf((math.log(g_u * h.unripe_pull / p_k) + 0.5 * s_k**2) / s_k)
    b, y, uf = bushes_per_test(machine), h.yield_per_bush, h.unripe_fraction
    assert t.ripe == pytest.approx(b * y * (1 - uf), rel=1e-9)
    assert t.unripe == pytest.approx(b * y * uf, rel=1e-9)
    assert t.ripe_picked == pytest.approx(b * y * (1 - uf) * pr, rel=1e-9)
    assert t.unripe_picked == pytest.approx(b * y * uf * pu, rel=1e-9)
    r = response_values(t)
    assert r["efficiency"] == pytest.approx(60 * b * y * ((1 - uf) * pr + uf * pu) / 10.0, rel=1e-9)
    assert r["ripe_removal"] == pytest.approx(100 * pr, rel=1e-9)


def test_quadrature_nodes_are_converged(machine):
    """The default nodes per table cell (Z_NODES, MASS_NODES) give every response within 1e-4 of twice as many, on
    a table shaped like a drive-past's; one node per cell does not (it misses by about 1 %)."""
    env = [shaped_table(s) for s in (0.85, 1.0, 1.15)]
    ref = response_values(expected_tally(machine, load_grid(machine, env, 2 * Z_NODES, 2 * MASS_NODES)))
    got = response_values(expected_tally(machine, load_grid(machine, env)))
    coarse = response_values(expected_tally(machine, load_grid(machine, env, 1, 1)))
    for n in RESPONSES:
        assert got[n] == pytest.approx(ref[n], rel=1e-4), n
    assert max(abs(coarse[n] / ref[n] - 1) for n in RESPONSES) > 1e-3


def test_counting_noise_matches_the_counted_field_tests(machine):
    """The delta-method variance of one field test about the expectation (expectation) against 1000 field tests
    counted fruit by fruit at the same tables: mean within 4 standard errors of the expectation, SD within 10 %
    (the SD of 1000 draws is known to about 2 %, a ratio estimator's first-order variance to a few % more)."""
    env = [shaped_table(s) for s in (0.85, 1.0, 1.15)]
    grid = load_grid(machine, env)
    e = response_values(expected_tally(machine, grid))
    v = expectation(machine, grid)[1]
    draws = [response_values(field_tally(machine, env, k)) for k in range(1000)]
    for n in RESPONSES:
        x = np.array([d[n] for d in draws])
        x = x[np.isfinite(x)]
        sd = math.sqrt(v[n])
        assert abs(x.mean() - e[n]) <= 4 * x.std(ddof=1) / math.sqrt(x.size), n
        assert x.std(ddof=1) == pytest.approx(sd, rel=0.10), n


def test_a_rate_is_a_count_and_scatters_less_with_more_fruit(machine):
    """Damage and unripe rates are counts of fruit: their counting SD falls as 1/sqrt(yield) (twice the fruit, a
    factor sqrt 2 less), while the efficiency's grows with the yield (bush-to-bush scatter)."""
    grid = load_grid(machine, [shaped_table()] * 3)
    p1 = HarvestParameters.described(machine)
    from dataclasses import replace

    p2 = replace(p1, yield_per_bush=2 * p1.yield_per_bush)
    v1, v2 = expectation(machine, grid, p1)[1], expectation(machine, grid, p2)[1]
    assert math.sqrt(v1["damage"] / v2["damage"]) == pytest.approx(math.sqrt(2), rel=1e-6)
    assert v2["efficiency"] > v1["efficiency"]


def test_parameter_rows_broadcast_over_the_nodes(machine):
    """Parameter arrays of shape (n, 1) give n tallies, each the scalar one."""
    grid = load_grid(machine, [shaped_table()] * 3)
    p = HarvestParameters.described(machine)
    rows = HarvestParameters(ripe_pull=np.array([[0.4], [0.6]]), unripe_pull=np.full((2, 1), p.unripe_pull),
                             bond_cv=np.full((2, 1), p.bond_cv), unripe_fraction=np.array([[0.1], [0.2]]),
                             yield_per_bush=np.array([[0.5], [1.0]]), bruise_height=np.full((2, 1), p.bruise_height))
    both = expected_tally(machine, grid, rows)
    from dataclasses import replace

    one = expected_tally(machine, grid, replace(p, ripe_pull=0.6, unripe_fraction=0.2, yield_per_bush=1.0))
    assert float(both.ripe_picked[1]) == pytest.approx(one.ripe_picked, rel=1e-12)
    assert expectation(machine, grid, rows)[1]["damage"].shape == (2,)


def test_responses_of_a_tally():
    """The table's responses from a tally by hand: 2 kg picked in 60 s is 2 kg/min, 0.5 kg unripe of it 25 %."""
    t = Tally(ripe=10.0, unripe=1.0, ripe_picked=1.5, unripe_picked=0.5, damaged=0.2, duration=60.0)
    r = response_values(t)
    assert r == pytest.approx({"efficiency": 2.0, "ripe_removal": 15.0, "unripe": 25.0, "unripe_shed": 50.0,
                               "damage": 10.0})
    nothing = response_values(Tally(1.0, 1.0, 0.0, 0.0, 0.0, 60.0))
    assert math.isnan(nothing["damage"]) and nothing["efficiency"] == 0.0


def test_the_streams_of_a_start_are_independent_and_reproducible():
    """Every kind of draw of a start has its own stream: the machine start of class 0 is not the field test's (the
    earlier scheme's seed s and (s, 0) gave numpy the same entropy, so class 0's start was drawn from its bushes'
    stream), starts differ, families differ, and the same key gives the same numbers."""
    assert not np.array_equal(np.random.default_rng(2024).random(4), np.random.default_rng((2024, 1)).random(4))
    assert np.array_equal(np.random.default_rng(2024).random(4), np.random.default_rng((2024, 0)).random(4))  # why
    a = stream(2024, 0, MACHINE, 0).random(8)
    assert np.array_equal(a, stream(2024, 0, MACHINE, 0).random(8))
    others = [stream(2024, 0, FIELD).random(8), stream(2024, 1, MACHINE, 0).random(8),
              stream(2025, 0, MACHINE, 0).random(8), stream(2024, 0, MACHINE, 1).random(8),
              np.random.default_rng(2024).random(8)]
    assert all(not np.array_equal(a, o) for o in others)
    assert seed_sequence(7, [3, MACHINE, 2]).spawn_key == (3, MACHINE, 2)


class _HarmonicBranch:
    """A branch motion (the interface of berryshaker.harvest.coupled_branch.BranchMotion that stem_force_table
    reads): at rest for 0.1 s, then 9 and 23 Hz harmonics whose amplitude grows along the branch."""

    def __init__(self, length: float):
        self.t = np.arange(6000) * 1e-4
        self.length = length

    def lateral(self, z, acceleration=True):
        tau = np.maximum(self.t - 0.1, 0.0)
        amp = (4e-3 + 8e-3 * np.asarray(z)[:, None] / self.length)
        w1, w2 = 2 * math.pi * 9.0, 2 * math.pi * 23.0
        y = amp * (np.sin(w1 * tau) + 0.5 * np.sin(w2 * tau))
        v = amp * (w1 * np.cos(w1 * tau) + 0.5 * w2 * np.cos(w2 * tau)) * (tau > 0)
        return y, v, None

    def axial(self, z):
        y, v, _ = self.lateral(z)
        return 0.2 * y, 0.2 * v

    def every(self, n):
        coarse = _HarmonicBranch(self.length)
        coarse.t = self.t[::n]
        return coarse


def test_a_table_read_at_another_pedicel_stiffness_is_the_table_of_that_pedicel(machine):
    """``pedicel_stiffness`` (calibrate's prior): a table is read at stiffness a k as a times the table at mass m / a
    (berryshaker.harvest.virtual.stem_force_tables).  Where m / a falls on a column of the mass axis the reading is the
    table recomputed on the same branch motion with the pedicel (a k, a c), to round-off; at the quadrature's nodes the
    responses of one start agree with those of the recomputed table within the mass axis's interpolation (measured
    on a drive-past: 0.1-2.5 % against a 129-column axis, as at the described stiffness); the node reading of the
    expectation is the fruit-by-fruit reading of the field test's; a scale outside the table names the field."""
    from dataclasses import replace

    from berryshaker.config import machine_from_dict
    from berryshaker.errors import ConfigError
    from berryshaker.harvest.virtual import bond_strengths, fruit_load_channels, stem_force_table

    motion = _HarmonicBranch(machine.plant.branch.length)
    table = stem_force_table(machine, motion)
    step = math.log(MASS_FACTORS[1] / MASS_FACTORS[0])
    a = math.exp(2 * step)  # m / a two columns down the mass axis
    d = machine.model_dump()
    d["plant"]["fruit"]["pedicel"].update(stiffness=a * 10.0, damping=a * 0.027)
    stiff = machine_from_dict(d)
    recomputed = stem_force_table(stiff, motion)
    m0, st = machine.plant.fruit.mass, bond_strengths(machine)
    z = np.array([0.3, 0.6, 0.9])
    for j in (MASS_FACTORS.size // 4, MASS_FACTORS.size // 2, 3 * MASS_FACTORS.size // 4):
        mass = np.full(3, MASS_FACTORS[j] * m0)
        for ripe in (True, False):
            got = fruit_load_channels(table, z, mass, m0, ripe, st, stiffness_scale=a)
            ref = fruit_load_channels(recomputed, z, mass, m0, ripe, st)
            assert got == pytest.approx(ref, rel=1e-9)
    p = replace(HarvestParameters.described(machine), pedicel_stiffness=a * 10.0)
    grid = load_grid(machine, [table] * 3)
    at_a = response_values(expected_tally(machine, grid, p))
    ref = response_values(expected_tally(stiff, load_grid(stiff, [recomputed] * 3)))
    for n in ("efficiency", "ripe_removal", "unripe", "damage"):
        assert at_a[n] == pytest.approx(ref[n], rel=0.03), n
    assert at_a["efficiency"] != pytest.approx(response_values(expected_tally(machine, grid))["efficiency"], rel=1e-3)
    cr, _ = grid.loads(machine.harvest.miner_exponent, a)
    by_fruit = fruit_load_channels(table, grid.z[:40], grid.mass[:40], m0, True, st, stiffness_scale=a)
    from berryshaker.plant.pedicel import miner_load

    assert cr[:40] == pytest.approx(miner_load(by_fruit, machine.harvest.miner_exponent), rel=1e-12)
    with pytest.raises(ConfigError, match="pedicel_stiffness"):
        expected_tally(machine, grid, replace(p, pedicel_stiffness=40.0))


def test_table_reading_is_numpy_interp_along_the_branch_bit_for_bit():
    """The tables are read in one gather for every fruit and channel; along the branch it is numpy.interp's own
    arithmetic (ends held, a node's value on the node), then linear in log mass, so every number is unchanged."""
    from berryshaker.harvest.virtual import stem_force_tables as T

    rng = np.random.default_rng(1)
    table = rng.random((T.Z_GRID.size, T.MASS_FACTORS.size, 4)) * 3
    z = np.concatenate([rng.random(3000), T.Z_GRID, [1.0 - 1e-17]])
    mass = rng.lognormal(np.log(1.8e-3), 0.8, z.size)  # some beyond the mass axis's ends
    j, w = T.mass_weights(mass / 1.8e-3)
    got = T._interp_table(table, z, mass, 1.8e-3)
    for c in range(table.shape[-1]):
        cols = np.array([np.interp(z, T.Z_GRID, table[:, k, c]) for k in range(T.MASS_FACTORS.size)])
        want = (1 - w) * cols[j, np.arange(z.size)] + w * cols[j + 1, np.arange(z.size)]
        assert got[:, c].tobytes() == want.tobytes()
        assert T.along_branch(table, z)[..., c].tobytes() == cols.T.tobytes()
