"""Study step ``validation``: the harvest model against the published record (:func:`plan`, :func:`run`; the
comparison is :func:`berryshaker.study.validation.validate`) and its report section (:func:`validation_section`).
Its data is a :class:`~berryshaker.study.harvest_records.Validation`.
"""

from __future__ import annotations

from berryshaker.report.sections import Raw, SectionInput, details, num, table
from berryshaker.study.harvest_records import Validation
from berryshaker.study.step_context import PlannedRuns, StudyContext
from berryshaker.study.step_result import Step, StepResult
from berryshaker.user_text import html_text


def plan(ctx: StudyContext) -> list[PlannedRuns]:
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


def run(ctx: StudyContext) -> StepResult:
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


def validation_section(inp: SectionInput) -> tuple[str, list[str]]:
    """The harvest model against the published record (study step ``validation``,
    berryshaker.study.validation.validate).

    Parameters
    ----------
    inp : SectionInput
        Results (``validation``, a ``berryshaker.study.harvest_records.Validation``: ``rows``, one per published
        number, in its unit; ``summary``; ``replicates``), machine.

    Returns
    -------
    tuple of (str, list of str)
        Title and HTML parts: the table (published value, model value with its interval, verdict, held out) and the
        counts; sources by their key in the record (full citations: docs/published_record.md, ``validate --json``).
    """
    title = "The harvest model against the published record (docs/harvest.md, Validation)"
    val = inp.res.validation
    if val is None:
        return title, ["<p>Not available (see Failed runs).</p>"]
    s = val.summary
    parts = [f"<p>Every published number the model can represent, run from {val.replicates} perturbed starts: the "
             "model's value with the 95 % prediction interval of one field result (an efficiency's widened by the "
             "published yield's range; wider than x10: no verdict) and the verdict; nothing is fitted to any of "
             f"them but the inputs.  Held out: {s.held_out} numbers: {s.consistent} consistent, "
             f"{s.not_reproduced} not reproduced, {s.no_verdict} without a verdict, {s.not_comparable} not "
             f"comparable; {s.inputs} inputs.</p>"]

    def model(r):
        if r.model is None:
            return "-"
        return Raw(f"{num(r.model)} {html_text(r.unit)}<br><span class='small'>[{num(r.lo)}, "
                    f"{num(r.hi)}]</span>")

    header = ["published number", "source", "published", "model [interval]", "verdict", "held out"]

    def rows(keep):
        return [[r.quantity, r.source_key, f"{num(r.published)} {r.unit}", model(r), r.verdict,
                 "yes" if r.held_out else "no"] for r in val.rows if keep(r)]

    parts.append(table(header, rows(lambda r: r.verdict != "not comparable"), left=(0, 1, 4)))
    other = [r for r in val.rows if r.verdict == "not comparable"]
    if other:
        reasons = sorted({r.how for r in other})
        parts.append(details(f"Table: {len(other)} published numbers of machines this description does not "
                              "represent (not comparable)",
                              [table(["published number", "source", "published", "case"],
                                      [[r.quantity, r.source_key, f"{num(r.published)} {r.unit}", r.case]
                                       for r in other], left=(0, 1, 3)),
                               "<p>" + html_text("; ".join(reasons)) + ".</p>"]))
    return title, parts


#: the step in the study's step table (:data:`berryshaker.study.steps.STEPS`)
STEP = Step(key="validation", run=run, result="validation", sections=(validation_section,), plan=plan)
