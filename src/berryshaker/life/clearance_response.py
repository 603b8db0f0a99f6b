"""The clearance response surrogate of the tolerance design (:mod:`berryshaker.life.tolerance`): per joint, its
peak collision force and Archard growth rate against its own clearance, from a small grid of multibody runs.

A one-at-a-time grid (``n_points`` clearances per joint, the other joints at the description's sizes) of multibody
runs through the cached sweep runner gives, per joint, its peak collision force and growth rate against its own
clearance; the design works on their linear interpolants.  Each grid point is the mean over ``starts`` perturbed
starts (default ``harvest.replicates``; the same starts at every point): one run's peak of a chaotic impact
sequence varies by 10-30 % from start to start, so a single run would rank fits on noise.  The standard error and
the 95th percentile of the peak over the starts are kept beside the mean, and a force that falls with growing
clearance beyond that noise is found by a paired t test over the starts (:meth:`ClearanceResponse.force_falls`).
Interactions between joints are therefore ignored, and the force at clearances below :data:`GRID_FLOOR` (m) is
taken as the force at the floor (the engine's step control makes runs below about 0.02 mm expensive: one at
0.012 mm took about a minute).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from berryshaker.errors import ConfigError

#: Smallest clearance of the surrogate grid (m); below it the force and growth rate are held constant.
GRID_FLOOR = 0.025e-3
#: Hours reported when a joint does not wear (zero growth rate).
LIFE_CAP_H = 1e7


@dataclass
class ClearanceResponse:
    """One joint's peak collision force and wear growth rate against its own clearance (a surrogate).

    Attributes
    ----------
    joint : str
        Pair name.
    clearance : numpy.ndarray
        Grid clearances (m, increasing).
    peak_force : numpy.ndarray
        Peak collision force of the joint (N) at each: the mean over the starts of each run's peak.
    growth_rate : numpy.ndarray
        Archard growth rate of its clearance (m per operating hour) at each (mean over the starts).
    peak_force_se : numpy.ndarray, optional
        Standard error of ``peak_force`` (N; s / sqrt(starts); zeros for one start).
    peak_force_p95 : numpy.ndarray, optional
        95th percentile over the starts of the per-start peaks (N).
    starts : int
        Perturbed starts per grid point (1: the centred start alone).
    peak_force_starts : numpy.ndarray, optional
        The per-start peaks (N), grid points x starts (the same starts at every point).
    """

    joint: str
    clearance: np.ndarray
    peak_force: np.ndarray
    growth_rate: np.ndarray
    peak_force_se: np.ndarray | None = None
    peak_force_p95: np.ndarray | None = None
    starts: int = 1
    peak_force_starts: np.ndarray | None = None

    def force(self, c):
        """Peak force (N) at clearance c (m): linear interpolation, constant beyond the grid.

        Parameters
        ----------
        c : float or array_like
            Clearance size (m).

        Returns
        -------
        float or numpy.ndarray
            Mean peak collision force (N).
        """
        return np.interp(c, self.clearance, self.peak_force)

    def rate(self, c):
        """Growth rate (m/h) at clearance c (m): linear interpolation, constant beyond the grid.

        Parameters
        ----------
        c : float or array_like
            Clearance size (m).

        Returns
        -------
        float or numpy.ndarray
            Clearance growth rate (m/h, per operating hour).
        """
        return np.interp(c, self.clearance, self.growth_rate)

    def hours_to(self, c0: float, c_limit: float, n: int = 400) -> float:
        """Operating hours for the clearance to grow from c0 to c_limit: int_{c0}^{c_limit} dc / r(c) (trapezoid
        rule on ``n`` points); 0 if c0 >= c_limit, :data:`LIFE_CAP_H` if the rate vanishes.

        Parameters
        ----------
        c0 : float
            Starting clearance (m).
        c_limit : float
            Clearance limit (m).
        n : int
            Points of the trapezoid rule.

        Returns
        -------
        float
            Operating hours (h), at most :data:`LIFE_CAP_H`.
        """
        if c0 >= c_limit:
            return 0.0
        c = np.linspace(c0, c_limit, n)
        r = self.rate(c)
        if np.any(r <= 0):
            return LIFE_CAP_H
        return float(min(np.trapezoid(1.0 / r, c), LIFE_CAP_H))

    def grow(self, c0: float, hours) -> np.ndarray:
        """Clearance (m) after each of ``hours`` (increasing, from 0) starting at c0: dc/dh = r(c), solved
        with scipy's RK45 on the interpolant.

        Parameters
        ----------
        c0 : float
            Clearance at 0 h (m).
        hours : array_like
            Operating hours (h), increasing from 0.

        Returns
        -------
        numpy.ndarray
            Clearance (m) at each of ``hours``.
        """
        from scipy.integrate import solve_ivp

        hours = np.asarray(hours, float)
        sol = solve_ivp(lambda h, c: self.rate(c), (0.0, float(hours[-1])), [c0], t_eval=hours, rtol=1e-8,
                        atol=1e-12)
        return sol.y[0]

    def force_falls(self, alpha: float = 0.05) -> list[dict]:
        """Grid steps where the mean peak force falls as the clearance grows beyond the noise: the paired t test
        over the starts (the same starts at every point), two-sided p < ``alpha``; a property of the dynamics, not
        noise (empty without per-start peaks).

        Parameters
        ----------
        alpha : float
            Significance level of the test (dimensionless).

        Returns
        -------
        list of dict
            Per falling step: ``from_mm``, ``to_mm`` (mm), ``change_N`` (mean change of the peak, N, < 0),
            ``se_N`` (its standard error, N) and ``p``.
        """
        from scipy import stats

        if self.peak_force_starts is None or self.starts < 2:
            return []
        out = []
        for i in range(len(self.clearance) - 1):
            d = self.peak_force_starts[i + 1] - self.peak_force_starts[i]
            m = float(d.mean())
            se = float(d.std(ddof=1) / np.sqrt(d.size))
            p = float(2 * stats.t.sf(abs(m) / se, d.size - 1)) if se > 0 else (0.0 if m != 0 else 1.0)
            if m < 0 and p < alpha:
                out.append({"from_mm": float(self.clearance[i] * 1e3), "to_mm": float(self.clearance[i + 1] * 1e3),
                            "change_N": m, "se_N": se, "p": p})
        return out

    def to_dict(self) -> dict:
        """JSON-able grid (mm, N, um/h).

        Returns
        -------
        dict
            ``clearance_mm``, ``peak_force_N``, ``growth_rate_um_per_h``, ``starts`` and, when known,
            ``peak_force_se_N`` and ``peak_force_p95_N``.
        """
        out = {"clearance_mm": (self.clearance * 1e3).tolist(), "peak_force_N": self.peak_force.tolist(),
               "growth_rate_um_per_h": (self.growth_rate * 1e6).tolist(), "starts": int(self.starts)}
        if self.peak_force_se is not None:
            out["peak_force_se_N"] = self.peak_force_se.tolist()
        if self.peak_force_p95 is not None:
            out["peak_force_p95_N"] = self.peak_force_p95.tolist()
        return out


def default_clearance_limits(machine, joints) -> dict[str, float]:
    """Clearance limit per joint (m): the service limit, :func:`berryshaker.life.service.service_limits` (the one
    rule; this name stays for callers that have not moved to it yet).

    Parameters
    ----------
    machine : MachineBase
        The machine description.
    joints : sequence of str, optional
        Clearance pairs (default every pair).

    Returns
    -------
    dict of str to float
        Joint -> service limit (m).
    """
    from berryshaker.life.service import service_limits

    return service_limits(machine, joints)


def response_grid(machine, joints, limits: dict[str, float], lo: dict[str, float], n_points: int = 4) -> dict:
    """Grid clearances (m) per joint: ``n_points`` from max(lo, GRID_FLOOR) to the joint's limit.

    Parameters
    ----------
    machine : MachineBase
        The machine description (unused; the grid depends on ``lo`` and ``limits`` only).
    joints : iterable of str
        Clearance pairs.
    limits : dict of str to float
        Clearance limit per joint (m): the grid's upper end (1.5 times the lower end when not above it).
    lo : dict of str to float
        Smallest clearance per joint (m), e.g. the tightest candidate fit's mean.
    n_points : int
        Grid points per joint (>= 2).

    Returns
    -------
    dict of str to numpy.ndarray
        Joint -> evenly spaced clearances (m).

    Raises
    ------
    ConfigError
        ``n_points`` < 2.
    """
    if n_points < 2:
        raise ConfigError(f"the surrogate grid needs >= 2 points per joint, got {n_points}")
    out = {}
    for j in joints:
        a = max(lo[j], GRID_FLOOR)
        b = limits[j]
        if b <= a:
            b = a * 1.5
        out[j] = np.linspace(a, b, n_points)
    return out


def clearance_responses(machine, joints, grid: dict[str, np.ndarray], runner, revolutions: int = 2,
                        label: str = "tolerance grid", starts: int | None = None) -> dict[str, ClearanceResponse]:
    """Run the one-at-a-time grid through the cached runner (:func:`berryshaker.life.runs.wear_rate_run`), each
    point from ``starts`` perturbed starts (seeds (seed_k, 0) of
    :func:`berryshaker.harvest.virtual.replicate_starts`, the same at every point; ``starts = 1``: the centred start
    alone; default ``harvest.replicates``), and build each joint's :class:`ClearanceResponse` from the means over
    the starts.

    Parameters
    ----------
    machine : MachineBase
        The machine description.
    joints : iterable of str
        Clearance pairs.
    grid : dict of str to numpy.ndarray
        Clearances (m) per joint (:func:`response_grid`); the other joints keep the description's sizes.
    runner : SweepRunner
        Cached runner of the multibody runs.
    revolutions : int
        Drive revolutions per run (>= 2).
    label : str
        Label of the runs in the runner's progress display.
    starts : int, optional
        Perturbed starts per grid point (>= 1; default ``harvest.replicates``).

    Returns
    -------
    dict of str to ClearanceResponse
        Per joint: the grid, mean peak force (N), its standard error and 95th percentile, the mean growth rate
        (m/h) and the per-start peaks.

    Raises
    ------
    ConfigError
        ``starts`` < 1.
    """
    from berryshaker.harvest.virtual import replicate_starts
    from berryshaker.life.runs import wear_rate_run

    starts = machine.harvest.replicates if starts is None else starts
    if int(starts) < 1:
        raise ConfigError(f"starts = {starts}: give at least 1 start per grid point")
    seeds = [None] if int(starts) == 1 else [[sd, 0] for sd in replicate_starts(machine, int(starts))]
    data = machine.model_dump(mode="json")
    jobs, where = [], []
    for j in joints:
        for k, c in enumerate(grid[j]):
            for sd in seeds:
                jobs.append(dict(machine_data=data, clearance={j: float(c)}, revolutions=int(revolutions), seed=sd))
                where.append((j, k))
    values = runner.values(wear_rate_run, jobs, label)
    out = {}
    for j in joints:
        peaks = np.array([[v["peak_force_N"][j] for v, w in zip(values, where) if w == (j, k)]
                          for k in range(len(grid[j]))])
        rates = np.array([[v["growth_rate_m_per_h"][j] for v, w in zip(values, where) if w == (j, k)]
                          for k in range(len(grid[j]))])
        n = peaks.shape[1]
        se = peaks.std(axis=1, ddof=1) / np.sqrt(n) if n > 1 else np.zeros(len(peaks))
        out[j] = ClearanceResponse(j, np.asarray(grid[j], float), peaks.mean(axis=1), rates.mean(axis=1), se,
                                   np.percentile(peaks, 95, axis=1), n, peaks)
    return out
