"""The typed result of the study's virtual L9 (:func:`berryshaker.study.l9.virtual_l9`, study step ``virtual_l9``):
:class:`VirtualL9` and its sub-records (:class:`L9Run`, :class:`L9Recommendation`, :class:`Estimate`,
:class:`ReplicatedL9`, :class:`ToleranceCheck`, ...), read by attribute by the report, the claims, the tables and
the summary; :meth:`~berryshaker.records.JsonRecord.to_json` gives the dict written to summary.json's
``results.l9``, key for key.

The range analysis per response (:func:`berryshaker.experiment.analysis.analyze`) and the replicated analysis
(:func:`berryshaker.experiment.replicates.analyze_replicated`, also the JSON of ``doe analyze``) are the experiment
layer's records (:mod:`berryshaker.experiment.analysis_records`, :mod:`berryshaker.experiment.replicated_records`);
:class:`ReplicatedL9` and :class:`L9Optimum` extend them with what the study adds.  What stays a ``dict`` field: the trade-off table's rows (their columns are
data: ``design_force_N:A``...) and the sequential-start statistics.
"""

from __future__ import annotations

from dataclasses import dataclass

from berryshaker.experiment.analysis_records import CompositeScore, FactorLevels, RangeAnalysis
from berryshaker.experiment.replicated_records import PairedDifference, ReplicatedAnalysis, ReplicatedOptimum
from berryshaker.records import JsonRecord, optional


@dataclass(frozen=True)
class Estimate(JsonRecord):
    """One response's replicates at one clearance set: mean, spread and 95 % interval of the mean
    (:func:`berryshaker.study.replicate_responses.interval`).

    Attributes
    ----------
    mean : float
        Mean of the replicates (the response's unit: kg/min, %, N or N m).
    sd : float
        Per-start standard deviation (the response's unit).
    ci : list of float
        95 % interval of the mean, [lo, hi] (the response's unit; clipped at 0 when no replicate is negative).
    n : int
        Number of replicates (starts).
    interval_from : str
        Which error the interval uses (this run's replicates or the pooled error, with its dof).
    """

    mean: float
    sd: float
    ci: list[float]
    n: int
    interval_from: str


@dataclass(frozen=True)
class L9Run(JsonRecord):
    """One run of the L9 (Table 7): its levels and clearances and the replicate means of the study's indexes.

    Attributes
    ----------
    run : int
        Run number (1-9).
    levels : dict of str to int
        Level (1-based) per clearance pair.
    clearance_mm : dict of str to float
        Clearance per pair (mm).
    name : str
        The clearance set's name ("A 0.25 mm, B 0.2 mm, ...").
    efficiency : float
        Replicate mean of the harvest efficiency (kg/min).
    unripe : float
        Replicate mean of the unripe rate (%).
    damage : float
        Replicate mean of the damage rate (%).
    replicates : dict of str to Estimate
        Every response's mean, SD and interval from this run's starts (response name -> :class:`Estimate`); a harvest
        response's are those of its counted field results (one per start: a virtual field test).
    expected : dict of str to Estimate
        Every harvest response's model expectation over this run's starts: mean, the model's start-to-start SD and
        the interval of the mean.
    """

    run: int
    levels: dict[str, int]
    clearance_mm: dict[str, float]
    name: str
    efficiency: float
    unripe: float
    damage: float
    replicates: dict[str, Estimate]
    expected: dict[str, Estimate]


@dataclass(frozen=True)
class FieldDetectability(JsonRecord):
    """A factor's effect on a harvest response in the model, and how many field tests it would take to see it.

    Attributes
    ----------
    effect : float
        The model's effect: largest minus smallest level mean of the expectation over the L9's starts (the
        response's unit).
    effect_se : float
        Its standard error over the starts (paired: the starts are shared; the response's unit).
    field_sd : float
        SD of one field test at one setting (the counted field results' pooled within-run SD: the model's
        start-to-start spread and the counting noise; the response's unit).
    tests_per_level : float or None
        Field tests at each of the two levels for a two-sided t test at alpha 0.05 to see the effect with power 0.8
        (statsmodels TTestIndPower; dimensionless count); None: no effect to see.
    l9_replicates : float or None
        Replicates of a whole field L9 that give as many tests per level (a level is in 3 of the 9 runs;
        dimensionless count).
    """

    effect: float
    effect_se: float
    field_sd: float
    tests_per_level: float | None
    l9_replicates: float | None


@dataclass(frozen=True)
class Perturbation(JsonRecord):
    """How the starts (blocks) of the replicated L9 differ.

    Attributes
    ----------
    initial_eccentricity : float
        Initial journal eccentricity, as a fraction of each free radius (dimensionless).
    start_phase_spread_rad : float
        Half-width of the uniform drive phase at the start (rad).
    what : str
        The perturbation in words.
    """

    initial_eccentricity: float
    start_phase_spread_rad: float
    what: str


@dataclass(frozen=True, kw_only=True)
class ReplicatedL9(ReplicatedAnalysis):
    """The replicated L9's analysis against its own noise: :func:`berryshaker.experiment.replicates.analyze_replicated`
    (randomised complete blocks: start k is block k): the fields of
    :class:`~berryshaker.experiment.replicated_records.ReplicatedAnalysis` (documented there) and the study's below.

    Attributes
    ----------
    seeds : list of int
        The starts' seeds.
    units : dict of str to str
        Unit per response.
    perturbation : Perturbation
        How the starts differ.
    text : str
        The analysis as text (:func:`berryshaker.experiment.replicates.describe_replicated`).
    """

    seeds: list[int]
    units: dict[str, str]
    perturbation: Perturbation
    text: str


@dataclass(frozen=True, kw_only=True)
class L9Optimum(ReplicatedOptimum):
    """The tiered optimum of the replicated L9: the fields of
    :class:`~berryshaker.experiment.replicated_records.ReplicatedOptimum` (documented there), ``levels`` being the
    recommended ones, and the two below.

    Attributes
    ----------
    levels : dict of str to int or None
        Level (1-based) per factor, None: no meaningful difference.
    decided_levels : dict of str to int or None
        The analysis' levels (1-based; None: no meaningful difference).
    tiered_levels : dict of str to int
        The tiered rule's levels (1-based), the configured level where nothing differs.
    """

    decided_levels: dict[str, int | None]
    tiered_levels: dict[str, int]


@dataclass(frozen=True)
class TieredChoice(JsonRecord):
    """The tiered rule's choice, before the confirmation against the trade-off table.

    Attributes
    ----------
    code : str
        Its level code ("A1B2C1F3").
    name : str
        Its clearance set's name (clearances in mm).
    levels : dict of str to int
        Level (1-based) per pair.
    l9_run : int or None
        The L9 run with these levels (1-based), None if it is not one.
    """

    code: str
    name: str
    levels: dict[str, int]
    l9_run: int | None


@dataclass(frozen=True)
class Confirmation(JsonRecord):
    """The tiered choice confirmed against the trade-off table of the runs
    (:func:`berryshaker.study.l9.confirmation.confirm_recommendation`, without its table).

    Attributes
    ----------
    levels : dict of str to int
        The recommended levels (1-based) per pair.
    l9_run : int or None
        The recommended L9 run (1-based), None if the recommendation is not an L9 run.
    moved : bool
        Whether a tested run dominating the tiered choice replaced it.
    tiered : TieredChoice
        The tiered rule's choice.
    dominated_by : list of str
        The candidates (trade-off table names) that dominate the tiered choice beyond the noise.
    better_in : list of str
        Trade-off columns in which the new recommendation beats the tiered choice (empty if not moved).
    statement : str
        The confirmation in words.
    rule : str
        The confirmation rule (:data:`berryshaker.study.l9.confirmation.CONFIRMATION_RULE`).
    """

    levels: dict[str, int]
    l9_run: int | None
    moved: bool
    tiered: TieredChoice
    dominated_by: list[str]
    better_in: list[str]
    statement: str
    rule: str


@dataclass(frozen=True)
class SequentialStarts(JsonRecord):
    """The recommended set's starts extended until every harvest response's mean is known to its target
    (:func:`berryshaker.study.l9.start_counts.sequential_starts`).

    Attributes
    ----------
    reached : dict or None
        Per harvest response its mean, standard error, target (the response's unit) and whether met, and
        ``all_met``; None when a further start failed.
    stopped : str
        Why the starts stopped ("target met", "max_replicates reached", or the failure).
    target : float
        Target standard error relative to the mean (dimensionless).
    max : int
        Most starts allowed (``harvest.max_replicates``).
    statement : str
        The starts in words.
    """

    reached: dict | None
    stopped: str
    target: float
    max: int
    statement: str


@dataclass(frozen=True)
class L9Recommendation(JsonRecord):
    """The virtual L9's recommended clearance set and its basis.

    Attributes
    ----------
    levels : dict of str to int
        Level (1-based) per pair.
    code : str
        Level code ("A1B1C1F1").
    name : str
        The clearance set's name (clearances in mm).
    clearance_mm : dict of str to float
        Clearance per pair (mm).
    l9_run : int or None
        The L9 run with these levels (1-based), None if it is not one.
    study : dict of str to str
        The study's own choice (``code``).
    same_as_study : bool
        Whether the levels are the study's.
    virtual_harvest : dict of str to float
        The model's expectation of every harvest response over all its starts, keyed by the response's column
        (``efficiency_kg_min`` kg/min, ``ripe_removal_pct``, ``unripe_rate_pct``, ``unripe_shed_pct``,
        ``damage_rate_pct`` %).
    replicates : dict of str to Estimate
        Every response's mean, SD and interval over all its starts.
    starts : int
        Number of starts behind those.
    sequential : SequentialStarts
        How the starts were extended.
    fitted : list of str
        Harvest responses fitted at this set (their values are no evidence).
    basis : dict of str to str
        Per pair, why its level was chosen.
    rule : str
        The recommendation rule (tiered rule, configured clearance, confirmation).
    statement : str
        Which harvest indexes differ, and the confirmation's statement.
    check : Confirmation
        The confirmation against the trade-off table.
    """

    levels: dict[str, int]
    code: str
    name: str
    clearance_mm: dict[str, float]
    l9_run: int | None
    study: dict[str, str]
    same_as_study: bool
    virtual_harvest: dict[str, float]
    replicates: dict[str, Estimate]
    starts: int
    sequential: SequentialStarts
    fitted: list[str]
    basis: dict[str, str]
    rule: str
    statement: str
    check: Confirmation


@dataclass(frozen=True)
class ToleranceVerdict(JsonRecord):
    """One response's change from the run tolerance to the check tolerance against its noise
    (:func:`berryshaker.study.l9.tolerance_check.tolerance_verdict`).

    Attributes
    ----------
    changes : list of float
        Change per checked replicate (the response's unit).
    max_abs_change : float
        Largest absolute change (the response's unit).
    mean_change : float
        Mean change (the response's unit).
    replicate_sd : float
        Per-start SD of the response at the recommended set (the response's unit).
    noise_sd : float
        Noise of the mean change, sqrt(2/k) x ``replicate_sd`` (the response's unit).
    within_replicate_spread : bool
        Whether |mean change| <= z ``noise_sd`` (z: the check's family-wise band,
        :func:`berryshaker.study.l9.tolerance_check.band_z`).
    """

    changes: list[float]
    max_abs_change: float
    mean_change: float
    replicate_sd: float
    noise_sd: float
    within_replicate_spread: bool


@dataclass(frozen=True)
class ToleranceCheck(JsonRecord):
    """The recommended set's first replicates re-run at a tighter solver tolerance
    (:func:`berryshaker.study.l9.tolerance_check.check_solver_tolerance`); only ``done`` and ``reason`` when
    it was not run.

    Attributes
    ----------
    done : bool
        Whether it was run.
    reason : str, optional
        Why not (only when not run).
    rtol : list of float, optional
        Relative tolerances of the runs and of the check (dimensionless).
    velocity_scale_m_s : float, optional
        Velocity scale below which velocities are held absolutely (m/s).
    replicates : int, optional
        Replicates re-run.
    responses : dict of str to ToleranceVerdict, optional
        Per response its verdict.
    all_within : bool, optional
        Whether every response's change is within its noise.
    statement : str, optional
        The check in words.
    """

    done: bool
    reason: str | None = optional()
    rtol: list[float] | None = optional()
    velocity_scale_m_s: float | None = optional()
    replicates: int | None = optional()
    responses: dict[str, ToleranceVerdict] | None = optional()
    all_within: bool | None = optional()
    statement: str | None = optional()


@dataclass(frozen=True)
class VirtualL9(JsonRecord):
    """The study's L9 field test through the virtual harvest, replicated, analysed against its own noise, and its
    recommendation (:func:`berryshaker.study.l9.virtual_l9`).  The first five fields are the range analysis of the
    replicate means (:func:`berryshaker.experiment.analysis.analyze`, the study's Table 8), ``optimum`` replaced by
    the tiered one.

    Attributes
    ----------
    responses : dict of str to RangeAnalysis
        Range analysis of efficiency (kg/min), unripe and damage (%): K, level means, range, best level, ANOVA
        (pooled), regression.
    weights : dict of str to float
        Priority weights of efficiency, damage and unripe (dimensionless).
    factors : dict of str to FactorLevels
        Per factor (pair) its level numbers, values (mm), unit and labels.
    composite : CompositeScore
        Range analysis of the weighted composite score (dimensionless).
    optimum : L9Optimum
        The tiered optimum of the replicated analysis with ``levels`` (recommended), ``decided_levels`` (the
        analysis') and ``tiered_levels`` (the tiered rule's, configured level where nothing differs).
    runs : list of L9Run
        The nine runs.
    replicated : ReplicatedL9
        The replicated analysis.
    response_units : dict of str to str
        Unit per response.
    tradeoff : list of dict
        The trade-off table's rows (``name``, ``clearance_mm:<pair>`` mm, each response with ``_lo``/``_hi``/
        ``_noise``, ``dominated``, ``dominated_by``...).
    tradeoff_columns : list of str
        Its column order.
    recommended : L9Recommendation
        The recommendation.
    tolerance_check : ToleranceCheck
        The solver-tolerance check at the recommendation.
    paired : dict of str to dict of str to PairedDifference
        Per response and pair, the extreme levels' paired difference.
    observations : dict of str to list of list of float
        Per response, its value per run and start (the response's unit; a harvest response's counted field results):
        the effect figures' data.
    detectability : dict of str to dict of str to FieldDetectability
        Per harvest response and factor: the model's effect and the field tests it would take to see it.
    """

    responses: dict[str, RangeAnalysis]
    weights: dict[str, float]
    factors: dict[str, FactorLevels]
    composite: CompositeScore
    optimum: L9Optimum
    runs: list[L9Run]
    replicated: ReplicatedL9
    response_units: dict[str, str]
    tradeoff: list[dict]
    tradeoff_columns: list[str]
    recommended: L9Recommendation
    tolerance_check: ToleranceCheck
    paired: dict[str, dict[str, PairedDifference]]
    observations: dict[str, list[list[float]]]
    detectability: dict[str, dict[str, FieldDetectability]]


__all__ = ["Confirmation", "Estimate", "L9Optimum", "L9Run", "PairedDifference", "Perturbation", "L9Recommendation",
           "ReplicatedL9", "SequentialStarts", "TieredChoice", "ToleranceCheck", "ToleranceVerdict", "VirtualL9"]
