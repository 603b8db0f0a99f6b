"""The whole calibration (:func:`calibrate`): the simulator's runs, the emulator's training and checks, the posterior,
then identifiability, checks, predictions and the recommendation, assembled into one
:class:`~berryshaker.study.field_calibration.result.CalibrationResult` (the command ``berryshaker calibrate`` writes
it, the report reads it).

Identifiability is the prior against the posterior 90 % intervals (:data:`IDENTIFIED_RULE`,
:data:`CONFOUNDED_RULE`); the checks are posterior predictive checks per run and a held-out run; the predictions are
of every level set of the sheet's factors (and named settings) with 90 % intervals of a future field result, and a
recommendation is made on them (:data:`RECOMMENDATION_RULE`).
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass

import numpy as np

from berryshaker.config import Machine
from berryshaker.errors import ConfigError
from berryshaker.study.field_calibration.emulator import Emulator
from berryshaker.study.field_calibration.posterior import predictive, sample_posterior
from berryshaker.study.field_calibration.priors import (
    PARAMETER_NAMES,
    RESPONSES,
    described_values,
    latin_hypercube,
    parameters_for,
    theta_of,
)
from berryshaker.study.field_calibration.result import (
    CalibrationResult,
    CheckSummary,
    Checks,
    Confounding,
    EmulatorCheck,
    EmulatorSummary,
    FactorSummary,
    HeldOutRun,
    ParameterSummary,
    Prediction,
    PriorSummary,
    CalibrationRecommendation,
    ResponsePrediction,
    RunCheck,
    SamplerSummary,
    SettingValue,
    SheetSummary,
    SimulatorSummary,
    Timings,
)
from berryshaker.study.field_calibration.sheet import FactorTarget, Sheet, level_sets
from berryshaker.study.field_calibration.simulator import Simulator, start_statistics, training_seeds


IDENTIFIED_RULE = ("identified: the posterior's central 90 % interval is narrower than half the prior's "
                   "(width ratio < 0.5)")
CONFOUNDED_RULE = "confounded: |posterior correlation| >= 0.5 between two parameters (on the prior's normal scores)"
RECOMMENDATION_RULE = (
    "a level set beats another on a response when the 90 % interval of the difference of their expected field "
    "results (same posterior draws at both, emulator errors independent) lies on the better side of zero; a level "
    "set is dominated when another beats it on at least one response and is beaten on none; the recommendation is "
    "the undominated level set with the best weighted score of the predicted means (each response scaled 0..1 over "
    "the level sets, weights efficiency 0.5, damage 0.3, unripe 0.2, the study's priority); the other undominated "
    "level sets are listed as 'no difference beyond the intervals'")
LIMITS = (
    "pedicel stiffness is not calibrated: the stem-load tables are computed at the described stiffness",
    "unripe bond CV, fruit mass, branch geometry and every machine value stay as described",
    "model discrepancy is off unless --discrepancy is given: the posterior then assumes the model can reproduce the "
    "field means exactly up to the replicate noise and the emulator's error",
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
        Seed of everything random in the method (the simulator's starts use the description's seeds).
    discrepancy : float
        Model discrepancy, fraction of the mean (0: off).
    """

    replicates: int | None = None
    theta_points: int = 40
    check_points: int = 8
    check_settings: int = 2
    steps: int | None = None
    walkers: int | None = None
    draws: int = 400
    held_out_run: bool = True
    seed: int = 0
    discrepancy: float = 0.0


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


def _train(sim: Simulator, responses: list[str], settings: list[int], seeds: list[int], u: np.ndarray,
           params) -> tuple[np.ndarray, np.ndarray]:
    """Simulated replicate means and SDs at every setting and unit-cube point: (settings, points, responses) each,
    the efficiency per kg of yield."""
    theta = theta_of(u, params)
    theta[:, PARAMETER_NAMES.index("yield_per_bush")] = 1.0  # efficiency per kg of yield
    cols = [list(RESPONSES).index(r) for r in responses]
    means, sds = [], []
    for s in settings:
        m, sd = start_statistics(sim.responses(s, seeds, theta))
        means.append(m[:, cols])
        sds.append(sd[:, cols])
    return np.stack(means), np.stack(sds)


def _emulator_check(sim, emulator: Emulator, settings, seeds, u, params) -> dict[str, EmulatorCheck]:
    """Held-out error of the emulator at ``settings`` and points ``u`` (neither trained on): RMSE of the mean, over the
    RMS replicate SD; RMSE of log SD; MSE of log(mean + c) and its root (``relative_rmse``, about the relative error
    of mean + c)."""
    mean, sd = _train(sim, emulator.responses, settings, seeds, u, params)
    x = np.repeat(np.array([sim.settings[s] for s in settings]), len(u), axis=0)
    uu = np.tile(u, (len(settings), 1))
    out = {}
    for j, r in enumerate(emulator.responses):
        pm, _, psd = emulator.predict(x, uu, r, with_var=False)
        floor = RESPONSES[r][1]
        m, s_ = mean[:, :, j].ravel(), sd[:, :, j].ravel()
        rms_sd = float(np.sqrt(np.mean(s_**2)))
        rmse = float(np.sqrt(np.mean((pm - m) ** 2)))
        out[r] = EmulatorCheck(
            rmse=rmse, replicate_sd_rms=rms_sd, rmse_over_sd=rmse / rms_sd if rms_sd > 0 else float("nan"),
            log_sd_rmse=float(np.sqrt(np.mean((np.log(np.maximum(psd, 1e-3 * floor))
                                               - np.log(np.maximum(s_, 1e-3 * floor))) ** 2))),
            mse_log_mean=float(np.mean((np.log(pm + floor) - np.log(m + floor)) ** 2)),
            relative_rmse=float(np.sqrt(np.mean((np.log(pm + floor) - np.log(m + floor)) ** 2))),
            points=int(len(m)), unit="kg/min per kg of yield per bush" if r == "efficiency" else "%")
    return out


def _fit_joint(sim, emulator: Emulator, unique: list[int], check_idx: list[int], seeds, focus_u: np.ndarray,
               check_u: np.ndarray | None, params) -> dict[str, EmulatorCheck]:
    """The joint GP (settings not simulated), trained with the simulator at posterior draws ``focus_u`` at every
    simulated setting as well, then checked at the untested settings ``check_idx`` on other posterior draws
    ``check_u`` (where its predictions are used): that held-out MSE of log(mean + c) is its own error, floored by
    the per-setting GPs' in :meth:`Emulator.joint_mse`.  Returns the check (empty without check settings)."""
    emulator.fit_joint((focus_u, *_train(sim, emulator.responses, unique, seeds, focus_u, params)))
    if not check_idx:
        return {}
    held = _emulator_check(sim, emulator, check_idx, seeds, check_u, params)
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
    from berryshaker.reference_study import PRIORITY_WEIGHTS, SENSES

    n = len(names)
    beats = np.zeros((n, n), bool)  # beats[a, b]: a better than b on some response
    worse = np.zeros((n, n), bool)
    for r in responses:
        e = expected[r] if SENSES[r] else -expected[r]
        d = e[:, None, :] - e[None, :, :]
        lo, hi = np.quantile(d, 0.05, axis=2), np.quantile(d, 0.95, axis=2)
        beats |= lo > 0
        worse |= hi < 0
    dominated = [bool(np.any(beats[:, b] & ~worse[:, b])) for b in range(n)]
    w = {r: PRIORITY_WEIGHTS[r] for r in responses}
    total = sum(w.values())
    score = np.zeros(n)
    for r in responses:
        m = expected[r].mean(axis=1)
        m = m if SENSES[r] else -m
        span = m.max() - m.min()
        score += w[r] / total * ((m - m.min()) / span if span > 0 else 0.0)
    free = [i for i in range(n) if not dominated[i]]
    best = max(free, key=lambda i: score[i])
    return CalibrationRecommendation(level_set=names[best], score=float(score[best]),
                          no_difference=[names[i] for i in free if i != best],
                          dominated=int(sum(dominated)), candidates=n, rule=RECOMMENDATION_RULE,
                          weights={r: w[r] / total for r in responses})


def calibrate(machine: Machine, sheet: Sheet, runner, options: CalibrationSettings | None = None,
              predict: list[np.ndarray] | None = None, progress=None) -> CalibrationResult:
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

    Returns
    -------
    CalibrationResult
        ``parameters`` (per name: unit, prior, described, posterior_mean, posterior_median, lo90, hi90, width_ratio,
        identified), ``identified_rule``, ``confounded``, ``predictions`` (per level set: setting, tested,
        extrapolated, responses with mean, lo90, hi90, unit), ``recommendation``, ``emulator``, ``checks``,
        ``sampler``, ``simulator``, ``sheet``, ``likelihood``, ``discrepancy``, ``limits``, ``timings_s``
        (:mod:`~berryshaker.study.field_calibration.result`); all values SI except the responses (kg/min, %) and
        the factors' settings and levels (the sheet's units).
    """
    opt = options or CalibrationSettings()
    if machine.plant is None:
        raise ConfigError("calibrate needs a [plant] block in the machine description (the harvest model runs on "
                          "it); add one, e.g. from the reference machine (config init)")
    if machine.harvest.bond_model != "pull_shear" or machine.harvest.damage_model != "impact":
        raise ConfigError("calibrate works on the published-strength model: set harvest.bond_model = \"pull_shear\" "
                          "and harvest.damage_model = \"impact\" (the defaults)")
    if not 0 <= opt.discrepancy < 1:
        raise ConfigError(f"--discrepancy {opt.discrepancy}: give a fraction of the mean in 0 .. 1 (0 = off)")
    params = parameters_for(machine)
    responses = [r for r in RESPONSES if r in sheet.observations]
    r_sim = int(opt.replicates or machine.harvest.replicates)
    if r_sim < 2:
        raise ConfigError("--replicates must be at least 2 (the replicate SD needs two starts)")
    sim = Simulator(machine, sheet.targets)
    sheet_idx = [sim.setting_index(x) for x in sheet.settings_si]
    unique = sorted(set(sheet_idx))
    checks = _check_settings(sheet.targets, np.array([sim.settings[i] for i in unique]), opt.check_settings,
                             opt.seed + 7)
    check_idx = [sim.setting_index(x) for x in checks]
    seeds = training_seeds(machine, r_sim)
    t0 = time.perf_counter()
    sim.run(runner, unique + check_idx, seeds, "calibration: simulator starts")
    t_sim = time.perf_counter() - t0
    # emulator
    if progress:
        progress("emulator", 0, 1)
    emulator = Emulator(sheet.targets, responses, opt.seed, r_sim)
    u_train = latin_hypercube(opt.theta_points, opt.seed + 1)
    u_check = latin_hypercube(opt.check_points, opt.seed + 2)
    t1 = time.perf_counter()
    emulator.fit([sim.settings[i] for i in unique], u_train, *_train(sim, responses, unique, seeds, u_train, params))
    held_theta = _emulator_check(sim, emulator, unique, seeds, u_check, params)
    for gps in emulator.local:
        for r in responses:
            gps[r].mse_log_mean = held_theta[r].mse_log_mean
    t_emu = time.perf_counter() - t1
    if progress:
        progress("emulator", 1, 1)
    # posterior
    t2 = time.perf_counter()
    post = sample_posterior(emulator, sheet, params, r_sim, opt.seed + 3, opt.discrepancy, opt.steps, opt.walkers,
                            progress=(lambda d, n: progress("sampling", d, n)) if progress else None)
    t_mcmc = time.perf_counter() - t2
    rng = np.random.default_rng(opt.seed + 4)
    pick = rng.choice(len(post["u"]), size=min(opt.draws, len(post["u"])), replace=False)
    u_draws = post["u"][pick]
    # the joint GP (settings not simulated): trained with simulated points at posterior draws as well, then checked
    # at the untested check settings on other posterior draws (where its predictions are used)
    t3 = time.perf_counter()
    focus_u = post["u"][rng.choice(len(post["u"]), size=min(16, len(post["u"])), replace=False)]
    check_u = (post["u"][rng.choice(len(post["u"]), size=min(opt.check_points, len(post["u"])), replace=False)]
               if check_idx else None)
    held_settings = _fit_joint(sim, emulator, unique, check_idx, seeds, focus_u, check_u, params)
    t_emu += time.perf_counter() - t3
    described = described_values(machine)
    parameters = _summaries(post["theta"], params, described)
    # posterior predictive checks on the sheet's runs
    ppc = []
    run_settings = sheet.settings_si
    for r in responses:
        _, fut = predictive(emulator, run_settings, u_draws, params, r, rng, sheet.replicates, r_sim, opt.discrepancy)
        for i in range(len(run_settings)):
            lo, hi = np.quantile(fut[i], [0.05, 0.95])
            ob = float(np.mean(sheet.observations[r][i]))
            ppc.append(RunCheck(run=i + 1, setting=sim.setting_text(sheet_idx[i]), response=r, observed_mean=ob,
                                lo90=float(lo), hi90=float(hi), inside=bool(lo <= ob <= hi)))
    held_run = _held_out_run(emulator, sheet, params, r_sim, opt, sim, sheet_idx, responses, progress)
    # predictions
    full = level_sets(sheet.targets)
    extra = [np.asarray(x, float) for x in (predict or [])]
    pred_settings = np.vstack([full] + [x[None, :] for x in extra]) if extra else full
    names = [", ".join(f"{t.name}={v / t.to_si:.6g}{t.unit}" for t, v in zip(sheet.targets, x)) for x in pred_settings]
    tested = {tuple(np.round(x, 15)) for x in sheet.settings_si}
    lo_b, hi_b = emulator.lo, emulator.hi
    expected, per_response = {}, {}
    for r in responses:
        e, fut = predictive(emulator, pred_settings, u_draws, params, r, rng, 1, r_sim, opt.discrepancy)
        expected[r] = e
        per_response[r] = []
        for i in range(len(pred_settings)):
            lo, hi = np.quantile(fut[i], [0.05, 0.95])
            per_response[r].append(ResponsePrediction(mean=float(np.mean(e[i])), lo90=float(lo), hi90=float(hi),
                                                      unit=RESPONSES[r][0]))
    predictions = [
        Prediction(level_set=names[i],
                   setting={t.name: SettingValue(value=float(v / t.to_si), unit=t.unit)
                            for t, v in zip(sheet.targets, x)},
                   tested=tuple(np.round(x, 15)) in tested, named=i >= len(full),
                   extrapolated=bool(np.any(x < lo_b - 1e-15) or np.any(x > hi_b + 1e-15)),
                   responses={r: per_response[r][i] for r in responses})
        for i, x in enumerate(pred_settings)] if responses else []
    recommendation = _recommend(names, expected, responses)
    inside = sum(c.inside for c in ppc)
    return CalibrationResult(
        parameters=parameters, identified_rule=IDENTIFIED_RULE,
        confounded=_confounded(post["z"], params), confounded_rule=CONFOUNDED_RULE,
        predictions=predictions, recommendation=recommendation,
        emulator=EmulatorSummary(
            kind="scikit-learn GaussianProcessRegressor per response on log(mean + c) and log(SD): "
                 "ConstantKernel x Matern(nu=2.5, ARD) + WhiteKernel, normalize_y; per simulated setting "
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
                                           rule="observed replicate mean inside the 90 % predictive interval of the "
                                                f"mean of {sheet.replicates} future result(s)"),
                      held_out_run=held_run),
        sampler=SamplerSummary(walkers=post["walkers"], steps=post["steps"], burn=post["burn"], thin=post["thin"],
                               acceptance_fraction=post["acceptance_fraction"],
                               autocorrelation_steps=post["autocorrelation_steps"], converged=post["converged"],
                               draws=int(len(post["u"])), package="emcee (DEMove 0.8, DESnookerMove 0.2)"),
        simulator=SimulatorSummary(starts_per_setting=r_sim, seeds=seeds, settings_simulated=len(sim.settings),
                                   coupled_runs=sim.runs, exact="post-processing of the cached stem-load tables at "
                                                                "every theta with common random numbers"),
        sheet=SheetSummary(runs=int(len(sheet.settings_si)), replicates=sheet.replicates, responses=responses,
                           factors={t.name: FactorSummary(sets=t.pair or "drive speed", unit=t.unit,
                                                          levels=[v / t.to_si for v in t.levels_si])
                                    for t in sheet.targets},
                           runs_identified_by=sheet.runs_identified_by),
        likelihood=("replicates of a run jointly normal: mean mu(theta) (emulated), per-result SD sigma(theta) (the "
                    "simulator's start-to-start SD), a term common to the run with variance sigma^2/R_sim + "
                    "emulator variance + (discrepancy x mu)^2; sigma is itself estimated from the R_sim starts, so the "
                    "likelihood is the multivariate Student t with R_sim - 1 dof; responses independent given "
                    "theta"),
        discrepancy=opt.discrepancy,
        discrepancy_text=("off (0): no model-discrepancy term" if opt.discrepancy == 0 else
                          f"on: SD {opt.discrepancy:g} x the mean, common to a run's replicates"),
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
    obs = {r: v[keep] for r, v in sheet.observations.items()}
    if progress:
        progress("held-out run", 0, 1)
    post = sample_posterior(emulator, sheet, params, r_sim, opt.seed + 5, opt.discrepancy,
                            opt.steps or 1000, opt.walkers, obs=obs, settings=sheet.settings_si[keep])
    rng = np.random.default_rng(opt.seed + 6)
    u = post["u"][rng.choice(len(post["u"]), size=min(opt.draws, len(post["u"])), replace=False)]
    rows = []
    for r in responses:
        _, fut = predictive(emulator, sheet.settings_si[:1], u, params, r, rng, sheet.replicates, r_sim,
                            opt.discrepancy)
        lo, hi = np.quantile(fut[0], [0.05, 0.95])
        ob = float(np.mean(sheet.observations[r][0]))
        rows.append(RunCheck(run=1, setting=sim.setting_text(sheet_idx[0]), response=r, observed_mean=ob,
                             lo90=float(lo), hi90=float(hi), inside=bool(lo <= ob <= hi)))
    if progress:
        progress("held-out run", 1, 1)
    return HeldOutRun(done=True, run=1, rows=rows, steps=post["steps"])
