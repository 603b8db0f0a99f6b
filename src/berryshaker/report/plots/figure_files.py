"""What every figure function shares (figure files): the extremes of a drawn series and the one way a figure is saved (PNG at print
resolution and SVG beside it, the canvas grown until no label or legend is cut, :func:`berryshaker.report.style.finish`).
"""

from __future__ import annotations

import contextlib
import contextvars
from pathlib import Path

import numpy as np

from berryshaker.report.style import PRINT_DPI, finish


def _extremes(y: np.ndarray) -> dict:
    y = np.asarray(y, float)
    return {"max": float(np.max(y)), "min": float(np.min(y)), "peak_abs": float(np.max(np.abs(y)))}


#: (dpi, svg) of the figures saved now: print resolution with an SVG beside, unless :func:`figure_output` says
_OUTPUT: contextvars.ContextVar = contextvars.ContextVar("figure_output", default=(PRINT_DPI, True))


@contextlib.contextmanager
def figure_output(dpi: int = PRINT_DPI, svg: bool = True):
    """Save the figures drawn inside the block at ``dpi`` and with or without the SVG beside each (a page that
    embeds its figures needs neither 300 dpi nor the SVGs).

    Parameters
    ----------
    dpi : int
        Resolution [1/in] (dots per inch).
    svg : bool
        Write the SVG beside each PNG.

    Yields
    ------
    None
        Inside the block figures are saved so.
    """
    token = _OUTPUT.set((int(dpi), bool(svg)))
    try:
        yield
    finally:
        _OUTPUT.reset(token)


def _out(fig, path, data: dict, return_figure: bool, dpi: int | None = None) -> dict:
    """Save ``fig`` (:func:`berryshaker.report.style.finish`), record its path (and the SVG's), return ``data``."""
    data["path"] = str(path)
    default_dpi, svg = _OUTPUT.get()
    kept = finish(fig, path, dpi=dpi or default_dpi, keep=return_figure, svg=svg)
    data["svg"] = str(Path(path).with_suffix(".svg")) if svg else None
    if kept is not None:
        data["figure"] = kept
    return data
