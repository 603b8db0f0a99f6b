"""Detachment that accumulates over load cycles: the Miner-Basquin equivalent load ratio of a fruit's stem.

A fruit whose strength factor is s (its strengths s P and s S, berryshaker.plant.pedicel.peaks) loaded by a
sequence of load cycles with peak pull-shear load ratios g_i takes from cycle i the damage 1 / N_f(g_i), with
Basquin's power law of the cycles to failure at a constant peak

    N_f(g) = (s / g)^beta                                                                   (Basquin 1910)

(one cycle at the fruit's strength breaks it, N_f(s) = 1), and comes off when Miner's sum reaches one:

    D = sum_i 1 / N_f(g_i) = sum_i (g_i / s)^beta >= 1                                       (Miner 1945)

equivalently when the equivalent load ratio

    g_eq(beta) = ( sum_i g_i^beta )^(1 / beta)  >=  s.                                        (1)

As beta -> inf, g_eq -> max_i g_i: the peak-only law (detachment at the single largest load).  g_eq is
homogeneous of degree 1 in the loads, so a strength scaled by a divides it by a, as it does the peak.

A load cycle is a reversal of g(t) (a local maximum; g >= 0 is the magnitude of the pull-shear ratio, so a fully
reversed shear cycle is two reversals, as Basquin's law is written in reversals 2 N_f): a maximum counts once g
has fallen below (1 - :data:`REVERSAL_GATE`) of it in g^2, and the next one starts once g^2 has risen by the gate
times the last peak's g^2 above the trough between them (a hysteresis filter of the peak-valley sequence, the
usual removal of small reversals before cycle counting, cf. ASTM E1049-85: ripples of the branch's higher modes on
a peak are not cycles of their own).  A peak counts only where g > 0.  The gate's 0.1 in g^2 is about 5 % in g [assumed]; the count of
a resolved signal does not depend on its sample rate (tests/plant/test_miner.py).

No fatigue exponent of the blueberry pedicel's abscission zone is published to our knowledge, so beta is
[assumed] (``harvest.miner_exponent``, default 8) and calibrated (docs/calibration.md).

The sums are accumulated scaled by the running largest peak M (S_k = sum_i (g_i / M)^beta_k, rescaled when a
larger peak comes), so beta = 30 neither overflows nor underflows: g_eq = M S_k^(1 / beta_k).  A stem-load table
carries g_eq at the fixed exponents :data:`MINER_EXPONENTS` beside the peak (the beta -> inf limit), and any
beta between is read by interpolating ln g_eq in 1 / beta with a monotone cubic (:func:`miner_load`, PCHIP:
ln g_eq falls monotonically with beta; 1 / beta is the natural coordinate, ln g_eq = ln M + ln(S) / beta with S
tending to the count of the largest peaks as beta grows).  tests/plant/test_miner.py chooses it against a direct
count at exponents between the nodes (beta = 4 ... 50 on strike trains: worst error 0.37 %, against 0.97 % linear in
1 / beta and 3.0 % linear in ln beta); on a coupled drive-past's table it is within 1.2 % at beta = 4 and 0.2 % at
6.5-25 (linear in 1 / beta 2.7 % and 1.3 %).

References
----------
Basquin, O.H. (1910).  The exponential law of endurance tests.  Proc. ASTM 10: 625-630.
Miner, M.A. (1945).  Cumulative damage in fatigue.  J. Appl. Mech. 12: A159-A164.
ASTM E1049-85 (2017).  Standard practices for cycle counting in fatigue analysis.
Fritsch, F.N. & Carlson, R.E. (1980).  Monotone piecewise cubic interpolation.  SIAM J. Numer. Anal. 17: 238-246.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy import interpolate

from berryshaker.errors import ConfigError

#: Miner-Basquin exponents (dimensionless) at which a stem-load table carries the equivalent load ratio; the
#: prior of ``calibrate`` spans 3-30
MINER_EXPONENTS = np.array([3.0, 5.0, 8.0, 13.0, 20.0, 30.0])
#: hysteresis gate of the reversal count, a fraction of the peak's g^2 (about 5 % of g) [assumed]
REVERSAL_GATE = 0.1


@njit(cache=True)
def _register(p2, j, s, i, pm, sums, half):
    """Add the peak g^2 = p2 to the scaled sums of (j, s, i): S_k = sum (g / M)^beta_k, M the running largest."""
    if not p2 > 0.0:
        return
    m = pm[j, s, i]
    if p2 > m:
        if m > 0.0:
            lr = math.log(m / p2)
            for k in range(half.shape[0]):
                sums[j, s, i, k] *= math.exp(half[k] * lr)
        pm[j, s, i] = p2
        m = p2
    lr = math.log(p2 / m)
    for k in range(half.shape[0]):
        sums[j, s, i, k] += math.exp(half[k] * lr)


@njit(cache=True, inline="always")
def _advance(g2, j, s, i, rising, cand, last, pm, sums, half, gate):
    """One sample g^2 of the reversal count of (j, s, i) (module docstring)."""
    c = cand[j, s, i]
    if rising[j, s, i]:
        if g2 > c:
            cand[j, s, i] = g2
        elif g2 < c * (1.0 - gate):
            _register(c, j, s, i, pm, sums, half)
            last[j, s, i] = c
            rising[j, s, i] = False
            cand[j, s, i] = g2
    else:
        if g2 < c:
            cand[j, s, i] = g2
        elif g2 > c + gate * last[j, s, i]:
            rising[j, s, i] = True
            cand[j, s, i] = g2


@njit(cache=True)
def _finish(j, s, i, rising, cand, pm, sums, half):
    """End of the signal: a maximum still rising (or not yet fallen through the gate) counts."""
    if rising[j, s, i]:
        _register(cand[j, s, i], j, s, i, pm, sums, half)


@njit(cache=True)
def _equivalent(pm2, sum_k, beta):
    """g_eq = M S^(1 / beta) from M^2 and the scaled sum (0 without a peak)."""
    if not pm2 > 0.0:
        return 0.0
    return math.exp(0.5 * math.log(pm2) + math.log(sum_k) / beta)


@njit(cache=True)
def _series_kernel(g, exponents, gate, out):
    n_r, n_t = g.shape
    n_k = exponents.shape[0]
    half = 0.5 * exponents
    rising = np.ones((1, 1, n_r), dtype=np.bool_)
    cand, last, pm = np.zeros((1, 1, n_r)), np.zeros((1, 1, n_r)), np.zeros((1, 1, n_r))
    sums = np.zeros((1, 1, n_r, n_k))
    for r in range(n_r):
        cand[0, 0, r] = g[r, 0] * g[r, 0]
        for n in range(1, n_t):
            _advance(g[r, n] * g[r, n], 0, 0, r, rising, cand, last, pm, sums, half, gate)
        _finish(0, 0, r, rising, cand, pm, sums, half)
        out[r, 0] = math.sqrt(pm[0, 0, r])
        for k in range(n_k):
            out[r, 1 + k] = _equivalent(pm[0, 0, r], sums[0, 0, r, k], exponents[k])


def miner_equivalent(g, exponents=MINER_EXPONENTS, gate: float = REVERSAL_GATE) -> np.ndarray:
    """Peak and Miner-Basquin equivalent load ratios (eq. 1 of the module docstring) of load-ratio series.

    The same reversal count and sums as the stem-load tables' compiled pass
    (berryshaker.plant.pedicel.peak_stem_loads), for series already computed (a rigid pedicel's m |a(t)| / S,
    tests).

    Parameters
    ----------
    g : array_like (n_t,) or (n_rows, n_t)
        Load ratios g(t) >= 0 (dimensionless), uniformly sampled.
    exponents : array_like
        Basquin exponents beta (dimensionless, > 0).
    gate : float
        Hysteresis gate of the reversal count (fraction of a peak's g^2, dimensionless).

    Returns
    -------
    numpy.ndarray (..., 1 + len(exponents))
        [..., 0]: max_t g; [..., 1 + k]: g_eq(exponents[k]) (dimensionless).
    """
    g = np.asarray(g, float)
    one = g.ndim == 1
    g2 = np.ascontiguousarray(np.atleast_2d(g))
    ex = np.ascontiguousarray(np.atleast_1d(np.asarray(exponents, float)))
    if np.any(~(ex > 0)) or np.any(g2 < 0) or not np.all(np.isfinite(g2)) or g2.shape[-1] < 1:
        raise ConfigError("miner_equivalent needs finite load ratios >= 0 and exponents > 0")
    out = np.zeros((g2.shape[0], 1 + ex.size))
    _series_kernel(g2, ex, float(gate), out)
    return out[0] if one else out


def miner_load(channels, exponent, exponents=MINER_EXPONENTS) -> np.ndarray:
    """The equivalent load ratio at Basquin exponent ``exponent`` from a table's channels: ln g_eq interpolated
    in 1 / beta by a monotone cubic (PCHIP, Fritsch & Carlson 1980) through the exponents carried and the peak at
    1 / beta = 0 (module docstring).

    Parameters
    ----------
    channels : array_like (1 + len(exponents), n) or (1, n)
        Row 0 the peak load ratio max g, rows 1 + k g_eq(exponents[k]) (dimensionless); a single row (a table of
        peaks only) is returned as it is whatever the exponent.
    exponent : float or numpy.ndarray (m, 1)
        Basquin exponent beta (dimensionless, >= min(exponents); inf = peak-only).
    exponents : array_like
        The exponents of rows 1 ... (increasing; dimensionless).

    Returns
    -------
    numpy.ndarray (n,) or (m, n)
        g_eq(beta) (dimensionless).
    """
    ch = np.asarray(channels, float)
    if ch.shape[0] == 1:
        return ch[0] if np.ndim(exponent) == 0 else np.broadcast_to(ch[0], (np.shape(exponent)[0], ch.shape[1]))
    ex = np.asarray(exponents, float)
    if ch.shape[0] != 1 + ex.size:
        raise ConfigError(f"miner_load: {ch.shape[0]} channels for {ex.size} exponents (expected {1 + ex.size})")
    beta = np.asarray(exponent, float)
    if np.any(~(beta >= ex[0] * (1 - 1e-12))):
        raise ConfigError(f"the Miner exponent must be >= {ex[0]:g} (the tables carry {ex.tolist()} and the peak), "
                          f"got {exponent}")
    x = 1.0 / beta.reshape(-1)
    nodes = np.concatenate([[0.0], 1.0 / ex[::-1]])  # increasing 1 / beta: the peak, then the largest exponent ...
    order = [0, *range(ch.shape[0] - 1, 0, -1)]  # node k holds channel row order[k]
    if beta.ndim == 0 and nodes.size >= 3:  # one exponent: the two nodes' derivatives of the cell it falls in
        logs: dict = {}

        def row(k):
            if k not in logs:
                logs[k] = np.log(np.maximum(ch[order[k]], 1e-300))
            return logs[k]

        return np.exp(_pchip_at(nodes, row, min(max(float(x[0]), 0.0), float(nodes[-1]))))
    logs_all = np.log(np.maximum(ch[order], 1e-300))
    out = np.exp(interpolate.PchipInterpolator(nodes, logs_all, axis=0, extrapolate=False)(np.clip(x, 0.0, nodes[-1])))
    return out[0] if beta.ndim == 0 else out


def _edge_slope(h0, h1, m0, m1):
    """PCHIP's end derivative: the one-sided three-point estimate, kept to the data's shape (Moler 2004, pchiptx;
    scipy.interpolate.PchipInterpolator's, the same arithmetic)."""
    d = ((2 * h0 + h1) * m0 - h0 * m1) / (h0 + h1)
    mask = np.sign(d) != np.sign(m0)
    mmm = ~mask & (np.sign(m0) != np.sign(m1)) & (np.abs(d) > 3.0 * np.abs(m0))
    d[mask] = 0.0
    d[mmm] = 3.0 * m0[mmm]
    return d


def _node_slope(x, row, j):
    """PCHIP's derivative at node j of every column (Fritsch & Carlson 1980: 0 where the slopes either side differ
    in sign or vanish, else their weighted harmonic mean; the ends by :func:`_edge_slope`), from the rows of y it
    needs (``row(k)``): scipy.interpolate.PchipInterpolator's arithmetic, bit for bit."""
    h = lambda a: x[a + 1] - x[a]  # noqa: E731
    m = lambda a: (row(a + 1) - row(a)) / h(a)  # noqa: E731
    if j == 0:
        return _edge_slope(h(0), h(1), m(0), m(1))
    if j == len(x) - 1:
        return _edge_slope(h(j - 1), h(j - 2), m(j - 1), m(j - 2))
    m0, m1 = m(j - 1), m(j)
    w1, w2 = 2 * h(j) + h(j - 1), h(j) + 2 * h(j - 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        d = 1.0 / ((w1 / m0 + w2 / m1) / (w1 + w2))
    d[(np.sign(m1) != np.sign(m0)) | (m1 == 0) | (m0 == 0)] = 0.0
    return d


def _pchip_at(x, row, at: float) -> np.ndarray:
    """The monotone cubic (PCHIP) through (x, y) of every column at one point ``at`` in [x[0], x[-1]]: the Hermite
    cubic of the cell holding it, from the derivatives at its two nodes (:func:`_node_slope`), evaluated as
    scipy.interpolate.PPoly does (tests/plant/test_miner.py: bit for bit against PchipInterpolator)."""
    i = max(min(int(np.searchsorted(x, at, side="right")) - 1, len(x) - 2), 0)
    d0, d1 = _node_slope(x, row, i), _node_slope(x, row, i + 1)
    dx = x[i + 1] - x[i]
    y0 = row(i)
    slope = (row(i + 1) - y0) / dx
    t = (d0 + d1 - 2 * slope) / dx
    s = at - x[i]
    res = 0.0 + y0 + d0 * s  # c3 + c2 s + c1 s^2 + c0 s^3, summed in PPoly's order
    return res + ((slope - d0) / dx - t) * (s * s) + (t / dx) * (s * s * s)
