"""The page of ``doe analyze --out analysis.html``: self-contained (figures embedded as base64 PNG, no scripts),
printable, every user text escaped.  It holds the sheet's factors, what the sheet lost (a blank response, a deleted
row) and what that cost, the weighted optimum with the 95 % interval of each predicted response, the desirability
optimum beside it (``--desirability``), and per response the range analysis, the ANOVA table (source, SS, df, MS,
F, p) and its figures (Pareto chart of the standardized effects, Minitab's four-in-one residual plots, interaction
plots, response surface), the main-effect plot, the regression note and the analysis as text (folded).
"""

from __future__ import annotations

import math
from pathlib import Path

from berryshaker.report.html_blocks import CSS, _maybe_img, _num, _table
from berryshaker.user_text import file_part, html_text


def _fixed(values: list, reference: list | None = None) -> list[str]:
    """Numbers of one group with the same decimals: four significant digits for the group's largest |value|
    (so 3 and 3.65 print as 3.000 and 3.650)."""
    ref = [abs(float(v)) for v in (reference if reference is not None else values) if math.isfinite(float(v))]
    top = max(ref, default=0.0)
    dec = 3 if top == 0.0 else max(0, min(6, 3 - int(math.floor(math.log10(top)))))
    return [f"{float(v):.{dec}f}" if math.isfinite(float(v)) else "-" for v in values]


def _cell(v) -> str:
    """An ANOVA number: four significant digits, '-' where there is none."""
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    if isinstance(v, int):
        return str(v)
    x = float(v)
    return _num(x) if x == 0 or 1e-3 <= abs(x) < 1e6 else f"{x:.3g}"


def anova_rows(res, name: str) -> list[list[str]]:
    """The ANOVA table of one response as the page prints it: one row per factor (with its own interaction with the
    blocks, the error its F is taken against, in a blocked analysis), the blocks, lack of fit, the pooled error and
    the total, each with SS, df, MS, F and p ('-' where a line has none).

    Parameters
    ----------
    res : DoeAnalysis or SheetReplicatedAnalysis
        The analysis.
    name : str
        The response.

    Returns
    -------
    list of list of str
        Rows of [source, SS, df, MS, F, p]; SS and MS in the response's unit squared.
    """
    ra = res.responses[name]
    an = ra.anova
    rows = []
    for f, a in an.factors.items():
        rows.append([f, _cell(a.ss), str(a.df), _cell(a.ms), _cell(a.f), _cell(a.p)])
        own = getattr(a, "error", None)
        if own is not None and getattr(an, "blocks", None) is not None:  # tested against its own interaction
            rows.append([f"{f} x blocks (its error)", _cell(own.ss), str(own.df), _cell(own.ms), "-", "-"])
    blocks = getattr(an, "blocks", None)
    if blocks is not None:
        rows.append(["blocks", _cell(blocks.ms_block * blocks.df_block), str(blocks.df_block), _cell(blocks.ms_block),
                     "-", "-"])
    for f in an.pooled:
        ss = an.ss_all[f] if hasattr(an, "ss_all") else float("nan")
        k = len(res.factors[f].level_numbers) - 1
        rows.append([f"{f} (pooled into the error)", _cell(ss), str(k), _cell(ss / k), "-", "-"])
    lof = getattr(an, "lack_of_fit", None)
    if lof is not None and lof.df > 0:
        rows.append(["lack of fit", _cell(lof.ss), str(lof.df), _cell(lof.ms), _cell(lof.f), _cell(lof.p)])
    rows.append(["error", _cell(an.error.ss), str(an.error.df), _cell(an.error.ms), "-", "-"])
    lost = getattr(res, "lost_plots", None)
    if lost is not None:
        n_obs = lost.present[name]
    elif hasattr(res, "significance_rule"):  # replicated: every plot
        n_obs = res.runs * res.replicates
    else:
        n_obs = len(res.composite.score)
    rows.append(["total", _cell(an.total_ss), str(n_obs - 1), "-", "-", "-"])
    return rows


def _interval(lo_hi) -> str:
    return "-" if lo_hi is None else " .. ".join(_fixed(list(lo_hi)))


def _lost_html(res) -> list[str]:
    lost = getattr(res, "lost_plots", None)
    if lost is None:
        return []
    what = "replicate" if res.block_column in (None, "replicate") else "block"
    rows = [[name, f"{lost.present[name]} of {lost.plots}",
             ", ".join(f"run {i} {what} {k}" for i, k in cells) or "none",
             f"{lost.error_df[name]} (of {lost.balanced_error_df}; {lost.lost_df[name]} lost)"]
            for name, cells in lost.lost.items()]
    return ["<h2>Lost plots</h2>",
            "<p>The sheet lost plots (a blank response cell or a deleted row), so the design is no longer orthogonal: "
            "every sum of squares is a Type II sum of squares (adjusted for the blocks and the other factors), "
            "level means are least-squares means, and the error is the run x block interaction of the plots "
            "present (the general regression significance test, Montgomery 2013, sec. 4.1.3).</p>",
            _table(["response", "plots with a value", "lost", "error degrees of freedom"], rows, left=(0, 2))]


def _desirability_html(res) -> list[str]:
    d = getattr(res, "desirability", None)
    if d is None:
        return []
    parts = ["<h2>Desirability optimum</h2>",
             f"<p>{html_text(d.method)}.  Overall desirability D = {d.overall:.3f}"
             + (f"; {d.ties} level sets reach it" if d.ties > 1 else "") + ".</p>"]
    goal_rows = []
    for name, g in d.goals.items():
        lim = ([g.low, g.target, g.high] if g.goal == "target" else [g.low, g.high])
        goal_rows.append([name, g.goal, " .. ".join(_fixed(lim)), g.unit or "-", *_fixed([d.values[name]]),
                          _interval(d.intervals[name]), f"{d.desirability[name]:.3f}"])
    parts.append(_table(["response", "goal", "limits", "unit", "predicted", "95 % interval", "d"], goal_rows,
                        left=(0, 1, 3)))
    parts.append(_table(["factor", "level", "setting"],
                        [[f, k if k is not None else "-", d.settings.get(f) or "no effect on the goals"]
                         for f, k in d.levels.items()], left=(0, 2)))
    if d.note:
        parts.append(f"<p class='small'>{html_text(d.note)}</p>")
    if len(d.candidates) > 1:
        rows = [[" ".join(f"{f}{k}" for f, k in c.levels.items() if k is not None) or "-", f"{c.overall:.3f}"]
                for c in d.candidates]
        parts.append("<p class='small'>The best level sets:</p>" + _table(["level set", "D"], rows))
    return parts


def doe_report(res, title: str, *, results_file: str = "", version: str = "", figures: Path | None = None) -> str:
    """Self-contained, printable HTML of ``doe analyze``: the factors; the lost plots and the degrees of freedom they
    cost; the weighted optimum with the weights, the predicted responses and their 95 % intervals; the desirability
    optimum; per response the range analysis, the ANOVA table and its figures; input file and package version.

    Parameters
    ----------
    res : DoeAnalysis or SheetReplicatedAnalysis
        The analysis of ``doe analyze`` (:func:`berryshaker.experiment.field_results.analyze_sheet`).
    title : str
        Title of the page.
    results_file : str
        The analysed sheet's file name.
    version : str
        The package version.
    figures : Path, optional
        The folder of the analysis' figures (:func:`berryshaker.report.plots.write_doe_figures`); they are embedded.

    Returns
    -------
    str
        The HTML document.
    """
    from berryshaker.report.style import response_units

    replicated = hasattr(res, "significance_rule")
    factors = res.factors
    units = {**response_units(), **(res.response_units or {})}  # the sheet's own units win
    fig = Path(figures) if figures is not None else None
    parts = [f"<!doctype html><html lang='en'><head><meta charset='utf-8'><title>{html_text(title)}</title>"
             f"<style>{CSS}</style></head><body><h1>{html_text(title)}</h1>",
             f"<p>Results file <code>{html_text(str(results_file))}</code>; berryshaker {html_text(str(version))}."
             + (f"  {res.runs} runs x {res.replicates} replicates" if replicated else
                f"  {len(res.composite.score)} runs, one each")
             + f"; runs told apart by {html_text(str(res.runs_identified_by or 'run column'))}.</p>"]
    if factors:
        parts.append("<h2>Factors</h2>")
        parts.append(_table(["factor", "unit", "levels"],
                            [[f, d.unit or "-", ", ".join(f"{n}: {lab}" for n, lab in zip(d.level_numbers, d.labels))]
                             for f, d in factors.items()], left=(0, 1, 2)))
    parts += _lost_html(res)
    o = res.optimum
    how = "given with --weights, scaled to sum 1" if res.weights_given else "equal (no --weights given)"
    method = o.method if replicated else res.composite.method
    parts.append("<h2>Weighted optimum</h2>")
    parts.append("<p>Weights of the composite score: "
                 f"{html_text(', '.join(f'{k} {v:.2f}' for k, v in res.weights.items()))} ({how}).  "
                 f"Rule: {html_text(method)}.</p>")
    parts.append(_table(["factor", "level", "setting"], [[f, n if n is not None else "-",
                                                          o.settings.get(f) or "no meaningful difference"]
                                                         for f, n in o.levels.items()], left=(0, 2)))
    if replicated:
        parts.append(f"<p class='small'>{html_text(res.significance_rule)}</p>")
    intervals = o.intervals or {}
    parts.append(_table(["response", "predicted at the optimum", "95 % interval", "unit"],
                        [[r, _fixed([v])[0], _interval(intervals.get(r)), units.get(r, "")]
                         for r, v in o.values.items()], left=(0, 3)))
    parts.append(f"<p class='small'>{html_text(o.prediction)}"
                 + ("" if replicated else "; interval from the pooled error over Taguchi's effective number of "
                    "replications N / (1 + dof of the factors used)") + ".</p>")
    parts += _desirability_html(res)
    if fig is not None:
        _maybe_img(parts, fig / "main_effects.png", "Main effects: mean response at each level"
                   + (" with 95 % intervals (for comparing levels)" if replicated else ""))
    for name, ra in res.responses.items():
        unit = units.get(name)
        esc = html_text(name)
        parts.append(f"<h2>{esc}{f' ({html_text(unit)})' if unit else ''} "
                     f"({'maximise' if ra.maximize else 'minimise'})</h2>")
        an = ra.anova.factors
        nlev = max(len(d.level_means) for d in ra.factors.values())
        means = [v for d in ra.factors.values() for v in d.level_means]
        rows = []
        for f, d in ra.factors.items():
            cells = _fixed(list(d.level_means) + [d.range], reference=means)
            labels = factors[f].labels if f in factors else []
            best = d.best_level
            rows.append([f, *cells[:-1], *([""] * (nlev - len(d.level_means))), cells[-1],
                         f"{best}" + (f" ({labels[best - 1]})" if len(labels) >= best and factors[f].values is not None
                                      else ""),
                         f"{an[f].f:.3g}" if f in an else "pooled", f"{an[f].p:.3g}" if f in an else ""])
        parts.append("<h3>Range analysis</h3>")
        parts.append(_table(["factor", *[f"k{j + 1}" for j in range(nlev)], "R", "best level", "ANOVA F", "p"], rows))
        sq = f" [{html_text(unit)}²]" if unit else ""
        parts.append("<h3>ANOVA</h3>")
        parts.append(_table(["source", f"SS{sq}", "df", f"MS{sq}", "F", "p"], anova_rows(res, name)))
        err = ra.anova.error
        kind = getattr(err, "kind", None) or ("the residual, with the pooled factor" if ra.anova.pooled else
                                              "the residual")
        parts.append(f"<p class='small'>F of each factor against the error: {html_text(kind)}."
                     + ("  With lost plots the sums of squares are Type II and need not add up to the total."
                        if getattr(res, "lost_plots", None) is not None else "") + "</p>")
        reg = ra.regression
        parts.append(f"<p class='small'>Ranking {html_text(' > '.join(ra.ranking))}.  Eq. 19 full quadratic: "
                     f"rank {reg.full_model_rank} of {len(reg.full_model_terms)} terms; aliased: "
                     f"{html_text(', '.join(reg.aliased_terms) or 'none')}.  Main-effects quadratic model: "
                     f"R² = {reg.main_effects_quadratic.r2:.3f} with "
                     f"{reg.main_effects_quadratic.residual_df} residual df.</p>")
        if fig is not None:
            for stem, caption in (("pareto", "Pareto chart of the standardized effects"),
                                  ("residuals", "Residual plots (four in one)"),
                                  ("interactions", "Interaction plots"),
                                  ("surface", "Response surface of the main-effects quadratic model")):
                _maybe_img(parts, fig / f"{stem}_{file_part(name)}.png", f"{name}: {caption}")
    if replicated and getattr(res, "text", ""):
        parts.append("<details><summary>The analysis as text</summary>"
                     f"<pre class='text'>{html_text(res.text)}</pre></details>")
    parts.append("</body></html>")
    return "\n".join(parts)


__all__ = ["anova_rows", "doe_report"]
