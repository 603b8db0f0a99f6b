"""Field tests: ``doe plan|analyze|virtual``."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer
from rich.table import Table

from berryshaker import __version__
from berryshaker.errors import BerryshakerError
from berryshaker.report.files import write_provenance
from berryshaker.cli.app import (
    ConfigOpt,
    JsonOpt,
    command,
    doe_app,
    err,
    out,
    _fail,
    _load,
    _print_json,
)


def _parse_weights(text: Optional[str]) -> Optional[dict]:
    if not text:
        return None
    out = {}
    for part in text.split(","):
        if "=" not in part:
            raise BerryshakerError(f"--weights: {part!r} is not NAME=VALUE")
        k, v = (s.strip() for s in part.split("=", 1))
        try:
            out[k] = float(v)
        except ValueError:
            raise BerryshakerError(f"--weights: {v!r} is not a number") from None
        if out[k] < 0:
            raise BerryshakerError(f"--weights: {k} must be >= 0")
    return out


@command(doe_app, "plan")
def doe_plan(
    array: str = typer.Option("L9", "--array", help="L4, L8, L9, L16, L18 or L27."),
    factor: list[str] = typer.Option(..., "--factor", help="NAME=v1,v2,v3[unit], e.g. A=0.25,0.5,0.75mm; repeat."),
    randomize: bool = typer.Option(False, "--randomize", help="Randomise the run order (needs --seed)."),
    seed: Optional[int] = typer.Option(None, "--seed", help="Seed of the randomised order."),
    out_file: Path = typer.Option(..., "--out", "-o", help="Field sheet CSV; a printable .html is written beside it."),
):
    """Write a field sheet: run, run order, factor levels (units in the header), empty response columns."""
    try:
        from berryshaker.experiment.field_sheet import parse_factor, plan_html, plan_table
        from berryshaker.report.files import write_text_atomic

        factors = [parse_factor(f) for f in factor]
        names = [f.name for f in factors]
        if len(set(names)) != len(names):
            raise BerryshakerError("factor names must be distinct")
        df = plan_table(array, factors, randomize, seed)
        write_text_atomic(out_file, df.to_csv(index=False))
        write_text_atomic(out_file.with_suffix(".html"), plan_html(df, f"berryshaker field sheet: {array} test of "
                                                                       f"{', '.join(names)}"))
    except BerryshakerError as exc:
        _fail(exc)
        return
    err.print(f"wrote {out_file} and {out_file.with_suffix('.html')} ({len(df)} runs)")


@command(doe_app, "analyze")
def doe_analyze(
    results: Path = typer.Argument(..., help="Filled field sheet (CSV)."),
    maximize: str = typer.Option("", "--maximize", help="Responses where larger is better, e.g. efficiency."),
    minimize: str = typer.Option("", "--minimize", help="Responses where smaller is better, e.g. unripe,damage."),
    weights: Optional[str] = typer.Option(None, "--weights", help="e.g. efficiency=0.5,damage=0.3,unripe=0.2"),
    as_json: bool = JsonOpt,
    plot: Optional[Path] = typer.Option(None, "--plot", help="Main-effect plots and response surfaces (PNG)."),
):
    """Range analysis, weighted optimum, pooled ANOVA and the eq. 19 regression of a field test.

    Responses: efficiency, unripe, damage (from indexes or raw masses in the sheet) or any numeric column.
    """
    try:
        import numpy as np

        from berryshaker.experiment.analysis import analyze
        from berryshaker.experiment.field_sheet import read_results

        senses = {r.strip(): True for r in maximize.split(",") if r.strip()}
        senses.update({r.strip(): False for r in minimize.split(",") if r.strip()})
        if not senses:
            raise BerryshakerError("name at least one response with --maximize or --minimize")
        fr = read_results(results, list(senses))
        df = fr.table
        levels = df[fr.factors].to_numpy(int)
        value_cols = [next((c for c in df.columns if c.startswith(n + "_") and not c.endswith("_level")), None)
                      for n in fr.factor_names]
        values = np.column_stack([df[c].to_numpy(float) if c else levels[:, i] for i, c in enumerate(value_cols)])
        res = analyze(levels, values, fr.factor_names, fr.responses, senses, _parse_weights(weights))
        res["version"] = __version__
        if plot is not None:
            from berryshaker.report.files import staged_directory
            from berryshaker.report.plots import plot_main_effects, plot_response_surfaces

            with staged_directory(plot) as stage:
                plot_main_effects(res, stage / "main_effects.png")
                write_provenance(stage, results_file=str(results))
                from berryshaker.experiment.analysis import quadratic_regression

                for r, y in fr.responses.items():
                    if len(fr.factor_names) >= 2:
                        plot_response_surfaces(values, y, fr.factor_names,
                                               quadratic_regression(values, y, fr.factor_names), r,
                                               stage / f"surface_{r}.png")
            res["plots"] = sorted(str(p) for p in plot.glob("*.png"))
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json(res)
        return
    _print_doe(res)


def _print_doe(res: dict) -> None:
    for name, ra in res["responses"].items():
        t = Table(title=f"{name} ({'maximise' if ra['maximize'] else 'minimise'}): range analysis", header_style="bold")
        t.add_column("factor")
        nlev = len(next(iter(ra["factors"].values()))["level_means"])
        for j in range(nlev):
            t.add_column(f"k{j + 1}", justify="right")
        for col in ("R", "best", "ANOVA F", "p"):
            t.add_column(col, justify="right")
        an = ra["anova"]["factors"]
        for f, d in ra["factors"].items():
            a = an.get(f)
            t.add_row(f, *[f"{v:.4g}" for v in d["level_means"]], f"{d['range']:.4g}", str(d["best_level"]),
                      f"{a['f']:.3g}" if a else "pooled", f"{a['p']:.3g}" if a else "")
        out.print(t)
        reg = ra["regression"]
        out.print(f"  ranking {' > '.join(ra['ranking'])}; eq. 19 full quadratic: rank {reg['full_model_rank']} "
                  f"of {len(reg['full_model_terms'])} terms, aliased: {', '.join(reg['aliased_terms']) or 'none'}; "
                  f"main-effects quadratic R² = {reg['main_effects_quadratic']['r2']:.3f} with "
                  f"{reg['main_effects_quadratic']['residual_df']} residual df")
    o = res["optimum"]
    out.print("[bold]weighted optimum[/]: " + " ".join(f"{f}{lv}" for f, lv in o["levels"].items()) + "  predicted "
              + ", ".join(f"{k} {v:.3g}" for k, v in o["values"].items()))


@command(doe_app, "virtual")
def doe_virtual(
    config: Optional[Path] = ConfigOpt,
    as_json: bool = JsonOpt,
    workers: Optional[int] = typer.Option(None, "--workers", help="Processes (default: all cores)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="Dask scheduler address."),
    cache: Optional[Path] = typer.Option(None, "--cache", help="Run cache folder."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Main-effect plots and response surfaces (PNG)."),
):
    """The study's L9 clearance test run through the virtual harvest and analysed like field data.

    The 27 coupled machine-plant runs go through the cached sweep runner (a repeat is instant).
    """
    try:
        from berryshaker.runs.runner import SweepRunner
        from berryshaker.study.l9 import virtual_l9

        machine = _load(config)
        if machine.plant is None:
            raise BerryshakerError("the virtual test needs a [plant] block in the machine description")
        runner = SweepRunner(workers=workers, scheduler=scheduler, cache_dir=cache, progress=not as_json, console=err)
        res = virtual_l9(machine, runner)
        res["version"] = __version__
        if plot is not None:
            import numpy as np

            from berryshaker.experiment.analysis import quadratic_regression
            from berryshaker.report.files import staged_directory
            from berryshaker.report.plots import plot_main_effects, plot_response_surfaces

            pairs = list(machine.pair_names)
            values = np.array([[r["clearance_mm"][p] for p in pairs] for r in res["runs"]])
            with staged_directory(plot) as stage:
                plot_main_effects(res, stage / "main_effects.png", "Virtual L9 test: main effects")
                write_provenance(stage, machine)
                for r in ("efficiency", "unripe", "damage"):
                    y = np.array([run[r] for run in res["runs"]])
                    plot_response_surfaces(values, y, pairs, quadratic_regression(values, y, pairs),
                                           r, stage / f"surface_{r}.png")
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json(res)
        return
    t = Table(title="Virtual L9 field test", header_style="bold")
    pairs = list(res["runs"][0]["clearance_mm"])
    for col in ("run", *[f"{p} (mm)" for p in pairs], "efficiency", "unripe", "damage"):
        t.add_column(col, justify="right")
    for r in res["runs"]:
        t.add_row(str(r["run"]), *[f"{r['clearance_mm'][p]:g}" for p in pairs], f"{r['efficiency']:.3f} kg/min",
                  f"{r['unripe']:.2f} %", f"{r['damage']:.2f} %")
    out.print(t)
    _print_doe(res)
    rec = res["recommended"]
    out.print(f"recommended {rec['code']} ({', '.join(f'{k} {v} mm' for k, v in rec['clearance_mm'].items())}); "
              f"study: {rec['study']['code']}")
