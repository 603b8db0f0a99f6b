"""Typed results of the analysis of a replicated orthogonal-array test
(:func:`berryshaker.experiment.replicates.analyze_replicated`: :class:`ReplicatedResponse` per response in a
:class:`ReplicatedAnalysis`, its weighted or tiered :class:`ReplicatedOptimum` with a :class:`Choice` per factor;
:class:`SheetReplicatedAnalysis` as ``doe analyze`` gives it).  Their :meth:`~berryshaker.records.JsonRecord.to_json`
is the JSON of ``doe analyze`` and of the study's replicated L9, key for key.
"""

from __future__ import annotations

from dataclasses import dataclass

from berryshaker.experiment.analysis_records import AnovaTerm, DesirabilityOptimum, ErrorTerm, FactorLevels, Regression
from berryshaker.records import JsonRecord, optional


@dataclass(frozen=True)
class PairedDifference(JsonRecord):
    """Two levels of a factor compared start by start (last minus first level, paired over the blocks;
    :func:`berryshaker.experiment.error_terms.paired_differences`).

    Attributes
    ----------
    levels : list of int
        The two levels compared ([first, last]).
    difference : float
        Mean paired difference, last minus first (the response's unit).
    se : float
        Its standard error (the response's unit).
    ci : list of float
        Its interval (the response's unit).
    p : float
        p of the paired t test over the starts (dimensionless).
    beyond_noise : bool
        Whether the difference is beyond the noise (p < alpha).
    """

    levels: list[int]
    difference: float
    se: float
    ci: list[float]
    p: float
    beyond_noise: bool


@dataclass(frozen=True)
class ReplicatedEffect(JsonRecord):
    """One factor's effect on a replicated response, judged against the replicate noise.

    Attributes
    ----------
    level_means : list of float
        Mean per level (the response's unit).
    level_se : list of float
        Standard error of each level mean, for comparisons between levels (the response's unit).
    level_ci : list of list of float
        Interval of each level mean (the response's unit).
    range : float
        Largest minus smallest level mean (the response's unit).
    range_ci : list of float
        Tukey-Kramer interval of the range (the response's unit).
    hsd : float
        Tukey-Kramer half-width of a level difference (the response's unit).
    significant : bool
        Whether the factor's F test has p < alpha.
    p : float
        Its p-value (dimensionless).
    paired : list of PairedDifference or None
        Every pair of levels compared within the blocks; None without blocks.
    K : list of float
        Level mean x observations per level (the response's unit).
    best_level : int
        The best level (1-based) for the response's sense.
    best_levels_within_noise : list of int
        Levels within the Tukey-Kramer margin of the best.
    verdict : str
        "level k best" or "no meaningful difference".
    """

    level_means: list[float]
    level_se: list[float]
    level_ci: list[list[float]]
    range: float
    range_ci: list[float]
    hsd: float
    significant: bool
    p: float
    paired: list[PairedDifference] | None
    K: list[float]
    best_level: int
    best_levels_within_noise: list[int]
    verdict: str


@dataclass(frozen=True)
class BlockVariance(JsonRecord):
    """Variance components of a blocked response (:func:`berryshaker.experiment.error_terms.block_variance`).

    Attributes
    ----------
    ms_block : float
        Block mean square (the response's unit squared).
    df_block : int
        Its degrees of freedom.
    ms_error : float
        Run x block interaction mean square (the response's unit squared).
    df_error : int
        Its degrees of freedom.
    var_block : float
        Block variance (the response's unit squared).
    per_start_sd : float
        Spread of one run's replicates, block included (the response's unit).
    """

    ms_block: float
    df_block: int
    ms_error: float
    df_error: int
    var_block: float
    per_start_sd: float


@dataclass(frozen=True)
class ReplicatedAnova(JsonRecord):
    """Main-effect ANOVA of a replicated response against its own noise.

    Attributes
    ----------
    factors : dict of str to AnovaTerm
        Per factor its row (with ``significant``).
    error : ErrorTerm
        What the effects are tested against (with ``kind``; the response's unit squared).
    blocks : BlockVariance or None
        The block variance components; None without blocks.
    pure_error : ErrorTerm
        The spread of each run's replicates, block included (the response's unit squared).
    lack_of_fit : ErrorTerm
        Between-run variation the main effects do not explain (df 0 when saturated).
    pooled : list of str
        Factors pooled (none: kept for the layout of :class:`Anova`).
    total_ss : float
        Total sum of squares (the response's unit squared).
    """

    factors: dict[str, AnovaTerm]
    error: ErrorTerm
    blocks: BlockVariance | None
    pure_error: ErrorTerm
    lack_of_fit: ErrorTerm
    pooled: list[str]
    total_ss: float


@dataclass(frozen=True)
class ReplicatedResponse(JsonRecord):
    """One response of :func:`berryshaker.experiment.replicates.analyze_replicated`.

    Attributes
    ----------
    maximize : bool
        Whether larger is better.
    factors : dict of str to ReplicatedEffect
        Per factor its effect against the noise.
    ranking : list of str
        Factors by decreasing range.
    run_means : list of float
        Mean per run (the response's unit).
    run_sd : list of float or None
        Replicate SD per run (the response's unit); None for a run with a single plot left (a sheet with lost plots).
    best_levels : dict of str to int
        Best level (1-based) per factor.
    significant_factors : list of str
        Factors with a significant effect.
    anova : ReplicatedAnova
        The ANOVA.
    regression : Regression
        The eq. 19 regression of the run means.
    """

    maximize: bool
    factors: dict[str, ReplicatedEffect]
    ranking: list[str]
    run_means: list[float]
    run_sd: list[float | None]
    best_levels: dict[str, int]
    significant_factors: list[str]
    anova: ReplicatedAnova
    regression: Regression


@dataclass(frozen=True)
class Choice(JsonRecord):
    """A factor's level chosen by the weighted (or tiered) optimum of the replicated analysis.

    Attributes
    ----------
    level : int or None
        The chosen level (1-based); None: no meaningful difference.
    setting : str or None
        Its label ("0.25 mm"); None with the level.
    status : str
        "chosen", "chosen; not distinguishable from ...", "no meaningful difference" or the tiers' account.
    reason : str
        Why, response by response.
    significant_responses : list of str
        Responses whose effect of the factor is significant (and weighted).
    equivalent_levels : list of int
        Levels not distinguishable from the chosen one.
    composite_level_means : list of float, optional
        The composite per level (dimensionless); only when a level is chosen.
    tier : str, optional
        Which tier chose ("primary", "fallback", "primary + fallback", "none"); tiered optimum only.
    """

    level: int | None
    setting: str | None
    status: str
    reason: str
    significant_responses: list[str]
    equivalent_levels: list[int]
    composite_level_means: list[float] | None = optional()
    tier: str | None = optional()


@dataclass(frozen=True)
class TierChoices(JsonRecord):
    """One tier's levels and choices in a tiered optimum.

    Attributes
    ----------
    levels : dict of str to int or None
        Level (1-based) per factor, None where nothing differs.
    choices : dict of str to Choice
        Per factor its choice.
    """

    levels: dict[str, int | None]
    choices: dict[str, Choice]


@dataclass(frozen=True, kw_only=True)
class ReplicatedOptimum(JsonRecord):
    """The weighted (or tiered) optimum of the replicated analysis: a level per factor only where an effect is
    significant.

    Attributes
    ----------
    levels : dict of str to int or None
        Level (1-based) per factor, None: no meaningful difference.
    settings : dict of str to str or None
        Its label per factor.
    choices : dict of str to Choice
        Per factor the choice and its reason.
    values : dict of str to float
        Predicted mean per response (the response's unit).
    intervals : dict of str to list of float
        Its interval per response (the response's unit).
    weights : dict of str to float
        Weights of the (primary) responses (dimensionless).
    fallback_weights : dict of str to float, optional
        Weights of the fallback responses (dimensionless); tiered only.
    method : str
        The rule in words.
    prediction : str
        The prediction model in words.
    primary : TierChoices, optional
        The primary tier's choice; tiered only.
    fallback : TierChoices, optional
        The fallback tier's choice; tiered only.
    """

    levels: dict[str, int | None]
    settings: dict[str, str | None]
    choices: dict[str, Choice]
    values: dict[str, float]
    intervals: dict[str, list[float]]
    weights: dict[str, float]
    fallback_weights: dict[str, float] | None = optional()
    method: str
    prediction: str
    primary: TierChoices | None = optional()
    fallback: TierChoices | None = optional()


@dataclass(frozen=True, kw_only=True)
class ReplicatedAnalysis(JsonRecord):
    """The analysis of a replicated orthogonal test (:func:`berryshaker.experiment.replicates.analyze_replicated`);
    read from a sheet (:func:`berryshaker.experiment.field_results.analyze_sheet`) it has the sheet's fields too.

    Attributes
    ----------
    significance_rule : str
        When an effect counts as significant.
    alpha : float
        Significance level (dimensionless).
    confidence : float
        Confidence of the intervals (dimensionless).
    runs : int
        Runs of the array.
    replicates : int
        Replicates per run.
    blocks : bool
        Whether replicate k of every run is block k.
    weights : dict of str to float
        Weights of the (primary) responses (dimensionless, summing to 1).
    factors : dict of str to FactorLevels
        Per factor its levels.
    responses : dict of str to ReplicatedResponse
        Per response its analysis.
    optimum : ReplicatedOptimum
        The weighted (or tiered) optimum.
    fallback_weights : dict of str to float, optional
        Weights of the fallback responses (dimensionless).
    notes : list of str
        Warnings (e.g. zero error).
    """

    significance_rule: str
    alpha: float
    confidence: float
    runs: int
    replicates: int
    blocks: bool
    weights: dict[str, float]
    factors: dict[str, FactorLevels]
    responses: dict[str, ReplicatedResponse]
    optimum: ReplicatedOptimum
    fallback_weights: dict[str, float] | None = optional()
    notes: list[str]


@dataclass(frozen=True)
class LostPlots(JsonRecord):
    """The plots a replicated field sheet lost (a blank response, a deleted row) and what they cost
    (:func:`berryshaker.experiment.unbalanced.analyze_unbalanced`).

    Attributes
    ----------
    plots : int
        Plots planned (runs x replicates).
    present : dict of str to int
        Plots with a value, per response.
    lost : dict of str to list of list of int
        The [run, replicate] of each lost plot, per response.
    error_df : dict of str to int
        The error's degrees of freedom left, per response.
    balanced_error_df : int
        The error's degrees of freedom of the complete sheet, (runs - 1)(replicates - 1).
    lost_df : dict of str to int
        Error degrees of freedom lost, per response.
    method : str
        How the unbalanced sheet is analysed.
    """

    plots: int
    present: dict[str, int]
    lost: dict[str, list[list[int]]]
    error_df: dict[str, int]
    balanced_error_df: int
    lost_df: dict[str, int]
    method: str


@dataclass(frozen=True, kw_only=True)
class SheetReplicatedAnalysis(ReplicatedAnalysis):
    """:class:`ReplicatedAnalysis` of a filled sheet (:func:`berryshaker.experiment.field_results.analyze_sheet`).

    Its fields are :class:`ReplicatedAnalysis`'s (documented there) and the sheet's below.

    Attributes
    ----------
    block_column : str or None
        The sheet's column numbering the blocks, None when it has none.
    text : str
        The analysis as text (:func:`berryshaker.experiment.replicates.describe_replicated`).
    weights_given : bool
        Whether the weights were given (else equal).
    response_units : dict of str to str
        Unit per response ('' where the sheet gives none).
    runs_identified_by : str
        How the sheet's runs were told apart.
    lost_plots : LostPlots, optional
        The plots lost and the degrees of freedom they cost; only for a sheet with lost plots (analysed by least
        squares, :mod:`berryshaker.experiment.unbalanced`).
    desirability : DesirabilityOptimum, optional
        The desirability optimum (``doe analyze --desirability``).
    """

    block_column: str | None
    text: str
    weights_given: bool
    response_units: dict[str, str]
    runs_identified_by: str
    lost_plots: LostPlots | None = optional()
    desirability: DesirabilityOptimum | None = optional()


__all__ = ["BlockVariance", "Choice", "LostPlots", "PairedDifference", "ReplicatedAnalysis", "ReplicatedAnova", "ReplicatedEffect",
           "ReplicatedOptimum", "ReplicatedResponse", "SheetReplicatedAnalysis", "TierChoices"]
