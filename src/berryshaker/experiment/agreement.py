"""Agreement between two simulated curves: the study's F statistic (eq. 18) and plainer measures."""

from __future__ import annotations

import numpy as np
from scipy import integrate, stats


def f_statistic(a, b):
    """Study eq. 18: F_xy = [sum (a_i - a_mean)^2 / sum (b_j - b_mean)^2] * (b_max^2 / a_max^2).

    Parameters
    ----------
    a, b : array_like
        Samples of the two curves in one unit, any (the study: a = multibody/ADAMS, b = MLSD/MATLAB, N).

    Returns
    -------
    float
        The ratio of the two curves' variations, each normalised by its own peak (dimensionless).

    Notes
    -----
    The sums are not divided by the sample counts; with equally many points (as here) this is the ratio
    of peak-normalised sample variances, compared with an F(m-1, n-1) critical value.  With hundreds of
    points any small difference becomes "significant"; the study used about ten points per curve (its
    critical values 3.09-3.20 are F_0.95 with about 9-10 degrees of freedom each).
    """
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    sa = np.sum((a - a.mean()) ** 2)
    sb = np.sum((b - b.mean()) ** 2)
    amax, bmax = np.max(np.abs(a)), np.max(np.abs(b))
    if sb == 0 or amax == 0:
        return float("inf")
    return float(sa / sb * (bmax**2 / amax**2))


def f_critical(m: int, n: int, alpha: float = 0.05) -> float:
    """Upper critical value of the F distribution with (m-1, n-1) degrees of freedom (scipy.stats).

    Parameters
    ----------
    m, n : int
        Sample counts of the two curves.
    alpha : float
        Significance level (dimensionless).

    Returns
    -------
    float
        F_(1-alpha)(m-1, n-1) (dimensionless).
    """
    return float(stats.f.ppf(1.0 - alpha, m - 1, n - 1))


#: relative tolerance on the statistics of two impact-force series for "agree" (our criterion; eq. 18 alone
#: passes on noise, see :func:`eq18_passes_on_noise`)
STATISTICS_TOLERANCE = {"mean": 0.10, "rms": 0.15, "p95": 0.20, "impulse_per_revolution": 0.10}


def impact_statistics(t, f, period: float | None = None) -> dict:
    """Statistics of a collision-force series that suit chaotic impact dynamics: mean, RMS, 95th percentile (N)
    and the impulse per drive revolution (N s; the time integral of |F| over one period, averaged).

    Parameters
    ----------
    t : array_like
        Times (s).
    f : array_like
        Force (N); its magnitude is used.
    period : float, optional
        Drive period (s); default the series' span.

    Returns
    -------
    dict
        ``mean``, ``rms``, ``p95`` (N) and ``impulse_per_revolution`` (N s).
    """
    t = np.asarray(t, float)
    f = np.abs(np.asarray(f, float))
    span = float(t[-1] - t[0]) or 1.0
    impulse = float(integrate.trapezoid(f, t))
    per = impulse / span * (period if period else span)
    return {"mean": float(f.mean()), "rms": float(np.sqrt(np.mean(f**2))), "p95": float(np.percentile(f, 95)),
            "impulse_per_revolution": per}


def statistics_agreement(t, a, b, period: float | None = None, tolerance: dict | None = None) -> dict:
    """Do two force series agree in the statistics an engineer uses (mean, RMS, p95, impulse per revolution)?

    Each relative difference |a - b| / max(|a|, |b|) must be within its tolerance
    (:data:`STATISTICS_TOLERANCE`).

    Parameters
    ----------
    t : array_like
        Common times (s).
    a, b : array_like
        The two force series on ``t`` (N).
    period : float, optional
        Drive period (s), for the impulse per revolution.
    tolerance : dict, optional
        Overrides of :data:`STATISTICS_TOLERANCE` (relative, dimensionless).

    Returns
    -------
    dict
        ``a`` and ``b`` (:func:`impact_statistics`), ``relative_difference``, ``tolerance`` and ``agree``.
    """
    tol = dict(STATISTICS_TOLERANCE, **(tolerance or {}))
    sa, sb = impact_statistics(t, a, period), impact_statistics(t, b, period)
    diff = {k: abs(sa[k] - sb[k]) / max(abs(sa[k]), abs(sb[k]), 1e-300) for k in sa}
    return {"a": sa, "b": sb, "relative_difference": diff, "tolerance": tol,
            "agree": bool(all(diff[k] <= tol[k] for k in tol))}


#: statistics of a run summary's collision force that model agreement judges (the impulse per revolution is the
#: mean times the period: it agrees exactly when the mean does and is not judged twice)
SUMMARY_STATISTICS = ("mean", "rms", "p95")
#: two-sided confidence of the noise band of a difference (Student's t with Welch's degrees of freedom: with 8
#: replicates of each model about 2.3 standard errors, 2.0 for many)
NOISE_CONFIDENCE = 0.95


def noise_quantile(sd_a: float, n_a: int, sd_b: float, n_b: int) -> float:
    """Student's t quantile of :data:`NOISE_CONFIDENCE` (two-sided) with the Welch-Satterthwaite degrees of
    freedom of the difference of two means of n_a and n_b runs with standard deviations sd_a and sd_b
    (B. L. Welch, Biometrika 34 (1947) 28-35; scipy.stats.t).  2.0 where neither model spreads (the band is
    zero then anyway).

    Parameters
    ----------
    sd_a, sd_b : float
        Standard deviations of the two models' runs (any unit, the same for both).
    n_a, n_b : int
        Numbers of runs (>= 2).

    Returns
    -------
    float
        The t quantile (dimensionless).
    """
    va, vb = sd_a * sd_a / n_a, sd_b * sd_b / n_b
    if va + vb <= 0.0:
        return 2.0
    dof = (va + vb) ** 2 / (va * va / (n_a - 1) + vb * vb / (n_b - 1))
    return float(stats.t.ppf(0.5 + NOISE_CONFIDENCE / 2.0, dof))


def judged_difference(difference: float, noise: float, tolerance: float) -> str:
    """Verdict on one relative difference against its tolerance, given its noise (the half-width of its
    :data:`NOISE_CONFIDENCE` band, relative): "agree" when even difference + noise is within the tolerance, "differ" when even
    difference - noise exceeds it, else "within noise" (the tolerance lies inside the difference's noise band:
    the runs cannot tell; guide: a difference smaller than the replicates' spread is no difference).

    Parameters
    ----------
    difference : float
        The relative difference (dimensionless).
    noise : float
        Half-width of its noise band (relative, dimensionless).
    tolerance : float
        The tolerance (relative, dimensionless).

    Returns
    -------
    {"agree", "differ", "within noise"}
        The verdict.
    """
    if difference + noise <= tolerance:
        return "agree"
    if difference - noise > tolerance:
        return "differ"
    return "within noise"


def _overall(verdicts) -> str:
    verdicts = list(verdicts)
    return "differ" if "differ" in verdicts else "agree" if all(v == "agree" for v in verdicts) else "within noise"


def summary_statistics_agreement(a: dict, b: dict, tolerance: dict | None = None, noise: dict | None = None) -> dict:
    """Agreement of two run summaries' statistics of one collision force.

    ``a`` and ``b`` hold ``mean``, ``rms`` and ``p95`` (N) over the same revolutions, as the multibody and reduced
    summaries give them.  Each relative difference |a - b| / max(|a|, |b|) must be within
    :data:`STATISTICS_TOLERANCE` (10 / 15 / 20 %).  ``noise`` (optional, per statistic): the relative noise band
    of a difference between two single runs (e.g. :func:`ensemble_agreement`'s ``single_run_noise``); with it each
    statistic gets a :func:`judged_difference` verdict.  Returns ``relative_difference``, ``worst`` (the statistic furthest outside or closest to its
    tolerance), ``verdict`` ("agree", "differ" or "within noise"; without noise "agree" or "differ") and
    ``agree`` (the verdict is "agree").

    Parameters
    ----------
    a, b : dict
        ``mean``, ``rms`` and ``p95`` of the force in each summary (N).
    tolerance : dict, optional
        Overrides of :data:`STATISTICS_TOLERANCE` (relative, dimensionless).
    noise : dict, optional
        Relative noise band of each statistic's difference (dimensionless).

    Returns
    -------
    dict
        ``relative_difference``, ``worst``, ``verdict``, ``agree``; with ``noise``, also ``noise`` and
        ``verdicts`` per statistic.
    """
    tol = {k: v for k, v in dict(STATISTICS_TOLERANCE, **(tolerance or {})).items() if k in SUMMARY_STATISTICS}
    diff = {k: abs(a[k] - b[k]) / max(abs(a[k]), abs(b[k]), 1e-300) for k in tol}
    worst = max(tol, key=lambda k: diff[k] / tol[k])
    band = {k: float((noise or {}).get(k, 0.0)) for k in tol}
    verdicts = {k: judged_difference(diff[k], band[k], tol[k]) for k in tol}
    verdict = _overall(verdicts.values())
    out = {"relative_difference": diff, "worst": worst, "verdict": verdict, "agree": verdict == "agree"}
    if noise is not None:
        out["noise"] = band
        out["verdicts"] = verdicts
    return out


def ensemble_agreement(a_runs: list[dict], b_runs: list[dict], tolerance: dict | None = None) -> dict:
    """Agreement of two models' collision-force statistics over replicates (e.g. perturbed starts of each).

    Each statistic (mean, RMS, p95, N) is averaged over each model's runs; the relative difference of the two
    means, d = |m_a - m_b| / max(m_a, m_b), is judged against :data:`STATISTICS_TOLERANCE` with its noise,
    t sqrt(SE_a^2 + SE_b^2) / max(m_a, m_b) with t of :func:`noise_quantile` (:func:`judged_difference`; the
    relative difference's own standard error is at most that fraction to first order).  One run
    of a chaotic impact sequence is one draw: a verdict on single runs flips with the draw, a
    verdict on these means only when the difference is within its noise, and then it says so.

    Parameters
    ----------
    a_runs, b_runs : list of dict
        Per run, ``mean``, ``rms`` and ``p95`` of the same force (N); at least two runs each.
    tolerance : dict, optional
        Overrides of :data:`STATISTICS_TOLERANCE`.

    Returns
    -------
    dict
        ``a`` / ``b``: per statistic the runs' ``mean``, standard error ``se`` and standard deviation ``sd`` (N)
        and ``n``; ``relative_difference``, ``noise`` (the band, relative), ``tolerance``, ``verdicts`` per
        statistic, ``verdict`` ("differ" if any differs, "agree" if all agree, else "within noise"), ``agree``;
        ``single_run_noise``: the band of a difference between two single runs (t sqrt(SD_a^2 + SD_b^2) / max
        mean), what one run per model can resolve (for :func:`summary_statistics_agreement`; it assumes the runs
        it is applied to spread as these, relative to their level).

    Raises
    ------
    ValueError
        Fewer than two runs of a model (no spread to measure).
    """
    if len(a_runs) < 2 or len(b_runs) < 2:
        raise ValueError(f"ensemble_agreement needs at least two runs of each model, got {len(a_runs)} and "
                         f"{len(b_runs)}")
    tol = {k: v for k, v in dict(STATISTICS_TOLERANCE, **(tolerance or {})).items() if k in SUMMARY_STATISTICS}
    out: dict = {"a": {}, "b": {}, "relative_difference": {}, "noise": {}, "single_run_noise": {}, "tolerance": tol,
                 "verdicts": {}}
    for k in tol:
        stats_k = []
        for side, runs in (("a", a_runs), ("b", b_runs)):
            v = np.array([float(r[k]) for r in runs])
            sd = float(v.std(ddof=1))
            out[side][k] = {"mean": float(v.mean()), "se": sd / np.sqrt(v.size), "sd": sd, "n": int(v.size)}
            stats_k.append(out[side][k])
        sa, sb = stats_k
        scale = max(abs(sa["mean"]), abs(sb["mean"]), 1e-300)
        d = abs(sa["mean"] - sb["mean"]) / scale
        q = noise_quantile(sa["sd"], sa["n"], sb["sd"], sb["n"])
        out["relative_difference"][k] = d
        out["noise"][k] = q * float(np.hypot(sa["se"], sb["se"])) / scale
        out["single_run_noise"][k] = q * float(np.hypot(sa["sd"], sb["sd"])) / scale
        out["verdicts"][k] = judged_difference(d, out["noise"][k], tol[k])
    out["verdict"] = _overall(out["verdicts"].values())
    out["agree"] = out["verdict"] == "agree"
    return out


def model_check(mb_runs: list, reduced_runs: list, pairs) -> dict | None:
    """The model check of claim 1: per pair, :func:`ensemble_agreement` of the multibody and reduced models'
    collision-force statistics over their replicate starts.

    Parameters
    ----------
    mb_runs, reduced_runs : list of dict or None
        Run summaries (``collision_force_N`` per pair: mean, rms, p95 in N) of each model's replicates; None for a
        run that failed (left out).
    pairs : sequence of str
        The clearance pairs.

    Returns
    -------
    dict or None
        ``starts`` (runs per model that ran), ``planned`` (runs per model asked for) and ``pairs`` (per pair
        :func:`ensemble_agreement`); None with fewer than two runs of either model.
    """
    a = [r for r in mb_runs if r is not None]
    b = [r for r in reduced_runs if r is not None]
    if len(a) < 2 or len(b) < 2:
        return None
    return {"starts": {"multibody": len(a), "reduced": len(b)},
            "planned": {"multibody": len(mb_runs), "reduced": len(reduced_runs)},
            "pairs": {p: ensemble_agreement([r["collision_force_N"][p] for r in a],
                                            [r["collision_force_N"][p] for r in b]) for p in pairs}}


def eq18_passes_on_noise(points: int = 10, alpha: float = 0.05, seed: int = 0) -> dict:
    """Show that eq. 18 cannot separate curves: a half-sine pulse train against uniform noise, the same curve
    reversed in time, and the curve divided by 10 all 'agree' by eq. 18 (it compares peak-normalised spreads
    only).  The report shows it beside the study's test.

    Parameters
    ----------
    points : int
        Samples of each curve in the F test.
    alpha : float
        Significance level (dimensionless).
    seed : int
        Seed of the noise.

    Returns
    -------
    dict
        Per case: ``f_statistic``, ``f_critical``, ``eq18_agree`` and ``statistics_agree``.
    """
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, 2001)
    ref = np.abs(np.sin(6 * np.pi * t)) ** 3
    cases = {"uniform noise": rng.uniform(0, 1, t.size), "time-reversed": ref[::-1], "divided by 10": ref / 10}
    out = {}
    for name, other in cases.items():
        ts = np.linspace(t[0], t[-1], points)
        f = f_statistic(np.interp(ts, t, other), np.interp(ts, t, ref))
        out[name] = {"f_statistic": f, "f_critical": f_critical(points, points, alpha),
                     "eq18_agree": bool(f < f_critical(points, points, alpha)),
                     "statistics_agree": statistics_agreement(t, other, ref)["agree"]}
    return out


def curve_agreement(t, a, b, points: int = 10, alpha: float = 0.05, period: float | None = None) -> dict:
    """Agreement of two force curves: the study's eq. 18 on ``points`` samples (``eq18_agree``), plainer
    measures (NRMSE, correlation, peak ratio) and our criterion ``agree``: the impact statistics agree within
    :data:`STATISTICS_TOLERANCE` (:func:`statistics_agreement`).

    Parameters
    ----------
    t : array_like
        Common time base of the two series (s).
    a, b : array_like
        Multibody (a) and MLSD (b) force series on ``t`` (N).
    points : int
        Samples used for the F test (the study used about ten).
    alpha : float
        Significance level (dimensionless).
    period : float, optional
        Drive period (s), for the impulse per revolution.

    Returns
    -------
    dict
        ``f_statistic``, ``f_critical``, ``alpha``, ``points``, ``eq18_agree``, ``agree``, ``statistics``
        (:func:`statistics_agreement`), ``nrmse``, ``correlation``, ``peak_ratio`` and ``mean_ratio``
        (dimensionless).
    """
    t = np.asarray(t, float)
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    ts = np.linspace(t[0], t[-1], points)
    sa, sb = np.interp(ts, t, a), np.interp(ts, t, b)
    f = f_statistic(sa, sb)
    fc = f_critical(points, points, alpha)
    span = float(np.max(b) - np.min(b)) or 1.0
    corr = float(np.corrcoef(a, b)[0, 1]) if np.std(a) > 0 and np.std(b) > 0 else float("nan")
    st = statistics_agreement(t, a, b, period)
    return {
        "f_statistic": f,
        "f_critical": fc,
        "alpha": alpha,
        "points": points,
        "eq18_agree": bool(f < fc),
        "agree": st["agree"],
        "statistics": st,
        "nrmse": float(np.sqrt(np.mean((a - b) ** 2)) / span),
        "correlation": corr,
        "peak_ratio": float(np.max(np.abs(a)) / max(np.max(np.abs(b)), 1e-300)),
        "mean_ratio": float(np.mean(np.abs(a)) / max(np.mean(np.abs(b)), 1e-300)),
    }


def model_agreement(machine, clearance: dict[str, float] | None = None, revolutions: int = 3, points: int = 10,
                    alpha: float = 0.05) -> dict:
    """Run a drive's reduced model and the multibody model on the same machine and clearances; compare the
    collision force of every pair (eq. 18 and plainer measures, :func:`curve_agreement`).

    The one comparison used by ``berryshaker compare`` and by the study.

    Parameters
    ----------
    machine : MachineBase
        The machine description (its drive must have a reduced model).
    clearance : dict pair -> float, optional
        Clearance size (m) per pair (:doc:`/nomenclature`); a pair left out keeps the description's.
    revolutions : int
        Drive revolutions (>= 2; statistics exclude the first).
    points : int
        Samples of each curve in the F test.
    alpha : float
        Significance level (dimensionless).

    Returns
    -------
    dict
        ``clearance_mm``, ``revolutions``, ``pairs`` (per pair: :func:`curve_agreement` plus ``peak_N`` of
        both models), ``t`` (s) and ``series`` (per pair: (multibody, reduced) force arrays on ``t``, N) — the
        last two are arrays for plotting, not JSON.

    Raises
    ------
    ConfigError
        The machine's drive has no reduced model.
    """
    from berryshaker.drives import drive_of
    from berryshaker.drives.simulation import simulate_multibody
    from berryshaker.errors import ConfigError

    drive = drive_of(machine)
    if drive.reduced_model is None:
        raise ConfigError(f"the {drive.name} drive has no reduced model to compare with the multibody model")
    # the multibody run first: in the study its compilation overlaps the reduced model's runs in the workers,
    # which have compiled the reduced model's core by the time this process needs it
    mbr, mbs = simulate_multibody(machine, clearance, revolutions=revolutions)
    ml = drive.reduced_model(machine, clearance, revolutions=revolutions)
    sel = ml.t >= ml.stats_from
    t = ml.t[sel]
    reduced_summary = ml.summary()
    res = {"clearance_mm": {k: v * 1e3 for k, v in ml.clearance.items()}, "revolutions": revolutions,
           "reduced_model": drive.reduced_model_name, "pairs": {}, "series": {}, "t": t}
    for p in machine.pair_names:
        b = np.abs(ml.series(f"F_{p}_N"))[sel]
        a_full = mbr.element_force(p) if p in mbr.compiled.frc_names else mbr.reaction(p)
        a = np.interp(t, mbr.t, np.abs(a_full))
        res["pairs"][p] = curve_agreement(t, a, b, points=points, alpha=alpha,
                                          period=2 * np.pi / machine.drive_speed)
        res["pairs"][p]["peak_N"] = {"multibody": float(mbs["collision_force_N"][p]["peak"]),
                                     "reduced": float(reduced_summary["collision_force_N"][p]["peak"])}
        res["series"][p] = (a, b)
    return res
