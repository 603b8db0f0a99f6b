"""How many replicates sample the noise: convergence of a spread in the number of starts, and sequential
replication to a standard-error target.

A replicate here is one independent draw of what varies between repeats of the same setting (in the virtual
harvest: the start of the machine in its clearances, the drive phase at which the comb meets the bush, the
population of bushes; in a field test: the row, the day).  Its spread is a *result* that needs converging like any
other: the sample standard deviation of n replicates has a sampling error of its own, about s / sqrt(2 (n - 1)) for
normal data and more for heavy tails,

    SE(s) ~= s / 2 sqrt(2 / (n - 1) + g2 / n)                                  (delta method on Var(s^2))

with g2 the excess kurtosis (Ahn, S. and Fessler, J. A. (2003), "Standard errors of mean, variance, and standard
deviation estimators", EECS Department, University of Michigan, eq. 9 and the delta method of sec. 4).  Three
replicates know their SD only to about +-50 %; the default count is where the SD is known to the tolerance of
:data:`SD_RELATIVE_ERROR` and neither it nor the mean moves beyond its own sampling error as more replicates come
(:func:`spread_convergence`).
"""

from __future__ import annotations

import math

import numpy as np

from berryshaker.errors import ConfigError

#: the largest relative sampling error of a replicate SD at which the spread counts as known (one standard error
#: of s over s): at 0.30 the SD of n >= 7 normal replicates; the default count of starts is chosen by it
SD_RELATIVE_ERROR = 0.30
#: replicate counts of the convergence table (nested: the first n of the largest count's replicates)
CONVERGENCE_COUNTS = (4, 8, 16, 32)


def sd_standard_error(x, kurtosis: float | None = None) -> float:
    """Sampling standard error of the sample standard deviation (ddof 1) of ``x``.

    Parameters
    ----------
    x : array_like
        Replicate values (at least 2), in any unit.
    kurtosis : float, optional
        Excess kurtosis g2 of the population (dimensionless); default the sample's own (scipy.stats.kurtosis, bias-corrected,
        0 for fewer than 4 values).  Give a better-founded value (from more replicates) when you have one.

    Returns
    -------
    float
        SE(s) = s / 2 sqrt(2 / (n - 1) + g2 / n) (module docstring; Ahn and Fessler 2003), in the unit of x.
    """
    from scipy import stats

    x = np.asarray(x, float)
    n = x.size
    if n < 2:
        raise ConfigError(f"a standard deviation needs at least 2 replicates, got {n}")
    s = float(np.std(x, ddof=1))
    g2 = kurtosis
    if g2 is None:
        g2 = float(stats.kurtosis(x, bias=False)) if n >= 4 and s > 0 else 0.0
    g2 = max(float(g2), -2.0 + 1e-9)  # the excess kurtosis of any distribution is >= -2
    return 0.5 * s * math.sqrt(max(2.0 / (n - 1) + g2 / n, 0.0))


def spread_convergence(samples: dict[str, np.ndarray], counts=CONVERGENCE_COUNTS,
                       sd_relative_error: float = SD_RELATIVE_ERROR, floors: dict[str, float] | None = None) -> dict:
    """Mean and spread of each response against the number of replicates, and the smallest count where they
    are stable.

    Parameters
    ----------
    samples : dict name -> ndarray (N,)
        Independent replicates of each response at one setting, in the order they were drawn (the first n of
        them are the n-replicate estimate).
    counts : sequence of int
        Replicate counts to tabulate (each >= 2; those above N are left out).
    sd_relative_error : float
        Largest SE(s) / s at which the spread counts as known.
    floors : dict name -> float, optional
        Resolution of a response (its unit): one whose N-replicate mean is below it by two standard errors
        (|mean_N| + 2 SE_N <= floor; a rare event such as one unripe berry shed in 32 starts) is ``negligible``
        and left out of the choice, as a constant one is.

    Returns
    -------
    dict
        ``table``: per response, per count n: ``mean``, ``se`` (s / sqrt n), ``sd``, ``sd_se``
        (:func:`sd_standard_error`, with the excess kurtosis of all N replicates), ``sd_relative_error``,
        ``mean_stable`` (|mean_n - mean_N| <= 2 se_n), ``sd_stable`` (|s_n - s_N| <= 2 SE(s_n)) and ``stable``
        (both, and SE(s_n) / s_n <= ``sd_relative_error``); a response whose replicates are all equal is
        ``constant`` and one below its floor ``negligible`` (no spread to converge, left out of the choice); ``chosen``: the smallest count at which every
        non-constant response is stable (None if none is); ``counts``, ``replicates`` (N), ``rule``.
    """
    from scipy import stats

    if not samples:
        raise ConfigError("spread_convergence: no responses given")
    arrays = {k: np.asarray(v, float) for k, v in samples.items()}
    N = min(v.size for v in arrays.values())
    counts = sorted({int(c) for c in counts if 2 <= int(c) <= N})
    if not counts:
        raise ConfigError(f"spread_convergence: {N} replicates; give counts between 2 and {N}")
    table: dict[str, dict] = {}
    constant: list[str] = []
    for name, v in arrays.items():
        v = v[:N]
        if not np.all(np.isfinite(v)):
            raise ConfigError(f"spread_convergence: response {name!r} has non-finite replicates")
        if np.ptp(v) == 0:
            constant.append(name)
        g2 = float(stats.kurtosis(v, bias=False)) if N >= 4 and np.ptp(v) > 0 else 0.0
        m_all, s_all = float(v.mean()), float(v.std(ddof=1))
        rows = {}
        for n in counts:
            x = v[:n]
            m, s = float(x.mean()), float(x.std(ddof=1))
            se, sse = s / math.sqrt(n), sd_standard_error(x, g2)
            rel = sse / s if s > 0 else 0.0
            mean_ok = abs(m - m_all) <= 2 * se or (s == 0 and m == m_all)
            sd_ok = abs(s - s_all) <= 2 * sse or s == s_all
            rows[n] = {"mean": m, "se": se, "sd": s, "sd_se": sse, "sd_relative_error": rel,
                       "mean_stable": bool(mean_ok), "sd_stable": bool(sd_ok),
                       "stable": bool(mean_ok and sd_ok and rel <= sd_relative_error)}
        negligible = name not in constant and abs(m_all) + 2 * s_all / math.sqrt(N) <= float(
            (floors or {}).get(name, -1.0))
        table[name] = {"rows": rows, "excess_kurtosis": g2, "constant": name in constant, "negligible": negligible,
                       "nonzero": int(np.count_nonzero(v))}
    judged = [k for k in table if not table[k]["constant"] and not table[k]["negligible"]]
    chosen = next((n for n in counts if all(table[k]["rows"][n]["stable"] for k in judged)), None)
    rule = (f"the smallest count at which, for every response that varies, the SD's own sampling error is at most "
            f"{100 * sd_relative_error:g} % (SE(s) = s/2 sqrt(2/(n-1) + g2/n), g2 the excess kurtosis of all {N} "
            f"replicates) and neither the mean nor the SD differs from its {N}-replicate value by more than 2 of its "
            "standard errors")
    if floors:
        rule += "; a response whose mean lies below its resolution (" + ", ".join(
            f"{k} {v:g}" for k, v in floors.items()) + ") by two standard errors is negligible and not judged"
    return {"table": table, "counts": counts, "replicates": N, "chosen": chosen, "constant": constant,
            "negligible": [k for k in table if table[k]["negligible"]], "rule": rule,
            "sd_relative_error": sd_relative_error}


def family_agreement(families: dict[str, dict[str, np.ndarray]], confidence: float = 0.95) -> dict:
    """Whether independent seed families give the same spread: per response, each family's SD with its sampling
    error, the first family's SD over the others' pooled SD with its F interval, and Levene's test of equal
    variances (scipy.stats.levene, median-centred: Brown and Forsythe 1974, robust to heavy tails).

    Parameters
    ----------
    families : dict of str to dict of str to numpy.ndarray
        Family label -> response -> independent replicates (any unit); the first family is the one judged.
    confidence : float
        Confidence of the ratio's interval.

    Returns
    -------
    dict
        ``responses``: per response ``sd`` (per family), ``sd_se``, ``n``, ``ratio`` (first / pooled others),
        ``ratio_ci``, ``levene_p`` and ``agree`` (Levene p >= 1 - confidence); ``families`` (labels), ``rule``.
    """
    from scipy import stats

    labels = list(families)
    if len(labels) < 2:
        raise ConfigError("family_agreement: give at least two seed families")
    out = {}
    for name in families[labels[0]]:
        xs = [np.asarray(families[f][name], float) for f in labels]
        xs = [x[np.isfinite(x)] for x in xs]
        sds = [float(np.std(x, ddof=1)) for x in xs]
        rest = np.concatenate([x - x.mean() for x in xs[1:]])
        df1, df2 = xs[0].size - 1, rest.size - (len(xs) - 1)
        pooled = float(np.sqrt(np.sum(rest**2) / df2)) if df2 > 0 else float("nan")
        ratio = sds[0] / pooled if pooled > 0 else float("nan")
        a = 1 - confidence
        ci = [ratio / math.sqrt(stats.f.ppf(1 - a / 2, df1, df2)), ratio / math.sqrt(stats.f.ppf(a / 2, df1, df2))]
        lev = float(stats.levene(*xs, center="median").pvalue) if all(np.ptp(x) > 0 for x in xs) else float("nan")
        out[name] = {"sd": dict(zip(labels, sds)), "sd_se": {f: sd_standard_error(x) for f, x in zip(labels, xs)},
                     "n": {f: int(x.size) for f, x in zip(labels, xs)}, "ratio": ratio,
                     "ratio_ci": [float(c) for c in ci], "levene_p": lev,
                     "agree": bool(not (lev < 1 - confidence))}
    return {"responses": out, "families": labels, "rule": (
        f"a family agrees when Levene's test (median-centred) of equal variances across the families gives p >= "
        f"{1 - confidence:g}; the ratio is the first family's SD over the pooled SD of the others, with its "
        f"{100 * confidence:g} % F interval")}


def standard_error_reached(samples: dict[str, np.ndarray], relative: float, floors: dict[str, float] | None = None
                           ) -> dict:
    """Whether the mean of each response is known to its target: SE = s / sqrt(n) <= max(relative |mean|, floor).

    Parameters
    ----------
    samples : dict name -> ndarray (n,)
        Replicates at one setting (n >= 2), each response in its unit.
    relative : float
        Target standard error as a fraction of the mean's magnitude.
    floors : dict name -> float, optional
        Absolute floor of a response's target (its unit), for means near zero (a rate of 0.1 %).

    Returns
    -------
    dict
        Per response ``mean``, ``se``, ``target``, ``met`` over its finite replicates (fewer than two: ``undefined``,
        not judged); ``all_met``.
    """
    floors = floors or {}
    out, ok = {}, True
    for name, v in samples.items():
        v = np.asarray(v, float)
        if v.size < 2:
            raise ConfigError(f"standard_error_reached: {name!r} has {v.size} replicate(s); need >= 2")
        v = v[np.isfinite(v)]  # an index undefined for a replicate (a rate of nothing picked) tells nothing
        if v.size < 2:
            out[name] = {"mean": float("nan"), "se": float("nan"), "target": float("nan"), "met": True,
                         "undefined": True}
            continue
        m, se = float(v.mean()), float(v.std(ddof=1) / math.sqrt(v.size))
        target = max(relative * abs(m), float(floors.get(name, 0.0)))
        met = bool(se <= target)
        ok &= met
        out[name] = {"mean": m, "se": se, "target": target, "met": met}
    return {"responses": out, "all_met": bool(ok), "relative": relative, "replicates": int(
        min(np.asarray(v).size for v in samples.values()))}


def describe_convergence(res: dict, units: dict[str, str] | None = None) -> str:
    """Plain-text table of :func:`spread_convergence`: mean +- SE and SD +- SE(SD) per response and count.

    Parameters
    ----------
    res : dict
        The result of :func:`spread_convergence`.
    units : dict name -> str, optional
        Unit of each response, printed beside its values.

    Returns
    -------
    str
        The table, one line per response and count, and the chosen count.
    """
    units = units or {}
    lines = [f"Replicates: {res['replicates']}; rule: {res['rule']}."]
    for name, t in res["table"].items():
        u = f" {units[name]}" if units.get(name) else ""
        if t["constant"]:
            lines.append(f"{name}: constant over every replicate ({t['rows'][res['counts'][0]]['mean']:.4g}{u}): no "
                         "spread to converge")
            continue
        if t["negligible"]:
            last = t["rows"][res["counts"][-1]]
            lines.append(f"{name}: negligible, {last['mean']:.3g} +- {last['se']:.2g}{u} over {res['replicates']} "
                         f"replicates (non-zero in {t['nonzero']}): below its resolution, not judged")
            continue
        lines.append(f"{name}{u} (excess kurtosis {t['excess_kurtosis']:.2f}):")
        for n, r in t["rows"].items():
            lines.append(f"  n = {n:>3}: mean {r['mean']:.4g} +- {r['se']:.2g}, SD {r['sd']:.4g} +- {r['sd_se']:.2g} "
                         f"({100 * r['sd_relative_error']:.0f} %) {'stable' if r['stable'] else 'not yet'}")
    lines.append("chosen: " + (f"{res['chosen']} replicates" if res["chosen"] else "none of the counts is stable"))
    return "\n".join(lines)


__all__ = ["CONVERGENCE_COUNTS", "SD_RELATIVE_ERROR", "describe_convergence", "sd_standard_error",
           "spread_convergence", "standard_error_reached"]
