"""The posterior of the calibrated parameters: the likelihood of a field sheet's results with the field's own noise
and a model discrepancy (:func:`log_likelihood`), the ``emcee`` sampler (:func:`sample_posterior`) and draws of
future field results over the posterior (:func:`predictive`).

The field results of sheet run s (setting x_s, R_s replicates, some may be lost) and response r are

    y_sr = mu_s(theta) + delta(x_s) + e_c,s + e_sr,

* mu_s(theta) the simulator's mean of the model's expectation (emulated; the efficiency x the yield per bush);
* e_sr ~ N(0, v_s), v_s = sigma_model,s^2 + sigma_count,s^2 + (kappa m)^2, the variance of one field test: the model's
  start-to-start spread and the counting noise of a test of ``operation.test_duration`` (both emulated at theta,
  berryshaker.harvest.virtual.field_test), and a further field noise the model does not know (rows, days, operators)
  of SD kappa x m (m the sheet's mean of the response; kappa half-normal, scale :data:`FIELD_NOISE_SCALE`,
  [assumed]), learnt from the sheet's own replicate scatter;
* e_c,s ~ N(0, sigma_model,s^2 / R_sim + sigma_emu,s^2), the simulated mean's own error over R_sim starts and the
  emulator's;
* delta(x) a model discrepancy (Kennedy and O'Hagan 2001, J. R. Statist. Soc. B 63, 425-464): a Gaussian process over
  the coded settings with an additive squared-exponential kernel, k(x, x') = (alpha m)^2 sum_f exp(-(x_f - x'_f)^2 /
  (2 l^2)) (one term per factor, each of amplitude alpha m: alpha is the size of a factor's discrepancy; length
  :data:`DISCREPANCY_LENGTH` in coded units, [assumed]), alpha half-normal with scale ``discrepancy`` (default
  :data:`DISCREPANCY_SCALE`, [assumed]; 0 turns it off): it absorbs a measured effect the model does not produce,
  and at untested settings the prediction follows it.

The run means are then jointly normal, ybar ~ N(mu, diag(v_s / R_s + sigma_model^2 / R_sim + sigma_emu^2) + K), and
each run's within sum of squares SS_s ~ v_s chi^2(R_s - 1) independently (the factorisation of the normal
likelihood into the sample means and the within sums of squares); responses independent given the parameters.
Sampled with ``emcee`` in the prior's standard-normal coordinates (theta) and the logarithms of kappa and alpha.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import special

from berryshaker.study.field_calibration.emulator import Emulator
from berryshaker.study.field_calibration.priors import PARAMETER_NAMES, Parameter, theta_of

#: half-normal prior scale of the further field noise kappa (SD as a fraction of the sheet's mean) [assumed: field
#: tests repeated on other rows and days scatter by 10-30 % beyond the counting noise]
FIELD_NOISE_SCALE = 0.3
#: default half-normal prior scale of the discrepancy amplitude alpha (fraction of the sheet's mean) [assumed: the
#: model's harvest indexes miss published field results by tens of per cent (docs/harvest.md "Validation"), so a
#: discrepancy of that size must be within the prior's reach]
DISCREPANCY_SCALE = 0.3
#: largest log of a noise or discrepancy fraction the sampler evaluates (beyond it the half-normal prior is ~0)
MAX_LOG_HYPER = 5.0
#: length of the discrepancy's kernel per factor, in coded units (levels at -1 .. 1) [assumed: the discrepancy varies
#: over about one level step, so neighbouring levels correlate (exp(-1/2)) and the extreme ones little (exp(-2))]
DISCREPANCY_LENGTH = 1.0


@dataclass
class SheetStatistics:
    """A sheet's results as the likelihood reads them, per response: run means, within sums of squares and counts.

    Attributes
    ----------
    coded : numpy.ndarray
        (runs, factors) settings coded to -1 .. 1 (the emulator's coding).
    settings : numpy.ndarray
        (runs, factors) SI settings.
    mean : dict of str to numpy.ndarray
        Response -> (runs,) replicate means (kg/min, %).
    ss : dict of str to numpy.ndarray
        Response -> (runs,) within sums of squares (units squared).
    n : dict of str to numpy.ndarray
        Response -> (runs,) results present (a lost plot is left out).
    scale : dict of str to float
        Response -> the sheet's mean over every result (the scale of kappa and alpha; its unit).
    """

    coded: np.ndarray
    settings: np.ndarray
    mean: dict
    ss: dict
    n: dict
    scale: dict

    @classmethod
    def of(cls, emulator: Emulator, settings: np.ndarray, obs: dict[str, np.ndarray]) -> "SheetStatistics":
        """The statistics of observations ``obs`` (response -> (runs, replicates), NaN for a lost result).

        Parameters
        ----------
        emulator : Emulator
            Its coding of the settings.
        settings : numpy.ndarray
            (runs, factors) SI.
        obs : dict of str to numpy.ndarray
            Response -> (runs, replicates) field results (kg/min, %).

        Returns
        -------
        SheetStatistics
            The run means, within sums of squares, counts and scales; a run with no result of a response is left
            out of that response (its count 0).
        """
        mean, ss, n, scale = {}, {}, {}, {}
        for r, y in obs.items():
            y = np.asarray(y, float)
            ok = np.isfinite(y)
            cnt = ok.sum(axis=1)
            with np.errstate(invalid="ignore"):
                m = np.where(cnt > 0, np.nansum(np.where(ok, y, 0.0), axis=1) / np.maximum(cnt, 1), np.nan)
            ss[r] = np.nansum(np.where(ok, (y - m[:, None]) ** 2, 0.0), axis=1)
            mean[r], n[r] = m, cnt
            vals = y[ok]
            scale[r] = float(max(abs(np.mean(vals)) if vals.size else 0.0, 1e-9))
        return cls(emulator.code(settings), np.asarray(settings, float), mean, ss, n, scale)


def kernel(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The discrepancy's kernel between coded settings in units of (alpha m)^2: the sum over the factors of
    exp(-(a_f - b_f)^2 / (2 l^2)), l = :data:`DISCREPANCY_LENGTH` (an additive squared-exponential kernel, one term
    of unit variance per factor).

    Parameters
    ----------
    a, b : numpy.ndarray
        (n, factors) and (m, factors) coded settings (dimensionless).

    Returns
    -------
    numpy.ndarray
        (n, m) kernel values (dimensionless; the number of factors on the diagonal).
    """
    d = np.asarray(a, float)[:, None, :] - np.asarray(b, float)[None, :, :]
    return np.sum(np.exp(-0.5 * (d / DISCREPANCY_LENGTH) ** 2), axis=-1)


def _log_halfnormal(s: np.ndarray, scale: float) -> np.ndarray:
    """Log prior of s = ln x with x half-normal of ``scale`` (the Jacobian e^s included)."""
    x = np.exp(s)
    return -0.5 * (x / scale) ** 2 + s


def _emulated(emulator: Emulator, settings: np.ndarray, u: np.ndarray, params, response: str):
    """Mean, emulator variance, model SD and counting SD at (settings x rows of u), shaped (rows, settings)."""
    mean, var_emu, sd, csd = emulator.predict_grid(settings, u, response)
    if response == "efficiency":
        yi = PARAMETER_NAMES.index("yield_per_bush")
        yb = params[yi].ppf(u[:, yi])[:, None]
        mean, var_emu, sd = mean * yb, var_emu * yb**2, sd * yb
    return mean, var_emu, sd, csd


def _response_terms(stats: SheetStatistics, r: str, mean, var_emu, sd, csd, kappa, alpha, r_sim: int, runs=None):
    """The likelihood's pieces of one response over walkers: field-test variance v, run-mean covariance Sigma and the
    residuals (of the runs ``runs``, default every run with a result)."""
    runs = np.flatnonzero(stats.n[r] > 0) if runs is None else np.asarray(runs)
    m = stats.scale[r]
    v = sd[:, runs] ** 2 + csd[:, runs] ** 2 + (kappa[:, None] * m) ** 2
    d = v / stats.n[r][runs] + sd[:, runs] ** 2 / r_sim + var_emu[:, runs]
    k = kernel(stats.coded[runs], stats.coded[runs])
    cov = (alpha[:, None, None] * m) ** 2 * k[None] + d[:, :, None] * np.eye(len(runs))[None]
    return runs, v, cov, stats.mean[r][runs][None, :] - mean[:, runs]


def log_likelihood(emulator: Emulator, stats: SheetStatistics, u: np.ndarray, hyper: np.ndarray,
                   params: tuple[Parameter, ...], r_sim: int, responses: list[str]) -> np.ndarray:
    """Log-likelihood of the sheet's results at parameter points ``u`` and noise/discrepancy values ``hyper``
    (module docstring).

    Parameters
    ----------
    emulator : Emulator
        The trained emulator.
    stats : SheetStatistics
        The sheet's run means, within sums of squares and counts.
    u : numpy.ndarray
        (walkers, 6) parameter points on the prior's unit cube.
    hyper : numpy.ndarray
        (walkers, 2 x responses) kappa and alpha per response (:func:`hyper_names` order; dimensionless).
    params : tuple of Parameter
        The parameters (the yield's quantile function).
    r_sim : int
        Starts behind the simulated means and SDs.
    responses : list of str
        The responses, in ``hyper``'s order.

    Returns
    -------
    numpy.ndarray
        (walkers,) log-likelihoods (dimensionless).
    """
    total = np.zeros(u.shape[0])
    for i, r in enumerate(responses):
        kappa, alpha = hyper[:, 2 * i], hyper[:, 2 * i + 1]
        mean, var_emu, sd, csd = _emulated(emulator, stats.settings, u, params, r)
        runs, v, cov, res = _response_terms(stats, r, mean, var_emu, sd, csd, kappa, alpha, r_sim)
        bad = ~np.all(np.isfinite(cov), axis=(1, 2)) | ~np.all(np.isfinite(res), axis=1) | np.any(v <= 0, axis=1)
        if np.any(bad):  # an emulated mean or SD outside its range: no likelihood there
            cov[bad] = np.eye(len(runs))
            res[bad] = 0.0
            v = np.where(bad[:, None], 1.0, v)
        chol = np.linalg.cholesky(cov)
        w = np.linalg.solve(chol, res[..., None])[..., 0]
        total += -0.5 * np.sum(w * w, axis=1) - np.sum(np.log(np.diagonal(chol, axis1=1, axis2=2)), axis=1)
        nr = stats.n[r][runs]
        within = nr > 1
        total += np.sum(np.where(within, -0.5 * (nr - 1) * np.log(v) - 0.5 * stats.ss[r][runs] / v, 0.0), axis=1)
        total[bad] = -np.inf
    return total


def sample_posterior(emulator: Emulator, stats: SheetStatistics, params: tuple[Parameter, ...], r_sim: int,
                     seed: int, responses: list[str], discrepancy: float = DISCREPANCY_SCALE,
                     steps: int | None = None, walkers: int | None = None, progress=None) -> dict:
    """Posterior draws with ``emcee`` (affine-invariant ensemble, vectorised log-probability) in the priors'
    standard-normal coordinates (theta = prior quantile of Phi(z)) and the logarithms of the noise and discrepancy
    parameters.

    Without ``steps`` the chain runs in blocks of 500 steps until it is 50 integrated autocorrelation times long (at
    most 4000 steps); burn-in = 3 tau, thinning = tau / 2 (tau the largest over the parameters).

    Parameters
    ----------
    emulator : Emulator
        The trained emulator.
    stats : SheetStatistics
        The sheet's statistics (a held-out run left out by the caller).
    params : tuple of Parameter
        The parameters.
    r_sim : int
        Starts behind the simulated means.
    seed : int
        Seed of the walkers' start and moves.
    responses : list of str
        The responses.
    discrepancy : float
        Half-normal prior scale of the discrepancy amplitude (fraction of the sheet's mean; 0: no discrepancy).
    steps : int, optional
        Fixed steps per walker.
    walkers : int, optional
        Walkers (default 4 x dimension, at least 24).
    progress : callable, optional
        ``progress(steps_done, steps_planned)``.

    Returns
    -------
    dict
        ``z`` (draws, 6) normal scores, ``u`` unit-cube points, ``theta`` (SI), ``hyper`` (draws, 2 x responses:
        kappa and alpha), ``acceptance_fraction``, ``autocorrelation_steps`` (per coordinate), ``steps``,
        ``walkers``, ``burn``, ``thin``, ``converged`` (chain >= 50 tau).
    """
    import emcee

    nt, nh = len(params), 2 * len(responses)
    use_alpha = discrepancy > 0
    free = [True] * nh if use_alpha else [i % 2 == 0 for i in range(nh)]
    dim = nt + sum(free)
    nw = walkers or max(24, 4 * dim)
    rng = np.random.default_rng(seed)

    def split(x):
        z = x[:, :nt]
        s = np.full((x.shape[0], nh), -np.inf)
        s[:, np.array(free)] = x[:, nt:]
        return z, s

    def log_prob(x):
        z, s = split(x)
        lp = -0.5 * np.sum(z**2, axis=1)
        for i in range(nh):
            if free[i]:
                lp = lp + _log_halfnormal(s[:, i], FIELD_NOISE_SCALE if i % 2 == 0 else discrepancy)
        out = np.full(x.shape[0], -np.inf)
        ok = np.all(np.isfinite(x), axis=1) & np.all(s[:, np.array(free)] < MAX_LOG_HYPER, axis=1)
        if np.any(ok):  # a noise or discrepancy of e^5 = 150 x the mean has no prior mass left: not evaluated
            u = np.clip(special.ndtr(z[ok]), 1e-12, 1 - 1e-12)
            out[ok] = lp[ok] + log_likelihood(emulator, stats, u, np.exp(s[ok]), params, r_sim, responses)
        return out

    sampler = emcee.EnsembleSampler(nw, dim, log_prob, vectorize=True,
                                    moves=[(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)])
    sampler.random_state = np.random.RandomState(seed).get_state()
    start = rng.standard_normal((nw, dim))
    start[:, nt:] = np.log(0.1) + 0.5 * rng.standard_normal((nw, dim - nt))  # noise and discrepancy near 10 %
    state = start
    planned = steps or 4000
    done, tau = 0, np.full(dim, np.nan)
    block = steps or 500
    while True:
        state = sampler.run_mcmc(state, block, progress=False)
        done += block
        if progress:
            progress(done, planned)
        tau = sampler.get_autocorr_time(tol=0)
        if steps or done >= planned or done >= 50 * float(np.nanmax(tau)):
            break
    t = float(np.nanmax(tau)) if np.all(np.isfinite(tau)) else done / 50
    burn = min(int(math.ceil(3 * t)), done // 2)
    thin = max(1, int(t / 2))
    x = sampler.get_chain(discard=burn, thin=thin, flat=True)
    z, s = split(x)
    u = np.clip(special.ndtr(z), 1e-12, 1 - 1e-12)
    return {"z": z, "u": u, "theta": theta_of(u, params), "hyper": np.exp(s),
            "acceptance_fraction": float(np.mean(sampler.acceptance_fraction)),
            "autocorrelation_steps": [float(v) for v in tau], "steps": done, "walkers": nw, "burn": burn,
            "thin": thin, "converged": bool(done >= 50 * t)}


def predictive(emulator: Emulator, stats: SheetStatistics, settings_si: np.ndarray, u: np.ndarray, hyper: np.ndarray,
               params: tuple[Parameter, ...], response: str, responses: list[str], rng: np.random.Generator,
               replicates: int = 1, r_sim: int = 2, leave_out: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Draws of the expected field result and of a future field result (the mean of ``replicates`` tests) at
    settings, over posterior draws: the emulated mean, the discrepancy conditioned on the sheet's residuals (Kennedy
    and O'Hagan's predictive mean and variance), the emulator's and the simulated mean's errors, and the noise of
    ``replicates`` field tests.

    Parameters
    ----------
    emulator : Emulator
        The trained emulator.
    stats : SheetStatistics
        The sheet's statistics (the residuals the discrepancy is conditioned on).
    settings_si : numpy.ndarray
        (settings, factors) SI.
    u : numpy.ndarray
        (draws, 6) posterior draws on the unit cube (prior probabilities, dimensionless).
    hyper : numpy.ndarray
        (draws, 2 x responses) kappa and alpha (fractions of the sheet's mean; dimensionless).
    params : tuple of Parameter
        The parameters.
    response : str
        Response name.
    responses : list of str
        The responses, in ``hyper``'s order.
    rng : numpy.random.Generator
        Noise draws.
    replicates : int
        Results averaged (1: one future field result).
    r_sim : int
        Starts behind the simulated means.
    leave_out : int, optional
        A sheet run the discrepancy is not conditioned on (a posterior predictive check of that run).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        (settings, draws) expected field result and future result draws, the response's unit; both clipped at 0
        (an efficiency or a rate is never negative).
    """
    i = responses.index(response)
    kappa, alpha = hyper[:, 2 * i], hyper[:, 2 * i + 1]
    m_o, ve_o, sd_o, cs_o = _emulated(emulator, stats.settings, u, params, response)
    runs = np.flatnonzero(stats.n[response] > 0)
    if leave_out is not None:
        runs = runs[runs != leave_out]
    mean, var_emu, sd, csd = _emulated(emulator, np.atleast_2d(settings_si), u, params, response)
    scale = stats.scale[response]
    a2 = (alpha * scale) ** 2
    if len(runs):
        _, _, cov, res = _response_terms(stats, response, m_o, ve_o, sd_o, cs_o, kappa, alpha, r_sim, runs)
        kso = a2[:, None, None] * kernel(emulator.code(settings_si), stats.coded[runs])[None]  # (draws, set, runs)
        chol = np.linalg.cholesky(cov)
        w = np.linalg.solve(chol, res[..., None])  # (draws, runs, 1)
        b = np.linalg.solve(chol, np.swapaxes(kso, 1, 2))  # (draws, runs, settings)
        delta = np.einsum("drs,dr->ds", b, w[..., 0])
        var_delta = np.maximum(a2[:, None] * stats.coded.shape[1] - np.sum(b * b, axis=1), 0.0)
    else:  # nothing to condition on: the discrepancy's prior
        delta, var_delta = np.zeros_like(mean), np.broadcast_to(a2[:, None] * stats.coded.shape[1], mean.shape)
    common = var_delta + var_emu + sd**2 / r_sim
    expected = np.maximum(mean + delta + np.sqrt(common) * rng.standard_normal(mean.shape), 0.0)
    v = sd**2 + csd**2 + (kappa[:, None] * scale) ** 2
    future = np.maximum(expected + np.sqrt(v / replicates) * rng.standard_normal(mean.shape), 0.0)
    return expected.T, future.T
