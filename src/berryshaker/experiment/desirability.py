"""The desirability optimiser of ``doe analyze --desirability`` (Derringer and Suich 1980) and the prediction at any
level set of a field sheet's factors, with its interval, for every kind of analysis (unreplicated, replicated,
replicated with lost plots).

Each goal turns a response's predicted mean y into a desirability d between 0 and 1 (Derringer, G. and Suich, R.,
"Simultaneous optimization of several response variables", *Journal of Quality Technology* 12(4), 214-219, 1980,
eq. 1-3 with the shape exponents 1; Montgomery, *Design and Analysis of Experiments*, 8th ed., 2013, sec. 11.3.4):

* maximise between L and U: d = 0 below L, (y - L) / (U - L) between, 1 above U;
* minimise between L and U: d = 1 below L, (U - y) / (U - L) between, 0 above U;
* target T within L..U: (y - L) / (T - L) below T, (U - y) / (U - T) above, 0 outside L..U.

The overall desirability D = (prod d_i)^(1/m) of the m goals is maximised over every level set of the factors
(the full factorial of their levels, tested or not).  The predictions are the analysis' own additive model, as the
weighted optimum beside it uses: a replicated sheet's over the factors significant for the response (a factor
without a significant effect is averaged, so noise is never ranked), an unreplicated sheet's over every factor.  A
factor that changes none of the goals' predictions (not significant, or an effect of exactly zero) is left at None.
"""

from __future__ import annotations

import itertools
import math
import re

import numpy as np

from berryshaker.errors import ConfigError
from berryshaker.experiment.analysis_records import DesirabilityCandidate, DesirabilityOptimum, Goal

_NUMBER = r"[-+]?(?:\d+(?:\.\d+)?|\.\d+)(?:[eE][-+]?\d+)?"  # no trailing point: "1..2" is two numbers
_GOAL = re.compile(rf"^(max|min|target):\s*({_NUMBER})\s*\.\.\s*({_NUMBER})(?:\s*\.\.\s*({_NUMBER}))?"
                   r"\s*((?:[A-Za-z%µμ][^\s]*)?)$")
#: level sets searched at most (the full factorial of the factors' levels)
MAX_LEVEL_SETS = 1_000_000


def _limit_factor(unit: str, response_unit: str, where: str, example: str) -> float:
    """Factor converting the goal's unit to the response's (1 when they are the same); a missing unit is an error
    where the response has one."""
    from berryshaker.units import unit_factor

    if unit == response_unit:
        return 1.0
    if not unit:
        raise ConfigError(f"{where}: give the limits' unit (the sheet's response is in {response_unit}), e.g. "
                          f"{example}{response_unit}")
    if not response_unit:
        raise ConfigError(f"{where}: the sheet gives this response no unit; write the limits as plain numbers")
    if "%" in (unit, response_unit):
        raise ConfigError(f"{where}: unit {unit!r} cannot be read as {response_unit!r}")
    return unit_factor(unit, response_unit, where)


def parse_desirability(text: str, responses: list[str], response_units: dict[str, str]) -> dict[str, Goal]:
    """Read ``efficiency=max:2..5kg/min,damage=min:0..5%,unripe=target:1..2..4%``: per response a goal
    (``max``, ``min`` or ``target``), its limits ``LOW..HIGH`` (a target ``LOW..TARGET..HIGH``) and their unit, which
    must be the response's or convertible to it.

    Parameters
    ----------
    text : str
        The goals, comma-separated.
    responses : list of str
        The analysed responses (only they can have a goal).
    response_units : dict of str to str
        Each response's unit in the sheet ('' for none).

    Returns
    -------
    dict of str to Goal
        Per response its goal, the limits in the response's unit.

    Raises
    ------
    ConfigError
        A goal not of that form, a response not analysed or named twice, limits not finite or not increasing, a
        missing or wrong unit.
    """
    if not isinstance(text, str) or not text.strip() or len(text) > 2000:
        raise ConfigError("--desirability: expected NAME=max:LOW..HIGHunit,... e.g. "
                          "efficiency=max:2..5kg/min,damage=min:0..5%")
    goals: dict[str, Goal] = {}
    for part in (p.strip() for p in text.split(",")):
        if not part:
            continue
        where = f"--desirability {part[:60]!r}"
        if "=" not in part:
            raise ConfigError(f"{where}: expected NAME=max:LOW..HIGHunit (or min:, or target:LOW..TARGET..HIGH)")
        name, spec = (x.strip() for x in part.split("=", 1))
        if name not in responses:
            raise ConfigError(f"{where}: {name!r} is not an analysed response ({', '.join(responses)}); name it in "
                              "--maximize or --minimize too")
        if name in goals:
            raise ConfigError(f"{where}: {name!r} has a goal already; give each response one goal")
        m = _GOAL.match(spec)
        if not m:
            raise ConfigError(f"{where}: expected max:LOW..HIGH, min:LOW..HIGH or target:LOW..TARGET..HIGH with "
                              "the unit after the last number, e.g. max:2..5kg/min")
        kind, a, b, c, unit = m.groups()
        nums = [float(x) for x in (a, b, c) if x is not None]
        if not all(math.isfinite(x) for x in nums):
            raise ConfigError(f"{where}: the limits must be finite numbers")
        if (kind == "target") != (len(nums) == 3):
            raise ConfigError(f"{where}: {'a target needs LOW..TARGET..HIGH' if kind == 'target' else 'give LOW..HIGH'}")
        example = f"{name}={kind}:" + "..".join(x for x in (a, b, c) if x is not None)
        f = _limit_factor(unit if unit != "pct" else "%", response_units.get(name, "") or "", where, example)
        nums = [x * f for x in nums]
        if any(y <= x for x, y in zip(nums, nums[1:])):
            raise ConfigError(f"{where}: the limits must increase (LOW < HIGH" + (", LOW < TARGET < HIGH" if
                                                                                    kind == "target" else "") + ")")
        unit_out = response_units.get(name, "") or ""
        if kind == "target":
            goals[name] = Goal("target", nums[0], nums[2], nums[1], unit_out)
        else:
            goals[name] = Goal({"max": "maximize", "min": "minimize"}[kind], nums[0], nums[1], None, unit_out)
    if not goals:
        raise ConfigError("--desirability is empty; give NAME=max:LOW..HIGHunit for some of " + ", ".join(responses))
    return goals


def individual_desirability(y, goal: Goal) -> np.ndarray:
    """Derringer and Suich's (1980) desirability of predicted means ``y`` for one goal (shape exponents 1).

    Parameters
    ----------
    y : array_like
        Predicted means (the goal's unit).
    goal : Goal
        The goal and its limits.

    Returns
    -------
    numpy.ndarray
        d, 0..1 (dimensionless).
    """
    y = np.asarray(y, float)
    lo, hi = goal.low, goal.high
    if goal.goal == "maximize":
        return np.clip((y - lo) / (hi - lo), 0.0, 1.0)
    if goal.goal == "minimize":
        return np.clip((hi - y) / (hi - lo), 0.0, 1.0)
    t = goal.target
    return np.where(y <= t, np.clip((y - lo) / (t - lo), 0.0, 1.0), np.clip((hi - y) / (hi - t), 0.0, 1.0))


def _used(res, name: str) -> list[str]:
    """The factors the analysis' prediction of ``name`` uses: the significant ones of a replicated analysis, every
    factor of an unreplicated one."""
    ra = res.responses[name]
    return [f for f in res.factors if getattr(ra.factors[f], "significant", True)]


def _point(res, name: str, chosen: dict) -> float:
    """The additive model's prediction of ``name`` at ``chosen`` (factor -> level or None: averaged)."""
    ra = res.responses[name]
    first = next(iter(ra.factors.values()))
    grand = float(np.mean(first.level_means))  # the (least-squares) grand mean: every factor's level means average it
    val = grand
    for f in _used(res, name):
        if chosen.get(f) is not None:
            val += ra.factors[f].level_means[res.factors[f].level_numbers.index(chosen[f])] - grand
    return float(val)


def level_set_prediction(fr, res, chosen: dict, confidence: float = 0.95) -> tuple[dict, dict]:
    """Every response's predicted mean and interval at a level set, by the analysis' own model and error.

    Parameters
    ----------
    fr : FieldResults
        The sheet as read (its observations).
    res : DoeAnalysis or SheetReplicatedAnalysis
        Its analysis.
    chosen : dict of str to int or None
        Level per factor (None: averaged).
    confidence : float
        Level of the intervals (dimensionless).

    Returns
    -------
    (dict, dict)
        Per response the prediction and its [low, high] interval (the response's unit).

    Notes
    -----
    Unreplicated: the pooled error over Taguchi's effective number of replications N / (1 + dof of the factors
    used), t on the pooled error's degrees of freedom (Roy, *A Primer on the Taguchi Method*, 1990, ch. 8).
    Replicated: :data:`berryshaker.experiment.replicates.PREDICTION_RULE` (the blocks' variance included); with lost
    plots its least-squares form (:func:`berryshaker.experiment.unbalanced.predict_at`).
    """
    from scipy import stats

    if getattr(res, "lost_plots", None) is not None:
        from berryshaker.experiment.unbalanced import _fit, predict_at

        values, intervals = {}, {}
        js = res.to_json()
        for name, y in fr.responses_replicated.items():
            values[name], intervals[name] = predict_at(_fit(fr.levels, y), list(res.factors), js["responses"][name],
                                                       chosen, confidence)
        return values, intervals
    if fr.responses_replicated is not None and fr.replicates >= 2:
        from berryshaker.experiment.replicates import _predict

        return _predict(list(res.factors), fr.responses_replicated, res.to_json(), dict(chosen), confidence)
    values, intervals = {}, {}
    n = len(fr.levels)
    for name in res.responses:
        val = _point(res, name, chosen)
        err = res.responses[name].anova.error
        dof_used = sum(len(res.factors[f].level_numbers) - 1 for f in res.factors if chosen.get(f) is not None)
        hw = float(stats.t.ppf(0.5 + confidence / 2, err.df)) * math.sqrt(err.ms * (1 + dof_used) / n) if err.df \
            else float("nan")
        values[name], intervals[name] = val, [val - hw, val + hw]
    return values, intervals


def desirability_optimum(fr, res, goals: dict[str, Goal], confidence: float = 0.95) -> DesirabilityOptimum:
    """The level set of the factors with the largest overall desirability (the module's rule).

    Parameters
    ----------
    fr : FieldResults
        The sheet as read.
    res : DoeAnalysis or SheetReplicatedAnalysis
        Its analysis.
    goals : dict of str to Goal
        Per response its goal (:func:`parse_desirability`).
    confidence : float
        Level of the intervals at the optimum (dimensionless).

    Returns
    -------
    DesirabilityOptimum
        The best level set, its predictions with intervals, each goal's d, D, ties and the best candidates.

    Raises
    ------
    ConfigError
        More level sets than :data:`MAX_LEVEL_SETS`.
    """
    factors = list(res.factors)
    def moves(f: str, name: str) -> bool:  # the factor enters the prediction and its levels differ
        lm = np.asarray(res.responses[name].factors[f].level_means, float)
        return f in _used(res, name) and float(np.ptp(lm)) > 1e-12 * max(float(np.max(np.abs(lm))), 1e-300)

    active = [f for f in factors if any(moves(f, name) for name in goals)]
    choices = [res.factors[f].level_numbers for f in active]
    total = math.prod(len(c) for c in choices)
    if total > MAX_LEVEL_SETS:
        raise ConfigError(f"--desirability: {total:,} level sets of {len(active)} factors, more than the "
                          f"{MAX_LEVEL_SETS:,} searched; give goals for fewer responses")
    sets = np.array(list(itertools.product(*choices)), dtype=int).reshape(total, len(active))
    logd = np.zeros(total)
    for name, goal in goals.items():
        ra = res.responses[name]
        grand = float(np.mean(next(iter(ra.factors.values())).level_means))
        y = np.full(total, grand)
        for j, f in enumerate(active):
            if moves(f, name):
                dev = np.array(ra.factors[f].level_means) - grand
                y += dev[[res.factors[f].level_numbers.index(k) for k in sets[:, j]]]
        with np.errstate(divide="ignore"):
            logd += np.log(individual_desirability(y, goal))
    overall = np.exp(logd / len(goals))
    order = np.argsort(-overall, kind="stable")
    best = float(overall[order[0]])
    ties = int(np.sum(np.isclose(overall, best, rtol=1e-12, atol=1e-15)))
    note = ""
    if best > 0:
        chosen = {f: (int(sets[order[0], active.index(f)]) if f in active else None) for f in factors}
    else:
        chosen = {f: None for f in factors}
        note = ("no level set brings every goal's prediction inside its limits (D = 0 everywhere); no setting is "
                "recommended - widen the limits or look at the goals one by one")
    if best > 0 and ties > 1:
        note = (f"{ties} level sets reach the same D; the first in level order is shown - the goals do not tell "
                "them apart")
    values, intervals = level_set_prediction(fr, res, chosen, confidence)
    labels = {f: (res.factors[f].labels[res.factors[f].level_numbers.index(k)] if k is not None else None)
              for f, k in chosen.items()}
    d = {name: float(individual_desirability(values[name], g)) for name, g in goals.items()}
    cands = [DesirabilityCandidate({f: (int(sets[i, active.index(f)]) if f in active else None) for f in factors},
                                   float(overall[i])) for i in order[:5]]
    method = ("Derringer-Suich desirability (1980; shape exponents 1): each goal's d from the predicted mean, D their "
              "geometric mean, maximised over every level set of the factors; predictions by the analysis' additive "
              "model (" + ("the factors significant for each response; others averaged" if fr.replicates >= 2 else
                           "every factor, as the weighted optimum's") + "), intervals "
              f"{100 * confidence:g} % as the weighted optimum's")
    return DesirabilityOptimum(goals=goals, levels=chosen, settings=labels,
                               values={k: values[k] for k in goals}, intervals={k: intervals[k] for k in goals},
                               desirability=d, overall=best, ties=ties, candidates=cands, method=method, note=note)


__all__ = ["MAX_LEVEL_SETS", "desirability_optimum", "individual_desirability", "level_set_prediction",
           "parse_desirability"]
