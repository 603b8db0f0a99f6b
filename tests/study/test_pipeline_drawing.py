"""StudyContext.draw: the study's figures are drawn in idle pool workers and waited for before the report; the
call is taken as it was when drawn; a figure whose worker died is drawn again in the study's process, and a real
error of a figure function stops the study (raised once, not drawn again)."""

import os

import pytest
import runner_jobs as J

from berryshaker.config import reference_machine
from berryshaker.runs.runner import SweepRunner
from berryshaker.study.pipeline import StudyContext


def _ctx(runner, tmp_path):
    return StudyContext(reference_machine(), runner, tmp_path)


def test_figures_are_drawn_in_a_worker_and_waited_for(tmp_path):
    with SweepRunner(workers=2, use_cache=False, progress=False) as runner:
        ctx = _ctx(runner, tmp_path)
        data = {"rows": [1, 2, 3]}
        ctx.draw(J.write_marker, str(tmp_path / "a.txt"), "first")
        ctx.draw(J.write_marker, str(tmp_path / "b.txt"), text=data)
        data["rows"].append(4)  # the call was taken as it was when drawn
        ctx.finish_drawing()
        a, b = (tmp_path / "a.txt").read_text().split(), (tmp_path / "b.txt").read_text()
    assert a[0] == "first" and int(a[1]) != os.getpid()  # drawn in a worker
    assert b.startswith("{'rows': [1, 2, 3]}")
    assert ctx.drawing == []


def test_a_figure_whose_worker_died_is_drawn_here(tmp_path):
    said = []
    with SweepRunner(workers=2, use_cache=False, progress=False) as runner:
        ctx = StudyContext(reference_machine(), runner, tmp_path, say=said.append)
        ctx.draw(J.write_marker, str(tmp_path / "c.txt"), "again", die_outside=os.getpid())
        ctx.finish_drawing()
    assert (tmp_path / "c.txt").read_text() == f"again {os.getpid()}"  # drawn again in this process
    assert said and "drawing it here" in said[0]


def test_a_real_error_of_a_figure_is_raised_once(tmp_path):
    said = []
    with SweepRunner(workers=2, use_cache=False, progress=False) as runner:
        ctx = StudyContext(reference_machine(), runner, tmp_path, say=said.append)
        ctx.draw(J.write_marker, str(tmp_path / "d.txt"), "bad")  # raises in the worker
        with pytest.raises(ValueError, match="real error"):
            ctx.finish_drawing()
    assert said == []  # raised as the worker raised it, not drawn again here


def test_without_a_pool_figures_are_drawn_at_once(tmp_path):
    with SweepRunner(workers=1, use_cache=False, progress=False) as runner:
        ctx = _ctx(runner, tmp_path)
        ctx.draw(J.write_marker, str(tmp_path / "e.txt"), "here")
        assert (tmp_path / "e.txt").read_text() == f"here {os.getpid()}" and ctx.drawing == []
