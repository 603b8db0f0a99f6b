"""The clearance response surrogate of the tolerance design (:mod:`berryshaker.life.tolerance`): per joint, its
static-equivalent collision force and Archard growth rate against its own clearance, from a small grid of multibody runs.

A one-at-a-time grid (``n_points`` clearances per joint, the other joints at the description's sizes) of multibody
runs through the cached sweep runner gives, per joint, its static-equivalent collision force (the p95 of its impact peaks,
berryshaker.multibody.impacts) and growth rate against its own
clearance; the design works on their linear interpolants.  Each grid point is the mean over ``starts`` perturbed
starts (default ``harvest.replicates``; the same starts at every point): a run's single largest force of a chaotic impact
sequence varies by 10-30 % from start to start and is no load, so a single run would rank fits on noise.  The standard error and
the 95th percentile of the load over the starts are kept beside the mean, and a force that falls with growing
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
    """One joint's sizing load and wear growth rate against its own clearance (a surrogate).

    Attributes
    ----------
    joint : str
        Pair name.
    clearance : numpy.ndarray
        Grid clearances (m, increasing).
    design_force : numpy.ndarray
        Static-equivalent collision force of the joint (N) at each: the mean over the starts of each run's p95 of
        its impact peaks (berryshaker.multibody.impacts).
    growth_rate : numpy.ndarray
        Archard growth rate of its clearance (m per operating hour) at each (mean over the starts).
    design_force_se : numpy.ndarray, optional
        Standard error of ``design_force`` (N; s / sqrt(starts); zeros for one start).
    design_force_p95 : numpy.ndarray, optional
        95th percentile over the starts of the per-start loads (N).
    starts : int
        Perturbed starts per grid point (1: the centred start alone).
    design_force_starts : numpy.ndarray, optional
        The per-start loads (N), grid points x starts (the same starts at every point).
    rolling_load : numpy.ndarray, optional
        A roller: its mean equivalent load over its revolutions (N, ISO 281; mean over the starts).
    roller_rev_per_h : numpy.ndarray, optional
        A roller: its revolutions per operating hour (1/h; mean over the starts).
    wear_scale : float
        The faster wear mode's k over the pair's nominal (lubricated) k (dimensionless,
        :func:`berryshaker.contact.wear.wear_scale`): :meth:`service_hours` divides by it.
    """

    joint: str
    clearance: np.ndarray
    design_force: np.ndarray
    growth_rate: np.ndarray
    design_force_se: np.ndarray | None = None
    design_force_p95: np.ndarray | None = None
    starts: int = 1
    design_force_starts: np.ndarray | None = None
    rolling_load: np.ndarray | None = None
    roller_rev_per_h: np.ndarray | None = None
    wear_scale: float = 1.0

    def force(self, c):
        """Peak force (N) at clearance c (m): linear interpolation, constant beyond the grid.

        Parameters
        ----------
        c : float or array_like
            Clearance size (m).

        Returns
        -------
        float or numpy.ndarray
            Mean static-equivalent collision force (N).
        """
        return np.interp(c, self.clearance, self.design_force)

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

    def service_hours(self, c0: float, c_limit: float) -> float:
        """Operating hours from c0 to c_limit (m) under the faster wear mode: :meth:`hours_to` / ``wear_scale``
        (the abrasive field wear where it is faster than the pair's lubricated wear, docs/life.md).

        Parameters
        ----------
        c0 : float
            Starting clearance (m).
        c_limit : float
            Clearance limit (m).

        Returns
        -------
        float
            Operating hours (h), at most :data:`LIFE_CAP_H`.
        """
        h = self.hours_to(c0, c_limit)
        return h if h >= LIFE_CAP_H else h / self.wear_scale

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
        """Grid steps where the mean static-equivalent force falls as the clearance grows beyond the noise: the paired t test
        over the starts (the same starts at every point), two-sided p < ``alpha``; a property of the dynamics, not
        noise (empty without per-start loads).

        Parameters
        ----------
        alpha : float
            Significance level of the test (dimensionless).

        Returns
        -------
        list of dict
            Per falling step: ``from_mm``, ``to_mm`` (mm), ``change_N`` (mean change of the load, N, < 0),
            ``se_N`` (its standard error, N) and ``p``.
        """
        from scipy import stats

        if self.design_force_starts is None or self.starts < 2:
            return []
        out = []
        for i in range(len(self.clearance) - 1):
            d = self.design_force_starts[i + 1] - self.design_force_starts[i]
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
            ``clearance_mm``, ``design_force_N``, ``growth_rate_um_per_h``, ``starts`` and, when known,
            ``design_force_se_N``, ``design_force_p95_N``, ``rolling_load_N`` and ``roller_rev_per_h``.
        """
        out = {"clearance_mm": (self.clearance * 1e3).tolist(), "design_force_N": self.design_force.tolist(),
               "growth_rate_um_per_h": (self.growth_rate * 1e6).tolist(), "starts": int(self.starts)}
        if self.design_force_se is not None:
            out["design_force_se_N"] = self.design_force_se.tolist()
        if self.design_force_p95 is not None:
            out["design_force_p95_N"] = self.design_force_p95.tolist()
        if self.rolling_load is not None:
            out["rolling_load_N"] = self.rolling_load.tolist()
            out["roller_rev_per_h"] = self.roller_rev_per_h.tolist()
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
        Per joint: the grid, mean static-equivalent force (N), its standard error and 95th percentile, the mean growth rate
        (m/h) and the per-start loads.

    Raises
    ------
    ConfigError
        ``starts`` < 1.
    """
    from berryshaker.contact.wear import wear_scale
    from berryshaker.harvest.virtual import replicate_starts
    from berryshaker.life.joint_loads import joint_geometry
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
        peaks = np.array([[v["design_force_N"][j] for v, w in zip(values, where) if w == (j, k)]
                          for k in range(len(grid[j]))])
        rates = np.array([[v["growth_rate_m_per_h"][j] for v, w in zip(values, where) if w == (j, k)]
                          for k in range(len(grid[j]))])
        n = peaks.shape[1]
        se = peaks.std(axis=1, ddof=1) / np.sqrt(n) if n > 1 else np.zeros(len(peaks))
        rolling = [[v.get("rolling_load_N", {}).get(j), v.get("roller_rev_per_h", {}).get(j)]
                   for v, w in zip(values, where) if w[0] == j]
        roll = turns = None
        if rolling and all(r[0] is not None for r in rolling):
            both = np.array(rolling, float).reshape(len(grid[j]), -1, 2)
            roll, turns = both[:, :, 0].mean(axis=1), both[:, :, 1].mean(axis=1)
        out[j] = ClearanceResponse(j, np.asarray(grid[j], float), peaks.mean(axis=1), rates.mean(axis=1), se,
                                   np.percentile(peaks, 95, axis=1), n, peaks, roll, turns,
                                   wear_scale(joint_geometry(machine, j).material_pair))
    return out
