"""The emulator: scikit-learn Gaussian processes of the simulator's replicate mean and SD of every response, per
simulated setting and joint over (setting, parameters) (:class:`Emulator`), with a batched prediction
(:class:`FittedGP`).

Per response a scikit-learn ``GaussianProcessRegressor`` (ARD Matern 5/2 + white noise, normalised targets) over
(coded setting, theta on the prior's unit cube) for log(mean + c) and log(SD) of the replicate results, trained on
a Latin hypercube of theta (scipy.stats.qmc) at the simulated settings; its error is checked on held-out theta
points and on held-out (untested) settings (:func:`berryshaker.study.field_calibration.workflow.calibrate`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from berryshaker.study.field_calibration.priors import PARAMETER_NAMES, RESPONSE_PARAMETERS, RESPONSES
from berryshaker.study.field_calibration.sheet import FactorTarget


#: most L-BFGS-B iterations of a GP's marginal-likelihood fit: scikit-learn's default (15000) let one fit of the
#: joint GP on clustered posterior points take over a minute on the reference L9; its hyperparameters converge in far
#: fewer iterations on the hypercube
GP_FIT_ITERATIONS = 200


def _bounded_lbfgs(obj_func, initial_theta, bounds):
    """scikit-learn's GP optimiser (L-BFGS-B on the log marginal likelihood) with at most :data:`GP_FIT_ITERATIONS`
    iterations: returns (theta_opt, func_min)."""
    from scipy.optimize import minimize

    res = minimize(obj_func, initial_theta, method="L-BFGS-B", jac=True, bounds=bounds,
                   options={"maxiter": GP_FIT_ITERATIONS})
    return res.x, res.fun


class FittedGP:
    """A fitted scikit-learn ``GaussianProcessRegressor`` with a batched predictive variance.

    ``GaussianProcessRegressor.predict(return_std=True)`` costs ~10 ms per call whatever the size; the sampler calls
    it thousands of times, so the prediction is computed here from the fitted kernel's hyperparameters, ``alpha_``
    and the Cholesky factor ``L_``, the same formulas (Rasmussen & Williams 2006, alg. 2.1): mean = k(x, X) alpha,
    var = k(x, x) - |L^-1 k(X, x)|^2 with the white-noise term left out (it is the training targets' noise, not the
    emulator's); k the Matern 5/2 kernel c (1 + sqrt5 r + 5 r^2 / 3) exp(-sqrt5 r), r the ARD-scaled distance.
    The test checks it against ``predict``.

    Parameters
    ----------
    x : numpy.ndarray
        (n, d) training inputs (dimensionless: coded settings, prior probabilities).
    y : numpy.ndarray
        (n,) training targets (their units: logs of responses, dimensionless).
    seed : int
        Seed of the optimiser.
    noise : float, optional
        Known variance of the targets (their units squared) added to the kernel's diagonal; default: learned by a
        WhiteKernel.
    """

    def __init__(self, x: np.ndarray, y: np.ndarray, seed: int, noise: float | None = None):
        from sklearn.gaussian_process import GaussianProcessRegressor
        from sklearn.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel

        k = ConstantKernel(1.0, (1e-3, 1e3)) * Matern(np.ones(x.shape[1]), (1e-2, 1e3), nu=2.5)
        ystd = float(np.std(y)) or 1.0
        if noise is None:
            k = k + WhiteKernel(1e-3, (1e-8, 1.0))
            alpha = 1e-10
        else:
            alpha = max(noise / ystd**2, 1e-10)  # normalize_y: the diagonal is in units of the targets' variance
        import warnings

        from sklearn.exceptions import ConvergenceWarning

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)  # a length scale at its bound: an irrelevant input
            self.gp = GaussianProcessRegressor(k, alpha=alpha, normalize_y=True, n_restarts_optimizer=0,
                                               optimizer=_bounded_lbfgs, random_state=seed).fit(x, y)
        kern = self.gp.kernel_
        latent = kern.k1 if noise is None else kern  # ConstantKernel x Matern
        self.amplitude = float(latent.k1.constant_value)
        self.length = np.asarray(latent.k2.length_scale, float)
        self.x_scaled = self.gp.X_train_ / self.length
        from scipy.linalg import solve_triangular

        # L^-1 once: a triangular solve per call costs milliseconds of threading overhead on small systems
        self.l_inv = solve_triangular(self.gp.L_, np.eye(len(x)), lower=True)
        self.scale = float(np.atleast_1d(self.gp._y_train_std)[0])
        self.offset = float(np.atleast_1d(self.gp._y_train_mean)[0])

    def predict(self, x: np.ndarray, with_var: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Mean and latent variance at ``x``.

        Parameters
        ----------
        x : numpy.ndarray
            (m, d) inputs.
        with_var : bool
            Compute the variance (else zeros).

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)
            Mean (their units: the targets') and variance (their units squared).
        """
        xs = np.asarray(x, float) / self.length
        d2 = (np.sum(xs**2, axis=1)[:, None] + np.sum(self.x_scaled**2, axis=1)[None, :] - 2.0 * xs @ self.x_scaled.T)
        r = math.sqrt(5.0) * np.sqrt(np.maximum(d2, 0.0))
        ks = self.amplitude * (1.0 + r + r * r / 3.0) * np.exp(-r)  # Matern 5/2 (sklearn's Matern, nu = 2.5)
        mean = ks @ self.gp.alpha_ * self.scale + self.offset
        if not with_var:
            return mean.ravel(), np.zeros(len(x))
        v = self.l_inv @ ks.T
        var = np.maximum(self.amplitude - np.einsum("ij,ij->j", v, v), 0.0) * self.scale**2
        return mean.ravel(), var


@dataclass
class _ResponseGP:
    """The two Gaussian processes of one response (log(mean + c) and log SD) on one input layout."""

    mean_gp: FittedGP
    logsd_gp: FittedGP
    columns: list[int]  # theta columns used (indexes into PARAMETER_NAMES)
    floor: float
    mse_log_mean: float = 0.0  # held-out MSE of log(mean + c)


class Emulator:
    """Gaussian-process emulator of the replicate mean and log SD of every response (efficiency per kg of yield: the
    yield scales it exactly).

    Two layouts, both scikit-learn ``GaussianProcessRegressor`` with an ARD Matern 5/2 kernel on log(mean + c)
    (learned white noise) and on log SD (noise fixed at the sampling variance of a log SD over R starts,
    1 / (2 (R - 1))):

    * **per setting** over theta on the prior's unit cube (the parameters the response depends on,
      :data:`RESPONSE_PARAMETERS`): the likelihood at the sheet's settings and the predictions there;
    * **joint** over (setting coded to -1 .. 1 over the sheet's level ranges, theta), of the setting's effect: the
      difference of log(mean + c) and log SD from the average of the per-setting GPs at the same theta, trained on up
      to :attr:`joint_points` of the simulated points (half of them, with :meth:`fit_joint`'s ``focus``, simulated at
      posterior draws): predictions at settings that were not simulated (far from every simulated setting it falls
      back to that average, not to the prior's mean); its error term is the larger of its own held-out error at
      untested settings and the per-setting GPs' (:meth:`joint_mse`).

    Parameters
    ----------
    targets : list of FactorTarget
        The sheet's factors.
    responses : list of str
        Response names (:data:`RESPONSES`).
    seed : int
        Seed of the optimisers and of the joint GP's subsample.
    r_sim : int
        Starts behind every simulated mean and SD.
    joint_points : int
        Most training points of the joint GP (its cost grows as their cube).
    """

    def __init__(self, targets: list[FactorTarget], responses: list[str], seed: int, r_sim: int,
                 joint_points: int = 160):
        self.lo = np.array([min(t.levels_si) for t in targets])
        self.hi = np.array([max(t.levels_si) for t in targets])
        self.responses = list(responses)
        self.seed = seed
        self.r_sim = r_sim
        self.joint_points = joint_points
        self.settings: list[tuple[float, ...]] = []
        self.local: list[dict[str, _ResponseGP]] = []
        self.joint: dict[str, _ResponseGP] | None = None
        self._data = None
        self.fit_seconds = 0.0
        self.training_points = 0

    def code(self, settings_si) -> np.ndarray:
        """Settings (SI, rows) coded to -1 .. 1 over the sheet's level ranges.

        Parameters
        ----------
        settings_si : array_like
            (n, factors) SI values.

        Returns
        -------
        numpy.ndarray
            Coded settings (dimensionless).
        """
        x = np.atleast_2d(np.asarray(settings_si, float))
        span = np.where(self.hi > self.lo, self.hi - self.lo, 1.0)
        return 2.0 * (x - self.lo) / span - 1.0

    def _pair(self, x, mean, sd, r, base: tuple | None = None) -> _ResponseGP:
        """GPs of log(mean + c) and log SD at inputs ``x``; with ``base`` = (log-mean, log-SD) per point, of the
        differences from it (the joint GP's setting effect)."""
        floor = RESPONSES[r][1]
        cols = [PARAMETER_NAMES.index(p) for p in RESPONSE_PARAMETERS[r]]
        b_mean, b_sd = base if base is not None else (0.0, 0.0)
        g_mean = FittedGP(x, np.log(mean + floor) - b_mean, self.seed)
        g_sd = FittedGP(x, np.log(np.maximum(sd, 1e-3 * floor)) - b_sd, self.seed,
                        noise=1.0 / (2 * (self.r_sim - 1)))
        return _ResponseGP(g_mean, g_sd, cols, floor)

    def _local_average(self, u: np.ndarray, r: str) -> tuple[np.ndarray, np.ndarray]:
        """Average over the simulated settings of the per-setting GPs' log(mean + c) and log SD at ``u``: the
        baseline of the joint GP, which models only the setting's effect on top of it."""
        cols = [PARAMETER_NAMES.index(p) for p in RESPONSE_PARAMETERS[r]]
        lm = np.mean([g[r].mean_gp.predict(u[:, cols], False)[0] for g in self.local], axis=0)
        ls = np.mean([g[r].logsd_gp.predict(u[:, cols], False)[0] for g in self.local], axis=0)
        return lm, ls

    def fit(self, settings_si: list, u: np.ndarray, mean: np.ndarray, sd: np.ndarray) -> None:
        """Train the per-setting GPs of every response.

        Parameters
        ----------
        settings_si : list of tuple of float
            The simulated settings (SI).
        u : numpy.ndarray
            (n, 6) theta on the prior's unit cube (the same points at every setting).
        mean, sd : numpy.ndarray
            (settings, n, responses) replicate mean and SD over the starts, the responses' units (%; efficiency in
            kg/min per kg of yield).
        """
        t0 = time.perf_counter()
        self.settings = [tuple(float(v) for v in s) for s in settings_si]
        self._lookup: dict = {}
        self.local = []
        for i in range(len(self.settings)):
            gps = {}
            for j, r in enumerate(self.responses):
                cols = [PARAMETER_NAMES.index(p) for p in RESPONSE_PARAMETERS[r]]
                gps[r] = self._pair(u[:, cols], mean[i, :, j], sd[i, :, j], r)
            self.local.append(gps)
        self._data = (np.array(self.settings, float), u, mean, sd)
        self.joint = None
        self.training_points = int(len(self.settings) * len(u))
        self.fit_seconds = time.perf_counter() - t0

    def fit_joint(self, focus: tuple | None = None) -> None:
        """Train the joint GPs (coded setting, theta) on a seeded subsample of the simulated Latin-hypercube points and,
        with ``focus``, on simulated points at posterior draws (where the predictions are made).

        Parameters
        ----------
        focus : (numpy.ndarray, numpy.ndarray, numpy.ndarray), optional
            ``(u, mean, sd)``: (k, 6) unit-cube points (dimensionless) and their simulated replicate means and SDs
            at every simulated setting, (settings, k, responses) in the responses' units (efficiency per kg of
            yield); they take half of :attr:`joint_points`.
        """
        t0 = time.perf_counter()
        s_all, u, mean, sd = self._data
        ns, nu = len(s_all), len(u)
        budget = min(self.joint_points // max(ns, 1), nu)  # per setting: no more than its hypercube
        nf = 0 if focus is None else min(len(focus[0]), budget // 2)
        per = max(4, min(nu, budget - nf))
        rng = np.random.default_rng(self.seed)
        self.joint = {}
        for j, r in enumerate(self.responses):
            cols = [PARAMETER_NAMES.index(p) for p in RESPONSE_PARAMETERS[r]]
            xs, uus, ms, ss = [], [], [], []
            for i in range(ns):
                pick = rng.choice(nu, size=per, replace=False)
                code = self.code(s_all[i:i + 1])
                xs.append(np.hstack([np.repeat(code, per, axis=0), u[pick][:, cols]]))
                uus.append(u[pick])
                ms.append(mean[i, pick, j])
                ss.append(sd[i, pick, j])
                if nf:
                    xs.append(np.hstack([np.repeat(code, nf, axis=0), focus[0][:nf][:, cols]]))
                    uus.append(focus[0][:nf])
                    ms.append(focus[1][i, :nf, j])
                    ss.append(focus[2][i, :nf, j])
            base = self._local_average(np.vstack(uus), r)
            self.joint[r] = self._pair(np.vstack(xs), np.concatenate(ms), np.concatenate(ss), r, base)
        self.fit_seconds += time.perf_counter() - t0

    def joint_mse(self, response: str) -> float:
        """The joint GP's error term: the larger of its held-out MSE of log(mean + c) at the untested check settings
        (0 when none were simulated) and the per-setting GPs' (the largest over the simulated settings).

        The joint GP predicts the average of the per-setting GPs plus the setting's effect, so it carries their error
        (the baseline's) on top of its own: a setting that was not simulated is never predicted more tightly than
        a simulated one, and without check settings the error is not the GP's variance alone (which under-covers).

        Parameters
        ----------
        response : str
            Response name.

        Returns
        -------
        float
            MSE of log(mean + c) (dimensionless).
        """
        own = self.joint[response].mse_log_mean if self.joint else 0.0
        return max([own] + [g[response].mse_log_mean for g in self.local])

    def _index(self, setting) -> int | None:
        key = tuple(float(v) for v in setting)
        if key in self._lookup:
            return self._lookup[key]
        hit = next((i for i, s in enumerate(self.settings) if np.allclose(s, key, rtol=1e-12, atol=0)), None)
        self._lookup[key] = hit
        return hit

    def predict(self, settings_si: np.ndarray, u: np.ndarray, response: str, with_var: bool = True,
                joint: bool = False):
        """Emulated replicate mean, its emulator variance and the replicate SD of one response.

        Rows at a simulated setting use its per-setting GP (unless ``joint``), the others the joint GP.

        Parameters
        ----------
        settings_si : numpy.ndarray
            (n, factors) SI.
        u : numpy.ndarray
            (n, 6) theta on the prior's unit cube.
        response : str
            Response name.
        with_var : bool
            Compute the emulator's variance (else only its held-out MSE).
        joint : bool
            Use the joint GP everywhere (its held-out check at simulated settings).

        Returns
        -------
        (numpy.ndarray, numpy.ndarray, numpy.ndarray)
            Mean (the response's unit; efficiency per kg of yield), the emulator's variance of it (delta method on
            the log scale: (mean + c)^2 max(GP variance, held-out MSE), the joint GP's MSE :meth:`joint_mse`; unit
            squared) and the replicate SD.
        """
        settings_si = np.atleast_2d(settings_si)
        u = np.atleast_2d(u)
        n = len(u)
        lm, var_log, lsd = np.empty(n), np.empty(n), np.empty(n)
        uniq, inverse = np.unique(settings_si, axis=0, return_inverse=True)
        groups: dict = {}
        for j, x in enumerate(uniq):
            key = None if joint else self._index(x)
            groups.setdefault(key, []).extend(np.flatnonzero(inverse.ravel() == j).tolist())
        floor = RESPONSES[response][1]
        for key, rows in groups.items():
            rows = np.array(rows)
            if key is None:
                if self.joint is None:
                    self.fit_joint()
                g = self.joint[response]
                x = np.hstack([self.code(settings_si[rows]), u[rows][:, g.columns]])
                b_mean, b_sd = self._local_average(u[rows], response)
                mse = self.joint_mse(response)
            else:
                g = self.local[key][response]
                x = u[rows][:, g.columns]
                b_mean, b_sd = 0.0, 0.0
                mse = g.mse_log_mean
            m, v = g.mean_gp.predict(x, with_var)
            lm[rows] = b_mean + m
            var_log[rows] = np.maximum(v, mse)
            lsd[rows] = b_sd + g.logsd_gp.predict(x, False)[0]
        mean = np.maximum(np.exp(lm) - floor, 0.0)
        return mean, (mean + floor) ** 2 * var_log, np.exp(lsd)
