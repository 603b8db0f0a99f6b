"""A report section is added the way a user adds one (docs/architecture.md, "Where a new thing goes"): one step
module (written here in a temporary folder, as a user's own file) and one line in the step table
(``berryshaker.study.steps.STEPS``).  No field of StudyResults is needed: the step's data is kept by its result
name.  The report is rendered from the stored results of a reference study (tests/data/*.json) without running it."""

from __future__ import annotations

import importlib.util
import json
import re
import sys
import textwrap
from pathlib import Path

import pytest
from l9_records_data import l9_record

from berryshaker.report.html import study_report
from berryshaker.study import steps as study_steps
from berryshaker.study.pipeline import planned_runs, report_sections, run_steps
from berryshaker.study.step_context import StudyContext
from berryshaker.study.step_result import StepResult, StudyResults, StudySummary
from berryshaker.study.steps import clearance_life

DATA = Path(__file__).parents[1] / "data"

#: the user's step module: its record, its run, its report section and its STEP, in one file
LEAF_STEP = '''
"""Study step ``leaf_count``: the leaves the combs pass (a test's step)."""

from __future__ import annotations

from dataclasses import dataclass

from berryshaker.records import JsonRecord
from berryshaker.report.sections import SectionInput
from berryshaker.study.step_result import Step, StepResult


@dataclass(frozen=True)
class LeafCount(JsonRecord):
    """The leaves counted.

    Attributes
    ----------
    leaves : int
        Leaves passed per comb cycle.
    """

    leaves: int


def run(ctx) -> StepResult:
    """Count the leaves."""
    return StepResult("leaf_count", LeafCount(leaves=42), note="counted by hand")


def leaf_count_section(inp: SectionInput) -> tuple[str, list[str]]:
    """The leaves, beside the virtual L9 it names by its section."""
    data = inp.res.step_data("leaf_count")
    leaves = data["leaves"] if isinstance(data, dict) else data.leaves  # read back from JSON: its JSON form
    return "Leaves passed by the combs", [f"<p>{leaves} leaves per cycle; "
                                         f"{inp.ref('virtual_l9_section', 'no L9')} has the L9.</p>"]


STEP = Step(key="leaf_count", run=run, result="leaf_count", sections=(leaf_count_section,))
'''


def _user_module(folder: Path, monkeypatch):
    """The user's step module, written to ``folder`` and imported from its file."""
    path = folder / "leaf_count.py"
    path.write_text(textwrap.dedent(LEAF_STEP), encoding="utf-8")
    spec = importlib.util.spec_from_file_location("leaf_count", path)
    mod = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "leaf_count", mod)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture()
def leaf_step(tmp_path, monkeypatch):
    """The user's module imported from its file, and its one line in the step table (after clearance life)."""
    mod = _user_module(tmp_path, monkeypatch)
    table = list(study_steps.STEPS)
    table.insert(table.index(clearance_life.STEP) + 1, mod.STEP)
    monkeypatch.setattr(study_steps, "STEPS", tuple(table))
    return mod


def _stored_results(extra: dict) -> StudyResults:
    """Every step's data of a reference study run, from the stored fixtures, with ``extra`` steps' data."""
    res = {}
    for name in ("mechanics_steps", "harvest_step_results", "report_sections"):
        res.update(json.loads((DATA / f"{name}.json").read_text(encoding="utf-8")))
    res["l9"] = l9_record(res["l9"])  # the trimmed L9 completed to a VirtualL9 (neutral values elsewhere)
    typed = StudyResults.from_json({k: v for k, v in res.items() if k != "l9"})
    return StudyResults.of_steps({**{k: getattr(typed, k) for k in res if k != "l9"}, "l9": res["l9"], **extra},
                                 failures=[])


def _summary(machine) -> StudySummary:
    return StudySummary(package="berryshaker", version="0.0-test", machine=machine.machine.name,
                        drive=machine.DRIVE, claims=[], optimum=None, failures=[], timings_s={"total": 1.0},
                        runs={"runs": 0, "cached": 0, "computed": 0, "failed": 0, "compute_s": 0.0,
                              "cached_compute_s": 0.0, "cold_compute_s": 0.0, "elapsed_s": 0.0})


def test_a_new_step_module_and_one_line_add_a_numbered_report_section(leaf_step, machine, tmp_path):
    step = leaf_step.STEP.run(None)
    res = _stored_results({step.name: step.data})
    assert res.other == {"leaf_count": step.data} and res.step_data("leaf_count").leaves == 42
    sections = report_sections()
    renderers = [r for _, rs in sections for r in rs]
    page = study_report(res, _summary(machine), machine, tmp_path, {step.name: step}, sections=sections)
    headings = re.findall(r"<h2>(\d+)\. ([^<]*)</h2>", page)
    assert [int(n) for n, _ in headings] == list(range(1, len(renderers) + 1))  # numbered in order, none typed
    k = renderers.index(leaf_step.leaf_count_section) + 1
    assert k == renderers.index(clearance_life.clearance_life_section) + 2  # the line after clearance life
    assert headings[k - 1] == (str(k), "Leaves passed by the combs")
    l9 = renderers.index(study_steps.virtual_l9.virtual_l9_section) + 1
    after = page.split(f"<h2>{k}. Leaves passed by the combs</h2>")[1]
    assert after.startswith("\n<p class='small'><b>Note:</b> counted by hand</p>")  # the step's note
    assert f"42 leaves per cycle; section {l9} has the L9." in after
    # the data goes to summary.json's results under its name and reads back (as its JSON form)
    back = StudyResults.from_json(res.to_json())
    assert back.other == {"leaf_count": {"leaves": 42}} and back.step_data("leaf_count") == {"leaves": 42}
    page_back = study_report(back, _summary(machine), machine, tmp_path, sections=sections)
    assert f"<h2>{k}. Leaves passed by the combs</h2>\n<p>42 leaves" in page_back


def test_the_pipeline_runs_a_new_step_and_its_plan(machine, tmp_path, monkeypatch):
    """run_steps runs the table's steps (here the user's alone), keeps its data under its name and starts the
    runs of its plan (``Step.plan``) ahead."""
    import dataclasses

    from berryshaker.runs.runner import SweepRunner

    mod = _user_module(tmp_path, monkeypatch)
    planned = []
    step = dataclasses.replace(mod.STEP, plan=lambda ctx: planned.append(ctx) or [])
    monkeypatch.setattr(study_steps, "STEPS", (step,))
    runner = SweepRunner(workers=1, cache_dir=tmp_path / "cache", progress=False)
    assert planned_runs(StudyContext(machine, runner, tmp_path)) == [] and len(planned) == 1
    results, steps, failures, timings = run_steps(machine, runner, tmp_path)
    assert results.step_data("leaf_count").leaves == 42 and results.l9 is None and failures == []
    assert isinstance(steps["leaf_count"], StepResult) and set(timings) == {"leaf_count", "total"}
