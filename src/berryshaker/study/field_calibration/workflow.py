"""The whole calibration (:func:`calibrate`): the simulator's runs, the emulator's training and checks, the posterior,
then identifiability, checks, predictions and the recommendation, assembled into one
:class:`~berryshaker.study.field_calibration.result.CalibrationResult` (the command ``berryshaker calibrate`` writes
it, the report reads it).

Identifiability is the prior against the posterior 90 % intervals (:data:`IDENTIFIED_RULE`,
:data:`CONFOUNDED_RULE`); the checks are posterior predictive checks per run (the discrepancy conditioned on the other
runs) and a held-out run; the model discrepancy is summarised per response with the residuals' factor effects
(:data:`RESIDUAL_RULE`); the predictions are of every level set of the sheet's factors (and named settings) with 90 %
intervals of a future field result, and a recommendation is made on them (:data:`RECOMMENDATION_RULE`).  A saved
calibration predicts again without the sampler (:func:`predict_saved`).

long module: the calibration's stages read each other's intermediate results (the simulator's training arrays, the
emulator, the posterior draws, the sheet's statistics) in one flow; split, every part would import the others.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass

import numpy as np

from berryshaker.config import Machine
from berryshaker.errors import ConfigError
from berryshaker.harvest.virtual.stem_force_tables import STIFFNESS_RANGE
from berryshaker.study.field_calibration.emulator import Emulator
from berryshaker.study.field_calibration.posterior import (
    DISCREPANCY_LENGTH,
    DISCREPANCY_SCALE,
    FIELD_NOISE_SCALE,
    SheetStatistics,
    predictive,
    sample_posterior,
)
from berryshaker.study.field_calibration.priors import (
    PARAMETER_NAMES,
    calibrated_responses,
    described_values,
    latin_hypercube,
    parameters_for,
    theta_of,
)
from berryshaker.study.field_calibration.result import (
    CalibrationRecommendation,
    CalibrationResult,
    Checks,
    CheckSummary,
    Confounding,
    EmulatorCheck,
    EmulatorSummary,
    FactorSummary,
    HeldOutRun,
    HyperSummary,
    ModelDiscrepancy,
    ParameterSummary,
    Prediction,
    PriorSummary,
    ResidualEffect,
    ResponsePrediction,
    RunCheck,
    SamplerSummary,
    SettingValue,
    SheetSummary,
    SimulatorSummary,
    Timings,
)
from berryshaker.study.field_calibration.sheet import FactorTarget, Sheet, level_sets
from berryshaker.study.field_calibration.simulator import Simulator, start_statistics, training_starts

IDENTIFIED_RULE = ("identified: the posterior's central 90 % interval is narrower than half the prior's "
                   "(width ratio < 0.5)")
CONFOUNDED_RULE = "confounded: |posterior correlation| >= 0.5 between two parameters (on the prior's normal scores)"
RECOMMENDATION_RULE = (
    "a level set beats another on a response when the 90 % interval of the difference of their expected field "
    "results (same posterior draws at both) lies on the better side of zero; a level set is dominated when another "
    "beats it on at least one response and is beaten on none; the recommendation is the undominated level set with "
    "the best weighted score of the predicted means (each response scaled 0..1 over the level sets, weights "
    "efficiency 0.5, damage 0.3, unripe 0.2, the study's priority; ties broken by the level set's order); the other "
    "undominated level sets are listed as 'no difference beyond the intervals'; the candidates are the level sets of "
    "the sheet's factors (named settings are predicted, not candidates)")
RESIDUAL_RULE = (
    "residuals of the sheet's results from the calibrated model (the emulated mean at the posterior median of the "
    "parameters) regressed on every factor's levels (statsmodels OLS, anova_lm type II); a factor's residual effect is "
    "beyond the noise when p < 0.05 / the number of factors (Bonferroni): an effect the sheet measured that the model "
    "does not produce")
#: key of the predictions' noise draws (their own generators, seeded [seed, PREDICTION_SEED, part], so a saved
#: calibration's predictions, :func:`predict_saved`, are the calibration's own)
PREDICTION_SEED = 8
LIMITS = (
    f"the pedicel stiffness is learnt within a factor {STIFFNESS_RANGE:g} of the described one (where the stem-load "
    "tables' mass axis ends), its damping scaled with it; on a rigid-stem description it is inert (posterior = prior)",
    "unripe bond CV, fruit mass, branch geometry and every machine value stay as described",
    "the model discrepancy is a Gaussian process over the coded settings, additive in the factors: it follows a "
    "measured main effect to untested level sets, not an interaction the sheet cannot resolve",
    "predictions at settings outside the sheet's level ranges extrapolate the emulator (flagged 'extrapolated')",
    "responses are treated as independent given the parameters (their correlation over starts is left out)",
    "replicates of a run are exchangeable: a sheet's block effects are not modelled",
)


@dataclass
class CalibrationSettings:
    """Sizes of the method (defaults: the command's).

    Attributes
    ----------
    replicates : int or None
        Simulated starts per setting (default ``harvest.replicates``).
    theta_points : int
        Latin-hypercube parameter points per simulated setting (emulator training).
    check_points : int
        Held-out parameter points per setting for the emulator's check.
    check_settings : int
        Untested settings simulated for the emulator's check.
    steps : int or None
        MCMC steps per walker (None: until 50 autocorrelation times).
    walkers : int or None
        Walkers (None: 4 x dimension, at least 24).
    draws : int
        Posterior draws used for predictions and checks.
    held_out_run : bool
        Calibrate once more without one run and predict it (when runs > parameters + 2).
    seed : int
        Seed of everything random in the method (the simulator's starts use the description's seed family).
    discrepancy : float
        Half-normal prior scale of the model discrepancy's amplitude, a fraction of the sheet's mean (0: off).
    """

    replicates: int | None = None
    theta_points: int = 48
    check_points: int = 8
    check_settings: int = 2
    steps: int | None = None
    walkers: int | None = None
    draws: int = 400
    held_out_run: bool = True
    seed: int = 0
    discrepancy: float = DISCREPANCY_SCALE


def _check_settings(targets: list[FactorTarget], tested: np.ndarray, count: int, seed: int) -> np.ndarray:
    """Untested settings for the emulator's check: untested level sets of the full factorial first (seeded choice),
    then points drawn uniformly inside the level ranges."""
    if count <= 0:
        return np.zeros((0, len(targets)))
    rng = np.random.default_rng(seed)
    full = level_sets(targets)
    untested = [x for x in full if not any(np.allclose(x, t, rtol=1e-12, atol=0) for t in tested)]
    pick = [untested[i] for i in rng.permutation(len(untested))[:count]]
    while len(pick) < count:
        pick.append(np.array([rng.uniform(min(t.levels_si), max(t.levels_si)) for t in targets]))
    return np.array(pick, float)


def _train(sim: Simulator, responses: list[str], settings: list[int], starts: list[int], u: np.ndarray,
           params) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Simulated means, model SDs and counting SDs at every setting and unit-cube point: (settings, points, responses)
    each; the efficiency's mean and model SD per kg of yield."""
    theta = theta_of(u, params)
    yb = theta[:, PARAMETER_NAMES.index("yield_per_bush")]
    means, sds, csds = [], [], []
    for s in settings:
        m, sd, csd = start_statistics(*sim.responses(s, starts, theta, responses))
        if "efficiency" in responses:
            j = responses.index("efficiency")
            m[:, j] /= yb
            sd[:, j] /= yb
        means.append(m)
        sds.append(sd)
        csds.append(csd)
    return np.stack(means), np.stack(sds), np.stack(csds)


def _emulator_check(sim, emulator: Emulator, settings, starts, u, params) -> dict[str, EmulatorCheck]:
    """Held-out error of the emulator at ``settings`` and points ``u`` (neither trained on): RMSE of the mean, over the
    RMS model SD; RMSE of log model SD; MSE of log(mean + c) and its root (``relative_rmse``, about the relative error
    of mean + c)."""
    mean, sd, _ = _train(sim, emulator.responses, settings, starts, u, params)
    x = np.repeat(np.array([sim.settings[s] for s in settings]), len(u), axis=0)
    uu = np.tile(u, (len(settings), 1))
    rows = calibrated_responses()
    out = {}
    for j, r in enumerate(emulator.responses):
        pm, _, psd, _ = emulator.predict(x, uu, r, with_var=False)
        floor = rows[r].floor
        m, s_ = mean[:, :, j].ravel(), sd[:, :, j].ravel()
        rms_sd = float(np.sqrt(np.mean(s_**2)))
        rmse = float(np.sqrt(np.mean((pm - m) ** 2)))
        out[r] = EmulatorCheck(
            rmse=rmse, replicate_sd_rms=rms_sd, rmse_over_sd=rmse / rms_sd if rms_sd > 0 else float("nan"),
            log_sd_rmse=float(np.sqrt(np.mean((np.log(np.maximum(psd, 1e-3 * floor))
                                               - np.log(np.maximum(s_, 1e-3 * floor))) ** 2))),
            mse_log_mean=float(np.mean((np.log(pm + floor) - np.log(m + floor)) ** 2)),
            relative_rmse=float(np.sqrt(np.mean((np.log(pm + floor) - np.log(m + floor)) ** 2))),
            points=int(len(m)), unit="kg/min per kg of yield per bush" if r == "efficiency" else rows[r].unit)
    return out


def _fit_joint(sim, emulator: Emulator, unique: list[int], check_idx: list[int], starts, focus_u: np.ndarray,
               check_u: np.ndarray | None, params) -> dict[str, EmulatorCheck]:
    """The joint GP (settings not simulated), trained with the simulator at posterior draws ``focus_u`` at every
    simulated setting as well, then checked at the untested settings ``check_idx`` on other posterior draws
    ``check_u`` (where its predictions are used): that held-out MSE of log(mean + c) is its own error, floored by
    the per-setting GPs' in :meth:`Emulator.joint_mse`.  Returns the check (empty without check settings)."""
    emulator.fit_joint((focus_u, *_train(sim, emulator.responses, unique, starts, focus_u, params)))
    if not check_idx:
        return {}
    held = _emulator_check(sim, emulator, check_idx, starts, check_u, params)
    for r in emulator.responses:
        emulator.joint[r].mse_log_mean = held[r].mse_log_mean
    return held


def _summaries(draws: np.ndarray, params, described: dict) -> dict[str, ParameterSummary]:
    out = {}
    for i, p in enumerate(params):
        v = draws[:, i]
        plo, phi = p.interval90()
        lo, hi = (float(x) for x in np.quantile(v, [0.05, 0.95]))
        ratio = (hi - lo) / (phi - plo)
        out[p.name] = ParameterSummary(
            unit=p.unit, prior=PriorSummary(distribution=p.distribution, text=p.describe(), lo90=plo, hi90=phi,
                                            source=p.source, tag=p.tag),
            described=float(described[p.name]), posterior_mean=float(np.mean(v)),
            posterior_median=float(np.median(v)), lo90=lo, hi90=hi, width_ratio=float(ratio),
            identified=bool(ratio < 0.5))
    return out


def _confounded(z: np.ndarray, params) -> list[Confounding]:
    c = np.corrcoef(z.T)
    out = []
    for i, j in itertools.combinations(range(len(params)), 2):
        if abs(c[i, j]) >= 0.5:
            out.append(Confounding(parameters=[params[i].name, params[j].name], correlation=float(c[i, j])))
    return out


def _recommend(names: list[str], expected: dict[str, np.ndarray], responses: list[str]) -> CalibrationRecommendation:
    """:data:`RECOMMENDATION_RULE` on the expected-result draws (level sets x draws) per response."""
    from berryshaker.reference_study import PRIORITY_WEIGHTS

    rows = calibrated_responses()
    n = len(names)
    beats = np.zeros((n, n), bool)  # beats[a, b]: a better than b on some response
    worse = np.zeros((n, n), bool)
    for r in responses:
        e = expected[r] if rows[r].maximize else -expected[r]
        d = e[:, None, :] - e[None, :, :]
        lo, hi = np.quantile(d, 0.05, axis=2), np.quantile(d, 0.95, axis=2)
        beats |= lo > 0
        worse |= hi < 0
    dominated = [bool(np.any(beats[:, b] & ~worse[:, b])) for b in range(n)]
    w = {r: PRIORITY_WEIGHTS.get(r, 0.0) for r in responses}
    total = sum(w.values()) or 1.0
    score = np.zeros(n)
    for r in responses:
        m = expected[r].mean(axis=1)
        m = m if rows[r].maximize else -m
        span = m.max() - m.min()
        score += w[r] / total * ((m - m.min()) / span if span > 0 else 0.0)
    free = [i for i in range(n) if not dominated[i]]
    best = max(free, key=lambda i: (round(float(score[i]), 9), -i))  # ties: the first level set (reproducible)
    return CalibrationRecommendation(level_set=names[best], score=float(score[best]),
                                     no_difference=[names[i] for i in free if i != best],
                                     dominated=int(sum(dominated)), candidates=n, rule=RECOMMENDATION_RULE,
                                     weights={r: w[r] / total for r in responses})


def _hyper(values: np.ndarray, scale: float) -> HyperSummary:
    lo, med, hi = (float(x) for x in np.quantile(values, [0.05, 0.5, 0.95]))
    return HyperSummary(median=med, lo90=lo, hi90=hi, prior_scale=float(scale))


def _residual_effects(sheet: Sheet, stats: SheetStatistics, emulator: Emulator, params, u_med: np.ndarray,
                      response: str) -> list[ResidualEffect]:
    """:data:`RESIDUAL_RULE` for one response."""
    import warnings

    import pandas as pd
    import statsmodels.formula.api as smf
    from statsmodels.stats.anova import anova_lm

    from berryshaker.study.field_calibration.posterior import _emulated

    mu = _emulated(emulator, stats.settings, u_med[None, :], params, response)[0][0]
    y = np.asarray(sheet.observations[response], float)
    rows = []
    for i in range(y.shape[0]):
        for v in y[i]:
            if np.isfinite(v):
                rows.append({"e": float(v - mu[i]), **{f"f{j}": float(sheet.settings_si[i, j])
                                                      for j in range(len(sheet.targets))}})
    df = pd.DataFrame(rows)
    factors = [j for j in range(len(sheet.targets)) if df[f"f{j}"].nunique() > 1]
    if not factors or len(df) <= 1 + sum(df[f"f{j}"].nunique() - 1 for j in factors):
        return []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a perfect fit (no error left) gives NaN F, handled below
        fit = smf.ols("e ~ " + " + ".join(f"C(f{j})" for j in factors), data=df).fit()
        table = anova_lm(fit, typ=2)
    out = []
    for j in factors:
        key = f"C(f{j})"
        f_val, p_val = float(table.loc[key, "F"]), float(table.loc[key, "PR(>F)"])
        lm = df.groupby(f"f{j}")["e"].mean()
        out.append(ResidualEffect(factor=sheet.targets[j].name, range=float(lm.max() - lm.min()),
                                  f=f_val if np.isfinite(f_val) else float("nan"),
                                  p=p_val if np.isfinite(p_val) else 1.0,
                                  beyond_noise=bool(np.isfinite(p_val) and p_val < 0.05 / len(factors))))
    return out


def _discrepancies(sheet, stats, emulator, params, post, responses, discrepancy) -> dict[str, ModelDiscrepancy]:
    """Per response the further field noise, the discrepancy and the residual effects, with the verdict."""
    rows = calibrated_responses()
    u_med = np.median(post["u"], axis=0)
    out = {}
    for i, r in enumerate(responses):
        eff = _residual_effects(sheet, stats, emulator, params, u_med, r)
        beyond = [e for e in eff if e.beyond_noise]
        unit = rows[r].unit
        if not beyond:
            verdict = (f"the model represents the sheet's {r}: no factor leaves a residual effect beyond the noise "
                       f"({RESIDUAL_RULE.split(';')[0]})")
        else:
            what = ", ".join(f"{e.factor} (residual range {e.range:.3g} {unit}, p = {e.p:.2g})" for e in beyond)
            verdict = (f"the sheet shows an effect on {r} that the model does not produce: {what}; "
                       + ("the predictions follow it through the model discrepancy (a Gaussian process over the "
                          "settings), with the discrepancy's uncertainty in their intervals" if discrepancy > 0 else
                          "with the discrepancy off (--discrepancy 0) the predictions do not follow it"))
        out[r] = ModelDiscrepancy(
            scale=float(stats.scale[r]), unit=unit, field_noise=_hyper(post["hyper"][:, 2 * i], FIELD_NOISE_SCALE),
            amplitude=_hyper(post["hyper"][:, 2 * i + 1], discrepancy) if discrepancy > 0 else None,
            residual_effects=eff, verdict=verdict)
    return out


def setting_names(targets, settings) -> list[str]:
    """Settings in the sheet's units, e.g. "A=0.25mm, speed=120rpm".

    Parameters
    ----------
    targets : list of FactorTarget
        The sheet's factors.
    settings : numpy.ndarray
        (n, factors) SI.

    Returns
    -------
    list of str
        One name per setting.
    """
    return [", ".join(f"{t.name}={v / t.to_si:.6g}{t.unit}" for t, v in zip(targets, x)) for x in settings]


def predictions(emulator: Emulator, stats: SheetStatistics, targets, tested, pred_settings: np.ndarray,
                named_from: int, u: np.ndarray, hyper: np.ndarray, params, responses: list[str], r_sim: int,
                seed: int) -> tuple[list[Prediction], dict[str, np.ndarray]]:
    """Predictions with 90 % intervals of one future field result at settings, and the expected results' draws.

    Parameters
    ----------
    emulator : Emulator
        The trained emulator.
    stats : SheetStatistics
        The sheet's statistics (the discrepancy is conditioned on them).
    targets : list of FactorTarget
        The sheet's factors.
    tested : numpy.ndarray
        (runs, factors) the sheet's settings (SI).
    pred_settings : numpy.ndarray
        (n, factors) the settings to predict (SI).
    named_from : int
        Index of the first setting the user named (the level sets come before it).
    u, hyper : numpy.ndarray
        Posterior draws: unit-cube points and the noise and discrepancy fractions (dimensionless).
    params : tuple of Parameter
        The parameters.
    responses : list of str
        The responses.
    r_sim : int
        Starts behind the simulated means.
    seed : int
        Seed of the noise draws: the level sets and the named settings draw from streams of their own, so a level
        set's prediction does not depend on which settings are named.

    Returns
    -------
    (list of Prediction, dict of str to numpy.ndarray)
        The predictions and, per response, (settings, draws) expected results.
    """
    rows = calibrated_responses()
    names = setting_names(targets, pred_settings)
    tested_keys = {tuple(np.round(x, 15)) for x in tested}
    expected, per = {}, {}
    parts = [(slice(0, named_from), 0), (slice(named_from, len(pred_settings)), 1)]
    rngs = {k: np.random.default_rng([int(seed), PREDICTION_SEED, k]) for _, k in parts}
    for r in responses:
        e = np.empty((len(pred_settings), len(u)))
        fut = np.empty_like(e)
        for sl, k in parts:
            if sl.stop > sl.start:
                e[sl], fut[sl] = predictive(emulator, stats, pred_settings[sl], u, hyper, params, r, responses,
                                            rngs[k], 1, r_sim)
        expected[r] = e
        lo, hi = np.quantile(fut, [0.05, 0.95], axis=1)
        per[r] = [ResponsePrediction(mean=float(np.mean(e[i])), lo90=float(lo[i]), hi90=float(hi[i]),
                                     unit=rows[r].unit) for i in range(len(pred_settings))]
    out = [Prediction(level_set=names[i],
                      setting={t.name: SettingValue(value=float(v / t.to_si), unit=t.unit) for t, v in zip(targets, x)},
                      tested=tuple(np.round(x, 15)) in tested_keys, named=i >= named_from,
                      extrapolated=bool(np.any(x < emulator.lo - 1e-15) or np.any(x > emulator.hi + 1e-15)),
                      responses={r: per[r][i] for r in responses})
           for i, x in enumerate(pred_settings)] if responses else []
    return out, expected


def calibrate(machine: Machine, sheet: Sheet, runner, options: CalibrationSettings | None = None,
              predict: list[np.ndarray] | None = None, progress=None, state_out: dict | None = None
              ) -> CalibrationResult:
    """Posterior of the harvest parameters given a field sheet, its checks and its predictions (module docstring).

    Parameters
    ----------
    machine : Machine
        The machine description (with [plant] and [harvest]).
    sheet : Sheet
        The field sheet (:func:`~berryshaker.study.field_calibration.sheet.read_sheet`).
    runner : SweepRunner
        Cached runner of the coupled starts.
    options : CalibrationSettings, optional
        Sizes and seed.
    predict : list of numpy.ndarray, optional
        Further settings to predict (SI, :func:`~berryshaker.study.field_calibration.sheet.parse_setting`).
    progress : callable, optional
        ``progress(stage, done, total)``: "emulator", "sampling", "held-out run".
    state_out : dict, optional
        Filled with the calibration's state (emulator, draws, sheet statistics) for
        :func:`berryshaker.study.field_calibration.saved.save_state`.

    Returns
    -------
    CalibrationResult
        ``parameters`` (per name: unit, prior, described, posterior_mean, posterior_median, lo90, hi90, width_ratio,
        identified), ``identified_rule``, ``confounded``, ``predictions`` (per level set: setting, tested,
        extrapolated, responses with mean, lo90, hi90, unit), ``recommendation``, ``emulator``, ``checks``,
        ``sampler``, ``simulator``, ``sheet``, ``likelihood``, ``discrepancy``, ``discrepancies``, ``limits``,
        ``timings_s`` (:mod:`~berryshaker.study.field_calibration.result`); all values SI except the responses
        (kg/min, %) and the factors' settings and levels (the sheet's units).
    """
    opt = options or CalibrationSettings()
    if machine.plant is None:
        raise ConfigError("calibrate needs a [plant] block in the machine description (the harvest model runs on "
                          "it); add one, e.g. from the reference machine (config init)")
    if machine.harvest.bond_model != "pull_shear" or machine.harvest.damage_model != "impact":
        raise ConfigError("calibrate works on the published-strength model: set harvest.bond_model = \"pull_shear\" "
                          "and harvest.damage_model = \"impact\" (the defaults)")
    if not 0 <= opt.discrepancy <= 1:
        raise ConfigError(f"--discrepancy {opt.discrepancy}: give the prior scale of the discrepancy as a fraction "
                          "of the mean in 0 .. 1 (0 = off)")
    params = parameters_for(machine)
    responses = [r for r in calibrated_responses() if r in sheet.observations]
    r_sim = int(opt.replicates or machine.harvest.replicates)
    if r_sim < 2:
        raise ConfigError("--replicates must be at least 2 (the replicate SD needs two starts)")
    sim = Simulator(machine, sheet.targets)
    sheet_idx = [sim.setting_index(x) for x in sheet.settings_si]
    unique = sorted(set(sheet_idx))
    checks = _check_settings(sheet.targets, np.array([sim.settings[i] for i in unique]), opt.check_settings,
                             opt.seed + 7)
    check_idx = [sim.setting_index(x) for x in checks]
    starts = training_starts(machine, r_sim)
    t0 = time.perf_counter()
    sim.run(runner, unique + check_idx, starts, "calibration: simulator starts")
    t_sim = time.perf_counter() - t0
    # emulator
    if progress:
        progress("emulator", 0, 1)
    emulator = Emulator(sheet.targets, responses, opt.seed, r_sim)
    u_train = latin_hypercube(opt.theta_points, opt.seed + 1)
    u_check = latin_hypercube(opt.check_points, opt.seed + 2)
    t1 = time.perf_counter()
    emulator.fit([sim.settings[i] for i in unique], u_train, *_train(sim, responses, unique, starts, u_train, params))
    held_theta = _emulator_check(sim, emulator, unique, starts, u_check, params)
    for gps in emulator.local:
        for r in responses:
            gps[r].mse_log_mean = held_theta[r].mse_log_mean
    t_emu = time.perf_counter() - t1
    if progress:
        progress("emulator", 1, 1)
    stats = SheetStatistics.of(emulator, sheet.settings_si, sheet.observations)
    # posterior
    t2 = time.perf_counter()
    post = sample_posterior(emulator, stats, params, r_sim, opt.seed + 3, responses, opt.discrepancy, opt.steps,
                            opt.walkers, progress=(lambda d, n: progress("sampling", d, n)) if progress else None)
    t_mcmc = time.perf_counter() - t2
    rng = np.random.default_rng(opt.seed + 4)
    pick = rng.choice(len(post["u"]), size=min(opt.draws, len(post["u"])), replace=False)
    u_draws, h_draws = post["u"][pick], post["hyper"][pick]
    # the joint GP (settings not simulated): trained with simulated points at posterior draws as well, then checked
    # at the untested check settings on other posterior draws (where its predictions are used)
    t3 = time.perf_counter()
    focus_u = post["u"][rng.choice(len(post["u"]), size=min(16, len(post["u"])), replace=False)]
    check_u = (post["u"][rng.choice(len(post["u"]), size=min(opt.check_points, len(post["u"])), replace=False)]
               if check_idx else None)
    held_settings = _fit_joint(sim, emulator, unique, check_idx, starts, focus_u, check_u, params)
    t_emu += time.perf_counter() - t3
    parameters = _summaries(post["theta"], params, described_values(machine))
    # posterior predictive checks on the sheet's runs: each run against the posterior with the discrepancy
    # conditioned on the other runs (a run does not predict itself)
    ppc = []
    for r in responses:
        for i in range(len(sheet.settings_si)):
            if stats.n[r][i] == 0:
                continue
            _, fut = predictive(emulator, stats, sheet.settings_si[i:i + 1], u_draws, h_draws, params, r, responses,
                                rng, int(stats.n[r][i]), r_sim, leave_out=i)
            lo, hi = np.quantile(fut[0], [0.05, 0.95])
            ob = float(stats.mean[r][i])
            ppc.append(RunCheck(run=i + 1, setting=sim.setting_text(sheet_idx[i]), response=r, observed_mean=ob,
                                lo90=float(lo), hi90=float(hi), inside=bool(lo <= ob <= hi)))
    held_run = _held_out_run(emulator, sheet, params, r_sim, opt, sim, sheet_idx, responses, progress)
    # predictions of every level set of the sheet's factors and the named settings
    full = level_sets(sheet.targets)
    extra = [np.asarray(x, float) for x in (predict or [])]
    pred_settings = np.vstack([full] + [x[None, :] for x in extra]) if extra else full
    preds, expected = predictions(emulator, stats, sheet.targets, sheet.settings_si, pred_settings, len(full),
                                  u_draws, h_draws, params, responses, r_sim, opt.seed)
    recommendation = _recommend(setting_names(sheet.targets, full), {r: e[:len(full)] for r, e in expected.items()},
                                responses)
    discrepancies = _discrepancies(sheet, stats, emulator, params, post, responses, opt.discrepancy)
    if state_out is not None:
        state_out.update({"emulator": emulator.state(), "u": u_draws, "hyper": h_draws, "responses": responses,
                          "r_sim": r_sim, "seed": opt.seed, "settings_si": np.asarray(sheet.settings_si, float),
                          "observations": {r: np.asarray(v, float) for r, v in sheet.observations.items()}})
    inside = sum(c.inside for c in ppc)
    return CalibrationResult(
        parameters=parameters, identified_rule=IDENTIFIED_RULE,
        confounded=_confounded(post["z"], params), confounded_rule=CONFOUNDED_RULE,
        predictions=preds, recommendation=recommendation,
        emulator=EmulatorSummary(
            kind="scikit-learn GaussianProcessRegressor per response on log(mean + c), log(model SD) and log(counting "
                 "SD): ConstantKernel x Matern(nu=2.5, ARD) + WhiteKernel, normalize_y; per simulated setting "
                 "over theta on the prior's unit cube (the likelihood, predictions there) and one joint GP "
                 "over (coded setting, theta) for settings not simulated",
            joint_fitted=emulator.joint is not None, joint_points=emulator.joint_points,
            training_points=emulator.training_points, theta_points_per_setting=opt.theta_points,
            held_out_theta=held_theta, held_out_settings=held_settings,
            held_out_settings_at="posterior draws not used in training, at untested settings simulated "
                                 "for the check (the joint GP's error where it predicts)",
            check_settings=[sim.setting_text(i) for i in check_idx],
            untested_relative_rmse={r: float(np.sqrt(emulator.joint_mse(r))) for r in responses},
            untested_error_rule="the joint GP's error term: the larger of its held-out error at the check "
                                "settings and the per-setting GPs' held-out error (its baseline's)",
            fit_s=emulator.fit_seconds),
        checks=Checks(posterior_predictive=ppc,
                      summary=CheckSummary(inside=int(inside), total=len(ppc),
                                           rule="observed run mean inside the 90 % predictive interval of the mean of "
                                                "as many future results (the discrepancy conditioned on the other "
                                                "runs)"),
                      held_out_run=held_run),
        sampler=SamplerSummary(walkers=post["walkers"], steps=post["steps"], burn=post["burn"], thin=post["thin"],
                               acceptance_fraction=post["acceptance_fraction"],
                               autocorrelation_steps=post["autocorrelation_steps"], converged=post["converged"],
                               draws=int(len(post["u"])), package="emcee (DEMove 0.8, DESnookerMove 0.2)"),
        simulator=SimulatorSummary(starts_per_setting=r_sim, seeds=starts, settings_simulated=len(sim.settings),
                                   coupled_runs=sim.runs, exact="the virtual harvest's own quadrature of each start's "
                                   "stem-load tables at every theta (berryshaker.harvest.virtual.field_test): the "
                                   "model's expectation and the counting variance of one field test"),
        sheet=SheetSummary(runs=int(len(sheet.settings_si)), replicates=sheet.replicates, responses=responses,
                           factors={t.name: FactorSummary(sets=t.pair or "drive speed", unit=t.unit,
                                                          levels=[v / t.to_si for v in t.levels_si])
                                    for t in sheet.targets},
                           runs_identified_by=sheet.runs_identified_by),
        likelihood=("each field result = the simulator's mean mu(theta) (emulated) + a model discrepancy delta(x) (a "
                    "Gaussian process over the coded settings, additive squared-exponential kernel, length "
                    f"{DISCREPANCY_LENGTH:g} coded unit) + the simulated mean's own error + one field test's noise "
                    "(the model's start-to-start SD, the counting noise of a test of operation.test_duration and a "
                    "further field noise kappa x the sheet's mean); run means jointly normal, each run's within sum "
                    "of squares chi-square; responses independent given theta"),
        discrepancy=opt.discrepancy,
        discrepancy_text=("off (0): no model-discrepancy term" if opt.discrepancy == 0 else
                          f"on: amplitude half-normal with scale {opt.discrepancy:g} x the sheet's mean"),
        discrepancies=discrepancies,
        limits=list(LIMITS), timings_s=Timings(simulator=t_sim, emulator=t_emu, sampling=t_mcmc),
    )


def _held_out_run(emulator, sheet: Sheet, params, r_sim, opt: CalibrationSettings, sim, sheet_idx, responses,
                  progress) -> HeldOutRun:
    """Calibrate without the sheet's first run and predict it (when runs > parameters + 2 and asked for)."""
    n = len(sheet.settings_si)
    if not opt.held_out_run or n <= len(params) + 2:
        return HeldOutRun(done=False, reason=f"{n} runs: a held-out run needs more than {len(params) + 2} "
                          "(parameters + 2)" if n <= len(params) + 2 else "not asked for")
    keep = np.arange(1, n)
    stats = SheetStatistics.of(emulator, sheet.settings_si[keep], {r: v[keep] for r, v in sheet.observations.items()})
    if progress:
        progress("held-out run", 0, 1)
    post = sample_posterior(emulator, stats, params, r_sim, opt.seed + 5, responses, opt.discrepancy,
                            opt.steps or 1000, opt.walkers)
    rng = np.random.default_rng(opt.seed + 6)
    pick = rng.choice(len(post["u"]), size=min(opt.draws, len(post["u"])), replace=False)
    rows = []
    for r in responses:
        y0 = np.asarray(sheet.observations[r][0], float)
        y0 = y0[np.isfinite(y0)]
        if not y0.size:
            continue
        _, fut = predictive(emulator, stats, sheet.settings_si[:1], post["u"][pick], post["hyper"][pick], params, r,
                            responses, rng, int(y0.size), r_sim)
        lo, hi = np.quantile(fut[0], [0.05, 0.95])
        ob = float(np.mean(y0))
        rows.append(RunCheck(run=1, setting=sim.setting_text(sheet_idx[0]), response=r, observed_mean=ob,
                             lo90=float(lo), hi90=float(hi), inside=bool(lo <= ob <= hi)))
    if progress:
        progress("held-out run", 1, 1)
    return HeldOutRun(done=True, run=1, rows=rows, steps=post["steps"])


def predict_saved(state: dict, targets, settings: list[np.ndarray], machine: Machine) -> tuple[list[Prediction], str]:
    """Predictions of a saved calibration (:mod:`berryshaker.study.field_calibration.saved`) at every level set of its
    sheet's factors and at ``settings``, without the simulator or the sampler: the same emulator and posterior draws.

    Parameters
    ----------
    state : dict
        The saved state (:func:`~berryshaker.study.field_calibration.saved.load_state`).
    targets : list of FactorTarget
        The sheet's factors (from the saved calibration's ``calibration.json``).
    settings : list of numpy.ndarray
        Further settings to predict (SI).
    machine : Machine
        The machine description (its priors).

    Returns
    -------
    (list of Prediction, str)
        The predictions and the recommendation's level set among the level sets.
    """
    emulator = Emulator.from_state(state["emulator"])
    responses = list(state["responses"])
    params = parameters_for(machine)
    stats = SheetStatistics.of(emulator, state["settings_si"], state["observations"])
    full = level_sets(targets)
    extra = [np.asarray(x, float) for x in settings]
    pred_settings = np.vstack([full] + [x[None, :] for x in extra]) if extra else full
    preds, expected = predictions(emulator, stats, targets, state["settings_si"], pred_settings, len(full),
                                  state["u"], state["hyper"], params, responses, int(state["r_sim"]),
                                  int(state["seed"]))
    rec = _recommend(setting_names(targets, full), {r: e[:len(full)] for r, e in expected.items()}, responses)
    return preds, rec.level_set
