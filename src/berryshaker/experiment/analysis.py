"""Analysis of an orthogonal test: range analysis, weighted multi-response optimum, ANOVA with pooling,
and the study's eq. 19 quadratic regression handled honestly.

long module: range analysis, the pooled ANOVA, the eq. 19 regression and the standardized effects and residuals
of the effect figures share one design matrix and one error term.
"""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd

from berryshaker.errors import ConfigError
from berryshaker.experiment.analysis_records import DoeAnalysis


def range_analysis(levels: np.ndarray, y: np.ndarray, factor_names: list[str], maximize: bool) -> dict:
    """Range (extreme-difference) analysis of one response.

    Parameters
    ----------
    levels : ndarray (runs, factors)
        1-based level numbers (1).
    y : ndarray (runs,)
        Response per run (any unit; the level means carry it).
    factor_names : list of str
        Names of the factors, one per column of ``levels``.
    maximize : bool
        Whether larger is better.

    Returns
    -------
    dict
        Per factor: K (sums K_ij of y at level j), level_means (k_ij = K_ij / n_j), range
        R_i = max_j k_ij - min_j k_ij, best_level (1-based); and ``ranking``: factors by decreasing R.

    Notes
    -----
    In an orthogonal array every level of a factor meets every level of every other factor equally often,
    so k_ij estimates the factor's main effect free of the others (e.g. Taguchi, *System of Experimental
    Design*, 1987; Montgomery, *Design and Analysis of Experiments*, ch. 8).
    """
    out = {"factors": {}, "ranking": []}
    for j, name in enumerate(factor_names):
        lv = levels[:, j]
        ks = sorted(np.unique(lv))
        K = [float(np.sum(y[lv == k])) for k in ks]
        k = [float(np.mean(y[lv == k])) for k in ks]
        best = int(ks[int(np.argmax(k) if maximize else np.argmin(k))])
        out["factors"][name] = {"K": K, "level_means": k, "range": float(max(k) - min(k)), "best_level": best}
    out["ranking"] = sorted(factor_names, key=lambda n: -out["factors"][n]["range"])
    return out


def composite_score(responses: dict[str, np.ndarray], senses: dict[str, bool], weights: dict[str, float]) -> np.ndarray:
    """Weighted comprehensive score per run: sum_i w_i d_i, d_i the response scaled to 0..1 over the runs
    (1 = best: (y - min)/(max - min) for a maximised response, (max - y)/(max - min) for a minimised one).

    This is the "comprehensive scoring" used with orthogonal tests when indexes conflict; the weights
    (normalised to sum to 1) encode the priority (the study: efficiency > damage > unripe shedding).

    Parameters
    ----------
    responses : dict name -> ndarray (runs,)
        Response values per run (any unit: each is scaled to 0..1).
    senses : dict name -> bool
        True where larger is better.
    weights : dict name -> float
        Priority of each response (1; normalised to sum to 1).

    Returns
    -------
    ndarray (runs,)
        The score per run, 0..1 (1), 1 = best in every weighted response.
    """
    total = sum(weights.values())
    if total <= 0:
        raise ConfigError("weights must sum to a positive number")
    score = np.zeros(len(next(iter(responses.values()))))
    for name, y in responses.items():
        w = weights.get(name, 0.0) / total
        span = float(np.max(y) - np.min(y))
        d = np.full_like(y, 0.5) if span == 0 else ((y - y.min()) / span if senses[name] else (y.max() - y) / span)
        score += w * d
    return score


def anova_pooled(levels: np.ndarray, y: np.ndarray, factor_names: list[str]) -> dict:
    """Main-effect ANOVA (statsmodels OLS + anova_lm); if no error degrees of freedom remain (a saturated
    array such as L9 with four 3-level factors), the factor with the smallest sum of squares is pooled
    into the error, as is usual practice (Taguchi; Roy, *A Primer on the Taguchi Method*, ch. 6).

    Parameters
    ----------
    levels : ndarray (runs, factors)
        1-based level numbers (1).
    y : ndarray (runs,)
        Response per run (any unit; sums of squares in its square).
    factor_names : list of str
        Names of the factors, one per column of ``levels``.

    Returns
    -------
    dict
        ``factors`` (per tested factor ss, df, ms, f, p), ``error`` {ss, df, ms}, ``pooled`` (the factors pooled
        into the error), ``ss_all`` (every factor's sum of squares) and ``total_ss``.
    """
    import statsmodels.formula.api as smf
    from statsmodels.stats.anova import anova_lm

    internal = {f: f"x{i}" for i, f in enumerate(factor_names)}  # formula-safe names ('C' is patsy's)
    df = pd.DataFrame(levels.astype(int), columns=factor_names)
    df["y"] = y
    n = len(y)
    dof = {f: len(np.unique(df[f])) - 1 for f in factor_names}
    # sums of squares of main effects (orthogonal: additive)
    ybar = y.mean()
    ss = {f: float(sum(np.sum(df[f] == k) * (y[df[f] == k].mean() - ybar) ** 2 for k in np.unique(df[f])))
          for f in factor_names}
    pooled = []
    terms = list(factor_names)
    if sum(dof.values()) >= n - 1:
        weakest = min(terms, key=lambda f: ss[f])
        pooled.append(weakest)
        terms.remove(weakest)
    if not terms:
        raise ConfigError("nothing left to test after pooling")
    dfi = df.rename(columns=internal)
    formula = "y ~ " + " + ".join(f"C({internal[f]})" for f in terms)
    fit = smf.ols(formula, data=dfi).fit()
    table = anova_lm(fit, typ=1)
    rows = {}
    for f in terms:
        r = table.loc[f"C({internal[f]})"]
        rows[f] = {"ss": float(r["sum_sq"]), "df": int(r["df"]), "ms": float(r["mean_sq"]),
                   "f": float(r["F"]), "p": float(r["PR(>F)"])}
    err = table.loc["Residual"]
    return {"factors": rows, "error": {"ss": float(err["sum_sq"]), "df": int(err["df"]),
                                       "ms": float(err["mean_sq"])},
            "pooled": pooled, "ss_all": ss, "total_ss": float(np.sum((y - ybar) ** 2))}


def factor_levels_report(factor_names: list[str], levels: np.ndarray,
                         level_values: dict[str, tuple[float, ...] | None] | None = None,
                         units: dict[str, str] | None = None) -> dict:
    """Per factor: level numbers, level values (or None when not known) and unit, for reports.

    Level numbers are never passed off as values: without known values ``values`` is None and
    ``label`` reads "level 1", "level 2", ...

    Parameters
    ----------
    factor_names : list of str
        Names of the factors, one per column of ``levels``.
    levels : ndarray (runs, factors)
        1-based level numbers (1).
    level_values : dict factor -> tuple of float or None, optional
        Value of each level in the factor's unit (its units as ``units`` says).
    units : dict factor -> str, optional
        Unit of each factor ('' for none).

    Returns
    -------
    dict
        Per factor ``level_numbers``, ``values`` (None when unknown), ``unit`` and ``labels``.
    """
    out = {}
    for j, f in enumerate(factor_names):
        nums = sorted(int(v) for v in np.unique(np.asarray(levels)[:, j]))
        vals = (level_values or {}).get(f)
        unit = (units or {}).get(f, "")
        if vals is not None:
            labels = [f"{v:g} {unit}".strip() for v in vals]
        else:
            labels = [f"level {k}" for k in nums]
        out[f] = {"level_numbers": nums, "values": list(vals) if vals is not None else None, "unit": unit,
                  "labels": labels}
    return out


def quadratic_terms(names: list[str]) -> list[str]:
    """Terms of the study's eq. 19: intercept, linear, squares, two-factor interactions (15 for four factors).

    Parameters
    ----------
    names : list of str
        Factor names.

    Returns
    -------
    list of str
        "1", the names, "<name>^2" and "<a>*<b>".
    """
    terms = ["1"] + list(names) + [f"{n}^2" for n in names] + [f"{a}*{b}" for a, b in itertools.combinations(names, 2)]
    return terms


def _design_matrix(x: np.ndarray, names: list[str], terms: list[str]) -> np.ndarray:
    cols = []
    for t in terms:
        if t == "1":
            cols.append(np.ones(len(x)))
        elif t.endswith("^2"):
            cols.append(x[:, names.index(t[:-2])] ** 2)
        elif "*" in t:
            a, b = t.split("*")
            cols.append(x[:, names.index(a)] * x[:, names.index(b)])
        else:
            cols.append(x[:, names.index(t)])
    return np.column_stack(cols)


def quadratic_regression(x: np.ndarray, y: np.ndarray, names: list[str]) -> dict:
    """The study's eq. 19 (full quadratic in the factors) handled honestly.

    * Reports the rank of the full quadratic model's design matrix at the test points: with nine runs
      at most nine of its fifteen coefficients can be estimated; which ones are aliased is stated.
    * Fits the largest identifiable hierarchy, the main-effects quadratic model (intercept + linear +
      squares: 9 coefficients for four 3-level factors), by least squares, with R^2 and residual degrees
      of freedom (0 for L9: it interpolates the data and carries no error estimate).
    * Fits the full eq. 19 as a ridge-regularised model (penalty chosen by leave-one-out
      cross-validation on centred and scaled terms), clearly labelled as regularised: its coefficients
      are shrunk, not estimated.

    Parameters
    ----------
    x : ndarray (runs, factors)
        Factor values of the runs (their units; scaled to -1..1 inside).
    y : ndarray (runs,)
        Response per run (any unit).
    names : list of str
        Factor names, one per column of ``x``.

    Returns
    -------
    dict
        ``full_model_terms``, ``full_model_rank``, ``aliased_terms``, ``main_effects_quadratic`` (terms,
        coefficients on the scaled factors, r2, residual_df), ``ridge_full`` (the regularised fit) and
        ``_scaling`` (lo, span per factor, for :func:`predict_main_quadratic`).
    """
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    n = len(y)
    full = quadratic_terms(names)
    # scale factors to -1..1 for conditioning, keep the transformation for the report
    lo, hi = x.min(axis=0), x.max(axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    xs = 2 * (x - lo) / span - 1
    X = _design_matrix(xs, names, full)
    rank = int(np.linalg.matrix_rank(X, tol=1e-9))
    # which terms are estimable: greedy independent subset in hierarchical order
    est, cols = [], []
    for j, t in enumerate(full):
        trial = cols + [j]
        if np.linalg.matrix_rank(X[:, trial], tol=1e-9) == len(trial):
            cols = trial
            est.append(t)
    aliased = [t for t in full if t not in est]
    main_q = ["1"] + list(names) + [f"{n_}^2" for n_ in names]
    Xm = _design_matrix(xs, names, main_q)
    beta, *_ = np.linalg.lstsq(Xm, y, rcond=None)
    fitted = Xm @ beta
    resid_df = n - np.linalg.matrix_rank(Xm)
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    r2 = 1.0 - float(np.sum((y - fitted) ** 2)) / ss_tot if ss_tot > 0 else 1.0
    # ridge on the full model (intercept unpenalised), LOO-CV over a grid of penalties
    Xc = X[:, 1:]
    mu, sd = Xc.mean(axis=0), Xc.std(axis=0)
    sd[sd == 0] = 1.0
    Z = (Xc - mu) / sd
    yc = y - y.mean()
    best = None
    # hat matrix H = Z (Z'Z + lam I)^-1 Z' = U diag(s^2 / (s^2 + lam)) U' from the thin SVD of Z: its
    # diagonal and H y cost O(n p), never the n x n matrix (a 100,000-row sheet would need 80 GB)
    U, sv, _ = np.linalg.svd(Z, full_matrices=False)
    U2 = U**2
    Uty = U.T @ yc
    for lam in np.logspace(-4, 3, 36):
        shrink = sv**2 / (sv**2 + lam)
        h = U2 @ shrink
        loo = (yc - U @ (shrink * Uty)) / (1 - h + 1.0 / n)
        score = float(np.mean(loo**2))
        if best is None or score < best[0]:
            best = (score, lam)
    lam = best[1]
    b = np.linalg.solve(Z.T @ Z + lam * np.eye(Z.shape[1]), Z.T @ yc)
    coef_ridge = {"1": float(y.mean() - np.sum(b * mu / sd))}
    coef_ridge.update({t: float(bi / s) for t, bi, s in zip(full[1:], b, sd)})
    fit_r = y.mean() + Z @ b
    r2_r = 1.0 - float(np.sum((y - fit_r) ** 2)) / ss_tot if ss_tot > 0 else 1.0
    return {
        "coded_factors": {nm: {"low": float(l), "high": float(h)} for nm, l, h in zip(names, lo, hi)},
        "coding": "each factor coded to -1..1 between its lowest and highest level",
        "full_model_terms": full,
        "runs": n,
        "full_model_rank": rank,
        "identifiable": rank == len(full),
        "estimable_terms": est,
        "aliased_terms": aliased,
        "main_effects_quadratic": {
            "terms": main_q,
            "coefficients": {t: float(c) for t, c in zip(main_q, beta)},
            "r2": r2,
            "residual_df": int(resid_df),
            "note": ("saturated: interpolates the data, no error estimate" if resid_df == 0 else ""),
        },
        "ridge_full_quadratic": {
            "label": "REGULARISED (ridge) full eq. 19: coefficients are shrunk, not estimated",
            "penalty": float(lam),
            "coefficients": coef_ridge,
            "r2": r2_r,
            "loo_mse": best[0],
        },
        "_scaling": (lo.tolist(), span.tolist()),
    }


def predict_main_quadratic(reg: dict, x: np.ndarray, names: list[str]) -> np.ndarray:
    """Predict a response from the main-effects quadratic fit of :func:`quadratic_regression` at points ``x``.

    Parameters
    ----------
    reg : dict
        :func:`quadratic_regression` output (with ``_scaling``).
    x : ndarray (points, factors)
        Factor values (the units of the fit's ``x``).
    names : list of str
        Factor names, as in the fit.

    Returns
    -------
    ndarray (points,)
        Predicted response (the unit of the fit's ``y``).
    """
    lo, span = (np.array(v) for v in reg["_scaling"])
    xs = 2 * (np.atleast_2d(x) - lo) / span - 1
    mq = reg["main_effects_quadratic"]
    X = _design_matrix(xs, names, mq["terms"])
    return X @ np.array([mq["coefficients"][t] for t in mq["terms"]])


def check_weights(weights: dict[str, float] | None, responses) -> dict[str, float]:
    """Weights of the composite, checked: every name an analysed response, every weight finite and > 0.

    None gives every response the weight 1.  Responses without a weight do not enter the composite.

    Parameters
    ----------
    weights : dict name -> float or None
        Priority of each response (1).
    responses : iterable of str
        The analysed responses.

    Returns
    -------
    dict name -> float
        The weights normalised to sum to 1 (1).
    """
    names = list(responses)
    if weights is None:
        weights = {r: 1.0 for r in names}
    if not weights:
        raise ConfigError(f"--weights is empty; give NAME=VALUE for some of {', '.join(names)}")
    unknown = [k for k in weights if k not in names]
    if unknown:
        raise ConfigError(f"--weights names {sorted(unknown)}, which are not analysed responses; valid: "
                          f"{', '.join(names)}")
    clean = {}
    for k, v in weights.items():
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise ConfigError(f"--weights: {k}={v!r} is not a number") from None
        if not np.isfinite(x) or x <= 0:
            raise ConfigError(f"--weights: {k}={v!r}: a weight must be a finite number > 0 (leave a response out "
                              "of --weights to give it no weight)")
        clean[k] = x
    total = float(sum(clean.values()))
    return {k: x / total for k, x in clean.items()}


def check_inputs(levels: np.ndarray, factor_names: list[str], responses: dict, senses: dict[str, bool]) -> None:
    """Shapes, finiteness and senses of an analysis' inputs (ConfigError naming the problem).

    Parameters
    ----------
    levels : ndarray (runs, factors)
        1-based level numbers (1).
    factor_names : list of str
        Names of the factors, one per column of ``levels``.
    responses : dict name -> ndarray (runs,) or (runs, replicates)
        Response values (any unit).
    senses : dict name -> bool
        True where larger is better; one per response.
    """
    levels = np.asarray(levels)
    if not responses:
        raise ConfigError("no response to analyse; name one with --maximize or --minimize")
    if levels.ndim != 2 or levels.shape[1] != len(factor_names):
        raise ConfigError(f"levels must be runs x {len(factor_names)} factors, got shape {levels.shape}")
    missing = [r for r in responses if r not in senses]
    if missing:
        raise ConfigError(f"responses {missing} have no sense; add them to --maximize or --minimize")
    unknown = [r for r in senses if r not in responses]
    if unknown:
        raise ConfigError(f"unknown response(s) {unknown} in --maximize/--minimize; valid: {', '.join(responses)}")
    for name, y in responses.items():
        y = np.asarray(y, float)
        if y.shape[0] != levels.shape[0]:
            raise ConfigError(f"response {name!r} has {y.shape[0]} runs, the design {levels.shape[0]}")
        if not np.isfinite(y).all():
            i = int(np.argwhere(~np.isfinite(y))[0][0])
            raise ConfigError(f"response {name!r}, run {i + 1}: value is not finite ({y.reshape(len(y), -1)[i]})")


def analyze(levels: np.ndarray, values: np.ndarray, factor_names: list[str], responses: dict[str, np.ndarray],
            senses: dict[str, bool], weights: dict[str, float] | None = None,
            level_values: dict[str, tuple[float, ...] | None] | None = None,
            units: dict[str, str] | None = None) -> DoeAnalysis:
    """Full analysis of a field (or virtual) orthogonal test; the JSON of ``doe analyze``.

    ``level_values`` / ``units`` (optional, e.g. from :class:`FieldResults`) are reported under
    ``factors`` (value and unit per level number) and ``optimum.settings``; a factor whose values are
    unknown is reported with ``values: null`` and "level N" labels, never as if the numbers were values.
    Weights are checked (:func:`check_weights`), as are the responses' shapes and senses.

    Parameters
    ----------
    levels : ndarray (runs, factors)
        1-based level numbers (1).
    values : ndarray (runs, factors)
        Factor values (their units) for the eq. 19 regression.
    factor_names : list of str
        Names of the factors, one per column.
    responses : dict name -> ndarray (runs,)
        Response per run (any unit).
    senses : dict name -> bool
        True where larger is better.
    weights : dict name -> float, optional
        Priority of the responses in the composite score (1); default equal.
    level_values : dict factor -> tuple of float or None, optional
        Level values (the factor's units).
    units : dict factor -> str, optional
        Unit per factor.

    Returns
    -------
    DoeAnalysis
        ``responses`` (per response the range analysis, ``anova`` with pooling, ``regression``), ``weights``,
        ``factors`` (:func:`factor_levels_report`), ``composite`` and ``optimum`` (levels, settings, predicted
        values, prediction method); :mod:`berryshaker.experiment.analysis_records`.
    """
    check_inputs(levels, factor_names, responses, senses)
    weights_n = check_weights(weights, responses)
    weights = weights_n
    out = {"responses": {}, "weights": weights_n,
           "factors": factor_levels_report(factor_names, levels, level_values, units)}
    for name, y in responses.items():
        ra = range_analysis(levels, y, factor_names, senses[name])
        ra["maximize"] = senses[name]
        ra["best_levels"] = {f: ra["factors"][f]["best_level"] for f in factor_names}
        ra["anova"] = anova_pooled(levels, y, factor_names)
        ra["regression"] = quadratic_regression(values, y, factor_names)
        ra["regression"].pop("_scaling")
        out["responses"][name] = ra
    score = composite_score(responses, senses, weights)
    comp = range_analysis(levels, score, factor_names, True)
    out["composite"] = {"method": "weighted sum of responses scaled 0..1 (1 = best), range analysis of the score",
                        "score": score.tolist(), **comp}
    opt_levels = {f: comp["factors"][f]["best_level"] for f in factor_names}
    # predicted responses at the optimum from the additive main-effects model
    values_at = {}
    for name, y in responses.items():
        ybar = float(np.mean(y))
        pred = ybar + sum(out["responses"][name]["factors"][f]["level_means"][opt_levels[f] - 1] - ybar
                          for f in factor_names)
        values_at[name] = pred
    labels = {f: d["labels"][d["level_numbers"].index(opt_levels[f])] for f, d in out["factors"].items()}
    out["optimum"] = {"levels": opt_levels, "settings": labels, "values": values_at,
                      "prediction": "additive main-effects model: mean + sum of level-mean deviations"}
    # the record made at one place from the dict the steps above build and read by key (validated: a key that is
    # not a field, or a missing one, is an error)
    return DoeAnalysis.from_json(out)


# ---- effects, residuals and interactions as Minitab draws them -------------------------------------------------
def _observations(levels: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Levels per observation (runs x replicates flattened, run by run) and the observations; lost plots (NaN) left
    out."""
    y = np.asarray(y, float)
    levels = np.asarray(levels, int)
    r = 1 if y.ndim == 1 else y.shape[1]
    lv, obs = np.repeat(levels, r, axis=0), y.reshape(-1)
    keep = ~np.isnan(obs)  # a lost plot (NaN) is no observation
    return (lv, obs) if keep.all() else (lv[keep], obs[keep])


def polynomial_contrasts(n_per_level) -> np.ndarray:
    """Orthogonal polynomial contrasts of k equally spaced levels (rows: linear, quadratic, ... order k - 1).

    Orthogonal in the metric sum_j a_j b_j / n_j of level means with n_j observations each, so the contrasts' sums
    of squares add up to the factor's; each row sums to zero.  For 3 equally replicated levels: (-1, 0, 1) and
    (1, -2, 1), scaled.

    Parameters
    ----------
    n_per_level : sequence of int
        Observations at each level (1).

    Returns
    -------
    ndarray (k - 1, k)
        The contrasts (1), each scaled so that sum_j c_j^2 / n_j = 1.
    """
    n = np.asarray(n_per_level, float)
    k = len(n)
    x = np.arange(1, k + 1, dtype=float)
    basis = [np.ones(k)]
    out = []
    for order in range(1, k):
        v = x**order
        for b in basis:
            v = v - (np.sum(v * b * n) / np.sum(b * b * n)) * b  # orthogonal to lower orders, weighted by n_j
        basis.append(v)
        c = v * n  # a contrast of the level means: sum_j c_j = sum_j n_j v_j = 0
        out.append(c / np.sqrt(np.sum(c**2 / n)))
    return np.array(out)


def lenth_pse(estimates) -> float:
    """Lenth's pseudo standard error of contrast estimates of equal standard error (Lenth 1989): s0 = 1.5 median
    |c|, PSE = 1.5 median of the |c| below 2.5 s0.  Minitab's error for an unreplicated design without error dof.

    Parameters
    ----------
    estimates : array_like
        Contrast estimates (any unit, the same for all).

    Returns
    -------
    float
        The pseudo standard error (same units as the estimates).
    """
    c = np.abs(np.asarray(estimates, float))
    s0 = 1.5 * np.median(c)
    small = c[c < 2.5 * s0]
    return float(1.5 * np.median(small)) if small.size else float(s0)


def standardized_effects(levels: np.ndarray, y: np.ndarray, factor_names: list[str], error_ms: float | None,
                         error_df: int | None, alpha: float = 0.05,
                         factor_errors: dict[str, tuple[float, int]] | None = None) -> dict:
    """Standardized effects of an orthogonal test: every factor's orthogonal polynomial contrasts (linear, quadratic,
    ...) as t statistics, for a Pareto chart of standardized effects.

    Parameters
    ----------
    levels : ndarray (runs, factors)
        1-based level numbers (1).
    y : ndarray (runs,) or (runs, replicates)
        Observations (any unit; estimates carry it, t is dimensionless).
    factor_names : list of str
        Names of the factors, one per column of ``levels``.
    error_ms, error_df : float, int
        The error the analysis tests against (the pooled ANOVA error, or the replicated / blocked error); without
        degrees of freedom (or a zero mean square) Lenth's pseudo standard error of the contrasts is used, with
        m / 3 degrees of freedom for m contrasts.
    alpha : float
        Significance level of the reference line t(1 - alpha/2, df).
    factor_errors : dict of str to (float, int), optional
        Per factor the error its own test uses (a blocked analysis: its interaction with the blocks; mean square in
        the unit of y squared, dof): its contrasts are standardized by it, so the chart's verdicts are the ANOVA's.

    Returns
    -------
    dict
        ``terms``: per contrast ``term`` ("A (linear)"; a 2-level factor just "A"), ``factor``, ``order``,
        ``estimate`` (contrast of the level means, unit of y), ``se``, ``t``, ``p``, ``significant``; ``error``
        {ms, df, method}; ``critical_t``; ``alpha``.  The squared t of a factor's contrasts sum to df x F of its
        ANOVA row against the same error.
    """
    from scipy import stats

    lv, obs = _observations(levels, y)
    rows = []
    for j, f in enumerate(factor_names):
        ks = sorted(int(v) for v in np.unique(lv[:, j]))
        means = np.array([obs[lv[:, j] == k].mean() for k in ks])
        n = np.array([np.sum(lv[:, j] == k) for k in ks], float)
        for order, c in enumerate(polynomial_contrasts(n), start=1):
            kind = {1: "linear", 2: "quadratic", 3: "cubic"}.get(order, f"order {order}")
            name = f if len(ks) == 2 else f"{f} ({kind})"
            rows.append({"term": name, "factor": f, "order": order, "estimate": float(c @ means),
                         "scale": float(np.sqrt(np.sum(c**2 / n)))})  # 1 by construction
    have_error = error_ms is not None and error_df and np.isfinite(error_ms) and error_ms > 0
    if have_error:
        ms, df, method = float(error_ms), int(error_df), "ANOVA error"
        se = np.sqrt(ms)
    else:
        se = lenth_pse([r["estimate"] for r in rows])
        ms, df, method = se**2, max(1, len(rows) // 3), "Lenth's pseudo standard error (no error degrees of freedom)"
    dfs = [df]
    for r in rows:
        r.pop("scale")
        own = (factor_errors or {}).get(r["factor"])
        s_r, df_r = (float(np.sqrt(own[0])), int(own[1])) if own and own[1] and own[0] > 0 else (se, df)
        dfs.append(df_r)
        r["se"] = float(s_r)
        r["t"] = float(r["estimate"] / s_r) if s_r > 0 else (float("inf") if r["estimate"] else 0.0)
        r["p"] = float(2 * stats.t.sf(abs(r["t"]), df_r))
        r["significant"] = bool(r["p"] < alpha)
    if factor_errors:
        method = "each factor's own error (its interaction with the blocks)"
    return {"terms": rows, "error": {"ms": ms, "df": df, "method": method},
            "critical_t": float(stats.t.ppf(1 - alpha / 2, min(dfs[1:] or dfs))), "alpha": alpha}


def main_effect_residuals(levels: np.ndarray, y: np.ndarray, factor_names: list[str], terms: list[str] | None = None,
                          blocks: bool = False) -> dict:
    """Fitted values and residuals of the additive main-effects model the analysis tests (grand mean + the level
    effects of ``terms``, default every factor; + block effects with ``blocks``: replicate k of every run in block k).

    Parameters
    ----------
    levels : ndarray (runs, factors)
        1-based level numbers (1).
    y : ndarray (runs,) or (runs, replicates)
        Observations (any unit; fitted values and residuals carry it).
    factor_names : list of str
        Names of the factors, one per column of ``levels``.
    terms : list of str, optional
        Factors in the model (an unreplicated analysis leaves its pooled factor out: it is the error).
    blocks : bool
        Add the block effects (columns of a 2-D ``y``).

    Returns
    -------
    dict
        ``fitted``, ``residuals`` (one per observation, run by run), ``ss`` (sum of squared residuals: the error and
        lack-of-fit sums of squares of the analysis), ``normal_quantiles`` and ``sorted_residuals`` (Blom's plotting
        positions (i - 3/8) / (n + 1/4) for a normal probability plot).
    """
    from scipy import stats

    y = np.asarray(y, float)
    lv, obs = _observations(levels, y)
    grand = obs.mean()
    fitted = np.full_like(obs, grand)
    for j, f in enumerate(factor_names):
        if terms is not None and f not in terms:
            continue
        for k in np.unique(lv[:, j]):
            sel = lv[:, j] == k
            fitted[sel] += obs[sel].mean() - grand
    if blocks and y.ndim == 2:
        fitted += np.tile(y.mean(axis=0) - grand, y.shape[0])
    res = obs - fitted
    n = len(res)
    q = stats.norm.ppf((np.arange(1, n + 1) - 0.375) / (n + 0.25))
    return {"fitted": fitted, "residuals": res, "ss": float(np.sum(res**2)), "normal_quantiles": q,
            "sorted_residuals": np.sort(res)}


def interaction_means(levels: np.ndarray, y: np.ndarray, factor_names: list[str]) -> dict:
    """Mean response at every combination of levels of every pair of factors (interaction plots).

    Parameters
    ----------
    levels : ndarray (runs, factors)
        1-based level numbers (1).
    y : ndarray (runs,) or (runs, replicates)
        Observations (any unit; the means carry it).
    factor_names : list of str
        Names of the factors, one per column of ``levels``.

    Returns
    -------
    dict
        ``"A x B"`` -> {"factors": (A, B), "levels": (levels of A, levels of B), "means": array (levels of A,
        levels of B), NaN where the combination was not run, "n": observations per cell}.
    """
    lv, obs = _observations(levels, y)
    out = {}
    for i, j in itertools.combinations(range(len(factor_names)), 2):
        ka, kb = np.unique(lv[:, i]), np.unique(lv[:, j])
        means = np.full((len(ka), len(kb)), np.nan)
        count = np.zeros((len(ka), len(kb)), int)
        for a_, a in enumerate(ka):
            for b_, b in enumerate(kb):
                sel = (lv[:, i] == a) & (lv[:, j] == b)
                count[a_, b_] = int(sel.sum())
                if sel.any():
                    means[a_, b_] = obs[sel].mean()
        out[f"{factor_names[i]} x {factor_names[j]}"] = {"factors": (factor_names[i], factor_names[j]),
                                                         "levels": (ka.tolist(), kb.tolist()), "means": means,
                                                         "n": count}
    return out
