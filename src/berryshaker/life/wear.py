"""Clearance over the machine's life: grow the joint clearances by wear, re-simulate, find the service limit.

The outer loop alternates a dynamic simulation at the current clearances (which gives each joint's
normal force and sliding speed over a steady window of operation) and Archard wear
(:mod:`berryshaker.contact.wear`) that turns those series into a clearance growth rate per operating hour.
The clearances are advanced with adaptive steps in hours and the machine is re-simulated, until the
horizon.  The maintenance interval is the first operating hour at which a user limit is crossed.

The dynamics enter only through a callable, so this loop is independent of the multibody engine:

``simulate(clearances) -> (loads, outputs)``
    ``clearances``: dict joint -> clearance size (m, the machine description's convention: radial for a
    pin in a bore, free travel for a roller in a groove).  ``loads``: dict joint -> ``(t, normal_force,
    sliding_speed)`` 1-D arrays (s, N, m/s) over a window that represents steady operation (whole drive
    periods).  ``outputs``: dict name -> float of scalar results (peak forces, harvest indexes...).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from scipy.integrate import trapezoid

from berryshaker.contact.wear import (
    MaterialPair,
    archard_wear_volume,
    material_pair,
)
from berryshaker.errors import ConfigError, SimulationError
from berryshaker.life.fits import Fit

SECONDS_PER_HOUR = 3600.0

LoadSeries = tuple[np.ndarray, np.ndarray, np.ndarray]
Simulator = Callable[[dict[str, float]], tuple[Mapping[str, LoadSeries], Mapping[str, float]]]


@dataclass(frozen=True)
class JointWear:
    """How one joint's load series becomes growth of its clearance size.

    Attributes
    ----------
    material : MaterialPair or str
        Archard data of the pair (a :class:`MaterialPair` or a key of ``MATERIAL_PAIRS``).
    geometry : {"pin-in-bore", "area"}
        "pin-in-bore": the clearance is the RADIAL clearance of a pin of ``pin_diameter`` in a bore of
        contact length ``bearing_length``, grown as in
        :func:`berryshaker.contact.wear.pin_in_bore_clearance_growth` with ``load_direction``.
        "area": the worn volume is spread over ``wear_area`` (m^2) and the clearance grows by
        volume / area.  For a roller in a groove (free travel = groove width - roller diameter) use the
        track area of ONE flank: contacts on either flank then add their depths to the free travel.
    pin_diameter, bearing_length : float
        Pin diameter d and bush contact length L (m), for "pin-in-bore".
    load_direction : {"fixed", "rotating"}
        For "pin-in-bore" (see the contact function).
    wear_area : float
        m^2, for "area".
    """

    material: MaterialPair | str
    geometry: Literal["pin-in-bore", "area"] = "pin-in-bore"
    pin_diameter: float | None = None
    bearing_length: float | None = None
    load_direction: Literal["fixed", "rotating"] = "fixed"
    wear_area: float | None = None

    def __post_init__(self):
        if isinstance(self.material, str):
            object.__setattr__(self, "material", material_pair(self.material))
        if self.geometry == "pin-in-bore":
            for name in ("pin_diameter", "bearing_length"):
                v = getattr(self, name)
                if v is None or not (math.isfinite(v) and v > 0):
                    raise ConfigError(f"joint wear: {name} must be a length > 0 (m) for a pin in a bore, got {v!r}")
            if self.load_direction not in ("fixed", "rotating"):
                raise ConfigError(f"joint wear: load_direction {self.load_direction!r}: choose 'fixed' or 'rotating'")
        elif self.geometry == "area":
            if self.wear_area is None or not (math.isfinite(self.wear_area) and self.wear_area > 0):
                raise ConfigError(f"joint wear: wear_area must be > 0 (m^2) for geometry 'area', "
                                  f"got {self.wear_area!r}")
        else:
            raise ConfigError(f"joint wear: geometry {self.geometry!r}: choose 'pin-in-bore' or 'area'")

    @property
    def depth_per_volume(self) -> float:
        """Clearance growth per worn volume (1/m^2): 4/(pi d L) fixed, 1/(pi d L) rotating, 1/A for an area."""
        if self.geometry == "area":
            return 1.0 / self.wear_area
        factor = 4.0 if self.load_direction == "fixed" else 1.0
        return factor / (math.pi * self.pin_diameter * self.bearing_length)

    def growth_rate(self, t, normal_force, sliding_speed) -> float:
        """Mean clearance growth rate over the series (m per operating second).

        Notes
        -----
        Archard volume over the window (trapezoid rule) times :attr:`depth_per_volume`, divided by the
        window length t[-1] - t[0]: the window is taken as representative of steady operation.

        Parameters
        ----------
        t : array_like
            Times of the window (s), increasing.
        normal_force : array_like
            Normal contact force at those times (N).
        sliding_speed : array_like
            Sliding speed at the contact (m/s).

        Returns
        -------
        float
            Clearance growth rate (m/s: m per operating second).
        """
        m = self.material
        volume = archard_wear_volume(normal_force, sliding_speed, t, m.wear_coefficient, m.hardness)
        duration = float(t[-1] - t[0])
        return float(volume[-1]) * self.depth_per_volume / duration


def clearance_size_from_fit(fit: Fit, joint_kind: str,
                            which: Literal["min", "mean", "max"] = "mean") -> float:
    """A joint's clearance ``size`` (m) from a fit, in the machine description's convention.

    Parameters
    ----------
    fit : Fit
        Diametral clearance limits.
    joint_kind : {"pin-in-bore", "roller-in-groove", "roller-in-slot"}
        A pin in a bore: radial clearance = diametral / 2.  A roller in a groove or slot (width against roller
        diameter): free travel = diametral value.  The 0.1.0 names "revolute" and "point-line" are accepted.
    which : {"min", "mean", "max"}
        Which value of the fit.

    Returns
    -------
    float
        Clearance size in m (>= 0; an interference fit gives 0).
    """
    value = {"min": fit.clearance_min, "mean": fit.clearance_mean, "max": fit.clearance_max}.get(which)
    if value is None:
        raise ConfigError(f"which={which!r}: choose 'min', 'mean' or 'max'")
    if joint_kind in ("pin-in-bore", "revolute"):
        value /= 2.0
    elif joint_kind not in ("roller-in-groove", "roller-in-slot", "point-line"):
        raise ConfigError(f"joint kind {joint_kind!r}: choose pin-in-bore, roller-in-groove or roller-in-slot")
    return max(value, 0.0)


@dataclass
class WearLife:
    """History of clearances, forces and outputs over operating hours, and the maintenance interval.

    Attributes
    ----------
    hours : numpy.ndarray
        Operating hours of the simulated states (h; 0 first).
    clearance, peak_force, mean_force, growth_rate : dict joint -> numpy.ndarray
        Clearance size (m), peak (the window's largest sample, an extreme) and time-mean |normal force| (N) over
        the simulated window, and the wear growth rate of the clearance (m per operating hour) at each state.
    design_force : dict joint -> numpy.ndarray
        The static-equivalent load (N) at each state: the simulator's ``collision_force_<joint>_static_equivalent``
        (the p95 of the impact peaks, berryshaker.multibody.impacts), else the p95 of the force series.
    outputs : dict name -> numpy.ndarray
        Scalar outputs of the simulator at each state (SI, the units of each output, e.g. N for a force).
    limits : dict key -> dict
        Each limit: {"max" or "min": value, "hours": first crossing (h) or None}.
    maintenance_interval_hours : float or None
        Earliest crossing over all limits (h), None if none was reached within the horizon.
    governing_limit : str or None
        The limit that sets the interval.
    completed : bool
        False if ``max_steps`` ran out before the horizon (and before the limits when stopping at them).
    message : str
        How the loop ended.
    """

    hours: np.ndarray
    clearance: dict[str, np.ndarray]
    peak_force: dict[str, np.ndarray]
    mean_force: dict[str, np.ndarray]
    growth_rate: dict[str, np.ndarray]
    outputs: dict[str, np.ndarray]
    limits: dict[str, dict[str, Any]] = field(default_factory=dict)
    design_force: dict[str, np.ndarray] = field(default_factory=dict)
    maintenance_interval_hours: float | None = None
    governing_limit: str | None = None
    completed: bool = True
    message: str = ""

    def to_dict(self) -> dict:
        """JSON-able result: per joint hours[], clearance_mm[] and, for wearing joints, peak_force_N[],
        mean_force_N[], growth_rate_um_per_h[]; outputs over hours; limits and the maintenance interval.

        Returns
        -------
        dict
            ``hours`` (h), ``joints`` (per joint ``hours``, ``wears``, ``clearance_mm`` and, if it wears,
            ``design_force_N``, ``peak_force_N``, ``mean_force_N``, ``growth_rate_um_per_h``), ``outputs`` (name ->
            values over
            hours), ``limits``, ``maintenance_interval_h`` (h or None), ``governing_limit``, ``completed``,
            ``message`` and a ``clearance_convention`` note.
        """
        hours = self.hours.tolist()
        return {
            "hours": hours,
            "joints": {j: {"hours": hours,
                           "wears": j in self.growth_rate,
                           "clearance_mm": (self.clearance[j] * 1e3).tolist(),
                           **({"design_force_N": self.design_force[j].tolist(),
                               "peak_force_N": self.peak_force[j].tolist(),
                               "mean_force_N": self.mean_force[j].tolist(),
                               "growth_rate_um_per_h": (self.growth_rate[j] * 1e6).tolist()}
                              if j in self.growth_rate else {})}
                       for j in self.clearance},
            "outputs": {k: v.tolist() for k, v in self.outputs.items()},
            "limits": self.limits,
            "maintenance_interval_h": self.maintenance_interval_hours,
            "governing_limit": self.governing_limit,
            "completed": self.completed,
            "message": self.message,
            "clearance_convention": "machine description sizes: radial for pin-in-bore, free travel for "
                                    "point-line pairs",
        }


def _parse_limits(limits: Mapping[str, Any] | None) -> dict[str, tuple[str, float]]:
    out: dict[str, tuple[str, float]] = {}
    for key, spec in (limits or {}).items():
        if isinstance(spec, Mapping):
            if len(spec) != 1 or next(iter(spec)) not in ("max", "min"):
                raise ConfigError(f"limit {key!r}: give a number (a maximum) or {{'max': v}} / {{'min': v}}, "
                                  f"got {spec!r}")
            sense, value = next(iter(spec.items()))
        else:
            sense, value = "max", spec
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise ConfigError(f"limit {key!r}: {value!r} is not a number (SI units)") from None
        if not math.isfinite(value):
            raise ConfigError(f"limit {key!r}: must be finite, got {value!r}")
        out[str(key)] = (sense, value)
    return out


def _first_crossing(hours: np.ndarray, values: np.ndarray, sense: str, bound: float) -> float | None:
    """First hour at which values exceed (max) or fall below (min) the bound, linear between states."""
    excess = values - bound if sense == "max" else bound - values
    over = np.nonzero(excess > 0)[0]
    if over.size == 0:
        return None
    i = int(over[0])
    if i == 0:
        return 0.0
    e0, e1 = excess[i - 1], excess[i]  # e0 <= 0 < e1
    return float(hours[i - 1] + (hours[i] - hours[i - 1]) * (-e0) / (e1 - e0))


def _check_loads(loads: Mapping[str, LoadSeries], joints: Mapping[str, JointWear]) -> dict[str, LoadSeries]:
    out = {}
    for j in joints:
        if j not in loads:
            raise SimulationError(f"wear loop: the simulator returned no load series for joint {j!r} "
                                  f"(it returned {', '.join(map(str, loads)) or 'none'})")
        try:
            t, f, v = (np.asarray(a, float) for a in loads[j])
        except (TypeError, ValueError):
            raise SimulationError(f"wear loop: loads[{j!r}] must be (t, normal_force, sliding_speed) arrays") from None
        if t.ndim != 1 or t.size < 2 or f.shape != t.shape or v.shape != t.shape:
            raise SimulationError(f"wear loop: loads[{j!r}] arrays must be 1-D of equal length >= 2, got "
                                  f"{t.shape}, {f.shape}, {v.shape}")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(f)) and np.all(np.isfinite(v))):
            raise SimulationError(f"wear loop: loads[{j!r}] contains non-finite values")
        if np.any(np.diff(t) <= 0):
            raise SimulationError(f"wear loop: loads[{j!r}] time must be strictly increasing")
        out[j] = (t, f, v)
    return out


def _machine_clearances(machine: Any) -> dict[str, float]:
    """Clearance sizes (m) of a machine description (``clearance_sizes()``; older ``clearance.sizes()``)."""
    if hasattr(machine, "clearance_sizes"):
        sizes = machine.clearance_sizes()
    elif hasattr(getattr(machine, "clearance", None), "sizes"):
        sizes = machine.clearance.sizes()
    else:
        raise ConfigError("wear_life: machine has no clearance sizes; pass machine=None and initial_clearances")
    return {str(k): float(v) for k, v in sizes.items()}


def wear_life(machine: Any, hours: float, limits: Mapping[str, Any] | None = None, *,
              simulate: Simulator, joints: Mapping[str, JointWear],
              initial_clearances: Mapping[str, float] | None = None,
              max_growth_fraction: float = 0.10, max_growth: float = 0.02e-3, min_growth: float = 1e-6,
              max_steps: int = 200, scheme: Literal["adams-bashforth2", "euler"] = "adams-bashforth2",
              stop_at_limits: bool = False) -> WearLife:
    """Grow joint clearances by Archard wear over operating hours, re-simulating as they grow.

    Parameters
    ----------
    machine : Machine or None
        Gives the initial clearance sizes (``machine.clearance_sizes()``, m); may be None when
        ``initial_clearances`` names every joint.
    hours : float
        Horizon (h, operating hours; > 0).
    limits : dict, optional
        Service limits.  Keys: a scalar output name of the simulator, ``"clearance:<joint>"`` (m),
        ``"design_force:<joint>"`` (the static-equivalent load), ``"peak_force:<joint>"`` or
        ``"mean_force:<joint>"`` (N).  Values: a number (a maximum) or
        ``{"max": v}`` / ``{"min": v}`` (SI units).
    simulate : callable
        ``simulate(clearances) -> (loads, outputs)``, see the module docstring.
    joints : dict joint -> JointWear
        The joints that wear; other joints keep their clearance.
    initial_clearances : dict, optional
        Clearance sizes (m) overriding the machine's (e.g. from :func:`clearance_size_from_fit`).
    max_growth_fraction, max_growth, min_growth : float
        Step control: in one step no clearance grows by more than
        ``clip(max_growth_fraction * c, min_growth, max_growth)`` (m) -- 10 % of its value but never more
        than 0.02 mm, and at least 1 um so that a zero clearance can start growing.
    max_steps : int
        Bound on the number of steps (simulations = steps + 1).
    scheme : {"adams-bashforth2", "euler"}
        Time integration of dc/dt = r(c): second-order variable-step Adams-Bashforth (default; the first
        step is Euler) or explicit Euler.  Both use one simulation per step.  Increments are clipped at
        zero: wear never shrinks a clearance.
    stop_at_limits : bool
        Stop once every limit has been crossed.

    Returns
    -------
    WearLife
        The clearances, forces, growth rates and outputs at each simulated state, each limit's first
        crossing and the maintenance interval.

    Notes
    -----
    Quasi-static separation of time scales: the wear over one simulated window is negligible, so the
    dynamics at a given clearance are periodic-steady and the growth rate is the window mean
    (:meth:`JointWear.growth_rate`).  The maintenance interval is the first crossing of any limit,
    linearly interpolated in hours between simulated states.
    """
    if not (isinstance(hours, (int, float)) and math.isfinite(hours) and hours > 0):
        raise ConfigError(f"hours: the horizon must be > 0 operating hours, got {hours!r}")
    if not (0 < max_growth_fraction and 0 < min_growth <= max_growth):
        raise ConfigError("step control: need max_growth_fraction > 0 and 0 < min_growth <= max_growth")
    if scheme not in ("adams-bashforth2", "euler"):
        raise ConfigError(f"scheme {scheme!r}: choose 'adams-bashforth2' or 'euler'")
    if int(max_steps) < 1:
        raise ConfigError(f"max_steps must be >= 1, got {max_steps!r}")
    clear: dict[str, float] = {}
    if machine is not None:
        clear.update(_machine_clearances(machine))
    clear.update({k: float(v) for k, v in (initial_clearances or {}).items()})
    for j in joints:
        if j not in clear:
            raise ConfigError(f"joint {j!r} has no initial clearance; known: {', '.join(clear) or 'none'} "
                              "(pass machine or initial_clearances)")
        if not (math.isfinite(clear[j]) and clear[j] >= 0):
            raise ConfigError(f"initial clearance of {j!r} must be >= 0 m, got {clear[j]!r}")
    limit_specs = _parse_limits(limits)
    names = list(joints)

    hist_h: list[float] = []
    hist_c: list[dict[str, float]] = []
    hist_peak: list[dict[str, float]] = []
    hist_design: list[dict[str, float]] = []
    hist_mean: list[dict[str, float]] = []
    hist_rate: list[np.ndarray] = []
    hist_out: list[dict[str, float]] = []

    def evaluate(h: float, c: dict[str, float]) -> np.ndarray:
        loads, outputs = simulate(dict(c))
        loads = _check_loads(loads, joints)
        rates = np.empty(len(names))
        peak, mean, design = {}, {}, {}
        for k, j in enumerate(names):
            t, f, v = loads[j]
            rates[k] = joints[j].growth_rate(t, f, v) * SECONDS_PER_HOUR
            af = np.abs(f)
            peak[j] = float(af.max())
            mean[j] = float(trapezoid(af, t) / (t[-1] - t[0]))
            d = float(dict(outputs).get(f"collision_force_{j}_static_equivalent", math.nan))
            design[j] = d if math.isfinite(d) else float(np.percentile(af, 95))
        hist_h.append(h)
        hist_c.append(dict(c))
        hist_peak.append(peak)
        hist_design.append(design)
        hist_mean.append(mean)
        hist_rate.append(rates)
        hist_out.append({str(k): float(v) for k, v in dict(outputs).items()})
        return rates

    def series(key: str) -> np.ndarray:
        kind, _, joint = key.partition(":")
        if joint and kind in ("clearance", "design_force", "peak_force", "mean_force"):
            if joint not in hist_c[0]:
                raise ConfigError(f"limit {key!r}: unknown joint {joint!r}; joints: {', '.join(hist_c[0])}")
            src = {"clearance": hist_c, "design_force": hist_design, "peak_force": hist_peak,
                   "mean_force": hist_mean}[kind]
            if joint not in src[0]:
                raise ConfigError(f"limit {key!r}: joint {joint!r} does not wear in this run; wearing joints: "
                                  f"{', '.join(names)}")
            return np.array([s[joint] for s in src])
        if key not in hist_out[0]:
            raise ConfigError(f"limit {key!r}: not an output of the simulator ({', '.join(hist_out[0]) or 'none'})"
                              f" nor clearance:/design_force:/peak_force:/mean_force:<joint>")
        return np.array([o[key] for o in hist_out])

    def crossings() -> dict[str, float | None]:
        hh = np.array(hist_h)
        return {key: _first_crossing(hh, series(key), sense, bound) for key, (sense, bound) in limit_specs.items()}

    h = 0.0
    c = dict(clear)
    rates = evaluate(h, c)
    crossings()  # validates the limit names against the first simulation
    prev_rates, prev_dt = None, None
    message = f"reached the horizon of {hours:g} h"
    completed = True
    steps = 0
    while h < hours * (1 - 1e-12):
        if steps >= max_steps:
            completed = False
            message = (f"stopped after max_steps={max_steps} at {h:.6g} h of {hours:g} h; raise max_steps or "
                       "the growth bounds")
            break
        if stop_at_limits and limit_specs and all(v is not None for v in crossings().values()):
            message = f"every limit crossed by {h:.6g} h"
            break
        allowed = np.array([min(max(max_growth_fraction * c[j], min_growth), max_growth) for j in names])
        with np.errstate(divide="ignore"):
            dt_each = np.where(rates > 0, allowed / np.where(rates > 0, rates, 1.0), np.inf)
        dt = float(min(np.min(dt_each) if dt_each.size else np.inf, hours - h))
        if scheme == "adams-bashforth2" and prev_rates is not None:
            w = dt / (2.0 * prev_dt)
            slope = (1.0 + w) * rates - w * prev_rates
        else:
            slope = rates
        incr = np.clip(slope * dt, 0.0, None)
        for k, j in enumerate(names):
            c[j] = c[j] + float(incr[k])
        h = h + dt if dt < hours - h else float(hours)
        prev_rates, prev_dt = rates, dt
        rates = evaluate(h, c)
        steps += 1

    hh = np.array(hist_h)
    cross = crossings()
    reached = {k: v for k, v in cross.items() if v is not None}
    governing = min(reached, key=reached.get) if reached else None
    return WearLife(
        hours=hh,
        clearance={j: np.array([s[j] for s in hist_c]) for j in hist_c[0]},
        peak_force={j: np.array([s[j] for s in hist_peak]) for j in names},
        design_force={j: np.array([s[j] for s in hist_design]) for j in names},
        mean_force={j: np.array([s[j] for s in hist_mean]) for j in names},
        growth_rate={j: np.array([r[k] for r in hist_rate]) for k, j in enumerate(names)},
        outputs={k: np.array([o.get(k, math.nan) for o in hist_out]) for k in hist_out[0]},
        limits={k: {limit_specs[k][0]: limit_specs[k][1], "hours": cross[k]} for k in limit_specs},
        maintenance_interval_hours=reached[governing] if governing else None,
        governing_limit=governing,
        completed=completed,
        message=message,
    )
