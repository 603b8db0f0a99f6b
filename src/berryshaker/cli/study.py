"""The whole study (``study``) and parameter sweeps (``sweep``)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from berryshaker import __version__
from berryshaker.cli.app import (
    ConfigOpt,
    JsonOpt,
    _fail,
    _load,
    _print_json,
    app,
    command,
    err,
    out,
    print_table,
)
from berryshaker.errors import BerryshakerError
from berryshaker.reference_study import CHOSEN_CODE, FIELD_RESULT
from berryshaker.user_text import markup_text

#: --scheduler's help: Dask exchanges pickles with the scheduler and its workers
SCHEDULER_HELP = ("Dask scheduler address, e.g. tls://10.0.0.5:8786. Runs and results travel as pickles (code runs "
                  "where they are loaded): give only a scheduler you trust, on a trusted network or over TLS "
                  "(tls://).")
CacheOpt = typer.Option(None, "--cache", help="Run cache folder (default ~/.cache/berryshaker/runs or $BERRYSHAKER_CACHE).")


@command(app)
def study(
    config: Optional[Path] = ConfigOpt,
    out_dir: Path = typer.Option(Path("berryshaker-study"), "--out", help="Output folder: new, empty, or an earlier study's output (then replaced atomically); any other folder is refused."),
    workers: Optional[int] = typer.Option(None, "--workers", help="Local processes (default: every core this process may run on, its CPU affinity)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help=SCHEDULER_HELP),
    cache: Optional[str] = CacheOpt,
    no_cache: bool = typer.Option(False, "--no-cache", help="Recompute every run."),
    as_json: bool = JsonOpt,
):
    """The whole study on the reference machine (or --config): report.html, summary.json, tables, figures.

    --out must be a new or empty folder or the output of an earlier study (it then gets replaced); a folder
    holding anything else is refused before any work, and nothing you made is ever removed.

    The report opens with the design answers for this machine (clearance and fit per joint, service interval, peak
    forces, drive torque, operating speed, each with its interval), then one section per step: kinematics; the
    reduced model against the multibody engine; collision force against clearance; comb load moments; fruit force;
    the virtual L9 field test from independent starts analysed as blocks; clearance life; the powered drive;
    harvest against shaking frequency; the harvest model against the published record.  On the study's own machine
    an appendix checks the study's claims.  Interrupted? Run it again: finished runs come from the cache.
    \f

    Parameters
    ----------
    config : Path, optional
        ``--config``: Machine description (TOML). Default: built-in reference machine.
    out_dir : Path
        ``--out``: Output folder: new, empty, or an earlier study's output (then replaced atomically); any other
        folder is refused.
    workers : int, optional
        ``--workers``: Local processes (default: every core this process may run on, its CPU affinity).
    scheduler : str, optional
        ``--scheduler``: Dask scheduler address, e.g. tls://10.0.0.5:8786. Runs and results travel as pickles (code
        runs where they are loaded): give only a scheduler you trust, on a trusted network or over TLS (tls://).
    cache : str, optional
        ``--cache``: Run cache folder (default ~/.cache/berryshaker/runs or $BERRYSHAKER_CACHE).
    no_cache : bool
        ``--no-cache``: Recompute every run.
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    """
    runner = None
    try:
        from berryshaker.outputs import prepare_output_dir
        from berryshaker.runs.runner import SweepRunner

        machine = _load(config)  # a config that fails validation stops here, before any simulation
        prepare_output_dir(out_dir, kind="study")  # refuse a folder with the user's files before any work
        if machine.plant is None:
            raise BerryshakerError("the study needs a [plant] block in the machine description")
        runner = SweepRunner(workers=workers, scheduler=scheduler, cache_dir=cache, use_cache=not no_cache,
                             progress=True, console=err)
        from berryshaker.study.pipeline import planned_runs_cached, run_study

        if scheduler:
            runner.check_scheduler()
        elif not planned_runs_cached(machine, runner):
            from berryshaker.study.runs import import_run_modules

            # the workers start and import what their runs need while this process checks the description's
            # geometry (its kernels compiled on a fresh install); with every planned run cached none is started
            runner.start_workers(import_run_modules)
        from berryshaker.drives import drive_of

        drive_of(machine).check(machine)
        summary = run_study(machine, out_dir, runner, console=err)
    except BerryshakerError as exc:
        if runner is not None:
            runner.abort()  # the workers started for the study (a check that failed after they started)
        _fail(exc)
        return
    except BaseException:  # Ctrl-C or a bug: the workers end now, not after their imports
        if runner is not None:
            runner.abort()
        raise
    if as_json:
        _print_json(summary.to_json())
        return
    from rich.text import Text

    from berryshaker.report.design import claims_apply

    if claims_apply(machine):  # the reference study's claims are about its machine (report: an appendix)
        rows = [[str(c.id), Text(c.verdict, style={"reproduced": "green", "not reproduced": "red"}.get(
            c.verdict, "yellow")), c.claim] for c in summary.claims]
        print_table(("#", "verdict", "claim"), rows, title="Claims of the study", justify=("left",) * 3)
    o = summary.optimum
    if o is not None:
        fitted = set(o.fitted)
        iv = o.intervals or {}

        def val(name, value, unit):
            est = iv.get(name)
            text = f"{value:.2f} {unit}" + (f" (SD {est.sd:.2g})" if est else "")
            return text + (" [fitted]" if name in fitted else "")

        out.print(f"recommended {o.code}: " + ", ".join(f"{p} {v:g} mm" for p, v in o.clearance_mm.items())
                  + f" -> {val('efficiency', o.efficiency_kg_min, 'kg/min')}, "
                    f"{val('unripe', o.unripe_rate_pct, '%')} unripe, {val('damage', o.damage_rate_pct, '%')} "
                    f"damage over {o.starts or '?'} starts (study {CHOSEN_CODE}: "
                    f"{FIELD_RESULT['efficiency_kg_min']} kg/min, {FIELD_RESULT['unripe_rate_pct']} %, "
                    f"{FIELD_RESULT['damage_rate_pct']} %" + ("; [fitted]: calibrated to that value here" if fitted
                                                              else "") + ")", markup=False, highlight=False)
    for f in summary.failures:
        out.print(f"[red]failed[/] {markup_text(f.step)} run {f.run} ({markup_text(f.inputs)}): {markup_text(f.error)}")
    out.print(f"report: {out_dir / 'report.html'}  ({summary.timings_s['total']:.0f} s)", markup=False, soft_wrap=True)


#: the harvest indexes a ``--model harvest`` sweep prints per point: column, header (unit)
HARVEST_SHOWN = (("ripe_removal_pct", "ripe removal (%)"), ("unripe_shed_pct", "unripe shedding (%)"),
                 ("damage_rate_pct", "damage (%)"), ("efficiency_kg_min", "efficiency (kg/min)"))


def sweep_display(header: list[str], rows: list[list], n_params: int) -> tuple[list[str], list[list]]:
    """The terminal table of a sweep: run, parameters, status, then the outputs that matter for its model.

    Harvest runs (their columns present) show each point's ripe removal, unripe shedding, damage and efficiency as
    "mean±SD over its replicate starts"; dynamics runs show up to four peak collision forces and the powered
    driveline's speed ripple and input power.

    Parameters
    ----------
    header : list of str
        Column names of the sweep table: run, the ``n_params`` parameters, status, then the outputs.
    rows : list of list
        The sweep table's rows, one per run, in ``header``'s order.
    n_params : int
        Number of swept parameters.

    Returns
    -------
    header : list of str
        The columns shown.
    rows : list of list
        The rows with those columns; harvest outputs as "mean±SD" text (three and two significant digits).
    """
    base = header[: n_params + 2]
    # the sizing loads where the model gives them (multibody: the p95 of the impact peaks), else the run's extremes
    cols = [c for c in header if c.endswith("_static_equivalent_N")][:4] or [c for c in header if c.endswith("_peak_N")][:4]
    cols += [c for c in ("speed_ripple_percent", "input_power_W") if c in header]
    harvest = [(k, h) for k, h in HARVEST_SHOWN if k in header]
    if not harvest:
        show = base + cols
        return show, [[dict(zip(header, row))[c] for c in show] for row in rows]

    def cell(d, k):
        v, sd = d.get(k, ""), d.get(k + "_sd", "")
        if not isinstance(v, (int, float)):
            return ""
        return f"{v:.3g}±{sd:.2g}" if isinstance(sd, (int, float)) else f"{v:.3g}"  # compact: 7 columns in 80

    shown = []
    for row in rows:
        d = dict(zip(header, row))
        shown.append([d[c] for c in base] + [cell(d, k) for k, _ in harvest])
    return base + [h for _, h in harvest], shown


def _harvest_figure(param, points, results, path: Path) -> None:
    """The removal figure of a ``--model harvest`` sweep over one parameter (failed points left out)."""
    from berryshaker.report.plots import plot_harvest_response

    ok = [(pt[0], r.value) for pt, r in zip(points, results) if not r.error and r.value]
    if not ok:
        raise BerryshakerError("--figure: every sweep point failed, nothing to draw")
    label = f"{param.key} [{param.unit}]" if param.unit else f"{param.key} [1]"
    freq = [v["shaking_frequency_hz"] for _, v in ok] if param.key.endswith(".speed") else None
    amp = [v.get("finger_amplitude_mm", float("nan")) for _, v in ok] if freq is None else None
    plot_harvest_response([x for x, _ in ok], [v for _, v in ok], label, path,
                          "virtual harvest against " + param.key, frequency_hz=freq, amplitude_mm=amp)


@command(app)
def sweep(
    param: list[str] = typer.Option(..., "--param", help="KEY=LO..HI unit, KEY=V1,V2,... unit or KEY=MEAN+-SD unit "
                                    "(units on each item allowed: 0.1mm..0.3mm, 0.25mm+-0.05mm); KEY is a dotted path "
                                    "of the machine description, e.g. clearance.A.size, and the values must have its "
                                    "dimension. Repeat for more parameters, each key once."),
    method: str = typer.Option("grid", "--method", help="grid (ranges get --points levels), lhs or montecarlo."),
    points: int = typer.Option(3, "--points", "-n", min=1, help="Grid levels per range, or samples for lhs/montecarlo "
                               "(at most 100,000 runs in all)."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of lhs / montecarlo sampling."),
    model: str = typer.Option("mlsd", "--model", help="mlsd, multibody, or harvest (virtual harvest: ripe removal, "
                              "unripe shedding, damage; coupled machine-plant runs)."),
    revolutions: int = typer.Option(3, "--revolutions", min=2, help="Drive-shaft revolutions per run."),
    driveline: Optional[str] = typer.Option(None, "--driveline",
                                            help="imposed or powered (with --model multibody): powered runs report "
                                                 "cam speed ripple, input power and energy lost per revolution per "
                                                 "joint. Default: the description's [driveline] mode."),
    specialised: Optional[bool] = typer.Option(
        None, "--specialised/--generic",
        help="With --model multibody: integrate with the engine's kernel written for the mechanism's structure "
             "(the same results bit for bit, about a quarter less time per harvester run, 10-20 s of compilation "
             "the first time on this machine, cached after that), or with the generic one. Default: specialised "
             "when it is compiled already or the sweep has at least 600 runs per worker (the environment variable "
             "BERRYSHAKER_KERNEL=generic or specialised decides instead)."),
    config: Optional[Path] = ConfigOpt,
    out_file: Optional[Path] = typer.Option(None, "--out", help="Tidy results table (CSV)."),
    figure: Optional[Path] = typer.Option(None, "--figure", help="With --model harvest and one --param: ripe removal, "
                                          "unripe shedding and damage against it (PNG or SVG)."),
    workers: Optional[int] = typer.Option(None, "--workers", help="Local processes (>= 1; default: every core this process may run on, its CPU affinity)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help=SCHEDULER_HELP),
    cache: Optional[str] = CacheOpt,
    as_json: bool = JsonOpt,
):
    """Factor grid, Latin hypercube or Monte Carlo (tolerances, wear) over any machine parameter.

    Every point's machine is validated like a config file (values, clearance limits, geometry over the cycle)
    before the first run starts; a sweep with an invalid point is refused, listing the points.  Points are
    simulated through the cached sweep runner; a run that fails is recorded with its error and the others
    finish.
    \f

    Parameters
    ----------
    param : list[str]
        ``--param``: KEY=LO..HI unit, KEY=V1,V2,... unit or KEY=MEAN+-SD unit (units on each item allowed:
        0.1mm..0.3mm, 0.25mm+-0.05mm); KEY is a dotted path of the machine description, e.g. clearance.A.size, and
        the values must have its dimension. Repeat for more parameters, each key once.
    method : str
        ``--method``: grid (ranges get --points levels), lhs or montecarlo.
    points : int
        ``--points``: Grid levels per range, or samples for lhs/montecarlo (at most 100,000 runs in all).
    seed : int
        ``--seed``: Seed of lhs / montecarlo sampling.
    model : str
        ``--model``: mlsd, multibody, or harvest (virtual harvest: ripe removal, unripe shedding, damage; coupled
        machine-plant runs).
    revolutions : int
        ``--revolutions``: Drive-shaft revolutions per run.
    driveline : str, optional
        ``--driveline``: imposed or powered (with --model multibody): powered runs report cam speed ripple, input
        power and energy lost per revolution per joint. Default: the description's [driveline] mode.
    specialised : bool, optional
        ``--specialised/--generic``: With --model multibody: integrate with the engine's kernel written for the
        mechanism's structure (the same results bit for bit, about a quarter less time per harvester run, 10-20 s of
        compilation the first time on this machine, cached after that), or with the generic one. Default:
        specialised when it is compiled already or the sweep has at least 600 runs per worker (the environment
        variable BERRYSHAKER_KERNEL=generic or specialised decides instead).
    config : Path, optional
        ``--config``: Machine description (TOML). Default: built-in reference machine.
    out_file : Path, optional
        ``--out``: Tidy results table (CSV).
    figure : Path, optional
        ``--figure``: With --model harvest and one --param: ripe removal, unripe shedding and damage against it (PNG
        or SVG).
    workers : int, optional
        ``--workers``: Local processes (>= 1; default: every core this process may run on, its CPU affinity).
    scheduler : str, optional
        ``--scheduler``: Dask scheduler address, e.g. tls://10.0.0.5:8786. Runs and results travel as pickles (code
        runs where they are loaded): give only a scheduler you trust, on a trusted network or over TLS (tls://).
    cache : str, optional
        ``--cache``: Run cache folder (default ~/.cache/berryshaker/runs or $BERRYSHAKER_CACHE).
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    """
    try:
        from berryshaker.runs.runner import SweepRunner
        from berryshaker.runs.sweep import (
            check_params,
            model_run,
            overrides_of,
            parse_param,
            sample_params,
            tidy_rows,
            validate_points,
        )

        if model not in ("mlsd", "multibody", "harvest"):
            raise BerryshakerError(f"--model {model!r}: choose mlsd, multibody or harvest")
        if driveline is not None and driveline not in ("imposed", "powered"):
            raise BerryshakerError(f"--driveline {driveline!r}: choose imposed or powered")
        if specialised is not None and model != "multibody":
            raise BerryshakerError("--specialised / --generic choose the multibody engine's kernel (the harvest "
                                   "model's coupled runs use the generic one, the MLSD its own): add --model "
                                   "multibody or drop the option")
        if figure is not None:
            from berryshaker.outputs import check_output_file

            if model != "harvest" or len(param) != 1:
                raise BerryshakerError("--figure draws the harvest indexes against one parameter: give --model harvest "
                                       "and exactly one --param")
            check_output_file(figure, allowed_suffixes=(".png", ".svg"))
        # the runner first: its checks (--workers, --scheduler, --cache) before any work
        runner = SweepRunner(workers=workers, scheduler=scheduler, cache_dir=cache, progress=True, console=err)
        if out_file is not None:
            from berryshaker.outputs import check_output_file

            check_output_file(out_file, allowed_suffixes=(".csv",))
        machine = _load(config)
        from berryshaker.drives.powered import is_powered, with_driveline_mode

        if is_powered(with_driveline_mode(machine, driveline)) and model != "multibody":
            raise BerryshakerError("the powered driveline runs in the multibody model: add --model multibody "
                                   "(or --driveline imposed)")
        params = [parse_param(p, machine) for p in param]
        check_params(params)
        pts = sample_params(params, method, points, seed)
        validate_points(machine, params, pts, revolutions)  # every point, before any run
        data = machine.model_dump(mode="json")
        kernel_why, kernel_arg = None, {}
        if model == "multibody":
            if specialised is None:
                from berryshaker.runs.sweep import choose_specialised

                specialised, kernel_why = choose_specialised(data, overrides_of(params, pts[0]), revolutions,
                                                             driveline, len(pts), runner.workers)
            else:
                kernel_why = "--specialised" if specialised else "--generic"
            # compiled already: each run left to choose (a point of another structure does not compile its own)
            from berryshaker.runs.sweep import COMPILED_ALREADY

            kernel_arg = {"specialised": None if kernel_why == COMPILED_ALREADY else specialised}
            err.print(f"multibody kernel: {'specialised' if specialised else 'generic'} ({kernel_why})")
        jobs = [dict(machine_data=data, overrides=overrides_of(params, pt), model=model, revolutions=revolutions,
                     **({"driveline": driveline} if driveline else {}),
                     **kernel_arg) for pt in pts]
        results = runner.map(model_run, jobs, f"sweep ({method}, {len(jobs)} runs)")
        header, rows = tidy_rows(params, pts, results)
        if out_file is not None:
            from berryshaker.report.tables import write_csv

            write_csv(out_file, header, rows)
        if figure is not None:
            _harvest_figure(params[0], pts, results, figure)
    except BerryshakerError as exc:
        _fail(exc)
        return
    failed = sum(1 for r in results if r.error)
    if as_json:
        _print_json({"columns": header, "rows": rows, "failed": failed, "runs": len(rows), "version": __version__,
                     **({"kernel": "specialised" if specialised else "generic", "kernel_reason": kernel_why}
                        if kernel_why else {})})
        return
    show, shown = sweep_display(header, rows[:40], len(params))
    # headers such as "clearance.A.size[mm]" wrap at dots, numbers are never split (the one table writer)
    print_table(show, shown, title=f"sweep: {len(rows)} runs, {failed} failed")
    if len(rows) > 40:
        out.print(f"(first 40 of {len(rows)} runs; --out writes them all)")
    if failed:
        for r in results:
            if r.error:
                out.print(f"[red]run {r.index + 1} failed[/]: {markup_text(r.error)}")
    if out_file is not None:
        out.print(f"wrote {out_file}", markup=False, soft_wrap=True)
    if figure is not None:
        out.print(f"wrote {figure}", markup=False, soft_wrap=True)
