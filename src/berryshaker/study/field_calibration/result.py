"""The result of :func:`~berryshaker.study.field_calibration.calibrate` as typed records:
:class:`CalibrationResult` and its parts.  The command ``berryshaker calibrate`` writes
:meth:`CalibrationResult.to_json` (``--json``, ``calibration.json``) and :mod:`berryshaker.report.calibration`
reads the attributes (without importing these classes: the report layer is below the study layer).
:meth:`CalibrationResult.from_json` reads a written result back, validated (an unknown key or a value of the wrong
type is an error naming the field).

Every record's fields are declared in the order of the JSON keys; maps keyed by data (per parameter, per response,
per factor) are ``dict`` fields.  Responses are in their own units (efficiency kg/min, or kg/min per kg of yield per
bush in the emulator's checks; unripe and damage rates %); parameters in their SI units
(:data:`~berryshaker.study.field_calibration.priors.PARAMETERS`).

long module: twenty-two small records, one per part of the result, each with its Attributes and units; they form one
tree, written and read back together, so they stay in one place.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from berryshaker.records import JsonRecord, optional


@dataclass(frozen=True)
class PriorSummary(JsonRecord):
    """A parameter's prior (:class:`~berryshaker.study.field_calibration.priors.Parameter`).

    Attributes
    ----------
    distribution : str
        The prior's family, e.g. ``lognormal``.
    text : str
        The prior in words, with its central 90 % interval and unit.
    lo90 : float
        Lower end of the prior's central 90 % interval (the parameter's unit, SI).
    hi90 : float
        Upper end of the prior's central 90 % interval (the parameter's unit, SI).
    source : str
        Where the range comes from.
    tag : str
        Provenance tag, e.g. ``[published range; ...]``.
    """

    distribution: str
    text: str
    lo90: float
    hi90: float
    source: str
    tag: str


@dataclass(frozen=True)
class ParameterSummary(JsonRecord):
    """Prior against posterior of one calibrated parameter
    (:data:`~berryshaker.study.field_calibration.workflow.IDENTIFIED_RULE`).

    Attributes
    ----------
    unit : str
        The parameter's SI unit ("" for a fraction).
    prior : PriorSummary
        Its prior.
    described : float
        The machine description's value (the parameter's unit).
    posterior_mean : float
        Posterior mean (the parameter's unit).
    posterior_median : float
        Posterior median (the parameter's unit).
    lo90 : float
        Lower end of the posterior's central 90 % interval (the parameter's unit).
    hi90 : float
        Upper end of the posterior's central 90 % interval (the parameter's unit).
    width_ratio : float
        Posterior 90 % width over the prior's (1).
    identified : bool
        ``width_ratio < 0.5``.
    """

    unit: str
    prior: PriorSummary
    described: float
    posterior_mean: float
    posterior_median: float
    lo90: float
    hi90: float
    width_ratio: float
    identified: bool


@dataclass(frozen=True)
class Confounding(JsonRecord):
    """Two parameters the sheet does not separate
    (:data:`~berryshaker.study.field_calibration.workflow.CONFOUNDED_RULE`).

    Attributes
    ----------
    parameters : list of str
        The two parameters' names.
    correlation : float
        Their posterior correlation on the prior's normal scores (1).
    """

    parameters: list[str]
    correlation: float


@dataclass(frozen=True)
class SettingValue(JsonRecord):
    """One factor's value at a predicted level set.

    Attributes
    ----------
    value : float
        The value in the sheet's unit of the factor (``unit``).
    unit : str
        That unit, e.g. ``mm`` or ``rpm``.
    """

    value: float
    unit: str


@dataclass(frozen=True)
class ResponsePrediction(JsonRecord):
    """Prediction of one response at a level set: a future field result.

    Attributes
    ----------
    mean : float
        Expected field result, mean over the posterior draws (the response's unit).
    lo90 : float
        Lower end of the 90 % interval of a future field result (the response's unit).
    hi90 : float
        Upper end of that interval (the response's unit).
    unit : str
        The response's unit: kg/min or %.
    """

    mean: float
    lo90: float
    hi90: float
    unit: str


@dataclass(frozen=True)
class Prediction(JsonRecord):
    """The predictions at one level set of the sheet's factors (or one named setting, ``--predict``).

    Attributes
    ----------
    level_set : str
        The level set in words, e.g. ``C=0.1mm, speed=150rpm``.
    setting : dict of str to SettingValue
        Per factor its value (the sheet's units).
    tested : bool
        A run of the sheet is at this setting.
    named : bool
        A setting given with ``--predict`` (not a level set of the sheet).
    extrapolated : bool
        Outside the sheet's level ranges (the emulator extrapolates).
    responses : dict of str to ResponsePrediction
        Per response its prediction.
    """

    level_set: str
    setting: dict[str, SettingValue]
    tested: bool
    named: bool
    extrapolated: bool
    responses: dict[str, ResponsePrediction]


@dataclass(frozen=True)
class CalibrationRecommendation(JsonRecord):
    """The recommended level set (:data:`~berryshaker.study.field_calibration.workflow.RECOMMENDATION_RULE`).

    Attributes
    ----------
    level_set : str
        The recommended level set.
    score : float
        Its weighted score of the predicted means, each response scaled 0..1 over the level sets (1).
    no_difference : list of str
        The other undominated level sets (no difference beyond the intervals).
    dominated : int
        Number of dominated level sets.
    candidates : int
        Number of level sets compared.
    rule : str
        The rule in words.
    weights : dict of str to float
        Per response its weight in the score (fractions summing to 1).
    """

    level_set: str
    score: float
    no_difference: list[str]
    dominated: int
    candidates: int
    rule: str
    weights: dict[str, float]


@dataclass(frozen=True)
class EmulatorCheck(JsonRecord):
    """Held-out error of the emulator for one response (points it was not trained on).

    Attributes
    ----------
    rmse : float
        RMSE of the emulated replicate mean (the response's unit, ``unit``).
    replicate_sd_rms : float
        RMS of the simulated replicate SD (the response's unit, ``unit``).
    rmse_over_sd : float
        ``rmse / replicate_sd_rms`` (1; NaN when the SD is 0).
    log_sd_rmse : float
        RMSE of log SD (1).
    mse_log_mean : float
        MSE of log(mean + c) (1): the emulator's error term in the likelihood.
    relative_rmse : float
        Its root, about the relative error of mean + c (1).
    points : int
        Points checked.
    unit : str
        The response's unit: kg/min per kg of yield per bush (efficiency) or %.
    """

    rmse: float
    replicate_sd_rms: float
    rmse_over_sd: float
    log_sd_rmse: float
    mse_log_mean: float
    relative_rmse: float
    points: int
    unit: str


@dataclass(frozen=True)
class EmulatorSummary(JsonRecord):
    """The emulator: its kind, training and held-out checks.

    Attributes
    ----------
    kind : str
        The Gaussian processes in words.
    joint_fitted : bool
        The joint GP over (coded setting, theta) is fitted.
    joint_points : int
        Training points budget of the joint GP.
    training_points : int
        Training points of the per-setting GPs (settings x parameter points).
    theta_points_per_setting : int
        Latin-hypercube parameter points per simulated setting.
    held_out_theta : dict of str to EmulatorCheck
        Per response the check at held-out parameter points of the simulated settings.
    held_out_settings : dict of str to EmulatorCheck
        Per response the check at the untested check settings (empty without check settings).
    held_out_settings_at : str
        Where that check is made, in words.
    check_settings : list of str
        The check settings in words.
    untested_relative_rmse : dict of str to float
        Per response the joint GP's error term at settings not simulated, relative RMSE of mean + c (1).
    untested_error_rule : str
        That error term's rule in words.
    fit_s : float
        Wall time of the per-setting GPs' fit (s).
    """

    kind: str
    joint_fitted: bool
    joint_points: int
    training_points: int
    theta_points_per_setting: int
    held_out_theta: dict[str, EmulatorCheck]
    held_out_settings: dict[str, EmulatorCheck]
    held_out_settings_at: str
    check_settings: list[str]
    untested_relative_rmse: dict[str, float]
    untested_error_rule: str
    fit_s: float


@dataclass(frozen=True)
class RunCheck(JsonRecord):
    """One sheet run's observed mean against its 90 % predictive interval, for one response.

    Attributes
    ----------
    run : int
        The sheet's run (1-based).
    setting : str
        Its setting in words.
    response : str
        The response.
    observed_mean : float
        Mean of the run's replicates (the response's unit: kg/min or %).
    lo90 : float
        Lower end of the 90 % predictive interval of the mean of the run's replicates (the response's unit).
    hi90 : float
        Upper end of that interval (the response's unit).
    inside : bool
        ``lo90 <= observed_mean <= hi90``.
    """

    run: int
    setting: str
    response: str
    observed_mean: float
    lo90: float
    hi90: float
    inside: bool


@dataclass(frozen=True)
class CheckSummary(JsonRecord):
    """How many posterior predictive checks hold.

    Attributes
    ----------
    inside : int
        Checks with the observed mean inside its interval.
    total : int
        Checks (runs x responses).
    rule : str
        The check in words.
    """

    inside: int
    total: int
    rule: str


@dataclass(frozen=True)
class HeldOutRun(JsonRecord):
    """The held-out run: calibrated without the sheet's first run, which is then predicted.  Done: ``run``,
    ``rows`` and ``steps``; not done: ``reason``.

    Attributes
    ----------
    done : bool
        It was made (runs > parameters + 2, and asked for).
    reason : str, optional
        Why not (only when not done).
    run : int, optional
        The held-out run (1).
    rows : list of RunCheck, optional
        Per response the held-out run against its predictive interval.
    steps : int, optional
        MCMC steps per walker of that calibration.
    """

    done: bool
    reason: str | None = optional()
    run: int | None = optional()
    rows: list[RunCheck] | None = optional()
    steps: int | None = optional()


@dataclass(frozen=True)
class Checks(JsonRecord):
    """The posterior predictive checks and the held-out run.

    Attributes
    ----------
    posterior_predictive : list of RunCheck
        Per response and run (response by response) its check.
    summary : CheckSummary
        How many hold.
    held_out_run : HeldOutRun
        The held-out run.
    """

    posterior_predictive: list[RunCheck]
    summary: CheckSummary
    held_out_run: HeldOutRun


@dataclass(frozen=True)
class SamplerSummary(JsonRecord):
    """The MCMC sampler's run.

    Attributes
    ----------
    walkers : int
        Walkers.
    steps : int
        Steps per walker.
    burn : int
        Burn-in steps discarded.
    thin : int
        Thinning (every n-th step kept).
    acceptance_fraction : float
        Mean acceptance fraction (1).
    autocorrelation_steps : list of float
        Per parameter the integrated autocorrelation time, a number of MCMC steps (1).
    converged : bool
        At least 50 autocorrelation times were run.
    draws : int
        Posterior draws kept.
    package : str
        The sampler package and its moves.
    """

    walkers: int
    steps: int
    burn: int
    thin: int
    acceptance_fraction: float
    autocorrelation_steps: list[float]
    converged: bool
    draws: int
    package: str


@dataclass(frozen=True)
class SimulatorSummary(JsonRecord):
    """The simulator's runs.

    Attributes
    ----------
    starts_per_setting : int
        Perturbed starts per setting (R_sim).
    seeds : list of int
        The starts' seeds.
    settings_simulated : int
        Settings simulated (the sheet's and the check settings).
    coupled_runs : int
        Coupled runs made or read from the cache.
    exact : str
        How a response at a parameter point is computed, in words.
    """

    starts_per_setting: int
    seeds: list[int]
    settings_simulated: int
    coupled_runs: int
    exact: str


@dataclass(frozen=True)
class FactorSummary(JsonRecord):
    """One factor of the sheet.

    Attributes
    ----------
    sets : str
        What it sets on the machine: a clearance pair's name or ``drive speed``.
    unit : str
        The sheet's unit of the factor.
    levels : list of float
        Its levels (the factor's unit, ``unit``).
    """

    sets: str
    unit: str
    levels: list[float]


@dataclass(frozen=True)
class SheetSummary(JsonRecord):
    """The field sheet calibrated to.

    Attributes
    ----------
    runs : int
        Runs of the sheet.
    replicates : int
        Replicates per run.
    responses : list of str
        The responses it has results of.
    factors : dict of str to FactorSummary
        Per factor what it sets, its unit and levels.
    runs_identified_by : str
        How the runs were told apart (e.g. ``run column``).
    file : str, optional
        The sheet's file (the command adds it).
    """

    runs: int
    replicates: int
    responses: list[str]
    factors: dict[str, FactorSummary]
    runs_identified_by: str
    file: str | None = optional()


@dataclass(frozen=True)
class HyperSummary(JsonRecord):
    """The posterior of a further field noise or a discrepancy amplitude of one response
    (berryshaker.study.field_calibration.posterior).

    Attributes
    ----------
    median : float
        Posterior median, as a fraction of the sheet's mean of the response (1).
    lo90, hi90 : float
        Its central 90 % interval (1).
    prior_scale : float
        The half-normal prior's scale (1).
    """

    median: float
    lo90: float
    hi90: float
    prior_scale: float


@dataclass(frozen=True)
class ResidualEffect(JsonRecord):
    """A factor's effect on the sheet's residuals from the calibrated model (what the model does not produce).

    Attributes
    ----------
    factor : str
        The sheet's factor.
    range : float
        Largest minus smallest level mean of the residuals (the response's unit).
    f : float
        F of the factor in the OLS of the residuals on every factor's levels (statsmodels anova_lm, type II; 1).
    p : float
        Its p-value (1).
    beyond_noise : bool
        p below 0.05 / the number of factors (Bonferroni).
    """

    factor: str
    range: float
    f: float
    p: float
    beyond_noise: bool


@dataclass(frozen=True)
class ModelDiscrepancy(JsonRecord):
    """What the sheet shows that the model does not produce, for one response.

    Attributes
    ----------
    scale : float
        The sheet's mean of the response (its unit): the scale of the two fractions below.
    unit : str
        The response's unit.
    field_noise : HyperSummary
        The further field noise kappa (beyond the model's field-test noise), SD as a fraction of ``scale``.
    amplitude : HyperSummary or None
        The discrepancy's amplitude alpha, SD as a fraction of ``scale``; None with the discrepancy off.
    residual_effects : list of ResidualEffect
        Per factor, the residuals' effect at the posterior median of the parameters.
    verdict : str
        In words: the model represents the sheet's effects, or which it cannot and what the predictions then do.
    """

    scale: float
    unit: str
    field_noise: HyperSummary
    amplitude: HyperSummary | None
    residual_effects: list[ResidualEffect]
    verdict: str


@dataclass(frozen=True)
class Timings(JsonRecord):
    """Wall times of the calibration's parts.

    Attributes
    ----------
    simulator : float
        The simulator's coupled runs (s).
    emulator : float
        Emulator training and checks (s).
    sampling : float
        The MCMC sampling (s).
    """

    simulator: float
    emulator: float
    sampling: float


@dataclass(frozen=True)
class CalibrationResult(JsonRecord):
    """The calibration of the harvest model to a field sheet (:func:`~berryshaker.study.field_calibration.calibrate`);
    the command adds the sheet's file, the provenance and the report folder.

    Attributes
    ----------
    parameters : dict of str to ParameterSummary
        Per calibrated parameter its prior against its posterior (the parameter's SI unit).
    identified_rule : str
        When a parameter counts as identified.
    confounded : list of Confounding
        Parameter pairs with a strong posterior correlation.
    confounded_rule : str
        When a pair counts as confounded.
    predictions : list of Prediction
        Per level set of the sheet's factors (then the named settings) its predictions.
    recommendation : CalibrationRecommendation
        The recommended level set.
    emulator : EmulatorSummary
        The emulator and its held-out checks.
    checks : Checks
        Posterior predictive checks and the held-out run.
    sampler : SamplerSummary
        The MCMC run.
    simulator : SimulatorSummary
        The simulator's runs.
    sheet : SheetSummary
        The field sheet.
    likelihood : str
        The likelihood in words.
    discrepancy : float
        Half-normal prior scale of the model discrepancy's amplitude, a fraction of the sheet's mean (1; 0: off).
    discrepancy_text : str
        The discrepancy in words.
    discrepancies : dict of str to ModelDiscrepancy
        Per response the further field noise, the discrepancy and the residual effects, with the verdict.
    limits : list of str
        The method's limits.
    timings_s : Timings
        Wall times of its parts (s).
    package : str, optional
        ``berryshaker`` (provenance, added by the command).
    version : str, optional
        The package version (provenance).
    code_sha256 : str, optional
        Fingerprint of the package's code (provenance).
    machine_si : dict, optional
        The machine description, SI (provenance).
    out : str, optional
        The report folder (``--out``; added after ``calibration.json`` is written, so only in ``--json``'s output).
    """

    parameters: dict[str, ParameterSummary]
    identified_rule: str
    confounded: list[Confounding]
    confounded_rule: str
    predictions: list[Prediction]
    recommendation: CalibrationRecommendation
    emulator: EmulatorSummary
    checks: Checks
    sampler: SamplerSummary
    simulator: SimulatorSummary
    sheet: SheetSummary
    likelihood: str
    discrepancy: float
    discrepancy_text: str
    discrepancies: dict[str, ModelDiscrepancy]
    limits: list[str]
    timings_s: Timings
    package: str | None = optional()
    version: str | None = optional()
    code_sha256: str | None = optional()
    machine_si: dict[str, Any] | None = optional()
    out: str | None = optional()


__all__ = ["CalibrationResult", "CheckSummary", "Checks", "Confounding", "EmulatorCheck", "EmulatorSummary",
           "FactorSummary", "HeldOutRun", "HyperSummary", "ModelDiscrepancy", "ParameterSummary", "ResidualEffect", "Prediction", "PriorSummary", "CalibrationRecommendation",
           "ResponsePrediction", "RunCheck", "SamplerSummary", "SettingValue", "SheetSummary", "SimulatorSummary",
           "Timings"]
