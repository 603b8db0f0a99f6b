"""What every figure function shares (figure files): the extremes of a drawn series and the one way a figure is saved (PNG at print
resolution and SVG beside it, the canvas grown until no label or legend is cut, :func:`berryshaker.report.style.finish`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from berryshaker.report.style import PRINT_DPI, finish


def _extremes(y: np.ndarray) -> dict:
    y = np.asarray(y, float)
    return {"max": float(np.max(y)), "min": float(np.min(y)), "peak_abs": float(np.max(np.abs(y)))}


def _out(fig, path, data: dict, return_figure: bool, dpi: int = PRINT_DPI) -> dict:
    """Save ``fig`` (:func:`berryshaker.report.style.finish`), record its path (and the SVG's), return ``data``."""
    data["path"] = str(path)
    kept = finish(fig, path, dpi=dpi, keep=return_figure)
    data["svg"] = str(Path(path).with_suffix(".svg"))
    if kept is not None:
        data["figure"] = kept
    return data
