"""The whole reference study as a pipeline of steps: kinematics, model agreement, clearance rows, fruit force,
the virtual L9 field test, clearance life, powered drive, harvest against frequency, validation, claims.  Each step
(:data:`berryshaker.study.steps.STEPS`, one module per step) returns a typed :class:`StepResult` (its data, figures
and tables) and names the renderers of its report sections, which the report numbers in the steps' order;
:func:`run_study` runs the steps, writes the outputs atomically into a checked destination and returns the
summary.

This module holds the machinery: running the steps (:func:`run_steps`, with the engine compiled beside a worker,
:func:`compile_engine_beside`), the steps' plans and sections in the table's order (:func:`planned_runs`,
:func:`report_sections`), the timings and the summary (:func:`study_summary`, :func:`l9_summary`).  The steps
themselves, each with its plan, its figures and its report sections, are the modules of
:mod:`berryshaker.study.steps`; what every step gets, :class:`StudyContext` and :class:`PlannedRuns`, is in
:mod:`berryshaker.study.step_context`.

Every multi-run step goes through :class:`berryshaker.runs.runner.SweepRunner` (cached, resumable, local
processes or a Dask cluster); the run functions are in :mod:`berryshaker.study.runs`.  A step whose runs are
known before it starts has a plan (``Step.plan``) from which it builds them; :func:`run_steps`
starts the planned runs ahead in idle workers, so they run while this process compiles, plots and analyses
(tests/study/test_pipeline.py checks that no planned run goes unused).
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

from berryshaker import __version__
from berryshaker.drives import drive_of
from berryshaker.multibody.engine import compile_engine
from berryshaker.plant.pedicel import compile_peak_stem_force
from berryshaker.records import to_json
from berryshaker.reference_study import CHOSEN_CODE, FIELD_RESULT
from berryshaker.runs.runner import usable_cores
from berryshaker.study import steps as study_steps
from berryshaker.study.claims import check_claims
from berryshaker.study.l9.records import VirtualL9
from berryshaker.study.runs import warm_worker
from berryshaker.study.step_context import PlannedRuns, StudyContext
from berryshaker.study.step_result import StepResult, StudyOptimum, StudyResults, StudySummary
from berryshaker.user_text import markup_text

#: the names callers import from here: the machinery's own, the steps' context and their result
__all__ = [
    "ENGINE_STEP", "PlannedRuns", "StepResult", "StudyContext", "compile_engine_beside", "l9_summary",
    "planned_runs", "report_sections", "run_steps", "run_study", "study_summary",
]


def report_sections() -> list[tuple[str, tuple]]:
    """The steps' report sections in the steps' order (:data:`berryshaker.study.steps.STEPS`): what
    :func:`berryshaker.report.html.study_report` renders.

    Returns
    -------
    list of (str, tuple of callable)
        Per step with sections: its result's name and its section renderers.
    """
    return [(s.result, s.sections) for s in study_steps.STEPS if s.sections]


#: the step that compiles the multibody engine in this process (its first multibody run)
ENGINE_STEP = "model_agreement"


def planned_runs(ctx: StudyContext) -> list[PlannedRuns]:
    """Every step's plan (``Step.plan``), in step order; a step whose plan fails is left out (the step itself
    reports the error when it runs).

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    list of PlannedRuns
        Every step's planned runs, in step order.
    """
    out = []
    for step in study_steps.STEPS:
        if step.plan is not None:
            try:
                out += step.plan(ctx)
            except Exception:  # noqa: BLE001 - the step will meet (and report) the same error
                continue
    return out


def planned_runs_cached(machine, runner) -> bool:
    """Whether every run the steps plan (``Step.plan``) is in ``runner``'s cache: a study that then starts no
    worker (its figures are drawn in this process).

    Parameters
    ----------
    machine : MachineBase
        The study's machine description.
    runner : SweepRunner
        The study's runner.

    Returns
    -------
    bool
        True when every planned run's cache entry is present.
    """
    ctx = StudyContext(machine, runner, Path("."))
    return all(runner.all_cached(p.fn, p.jobs) for p in planned_runs(ctx))


def compile_engine_beside(machine, warm, timeout: float = 60.0) -> str | None:
    """Compile the multibody engine's projection and event helpers here while a worker compiles its force
    evaluation and the step helpers that call it (``study.runs.warm_worker``, started as the future ``warm``), wait
    for the worker (at most
    ``timeout`` s), then compile the right-hand side on top of both: the engine's first run (here or in a worker)
    then compiles only the integrator itself and loads the rest from numba's cache.

    An optimisation only: when it fails (a worker that crashed or is late, a machine whose mechanism cannot be
    built) the first run compiles what is missing and meets any real error itself; the reason is returned for
    the log (None when all went well).  When the projection was in the cache already, so is the rest (one source
    file), and nothing is waited for.

    Parameters
    ----------
    machine : MachineBase
        The machine description (its drive's mechanism is compiled).
    warm : Future
        The worker's :func:`berryshaker.study.runs.warm_worker`.
    timeout : float
        Longest wait for the worker (s).

    Returns
    -------
    str or None
        Why it did not work ("<exception type>: <message>"), or None.
    """
    try:
        spec = drive_of(machine).mechanism(machine, revolutions=2)
        seconds = compile_engine(spec, ("projection", "step_events"))
        if seconds["projection"] >= 1.0:
            warm.result(timeout=timeout)
        compile_engine(spec, ("right_hand_side",))
    except Exception as exc:  # noqa: BLE001 - see the docstring
        return f"{type(exc).__name__}: {exc}"
    return None


def run_steps(machine, runner, figs: Path, console=None) -> tuple[StudyResults, dict, list[dict], dict]:
    """Run every step; return (StudyResults, the StepResults by result name, failures, timings in s).

    The steps run in order in this process, but their runs need not wait for them: the runs every step will ask
    for (``Step.plan``) start ahead in the runner's idle workers (``SweepRunner.prefetch``; local pool only).
    When multibody runs are to be computed, a worker compiles the engine's force evaluation while this process
    compiles the rest of it (:func:`compile_engine_beside`, before :data:`ENGINE_STEP`, whose first multibody
    run then compiles only the integrator).  The reduced model's runs start at once in one worker (on a machine
    with fewer than three cores, once the engine's parts are compiled); the multibody ones right after
    :data:`ENGINE_STEP` has compiled the engine (``StudyContext.engine_compiled``, called before that step draws its
    figures), so the workers load the compiled engine instead of compiling it as well.  While this
    process plots and analyses a step, the workers are already running the next steps' runs.  Results are the
    same as without it (each step's map takes the same runs).

    Parameters
    ----------
    machine : MachineBase
        The study's machine description.
    runner : SweepRunner
        Runs the steps' runs (cached).
    figs : Path
        Folder the figures are written to.
    console : rich.console.Console, optional
        Where progress is printed (default silent).

    Returns
    -------
    results : StudyResults
        Each step's data under its step's result name, with ``claims`` and ``failures``.
    steps : dict of str to StepResult
        Each step's result.
    failures : list of FailedRun
        Failed runs.
    timings : dict of str to float
        Seconds per step and ``total`` (s).
    """

    def say(msg):
        if console is not None:
            console.print(f"[bold cyan]study[/] {markup_text(msg)}")

    ctx = StudyContext(machine, runner, figs, say=say)
    results: dict = ctx.results
    steps: dict[str, StepResult] = {}
    timings: dict[str, float] = {}
    t_all = time.perf_counter()
    plans = planned_runs(ctx)
    try:
        # the engine compiled on two cores when runs need it: a worker its forces, this process the rest
        # (compile_engine_beside); on two cores the reduced model's runs wait for that (a third process would
        # slow both down, and they are not what the study waits for)
        plans = [p for p in plans if not runner.all_cached(p.fn, p.jobs)]
        # nothing planned to compute: no worker is started for the figures either (they are drawn here)
        ctx.draw_in_workers = bool(plans)
        warm = None
        if runner.workers > 1 and not runner.scheduler and any(p.engine for p in plans):
            warm = runner.warm_up(warm_worker, dict(machine_data=ctx.data))
        defer = warm is not None and usable_cores() < 3
        if not defer:
            for p in plans:
                if not p.engine:
                    runner.prefetch(p.fn, p.jobs, chunks=1)
        engine_ready = not any(step.key == ENGINE_STEP for step in study_steps.STEPS)

        def start_planned():
            nonlocal plans
            for p in plans:
                runner.prefetch(p.fn, p.jobs)
            plans = []

        ctx.engine_compiled = start_planned
        for step in study_steps.STEPS:
            key = step.key
            if engine_ready and plans:
                start_planned()
            t0 = time.perf_counter()
            if key == ENGINE_STEP and warm is not None:
                why = compile_engine_beside(machine, warm)
                if why:
                    say(f"compiling the engine beside a worker did not work ({why}); its first run compiles it")
                if defer:
                    for p in plans:
                        if not p.engine:
                            runner.prefetch(p.fn, p.jobs, chunks=1)
                runner.warm_up(compile_peak_stem_force)  # the replicate runs' stem-force kernel, in an idle worker
            r = step.run(ctx)
            if r.name != step.result:  # the report finds a step's note by this name
                raise RuntimeError(f"step {key} returned a StepResult named {r.name!r}, not {step.result!r}")
            engine_ready = engine_ready or key == ENGINE_STEP
            r.seconds = time.perf_counter() - t0
            steps[r.name] = r
            results[r.name] = r.data
            timings[key] = r.seconds
        ctx.finish_drawing()
    except BaseException:  # Ctrl-C or an error between maps: runs started ahead stop now (finished ones are cached)
        runner.abort()
        raise
    done = StudyResults.of_steps(results, ctx.failures)
    done = dataclasses.replace(done, claims=check_claims(done, machine.pair_names))
    timings["total"] = time.perf_counter() - t_all
    return done, steps, ctx.failures, timings


def study_summary(machine, results: StudyResults, failures: list, timings: dict, runner_stats: dict) -> StudySummary:
    """The head of summary.json: claims, the recommended clearances, failures, timings, run counts.

    Parameters
    ----------
    machine : MachineBase
        The study's machine description.
    results : StudyResults
        The steps' data with ``claims`` (:func:`run_steps`).
    failures : list of FailedRun
        Failed runs.
    timings : dict of str to float
        Seconds per step (s).
    runner_stats : dict
        The runner's run counts.

    Returns
    -------
    StudySummary
        ``package``, ``version``, ``machine``, ``drive``, ``claims``, ``optimum`` (the L9's recommendation: code,
        clearances in mm, efficiency kg/min, unripe and damage rates %, the study's field result...; None without
        an L9), ``failures``, ``timings_s`` (s), ``runs`` and :func:`l9_summary`'s entries.
    """
    optimum = None
    l9 = results.l9
    if l9 is not None:
        rec = l9.recommended
        vh = rec.virtual_harvest
        optimum = StudyOptimum(code=rec.code, name=rec.name, clearance_mm=rec.clearance_mm,
                               efficiency_kg_min=vh["efficiency_kg_min"], unripe_rate_pct=vh["unripe_rate_pct"],
                               damage_rate_pct=vh["damage_rate_pct"], study={"code": CHOSEN_CODE, **FIELD_RESULT},
                               fitted=rec.fitted, starts=rec.starts, intervals=rec.replicates, basis=rec.basis,
                               statement=rec.statement)
    return StudySummary(package="berryshaker", version=__version__, machine=machine.machine.name,
                        drive=machine.DRIVE, claims=list(results.claims), optimum=optimum, failures=list(failures),
                        timings_s=timings, runs=dict(runner_stats), **l9_summary(l9))


def l9_summary(l9: VirtualL9 | None) -> dict:
    """summary.json entries of the replicated L9: ``l9_replicates`` (pooled replicate SD, dof and significant
    factors per response; the solver-tolerance check) and ``tradeoff`` (the trade-off table's rows), as JSON.

    Parameters
    ----------
    l9 : VirtualL9 or None
        The virtual L9 (:func:`berryshaker.study.l9.virtual_l9`).

    Returns
    -------
    dict
        ``l9_replicates``, ``tradeoff`` and ``tradeoff_columns``; empty without a replicated L9.
    """
    if l9 is None:
        return {}
    rep = l9.replicated
    per = {n: {"replicate_sd": ra.anova.pure_error.ms ** 0.5, "dof": ra.anova.pure_error.df,
               "blocked_error_sd": ra.anova.error.ms ** 0.5, "blocked_error_dof": ra.anova.error.df,
               "significant_factors": ra.significant_factors,
               "p": {f: d.p for f, d in ra.factors.items()}, "paired": to_json(l9.paired.get(n))}
           for n, ra in rep.responses.items()}
    return {"l9_replicates": {"replicates": rep.replicates, "blocks": rep.blocks, "seeds": rep.seeds,
                              "perturbation": rep.perturbation.to_json(), "significance_rule": rep.significance_rule,
                              "responses": per, "tolerance_check": l9.tolerance_check.to_json()},
            "tradeoff": l9.tradeoff, "tradeoff_columns": l9.tradeoff_columns}


def run_study(machine, out_dir: Path, runner, console=None) -> StudySummary:
    """Run every step and write report.html, summary.json, tables/ and figures/ into ``out_dir``.

    The destination is checked before any work (:func:`berryshaker.outputs.prepare_output_dir`: a new or
    empty folder, or a previous berryshaker output); outputs are staged and moved in atomically.

    Parameters
    ----------
    machine : MachineBase
        The study's machine description.
    out_dir : Path
        Output folder.
    runner : SweepRunner
        Runs the steps' runs (cached).
    console : rich.console.Console, optional
        Where progress is printed (default silent).

    Returns
    -------
    StudySummary
        :func:`study_summary`.
    """
    from berryshaker.outputs import staged_directory, write_json_atomic, write_text_atomic
    from berryshaker.report.html import study_report
    from berryshaker.report.html_blocks import page_figure_cache
    from berryshaker.study.tables import strip_series, write_tables

    with staged_directory(out_dir, kind="study") as stage:
        figs = stage / "figures"
        figs.mkdir()
        tables = stage / "tables"
        tables.mkdir()
        results, steps, failures, timings = run_steps(machine, runner, figs, console)
        summary = study_summary(machine, results, failures, timings, runner.stats)
        write_tables(machine, results, tables)
        write_json_atomic(stage / "summary.json", {**summary.to_json(), "results": strip_series(results.to_json()),
                                                   "machine_si": machine.model_dump(mode="json")})
        with page_figure_cache(runner.cache_dir / "page-figures" if runner.use_cache else None):
            page = study_report(results, summary, machine, figs, steps, sections=report_sections())
        write_text_atomic(stage / "report.html", page)
    return summary

