"""The design answers (:func:`berryshaker.report.design.design_answers`) as the study report's opening section:
tables of at most :data:`MAX_COLUMNS` columns with fixed widths, so nothing is wider than an A4 page (794 CSS px),
each number with its interval and the report section it comes from.  A section is named by its renderer's name
(:data:`STEP_SECTIONS`) and numbered as the report numbers it
(:func:`berryshaker.report.sections.section_numbers`, in the order of ``berryshaker.study.steps.STEPS``).
"""

from __future__ import annotations

import math

from berryshaker.report.design_quantity import Quantity
from berryshaker.report.design_records import DesignAnswers
from berryshaker.report.html_blocks import _details, _Raw, _table
from berryshaker.report.sections import section_number
from berryshaker.user_text import html_text

#: widest table of the section (columns); with fixed column widths every table fits an A4 page
MAX_COLUMNS = 6
#: the report section of each step the answers come from: step -> (the name of the renderer of its first section
#: (``berryshaker.study.steps``), or None for the unnumbered configuration at the end; the section's short name);
#: the number is the report's
STEP_SECTIONS = {"virtual_l9": ("virtual_l9_section", "Virtual L9"),
                 "clearance_life": ("clearance_life_section", "Clearance life"),
                 "powered_drive": ("powered_drive_section", "Powered drive"),
                 "harvest_response": ("harvest_response_section", "Harvest response"),
                 "kinematics": ("kinematics_section", "Kinematics"), "machine": (None, "Configuration")}


def section_label(step: str, numbers: dict | None = None) -> str:
    """The report section a step's answers come from: "6. Virtual L9", numbered as the report numbers it.

    Parameters
    ----------
    step : str
        The study step (a key of :data:`STEP_SECTIONS`; another name is its own label).
    numbers : dict, optional
        Each section's number in the report, by renderer (:func:`berryshaker.report.sections.section_numbers`);
        None or a section not in it: the short name without a number.

    Returns
    -------
    str
        "N. short name", or the short name.
    """
    render, name = STEP_SECTIONS.get(step, (None, step))
    n = section_number(numbers, render)
    return name if n is None else f"{n}. {name}"


def _section_ref(step: str, numbers: dict | None) -> str:
    """How the answers name a step's section in a sentence: "section N", or its short name when not numbered."""
    n = section_number(numbers, STEP_SECTIONS[step][0])
    return STEP_SECTIONS[step][1] if n is None else f"section {n}"


def _section_numbers(steps: tuple, numbers: dict | None) -> str:
    """The numbers of the steps' sections in a table cell, "6, 7" (those the report has)."""
    got = [section_number(numbers, STEP_SECTIONS[s][0]) for s in steps]
    return ", ".join(str(n) for n in got if n is not None)


def _num(v) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    v = float(v)
    return f"{v:.0f}" if abs(v) >= 100 else f"{v:.3g}"  # whole newtons and hours, no "9.92e+03"


def _cell(q: Quantity | None):
    """A quantity as a table cell: value, and its interval on a second line."""
    if q is None:
        return "-"
    iv = "" if q.lo is None or q.hi is None or q.lo == q.hi else \
        f"<span class='ci'>[{_num(q.lo)}, {_num(q.hi)}]</span>"
    return _Raw(f"{html_text(_num(q.value))}{iv}")


def _range(q: Quantity | None) -> str:
    """A fit's clearance range as the second line of a cell."""
    return "" if q is None else f"<span class='ci'>{_num(q.lo)} .. {_num(q.hi)} mm</span>"


def _life_cell(q: Quantity | None):
    """A service life: its hours and interval within the design life, else how it reads; the governing mechanism
    under it."""
    if q is None:
        return "-"
    if q.reads is None:  # a life from before the mechanisms
        return _cell(q)
    text = html_text(q.reads)
    return _Raw(text + (f"<span class='ci'>{html_text(q.mechanism)}</span>" if q.mechanism else ""))


def _src(q: Quantity | None, numbers: dict | None) -> str:
    return "" if q is None else section_label(q.source.step, numbers)


def design_answers_html(answers: DesignAnswers, numbers: dict | None = None, at: str = "") -> str:
    """The design answers as the report's opening section: HTML fragments (h2, p, tables of at most
    :data:`MAX_COLUMNS` columns with fixed widths), to go first in the report of every machine.

    Parameters
    ----------
    answers : DesignAnswers
        :func:`berryshaker.report.design.design_answers`.
    numbers : dict, optional
        Each section's number in the report, by renderer (:func:`berryshaker.report.sections.section_numbers`):
        the sections the numbers come from are named by these numbers (None: by their short names).
    at : str
        The operating point every number but the last part's is at, in words ("drive speed 120 r/min (shaking 2 Hz)
        and travel speed 30 m/min"); the last part, the drive speed to run with, compares drive speeds and says so.

    Returns
    -------
    str
        HTML (no document head; the report's CSS styles it).
    """
    a = answers
    parts = [f"<h2>Design answers for {html_text(a.machine)}</h2>"]
    if at:
        parts.append(f"<p class='op'><b>One operating point:</b> every number in this section is at the described "
                     f"{html_text(at)}, except the last part, which compares drive speeds.</p>")
    rec = a.recommended
    if rec:
        parts.append(f"<p>Recommended clearances: <b>{html_text(rec.name)}</b> (L9 code "
                     f"<code>{html_text(str(rec.code))}</code>"
                     + (f", {rec.starts} starts" if rec.starts else "") + ").  Each number below is the "
                     "mean with its 95 % interval under it; the last column names the report section it comes "
                     "from.</p>")
    else:
        parts.append("<p>No recommended clearances: the virtual L9 did not run (see Failed runs).</p>")
    if a.missing:
        parts.append(f"<p class='small'>Steps without results: {html_text(', '.join(a.missing))}.</p>")
    joints = a.joints
    if joints:
        parts.append("<h3>Per joint</h3>")
        rows = []
        for p, j in joints.items():
            fit = "-" if j.fit is None else j.fit
            q = j.fit_clearance
            rng = "" if q is None else f"<span class='ci'>{_num(q.lo)} .. {_num(q.hi)} mm</span>"
            rows.append([p, _cell(j.clearance), _cell(j.design_force),
                         _Raw(html_text(str(fit)) + rng), _life_cell(j.service_interval),
                         _section_numbers(("virtual_l9", "clearance_life") if j.fit else ("virtual_l9",),
                                          numbers)])
        parts.append(_table(["joint", "clearance, worn level (mm)", "static-equivalent collision force (N)",
                             "fit (new machine), clearance (mm)", "service life (h)", "section"], rows, left=(0, 3),
                            widths=(13, 15, 20, 22, 18, 12)))
        drawn = [[p, _Raw(html_text(j.drawing_fit) + _range(j.drawing_fit_clearance)),
                  _life_cell(j.drawing_service_interval)]
                 for p, j in joints.items() if j.drawing_fit]
        if drawn:
            parts.append(_table(["joint", "fit on the drawing (new machine), clearance (mm)", "service life (h)"],
                                drawn, left=(0, 1, 2), widths=(13, 40, 47)))
        mechs = {j.service_interval.mechanism: j.service_interval.interval.split("interval: ", 1)[-1]
                 for j in joints.values() if j.service_interval is not None and j.service_interval.mechanism}
        parts.append("<p class='small'>Clearance, worn level: the L9's recommended level (a worn state the virtual "
                     "test runs at); static-equivalent force: the p95 of the impact peaks of each start's "
                     "drive-pasts (coupled with the bush), mean over the recommended set's starts; fit (new "
                     "machine) and service life: the clearance-life step (the governing mechanism's hours from the "
                     "fit's mean clearance, on its surrogate; never a number beyond the machine's design life).  "
                     "Governing mechanisms and their dominant uncertainty: "
                     + html_text("; ".join(f"{m}: {u}" for m, u in mechs.items()) or "not available") + ".</p>")
    loads = a.loads.quantities() + a.harvest.quantities()
    if loads:
        parts.append("<h3>At the recommended set</h3>")
        parts.append(_table(["quantity", "unit", "mean [95 % interval]", "SD", "tag", "section"],
                            [[q.label, q.unit, _cell(q), _num(q.sd), q.tag, _src(q, numbers)]
                             for q in loads],
                            left=(0, 1, 4, 5), widths=(28, 10, 20, 10, 15, 17)))
    diffs = a.differences
    if diffs:
        parts.append("<h3>What differs beyond the noise, and what does not</h3>")
        factors = list(dict.fromkeys(d.factor for d in diffs))[:MAX_COLUMNS - 1]
        by = {(d.response, d.factor): d for d in diffs}
        rows = []
        for n in dict.fromkeys(d.response for d in diffs):
            unit = next(d.difference.unit for d in diffs if d.response == n)
            cells = []
            for f in factors:
                d = by.get((n, f))
                if d is None:
                    cells.append("-")
                    continue
                q = d.difference
                verdict = "<b>differs</b>" if d.beyond_noise else "no difference"
                cells.append(_Raw(html_text(("+" if q.value >= 0 else "") + _num(q.value)) + f"<span class='ci'>[{_num(q.lo)}, "
                                  f"{_num(q.hi)}] {verdict}</span>"))
            rows.append([f"{n} ({unit})" if unit else n, *cells])
        levels = diffs[0].levels
        header = ["response", *[f"{f}{levels[1]} - {f}{levels[0]}" for f in factors]]
        widths = (100 - 18 * len(factors), *[18] * len(factors))
        # the harvest indexes shown, the machine loads (collision forces, drive torque) folded
        loads = [r for r in rows if r[0].startswith(("peak_force", "drive_torque"))]
        parts.append(_table(header, [r for r in rows if r not in loads], left=(0,), widths=widths))
        if loads:
            parts.append(_details("The same for the machine loads: peak collision forces, drive torque",
                                  [_table(header, loads, left=(0,), widths=widths)]))
        parts.append("<p class='small'>Paired difference of each factor's last and first level over the L9's starts "
                     f"({_section_ref('virtual_l9', numbers)}) with its 95 % interval: 'no difference' where the "
                     "paired t test cannot tell the "
                     "levels apart (p >= 0.05); such a difference is noise and is not ranked.</p>")
    to = a.tradeoff
    if to.candidates:
        parts.append(f"<p class='small'>Trade-off table ({_section_ref('virtual_l9', numbers)}): "
                     f"{to.candidates} candidates, "
                     f"{to.dominated} dominated beyond the noise.  {html_text(to.statement or '')}</p>")
    why = a.why_efficiency
    if why:
        parts.append("<h3>Why this efficiency</h3>")
        parts.append(f"<p>{html_text(why.statement)}</p>")
        cmp_ = a.comparison
        if cmp_:
            parts.append(f"<p>{html_text(cmp_.statement)}</p>")
    op = a.operating_point
    if op:
        parts.append("<h3>Another operating point: the drive speed to run with</h3>")
        parts.append("<p class='small'>The numbers above are at the described operating point; these compare the "
                     f"harvest-response step's drive speeds ({_section_ref('harvest_response', numbers)}).</p>")
        parts.append(f"<p>{html_text(op.statement)}</p>")
        if op.speed:
            items = [("drive speed", op.speed), ("shaking frequency", op.frequency),
                     *[(k.replace("_", " "), getattr(op, k)) for k in ("finger_amplitude", "comb_swing",
                                                                       "ripe_removal", "unripe_shed", "damage",
                                                                       "efficiency") if getattr(op, k) is not None]]
            parts.append(_table(["quantity", "unit", "mean [95 % interval]", "SD", "section"],
                                [[n, q.unit, _cell(q), _num(q.sd), _src(q, numbers)] for n, q in items],
                                left=(0, 1, 4), widths=(30, 12, 22, 14, 22)))
        parts.append(f"<p class='small'>Rule: {html_text(op.rule)}; limits: damage "
                     f"{op.limits.damage_pct:g} %, unripe shedding {op.limits.unripe_shed_pct:g} % "
                     f"{op.limits.tag}.</p>")
    return "\n".join(parts)

