"""The figure cache (berryshaker.report.plots.figure_cache): a figure drawn before by the same call is copied, the
bytes a fresh draw writes; another call, other code or a damaged, linked or foreign entry is drawn anew; the study's
StudyContext.draw goes through it."""

import os
from unittest.mock import patch

import numpy as np

from berryshaker.config import reference_machine
from berryshaker.report import plots as P
from berryshaker.report.plots import figure_cache as fc
from berryshaker.study.step_context import StudyContext

SERIES = {"a": np.array([1.0, 2.0, 3.0]), "b": np.array([2.0, 1.0, 0.5])}
LABELS = ["x", "y", "z"]


def _draw(cache, figs, title="force [N]"):
    figs.mkdir(exist_ok=True)
    fc.draw_cached(cache, P.plot_bars, (SERIES, LABELS, title, figs / "bars.png"), {}, figs)
    return {p.name: p.read_bytes() for p in sorted(figs.iterdir())}


def _counting():
    calls = []
    real = P.plot_bars

    def counted(*a, **k):
        calls.append(1)
        return real(*a, **k)
    counted.__module__, counted.__qualname__ = real.__module__, real.__qualname__
    return counted, calls


def test_a_kept_figure_is_the_bytes_of_a_fresh_draw_and_is_not_drawn_again(tmp_path):
    fresh = _draw(None, tmp_path / "fresh")
    assert set(fresh) == {"bars.png", "bars.svg"}
    assert _draw(None, tmp_path / "fresh2") == fresh  # deterministic: no date, fixed SVG ids
    cache = tmp_path / "cache"
    assert _draw(cache, tmp_path / "s1") == fresh  # drawn and kept
    fn, calls = _counting()
    figs = tmp_path / "s2"
    figs.mkdir()
    args = (SERIES, LABELS, "force [N]", figs / "bars.png")
    assert fc.restore_figure(cache, fc.figure_key(fn, args, {}, figs), figs)  # its paths are relative in the key
    assert calls == [] and {p.name: p.read_bytes() for p in figs.iterdir()} == fresh
    fc.draw_cached(cache, fn, (SERIES, LABELS, "moment [N m]", figs / "m.png"), {}, figs)
    assert calls == [1]  # another call: drawn


def test_other_code_or_a_damaged_linked_entry_is_drawn_again(tmp_path):
    cache = tmp_path / "cache"
    fresh = _draw(cache, tmp_path / "s1")
    key = fc.figure_key(P.plot_bars, (SERIES, LABELS, "force [N]", tmp_path / "s1" / "bars.png"), {}, tmp_path / "s1")
    entry = fc.figure_entry_path(cache, key)
    with patch("berryshaker.outputs.code_fingerprint", lambda: "other code"):
        assert fc.figure_key(P.plot_bars, (SERIES, LABELS, "force [N]", tmp_path / "s1" / "bars.png"), {},
                             tmp_path / "s1") != key
    data = entry.read_bytes()
    entry.write_bytes(data[:-10])  # truncated
    assert fc.read_figure_entry(cache, key) is None
    assert _draw(cache, tmp_path / "s2") == fresh  # drawn and kept again
    assert fc.read_figure_entry(cache, key) is not None
    elsewhere = tmp_path / "elsewhere.fig"
    elsewhere.write_bytes(data)
    entry.unlink()
    os.symlink(elsewhere, entry)
    assert fc.read_figure_entry(cache, key) is None  # never through a symlink
    with patch("berryshaker.runs.cache._foreign", lambda st: "owned by another user"):
        entry.unlink()
        entry.write_bytes(data)
        assert fc.read_figure_entry(cache, key) is None


def test_a_figure_writing_outside_its_folder_or_unpicklable_is_not_kept(tmp_path):
    cache = tmp_path / "cache"
    figs = tmp_path / "figs"
    figs.mkdir()
    fc.draw_cached(cache, P.plot_bars, (SERIES, LABELS, "force [N]", tmp_path / "out.png"), {}, figs)
    assert (tmp_path / "out.png").is_file() and not cache.exists()
    import threading

    assert fc.figure_key(P.plot_bars, (threading.Lock(),), {}, figs) is None  # does not pickle
    assert fc.figure_key(P.plot_bars, (lambda: 0,), {}, figs) is None  # a lambda is not named by its name
    assert fc.figure_key(P.plot_bars, (np.sum,), {}, figs) is not None


class _Runner:
    """A runner with a cache and no pool (figures drawn in the study's process)."""

    def __init__(self, cache_dir):
        self.cache_dir, self.use_cache = cache_dir, True

    def warm_up(self, fn, kwargs):
        return None


def test_the_study_context_draws_through_the_cache(tmp_path):
    ctx = StudyContext(reference_machine(), _Runner(tmp_path / "runs"), tmp_path / "f1")
    ctx.figs.mkdir()
    ctx.draw(P.plot_bars, SERIES, LABELS, "force [N]", ctx.figs / "bars.png")
    assert ctx.figure_cache == tmp_path / "runs" / "figures" and any(ctx.figure_cache.rglob("*.fig"))
    fn, calls = _counting()
    again = StudyContext(reference_machine(), _Runner(tmp_path / "runs"), tmp_path / "f2")
    again.figs.mkdir()
    again.draw(fn, SERIES, LABELS, "force [N]", again.figs / "bars.png")
    assert calls == [] and (again.figs / "bars.png").read_bytes() == (ctx.figs / "bars.png").read_bytes()
    assert StudyContext(reference_machine(), object(), tmp_path).figure_cache is None


def test_the_key_reads_what_the_arguments_hold_not_how_they_share_objects(tmp_path):
    """The same numbers read from the run cache (JSON: a key met twice is one string) and returned by a worker
    (pickled: each its own) pickle to other bytes; the key is the same."""
    import pickle

    word = "force [N]"
    shared = {"a": [word, word], "b": np.arange(3.0)}
    apart = {"a": ["force [N]", "".join(["force", " [N]"])], "b": np.arange(3.0)}
    assert pickle.dumps(shared) != pickle.dumps(apart)
    key = fc.figure_key(P.plot_bars, (shared, tmp_path / "x.png"), {"title": "t"}, tmp_path)
    assert key == fc.figure_key(P.plot_bars, (apart, tmp_path / "x.png"), {"title": "t"}, tmp_path)
    assert key != fc.figure_key(P.plot_bars, (shared, tmp_path / "y.png"), {"title": "t"}, tmp_path)
    assert key != fc.figure_key(P.plot_bars, (shared, tmp_path / "x.png"), {"title": "u"}, tmp_path)
    assert key != fc.figure_key(P.plot_bars, ({"a": [word, 1], "b": np.arange(3.0)}, tmp_path / "x.png"),
                                {"title": "t"}, tmp_path)
