"""Field tests: ``doe plan|analyze|virtual``."""

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
    command,
    doe_app,
    err,
    out,
    print_table,
)
from berryshaker.cli.doe_print import _print_doe
from berryshaker.cli.study import SCHEDULER_HELP
from berryshaker.errors import BerryshakerError
from berryshaker.outputs import write_provenance


def _parse_weights(text: Optional[str]) -> Optional[dict]:
    """``efficiency=0.5,damage=0.3`` -> {"efficiency": 0.5, "damage": 0.3}; the values are checked by
    :func:`berryshaker.experiment.analysis.check_weights` (finite, > 0, analysed responses only)."""
    if text is None:
        return None
    weights: dict[str, float] = {}
    for part in text.split(","):
        if not part.strip():
            continue
        if "=" not in part:
            raise BerryshakerError(f"--weights: {part.strip()!r} is not NAME=VALUE, e.g. efficiency=0.5,damage=0.3")
        k, v = (x.strip() for x in part.split("=", 1))
        if k in weights:
            raise BerryshakerError(f"--weights: {k} is given twice ({k}={weights[k]:g} and {k}={v}); give each "
                                   "response once")
        try:
            weights[k] = float(v)
        except ValueError:
            raise BerryshakerError(f"--weights: {k}={v!r}: {v!r} is not a number") from None
    return weights


def _senses(maximize: str, minimize: str) -> dict[str, bool]:
    up = [r.strip() for r in maximize.split(",") if r.strip()]
    down = [r.strip() for r in minimize.split(",") if r.strip()]
    both = sorted(set(up) & set(down))
    if both:
        raise BerryshakerError(f"{', '.join(both)} is named in both --maximize and --minimize; name it once")
    senses = {r: True for r in up}
    senses.update({r: False for r in down})
    if not senses:
        raise BerryshakerError("name at least one response with --maximize or --minimize, e.g. "
                               "--maximize efficiency --minimize unripe,damage")
    return senses


def _plan_paths(out_file: Path) -> tuple[Path, Path]:
    """Field sheet CSV and printable HTML from one --out: ``plan``, ``plan.csv`` or ``plan.html`` all give
    ``plan.csv`` + ``plan.html`` (the CSV is never overwritten by the HTML)."""
    if out_file.is_dir():
        raise BerryshakerError(f"--out {out_file} is a folder; give a file name, e.g. {out_file / 'plan.csv'}")
    ext = out_file.suffix.lower()
    if ext not in ("", ".csv", ".html", ".htm"):
        raise BerryshakerError(f"--out {out_file}: name the field sheet *.csv (the printable *.html is written "
                               "beside it)")
    stem = out_file.with_suffix("") if ext else out_file
    return stem.with_name(stem.name + ".csv"), stem.with_name(stem.name + ".html")


#: replicates of a field sheet when neither --replicates nor --config says: three repeats of every run give the
#: blocked analysis 2 (runs - 1) error degrees of freedom (16 for an L9)
FIELD_REPLICATES = 3


def _check_replicates(replicates: int, what: str) -> None:
    """Refuse ``--replicates`` above harvest.replicates' own bound (``harvest.spec.MAX_COUNT``) before any work."""
    from berryshaker.harvest.spec import MAX_COUNT

    if replicates > MAX_COUNT:
        raise BerryshakerError(f"--replicates {replicates:,}: at most {MAX_COUNT:,} replicates per run (each replicate "
                               f"multiplies the {what}; as for harvest.replicates, more is a slip of the number, "
                               "not a plan)")


@command(doe_app, "plan")
def doe_plan(
    array: str = typer.Option("L9", "--array", help="L4, L8, L9, L16, L18 or L27."),
    factor: list[str] = typer.Option(..., "--factor", help="NAME=v1,v2,v3[unit], e.g. A=0.25,0.5,0.75mm; "
                                     "repeat."),
    randomize: bool = typer.Option(False, "--randomize", help="Randomise the test order of the runs within each "
                                   "replicate (needs --seed): replicate k is tested whole before replicate k + 1, as "
                                   "`doe analyze` reads it as block k (a field day, a row of bushes)."),
    replicates: Optional[int] = typer.Option(None, "--replicates", min=1, help="Times each run is tested (rows = runs "
                                             "x replicates, numbered in a 'replicate' column; >= 2 lets `doe analyze` "
                                             "judge effects against the replicate spread). Default: harvest.replicates "
                                             "of --config (the virtual harvest's starts), else 3."),
    config: Optional[Path] = typer.Option(None, "--config", "-c", help="Machine description whose "
                                          "harvest.replicates is the default of --replicates."),
    seed: Optional[int] = typer.Option(None, "--seed", help="Seed of the randomised order (an integer >= 0)."),
    out_file: Path = typer.Option(..., "--out", "-o", help="Field sheet: NAME.csv, and the printable NAME.html "
                                  "beside it (--out NAME.html gives the same two files)."),
    force: bool = typer.Option(False, "--force", help="Replace existing sheets of that name."),
):
    """Write a field sheet: run, replicate, test order, factor levels (units in the header), empty response
    columns; one row per run and replicate.
    \f

    Parameters
    ----------
    array : str
        ``--array``: L4, L8, L9, L16, L18 or L27.
    factor : list[str]
        ``--factor``: NAME=v1,v2,v3[unit], e.g. A=0.25,0.5,0.75mm; repeat.
    randomize : bool
        ``--randomize``: Randomise the test order of the runs within each replicate (needs --seed): replicate k is
        tested whole before replicate k + 1, as `doe analyze` reads it as block k (a field day, a row of bushes).
    replicates : int, optional
        ``--replicates``: Times each run is tested (rows = runs x replicates, numbered in a 'replicate' column; >= 2
        lets `doe analyze` judge effects against the replicate spread). Default: harvest.replicates of --config (the
        virtual harvest's starts), else 3.
    config : Path, optional
        ``--config``: Machine description whose harvest.replicates is the default of --replicates.
    seed : int, optional
        ``--seed``: Seed of the randomised order (an integer >= 0).
    out_file : Path
        ``--out``: Field sheet: NAME.csv, and the printable NAME.html beside it (--out NAME.html gives the same two
        files).
    force : bool
        ``--force``: Replace existing sheets of that name.
    """
    try:
        import hashlib

        from berryshaker.experiment.field_sheet import parse_factor, plan_html, plan_table
        from berryshaker.outputs import check_forced_pair, check_output_file, stamp_html, write_files_atomic
        from berryshaker.report.tables import csv_text as table_csv_text

        if seed is not None and seed < 0:
            raise BerryshakerError(f"--seed {seed}: the seed must be an integer >= 0")
        csv_path, html_path = _plan_paths(out_file)
        factors = [parse_factor(f) for f in factor]
        names = [f.name for f in factors]
        if len(set(names)) != len(names):
            raise BerryshakerError("factor names must be distinct")
        check_output_file(csv_path, allowed_suffixes=(".csv",), overwrite=force)
        check_output_file(html_path, allowed_suffixes=(".html",), overwrite=force)
        if force:  # the named file may be replaced; the other only if it is this command's own, unchanged
            check_forced_pair(out_file, csv_path, html_path, "doe plan")
        if replicates is None:
            harvest = _load(config).harvest if config is not None else None
            replicates = harvest.replicates if harvest is not None else FIELD_REPLICATES
        _check_replicates(replicates, "rows of the field sheet: it is printed and filled in by hand")
        df = plan_table(array, factors, randomize, seed, replicates=replicates)
        csv_text = table_csv_text(list(df.columns), df.itertuples(index=False, name=None))  # cells neutralised
        page = stamp_html(plan_html(df, f"berryshaker field sheet: {array} test of {', '.join(names)}"), "doe plan",
                          {"csv": hashlib.sha256(csv_text.encode("utf-8")).hexdigest()})
        write_files_atomic({csv_path: csv_text.encode("utf-8"), html_path: page.encode("utf-8")})  # both or neither
    except BerryshakerError as exc:
        _fail(exc)
        return
    err.print(f"wrote {csv_path} and {html_path} ({df['run'].nunique()} runs x {replicates} replicate(s) = "
              f"{len(df)} rows)", markup=False, highlight=False)


#: resolution of the figures embedded in ``doe analyze --out *.html`` (sharp on screen and on A4; --plot keeps 300 dpi)
PAGE_DPI = 150

SHEET_HELP = ("The worksheet of an .xlsx workbook, by the name on its tab (default: the first worksheet). Cells are "
              "read as strictly as a CSV's: a formula is an error naming the cell (paste the values), a date or a "
              "boolean is refused where a number belongs.")

DESIRABILITY_HELP = ("Derringer-Suich desirability optimiser beside the weighted optimum: per response a goal and its "
                     "limits with the response's unit, e.g. efficiency=max:2..5kg/min,damage=min:0..5%,"
                     "unripe=target:1..2..4% (d = 0 outside the limits, 1 at or beyond the better one; D their "
                     "geometric mean, maximised over every level set of the factors).")


@command(doe_app, "analyze")
def doe_analyze(
    results: Path = typer.Argument(..., help="Filled field sheet (CSV or .xlsx): `doe plan` columns, plain factor "
                                   "columns holding level values, or a statistics package's worksheet (Minitab: "
                                   "StdOrder, RunOrder, PtType, Blocks are bookkeeping; repeated settings are "
                                   "replicates; units in the header, e.g. 'Speed (rpm)')."),
    sheet: Optional[str] = typer.Option(None, "--sheet", help=SHEET_HELP),
    maximize: str = typer.Option("", "--maximize", help="Responses where larger is better, e.g. efficiency."),
    minimize: str = typer.Option("", "--minimize", help="Responses where smaller is better, e.g. unripe,damage."),
    weights: Optional[str] = typer.Option(None, "--weights", help="Weights of the composite score, e.g. "
                                          "efficiency=0.5,damage=0.3,unripe=0.2 (each > 0; a response left out "
                                          "gets no weight). Default: equal weights."),
    desirability: Optional[str] = typer.Option(None, "--desirability", help=DESIRABILITY_HELP),
    as_json: bool = JsonOpt,
    plot: Optional[Path] = typer.Option(None, "--plot", help="Main-effect plots and response surfaces (PNG)."),
    report: Optional[Path] = typer.Option(None, "--out", "-o", help="Write the analysis to a file: *.html "
                                          "(printable, self-contained: figures embedded, ANOVA tables, the optimum's "
                                          "intervals) or *.json."),
    force: bool = typer.Option(False, "--force", help="Replace an existing --out file."),
):
    """Range analysis, weighted optimum, ANOVA and the eq. 19 regression of a field test.

    Responses: efficiency, unripe, damage (from indexes or raw masses in the sheet) or any numeric column.  A
    sheet with a 'block' column (a field day or row shared by every run) or a 'replicate' column (`doe plan
    --replicates`, >= 2 per run) is analysed as randomised complete blocks, as the virtual L9: effects tested
    against the run x block interaction, paired differences between levels with their standard errors, 95 %
    intervals, and an optimum that leaves a factor at "no meaningful difference" where no weighted response
    differs significantly (--json: replicated, text, block_column).  Replicate numbers that are not real blocks
    cost the analysis r - 1 error degrees of freedom and nothing else.  A replicated sheet that lost plots (a blank
    response cell, a deleted row) is analysed by least squares on the plots present (Type II sums of squares,
    least-squares level means; the lost plots and error degrees of freedom are stated, --json: lost_plots).
    Without replicates the weakest factor is pooled into the error.  A sheet too small to analyse (one run, a factor
    with one level, no error degrees of freedom) is refused with the reason.
    \f

    Parameters
    ----------
    results : Path
        Argument: Filled field sheet (CSV or .xlsx): `doe plan` columns, plain factor columns holding level values,
        or a statistics package's worksheet (Minitab: StdOrder, RunOrder, PtType, Blocks are bookkeeping; repeated
        settings are replicates; units in the header, e.g. 'Speed (rpm)').
    sheet : str, optional
        ``--sheet``: The worksheet of an .xlsx workbook, by the name on its tab (default: the first worksheet).
        Cells are read as strictly as a CSV's: a formula is an error naming the cell (paste the values), a date or
        a boolean is refused where a number belongs.
    maximize : str
        ``--maximize``: Responses where larger is better, e.g. efficiency.
    minimize : str
        ``--minimize``: Responses where smaller is better, e.g. unripe,damage.
    weights : str, optional
        ``--weights``: Weights of the composite score, e.g. efficiency=0.5,damage=0.3,unripe=0.2 (each > 0; a
        response left out gets no weight). Default: equal weights.
    desirability : str, optional
        ``--desirability``: Derringer-Suich desirability optimiser beside the weighted optimum: per response a goal
        and its limits with the response's unit, e.g. efficiency=max:2..5kg/min,damage=min:0..5%,
        unripe=target:1..2..4% (d = 0 outside the limits, 1 at or beyond the better one; D their geometric mean,
        maximised over every level set of the factors).
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    plot : Path, optional
        ``--plot``: Main-effect plots and response surfaces (PNG).
    report : Path, optional
        ``--out``: Write the analysis to a file: ``*.html`` (printable, self-contained: figures embedded, ANOVA
        tables, the optimum's intervals) or ``*.json``.
    force : bool
        ``--force``: Replace an existing --out file.
    """
    try:
        from berryshaker.experiment.field_results import analyze_sheet

        if report is not None:
            from berryshaker.outputs import check_output_file

            if report.is_dir():
                raise BerryshakerError(f"--out {report} is a folder; give a file name, e.g. "
                                       f"{report / 'analysis.html'}")
            check_output_file(report, allowed_suffixes=(".html", ".json"), overwrite=force)
        if plot is not None:
            from berryshaker.outputs import prepare_output_dir

            prepare_output_dir(plot, kind="doe analyze --plot")
        senses = _senses(maximize, minimize)
        fr, res = analyze_sheet(results, senses, _parse_weights(weights), sheet=sheet, desirability=desirability)
        extra: dict = {"results_file": str(results), "version": __version__}  # the JSON's keys after the analysis'
        if plot is not None:
            from berryshaker.outputs import staged_directory
            from berryshaker.report.plots import write_doe_figures
            from berryshaker.report.table_files import write_doe_tables

            with staged_directory(plot, kind="doe analyze --plot") as stage:
                write_doe_figures(fr, res, stage)
                write_doe_tables(res, stage)
                write_provenance(stage, results_file=str(results))
            extra["plots"] = sorted(str(p) for p in plot.glob("*.png"))
        if report is not None:
            from berryshaker.outputs import provenance, write_json_atomic, write_text_atomic

            if report.suffix.lower() == ".json":
                write_json_atomic(report, {**res.to_json(), **extra, "provenance": provenance(results_file=str(results))})
            else:
                import tempfile

                from berryshaker.report.doe_page import doe_report
                from berryshaker.report.plots import write_doe_figures
                from berryshaker.report.plots.figure_files import figure_output

                with tempfile.TemporaryDirectory(prefix="berryshaker-doe-") as figs:  # embedded, then removed
                    with figure_output(dpi=PAGE_DPI, svg=False):
                        write_doe_figures(fr, res, Path(figs))
                    page = doe_report(res, f"Field test analysis: {results.name}", results_file=str(results),
                                      version=__version__, figures=Path(figs))
                write_text_atomic(report, page)
            extra["out"] = str(report)
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json({**res.to_json(), **extra})
        return
    _print_doe(res)
    for p in extra.get("plots", []):
        err.print(f"wrote {p}", markup=False, highlight=False)
    if extra.get("out"):
        err.print(f"wrote {extra['out']}", markup=False, highlight=False)


@command(doe_app, "virtual")
def doe_virtual(
    config: Optional[Path] = ConfigOpt,
    as_json: bool = JsonOpt,
    workers: Optional[int] = typer.Option(None, "--workers", help="Processes (default: every core this process may run on, its CPU affinity)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help=SCHEDULER_HELP),
    cache: Optional[str] = typer.Option(None, "--cache", help="Run cache folder."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Main-effect plots and response surfaces (PNG)."),
    replicates: Optional[int] = typer.Option(None, "--replicates", min=2,
                                             help="Starts per run (>= 2; default harvest.replicates in the "
                                             "description, chosen by --convergence)."),
    convergence: bool = typer.Option(False, "--convergence", help="Instead of the L9: mean and SD of every harvest "
                                     "response at the configured clearances against the number of starts, with the "
                                     "SD's own sampling error, and the smallest count where both are stable."),
    starts: str = typer.Option("4,8,16,32", "--starts", help="With --convergence: the start counts of the table "
                               "(comma-separated, nested: the first n of the largest)."),
):
    """The study's L9 clearance test run through the virtual harvest, replicated, and analysed against its noise.

    Each of the 9 runs is repeated from harvest.replicates independent starts (or --replicates); each start is one
    virtual field test: one drive-past from a perturbed machine start (eccentricity in every clearance) carrying every
    branch class's branch, each meeting the comb at its own drawn drive phase, and the bushes a test of operation.test_duration passes with every fruit
    counted (each kind of draw from its own stream of the seed family harvest.seed).  The same starts serve every
    run, and the analysis treats start k as block k: each factor is tested against its own interaction with the
    starts (one verdict per factor and response, also in the paired differences), and beside every effect of the
    model's expectation stands how many field tests per level it would take to see it.  The recommended set's starts
    are then extended until every harvest response's expected mean is known to harvest.se_target of itself (at
    most harvest.max_replicates).  One coupled run per start goes through the cached sweep runner
    (a repeat is instant).

    --convergence prints how the mean and the SD of each harvest response settle with the number of starts (the
    study that chose harvest.replicates), for the model's expectation (<name>_expected: the model's spread) and the
    counted field results (the field's spread), and whether two further seed families give the same spreads;
    --json keys: table (response -> rows -> n -> mean, se, sd, sd_se, sd_relative_error, stable), chosen, configured,
    rule, seeds, values, families (per response: sd per family, ratio, ratio_ci, levene_p, agree).

    --json keys: runs (levels, clearance_mm, replicate means of efficiency/unripe/damage, replicates: per
    response {mean, sd, ci, n} of the counted field results, expected: the model's expectation {mean, sd, ci, n});
    detectability (response -> factor -> effect, effect_se, field_sd, tests_per_level, l9_replicates); responses
    (range analysis of the means); replicated (ANOVA, each factor against its own interaction with the starts:
    responses -> factors -> level_means, level_ci, range_ci, p, significant; significance_rule;
    optimum with choices and tiers; perturbation; seeds); optimum (the recommended levels, decided_levels,
    rule in method, tiered_levels); paired (response -> factor -> the paired difference of the extreme levels,
    e.g. A3 - A1: difference, se, ci, p, beyond_noise); recommended (levels, code, clearance_mm, virtual_harvest,
    starts, sequential (reached, stopped), fitted (responses whose value there is a calibration target),
    replicates (per response mean, sd per start, ci, n), basis per factor, rule, statement, check: the tiered
    choice confirmed against the trade-off table - moved,
    tiered, dominated_by, better_in, statement); tolerance_check (rtol: the runs' and the check's, 1e-5 and 1e-7; per response changes, mean_change,
    max_abs_change, replicate_sd, noise_sd, within_replicate_spread: |mean_change| <= z noise_sd, z the family-wise band; statement); tradeoff (one row per candidate: name, clearance_mm:<pair>, efficiency,
    ripe_removal, unripe, unripe_shed, damage, design_force_N:<pair>, drive_torque_design_Nm, drive_torque_rms_Nm,
    each with _lo/_hi (95 % interval) and _noise (Tukey-Kramer comparison half-width on the pure error);
    dominated, dominated_by); tradeoff_columns; response_units.
    Responses: efficiency (kg/min), ripe_removal (%), unripe (% of the picked mass), unripe_shed (% of the unripe
    mass), damage (%), design_force_<pair> (N: the static-equivalent collision force, the p95 of the impact peaks), drive_torque_design and drive_torque_rms (N m).
    \f

    Parameters
    ----------
    config : Path, optional
        ``--config``: Machine description (TOML). Default: built-in reference machine.
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    workers : int, optional
        ``--workers``: Processes (default: every core this process may run on, its CPU affinity).
    scheduler : str, optional
        ``--scheduler``: Dask scheduler address, e.g. tls://10.0.0.5:8786. Runs and results travel as pickles (code
        runs where they are loaded): give only a scheduler you trust, on a trusted network or over TLS (tls://).
    cache : str, optional
        ``--cache``: Run cache folder.
    plot : Path, optional
        ``--plot``: Main-effect plots and response surfaces (PNG).
    replicates : int, optional
        ``--replicates``: Starts per run (>= 2; default harvest.replicates in the description, chosen by
        --convergence).
    convergence : bool
        ``--convergence``: Instead of the L9: mean and SD of every harvest response at the configured clearances
        against the number of starts, with the SD's own sampling error, and the smallest count where both are
        stable.
    starts : str
        ``--starts``: With --convergence: the start counts of the table (comma-separated, nested: the first n of the
        largest).
    """
    try:
        from berryshaker.outputs import prepare_output_dir
        from berryshaker.runs.runner import SweepRunner
        from berryshaker.study.l9 import virtual_l9

        if plot is not None:
            prepare_output_dir(plot, kind="doe virtual --plot")
        machine = _load(config)
        if machine.plant is None:
            raise BerryshakerError("the virtual test needs a [plant] block in the machine description")
        if replicates is not None:
            _check_replicates(replicates, "coupled runs: one per run of the 9 and start")
        runner = SweepRunner(workers=workers, scheduler=scheduler, cache_dir=cache, progress=True, console=err)
        if convergence:
            from berryshaker.experiment.noise import describe_convergence
            from berryshaker.study.l9 import start_convergence

            counts = _start_counts(starts)
            res = start_convergence(machine, runner, counts=counts)
            res["version"] = __version__
            if as_json:
                _print_json(res)
            else:
                out.print(describe_convergence(res, res["units"]), markup=False, highlight=False)
                out.print(f"harvest.replicates in the description: {res['configured']}", markup=False)
            return
        res = virtual_l9(machine, runner, replicates).to_json()  # printed and plotted as JSON
        res["version"] = __version__
        if plot is not None:
            import numpy as np

            from berryshaker.experiment.analysis import quadratic_regression
            from berryshaker.outputs import staged_directory
            from berryshaker.report.plots import plot_main_effects, plot_response_surfaces

            pairs = list(machine.pair_names)
            values = np.array([[r["clearance_mm"][p] for p in pairs] for r in res["runs"]])
            with staged_directory(plot, kind="doe virtual --plot") as stage:
                plot_main_effects(res, stage / "main_effects.png", "Virtual L9 test: main effects",
                                  level_values={p: [v * 1e3 for v in machine.clearance_levels()[p]] for p in pairs},
                                  factor_unit="mm")
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
    pairs = list(res["runs"][0]["clearance_mm"])
    rows = [[str(r["run"]), *[f"{r['clearance_mm'][p]:g}" for p in pairs], f"{r['efficiency']:.3f} kg/min",
             f"{r['unripe']:.2f} %", f"{r['damage']:.2f} %"] for r in res["runs"]]
    print_table(("run", *[f"{p} (mm)" for p in pairs], "efficiency", "unripe", "damage"), rows,
                title="Virtual L9 field test", justify=("right",) * (len(pairs) + 4))
    _print_doe(res)
    _print_tradeoff(res)
    rec = res["recommended"]
    out.print(f"recommended {rec['code']} ({', '.join(f'{k} {v} mm' for k, v in rec['clearance_mm'].items())}); "
              f"study: {rec['study']['code']}")
    units = res.get("response_units", {})
    fitted = set(rec.get("fitted") or [])
    out.print(f"at the recommendation, over {rec.get('starts', '?')} starts (mean [95 % interval], SD per start): "
              + "; ".join(f"{n} {v['mean']:.3g} [{v['ci'][0]:.3g}, {v['ci'][1]:.3g}] {units.get(n, '')}, SD "
                          f"{v['sd']:.2g}" + (" (fitted)" if n in fitted else "")
                          for n, v in rec["replicates"].items() if n in ("efficiency", "ripe_removal", "damage",
                                                                          "unripe")),
              markup=False, highlight=False)
    if rec.get("sequential"):
        out.print(rec["sequential"]["statement"], markup=False, highlight=False)
    out.print(rec.get("statement", ""), markup=False, highlight=False)
    tc = res.get("tolerance_check") or {}
    if tc.get("done"):
        out.print(f"solver tolerance: {tc['statement']}", markup=False, highlight=False)
    _print_detectability(res)


def _print_detectability(res: dict) -> None:
    """Per harvest response and factor: the model's effect and the field tests per level that would see it."""
    det = res.get("detectability") or {}
    if not det:
        return
    units = res.get("response_units", {})
    rows = []
    for n, per in det.items():
        for p, d in per.items():
            sig = res["replicated"]["responses"].get(n, {}).get("factors", {}).get(p, {}).get("significant")
            tests = d["tests_per_level"]
            rows.append([n, p, f"{d['effect']:.3g} ± {d['effect_se']:.2g} {units.get(n, '')}",
                         "differs" if sig else "no difference", f"{d['field_sd']:.3g}",
                         "-" if tests is None else (">10,000" if tests > 1e4 else f"{tests:.0f}")])
    print_table(["response", "factor", "model effect (range ± SE)", "verdict", "SD of one field test",
                 "field tests per level to see it"], rows,
                title="What a field test would see (two-sided t test, alpha 0.05, power 0.8)")


def _start_counts(text: str) -> tuple[int, ...]:
    """``--starts 4,8,16,32`` as counts (each 2..1000)."""
    try:
        counts = tuple(int(x) for x in text.split(",") if x.strip())
    except ValueError:
        counts = ()
    if not counts or any(not 2 <= c <= 1000 for c in counts):
        raise BerryshakerError(f"--starts {text!r}: give comma-separated start counts between 2 and 1000, e.g. "
                               "4,8,16,32")
    return counts


def _print_tradeoff(res: dict) -> None:
    """The trade-off table: mean [95 % interval] of each column per candidate."""
    recs = res.get("tradeoff") or []
    if not recs:
        return
    cols = [c for c in res.get("tradeoff_columns", []) if c in recs[0] and not c.endswith(("_lo", "_hi", "_noise"))
            and not c.startswith("clearance") and c not in ("name", "dominated", "dominated_by", "unripe_shed")]
    rows = [[r["name"] + (" *" if r.get("dominated") else ""),
             *[f"{r[c]:.4g} [{r.get(c + '_lo', r[c]):.4g}, {r.get(c + '_hi', r[c]):.4g}]" for c in cols]] for r in recs]
    print_table(["candidate", *cols], rows, title="Trade-off (mean [95 % interval]); * = dominated beyond noise")
