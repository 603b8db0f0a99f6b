"""Typed results of the study steps ``clearance_life`` (:func:`berryshaker.study.steps.clearance_life.step_life`:
:class:`ClearanceLife`) and ``powered_drive`` (:func:`berryshaker.study.steps.powered_drive.run`:
:class:`PoweredDrive`, one :class:`PoweredLevel` per clearance level).  Their JSON forms are the dicts the steps
wrote before (:mod:`berryshaker.records`).
"""

from __future__ import annotations

from dataclasses import dataclass

from berryshaker.life.service_life import JointLife
from berryshaker.records import JsonRecord, optional
from berryshaker.study.statistic_records import DriveMoment, SpeedRange


@dataclass(frozen=True)
class ClearanceGrowth(JsonRecord):
    """One joint's clearance over the operating hours (wear surrogate).

    Attributes
    ----------
    hours : list of float
        Operating hours (h).
    clearance_mm : list of float
        The clearance at each (mm).
    """

    hours: list[float]
    clearance_mm: list[float]


@dataclass(frozen=True)
class RecommendedFits(JsonRecord):
    """The fits recommended by NSGA-II on the surrogate (the front's compromise).

    Attributes
    ----------
    fits : dict of str to str
        ISO 286 fit designation per joint (e.g. "H9/d9").
    cost : float
        Manufacturing cost of the fits, summed over hole and shaft of every joint (relative cost units, 1;
        :func:`berryshaker.life.tolerance.tolerance_cost`).
    design_force_N : float
        Static-equivalent collision force, the largest over the joints, each at its fit's mean clearance (N).
    maintenance_interval_h : float
        Hours until the first joint grows from its fit's mean clearance to its service limit under the faster wear
        mode (h; the design's objective, :meth:`~berryshaker.life.clearance_response.ClearanceResponse.service_hours`).
    """

    fits: dict[str, str]
    cost: float
    design_force_N: float
    maintenance_interval_h: float


@dataclass(frozen=True)
class FitLife(JsonRecord):
    """A fit evaluated on the surrogate: the new machine's clearance it gives, the joint's sizing load there and
    its service life (:func:`berryshaker.study.steps.clearance_life.fit_life`).

    Attributes
    ----------
    fit : str
        ISO 286 fit designation (e.g. "H8/f7").
    source : str
        "drawing" (``clearance.<pair>.fit`` of the description) or "recommended" (the tolerance design's).
    clearance_min_mm, clearance_mm, clearance_max_mm : float
        The new machine's clearance by the fit's ISO 286 limits: smallest, mean, largest (mm; radial for a pin,
        free travel for a roller).
    design_force_N : float
        Static-equivalent collision force at the mean clearance (N; the surrogate, machine without the bush).
    design_force_se_N : float, optional
        Its standard error over the surrogate's starts (N).
    starts : int, optional
        The surrogate's starts per clearance.
    life : JointLife
        The joint's service life from the fit's mean clearance.
    """

    fit: str
    source: str
    clearance_min_mm: float
    clearance_mm: float
    clearance_max_mm: float
    design_force_N: float
    life: JointLife
    design_force_se_N: float | None = optional()
    starts: int | None = optional()


@dataclass(frozen=True)
class ClearanceLife(JsonRecord):
    """Data of the study step ``clearance_life``: clearance growth by wear and the recommended fits.

    Attributes
    ----------
    horizon_h : float
        Operating hours of the growth (h).
    growth : dict of str to ClearanceGrowth
        Per joint its clearance over the hours (mm against h) under the faster wear mode, ended where it reaches
        its service limit.
    hours_to_limit : dict of str to float or None
        Per joint the hours from the described clearance (a worn level) to its service limit under the faster wear
        mode (h; None: not within the machine's design life).
    clearance_limit_mm : dict of str to float
        Per joint its service limit (mm).
    recommended : RecommendedFits
        The recommended fits.
    front_size : int
        Designs on the NSGA-II front.
    simulations : int
        Coupled runs of the surrogate's grid.
    surrogate : dict of str to dict
        Per joint the surrogate's grid (:meth:`berryshaker.life.clearance_response.ClearanceResponse.to_dict`:
        clearances mm, static-equivalent forces N, growth rates um/h, starts).
    notes : list of str
        What the estimate rests on.
    life : dict of str to JointLife, optional
        Per joint its service life from the new machine's clearance (its fit on the drawing, else its described
        size) by mechanism (:func:`berryshaker.life.service_life.joint_life`).
    drawing_fits : dict of str to FitLife, optional
        Per joint with a fit on the drawing (``clearance.<pair>.fit``): that fit evaluated.
    recommended_fits : dict of str to FitLife, optional
        Per joint: the recommended fit evaluated.
    """

    horizon_h: float
    growth: dict[str, ClearanceGrowth]
    hours_to_limit: dict[str, float | None]
    clearance_limit_mm: dict[str, float]
    recommended: RecommendedFits
    front_size: int
    simulations: int
    surrogate: dict[str, dict]
    notes: list[str]
    life: dict[str, JointLife] | None = optional()
    drawing_fits: dict[str, FitLife] | None = optional()
    recommended_fits: dict[str, FitLife] | None = optional()



@dataclass(frozen=True)
class PoweredLevel(JsonRecord):
    """The powered drive at one clearance level: replicate means over perturbed starts.

    Attributes
    ----------
    clearance_mm : dict of str to float
        Clearance per pair (mm).
    cam_speed_rpm : SpeedRange
        Drive-shaft speed (r/min).
    speed_ripple_percent : float
        Speed ripple, (max - min) / mean (%).
    input_power_W : float
        Mean input power (W).
    energy_per_revolution_J : dict of str to float
        Energy lost per revolution by each joint and element (J/rev): the clearance pairs, the bush, belt, mesh
        and guide friction.
    drive_moment_Nm : DriveMoment
        Drive moment statistics (peak, mean, rms, p95, mean_abs; N m).
    replicates : int
        Finished starts averaged.
    audit_relative_residual : float
        Largest energy-audit residual over the replicates (1).
    speed_ripple_sd_percent : float
        SD of the ripple over the replicates (%).
    clearance_energy_sd_J : float
        SD of the energy lost in the clearance joints over the replicates (J/rev).
    """

    clearance_mm: dict[str, float]
    cam_speed_rpm: SpeedRange
    speed_ripple_percent: float
    input_power_W: float
    energy_per_revolution_J: dict[str, float]
    drive_moment_Nm: DriveMoment
    replicates: int
    audit_relative_residual: float
    speed_ripple_sd_percent: float
    clearance_energy_sd_J: float


@dataclass(frozen=True)
class PoweredDrive(JsonRecord):
    """Data of the study step ``powered_drive``: speed ripple, input power and energy lost per joint against
    clearance.

    Attributes
    ----------
    levels : dict of str to PoweredLevel
        Per clearance level ("1", "2", "3") that ran its replicate means.
    replicates : int
        Perturbed starts planned per level.
    seeds : list of int
        Their seeds.
    ripple_grows_with_clearance : bool
        Whether the ripple rises significantly at every level step.
    ripple_trend : dict
        The ripple's trend (:func:`berryshaker.experiment.replicates.replicate_trend`: mean, sd %, steps, grows,
        alpha).
    clearance_energy_per_revolution_J : dict of str to float
        Per level the energy lost in the clearance joints, replicate mean (J/rev).
    energy_trend : dict
        That energy's trend (:func:`berryshaker.experiment.replicates.replicate_trend`; J/rev).
    energy_grows_with_clearance : bool
        Whether that energy rises significantly at every level step.
    finding : str
        The finding, as the report states it.
    """

    levels: dict[str, PoweredLevel]
    replicates: int
    seeds: list[int]
    ripple_grows_with_clearance: bool
    ripple_trend: dict
    clearance_energy_per_revolution_J: dict[str, float]
    energy_trend: dict
    energy_grows_with_clearance: bool
    finding: str


__all__ = ["FitLife", "ClearanceGrowth", "RecommendedFits", "ClearanceLife", "PoweredLevel", "PoweredDrive"]
