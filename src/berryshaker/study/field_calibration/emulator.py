"""The emulator: scikit-learn Gaussian processes of the simulator's mean, the model's start-to-start SD and the
counting SD of one field test of every response, per simulated setting and joint over (setting, parameters)
(:class:`Emulator`), with a batched prediction (:class:`FittedGP`).

Per response a scikit-learn ``GaussianProcessRegressor`` (ARD Matern 5/2 + white noise, normalised targets) over
(coded setting, theta on the prior's unit cube) for log(mean + c), log(model SD) and log(counting SD), trained on
a Latin hypercube of theta (scipy.stats.qmc) at the simulated settings; its error is checked on held-out theta
points and on held-out (untested) settings (:func:`berryshaker.study.field_calibration.workflow.calibrate`).

long module: one idea, the emulator: its GPs' fit, their prediction one setting at a time and stacked over the
settings (the sampler's), and their saved state.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from berryshaker.study.field_calibration.priors import (
    PARAMETER_NAMES,
    calibrated_responses,
    count_parameters,
    mean_parameters,
)
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
    kernel_theta : numpy.ndarray, optional
        Log hyperparameters of a saved fit (dimensionless): the kernel is rebuilt with them, not optimised
        (:meth:`from_state`).
    """

    def __init__(self, x: np.ndarray, y: np.ndarray, seed: int, noise: float | None = None,
                 kernel_theta: np.ndarray | None = None):
        from sklearn.gaussian_process import GaussianProcessRegressor
        from sklearn.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel

        x, y = np.asarray(x, float), np.asarray(y, float)
        k = ConstantKernel(1.0, (1e-3, 1e3)) * Matern(np.ones(x.shape[1]), (1e-2, 1e3), nu=2.5)
        ystd = float(np.std(y)) or 1.0
        if noise is None:
            k = k + WhiteKernel(1e-3, (1e-8, 1.0))
            alpha = 1e-10
        else:
            alpha = max(noise / ystd**2, 1e-10)  # normalize_y: the diagonal is in units of the targets' variance
        if kernel_theta is not None:  # a saved fit: its hyperparameters, no optimisation (the same GP, bit for bit)
            k = k.clone_with_theta(np.asarray(kernel_theta, float))
        import warnings

        from sklearn.exceptions import ConvergenceWarning

        self.x_train, self.y_train, self.seed, self.noise = x, y, seed, noise
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)  # a length scale at its bound: an irrelevant input
            self.gp = GaussianProcessRegressor(k, alpha=alpha, normalize_y=True, n_restarts_optimizer=0,
                                               optimizer=None if kernel_theta is not None else _bounded_lbfgs,
                                               random_state=seed).fit(x, y)
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

    def state(self) -> dict:
        """What rebuilds this GP without refitting (:meth:`from_state`): its training data and fitted hyperparameters.

        Returns
        -------
        dict
            ``x``, ``y``, ``kernel_theta`` (arrays), ``seed``, ``noise`` (None or the fixed target variance).
        """
        return {"x": self.x_train, "y": self.y_train, "kernel_theta": np.asarray(self.gp.kernel_.theta, float),
                "seed": int(self.seed), "noise": self.noise}

    @classmethod
    def from_state(cls, state: dict) -> "FittedGP":
        """The GP of a :meth:`state`.

        Parameters
        ----------
        state : dict
            As :meth:`state` gives it.

        Returns
        -------
        FittedGP
            The same fit (its hyperparameters fixed).
        """
        return cls(state["x"], state["y"], int(state["seed"]), state["noise"], kernel_theta=state["kernel_theta"])

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


class GPStack:
    """The :class:`FittedGP` of one target at every simulated setting, predicted at the same inputs in one batched
    evaluation: the sampler asks every setting's GPs at the same walkers, and one (settings x rows x training points)
    evaluation replaces a call per setting (the same formulas as :meth:`FittedGP.predict`, equal to round-off;
    the test checks it).

    Parameters
    ----------
    gps : list of FittedGP
        One per setting, with the same number of training points and inputs (their hyperparameters differ).
    """

    def __init__(self, gps: list[FittedGP]):
        self.length = np.stack([g.length for g in gps])  # (S, d)
        self.amplitude = np.array([g.amplitude for g in gps])
        self.x_scaled = np.stack([g.x_scaled for g in gps])  # (S, n, d)
        self.x_norm2 = np.sum(self.x_scaled**2, axis=2)  # (S, n)
        self.alpha = np.stack([np.ravel(g.gp.alpha_) for g in gps])  # (S, n)
        self.l_inv = np.stack([g.l_inv for g in gps])  # (S, n, n)
        self.scale = np.array([g.scale for g in gps])
        self.offset = np.array([g.offset for g in gps])

    def predict(self, x: np.ndarray, with_var: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Every setting's mean and latent variance at ``x``.

        Parameters
        ----------
        x : numpy.ndarray
            (m, d) inputs, the same at every setting (dimensionless).
        with_var : bool
            Compute the variance (else zeros).

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)
            (settings, m) means (the targets' units) and variances (their units squared).
        """
        xs = np.asarray(x, float)[None, :, :] / self.length[:, None, :]  # (S, m, d)
        d2 = (np.sum(xs**2, axis=2)[:, :, None] + self.x_norm2[:, None, :]
              - 2.0 * xs @ self.x_scaled.transpose(0, 2, 1))
        r = math.sqrt(5.0) * np.sqrt(np.maximum(d2, 0.0))
        ks = self.amplitude[:, None, None] * (1.0 + r + r * r / 3.0) * np.exp(-r)  # (S, m, n) Matern 5/2
        mean = (ks @ self.alpha[:, :, None])[:, :, 0] * self.scale[:, None] + self.offset[:, None]
        if not with_var:
            return mean, np.zeros_like(mean)
        v = self.l_inv @ ks.transpose(0, 2, 1)  # (S, n, m)
        var = np.maximum(self.amplitude[:, None] - np.einsum("snm,snm->sm", v, v), 0.0) * self.scale[:, None] ** 2
        return mean, var


@dataclass
class _ResponseGP:
    """The three Gaussian processes of one response (log(mean + c), log model SD, log counting SD) on one input
    layout."""

    mean_gp: FittedGP
    logsd_gp: FittedGP
    logcsd_gp: FittedGP
    columns: list[int]  # theta columns of the mean and model-SD GPs (indexes into PARAMETER_NAMES)
    count_columns: list[int]  # theta columns of the counting-SD GP
    floor: float
    mse_log_mean: float = 0.0  # held-out MSE of log(mean + c)


class Emulator:
    """Gaussian-process emulator of the mean, the log model SD and the log counting SD of every response (the
    efficiency's mean and model SD per kg of yield: the yield scales them exactly; its counting SD is not
    proportional to the yield and is emulated with the yield as an input).

    Two layouts, both scikit-learn ``GaussianProcessRegressor`` with an ARD Matern 5/2 kernel on log(mean + c)
    (learned white noise), on log model SD (noise fixed at the sampling variance of a log SD over R starts,
    1 / (2 (R - 1))) and on log counting SD (learned white noise):

    * **per setting** over theta on the prior's unit cube (the parameters the response depends on,
      :func:`~berryshaker.study.field_calibration.priors.mean_parameters` and
      :func:`~berryshaker.study.field_calibration.priors.count_parameters`): the likelihood at the sheet's settings
      and the predictions there;
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
        Response names (the calibrated harvest responses).
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

    def state(self) -> dict:
        """Everything :meth:`from_state` needs to rebuild the trained emulator without refitting: nested dicts of
        arrays and numbers (berryshaker.study.field_calibration.saved writes them).

        Returns
        -------
        dict
            The coding bounds, responses, settings, every GP's :meth:`FittedGP.state` and held-out error.
        """
        def rgp(g: _ResponseGP) -> dict:
            return {"mean": g.mean_gp.state(), "sd": g.logsd_gp.state(), "csd": g.logcsd_gp.state(),
                    "columns": np.asarray(g.columns), "count_columns": np.asarray(g.count_columns),
                    "floor": g.floor, "mse_log_mean": g.mse_log_mean}

        return {"lo": self.lo, "hi": self.hi, "responses": list(self.responses), "seed": self.seed,
                "r_sim": self.r_sim, "joint_points": self.joint_points,
                "settings": np.asarray(self.settings, float).reshape(len(self.settings), -1),
                "local": [{r: rgp(g) for r, g in gps.items()} for gps in self.local],
                "joint": None if self.joint is None else {r: rgp(g) for r, g in self.joint.items()}}

    @classmethod
    def from_state(cls, state: dict) -> "Emulator":
        """The emulator of a :meth:`state`.

        Parameters
        ----------
        state : dict
            As :meth:`state` gives it.

        Returns
        -------
        Emulator
            The same emulator (its GPs rebuilt with their fitted hyperparameters).
        """
        def rgp(d: dict) -> _ResponseGP:
            return _ResponseGP(FittedGP.from_state(d["mean"]), FittedGP.from_state(d["sd"]),
                               FittedGP.from_state(d["csd"]), [int(c) for c in d["columns"]],
                               [int(c) for c in d["count_columns"]], float(d["floor"]), float(d["mse_log_mean"]))

        em = cls.__new__(cls)
        em.lo, em.hi = np.asarray(state["lo"], float), np.asarray(state["hi"], float)
        em.responses = list(state["responses"])
        em.seed, em.r_sim, em.joint_points = int(state["seed"]), int(state["r_sim"]), int(state["joint_points"])
        em.settings = [tuple(float(v) for v in row) for row in np.asarray(state["settings"], float)]
        em._lookup, em._stacks = {}, {}
        em.local = [{r: rgp(d) for r, d in gps.items()} for gps in state["local"]]
        em.joint = None if state["joint"] is None else {r: rgp(d) for r, d in state["joint"].items()}
        em._data = None
        em.fit_seconds, em.training_points = 0.0, 0
        return em

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

    def _pair(self, x, xc, mean, sd, csd, r, base: tuple | None = None) -> _ResponseGP:
        """GPs of log(mean + c), log model SD (inputs ``x``) and log counting SD (inputs ``xc``); with ``base`` =
        (log-mean, log-SD, log counting SD) per point, of the differences from it (the joint GP's setting effect)."""
        floor = calibrated_responses()[r].floor
        cols = [PARAMETER_NAMES.index(p) for p in mean_parameters(r)]
        ccols = [PARAMETER_NAMES.index(p) for p in count_parameters(r)]
        b_mean, b_sd, b_csd = base if base is not None else (0.0, 0.0, 0.0)
        g_mean = FittedGP(x, np.log(mean + floor) - b_mean, self.seed)
        g_sd = FittedGP(x, np.log(np.maximum(sd, 1e-3 * floor)) - b_sd, self.seed,
                        noise=1.0 / (2 * (self.r_sim - 1)))
        g_csd = FittedGP(xc, np.log(np.maximum(csd, 1e-3 * floor)) - b_csd, self.seed)
        return _ResponseGP(g_mean, g_sd, g_csd, cols, ccols, floor)

    def _local_average(self, u: np.ndarray, r: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Average over the simulated settings of the per-setting GPs' log(mean + c), log model SD and log counting
        SD at ``u``: the baseline of the joint GP, which models only the setting's effect on top of it.  Evaluated
        once per distinct row of ``u`` (a prediction over settings repeats every draw once per setting), every
        setting's GPs in one batch (:class:`GPStack`)."""
        cols = [PARAMETER_NAMES.index(p) for p in mean_parameters(r)]
        ccols = [PARAMETER_NAMES.index(p) for p in count_parameters(r)]
        rows, back = np.unique(u, axis=0, return_inverse=True)
        back = back.ravel()
        st_mean, st_sd, st_csd = self._stack(r)
        lm = np.mean(st_mean.predict(rows[:, cols], False)[0], axis=0)
        ls = np.mean(st_sd.predict(rows[:, cols], False)[0], axis=0)
        lc = np.mean(st_csd.predict(rows[:, ccols], False)[0], axis=0)
        return lm[back], ls[back], lc[back]

    def fit(self, settings_si: list, u: np.ndarray, mean: np.ndarray, sd: np.ndarray, csd: np.ndarray) -> None:
        """Train the per-setting GPs of every response.

        Parameters
        ----------
        settings_si : list of tuple of float
            The simulated settings (SI).
        u : numpy.ndarray
            (n, 6) theta on the prior's unit cube (the same points at every setting).
        mean, sd, csd : numpy.ndarray
            (settings, n, responses) mean of the expectation over the starts, the model's start-to-start SD and the
            counting SD of one field test, the responses' units (%; the efficiency's mean and model SD in kg/min per
            kg of yield, its counting SD in kg/min).
        """
        t0 = time.perf_counter()
        self.settings = [tuple(float(v) for v in s) for s in settings_si]
        self._lookup: dict = {}
        self._stacks: dict = {}
        self.local = []
        for i in range(len(self.settings)):
            gps = {}
            for j, r in enumerate(self.responses):
                cols = [PARAMETER_NAMES.index(p) for p in mean_parameters(r)]
                ccols = [PARAMETER_NAMES.index(p) for p in count_parameters(r)]
                gps[r] = self._pair(u[:, cols], u[:, ccols], mean[i, :, j], sd[i, :, j], csd[i, :, j], r)
            self.local.append(gps)
        self._data = (np.array(self.settings, float), u, mean, sd, csd)
        self.joint = None
        self.training_points = int(len(self.settings) * len(u))
        self.fit_seconds = time.perf_counter() - t0

    def fit_joint(self, focus: tuple | None = None) -> None:
        """Train the joint GPs (coded setting, theta) on a seeded subsample of the simulated Latin-hypercube points and,
        with ``focus``, on simulated points at posterior draws (where the predictions are made).

        Parameters
        ----------
        focus : (numpy.ndarray, numpy.ndarray, numpy.ndarray, numpy.ndarray), optional
            ``(u, mean, sd, csd)``: (k, 6) unit-cube points (dimensionless) and their simulated means, model SDs and
            counting SDs at every simulated setting, (settings, k, responses) as :meth:`fit` takes them; they take
            half of :attr:`joint_points`.
        """
        t0 = time.perf_counter()
        s_all, u, mean, sd, csd = self._data
        ns, nu = len(s_all), len(u)
        budget = min(self.joint_points // max(ns, 1), nu)  # per setting: no more than its hypercube
        nf = 0 if focus is None else min(len(focus[0]), budget // 2)
        per = max(4, min(nu, budget - nf))
        rng = np.random.default_rng(self.seed)
        self.joint = {}
        for j, r in enumerate(self.responses):
            cols = [PARAMETER_NAMES.index(p) for p in mean_parameters(r)]
            ccols = [PARAMETER_NAMES.index(p) for p in count_parameters(r)]
            xs, xcs, uus, ms, ss, cs = [], [], [], [], [], []
            for i in range(ns):
                pick = rng.choice(nu, size=per, replace=False)
                code = self.code(s_all[i:i + 1])
                parts = [(u[pick], mean[i, pick, j], sd[i, pick, j], csd[i, pick, j])]
                if nf:
                    parts.append((focus[0][:nf], focus[1][i, :nf, j], focus[2][i, :nf, j], focus[3][i, :nf, j]))
                for uu, mm, s_, c_ in parts:
                    xs.append(np.hstack([np.repeat(code, len(uu), axis=0), uu[:, cols]]))
                    xcs.append(np.hstack([np.repeat(code, len(uu), axis=0), uu[:, ccols]]))
                    uus.append(uu)
                    ms.append(mm)
                    ss.append(s_)
                    cs.append(c_)
            base = self._local_average(np.vstack(uus), r)
            self.joint[r] = self._pair(np.vstack(xs), np.vstack(xcs), np.concatenate(ms), np.concatenate(ss),
                                       np.concatenate(cs), r, base)
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
        (numpy.ndarray, numpy.ndarray, numpy.ndarray, numpy.ndarray)
            Mean (the response's unit; efficiency per kg of yield), the emulator's variance of it (delta method on
            the log scale: (mean + c)^2 max(GP variance, held-out MSE), the joint GP's MSE :meth:`joint_mse`; unit
            squared), the model's start-to-start SD (efficiency per kg of yield) and the counting SD of one field
            test (the response's unit).
        """
        settings_si = np.atleast_2d(settings_si)
        u = np.atleast_2d(u)
        n = len(u)
        lm, var_log, lsd, lcsd = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
        uniq, inverse = np.unique(settings_si, axis=0, return_inverse=True)
        groups: dict = {}
        for j, x in enumerate(uniq):
            key = None if joint else self._index(x)
            groups.setdefault(key, []).extend(np.flatnonzero(inverse.ravel() == j).tolist())
        floor = calibrated_responses()[response].floor
        for key, rows in groups.items():
            rows = np.array(rows)
            if key is None:
                if self.joint is None:
                    self.fit_joint()
                g = self.joint[response]
                code = self.code(settings_si[rows])
                x = np.hstack([code, u[rows][:, g.columns]])
                xc = np.hstack([code, u[rows][:, g.count_columns]])
                b_mean, b_sd, b_csd = self._local_average(u[rows], response)
                mse = self.joint_mse(response)
            else:
                g = self.local[key][response]
                x, xc = u[rows][:, g.columns], u[rows][:, g.count_columns]
                b_mean, b_sd, b_csd = 0.0, 0.0, 0.0
                mse = g.mse_log_mean
            m, v = g.mean_gp.predict(x, with_var)
            lm[rows] = b_mean + m
            var_log[rows] = np.maximum(v, mse)
            lsd[rows] = b_sd + g.logsd_gp.predict(x, False)[0]
            lcsd[rows] = b_csd + g.logcsd_gp.predict(xc, False)[0]
        mean = np.maximum(np.exp(lm) - floor, 0.0)
        return mean, (mean + floor) ** 2 * var_log, np.exp(lsd), np.exp(lcsd)

    def _stack(self, response: str) -> tuple[GPStack, GPStack, GPStack]:
        """The per-setting GPs of ``response`` (log mean, log model SD, log counting SD) stacked, built once."""
        if response not in self._stacks:
            gps = [g[response] for g in self.local]
            self._stacks[response] = (GPStack([g.mean_gp for g in gps]), GPStack([g.logsd_gp for g in gps]),
                                      GPStack([g.logcsd_gp for g in gps]))
        return self._stacks[response]

    def predict_grid(self, settings_si: np.ndarray, u: np.ndarray, response: str, with_var: bool = True):
        """:meth:`predict` at every (row of ``u``, setting) pair: the simulated settings' GPs in one batched
        evaluation (:class:`GPStack`), the others through the joint GP.

        Parameters
        ----------
        settings_si : numpy.ndarray
            (k, factors) SI.
        u : numpy.ndarray
            (n, 6) theta on the prior's unit cube.
        response : str
            Response name.
        with_var : bool
            Compute the emulator's variance (else only its held-out MSE).

        Returns
        -------
        (numpy.ndarray, numpy.ndarray, numpy.ndarray, numpy.ndarray)
            As :meth:`predict` (mean, the response's unit; its variance, unit squared; model SD and counting SD,
            the response's unit; the efficiency's mean and model SD per kg of yield, its variance per kg of yield
            squared), each shaped (n, k).
        """
        settings_si, u = np.atleast_2d(np.asarray(settings_si, float)), np.atleast_2d(np.asarray(u, float))
        n, k = len(u), len(settings_si)
        out = [np.empty((n, k)) for _ in range(4)]
        index = [self._index(s) for s in settings_si]
        sim = [j for j, i in enumerate(index) if i is not None]
        if sim:
            at = np.array([index[j] for j in sim])
            st_mean, st_sd, st_csd = self._stack(response)
            g = self.local[0][response]
            m, v = st_mean.predict(u[:, g.columns], with_var)
            mse = np.array([gps[response].mse_log_mean for gps in self.local])
            floor = calibrated_responses()[response].floor
            mean = np.maximum(np.exp(m[at]) - floor, 0.0)
            out[0][:, sim] = mean.T
            out[1][:, sim] = ((mean + floor) ** 2 * np.maximum(v[at], mse[at, None])).T
            out[2][:, sim] = np.exp(st_sd.predict(u[:, g.columns], False)[0][at]).T
            out[3][:, sim] = np.exp(st_csd.predict(u[:, g.count_columns], False)[0][at]).T
        rest = [j for j, i in enumerate(index) if i is None]
        if rest:
            xx = np.tile(settings_si[rest], (n, 1))
            for a, b in zip(out, self.predict(xx, np.repeat(u, len(rest), axis=0), response, with_var)):
                a[:, rest] = b.reshape(n, len(rest))
        return tuple(out)
