"""Variance-based (Sobol) sensitivity of the drive's outputs to joint clearances and any named parameter.

First-order indices S1 (the share of the output variance explained by one parameter alone) and total indices
ST (including all its interactions) with bootstrap confidence intervals, estimated with SALib: Saltelli's
extension of the Sobol sequence for sampling (``SALib.sample.sobol``) and the Saltelli/Jansen estimators for
the analysis (``SALib.analyze.sobol``).

Sources: I. M. Sobol', "Global sensitivity indices for nonlinear mathematical models and their Monte Carlo
estimates", Math. Comput. Simul. 55 (2001) 271-280; A. Saltelli et al., "Variance based sensitivity analysis
of model output. Design and estimator for the total sensitivity index", Comput. Phys. Commun. 181 (2010)
259-270; J. Herman and W. Usher, "SALib: An open-source Python library for sensitivity analysis", JOSS 2 (2017).

The machine runs go through the cached sweep runner (local processes or a Dask cluster): N (D + 2) runs for D
parameters and a base sample N (a power of two).  Parameters are sampled uniformly over their ranges.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from berryshaker.errors import ConfigError


@dataclass(frozen=True)
class SobolParameter:
    """One input of a Sobol analysis: a dotted key of the machine description and its SI range.

    Attributes
    ----------
    key : str
        ``clearance.A.size``, ``cam.speed`` ...
    lo, hi : float
        SI bounds (uniform distribution).
    unit : str
        Display unit of the user's input ("mm"); ``factor`` is its SI value.
    factor : float
        SI value of one ``unit``.
    """

    key: str
    lo: float
    hi: float
    unit: str = ""
    factor: float = 1.0


def parse_sensitivity_param(spec: str) -> SobolParameter:
    """``KEY=LO..HI[unit]`` (e.g. ``clearance.A.size=0.1..0.8mm``) as a :class:`SobolParameter` (SI bounds).

    Parameters
    ----------
    spec : str
        The ``--param`` text (read by :func:`berryshaker.runs.sweep.parse_param`).

    Returns
    -------
    SobolParameter
        Key, SI bounds and the display unit given.

    Raises
    ------
    ConfigError
        The text is not a range (a list or MEAN+-SD).
    """
    from berryshaker.runs.sweep import parse_param

    p = parse_param(spec)
    if p.kind != "range":
        raise ConfigError(f"--param {spec!r}: a Sobol analysis needs a range KEY=LO..HI[unit], e.g. "
                          "clearance.A.size=0.1..0.8mm")
    return SobolParameter(p.key, p.values[0] * p.factor, p.values[1] * p.factor, p.unit, p.factor)


def default_clearance_params(machine) -> list[SobolParameter]:
    """Every clearance pair's size over its test levels (smallest to largest level), in mm.

    Parameters
    ----------
    machine : MachineBase
        Any drive's machine description (its clearance test levels).

    Returns
    -------
    list of SobolParameter
        ``clearance.<pair>.size`` from the pair's smallest to its largest level (SI bounds), displayed in mm.
    """
    levels = machine.clearance_levels()
    return [SobolParameter(f"clearance.{p}.size", min(lv), max(lv), "mm", 1e-3) for p, lv in levels.items()]


def sobol_problem(params: list[SobolParameter]) -> dict:
    """SALib problem dict (names, SI bounds).

    Parameters
    ----------
    params : list of SobolParameter
        At least one, each key once, each with finite LO < HI.

    Returns
    -------
    dict
        ``num_vars``, ``names`` (the keys) and ``bounds`` ([lo, hi] per parameter, SI).

    Raises
    ------
    ConfigError
        No parameter, a key given twice, or bounds that are not finite with LO < HI.
    """
    if not params:
        raise ConfigError("a sensitivity analysis needs at least one --param KEY=LO..HI[unit]")
    names = [p.key for p in params]
    if len(set(names)) != len(names):
        raise ConfigError(f"--param: each parameter once, got {', '.join(names)}")
    for p in params:
        if not (math.isfinite(p.lo) and math.isfinite(p.hi) and p.hi > p.lo):
            raise ConfigError(f"--param {p.key}: needs LO < HI, got {p.lo!r}..{p.hi!r}")
    return {"num_vars": len(params), "names": names, "bounds": [[p.lo, p.hi] for p in params]}


def _check_n(n: int) -> int:
    n = int(n)
    if n < 2 or n & (n - 1):
        raise ConfigError(f"--samples must be a power of two >= 2 (the Sobol sequence's balance), got {n}")
    return n


def sobol_sample(problem: dict, n: int, seed: int | None = 0, second_order: bool = False) -> np.ndarray:
    """Saltelli sample of a problem: shape (N (D + 2), D), or (N (2 D + 2), D) with second order.

    Parameters
    ----------
    problem : dict
        :func:`sobol_problem`.
    n : int
        Base sample N, a power of two >= 2.
    seed : int, optional
        Seed of the scrambled Sobol sequence.
    second_order : bool
        Also sample for second-order indices.

    Returns
    -------
    numpy.ndarray
        One row per run, one column per parameter, within the bounds (SI, the parameters' units).

    Raises
    ------
    ConfigError
        ``n`` is not a power of two >= 2.

    Notes
    -----
    ``SALib.sample.sobol.sample`` (scrambled Sobol sequence, Saltelli 2010 cross-sampling matrices).
    """
    from SALib.sample import sobol as sobol_sampler

    return sobol_sampler.sample(problem, _check_n(n), calc_second_order=second_order, scramble=True, seed=seed)


def sobol_analyze(problem: dict, y, seed: int | None = 0, second_order: bool = False,
                  conf_level: float = 0.95, num_resamples: int = 200) -> dict[str, dict[str, float | None]]:
    """First-order and total Sobol indices with bootstrap confidence half-widths.

    Parameters
    ----------
    problem : dict
        :func:`sobol_problem`.
    y : array_like
        Model outputs at :func:`sobol_sample`'s rows, in order (any unit: the indices are ratios of variances).
    seed : int
        Bootstrap seed (0 included: the same intervals whatever numpy's global state).
    second_order : bool
        As sampled.
    conf_level : float
        Confidence level of the intervals (a fraction, e.g. 0.95).
    num_resamples : int
        Bootstrap resamples.

    Returns
    -------
    dict
        parameter -> {"S1", "S1_conf", "ST", "ST_conf"} (None where the output has no variance).

    Notes
    -----
    S1_i = V[E(Y | X_i)] / V(Y) (Saltelli 2010 estimator), ST_i = E[V(Y | X_~i)] / V(Y) (Jansen estimator), as
    implemented in ``SALib.analyze.sobol.analyze``.  ``*_conf`` is the half-width of the bootstrap interval.
    """
    from SALib.analyze import sobol as sobol_analyzer

    y = np.asarray(y, float)
    if not np.all(np.isfinite(y)):
        raise ConfigError("sensitivity: some outputs are not finite; the Sobol estimators need every run")
    names = problem["names"]
    if np.ptp(y) == 0.0:
        return {n: {"S1": None, "S1_conf": None, "ST": None, "ST_conf": None} for n in names}
    # SALib seeds its bootstrap only for a truthy seed (``if seed:``): seed 0, this function's default, left the
    # intervals to numpy's global state, so they changed with whatever ran before; a Generator is always truthy
    rng = None if seed is None else np.random.default_rng(seed)
    res = sobol_analyzer.analyze(problem, y, calc_second_order=second_order, num_resamples=num_resamples,
                                 conf_level=conf_level, print_to_console=False, seed=rng)

    def num(x):
        return float(x) if math.isfinite(float(x)) else None

    return {n: {"S1": num(res["S1"][k]), "S1_conf": num(res["S1_conf"][k]), "ST": num(res["ST"][k]),
                "ST_conf": num(res["ST_conf"][k])} for k, n in enumerate(names)}


#: largest 95 % half-width (share of the variance) at which an index counts as resolved
RESOLVED_HALF_WIDTH = 0.1
#: half-width to aim for when suggesting a larger N (the intervals shrink as 1 / sqrt(N))
TARGET_HALF_WIDTH = 0.05


def output_unit(name: str) -> str:
    """SI unit of a flat output name (:func:`berryshaker.life.joint_loads.flat_outputs` and ``joint_loads``):
    forces "N", moments "N m", sliding speeds "m/s", swings "deg"; "" if the name does not say.

    Parameters
    ----------
    name : str
        Output name, e.g. ``collision_force_A_peak``.

    Returns
    -------
    str
        Its unit ("deg", "N m", "N", "m/s" or "").
    """
    if name.endswith("_deg"):
        return "deg"
    if "moment" in name:
        return "N m"
    if "force" in name:
        return "N"
    if "speed" in name:
        return "m/s"
    return ""


def resolution(indices: dict[str, dict[str, float | None]], n: int) -> dict:
    """Which Sobol indices the sample resolves, and the base sample N to try if some are not.

    An index is *not resolved* when its 95 % bootstrap half-width exceeds :data:`RESOLVED_HALF_WIDTH` (0.1 of
    the variance) or its estimate lies outside [0, 1] beyond its interval (a negative S1 is sampling noise:
    the true index is >= 0).  The intervals shrink as 1/sqrt(N), so the suggested N is the next power of two
    above N (w / :data:`TARGET_HALF_WIDTH`)^2 for the widest interval w [assumed scaling].

    Parameters
    ----------
    indices : dict
        Parameter -> {"S1", "S1_conf", "ST", "ST_conf"} (:func:`sobol_analyze`).
    n : int
        The base sample N they were estimated from.

    Returns
    -------
    dict
        ``unresolved``: list of "S1 of clearance.A.size: -0.12 +- 0.35" strings; ``negative_within_noise``: the
        resolved indices estimated below 0 (their interval includes 0: read them as 0); ``suggested_samples``: int
        or None; ``widest_half_width``: float or None.
    """
    bad, negative, widest = [], [], 0.0
    for key, ind in indices.items():
        for s in ("S1", "ST"):
            v, c = ind.get(s), ind.get(s + "_conf")
            if v is None:
                continue
            c = 0.0 if c is None else float(c)
            widest = max(widest, c)
            if c > RESOLVED_HALF_WIDTH or v + c < 0.0 or v - c > 1.0:
                bad.append(f"{s} of {key}: {v:.3f} +- {c:.3f}")
            elif v < 0.0:
                negative.append(f"{s} of {key}: {v:.3f} +- {c:.3f}")
    suggested = None
    if bad:
        need = n * max(widest / TARGET_HALF_WIDTH, 1.0) ** 2
        suggested = max(2 * n, 1 << math.ceil(math.log2(need)))
    return {"unresolved": bad, "negative_within_noise": negative, "suggested_samples": suggested,
            "widest_half_width": widest if indices else None}


def sobol_indices(fn: Callable[[np.ndarray], np.ndarray], problem: dict, n: int, seed: int | None = 0) -> dict:
    """Sobol indices of a vectorised function ``fn(X) -> y`` (X of shape (runs, D)): sample, evaluate, analyse.

    Used for analytic checks (e.g. the Ishigami function) of the same plumbing the machine analysis uses.

    Parameters
    ----------
    fn : callable
        ``fn(X) -> y``, one output per row of X.
    problem : dict
        :func:`sobol_problem`.
    n : int
        Base sample N (a power of two).
    seed : int, optional
        Seed of the sample and of the bootstrap.

    Returns
    -------
    dict
        Parameter -> {"S1", "S1_conf", "ST", "ST_conf"} (:func:`sobol_analyze`).
    """
    x = sobol_sample(problem, n, seed)
    return sobol_analyze(problem, fn(x), seed)


def machine_sobol(machine, params: list[SobolParameter], outputs: list[str], n: int, runner, model: str = "mlsd",
                  revolutions: int = 2, seed: int | None = 0, label: str = "sensitivity") -> dict:
    """Sobol indices of machine outputs, every run through the cached sweep runner.

    Parameters
    ----------
    machine : MachineBase
        The machine description (the runs override the parameters on a copy).
    params : list of SobolParameter
        Inputs and their SI ranges.
    outputs : list of str
        Output names of :func:`berryshaker.life.runs.summary_outputs_run` (``collision_force_A_peak``...).
    n : int
        Base sample (power of two); the runs are N (D + 2).
    runner : SweepRunner
        Cached, local or Dask.
    model : {"mlsd", "multibody"}
        Which dynamics.
    revolutions : int
        Drive revolutions per run (>= 2).
    seed : int
        Seed of the scrambled Sobol sequence and of the bootstrap.
    label : str
        Label of the runs in the runner's progress display.

    Returns
    -------
    dict
        ``indices[output][param] = {S1, S1_conf, ST, ST_conf}``, ``output_mean``/``output_std`` (SI, in
        ``output_unit[output]``), ``resolution[output]`` (:func:`resolution`: the indices N does not resolve and
        the N to try), ``runs``, ``parameters`` (key, SI bounds, unit), ``model``, ``samples``, ``seed``.
    """
    from berryshaker.life.runs import summary_outputs_run

    problem = sobol_problem(params)
    if not outputs:
        raise ConfigError("sensitivity: name at least one --output, e.g. collision_force_A_peak")
    x = sobol_sample(problem, n, seed)
    data = machine.model_dump(mode="json")
    jobs = [dict(machine_data=data, overrides={p.key: float(v) for p, v in zip(params, row)}, model=model,
                 revolutions=int(revolutions)) for row in x]
    values = runner.values(summary_outputs_run, jobs, label)
    available = sorted(values[0])
    missing = [o for o in outputs if o not in available]
    if missing:
        raise ConfigError(f"unknown output(s) {', '.join(missing)} for the {model} model; available: "
                          f"{', '.join(available)}")
    result = {"model": model, "samples": int(n), "runs": len(jobs), "seed": seed, "revolutions": int(revolutions),
              "parameters": [{"key": p.key, "lo": p.lo, "hi": p.hi, "unit": p.unit,
                              "lo_display": p.lo / p.factor, "hi_display": p.hi / p.factor} for p in params],
              "indices": {}, "output_mean": {}, "output_std": {},
              "method": "Sobol indices, Saltelli sampling (scrambled Sobol sequence) and SALib's Saltelli/Jansen "
                        "estimators; 95 % bootstrap confidence half-widths"}
    for o in outputs:
        y = np.array([math.nan if v.get(o) is None else v[o] for v in values], float)
        result["indices"][o] = sobol_analyze(problem, y, seed)
        result["output_mean"][o] = float(np.mean(y))
        result["output_std"][o] = float(np.std(y))
        result.setdefault("output_unit", {})[o] = output_unit(o)
        result.setdefault("resolution", {})[o] = resolution(result["indices"][o], int(n))
    return result
