"""Study step ``model_agreement``: the reduced model against the multibody model at the model-check level (Table 3,
eq. 18; :func:`run`, the study's first multibody run, which compiles the engine) and its report section
(:func:`model_agreement_section`, which also shows the ``clearance_rows`` step's model check).  Its data is a
:class:`~berryshaker.study.mechanics_records.ModelAgreement`.
"""

from __future__ import annotations

from berryshaker.experiment.clearance_sets import level_set
from berryshaker.reference_study import EQ18_F, MODEL_CHECK_LEVEL
from berryshaker.report.sections import SectionInput, details, maybe_img, table
from berryshaker.study.mechanics_records import (
    ModelAgreement,
    PairAgreement,
)
from berryshaker.study.step_context import StudyContext
from berryshaker.study.step_result import Step, StepResult


def run(ctx: StudyContext) -> StepResult:
    """Reduced model vs multibody at the study's model-check level (Table 3, eq. 18).

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    StepResult
        ``agreement``: a :class:`ModelAgreement`, the model-check level's clearances (mm) and the per-pair
        agreement statistics, with one figure per pair; no data (a note) when the drive has no reduced model.
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
        ctx.draw(P.plot_time_series, ag["t"], {"multibody": a, "MLSD": b}, f"collision force at {p} [N]", ctx.figs / name,
                           f"Pair {p}: MLSD vs multibody, level {MODEL_CHECK_LEVEL} (study Fig. {14 + k})",
                           zoom="peak")
        figs.append(name)
    data = ModelAgreement(clearance_mm={p: v * 1e3 for p, v in lvl.items()},
                          pairs={p: PairAgreement.from_json(v) for p, v in ag["pairs"].items()})
    return StepResult("agreement", data, figs)


def model_agreement_section(inp: SectionInput) -> tuple[str, list[str]]:
    """The reduced (MLSD) model against the multibody model.  Owned by the study step ``model_agreement`` (one run
    of each model, eq. 18); it also shows the ``clearance_rows`` step's model check (means over perturbed starts,
    claim 1) and its agreement on every clearance row, which compare the same two models.

    Parameters
    ----------
    inp : SectionInput
        Results (``agreement``: a ``berryshaker.study.mechanics_records.ModelAgreement``; ``rows``' ``model_check``
        and ``agreement`` of a ``ClearanceRows``; read by attribute, forces in N), machine, figures.

    Returns
    -------
    tuple of (str, list of str)
        Title and HTML parts.
    """
    res, figs, PAIR_NAMES = inp.res, inp.figs, inp.pairs
    parts = []
    if res.agreement:
        ag = res.agreement.pairs
        parts.append("<p>One run of each model from the centred start (the curves of Figs. 14-17): the study's eq. 18 "
                     "and plainer measures of the two curves; 'statistics agree' judges this one draw of a chaotic "
                     "impact sequence.  Claim 1 rests on the means over perturbed starts below.</p>")
        parts.append(table(["pair", "F (eq. 18)", "F critical (5 %)", "statistics agree (this run)", "NRMSE",
                             "correlation", "peak ratio"],
                            [[p, ag[p].f_statistic, ag[p].f_critical, ag[p].agree, ag[p].nrmse,
                              ag[p].correlation, ag[p].peak_ratio] for p in PAIR_NAMES]))
        parts.append("<p class='small'>Study: F = " + ", ".join(f"{EQ18_F[p][0]}" for p in EQ18_F) + " against "
                     + ", ".join(f"{EQ18_F[p][1]}" for p in EQ18_F) + ".</p>")
        curves: list[str] = []
        for i, p in enumerate(PAIR_NAMES):
            maybe_img(curves, figs / f"fig{14 + i}_agreement_{p}.png", f"Pair {p}: collision force, both models, level 2")
        parts.append(details(f"Figures 14-{13 + len(PAIR_NAMES)}: both models' collision force per pair", curves))
    check = res.rows.model_check if res.rows is not None else None
    if check:
        st = check.starts
        parts.append(f"<p>The model check (claim 1): level {check.level}, each statistic's mean over "
                     f"{st.multibody} perturbed starts of the multibody model and {st.reduced} turned starts of "
                     "the MLSD (+- one standard error), their relative difference +- its noise (95 % Student-t band) "
                     "and the tolerance.  'within noise': the tolerance lies inside the noise band, so these runs "
                     "cannot tell.</p>")
        parts.append(table(["pair", "statistic", "multibody (N)", "MLSD (N)", "difference", "tolerance", "verdict"],
                            [[p, k, f"{c.a[k].mean:.0f} +- {c.a[k].se:.0f}",
                              f"{c.b[k].mean:.0f} +- {c.b[k].se:.0f}",
                              f"{100 * c.relative_difference[k]:.1f} +- {100 * c.noise[k]:.1f} %",
                              f"{100 * c.tolerance[k]:.0f} %", c.verdicts[k]]
                             for p, c in check.pairs.items() for k in c.tolerance], left=(0, 1, 6)))
    row_ag = (res.rows.agreement if res.rows is not None else None) or {}
    if row_ag:
        parts.append("<p>Agreement on every clearance row (mean, RMS, p95 of each pair's force within 10 / 15 / 20 %, "
                     "one run per model and row, each difference beyond the noise of single runs measured at the model "
                     "check; cell: agrees, or the statistic furthest outside with its relative difference, "
                     "'differs' beyond the noise or 'within noise').  A pair with no clearance compares the multibody "
                     "model's ideal-joint reaction with the MLSD's stiff link, which rings (docs/mlsd.md).</p>")

        def cell(c):
            verdict = c.verdict
            if verdict == "agree":
                return "yes"
            worst = f"{c.worst} {100 * c.relative_difference[c.worst]:.0f} %"
            return f"differs: {worst}" if verdict == "differ" else f"within noise: {worst}"

        parts.append(details("Agreement on every clearance row (table)", [table(
            ["row"] + list(PAIR_NAMES), [[r] + [cell(per[p]) for p in PAIR_NAMES] for r, per in
                                         sorted(row_ag.items(), key=lambda kv: int(kv[0]))],
            left=tuple(range(len(PAIR_NAMES) + 1)))]))
    return "MLSD model vs multibody contact simulation (eq. 18; Figs. 14-17)", parts


#: the step in the study's step table (:data:`berryshaker.study.steps.STEPS`)
STEP = Step(key="model_agreement", run=run, result="agreement", sections=(model_agreement_section,))
