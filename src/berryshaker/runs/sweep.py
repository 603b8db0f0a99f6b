"""Parameter sweeps over a machine description: KEY=values parsing, sampling (grid, Latin hypercube,
Monte Carlo), one sweep point (override, validate, simulate, summarise) and the tidy results table.

Runs go through :class:`berryshaker.runs.runner.SweepRunner` (cached, resumable, local or Dask).

long module: its length is numpydoc sections; parsing, sizing, sampling and running a sweep point share the
SweepParam and the point layout.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

from berryshaker.compiled_cache import COMPILED_ALREADY as _COMPILED_ALREADY
from berryshaker.runs.runner import RunResult

#: most points one sweep may have (each is validated before the runner starts): each point is a simulation
#: (0.1-0.5 s of a core for the MLSD and multibody models, seconds for a coupled harvest run), so the bound is
#: already hours of CPU; more is a slip of the number or a sweep to split
MAX_SWEEP_POINTS = 100_000
#: validating this many points or more shows a progress bar (about 2 ms per point) when stderr is a terminal
VALIDATE_PROGRESS_FROM = 2_000
#: spacing of the written series of a sweep point's run (s), as in the reduced and multibody models
SWEEP_OUTPUT_STEP = 1e-4


@dataclass(frozen=True)
class SweepParam:
    """One swept parameter, read by :func:`parse_param`.

    Attributes
    ----------
    key : str
        Dotted path in the machine description, e.g. ``clearance.A.size``.
    kind : str
        "range", "levels" or "normal".
    values : tuple
        (lo, hi), the levels or (mean, sd), in the units of ``unit``.
    unit : str
        The display unit the user wrote.
    factor : float
        SI value of one ``unit`` (SI units of ``dimension``).
    dimension : str
        Of the field (a key of :data:`berryshaker.units.DIMENSIONS`).
    """

    key: str  # dotted path in the machine description, e.g. clearance.A.size
    kind: str  # "range", "levels" or "normal"
    values: tuple  # (lo, hi) | levels | (mean, sd), in ``unit``
    unit: str
    factor: float  # SI value of one ``unit``
    dimension: str = "dimensionless"  # of the field (berryshaker.units.DIMENSIONS)


def _machine_class(machine):
    if machine is None:
        from berryshaker.drives import get_drive

        return get_drive("groove_cam").machine_class
    return machine if isinstance(machine, type) else type(machine)


def parse_param(spec: str, machine=None) -> SweepParam:
    """Read one ``--param KEY=VALUES``: ``clearance.A.size=0.1..0.8mm`` (range), ``cam.speed=100,120,140rpm``
    (levels) or ``clearance.C.size=0.1+-0.02mm`` (normal: mean +- standard deviation, for Monte Carlo
    tolerances); units may be written on every item (``0.1mm..0.3mm``, ``0.25mm+-0.05mm``).

    The values are read by :func:`berryshaker.units.parse_value_list` with the dimension of KEY's field in the
    machine description (its declared quantity type or display unit), so ``cam.speed=100,120kg`` is refused
    instead of running at 100 rad/s, and an angle needs its unit.

    Parameters
    ----------
    spec : str
        ``KEY=VALUES``.
    machine : MachineBase instance or class, optional
        Whose fields KEY names; default the groove-cam drive's description.

    Returns
    -------
    SweepParam
        The key, the kind of list, its values in the user's unit and that unit's SI factor.

    Raises
    ------
    ConfigError
        No ``=``, an unknown key, a key that is not a number (a name, a flag, a section), or values that
        :func:`~berryshaker.units.parse_value_list` refuses (wrong dimension, unit missing, LO >= HI, ...).
    """
    from berryshaker.errors import ConfigError
    from berryshaker.quantity_fields import field_dimension, field_info_at
    from berryshaker.units import parse_value_list

    forms = "KEY=LO..HI unit, KEY=V1,V2,... unit or KEY=MEAN+-SD unit"
    if not isinstance(spec, str) or "=" not in spec:
        raise ConfigError(f"--param {spec!r}: expected {forms}, e.g. clearance.A.size=0.1..0.3mm")
    key, rhs = (t.strip() for t in spec.split("=", 1))
    if not key:
        raise ConfigError(f"--param {spec!r}: the key before '=' is empty; expected {forms}")
    info = field_info_at(_machine_class(machine), key)
    dim = field_dimension(info)
    if dim is None:
        raise ConfigError(f"--param {key}: not a single number in the machine description (a name, a flag, a list "
                          "or a section), so it cannot be swept")
    if machine is not None and not isinstance(machine, type):
        apply_overrides(machine.model_dump(mode="json"), {key: None})  # the entry exists (clearance.X.size)
    vs = parse_value_list(rhs, dim, f"--param {key}")
    return SweepParam(key, vs.kind, tuple(float(f"{v:.12g}") for v in vs.in_unit()), vs.unit, vs.unit_si, dim)


def check_params(params: list[SweepParam]) -> None:
    """Refuse a sweep that names a key twice.

    Parameters
    ----------
    params : list of SweepParam
        The swept parameters.

    Raises
    ------
    ConfigError
        A key given twice; the message says how to list several values in one ``--param``.
    """
    from berryshaker.errors import ConfigError

    seen: set[str] = set()
    for p in params:
        if p.key in seen:
            raise ConfigError(f"--param {p.key} is given twice; give each parameter once (list several values "
                              f"in one --param, e.g. {p.key}=V1,V2,V3)")
        seen.add(p.key)


def apply_overrides(machine_data: dict, overrides: dict) -> dict:
    """A copy of a machine's dict (as dumped to JSON) with SI values set at dotted keys.

    Parameters
    ----------
    machine_data : dict
        The machine description, as dumped to JSON (SI).
    overrides : dict
        Dotted key -> value, in SI units of the key's field.

    Returns
    -------
    dict
        The new description (the input is not changed).

    Raises
    ------
    ConfigError
        A key that is not in the description.
    """
    from berryshaker.errors import ConfigError

    data = json.loads(json.dumps(machine_data))
    for key, value in overrides.items():
        node = data
        parts = key.split(".")
        for k in parts[:-1]:
            if not isinstance(node, dict) or k not in node:
                raise ConfigError(f"unknown parameter {key!r} (no {k!r} in the machine description)")
            node = node[k]
        if not isinstance(node, dict) or parts[-1] not in node:
            raise ConfigError(f"unknown parameter {key!r}")
        node[parts[-1]] = value
    return data


def point_machine(machine_data: dict, overrides: dict, revolutions: int = 3, check: bool = True):
    """The validated machine of one sweep point: overrides applied, the description validated like a config
    file, the drive's check run (geometry over the cycle) and the run length checked against the engines' output
    cap (:func:`berryshaker.multibody.engine.check_output_samples`).

    Parameters
    ----------
    machine_data : dict
        The machine description, as dumped to JSON (SI).
    overrides : dict
        Dotted key -> value in SI units of the key's field.
    revolutions : int
        Drive-shaft revolutions of the run.
    check : bool
        Run the drive's geometry check (False leaves it to the caller).

    Returns
    -------
    MachineBase
        The point's machine.

    Raises
    ------
    ConfigError, GeometryError
        The point would be refused by a simulation; the message names the field.
    """
    import math

    from berryshaker.config import machine_from_dict
    from berryshaker.drives import drive_of
    from berryshaker.multibody.engine import check_output_samples

    machine = machine_from_dict(apply_overrides(machine_data, overrides), "(sweep point)")
    if check:
        drive_of(machine).check(machine)
    check_output_samples(revolutions * 2 * math.pi / machine.drive_speed, SWEEP_OUTPUT_STEP,
                         "use fewer --revolutions")
    return machine


def validate_points(machine, params: list[SweepParam], points: list[list[float]], revolutions: int,
                    limit: int = 8, progress: bool | None = None) -> None:
    """Validate every sweep point's machine before any run starts (values, clearance limits, geometry over
    the cycle, run length); refuse the sweep listing the first ``limit`` bad points with their errors.

    Parameters
    ----------
    machine : MachineBase
        The swept machine.
    params : list of SweepParam
        The swept parameters.
    points : list of list of float
        The sampled points, in each parameter's unit.
    revolutions : int
        Drive-shaft revolutions per run.
    limit : int
        Bad points listed in the message.
    progress : bool, optional
        Show a progress bar on stderr (about 2 ms per point); default when there are at least
        :data:`VALIDATE_PROGRESS_FROM` points and stderr is a terminal (without a terminal such a sweep prints one
        line saying what it validates and about how long it takes).

    Raises
    ------
    ConfigError
        Too many points, or at least one point that a run would refuse.
    """
    from berryshaker.errors import BerryshakerError, ConfigError

    if len(points) > MAX_SWEEP_POINTS:
        raise ConfigError(f"the sweep has {len(points):,} points: at most {MAX_SWEEP_POINTS:,} runs per sweep; use "
                          "fewer --points or levels, or split the sweep")
    import sys

    from rich.console import Console
    from rich.progress import Progress

    data = machine.model_dump(mode="json")
    bad = []
    long = len(points) >= VALIDATE_PROGRESS_FROM
    if progress is None:
        progress = long and sys.stderr.isatty()
    if long and not progress:  # no terminal for a bar: one line, so a long preparation is never silent
        print(f"validating {len(points):,} sweep points before any run (about {len(points) * 2e-3:.0f} s) ...",
              file=sys.stderr, flush=True)
    with Progress(console=Console(stderr=True), transient=True, disable=not progress) as bar:
        task = bar.add_task(f"validating {len(points):,} sweep points", total=len(points))
        for i, pt in enumerate(points):
            try:
                point_machine(data, overrides_of(params, pt), revolutions)
            except BerryshakerError as exc:
                where = ", ".join(f"{p.key} = {v:.6g}{' ' + p.unit if p.unit else ''}" for p, v in zip(params, pt))
                bad.append(f"point {i + 1} ({where}): {str(exc).replace(chr(10), ' ')}")
            bar.advance(task)
    if bad:
        more = f"\n  ... and {len(bad) - limit} more" if len(bad) > limit else ""
        raise ConfigError(f"{len(bad)} of {len(points)} sweep points would be refused; nothing was run:\n  "
                          + "\n  ".join(bad[:limit]) + more)


def overrides_of(params: list[SweepParam], point: list[float]) -> dict:
    """SI overrides of one sampled point.

    Parameters
    ----------
    params : list of SweepParam
        The swept parameters.
    point : list of float
        One value per parameter, in the units of its ``unit``.

    Returns
    -------
    dict
        Dotted key -> value in SI units of the key's field.
    """
    return {p.key: float(v) * p.factor for p, v in zip(params, point)}


def sweep_size(params: list[SweepParam], method: str, n: int) -> int:
    """Runs of a sweep: ``n`` for lhs / montecarlo; for a grid the product of ``n`` per range and the number of
    levels of each list (an exact integer, however large).

    Parameters
    ----------
    params : list of SweepParam
        The swept parameters.
    method : str
        "grid", "lhs" or "montecarlo".
    n : int
        ``--points``: grid levels per range, or samples.

    Returns
    -------
    int
        The number of runs.
    """
    if method != "grid":
        return n
    size = 1
    for p in params:
        size *= len(p.values) if p.kind == "levels" else n
    return size


def check_sweep_size(params: list[SweepParam], method: str, n: int) -> int:
    """Refuse a sweep of more than :data:`MAX_SWEEP_POINTS` runs before any work (sampling, validation, runs),
    with the arithmetic that gives its size.

    Parameters
    ----------
    params : list of SweepParam
        The swept parameters.
    method : str
        "grid", "lhs" or "montecarlo".
    n : int
        ``--points``.

    Returns
    -------
    int
        The number of runs (:func:`sweep_size`).

    Raises
    ------
    ConfigError
        Too many runs; the message names ``--points``, the count, the bound and what to do instead.
    """
    from berryshaker.errors import ConfigError

    size = sweep_size(params, method, n)
    if size <= MAX_SWEEP_POINTS:
        return size
    why = (f"at most {MAX_SWEEP_POINTS:,} runs per sweep (each run is a simulation of 0.1 s to seconds of a core, "
           "so the bound is hours already)")
    if method == "grid":
        ranges = sum(1 for p in params if p.kind != "levels")
        terms = [f"--points {n:,}" + (f" ^ {ranges} ranges" if ranges > 1 else "")] if ranges else []
        terms += [f"{len(p.values)} levels of {p.key}" for p in params if p.kind == "levels"]
        count = f"{size:,}" if size < 10**12 else f"{float(size):.3g}"
        raise ConfigError(f"the grid has {' x '.join(terms)} = {count} runs: {why}; use fewer --points or levels, "
                          "split the sweep, or sample the ranges with --method lhs (--points samples in all)")
    raise ConfigError(f"--points {n:,} with --method {method} is {n:,} runs: {why}; use fewer --points or split "
                      "the sweep")


def sample_params(params: list[SweepParam], method: str, n: int, seed: int | None) -> list[list[float]]:
    """Sample points: full grid, Latin hypercube or Monte Carlo.

    Parameters
    ----------
    params : list of SweepParam
        The swept parameters.
    method : str
        "grid", "lhs" or "montecarlo".
    n : int
        Grid levels per range, or samples.
    seed : int or None
        Seed of lhs / montecarlo sampling.

    Returns
    -------
    list of list of float
        The points, each value in its parameter's unit.
    """
    import itertools

    import numpy as np
    from scipy.stats import qmc

    from berryshaker.errors import ConfigError

    if not params:
        raise ConfigError("a sweep needs at least one --param KEY=VALUES")
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ConfigError(f"--points must be a whole number >= 1, got {n!r}")
    check_sweep_size(params, method, n)
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


def model_run(machine_data: dict, overrides: dict, model: str = "mlsd", revolutions: int = 3,
              driveline: str | None = None, specialised: bool | None = None) -> dict:
    """One sweep point: apply SI overrides (dotted keys) to the machine, validate, simulate, summarise.

    Parameters
    ----------
    machine_data : dict
        The machine description, as dumped to JSON (SI).
    overrides : dict
        Dotted key -> value in SI units of the key's field.
    model : str
        "mlsd", "multibody" or "harvest".
    revolutions : int
        Drive-shaft revolutions of the run.
    driveline : str, optional
        "imposed" or "powered": overrides the machine's ``[driveline] mode`` (multibody model only).
    specialised : bool, optional
        Integrate the multibody model with the kernel specialised to its structure (the same summary, bitwise;
        :mod:`berryshaker.multibody.specialised`); False: the generic kernel; None: as
        :func:`berryshaker.compiled_cache.resolve_kernel` decides.  Not part of the run's cache key.

    Returns
    -------
    dict
        The run's JSON summary (forces in N, moments in N m, as the model's summary gives them).
    """
    from berryshaker.drives import drive_of
    from berryshaker.errors import ConfigError

    # no geometry check here: every model below runs the drive's check itself (the multibody mechanism, the
    # reduced model, the harvest's kinematics), and a sweep checked every point before its first run
    # (validate_points); ~1 ms of a 0.1 s run
    machine = point_machine(machine_data, overrides, revolutions, check=False)
    drive = drive_of(machine)
    if model == "harvest":  # virtual harvest: coupled drive-past runs, picking indexes (revolutions unused)
        from berryshaker.harvest.virtual import harvest_response

        return harvest_response(machine)
    if model == "mlsd":
        if drive.reduced_model is None:
            raise ConfigError(f"the {drive.name} drive has no reduced model; use --model multibody")
        return drive.reduced_model(machine, {}, revolutions=revolutions).summary()
    from berryshaker.drives.simulation import simulate_multibody

    # only the summary is kept: the start-up revolution's samples are not written (the summary is the same)
    return simulate_multibody(machine, {}, revolutions=revolutions, driveline=driveline, series="statistics",
                              specialised=specialised)[1]


#: runs per worker from which ``berryshaker sweep`` picks the specialised kernel for a structure it has not compiled
#: yet: its 10-20 s of compilation against ~24 ms saved per harvester run
SPECIALISE_FROM_RUNS_PER_WORKER = 600
#: :func:`choose_specialised`'s reason when the first point's structure is compiled: then every run is left to choose
#: (each takes the specialised kernel if its own structure is compiled), not forced to compile its structure
#: (:data:`berryshaker.compiled_cache.COMPILED_ALREADY`)
COMPILED_ALREADY = _COMPILED_ALREADY


def choose_specialised(machine_data: dict, overrides: dict, revolutions: int, driveline: str | None, runs: int,
                       workers: int, explicit: bool | None = None) -> tuple[bool, str]:
    """The multibody kernel of a sweep, by the one rule (:func:`berryshaker.compiled_cache.resolve_kernel`):
    ``explicit`` (``berryshaker sweep --specialised`` / ``--generic``) if given; else the environment variable
    ``BERRYSHAKER_KERNEL`` set to generic or specialised; else the specialised kernel when this machine has compiled
    it for the sweep's structure (the first point's) or when the sweep has at least
    :data:`SPECIALISE_FROM_RUNS_PER_WORKER` runs per worker; else the generic one.

    Parameters
    ----------
    machine_data : dict
        The machine description, as dumped to JSON (SI).
    overrides : dict
        The first point's SI overrides.
    revolutions : int
        Drive-shaft revolutions per run.
    driveline : str or None
        "imposed" or "powered", None: the machine's.
    runs : int
        Runs of the sweep.
    workers : int
        Workers sharing them.
    explicit : bool, optional
        ``--specialised`` (True) or ``--generic`` (False).

    Returns
    -------
    specialised : bool
        True for the specialised kernel.
    why : str
        Why, for the user.
    """
    from berryshaker.compiled_cache import resolve_kernel

    def compiled() -> bool:
        from berryshaker.drives import drive_of
        from berryshaker.drives.powered import with_driveline_mode
        from berryshaker.multibody.engine import compile_mechanism
        from berryshaker.multibody.specialised import is_compiled

        machine = with_driveline_mode(point_machine(machine_data, overrides, revolutions, check=False), driveline)
        cm = compile_mechanism(drive_of(machine).mechanism(machine, revolutions=revolutions))
        return is_compiled(cm.model, cm.n)

    def pays() -> tuple[bool, str]:
        per_worker = runs / max(workers, 1)
        if per_worker >= SPECIALISE_FROM_RUNS_PER_WORKER:
            return True, f"{per_worker:.0f} runs per worker pay for its compilation"
        return False, (f"{per_worker:.0f} runs per worker, fewer than the {SPECIALISE_FROM_RUNS_PER_WORKER} that pay "
                       "for compiling the specialised kernel (--specialised forces it)")

    return resolve_kernel(explicit, compiled, pays, asked="--specialised" if explicit else "--generic")


model_run.cache_key_ignores = ("specialised",)  # the kernel: bitwise the same summary (multibody.specialised)


def harvest_output_columns() -> list[str]:
    """Outputs of a ``--model harvest`` point (berryshaker.harvest.virtual.harvest_response): every harvest
    response's mean with its model, field and counting spreads (the response table's columns), the shaking
    frequency and amplitude, the number of starts.

    Returns
    -------
    list of str
        Column names (their units in the names).
    """
    from berryshaker.harvest.virtual import harvest_columns

    return [*harvest_columns(), "shaking_frequency_hz", "comb_swing_deg", "finger_amplitude_mm", "replicates"]


def tidy_rows(params: list[SweepParam], points: list[list[float]], results: list[RunResult]) -> tuple[list, list]:
    """A tidy results table: one row per run, parameter columns (their units), status, outputs.

    Parameters
    ----------
    params : list of SweepParam
        The swept parameters.
    points : list of list of float
        The sampled points, in each parameter's unit.
    results : list of RunResult
        The runs, in the points' order.

    Returns
    -------
    header : list of str
        Column names (parameters with their units, outputs with theirs in the name).
    rows : list of list
        One row per run.
    """
    header = ["run"] + [f"{p.key}[{p.unit}]" if p.unit else p.key for p in params] + ["status", "error"]
    out_cols: list[str] = []
    rows = []
    for i, (pt, r) in enumerate(zip(points, results)):
        vals = {}
        if r.value:
            for pair, s in r.value.get("collision_force_N", {}).items():
                if "static_equivalent" in s:  # the sizing load (multibody); "peak" is the run's extreme
                    vals[f"collision_force_{pair}_static_equivalent_N"] = s["static_equivalent"]
                for stat in ("peak", "mean", "rms"):
                    vals[f"collision_force_{pair}_{stat}_N"] = s[stat]
            for side, s in r.value.get("load_moment_Nm", {}).items():
                vals[f"load_moment_{side}_peak_Nm"] = s["peak"]
                vals[f"load_moment_{side}_rms_Nm"] = s["rms"]
            d = r.value.get("drive_moment_Nm", {})
            if d:
                if "design" in d:  # the design torque (multibody); "peak" is the run's extreme
                    vals["drive_moment_design_Nm"] = d["design"]
                vals["drive_moment_peak_Nm"], vals["drive_moment_rms_Nm"] = d["peak"], d["rms"]
            if r.value.get("driveline_mode") == "powered":  # powered driveline (drives/powered.py)
                vals["cam_speed_mean_rpm"] = r.value["cam_speed_rpm"]["mean"]
                vals["speed_ripple_percent"] = r.value["speed_ripple_percent"]
                vals["input_power_W"] = r.value["input_power_W"]
                for name, e in r.value["energy_per_revolution_J"].items():
                    vals[f"energy_lost_{name.replace(' ', '_')}_J_per_rev"] = e
            for key in harvest_output_columns():  # --model harvest
                if key in r.value:
                    vals[key] = r.value[key]
        for k in vals:
            if k not in out_cols:
                out_cols.append(k)
        rows.append((i + 1, pt, "failed" if r.error else "ok", r.error or "", vals))
    table = [[i, *pt, status, error, *[vals.get(c, "") for c in out_cols]] for i, pt, status, error, vals in rows]
    return header + out_cols, table
