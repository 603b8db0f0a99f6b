"""Self-contained HTML report of the study: every figure embedded (base64 PNG), numbers in tables, the
resolved configuration and package version at the end.  Opens offline; no scripts.

long module: the study report's sections are rendered here from the steps' results and share this module's table
and figure helpers.
"""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

from berryshaker.config import machine_table
from berryshaker.report.design import claims_apply, design_answers, design_answers_html, level_set_name
from berryshaker.report.headline import report_title, runs_text, verdict_class, verdict_counts
from berryshaker.reference_study import CHOSEN_CODE, CLEARANCE_LEVELS_MM, CHOSEN_LEVELS, EQ18_F, FIELD_RESULT
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


def study_report(res: dict, summary: dict, machine, figs: Path, steps: dict | None = None) -> str:
    """The self-contained HTML report of a study: claims with verdicts, failures, recommendation, one section
    per step (a step that did not run says why), configuration with provenance tags.

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

    Returns
    -------
    str
        The HTML document.
    """
    PAIR_NAMES = machine.pair_names
    steps = steps or {}

    def note(name):
        st = steps.get(name)
        if st is not None and st.note:
            parts.append(f"<p class='small'><b>Note:</b> {html.escape(st.note)}</p>")

    k = res["kinematics"]
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
                         + " (section 6 gives the trade-off table).</p>")
    # kinematics
    parts.append("<h2>1. Kinematics of the drive (eq. 1-3)</h2>")
    krows = []
    if "cam" in k:
        c = k["cam"]
        krows += [
            ["stroke", f"{c['stroke_mm']:.2f} mm"], ["max push-rod velocity", f"{c['max_velocity_m_s']:.4f} m/s"],
            ["max acceleration", f"{c['max_acceleration_m_s2']:.3f} m/s²"], ["max jerk", f"{c['max_jerk_m_s3']:.1f} m/s³"],
            ["pressure angle", f"{c['pressure_angle_deg']['min']:.2f} .. {c['pressure_angle_deg']['max']:.2f} deg"],
            ["min pitch radius of curvature",
             f"{c['min_radius_of_curvature_mm']:.2f} mm (roller {c['roller_radius_mm']:.1f} mm)"]]
    for key, val in (k.get("drive_specific") or {}).items():
        krows.append([key.replace("_", " "), str(val)])
    parts.append(_table(["quantity", "value"], krows + [
        ["left comb swing", f"{k['combs']['left']['swing_deg']['min']:.2f} .. {k['combs']['left']['swing_deg']['max']:.2f} deg"],
        ["right comb swing", f"{k['combs']['right']['swing_deg']['min']:.2f} .. {k['combs']['right']['swing_deg']['max']:.2f} deg"],
        ["transmission angle", f"{k['linkage']['transmission_angle_deg']['min']:.2f} .. "
                               f"{k['linkage']['transmission_angle_deg']['max']:.2f} deg"],
        ["comb frequency", f"{k['drive']['comb_frequency_hz']:.3f} Hz"]]))
    for name, cap in (("svaj.png", "Push-rod displacement, velocity, acceleration, jerk (3-4-5 law, corrected return)"),
                      ("groove_profile.png", "Groove cam: pitch curve and walls offset along its normal (corrected eq. 2)"),
                      ("comb_angles.png", "Comb swings, tip speeds and transmission angle (eq. 3)")):
        _maybe_img(parts, figs / name, cap)
    # agreement
    parts.append("<h2>2. MLSD model vs multibody contact simulation (eq. 18; Figs. 14-17)</h2>")
    note("agreement")
    if res.get("agreement"):
        ag = res["agreement"]["pairs"]
        parts.append("<p>One run of each model from the centred start (the curves of Figs. 14-17): the study's eq. 18 "
                     "and plainer measures of the two curves; 'statistics agree' judges this one draw of a chaotic "
                     "impact sequence.  Claim 1 rests on the means over perturbed starts below.</p>")
        parts.append(_table(["pair", "F (eq. 18)", "F critical (5 %)", "statistics agree (this run)", "NRMSE",
                             "correlation", "peak ratio"],
                            [[p, ag[p]["f_statistic"], ag[p]["f_critical"], ag[p]["agree"], ag[p]["nrmse"],
                              ag[p]["correlation"], ag[p]["peak_ratio"]] for p in PAIR_NAMES]))
        parts.append("<p class='small'>Study: F = " + ", ".join(f"{EQ18_F[p][0]}" for p in EQ18_F) + " against "
                     + ", ".join(f"{EQ18_F[p][1]}" for p in EQ18_F) + ".</p>")
        for i, p in enumerate(PAIR_NAMES):
            _maybe_img(parts, figs / f"fig{14 + i}_agreement_{p}.png", f"Pair {p}: collision force, both models, level 2")
    check = (res.get("rows") or {}).get("model_check")
    if check:
        st = check["starts"]
        parts.append(f"<p>The model check (claim 1): level {check['level']}, each statistic's mean over "
                     f"{st['multibody']} perturbed starts of the multibody model and {st['reduced']} turned starts of "
                     "the MLSD (+- one standard error), their relative difference +- its noise (95 % Student-t band) "
                     "and the tolerance.  'within noise': the tolerance lies inside the noise band, so these runs "
                     "cannot tell.</p>")
        parts.append(_table(["pair", "statistic", "multibody (N)", "MLSD (N)", "difference", "tolerance", "verdict"],
                            [[p, k, f"{c['a'][k]['mean']:.0f} +- {c['a'][k]['se']:.0f}",
                              f"{c['b'][k]['mean']:.0f} +- {c['b'][k]['se']:.0f}",
                              f"{100 * c['relative_difference'][k]:.1f} +- {100 * c['noise'][k]:.1f} %",
                              f"{100 * c['tolerance'][k]:.0f} %", c["verdicts"][k]]
                             for p, c in check["pairs"].items() for k in c["tolerance"]], left=(0, 1, 6)))
    row_ag = (res.get("rows") or {}).get("agreement") or {}
    if row_ag:
        parts.append("<p>Agreement on every clearance row (mean, RMS, p95 of each pair's force within 10 / 15 / 20 %, "
                     "one run per model and row, each difference beyond the noise of single runs measured at the model "
                     "check; cell: agrees, or the statistic furthest outside with its relative difference, "
                     "'differs' beyond the noise or 'within noise').  A pair with no clearance compares the multibody "
                     "model's ideal-joint reaction with the MLSD's stiff link, which rings (docs/mlsd.md).</p>")

        def cell(c):
            verdict = c.get("verdict", "agree" if c["agree"] else "differ")
            if verdict == "agree":
                return "yes"
            worst = f"{c['worst']} {100 * c['relative_difference'][c['worst']]:.0f} %"
            return f"differs: {worst}" if verdict == "differ" else f"within noise: {worst}"

        parts.append(_table(["row"] + list(PAIR_NAMES),
                            [[r] + [cell(per[p]) for p in PAIR_NAMES] for r, per in
                             sorted(row_ag.items(), key=lambda kv: int(kv[0]))], left=tuple(range(len(PAIR_NAMES) + 1))))
    # rows
    last = 4 + 3 * len(PAIR_NAMES)
    lv = (last - 2, last - 1, last)
    parts.append(f"<h2>3. Collision force against clearance (rows 1-{last - 3}; Figs. 18-21)</h2>")
    note("rows")
    mb = res["rows"]["multibody"]
    rows = []
    for r in range(1, last + 1):
        if str(r) not in mb:
            continue
        s = mb[str(r)]
        rows.append([r, *[s["clearance_mm"][p] for p in PAIR_NAMES], *[s["collision_force_N"][p]["peak"] for p in PAIR_NAMES],
                     *[s["collision_force_N"][p]["mean"] for p in PAIR_NAMES]])
    parts.append(_table(["row", *[f"{p} mm" for p in PAIR_NAMES], *[f"peak {p} (N)" for p in PAIR_NAMES],
                         *[f"mean {p} (N)" for p in PAIR_NAMES]], rows))
    for i, p in enumerate(PAIR_NAMES):
        _maybe_img(parts, figs / f"fig{18 + i}_rows_{p}.png", f"Clearance {p} alone: collision force")
    parts.append(f"<h2>4. Comb load moments (rows 1, {lv[0]}-{lv[2]}; Figs. 22-23)</h2>")
    parts.append("<p class='small'>These machine-only runs have no plant: the load is the aggregate bush model (a "
                 "spring-damper about each comb shaft, 200 N m/rad [assumed]); peak and rms are per comb, about its "
                 "shaft.  It loads the combs about 40 times more than the explicit bush of branches in section 9 "
                 "(there about 16 N m peak, 1 N m rms; here about 81 N m peak, 48 N m rms; docs/plant.md).</p>")
    parts.append(_table(["row", "left peak (N m)", "left rms", "right peak", "right rms"],
                        [[r, mb[str(r)]["load_moment_Nm"]["left"]["peak"], mb[str(r)]["load_moment_Nm"]["left"]["rms"],
                          mb[str(r)]["load_moment_Nm"]["right"]["peak"], mb[str(r)]["load_moment_Nm"]["right"]["rms"]]
                         for r in (1, *lv) if str(r) in mb]))
    for i, side in enumerate(("left", "right")):
        _maybe_img(parts, figs / f"fig{22 + i}_moment_{side}.png", f"{side} comb load moment")
    # fruit force
    parts.append("<h2>5. Fruit harvesting force (eq. 16-17; Figs. 24-26)</h2>")
    if (res.get("fruit_force") or {}).get("chosen"):
        pos = res["fruit_force"]["chosen"]["summary"]["positions"]
        parts.append(_table(["fruit", "z (m)", "peak (N)", "study range (N)", "ripe fruit", "unripe fruit"],
                            [[n, d["z_m"], d["peak_force_N"], "-".join(str(x) for x in d.get("study_range_N", [])),
                              d["eq17"]["ripe"], d["eq17"]["unripe"]] for n, d in pos.items()]))
    _maybe_img(parts, figs / "fig24_26_fruit_force.png", "Fruit force against machine-to-plant distance")
    _maybe_img(parts, figs / "fruit_force_by_level.png", "Peak fruit force at the three level sets")
    # L9
    l9 = res["l9"]
    parts.append("<h2>6. Virtual L9 field test (Tables 7-8; Figs. 27-29)</h2>")
    note("l9")
    if l9 is None:
        l9 = {"runs": [], "responses": {}}
        parts.append("<p>Not available: the virtual L9 test failed (see Failed runs).</p>")
    parts.append(_table(["run", *[f"{p} mm" for p in PAIR_NAMES], "efficiency (kg/min)", "unripe (%)", "damage (%)"],
                        [[r["run"], *[r["clearance_mm"][p] for p in PAIR_NAMES], r["efficiency"], r["unripe"], r["damage"]]
                         for r in l9["runs"]]))
    for name in [n for n in ("efficiency", "unripe", "damage") if n in l9["responses"]]:
        ra = l9["responses"][name]
        an = ra["anova"]["factors"]
        parts.append(f"<h3>{name}: range analysis ({'maximise' if ra['maximize'] else 'minimise'})</h3>")
        parts.append(_table(["factor", "k1", "k2", "k3", "R", "best", "ANOVA F", "p"],
                            [[f, *ra["factors"][f]["level_means"], ra["factors"][f]["range"], ra["factors"][f]["best_level"],
                              an[f]["f"] if f in an else "pooled", an[f]["p"] if f in an else ""] for f in PAIR_NAMES]))
        reg = ra["regression"]
        parts.append(f"<p class='small'>Ranking {' > '.join(ra['ranking'])}.  Eq. 19 (full quadratic, "
                     f"{len(reg['full_model_terms'])} terms) has rank {reg['full_model_rank']} at the nine runs; aliased: "
                     f"{', '.join(reg['aliased_terms'])}.  Fitted instead: the main-effects quadratic model "
                     f"(R² = {reg['main_effects_quadratic']['r2']:.3f}, {reg['main_effects_quadratic']['residual_df']} "
                     "residual df: it interpolates) and a ridge-regularised full model, labelled as such.</p>")
    rep = l9.get("replicated") if isinstance(l9, dict) else None
    if rep:
        parts.append(f"<h3>Against its own noise ({len(rep.get('seeds', []))} population seeds per run)</h3>")
        parts.append("<p class='small'>Each run's indexes were recomputed for independently sampled bushes; effects are "
                     "tested against that replicate error, and a factor whose effect is not significant is 'no "
                     "meaningful difference' in the recommendation.</p>")
        parts.append(f"<pre class='text'>{html.escape(rep.get('text', ''))}</pre>")
        parts.extend(l9_replicates_section(l9, figs, PAIR_NAMES))
    _maybe_img(parts, figs / "l9_main_effects.png", "Main effects of the virtual L9")
    for i, name in enumerate(("efficiency", "unripe", "damage")):
        _maybe_img(parts, figs / f"fig{27 + i}_surface_{name}.png", f"Response surfaces: {name}")
    # clearance life
    parts.append("<h2>7. Clearance life: wear and fits (docs/life.md)</h2>")
    note("clearance_life")
    life = res.get("clearance_life")
    if life:
        rec = life["recommended"]
        parts.append(_table(["joint", "clearance now (mm)", f"after {life['horizon_h']:g} h (mm)", "service limit (mm)",
                             "hours to the limit", "recommended fit"],
                            [[j, g["clearance_mm"][0], g["clearance_mm"][-1], life["clearance_limit_mm"][j],
                              "not reached" if life["hours_to_limit"][j] is None else life["hours_to_limit"][j],
                              rec["fits"].get(j, "")] for j, g in life["growth"].items()]))
        parts.append("<p class='small'>" + "; ".join(html.escape(n) for n in life.get("notes", [])) + "</p>")
        _maybe_img(parts, figs / "life_clearance_growth.png", "Clearance growth by wear against operating hours")
    _powered_drive_section(parts, res.get("powered_drive"), PAIR_NAMES, note)
    # config
    parts.extend(harvest_response_section(res, figs, steps.get("harvest_response")))
    parts.extend(validation_section(res.get("validation"), steps.get("validation")))
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


def _powered_drive_section(parts: list, pw: dict | None, pairs, note) -> None:
    """Section 8: the powered driveline at clearance levels 1-3 (study step ``powered_drive``)."""
    parts.append("<h2>8. Powered drive: speed ripple, input power and energy lost per joint (docs/driveline.md)</h2>")
    note("powered_drive")
    if not pw:
        return
    rows = []
    for lv, d in pw["levels"].items():
        e, sp = d["energy_per_revolution_J"], d["cam_speed_rpm"]
        ripple = d["speed_ripple_percent"]
        if "speed_ripple_sd_percent" in d:
            ripple = f"{ripple:.3g} +- {d['speed_ripple_sd_percent']:.2g}"
        rows.append([lv, ", ".join(f"{p} {d['clearance_mm'][p]:g}" for p in pairs),
                     f"{sp['min']:.1f} .. {sp['max']:.1f} ({sp['mean']:.2f})", ripple,
                     d["input_power_W"], *[e[p] for p in pairs], e.get("belt", 0.0), e.get("mesh", 0.0),
                     d["audit_relative_residual"]])
    parts.append(_table(["level", "clearance (mm)", "shaft speed min .. max (mean), r/min, replicate means", "ripple (%)",
                         "input power (W)", *[f"lost in {p} (J/rev)" for p in pairs], "belt (J/rev)",
                         "mesh (J/rev)", "energy audit residual"], rows, left=(0, 1, 2, 3)))
    reps = pw.get("replicates")
    rep_text = (f" Every level is the mean of {reps} runs from seeded perturbed starts (clearance joints off centre, "
                "seeds in summary.json); ripple is shown as mean +- SD, and a trend is stated only where Welch's "
                "t-test between consecutive levels finds it beyond that spread." if reps else "")
    parts.append(f"<p>{html.escape(pw['finding'])} Energy lost per revolution is the work of each joint's contact "
                 "damping and friction, integrated with the motion; the audit residual is the largest over the "
                 "replicates of |motor work - kinetic, stored and dissipated energy| / motor work over revolutions "
                 f"2-3.{rep_text}</p>")


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


def harvest_response_section(res: dict, figs: Path, step=None) -> list[str]:
    """Section 9: the comb's load (the bush), harvest against shaking frequency, calibration (fitted / held out).

    Parameters
    ----------
    res : dict
        The study's results.
    figs : Path
        Folder of the figures.
    step : StepResult, optional
        The step, for its note.

    Returns
    -------
    list of str
        HTML parts.
    """
    parts = ["<h2>9. The bush as the comb's load; harvest against shaking frequency; calibration</h2>"]
    if step is not None and step.note:
        parts.append(f"<p class='small'><b>Note:</b> {html.escape(step.note)}</p>")
    chosen = ((res.get("fruit_force") or {}).get("chosen") or {}).get("summary") or {}
    if chosen.get("load_moment_Nm"):
        bush = chosen.get("bush") or {}
        who = (f"the sum of the reactions of {bush.get('branches')} branches ({bush.get('members')} simulated "
               f"members with {bush.get('modes_per_member')} modes each, seed {bush.get('seed')}, plus the "
               "instrumented fruit branch)" if chosen.get("load_model") == "branches"
               else "the aggregate spring-damper (combs.load_model = aggregate)")
        parts.append(f"<p>Comb load moment at the chosen clearances while the bush is in the comb: {html.escape(who)}."
                     " Per comb, about its shaft; compare section 4's aggregate spring-damper, which loads the combs "
                     "about 40 times more.</p>")
        parts.append(_table(["comb", "peak (N m)", "rms (N m)"],
                            [[side, v["peak"], v["rms"]] for side, v in chosen["load_moment_Nm"].items()]))
    hr = res.get("harvest_response")
    if not hr:
        parts.append("<p>Not available (see Failed runs).</p>")
        return parts
    reps = next((r.get("replicates") for r in hr["rows"] if r.get("replicates")), None)
    parts.append("<p>Ripe removal (% of the ripe mass), unripe shedding (% of the unripe mass) and damage (% of the "
                 "picked mass) of the seeded virtual harvest against the drive-shaft speed, one comb cycle per "
                 "revolution, at the configured clearances; every other value as described."
                 + (f" Each row is the mean over {reps} replicates from perturbed starts (the calibration's "
                    "statistic and seeds) with the SD over the replicates." if reps else "") + "</p>")

    def _sd(r, key):  # mean with the replicates' SD when the row has it (runs before replicates: the value)
        return f"{r[key]:.3g} ± {r[key + '_sd']:.2g}" if key + "_sd" in r else r[key]

    parts.append(_table(["drive speed (r/min)", "frequency (Hz)", "ripe removal (%)", "unripe shedding (%)",
                         "damage (%)", "efficiency (kg/min)"],
                        [[r["speed_rpm"], r["shaking_frequency_hz"], _sd(r, "ripe_removal_pct"),
                          _sd(r, "unripe_shed_pct"), _sd(r, "damage_rate_pct"), _sd(r, "efficiency_kg_min")]
                         for r in hr["rows"]]))
    _maybe_img(parts, figs / "harvest_vs_frequency.png", "Virtual harvest against shaking frequency")
    cal = hr.get("calibration") or {}
    if cal:
        parts.append("<p>Calibration: every plant and picking parameter with its provenance; [calibrated] values "
                     "were fitted to the target named, the quantities below them were not fitted and are "
                     "held-out comparisons with the study (docs/plant.md).</p>")
        parts.append(_table(["parameter", "value", "unit", "tag", "target or source"],
                            [[p["parameter"], p["value"], p["unit"], p["tag"], p["target_or_source"]]
                             for p in cal["parameters"]], left=(0, 3, 4)))
        parts.append(_table(["quantity", "model", "study", "inside the study's range"],
                            [[h["quantity"], h["model"], h["study"], "-" if h["inside"] is None else h["inside"]]
                             for h in cal["held_out"]]))
    return parts


def validation_section(val: dict | None, step=None) -> list[str]:
    """Section 10: the harvest model against the published record (berryshaker.study.validation.validate).

    Parameters
    ----------
    val : dict or None
        The validation step's result: ``rows`` (one per published number), ``summary``, ``replicates``.
    step : StepResult, optional
        The step, for its note.

    Returns
    -------
    list of str
        HTML parts: the table (published value, model value with its interval, verdict, held out) and the counts;
        sources by their key in the record (full citations: docs/published_record.md, ``validate --json``).
    """
    parts = ["<h2>10. The harvest model against the published record (docs/harvest.md, Validation)</h2>"]
    if step is not None and step.note:
        parts.append(f"<p class='small'><b>Note:</b> {html.escape(step.note)}</p>")
    if not val:
        parts.append("<p>Not available (see Failed runs).</p>")
        return parts
    s = val["summary"]
    parts.append(f"<p>Every published number the model can represent, set up on this machine and run from "
                 f"{val['replicates']} perturbed starts: the model's value with the 95 % prediction interval of one "
                 "field result (an efficiency's widened by the published yield's range), the verdict, and whether the "
                 "number was held out (nothing is fitted to any of them; model inputs read 'input').  Held out: "
                 f"{s['held_out']} numbers, {s['consistent']} consistent, {s['not_reproduced']} not reproduced; "
                 f"{s['inputs']} inputs; {s['not_represented']} not represented.</p>")

    def model(r):
        if r["model"] is None:
            return "-"
        return _Raw(f"{_num(r['model'])} {html.escape(r['unit'])}<br><span class='small'>[{_num(r['lo'])}, "
                    f"{_num(r['hi'])}]</span>")

    parts.append(_table(["published number", "source", "published", "model [interval]", "verdict", "held out"],
                        [[r["quantity"], r.get("source_key", ""), f"{_num(r['published'])} {r['unit']}", model(r),
                          r["verdict"], "yes" if r["held_out"] else "no"] for r in val["rows"]],
                        left=(0, 1, 4)))
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
