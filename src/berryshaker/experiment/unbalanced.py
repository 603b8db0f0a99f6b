"""Analysis of a blocked, replicated orthogonal test that lost plots (a blank response cell or a deleted row of a
field sheet): the same questions as the balanced analysis of :mod:`berryshaker.experiment.replicates`, answered by
least squares on the plots that are there.

With every plot present the randomised complete block analysis is orthogonal: each sum of squares is a sum of
squared level-mean deviations.  A lost plot breaks that, so every term is estimated by the general regression
significance test (Montgomery, *Design and Analysis of Experiments*, 8th ed., 2013, sec. 4.1.3 "exact analysis of
the missing value problem" and sec. 10.3.4; Searle, *Linear Models for Unbalanced Data*, 1987, ch. 4):

* the pooled error is the run x block interaction of the plots present: the residual of ``y ~ block + run``
  (statsmodels OLS, fixed block and run effects), with N - n - b + 1 degrees of freedom for N plots, n runs and b
  blocks (the balanced analysis' (n - 1)(r - 1) less one per lost plot);
* a factor's sum of squares is its Type II sum of squares in the main-effects model ``y ~ block + A + B + ...``
  (the residual sum of squares without the factor less the one with it: adjusted for the blocks and the other
  factors), tested by F against the factor's own interaction with the blocks among the plots present (the extra sum
  of squares of its factor x block columns over ``y ~ block + run``, Greenhouse-Geisser corrected from the blocks
  that kept every run), as the balanced analysis tests it; lack of fit is the main-effects model's residual less the
  pooled error;
* level means are least-squares means (the model's prediction at the level, averaged with equal weight over the
  blocks and the other factors' levels), their standard errors sqrt(MS l (X'X)^-1 l') with MS the factor's own error
  for comparisons between levels, level differences (``paired``) the contrasts of two least-squares means with
  Student t on that error's degrees of freedom, and the Tukey-Kramer half-width q / sqrt(2) times the standard error
  of the extreme pair's difference;
* the block variance sigma_b^2 = max((MS_blocks - MS_E) / n0, 0) from the blocks' mean square adjusted for the runs,
  with n0 = (N - sum_k N_k^2 / N) / (b - 1) plots per block (Searle, Casella and McCulloch, *Variance Components*,
  1992, sec. 3.6: the one-way coefficient, an approximation here); the optimum's interval adds it as the balanced
  analysis does, with Satterthwaite's (1946) degrees of freedom.

With every plot present each of these equals the balanced analysis' number (tests/experiment/test_unbalanced.py
holds that), but a complete sheet is analysed by :func:`berryshaker.experiment.replicates.analyze_replicated`, whose
numbers it keeps.

long module: the least-squares fits, each factor's test against its own interaction, the level means, the blocks'
variance and the tiered optimum read one another's fits; split, every part would import the others.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from berryshaker.errors import ConfigError
from berryshaker.experiment.analysis import (
    check_weights,
    factor_levels_report,
    polynomial_contrasts,
    quadratic_regression,
)
from berryshaker.experiment.error_terms import _studentized_range_quantile
from berryshaker.experiment.replicated_records import ReplicatedAnalysis
from berryshaker.experiment.replicates import PREDICTION_RULE


@dataclass
class _Fit:
    """The least-squares fits of one response's plots: the main-effects model (blocks + factors) and the error."""

    levels: np.ndarray  # (runs, factors) 1-based
    run: np.ndarray  # per plot: run index (0-based)
    block: np.ndarray  # per plot: block index (0-based, among the blocks present)
    y: np.ndarray  # per plot
    ks: list[list[int]]  # level numbers per factor
    X: np.ndarray  # main-effects model matrix
    beta: np.ndarray
    xtx_inv: np.ndarray
    ssr_main: float
    df_main: int
    ss_e: float
    df_e: int
    ss_block: float  # blocks adjusted for the runs
    df_block: int
    n0: float  # plots per block in E[MS_blocks] = sigma^2 + n0 sigma_b^2

    @property
    def ms_e(self) -> float:
        return self.ss_e / self.df_e

    def average_row(self, fixed: dict[int, int] | None = None) -> np.ndarray:
        """The model-matrix row averaged over the blocks and the levels of every factor not in ``fixed``
        (factor index -> level number): the least-squares mean's contrast ``l``."""
        fixed = fixed or {}
        nb = int(self.block.max()) + 1
        row = [1.0] + [1.0 / nb] * (nb - 1)
        for j, ks in enumerate(self.ks):
            if j in fixed:
                row += [1.0 if fixed[j] == k else 0.0 for k in ks[1:]]
            else:
                row += [1.0 / len(ks)] * (len(ks) - 1)
        return np.array(row)

    def mean_and_var(self, row: np.ndarray) -> tuple[float, float]:
        """l beta and l (X'X)^-1 l' (the variance over sigma^2) of a contrast row."""
        return float(row @ self.beta), float(row @ self.xtx_inv @ row)


def _dummies(codes: np.ndarray, values: list[int]) -> np.ndarray:
    """Treatment-coded columns of ``codes`` (the first of ``values`` is the reference)."""
    return np.column_stack([(codes == v).astype(float) for v in values[1:]]) if len(values) > 1 else \
        np.zeros((len(codes), 0))


def _ols(y: np.ndarray, X: np.ndarray):
    import statsmodels.api as sm

    return sm.OLS(y, X).fit()


def _fit(levels: np.ndarray, y: np.ndarray) -> _Fit:
    """Fit one response's plots (``y`` (runs, blocks) with NaN where lost)."""
    n, r = y.shape
    run, blk = np.nonzero(np.isfinite(y))
    obs = y[run, blk]
    present = sorted(set(blk.tolist()))
    block = np.searchsorted(present, blk)
    nb = len(present)
    ks = [sorted(int(v) for v in np.unique(levels[:, j])) for j in range(levels.shape[1])]
    lv = levels[run]
    cols = [np.ones((len(obs), 1)), _dummies(block, list(range(nb)))]
    cols += [_dummies(lv[:, j], ks[j]) for j in range(levels.shape[1])]
    X = np.hstack(cols)
    if np.linalg.matrix_rank(X) < X.shape[1]:
        raise ConfigError("the plots left cannot separate the factors' effects from the blocks' (too many plots "
                          "lost in one place); fill in more of the sheet")
    main = _ols(obs, X)
    runs_x = np.hstack([np.ones((len(obs), 1)), _dummies(block, list(range(nb))), _dummies(run, list(range(n)))])
    full = _ols(obs, runs_x)
    df_e = int(round(full.df_resid))
    only_runs = _ols(obs, np.hstack([np.ones((len(obs), 1)), _dummies(run, list(range(n)))]))
    counts = np.bincount(block, minlength=nb).astype(float)
    N = float(len(obs))
    n0 = (N - float(np.sum(counts**2)) / N) / (nb - 1) if nb > 1 else float("nan")
    return _Fit(levels, run, block, obs, ks, X, np.asarray(main.params), np.linalg.inv(X.T @ X),
                float(main.ssr), int(round(main.df_resid)), float(full.ssr), df_e,
                float(only_runs.ssr - full.ssr), nb - 1, n0)


def _type2(fit: _Fit, j: int) -> tuple[float, int]:
    """Type II sum of squares and degrees of freedom of factor ``j`` in the main-effects model."""
    start = 1 + int(fit.block.max()) + sum(len(k) - 1 for k in fit.ks[:j])
    width = len(fit.ks[j]) - 1
    keep = [c for c in range(fit.X.shape[1]) if not start <= c < start + width]
    return float(_ols(fit.y, fit.X[:, keep]).ssr - fit.ssr_main), width


def _own_error(fit: _Fit, j: int) -> tuple[float, int, float]:
    """Factor ``j``'s own interaction with the blocks among the plots present: the extra sum of squares of the
    factor x block columns over ``y ~ block + run`` and their degrees of freedom (with every plot present, exactly
    :func:`berryshaker.experiment.error_terms.factor_block_error`), and the Greenhouse-Geisser epsilon of the blocks
    that kept every run (1 with fewer than three)."""
    from berryshaker.experiment.error_terms import sphericity_epsilon

    n = fit.levels.shape[0]
    nb = int(fit.block.max()) + 1
    base = np.hstack([np.ones((len(fit.y), 1)), _dummies(fit.block, list(range(nb))),
                      _dummies(fit.run, list(range(n)))])
    lv = fit.levels[fit.run, j]
    fx = _dummies(lv, fit.ks[j])
    bx = _dummies(fit.block, list(range(nb)))
    inter = np.column_stack([fx[:, a] * bx[:, b] for a in range(fx.shape[1]) for b in range(bx.shape[1])]) \
        if fx.shape[1] and bx.shape[1] else np.zeros((len(fit.y), 0))
    X = np.hstack([base, inter])
    df = int(np.linalg.matrix_rank(X) - np.linalg.matrix_rank(base))
    if df < 1:
        return float("nan"), 0, 1.0
    ss = float(_ols(fit.y, base).ssr - _ols(fit.y, X).ssr)
    grid = np.full((n, nb), np.nan)
    grid[fit.run, fit.block] = fit.y
    whole = grid[:, np.isfinite(grid).all(axis=0)]
    eps = sphericity_epsilon(fit.levels[:, j], whole) if whole.shape[1] >= 3 else 1.0
    return ss, df, eps


def _tukey(ms: float, dof: int, k: int, var_diff: float, confidence: float) -> float:
    """Tukey-Kramer half-width of a level difference whose variance is ``var_diff`` sigma^2."""
    if k < 2 or dof < 1:
        return float("nan")
    return _studentized_range_quantile(float(confidence), int(k), int(dof)) / np.sqrt(2.0) * float(
        np.sqrt(ms * var_diff))


def _factor(fit: _Fit, j: int, alpha: float, confidence: float) -> dict:
    """One factor's ANOVA row, least-squares level means, their comparisons and the Tukey-Kramer margin."""
    from scipy import stats

    ss, df = _type2(fit, j)
    ss_own, df_e, eps = _own_error(fit, j)  # the factor against its own interaction with the blocks
    ms_e = ss_own / df_e if df_e else float("nan")
    ms = ss / df
    if ms_e > 0:
        F = ms / ms_e
        p = float(stats.f.sf(F, eps * df, eps * df_e))  # Greenhouse-Geisser degrees of freedom
    else:
        F, p = (float("inf"), 0.0) if ss > 1e-12 * max(float(np.sum((fit.y - fit.y.mean()) ** 2)), 1e-300) else (
            float("nan"), 1.0)
    t = float(stats.t.ppf(0.5 + confidence / 2, df_e))
    ks = fit.ks[j]
    rows = [fit.average_row({j: k}) for k in ks]
    mv = [fit.mean_and_var(row) for row in rows]
    means = [m for m, _ in mv]
    ses = [float(np.sqrt(ms_e * v)) for _, v in mv]
    nobs = [int(np.sum(fit.levels[fit.run, j] == k)) for k in ks]
    paired = []
    for a in range(len(ks)):
        for b in range(a + 1, len(ks)):
            d = rows[b] - rows[a]
            diff, v = fit.mean_and_var(d)
            se = float(np.sqrt(ms_e * v))
            pp = float(2 * stats.t.sf(abs(diff) / se, df_e)) if se > 0 else (0.0 if diff else 1.0)
            paired.append({"levels": [ks[a], ks[b]], "difference": diff, "se": se,
                           "ci": [diff - t * se, diff + t * se], "p": pp,
                           "beyond_noise": bool(pp < 1 - confidence and p < alpha)})
    hi, lo = int(np.argmax(means)), int(np.argmin(means))
    hw = _tukey(ms_e, df_e, len(ks), fit.mean_and_var(rows[hi] - rows[lo])[1], confidence)
    R = means[hi] - means[lo]
    return {"ss": ss, "df": df, "ms": ms, "f": float(F), "p": p, "significant": bool(p < alpha),
            "error": {"ss": ss_own, "df": df_e, "ms": ms_e,
                      "kind": f"its own interaction with the blocks of the plots present (Greenhouse-Geisser epsilon "
                              f"{eps:.3g})"}, "levels": ks,
            "level_means": means, "level_se": ses, "level_ci": [[m - t * s, m + t * s] for m, s in zip(means, ses)],
            "range": R, "range_ci": [R - hw, R + hw], "hsd": hw, "n_per_level": nobs, "paired": paired,
            "rows": rows}


def _blocks(fit: _Fit) -> dict:
    """Variance components of the blocks (:class:`~berryshaker.experiment.replicated_records.BlockVariance`)."""
    ms_b = fit.ss_block / fit.df_block if fit.df_block else float("nan")
    ms_e = fit.ms_e
    var_b = max((ms_b - ms_e) / fit.n0, 0.0) if np.isfinite(ms_b) else float("nan")
    return {"ms_block": ms_b, "df_block": fit.df_block, "ms_error": ms_e, "df_error": fit.df_e, "var_block": var_b,
            "per_start_sd": float(np.sqrt(var_b + ms_e)) if np.isfinite(var_b) else float("nan")}


def _check(y: np.ndarray, name: str) -> None:
    n, r = y.shape
    present = np.isfinite(y)
    if r < 2:
        raise ConfigError(f"response {name!r}: a blocked analysis needs at least 2 replicates per run")
    if (~np.isfinite(y) & ~np.isnan(y)).any():
        raise ConfigError(f"response {name!r}: values must be finite")
    empty = np.flatnonzero(~present.any(axis=1))
    if len(empty):
        raise ConfigError(f"response {name!r}: run {int(empty[0]) + 1} has no value left; every run needs one")
    plots = int(present.sum())
    blocks = int(present.any(axis=0).sum())
    df_e = plots - n - blocks + 1
    if df_e < 1:
        raise ConfigError(f"response {name!r}: {plots} plots of {n} runs in {blocks} blocks leave {max(df_e, 0)} "
                          "degrees of freedom for the error, so no effect can be judged against the noise; fill in "
                          "the lost plots or test another replicate")


def analyze_unbalanced(levels: np.ndarray, values: np.ndarray, factor_names: list[str],
                       responses_replicated: dict[str, np.ndarray], senses: dict[str, bool],
                       weights: dict[str, float] | None = None, *, alpha: float = 0.05, confidence: float = 0.95,
                       level_values: dict[str, tuple[float, ...] | None] | None = None,
                       units: dict[str, str] | None = None) -> tuple[ReplicatedAnalysis, dict]:
    """Analysis of a blocked replicated test with lost plots (NaN), in the layout of
    :func:`berryshaker.experiment.replicates.analyze_replicated` with ``blocks=True``.

    Parameters
    ----------
    levels : ndarray (runs, factors)
        1-based level numbers of an orthogonal array (dimensionless).
    values : ndarray (runs, factors)
        Level values in each factor's unit, for the eq. 19 regression of the run means.
    factor_names : list of str
        Names of the factors.
    responses_replicated : dict name -> ndarray (runs, blocks)
        Observations in each response's unit, NaN where a plot was lost; column k is block k.
    senses : dict name -> bool
        True where larger is better.
    weights : dict name -> float, optional
        Priority of the responses (dimensionless, > 0; normalised); default equal.
    alpha : float
        An effect is significant only if its p-value < alpha (dimensionless).
    confidence : float
        Level of the intervals (dimensionless).
    level_values, units : dict, optional
        Level values and units per factor (reported).

    Returns
    -------
    (ReplicatedAnalysis, dict)
        The analysis (level means are least-squares means, ``run_means`` the runs' least-squares means over the
        blocks, ``run_sd`` None for a run with one plot left) and what was lost: ``plots`` (planned), ``present``
        (per response), ``lost`` (per response the [run, block] cells), ``error_df`` (per response),
        ``balanced_error_df`` ((n - 1)(r - 1)), ``lost_df`` (per response) and ``method``.

    Raises
    ------
    ConfigError
        Inconsistent inputs, a run with no plot left, or no error degrees of freedom left.
    """
    if not 0 < alpha < 1 or not 0 < confidence < 1:
        raise ConfigError("alpha and confidence must lie between 0 and 1")
    levels = np.asarray(levels, int)
    values = np.asarray(values, float)
    reps = {k: np.asarray(v, float) for k, v in responses_replicated.items()}
    if set(reps) != set(senses):
        raise ConfigError(f"responses {sorted(reps)} and senses {sorted(senses)} differ")
    shapes = {y.shape for y in reps.values()}
    if len(shapes) != 1 or next(iter(shapes))[0] != len(levels) or levels.shape[1] != len(factor_names):
        raise ConfigError(f"responses of shapes {sorted(shapes)} do not match {len(levels)} runs x "
                          f"{len(factor_names)} factors")
    for name, y in reps.items():
        _check(y, name)
    n, r = next(iter(shapes))
    w = check_weights(weights, reps)
    rule = (f"an effect is significant only if p < {alpha:g} (F test of the factor's Type II sum of squares: adjusted "
            "for the blocks and the other factors, against the factor's own interaction with the blocks among the plots present (Greenhouse-Geisser corrected); "
            "lost plots leave the design unbalanced); otherwise the levels show no meaningful difference. Intervals: "
            f"{100 * confidence:g} % (least-squares level means: t, for comparisons between levels; range: "
            "Tukey-Kramer, simultaneous over all level pairs; level differences: t on the error's degrees of freedom).")
    out = {"significance_rule": rule, "alpha": alpha, "confidence": confidence, "runs": n, "replicates": r,
           "blocks": True, "weights": w, "factors": factor_levels_report(factor_names, levels, level_values, units),
           "responses": {}, "notes": []}
    fits, info = {}, {"plots": n * r, "present": {}, "lost": {}, "error_df": {}, "balanced_error_df": (n - 1) * (r - 1),
                      "lost_df": {}}
    for name, y in reps.items():
        fit = _fit(levels, y)
        fits[name] = fit
        fac = {f: _factor(fit, j, alpha, confidence) for j, f in enumerate(factor_names)}
        mx = senses[name]
        effects = {}
        for f, d in fac.items():
            b = int(np.argmax(d["level_means"]) if mx else np.argmin(d["level_means"]))
            best = d["level_means"][b]
            within = [d["levels"][i] for i, m in enumerate(d["level_means"])
                      if abs(best - m) <= d["hsd"] or not np.isfinite(d["hsd"])]
            effects[f] = {**{k: d[k] for k in ("level_means", "level_se", "level_ci", "range", "range_ci", "hsd",
                                               "significant", "p", "paired")},
                          "K": [m * c for m, c in zip(d["level_means"], d["n_per_level"])],
                          "best_level": d["levels"][b], "best_levels_within_noise": within,
                          "verdict": f"level {d['levels'][b]} best" if d["significant"] else "no meaningful difference"}
        run_means = _run_means(fit, n)
        present = np.isfinite(y)
        run_sd = [float(np.std(y[i][present[i]], ddof=1)) if present[i].sum() >= 2 else None for i in range(n)]
        reg = quadratic_regression(values, np.asarray(run_means), factor_names)
        reg.pop("_scaling")
        ss_pe = float(sum(np.sum((y[i][present[i]] - y[i][present[i]].mean()) ** 2) for i in range(n)))
        df_pe = int(present.sum()) - n
        ss_lof, df_lof = max(fit.ssr_main - fit.ss_e, 0.0), fit.df_main - fit.df_e
        lof = {"ss": ss_lof, "df": int(df_lof), "ms": ss_lof / df_lof if df_lof > 0 else float("nan")}
        if df_lof > 0 and fit.ms_e > 0:
            from scipy import stats

            lof["f"] = lof["ms"] / fit.ms_e
            lof["p"] = float(stats.f.sf(lof["f"], df_lof, fit.df_e))
        out["responses"][name] = {
            "maximize": mx, "factors": effects, "ranking": sorted(factor_names, key=lambda f: -effects[f]["range"]),
            "run_means": run_means, "run_sd": run_sd, "best_levels": {f: effects[f]["best_level"] for f in factor_names},
            "significant_factors": [f for f in factor_names if effects[f]["significant"]],
            "anova": {"factors": {f: {k: fac[f][k] for k in ("ss", "df", "ms", "f", "p", "significant", "error")}
                                  for f in factor_names},
                      "error": {"ss": fit.ss_e, "df": fit.df_e, "ms": fit.ms_e,
                                "kind": "run x block interaction of the plots present (least squares, unbalanced)"},
                      "blocks": _blocks(fit), "pure_error": {"ss": ss_pe, "df": df_pe, "ms": ss_pe / df_pe},
                      "lack_of_fit": lof, "pooled": [], "total_ss": float(np.sum((fit.y - fit.y.mean()) ** 2))},
            "regression": reg}
        if fit.ms_e == 0:
            out["notes"].append(f"{name}: zero run x block interaction; effects are exact, not judged against noise")
        lost = [[int(i) + 1, int(j) + 1] for i, j in np.argwhere(~present)]
        info["present"][name] = int(present.sum())
        info["lost"][name] = lost
        info["error_df"][name] = fit.df_e
        info["lost_df"][name] = info["balanced_error_df"] - fit.df_e
    out["optimum"] = _optimum(levels, factor_names, reps, senses, w, out, fits, alpha, confidence)
    info["method"] = ("least squares on the plots present (Montgomery 2013, sec. 4.1.3): Type II sums of squares, "
                      "least-squares level means, error = run x block interaction of the plots present")
    return ReplicatedAnalysis.from_json(out), info


def describe_lost(info: dict, what: str = "replicate") -> list[str]:
    """The lost plots and degrees of freedom of :func:`analyze_unbalanced` in words, one line each.

    Parameters
    ----------
    info : dict
        :func:`analyze_unbalanced`'s second result (or its record's JSON).
    what : str
        What the sheet calls a block ("replicate", "block").

    Returns
    -------
    list of str
        The lines.
    """
    lines = []
    for name, cells in info["lost"].items():
        if not cells:
            continue
        where = ", ".join(f"run {i} {what} {k}" for i, k in cells[:12]) + (" ..." if len(cells) > 12 else "")
        lines.append(f"Lost plots of {name}: {len(cells)} of {info['plots']} ({where}); error "
                     f"{info['error_df'][name]} degrees of freedom instead of {info['balanced_error_df']} "
                     f"({info['lost_df'][name]} lost); the design is no longer orthogonal, so sums of squares are "
                     "Type II and level means least-squares means")
    return lines


def _run_means(fit: _Fit, n: int) -> list[float]:
    """Each run's least-squares mean over the blocks (``y ~ block + run``): its mean had no plot been lost."""
    nb = int(fit.block.max()) + 1
    X = np.hstack([np.ones((len(fit.y), 1)), _dummies(fit.block, list(range(nb))), _dummies(fit.run, list(range(n)))])
    beta = np.asarray(_ols(fit.y, X).params)
    base = beta[0] + beta[1:nb].sum() / nb
    return [float(base + (beta[nb + i - 1] if i > 0 else 0.0)) for i in range(n)]


def _optimum(levels, factor_names, reps, senses, w, out, fits, alpha, confidence) -> dict:
    """Per factor a level from the responses it significantly affects (as the balanced analysis' weighted optimum),
    the composite's level means least-squares means of the plots where every response used is present."""
    scale = {k: float(np.ptp(out["responses"][k]["run_means"])) for k in reps}
    choices: dict = {}
    chosen: dict = {}
    for j, f in enumerate(factor_names):
        sig = [k for k in reps if k in w and scale[k] > 0 and out["responses"][k]["factors"][f]["significant"]]
        pvals = {k: out["responses"][k]["factors"][f]["p"] for k in reps}
        labels, nums = out["factors"][f]["labels"], out["factors"][f]["level_numbers"]
        if not sig:
            reason = (f"no response differs significantly between the levels of {f} ("
                      + ", ".join(f"{k}: p = {p:.3g}" for k, p in pvals.items()) + f", rule p < {alpha:g})")
            choices[f] = {"level": None, "setting": None, "status": "no meaningful difference", "reason": reason,
                          "significant_responses": [], "equivalent_levels": nums}
            chosen[f] = None
            continue
        z = sum((w[k] * (1.0 if senses[k] else -1.0) / scale[k]) * reps[k] for k in sig)  # NaN where any is lost
        zf = _fit(levels, z)
        d = _factor(zf, j, alpha, confidence)
        means, ks = d["level_means"], d["levels"]
        b = int(np.argmax(means))
        equivalent = [ks[i] for i in range(len(ks)) if i == b or means[b] - means[i] <= _tukey(
            d["error"]["ms"], d["error"]["df"], len(ks), zf.mean_and_var(d["rows"][b] - d["rows"][i])[1], confidence)]
        parts = []
        for k in reps:
            fr = out["responses"][k]["factors"][f]
            if k in sig:
                lm = ", ".join(f"{v:.4g}" for v in fr["level_means"])
                parts.append(f"{k} differs (p = {pvals[k]:.3g}; least-squares level means {lm}; "
                             f"{'max' if senses[k] else 'min'}imised best at level {fr['best_level']})")
            elif k in w:
                parts.append(f"{k}: no significant difference (p = {pvals[k]:.3g}), not used")
        status = "chosen" if len(equivalent) == 1 else "chosen; not distinguishable from level(s) " + ", ".join(
            str(k) for k in equivalent if k != ks[b])
        choices[f] = {"level": ks[b], "setting": labels[nums.index(ks[b])], "status": status,
                      "reason": "; ".join(parts), "significant_responses": sig, "equivalent_levels": equivalent,
                      "composite_level_means": means}
        chosen[f] = ks[b]
    values, intervals = {}, {}
    for k in reps:
        values[k], intervals[k] = predict_at(fits[k], factor_names, out["responses"][k], chosen, confidence)
    return {"levels": chosen, "settings": {f: c["setting"] for f, c in choices.items()}, "choices": choices,
            "values": values, "intervals": intervals, "weights": w,
            "method": ("per factor, a weighted sum of the responses whose effect of that factor is significant, each "
                       "signed (+ maximise, - minimise) and divided by its range of run means over the design; "
                       "responses without a significant effect contribute nothing; least-squares means of the plots "
                       "present"),
            "prediction": PREDICTION_RULE + "; least-squares means of the plots present"}


def predict_at(fit: _Fit, factor_names: list[str], response: dict, chosen: dict, confidence: float) -> tuple:
    """A response's predicted mean and interval at a level set (the additive model over the factors significant
    for it; a factor at None or not significant is averaged), the blocks' variance added over the blocks.

    Parameters
    ----------
    fit : _Fit
        The response's fit.
    factor_names : list of str
        The factors.
    response : dict
        The response's analysis (its ``factors`` with ``significant`` and ``anova`` with ``blocks``).
    chosen : dict factor -> int or None
        The level set.
    confidence : float
        Level of the interval (dimensionless).

    Returns
    -------
    (float, list of float)
        The prediction and its interval (the response's unit).
    """
    from scipy import stats

    used = {j: chosen[f] for j, f in enumerate(factor_names)
            if chosen.get(f) is not None and response["factors"][f]["significant"]}
    val, c = fit.mean_and_var(fit.average_row(used))
    ms_e, df_e = fit.ms_e, fit.df_e
    var, dof = ms_e * c, float(df_e)
    bl = response["anova"]["blocks"]
    if np.isfinite(bl["ms_block"]) and bl["ms_block"] > ms_e:
        nb = fit.df_block + 1
        c1 = max(ms_e * (c - 1.0 / (fit.n0 * nb)), 0.0)
        c2 = bl["ms_block"] / (fit.n0 * nb)
        var = c1 + c2
        dof = var**2 / ((c1**2 / df_e if c1 > 0 else 0.0) + c2**2 / bl["df_block"])
    hw = float(stats.t.ppf(0.5 + confidence / 2, dof)) * float(np.sqrt(var))
    return float(val), [float(val - hw), float(val + hw)]


def standardized_effects_unbalanced(levels: np.ndarray, y: np.ndarray, factor_names: list[str],
                                    alpha: float = 0.05) -> dict:
    """Standardized effects of a blocked test with lost plots: every factor's orthogonal polynomial contrasts of its
    least-squares level means with their standard errors from the model, as t statistics (the layout of
    :func:`berryshaker.experiment.analysis.standardized_effects`).

    Parameters
    ----------
    levels : ndarray (runs, factors)
        1-based level numbers (1).
    y : ndarray (runs, blocks)
        Observations (any unit), NaN where lost.
    factor_names : list of str
        Names of the factors.
    alpha : float
        Significance level of the reference line t(1 - alpha/2, df).

    Returns
    -------
    dict
        ``terms`` (term, factor, order, estimate, se, t, p, significant), ``error`` {ms, df, method},
        ``critical_t``, ``alpha``.
    """
    from scipy import stats

    fit = _fit(np.asarray(levels, int), np.asarray(y, float))
    rows = []
    for j, f in enumerate(factor_names):
        ks = fit.ks[j]
        L = np.array([fit.average_row({j: k}) for k in ks])
        n = [int(np.sum(fit.levels[fit.run, j] == k)) for k in ks]
        for order, c in enumerate(polynomial_contrasts(n), start=1):
            kind = {1: "linear", 2: "quadratic", 3: "cubic"}.get(order, f"order {order}")
            est, v = fit.mean_and_var(c @ L)
            se = float(np.sqrt(fit.ms_e * v))
            t = est / se if se > 0 else (float("inf") if est else 0.0)
            p = float(2 * stats.t.sf(abs(t), fit.df_e))
            rows.append({"term": f if len(ks) == 2 else f"{f} ({kind})", "factor": f, "order": order,
                         "estimate": est, "se": se, "t": float(t), "p": p, "significant": bool(p < alpha)})
    return {"terms": rows, "error": {"ms": fit.ms_e, "df": fit.df_e, "method": "least squares on the plots present"},
            "critical_t": float(stats.t.ppf(1 - alpha / 2, fit.df_e)), "alpha": alpha}


def residuals_unbalanced(levels: np.ndarray, y: np.ndarray) -> dict:
    """Fitted values and residuals of the main-effects model with blocks on the plots present (the layout of
    :func:`berryshaker.experiment.analysis.main_effect_residuals`), in the order of the plots run by run.

    Parameters
    ----------
    levels : ndarray (runs, factors)
        1-based level numbers (1).
    y : ndarray (runs, blocks)
        Observations (any unit), NaN where lost.

    Returns
    -------
    dict
        ``fitted``, ``residuals``, ``ss``, ``normal_quantiles``, ``sorted_residuals`` (Blom's plotting positions).
    """
    from scipy import stats

    fit = _fit(np.asarray(levels, int), np.asarray(y, float))
    fitted = fit.X @ fit.beta
    res = fit.y - fitted
    m = len(res)
    q = stats.norm.ppf((np.arange(1, m + 1) - 0.375) / (m + 0.25))
    return {"fitted": fitted, "residuals": res, "ss": float(np.sum(res**2)), "normal_quantiles": q,
            "sorted_residuals": np.sort(res)}


__all__ = ["analyze_unbalanced", "describe_lost", "predict_at", "residuals_unbalanced", "standardized_effects_unbalanced"]
