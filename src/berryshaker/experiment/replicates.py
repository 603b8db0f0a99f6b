"""Analysis of a replicated orthogonal test: effects judged against their own noise.

Each run of the design is repeated ``r`` times (field repeats, or simulations with different plant
populations / perturbed initial states).  The spread of the repeats of one run is *pure error*: it
measures the noise without assuming any model.  With ``n`` runs it has ``n (r - 1)`` degrees of freedom
(9 (r - 1) for an L9), so every main effect can be F-tested even when the main effects use up all the
between-run degrees of freedom (a saturated L9 with four 3-level factors, where the unreplicated analysis
has to pool a factor into the error).

Methods (Montgomery, *Design and Analysis of Experiments*, 8th ed., 2013: sec. 3.3 ANOVA F test, 3.5.7
Tukey's test, and the lack-of-fit test against pure error of its regression chapter; Taguchi's effective
number of replications for the prediction interval of an additive model, e.g. Roy, *A Primer on the
Taguchi Method*, 1990):

* sums of squares of the main effects from statsmodels OLS (``y ~ C(A) + C(B) + ...`` on all
  observations, ``anova_lm``; the array is orthogonal, so sequential = partial sums of squares);
* F = MS_factor / MS_pure_error with (k - 1, n (r - 1)) degrees of freedom, p from scipy's F
  distribution; an effect is *significant* only if p < alpha;
* level means with standard error sqrt(MS_E / N_level) (N_level observations at the level; MS_E the pure error, or
  with blocks the run x block interaction: then an interval for comparing levels, not for a level's absolute mean) and
  t-intervals; the range R (best minus worst level mean) with a Tukey-Kramer simultaneous interval
  (studentized range; it stays valid although the extreme pair is picked after seeing the data);
* lack of fit (between-run variation the main effects do not explain) tested against pure error when
  the design leaves degrees of freedom for it.

The weighted optimum never ranks noise: a response enters the choice of a factor's level only if that
factor's effect on it is significant; the scaling of a response (to combine it with others) is its
range of run means over the whole design, fixed per response, so a noise-sized level difference is not
stretched to 0..1 as a min-max scaling of each factor's level means would.  Levels whose composite
score is within the Tukey-Kramer margin of the best are reported as not distinguishable from it.

long module: the ANOVA, its error terms (pure or blocked), the level comparisons and the tiered optimum read each
other's intermediate results; split, every half would import the other.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from berryshaker.errors import ConfigError
from berryshaker.experiment.analysis import check_inputs, check_weights, factor_levels_report, quadratic_regression
from berryshaker.experiment.error_terms import (
    _tukey_half_width,
    block_variance,
    error_term,
    factor_error,
    paired_differences,
    pure_error,
    sphericity_epsilon,
)
from berryshaker.experiment.replicated_records import ReplicatedAnalysis


def _main_effect_ss(levels: np.ndarray, y: np.ndarray, factor_names: list[str]) -> tuple[dict, float, int]:
    """Main-effect sums of squares from statsmodels OLS on all observations; residual SS and dof."""
    import statsmodels.formula.api as smf
    from statsmodels.stats.anova import anova_lm

    n, r = y.shape
    internal = [f"x{i}" for i in range(len(factor_names))]
    long = pd.DataFrame(np.repeat(levels.astype(int), r, axis=0), columns=internal)
    long["y"] = y.reshape(-1)
    fit = smf.ols("y ~ " + " + ".join(f"C({c})" for c in internal), data=long).fit()
    table = anova_lm(fit, typ=1)
    ss = {f: (float(table.loc[f"C({c})", "sum_sq"]), int(table.loc[f"C({c})", "df"]))
          for f, c in zip(factor_names, internal)}
    return ss, float(table.loc["Residual", "sum_sq"]), int(round(table.loc["Residual", "df"]))


def replicated_anova(levels: np.ndarray, y: np.ndarray, factor_names: list[str], alpha: float = 0.05,
                     confidence: float = 0.95, blocks: bool = False) -> dict:
    """Main-effect ANOVA and level statistics of one replicated response.

    Parameters
    ----------
    levels : ndarray (runs, factors)
        1-based level numbers of an orthogonal array (dimensionless).
    y : ndarray (runs, replicates)
        Observations (any unit); at least 2 replicates.
    factor_names : list of str
        Names of the factors (columns of ``levels``).
    alpha : float
        Significance level (dimensionless): an effect is significant only if p < alpha.
    confidence : float
        Level of the intervals (dimensionless; 0.95: 95 %).
    blocks : bool
        Replicate k of every run shares block k (the same start, field day or row): each factor is tested against
        its own interaction with the blocks (:func:`factor_block_error`) instead of the pure error, and every
        factor's level pairs get paired differences (:func:`paired_differences`), beyond the noise only where the
        factor's own test is significant (one verdict per factor).

    Returns
    -------
    dict
        ``pure_error`` {ss, df, ms}: the spread of each run's replicates (block included); ``error`` {ss, df, ms,
        kind}: the pooled error (the pure error, or the run x block interaction: the sum of the factors' own
        interactions in a saturated array); ``blocks`` (:func:`block_variance`, or None); ``lack_of_fit`` {ss, df,
        ms, f, p} (df 0 when saturated); ``factors``: per factor ss, df, ms, f, p, significant, ``error`` (what it
        is tested against), level_means, level_se (for comparisons between levels), level_ci, range, range_ci
        (Tukey-Kramer, for the difference of the extreme levels), hsd (Tukey-Kramer half-width of a level
        difference), ``paired`` (with blocks) and the levels.
    """
    from scipy import stats

    levels = np.asarray(levels)
    y = np.asarray(y, float)
    n, r = y.shape
    ss_pe, df_pe = pure_error(y)
    ss_e, df_e = error_term(y, blocks)
    ms_e = ss_e / df_e if df_e else float("nan")
    ss, ss_res, df_res = _main_effect_ss(levels, y, factor_names)
    if blocks:  # the blocks take r - 1 degrees of freedom and their sum of squares out of the residual
        bv = block_variance(y)
        ss_res -= bv["ms_block"] * bv["df_block"]
        df_res -= bv["df_block"]
    ss_lof, df_lof = max(ss_res - ss_e, 0.0), df_res - df_e
    total = float(np.sum((y - y.mean()) ** 2))
    factors = {}
    for j, f in enumerate(factor_names):
        ssf, dff = ss[f]
        msf = ssf / dff
        ss_ef, df_ef = factor_error(levels[:, j], y, blocks)
        ms_ef = ss_ef / df_ef if df_ef else float("nan")
        eps = sphericity_epsilon(levels[:, j], y) if blocks else 1.0
        t = float(stats.t.ppf(0.5 + confidence / 2, df_ef)) if df_ef else float("nan")
        if ms_ef > 0:
            F = msf / ms_ef
            p = float(stats.f.sf(F, eps * dff, eps * df_ef))  # Greenhouse-Geisser degrees of freedom
        else:  # identical replicates: no noise estimate; an effect larger than round-off counts as real
            real = ssf > 1e-12 * max(total, 1e-300)
            F, p = (float("inf"), 0.0) if real else (float("nan"), 1.0)
        ks = sorted(int(v) for v in np.unique(levels[:, j]))
        means, ses, cis, nobs = [], [], [], []
        for k in ks:
            obs = y[levels[:, j] == k]
            m = float(obs.mean())
            se = float(np.sqrt(ms_ef / obs.size))
            means.append(m)
            ses.append(se)
            cis.append([m - t * se, m + t * se])
            nobs.append(obs.size)
        hi, lo = int(np.argmax(means)), int(np.argmin(means))
        R = means[hi] - means[lo]
        hw = _tukey_half_width(ms_ef, df_ef, len(ks), nobs[hi], nobs[lo], confidence)
        paired = None
        if blocks:  # one verdict per factor: a pair is beyond the noise only where the factor's own test is
            paired = [dict(q, beyond_noise=bool(q["beyond_noise"] and p < alpha))
                      for q in paired_differences(levels[:, j], y, confidence)]
        own = (f"its own interaction with the blocks ({f} x block; Greenhouse-Geisser epsilon {eps:.3g})" if blocks
               else "pure error (replicates)")
        factors[f] = {"ss": ssf, "df": dff, "ms": msf, "f": float(F), "p": p, "significant": bool(p < alpha),
                      "error": {"ss": ss_ef, "df": df_ef, "ms": ms_ef, "kind": own},
                      "levels": ks, "level_means": means, "level_se": ses, "level_ci": cis, "range": R,
                      "range_ci": [R - hw, R + hw], "hsd": hw, "n_per_level": nobs, "paired": paired}
    lof = {"ss": ss_lof, "df": int(df_lof), "ms": ss_lof / df_lof if df_lof > 0 else float("nan")}
    if df_lof > 0 and ms_e > 0:
        lof["f"] = lof["ms"] / ms_e
        lof["p"] = float(stats.f.sf(lof["f"], df_lof, df_e))
    kind = ("run x block interaction (replicate k of every run shares block k)" if blocks
            else "pure error (replicates)")
    return {"pure_error": {"ss": ss_pe, "df": df_pe, "ms": ss_pe / df_pe},
            "error": {"ss": ss_e, "df": df_e, "ms": ms_e, "kind": kind},
            "blocks": block_variance(y) if blocks else None, "lack_of_fit": lof, "factors": factors,
            "total_ss": total, "replicates": r, "runs": n}


def _best(means: list[float], maximize: bool) -> int:
    return int(np.argmax(means) if maximize else np.argmin(means))


def analyze_replicated(levels: np.ndarray, values: np.ndarray, factor_names: list[str],
                       responses_replicated: dict[str, np.ndarray], senses: dict[str, bool],
                       weights: dict[str, float] | None = None, *, alpha: float = 0.05, confidence: float = 0.95,
                       level_values: dict[str, tuple[float, ...] | None] | None = None,
                       units: dict[str, str] | None = None, fallback_weights: dict[str, float] | None = None,
                       blocks: bool = False) -> ReplicatedAnalysis:
    """Analysis of a replicated orthogonal test, with every effect judged against the replicate noise.

    Parameters
    ----------
    levels : ndarray (runs, factors)
        1-based level numbers (dimensionless).
    values : ndarray (runs, factors)
        Level values in each factor's unit (``units``), for the eq. 19 regression of the run means.
    factor_names : list of str
        Names of the factors (columns of ``levels``).
    responses_replicated : dict name -> ndarray (runs, replicates)
        Observations in each response's unit; at least 2 replicates, the same number for every response.
    senses : dict name -> bool
        True where larger is better.
    weights : dict name -> float, optional
        Priority of the responses (dimensionless, > 0, normalised); default equal.
    alpha : float
        An effect is significant only if its p-value < alpha (dimensionless).
    confidence : float
        Level of the intervals (dimensionless).
    level_values, units : dict, optional
        Level values and units per factor (reported, see :func:`factor_levels_report`).
    fallback_weights : dict name -> float, optional
        Weights (dimensionless) of second-tier responses (e.g. machine loads when the primary ones are harvest
        indexes): they decide a factor's level only where the weighted (primary) responses show no significant
        difference, or cannot tell the best levels apart (:data:`TIERED_RULE`).
    blocks : bool
        Replicate k of every run shares block k (common random numbers in a simulation: the same start for
        every run; a field day or a row of bushes in a field test): effects are judged against the run x block
        interaction (randomised complete blocks, :func:`block_error`), and each factor's levels are compared
        by paired differences (:func:`paired_differences`).  Without blocks, against the pure error.

    Returns
    -------
    ReplicatedAnalysis
        ``significance_rule`` (the rule in words); per response (``responses``): range analysis of the
        run means (``factors`` with level_means, level_ci, range, range_ci, best_level, significant,
        verdict), ``anova`` (F and p against pure error, pure error and lack of fit), ``regression`` (eq.
        19 on the run means); ``optimum``: per factor a chosen level with its reason, or level None with
        "no meaningful difference", and the predicted response means with intervals.
    """
    if not 0 < alpha < 1 or not 0 < confidence < 1:
        raise ConfigError("alpha and confidence must lie between 0 and 1")
    levels = np.asarray(levels)
    values = np.asarray(values, float)
    reps = {}
    for name, y in responses_replicated.items():
        y = np.asarray(y, float)
        if y.ndim != 2:
            raise ConfigError(f"response {name!r}: replicated values must be an array (runs, replicates), got "
                              f"shape {y.shape}")
        reps[name] = y
    check_inputs(levels, factor_names, reps, senses)
    shapes = {y.shape for y in reps.values()}
    if len(shapes) > 1:
        raise ConfigError(f"responses have different shapes {sorted(shapes)}; every response needs the same "
                          "runs x replicates")
    n, r = next(iter(shapes))
    if r < 2:
        raise ConfigError("a replicated analysis needs at least 2 replicates per run (use analyze() for a single "
                          "replicate, which pools the weakest factor into the error)")
    w = check_weights(weights, reps)
    if blocks:
        err = (f"the factor's own interaction with the blocks ({n} runs x {r} blocks, replicate k of every run in block "
               f"k: (levels - 1) x {r - 1} degrees of freedom per factor, Greenhouse-Geisser corrected; block effects "
               "cancel, and a factor whose effect varies from block to block is judged against that variation, not "
               "a pool of all factors')")
    else:
        err = f"the pure (replicate) error, {n} runs x {r} replicates = {n * (r - 1)} degrees of freedom"
    rule = (f"an effect is significant only if p < {alpha:g} (F test of the factor mean square against {err}); "
            f"otherwise the levels show no meaningful difference. Intervals: {100 * confidence:g} % (level means: t, "
            "for comparisons between levels; range: Tukey-Kramer, simultaneous over all level pairs"
            + ("; paired differences: Student t over the blocks" if blocks else "") + ").")
    out = {"significance_rule": rule, "alpha": alpha, "confidence": confidence, "runs": n, "replicates": r,
           "blocks": bool(blocks),
           "weights": w, "factors": factor_levels_report(factor_names, levels, level_values, units),
           "responses": {}}
    notes = []
    for name, y in reps.items():
        an = replicated_anova(levels, y, factor_names, alpha, confidence, blocks)
        mx = senses[name]
        if an["error"]["ms"] == 0 and an["pure_error"]["ms"] > 0:
            notes.append(f"{name}: zero run x block interaction (the starts shift every run alike); effects are "
                         "exact for this model, not judged against noise")
        elif an["error"]["ms"] == 0:
            notes.append(f"{name}: the replicates are identical (zero pure error); effects are exact for this "
                         "model, not judged against noise - check that the replicates vary the seed")
        fac = {}
        for f, d in an["factors"].items():
            b = _best(d["level_means"], mx)
            best_val = d["level_means"][b]
            within = [d["levels"][i] for i, m in enumerate(d["level_means"])
                      if abs(best_val - m) <= d["hsd"] or not np.isfinite(d["hsd"])]
            fac[f] = {**{k: d[k] for k in ("level_means", "level_se", "level_ci", "range", "range_ci", "hsd",
                                           "significant", "p", "paired")},
                      "K": [m * c for m, c in zip(d["level_means"], d["n_per_level"])],
                      "best_level": d["levels"][b], "best_levels_within_noise": within,
                      "verdict": (f"level {d['levels'][b]} best" if d["significant"] else "no meaningful difference")}
        ranking = sorted(factor_names, key=lambda f: -fac[f]["range"])
        run_means = y.mean(axis=1)
        reg = quadratic_regression(values, run_means, factor_names)
        reg.pop("_scaling")
        out["responses"][name] = {
            "maximize": mx, "factors": fac, "ranking": ranking, "run_means": run_means.tolist(),
            "run_sd": y.std(axis=1, ddof=1).tolist(),
            "best_levels": {f: fac[f]["best_level"] for f in factor_names},
            "significant_factors": [f for f in factor_names if fac[f]["significant"]],
            "anova": {"factors": {f: {k: an["factors"][f][k] for k in ("ss", "df", "ms", "f", "p", "significant",
                                                                       "error")}
                                  for f in factor_names},
                      "error": an["error"], "blocks": an["blocks"],
                      "pure_error": an["pure_error"], "lack_of_fit": an["lack_of_fit"], "pooled": [],
                      "total_ss": an["total_ss"]},
            "regression": reg,
        }
    out["optimum"] = _weighted_optimum(levels, factor_names, reps, senses, w, out, alpha, confidence, blocks)
    if fallback_weights:
        wf = check_weights(fallback_weights, reps)
        out["fallback_weights"] = wf
        fb = _weighted_optimum(levels, factor_names, reps, senses, wf, out, alpha, confidence, blocks)
        out["optimum"] = _tiered_optimum(out["optimum"], fb, factor_names, reps, out, confidence)
    out["notes"] = notes
    return ReplicatedAnalysis.from_json(out)  # the record, at one place: the optimum above reads the dict by key


def _weighted_optimum(levels, factor_names, reps, senses, w, out, alpha, confidence, blocks=False) -> dict:
    """Per factor: a level chosen from the responses it significantly affects, or no meaningful difference."""
    n, r = next(iter(reps.values())).shape
    scale = {}
    for name, y in reps.items():
        m = y.mean(axis=1)
        scale[name] = float(m.max() - m.min())
    choices: dict = {}
    chosen: dict = {}
    for j, f in enumerate(factor_names):
        sig = [name for name in reps if name in w and scale[name] > 0
               and out["responses"][name]["factors"][f]["significant"]]
        pvals = {name: out["responses"][name]["factors"][f]["p"] for name in reps}
        labels = out["factors"][f]["labels"]
        nums = out["factors"][f]["level_numbers"]
        if not sig:
            reason = (f"no response differs significantly between the levels of {f} ("
                      + ", ".join(f"{name}: p = {p:.3g}" for name, p in pvals.items()) + f", rule p < {alpha:g})")
            choices[f] = {"level": None, "setting": None, "status": "no meaningful difference", "reason": reason,
                          "significant_responses": [], "equivalent_levels": nums}
            chosen[f] = None
            continue
        # composite per observation over the responses this factor significantly affects
        z = sum((w[name] * (1.0 if senses[name] else -1.0) / scale[name]) * reps[name] for name in sig)
        ss_pe, df_pe = factor_error(levels[:, j], z, blocks)
        ms = ss_pe / df_pe
        ks = sorted(int(v) for v in np.unique(levels[:, j]))
        means = [float(z[levels[:, j] == k].mean()) for k in ks]
        nobs = [int(z[levels[:, j] == k].size) for k in ks]
        b = int(np.argmax(means))
        equivalent = [ks[i] for i in range(len(ks)) if i == b or
                      means[b] - means[i] <= _tukey_half_width(ms, df_pe, len(ks), nobs[b], nobs[i], confidence)]
        parts = []
        for name in reps:
            fr = out["responses"][name]["factors"][f]
            if name in sig:
                lm = ", ".join(f"{v:.4g}" for v in fr["level_means"])
                parts.append(f"{name} differs (p = {pvals[name]:.3g}; level means {lm}; "
                             f"{'max' if senses[name] else 'min'}imised best at level {fr['best_level']})")
            elif name in w:
                parts.append(f"{name}: no significant difference (p = {pvals[name]:.3g}), not used")
        status = "chosen"
        if len(equivalent) > 1:
            status = "chosen; not distinguishable from level(s) " + ", ".join(
                str(k) for k in equivalent if k != ks[b])
        choices[f] = {"level": ks[b], "setting": labels[nums.index(ks[b])], "status": status,
                      "reason": "; ".join(parts), "significant_responses": sig, "equivalent_levels": equivalent,
                      "composite_level_means": means}
        chosen[f] = ks[b]
    pred, intervals = _predict(factor_names, reps, out, chosen, confidence)
    return {"levels": chosen, "settings": {f: c["setting"] for f, c in choices.items()}, "choices": choices,
            "values": pred, "intervals": intervals, "weights": w,
            "method": ("per factor, a weighted sum of the responses whose effect of that factor is significant, each "
                       "signed (+ maximise, - minimise) and divided by its range of run means over the design; "
                       "responses without a significant effect contribute nothing"),
            "prediction": PREDICTION_RULE}


PREDICTION_RULE = ("additive model: grand mean + level-mean deviations of the factors significant for the response at "
                   "the chosen levels (others averaged); interval from the error over Taguchi's effective number of "
                   "replications N / (1 + dof of the factors used), plus, with blocks, the block variance over the "
                   "number of blocks (dof by Satterthwaite)")


def _predict(factor_names, reps, out, chosen, confidence) -> tuple[dict, dict]:
    """Predicted response means at the chosen levels (``None``: the factor is averaged) with intervals."""
    from scipy import stats

    # predicted response means at the choice: additive model over the factors significant for the response
    pred, intervals = {}, {}
    for name, y in reps.items():
        ra = out["responses"][name]
        grand = float(y.mean())
        used = [f for f in factor_names if chosen[f] is not None and ra["factors"][f]["significant"]]
        val = grand + sum(ra["factors"][f]["level_means"][out["factors"][f]["level_numbers"].index(chosen[f])] - grand
                          for f in used)
        dof_used = sum(len(out["factors"][f]["level_numbers"]) - 1 for f in used)
        n_eff = y.size / (1 + dof_used)
        e, bl = ra["anova"]["error"], ra["anova"].get("blocks")
        var, dof = e["ms"] / n_eff, e["df"]
        if bl is not None and bl["ms_block"] > e["ms"]:
            # the blocks (starts) are shared: their spread does not average out over the runs, only over the r
            # blocks; var = sigma^2 / n_eff + sigma_beta^2 / r, dof by Satterthwaite (1946)
            n_all = y.size
            c1, c2 = e["ms"] * (1 / n_eff - 1 / n_all), bl["ms_block"] / n_all
            var = c1 + c2
            dof = var**2 / (c1**2 / e["df"] + c2**2 / bl["df_block"])
        t = float(stats.t.ppf(0.5 + confidence / 2, dof))
        hw = t * float(np.sqrt(var))
        pred[name] = float(val)
        intervals[name] = [float(val - hw), float(val + hw)]
    return pred, intervals


TIERED_RULE = ("two tiers, never ranking noise: per factor, the primary responses (weighted) whose effect of that factor "
               "is significant choose the level; where they cannot tell several levels apart (Tukey-Kramer) or no "
               "primary response differs significantly, the fallback responses that do differ significantly decide "
               "(among the primary's indistinguishable levels, or among all levels); where nothing differs "
               "significantly the factor is 'no meaningful difference' (level None). Each tier's composite divides a "
               "response by its range of run means over the whole design (fixed per response), so a noise-sized "
               "level difference is never stretched to full weight, and a response without a significant effect of "
               "the factor has weight zero for it")


def _tiered_optimum(primary: dict, fallback: dict, factor_names, reps, out, confidence) -> dict:
    """Merge a primary and a fallback :func:`_weighted_optimum` per factor (:data:`TIERED_RULE`)."""
    choices: dict = {}
    chosen: dict = {}
    for f in factor_names:
        p, s = primary["choices"][f], fallback["choices"][f]
        if p["level"] is not None:
            eq = p["equivalent_levels"]
            if len(eq) > 1 and s["level"] is not None:
                ks = sorted(int(v) for v in out["factors"][f]["level_numbers"])
                means = s["composite_level_means"]
                best = max(eq, key=lambda k: means[ks.index(k)])
                c = dict(p, level=best, setting=out["factors"][f]["labels"][ks.index(best)], tier="primary + fallback",
                         status=(f"primary responses cannot tell levels {', '.join(map(str, eq))} apart; the fallback "
                                 f"responses choose level {best} among them"),
                         reason=p["reason"] + " | fallback: " + s["reason"])
            else:
                c = dict(p, tier="primary")
        elif s["level"] is not None:
            c = dict(s, tier="fallback",
                     status=f"primary responses do not differ; fallback responses choose: {s['status']}",
                     reason="primary: " + p["reason"] + " | fallback: " + s["reason"])
        else:
            c = dict(p, tier="none", reason="primary: " + p["reason"] + " | fallback: " + s["reason"])
        choices[f] = c
        chosen[f] = c["level"]
    pred, intervals = _predict(factor_names, reps, out, chosen, confidence)
    return {"levels": chosen, "settings": {f: c["setting"] for f, c in choices.items()}, "choices": choices,
            "values": pred, "intervals": intervals, "weights": primary["weights"],
            "fallback_weights": fallback["weights"], "method": TIERED_RULE, "prediction": PREDICTION_RULE,
            "primary": {k: primary[k] for k in ("levels", "choices")},
            "fallback": {k: fallback[k] for k in ("levels", "choices")}}


def describe_replicated(res: ReplicatedAnalysis) -> str:
    """Plain-text summary of :func:`analyze_replicated` (rule, per-response table, optimum with reasons).

    Parameters
    ----------
    res : ReplicatedAnalysis
        The result of :func:`analyze_replicated`.

    Returns
    -------
    str
        The summary, one line per item.
    """
    lines = [f"Significance rule: {res.significance_rule}"]
    for name, ra in res.responses.items():
        pe, e, blocked = ra.anova.pure_error, ra.anova.error, bool(ra.anova.blocks)
        head = f"{name} ({'maximise' if ra.maximize else 'minimise'}); replicate SD {pe.ms ** 0.5:.4g} ({pe.df} dof)"
        if blocked:
            head += f"; blocked error SD {e.ms ** 0.5:.4g} ({e.df} dof)"
        lines.append(head)
        for f, d in ra.factors.items():
            a = ra.anova.factors[f]
            lm = ", ".join(f"{m:.4g} [{lo:.4g}, {hi:.4g}]" for m, (lo, hi) in zip(d.level_means, d.level_ci))
            against = f" against {f} x block ({a.error.df} dof)" if blocked and a.error is not None else ""
            lines.append(f"  {f}: R = {d.range:.4g} [{d.range_ci[0]:.4g}, {d.range_ci[1]:.4g}], F = {a.f:.3g}{against}, "
                         f"p = {a.p:.3g} -> {d.verdict}; level means {lm}"
                         + (" (intervals for comparing levels: the starts' shared luck left out)" if blocked else ""))
            if d.paired:
                lines.append("     paired: " + "; ".join(
                    f"{f}{q.levels[1]} - {f}{q.levels[0]} = {q.difference:+.4g} +- {q.se:.2g} (SE, p = {q.p:.2g})"
                    for q in d.paired))
    lines.append("Weighted choice:")
    for f, c in res.optimum.choices.items():
        if c.level is None:
            what = c.status
        elif c.setting == f"level {c.level}":
            what = f"{c.setting}, {c.status}"
        else:
            what = f"{c.setting} (level {c.level}), {c.status}"
        lines.append(f"  {f}: {what}: {c.reason}")
    for name, v in res.optimum.values.items():
        lo, hi = res.optimum.intervals[name]
        lines.append(f"  predicted {name}: {v:.4g} [{lo:.4g}, {hi:.4g}]")
    lines.extend(f"Note: {n}" for n in res.notes)
    return "\n".join(lines)


#: significance level of level-to-level comparisons (Welch's t-test over the replicates, :func:`replicate_trend`)
TREND_ALPHA = 0.05


def replicate_trend(samples: list[list[float]], alpha: float = TREND_ALPHA) -> dict:
    """Is a response growing from one level to the next, beyond the spread of its replicates?

    Parameters
    ----------
    samples : list of lists
        Replicate values of the response at each level, in level order (at least 2 per level).
    alpha : float
        Significance level (dimensionless) of each two-sided Welch t-test (scipy.stats.ttest_ind, unequal variances) between
        consecutive levels.

    Returns
    -------
    dict
        ``mean``, ``sd`` (ddof 1) per level; ``steps``: per consecutive pair the difference, its p-value and
        ``"up"``, ``"down"`` or ``"no difference"`` (p >= alpha: within the replicate noise); ``grows``: every
        step is a significant rise.

    References
    ----------
    Welch, B. L. (1947). The generalization of "Student's" problem when several different population variances
    are involved. Biometrika 34, 28-35.
    """
    from scipy import stats

    x = [np.asarray(v, float) for v in samples]
    if len(x) < 2 or any(v.size < 2 or not np.all(np.isfinite(v)) for v in x):
        raise ConfigError("replicate_trend: give at least two levels, each with at least two finite replicate "
                          f"values (got {[v.size for v in x]} values per level)")
    steps = []
    for a, b in zip(x, x[1:]):
        p = float(stats.ttest_ind(b, a, equal_var=False).pvalue) if (np.ptp(a) > 0 or np.ptp(b) > 0) else (
            0.0 if b.mean() != a.mean() else 1.0)
        d = float(b.mean() - a.mean())
        steps.append({"difference": d, "p": p, "verdict": ("up" if d > 0 else "down") if p < alpha else "no difference"})
    return {"mean": [float(v.mean()) for v in x], "sd": [float(v.std(ddof=1)) for v in x], "steps": steps,
            "grows": all(s["verdict"] == "up" for s in steps), "alpha": alpha}


__all__ = ["analyze_replicated", "describe_replicated", "replicated_anova", "replicate_trend"]
