"""Self-contained HTML report of the study: every figure embedded (base64 PNG), numbers in tables, the
resolved configuration and package version at the end.  Opens offline; no scripts."""

from __future__ import annotations

import base64
import html
from pathlib import Path

from berryshaker.config import machine_table
from berryshaker.reference_study import CHOSEN_CODE, CLEARANCE_LEVELS_MM, CHOSEN_LEVELS, EQ18_F, FIELD_RESULT

CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;
color:#1d2330;line-height:1.45}h1{font-size:1.7em}h2{border-bottom:2px solid #c9d3e0;padding-bottom:.2em;margin-top:2em}
table{border-collapse:collapse;margin:.8em 0;font-size:.92em}td,th{border:1px solid #c9d3e0;padding:4px 9px;
text-align:right;vertical-align:top}th{background:#eef2f7}td.l,th.l{text-align:left}
figure{margin:1em 0}figure img{max-width:100%;border:1px solid #dde3eb}figcaption{font-size:.9em;color:#4a5568}
.v-reproduced{background:#e3f6e8}.v-not{background:#fbe4e4}.v-partly{background:#fff5d6}.v-nc{background:#eef}
.small{font-size:.85em;color:#4a5568}code{background:#f3f5f8;padding:0 3px}
"""


def _img(path: Path, caption: str) -> str:
    data = base64.b64encode(Path(path).read_bytes()).decode()
    return (f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")


def _maybe_img(parts: list, path: Path, caption: str) -> None:
    if Path(path).exists():
        parts.append(_img(path, caption))


def _table(header, rows, left=(0,)) -> str:
    h = "".join(f'<th class="{"l" if i in left else ""}">{html.escape(str(c))}</th>' for i, c in enumerate(header))
    body = []
    for r in rows:
        body.append("<tr>" + "".join(
            f'<td class="{"l" if i in left else ""}">{c if isinstance(c, _Raw) else html.escape(_fmt(c))}</td>'
            for i, c in enumerate(r)) + "</tr>")
    return f"<table><thead><tr>{h}</tr></thead><tbody>{''.join(body)}</tbody></table>"


class _Raw(str):
    pass


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def _vclass(verdict: str) -> str:
    return {"reproduced": "v-reproduced", "not reproduced": "v-not", "partly reproduced": "v-partly"}.get(verdict, "v-nc")


def study_report(res: dict, summary: dict, machine, figs: Path, steps: dict | None = None) -> str:
    """The self-contained HTML report of a study: claims with verdicts, failures, recommendation, one section
    per step (a step that did not run says why), configuration with provenance tags."""
    PAIR_NAMES = machine.pair_names
    steps = steps or {}

    def note(name):
        st = steps.get(name)
        if st is not None and st.note:
            parts.append(f"<p class='small'><b>Note:</b> {html.escape(st.note)}</p>")

    k = res["kinematics"]
    parts = [f"<!doctype html><html lang='en'><head><meta charset='utf-8'><title>berryshaker study - "
             f"{html.escape(machine.machine.name)}</title><style>{CSS}</style></head><body>",
             "<h1>Blueberry harvester with transmission clearance: the reference study, reproduced</h1>",
             f"<p>Machine: <b>{html.escape(machine.machine.name)}</b>. berryshaker {html.escape(summary['version'])}. "
             f"Total time {summary['timings_s']['total']:.1f} s; {summary['runs']['runs']} runs "
             f"({summary['runs']['cached']} from the cache).  Values marked [assumed] in the configuration are "
             "ours, not the study's (its tables were lost): see the end of this report.</p>"]
    # claims
    parts.append("<h2>Claims of the study and what our models give</h2>")
    rows = [[c["id"], c["claim"], _Raw(f'<span class="{_vclass(c["verdict"])}">{html.escape(c["verdict"])}</span>'),
             c["detail"]] for c in res["claims"]]
    parts.append(_table(["#", "claim (docs/study.md)", "verdict", "our numbers"], rows, left=(1, 2, 3)))
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
        parts.append(_table(["", *[f"{p} (mm)" for p in PAIR_NAMES], "efficiency (kg/min)", "unripe (%)",
                             "damage (%)"], [
            [f"ours ({opt['code']})", *[opt["clearance_mm"][p] for p in PAIR_NAMES], opt["efficiency_kg_min"],
             opt["unripe_rate_pct"], opt["damage_rate_pct"]],
            *([[f"study ({CHOSEN_CODE})", *[CLEARANCE_LEVELS_MM[p][CHOSEN_LEVELS[p] - 1] for p in PAIR_NAMES],
                FIELD_RESULT["efficiency_kg_min"], FIELD_RESULT["unripe_rate_pct"], FIELD_RESULT["damage_rate_pct"]]]
              if tuple(PAIR_NAMES) == tuple(CHOSEN_LEVELS) else [])]))
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
        parts.append(_table(["pair", "F (eq. 18)", "F critical (5 %)", "agree", "NRMSE", "correlation", "peak ratio"],
                            [[p, ag[p]["f_statistic"], ag[p]["f_critical"], ag[p]["agree"], ag[p]["nrmse"],
                              ag[p]["correlation"], ag[p]["peak_ratio"]] for p in PAIR_NAMES]))
        parts.append("<p class='small'>Study: F = " + ", ".join(f"{EQ18_F[p][0]}" for p in EQ18_F) + " against "
                     + ", ".join(f"{EQ18_F[p][1]}" for p in EQ18_F) + ".</p>")
        for i, p in enumerate(PAIR_NAMES):
            _maybe_img(parts, figs / f"fig{14 + i}_agreement_{p}.png", f"Pair {p}: collision force, both models, level 2")
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
    _maybe_img(parts, figs / "l9_main_effects.png", "Main effects of the virtual L9")
    for i, name in enumerate(("efficiency", "unripe", "damage")):
        _maybe_img(parts, figs / f"fig{27 + i}_surface_{name}.png", f"Response surfaces: {name}")
    # config
    parts.append("<h2>Configuration and provenance</h2>")
    parts.append(f"<p>berryshaker {html.escape(summary['version'])}; timings (s): "
                 + ", ".join(f"{k_} {v:.1f}" for k_, v in summary["timings_s"].items()) + "</p>")
    parts.append("<p class='small'>Provenance: [study] from the reference study's text, [assumed] our default where its "
                 "tables were lost, [calibrated] fitted to one published number (docs/plant.md, docs/harvest.md), "
                 "[default] not set in the file (the description's default).</p>")
    parts.append(_table(["key", "value", "source"], [[k_, v_, f"[{t_}]"] for k_, v_, t_ in machine_table(machine)],
                        left=(0, 1, 2)))
    parts.append("</body></html>")
    return "\n".join(parts)
