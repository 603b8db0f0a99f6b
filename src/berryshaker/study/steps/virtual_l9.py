"""Study step ``virtual_l9``: the study's L9 field test through the virtual harvest, analysed like field data
(:func:`plan`, :func:`run`; the workflow is :mod:`berryshaker.study.l9`), its figures (:func:`l9_replicate_figures`)
and its report section (:func:`virtual_l9_section`).  Its data is a
:class:`~berryshaker.study.l9.records.VirtualL9`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

import numpy as np

from berryshaker.report.l9_replicates import l9_replicates_section
from berryshaker.report.sections import SectionInput, details, maybe_img, table
from berryshaker.study.l9 import virtual_l9
from berryshaker.study.step_context import PlannedRuns, StudyContext
from berryshaker.study.step_result import FailedRun, Step, StepResult
from berryshaker.user_text import html_text


def run(ctx: StudyContext) -> StepResult:
    """The study's L9 field test through the virtual harvest, analysed like field data.

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    StepResult
        ``l9``: the virtual L9 (:class:`~berryshaker.study.l9.records.VirtualL9`,
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


def plan(ctx: StudyContext) -> list[PlannedRuns]:
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


def virtual_l9_section(inp: SectionInput) -> tuple[str, list[str]]:
    """The virtual L9 field test (study step ``virtual_l9``): runs, the replicated analysis and the recommendation
    (:func:`berryshaker.report.l9_replicates.l9_replicates_section`), the main effects (drawn once, with their
    intervals); folded: the single-run range analyses, the replicated analysis as text and the response surfaces.

    Parameters
    ----------
    inp : SectionInput
        Results (``l9``: the study's ``VirtualL9`` record, read by attribute; clearances in mm, efficiency kg/min,
        rates %), machine, figures.

    Returns
    -------
    tuple of (str, list of str)
        Title and HTML parts.
    """
    figs, PAIR_NAMES = inp.figs, inp.pairs
    parts = []
    l9 = inp.res.l9
    if l9 is None:
        parts.append("<p>Not available: the virtual L9 test failed (see Failed runs).</p>")
    runs, responses = (l9.runs, l9.responses) if l9 is not None else ([], {})
    parts.append(table(["run", *[f"{p} mm" for p in PAIR_NAMES], "efficiency (kg/min)", "unripe (%)", "damage (%)"],
                        [[r.run, *[r.clearance_mm[p] for p in PAIR_NAMES], r.efficiency, r.unripe, r.damage]
                         for r in runs]))
    ranges: list[str] = []
    for name in [n for n in ("efficiency", "unripe", "damage") if n in responses]:
        ra = responses[name]
        an = ra.anova.factors
        ranges.append(f"<h3>{name}: range analysis ({'maximise' if ra.maximize else 'minimise'})</h3>")
        ranges.append(table(["factor", "k1", "k2", "k3", "R", "best", "ANOVA F", "p"],
                             [[f, *ra.factors[f].level_means, ra.factors[f].range, ra.factors[f].best_level,
                               an[f].f if f in an else "pooled", an[f].p if f in an else ""] for f in PAIR_NAMES]))
        reg = ra.regression
        ranges.append(f"<p class='small'>Ranking {' > '.join(ra.ranking)}.  Eq. 19 (full quadratic, "
                      f"{len(reg.full_model_terms)} terms) has rank {reg.full_model_rank} at the nine runs; aliased: "
                      f"{', '.join(reg.aliased_terms)}.  Fitted instead: the main-effects quadratic model "
                      f"(R² = {reg.main_effects_quadratic.r2:.3f}, {reg.main_effects_quadratic.residual_df} "
                      "residual df: it interpolates) and a ridge-regularised full model, labelled as such.</p>")
    parts.append(details("The study's range analysis of the nine runs (Table 8: one value per run, no noise)",
                          ranges))
    rep = l9.replicated if l9 is not None else None
    if rep:
        parts.append(f"<h3>Against its own noise ({len(rep.seeds)} population seeds per run)</h3>")
        parts.append("<p class='small'>Each run's indexes were recomputed for independently sampled bushes; effects are "
                     "tested against that replicate error, and a factor whose effect is not significant is 'no "
                     "meaningful difference' in the recommendation.</p>")
        parts.append(details("The replicated analysis as text (ANOVA tables, paired differences)",
                              [f"<pre class='text'>{html_text(rep.text)}</pre>"]))
        parts.extend(l9_replicates_section(l9, figs, PAIR_NAMES))
    else:  # the single-run main effects, where there is no replicated analysis to draw them with intervals
        maybe_img(parts, figs / "l9_main_effects.png", "Main effects of the virtual L9")
    surfaces: list[str] = []
    for i, name in enumerate(("efficiency", "unripe", "damage")):
        maybe_img(surfaces, figs / f"fig{27 + i}_surface_{name}.png", f"Response surfaces: {name}")
    parts.append(details("Figures 27-29: response surfaces", surfaces))
    return "Virtual L9 field test (Tables 7-8; Figs. 27-29)", parts


#: the step in the study's step table (:data:`berryshaker.study.steps.STEPS`)
STEP = Step(key="virtual_l9", run=run, result="l9", sections=(virtual_l9_section,), plan=plan)
