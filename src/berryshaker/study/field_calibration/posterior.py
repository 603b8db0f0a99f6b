"""The posterior of the calibrated parameters: the Student-t likelihood of a field sheet's results
(:func:`log_likelihood`), the ``emcee`` sampler (:func:`sample_posterior`) and draws of future field results over
the posterior (:func:`predictive`).

The replicates y_{s,1..R} of sheet run s are jointly normal, each y_{s,r} = mu_s(theta) + e_c + e_r with
e_r ~ N(0, sigma_s(theta)^2) (the simulator's start-to-start SD) and a term common to the run
e_c ~ N(0, sigma_s^2 / R_sim + sigma_emu^2 + (delta mu_s)^2) (the simulated mean's own error over R_sim starts, the
emulator's error, the optional model discrepancy delta as a fraction of the mean); sigma_s is estimated from the
R_sim starts, so the likelihood is the multivariate Student t this gives (:func:`log_likelihood`); responses
independent given theta.  Sampled with ``emcee`` in the prior's standard-normal coordinates.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import special

from berryshaker.study.field_calibration.emulator import Emulator
from berryshaker.study.field_calibration.priors import PARAMETER_NAMES, Parameter, theta_of
from berryshaker.study.field_calibration.sheet import Sheet


def log_likelihood(emulator: Emulator, sheet_settings: np.ndarray, obs: dict[str, np.ndarray], u: np.ndarray,
                   params: tuple[Parameter, ...], r_sim: int, discrepancy: float = 0.0) -> np.ndarray:
    """Log-likelihood of the sheet's results at parameter points ``u`` (module docstring).

    The replicates y_1..R of a run are y = mu 1 + e_c 1 + e with e ~ N(0, sigma^2 I) (sigma the simulator's
    start-to-start SD) and e_c common to the run, variance tau^2 = sigma^2 / R_sim + sigma_emu^2 + (delta mu)^2.
    sigma itself is estimated from the R_sim simulated starts, so the density is the multivariate Student t with
    nu = R_sim - 1 degrees of freedom that this gives under the reference prior p(mu, sigma^2) ~ 1 / sigma^2
    (Gelman et al., Bayesian Data Analysis, 3rd ed. 2013, sec. 3.2: the predictive of new draws from a normal
    sample), scale matrix Sigma = sigma^2 I + tau^2 1 1^T:

        ln p = ln G((nu + R)/2) - ln G(nu/2) - R/2 ln(nu pi) - 1/2 ln|Sigma| - (nu + R)/2 ln(1 + Q / nu),
        |Sigma| = sigma^(2 (R - 1)) (sigma^2 + R tau^2),  Q = SS_w / sigma^2 + R (ybar - mu)^2 / (sigma^2 + R tau^2),

    ybar and SS_w the run's replicate mean and within sum of squares.  (A normal density with sigma taken as known
    made a sheet from the reference parameters exclude them: with R_sim = 3 an SD is known to a factor of two.)

    Parameters
    ----------
    emulator : Emulator
        The trained emulator.
    sheet_settings : numpy.ndarray
        (runs, factors) SI.
    obs : dict of str to numpy.ndarray
        Response -> (runs, replicates) field results (kg/min, %).
    u : numpy.ndarray
        (walkers, 6) parameter points on the prior's unit cube.
    params : tuple of Parameter
        The parameters (the yield's quantile function).
    r_sim : int
        Starts behind the simulated means and SDs (>= 2).
    discrepancy : float
        delta, the model discrepancy's SD as a fraction of the mean (0: off).

    Returns
    -------
    numpy.ndarray
        (walkers,) log-likelihoods (dimensionless).
    """
    nw, ns = u.shape[0], sheet_settings.shape[0]
    uu = np.repeat(u, ns, axis=0)
    xx = np.tile(sheet_settings, (nw, 1))
    yi = PARAMETER_NAMES.index("yield_per_bush")
    yb = params[yi].ppf(uu[:, yi])
    nu = r_sim - 1.0
    total = np.zeros(nw)
    for r, y in obs.items():
        mean, var_emu, sd = emulator.predict(xx, uu, r)
        if r == "efficiency":
            mean, var_emu, sd = mean * yb, var_emu * yb**2, sd * yb
        R = y.shape[1]
        ybar = np.tile(y.mean(axis=1), nw)
        ssw = np.tile(((y - y.mean(axis=1, keepdims=True)) ** 2).sum(axis=1), nw)
        s2 = np.maximum(sd, 1e-6) ** 2
        tau2 = s2 / r_sim + var_emu + (discrepancy * mean) ** 2
        big = s2 + R * tau2
        q = ssw / s2 + R * (ybar - mean) ** 2 / big
        ll = (special.gammaln((nu + R) / 2) - special.gammaln(nu / 2) - R / 2 * math.log(nu * math.pi)
              - 0.5 * ((R - 1) * np.log(s2) + np.log(big)) - (nu + R) / 2 * np.log1p(q / nu))
        total += ll.reshape(nw, ns).sum(axis=1)
    return total


def sample_posterior(emulator: Emulator, sheet: Sheet, params: tuple[Parameter, ...], r_sim: int, seed: int,
                     discrepancy: float = 0.0, steps: int | None = None, walkers: int | None = None,
                     obs: dict | None = None, settings: np.ndarray | None = None, progress=None) -> dict:
    """Posterior draws of the parameters with ``emcee`` (affine-invariant ensemble, vectorised log-probability) in the
    priors' standard-normal coordinates (prior N(0, 1) per coordinate; theta = prior quantile of Phi(z)).

    Without ``steps`` the chain runs in blocks of 500 steps until it is 50 integrated autocorrelation times long (at
    most 4000 steps); burn-in = 3 tau, thinning = tau / 2 (tau the largest over the parameters).

    Parameters
    ----------
    emulator : Emulator
        The trained emulator.
    sheet : Sheet
        The sheet (settings and results).
    params : tuple of Parameter
        The parameters.
    r_sim : int
        Starts behind the simulated means.
    seed : int
        Seed of the walkers' start and moves.
    discrepancy : float
        Model discrepancy (fraction of the mean).
    steps : int, optional
        Fixed steps per walker.
    walkers : int, optional
        Walkers (default 4 x dimension, at least 24).
    obs : dict, optional
        Results to use instead of the sheet's (a held-out run left out).
    settings : numpy.ndarray, optional
        Settings of ``obs`` (default the sheet's).
    progress : callable, optional
        ``progress(steps_done, steps_planned)``.

    Returns
    -------
    dict
        ``z`` (draws, 6) normal scores, ``u`` unit-cube points, ``theta`` (SI), ``acceptance_fraction``,
        ``autocorrelation_steps`` (per parameter), ``steps``, ``walkers``, ``burn``, ``thin``, ``converged``
        (chain >= 50 tau).
    """
    import emcee

    obs = sheet.observations if obs is None else obs
    settings = sheet.settings_si if settings is None else settings
    dim = len(params)
    nw = walkers or max(24, 4 * dim)
    rng = np.random.default_rng(seed)

    def log_prob(z):
        u = special.ndtr(z)
        u = np.clip(u, 1e-12, 1 - 1e-12)
        return -0.5 * np.sum(z**2, axis=1) + log_likelihood(emulator, settings, obs, u, params, r_sim,
                                                              discrepancy)

    sampler = emcee.EnsembleSampler(nw, dim, log_prob, vectorize=True,
                                    moves=[(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)])
    sampler.random_state = np.random.RandomState(seed).get_state()
    state = rng.standard_normal((nw, dim))
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
    z = sampler.get_chain(discard=burn, thin=thin, flat=True)
    u = np.clip(special.ndtr(z), 1e-12, 1 - 1e-12)
    return {"z": z, "u": u, "theta": theta_of(u, params),
            "acceptance_fraction": float(np.mean(sampler.acceptance_fraction)),
            "autocorrelation_steps": [float(x) for x in tau], "steps": done, "walkers": nw, "burn": burn,
            "thin": thin, "converged": bool(done >= 50 * t)}


def predictive(emulator: Emulator, settings_si: np.ndarray, u: np.ndarray, params: tuple[Parameter, ...],
               response: str, rng: np.random.Generator, replicates: int = 1, r_sim: int | None = None,
               discrepancy: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Draws of a future field result (the mean of ``replicates`` results) at settings, over posterior draws: the
    emulated mean + emulator error + the simulated mean's own error + discrepancy + replicate noise.

    Parameters
    ----------
    emulator : Emulator
        The trained emulator.
    settings_si : numpy.ndarray
        (settings, factors) SI.
    u : numpy.ndarray
        (draws, 6) posterior draws on the unit cube (prior probabilities, dimensionless).
    params : tuple of Parameter
        The parameters.
    response : str
        Response name.
    rng : numpy.random.Generator
        Noise draws.
    replicates : int
        Results averaged (1: one future field result).
    r_sim : int, optional
        Starts behind the simulated means: adds sigma^2 / R_sim to the emulator error, and sigma is drawn as known
        from R_sim starts (x sqrt(nu / chi2_nu), nu = R_sim - 1).
    discrepancy : float
        Model discrepancy (fraction of the mean).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        (settings, draws) expected result (mean) and future result draws, the response's unit; both clipped at 0
        (an efficiency or a rate is never negative).
    """
    ns, nd = settings_si.shape[0], u.shape[0]
    uu = np.tile(u, (ns, 1))
    xx = np.repeat(settings_si, nd, axis=0)
    mean, var_emu, sd = emulator.predict(xx, uu, response)
    if response == "efficiency":
        yb = params[PARAMETER_NAMES.index("yield_per_bush")].ppf(uu[:, PARAMETER_NAMES.index("yield_per_bush")])
        mean, var_emu, sd = mean * yb, var_emu * yb**2, sd * yb
    if r_sim:  # sigma known from R_sim starts: scaled by sqrt(nu / chi2_nu) per draw (the t of log_likelihood)
        sd = sd * np.sqrt((r_sim - 1) / rng.chisquare(r_sim - 1, mean.size))
    common = var_emu + (sd**2 / r_sim if r_sim else 0.0) + (discrepancy * mean) ** 2
    expected = np.maximum(mean + np.sqrt(common) * rng.standard_normal(mean.size), 0.0)
    future = np.maximum(expected + sd / math.sqrt(replicates) * rng.standard_normal(mean.size), 0.0)  # rates >= 0
    return expected.reshape(ns, nd), future.reshape(ns, nd)
