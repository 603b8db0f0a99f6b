"""Clearance over the machine's life: ``fits``, ``wear``, ``sensitivity``, ``tolerance`` (docs/life.md)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Optional

import typer

from berryshaker import __version__
from berryshaker.cli.app import (
    ConfigOpt,
    JsonOpt,
    _load,
    _print_json,
    app,
    check_number,
    check_range,
    command,
    err,
    out,
    print_table,
)
from berryshaker.cli.study import SCHEDULER_HELP
from berryshaker.errors import ConfigError

WorkersOpt = typer.Option(None, "--workers", help="Local processes (default: every core this process may run on, its CPU affinity).")
SchedulerOpt = typer.Option(None, "--scheduler", help=SCHEDULER_HELP)
CacheOpt = typer.Option(None, "--cache", help="Run cache folder (default ~/.cache/berryshaker/runs).")
PlotOpt = typer.Option(None, "--plot", help="Folder for PNG figures: new, empty, or an earlier berryshaker output "
                       "(only this command's own unchanged figures there are replaced).")
#: largest seed (numpy's and SALib's generators take 0 .. 2**32 - 1)
SEED_MAX = 2**32 - 1


def _check_joints(machine, joints, flag: str = "--joint") -> list[str]:
    """The joints named by ``--joint`` (each once, each a clearance pair of the machine), or every pair."""
    pairs = list(machine.pair_names)
    if not joints:
        return pairs
    unknown = [j for j in joints if j not in pairs]
    if unknown:
        raise ConfigError(f"{flag} {', '.join(unknown)}: not a clearance pair of {machine.machine.name}; pairs: "
                          f"{', '.join(pairs)}")
    if len(set(joints)) != len(joints):
        raise ConfigError(f"{flag}: name each joint once, got {', '.join(joints)}")
    return list(joints)


def _staged_plots(plot: Path, kind: str, draw) -> list[str]:
    """Draw figures with ``draw(folder) -> names`` into a staging folder beside ``plot`` and move them in only when
    all succeeded (:func:`berryshaker.outputs.staged_directory`); returns their paths."""
    from berryshaker.outputs import staged_directory

    with staged_directory(plot, kind=kind) as stage:
        names = draw(stage)
    return [str(plot / n) for n in names]


def _check_plot(plot: Optional[Path], kind: str) -> None:
    """Refuse a --plot folder holding files berryshaker did not write, before any work."""
    if plot is not None:
        from berryshaker.outputs import prepare_output_dir

        prepare_output_dir(plot, kind=kind)

_LIMIT_DIMENSION = {"clearance": "length", "design_force": "force", "peak_force": "force", "mean_force": "force"}


def parse_limit(spec: str, machine=None) -> tuple[str, float]:
    """``peak_force:A=8000N``, ``clearance:C=0.5mm`` or ``OUTPUT=VALUE`` -> (key, SI value) for
    :func:`berryshaker.life.wear.wear_life` (a maximum).

    Parameters
    ----------
    spec : str
        ``KIND:JOINT=VALUE`` (kinds of ``_LIMIT_DIMENSION``, the value with its unit, e.g. "0.5mm", "8000N") or
        ``OUTPUT=VALUE`` (a plain number in the output's SI unit).
    machine : MachineBase, optional
        The machine whose clearance pairs ``JOINT`` must name (checked when given).

    Returns
    -------
    (str, float)
        The key (``KIND:JOINT`` or ``OUTPUT``) and the limit in SI (m, N).

    Raises
    ------
    ConfigError
        No ``=``, an unknown kind or joint, or a value that is not a positive number of the kind's dimension
        within berryshaker's bounds (:data:`berryshaker.units.LIMITS`: a limit is a maximum the joint wears
        towards, so 0, a negative or a 1e9 mm limit is a slip, not a plan).
    """
    from berryshaker.units import check_limits, parse_quantity

    if "=" not in spec:
        raise ConfigError(f"--limit {spec!r}: expected KIND:JOINT=VALUE, e.g. clearance:C=0.5mm or peak_force:A=8000N")
    key, value = (s.strip() for s in spec.split("=", 1))
    kind, _, joint = key.partition(":") if ":" in key else ("", "", "")
    if ":" in key and kind not in _LIMIT_DIMENSION:
        raise ConfigError(f"--limit {spec!r}: kind {kind!r} is not one of {', '.join(_LIMIT_DIMENSION)}")
    if kind and machine is not None and joint not in machine.pair_names:
        raise ConfigError(f"--limit {spec!r}: {joint!r} is not a clearance pair of this machine; pairs: "
                          f"{', '.join(machine.pair_names)}")
    dim = _LIMIT_DIMENSION.get(kind)
    try:
        v = parse_quantity(value, dim, field=f"--limit {key}") if dim else float(value)
    except ValueError:
        raise ConfigError(f"--limit {spec!r}: {value!r} is not a number") from None
    if not (math.isfinite(v) and v > 0):
        raise ConfigError(f"--limit {spec!r}: a service limit is a maximum the joint reaches in service: give a "
                          "positive value")
    if dim:
        check_limits(v, dim, f"--limit {key}")
    return key, float(v)


def parse_limits(specs: list[str], machine) -> dict[str, float]:
    """Every ``--limit`` (:func:`parse_limit`), each key once.

    Parameters
    ----------
    specs : list of str
        The ``--limit`` values.
    machine : MachineBase
        The machine (its clearance pairs).

    Returns
    -------
    dict
        Key -> limit (SI).

    Raises
    ------
    ConfigError
        A bad limit, or a key given twice.
    """
    out: dict[str, float] = {}
    for spec in specs:
        key, v = parse_limit(spec, machine)
        if key in out:
            raise ConfigError(f"--limit {key} is given twice; give each limit once")
        out[key] = v
    return out


def _runner(workers, scheduler, cache, progress: bool):
    from berryshaker.runs.runner import SweepRunner

    return SweepRunner(workers=workers, scheduler=scheduler, cache_dir=cache, progress=progress, console=err)


# ---- fits ------------------------------------------------------------------------------------------------
@command(app, "fits")
def fits_cmd(
    spec: str = typer.Argument(..., help="Fit, e.g. H7/f7 (with --diameter), '20 H7/f7', or a range '0.02..0.06 mm'."),
    diameter: Optional[str] = typer.Option(None, "--diameter", "-d", help="Nominal diameter, e.g. 20mm."),
    as_json: bool = JsonOpt,
):
    """Limits and clearance of an ISO 286 fit (diametral; radial = half, the pin-in-bore 'size').
    \f

    Parameters
    ----------
    spec : str
        Argument: Fit, e.g. H7/f7 (with --diameter), '20 H7/f7', or a range '0.02..0.06 mm'.
    diameter : str, optional
        ``--diameter``: Nominal diameter, e.g. 20mm.
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    """
    from berryshaker.life.fits import fit_summary, parse_fit
    from berryshaker.units import parse_quantity

    nominal = parse_quantity(diameter, "length", field="--diameter") * 1e3 if diameter else None
    s = fit_summary(parse_fit(spec, nominal))
    s["version"] = __version__
    if as_json:
        _print_json(s)
        return
    rows = []
    for part in ("hole", "shaft"):
        z = s[part]
        if z:
            rows.append([f"{part} {z['class']}", f"{z['upper_deviation_um']:+g} µm", f"{z['lower_deviation_um']:+g} µm",
                         f"{z['tolerance_um']:g} µm", f"{z['max_size_mm']:.3f} mm", f"{z['min_size_mm']:.3f} mm"])
    print_table(("part", "upper", "lower", "tolerance", "max size", "min size"), rows,
                title=f"fit {s['designation']}" + (f" at {s['nominal_mm']:g} mm" if s["nominal_mm"] else ""))
    out.print(f"{s['kind']} fit ({s['basis']} basis): diametral clearance {s['clearance_min_mm']:.4g} .. "
              f"{s['clearance_max_mm']:.4g} mm (mean {s['clearance_mean_mm']:.4g}); radial "
              f"{s['radial_clearance_min_mm']:.4g} .. {s['radial_clearance_max_mm']:.4g} mm")


# ---- wear ------------------------------------------------------------------------------------------------
def _plot_wear(res: dict, folder: Path) -> list[str]:
    from berryshaker.report.plots.life import plot_clearance_growth

    folder.mkdir(parents=True, exist_ok=True)
    name = "wear_clearance.png"
    plot_clearance_growth(res["joints"], {j: (lim * 1e3 if (lim := res["limits_si"].get(f"clearance:{j}")) is not None
                                              else None) for j in res["joints"]}, folder / name,
                          f"Clearance growth by wear (interval {res['maintenance_interval_h'] or 'not reached'} h)",
                          labels={j: f"{j} ({d['size_convention']})" for j, d in res["joints"].items()}, markers=True)
    return [name]


@command(app, "wear")
def wear_cmd(
    hours: float = typer.Option(2000.0, "--hours", help="Operating hours to simulate."),
    limit: list[str] = typer.Option([], "--limit", help="Service limit, repeatable: clearance:C=0.5mm, design_force:A=8000N (static-equivalent), peak_force:A=8000N, "
                                    "mean_force:B=900N or OUTPUT=VALUE (SI). Default: each joint's service limit, the smaller of its "
                                    "largest test level and 2.5 % of its pin (roller) diameter (docs/life.md)."),
    joint: list[str] = typer.Option([], "--joint", help="Joints that wear (repeatable; default all pairs)."),
    revolutions: int = typer.Option(2, "--revolutions", "-n", min=2, max=200,
                                     help="Drive revolutions per simulation (2..200)."),
    load_direction: str = typer.Option("fixed", "--load-direction", help="Pins: fixed (conservative) or rotating."),
    slip: Optional[float] = typer.Option(None, "--slip", help="Roller slip ratio (default 0.05 [assumed])."),
    from_fit: bool = typer.Option(False, "--from-fit", help="Start from each pair's fit (mean clearance), not its size."),
    cache: Optional[str] = CacheOpt,
    config: Optional[Path] = ConfigOpt,
    as_json: bool = JsonOpt,
    plot: Optional[Path] = PlotOpt,
):
    """Clearance growth of every joint by Archard wear over operating hours and the maintenance interval.

    Simulates the multibody drive, wears the joints (adaptive steps in hours), re-simulates; each simulation is
    cached.  JSON: joints.<name>.hours[], .clearance_mm[], .maintenance_interval_h (null if not reached).
    \f

    Parameters
    ----------
    hours : float
        ``--hours``: Operating hours to simulate (h).
    limit : list[str]
        ``--limit``: Service limit, repeatable: clearance:C=0.5mm, design_force:A=8000N (static-equivalent),
        peak_force:A=8000N, mean_force:B=900N or OUTPUT=VALUE (SI). Default: each joint's service limit, the smaller
        of its largest test level and 2.5 % of its pin (roller) diameter (docs/life.md).
    joint : list[str]
        ``--joint``: Joints that wear (repeatable; default all pairs).
    revolutions : int
        ``--revolutions``: Drive revolutions per simulation (2..200).
    load_direction : str
        ``--load-direction``: Pins: fixed (conservative) or rotating.
    slip : float, optional
        ``--slip``: Roller slip ratio (dimensionless) (default 0.05 [assumed]).
    from_fit : bool
        ``--from-fit``: Start from each pair's fit (mean clearance), not its size.
    cache : str, optional
        ``--cache``: Run cache folder (default ~/.cache/berryshaker/runs).
    config : Path, optional
        ``--config``: Machine description (TOML). Default: built-in reference machine.
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    plot : Path, optional
        ``--plot``: Folder for PNG figures: new, empty, or an earlier berryshaker output (only this command's own
        unchanged figures there are replaced).
    """
    from berryshaker.life.service import machine_wear

    if not (math.isfinite(hours) and 0 < hours <= 1e7):
        raise ConfigError(f"--hours {hours!r}: expected operating hours in (0, 1e7]")
    if slip is not None:
        check_number("--slip", slip, 0.0, 1.0, what="the roller's slip ratio, a fraction")
    _check_plot(plot, "wear --plot")
    machine = _load(config)
    joints = _check_joints(machine, joint)
    limits = parse_limits(limit, machine) if limit else None
    runner = _runner(1, None, cache, progress=False)
    status = err.status("wear: starting")
    if status is not None:
        status.start()
    try:
        res = machine_wear(machine, hours, limits, runner=runner, revolutions=revolutions,
                           load_direction=load_direction, slip=slip, joints=joints, from_fit=from_fit,
                           say=(lambda m: status.update(f"wear: {m}")) if status is not None else None)
    finally:
        if status is not None:
            status.stop()
        runner.close()
    if plot is not None:
        res["figures"] = _staged_plots(plot, "wear --plot", lambda folder: _plot_wear(res, folder))
    if as_json:
        _print_json(res)
        return
    rows = []
    for j, d in res["joints"].items():
        rate = d.get("growth_rate_um_per_h", [math.nan])[0]
        mi = d["maintenance_interval_h"]
        rows.append([j, d["material_pair"], f"{d['clearance_mm'][0]:.4g} mm", f"{d['clearance_mm'][-1]:.4g} mm",
                     f"{rate:.3g} µm/h" if d["wears"] else "does not wear",
                     "" if not d["wears"] else "not reached" if mi is None else f"{mi:.0f} h"])
    print_table(("joint", "material", "start", "end", "growth rate (start)", "maintenance interval"), rows,
                title=f"clearance over {hours:g} h - {machine.machine.name}", justify=("left",) * 2 + ("right",) * 4)
    mi = res["maintenance_interval_h"]
    out.print(f"maintenance interval: {'not reached within the horizon' if mi is None else f'{mi:.0f} h'}"
              + (f" ({res['governing_limit']})" if res["governing_limit"] else "")
              + f"; {res['simulations']} simulations ({res['simulations_from_cache']} from the cache) in "
                f"{res['wall_time_s']:.1f} s; {res['message']}")


# ---- sensitivity -----------------------------------------------------------------------------------------
def _plot_sobol(res: dict, folder: Path) -> list[str]:
    from berryshaker.report.plots.life import plot_sobol, sobol_file_name

    folder.mkdir(parents=True, exist_ok=True)
    names = []
    for o, ind in res["indices"].items():
        name = sobol_file_name(o)
        plot_sobol(ind, o, folder / name)
        names.append(name)
    return names


@command(app, "sensitivity")
def sensitivity_cmd(
    output: list[str] = typer.Option([], "--output", help="Output name, repeatable (default: every pair's "
                                     "static-equivalent collision force, collision_force_<pair>_static_equivalent, with "
                                     "--model multibody; the reduced model's peak, collision_force_<pair>_peak)."),
    param: list[str] = typer.Option([], "--param", help="KEY=LO..HI[unit], repeatable, e.g. "
                                    "clearance.A.size=0.1..0.8mm (default: every pair over its test levels)."),
    samples: int = typer.Option(64, "--samples", "-N", help="Base sample N (power of two); runs = N (D + 2)."),
    model: Optional[str] = typer.Option(None, "--model", help="mlsd (default where the drive has it) or multibody."),
    revolutions: int = typer.Option(2, "--revolutions", "-n", min=2, max=200, help="Drive revolutions per run (2..200)."),
    seed: int = typer.Option(0, "--seed"),
    workers: Optional[int] = WorkersOpt,
    scheduler: Optional[str] = SchedulerOpt,
    cache: Optional[str] = CacheOpt,
    config: Optional[Path] = ConfigOpt,
    as_json: bool = JsonOpt,
    plot: Optional[Path] = PlotOpt,
):
    """Sobol sensitivity indices (S1, ST with 95 % confidence) of outputs to clearances and named parameters.
    \f

    Parameters
    ----------
    output : list[str]
        ``--output``: Output name, repeatable (default: every pair's static-equivalent collision force,
        collision_force_<pair>_static_equivalent, with --model multibody; the reduced model's peak,
        collision_force_<pair>_peak).
    param : list[str]
        ``--param``: KEY=LO..HI[unit], repeatable, e.g. clearance.A.size=0.1..0.8mm (default: every pair over its
        test levels).
    samples : int
        ``--samples``: Base sample N (power of two); runs = N (D + 2).
    model : str, optional
        ``--model``: mlsd (default where the drive has it) or multibody.
    revolutions : int
        ``--revolutions``: Drive revolutions per run (2..200).
    seed : int
        ``--seed``: Seed of the Sobol sequence and the bootstrap (0 .. 2**32 - 1).
    workers : int, optional
        ``--workers``: Local processes (default: every core this process may run on, its CPU affinity).
    scheduler : str, optional
        ``--scheduler``: Dask scheduler address, e.g. tls://10.0.0.5:8786. Runs and results travel as pickles (code
        runs where they are loaded): give only a scheduler you trust, on a trusted network or over TLS (tls://).
    cache : str, optional
        ``--cache``: Run cache folder (default ~/.cache/berryshaker/runs).
    config : Path, optional
        ``--config``: Machine description (TOML). Default: built-in reference machine.
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    plot : Path, optional
        ``--plot``: Folder for PNG figures: new, empty, or an earlier berryshaker output (only this command's own
        unchanged figures there are replaced).
    """
    from berryshaker.drives import drive_of
    from berryshaker.life.sensitivity import default_clearance_params, machine_sobol, parse_sensitivity_param

    check_range("--seed", seed, 0, SEED_MAX, "the seed of the Sobol sequence and the bootstrap")
    check_range("--samples", samples, 2, 2**16, "the base sample N, a power of two; runs = N (D + 2)")
    _check_plot(plot, "sensitivity --plot")
    machine = _load(config)
    if model is None:
        model = "mlsd" if drive_of(machine).reduced_model is not None else "multibody"
    params = [parse_sensitivity_param(p) for p in param] if param else default_clearance_params(machine)
    # the multibody runs' sizing load of the impacts; the reduced model has no impacts to count: its peak
    stat = "static_equivalent" if model == "multibody" else "peak"
    outputs = output or [f"collision_force_{p}_{stat}" for p in machine.pair_names]
    with _runner(workers, scheduler, cache, progress=True) as runner:
        res = machine_sobol(machine, params, outputs, samples, runner, model, revolutions, seed)
        res["runner"] = runner.summary_line()
    res["version"] = __version__
    if plot is not None:
        res["figures"] = _staged_plots(plot, "sensitivity --plot", lambda folder: _plot_sobol(res, folder))
    for o in res["indices"]:  # on stderr with --json too: the JSON's numbers are read with them
        rz = res["resolution"][o]
        if rz["unresolved"]:
            err.print(f"warning: N = {samples} does not resolve {len(rz['unresolved'])} index(es) of {o} (95 % "
                      f"half-width above 0.1, or the estimate outside 0..1 beyond its interval): "
                      f"{'; '.join(rz['unresolved'])}. Try -N {rz['suggested_samples']} "
                      f"({rz['suggested_samples'] * (len(res['parameters']) + 2)} runs).", markup=False, highlight=False)
        if rz["negative_within_noise"]:
            err.print(f"note: negative estimates of {o} are sampling noise around 0 (a Sobol index is >= 0): "
                      f"{'; '.join(rz['negative_within_noise'])}.", markup=False, highlight=False)
    if as_json:
        _print_json(res)
        return
    for o, ind in res["indices"].items():
        unit = res["output_unit"].get(o, "")
        u = f" {unit}" if unit else " (unit not known from the name)"

        def f(x):
            return "n/a" if x is None else f"{x:.3f}"

        print_table(("parameter", "S1 (1)", "± 95 %", "ST (1)", "± 95 % "),
                    [[k, f(v["S1"]), f(v["S1_conf"]), f(v["ST"]), f(v["ST_conf"])] for k, v in ind.items()],
                    title=f"{o}: mean {res['output_mean'][o]:.4g}{u}, sd {res['output_std'][o]:.3g}{u}")
    out.print("S1, ST and their 95 % bootstrap half-widths are shares of the output's variance (1, dimensionless); "
              "parameters are sampled uniformly over: " + ", ".join(
                  f"{p['key']} {p['lo_display']:g}..{p['hi_display']:g} {p['unit']}".rstrip()
                  for p in res["parameters"]), markup=False, highlight=False)
    out.print(f"{res['runs']} {model} runs (N = {samples}); {res['runner']}")


# ---- tolerance -------------------------------------------------------------------------------------------
def _plot_front(res: dict, folder: Path) -> list[str]:
    from berryshaker.report.plots.life import plot_fit_front

    folder.mkdir(parents=True, exist_ok=True)
    name = "tolerance_pareto.png"
    plot_fit_front(res["front"], res["recommended"], folder / name)
    return [name]


@command(app, "tolerance")
def tolerance_cmd(
    fits: str = typer.Option(",".join(("H7/g6", "H7/f7", "H8/f7", "H8/e8", "H9/d9", "H11/c11")), "--fits",
                             help="Candidate fits, comma-separated."),
    joint: list[str] = typer.Option([], "--joint", help="Joints to design (repeatable; default all pairs)."),
    limit: list[str] = typer.Option([], "--limit", help="Clearance limit for the life objective, clearance:C=0.3mm "
                                    "(repeatable; default each joint's service limit, docs/life.md)."),
    points: int = typer.Option(4, "--points", help="Surrogate grid clearances per joint (multibody runs each)."),
    revolutions: int = typer.Option(2, "--revolutions", "-n", min=2, max=200, help="Drive revolutions per run (2..200)."),
    pop_size: int = typer.Option(60, "--pop-size"),
    generations: int = typer.Option(80, "--generations"),
    seed: int = typer.Option(1, "--seed"),
    workers: Optional[int] = WorkersOpt,
    scheduler: Optional[str] = SchedulerOpt,
    cache: Optional[str] = CacheOpt,
    config: Optional[Path] = ConfigOpt,
    as_json: bool = JsonOpt,
    plot: Optional[Path] = PlotOpt,
):
    """Choose a fit per joint: Pareto front of cost, static-equivalent collision force and life (NSGA-II on a cached surrogate
    of a few multibody runs per joint) and the recommended fit specification.
    \f

    Parameters
    ----------
    fits : str
        ``--fits``: Candidate fits, comma-separated.
    joint : list[str]
        ``--joint``: Joints to design (repeatable; default all pairs).
    limit : list[str]
        ``--limit``: Clearance limit for the life objective, clearance:C=0.3mm (repeatable; default each joint's
        service limit, docs/life.md).
    points : int
        ``--points``: Surrogate grid clearances per joint (multibody runs each).
    revolutions : int
        ``--revolutions``: Drive revolutions per run (2..200).
    pop_size : int
        ``--pop-size``: NSGA-II population size (2 .. 10000).
    generations : int
        ``--generations``: NSGA-II generations (1 .. 100000).
    seed : int
        ``--seed``: Seed of NSGA-II (0 .. 2**32 - 1).
    workers : int, optional
        ``--workers``: Local processes (default: every core this process may run on, its CPU affinity).
    scheduler : str, optional
        ``--scheduler``: Dask scheduler address, e.g. tls://10.0.0.5:8786. Runs and results travel as pickles (code
        runs where they are loaded): give only a scheduler you trust, on a trusted network or over TLS (tls://).
    cache : str, optional
        ``--cache``: Run cache folder (default ~/.cache/berryshaker/runs).
    config : Path, optional
        ``--config``: Machine description (TOML). Default: built-in reference machine.
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    plot : Path, optional
        ``--plot``: Folder for PNG figures: new, empty, or an earlier berryshaker output (only this command's own
        unchanged figures there are replaced).
    """
    from berryshaker.life.tolerance import tolerance_design

    check_range("--pop-size", pop_size, 2, 10_000, "the NSGA-II population")
    check_range("--generations", generations, 1, 100_000, "NSGA-II generations")
    check_range("--points", points, 2, 64, "surrogate grid clearances per joint, one multibody run each")
    check_range("--seed", seed, 0, SEED_MAX, "the NSGA-II seed")
    _check_plot(plot, "tolerance --plot")
    machine = _load(config)
    lims = {}
    for key, v in parse_limits(limit, machine).items():
        kind, _, j = key.partition(":")
        if kind != "clearance" or not j:
            raise ConfigError(f"--limit {key}: tolerance takes clearance limits, clearance:<joint>=VALUE")
        lims[j] = v
    with _runner(workers, scheduler, cache, progress=True) as runner:
        design = tolerance_design(machine, runner, joint or None, [f.strip() for f in fits.split(",") if f.strip()],
                                  lims, points, revolutions, pop_size, generations, seed)
        res = design.to_dict()
        res["runner"] = runner.summary_line()
    res["version"] = __version__
    if plot is not None:
        res["figures"] = _staged_plots(plot, "tolerance --plot", lambda folder: _plot_front(res, folder))
    if as_json:
        _print_json(res)
        return
    from berryshaker.life.service_life import DESIGN_LIFE_H

    def hours(h):  # never a number beyond the machine's design life
        return f"{h:.0f} h" if h <= DESIGN_LIFE_H else f"> {DESIGN_LIFE_H:,.0f} h"

    rows = [[f"{k + 1}" + (" *" if k == res["recommended"]["index"] else ""), *[d["fits"][j] for j in design.joints],
             f"{d['cost']:.2f}", f"{d['design_force_N']:.0f} N", hours(d["life_h"])] for k, d in enumerate(res["front"])]
    print_table(["#"] + design.joints + ["cost", "static-equivalent force", "interval"], rows,
                title="Pareto front (cost, static-equivalent collision force, maintenance interval)",
                justify=["right"] * (len(design.joints) + 4))
    rows = [[j, f"Ø{d['diameter_mm']:g} {d['fit']}", f"{d['clearance_min_mm']:.3f}..{d['clearance_max_mm']:.3f} mm",
             f"{d['size_mm']:.4f} mm {d['size_convention']}", f"{d['design_force_N']:.0f} N",
             f"{hours(d['maintenance_interval_h'])} to {d['clearance_limit_mm']:g} mm"]
            for j, d in res["recommended"]["joints"].items()]
    print_table(("joint", "fit", "clearance (diametral)", "size", "static-equivalent force", "interval to limit"), rows,
                title="recommended fit specification (*)", justify=("left",) * 2 + ("right",) * 4)
    for n in res["notes"]:
        out.print(f"- {n}", markup=False)
    out.print(res["runner"])
