"""One plotting style for every berryshaker figure, and the checks that hold figures to it.

The rules (issue "A report and a command line an engineer is glad to hand on"):

* every axis and colour bar carries a unit in brackets or parentheses at the end of its label
  (:func:`require_unit`; dimensionless quantities write ``[-]``);
* panels that are compared share their scale; a surface figure has one colour bar per response;
* legends sit outside the data (:func:`legend_outside`);
* each clearance pair and each model keeps its colour and line style across figures
  (:data:`PAIR_COLOURS`, :data:`MODEL_STYLES`);
* long series are thinned by :func:`decimate_minmax`, which keeps each bin's minimum and maximum so the
  drawn peak equals the data peak exactly (plain striding drops impact peaks);
* tick labels never use an offset or a hidden power of ten (:func:`plain_ticks`);
* text is text: mathtext is off (:func:`pyplot`), so a ``$`` in a user's name is never parsed as TeX;
* layout is matplotlib's constrained layout, so outside legends and colour bars are not cut off, and the canvas
  grows where anything still reaches beyond it (:func:`fit_canvas`); PNGs are saved at 300 dpi with an SVG beside.

:func:`audit_figure` checks a drawn figure against these rules; the figure tests use it.

long module: the style's constants and the checks that hold every figure to them (units, legends, canvas fit,
decimation) are one contract; split, each check would import the constants it checks.
"""

from __future__ import annotations

import contextlib
import contextvars
import re
import warnings
from collections.abc import Iterator

import numpy as np

#: Colour per clearance pair (Okabe-Ito colour-blind-safe palette), the same in every figure.
PAIR_COLOURS: dict[str, str] = {"A": "#0072B2", "B": "#E69F00", "C": "#009E73", "F": "#CC79A7"}

#: Line style per model.  The multibody curve is drawn solid, thick and underneath; the MLSD curve
#: dashed, thin and on top, so neither hides the other.  ``color`` None = the pair's colour.
MODEL_STYLES: dict[str, dict] = {
    "multibody": {"color": None, "linestyle": "-", "linewidth": 2.4, "alpha": 0.55, "zorder": 2},
    "mlsd": {"color": "#222222", "linestyle": "--", "linewidth": 1.0, "alpha": 1.0, "zorder": 3},
}

#: Colour per fruit position on the branch.
FRUIT_COLOURS: dict[str, str] = {"root": "#D55E00", "middle": "#0072B2", "end": "#009E73"}

#: Colour per clearance level set: no clearance, then levels 1-3 (light to dark).
LEVEL_COLOURS: dict[str, str] = {"none": "#7F7F7F", "level 1": "#9ECAE1", "level 2": "#4292C6",
                                 "level 3": "#08519C"}

#: Fallback colours for series without a fixed colour (Okabe-Ito order).
SERIES_COLOURS: tuple[str, ...] = ("#0072B2", "#E69F00", "#009E73", "#CC79A7", "#D55E00", "#56B4E9",
                                   "#F0E442", "#000000")

def response_units() -> dict[str, str]:
    """Units of the harvest responses (the one table, berryshaker.harvest.virtual.RESPONSES).

    Returns
    -------
    dict of str to str
        Name -> unit ("kg/min", "%").
    """
    from berryshaker.harvest.virtual.responses import response_units as units

    return units()


def response_names() -> dict[str, str]:
    """Long names of the harvest responses (their labels in the one table).

    Returns
    -------
    dict of str to str
        Name -> label ("picking efficiency", ...).
    """
    from berryshaker.harvest.virtual.responses import response_labels

    return response_labels()

#: Shading of reference bands (study ranges, bond forces, noise bands).
BAND_ALPHA = 0.18

_UNIT_AT_END = re.compile(r"(\[[^\[\]]+\]|\([^()]+\))\s*$")


def has_unit(label: str) -> bool:
    """True if ``label`` ends with a unit in brackets or parentheses, e.g. ``"force [N]"``, ``"s (mm)"``.

    Parameters
    ----------
    label : str
        Axis or colour-bar label.

    Returns
    -------
    bool
        Whether it ends with a unit.
    """
    return bool(_UNIT_AT_END.search(label or ""))


def require_unit(label: str, *, strict: bool = True) -> str:
    """Return ``label`` if it ends with a unit in ``[...]`` or ``(...)``.

    Parameters
    ----------
    label : str
        Axis or colour-bar label.
    strict : bool
        True: raise ``ValueError`` for a label without a unit.  False: warn and return the label with
        ``" [unit?]"`` appended, so the omission is visible on the figure instead of silent.

    Returns
    -------
    str
        The label (with " [unit?]" appended when not strict and it had none).
    """
    if has_unit(label):
        return label
    msg = (f"axis label {label!r} has no unit: end it with the unit in brackets, e.g. 'force [N]', "
           "or '[-]' for a dimensionless quantity")
    if strict:
        raise ValueError(msg)
    warnings.warn(msg, stacklevel=2)
    return f"{label} [unit?]"


def pyplot():
    """matplotlib.pyplot on the Agg backend (no display needed), with mathtext off: a ``$`` in a name from a sheet
    or a description is text, never parsed as TeX (``eff$^$`` was a ParseSyntaxException traceback); the figures'
    own labels write powers as Unicode (``m/s²``).

    Returns
    -------
    module
        matplotlib.pyplot.
    """
    import matplotlib

    matplotlib.use("Agg")
    matplotlib.rcParams["text.parse_math"] = False
    import matplotlib.pyplot as plt

    return plt


def new_figure(nrows: int = 1, ncols: int = 1, *, figsize=(8.0, 4.0), **subplot_kw):
    """A figure with constrained layout (legends outside and colour bars are given room) and its axes.

    ``subplot_kw`` goes to :func:`matplotlib.pyplot.subplots` (``sharex``, ``sharey``, ``squeeze``...).

    Parameters
    ----------
    nrows, ncols : int
        Grid of axes.
    figsize : (float, float)
        Size in inches (1 in = 25.4 mm).
    **subplot_kw
        Passed on to :func:`matplotlib.pyplot.subplots`.

    Returns
    -------
    fig, axes : Figure and Axes or a grid of Axes
        The figure and its axes.
    """
    plt = pyplot()
    fig, axes = plt.subplots(nrows, ncols, figsize=figsize, layout="constrained", **subplot_kw)
    return fig, axes


def plain_ticks(ax) -> None:
    """No offset ("1e-14+2.86") and no hidden power of ten on the numeric axes of ``ax``.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes.
    """
    from matplotlib.ticker import ScalarFormatter

    for axis in (ax.xaxis, ax.yaxis):
        fmt = axis.get_major_formatter()
        if isinstance(fmt, ScalarFormatter):
            fmt.set_useOffset(False)
            fmt.set_scientific(False)


def label_axes(ax, xlabel: str | None = None, ylabel: str | None = None, *, strict: bool = True) -> None:
    """Set axis labels after checking each carries a unit (see :func:`require_unit`); plain ticks.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes.
    xlabel, ylabel : str, optional
        Labels, each ending with its unit.
    strict : bool
        Refuse a label without unit (else flag it, :func:`require_unit`).
    """
    if xlabel is not None:
        ax.set_xlabel(require_unit(xlabel, strict=strict))
    if ylabel is not None:
        ax.set_ylabel(require_unit(ylabel, strict=strict))
    plain_ticks(ax)


def legend_outside(ax, *, where: str = "right", handles=None, labels=None, fontsize: float = 8, **kw):
    """Legend outside the data area of ``ax``: to its right (``where="right"``) or below it ("below").

    With constrained layout the figure makes room for it.  Returns the legend (None if nothing to show).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes.
    where : str
        "right", "below" or "above".
    handles, labels : list, optional
        Legend entries (default the axes').
    fontsize : float
        Font size in points (1/72 in).
    **kw
        Passed on to :meth:`matplotlib.axes.Axes.legend`.

    Returns
    -------
    matplotlib.legend.Legend or None
        The legend.
    """
    if handles is None:
        handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return None
    if where == "right":
        place = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "borderaxespad": 0.0}
    elif where == "below":
        place = {"loc": "upper center", "bbox_to_anchor": (0.5, -0.14), "borderaxespad": 0.0,
                     "ncol": min(4, len(handles))}
    elif where == "above":
        place = {"loc": "lower left", "bbox_to_anchor": (0.0, 1.02), "borderaxespad": 0.0,
                     "ncol": min(4, len(handles))}
    else:
        raise ValueError(f"where={where!r}: use 'right', 'below' or 'above'")
    place.update(kw)
    return ax.legend(handles, labels, fontsize=fontsize, **place)


def colour_bar(fig, mappable, axes, label: str, *, strict: bool = True):
    """One colour bar for ``axes`` (one Axes or a list), labelled with a unit, ticks without offset.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    mappable : ScalarMappable
        What the bar shows.
    axes : Axes or list of Axes
        The axes it serves.
    label : str
        Label with unit.
    strict : bool
        Refuse a label without unit.

    Returns
    -------
    matplotlib.colorbar.Colorbar
        The colour bar.
    """
    from matplotlib.ticker import ScalarFormatter

    cb = fig.colorbar(mappable, ax=axes)
    cb.set_label(require_unit(label, strict=strict))
    fmt = ScalarFormatter(useOffset=False)
    fmt.set_scientific(False)
    cb.formatter = fmt
    cb.update_ticks()
    return cb


def widen_span(lo: float, hi: float, *, rel: float = 1e-3, abs_min: float = 1e-12) -> tuple[float, float]:
    """(lo, hi) widened about its centre so hi - lo is at least ``rel`` x |centre| (and ``abs_min``).

    A nearly constant field otherwise gets a colour bar with ticks like 2.86 + 1e-14.

    Parameters
    ----------
    lo, hi : float
        The span (any unit).
    rel : float
        Least width relative to |centre| (1).
    abs_min : float
        Least width (same units as lo and hi).

    Returns
    -------
    (float, float)
        The widened span (same units as lo and hi).
    """
    lo, hi = float(lo), float(hi)
    need = max(rel * abs(0.5 * (lo + hi)), abs_min)
    if hi - lo < need:
        c = 0.5 * (lo + hi)
        lo, hi = c - need / 2, c + need / 2
    return lo, hi


def _bin_extrema(y2: np.ndarray, n: int, n_bins: int) -> np.ndarray:
    """Sorted unique indices of each bin's minimum and maximum (bins of consecutive samples)."""
    size = -(-n // n_bins)  # ceil
    nb = -(-n // size)
    pad = nb * size - n
    if y2.ndim == 1:
        y2 = y2[None, :]
    idx = []
    base = np.arange(nb) * size
    for y in y2:
        yp = np.concatenate([y, np.full(pad, y[-1])]) if pad else y
        blocks = yp.reshape(nb, size)
        idx.append(np.minimum(base + np.argmin(blocks, axis=1), n - 1))
        idx.append(np.minimum(base + np.argmax(blocks, axis=1), n - 1))
    return np.unique(np.concatenate(idx + [np.array([0, n - 1])]))


def decimate_minmax(x, y, n_bins: int = 2000) -> tuple[np.ndarray, np.ndarray]:
    """Thin a series for plotting while keeping every extreme: per bin of consecutive samples the
    minimum and the maximum (in time order), plus the first and last sample.

    Parameters
    ----------
    x, y : array_like (n,)
        Abscissa (e.g. time [s]) and values.  NaN values are not supported.
    n_bins : int
        Number of bins; the result has at most 2 n_bins + 2 points.  A series shorter than that is
        returned whole (as copies).

    Returns
    -------
    x_d, y_d : ndarray
        The kept samples (same units as x and y), exactly as in the input (no averaging), so ``max(y_d) == max(y)`` and
        ``min(y_d) == min(y)``: a plotted peak equals the data peak.

    Notes
    -----
    This is the min-max (envelope) decimation used by oscilloscopes and plotting libraries for
    long records; taking every k-th sample instead can miss a short impact peak entirely.
    """
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    if x.shape != y.shape or x.ndim != 1:
        raise ValueError(f"x and y must be 1-D and of equal length, got {x.shape} and {y.shape}")
    if n_bins < 1:
        raise ValueError(f"n_bins must be at least 1, got {n_bins}")
    n = len(y)
    if n <= 2 * n_bins + 2:
        return x.copy(), y.copy()
    idx = _bin_extrema(y, n, n_bins)
    return x[idx], y[idx]


def decimate_minmax_shared(x, series: dict, n_bins: int = 2000) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """:func:`decimate_minmax` for several series on one abscissa: keeps the union of every series'
    bin extrema, so all series stay on a common (thinned) ``x`` and every series keeps its peaks.

    Returns ``(x_d, {name: y_d})``; at most (4 n_bins + 2) points for two series, and so on.

    Parameters
    ----------
    x : array_like (n,)
        Abscissa (its units, e.g. time [s]).
    series : dict name -> array_like (n,)
        Values (their units).
    n_bins : int
        Number of bins.

    Returns
    -------
    (ndarray, dict name -> ndarray)
        The kept abscissa and series (same units as the input).
    """
    x = np.asarray(x, float)
    ys = {k: np.asarray(v, float) for k, v in series.items()}
    for k, v in ys.items():
        if v.shape != x.shape:
            raise ValueError(f"series {k!r} has shape {v.shape}, the abscissa {x.shape}")
    n = len(x)
    if not ys or n <= 2 * n_bins + 2:
        return x.copy(), {k: v.copy() for k, v in ys.items()}
    idx = _bin_extrema(np.vstack(list(ys.values())), n, n_bins)
    return x[idx], {k: v[idx] for k, v in ys.items()}


def pair_of(name: str) -> str | None:
    """The clearance pair a series name refers to ("|F_A|", "F_B_N", "A", "pair C") or None.

    Parameters
    ----------
    name : str
        A series name.

    Returns
    -------
    str or None
        The pair's letter.
    """
    # a force's name first: "F_A" is pair A (not the F before the underscore)
    m = (re.search(r"(?:^|[^A-Za-z])F_([ABCF])(?:$|[^A-Za-z])", name)
         or re.search(r"(?:^|[^A-Za-z])([ABCF])(?:$|[^A-Za-z])", name))
    return m.group(1) if m else None


def model_of(name: str) -> str | None:
    """'multibody' or 'mlsd' if a series name names one of the two models, else None.

    Parameters
    ----------
    name : str
        A series name.

    Returns
    -------
    str or None
        'multibody', 'mlsd' or None.
    """
    low = name.lower()
    if "multibody" in low or "multi-body" in low:
        return "multibody"
    if "mlsd" in low:
        return "mlsd"
    return None


def lighter(colour: str, amount: float) -> tuple[float, float, float]:
    """``colour`` mixed with white: amount 0 = unchanged, 1 = white.

    Parameters
    ----------
    colour : str
        A matplotlib colour.
    amount : float
        0 = unchanged, 1 = white (1).

    Returns
    -------
    (float, float, float)
        RGB, each 0..1 (1).
    """
    from matplotlib.colors import to_rgb

    r, g, b = to_rgb(colour)
    return (r + (1 - r) * amount, g + (1 - g) * amount, b + (1 - b) * amount)


def audit_figure(fig) -> list[str]:
    """Problems of a drawn figure against the style rules; an empty list when it complies.

    Checks every axes (colour bars included): non-empty axis labels end with a unit; a data axes has a
    y label; numeric x axes whose tick labels show have an x label; no tick-label offset text; no
    legend overlapping any data axes.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.

    Returns
    -------
    list of str
        The problems found.
    """
    from matplotlib.ticker import ScalarFormatter

    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    problems = []
    data_axes = [ax for ax in fig.axes if ax.get_label() != "<colorbar>" and ax.axison]
    for k, ax in enumerate(fig.axes):
        if not ax.axison:
            continue
        is_cbar = ax.get_label() == "<colorbar>"
        name = f"colour bar {k}" if is_cbar else f"axes {k} ({ax.get_title()[:40]!r})"
        for which, axis in (("x", ax.xaxis), ("y", ax.yaxis)):
            text = axis.get_label().get_text()
            if text and not has_unit(text):
                problems.append(f"{name}: {which} label {text!r} has no unit")
            if axis.get_offset_text().get_text().strip():
                problems.append(f"{name}: {which} axis shows offset {axis.get_offset_text().get_text()!r}")
            numeric = isinstance(axis.get_major_formatter(), ScalarFormatter)
            shown = any(t.get_visible() and t.get_text() for t in axis.get_ticklabels())
            if numeric and shown and not text:
                # a colour bar's long axis needs the label; its short axis has no ticks
                problems.append(f"{name}: numeric {which} axis without a label")
        leg = ax.get_legend()
        if leg is not None and leg.get_visible():
            lb = leg.get_window_extent(renderer)
            for other in data_axes:
                if lb.overlaps(other.get_window_extent(renderer)):
                    problems.append(f"{name}: legend overlaps the data area of {other.get_title()[:40]!r}")
    for leg in fig.legends:
        lb = leg.get_window_extent(renderer)
        for other in data_axes:
            if lb.overlaps(other.get_window_extent(renderer)):
                problems.append(f"figure legend overlaps the data area of {other.get_title()[:40]!r}")
    return problems


#: Resolution of every PNG figure: print quality at the figure's size in inches (the report embeds them; an SVG of the
#: same figure is written beside each PNG).
PRINT_DPI = 300


def canvas_overflow(fig) -> tuple[float, float, float, float]:
    """How far the drawn artists (labels, titles, legends outside, colour bars) reach beyond the canvas, in inches:
    (left, bottom, right, top), each >= 0; all zero when nothing is cut.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.

    Returns
    -------
    (float, float, float, float)
        Overflow [in] at the left, bottom, right and top (1 in = 25.4 mm).
    """
    fig.canvas.draw()
    bb = fig.get_tightbbox(fig.canvas.get_renderer())
    w, h = fig.get_size_inches()
    return (max(0.0, -bb.x0), max(0.0, -bb.y0), max(0.0, bb.x1 - w), max(0.0, bb.y1 - h))


def fit_canvas(fig, *, pad: float = 0.05) -> bool:
    """Grow the canvas so every artist lies inside it with ``pad`` inches to spare; returns True if it grew.

    The layout (constrained layout) is drawn first; what still reaches beyond the edge (an equal-aspect axes'
    outside legend, a long title) is given room by freezing the layout and widening the canvas on that side, every
    axes and figure-level text keeping its size in inches.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    pad : float
        Room left around the artists [in] (1 in = 25.4 mm).

    Returns
    -------
    bool
        Whether the canvas grew.
    """
    over = canvas_overflow(fig)
    if max(over) <= 1e-3:
        return False
    left, bottom, right, top = (o + pad if o > 1e-3 else 0.0 for o in over)
    w, h = fig.get_size_inches()
    W, H = w + left + right, h + bottom + top
    boxes = [(ax, ax.get_position()) for ax in fig.axes]
    texts = [(t, t.get_position()) for t in fig.texts]
    fig.set_layout_engine("none")
    fig.set_size_inches(W, H)
    for ax, b in boxes:
        ax.set_position([(b.x0 * w + left) / W, (b.y0 * h + bottom) / H, b.width * w / W, b.height * h / H])
    for t, (x, y) in texts:
        t.set_position(((x * w + left) / W, (y * h + bottom) / H))
    for leg in fig.legends:
        leg.set_bbox_to_anchor(None)
    return True


#: savefig metadata per format that leaves out the date of the save, so a figure's file depends only on what it
#: shows (the figure cache's copies are the bytes a fresh draw writes: :mod:`berryshaker.report.plots.figure_cache`)
FIXED_METADATA = {"svg": {"Date": None}, "pdf": {"CreationDate": None}, "ps": {"CreationDate": None},
                  "eps": {"CreationDate": None}}
#: the salt of the SVG's element ids (matplotlib's default is random per process)
SVG_HASH_SALT = "berryshaker"


def rendered(fig, fmt: str, **kw) -> bytes:
    """The bytes of ``fig`` saved as ``fmt``, the same for the same figure in every process and on every day: no
    date in the metadata (:data:`FIXED_METADATA`), SVG ids from a fixed salt (:data:`SVG_HASH_SALT`).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    fmt : str
        The format ("png", "svg", ...).
    **kw
        Passed on to ``savefig`` (``dpi``).

    Returns
    -------
    bytes
        The file's content.
    """
    import io

    import matplotlib

    buf = io.BytesIO()
    with matplotlib.rc_context({"svg.hashsalt": SVG_HASH_SALT}):
        fig.savefig(buf, format=fmt, metadata=FIXED_METADATA.get(fmt), **kw)
    return buf.getvalue()


#: the files the figure functions wrote inside :func:`recording_written` (None outside it)
_WRITTEN: contextvars.ContextVar = contextvars.ContextVar("figure_files_written", default=None)


@contextlib.contextmanager
def recording_written() -> Iterator[list]:
    """Inside the block, the paths of the figure files written (:func:`finish`) are appended to the list yielded
    (what the figure cache keeps of a figure call).

    Yields
    ------
    list of Path
        The files written so far.
    """
    paths: list = []
    token = _WRITTEN.set(paths)
    try:
        yield paths
    finally:
        _WRITTEN.reset(token)


def written(files) -> None:
    """Record figure files just written (for :func:`recording_written`).

    Parameters
    ----------
    files : iterable of path
        The files.
    """
    paths = _WRITTEN.get()
    if paths is not None:
        paths.extend(files)


def finish(fig, path, *, dpi: int = PRINT_DPI, keep: bool = False, svg: bool = True):
    """Save ``fig`` to ``path`` (PNG at ``dpi``) and, with ``svg``, the same figure as SVG beside it, both written
    together or neither (:func:`berryshaker.outputs.write_files_atomic`); close it unless ``keep``.  The canvas is grown first until no label, title or legend is cut (:func:`fit_canvas`).  Returns the
    figure if kept, else None.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    path : path
        PNG file.
    dpi : int
        Resolution [1/in] (dots per inch).
    keep : bool
        Leave the figure open.
    svg : bool
        Write the SVG beside the PNG.

    Returns
    -------
    Figure or None
        The figure if kept.
    """
    from pathlib import Path

    from berryshaker.outputs import write_files_atomic

    fit_canvas(fig)
    path = Path(path)
    files = {path: rendered(fig, path.suffix.lstrip(".").lower() or "png", dpi=dpi)}
    if svg:
        files[path.with_suffix(".svg")] = rendered(fig, "svg")
    write_files_atomic(files)  # the PNG and its SVG together or neither (a full disk: one error, nothing half-written)
    written(files)
    if keep:
        return fig
    pyplot().close(fig)
    return None
