"""The study report's numbered sections, the generic part: what every section renderer reads
(:class:`SectionInput`), how the sections are numbered (:func:`section_numbers`, :func:`section_number`) and
rendered under their headings (:func:`step_sections`).  The renderers themselves are held by the study steps that
make them, one module per step (``berryshaker.study.steps``, each step's ``STEP.sections``); the report
(:func:`berryshaker.report.html.study_report`) renders the steps' sections in the step table's order and numbers
them as it goes; no heading carries a typed number, and a section names another by its renderer's name
(:meth:`SectionInput.ref`), so no step module imports another's.

A renderer takes a :class:`SectionInput` and returns the section's title (without its number) and its HTML parts;
the note of its step (e.g. why it did not run) is shown under the heading of the step's first section.  A section
that also reads another step's results names its owning step in its docstring.

Each section shows its answer (the table an engineer reads, at most a figure or two); the rest (further figures, the
tables behind them, the analyses as text) is folded under a one-line ``<details>`` summary (printed open), so the
report's body stays about 15 screens long before its appendix.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

from berryshaker.report.html_blocks import _details, _maybe_img, _num, _Raw, _table
from berryshaker.user_text import html_text

#: the HTML blocks the steps' section renderers are built of (:mod:`berryshaker.report.html_blocks`): a block
#: folded under a one-line summary (``details(summary, parts)``), a figure embedded where its file exists
#: (``maybe_img(parts, path, caption)``), a number as the report prints it (``num(v)``), HTML a table cell keeps as
#: it is (``Raw``) and a table (``table(header, rows, left=(0,), widths=None)``)
details, maybe_img, num, Raw, table = _details, _maybe_img, _num, _Raw, _table

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
        Each section's number in this report, by renderer (:func:`section_numbers`; look one up with
        :func:`section_number`).
    """

    res: Any
    machine: Any
    figs: Path
    numbers: dict = field(default_factory=dict)

    @property
    def pairs(self) -> tuple:
        """The machine's clearance pairs, in order."""
        return tuple(self.machine.pair_names)

    def ref(self, renderer: Renderer | str, absent: str) -> str:
        """How a section names another: "section N", or ``absent`` when that section is not in the report.

        Parameters
        ----------
        renderer : callable or str
            The other section's renderer, or its name (e.g. ``"harvest_response_section"``: a step's section names
            another step's by name, without importing its module).
        absent : str
            The words used when it is not in this report.

        Returns
        -------
        str
            "section N" or ``absent``.
        """
        n = section_number(self.numbers, renderer)
        return absent if n is None else f"section {n}"


def section_number(numbers: dict | None, renderer: Renderer | str | None) -> int | None:
    """A section's number in a report, found by its renderer or by the renderer's name.

    Parameters
    ----------
    numbers : dict or None
        Section number by renderer (:func:`section_numbers`).
    renderer : callable, str or None
        The section's renderer, or its ``__name__``.

    Returns
    -------
    int or None
        Its number; None when it is not in the report (or ``renderer`` is None).
    """
    if renderer is None or not numbers:
        return None
    if not isinstance(renderer, str):
        return numbers.get(renderer)
    return next((n for r, n in numbers.items() if getattr(r, "__name__", r) == renderer), None)


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
