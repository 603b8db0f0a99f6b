"""Study step ``harvest_response``: the harvest against the shaking frequency with the calibration (:func:`plan`,
:func:`run`), its figure and its report section (:func:`harvest_response_section`, which also reads the
``fruit_force`` step's drive-past).  Its run functions are in :mod:`berryshaker.study.runs`; its data is a
:class:`~berryshaker.study.harvest_records.HarvestResponse`.
"""

from __future__ import annotations

from berryshaker.config import value_tag
from berryshaker.report.sections import SectionInput, details, maybe_img, table
from berryshaker.study.harvest_records import Calibration, HarvestResponse, HarvestSpeedRow
from berryshaker.study.step_context import PlannedRuns, StudyContext
from berryshaker.study.step_result import FailedRun, Step, StepResult
from berryshaker.user_text import html_text

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


def plan(ctx: StudyContext) -> list[PlannedRuns]:
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


def run(ctx: StudyContext) -> StepResult:
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
    from berryshaker.runs.cache import value_digest
    from berryshaker.study.l9 import replicate_envelopes, replicate_starts
    from berryshaker.study.runs import replicate_run, stored_harvest

    ctx.say("harvest against shaking frequency, calibration")
    own = ctx.machine.drive_speed * 60 / (2 * math.pi)
    speeds, machines, per_speed = _response_runs(ctx)
    seeds = replicate_starts(ctx.machine)
    outs = ctx.collect(replicate_run, [j for jobs in per_speed for j in jobs], RESPONSE_LABEL,
                       lambda j: f"drive {machine_from_dict(j['machine_data']).drive_speed * 60 / (2 * math.pi):.0f} "
                                 f"r/min, seed {j['seed']}")
    rows, cal_out, at = [], None, 0
    for rpm, m, jobs in zip(speeds, machines, per_speed):
        o = outs[at:at + len(jobs)]
        at += len(jobs)
        if math.isclose(rpm, own):
            cal_out = o
        reps = replicate_envelopes(m, o, seeds)
        if reps:  # each start's responses as its run kept them (the same description and start), else computed
            digest = value_digest(jobs[0]["machine_data"])
            known = [stored_harvest(out, digest, k) for out, k in zip(o, seeds) if out is not None]
            rows.append({"speed_rpm": rpm, **replicate_response(m, reps, known)})
    figs = []
    if len(rows) > 1:
        ctx.draw(P.plot_harvest_response, [r["speed_rpm"] for r in rows], rows, "drive-shaft speed [rpm]",
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
        have = cells_from_outputs(ctx.machine, cal_out, seeds)
        try:
            seq = sequential_starts(ctx.machine, ctx.runner, ctx.machine.clearance_sizes(), have=have, data=ctx.data,
                                    label="calibration starts", have_outputs=cal_out)
            reps = replicate_envelopes(ctx.machine, seq["outputs"], seq["seeds"])
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


def harvest_response_section(inp: SectionInput) -> tuple[str, list[str]]:
    """The comb's load (the bush), harvest against shaking frequency, calibration (fitted / held out).  Owned by
    the study step ``harvest_response``; its first paragraph reads the ``fruit_force`` step's drive-past at the
    chosen clearances (the comb load moment with the bush in the comb).

    Parameters
    ----------
    inp : SectionInput
        Results (``harvest_response``, a ``berryshaker.study.harvest_records.HarvestResponse``: speeds r/min,
        frequency Hz, rates %, efficiency kg/min; ``fruit_force``'s ``chosen`` summary, a
        ``berryshaker.study.fruit_force_records.FruitForceSummary``: moments in N m), machine, figures.

    Returns
    -------
    tuple of (str, list of str)
        Title and HTML parts.
    """
    title = "The bush as the comb's load; harvest against shaking frequency; calibration"
    res, figs, parts = inp.res, inp.figs, []
    ff = res.fruit_force
    chosen = None if ff is None or ff.chosen is None else ff.chosen.summary
    if chosen is not None and chosen.load_moment_Nm:
        bush = chosen.bush
        who = (f"the sum of the reactions of {bush.branches} branches ({bush.members} simulated members with "
               f"{bush.modes_per_member} modes each, seed {bush.seed}, plus the instrumented fruit branch)"
               if chosen.load_model == "branches" and bush is not None
               else "the aggregate spring-damper (combs.load_model = aggregate)")
        parts.append(f"<p>Comb load moment at the chosen clearances while the bush is in the comb: {html_text(who)}."
                     f" Per comb, about its shaft; compare {inp.ref('comb_load_section', 'the comb-load section')}'s "
                     "aggregate spring-damper, which loads the combs about 40 times more.</p>")
        parts.append(table(["comb", "peak (N m)", "rms (N m)"],
                            [[side, v.peak, v.rms] for side, v in chosen.load_moment_Nm.items()]))
    hr = res.harvest_response
    if hr is None:
        parts.append("<p>Not available (see Failed runs).</p>")
        return title, parts
    reps = next((r.replicates for r in hr.rows if r.replicates), None)
    beta = inp.machine.harvest.miner_exponent
    tag = value_tag(inp.machine, "harvest.miner_exponent")
    parts.append("<p>The virtual harvest against the drive-shaft speed (one comb cycle per revolution) at the "
                 "configured clearances, every other value as described.  Detachment adds up over load cycles "
                 f"(Miner, Basquin exponent {beta:g} [{tag}]), so removal grows with shaking time (travel speed: "
                 "docs/harvest.md, \"Trends\")."
                 + (f" Each cell: the expectation over {reps} perturbed starts ± the start-to-start SD; in brackets "
                    "one counted field test's SD." if reps else "") + "</p>")
    names = list(hr.rows[0].responses) if hr.rows else []

    def _sd(s):  # the expectation with the model's SD and the field test's
        return f"{s.mean:.3g} ± {s.sd:.2g} ({s.field_sd:.2g})"

    parts.append(table(["drive speed (r/min)", "frequency (Hz)"]
                        + [f"{n.replace('_', ' ')} ({hr.rows[0].responses[n].unit})" for n in names],
                        [[r.speed_rpm, r.shaking_frequency_hz, *[_sd(r.responses[n]) for n in names]]
                         for r in hr.rows]))
    maybe_img(parts, figs / "harvest_vs_frequency.png", "Virtual harvest against shaking frequency")
    cal = hr.calibration
    if cal is not None:
        parts.append(details("Calibration: every plant and picking parameter, its provenance, the held-out checks", [
            "<p>Calibration: every plant and picking parameter with its provenance; [calibrated] values "
            "were fitted to the target named, the quantities below them were not fitted and are "
            "held-out comparisons with the study (docs/plant.md).</p>",
            table(["parameter", "value", "unit", "tag", "target or source"],
                   [[p.parameter, p.value, p.unit, p.tag, p.target_or_source] for p in cal.parameters], left=(0, 3, 4)),
            table(["quantity", "model", "study", "inside the study's range"],
                   [[h.quantity, h.model, h.study, "-" if h.inside is None else h.inside] for h in cal.held_out])]))
    return title, parts


#: the step in the study's step table (:data:`berryshaker.study.steps.STEPS`)
STEP = Step(key="harvest_response", run=run, result="harvest_response",
            sections=(harvest_response_section,), plan=plan)
