"""Records of statistics that several study steps' results share: a comb's load moment (:class:`MomentStatistics`),
the drive moment (:class:`DriveMoment`), a shaft speed's range (:class:`SpeedRange`) and one statistic over a set's
perturbed starts (:class:`StartStatistic`).  Each step's own records (:mod:`berryshaker.study.mechanics_records`,
:mod:`~berryshaker.study.fruit_force_records`, :mod:`~berryshaker.study.life_drive_records`) use these.
"""

from __future__ import annotations

from dataclasses import dataclass

from berryshaker.records import JsonRecord, optional


@dataclass(frozen=True)
class MomentStatistics(JsonRecord):
    """A comb's load moment about its shaft: magnitude statistics over the analysed part of a run (revolutions 2..N
    of a machine run; the bush inside the comb for a drive-past).

    Attributes
    ----------
    peak : float
        Peak magnitude (N m).
    rms : float
        Root mean square (N m).
    mean : float
        Mean magnitude (N m).
    """

    peak: float
    rms: float
    mean: float


@dataclass(frozen=True)
class DriveMoment(JsonRecord):
    """The moment the drive applies to its shaft in its direction of rotation, over revolutions 2..N.

    Attributes
    ----------
    peak : float
        Peak magnitude (N m).
    mean : float
        Signed mean (N m; mean drive power / speed).
    rms : float
        Root mean square (N m).
    p95 : float
        95th percentile of the magnitude (N m).
    mean_abs : float
        Mean of the magnitude (N m).
    design : float or None
        The sizing value: the 95th percentile of the revolutions' peak magnitudes (N m); the single ``peak`` is the
        extreme, kept for reference, not a design load.
    fatigue_equivalent : float or None
        The cube-mean magnitude (mean |M|^3)^(1/3) over the window (N m;
        :func:`berryshaker.drives.simulation.drive_torque_loads`).
    """

    peak: float
    mean: float
    rms: float
    p95: float
    mean_abs: float
    design: float | None = optional()
    fatigue_equivalent: float | None = optional()


@dataclass(frozen=True)
class SpeedRange(JsonRecord):
    """A shaft's speed over a powered run (the cam or drive shaft).

    Attributes
    ----------
    min : float
        Lowest speed (r/min).
    max : float
        Highest speed (r/min).
    mean : float
        Mean speed (r/min).
    """

    min: float
    max: float
    mean: float


@dataclass(frozen=True, kw_only=True)
class StartStatistic(JsonRecord):
    """One per-run force statistic (a collision force's peak or mean, a fruit's peak stem force) over a set's
    perturbed starts, paired by position with every other set of the same starts.

    Attributes
    ----------
    mean : float
        Mean over the starts that finished (N).
    sd : float
        Their sample standard deviation (N).
    se : float
        Standard error of the mean (N).
    p95 : float or None
        95th percentile of the per-start values (N); only where the step reports it (the clearance rows).
    values : list of float or None
        One per planned start, in the starts' order (N); None where the run failed.
    """

    mean: float
    sd: float
    se: float
    p95: float | None = optional()
    values: list[float | None]


__all__ = ["MomentStatistics", "DriveMoment", "SpeedRange", "StartStatistic"]
