"""The design answers as typed records (:func:`berryshaker.report.design.design_answers`): :class:`DesignAnswers`
and its parts, every number a :class:`~berryshaker.report.design_quantity.Quantity`.  What the report's opening
section (:mod:`berryshaker.report.design_html`) renders and what a design report or explorer reads, by attribute;
:meth:`~berryshaker.records.JsonRecord.to_json` gives the answers' JSON form (one key per field, in order; an
optional field that is None left out), :meth:`~berryshaker.records.JsonRecord.from_json` reads it back.

The harvest parts (:class:`HarvestIndexes`, :class:`OperatingPoint`, :class:`WhyEfficiency`, :class:`Comparison`,
:class:`PublishedReference`) are made by :mod:`berryshaker.report.harvest_answers`, the rest by
:mod:`berryshaker.report.design`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from berryshaker.records import JsonRecord, optional
from berryshaker.report.design_quantity import Quantity, QuantitySet

# ------------------------------------------------------------------------------------------------------ harvest


@dataclass(frozen=True)
class HarvestIndexes(QuantitySet):
    """The harvest indexes at the recommended set (the virtual L9's replicates of that set), each a quantity with
    its 95 % interval, SD, count and ``label`` (:data:`~berryshaker.report.harvest_answers.HARVEST_LABELS`); an index the L9 did not record is None.

    Attributes
    ----------
    efficiency : Quantity, optional
        Picked mass per minute (kg/min).
    ripe_removal : Quantity, optional
        Ripe removal (% of the ripe mass).
    unripe_shed : Quantity, optional
        Unripe shedding (% of the unripe mass).
    unripe : Quantity, optional
        Unripe rate (% of the picked mass).
    damage : Quantity, optional
        Damage rate (% of the picked mass).
    """

    efficiency: Quantity | None = optional()
    ripe_removal: Quantity | None = optional()
    unripe_shed: Quantity | None = optional()
    unripe: Quantity | None = optional()
    damage: Quantity | None = optional()


@dataclass(frozen=True)
class SpeedLimits(JsonRecord):
    """The limits of the operating-point rule (:data:`~berryshaker.report.harvest_answers.SPEED_RULE`) on the replicate means.

    Attributes
    ----------
    damage_pct : float
        Limit on the mean damage (% of the picked mass).
    unripe_shed_pct : float
        Limit on the mean unripe shedding (% of the unripe mass).
    tag : str
        Their provenance tag ("[assumed]").
    """

    damage_pct: float
    unripe_shed_pct: float
    tag: str


@dataclass(frozen=True)
class ExcludedSpeed(JsonRecord):
    """A drive speed the operating-point rule left out, and why.

    Attributes
    ----------
    speed_rpm : float
        The drive speed (r/min).
    why : str
        The limits it is over (e.g. "damage 9 % > 5 %"); "" when left out for damage beyond the noise of the
        lowest.
    """

    speed_rpm: float
    why: str


@dataclass(frozen=True)
class OperatingPoint(JsonRecord):
    """The drive speed to run with (:func:`~berryshaker.report.harvest_answers.operating_point`), chosen from the harvest-response step's rows by
    :data:`~berryshaker.report.harvest_answers.SPEED_RULE`, with the harvest indexes at that speed and the stroke the geometry sets.

    Attributes
    ----------
    speed : Quantity
        The drive speed (r/min), a design value.
    frequency : Quantity
        The shaking frequency at that speed (Hz).
    ripe_removal, unripe_shed, damage : Quantity, optional
        Ripe removal, unripe shedding and damage at that speed (%), mean with the 95 % t-interval of its
        replicates; None where the step's row has no such column.
    efficiency : Quantity, optional
        Efficiency at that speed (kg/min), as above.
    finger_amplitude : Quantity, optional
        The finger's amplitude of the stroke (mm), geometric.
    comb_swing : Quantity, optional
        The comb's swing of the stroke (deg), geometric.
    within_limits : bool
        Whether a speed keeps the mean damage and unripe shedding within ``limits``.
    rule : str
        The rule (:data:`~berryshaker.report.harvest_answers.SPEED_RULE`).
    limits : SpeedLimits
        The rule's limits (%).
    no_difference : list of float
        Drive speeds whose removal is within the noise of the chosen one's (r/min).
    excluded : list of ExcludedSpeed
        Drive speeds left out, with the reason.
    statement : str
        The choice in words.

    The fields after ``comb_swing`` are keyword-only (they follow the optional ones).
    """

    speed: Quantity
    frequency: Quantity
    ripe_removal: Quantity | None = optional()
    unripe_shed: Quantity | None = optional()
    damage: Quantity | None = optional()
    efficiency: Quantity | None = optional()
    finger_amplitude: Quantity | None = optional()
    comb_swing: Quantity | None = optional()
    within_limits: bool = field(kw_only=True)
    rule: str = field(kw_only=True)
    limits: SpeedLimits = field(kw_only=True)
    no_difference: list[float] = field(kw_only=True)
    excluded: list[ExcludedSpeed] = field(kw_only=True)
    statement: str = field(kw_only=True)


@dataclass(frozen=True)
class KinematicDrivers(JsonRecord):
    """The kinematic quantities that set the removal (:func:`~berryshaker.report.harvest_answers.why_efficiency`): the finger's amplitude, the
    frequency, the peak speed and acceleration and those over a sinusoid's of the same amplitude and frequency
    (the waveform's factors), of the comb of the widest swing.  A quantity the data do not give is None.

    Attributes
    ----------
    comb : str
        The comb ("left", "right").
    comb_swing_deg : float
        Half its peak-to-peak swing (deg).
    frequency_hz : float or None
        The shaking frequency (Hz); None when neither the harvest-response step nor the kinematics give it.
    finger_amplitude_mm : float, optional
        The finger's amplitude (mm): the half swing times the finger radius.
    tip_speed_m_s : float, optional
        The comb tip's peak speed (m/s).
    tip_acceleration_m_s2 : float, optional
        The comb tip's peak acceleration (m/s^2).
    speed_over_sinusoid : float, optional
        Peak tip speed over a sinusoid's of the same amplitude and frequency (dimensionless).
    acceleration_over_sinusoid : float, optional
        Peak tip acceleration over the sinusoid's (dimensionless).
    finger_speed_m_s : float, optional
        The finger's peak speed (m/s).
    finger_acceleration_m_s2 : float, optional
        The finger's peak acceleration (m/s^2).
    """

    comb: str
    comb_swing_deg: float
    frequency_hz: float | None
    finger_amplitude_mm: float | None = optional()
    tip_speed_m_s: float | None = optional()
    tip_acceleration_m_s2: float | None = optional()
    speed_over_sinusoid: float | None = optional()
    acceleration_over_sinusoid: float | None = optional()
    finger_speed_m_s: float | None = optional()
    finger_acceleration_m_s2: float | None = optional()


@dataclass(frozen=True)
class WhyEfficiency(JsonRecord):
    """Efficiency decomposed (:func:`~berryshaker.report.harvest_answers.why_efficiency`): picked mass per minute = (ripe removal x ripe yield +
    unripe shedding x unripe yield) per bush x bushes per minute, with the kinematic quantities that set the
    removal.

    Attributes
    ----------
    efficiency : Quantity
        Efficiency at the recommended set (kg/min).
    ripe_removal : Quantity
        Ripe removal at the recommended set (%).
    unripe_shed : Quantity or None
        Unripe shedding at the recommended set (%); None when the L9 did not record it.
    yield_per_bush_kg : Quantity
        The yield per bush the study ran with (kg), with its input tag.
    unripe_fraction : Quantity
        The unripe fraction of the yield (dimensionless), with its input tag.
    bushes_per_min : Quantity
        Bushes per minute: walking speed / plant spacing (1/min).
    product_kg_min : float
        The decomposition's value (kg/min): equals the efficiency up to the sampled ripe fraction.
    ripe_part_kg_min : float
        Its ripe part (kg/min).
    unripe_part_kg_min : float
        Its unripe part (kg/min).
    drivers : KinematicDrivers
        The finger's motion that sets the removal.
    statement : str
        The decomposition in words.
    """

    efficiency: Quantity
    ripe_removal: Quantity
    unripe_shed: Quantity | None
    yield_per_bush_kg: Quantity
    unripe_fraction: Quantity
    bushes_per_min: Quantity
    product_kg_min: float
    ripe_part_kg_min: float
    unripe_part_kg_min: float
    drivers: KinematicDrivers
    statement: str


@dataclass(frozen=True)
class Comparison(JsonRecord):
    """Why one machine's efficiency differs from another's (:func:`~berryshaker.report.harvest_answers.compare_efficiency`).

    Attributes
    ----------
    ratio : float
        Efficiency of this machine over the other's (dimensionless).
    factors : dict of str to float
        The ratio split into factors (dimensionless ratios), by name: "ripe removal", "ripe yield per bush",
        "bushes per minute"; their product is the ratio of the decompositions.
    drivers : dict of str to tuple of float
        The removal's kinematic drivers side by side, by label with its unit (e.g. "frequency (Hz)"): (this
        machine's, the other's, their ratio), the first two in the label's unit; a list in the JSON form.
    dominant : str or None
        The factor furthest from 1; None when the efficiencies are within 5 % of each other.
    statement : str
        The comparison in words.
    """

    ratio: float
    factors: dict[str, float]
    drivers: dict[str, tuple[float, float, float]]
    dominant: str | None
    statement: str


@dataclass(frozen=True)
class PublishedReference(JsonRecord):
    """The reference machine's published efficiency split like :class:`WhyEfficiency` (:func:`~berryshaker.report.harvest_answers.published_reference`):
    what :func:`~berryshaker.report.harvest_answers.compare_efficiency` reads, and the machine's name.

    Attributes
    ----------
    machine : str
        The reference machine's name (published field result).
    efficiency : Quantity
        The published efficiency (kg/min), without an interval.
    ripe_removal : Quantity
        The ripe removal it implies (%).
    yield_per_bush_kg : Quantity
        The reference description's yield per bush (kg).
    unripe_fraction : Quantity
        Its unripe fraction (dimensionless).
    bushes_per_min : Quantity
        Its bushes per minute (1/min).
    drivers : KinematicDrivers
        The finger's motion of the reference description's kinematics.
    """

    machine: str
    efficiency: Quantity
    ripe_removal: Quantity
    yield_per_bush_kg: Quantity
    unripe_fraction: Quantity
    bushes_per_min: Quantity
    drivers: KinematicDrivers


# ------------------------------------------------------------------------------------------------------- design


@dataclass(frozen=True)
class Recommended(JsonRecord):
    """The recommended clearance set of the virtual L9 (or the study's optimum).

    Attributes
    ----------
    code : str or None
        Its L9 level code (e.g. "A1B1C1F1").
    name : str
        The set named by its clearances (:func:`berryshaker.report.design.level_set_name`, in mm).
    statement : str
        Why it is recommended, in words.
    starts : int or None
        Number of starts (replicates) the set was run with.
    l9_run : int or None
        The L9 run it is (1..9), None when it is not a tested run.
    """

    code: str | None
    name: str
    statement: str
    starts: int | None
    l9_run: int | None


@dataclass(frozen=True)
class JointAnswers(JsonRecord):
    """One joint's answers; a part a step did not give is None (left out of the JSON form).

    Attributes
    ----------
    clearance : Quantity, optional
        The recommended clearance (mm), the L9's level, with its ``basis``.
    design_force : Quantity, optional
        Static-equivalent collision force at the recommended set (N; the p95 of the impact peaks of each start's
        drive-pasts): mean over its starts, 95 % interval, SD, count.
    fit : str, optional
        The recommended ISO 286 fit (e.g. "H11/c11") of the clearance-life step.
    fit_clearance : Quantity, optional
        The fit's clearance (mm): its mean, the range of its ISO 286 limits as the interval.
    service_interval : Quantity, optional
        Service life (h) from the fit's mean clearance: its governing mechanism's hours and interval (None beyond
        the machine's design life; ``reads`` states it), with ``limit_mm`` and ``mechanism``.
    fit_design_force : Quantity, optional
        Static-equivalent collision force at the fit's mean clearance (N), machine without the bush (the life step's
        surrogate).
    drawing_fit : str, optional
        The fit on the user's drawing (``clearance.<pair>.fit``).
    drawing_fit_clearance : Quantity, optional
        Its new-machine clearance (mm).
    drawing_service_interval : Quantity, optional
        Its service life (h).
    """

    clearance: Quantity | None = optional()
    design_force: Quantity | None = optional()
    fit: str | None = optional()
    fit_clearance: Quantity | None = optional()
    service_interval: Quantity | None = optional()
    fit_design_force: Quantity | None = optional()
    drawing_fit: str | None = optional()
    drawing_fit_clearance: Quantity | None = optional()
    drawing_service_interval: Quantity | None = optional()


@dataclass(frozen=True)
class Loads(QuantitySet):
    """The drive torque at the recommended set (the virtual L9's replicates), each with ``label``; None where the
    L9 did not record it.

    Attributes
    ----------
    drive_torque_design : Quantity, optional
        Design drive torque: the p95 of the per-revolution peaks of the drive moment
        (berryshaker.multibody.drive_loads.design_torque; N m).
    drive_torque_rms : Quantity, optional
        RMS drive torque (N m).
    """

    drive_torque_design: Quantity | None = optional()
    drive_torque_rms: Quantity | None = optional()


@dataclass(frozen=True)
class Difference(JsonRecord):
    """One of the L9's paired differences: a factor's last minus first level over the blocked starts, for one
    response (:func:`berryshaker.report.design.differences`).

    Attributes
    ----------
    response : str
        The response (e.g. "efficiency", "design_force_C").
    factor : str
        The factor (a clearance pair).
    levels : list of int
        The two levels compared, [first, last].
    beyond_noise : bool
        Whether the difference is beyond the noise (paired t test, p < 0.05).
    verdict : str
        "differs" or "no difference".
    p : float
        Two-sided p of the paired t test (dimensionless).
    difference : Quantity
        The difference in the response's unit with its 95 % interval and ``se``.
    """

    response: str
    factor: str
    levels: list[int]
    beyond_noise: bool
    verdict: str
    p: float
    difference: Quantity


@dataclass(frozen=True)
class TradeoffCandidate(JsonRecord):
    """One candidate of the L9's trade-off table.

    Attributes
    ----------
    candidate : str
        Its name in the table (e.g. "run 1 (A1B1C1F1), recommended").
    name : str
        Its clearances (:func:`berryshaker.report.design.level_set_name`, in mm).
    dominated : bool
        Whether another candidate dominates it beyond the noise.
    """

    candidate: str
    name: str
    dominated: bool


@dataclass(frozen=True)
class Tradeoff(JsonRecord):
    """The L9's trade-off table in brief.

    Attributes
    ----------
    candidates : int
        Number of candidates.
    dominated : int
        Number dominated beyond the noise.
    recommended : str or None
        The recommended candidate's name; None when none is marked so.
    named : list of TradeoffCandidate
        Every candidate, in the table's order.
    statement : str
        The recommendation check's statement ("" without one).
    """

    candidates: int
    dominated: int
    recommended: str | None
    named: list[TradeoffCandidate]
    statement: str


@dataclass(frozen=True)
class DesignAnswers(JsonRecord):
    """The answers an engineer brings to the study of their machine (:func:`berryshaker.report.design.design_answers`),
    each number a :class:`~berryshaker.report.design_quantity.Quantity` with its interval and source.

    Attributes
    ----------
    machine : str
        The machine's name.
    drive : str
        Its drive (e.g. "groove_cam").
    pairs : list of str
        Its clearance pairs, in order.
    claims_apply : bool
        Whether the reference study's claims can be checked on it (:func:`berryshaker.report.design.claims_apply`).
    recommended : Recommended or None
        The recommended clearance set; None without the virtual L9.
    joints : dict of str to JointAnswers
        Per clearance pair (in the machine's order): its answers.
    loads : Loads
        The drive torque at the recommended set (N m).
    harvest : HarvestIndexes
        The harvest indexes at the recommended set (kg/min, %).
    operating_point : OperatingPoint or None
        The drive speed to run with; None without the harvest-response step.
    differences : list of Difference
        The L9's paired differences, per response and factor.
    tradeoff : Tradeoff
        The L9's trade-off table in brief.
    why_efficiency : WhyEfficiency or None
        The efficiency decomposed; None without the efficiency or removal at the recommended set.
    comparison : Comparison or None
        The efficiency against a reference; None when nothing is compared.
    missing : list of str
        Steps without results ("virtual_l9", "clearance_life", "harvest_response").
    """

    machine: str
    drive: str
    pairs: list[str]
    claims_apply: bool
    recommended: Recommended | None
    joints: dict[str, JointAnswers]
    loads: Loads
    harvest: HarvestIndexes
    operating_point: OperatingPoint | None
    differences: list[Difference]
    tradeoff: Tradeoff
    why_efficiency: WhyEfficiency | None
    comparison: Comparison | None
    missing: list[str]
