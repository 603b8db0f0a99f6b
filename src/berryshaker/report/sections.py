"""The study report's numbered sections: one renderer per section, each held by the study step that makes it
(:data:`berryshaker.study.pipeline.STEPS`).  The report (:func:`berryshaker.report.html.study_report`) renders the
steps' sections in the pipeline's order and numbers them as it goes (:func:`step_sections`); no heading carries a
typed number, and a section names another by its renderer (:meth:`SectionInput.ref`).

A renderer takes a :class:`SectionInput` and returns the section's title (without its number) and its HTML parts;
the note of its step (e.g. why it did not run) is shown under the heading of the step's first section.  A section
that also reads another step's results names its owning step in its docstring.

Each section shows its answer (the table an engineer reads, at most a figure or two); the rest (further figures, the
tables behind them, the analyses as text) is folded under a one-line ``<details>`` summary (printed open), so the
report's body stays about 15 screens long before its appendix.

long module: one renderer per section of the report, and the sections name each other by their renderers
(:meth:`SectionInput.ref`): split, the modules would import each other.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence

from berryshaker.reference_study import EQ18_F
from berryshaker.report.html_blocks import _details, _maybe_img, _num, _Raw, _table
from berryshaker.report.l9_replicates import l9_replicates_section
from berryshaker.report.life_tables import life_parts
from berryshaker.user_text import html_text

#: a section renderer: input -> (title without its number, HTML parts)
Renderer = Callable[["SectionInput"], "tuple[str, list[str]]"]


@dataclass(frozen=True)
class SectionInput:
    """What every section renderer reads.

    Attributes
    ----------
    res : StudyResults
        The steps' results, each step's data under its result name (``berryshaker.study.step_result.StudyResults``,
        read by attribute; SI inside, the renderers print units at the edges).
    machine : MachineBase
        The machine description (its clearance pairs).
    figs : Path
        Folder of the figures (PNG, embedded where present).
    numbers : dict
        Each section's number in this report, by renderer (:func:`section_numbers`).
    """

    res: object
    machine: object
    figs: Path
    numbers: dict = field(default_factory=dict)

    @property
    def pairs(self) -> tuple:
        """The machine's clearance pairs, in order."""
        return tuple(self.machine.pair_names)

    def ref(self, renderer: Renderer, absent: str) -> str:
        """How a section names another: "section N", or ``absent`` when that section is not in the report.

        Parameters
        ----------
        renderer : callable
            The other section's renderer.
        absent : str
            The words used when it is not in this report.

        Returns
        -------
        str
            "section N" or ``absent``.
        """
        n = self.numbers.get(renderer)
        return absent if n is None else f"section {n}"


def section_numbers(steps: Sequence[tuple[str, Sequence[Renderer]]]) -> dict:
    """Number the steps' sections 1, 2, ... in the steps' order (a step's own sections in its order).

    Parameters
    ----------
    steps : sequence of (str, sequence of callable)
        Per study step in the pipeline's order: its name (its results' key) and its section renderers.

    Returns
    -------
    dict
        Section number by renderer.
    """
    renderers = [r for _, rs in steps for r in rs]
    return {r: i + 1 for i, r in enumerate(renderers)}


def step_sections(steps: Sequence[tuple[str, Sequence[Renderer]]], inp: SectionInput, notes: dict) -> list[str]:
    """The steps' sections in the steps' order, each under a heading numbered here; a step's note (e.g. why it did
    not run) under the heading of its first section.

    Parameters
    ----------
    steps : sequence of (str, sequence of callable)
        Per study step in the pipeline's order: its name and its section renderers.
    inp : SectionInput
        What the renderers read; its ``numbers`` are :func:`section_numbers` of ``steps``.
    notes : dict
        Each step's note by step name ("" or absent: none).

    Returns
    -------
    list of str
        HTML parts.
    """
    parts = []
    for name, renderers in steps:
        for k, render in enumerate(renderers):
            title, body = render(inp)
            parts.append(f"<h2>{inp.numbers[render]}. {html_text(title, quote=False)}</h2>")
            if k == 0 and notes.get(name):
                parts.append(f"<p class='small'><b>Note:</b> {html_text(notes[name])}</p>")
            parts.extend(body)
    return parts


def _rows_last(inp: SectionInput) -> int:
    """The last clearance row: row 1, three per pair, the three level sets."""
    return 4 + 3 * len(inp.pairs)


def kinematics_section(inp: SectionInput) -> tuple[str, list[str]]:
    """The drive's kinematics (study step ``kinematics``): the summary table and its figures.

    Parameters
    ----------
    inp : SectionInput
        Results (``kinematics``: a ``berryshaker.drives.kinematics_record.KinematicsSummary``, read by attribute;
        lengths in mm, angles in deg, speeds m/s, frequency Hz), machine, figures.

    Returns
    -------
    tuple of (str, list of str)
        Title and HTML parts.
    """
    k, figs = inp.res.kinematics, inp.figs
    parts = []
    krows = []
    if k.cam is not None:
        c = k.cam
        krows += [
            ["stroke", f"{c.stroke_mm:.2f} mm"], ["max push-rod velocity", f"{c.max_velocity_m_s:.4f} m/s"],
            ["max acceleration", f"{c.max_acceleration_m_s2:.3f} m/s²"], ["max jerk", f"{c.max_jerk_m_s3:.1f} m/s³"],
            ["pressure angle", f"{c.pressure_angle_deg.min:.2f} .. {c.pressure_angle_deg.max:.2f} deg"],
            ["min pitch radius of curvature",
             f"{c.min_radius_of_curvature_mm:.2f} mm (roller {c.roller_radius_mm:.1f} mm)"]]
    for key, val in (k.drive_specific or {}).items():
        krows.append([key.replace("_", " "), str(val)])
    left, right, ta = k.combs["left"].swing_deg, k.combs["right"].swing_deg, k.linkage.transmission_angle_deg
    parts.append(_table(["quantity", "value"], krows + [
        ["left comb swing", f"{left.min:.2f} .. {left.max:.2f} deg"],
        ["right comb swing", f"{right.min:.2f} .. {right.max:.2f} deg"],
        ["transmission angle", f"{ta.min:.2f} .. {ta.max:.2f} deg"],
        ["comb frequency", f"{k.drive.comb_frequency_hz:.3f} Hz"]]))
    more: list[str] = []
    for name, cap in (("svaj.png", "Push-rod displacement, velocity, acceleration, jerk (3-4-5 law, corrected return)"),
                      ("groove_profile.png", "Groove cam: pitch curve and walls offset along its normal (corrected eq. 2)"),
                      ("comb_angles.png", "Comb swings, tip speeds and transmission angle (eq. 3)")):
        _maybe_img(more, figs / name, cap)
    parts.append(_details("Figures: the push rod's motion, the groove, the comb swings", more))
    return "Kinematics of the drive (eq. 1-3)", parts


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
        parts.append(_table(["pair", "F (eq. 18)", "F critical (5 %)", "statistics agree (this run)", "NRMSE",
                             "correlation", "peak ratio"],
                            [[p, ag[p].f_statistic, ag[p].f_critical, ag[p].agree, ag[p].nrmse,
                              ag[p].correlation, ag[p].peak_ratio] for p in PAIR_NAMES]))
        parts.append("<p class='small'>Study: F = " + ", ".join(f"{EQ18_F[p][0]}" for p in EQ18_F) + " against "
                     + ", ".join(f"{EQ18_F[p][1]}" for p in EQ18_F) + ".</p>")
        curves: list[str] = []
        for i, p in enumerate(PAIR_NAMES):
            _maybe_img(curves, figs / f"fig{14 + i}_agreement_{p}.png", f"Pair {p}: collision force, both models, level 2")
        parts.append(_details(f"Figures 14-{13 + len(PAIR_NAMES)}: both models' collision force per pair", curves))
    check = res.rows.model_check if res.rows is not None else None
    if check:
        st = check.starts
        parts.append(f"<p>The model check (claim 1): level {check.level}, each statistic's mean over "
                     f"{st.multibody} perturbed starts of the multibody model and {st.reduced} turned starts of "
                     "the MLSD (+- one standard error), their relative difference +- its noise (95 % Student-t band) "
                     "and the tolerance.  'within noise': the tolerance lies inside the noise band, so these runs "
                     "cannot tell.</p>")
        parts.append(_table(["pair", "statistic", "multibody (N)", "MLSD (N)", "difference", "tolerance", "verdict"],
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

        parts.append(_details("Agreement on every clearance row (table)", [_table(
            ["row"] + list(PAIR_NAMES), [[r] + [cell(per[p]) for p in PAIR_NAMES] for r, per in
                                         sorted(row_ag.items(), key=lambda kv: int(kv[0]))],
            left=tuple(range(len(PAIR_NAMES) + 1)))]))
    return "MLSD model vs multibody contact simulation (eq. 18; Figs. 14-17)", parts


def collision_force_section(inp: SectionInput) -> tuple[str, list[str]]:
    """Collision force against clearance on the single-factor rows (study step ``clearance_rows``, its first
    section).

    Parameters
    ----------
    inp : SectionInput
        Results (``rows``: a ``berryshaker.study.mechanics_records.ClearanceRows``, read by attribute; clearances
        in mm, forces in N), machine, figures.

    Returns
    -------
    tuple of (str, list of str)
        Title and HTML parts.
    """
    res, figs, PAIR_NAMES = inp.res, inp.figs, inp.pairs
    last = _rows_last(inp)
    title = f"Collision force against clearance (rows 1-{last - 3}; Figs. 18-21)"
    if res.rows is None:
        return title, ["<p>Not available (see Failed runs).</p>"]
    mb = res.rows.multibody
    rows = []
    for r in range(1, last + 1):
        if str(r) not in mb:
            continue
        s = mb[str(r)]
        rows.append([r, *[s.clearance_mm[p] for p in PAIR_NAMES], *[s.collision_force_N[p].peak for p in PAIR_NAMES],
                     *[s.collision_force_N[p].mean for p in PAIR_NAMES]])
    parts = [_table(["row", *[f"{p} mm" for p in PAIR_NAMES], *[f"peak {p} (N)" for p in PAIR_NAMES],
                     *[f"mean {p} (N)" for p in PAIR_NAMES]], rows)]
    bars: list[str] = []
    for i, p in enumerate(PAIR_NAMES):
        _maybe_img(bars, figs / f"fig{18 + i}_rows_{p}.png", f"Clearance {p} alone: collision force")
    parts.append(_details(f"Figures 18-{17 + len(PAIR_NAMES)}: collision force against each pair's clearance", bars))
    return title, parts


def comb_load_section(inp: SectionInput) -> tuple[str, list[str]]:
    """Comb load moments on row 1 and the three level sets (study step ``clearance_rows``, its second section).

    Parameters
    ----------
    inp : SectionInput
        Results (``rows``: a ``berryshaker.study.mechanics_records.ClearanceRows``, read by attribute; moments in
        N m), machine, figures.

    Returns
    -------
    tuple of (str, list of str)
        Title and HTML parts.
    """
    last = _rows_last(inp)
    lv = (last - 2, last - 1, last)
    title = f"Comb load moments (rows 1, {lv[0]}-{lv[2]}; Figs. 22-23)"
    if inp.res.rows is None:
        return title, ["<p>Not available (see Failed runs).</p>"]
    mb = inp.res.rows.multibody
    parts = ["<p class='small'>These machine-only runs have no plant: the load is the aggregate bush model (a "
             "spring-damper about each comb shaft, 200 N m/rad [assumed]); peak and rms are per comb, about its "
             "shaft.  It loads the combs about 40 times more than the explicit bush of branches in "
             f"{inp.ref(harvest_response_section, 'the harvest-response section')} "
             "(there about 16 N m peak, 1 N m rms; here about 81 N m peak, 48 N m rms; docs/plant.md).</p>"]
    parts.append(_table(["row", "left peak (N m)", "left rms", "right peak", "right rms"],
                        [[r, mb[str(r)].load_moment_Nm["left"].peak, mb[str(r)].load_moment_Nm["left"].rms,
                          mb[str(r)].load_moment_Nm["right"].peak, mb[str(r)].load_moment_Nm["right"].rms]
                         for r in (1, *lv) if str(r) in mb]))
    moments: list[str] = []
    for i, side in enumerate(("left", "right")):
        _maybe_img(moments, inp.figs / f"fig{22 + i}_moment_{side}.png", f"{side} comb load moment")
    parts.append(_details("Figures 22-23: the comb load moments", moments))
    return title, parts


def fruit_force_section(inp: SectionInput) -> tuple[str, list[str]]:
    """Fruit harvesting force at the chosen clearances and the level sets (study step ``fruit_force``).

    Parameters
    ----------
    inp : SectionInput
        Results (``fruit_force``, a ``berryshaker.study.fruit_force_records.FruitForceStep``: heights in m,
        forces in N), machine, figures.

    Returns
    -------
    tuple of (str, list of str)
        Title and HTML parts.
    """
    res, parts = inp.res, []
    if res.fruit_force is not None and res.fruit_force.chosen is not None:
        pos = res.fruit_force.chosen.summary.positions
        parts.append(_table(["fruit", "z (m)", "peak (N)", "study range (N)", "ripe fruit", "unripe fruit"],
                            [[n, d.z_m, d.peak_force_N, "-".join(str(x) for x in d.study_range_N or []),
                              d.eq17.ripe, d.eq17.unripe] for n, d in pos.items()]))
    _maybe_img(parts, inp.figs / "fig24_26_fruit_force.png", "Fruit force against machine-to-plant distance")
    by_level: list[str] = []
    _maybe_img(by_level, inp.figs / "fruit_force_by_level.png", "Peak fruit force at the three level sets")
    parts.append(_details("Figure: the peak fruit force at the three level sets", by_level))
    if res.fruit_force is not None:
        parts.extend(transmission_parts(res.fruit_force))
    return "Fruit harvesting force (eq. 16-17; Figs. 24-26)", parts


def transmission_parts(ff) -> list[str]:
    """The table that follows the clearance impacts from the pins to the fruit at level sets 1 and 3 (the smallest
    and the largest clearances), with the sentence it supports; empty when either drive-past lacks it.

    Parameters
    ----------
    ff : FruitForceStep
        The study step's data (``rows`` by clearance row, ``level_rows``; RMS values in N or m/s^2).

    Returns
    -------
    list of str
        HTML parts.
    """
    from berryshaker.harvest.transmission import IMPACT_BAND_HZ

    lo, hi = (ff.rows.get(str(ff.level_rows[0])), ff.rows.get(str(ff.level_rows[-1])))
    if lo is None or hi is None or lo.transmission is None or hi.transmission is None:
        return []
    a, b = lo.transmission, hi.transmission
    rows = [[link, a[link].unit, f"{_num(a[link].shaking_band_rms)} → {_num(b[link].shaking_band_rms)}",
             f"{_num(a[link].impact_band_rms)} → {_num(b[link].impact_band_rms)}",
             f"{100 * a[link].impact_share:.3g} → {100 * b[link].impact_share:.3g}"] for link in a if link in b]
    pins = [v.impact_share for k, v in b.items() if k.startswith("pin ")]
    stems = [v.impact_share for k, v in b.items() if k.startswith("stem ")]
    text = ""
    if pins and stems and "fingers" in b:
        span = f"{100 * min(pins):.0f}" + ("" if f"{100 * min(pins):.0f}" == f"{100 * max(pins):.0f}"
                                           else f"-{100 * max(pins):.0f}")
        text = (f"<p>The clearance impacts (above {IMPACT_BAND_HZ:g} Hz) are {span} % of the pins' force "
                f"fluctuation at level set 3, {100 * b['fingers'].impact_share:.2g} % of the fingers' and at most "
                f"{100 * max(stems):.2g} % of a stem force: fingers, branch and pedicel filter them out, so the "
                "clearances barely move the harvest (docs/harvest.md, \"From the pin to the fruit\").</p>")
    return [text, _details(f"Table: from the pin to the fruit, the shaking band (below {IMPACT_BAND_HZ:g} Hz) and "
                           "the impact band (above), level set 1 → level set 3",
                           [_table(["link", "unit", "shaking-band RMS", "impact-band RMS",
                                    "impact share of the fluctuation (%)"], rows)])]


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
    parts.append(_table(["run", *[f"{p} mm" for p in PAIR_NAMES], "efficiency (kg/min)", "unripe (%)", "damage (%)"],
                        [[r.run, *[r.clearance_mm[p] for p in PAIR_NAMES], r.efficiency, r.unripe, r.damage]
                         for r in runs]))
    ranges: list[str] = []
    for name in [n for n in ("efficiency", "unripe", "damage") if n in responses]:
        ra = responses[name]
        an = ra.anova.factors
        ranges.append(f"<h3>{name}: range analysis ({'maximise' if ra.maximize else 'minimise'})</h3>")
        ranges.append(_table(["factor", "k1", "k2", "k3", "R", "best", "ANOVA F", "p"],
                             [[f, *ra.factors[f].level_means, ra.factors[f].range, ra.factors[f].best_level,
                               an[f].f if f in an else "pooled", an[f].p if f in an else ""] for f in PAIR_NAMES]))
        reg = ra.regression
        ranges.append(f"<p class='small'>Ranking {' > '.join(ra.ranking)}.  Eq. 19 (full quadratic, "
                      f"{len(reg.full_model_terms)} terms) has rank {reg.full_model_rank} at the nine runs; aliased: "
                      f"{', '.join(reg.aliased_terms)}.  Fitted instead: the main-effects quadratic model "
                      f"(R² = {reg.main_effects_quadratic.r2:.3f}, {reg.main_effects_quadratic.residual_df} "
                      "residual df: it interpolates) and a ridge-regularised full model, labelled as such.</p>")
    parts.append(_details("The study's range analysis of the nine runs (Table 8: one value per run, no noise)",
                          ranges))
    rep = l9.replicated if l9 is not None else None
    if rep:
        parts.append(f"<h3>Against its own noise ({len(rep.seeds)} population seeds per run)</h3>")
        parts.append("<p class='small'>Each run's indexes were recomputed for independently sampled bushes; effects are "
                     "tested against that replicate error, and a factor whose effect is not significant is 'no "
                     "meaningful difference' in the recommendation.</p>")
        parts.append(_details("The replicated analysis as text (ANOVA tables, paired differences)",
                              [f"<pre class='text'>{html_text(rep.text)}</pre>"]))
        parts.extend(l9_replicates_section(l9, figs, PAIR_NAMES))
    else:  # the single-run main effects, where there is no replicated analysis to draw them with intervals
        _maybe_img(parts, figs / "l9_main_effects.png", "Main effects of the virtual L9")
    surfaces: list[str] = []
    for i, name in enumerate(("efficiency", "unripe", "damage")):
        _maybe_img(surfaces, figs / f"fig{27 + i}_surface_{name}.png", f"Response surfaces: {name}")
    parts.append(_details("Figures 27-29: response surfaces", surfaces))
    return "Virtual L9 field test (Tables 7-8; Figs. 27-29)", parts


def clearance_life_section(inp: SectionInput) -> tuple[str, list[str]]:
    """Clearance over the machine's life (study step ``clearance_life``): wear growth, service life and fits.

    Parameters
    ----------
    inp : SectionInput
        Results (``clearance_life``, a ``berryshaker.study.life_drive_records.ClearanceLife``: clearances in mm,
        hours h), machine, figures.

    Returns
    -------
    tuple of (str, list of str)
        Title and HTML parts (none but the title when the step has no results).
    """
    parts = []
    life = inp.res.clearance_life
    if life is not None:
        parts += life_parts(life)
        more = ["<p class='small'>" + "; ".join(html_text(n) for n in life.notes) + "</p>"]
        _maybe_img(more, inp.figs / "life_clearance_growth.png", "Clearance growth by wear against operating hours")
        parts.append(_details("How the life was found (notes) and the clearance growth against hours (figure)", more))
    return "Clearance life: wear and fits (docs/life.md)", parts


def powered_drive_section(inp: SectionInput) -> tuple[str, list[str]]:
    """The powered driveline at clearance levels 1-3 (study step ``powered_drive``).

    Parameters
    ----------
    inp : SectionInput
        Results (``powered_drive``, a ``berryshaker.study.life_drive_records.PoweredDrive``: clearances in mm,
        speeds r/min, ripple %, power W, energy J/rev), machine.

    Returns
    -------
    tuple of (str, list of str)
        Title and HTML parts: the table, then the finding (none but the title when the step has no results).
    """
    title = "Powered drive: speed ripple, input power and energy lost per joint (docs/driveline.md)"
    pw, pairs = inp.res.powered_drive, inp.pairs
    if pw is None:
        return title, []
    rows = []
    for lv, d in pw.levels.items():
        e, sp = d.energy_per_revolution_J, d.cam_speed_rpm
        ripple = f"{d.speed_ripple_percent:.3g} +- {d.speed_ripple_sd_percent:.2g}"
        rows.append([lv, ", ".join(f"{p} {d.clearance_mm[p]:g}" for p in pairs),
                     f"{sp.min:.1f} .. {sp.max:.1f} ({sp.mean:.2f})", ripple,
                     d.input_power_W, *[e[p] for p in pairs], e.get("belt", 0.0), e.get("mesh", 0.0),
                     d.audit_relative_residual])
    parts = [_table(["level", "clearance (mm)", "shaft speed min .. max (mean), r/min, replicate means", "ripple (%)",
                     "input power (W)", *[f"lost in {p} (J/rev)" for p in pairs], "belt (J/rev)",
                     "mesh (J/rev)", "energy audit residual"], rows, left=(0, 1, 2, 3))]
    reps = pw.replicates
    rep_text = (f" Every level is the mean of {reps} runs from seeded perturbed starts (clearance joints off centre, "
                "seeds in summary.json); ripple is shown as mean +- SD, and a trend is stated only where Welch's "
                "t-test between consecutive levels finds it beyond that spread." if reps else "")
    parts.append(f"<p>{html_text(pw.finding)} Energy lost per revolution is the work of each joint's contact "
                 "damping and friction, integrated with the motion; the audit residual is the largest over the "
                 "replicates of |motor work - kinetic, stored and dissipated energy| / motor work over revolutions "
                 f"2-3.{rep_text}</p>")
    return title, parts


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
                     f" Per comb, about its shaft; compare {inp.ref(comb_load_section, 'the comb-load section')}'s "
                     "aggregate spring-damper, which loads the combs about 40 times more.</p>")
        parts.append(_table(["comb", "peak (N m)", "rms (N m)"],
                            [[side, v.peak, v.rms] for side, v in chosen.load_moment_Nm.items()]))
    hr = res.harvest_response
    if hr is None:
        parts.append("<p>Not available (see Failed runs).</p>")
        return title, parts
    reps = next((r.replicates for r in hr.rows if r.replicates), None)
    parts.append("<p>The harvest responses of the seeded virtual harvest against the drive-shaft speed, one comb cycle "
                 "per revolution, at the configured clearances; every other value as described."
                 + (f" Each cell is the model's expectation over {reps} perturbed starts ± the model's start-to-start "
                    "SD, and in brackets the SD of one counted field test (the field's test-to-test spread)."
                    if reps else "") + "</p>")
    names = list(hr.rows[0].responses) if hr.rows else []

    def _sd(s):  # the expectation with the model's SD and the field test's
        return f"{s.mean:.3g} ± {s.sd:.2g} ({s.field_sd:.2g})"

    parts.append(_table(["drive speed (r/min)", "frequency (Hz)"]
                        + [f"{n.replace('_', ' ')} ({hr.rows[0].responses[n].unit})" for n in names],
                        [[r.speed_rpm, r.shaking_frequency_hz, *[_sd(r.responses[n]) for n in names]]
                         for r in hr.rows]))
    _maybe_img(parts, figs / "harvest_vs_frequency.png", "Virtual harvest against shaking frequency")
    cal = hr.calibration
    if cal is not None:
        parts.append(_details("Calibration: every plant and picking parameter, its provenance, the held-out checks", [
            "<p>Calibration: every plant and picking parameter with its provenance; [calibrated] values "
            "were fitted to the target named, the quantities below them were not fitted and are "
            "held-out comparisons with the study (docs/plant.md).</p>",
            _table(["parameter", "value", "unit", "tag", "target or source"],
                   [[p.parameter, p.value, p.unit, p.tag, p.target_or_source] for p in cal.parameters], left=(0, 3, 4)),
            _table(["quantity", "model", "study", "inside the study's range"],
                   [[h.quantity, h.model, h.study, "-" if h.inside is None else h.inside] for h in cal.held_out])]))
    return title, parts


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
        return _Raw(f"{_num(r.model)} {html_text(r.unit)}<br><span class='small'>[{_num(r.lo)}, "
                    f"{_num(r.hi)}]</span>")

    header = ["published number", "source", "published", "model [interval]", "verdict", "held out"]

    def rows(keep):
        return [[r.quantity, r.source_key, f"{_num(r.published)} {r.unit}", model(r), r.verdict,
                 "yes" if r.held_out else "no"] for r in val.rows if keep(r)]

    parts.append(_table(header, rows(lambda r: r.verdict != "not comparable"), left=(0, 1, 4)))
    other = [r for r in val.rows if r.verdict == "not comparable"]
    if other:
        reasons = sorted({r.how for r in other})
        parts.append(_details(f"Table: {len(other)} published numbers of machines this description does not "
                              "represent (not comparable)",
                              [_table(["published number", "source", "published", "case"],
                                      [[r.quantity, r.source_key, f"{_num(r.published)} {r.unit}", r.case]
                                       for r in other], left=(0, 1, 3)),
                               "<p>" + html_text("; ".join(reasons)) + ".</p>"]))
    return title, parts
