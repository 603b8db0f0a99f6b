"""Parameter sweeps over a machine description: KEY=values parsing, sampling (grid, Latin hypercube,
Monte Carlo), one sweep point (override, validate, simulate, summarise) and the tidy results table.

Runs go through :class:`berryshaker.runs.runner.SweepRunner` (cached, resumable, local or Dask).
"""

from __future__ import annotations

import json
from dataclasses import dataclass

from berryshaker.runs.runner import RunResult

@dataclass(frozen=True)
class SweepParam:
    key: str  # dotted path in the machine description, e.g. clearance.A.size
    kind: str  # "range", "levels" or "normal"
    values: tuple  # (lo, hi) | levels | (mean, sd), in ``unit``
    unit: str
    factor: float  # SI value of one ``unit``


def _unit_factor(unit: str) -> float:
    if not unit:
        return 1.0
    from berryshaker.units import _registry

    ureg = _registry()
    try:
        return float(ureg.Quantity(1.0, unit.replace("r/min", "rpm")).to_base_units().magnitude)
    except Exception:  # noqa: BLE001
        from berryshaker.errors import ConfigError

        raise ConfigError(f"--param: unknown unit {unit!r}") from None


def parse_param(spec: str) -> SweepParam:
    """``clearance.A.size=0.1..0.8mm`` (range), ``cam.speed=100,120,140rpm`` (levels) or
    ``clearance.C.size=0.1+-0.02mm`` (normal: mean +- standard deviation, for Monte Carlo tolerances)."""
    import re

    from berryshaker.errors import ConfigError

    if "=" not in spec:
        raise ConfigError(f"--param {spec!r}: expected KEY=LO..HI[unit], KEY=v1,v2[unit] or KEY=MEAN+-SD[unit]")
    key, rhs = (s.strip() for s in spec.split("=", 1))
    num = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?"
    m = re.fullmatch(rf"({num})\.\.({num})\s*(.*)", rhs, re.I)
    if m:
        lo, hi, unit = float(m.group(1)), float(m.group(2)), m.group(3).strip()
        if not hi > lo:
            raise ConfigError(f"--param {spec!r}: the range needs LO < HI")
        return SweepParam(key, "range", (lo, hi), unit, _unit_factor(unit))
    m = re.fullmatch(rf"({num})\s*\+-\s*({num})\s*(.*)", rhs, re.I)
    if m:
        mean, sd, unit = float(m.group(1)), float(m.group(2)), m.group(3).strip()
        if sd < 0:
            raise ConfigError(f"--param {spec!r}: the standard deviation must be >= 0")
        return SweepParam(key, "normal", (mean, sd), unit, _unit_factor(unit))
    parts = [p.strip() for p in rhs.split(",") if p.strip()]
    m = re.fullmatch(rf"({num})\s*(.*)", parts[-1] if parts else "", re.I)
    if not parts or not m:
        raise ConfigError(f"--param {spec!r}: cannot read the values")
    unit = m.group(2).strip()
    try:
        levels = tuple(float(p) for p in parts[:-1] + [m.group(1)])
    except ValueError:
        raise ConfigError(f"--param {spec!r}: levels must be numbers") from None
    return SweepParam(key, "levels", levels, unit, _unit_factor(unit))


def sample_params(params: list[SweepParam], method: str, n: int, seed: int | None) -> list[list[float]]:
    """Sample points (in each parameter's own unit): full grid, Latin hypercube or Monte Carlo."""
    import itertools

    import numpy as np
    from scipy.stats import qmc

    from berryshaker.errors import ConfigError

    if method == "grid":
        axes = []
        for p in params:
            if p.kind == "levels":
                axes.append(list(p.values))
            elif p.kind == "range":
                axes.append(list(np.linspace(p.values[0], p.values[1], n)))
            else:
                raise ConfigError(f"--param {p.key}: a grid needs a range or levels, not mean+-sd")
        return [list(pt) for pt in itertools.product(*axes)]
    rng = np.random.default_rng(seed)
    if method == "lhs":
        u = qmc.LatinHypercube(d=len(params), seed=rng).random(n)
    elif method == "montecarlo":
        u = rng.random((n, len(params)))
    else:
        raise ConfigError(f"unknown sampling method {method!r}: grid, lhs or montecarlo")
    out = np.empty_like(u)
    from scipy.stats import norm

    for j, p in enumerate(params):
        if p.kind == "range":
            out[:, j] = p.values[0] + u[:, j] * (p.values[1] - p.values[0])
        elif p.kind == "normal":
            out[:, j] = p.values[0] + p.values[1] * norm.ppf(np.clip(u[:, j], 1e-12, 1 - 1e-12))
        else:
            out[:, j] = np.array(p.values)[np.minimum((u[:, j] * len(p.values)).astype(int), len(p.values) - 1)]
    return out.tolist()


def model_run(machine_data: dict, overrides: dict, model: str = "mlsd", revolutions: int = 3) -> dict:
    """One sweep point: apply SI overrides (dotted keys) to the machine, validate, simulate, summarise."""
    from berryshaker.config import machine_from_dict
    from berryshaker.errors import ConfigError

    data = json.loads(json.dumps(machine_data))
    for key, value in overrides.items():
        node = data
        parts = key.split(".")
        for k in parts[:-1]:
            if not isinstance(node, dict) or k not in node:
                raise ConfigError(f"unknown parameter {key!r} (no {k!r} in the machine description)")
            node = node[k]
        if parts[-1] not in node:
            raise ConfigError(f"unknown parameter {key!r}")
        node[parts[-1]] = value
    machine = machine_from_dict(data, "(sweep point)")
    from berryshaker.drives import drive_of

    drive = drive_of(machine)
    drive.check(machine)
    if model == "mlsd":
        if drive.reduced_model is None:
            raise ConfigError(f"the {drive.name} drive has no reduced model; use --model multibody")
        return drive.reduced_model(machine, {}, revolutions=revolutions).summary()
    from berryshaker.drives.simulation import simulate_multibody

    return simulate_multibody(machine, {}, revolutions=revolutions)[1]


def tidy_rows(params: list[SweepParam], points: list[list[float]], results: list[RunResult]) -> tuple[list, list]:
    """A tidy results table: one row per run, parameter columns (their units), status, outputs."""
    header = ["run"] + [f"{p.key}[{p.unit}]" if p.unit else p.key for p in params] + ["status", "error"]
    out_cols: list[str] = []
    rows = []
    for i, (pt, r) in enumerate(zip(points, results)):
        vals = {}
        if r.value:
            for pair, s in r.value.get("collision_force_N", {}).items():
                for stat in ("peak", "mean", "rms"):
                    vals[f"collision_force_{pair}_{stat}_N"] = s[stat]
            for side, s in r.value.get("load_moment_Nm", {}).items():
                vals[f"load_moment_{side}_peak_Nm"] = s["peak"]
                vals[f"load_moment_{side}_rms_Nm"] = s["rms"]
            d = r.value.get("drive_moment_Nm", {})
            if d:
                vals["drive_moment_peak_Nm"], vals["drive_moment_rms_Nm"] = d["peak"], d["rms"]
        for k in vals:
            if k not in out_cols:
                out_cols.append(k)
        rows.append((i + 1, pt, "failed" if r.error else "ok", r.error or "", vals))
    table = [[i, *pt, status, error, *[vals.get(c, "") for c in out_cols]] for i, pt, status, error, vals in rows]
    return header + out_cols, table
