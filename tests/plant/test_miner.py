"""The cumulative (Miner-Basquin) detachment of berryshaker.plant.pedicel.miner: the count of load cycles, its
limits, its reading at any exponent, its independence of the sample rate, and removal that grows with shaking time."""

import math

import numpy as np
import pytest

from berryshaker.errors import ConfigError
from berryshaker.plant.pedicel import MINER_EXPONENTS, miner_equivalent, miner_load, peak_stem_loads, stem_response

M0, K, C = 1.8e-3, 10.0, 0.027
STRENGTHS = [(0.47, 0.23), (2.05, 1.0)]


def _strikes(duration, step, seed=1, rate=2.0, equal=False):
    """Branch motion at 3 places under finger strikes: every 1 / rate s a strike of random size (``equal``: all of
    one size) sets the branch ringing in two modes (6 and 35 Hz, decay times 0.2 and 0.05 s) from a velocity jump;
    displacement and velocity (m, m/s) in closed form."""
    t = np.arange(0.0, duration, step)
    rng = np.random.default_rng(seed)
    rows = []
    for scale in (0.5, 1.0, 1.4):
        y, v = np.zeros_like(t), np.zeros_like(t)
        for tk in np.arange(0.05, duration, 1.0 / rate):
            amp = scale * (6e-3 if equal else rng.uniform(3e-3, 8e-3))
            s_ = np.clip(t - tk, 0.0, None)
            on = t > tk
            for a_, f_, tau in ((amp, 6.0, 0.2), (0.1 * amp, 35.0, 0.05)):
                w_ = 2 * math.pi * f_
                e_ = np.exp(-s_ / tau)
                y += on * a_ * e_ * np.sin(w_ * s_)
                v += on * a_ * e_ * (w_ * np.cos(w_ * s_) - np.sin(w_ * s_) / tau)
        rows.append((y, v))
    y, v = np.array([r[0] for r in rows]), np.array([r[1] for r in rows])
    return t, (y, v), (0.2 * y[::-1], 0.2 * v[::-1])


def _series(t, lat, ax, mass, strength):
    """g(t) of one fruit from the second-order-section response (berryshaker.plant.pedicel.stem_response)."""
    _, f_lat = stem_response(t, *lat, mass=mass, stiffness=K, damping=C)
    _, f_ax = stem_response(t, *ax, mass=mass, stiffness=K, damping=C)
    return np.hypot(np.maximum(f_ax + mass * 9.80665, 0.0) / strength[0], f_lat / strength[1])[0]


def test_the_compiled_count_is_the_series_count_and_the_law_in_closed_form():
    """The stem-load tables' compiled pass counts the same cycles as miner_equivalent on the series (to round-off),
    and on a signal of N equal cycles of peak G, g_eq = N^(1/beta) G (eq. 1); a constant load is one cycle."""
    t, lat, ax = _strikes(1.0, 1e-4)
    masses = np.array([0.8, 1.5]) * M0
    table = peak_stem_loads(t, lat, ax, masses, K, C, True, STRENGTHS, MINER_EXPONENTS)
    assert table.shape == (3, 2, 1 + 2 * (1 + MINER_EXPONENTS.size))
    for j, m in enumerate(masses):
        for s, st in enumerate(STRENGTHS):
            ref = np.array([miner_equivalent(_series(t, (lat[0][i:i + 1], lat[1][i:i + 1]),
                                                     (ax[0][i:i + 1], ax[1][i:i + 1]), m, st)) for i in range(3)])
            got = np.concatenate([table[:, j, 1 + s:2 + s], table[:, j, 3 + s * 6:9 + s * 6]], axis=1)
            np.testing.assert_allclose(got, ref, rtol=1e-9)
    tt = np.linspace(0.0, 5.0, 20001)
    g = 0.7 * np.abs(np.sin(2 * math.pi * tt))  # 10 half-waves of peak 0.7: 10 reversals
    np.testing.assert_allclose(miner_equivalent(g, [3.0, 8.0, 30.0]), [0.7, 0.7 * 10 ** (1 / 3), 0.7 * 10 ** (1 / 8),
                                                                        0.7 * 10 ** (1 / 30)], rtol=1e-7)
    assert miner_equivalent(np.full(50, 0.3), [8.0]) == pytest.approx([0.3, 0.3])
    assert miner_equivalent(np.zeros(50), [8.0]) == pytest.approx([0.0, 0.0])


def test_the_peak_only_law_is_the_limit_of_large_exponents_and_nothing_overflows():
    """beta -> inf: g_eq -> max g (the peak-only law); the scaled sums hold beta = 30 ... 400 at loads 1e-6 ... 1e3."""
    t, lat, ax = _strikes(1.0, 1e-4)
    g = _series(t, (lat[0][2:], lat[1][2:]), (ax[0][2:], ax[1][2:]), M0, STRENGTHS[0])
    big = miner_equivalent(g, [50.0, 200.0, 400.0])
    assert big[1:] == pytest.approx(np.full(3, big[0]), rel=0.03)
    assert np.all(np.diff(big[1:]) < 0) and big[-1] / big[0] - 1 < 0.01
    for scale in (1e-6, 1e3):
        assert miner_equivalent(scale * g, [3.0, 30.0, 400.0]) == pytest.approx(scale * miner_equivalent(g, [3.0, 30.0,
                                                                                                              400.0]))
    ch = miner_equivalent(g)[:, None]
    assert miner_load(ch, math.inf) == pytest.approx(ch[0])
    assert miner_load(ch, 1e9) == pytest.approx(ch[0], rel=1e-6)
    with pytest.raises(ConfigError, match=">= 3"):
        miner_load(ch, 2.0)


def test_the_reading_between_exponents_is_a_monotone_cubic_in_one_over_beta():
    """The tables carry g_eq at MINER_EXPONENTS; an exponent between is read by PCHIP of ln g_eq in 1/beta.  Against a
    direct count at beta = 4 ... 50 on strike trains its worst error is the smallest of three readings (linear in
    1/beta, linear in ln beta): within 1 % at beta = 4 and 0.3 % from 6.5 up."""
    t, lat, ax = _strikes(2.0, 1e-4, seed=4)
    masses = np.array([0.6, 1.0, 1.8]) * M0
    table = peak_stem_loads(t, lat, ax, masses, K, C, True, STRENGTHS[:1], MINER_EXPONENTS)
    ch = np.concatenate([table[..., 1:2], table[..., 2:]], axis=-1).reshape(-1, 1 + MINER_EXPONENTS.size).T
    mid = np.array([4.0, 6.5, 10.0, 16.0, 25.0, 50.0])
    direct = peak_stem_loads(t, lat, ax, masses, K, C, True, STRENGTHS[:1], mid)[..., 2:].reshape(-1, mid.size).T
    nodes, logs = np.concatenate([[0.0], 1 / MINER_EXPONENTS[::-1]]), np.log(np.concatenate([ch[:1], ch[1:][::-1]]))
    lb, lf = np.log(MINER_EXPONENTS), np.log(ch[1:])
    worst = np.zeros(3)
    for k, beta in enumerate(mid):
        pchip = np.max(np.abs(miner_load(ch, beta) / direct[k] - 1))
        lin_inv = np.max(np.abs(np.exp([np.interp(1 / beta, nodes, c) for c in logs.T]) / direct[k] - 1))
        lin_log = (np.max(np.abs(np.exp([np.interp(math.log(beta), lb, c) for c in lf.T]) / direct[k] - 1))
                   if beta <= 30 else 0.0)  # ln beta has no node at the peak: judged on 3-30 only
        worst = np.maximum(worst, [pchip, lin_inv, lin_log])
        assert pchip < (0.01 if beta < 5 else 0.003), (beta, pchip)
    print("worst relative error: pchip in 1/beta, linear in 1/beta, linear in ln beta", worst)
    assert worst[0] < min(worst[1:]), worst


def test_the_count_does_not_depend_on_the_sample_rate():
    """A signal sampled at the tables' step (1e-4 s, ENVELOPE_OUTPUT_STEP) and at half of it gives the same g_eq at
    every exponent to within twice the peak's own sampling error (the count adds none: no cycle is gained or lost;
    measured 1.3e-4 for g_eq and 0.7e-4 for the peak on a coupled drive-past's table at 1e-4 against 5e-5 s)."""
    t, lat, ax = _strikes(1.0, 5e-5, seed=2)
    masses = np.array([0.7, 1.6]) * M0
    fine = peak_stem_loads(t, lat, ax, masses, K, C, True, STRENGTHS, MINER_EXPONENTS)
    sub = lambda p: tuple(x[:, ::2] for x in p)  # noqa: E731
    coarse = peak_stem_loads(t[::2], sub(lat), sub(ax), masses, K, C, True, STRENGTHS, MINER_EXPONENTS)
    err = np.abs(coarse / fine - 1)
    peak_err = np.max(err[..., 1:3])
    assert peak_err < 1e-3
    assert np.max(err[..., 3:]) <= 2 * peak_err + 1e-6, (np.max(err[..., 3:]), peak_err)


def test_removal_grows_with_shaking_time_for_a_finite_exponent_only():
    """Twice the shaking (a train of equal strikes, twice as long): the peak is the same, so the peak-only law removes
    no more fruit; with beta finite g_eq grows (about 2^(1/beta)) and so does the probability of detachment over
    the lognormal strengths (berryshaker.harvest.virtual.field_test)."""
    from berryshaker.harvest.virtual.field_test import _p_below

    t, lat, ax = _strikes(2.0, 1e-4, rate=2.0, equal=True)
    half = t.size // 2
    cut = lambda p: tuple(x[:, :half] for x in p)  # noqa: E731
    short = peak_stem_loads(t[:half], cut(lat), cut(ax), [M0], K, C, True, STRENGTHS[:1], MINER_EXPONENTS)
    full = peak_stem_loads(t, lat, ax, [M0], K, C, True, STRENGTHS[:1], MINER_EXPONENTS)
    ch = lambda tb: np.concatenate([tb[:, 0, 1:2], tb[:, 0, 2:]], axis=1).T  # noqa: E731
    for beta, grows in ((math.inf, False), (30.0, True), (8.0, True), (3.0, True)):
        gs, gf = miner_load(ch(short), beta), miner_load(ch(full), beta)
        ps, pf = _p_below(gs, 0.24), _p_below(gf, 0.24)
        if grows:
            assert np.all(gf / gs > 2 ** (0.8 / beta)) and np.all(pf > ps), (beta, gs, gf)
        else:  # the same peak, up to the pedicel's ringing left from the strike before (0.3 %)
            np.testing.assert_allclose(gf, gs, rtol=5e-3)
            np.testing.assert_allclose(pf, ps, atol=5e-3)


def test_the_miner_exponent_is_validated_with_a_clear_error():
    """harvest.miner_exponent below the tables' smallest exponent (3) or NaN is refused, naming the field and the
    range; a large value is the peak-only law."""
    from berryshaker.config import machine_from_dict, reference_machine

    d = reference_machine().model_dump(mode="json")
    assert reference_machine().harvest.miner_exponent == 8.0
    for bad in (2.0, float("nan")):
        d["harvest"]["miner_exponent"] = bad
        with pytest.raises(ConfigError, match="miner_exponent"):
            machine_from_dict(d)
    d["harvest"]["miner_exponent"] = 1e9
    assert machine_from_dict(d).harvest.miner_exponent == 1e9
    ch = np.array([[1.0], [1.6], [1.3], [1.1], [1.05], [1.02], [1.01]])
    assert miner_load(ch, 1e9) == pytest.approx([1.0], rel=1e-6)


def test_the_reading_at_one_exponent_is_scipys_pchip_bit_for_bit():
    """miner_load at one exponent evaluates only the cell the exponent falls in (its two nodes' derivatives), with
    scipy.interpolate.PchipInterpolator's arithmetic: every value equal to the full interpolator's, at the nodes
    (the exponents carried, the peak), between them and at the ends, for rising, flat and zero channels."""
    from scipy import interpolate

    from berryshaker.plant.pedicel import MINER_EXPONENTS, miner_load

    ex = np.asarray(MINER_EXPONENTS, float)
    nodes = np.concatenate([[0.0], 1.0 / ex[::-1]])
    rng = np.random.default_rng(7)
    for trial in range(60):
        n = int(rng.integers(1, 2000))
        ch = np.sort(rng.random((1 + ex.size, n)) * rng.uniform(0.1, 5), axis=0)[::-1].copy()
        ch[:, : n // (2 + trial % 4)] *= trial % 3 != 0  # columns of zeros
        ch[2:, : n // 7] = ch[1, : n // 7]  # flat stretches
        logs = np.log(np.maximum(np.concatenate([ch[:1], ch[1:][::-1]]), 1e-300))
        full = interpolate.PchipInterpolator(nodes, logs, axis=0, extrapolate=False)
        for beta in (math.inf, *ex, 4.2, 7.5, 29.0, 1e9):
            want = np.exp(full(np.clip([1.0 / beta], 0.0, nodes[-1])))[0]
            assert miner_load(ch, beta).tobytes() == want.tobytes()
