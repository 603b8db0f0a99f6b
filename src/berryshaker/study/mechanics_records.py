"""Typed results of the study's mechanism steps (:mod:`berryshaker.study.steps.model_agreement`,
:mod:`berryshaker.study.steps.clearance_rows`): the reduced model against the multibody model at the model-check
level (:class:`ModelAgreement`, step ``model_agreement``) and every clearance row in both models with the
perturbed starts, the model check and the per-row agreement (:class:`ClearanceRows`, step ``clearance_rows``).  The kinematics step's record is the drives'
(:class:`berryshaker.drives.kinematics_record.KinematicsSummary`).

The run summaries (:func:`berryshaker.study.runs.multibody_row`, :func:`~berryshaker.study.runs.reduced_row`) and
the agreement statistics (:mod:`berryshaker.experiment.agreement`) are dicts where they are made (they are also the
JSON of ``berryshaker simulate`` and ``compare``); the steps read them into these records with
:meth:`~berryshaker.records.JsonRecord.from_json`.  Statistics keyed by the statistic's name ("mean", "rms",
"p95") stay maps: their keys are the tolerance table's (:data:`berryshaker.experiment.agreement.STATISTICS_TOLERANCE`);
so does a powered run's energy audit (a table of the engine, :func:`berryshaker.multibody.energy.energy_audit`).

long module: two dozen small records, one per part of the two steps' results, each with its Attributes and units;
they form one tree (``ClearanceRows`` holds the rows, the starts, the model check and the agreement) read together.
"""

from __future__ import annotations

from dataclasses import dataclass

from berryshaker.records import JsonRecord, optional
from berryshaker.study.statistic_records import DriveMoment, MomentStatistics, SpeedRange, StartStatistic


# ----------------------------------------------------------------------------------------------- run summaries
@dataclass(frozen=True)
class ForceStatistics(JsonRecord):
    """Statistics of the magnitude of a force (N) or moment (N m) over revolutions 2..N of a run.

    Attributes
    ----------
    peak : float
        Peak (N or N m).
    mean : float
        Mean (N or N m).
    rms : float
        Root mean square (N or N m).
    p95 : float
        95th percentile (N or N m).
    static_equivalent : float, optional
        A multibody run's clearance pair: the p95 of its impact peaks (N; berryshaker.multibody.impacts).
    fatigue_equivalent : float, optional
        A multibody run's clearance pair: ISO 281's mean equivalent load of its impact peaks (N).
    """

    peak: float
    mean: float
    rms: float
    p95: float
    static_equivalent: float | None = optional()
    fatigue_equivalent: float | None = optional()



@dataclass(frozen=True, kw_only=True)
class MultibodyRow(JsonRecord):
    """One clearance row's multibody run (:func:`berryshaker.drives.simulation.multibody_summary`).

    Attributes
    ----------
    model : str
        "multibody".
    drive : str
        The drive's name (e.g. "groove_cam").
    clearance_mm : dict of str to float
        Clearance size per pair (mm; 0: an ideal joint).
    collision_force_N : dict of str to ForceStatistics
        Per pair, its collision force (an ideal joint: its reaction force) (N).
    pair_state : dict of str to str
        Per pair, "clearance" or "ideal joint (reaction force)".
    load_moment_Nm : dict of str to ForceStatistics
        Per comb ("left", "right"), the aggregate bush's load moment about its shaft (N m); empty with a plant.
    drive_moment_Nm : DriveMoment
        The drive moment (N m).
    load_model : str or None
        "aggregate (no plant in this run)" where the load is the aggregate bush (absent otherwise).
    steps : int
        Accepted integrator steps.
    rejected_steps : int
        Rejected integrator steps.
    contact_onsets : dict of str to int
        Impacts per pair over the statistics window.
    contact_onsets_located : int
        Their total.
    event_cuts : int
        Integrator steps cut back to a contact onset (the whole run).
    wall_time_s : float
        Wall time of the run (s).
    revolutions : int
        Drive revolutions run.
    statistics_over : str
        The revolutions the statistics are over (e.g. "revolutions 2..3").
    driveline_mode : str or None
        "powered" when the run had a powered driveline (:func:`berryshaker.drives.powered.driveline_summary`;
        this and the fields below are absent otherwise).
    driveline_speed_ripple_percent : dict of str to float or None
        Speed ripple of the motor rotor and the input shaft (%).
    cam_speed_rpm : SpeedRange or None
        The driven shaft's speed: ``min``, ``max``, ``mean`` (r/min).
    speed_ripple_percent : float or None
        The driven shaft's speed ripple (%).
    input_power_W : float or None
        Mean input power (W).
    energy_per_revolution_J : dict of str to float or None
        Energy dissipated per revolution, per element (J).
    energy_audit : dict or None
        The run's energy audit (J; :func:`berryshaker.multibody.energy.energy_audit`, a table of the engine).
    """

    model: str
    drive: str
    clearance_mm: dict[str, float]
    collision_force_N: dict[str, ForceStatistics]
    pair_state: dict[str, str]
    load_moment_Nm: dict[str, ForceStatistics]
    drive_moment_Nm: DriveMoment
    load_model: str | None = optional()
    steps: int
    rejected_steps: int
    contact_onsets: dict[str, int]
    contact_onsets_located: int
    event_cuts: int
    wall_time_s: float
    revolutions: int
    statistics_over: str
    driveline_mode: str | None = optional()
    driveline_speed_ripple_percent: dict[str, float] | None = optional()
    cam_speed_rpm: SpeedRange | None = optional()
    speed_ripple_percent: float | None = optional()
    input_power_W: float | None = optional()
    energy_per_revolution_J: dict[str, float] | None = optional()
    energy_audit: dict | None = optional()



@dataclass(frozen=True)
class ReducedDriveMoment(JsonRecord):
    """The reduced model's drive moment on the cam in its direction of rotation (eq. 9), over revolutions 2..N.

    Attributes
    ----------
    peak : float
        Peak magnitude (N m).
    rms : float
        Root mean square (N m).
    mean : float
        Signed mean (N m).
    mean_abs : float
        Mean magnitude (N m).
    mean_power_W : float
        Mean drive power (W).
    """

    peak: float
    rms: float
    mean: float
    mean_abs: float
    mean_power_W: float


@dataclass(frozen=True)
class ReducedRow(JsonRecord):
    """One clearance row's reduced-model run (the groove cam's MLSD summary,
    :meth:`berryshaker.drives.groove_cam.mlsd.MlsdResult.summary`).

    Attributes
    ----------
    model : str
        "mlsd".
    clearance_mm : dict of str to float
        Clearance size per pair (mm).
    revolutions : int
        Drive revolutions run.
    statistics_over : str
        The revolutions the statistics are over.
    collision_force_N : dict of str to ForceStatistics
        Per pair, its collision force (N).
    load_moment_Nm : dict of str to MomentStatistics
        Per comb ("left", "right"), its load moment (N m).
    drive_moment_Nm : ReducedDriveMoment
        The drive moment (N m) and mean power (W).
    bearing_reaction_N : dict of str to ForceStatistics
        Per push-rod bearing ("G", "H"), its reaction (N).
    steps : int
        Accepted integrator steps.
    rejected_steps : int
        Rejected integrator steps.
    wall_time_s : float
        Wall time of the run (s).
    contact_onsets : dict of str to int
        Impacts per pair on the written series.
    contact_onsets_located : int
        Their total.
    contact_onsets_every_step : dict of str to int
        Impacts per pair on every accepted integrator step.
    event_cuts : int
        Integrator steps cut back to a contact onset.
    """

    model: str
    clearance_mm: dict[str, float]
    revolutions: int
    statistics_over: str
    collision_force_N: dict[str, ForceStatistics]
    load_moment_Nm: dict[str, MomentStatistics]
    drive_moment_Nm: ReducedDriveMoment
    bearing_reaction_N: dict[str, ForceStatistics]
    steps: int
    rejected_steps: int
    wall_time_s: float
    contact_onsets: dict[str, int]
    contact_onsets_located: int
    contact_onsets_every_step: dict[str, int]
    event_cuts: int


# ------------------------------------------------------------------------------------------ perturbed starts

@dataclass(frozen=True)
class PairStarts(JsonRecord):
    """A pair's collision force over a row's perturbed starts.

    Attributes
    ----------
    peak : StartStatistic
        The per-start peaks (N): each run's single largest force, an extreme.
    mean : StartStatistic
        The per-start means (N).
    static_equivalent : StartStatistic, optional
        The per-start static-equivalent loads (N): the p95 of the run's impact peaks (a pair closed to an ideal
        joint: the p95 of its reaction), the load the claims on collision forces are judged on.
    """

    peak: StartStatistic
    mean: StartStatistic
    static_equivalent: StartStatistic | None = optional()


@dataclass(frozen=True)
class RowStarts(JsonRecord):
    """A clearance row's perturbed starts (:func:`berryshaker.study.steps.clearance_rows.row_start_statistics`).

    Attributes
    ----------
    pairs : dict of str to PairStarts
        Per pair, the statistics of its collision force (N).
    starts : int
        Starts that finished.
    """

    pairs: dict[str, PairStarts]
    starts: int


# ------------------------------------------------------------------------------------- agreement of the models
@dataclass(frozen=True)
class EnsembleStatistic(JsonRecord):
    """One statistic of a collision force over one model's replicate starts.

    Attributes
    ----------
    mean : float
        Mean over the runs (N).
    se : float
        Its standard error (N).
    sd : float
        The runs' standard deviation (N).
    n : int
        Runs.
    """

    mean: float
    se: float
    sd: float
    n: int


@dataclass(frozen=True)
class EnsembleAgreement(JsonRecord):
    """One pair's model check: the two models' statistics over their replicate starts
    (:func:`berryshaker.experiment.agreement.ensemble_agreement`; a = multibody, b = reduced model).

    Attributes
    ----------
    a : dict of str to EnsembleStatistic
        Per statistic ("mean", "rms", "p95"), the multibody model's (N).
    b : dict of str to EnsembleStatistic
        The same of the reduced model (N).
    relative_difference : dict of str to float
        Per statistic, |m_a - m_b| / max(m_a, m_b) (dimensionless).
    noise : dict of str to float
        Per statistic, the 95 % noise band of that difference (relative).
    single_run_noise : dict of str to float
        Per statistic, the band of a difference between two single runs (relative).
    tolerance : dict of str to float
        Per statistic, the tolerance (relative).
    verdicts : dict of str to str
        Per statistic, "agree", "differ" or "within noise".
    verdict : str
        "differ" if any differs, "agree" if all agree, else "within noise".
    agree : bool
        The verdict is "agree".
    """

    a: dict[str, EnsembleStatistic]
    b: dict[str, EnsembleStatistic]
    relative_difference: dict[str, float]
    noise: dict[str, float]
    single_run_noise: dict[str, float]
    tolerance: dict[str, float]
    verdicts: dict[str, str]
    verdict: str
    agree: bool


@dataclass(frozen=True)
class ModelRuns(JsonRecord):
    """A count of runs per model.

    Attributes
    ----------
    multibody : int
        Multibody runs.
    reduced : int
        Reduced-model runs.
    """

    multibody: int
    reduced: int


@dataclass(frozen=True)
class ModelCheck(JsonRecord):
    """The model check of claim 1 (:func:`berryshaker.experiment.agreement.model_check`) at one level.

    Attributes
    ----------
    level : int
        The clearance level set checked.
    starts : ModelRuns
        Runs per model that finished.
    planned : ModelRuns
        Runs per model asked for.
    pairs : dict of str to EnsembleAgreement
        Per pair, the two models' agreement over their starts (N, relative).
    """

    level: int
    starts: ModelRuns
    planned: ModelRuns
    pairs: dict[str, EnsembleAgreement]


@dataclass(frozen=True)
class RowAgreement(JsonRecord):
    """One row-pair's agreement of one run per model
    (:func:`berryshaker.experiment.agreement.summary_statistics_agreement`).

    Attributes
    ----------
    relative_difference : dict of str to float
        Per statistic ("mean", "rms", "p95"), the relative difference (dimensionless).
    worst : str
        The statistic furthest outside (or closest to) its tolerance.
    verdict : str
        "agree", "differ" or "within noise".
    agree : bool
        The verdict is "agree".
    noise : dict of str to float or None
        Per statistic, the single-run noise band it was judged with (relative; absent without a model check).
    verdicts : dict of str to str or None
        Per statistic, its verdict (absent without a model check).
    """

    relative_difference: dict[str, float]
    worst: str
    verdict: str
    agree: bool
    noise: dict[str, float] | None = optional()
    verdicts: dict[str, str] | None = optional()


@dataclass(frozen=True)
class ClearanceRows(JsonRecord):
    """Step ``clearance_rows``: every clearance row in the multibody and the reduced model.

    Attributes
    ----------
    multibody : dict of str to MultibodyRow
        Row ("1", "2", ...) -> its multibody run (forces N, moments N m); failed rows are left out.
    mlsd : dict of str to ReducedRow
        Row -> its reduced-model run; empty when the drive has none.
    starts : dict of str to RowStarts
        Row -> its multibody perturbed starts' collision-force statistics (N); rows with fewer than two finished
        starts are left out.
    model_check : ModelCheck or None
        The model check at the model-check level (absent without a reduced model or without enough starts).
    agreement : dict of str to dict of str to RowAgreement or None
        Row -> pair -> agreement of the two models' runs (absent without a reduced model).
    """

    multibody: dict[str, MultibodyRow]
    mlsd: dict[str, ReducedRow]
    starts: dict[str, RowStarts]
    model_check: ModelCheck | None = optional()
    agreement: dict[str, dict[str, RowAgreement]] | None = optional()


# ------------------------------------------------------------------------------------- step model_agreement
@dataclass(frozen=True)
class StatisticsAgreement(JsonRecord):
    """The impact statistics of two force series (:func:`berryshaker.experiment.agreement.statistics_agreement`;
    a = multibody, b = reduced model).

    Attributes
    ----------
    a : dict of str to float
        ``mean``, ``rms``, ``p95`` (N) and ``impulse_per_revolution`` (N s) of the multibody series.
    b : dict of str to float
        The same of the reduced model's series.
    relative_difference : dict of str to float
        Per statistic, the relative difference (dimensionless).
    tolerance : dict of str to float
        Per statistic, the tolerance (relative).
    agree : bool
        Every difference is within its tolerance.
    """

    a: dict[str, float]
    b: dict[str, float]
    relative_difference: dict[str, float]
    tolerance: dict[str, float]
    agree: bool


@dataclass(frozen=True)
class PeakForces(JsonRecord):
    """A pair's peak collision force in each model.

    Attributes
    ----------
    multibody : float
        The multibody model's (N).
    reduced : float
        The reduced model's (N).
    """

    multibody: float
    reduced: float


@dataclass(frozen=True)
class PairAgreement(JsonRecord):
    """One pair's collision-force curves of one run per model (:func:`berryshaker.experiment.agreement.curve_agreement`).

    Attributes
    ----------
    f_statistic : float
        The study's eq. 18 F (dimensionless).
    f_critical : float
        Its critical value (dimensionless).
    alpha : float
        Significance level (dimensionless).
    points : int
        Samples of each curve in the F test.
    eq18_agree : bool
        F below its critical value.
    agree : bool
        The impact statistics agree (``statistics.agree``).
    statistics : StatisticsAgreement
        The impact statistics of both curves (N, N s).
    nrmse : float
        Normalised RMS difference (dimensionless).
    correlation : float
        Correlation of the curves (dimensionless; NaN where one is constant).
    peak_ratio : float
        Multibody peak / reduced peak (dimensionless).
    mean_ratio : float
        Multibody mean / reduced mean (dimensionless).
    peak_N : PeakForces
        Each model's peak (N).
    """

    f_statistic: float
    f_critical: float
    alpha: float
    points: int
    eq18_agree: bool
    agree: bool
    statistics: StatisticsAgreement
    nrmse: float
    correlation: float
    peak_ratio: float
    mean_ratio: float
    peak_N: PeakForces


@dataclass(frozen=True)
class ModelAgreement(JsonRecord):
    """Step ``model_agreement``: the reduced model against the multibody model at the model-check level, one run of
    each from the centred start (eq. 18 and plainer measures).

    Attributes
    ----------
    clearance_mm : dict of str to float
        The level's clearance per pair (mm).
    pairs : dict of str to PairAgreement
        Per pair, the agreement of the two curves.
    """

    clearance_mm: dict[str, float]
    pairs: dict[str, PairAgreement]


__all__ = ["ForceStatistics", "MultibodyRow", "ReducedDriveMoment", "ReducedRow",
           "PairStarts", "RowStarts", "EnsembleStatistic", "EnsembleAgreement", "ModelRuns",
           "ModelCheck", "RowAgreement", "ClearanceRows", "StatisticsAgreement", "PeakForces", "PairAgreement",
           "ModelAgreement"]
