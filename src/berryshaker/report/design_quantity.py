"""A design answer's number and where the answers read it: :class:`Quantity` (value, unit, interval, source step
and provenance tag; made by :func:`quantity`), a {mean, sd, ci, n} estimate as a quantity, and the study's results
and recommended set as the answers find them in ``summary.json`` (:mod:`berryshaker.report.design`).  Tags:
``[computed]`` a result of this study's runs; ``[assumed]``, ``[calibrated]``, ``[study]``, ``[published]``,
``[default]`` the inputs' tags (``berryshaker.config.value_tag``) where a number is an input.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from berryshaker.records import JsonRecord, optional

#: significance level of the answers' tests and intervals (95 %)
ALPHA = 0.05


@dataclass(frozen=True)
class Source(JsonRecord):
    """Where a design answer's number comes from: the study step and the place in its results.

    Attributes
    ----------
    step : str
        The study step (a key of :data:`berryshaker.report.design_html.STEP_SECTIONS`, which names its report
        section; "machine" for an input of the machine description).
    where : str
        Where in that step's results (e.g. "recommended.replicates.design_force_A").
    """

    step: str
    where: str


@dataclass(frozen=True)
class Quantity(JsonRecord):
    """One design answer's number: value, unit, interval (lo, hi, what it is), its source and its provenance tag,
    with the extras some answers carry (an extra that is None is left out of the JSON form).

    Attributes
    ----------
    value : float or None
        The value, in ``unit`` (e.g. mm, N, h; dimensionless when ``unit`` is "").
    unit : str
        Its unit ("mm", "N", "N m", "h", "kg/min", "%", "r/min", "Hz", "deg", "1/min"; "" for a dimensionless
        number).
    lo, hi : float or None
        The interval's ends, in ``unit`` (e.g. mm, N, h); None where there is none (``interval`` then says why).
    interval : str
        What the interval is (e.g. "95 % t-interval of the mean of 32 starts").
    source : Source
        The study step and the place in its results the number comes from.
    tag : str
        Provenance tag ("[computed]", "[assumed]", "[calibrated]", ...).
    basis : str, optional
        A recommended clearance's basis: why the L9 chose that level (the joint's clearance only).
    sd : float, optional
        Standard deviation of the replicates, in the quantity's unit (``unit``; an estimate from replicates
        only).
    n : int, optional
        Number of replicates (starts) the estimate rests on.
    se : float, optional
        Standard error of a paired difference, in the quantity's unit (``unit``; a difference only).
    material_pair : str, optional
        The joint's material pair whose Archard k sets the interval (a service interval only).
    limit_mm : float, optional
        The joint's service limit of clearance (mm) the service interval runs to (a service interval only).
    label : str, optional
        The quantity's name in the answers' tables (the loads and harvest indexes at the recommended set).
    reads : str, optional
        A service life as the report states it (no number beyond the machine's design life).
    mechanism : str, optional
        A service life's governing mechanism.
    """

    value: float | None
    unit: str
    lo: float | None
    hi: float | None
    interval: str
    source: Source
    tag: str
    basis: str | None = optional()
    sd: float | None = optional()
    n: int | None = optional()
    se: float | None = optional()
    material_pair: str | None = optional()
    limit_mm: float | None = optional()
    label: str | None = optional()
    reads: str | None = optional()
    mechanism: str | None = optional()


@dataclass(frozen=True)
class QuantitySet(JsonRecord):
    """Base of the answers that are a fixed set of named quantities, each present or not (None, left out of the
    JSON form): the loads and the harvest indexes at the recommended set."""

    def quantities(self) -> list[Quantity]:
        """The quantities present, in field order (the order the answers' table lists them).

        Returns
        -------
        list of Quantity
            The fields that are not None.
        """
        return [q for q in (getattr(self, f.name) for f in fields(self)) if q is not None]


def quantity(value, unit: str, lo=None, hi=None, interval: str = "", step: str = "", where: str = "",
             tag: str = "[computed]", **extra) -> Quantity:
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
        Where in that step's results (e.g. "recommended.replicates.design_force_A").
    tag : str
        Provenance tag.
    **extra
        The extras of :class:`Quantity` (basis, sd, n, se, material_pair, limit_mm, label); another name is a
        TypeError.

    Returns
    -------
    Quantity
        The number; its values and bounds as Python floats.
    """
    return Quantity(None if value is None else float(value), unit, None if lo is None else float(lo),
                    None if hi is None else float(hi), interval, Source(step, where), tag, **extra)


def _estimate(est: dict | None, unit: str, step: str, where: str, tag: str = "[computed]") -> Quantity | None:
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
