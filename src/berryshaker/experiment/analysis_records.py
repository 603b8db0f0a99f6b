"""Typed results of the range analysis of an orthogonal-array test (:func:`berryshaker.experiment.analysis.analyze`:
:class:`RangeAnalysis` per response in a :class:`DoeAnalysis`) with its ANOVA, regression, composite and optimum
sub-records, and the records the replicated analysis shares (:class:`FactorLevels`, :class:`AnovaTerm`,
:class:`ErrorTerm`, :class:`Regression`; the replicated analysis' own are in
:mod:`berryshaker.experiment.replicated_records`).  Their :meth:`~berryshaker.records.JsonRecord.to_json` is the
JSON of ``doe analyze`` and of the study's L9, key for key.

Maps keyed by data (per factor, per response, per regression term) stay ``dict`` fields, their values records where
the values have fixed keys.
"""

from __future__ import annotations

from dataclasses import dataclass

from berryshaker.records import JsonRecord, optional


@dataclass(frozen=True)
class FactorLevels(JsonRecord):
    """A factor's levels as reported (:func:`berryshaker.experiment.analysis.factor_levels_report`).

    Attributes
    ----------
    level_numbers : list of int
        The level numbers (1-based).
    values : list of float or None
        Each level's value (the factor's unit, :attr:`unit`); None when unknown.
    unit : str
        The factor's unit ('' for none).
    labels : list of str
        "0.25 mm" per level, or "level 1" ... when the values are unknown.
    """

    level_numbers: list[int]
    values: list[float] | None
    unit: str
    labels: list[str]


@dataclass(frozen=True)
class FactorEffect(JsonRecord):
    """One factor's range analysis (:func:`berryshaker.experiment.analysis.range_analysis`).

    Attributes
    ----------
    K : list of float
        Sum of the response at each level (the response's unit).
    level_means : list of float
        Mean of the response at each level (the response's unit).
    range : float
        Largest minus smallest level mean (the response's unit).
    best_level : int
        The best level (1-based) for the response's sense.
    """

    K: list[float]
    level_means: list[float]
    range: float
    best_level: int


@dataclass(frozen=True)
class ErrorTerm(JsonRecord):
    """An error (or lack-of-fit) line of an ANOVA table.

    Attributes
    ----------
    ss : float
        Sum of squares (the response's unit squared).
    df : int
        Degrees of freedom.
    ms : float
        Mean square (the response's unit squared; NaN without degrees of freedom).
    kind : str, optional
        What the error is (pure error or the run x block interaction); the replicated analysis' ``error`` only.
    f : float, optional
        F ratio against the error (dimensionless); lack of fit with degrees of freedom only.
    p : float, optional
        p-value of that F test (dimensionless).
    """

    ss: float
    df: int
    ms: float
    kind: str | None = optional()
    f: float | None = optional()
    p: float | None = optional()


@dataclass(frozen=True)
class AnovaTerm(JsonRecord):
    """One factor's row of an ANOVA table.

    Attributes
    ----------
    ss : float
        Sum of squares (the response's unit squared).
    df : int
        Degrees of freedom.
    ms : float
        Mean square (the response's unit squared).
    f : float
        F ratio against the error (dimensionless).
    p : float
        p-value of the F test (dimensionless).
    significant : bool, optional
        p < alpha (the replicated analysis only).
    error : ErrorTerm, optional
        The error this factor is tested against (the replicated analysis only: its own interaction with the
        blocks, or the pure error).
    """

    ss: float
    df: int
    ms: float
    f: float
    p: float
    significant: bool | None = optional()
    error: ErrorTerm | None = optional()


@dataclass(frozen=True)
class Anova(JsonRecord):
    """Main-effect ANOVA of an unreplicated test with the weakest factor pooled when no error remains
    (:func:`berryshaker.experiment.analysis.anova_pooled`).

    Attributes
    ----------
    factors : dict of str to AnovaTerm
        Per tested factor its row.
    error : ErrorTerm
        The error (the pooled factors' and the residual's; the response's unit squared).
    pooled : list of str
        The factors pooled into the error.
    ss_all : dict of str to float
        Every factor's sum of squares (the response's unit squared).
    total_ss : float
        Total sum of squares (the response's unit squared).
    """

    factors: dict[str, AnovaTerm]
    error: ErrorTerm
    pooled: list[str]
    ss_all: dict[str, float]
    total_ss: float


@dataclass(frozen=True)
class CodedRange(JsonRecord):
    """A factor's range coded to -1..1 in the regression.

    Attributes
    ----------
    low : float
        Its lowest level value (the factor's unit), coded -1.
    high : float
        Its highest level value (the factor's unit), coded +1.
    """

    low: float
    high: float


@dataclass(frozen=True)
class MainQuadratic(JsonRecord):
    """The main-effects quadratic fit (intercept, linear, squares) of the eq. 19 regression.

    Attributes
    ----------
    terms : list of str
        Its terms.
    coefficients : dict of str to float
        Coefficient per term on the coded factors (the response's unit).
    r2 : float
        Coefficient of determination (dimensionless).
    residual_df : int
        Residual degrees of freedom.
    note : str
        "saturated: ..." when it interpolates the data, else ''.
    """

    terms: list[str]
    coefficients: dict[str, float]
    r2: float
    residual_df: int
    note: str


@dataclass(frozen=True)
class RidgeQuadratic(JsonRecord):
    """The ridge-regularised full eq. 19 (coefficients shrunk, not estimated).

    Attributes
    ----------
    label : str
        The fit's label (it is regularised).
    penalty : float
        Ridge penalty chosen by leave-one-out cross-validation (dimensionless, on standardised terms).
    coefficients : dict of str to float
        Coefficient per term on the coded factors (the response's unit).
    r2 : float
        Coefficient of determination (dimensionless).
    loo_mse : float
        Leave-one-out mean squared error (the response's unit squared).
    """

    label: str
    penalty: float
    coefficients: dict[str, float]
    r2: float
    loo_mse: float


@dataclass(frozen=True)
class Regression(JsonRecord):
    """The study's eq. 19 quadratic regression handled honestly
    (:func:`berryshaker.experiment.analysis.quadratic_regression`, without its scaling).

    Attributes
    ----------
    coded_factors : dict of str to CodedRange
        Per factor its coded range (the factor's unit).
    coding : str
        The coding in words.
    full_model_terms : list of str
        The 15 terms of eq. 19 (for four factors).
    runs : int
        Runs fitted.
    full_model_rank : int
        Rank of the full model's design matrix at the runs.
    identifiable : bool
        Whether every full-model term is estimable.
    estimable_terms : list of str
        The estimable terms (in hierarchical order).
    aliased_terms : list of str
        The others.
    main_effects_quadratic : MainQuadratic
        The largest identifiable hierarchy's fit.
    ridge_full_quadratic : RidgeQuadratic
        The regularised full fit.
    """

    coded_factors: dict[str, CodedRange]
    coding: str
    full_model_terms: list[str]
    runs: int
    full_model_rank: int
    identifiable: bool
    estimable_terms: list[str]
    aliased_terms: list[str]
    main_effects_quadratic: MainQuadratic
    ridge_full_quadratic: RidgeQuadratic


@dataclass(frozen=True)
class RangeAnalysis(JsonRecord):
    """One response's range analysis with its pooled ANOVA and regression (a response of
    :func:`berryshaker.experiment.analysis.analyze`).

    Attributes
    ----------
    factors : dict of str to FactorEffect
        Per factor its level sums, level means, range (the response's unit) and best level.
    ranking : list of str
        Factors by decreasing range.
    maximize : bool
        Whether larger is better.
    best_levels : dict of str to int
        Best level (1-based) per factor.
    anova : Anova
        The ANOVA with pooling.
    regression : Regression
        The eq. 19 regression.
    """

    factors: dict[str, FactorEffect]
    ranking: list[str]
    maximize: bool
    best_levels: dict[str, int]
    anova: Anova
    regression: Regression


@dataclass(frozen=True)
class CompositeScore(JsonRecord):
    """The range analysis of the weighted composite score (:func:`berryshaker.experiment.analysis.composite_score`).

    Attributes
    ----------
    method : str
        How the score is made.
    score : list of float
        Score per run, 0..1 (dimensionless, 1 = best).
    factors : dict of str to FactorEffect
        Per factor the range analysis of the score (dimensionless).
    ranking : list of str
        Factors by decreasing range of the score.
    """

    method: str
    score: list[float]
    factors: dict[str, FactorEffect]
    ranking: list[str]


@dataclass(frozen=True)
class RangeOptimum(JsonRecord):
    """The composite score's best levels with the responses predicted there by the additive model.

    Attributes
    ----------
    levels : dict of str to int
        Best level (1-based) per factor.
    settings : dict of str to str
        Its label per factor ("0.25 mm" or "level 2").
    values : dict of str to float
        Predicted value per response (the response's unit).
    prediction : str
        The prediction model in words.
    intervals : dict of str to list of float, optional
        Each predicted value's interval (the response's unit; a field sheet's analysis: the pooled error over
        Taguchi's effective number of replications, :func:`berryshaker.experiment.desirability.level_set_prediction`).
    """

    levels: dict[str, int]
    settings: dict[str, str]
    values: dict[str, float]
    prediction: str
    intervals: dict[str, list[float]] | None = optional()


@dataclass(frozen=True)
class Goal(JsonRecord):
    """One response's goal in the desirability optimiser (``--desirability efficiency=max:2..5kg/min``;
    :func:`berryshaker.experiment.desirability.parse_desirability`).

    Attributes
    ----------
    goal : str
        "maximize", "minimize" or "target".
    low : float
        Lower limit (the response's unit in the sheet, ``unit``).
    high : float
        Upper limit (the response's unit).
    target : float, optional
        The target (the response's unit); "target" goals only.
    unit : str
        The response's unit ('' for none); the limits were given in it or converted to it.
    """

    goal: str
    low: float
    high: float
    target: float | None = optional()
    unit: str = ""


@dataclass(frozen=True)
class DesirabilityCandidate(JsonRecord):
    """A level set and its overall desirability.

    Attributes
    ----------
    levels : dict of str to int or None
        Level (1-based) per factor; None: the factor changes none of the goals' predictions.
    overall : float
        Overall desirability D (dimensionless, 0..1).
    """

    levels: dict[str, int | None]
    overall: float


@dataclass(frozen=True)
class DesirabilityOptimum(JsonRecord):
    """The Derringer-Suich desirability optimum over the level sets of the factors
    (:func:`berryshaker.experiment.desirability.desirability_optimum`).

    Attributes
    ----------
    goals : dict of str to Goal
        Per response its goal and limits.
    levels : dict of str to int or None
        The best level set (1-based); None for a factor that changes none of the goals' predictions, and for every
        factor when no level set meets every goal's limits (``overall`` 0).
    settings : dict of str to str or None
        Its label per factor.
    values : dict of str to float
        Predicted mean per goal response there (the response's unit).
    intervals : dict of str to list of float
        Its interval (the response's unit).
    desirability : dict of str to float
        Each goal's desirability d_i there (dimensionless, 0..1).
    overall : float
        The overall desirability D, the geometric mean of the d_i (dimensionless).
    ties : int
        Level sets with the same D.
    candidates : list of DesirabilityCandidate
        The best level sets, best first (at most five).
    method : str
        The rule in words.
    note : str
        What the result does not tell ('' when nothing).
    """

    goals: dict[str, Goal]
    levels: dict[str, int | None]
    settings: dict[str, str | None]
    values: dict[str, float]
    intervals: dict[str, list[float]]
    desirability: dict[str, float]
    overall: float
    ties: int
    candidates: list[DesirabilityCandidate]
    method: str
    note: str


@dataclass(frozen=True, kw_only=True)
class DoeAnalysis(JsonRecord):
    """The range analysis of an unreplicated orthogonal test (:func:`berryshaker.experiment.analysis.analyze`);
    read from a sheet (:func:`berryshaker.experiment.field_results.analyze_sheet`) it has the sheet's fields too.

    Attributes
    ----------
    responses : dict of str to RangeAnalysis
        Per response its range analysis.
    weights : dict of str to float
        Weights of the composite (dimensionless, summing to 1).
    factors : dict of str to FactorLevels
        Per factor its levels.
    composite : CompositeScore
        The composite score's range analysis.
    optimum : RangeOptimum
        The composite's optimum.
    replicates : int, optional
        Replicates per run of the sheet (1).
    weights_given : bool, optional
        Whether the weights were given (else equal).
    response_units : dict of str to str, optional
        Unit per response ('' where the sheet gives none).
    runs_identified_by : str, optional
        How the sheet's runs were told apart.
    desirability : DesirabilityOptimum, optional
        The desirability optimum (``doe analyze --desirability``).
    """

    responses: dict[str, RangeAnalysis]
    weights: dict[str, float]
    factors: dict[str, FactorLevels]
    composite: CompositeScore
    optimum: RangeOptimum
    replicates: int | None = optional()
    weights_given: bool | None = optional()
    response_units: dict[str, str] | None = optional()
    runs_identified_by: str | None = optional()
    desirability: DesirabilityOptimum | None = optional()


__all__ = ["Anova", "AnovaTerm", "CodedRange", "CompositeScore", "DesirabilityCandidate", "DesirabilityOptimum",
           "DoeAnalysis", "Goal", "ErrorTerm", "FactorEffect",
           "FactorLevels", "MainQuadratic", "RangeAnalysis", "RangeOptimum", "Regression", "RidgeQuadratic"]
