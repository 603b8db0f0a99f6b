"""The virtual L9's replicated analysis in the study report (study/l9/__init__.py's ``replicated``, ``paired``,
``recommended``, ``tolerance_check`` and ``tradeoff``): replicate spread and significance, the recommendation and
its basis, the solver-tolerance check, the trade-off of the candidate clearance sets and Minitab's effect figures,
as HTML parts of the virtual L9 section (:func:`berryshaker.report.sections.virtual_l9_section`).
"""

from __future__ import annotations

import re
from pathlib import Path

from berryshaker.report.design import level_set_name
from berryshaker.report.html_blocks import _details, _maybe_img, _num, _Raw, _table
from berryshaker.units import format_tolerance
from berryshaker.user_text import html_text


def _short_candidate(name: str) -> str:
    """A trade-off candidate's short label: "run 3 (A 0.25 mm, ...)" -> "3", "recommended (...)" -> "rec."."""
    m = re.match(r"run (\d+)\b", name)
    if m:
        return m.group(1)
    return "rec." if name.startswith("recommended") else name


def l9_replicates_section(l9, figs: Path, pair_names) -> list[str]:
    """Replicate spread, significance, the recommendation's basis, the solver-tolerance check and the trade-off
    table of the virtual L9 (study/l9/__init__.py), as HTML parts.

    Parameters
    ----------
    l9 : VirtualL9
        The virtual L9 (``berryshaker.study.l9.records.VirtualL9``, read by attribute; response units in
        ``response_units``).
    figs : Path
        Folder of the figures.
    pair_names : sequence of str
        The clearance pairs (factors).

    Returns
    -------
    list of str
        HTML parts.
    """
    rep = l9.replicated
    units = l9.response_units or rep.units
    parts = [f"<p class='small'>Replicates: {html_text(rep.perturbation.what)}.</p>"]
    rows = []
    paired = l9.paired
    for name, ra in rep.responses.items():
        sd = ra.anova.pure_error.ms ** 0.5
        sig = ", ".join(f"{f} (p = {ra.factors[f].p:.2g})" for f in ra.significant_factors) or "none"
        pr = "; ".join(f"{f}{q.levels[1]} - {f}{q.levels[0]}: {q.difference:+.3g} +- {q.se:.2g}"
                       + ("" if q.beyond_noise else " (no difference)") for f, q in paired.get(name, {}).items())
        rows.append([name, units.get(name, ""), float(sum(ra.run_means) / len(ra.run_means)), sd, sig, pr])
    if rows:
        parts.append(_details("Replicate spread and significance per response (table; the design answers give the "
                              "paired differences with their intervals)", [
            "<p class='small'>Each start is one virtual field test (its machine start and the bushes and "
            "fruit it counts), and the starts are blocks: start k is the same for every run, so its luck "
            "cancels from every comparison.  Per-start SD: the spread of one run's field tests; each factor "
            "is tested against its own interaction with the starts, one verdict per factor and response; "
            "paired differences: the extreme levels of each factor compared start by start, +- one "
            "standard error, with that verdict.</p>",
            _table(["response", "unit", "grand mean", "per-start SD", "significant factors",
                    "paired differences (last - first level)"], rows, left=(0, 1, 4, 5))]))
    det = getattr(l9, "detectability", None) or {}
    if det:
        drows = []
        for name, per in det.items():
            ra = rep.responses.get(name)
            for f, d in per.items():
                n = d.tests_per_level
                drows.append([name, f, f"{d.effect:.3g} ± {d.effect_se:.2g} {units.get(name, '')}",
                              "differs" if ra is not None and ra.factors[f].significant else "no difference",
                              f"{d.field_sd:.3g}", "-" if n is None else (">10,000" if n > 1e4 else f"{n:.0f}")])
        parts.append("<details><summary>What a field test would see: the model's effects against the noise of one "
                     "field test</summary>")
        parts.append("<p class='small'>Model effect: the range of the factor's level means of the model's expectation "
                     "(the starts shared, so paired); SD of one field test: the counted field results' spread at one "
                     "setting; field tests per level: what a two-sided t test at alpha 0.05 needs to see that effect "
                     "with power 0.8 (statsmodels TTestIndPower).</p>")
        parts.append(_table(["response", "factor", "model effect (range ± SE)", "verdict", "SD of one field test",
                             "field tests per level"], drows, left=(0, 1, 3)))
        parts.append("</details>")
    rec = l9.recommended
    if rec.statement:
        parts.append("<h3>Recommendation and its basis</h3>")
        parts.append(f"<p><b>{html_text(rec.name or level_set_name(rec.clearance_mm))}</b> "
                     f"({html_text(rec.code)}): {html_text(rec.statement)}</p>")
        parts.append(_table(["factor", "level", "basis"], [[p, rec.levels[p], rec.basis[p]]
                                                          for p in pair_names if p in rec.basis],
                            left=(0, 2)))
        parts.append(_details("The rule that chose the levels (two tiers, never ranking noise)",
                              [f"<p class='small'>{html_text(rec.rule)}.</p>"]))
        parts.append(f"<p class='small'>Starts at the recommendation: {html_text(rec.sequential.statement)}.</p>")
    tc = l9.tolerance_check
    check: list[str] = []
    if tc.done:
        rt = tc.rtol  # run and check tolerances (dimensionless)
        check.append(f"<p>{html_text(tc.statement)} ({tc.replicates} replicate(s) of the recommended set "
                     f"re-run at rtol {format_tolerance(rt[1])}"
                     + (f"; velocities held absolutely below rtol x {tc.velocity_scale_m_s:g} m/s at both"
                        if tc.velocity_scale_m_s is not None else "") + ").</p>")
        fmt = [format_tolerance(x) for x in rt]
        check.append(_table(["response", _Raw(f"mean change <span class='nw'>{fmt[0]}</span> -&gt; <span class='nw'>{fmt[1]}</span>"), "largest change", "replicate SD",
                             "noise of the mean (SD)", "within 2 x noise"],
                            [[n, v.mean_change, v.max_abs_change, v.replicate_sd, v.noise_sd, v.within_replicate_spread]
                             for n, v in tc.responses.items()]))
        parts.append(_details(f"Solver-tolerance check: {tc.statement}", check))
    else:
        parts.append(f"<p class='small'>Solver-tolerance check not run: {html_text(tc.reason or '')}.</p>")
    recs = l9.tradeoff
    if recs:
        parts.append("<h3>Trade-off of the candidate clearance sets</h3>")
        forces = [f"design_force_N:{p}" for p in pair_names if f"design_force_N:{p}" in recs[0]]
        idx = [n for n in ("efficiency", "ripe_removal", "unripe", "damage") if n in recs[0]]
        tq = [c for c in ("drive_torque_design_Nm", "drive_torque_rms_Nm") if c in recs[0]]

        def cell(r, c):  # the mean, its interval on a second line: narrow columns, short rows
            lo, hi = r.get(f"{c}_lo", r[c]), r.get(f"{c}_hi", r[c])
            return _Raw(f"{_num(r[c])}<span class='ci'>[{_num(lo)}, {_num(hi)}]</span>")

        short = {r["name"]: _short_candidate(r["name"]) for r in recs}

        def beaten_by(r):
            names = [n.strip() for n in (r.get("dominated_by") or "").split("; ") if n.strip()]
            return "; ".join(short.get(n, n) for n in names) or "-"

        header = (["candidate"] + [f"{n} ({units.get(n, '')})" for n in idx] + ["dominated by"])
        body = [[r["name"]] + [cell(r, c) for c in idx] + [beaten_by(r)] for r in recs]
        table = [_table(header, body, left=(0, len(header) - 1))]
        loads = (["candidate"] + [f"static-equivalent force {c.split(':')[1]} (N)" for c in forces]
                 + ["drive torque, design: p95 of the per-revolution peaks (N m)", "drive torque RMS (N m)"][:len(tq)])
        if len(loads) > 1:
            table.append(_table(loads, [[r["name"]] + [cell(r, c) for c in forces + tq] for r in recs]))
        table.append("<p class='small'>Each cell: mean of the replicates [95 % interval of the mean]; the machine loads "
                     "of the same candidates in the second table (a collision force there is the static-equivalent load, the p95 "
                     "of the impact peaks over each start's drive-past, not a run's single largest force); "
                     "'dominated by' names the dominating candidates by "
                     "run number ('rec.': the recommended set).  A candidate is "
                     "dominated if another is no worse beyond noise in every judged column and better beyond noise in "
                     "one, 'beyond noise' being the Tukey-Kramer margin on the ANOVA's error (blocked on the starts), "
                     "simultaneous over all candidates (docs/harvest.md, \"Trade-off table\"); clearances are "
                     "descriptive.  The tiered "
                     "choice is confirmed against this table: a tested run that dominates it becomes the "
                     "recommendation.</p>")
        parts.append(_details(f"The {len(recs)} candidates' harvest indexes and machine loads, and which dominate "
                              "which (tables; the figure below draws them)", table))
    _maybe_img(parts, figs / "l9_tradeoff.png", "Trade-off: efficiency against static-equivalent collision force and drive torque")
    # the main effects, drawn once: with the replicates' 95 % intervals (the single-run figure is not repeated)
    _maybe_img(parts, figs / "l9_effects_harvest.png", "Main effects on the harvest indexes with 95 % intervals")
    more: list[str] = []
    _maybe_img(more, figs / "l9_effects_loads.png", "Main effects on the machine loads with 95 % intervals")
    for name in sorted(rep.responses):  # Minitab's effect figures (report.plots.effects), where drawn
        for kind, what in (("pareto", "Pareto chart of the standardized effects (t of each factor's linear and "
                                      "quadratic contrasts against the blocked error)"),
                           ("residuals", "Residuals of the main-effects model with blocks: normal probability plot "
                                         "and residuals against fitted values"),
                           ("interactions", "Interaction plots: mean of the starts at each pair of levels")):
            _maybe_img(more, figs / f"l9_{kind}_{name}.png", f"{name}: {what}")
    parts.append(_details("Figures: main effects on the machine loads; per harvest index, Pareto chart of the "
                          "effects, residuals, interactions", more))
    return parts
