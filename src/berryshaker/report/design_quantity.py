"""A design answer's number and where the answers read it: :func:`quantity` (value, unit, interval, source step
and provenance tag), a {mean, sd, ci, n} estimate as a quantity, and the study's results and recommended set as
the answers find them in ``summary.json`` (:mod:`berryshaker.report.design`).  Tags: ``[computed]`` a result of
this study's runs; ``[assumed]``, ``[calibrated]``, ``[study]``, ``[published]``, ``[default]`` the inputs' tags
(``berryshaker.config.value_tag``) where a number is an input.
"""

from __future__ import annotations

#: significance level of the answers' tests and intervals (95 %)
ALPHA = 0.05


def quantity(value, unit: str, lo=None, hi=None, interval: str = "", step: str = "", where: str = "",
             tag: str = "[computed]", **extra) -> dict:
    """One answer's number: value, unit, interval (lo, hi, what it is), its source and its provenance tag.

    Parameters
    ----------
    value : float
        The value, in ``unit`` (e.g. mm, N, h; dimensionless when ``unit`` is "").
    unit : str
        Its unit ("mm", "N", "h", "kg/min", "%", ...; "" for a dimensionless number).
    lo, hi : float, optional
        The interval's ends, in ``unit`` (e.g. mm, N, h); None where there is none (``interval`` then says why).
    interval : str
        What the interval is (e.g. "95 % t-interval of the mean of 32 starts").
    step : str
        The study step the number comes from (a key of :data:`berryshaker.report.design_html.STEP_SECTIONS`,
        which names its report section).
    where : str
        Where in that step's results (e.g. "recommended.replicates.peak_force_A").
    tag : str
        Provenance tag.
    **extra
        Further fields (sd, n, ...).

    Returns
    -------
    dict
        ``value``, ``unit``, ``lo``, ``hi``, ``interval``, ``source`` {step, where}, ``tag`` and ``extra``'s.
    """
    return {"value": None if value is None else float(value), "unit": unit,
            "lo": None if lo is None else float(lo), "hi": None if hi is None else float(hi),
            "interval": interval, "source": {"step": step, "where": where},
            "tag": tag, **extra}


def _estimate(est: dict | None, unit: str, step: str, where: str, tag: str = "[computed]") -> dict | None:
    """:func:`quantity` of a {mean, sd, ci, n, interval_from} estimate (study/replicate_responses.py ``interval``)."""
    if not est:
        return None
    n = est.get("n")
    return quantity(est["mean"], unit, est["ci"][0], est["ci"][1],
                    f"95 % interval of the mean of {n} starts ({est.get('interval_from', 'its replicates')}), "
                    f"SD {est['sd']:.3g} {unit}".rstrip(), step, where, tag, sd=est.get("sd"), n=n)


def _results(summary: dict) -> dict:
    return summary.get("results", summary)


def _recommended(summary: dict) -> dict:
    l9 = _results(summary).get("l9") or {}
    return l9.get("recommended") or {}

