"""Calibrate the harvest model to a field sheet and predict the untested level sets: ``calibrate``."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Optional

import typer

from berryshaker.cli.app import ConfigOpt, JsonOpt, _fail, _load, _print_json, app, command, err, out
from berryshaker.cli.doe import SHEET_HELP
from berryshaker.cli.study import SCHEDULER_HELP
from berryshaker.errors import BerryshakerError


def _stage_progress(enabled: bool):
    """A rich progress bar on stderr for the stages after the runs (emulator, sampling, held-out run), and the
    ``progress(stage, done, total)`` callback of :func:`berryshaker.study.field_calibration.calibrate`."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    bar = Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                   console=err, transient=True, disable=not enabled)
    tasks: dict[str, int] = {}

    def progress(stage: str, done: int, total: int) -> None:
        label = {"emulator": "calibrate: emulator training and checks", "sampling": "calibrate: MCMC steps",
                 "held-out run": "calibrate: held-out run"}.get(stage, stage)
        if not tasks:  # started after the runner's own progress (rich shows one live display at a time)
            bar.start()
        if stage not in tasks:
            tasks[stage] = bar.add_task(label, total=total)
        bar.update(tasks[stage], completed=done, total=total)

    return bar, progress


#: level sets the console lists (the best by the recommendation's score; --json and the report have them all)
TOP_SETS = 10


@command(app, "calibrate")
def calibrate(
    sheet: Optional[Path] = typer.Argument(None, help="Filled field sheet (CSV or .xlsx): the `doe plan` layout, or plain factor columns "
                                 "with a replicate or block column as a statistics package writes them.  Factors: "
                                 "clearance pairs of the machine with a length unit (A_mm, 'C (mm)') and the drive "
                                 "speed with a speed unit (speed_rpm).  Responses: efficiency_kg_min, "
                                 "unripe_rate_pct, damage_rate_pct (or the raw masses)."),
    worksheet: Optional[str] = typer.Option(None, "--sheet", help=SHEET_HELP),
    config: Optional[Path] = ConfigOpt,
    out_dir: Optional[Path] = typer.Option(None, "--out", help="Report folder (report.html, calibration.json, tables "
                                           "as CSV and xlsx, figures): new, empty, or an earlier calibrate output; "
                                           "any other folder is refused before the work."),
    as_json: bool = JsonOpt,
    replicates: Optional[int] = typer.Option(None, "--replicates", min=2, max=64,
                                             help="Simulated starts per setting (default harvest.replicates)."),
    workers: Optional[int] = typer.Option(None, "--workers", help="Processes (default: every core this process "
                                          "may run on)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help=SCHEDULER_HELP),
    cache: Optional[str] = typer.Option(None, "--cache", help="Run cache folder (shared with study and validate)."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the emulator's design, the sampler and the "
                             "predictive draws (the simulator's starts use the description's harvest.seed)."),
    predict: Optional[list[str]] = typer.Option(None, "--predict", help="A further setting to predict, e.g. "
                                                "A=0.1mm,speed=130rpm (factors of the sheet only; a factor not named "
                                                "keeps the described value); repeat for more."),
    discrepancy: float = typer.Option(0.3, "--discrepancy", min=0.0, max=1.0,
                                      help="Prior scale of the model discrepancy (a Gaussian process over the "
                                      "settings that absorbs a measured effect the model does not produce), as a "
                                      "fraction of the sheet's mean; 0 turns it off."),
    saved: Optional[Path] = typer.Option(None, "--from", help="Predict from the calibration saved in this --out "
                                         "folder (no runs, no sampling: seconds); with --predict for further "
                                         "settings.  No sheet argument then."),
    check_settings: int = typer.Option(2, "--check-settings", min=0, max=20,
                                       help="Untested settings simulated to check the emulator's error there."),
    emulator_points: int = typer.Option(48, "--emulator-points", min=8, max=400,
                                        help="Latin-hypercube parameter points per simulated setting (emulator "
                                        "training)."),
    steps: Optional[int] = typer.Option(None, "--steps", min=50, max=100000,
                                        help="MCMC steps per walker (default: until the chain is 50 autocorrelation "
                                        "times long, at most 4000)."),
):
    """Calibrate the harvest model to your own field sheet and predict the settings you did not test.

    The harvest parameters that act after the coupled runs -- ripe and unripe bond strength, the ripe strengths'
    spread, the unripe fraction, the yield per bush, the bruise threshold of the catching surface, the Miner
    exponent of the cumulative detachment, the share of the detached fruit a finger strikes and the pedicel
    stiffness (within a factor 2.5 of the described one, its damping scaled alike) -- get a
    prior from the published ranges (config show lists them) and a posterior from the sheet.  Each setting of the
    sheet is simulated from harvest.replicates perturbed starts (cached, resumable, on a Dask cluster with
    --scheduler); the responses at any parameter value are exact post-processing of those runs, a Gaussian-process
    emulator (its held-out error reported and carried into the likelihood) stands in for them during sampling
    (emcee), and the likelihood carries the simulator's own start-to-start noise.  Output: prior against posterior
    per parameter (identified or not, confounded pairs), posterior predictive checks on the sheet's runs and one
    held-out run, predictions with 90 % intervals of every level set of the sheet's factors (and --predict
    settings), and a recommendation made on those intervals.  The likelihood carries a field test's own noise (the
    model's start-to-start spread, the counting noise of a test of operation.test_duration and a further field noise
    learnt from the sheet's replicates) and a model discrepancy, so an effect the sheet measured and the model does
    not produce is named and the predictions follow it.  The --out folder keeps the calibration (calibration_state.npz):
    `calibrate --from DIR --predict ...` predicts again in seconds.  Method and
    priors: docs/calibration.md.

    --json keys: parameters (per name: prior, described, posterior_mean, posterior_median, lo90, hi90, width_ratio,
    identified), identified_rule, confounded, predictions (per level set: level_set, setting, tested, named,
    extrapolated, responses: per response mean, lo90, hi90, unit), recommendation, emulator (held_out_theta,
    held_out_settings: rmse, rmse_over_sd, relative_rmse, log_sd_rmse), checks (posterior_predictive, summary,
    held_out_run), sampler, simulator, sheet, likelihood, discrepancy, discrepancies (per response: field_noise,
    amplitude, residual_effects, verdict), limits, timings_s, version, code_sha256, machine_si.
    \f

    Parameters
    ----------
    sheet : Path, optional
        Argument: Filled field sheet (CSV or .xlsx); none with ``--from``.
    worksheet : str, optional
        ``--sheet``: The worksheet of an .xlsx workbook, by the name on its tab (default: the first worksheet).
        Cells are read as strictly as a CSV's: a formula is an error naming the cell (paste the values), a date or
        a boolean is refused where a number belongs.
    config : Path, optional
        ``--config``: Machine description (TOML). Default: built-in reference machine.
    out_dir : Path, optional
        ``--out``: Report folder (report.html, calibration.json, tables as CSV and xlsx, figures).
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    replicates : int, optional
        ``--replicates``: Simulated starts per setting (default harvest.replicates).
    workers : int, optional
        ``--workers``: Processes (default: every core this process may run on).
    scheduler : str, optional
        ``--scheduler``: Dask scheduler address, e.g. tls://10.0.0.5:8786. Runs and results travel as pickles (code
        runs where they are loaded): give only a scheduler you trust, on a trusted network or over TLS (tls://).
    cache : str, optional
        ``--cache``: Run cache folder (shared with study and validate).
    seed : int
        ``--seed``: Seed of the emulator's design, the sampler and the predictive draws.
    predict : list of str, optional
        ``--predict``: Further settings to predict, e.g. A=0.1mm,speed=130rpm.
    discrepancy : float
        ``--discrepancy``: Prior scale of the model discrepancy, a fraction of the sheet's mean (0 = off).
    saved : Path, optional
        ``--from``: Predict from the calibration saved in this folder.
    check_settings : int
        ``--check-settings``: Untested settings simulated to check the emulator's error there.
    emulator_points : int
        ``--emulator-points``: Latin-hypercube parameter points per simulated setting.
    steps : int, optional
        ``--steps``: MCMC steps per walker (default: until 50 autocorrelation times, at most 4000).
    """
    runner = None
    try:
        from berryshaker.outputs import prepare_output_dir, provenance
        from berryshaker.runs.runner import SweepRunner
        from berryshaker.study.field_calibration import (
            STATE_FILE,
            CalibrationSettings,
            parse_setting,
            read_sheet,
            save_state,
        )
        from berryshaker.study.field_calibration import calibrate as run_calibration

        machine = _load(config)
        if saved is not None:
            if sheet is not None:
                raise BerryshakerError("give either a sheet to calibrate or --from DIR to predict from a saved "
                                       "calibration, not both")
            _predict_saved(saved, machine, predict or [], as_json)
            return
        if sheet is None:
            raise BerryshakerError("give the filled field sheet to calibrate (or --from DIR to predict from a saved "
                                   "calibration)")
        if out_dir is not None:
            prepare_output_dir(out_dir, kind="calibrate")  # refuse a folder with the user's files before any work
        if machine.plant is None:
            raise BerryshakerError("calibrate needs a [plant] block in the machine description (the harvest model "
                                   "runs on it); add one, e.g. from the reference machine (config init)")
        fs = read_sheet(sheet, machine, worksheet)
        named = [parse_setting(p, fs.targets, machine) for p in (predict or [])]
        opts = CalibrationSettings(replicates=replicates, theta_points=emulator_points, check_settings=check_settings,
                                   steps=steps, seed=seed, discrepancy=discrepancy)
        bar, progress = _stage_progress(True)
        runner = SweepRunner(workers=workers, scheduler=scheduler, cache_dir=cache, progress=True, console=err)
        state: dict = {}
        with runner:
            try:
                res = run_calibration(machine, fs, runner, opts, named, progress, state_out=state)
            finally:
                bar.stop()
        res = replace(res, sheet=replace(res.sheet, file=str(sheet)), **provenance(machine))
        if out_dir is not None:
            from berryshaker.outputs import staged_directory, write_json_atomic
            from berryshaker.report.calibration import write_calibration_outputs

            with staged_directory(out_dir, kind="calibrate") as stage:
                write_calibration_outputs(res, stage, f"Calibration to {sheet.name}")
                write_json_atomic(stage / "calibration.json", res.to_json())
                save_state(stage / STATE_FILE, state)
            res = replace(res, out=str(out_dir))
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json(res.to_json())
        return
    _print_calibration(res)


def _predict_saved(folder: Path, machine, predict: list[str], as_json: bool) -> None:
    """``calibrate --from DIR``: the saved calibration's predictions at every level set and the ``--predict``
    settings, printed (the best :data:`TOP_SETS`) or as JSON (``predictions``, ``recommendation``, ``from``)."""
    import json

    from berryshaker.study.field_calibration import (
        CalibrationResult,
        FactorTarget,
        load_state,
        parse_setting,
        predict_saved,
    )

    cal_file = Path(folder) / "calibration.json"
    if not cal_file.is_file():
        raise BerryshakerError(f"--from {folder}: no calibration.json there; give the --out folder of a calibrate run")
    cal = CalibrationResult.from_json(json.loads(cal_file.read_text(encoding="utf-8")))
    if cal.code_sha256 and machine.model_dump(mode="json") != cal.machine_si:
        raise BerryshakerError(f"--from {folder}: the calibration was made with another machine description; give "
                               "the same --config as the calibration")
    state = load_state(folder)
    from berryshaker.units import parse_unit, unit_dimension

    targets = []
    for name, f in cal.sheet.factors.items():
        dim = unit_dimension(f.unit)
        to_si = parse_unit(f.unit, dim, f"factor {name}")
        kind, pair = ("drive_speed", "") if f.sets == "drive speed" else ("clearance", f.sets)
        targets.append(FactorTarget(name, kind, pair, f.unit, to_si, tuple(v * to_si for v in f.levels)))
    named = [parse_setting(p, targets, machine) for p in predict]
    preds, rec = predict_saved(state, targets, named, machine)
    if as_json:
        _print_json({"from": str(folder), "predictions": [p.to_json() for p in preds], "recommendation": rec})
        return
    _print_predictions(preds, rec, [])


def _print_predictions(preds, level_set: str, no_difference: list[str]) -> None:
    """The predictions table on the console: the recommended set, the named settings and the best others (at most
    :data:`TOP_SETS` rows in all, by the mean efficiency where the sheet has one)."""
    from berryshaker.cli.app import print_table

    def q(v):
        return f"{v:.3g}"

    responses = list(preds[0].responses) if preds else []
    key = "efficiency" if "efficiency" in responses else (responses[0] if responses else None)
    order = sorted(preds, key=lambda p: (p.level_set != level_set, not p.named,
                                         -(p.responses[key].mean if key else 0.0)))
    shown = order[:max(TOP_SETS, sum(p.named for p in preds) + 1)]
    print_table(["level set", "tested", *[f"{r} ({preds[0].responses[r].unit})" for r in responses]],
                [[p.level_set + (" (extrapolated)" if p.extrapolated else "") + (" (recommended)" if p.level_set
                                                                                   == level_set else ""),
                  "yes" if p.tested else "",
                  *[f"{q(p.responses[r].mean)} [{q(p.responses[r].lo90)}, "
                    f"{q(p.responses[r].hi90)}]" for r in responses]] for p in shown],
                title=f"Predicted field result: mean [90 % interval]; the recommended set, named settings and the best "
                      f"by {key} ({len(shown)} of {len(preds)}; --json or the report list all)")
    out.print(f"recommended: {level_set}" + (f"; no difference beyond the intervals from {len(no_difference)} other "
                                              "level set(s)" if no_difference else ""), markup=False, highlight=False)


def _print_calibration(res) -> None:
    """The calibration's tables and lines on the console (``res``: a
    :class:`~berryshaker.study.field_calibration.result.CalibrationResult`)."""
    from berryshaker.cli.app import print_table

    def q(v):
        return f"{v:.3g}"

    print_table(["parameter", "unit", "prior 90 %", "described", "posterior mean", "posterior 90 %", "identified"],
                [[n, p.unit or "-", f"{q(p.prior.lo90)} .. {q(p.prior.hi90)}", q(p.described),
                  q(p.posterior_mean), f"{q(p.lo90)} .. {q(p.hi90)}",
                  "yes" if p.identified else "no"] for n, p in res.parameters.items()],
                title=f"What the sheet tells ({res.identified_rule})")
    if res.confounded:
        out.print("confounded: " + "; ".join(f"{c.parameters[0]} with {c.parameters[1]} (r = "
                                             f"{c.correlation:+.2f})" for c in res.confounded),
                  markup=False, highlight=False)
    for r, d in res.discrepancies.items():
        out.print(f"{r}: {d.verdict}", markup=False, highlight=False)
    rec = res.recommendation
    _print_predictions(res.predictions, rec.level_set, rec.no_difference)
    s = res.checks.summary
    em = res.emulator.held_out_theta
    out.print(f"checks: {s.inside} of {s.total} run means inside their 90 % predictive interval; emulator "
              "held-out RMSE / replicate SD: " + ", ".join(f"{r} {e.rmse_over_sd:.2f}" for r, e in em.items())
              + f"; discrepancy {res.discrepancy_text}.",
              markup=False, highlight=False)
    if res.out:
        err.print(f"wrote {res.out}", markup=False, highlight=False)
