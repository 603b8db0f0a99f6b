"""The gallery of worked examples (examples/gallery/plot_*.py) runs as written (scikit-fem's way).

Each script runs in a temporary working folder (they write their files there) with matplotlib's non-interactive
backend, once per suite: the documentation build does not execute them (docs/conf.py, ``plot_gallery``).
They are kept to seconds each (the reduced model, small sweeps, one multibody run).
"""

from __future__ import annotations

import runpy
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

GALLERY = Path(__file__).resolve().parents[1] / "examples" / "gallery"
SCRIPTS = sorted(GALLERY.glob("plot_*.py"))


def test_gallery_is_not_empty():
    """The gallery has its four examples (own machine, clearance sweep, field test, joint life) at least."""
    assert len(SCRIPTS) >= 4, [s.name for s in SCRIPTS]


@pytest.mark.parametrize("script", SCRIPTS, ids=[s.stem for s in SCRIPTS])
def test_example_runs(script, tmp_path, monkeypatch):
    """The script runs to its end and draws at least one figure."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(plt, "show", lambda *a, **k: None)  # Agg cannot show; sphinx-gallery collects figures
    plt.close("all")
    try:
        runpy.run_path(str(script), run_name="__main__")
        assert plt.get_fignums(), f"{script.name} drew no figure"
    finally:
        plt.close("all")
