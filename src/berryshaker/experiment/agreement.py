"""Agreement between two simulated curves: the study's F statistic (eq. 18) and plainer measures."""

from __future__ import annotations

import numpy as np
from scipy import stats


def f_statistic(a, b):
    """Study eq. 18: F_xy = [sum (a_i - a_mean)^2 / sum (b_j - b_mean)^2] * (b_max^2 / a_max^2).

    Parameters
    ----------
    a, b : array_like
        Samples of the two curves (the study: a = multibody/ADAMS, b = MLSD/MATLAB).

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
    """Upper critical value of the F distribution with (m-1, n-1) degrees of freedom (scipy.stats)."""
    return float(stats.f.ppf(1.0 - alpha, m - 1, n - 1))


#: relative tolerance on the statistics of two impact-force series for "agree" (our criterion; eq. 18 alone
#: passes on noise, see :func:`eq18_passes_on_noise`)
STATISTICS_TOLERANCE = {"mean": 0.10, "rms": 0.15, "p95": 0.20, "impulse_per_revolution": 0.10}


def impact_statistics(t, f, period: float | None = None) -> dict:
    """Statistics of a collision-force series that suit chaotic impact dynamics: mean, RMS, 95th percentile (N)
    and the impulse per drive revolution (N s; the time integral of |F| over one period, averaged)."""
    t = np.asarray(t, float)
    f = np.abs(np.asarray(f, float))
    span = float(t[-1] - t[0]) or 1.0
    impulse = float(np.trapezoid(f, t)) if hasattr(np, "trapezoid") else float(np.trapz(f, t))
    per = impulse / span * (period if period else span)
    return {"mean": float(f.mean()), "rms": float(np.sqrt(np.mean(f**2))), "p95": float(np.percentile(f, 95)),
            "impulse_per_revolution": per}


def statistics_agreement(t, a, b, period: float | None = None, tolerance: dict | None = None) -> dict:
    """Do two force series agree in the statistics an engineer uses (mean, RMS, p95, impulse per revolution)?

    Each relative difference |a - b| / max(|a|, |b|) must be within its tolerance
    (:data:`STATISTICS_TOLERANCE`).  Returns both statistics, the differences and ``agree``.
    """
    tol = dict(STATISTICS_TOLERANCE, **(tolerance or {}))
    sa, sb = impact_statistics(t, a, period), impact_statistics(t, b, period)
    diff = {k: abs(sa[k] - sb[k]) / max(abs(sa[k]), abs(sb[k]), 1e-300) for k in sa}
    return {"a": sa, "b": sb, "relative_difference": diff, "tolerance": tol,
            "agree": bool(all(diff[k] <= tol[k] for k in tol))}


def summary_statistics_agreement(a: dict, b: dict, tolerance: dict | None = None) -> dict:
    """Agreement of two run summaries' statistics of one collision force.

    ``a`` and ``b`` hold ``mean``, ``rms`` and ``p95`` (N) over the same revolutions, as the multibody and reduced
    summaries give them.  Each relative difference |a - b| / max(|a|, |b|) must be within
    :data:`STATISTICS_TOLERANCE` (10 / 15 / 20 %); the impulse per revolution is the mean times the period, so it
    agrees exactly when the mean does and is not judged twice.  Returns ``relative_difference``, ``worst`` (the
    statistic furthest outside or closest to its tolerance) and ``agree``.
    """
    tol = {k: v for k, v in dict(STATISTICS_TOLERANCE, **(tolerance or {})).items() if k in ("mean", "rms", "p95")}
    diff = {k: abs(a[k] - b[k]) / max(abs(a[k]), abs(b[k]), 1e-300) for k in tol}
    worst = max(tol, key=lambda k: diff[k] / tol[k])
    return {"relative_difference": diff, "worst": worst, "agree": bool(all(diff[k] <= tol[k] for k in tol))}


def eq18_passes_on_noise(points: int = 10, alpha: float = 0.05, seed: int = 0) -> dict:
    """Show that eq. 18 cannot separate curves: a half-sine pulse train against uniform noise, the same curve
    reversed in time, and the curve divided by 10 all 'agree' by eq. 18 (it compares peak-normalised spreads
    only).  Returns F and the verdict for each case; the report shows it beside the study's test."""
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
        Multibody (a) and MLSD (b) series on ``t``.
    points : int
        Samples used for the F test (the study used about ten).
    alpha : float
        Significance level.
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
