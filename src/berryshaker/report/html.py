"""Self-contained HTML report of the study: every figure embedded (base64 PNG), numbers in tables, the
resolved configuration and package version at the end.  Opens offline; no scripts.  The page opens with the design
answers at the described operating point (:mod:`berryshaker.report.design_html`), then the study steps' numbered
sections (each its answer with the rest folded; :mod:`berryshaker.report.sections`, the renderers in the
steps' modules, ``berryshaker.study.steps``), then an appendix (the claims,
the configuration); the page of ``doe analyze`` is :mod:`berryshaker.report.doe_page`'s.  Tables, figures and the CSS are
:mod:`berryshaker.report.html_blocks`'.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Sequence

from berryshaker.config import machine_table
from berryshaker.reference_study import CHOSEN_CODE, CHOSEN_LEVELS, CLEARANCE_LEVELS_MM, FIELD_RESULT
from berryshaker.report.design import claims_apply, design_answers, level_set_name
from berryshaker.report.design_html import design_answers_html
from berryshaker.report.headline import report_title, runs_text, verdict_class, verdict_counts
from berryshaker.report.html_blocks import CSS, _plain, _Raw, _table
from berryshaker.report.sections import SectionInput, section_numbers, step_sections
from berryshaker.user_text import html_text


def study_report(res, summary, machine, figs: Path, steps: dict | None = None, *,
                 sections: Sequence[tuple[str, Sequence[Callable]]]) -> str:
    """The self-contained HTML report of a study: design answers, failures, recommendation, then the steps'
    sections in the pipeline's order, numbered as they come (a step that did not run says why), the claims
    appendix and the configuration with provenance tags.

    Parameters
    ----------
    res : StudyResults
        The steps' results (``berryshaker.study.step_result.StudyResults``; SI inside, the report prints units at
        the edges).
    summary : StudySummary
        The head of summary.json (``berryshaker.study.step_result.StudySummary``: version, timings, runs, failures,
        optimum; read by attribute).
    machine : Machine
        The machine description.
    figs : Path
        Folder of the figures (PNG, embedded).
    steps : dict name -> StepResult, optional
        The steps, for their notes.
    sections : sequence of (str, sequence of callable)
        Per study step in the pipeline's order: its name and the renderers of its report sections
        (``berryshaker.study.pipeline.report_sections()``: each step's ``STEP.sections``).

    Returns
    -------
    str
        The HTML document.
    """
    PAIR_NAMES = machine.pair_names
    steps = steps or {}
    inp = SectionInput(res, machine, figs, section_numbers(sections))
    reference = claims_apply(machine)  # the study's pairs: its claims can be checked (study/claims.py's rule)
    title = report_title(res.claims) if reference else f"Design study of {machine.machine.name}"
    parts = [f"<!doctype html><html lang='en'><head><meta charset='utf-8'><title>berryshaker study - "
             f"{html_text(machine.machine.name)}</title><style>{CSS}</style></head><body>",
             f"<h1>{html_text(title)}</h1>",
             f"<p>Machine: <b>{html_text(machine.machine.name)}</b>. berryshaker {html_text(summary.version)}. "
             f"Total time {summary.timings_s['total']:.1f} s; {html_text(runs_text(summary.runs))}.  "
             + (f"{html_text(verdict_counts(res.claims))} (appendix).  " if reference else "")
             + "Values marked [assumed] in the configuration are ours, not the study's (its tables were lost): see "
             "the end of this report.</p>"]
    # the design answers first, for every machine (report/design.py), at the described operating point
    try:
        parts.append(design_answers_html(design_answers({**summary.to_json(), "results": res.to_json()}, machine),
                                         inp.numbers, at=operating_point_text(machine)))
    except Exception as exc:  # noqa: BLE001 - the report's other sections stand without its summary
        parts.append(f"<p class='small'>Design answers not available: {html_text(f'{type(exc).__name__}: {exc}')}"
                     "</p>")
    fails = summary.failures
    parts.append("<h2>Failed runs</h2>")
    if fails:
        parts.append("<p>These runs failed; the steps that needed them are marked 'not comparable' or left out.</p>")
        parts.append(_table(["step", "run", "inputs", "error"], [[f.step, f.run, f.inputs, f.error] for f in fails], left=(0, 2, 3)))
    else:
        parts.append("<p>None: every run of the study completed.</p>")
    opt = summary.optimum
    parts.append("<h2>Recommended clearances</h2>")
    if opt is None:
        parts.append("<p>Not available: the virtual L9 test failed (see Failed runs).</p>")
    else:
        fitted = set(opt.fitted)
        iv = opt.intervals or {}

        def cell(name, value):
            est = iv.get(name)
            text = f"{value:.3g}" if est is None else (f"{est.mean:.3g} [{est.ci[0]:.3g}, {est.ci[1]:.3g}], "
                                                      f"SD {est.sd:.2g}")
            return text + (" (fitted)" if name in fitted else "")

        parts.append(_table(["", *[f"{p} (mm)" for p in PAIR_NAMES], "efficiency (kg/min)", "unripe (%)",
                             "damage (%)"], [
            [f"ours ({level_set_name(opt.clearance_mm)}; {opt.code})", *[opt.clearance_mm[p] for p in PAIR_NAMES],
             cell("efficiency", opt.efficiency_kg_min), cell("unripe", opt.unripe_rate_pct),
             cell("damage", opt.damage_rate_pct)],
            *([[f"study ({CHOSEN_CODE})", *[CLEARANCE_LEVELS_MM[p][CHOSEN_LEVELS[p] - 1] for p in PAIR_NAMES],
                FIELD_RESULT["efficiency_kg_min"], FIELD_RESULT["unripe_rate_pct"], FIELD_RESULT["damage_rate_pct"]]]
              if tuple(PAIR_NAMES) == tuple(CHOSEN_LEVELS) else [])]))
        if opt.statement:  # the statement itself stands under the L9's recommendation (its basis), once
            parts.append("<p class='small'>Why these clearances: "
                         f"{inp.ref('virtual_l9_section', 'the virtual L9 section')}, its recommendation and basis.  "
                         f"Index values: mean [95 % interval] over "
                         f"{opt.starts or 'the'} perturbed starts, and the SD of one start"
                         + ("; <b>fitted</b>: the harvest model's calibrated parameters were fitted to the study's "
                            "value of that index at these clearances, so it reproduces the target by construction "
                            "and is not evidence" if fitted else "")
                         + " (the same section gives the trade-off table).</p>")
    # the steps' sections, numbered in the step table's order (report/sections.py)
    parts.extend(step_sections(sections, inp, {n: st.note for n, st in steps.items()}))
    # the appendix: what an engineer looks up, not reads (the tests measure the report's height up to here)
    parts.append("<div id='appendix' class='appendix'></div>")
    if reference:  # the reference study's claims: an appendix, on its machine only
        _claims_section(parts, res)
    parts.append("<h2>Configuration and provenance</h2>")
    parts.append(f"<p>berryshaker {html_text(summary.version)}; timings (s): "
                 + ", ".join(f"{k_} {v:.1f}" for k_, v in summary.timings_s.items()) + "</p>")
    parts.append("<p class='small'>Provenance: [study] from the reference study's text, [published] from another "
                 "publication (docs/published_record.md), [assumed] our default where no source gives it, "
                 "[calibrated] fitted to a measured value (docs/plant.md, docs/harvest.md), [default] not set in the "
                 "file (the description's default).</p>")
    parts.append(_table(["key", "value", "source"], [[k_, v_, f"[{t_}]"] for k_, v_, t_ in machine_table(machine)],
                        left=(0, 1, 2)))
    parts.append("</body></html>")
    return "\n".join(parts)


def operating_point_text(machine) -> str:
    """The described operating point in words: drive speed, shaking frequency (one comb cycle per revolution) and
    travel speed.

    Parameters
    ----------
    machine : Machine
        The machine description (SI: rad/s, m/s).

    Returns
    -------
    str
        E.g. "drive speed 120 r/min (shaking 2 Hz) and travel speed 30 m/min".
    """
    import math

    rpm = machine.drive_speed * 60.0 / (2 * math.pi)
    return (f"drive speed {rpm:.4g} r/min (shaking {rpm / 60.0:.3g} Hz) and travel speed "
            f"{machine.operation.walking_speed * 60.0:.3g} m/min")


def _claims_section(parts: list, res) -> None:
    """Appendix: the reference study's claims with their verdicts (shown for the study's machine only)."""
    parts.append("<h2>Appendix: claims of the reference study and what our models give</h2>")
    with_criterion = any(c.criterion for c in res.claims)
    rows = [[c.id, c.claim, _Raw(f'<span class="{verdict_class(c.verdict)}">{html_text(c.verdict)}</span>'),
             *([_plain(c.criterion)] if with_criterion else []), _plain(c.detail)]
            for c in res.claims]
    parts.append(_table(["#", "claim (docs/study.md)", "verdict", *(["criterion"] if with_criterion else []),
                         "our numbers"], rows, left=(1, 2, 3, 4),
                        widths=(4, 22, 11, 27, 36) if with_criterion else (4, 32, 12, 52)))
