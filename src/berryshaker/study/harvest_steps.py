"""The study's harvest steps: the fruit force of the machine driving past a branch (:func:`plan_fruit_force`,
:func:`step_fruit_force`, :func:`fruit_start_statistics`), the virtual L9 field test with its figures
(:func:`plan_l9`, :func:`step_l9`, :func:`l9_replicate_figures`), the harvest against the shaking frequency with the
calibration (:func:`plan_harvest_response`, :func:`step_harvest_response`) and the harvest model against the
published record (:func:`plan_validation`, :func:`step_validation`).  Steps of
:data:`berryshaker.study.pipeline.STEPS`; their run functions are in :mod:`berryshaker.study.runs`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

import numpy as np

from berryshaker.experiment.clearance_sets import clearance_row, n_rows
from berryshaker.reference_study import FRUIT_FORCE_N
from berryshaker.study.fruit_force_records import DrivePast, FruitForceStep, FruitStartSet
from berryshaker.study.harvest_records import Calibration, HarvestResponse, HarvestSpeedRow, Validation
from berryshaker.study.l9 import virtual_l9
from berryshaker.study.runs import fruit_force_run, replicate_run
from berryshaker.study.step_context import PlannedRuns, StudyContext, describe_clearance
from berryshaker.study.step_result import FailedRun, StepResult


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
    from berryshaker.harvest.virtual import replicate_starts
    from berryshaker.study.l9 import replicate_jobs

    last = n_rows(ctx.machine)
    c = _fruit_class(ctx.machine)
    seeds = replicate_starts(ctx.machine)
    sets = [ctx.machine.clearance_sizes()] + [clearance_row(ctx.machine, r) for r in (last - 2, last - 1, last)]
    return [j for cl in sets for j in replicate_jobs(ctx.machine, cl, seeds, data=ctx.data) if j["seed"][2] == c]


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
        ``fruit_force``: a :class:`~berryshaker.study.fruit_force_records.FruitForceStep`, the drive-pasts at the
        configured clearances (``chosen``) and the level sets (``rows``), the perturbed starts' peak stem forces (N)
        per set and the branch class; the fruit-force figures.
    """
    from berryshaker.report import plots as P

    ctx.say("fruit force (rigid-flexible coupling)")
    last = n_rows(ctx.machine)
    level_rows = (last - 2, last - 1, last)
    plan, starts = plan_fruit_force(ctx)
    ff = ctx.collect(fruit_force_run, plan.jobs, plan.label, lambda j: "clearances " + describe_clearance(j["clearance"]))
    so = ctx.collect(replicate_run, starts.jobs, starts.label,
                     lambda j: f"start seed {j['seed'][0]}, clearances " + describe_clearance(j["clearance"]))
    starts_stats = fruit_start_statistics(ctx.machine, so, ["chosen"] + [str(r) for r in level_rows])
    data = FruitForceStep(chosen=None if ff[0] is None else DrivePast.from_json(ff[0]),
                          rows={str(r): DrivePast.from_json(v) for r, v in zip(level_rows, ff[1:]) if v is not None},
                          level_rows=list(level_rows),
                          starts={k: FruitStartSet.from_json(v) for k, v in starts_stats.items()},
                          branch_class=ctx.machine.harvest.branch_classes[_fruit_class(ctx.machine)])
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
        ``l9``: the virtual L9 (:class:`~berryshaker.study.l9_records.VirtualL9`,
        :func:`berryshaker.study.l9.virtual_l9`) and its figures (drawn in workers, from its JSON form); no data
        (a note, and a failure logged) when it fails.
    """
    from berryshaker.errors import SimulationError
    from berryshaker.experiment.analysis import quadratic_regression
    from berryshaker.report import plots as P

    ctx.say("virtual L9 field test")
    try:
        l9 = virtual_l9(ctx.machine, ctx.runner)
    except SimulationError as exc:
        ctx.failures.append(FailedRun(step="virtual L9", run="", inputs="L9 clearance sets", error=str(exc)))
        return StepResult("l9", None, note=f"the virtual L9 failed: {exc}")
    pairs = list(ctx.machine.pair_names)
    values = np.array([[r.clearance_mm[p] for p in pairs] for r in l9.runs])
    levels_mm = {p: [v * 1e3 for v in ctx.machine.clearance_levels()[p]] for p in pairs}
    # the figures are drawn in idle workers while the next steps run (StudyContext.draw); the plots read the JSON form
    l9_json = l9.to_json()
    ctx.draw(P.plot_main_effects, l9_json, ctx.figs / "l9_main_effects.png", "Virtual L9: main effects (study Table 8)",
             level_values=levels_mm, factor_unit="mm")
    figs = ["l9_main_effects.png"]
    for k, name in enumerate(("efficiency", "unripe", "damage")):
        y = np.array([getattr(r, name) for r in l9.runs])
        ctx.draw(P.plot_response_surfaces, values, y, pairs, quadratic_regression(values, y, pairs), name,
                 ctx.figs / f"fig{27 + k}_surface_{name}.png")
        figs.append(f"fig{27 + k}_surface_{name}.png")
    figs += l9_replicate_figures(l9_json, levels_mm, ctx.figs, ctx.draw)
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
        The virtual L9's JSON form (``VirtualL9.to_json()`` of :func:`berryshaker.study.l9.virtual_l9`; the figures
        are drawn in pool workers from plain data).
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
                                                        if n.startswith(("design_force_", "peak_force_", "drive_torque_"))],
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
    from berryshaker.study.l9 import replicate_jobs, replicate_starts

    own = ctx.machine.drive_speed * 60 / (2 * math.pi)
    speeds = sorted(set(RESPONSE_SPEEDS_RPM) | {round(own, 6)})
    datas = [with_drive_speed(ctx.data, rpm * 2 * math.pi / 60) if not math.isclose(rpm, own) else ctx.data
             for rpm in speeds]
    seeds = replicate_starts(ctx.machine)
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
        ``harvest_response``: a :class:`~berryshaker.study.harvest_records.HarvestResponse`, ``rows`` (the
        harvest indexes at each drive speed, rpm: replicate means and SDs), ``configured_rpm`` and ``calibration``
        (:func:`berryshaker.harvest.calibration.calibration_table`), with the figure.
    """
    import math

    from berryshaker.config import machine_from_dict
    from berryshaker.harvest.calibration import calibration_table
    from berryshaker.harvest.virtual import calibrate_harvest, replicate_response
    from berryshaker.report import plots as P
    from berryshaker.study.l9 import replicate_envelopes, replicate_starts
    from berryshaker.study.runs import replicate_run

    ctx.say("harvest against shaking frequency, calibration")
    own = ctx.machine.drive_speed * 60 / (2 * math.pi)
    speeds, machines, per_speed = _response_runs(ctx)
    seeds = replicate_starts(ctx.machine)
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
    from berryshaker.errors import SimulationError
    from berryshaker.study.l9 import cells_from_outputs, sequential_starts

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
            ctx.failures.append(FailedRun(step="calibration starts", run="", inputs="configured clearances",
                                          error=str(exc)))
            reps = replicate_envelopes(ctx.machine, cal_out, seeds)
        fit = calibrate_harvest(ctx.machine, replicates=reps)
        if seq is not None:
            fit["sequential"] = {k: seq[k] for k in ("reached", "stopped", "target", "max", "statement")}
    elif cal_out is not None:  # some of the configured speed's starts failed: calibrate on the ones that ran
        reps = replicate_envelopes(ctx.machine, cal_out, seeds)
        if len(reps) >= 2:
            fit = calibrate_harvest(ctx.machine, replicates=reps)
    ff = ctx.results.get("fruit_force")  # a FruitForceStep, or None when that step produced no data
    chosen = None if ff is None or ff.chosen is None else ff.chosen.summary.to_json()
    data = HarvestResponse(rows=[HarvestSpeedRow.from_columns(r["speed_rpm"], r) for r in rows], configured_rpm=own,
                           calibration=Calibration.from_json(calibration_table(ctx.machine, chosen, fit)))
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
        ``validation``: :func:`berryshaker.study.validation.validate`'s rows, replicates and summary as a
        :class:`~berryshaker.study.harvest_records.Validation`.
    """
    from berryshaker.study.validation import validate

    ctx.say("harvest model against the published record")
    res = validate(ctx.machine, ctx.runner, data=ctx.data,
                   collect=lambda fn, jobs, label: ctx.collect(fn, jobs, label, lambda j: f"seed {j['seed']}"))
    return StepResult("validation", Validation.from_json(res))
