"""Self-contained HTML report of the study: every figure embedded (base64 PNG), numbers in tables, the
resolved configuration and package version at the end.  Opens offline; no scripts.  The study steps' numbered
sections are rendered in :mod:`berryshaker.report.sections` with this module's table and figure helpers; the
report of ``doe analyze`` is here too.
"""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path
from typing import Callable, Sequence

from berryshaker.config import machine_table
from berryshaker.report.design import claims_apply, design_answers, design_answers_html, level_set_name
from berryshaker.report.headline import report_title, runs_text, verdict_class, verdict_counts
from berryshaker.reference_study import CHOSEN_CODE, CLEARANCE_LEVELS_MM, CHOSEN_LEVELS, FIELD_RESULT
from berryshaker.units import format_tolerance

CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;
color:#1d2330;line-height:1.45}h1{font-size:1.7em}h2{border-bottom:2px solid #c9d3e0;padding-bottom:.2em;margin-top:2em}
table{border-collapse:collapse;margin:.8em 0;font-size:.92em;max-width:100%}td,th{border:1px solid #c9d3e0;
padding:4px 9px;text-align:right;vertical-align:top}th{background:#eef2f7}td.l,th.l{text-align:left}
figure{margin:1em 0}figure img{max-width:100%;border:1px solid #dde3eb}figcaption{font-size:.9em;color:#4a5568}
.v-reproduced{background:#e3f6e8}.v-not{background:#fbe4e4}.v-partly{background:#fff5d6}.v-nc{background:#eef}
.small{font-size:.85em;color:#4a5568}code{background:#f3f5f8;padding:0 3px}
.wrap{max-width:100%;overflow-x:auto}td,th{overflow-wrap:break-word}thead{display:table-header-group}
.wide table{font-size:.78em}.wide td,.wide th{padding:2px 4px;overflow-wrap:anywhere}
table.fixed{table-layout:fixed;width:100%}td .ci{display:block;font-size:.85em;color:#4a5568}pre.text{white-space:pre-wrap;overflow-wrap:anywhere;font-size:.8em;background:#f7f9fb;
padding:.5em;max-width:100%;box-sizing:border-box}img,svg{max-width:100%}.nw{white-space:nowrap}
span[class^="v-"]{white-space:nowrap}
@page{size:A4;margin:14mm 12mm}
@media print{
body{max-width:none;margin:0;padding:0;font-size:9.5pt}h1{font-size:15pt}h2{font-size:12.5pt;margin-top:1.2em}
h1,h2,h3{page-break-after:avoid;break-after:avoid}
table{page-break-inside:auto;font-size:8pt;max-width:100%}tr{page-break-inside:avoid;break-inside:avoid}
td,th{padding:2px 4px;-webkit-print-color-adjust:exact;print-color-adjust:exact}
.wrap{overflow:visible}pre.text{font-size:7pt}.wide table{font-size:7pt}.wide td,.wide th{padding:1px 3px}
figure{page-break-inside:avoid;break-inside:avoid}figure img{max-width:100%;max-height:23cm;border:none}
span[class^="v-"]{-webkit-print-color-adjust:exact;print-color-adjust:exact}}
"""

#: Columns from which a table is printed in the smaller "wide" style.
WIDE_COLUMNS = 8


def _img(path: Path, caption: str) -> str:
    data = base64.b64encode(Path(path).read_bytes()).decode()
    return (f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")


def _maybe_img(parts: list, path: Path, caption: str) -> None:
    if Path(path).exists():
        parts.append(_img(path, caption))


def _table(header, rows, left=(0,), widths=None) -> str:
    """A table in a div that never gets wider than the page: ``widths`` (percent per column) fixes the columns'
    shares (long texts wrap inside them); tables of :data:`WIDE_COLUMNS` columns or more print smaller."""
    cols = "" if widths is None else "<colgroup>" + "".join(f"<col style='width:{w:g}%'>" for w in widths) + "</colgroup>"
    h = "".join(f'<th class="{"l" if i in left else ""}">{c if isinstance(c, _Raw) else html.escape(str(c))}</th>'
                for i, c in enumerate(header))
    body = []
    for r in rows:
        body.append("<tr>" + "".join(
            f'<td class="{"l" if i in left else ""}">{c if isinstance(c, _Raw) else html.escape(_fmt(c))}</td>'
            for i, c in enumerate(r)) + "</tr>")
    wide = " wide" if len(header) >= WIDE_COLUMNS else ""
    cls = " class='fixed'" if widths is not None else ""
    return (f"<div class='wrap{wide}'><table{cls}>{cols}<thead><tr>{h}</tr></thead><tbody>{''.join(body)}</tbody>"
            "</table></div>")


class _Raw(str):
    pass


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def _plain(text: str) -> str:
    """Python's True/False in a sentence read "yes"/"no" in the report."""
    return re.sub(r"\bFalse\b", "no", re.sub(r"\bTrue\b", "yes", str(text)))


def study_report(res: dict, summary: dict, machine, figs: Path, steps: dict | None = None, *,
                 sections: Sequence[tuple[str, Sequence[Callable]]]) -> str:
    """The self-contained HTML report of a study: design answers, failures, recommendation, then the steps'
    sections in the pipeline's order, numbered as they come (a step that did not run says why), the claims
    appendix and the configuration with provenance tags.

    Parameters
    ----------
    res : dict
        The steps' results (SI inside; the report prints units at the edges).
    summary : dict
        The head of summary.json (version, timings, runs, failures, optimum).
    machine : Machine
        The machine description.
    figs : Path
        Folder of the figures (PNG, embedded).
    steps : dict name -> StepResult, optional
        The steps, for their notes.
    sections : sequence of (str, sequence of callable)
        Per study step in the pipeline's order: its name and the renderers of its report sections
        (:mod:`berryshaker.report.sections`; ``berryshaker.study.pipeline.report_sections()``).

    Returns
    -------
    str
        The HTML document.
    """
    # (here, not at the top: report/sections.py builds on this module's helpers)
    from berryshaker.report.sections import SectionInput, section_numbers, step_sections, virtual_l9_section

    PAIR_NAMES = machine.pair_names
    steps = steps or {}
    inp = SectionInput(res, machine, figs, section_numbers(sections))
    reference = claims_apply(machine)  # the study's pairs: its claims can be checked (study/claims.py's rule)
    title = report_title(res["claims"]) if reference else f"Design study of {machine.machine.name}"
    parts = [f"<!doctype html><html lang='en'><head><meta charset='utf-8'><title>berryshaker study - "
             f"{html.escape(machine.machine.name)}</title><style>{CSS}</style></head><body>",
             f"<h1>{html.escape(title)}</h1>",
             f"<p>Machine: <b>{html.escape(machine.machine.name)}</b>. berryshaker {html.escape(summary['version'])}. "
             f"Total time {summary['timings_s']['total']:.1f} s; {html.escape(runs_text(summary['runs']))}.  "
             + (f"{html.escape(verdict_counts(res['claims']))} (appendix).  " if reference else "")
             + "Values marked [assumed] in the configuration are ours, not the study's (its tables were lost): see "
             "the end of this report.</p>"]
    # the design answers first, for every machine (report/design.py)
    try:
        parts.append(design_answers_html(design_answers({**summary, "results": res}, machine)))
    except Exception as exc:  # noqa: BLE001 - the report's other sections stand without its summary
        parts.append(f"<p class='small'>Design answers not available: {html.escape(f'{type(exc).__name__}: {exc}')}"
                     "</p>")
    fails = summary.get("failures") or []
    parts.append("<h2>Failed runs</h2>")
    if fails:
        parts.append("<p>These runs failed; the steps that needed them are marked 'not comparable' or left out.</p>")
        parts.append(_table(["step", "run", "inputs", "error"], [[f["step"], f["run"], f["inputs"], f["error"]]
                                                                  for f in fails], left=(0, 2, 3)))
    else:
        parts.append("<p>None: every run of the study completed.</p>")
    opt = summary["optimum"]
    parts.append("<h2>Recommended clearances</h2>")
    if opt is None:
        parts.append("<p>Not available: the virtual L9 test failed (see Failed runs).</p>")
    else:
        fitted = set(opt.get("fitted") or [])
        iv = opt.get("intervals") or {}

        def cell(name, value):
            est = iv.get(name)
            text = f"{value:.3g}" if est is None else (f"{est['mean']:.3g} [{est['ci'][0]:.3g}, {est['ci'][1]:.3g}], "
                                                      f"SD {est['sd']:.2g}")
            return text + (" (fitted)" if name in fitted else "")

        parts.append(_table(["", *[f"{p} (mm)" for p in PAIR_NAMES], "efficiency (kg/min)", "unripe (%)",
                             "damage (%)"], [
            [f"ours ({level_set_name(opt['clearance_mm'])}; {opt['code']})", *[opt["clearance_mm"][p] for p in PAIR_NAMES],
             cell("efficiency", opt["efficiency_kg_min"]), cell("unripe", opt["unripe_rate_pct"]),
             cell("damage", opt["damage_rate_pct"])],
            *([[f"study ({CHOSEN_CODE})", *[CLEARANCE_LEVELS_MM[p][CHOSEN_LEVELS[p] - 1] for p in PAIR_NAMES],
                FIELD_RESULT["efficiency_kg_min"], FIELD_RESULT["unripe_rate_pct"], FIELD_RESULT["damage_rate_pct"]]]
              if tuple(PAIR_NAMES) == tuple(CHOSEN_LEVELS) else [])]))
        if opt.get("statement"):
            parts.append(f"<p class='small'>{html.escape(opt['statement'])} Index values: mean [95 % interval] over "
                         f"{opt.get('starts') or 'the'} perturbed starts, and the SD of one start"
                         + ("; <b>fitted</b>: the harvest model's calibrated parameters were fitted to the study's "
                            "value of that index at these clearances, so it reproduces the target by construction "
                            "and is not evidence" if fitted else "")
                         + f" ({inp.ref(virtual_l9_section, 'the virtual L9 section')} gives the trade-off table)."
                         "</p>")
    # the steps' sections, numbered in the pipeline's order (report/sections.py)
    parts.extend(step_sections(sections, inp, {n: st.note for n, st in steps.items()}))
    if reference:  # the reference study's claims: an appendix, on its machine only
        _claims_section(parts, res)
    parts.append("<h2>Configuration and provenance</h2>")
    parts.append(f"<p>berryshaker {html.escape(summary['version'])}; timings (s): "
                 + ", ".join(f"{k_} {v:.1f}" for k_, v in summary["timings_s"].items()) + "</p>")
    parts.append("<p class='small'>Provenance: [study] from the reference study's text, [published] from another "
                 "publication (docs/published_record.md), [assumed] our default where no source gives it, "
                 "[calibrated] fitted to a measured value (docs/plant.md, docs/harvest.md), [default] not set in the "
                 "file (the description's default).</p>")
    parts.append(_table(["key", "value", "source"], [[k_, v_, f"[{t_}]"] for k_, v_, t_ in machine_table(machine)],
                        left=(0, 1, 2)))
    parts.append("</body></html>")
    return "\n".join(parts)


def _claims_section(parts: list, res: dict) -> None:
    """Appendix: the reference study's claims with their verdicts (shown for the study's machine only)."""
    parts.append("<h2>Appendix: claims of the reference study and what our models give</h2>")
    with_criterion = any(c.get("criterion") for c in res["claims"])
    rows = [[c["id"], c["claim"], _Raw(f'<span class="{verdict_class(c["verdict"])}">{html.escape(c["verdict"])}</span>'),
             *([_plain(c.get("criterion", ""))] if with_criterion else []), _plain(c["detail"])]
            for c in res["claims"]]
    parts.append(_table(["#", "claim (docs/study.md)", "verdict", *(["criterion"] if with_criterion else []),
                         "our numbers"], rows, left=(1, 2, 3, 4),
                        widths=(4, 22, 11, 27, 36) if with_criterion else (4, 32, 12, 52)))


def _num(v: float) -> str:
    """Four significant digits, whole numbers from 10 000 on (no "1.005e+04" in a table)."""
    return f"{v:.0f}" if abs(v) >= 1e4 else f"{v:.4g}"


def _short_candidate(name: str) -> str:
    """A trade-off candidate's short label: "run 3 (A1B3C3F3)" -> "3", "recommended (A1B1C1F3)" -> "rec."."""
    m = re.match(r"run (\d+)\b", name)
    if m:
        return m.group(1)
    return "rec." if name.startswith("recommended") else name


def _ci_text(est: dict | None, digits: int = 4) -> str:
    """"m +- h [lo, hi]" of a {mean, sd, ci} estimate (h: half-width of the interval)."""
    if not est:
        return ""
    lo, hi = est["ci"]
    return f"{est['mean']:.{digits}g} [{lo:.{digits}g}, {hi:.{digits}g}]"


def l9_replicates_section(l9: dict, figs: Path, pair_names) -> list[str]:
    """Replicate spread, significance, the recommendation's basis, the solver-tolerance check and the trade-off
    table of the virtual L9 (study/l9.py), as HTML parts.

    Parameters
    ----------
    l9 : dict
        The virtual L9 (study/l9.py).
    figs : Path
        Folder of the figures.
    pair_names : sequence of str
        The clearance pairs (factors).

    Returns
    -------
    list of str
        HTML parts.
    """
    rep = l9.get("replicated") or {}
    units = l9.get("response_units") or rep.get("units") or {}
    parts = []
    pert = rep.get("perturbation")
    if pert:
        parts.append(f"<p class='small'>Replicates: {html.escape(pert['what'])}.</p>")
    rows = []
    paired = l9.get("paired") or {}
    for name, ra in rep.get("responses", {}).items():
        sd = ra["anova"]["pure_error"]["ms"] ** 0.5
        e = ra["anova"].get("error", ra["anova"]["pure_error"])
        sig = ", ".join(f"{f} (p = {ra['factors'][f]['p']:.2g})" for f in ra["significant_factors"]) or "none"
        pr = "; ".join(f"{f}{q['levels'][1]} - {f}{q['levels'][0]}: {q['difference']:+.3g} +- {q['se']:.2g}"
                       + ("" if q["beyond_noise"] else " (noise)") for f, q in paired.get(name, {}).items())
        rows.append([name, units.get(name, ""), float(sum(ra["run_means"]) / len(ra["run_means"])), sd,
                     e["ms"] ** 0.5, e["df"], sig, pr])
    if rows:
        parts.append("<h3>Replicate spread and significance</h3>")
        parts.append("<p class='small'>The starts are blocks: start k is the same for every run, so its luck cancels "
                     "from every comparison.  Per-start SD: the spread of one run's starts; blocked error SD: what "
                     "effects are tested against (the run x start interaction); paired differences: the extreme levels "
                     "of each factor compared start by start, +- one standard error, marked (noise) where that "
                     "contrast's own paired t test over the starts (r - 1 dof) cannot tell them apart; the "
                     "significant factors come from the F test, which pools the error of every contrast.</p>")
        parts.append(_table(["response", "unit", "grand mean", "per-start SD", "blocked error SD", "dof",
                             "significant factors", "paired differences (last - first level)"],
                            rows, left=(0, 1, 6, 7)))
    rec = l9.get("recommended") or {}
    if rec.get("statement"):
        parts.append("<h3>Recommendation and its basis</h3>")
        parts.append(f"<p><b>{html.escape(rec.get('name') or level_set_name(rec['clearance_mm']))}</b> "
                     f"({html.escape(rec['code'])}): {html.escape(rec['statement'])}</p>")
        parts.append(_table(["factor", "level", "basis"], [[p, rec["levels"][p], rec["basis"][p]]
                                                          for p in pair_names if p in rec.get("basis", {})],
                            left=(0, 2)))
        parts.append(f"<p class='small'>Rule: {html.escape(rec.get('rule', ''))}.</p>")
        seq = rec.get("sequential")
        if seq:
            parts.append(f"<p class='small'>Starts at the recommendation: {html.escape(seq['statement'])}.</p>")
    tc = l9.get("tolerance_check") or {}
    if tc.get("done"):
        rt = tc.get("rtol", [1e-6, 1e-7])  # a summary written before the tolerances were recorded: 1e-6, 1e-7
        parts.append("<h3>Solver-tolerance check</h3>")
        parts.append(f"<p>{html.escape(tc['statement'])} ({tc['replicates']} replicate(s) of the recommended set "
                     f"re-run at rtol {format_tolerance(rt[1])}"
                     + (f"; velocities held absolutely below rtol x {tc['velocity_scale_m_s']:g} m/s at both"
                        if "velocity_scale_m_s" in tc else "") + ").</p>")
        fmt = [format_tolerance(x) for x in rt]
        rule = "within 2 x noise" if all("mean_change" in v for v in tc["responses"].values()) else \
            "within 1 SD (a summary from before 2026-11-23)"
        parts.append(_table(["response", _Raw(f"mean change <span class='nw'>{fmt[0]}</span> -&gt; <span class='nw'>{fmt[1]}</span>"), "largest change", "replicate SD",
                             "noise of the mean (SD)", rule],
                            [[n, v.get("mean_change", float("nan")), v["max_abs_change"], v["replicate_sd"],
                              v.get("noise_sd", float("nan")), v["within_replicate_spread"]]
                             for n, v in tc["responses"].items()]))
    elif tc:
        parts.append(f"<p class='small'>Solver-tolerance check not run: {html.escape(tc.get('reason', ''))}.</p>")
    recs = l9.get("tradeoff") or []
    if recs:
        parts.append("<h3>Trade-off of the candidate clearance sets</h3>")
        forces = [f"peak_force_N:{p}" for p in pair_names if f"peak_force_N:{p}" in recs[0]]
        idx = [n for n in ("efficiency", "ripe_removal", "unripe", "damage") if n in recs[0]]
        tq = [c for c in ("drive_torque_peak_Nm", "drive_torque_rms_Nm") if c in recs[0]]

        def cell(r, c):  # the mean, its interval on a second line: narrow columns, short rows
            lo, hi = r.get(f"{c}_lo", r[c]), r.get(f"{c}_hi", r[c])
            return _Raw(f"{_num(r[c])}<span class='ci'>[{_num(lo)}, {_num(hi)}]</span>")

        short = {r["name"]: _short_candidate(r["name"]) for r in recs}

        def beaten_by(r):
            names = [n.strip() for n in re.split(r",\s*(?=run |recommended)", r.get("dominated_by") or "") if n.strip()]
            return ", ".join(short.get(n, n) for n in names) or "-"

        header = (["candidate"] + [f"{n} ({units.get(n, '')})" for n in idx] + ["dominated by"])
        body = [[r["name"]] + [cell(r, c) for c in idx] + [beaten_by(r)] for r in recs]
        parts.append(_table(header, body, left=(0, len(header) - 1)))
        loads = (["candidate"] + [f"peak force {c.split(':')[1]} (N)" for c in forces]
                 + ["drive torque peak (N m)", "drive torque RMS (N m)"][:len(tq)])
        if len(loads) > 1:
            parts.append(_table(loads, [[r["name"]] + [cell(r, c) for c in forces + tq] for r in recs]))
        parts.append("<p class='small'>Each cell: mean of the replicates [95 % interval of the mean]; the machine loads "
                     "of the same candidates in the second table; 'dominated by' names the dominating candidates by "
                     "run number ('rec.': the recommended set).  A candidate is "
                     "dominated if another is no worse beyond noise in every judged column and better beyond noise in "
                     "one, 'beyond noise' being the Tukey-Kramer margin on the ANOVA's pure error, simultaneous over "
                     "all candidates (experiment/tradeoff.py, study/l9.py); clearances are descriptive.  The tiered "
                     "choice is confirmed against this table: a tested run that dominates it becomes the "
                     "recommendation.</p>")
    _maybe_img(parts, figs / "l9_tradeoff.png", "Trade-off: efficiency against peak collision force and drive torque")
    _maybe_img(parts, figs / "l9_effects_harvest.png", "Main effects on the harvest indexes with 95 % intervals")
    _maybe_img(parts, figs / "l9_effects_loads.png", "Main effects on the machine loads with 95 % intervals")
    for name in sorted(rep.get("responses", {})):  # Minitab's effect figures (report.plots.effects), where drawn
        for kind, what in (("pareto", "Pareto chart of the standardized effects (t of each factor's linear and "
                                      "quadratic contrasts against the blocked error)"),
                           ("residuals", "Residuals of the main-effects model with blocks: normal probability plot "
                                         "and residuals against fitted values"),
                           ("interactions", "Interaction plots: mean of the starts at each pair of levels")):
            _maybe_img(parts, figs / f"l9_{kind}_{name}.png", f"{name}: {what}")
    return parts


def doe_report(res: dict, title: str) -> str:
    """Self-contained, printable HTML of ``doe analyze``: per response the range analysis (level means, range,
    best level with its value), pooled ANOVA and regression notes; the weighted optimum with the weights used
    and the predicted responses; the factors' level values and units; input file and package version.

    Parameters
    ----------
    res : dict
        The analysis of ``doe analyze``.
    title : str
        Title of the page.

    Returns
    -------
    str
        The HTML document.
    """
    from berryshaker.report.style import RESPONSE_UNITS

    factors = res.get("factors") or {}
    units = {**RESPONSE_UNITS, **(res.get("response_units") or {})}  # the sheet's units first (issue 45)
    parts = [f"<!doctype html><html lang='en'><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
             f"<style>{CSS}</style></head><body><h1>{html.escape(title)}</h1>",
             f"<p>Results file <code>{html.escape(str(res.get('results_file', '')))}</code>; berryshaker "
             f"{html.escape(str(res.get('version', '')))}.</p>"]
    if factors:
        parts.append("<h2>Factors</h2>")
        parts.append(_table(["factor", "unit", "levels"],
                            [[f, d.get("unit") or "-", ", ".join(f"{n}: {lab}" for n, lab in
                                                                 zip(d["level_numbers"], d["labels"]))]
                             for f, d in factors.items()], left=(0, 1, 2)))
    o = res["optimum"]
    w = res.get("weights") or {}
    how = "given with --weights, scaled to sum 1" if res.get("weights_given") else "equal (no --weights given)"
    parts.append("<h2>Weighted optimum</h2>")
    parts.append(f"<p>Weights of the composite score: {html.escape(', '.join(f'{k} {v:.2f}' for k, v in w.items()))} "
                 f"({how}).  {html.escape(res.get('composite', {}).get('method', ''))}.</p>")
    parts.append(_table(["factor", "level", "setting"], [[f, n if n is not None else "-",
                                                          (o.get("settings") or {}).get(f) or "no meaningful difference"]
                                                         for f, n in o["levels"].items()], left=(0, 2)))
    if res.get("significance_rule"):  # a replicated sheet: effects against the replicate spread
        parts.append(f"<p class='small'>{res['runs']} runs x {res['replicates']} replicates.  "
                     f"{html.escape(res['significance_rule'])}</p>")
    parts.append(_table(["response", "predicted at the optimum", "unit"],
                        [[r, _fixed([v])[0], units.get(r, "")] for r, v in o["values"].items()],
                        left=(0, 2)))
    parts.append(f"<p class='small'>{html.escape(o.get('prediction', ''))}</p>")
    for name, ra in res["responses"].items():
        unit = units.get(name)
        parts.append(f"<h2>{html.escape(name)}{f' ({unit})' if unit else ''}: range analysis "
                     f"({'maximise' if ra['maximize'] else 'minimise'})</h2>")
        an = ra["anova"]["factors"]
        nlev = len(next(iter(ra["factors"].values()))["level_means"])
        means = [v for d in ra["factors"].values() for v in d["level_means"]]
        rows = []
        for f, d in ra["factors"].items():
            cells = _fixed(list(d["level_means"]) + [d["range"]], reference=means)
            labels = (factors.get(f) or {}).get("labels") or []
            best = d["best_level"]
            rows.append([f, *cells, f"{best}" + (f" ({labels[best - 1]})" if len(labels) >= best and
                                                   (factors.get(f) or {}).get("values") is not None else ""),
                         f"{an[f]['f']:.3g}" if f in an else "pooled", f"{an[f]['p']:.3g}" if f in an else ""])
        parts.append(_table(["factor", *[f"k{j + 1}" for j in range(nlev)], "R", "best level", "ANOVA F", "p"],
                            rows))
        reg = ra["regression"]
        parts.append(f"<p class='small'>Ranking {html.escape(' > '.join(ra['ranking']))}.  Eq. 19 full quadratic: "
                     f"rank {reg['full_model_rank']} of {len(reg['full_model_terms'])} terms; aliased: "
                     f"{html.escape(', '.join(reg['aliased_terms']) or 'none')}.  Main-effects quadratic model: "
                     f"R² = {reg['main_effects_quadratic']['r2']:.3f} with "
                     f"{reg['main_effects_quadratic']['residual_df']} residual df.</p>")
    parts.append("</body></html>")
    return "\n".join(parts)


def _fixed(values: list, reference: list | None = None) -> list[str]:
    """Numbers of one group with the same decimals: four significant digits for the group's largest |value|
    (so 3 and 3.65 print as 3.000 and 3.650)."""
    import math

    ref = [abs(float(v)) for v in (reference if reference is not None else values) if math.isfinite(float(v))]
    top = max(ref, default=0.0)
    dec = 3 if top == 0.0 else max(0, min(6, 3 - int(math.floor(math.log10(top)))))
    return [f"{float(v):.{dec}f}" for v in values]
