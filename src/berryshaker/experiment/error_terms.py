"""The error terms of a replicated orthogonal test: the pure error of each run's replicates, the run x block
interaction of a randomised complete block design, a factor's own interaction with the blocks, the block variance
components, paired differences between a factor's levels within the blocks, and Tukey-Kramer comparison margins
(Montgomery, *Design and Analysis of Experiments*, 8th ed., 2013: sec. 3.3, 3.5.7, 4.1, 13.1, 14.5; Maxwell and
Delaney 2004, ch. 12).  The analysis that uses them is :mod:`berryshaker.experiment.replicates`.
"""

from __future__ import annotations

import functools

import numpy as np

from berryshaker.errors import ConfigError


def pure_error(y: np.ndarray) -> tuple[float, int]:
    """Pure-error sum of squares and degrees of freedom of a (runs, replicates) array.

    SS_PE = sum_i sum_j (y_ij - ybar_i)^2 with sum_i (r_i - 1) degrees of freedom (here r_i = r).

    Parameters
    ----------
    y : ndarray (runs, replicates)
        Observations (any unit).

    Returns
    -------
    (float, int)
        SS_PE (the unit of y squared) and its degrees of freedom.
    """
    y = np.asarray(y, float)
    return float(np.sum((y - y.mean(axis=1, keepdims=True)) ** 2)), int(y.shape[0] * (y.shape[1] - 1))


@functools.lru_cache(maxsize=256)
def _studentized_range_quantile(confidence: float, k: int, dof: int) -> float:
    from scipy.stats import studentized_range

    return float(studentized_range.ppf(confidence, k, dof))  # slow (numerical integration): cached


def _tukey_half_width(ms: float, dof: int, k: int, n_a: int, n_b: int, confidence: float) -> float:
    """Tukey-Kramer simultaneous half-width for the difference of two of k means (n_a, n_b observations):
    q(confidence; k, dof) / sqrt(2) * sqrt(MS_PE (1/n_a + 1/n_b)) (Montgomery 2013, sec. 3.5.7)."""
    if k < 2 or dof < 1:
        return float("nan")
    q = _studentized_range_quantile(float(confidence), int(k), int(dof))
    return q / np.sqrt(2.0) * float(np.sqrt(ms * (1.0 / n_a + 1.0 / n_b)))


def comparison_half_width(ms: float, dof: int, k: int, n: int, confidence: float = 0.95) -> float:
    """Per-mean comparison half-width h = q(confidence; k, dof) / sqrt(2) sqrt(MS_E / n) of one of k means.

    Two of the k means (n_a, n_b observations) differ beyond noise, simultaneously over all k (k - 1) / 2
    pairs, iff |a - b| > sqrt(h_a^2 + h_b^2) = q / sqrt(2) sqrt(MS_E (1/n_a + 1/n_b)), the Tukey-Kramer margin
    of :func:`_tukey_half_width` (Montgomery 2013, sec. 3.5.7) split per mean.  ``ms``, ``dof``: the pure-error
    mean square and its degrees of freedom; nan if k < 2 or dof < 1; 0 if ms = 0.

    Parameters
    ----------
    ms : float
        Error mean square (the response's unit squared).
    dof : int
        Its degrees of freedom.
    k : int
        Number of means compared.
    n : int
        Observations per mean (>= 1).
    confidence : float
        Simultaneous confidence (dimensionless).

    Returns
    -------
    float
        h, in the response's unit.
    """
    if n < 1:
        raise ConfigError(f"comparison half-width: n = {n} observations, need >= 1")
    return _tukey_half_width(ms, dof, k, n, n, confidence) / np.sqrt(2.0)


def block_error(y: np.ndarray) -> tuple[float, int]:
    """Run x block interaction sum of squares and degrees of freedom of a (runs, blocks) array.

    ``SS_E = sum_i sum_k (y_ik - ybar_i. - ybar_.k + ybar_..)^2`` with (n - 1)(r - 1) degrees of freedom: the error of a
    randomised complete block design with the n runs as treatments and the r blocks (Montgomery 2013, sec. 4.1,
    eq. 4.7).  Block effects (a start, a field day, a row of bushes shared by every run) cancel from it.

    Parameters
    ----------
    y : ndarray (runs, blocks)
        Observations (any unit).

    Returns
    -------
    (float, int)
        SS_E (the unit of y squared) and its degrees of freedom.
    """
    y = np.asarray(y, float)
    n, r = y.shape
    e = y - y.mean(axis=1, keepdims=True) - y.mean(axis=0, keepdims=True) + y.mean()
    return float(np.sum(e**2)), int((n - 1) * (r - 1))


def factor_block_error(levels_j: np.ndarray, y: np.ndarray) -> tuple[float, int]:
    """A factor's own interaction with the blocks: its sum of squares and degrees of freedom.

    ``SS_AxB = sum_a n_a sum_k (ybar_ak - ybar_a. - ybar_.k + ybar_..)^2`` with (L - 1)(r - 1) degrees of freedom,
    ybar_ak the mean of the n_a runs at level a in block k.  A factor is tested against its own interaction with the
    blocks, the univariate analysis of a repeated-measures (within-block) factor, which stays valid when the
    factors' interactions with the blocks differ (no sphericity over the factors assumed; Maxwell and Delaney 2004,
    Designing Experiments and Analyzing Data, 2nd ed., ch. 12; Montgomery 2013, sec. 14.5 for the split-plot
    form).  In a saturated orthogonal array the run x block interaction (:func:`block_error`) is the sum of the
    factors' own interactions.

    Parameters
    ----------
    levels_j : ndarray (runs,)
        The factor's level (1-based) in each run.
    y : ndarray (runs, blocks)
        Observations (any unit).

    Returns
    -------
    (float, int)
        SS_AxB (the unit of y squared) and its degrees of freedom.
    """
    y = np.asarray(y, float)
    levels_j = np.asarray(levels_j)
    ks = sorted(int(v) for v in np.unique(levels_j))
    block = y.mean(axis=0)
    grand = y.mean()
    ss = 0.0
    for k in ks:
        sel = levels_j == k
        m = y[sel].mean(axis=0)
        ss += int(sel.sum()) * float(np.sum((m - m.mean() - block + grand) ** 2))
    return ss, int((len(ks) - 1) * (y.shape[1] - 1))


def sphericity_epsilon(levels_j: np.ndarray, y: np.ndarray) -> float:
    """Greenhouse-Geisser epsilon of one factor's levels over the blocks: how far the covariance of its level
    contrasts across the blocks is from sphericity.

    With D_k the orthonormal (Helmert) contrasts of the factor's level means in block k and S their covariance over
    the blocks, epsilon = (tr S)^2 / ((L - 1) tr(S^2)), between 1 / (L - 1) and 1 (Box 1954; Greenhouse and Geisser
    1959, Psychometrika 24, 95-112).  The factor's F test against its own interaction with the blocks is then
    referred to F(epsilon (L - 1), epsilon (L - 1)(r - 1)): when the factor's effect varies from block to block in
    one contrast only, the uncorrected test rejects a null factor about twice as often as it should.

    Parameters
    ----------
    levels_j : ndarray (runs,)
        The factor's level (1-based) in each run (dimensionless).
    y : ndarray (runs, blocks)
        Observations (any unit).

    Returns
    -------
    float
        Epsilon (dimensionless; 1 for a two-level factor or contrasts without spread).
    """
    from scipy.linalg import helmert

    y = np.asarray(y, float)
    levels_j = np.asarray(levels_j)
    ks = sorted(int(v) for v in np.unique(levels_j))
    if len(ks) < 3 or y.shape[1] < 3:
        return 1.0
    m = np.array([y[levels_j == k].mean(axis=0) for k in ks])  # (levels, blocks)
    d = helmert(len(ks)) @ m  # (levels - 1, blocks): orthonormal contrasts per block
    cov = np.cov(d)
    tr, tr2 = float(np.trace(cov)), float(np.trace(cov @ cov))
    return float(min(max(tr * tr / ((len(ks) - 1) * tr2), 1.0 / (len(ks) - 1)), 1.0)) if tr2 > 0 else 1.0


def factor_error(levels_j: np.ndarray, y: np.ndarray, blocks: bool) -> tuple[float, int]:
    """The error one factor's effect is judged against: its own interaction with the blocks
    (:func:`factor_block_error`) with blocks, else the pure error (:func:`pure_error`).

    Parameters
    ----------
    levels_j : ndarray (runs,)
        The factor's level (1-based) in each run.
    y : ndarray (runs, replicates)
        Observations (any unit).
    blocks : bool
        Replicate k of every run shares block k.

    Returns
    -------
    (float, int)
        The sum of squares (the unit of y squared) and its degrees of freedom.
    """
    return factor_block_error(levels_j, y) if blocks else pure_error(y)


def error_term(y: np.ndarray, blocks: bool) -> tuple[float, int]:
    """The error that effects are judged against: :func:`block_error` with blocks, else :func:`pure_error`.

    Parameters
    ----------
    y : ndarray (runs, replicates)
        Observations (any unit).
    blocks : bool
        Replicate k of every run shares block k.

    Returns
    -------
    (float, int)
        The sum of squares (the unit of y squared) and its degrees of freedom.
    """
    return block_error(y) if blocks else pure_error(y)


def block_variance(y: np.ndarray) -> dict:
    """Variance components of a blocked (runs, blocks) array: y_ik = mu + tau_i + beta_k + e_ik.

    ``ms_block = n sum_k (ybar_.k - ybar_..)^2 / (r - 1)`` estimates sigma^2 + n sigma_beta^2, ``ms_error`` (the
    interaction, :func:`block_error`) estimates sigma^2, so sigma_beta^2 = max((ms_block - ms_error) / n, 0)
    (method of moments, Montgomery 2013, sec. 13.1).  ``per_start_sd`` = sqrt(sigma_beta^2 + sigma^2): the spread of
    one run's replicates, block included.

    Parameters
    ----------
    y : ndarray (runs, blocks)
        Observations (any unit).

    Returns
    -------
    dict
        ``ms_block``, ``df_block``, ``ms_error``, ``df_error``, ``var_block`` (the unit of y squared) and
        ``per_start_sd`` (the unit of y).
    """
    y = np.asarray(y, float)
    n, r = y.shape
    ss_e, df_e = block_error(y)
    ms_e = ss_e / df_e if df_e else float("nan")
    ms_b = n * float(np.sum((y.mean(axis=0) - y.mean()) ** 2)) / (r - 1) if r > 1 else float("nan")
    var_b = max((ms_b - ms_e) / n, 0.0) if np.isfinite(ms_b) and np.isfinite(ms_e) else float("nan")
    return {"ms_block": ms_b, "df_block": r - 1, "ms_error": ms_e, "df_error": df_e, "var_block": var_b,
            "per_start_sd": float(np.sqrt(var_b + ms_e)) if np.isfinite(var_b) else float("nan")}


def paired_differences(levels_j: np.ndarray, y: np.ndarray, confidence: float = 0.95) -> list[dict]:
    """Paired (within-block) differences between the levels of one factor.

    Parameters
    ----------
    levels_j : ndarray (runs,)
        The factor's level (1-based) in each run.
    y : ndarray (runs, blocks)
        Observations (any unit); column k is block k, shared by every run (a start drawn once and used for every
        run: common random numbers; a field day or row in a field test).
    confidence : float
        Level of the t-intervals (dimensionless).

    Returns
    -------
    list of dict
        For every pair of levels a < b: ``levels`` [a, b], ``difference`` dbar = mean_k d_k with
        d_k = mean(y_ik, level b) - mean(y_ik, level a) in block k, ``se`` = sd(d) / sqrt(r), ``ci`` (Student t,
        r - 1 dof), ``p`` (two-sided paired t test), ``beyond_noise`` (p < 1 - confidence).

    Notes
    -----
    The paired t test of Student (1908) on the block-wise contrasts: block effects cancel from each d_k, so the
    standard error is that of the contrast itself, not of the start-to-start spread (Montgomery 2013, sec. 2.5.1).
    """
    from scipy import stats

    y = np.asarray(y, float)
    levels_j = np.asarray(levels_j)
    r = y.shape[1]
    ks = sorted(int(v) for v in np.unique(levels_j))
    means = {k: y[levels_j == k].mean(axis=0) for k in ks}
    out = []
    for i, a in enumerate(ks):
        for b in ks[i + 1:]:
            d = means[b] - means[a]
            dbar = float(d.mean())
            if r < 2:
                out.append({"levels": [a, b], "difference": dbar, "se": float("nan"), "ci": [float("nan")] * 2,
                            "p": float("nan"), "beyond_noise": False})
                continue
            se = float(d.std(ddof=1) / np.sqrt(r))
            t = float(stats.t.ppf(0.5 + confidence / 2, r - 1))
            if se > 0:
                p = float(2 * stats.t.sf(abs(dbar) / se, r - 1))
            else:
                p = 0.0 if dbar != 0 else 1.0
            out.append({"levels": [a, b], "difference": dbar, "se": se, "ci": [dbar - t * se, dbar + t * se],
                        "p": p, "beyond_noise": bool(p < 1 - confidence)})
    return out
