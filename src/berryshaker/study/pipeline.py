"""The whole reference study as a pipeline of steps: kinematics, model agreement, clearance rows, fruit force,
the virtual L9 field test, clearance life, powered drive, harvest against frequency, validation, claims.  Each step
(:data:`STEPS`) returns a typed :class:`StepResult` (its data, figures and tables) and names the renderers of its
report sections (:mod:`berryshaker.report.sections`), which the report numbers in the steps' order;
:func:`run_study` runs the steps, writes the outputs atomically into a checked destination and returns the
summary.

Every multi-run step goes through :class:`berryshaker.runs.runner.SweepRunner` (cached, resumable, local
processes or a Dask cluster); the run functions are in :mod:`berryshaker.study.runs`.  A step whose runs are
known before it starts has a plan (``plan_<step>``, :data:`PLANS`) from which it builds them; :func:`run_steps`
starts the planned runs ahead in idle workers, so they run while this process compiles, plots and analyses.

long module: each step sits beside its plan and its figures, so what a step asks the runner for and what was
started ahead for it cannot drift apart (tests/study/test_pipeline.py checks that no planned run goes unused).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from berryshaker import __version__
from berryshaker.drives import drive_of
from berryshaker.errors import ConfigError
from berryshaker.experiment.clearance_sets import clearance_row, level_set, n_rows
from berryshaker.experiment.replicates import replicate_trend
from berryshaker.multibody.engine import compile_engine
from berryshaker.plant.pedicel import compile_peak_stem_force
from berryshaker.reference_study import CHOSEN_CODE, FIELD_RESULT, FRUIT_FORCE_N, MODEL_CHECK_LEVEL
from berryshaker.report import sections as S
from berryshaker.runs.runner import usable_cores
from berryshaker.study.claims import check_claims
from berryshaker.study.life_step import step_life
from berryshaker.study.step_result import StepResult
from berryshaker.study.l9 import virtual_l9
from berryshaker.study.runs import (
    fruit_force_run,
    model_check_jobs,
    multibody_row,
    powered_row,
    reduced_row,
    replicate_run,
    warm_worker,
)


def _silent(msg: str) -> None:
    """A progress message nobody reads (the default ``StudyContext.say``).

    Parameters
    ----------
    msg : str
        The message (ignored).
    """


def _nothing() -> None:
    """No action (the default ``StudyContext.engine_compiled``)."""


@dataclass
class StudyContext:
    """What every step gets: the machine, its drive, the runner, the figure folder and the failure log.

    Attributes
    ----------
    machine : MachineBase
        The study's machine description.
    runner : SweepRunner
        Runs the steps' runs (cached).
    figs : Path
        Folder the figures are written to.
    failures : list of dict
        Failed runs (step, run, inputs, error), for the report.
    say : callable
        ``say(msg)``: progress messages (default silent).
    results : dict
        Data of the steps run so far, by step name.
    drawing : list
        Figures being drawn in pool workers: (future, pickled call).
    engine_compiled : callable
        Called by the step that compiles the multibody engine once it has (then the planned runs that need it
        start).
    """

    machine: object
    runner: object
    figs: Path
    failures: list = field(default_factory=list)
    say: Callable[[str], None] = field(default=None)
    results: dict = field(default_factory=dict)  # data of the steps run so far, by step name
    drawing: list = field(default_factory=list)  # figures drawn in pool workers: (future, pickled call)
    # called by the step that compiles the multibody engine once it has (run_steps then starts the planned runs
    # that need it, while that step still plots)
    engine_compiled: Callable[[], None] = field(default=None)

    def __post_init__(self):
        """Silent defaults for the callbacks (``say``, ``engine_compiled``) not given."""
        if self.say is None:
            self.say = _silent
        if self.engine_compiled is None:
            self.engine_compiled = _nothing

    @property
    def drive(self):
        """The machine's drive plug-in."""
        return drive_of(self.machine)

    @property
    def data(self) -> dict:
        """The machine as a JSON-compatible dict (what the run functions take)."""
        return self.machine.model_dump(mode="json")

    def draw(self, fn, *args, **kwargs) -> None:
        """Draw a figure (``fn(*args, **kwargs)``, a function of berryshaker.report.plots: data in, one PNG out) in
        a pool worker when the runner has a local pool, else here; :meth:`finish_drawing` waits for it.  (The
        virtual L9's figures took ~3 s of this process at the end of its step while both workers idled,
        benchmarks/HISTORY.md sec. 22.)  The figure functions set their whole style themselves
        (berryshaker.report.style), so a worker draws what this process would; a matplotlib style set globally
        by a program that calls :func:`run_study` does not reach the workers.

        Parameters
        ----------
        fn : callable
            The figure function.
        *args
            Its positional arguments (pickled now).
        **kwargs
            Its keyword arguments (pickled now).
        """
        import pickle

        # pickled now: the pool pickles a call's arguments later, in its own thread, and the step's data may
        # change meanwhile (the next steps and the claims add to the results)
        payload = pickle.dumps((fn, args, kwargs))
        fut = self.runner.warm_up(draw_figure, dict(payload=payload))
        if fut is None:
            fn(*args, **kwargs)
        else:
            self.drawing.append((fut, payload))

    def finish_drawing(self) -> None:
        """Wait for the figures drawn in workers (:meth:`draw`).  A figure whose worker died (the pool broke) or was
        cancelled is drawn here; an error of the figure function itself is raised here, as without the pool."""
        from concurrent.futures import CancelledError
        from concurrent.futures.process import BrokenProcessPool

        pending, self.drawing = self.drawing, []
        for fut, payload in pending:
            try:
                fut.result()
            except (BrokenProcessPool, CancelledError):
                self.say("a worker drawing a figure stopped; drawing it here")
                draw_figure(payload)

    def collect(self, fn, jobs, label, describe):
        """Run jobs through the sweep runner; failed runs are logged and come back as None.

        Parameters
        ----------
        fn : callable
            A module-level run function.
        jobs : list of dict
            Its keyword arguments, one dict per run.
        label : str
            Progress label, and the failure log's step.
        describe : callable
            ``describe(job) -> str``: the inputs of a failed run, for the log.

        Returns
        -------
        list
            Each run's value in the jobs' order, None where it failed.
        """
        outs = self.runner.map(fn, jobs, label)
        for o in outs:
            if o.error:
                self.failures.append({"step": label, "run": o.index + 1, "inputs": describe(jobs[o.index]),
                                      "error": o.error})
        return [o.value for o in outs]


def draw_figure(payload: bytes) -> None:
    """Draw a figure of :meth:`StudyContext.draw` in a pool worker: ``payload`` is the pickled call
    ``(fn, args, kwargs)``.

    Parameters
    ----------
    payload : bytes
        The pickled call.
    """
    import pickle

    fn, args, kwargs = pickle.loads(payload)
    fn(*args, **kwargs)


@dataclass
class PlannedRuns:
    """Runs a step will ask the runner for, known before it starts: the study starts them ahead in idle workers
    (``SweepRunner.prefetch``) and the step's own map takes their results.  ``engine``: they need the compiled
    multibody engine (started only once this process has compiled it, so workers do not compile it too).

    Attributes
    ----------
    fn : callable
        The module-level run function.
    jobs : list of dict
        Its keyword arguments, one dict per run.
    label : str
        The step's label of these runs.
    engine : bool
        Whether the runs need the compiled multibody engine.
    """

    fn: Callable
    jobs: list[dict]
    label: str
    engine: bool = True


def _describe(clearance: dict) -> str:
    return ", ".join(f"{p} {v * 1e3:g} mm" for p, v in clearance.items()) or "as configured"


# ---- steps ---------------------------------------------------------------------------------------------
def step_kinematics(ctx: StudyContext) -> StepResult:
    """Ideal kinematics over one drive-shaft revolution (study eq. 1-3) and its figures.

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    StepResult
        ``kinematics``: the drive's kinematics summary (units in the key names) and its figures.
    """
    from berryshaker.report import plots as P

    ctx.say("kinematics")
    kin = ctx.drive.check(ctx.machine)
    data = ctx.drive.kinematics_summary(ctx.machine, kin)
    figs = P.write_kinematics_figures(ctx.machine, kin, ctx.figs) or []
    return StepResult("kinematics", data, list(figs))


def step_agreement(ctx: StudyContext) -> StepResult:
    """Reduced model vs multibody at the study's model-check level (Table 3, eq. 18).

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    StepResult
        ``agreement``: the model-check level's clearances (mm) and the per-pair agreement statistics, with
        one figure per pair; no data (a note) when the drive has no reduced model.
    """
    from berryshaker.experiment.agreement import model_agreement
    from berryshaker.report import plots as P

    if ctx.drive.reduced_model is None:
        return StepResult("agreement", None, note=f"the {ctx.drive.name} drive has no reduced model: there is "
                          "nothing to compare the multibody model with (claim 1 is not comparable)")
    ctx.say(f"{ctx.drive.reduced_model_name.upper()} vs multibody at level {MODEL_CHECK_LEVEL} (eq. 18; compiling "
            "on the first run)")
    lvl = level_set(ctx.machine, MODEL_CHECK_LEVEL)
    ag = model_agreement(ctx.machine, lvl, revolutions=3)
    ctx.engine_compiled()  # the workers can start the multibody runs while the figures are drawn here
    figs = []
    for k, (p, (a, b)) in enumerate(ag["series"].items()):
        name = f"fig{14 + k}_agreement_{p}.png"
        P.plot_time_series(ag["t"], {"multibody": a, "MLSD": b}, f"collision force at {p} [N]", ctx.figs / name,
                           f"Pair {p}: MLSD vs multibody, level {MODEL_CHECK_LEVEL} (study Fig. {14 + k})",
                           zoom="peak")
        figs.append(name)
    return StepResult("agreement", {"clearance_mm": {p: v * 1e3 for p, v in lvl.items()}, "pairs": ag["pairs"]},
                      figs)


#: perturbed starts of each model at the model-check level: the means claim 1 judges and the noise its row
#: comparisons allow for (benchmarks/HISTORY.md sec. 26)
MODEL_CHECK_STARTS = 8


def _model_check_jobs(ctx: StudyContext) -> list[dict]:
    return model_check_jobs(ctx.machine, level_set(ctx.machine, MODEL_CHECK_LEVEL), MODEL_CHECK_STARTS)


def plan_rows(ctx: StudyContext) -> list[PlannedRuns]:
    """Every clearance row in the multibody model and, if the drive has one, the reduced model (3 revolutions);
    with a reduced model also :data:`MODEL_CHECK_STARTS` replicate starts of each at the model-check level.

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    list of PlannedRuns
        Multibody rows, their perturbed starts and, with a reduced model, its rows and the model check's
        starts of both models (the reduced model's runs do not need the engine).
    """
    last = n_rows(ctx.machine)
    jobs = [dict(machine_data=ctx.data, clearance=clearance_row(ctx.machine, r), revolutions=3)
            for r in range(1, last + 1)]
    plans = [PlannedRuns(multibody_row, jobs, f"rows 1-{last}, multibody"),
             PlannedRuns(multibody_row, _row_start_jobs(ctx, jobs),
                         f"rows 1-{last} x {ctx.machine.harvest.replicates} perturbed starts, multibody")]
    if ctx.drive.reduced_model is not None:
        name = ctx.drive.reduced_model_name.upper()
        plans.append(PlannedRuns(reduced_row, jobs, f"rows 1-{last}, {name}", engine=False))
        try:
            check = _model_check_jobs(ctx)
        except ConfigError:  # replicates that would be copies: no model check (step_rows says why)
            return plans
        plans.append(PlannedRuns(multibody_row, check, f"level {MODEL_CHECK_LEVEL}, {len(check)} perturbed starts, "
                                                       "multibody"))
        # (started with the multibody runs, after the engine step: beside the engine's compilation on two cores
        # they slowed it by more than they took, benchmarks/HISTORY.md sec. 26)
        plans.append(PlannedRuns(reduced_row, check, f"level {MODEL_CHECK_LEVEL}, {len(check)} turned starts, {name}"))
    return plans


def _row_start_jobs(ctx: StudyContext, jobs: list[dict]) -> list[dict]:
    """Every row's job from ``harvest.replicates`` perturbed starts (seeds (seed_k, 0): the same starts for every
    row, common random numbers), row-major: the claims on collision forces (2 and 3) are judged on the mean of the
    per-start peaks with its noise, never on one run's peak (the peak of a chaotic impact sequence varies by
    10-30 % between starts)."""
    from berryshaker.harvest.virtual import replicate_seeds

    return [dict(j, seed=[sd, 0]) for j in jobs for sd in replicate_seeds(ctx.machine)]


def row_start_statistics(summaries: list, pairs, rows: list[int], starts: int) -> dict:
    """Per row and pair, the statistics of the per-start collision-force peaks and means over perturbed starts.

    ``summaries``: :func:`multibody_row` outputs, row-major (``starts`` per row; a failed run None).  Per row and
    pair: ``peak`` and ``mean`` each {mean, sd, se, p95 (of the per-start values that ran), values (one per planned
    start, in the starts' order, None where the run failed: paired comparisons match starts by position)},
    ``starts`` (the runs that finished).

    Parameters
    ----------
    summaries : list
        :func:`multibody_row` outputs (forces in N), row-major; None for a failed run.
    pairs : iterable of str
        Clearance pairs.
    rows : list of int
        The rows, in the summaries' order.
    starts : int
        Starts per row.

    Returns
    -------
    dict
        Row (as text) -> ``pairs`` (the statistics above, N) and ``starts``; rows with fewer than two finished
        starts are left out.
    """
    out = {}
    for i, r in enumerate(rows):
        chunk = summaries[i * starts:(i + 1) * starts]
        ss = [x for x in chunk if x is not None]
        if len(ss) < 2:
            continue
        per = {}
        for p in pairs:
            st = {}
            for key in ("peak", "mean"):
                v = np.array([x["collision_force_N"][p][key] for x in ss], float)
                st[key] = {"mean": float(v.mean()), "sd": float(v.std(ddof=1)), "se": float(v.std(ddof=1) / np.sqrt(v.size)),
                           "p95": float(np.percentile(v, 95)),
                           "values": [None if x is None else float(x["collision_force_N"][p][key]) for x in chunk]}
            per[p] = st
        out[str(r)] = {"pairs": per, "starts": len(ss)}
    return out


def step_rows(ctx: StudyContext) -> StepResult:
    """Every clearance row (single-factor sweeps and level sets) in the multibody and the reduced model.

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    StepResult
        ``rows``: per row the multibody and reduced-model summaries (forces N, moments N m), the perturbed
        starts' statistics (``starts``), the model check and per-row agreement; the row figures and a note.
    """
    last = n_rows(ctx.machine)
    ctx.say(f"clearance rows 1-{last} (single-factor sweeps and level sets)")
    rows = list(range(1, last + 1))
    plans = plan_rows(ctx)
    jobs = plans[0].jobs
    row_of = {id(j): r for j, r in zip(jobs, rows)}

    def describe(j):
        return f"row {row_of[id(j)]}: " + _describe(j["clearance"])

    out = {"multibody": {}, "mlsd": {}}
    mb_rows = ctx.collect(multibody_row, jobs, plans[0].label, describe)
    out["multibody"] = {str(r): v for r, v in zip(rows, mb_rows) if v is not None}
    starts = ctx.collect(multibody_row, plans[1].jobs, plans[1].label,
                         lambda j: f"start seed {j['seed'][0]}, " + _describe(j["clearance"]))
    out["starts"] = row_start_statistics(starts, ctx.machine.pair_names, rows, ctx.machine.harvest.replicates)
    note = ""
    if len(plans) > 2:
        ml_rows = ctx.collect(reduced_row, jobs, plans[2].label, describe)
        out["mlsd"] = {str(r): v for r, v in zip(rows, ml_rows) if v is not None}

        def start(j):
            return f"level {MODEL_CHECK_LEVEL}, seed {j['seed'][0]}"

        from berryshaker.experiment.agreement import model_check

        check = None
        if len(plans) > 3:
            check = model_check(ctx.collect(multibody_row, plans[3].jobs, plans[3].label, start),
                                ctx.collect(reduced_row, plans[4].jobs, plans[4].label, start), ctx.machine.pair_names)
        else:
            try:
                _model_check_jobs(ctx)
            except ConfigError as exc:
                note = f"no model check (claim 1 is not comparable): {exc}"
        if check is not None:
            check = {"level": MODEL_CHECK_LEVEL, **check}
        out["model_check"] = check
        # model agreement on every row, not only at the model-check level (the same statistics criterion); one
        # run per model and row, so a difference counts only beyond the noise of single runs measured at the
        # model-check level
        from berryshaker.experiment.agreement import summary_statistics_agreement

        noise = {p: check["pairs"][p]["single_run_noise"] for p in ctx.machine.pair_names} if check else {}
        out["agreement"] = {
            r: {p: summary_statistics_agreement(out["multibody"][r]["collision_force_N"][p],
                                                out["mlsd"][r]["collision_force_N"][p], noise=noise.get(p))
                for p in ctx.machine.pair_names}
            for r in out["multibody"] if r in out["mlsd"]}
    else:
        note = f"the {ctx.drive.name} drive has no reduced model: rows are multibody only"
    figs = _plot_rows(ctx.machine, out, ctx.figs)
    return StepResult("rows", out, figs, note)


def plan_fruit_force(ctx: StudyContext) -> list[PlannedRuns]:
    """Drive-pasts at the configured clearances and at the three level sets (the last three clearance rows).

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    list of PlannedRuns
        The drive-pasts (:func:`berryshaker.study.runs.fruit_force_run`) and their perturbed starts
        (:func:`berryshaker.study.runs.replicate_run`).
    """
    last = n_rows(ctx.machine)
    jobs = [dict(machine_data=ctx.data, clearance={})] + [
        dict(machine_data=ctx.data, clearance=clearance_row(ctx.machine, r)) for r in (last - 2, last - 1, last)]
    return [PlannedRuns(fruit_force_run, jobs, "fruit force runs"),
            PlannedRuns(replicate_run, _fruit_start_jobs(ctx), "fruit force: perturbed starts")]


def _fruit_class(machine) -> int:
    """Index of the branch class nearest the reference branch (diameter scale 1): the fruit-force branch."""
    return int(np.argmin([abs(s - 1.0) for s in machine.harvest.branch_classes]))


def _fruit_start_jobs(ctx: StudyContext) -> list[dict]:
    """Perturbed starts (``harvest.replicates``, the virtual harvest's seeds) of the fruit-force branch's drive-past
    at the configured clearances and at the three level sets: the fruit force's claims judged on replicate means
    (set-major; the same jobs as the virtual harvest's for that branch class, shared through the cache)."""
    from berryshaker.harvest.virtual import replicate_seeds
    from berryshaker.study.l9 import replicate_jobs

    last = n_rows(ctx.machine)
    c = _fruit_class(ctx.machine)
    seeds = replicate_seeds(ctx.machine)
    sets = [ctx.machine.clearance_sizes()] + [clearance_row(ctx.machine, r) for r in (last - 2, last - 1, last)]
    return [j for cl in sets for j in replicate_jobs(ctx.machine, cl, seeds, data=ctx.data) if j["seed"][1] == c]


def fruit_start_statistics(machine, outs: list, keys: list[str]) -> dict:
    """Peak stem force of the named fruit (``plant.fruit``: root, middle, end; mass m0) per perturbed start, read
    from each start's stem-force table (:func:`berryshaker.harvest.virtual.fruit_peak_force`), and its mean, SD and
    SE per set.  ``outs``: :func:`replicate_run` outputs, set-major (equal counts per set; a failed run None);
    ``keys``: the sets' names.

    Parameters
    ----------
    machine : MachineBase
        The machine description (its [plant] fruit).
    outs : list
        :func:`replicate_run` outputs, set-major; None for a failed run.
    keys : list of str
        The sets' names.

    Returns
    -------
    dict
        Set -> ``positions`` (fruit name -> ``mean``, ``sd``, ``se`` in N and ``values`` per start, N or None) and
        ``starts``; sets with fewer than two finished starts are left out.
    """
    from berryshaker.harvest.virtual import fruit_peak_force

    f = machine.plant.fruit
    m0 = f.mass
    n = len(outs) // len(keys)
    out = {}
    for i, k in enumerate(keys):
        envs = [None if o is None else np.array(o["envelope"]) for o in outs[i * n:(i + 1) * n]]
        if sum(e is not None for e in envs) < 2:
            continue
        per = {}
        for name, z in zip(f.names, f.positions):
            vals = [None if e is None else float(fruit_peak_force(e, np.array([z]), np.array([m0]), m0)[0])
                    for e in envs]
            v = np.array([x for x in vals if x is not None])
            per[name] = {"mean": float(v.mean()), "sd": float(v.std(ddof=1)), "se": float(v.std(ddof=1) / np.sqrt(v.size)),
                         "values": vals}  # one per planned start, None where the run failed (pairing by position)
        out[k] = {"positions": per, "starts": int(sum(e is not None for e in envs))}
    return out


def step_fruit_force(ctx: StudyContext) -> StepResult:
    """The machine drives past a branch (rigid-flexible coupling): fruit force at the configured clearances and
    at the level sets.

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    StepResult
        ``fruit_force``: the drive-pasts at the configured clearances (``chosen``) and the level sets
        (``rows``), the perturbed starts' peak stem forces (N) per set and the branch class; the fruit-force figures.
    """
    from berryshaker.report import plots as P

    ctx.say("fruit force (rigid-flexible coupling)")
    last = n_rows(ctx.machine)
    level_rows = (last - 2, last - 1, last)
    plan, starts = plan_fruit_force(ctx)
    ff = ctx.collect(fruit_force_run, plan.jobs, plan.label, lambda j: "clearances " + _describe(j["clearance"]))
    so = ctx.collect(replicate_run, starts.jobs, starts.label,
                     lambda j: f"start seed {j['seed'][0]}, clearances " + _describe(j["clearance"]))
    data = {"chosen": ff[0], "rows": {str(r): v for r, v in zip(level_rows, ff[1:]) if v is not None},
            "level_rows": list(level_rows),
            "starts": fruit_start_statistics(ctx.machine, so, ["chosen"] + [str(r) for r in level_rows]),
            "branch_class": ctx.machine.harvest.branch_classes[_fruit_class(ctx.machine)]}
    figs = []
    if ff[0] is not None:
        P.plot_fruit_force(np.array(ff[0]["distance"]), {k: np.array(v) for k, v in ff[0]["forces"].items()},
                           FRUIT_FORCE_N, ctx.figs / "fig24_26_fruit_force.png",
                           "Fruit harvesting force at the chosen clearances (study Figs. 24-26)",
                           peaks=ff[0]["peaks_exact"])
        figs.append("fig24_26_fruit_force.png")
    if all(v is not None for v in ff[1:]):
        P.plot_bars({f"level {i + 1}": [ff[i + 1]["peaks_exact"][n] for n in ("root", "middle", "end")]
                     for i, r in enumerate(level_rows)}, ["root", "middle", "end"], "peak fruit force [N]",
                    ctx.figs / "fruit_force_by_level.png",
                    f"Peak fruit force at level sets 1-3 (rows {level_rows[0]}-{level_rows[-1]})")
        figs.append("fruit_force_by_level.png")
    return StepResult("fruit_force", data, figs)


def step_l9(ctx: StudyContext) -> StepResult:
    """The study's L9 field test through the virtual harvest, analysed like field data.

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    StepResult
        ``l9``: the virtual L9 (:func:`berryshaker.study.l9.virtual_l9`) and its figures (drawn in workers);
        no data (a note, and a failure logged) when it fails.
    """
    from berryshaker.errors import SimulationError
    from berryshaker.experiment.analysis import quadratic_regression
    from berryshaker.report import plots as P

    ctx.say("virtual L9 field test")
    try:
        l9 = virtual_l9(ctx.machine, ctx.runner)
    except SimulationError as exc:
        ctx.failures.append({"step": "virtual L9", "run": "", "inputs": "L9 clearance sets", "error": str(exc)})
        return StepResult("l9", None, note=f"the virtual L9 failed: {exc}")
    pairs = list(ctx.machine.pair_names)
    values = np.array([[r["clearance_mm"][p] for p in pairs] for r in l9["runs"]])
    levels_mm = {p: [v * 1e3 for v in ctx.machine.clearance_levels()[p]] for p in pairs}
    # the figures are drawn in idle workers while the next steps run (StudyContext.draw)
    ctx.draw(P.plot_main_effects, l9, ctx.figs / "l9_main_effects.png", "Virtual L9: main effects (study Table 8)",
             level_values=levels_mm, factor_unit="mm")
    figs = ["l9_main_effects.png"]
    for k, name in enumerate(("efficiency", "unripe", "damage")):
        y = np.array([r[name] for r in l9["runs"]])
        ctx.draw(P.plot_response_surfaces, values, y, pairs, quadratic_regression(values, y, pairs), name,
                 ctx.figs / f"fig{27 + k}_surface_{name}.png")
        figs.append(f"fig{27 + k}_surface_{name}.png")
    figs += l9_replicate_figures(l9, levels_mm, ctx.figs, ctx.draw)
    return StepResult("l9", l9, figs)


def plan_l9(ctx: StudyContext) -> list[PlannedRuns]:
    """The replicated L9's coupled drive-pasts (not the runs at the recommendation: they depend on the analysis).

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    list of PlannedRuns
        One: the replicated L9's :func:`berryshaker.study.runs.replicate_run` jobs.
    """
    from berryshaker.study.l9 import l9_jobs
    from berryshaker.study.runs import replicate_run

    jobs, label = l9_jobs(ctx.machine, data=ctx.data)
    return [PlannedRuns(replicate_run, jobs, label)]


def l9_replicate_figures(l9: dict, levels_mm: dict, figs: Path, draw: Callable) -> list[str]:
    """Trade-off plot and main effects with 95 % intervals (harvest indexes; machine loads) of the replicated L9,
    each drawn by ``draw(fn, *args, **kwargs)`` (:meth:`StudyContext.draw`).

    Parameters
    ----------
    l9 : dict
        The virtual L9 (:func:`berryshaker.study.l9.virtual_l9`).
    levels_mm : dict of str to list of float
        Clearance levels per pair (mm).
    figs : Path
        Folder of the figures.
    draw : callable
        Draws one figure.

    Returns
    -------
    list of str
        File names of the figures asked for.
    """
    from berryshaker.report import plots as P
    from berryshaker.study.l9 import HARVEST_RESPONSES

    rep = l9.get("replicated") or {}
    out = []
    if l9.get("tradeoff"):
        draw(P.plot_tradeoff, l9["tradeoff"], figs / "l9_tradeoff.png")
        out.append("l9_tradeoff.png")
    units = l9.get("response_units") or {}
    for name, rows, title in (("l9_effects_harvest.png", [n for n in HARVEST_RESPONSES if n != "unripe_shed"],
                               "Virtual L9: harvest indexes"),
                              ("l9_effects_loads.png", [n for n in rep.get("responses", {})
                                                        if n.startswith(("peak_force_", "drive_torque_"))],
                               "Virtual L9: machine loads")):
        rows = [n for n in rows if n in rep.get("responses", {})]
        if rows:
            draw(P.plot_replicated_effects, rep, rows, figs / name, title, level_values=levels_mm, units=units)
            out.append(name)
    # Minitab-style effect figures (Pareto of standardized effects, residuals, interactions) of the harvest indexes
    obs = l9.get("observations") or {}
    rows = [n for n in ("efficiency", "ripe_removal", "damage") if n in obs and n in rep.get("responses", {})]
    if rows:
        pairs = list(levels_mm)
        lv = np.array([[r["levels"][p] for p in pairs] for r in l9["runs"]])
        draw(P.write_effect_figures, lv, {n: np.asarray(obs[n]) for n in rows}, pairs, rep, figs, "l9_",
             units=units, level_values=levels_mm, factor_units={p: "mm" for p in pairs}, blocks=rep.get("blocks", True))
        out += [f"l9_{k}_{n}.png" for n in rows for k in ("pareto", "residuals", "interactions")]
    return out


#: drive-shaft speeds of the harvest-against-frequency section (r/min); the configured speed is added
RESPONSE_SPEEDS_RPM = (60.0, 90.0, 120.0, 150.0, 180.0)


RESPONSE_LABEL = "harvest vs frequency: replicates (perturbed starts)"


def _response_runs(ctx: StudyContext) -> tuple[list[float], list, list[list[dict]]]:
    """Drive speeds (r/min, the configured one included), the machine at each, and its replicate jobs
    (:func:`berryshaker.study.l9.replicate_jobs` at the configured clearances)."""
    import math

    from berryshaker.config import machine_from_dict
    from berryshaker.harvest.virtual import with_drive_speed
    from berryshaker.study.l9 import replicate_jobs, replicate_seeds

    own = ctx.machine.drive_speed * 60 / (2 * math.pi)
    speeds = sorted(set(RESPONSE_SPEEDS_RPM) | {round(own, 6)})
    datas = [with_drive_speed(ctx.data, rpm * 2 * math.pi / 60) if not math.isclose(rpm, own) else ctx.data
             for rpm in speeds]
    seeds = replicate_seeds(ctx.machine)
    cal_cl = ctx.machine.clearance_sizes()
    machines = [machine_from_dict(d) for d in datas]
    return speeds, machines, [replicate_jobs(m, cal_cl, seeds, data=d) for m, d in zip(machines, datas)]


def plan_harvest_response(ctx: StudyContext) -> list[PlannedRuns]:
    """The replicated drive-pasts at every drive speed of the harvest-response step.

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    list of PlannedRuns
        One: the replicate jobs of every drive speed.
    """
    from berryshaker.study.runs import replicate_run

    _, _, per_speed = _response_runs(ctx)
    return [PlannedRuns(replicate_run, [j for jobs in per_speed for j in jobs], RESPONSE_LABEL)]


def step_harvest_response(ctx: StudyContext) -> StepResult:
    """Ripe removal, unripe shedding and damage against the shaking frequency at the configured clearances, and
    the calibration: both on the statistic the virtual L9 reports, the replicate mean over perturbed starts
    (``harvest.replicates`` replicates, the same seeds; at the configured speed the runs are the calibration's,
    shared through the cache), with the SD over the replicates; what is fitted, what is held out.

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    StepResult
        ``harvest_response``: ``rows`` (the harvest indexes at each drive speed, rpm: replicate means and SDs),
        ``configured_rpm`` and ``calibration`` (:func:`berryshaker.harvest.calibration.calibration_table`), with
        the figure.
    """
    import math

    from berryshaker.config import machine_from_dict
    from berryshaker.harvest.calibration import calibration_table
    from berryshaker.harvest.virtual import calibrate_harvest, replicate_response
    from berryshaker.report import plots as P
    from berryshaker.study.l9 import replicate_envelopes, replicate_seeds
    from berryshaker.study.runs import replicate_run

    ctx.say("harvest against shaking frequency, calibration")
    own = ctx.machine.drive_speed * 60 / (2 * math.pi)
    speeds, machines, per_speed = _response_runs(ctx)
    seeds = replicate_seeds(ctx.machine)
    outs = ctx.collect(replicate_run, [j for jobs in per_speed for j in jobs], RESPONSE_LABEL,
                       lambda j: f"drive {machine_from_dict(j['machine_data']).drive_speed * 60 / (2 * math.pi):.0f} "
                                 f"r/min, branch class x{j['scale']:g}, seed {j['seed']}")
    rows, cal_out, at = [], None, 0
    for rpm, m, jobs in zip(speeds, machines, per_speed):
        o = outs[at:at + len(jobs)]
        at += len(jobs)
        if math.isclose(rpm, own):
            cal_out = o
        reps = replicate_envelopes(m, o, seeds)
        if reps:
            rows.append({"speed_rpm": rpm, **replicate_response(m, reps)})
    data = {"rows": rows, "configured_rpm": own}
    figs = []
    if len(rows) > 1:
        P.plot_harvest_response([r["speed_rpm"] for r in rows], rows, "drive-shaft speed [rpm]",
                                ctx.figs / "harvest_vs_frequency.png",
                                "Virtual harvest against shaking frequency (configured clearances)",
                                frequency_hz=[r["shaking_frequency_hz"] for r in rows])
        figs.append("harvest_vs_frequency.png")
    # the calibration is on the statistic the virtual L9 reports, the mean over perturbed starts at the configured
    # clearances, converged: the configured speed's starts above (the L9's seeds) extended until every harvest
    # response's mean is known to harvest.se_target (study.l9.sequential_starts; identical runs are cached)
    from berryshaker.study.l9 import cells_from_outputs, sequential_starts

    from berryshaker.errors import SimulationError

    fit, seq = None, None
    if cal_out is not None and all(v is not None for v in cal_out):
        nc = len(ctx.machine.harvest.branch_classes)
        have_out = [cal_out[k * nc:(k + 1) * nc] for k in range(len(seeds))]
        have = cells_from_outputs(ctx.machine, cal_out, seeds)
        try:
            seq = sequential_starts(ctx.machine, ctx.runner, ctx.machine.clearance_sizes(), have=have, data=ctx.data,
                                    label="calibration starts", have_outputs=have_out)
            reps = [([np.array(v["envelope"]) for v in o], sd) for o, sd in zip(seq["outputs"], seq["seeds"])]
        except SimulationError as exc:  # a further start failed: the calibration rests on the first ones, and says so
            ctx.failures.append({"step": "calibration starts", "run": "", "inputs": "configured clearances",
                                 "error": str(exc)})
            reps = replicate_envelopes(ctx.machine, cal_out, seeds)
        fit = calibrate_harvest(ctx.machine, replicates=reps)
        if seq is not None:
            fit["sequential"] = {k: seq[k] for k in ("reached", "stopped", "target", "max", "statement")}
    elif cal_out is not None:  # some of the configured speed's starts failed: calibrate on the ones that ran
        reps = replicate_envelopes(ctx.machine, cal_out, seeds)
        if len(reps) >= 2:
            fit = calibrate_harvest(ctx.machine, replicates=reps)
    chosen = (ctx.results.get("fruit_force") or {}).get("chosen") or {}
    data["calibration"] = calibration_table(ctx.machine, chosen.get("summary"), fit)
    return StepResult("harvest_response", data, figs)


def plan_validation(ctx: StudyContext) -> list[PlannedRuns]:
    """The replicated drive-pasts of the validation cases (berryshaker.study.validation.case_jobs); the reference
    case's are the calibration's (cached).

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    list of PlannedRuns
        One per validation case that can be set up.
    """
    from berryshaker.study.runs import replicate_run
    from berryshaker.study.validation import case_jobs

    return [PlannedRuns(replicate_run, jobs, f"validation: {case.name}")
            for case, m, jobs, _ in case_jobs(ctx.machine, data=ctx.data) if jobs]


def step_validation(ctx: StudyContext) -> StepResult:
    """The harvest model against the published record (berryshaker.study.validation.validate: one row per
    published number with the model's value, interval and verdict; the same table as ``berryshaker validate``).

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    StepResult
        ``validation``: :func:`berryshaker.study.validation.validate`'s rows, replicates and summary.
    """
    from berryshaker.study.validation import validate

    ctx.say("harvest model against the published record")
    res = validate(ctx.machine, ctx.runner, data=ctx.data,
                   collect=lambda fn, jobs, label: ctx.collect(fn, jobs, label, lambda j: f"seed {j['seed']}"))
    return StepResult("validation", res)


def step_clearance_life(ctx: StudyContext) -> StepResult:
    """Clearance over the machine's life: wear growth of each joint and the recommended fits (life/).

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    StepResult
        ``clearance_life``: :func:`berryshaker.study.life_step.step_life`'s result; no data (a note, and a
        failure logged) when it fails.
    """
    ctx.say("clearance life (wear, fits)")
    try:
        return step_life(ctx)
    except Exception as exc:  # noqa: BLE001 - a life estimate must not sink the whole study
        ctx.failures.append({"step": "clearance life", "run": "", "inputs": "wear and fit surrogate",
                             "error": f"{type(exc).__name__}: {exc}"})
        return StepResult("clearance_life", None, note=f"the clearance-life step failed: {exc}")


#: replicates of each powered-drive level: seeded perturbed starts (docs/driveline.md sec. 5).  Over 3 revolutions
#: a single run's ripple scatters by 0.2-1.2 percentage points and its clearance energy loss by 0.014-0.047 J/rev
#: between starts (reference machine, 6 starts per level, measured); 4 replicates resolve the level-to-level steps
#: (13.0 -> 17.2 -> 22.5 %, 0.42 -> 0.81 -> 1.23 J/rev) many times over their standard error.
POWERED_REPLICATES = 4


def _replicate_mean(values: list):
    """Mean of each numeric leaf over replicate summaries of the same shape (dicts of numbers)."""
    first = values[0]
    if isinstance(first, dict):
        return {k: _replicate_mean([v[k] for v in values]) for k in first}
    return float(np.mean(values))


def _trend_text(name: str, unit: str, tr: dict, levels: list[str]) -> str:
    vals = " -> ".join(f"{m:.3g} +- {s:.2g}{unit}" for m, s in zip(tr["mean"], tr["sd"]))
    if tr["grows"]:
        return f"{name} grows with clearance ({vals} at levels {', '.join(levels)}, replicate mean +- SD)"
    flat = [f"{levels[i]}->{levels[i + 1]}" for i, s in enumerate(tr["steps"]) if s["verdict"] != "up"]
    return (f"{name} does not grow significantly at every level step ({vals}; no significant rise at "
            f"{', '.join(flat)}, Welch p >= {tr['alpha']:g} or a fall)")


POWERED_LEVELS = (1, 2, 3)


def plan_powered_drive(ctx: StudyContext) -> list[PlannedRuns]:
    """Powered-drive runs: levels 1-3, :data:`POWERED_REPLICATES` seeded perturbed starts each (3 revolutions).

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    list of PlannedRuns
        One: :func:`berryshaker.study.runs.powered_row` at levels 1-3 x :data:`POWERED_REPLICATES`
        starts.
    """
    from berryshaker.harvest.virtual import replicate_seeds

    seeds = replicate_seeds(ctx.machine, POWERED_REPLICATES)
    jobs = [dict(machine_data=ctx.data, clearance=level_set(ctx.machine, lv), revolutions=3, seed=[sd, lv])
            for lv in POWERED_LEVELS for sd in seeds]
    return [PlannedRuns(powered_row, jobs, f"powered drive, levels 1-3 x {len(seeds)} replicates")]


def step_powered_drive(ctx: StudyContext) -> StepResult:
    """Powered drive: speed ripple, input power and energy lost per joint against clearance (levels 1-3), the
    driveline of ``[driveline]`` (or its defaults) turning the drive shaft (docs/driveline.md sec. 5).  Each
    level is run from :data:`POWERED_REPLICATES` seeded perturbed starts; the table shows replicate means and
    a trend is stated only where the level-to-level step exceeds the replicate spread (:func:`replicate_trend`).

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    StepResult
        ``powered_drive``: per level the replicate means (speed ripple %, input power W, energy per
        revolution J, drive moment N m) with their SDs, the trends and the finding; no data when fewer than two
        levels ran.
    """
    from berryshaker.harvest.virtual import replicate_seeds

    ctx.say(f"powered drive at clearance levels 1-3, {POWERED_REPLICATES} perturbed starts each")
    levels = POWERED_LEVELS
    seeds = replicate_seeds(ctx.machine, POWERED_REPLICATES)
    (plan,) = plan_powered_drive(ctx)
    outs = ctx.collect(powered_row, plan.jobs, plan.label,
                       lambda j: f"{_describe(j['clearance'])}, start seed {j['seed']}")
    data, ripples, losts = {}, {}, {}
    pairs = ctx.machine.pair_names
    for i, lv in enumerate(levels):
        reps = [s for s in outs[i * len(seeds):(i + 1) * len(seeds)] if s is not None]
        if len(reps) < 2:
            continue
        keys = ("cam_speed_rpm", "speed_ripple_percent", "input_power_W", "energy_per_revolution_J", "drive_moment_Nm")
        d = {"clearance_mm": reps[0]["clearance_mm"], **{k: _replicate_mean([r[k] for r in reps]) for k in keys}}
        d["replicates"] = len(reps)
        d["audit_relative_residual"] = max(r["energy_audit"]["relative_residual"] for r in reps)
        ripples[str(lv)] = [r["speed_ripple_percent"] for r in reps]
        losts[str(lv)] = [sum(v for j, v in r["energy_per_revolution_J"].items() if j in pairs) for r in reps]
        d["speed_ripple_sd_percent"] = float(np.std(ripples[str(lv)], ddof=1))
        d["clearance_energy_sd_J"] = float(np.std(losts[str(lv)], ddof=1))
        data[str(lv)] = d
    if len(data) < 2:
        return StepResult("powered_drive", None, note="the powered-drive runs failed (see Failed runs)")
    names = sorted(data)
    ripple_tr = replicate_trend([ripples[k] for k in names])
    lost_tr = replicate_trend([losts[k] for k in names])
    lost = {k: m for k, m in zip(names, lost_tr["mean"])}
    text = _trend_text("The drive-shaft speed ripple", " %", ripple_tr, names)
    verdict = (text + ": larger clearances give faster impacts and larger drive-moment peaks, which the compliant "
               "mesh and belt pass to the shaft's speed." if ripple_tr["grows"] else
               text + ": at these levels the swing of the drive moment over the cam cycle, not the impacts, sets "
               "the ripple.")
    verdict += " " + _trend_text("The energy lost in the clearance joints", " J/rev", lost_tr, names) + "."
    return StepResult("powered_drive", {"levels": data, "replicates": len(seeds), "seeds": seeds,
                                        "ripple_grows_with_clearance": ripple_tr["grows"], "ripple_trend": ripple_tr,
                                        "clearance_energy_per_revolution_J": lost, "energy_trend": lost_tr,
                                        "energy_grows_with_clearance": lost_tr["grows"], "finding": verdict})


@dataclass(frozen=True)
class Step:
    """One step of the study: what runs it and what renders it.

    Attributes
    ----------
    key : str
        Its name in the timings (``summary.json``'s ``timings_s``) and in :data:`PLANS`.
    run : callable
        ``run(ctx) -> StepResult``.
    result : str
        Its :class:`StepResult`'s name: the key of its data in the results, and of its note.
    sections : tuple of callable
        The renderers of its report sections, in order (:mod:`berryshaker.report.sections`); the report numbers
        them in the steps' order.
    """

    key: str
    run: Callable[[StudyContext], StepResult]
    result: str
    sections: tuple = ()


#: the study's steps, in the order they run and their sections stand in the report (the machine's own steps,
#: then the harvest against frequency and the published record); only ``harvest_response`` reads an earlier
#: step's results (``fruit_force``)
STEPS = (Step("kinematics", step_kinematics, "kinematics", (S.kinematics_section,)),
         Step("model_agreement", step_agreement, "agreement", (S.model_agreement_section,)),
         Step("clearance_rows", step_rows, "rows", (S.collision_force_section, S.comb_load_section)),
         Step("fruit_force", step_fruit_force, "fruit_force", (S.fruit_force_section,)),
         Step("virtual_l9", step_l9, "l9", (S.virtual_l9_section,)),
         Step("clearance_life", step_clearance_life, "clearance_life", (S.clearance_life_section,)),
         Step("powered_drive", step_powered_drive, "powered_drive", (S.powered_drive_section,)),
         Step("harvest_response", step_harvest_response, "harvest_response", (S.harvest_response_section,)),
         Step("validation", step_validation, "validation", (S.validation_section,)))


def report_sections() -> list[tuple[str, tuple]]:
    """The steps' report sections in the steps' order: what :func:`berryshaker.report.html.study_report` renders.

    Returns
    -------
    list of (str, tuple of callable)
        Per step with sections: its result's name and its section renderers.
    """
    return [(s.result, s.sections) for s in STEPS if s.sections]


#: the runs each step will ask for, known before it starts (:class:`PlannedRuns`), by step name
PLANS = {"clearance_rows": plan_rows, "fruit_force": plan_fruit_force, "virtual_l9": plan_l9,
         "harvest_response": plan_harvest_response, "validation": plan_validation, "powered_drive": plan_powered_drive}
#: the step that compiles the multibody engine in this process (its first multibody run)
ENGINE_STEP = "model_agreement"


def planned_runs(ctx: StudyContext) -> list[PlannedRuns]:
    """Every step's :data:`PLANS`, in step order; a step whose plan fails is left out (the step itself reports
    the error when it runs).

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
    for step in STEPS:
        if step.key in PLANS:
            try:
                out += PLANS[step.key](ctx)
            except Exception:  # noqa: BLE001 - the step will meet (and report) the same error
                continue
    return out


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


def run_steps(machine, runner, figs: Path, console=None) -> tuple[dict, dict, list[dict], dict]:
    """Run every step; return (results by step name, StepResults, failures, timings in s).

    The steps run in order in this process, but their runs need not wait for them: the runs every step will ask
    for (:data:`PLANS`) start ahead in the runner's idle workers (``SweepRunner.prefetch``; local pool only).
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
    results : dict
        Each step's data by step name, with ``claims`` and ``failures``.
    steps : dict of str to StepResult
        Each step's result.
    failures : list of dict
        Failed runs.
    timings : dict of str to float
        Seconds per step and ``total`` (s).
    """

    def say(msg):
        if console is not None:
            console.print(f"[bold cyan]study[/] {msg}")

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
        warm = None
        if runner.workers > 1 and not runner.scheduler and any(p.engine and not runner.all_cached(p.fn, p.jobs)
                                                               for p in plans):
            warm = runner.warm_up(warm_worker, dict(machine_data=ctx.data))
        defer = warm is not None and usable_cores() < 3
        if not defer:
            for p in plans:
                if not p.engine:
                    runner.prefetch(p.fn, p.jobs, chunks=1)
        engine_ready = not any(step.key == ENGINE_STEP for step in STEPS)

        def start_planned():
            nonlocal plans
            for p in plans:
                runner.prefetch(p.fn, p.jobs)
            plans = []

        ctx.engine_compiled = start_planned
        for step in STEPS:
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
    results["claims"] = check_claims(results, machine.pair_names)
    results["failures"] = ctx.failures
    timings["total"] = time.perf_counter() - t_all
    return results, steps, ctx.failures, timings


def study_summary(machine, results: dict, failures: list, timings: dict, runner_stats: dict) -> dict:
    """The head of summary.json: claims, the recommended clearances, failures, timings, run counts.

    Parameters
    ----------
    machine : MachineBase
        The study's machine description.
    results : dict
        The steps' data with ``claims`` (:func:`run_steps`).
    failures : list of dict
        Failed runs.
    timings : dict of str to float
        Seconds per step (s).
    runner_stats : dict
        The runner's run counts.

    Returns
    -------
    dict
        ``package``, ``version``, ``machine``, ``drive``, ``claims``, ``optimum`` (the L9's recommendation: code,
        clearances in mm, efficiency kg/min, unripe and damage rates %, the study's field result...; None without
        an L9), ``failures``, ``timings_s`` (s), ``runs`` and :func:`l9_summary`'s entries.
    """
    optimum = None
    l9 = results.get("l9")
    if l9 is not None:
        rec = l9["recommended"]
        vh = rec["virtual_harvest"]
        optimum = {"code": rec["code"], "name": rec.get("name"), "clearance_mm": rec["clearance_mm"],
                   "efficiency_kg_min": vh["efficiency_kg_min"], "unripe_rate_pct": vh["unripe_rate_pct"],
                   "damage_rate_pct": vh["damage_rate_pct"], "study": {"code": CHOSEN_CODE, **FIELD_RESULT},
                   "fitted": rec.get("fitted", []), "starts": rec.get("starts"),
                   "intervals": rec.get("replicates"), "basis": rec.get("basis"), "statement": rec.get("statement")}
    return {
        "package": "berryshaker", "version": __version__, "machine": machine.machine.name,
        "drive": machine.DRIVE,
        "claims": [{k: c[k] for k in ("id", "verdict", "detail", "claim", "criterion")} for c in results["claims"]],
        "optimum": optimum, "failures": failures, "timings_s": timings, "runs": dict(runner_stats),
        **l9_summary(l9),
    }


def l9_summary(l9: dict | None) -> dict:
    """summary.json entries of the replicated L9: ``l9_replicates`` (pooled replicate SD, dof and significant
    factors per response; the solver-tolerance check) and ``tradeoff`` (the trade-off table's rows).

    Parameters
    ----------
    l9 : dict or None
        The virtual L9 (:func:`berryshaker.study.l9.virtual_l9`).

    Returns
    -------
    dict
        ``l9_replicates``, ``tradeoff`` and ``tradeoff_columns``; empty without a replicated L9.
    """
    if not l9 or "replicated" not in l9:
        return {}
    rep = l9["replicated"]
    per = {n: {"replicate_sd": ra["anova"]["pure_error"]["ms"] ** 0.5, "dof": ra["anova"]["pure_error"]["df"],
               "blocked_error_sd": ra["anova"]["error"]["ms"] ** 0.5, "blocked_error_dof": ra["anova"]["error"]["df"],
               "significant_factors": ra["significant_factors"],
               "p": {f: d["p"] for f, d in ra["factors"].items()}, "paired": (l9.get("paired") or {}).get(n)}
           for n, ra in rep["responses"].items()}
    return {"l9_replicates": {"replicates": rep["replicates"], "blocks": rep.get("blocks"), "seeds": rep.get("seeds"),
                              "perturbation": rep.get("perturbation"), "significance_rule": rep["significance_rule"],
                              "responses": per, "tolerance_check": l9.get("tolerance_check")},
            "tradeoff": l9.get("tradeoff", []), "tradeoff_columns": l9.get("tradeoff_columns", [])}


def run_study(machine, out_dir: Path, runner, console=None) -> dict:
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
    dict
        :func:`study_summary`.
    """
    from berryshaker.outputs import staged_directory, write_json_atomic, write_text_atomic
    from berryshaker.report.html import study_report
    from berryshaker.study.tables import strip_series, write_tables

    with staged_directory(out_dir, kind="study") as stage:
        figs = stage / "figures"
        figs.mkdir()
        tables = stage / "tables"
        tables.mkdir()
        results, steps, failures, timings = run_steps(machine, runner, figs, console)
        summary = study_summary(machine, results, failures, timings, runner.stats)
        write_tables(machine, results, tables)
        write_json_atomic(stage / "summary.json", {**summary, "results": strip_series(results),
                                                   "machine_si": machine.model_dump(mode="json")})
        write_text_atomic(stage / "report.html", study_report(results, summary, machine, figs, steps,
                                                              sections=report_sections()))
    return summary


def _plot_rows(machine, rows: dict, figs: Path) -> list[str]:
    from berryshaker.report import plots as P

    mb, ml = rows["multibody"], rows["mlsd"]
    last = n_rows(machine)
    models = [("multibody", mb)] + ([("MLSD", ml)] if ml else [])
    if not all(str(r) in m for r in range(1, last + 1) for _, m in models):
        return []  # a failed row: the tables and the Failed runs section tell which
    names = []
    levels = machine.clearance_levels()
    for k, p in enumerate(machine.pair_names):
        rr = [1] + [2 + 3 * k + j for j in range(3)]
        labels = ["none"] + [f"{levels[p][j] * 1e3:g} mm" for j in range(3)]
        series = {"multibody peak": [mb[str(r)]["collision_force_N"][p]["peak"] for r in rr]}
        if ml:
            series["MLSD peak"] = [ml[str(r)]["collision_force_N"][p]["peak"] for r in rr]
        series["multibody mean"] = [mb[str(r)]["collision_force_N"][p]["mean"] for r in rr]
        name = f"fig{18 + k}_rows_{p}.png"
        P.plot_bars(series, labels, f"collision force at joint {p} [N]", figs / name,
                    f"Clearance {p} alone (rows {rr[1]}-{rr[-1]}; study Fig. {18 + k})", pair=p, reference_index=0)
        names.append(name)
    rr = [1, last - 2, last - 1, last]
    labels = ["none", "level 1", "level 2", "level 3"]
    for k, side in enumerate(("left", "right")):
        series = {"multibody rms": [mb[str(r)]["load_moment_Nm"][side]["rms"] for r in rr],
                  "multibody peak": [mb[str(r)]["load_moment_Nm"][side]["peak"] for r in rr]}
        if ml:
            series["MLSD rms"] = [ml[str(r)]["load_moment_Nm"][side]["rms"] for r in rr]
        name = f"fig{22 + k}_moment_{side}.png"
        P.plot_bars(series, labels, f"{side} comb load moment [N m]", figs / name,
                    f"{side.capitalize()} comb load moment, row 1 and the level sets (study Fig. {22 + k})")
        names.append(name)
    return names
