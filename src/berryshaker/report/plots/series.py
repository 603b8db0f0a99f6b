"""Figures of time series (collision forces, joint forces, any signals of a saved run), the fruit force against
distance (eq. 16), grouped bars and the harvest against a machine setting."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from berryshaker.report.plots.figure_files import _extremes, _out
from berryshaker.report.style import (
    BAND_ALPHA,
    FRUIT_COLOURS,
    LEVEL_COLOURS,
    MODEL_STYLES,
    PAIR_COLOURS,
    SERIES_COLOURS,
    decimate_minmax,
    decimate_minmax_shared,
    label_axes,
    legend_outside,
    lighter,
    model_of,
    new_figure,
    pair_of,
    require_unit,
)


def _series_style(name: str, i: int, colours: dict | None) -> dict:
    """Line style of a series: explicit colour > model style (multibody/MLSD) > pair colour > cycle."""
    pair = pair_of(name)
    base = PAIR_COLOURS.get(pair) if pair else None
    model = model_of(name)
    if model is not None:
        st = dict(MODEL_STYLES[model])
        if st["color"] is None:
            st["color"] = base or SERIES_COLOURS[0]
    else:
        st = {"color": base or SERIES_COLOURS[i % len(SERIES_COLOURS)], "linestyle": "-", "linewidth": 1.0,
              "alpha": 1.0, "zorder": 2}
    if colours and name in colours:
        st["color"] = colours[name]
    return st


def _zoom_window(t: np.ndarray, series: dict, zoom) -> tuple[float, float] | None:
    if zoom is None:
        return None
    if isinstance(zoom, str):
        if zoom != "peak":
            raise ValueError(f"zoom={zoom!r}: give (t0, t1) in seconds or 'peak'")
        y = np.abs(np.asarray(next(iter(series.values())), float))
        k = int(np.argmax(y))
        half = 0.02 * (t[-1] - t[0])
        return float(max(t[0], t[k] - half)), float(min(t[-1], t[k] + half))
    t0, t1 = (float(v) for v in zoom)
    if not t1 > t0:
        raise ValueError(f"zoom=({t0}, {t1}): the end must come after the start")
    return t0, t1


def plot_time_series(t, series: dict[str, np.ndarray], ylabel: str, path: Path, title: str = "", *,
                     zoom=None, n_bins: int = 2000, xlabel: str = "time [s]", colours: dict | None = None,
                     return_figure: bool = False) -> dict:
    """Several time series on one axis, thinned by peak-preserving decimation.

    Parameters
    ----------
    t : array_like (n,)
        Time [s].
    series : dict name -> array (n,)
        Named series (the units of ``ylabel``).  Names containing "multibody" / "MLSD" get :data:`MODEL_STYLES` (multibody solid,
        thick and underneath; MLSD dashed on top, so neither hides the other); names naming a clearance
        pair ("|F_A|") get that pair's colour.
    ylabel : str
        Quantity with unit, e.g. ``"collision force at A [N]"`` (a label without unit is flagged).
    zoom : (t0, t1) or "peak" or None
        Adds a second panel showing [t0, t1] (seconds) at full resolution; "peak": 4 % of the record
        around the largest |value| of the first series.  The window is shaded on the main panel.
    n_bins : int
        Decimation bins (:func:`berryshaker.report.style.decimate_minmax`).
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    title : str
        Figure title (a default when empty).
    xlabel : str
        Label of the abscissa with unit.
    colours : dict name -> colour, optional
        Overrides.
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        ``series``: per name the drawn x, y and their max, min, peak_abs (equal to the input's);
        ``zoom``: the window or None; ``path``.
    """
    t = np.asarray(t, float)
    window = _zoom_window(t, series, zoom)
    nrows = 2 if window else 1
    fig, axes = new_figure(nrows, 1, figsize=(10, 4.2 if nrows == 1 else 7.0), squeeze=False)
    ax = axes[0, 0]
    ylabel = require_unit(ylabel, strict=False)
    data = {"series": {}, "zoom": window}
    styles = {name: _series_style(name, i, colours) for i, name in enumerate(series)}
    for name, y in series.items():
        y = np.asarray(y, float)
        xd, yd = decimate_minmax(t, y, n_bins)
        ax.plot(xd, yd, label=name, **styles[name])
        data["series"][name] = {"x": xd, "y": yd, **_extremes(yd), "input_peak_abs": float(np.max(np.abs(y)))}
    label_axes(ax, xlabel, ylabel, strict=False)
    ax.grid(alpha=0.3)
    if title:
        ax.set_title(title)
    if window:
        ax.axvspan(*window, color="#999999", alpha=0.2, lw=0, label="zoom window (lower panel)")
        zx = axes[1, 0]
        sel = (t >= window[0]) & (t <= window[1])
        for name, y in series.items():
            y = np.asarray(y, float)[sel]
            if y.size:
                xd, yd = decimate_minmax(t[sel], y, n_bins)
                zx.plot(xd, yd, label=name, **styles[name])
        zx.set_xlim(*window)
        label_axes(zx, xlabel, ylabel, strict=False)
        zx.set_title(f"zoom: {window[0]:.4g} s to {window[1]:.4g} s (full resolution)", fontsize=9)
        zx.grid(alpha=0.3)
    legend_outside(ax)
    return _out(fig, path, data, return_figure)


def plot_joint_forces(t, forces: dict[str, np.ndarray], path: Path, title: str = "", *,
                      quantity: str = "collision force", unit: str = "N", sharey: bool = False,
                      peaks: dict[str, float] | None = None, n_bins: int = 2000, return_figure: bool = False) -> dict:
    """One panel per joint (shared time axis), e.g. the four clearance collision forces of
    ``simulate --plot``; each panel in its pair's colour with its peak in the panel title.

    Parameters
    ----------
    t : array_like (n,)
        Time [s].
    forces : dict joint -> array (n,)
        Keys naming the pair ("A", "|F_A|"...), values in ``unit`` (its units).  Plotted as given (pass magnitudes
        if wanted).
    title : str
        Figure title; put the clearance set here (e.g. "A 0.25 mm, B 0.2 mm, C 0.1 mm, F 0.2 mm").
    quantity, unit : str
        Y labels read "<quantity> at <joint> [<unit>]".
    sharey : bool
        One y scale for all panels (compare magnitudes) or one per panel (default: see each waveform).
    peaks : dict joint -> float, optional
        The peaks a table beside the figure prints (``simulate``: over every integrator step, which the series
        written every 0.1 ms can miss between its samples): each panel states this peak and draws it as a dotted
        line, so figure and table give one number.  Default: the drawn series' peak.
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    n_bins : int
        Bins of the peak-preserving decimation (:func:`berryshaker.report.style.decimate_minmax`).
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        ``series``: per joint the drawn x, y and max, min, peak_abs; ``path``.
    """
    t = np.asarray(t, float)
    n = len(forces)
    fig, axes = new_figure(n, 1, figsize=(10, 1.9 * n + 1.0), sharex=True, sharey=sharey, squeeze=False)
    data = {"series": {}}
    for i, (name, y) in enumerate(forces.items()):
        ax = axes[i, 0]
        y = np.asarray(y, float)
        xd, yd = decimate_minmax(t, y, n_bins)
        st = _series_style(name, i, None)
        st.update(linewidth=0.9, alpha=1.0)
        ax.plot(xd, yd, **st)
        joint = pair_of(name) or name
        label_axes(ax, ylabel=f"{quantity} at {joint} [{unit}]")
        ax.yaxis.label.set_fontsize(8)
        ex = _extremes(yd)
        stated = None if peaks is None else peaks.get(name, peaks.get(joint))
        if stated is None:
            ax.set_title(f"{joint}: peak |value| {ex['peak_abs']:.4g} {unit}", loc="right", fontsize=8)
        else:
            ax.axhline(stated, color=st["color"], linestyle=":", linewidth=0.9)
            ax.set_title(f"{joint}: peak {stated:.6g} {unit} over every integrator step (dotted; the samples drawn "
                         f"reach {ex['peak_abs']:.6g} {unit})", loc="right", fontsize=8)
        ax.grid(alpha=0.3)
        data["series"][name] = {"x": xd, "y": yd, **ex, "input_peak_abs": float(np.max(np.abs(y))),
                                "stated_peak": ex["peak_abs"] if stated is None else float(stated)}
    label_axes(axes[-1, 0], xlabel="time [s]")
    fig.suptitle((title or f"{quantity.capitalize()} per joint")
                 + ("" if sharey else "\n(each panel has its own y scale)"), fontsize=11)
    return _out(fig, path, data, return_figure)


# ---- plant -----------------------------------------------------------------------------------------
def plot_fruit_force(distance, forces: dict, ranges: dict, path: Path, title: str = "", *,
                     peaks: dict | None = None, n_bins: int = 1500, bonds: bool = True,
                     return_figure: bool = False) -> dict:
    """Fruit harvesting force against machine-to-plant distance (study eq. 16, Figs. 24-26), one panel per
    fruit on a common force scale, with the study's range of peak force and the eq. 17 bond forces
    as labelled bands, and each trace's peak marked.

    Parameters
    ----------
    distance : array_like (n,)
        Machine-to-plant distance along the row [m].
    forces : dict fruit -> array (n,)
        Fruit force [N] (study eq. 16).  Give the full-resolution series: it is thinned here with
        min-max decimation, which keeps every peak (taking every k-th sample drops impact peaks).
    ranges : dict fruit -> (lo, hi)
        The study's range of peak force [N] per fruit (Sec. 3.4), drawn as shaded bands at +-.
    peaks : dict fruit -> float, optional
        Peak |force| [N] of the table the figure accompanies.  If the drawn peak differs (the series was
        thinned before it got here), the legend says so and ``peak_matches_table`` is False.
    bonds : bool
        Draw the ripe bond band Fa and the lower end of the unripe bond Fb (eq. 17; values from
        :mod:`berryshaker.reference_study`).
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    title : str
        Figure title (a default when empty).
    n_bins : int
        Bins of the peak-preserving decimation (:func:`berryshaker.report.style.decimate_minmax`).
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        ``fruit``: per fruit the drawn x, y, max, min, peak_abs, the peak's position, and (with
        ``peaks``) table_peak and peak_matches_table; ``path``.
    """
    from berryshaker.reference_study import RIPE_BOND_N, UNRIPE_BOND_N

    names = list(forces)
    x = np.asarray(distance, float)
    fig, axes = new_figure(len(names), 1, figsize=(10, 2.5 * len(names) + 0.8), sharex=True, sharey=True,
                           squeeze=False)
    axes = axes[:, 0]
    data = {"fruit": {}}
    top = 0.0
    for i, (ax, name) in enumerate(zip(axes, names)):
        first = i == 0  # the reference bands are the same in every panel: named once, in the top legend
        y = np.asarray(forces[name], float)
        xd, yd = decimate_minmax(x, y, n_bins)
        ex = _extremes(yd)
        colour = FRUIT_COLOURS.get(name, SERIES_COLOURS[0])
        ax.plot(xd, yd, lw=0.7, color=colour, label=f"{name} fruit, F")
        k = int(np.argmax(np.abs(yd)))
        entry = {"x": xd, "y": yd, **ex, "peak_at_m": float(xd[k])}
        peak_label = f"peak |F| = {ex['peak_abs']:.4g} N"
        if peaks is not None and name in peaks:
            tp = float(peaks[name])
            entry["table_peak"] = tp
            entry["peak_matches_table"] = bool(abs(tp - ex["peak_abs"]) <= 1e-9 * max(1.0, abs(tp)))
            if not entry["peak_matches_table"]:
                peak_label += f" (table {tp:.4g} N: series was thinned before plotting)"
        ax.plot([xd[k]], [yd[k]], "v" if yd[k] > 0 else "^", color="k", ms=6, zorder=5, label=peak_label)
        if name in ranges:
            lo, hi = ranges[name]
            ax.axhspan(lo, hi, color="#2CA02C", alpha=BAND_ALPHA, lw=0,
                       label=f"study range of peak |F|, {lo:g}-{hi:g} N (Sec. 3.4)")
            ax.axhspan(-hi, -lo, color="#2CA02C", alpha=BAND_ALPHA, lw=0)
            top = max(top, hi)
        if bonds:
            (fa0, fa1), fb0 = RIPE_BOND_N, UNRIPE_BOND_N[0]
            ax.axhspan(fa0, fa1, color="#E69F00", alpha=0.35, lw=0,
                       label=f"ripe bond Fa {fa0:.2f}-{fa1:.2f} N (eq. 17)" if first else None)
            ax.axhspan(-fa1, -fa0, color="#E69F00", alpha=0.35, lw=0)
            ax.axhline(fb0, color="#C00000", ls=":", lw=1.0,
                       label=f"unripe bond Fb from {fb0:.1f} N (eq. 17)" if first else None)
            ax.axhline(-fb0, color="#C00000", ls=":", lw=1.0)
            top = max(top, fb0)
        top = max(top, ex["peak_abs"])
        label_axes(ax, ylabel=f"{name}: F [N]")
        legend_outside(ax)
        ax.grid(alpha=0.3)
        data["fruit"][name] = entry
    axes[0].set_ylim(-1.12 * top, 1.12 * top)
    label_axes(axes[-1], xlabel="machine-to-plant distance along the row [m]")
    axes[0].set_title(title or "Fruit harvesting force (study eq. 16, Figs. 24-26)")
    return _out(fig, path, data, return_figure)


# ---- bars ------------------------------------------------------------------------------------------
def _bar_style(name: str, i: int, pair: str | None, colours: dict | None) -> dict:
    if colours and name in colours:
        return {"color": colours[name], "edgecolor": "black", "hatch": None}
    if name in LEVEL_COLOURS:
        return {"color": LEVEL_COLOURS[name], "edgecolor": "black", "hatch": None}
    if name in FRUIT_COLOURS:
        return {"color": FRUIT_COLOURS[name], "edgecolor": "black", "hatch": None}
    base = PAIR_COLOURS.get(pair) if pair else None
    if base is None:
        return {"color": SERIES_COLOURS[i % len(SERIES_COLOURS)], "edgecolor": "black", "hatch": None}
    low = name.lower()
    if model_of(name) == "mlsd":
        return {"color": "white", "edgecolor": base, "hatch": "////"}
    if "mean" in low or "rms" in low:
        return {"color": lighter(base, 0.55), "edgecolor": base, "hatch": None}
    return {"color": base, "edgecolor": "black", "hatch": None}


def plot_bars(series: dict, labels: list, ylabel: str, path: Path, title: str = "", *, pair: str | None = None,
              colours: dict | None = None, reference_index: int | None = None,
              reference_label: str = "joint reaction (no clearance)", annotate: bool = False,
              return_figure: bool = False) -> dict:
    """Grouped bars: one group per label, one bar per series; legend outside the data.

    Parameters
    ----------
    series : dict name -> list (one value per label)
        Bar heights (the units of ``ylabel``).
    labels : list of str
        Group labels (e.g. "none", "0.25 mm", ...).
    ylabel : str
        Names the joint and quantity with unit, e.g. ``"peak collision force at A [N]"``.
    pair : str, optional
        Clearance pair shown: bars take its colour (:data:`PAIR_COLOURS`): multibody solid, MLSD
        hatched outline, mean/rms a lighter shade.  Without it, series named like
        :data:`LEVEL_COLOURS` / :data:`FRUIT_COLOURS` keys get those colours, others a fixed cycle.
    colours : dict name -> colour, optional
        Overrides.
    reference_index : int, optional
        Group drawn cross-hatched and annotated with ``reference_label``: with zero clearance the
        "collision force" is the ideal joint's reaction force, a different quantity.
    annotate : bool
        Print each bar's value above it.
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    title : str
        Figure title (a default when empty).
    reference_label : str
        Legend text of the reference group.
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        ``bars``: per series the drawn heights; ``labels``; ``path``.
    """
    from matplotlib.patches import Patch

    fig, ax = new_figure(figsize=(9.5, 4.2))
    n = len(series)
    width = 0.8 / max(n, 1)
    x = np.arange(len(labels))
    data = {"bars": {}, "labels": list(labels)}
    for i, (name, vals) in enumerate(series.items()):
        vals = np.asarray(vals, float)
        st = _bar_style(name, i, pair, colours)
        rects = ax.bar(x + (i - (n - 1) / 2) * width, vals, width, label=name, color=st["color"],
                       edgecolor=st["edgecolor"], hatch=st["hatch"], linewidth=0.8)
        if reference_index is not None and 0 <= reference_index < len(rects):
            rects[reference_index].set_hatch((st["hatch"] or "") + "xx")
            rects[reference_index].set_edgecolor("#555555")
        if annotate:
            ax.bar_label(rects, fmt="%.3g", fontsize=7, padding=1)
        data["bars"][name] = vals
    ticks = [str(v) for v in labels]
    if reference_index is not None and 0 <= reference_index < len(ticks):
        # the annotation goes under the group, where it cannot cover a bar
        ticks[reference_index] += "\n" + reference_label.replace(" (", "\n(")
    ax.set_xticks(x)
    ax.set_xticklabels(ticks)
    label_axes(ax, ylabel=ylabel, strict=False)
    ax.grid(alpha=0.3, axis="y")
    ax.margins(y=0.12)
    handles, names = ax.get_legend_handles_labels()
    if reference_index is not None:
        handles.append(Patch(facecolor="white", edgecolor="#555555", hatch="xx"))
        names.append(reference_label)
        data["reference"] = {"index": reference_index, "label": reference_label}
    legend_outside(ax, handles=handles, labels=names)
    if title:
        ax.set_title(title)
    return _out(fig, path, data, return_figure)


#: the three picking indexes against a machine setting, as the vibratory-harvesting literature draws them
HARVEST_RESPONSE_SERIES = {"ripe_removal_pct": ("ripe removal (% of ripe mass)", "#1b7837", "o", "-"),
                           "unripe_shed_pct": ("unripe shedding (% of unripe mass)", "#762a83", "s", "--"),
                           "damage_rate_pct": ("damage rate (% of picked mass)", "#b2182b", "^", ":")}


def plot_harvest_response(x, rows: list[dict], xlabel: str, path: Path, title: str = "", *,
                          frequency_hz=None, amplitude_mm=None, return_figure: bool = False) -> dict:
    """Ripe removal, unripe shedding and damage against one machine setting (e.g. the cam speed).

    Each index is drawn as its replicate mean with +- one SD bars (the rows' ``<index>_sd``) where present.

    Parameters
    ----------
    x : sequence of float
        The swept values (their units: those named in ``xlabel``).
    rows : list of dict
        One :func:`berryshaker.harvest.virtual.harvest_response` per value.
    xlabel : str
        Axis label with unit, e.g. ``"cam speed [rpm]"``.
    frequency_hz : sequence of float, optional
        The shaking frequency of each point [Hz]: drawn as a second x axis on top (drive speeds only).
    amplitude_mm : sequence of float, optional
        The finger amplitude of each point [mm] (:func:`berryshaker.harvest.virtual.shaking_amplitude`): drawn as a
        second x axis on top when it is strictly monotonic in x and no frequency axis is drawn (drive geometry).
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    title : str
        Figure title (a default when empty).
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        ``x`` (sorted) and per index key the drawn values; ``path``.
    """
    fig, ax = new_figure(figsize=(7.5, 4.2))
    order = np.argsort(np.asarray(x, float))
    xs = np.asarray(x, float)[order]
    data = {"x": xs, "series": {}}
    for key, (label, colour, marker, ls) in HARVEST_RESPONSE_SERIES.items():
        ys = np.array([float(rows[i].get(key, float("nan"))) for i in order])
        sd = np.array([float(rows[i].get(f"{key}_sd", 0.0) or 0.0) for i in order])
        if np.any(sd > 0):
            ax.errorbar(xs, ys, yerr=sd, color=colour, marker=marker, linestyle=ls, capsize=3,
                        label=label + " (mean ± SD)")
            data["series"][f"{key}_sd"] = sd
        else:
            ax.plot(xs, ys, color=colour, marker=marker, linestyle=ls, label=label)
        data["series"][key] = ys
    label_axes(ax, xlabel=xlabel, ylabel="share of the fruit mass [%]", strict=False)
    ax.grid(alpha=0.3)
    ax.set_ylim(bottom=0.0)
    if frequency_hz is not None and len(xs) > 1:
        fz = np.asarray(frequency_hz, float)[order]
        # the frequency is linear in a drive speed (one comb cycle per revolution): a straight-line map, valid
        # beyond the data too (the axis limits lie outside it)
        slope, icpt = np.polyfit(xs, fz, 1)
        top = ax.secondary_xaxis("top", functions=(lambda v: slope * np.asarray(v) + icpt,
                                                   lambda f: (np.asarray(f) - icpt) / slope))
        top.set_xlabel("shaking frequency [Hz]")
        data["frequency_hz"] = fz
    elif amplitude_mm is not None and len(xs) > 1:
        am = np.asarray(amplitude_mm, float)[order]
        d = np.diff(am)
        if np.all(d > 0) or np.all(d < 0):  # a monotonic map between the swept value and the amplitude
            xa, aa = (xs, am) if d[0] > 0 else (xs[::-1], am[::-1])
            top = ax.secondary_xaxis("top", functions=(lambda v: np.interp(v, xs, am),
                                                       lambda a: np.interp(a, aa, xa)))
            top.set_xlabel("finger amplitude [mm]")
            data["amplitude_mm"] = am
    legend_outside(ax)
    if title:
        # left-aligned: a long title centred on the narrow axes (legend outside) would run off the figure
        ax.set_title(title, pad=28 if ("frequency_hz" in data or "amplitude_mm" in data) else 6, loc="left")
    return _out(fig, path, data, return_figure)




def plot_signals(x: tuple[str, np.ndarray, str], ys: dict[str, tuple[np.ndarray, str]], path: Path,
                 title: str = "", *, n_bins: int = 2000, return_figure: bool = False) -> dict:
    """Any signals of a saved run against time or against another signal (``berryshaker plot``): one panel per
    unit, sharing the abscissa, each series in its pair's colour where it names one.

    Against an abscissa that increases (time, the drive angle) the series are thinned by peak-preserving
    decimation (:func:`berryshaker.report.style.decimate_minmax_shared`: the drawn peak is the data's); against
    any other signal (a phase plot) every sample is drawn.

    Parameters
    ----------
    x : (str, ndarray, str)
        The abscissa's name, values (SI) and their unit (e.g. ``("time", t, "s")``).
    ys : dict name -> (ndarray, str)
        The series' values (SI) and their units (e.g. ``"N"``, ``"N m"``), each the length of ``x``.
    path : Path
        The figure file (its suffix sets the format: .png at 300 dpi, .svg, .pdf); written atomically, nothing
        beside it.
    title : str
        Figure title.
    n_bins : int
        Bins of the decimation.
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        ``panels``: per unit, the drawn ``x`` and ``y`` of each series with its extremes and the peak |value| of
        its input (``input_peak_abs``); ``decimated`` (bool); ``xlabel``; ``path``.
    """
    from berryshaker.outputs import write_bytes_atomic
    from berryshaker.report.style import PRINT_DPI, fit_canvas, pyplot, rendered, written

    x_name, xv, x_unit = x
    xv = np.asarray(xv, float)
    units: dict[str, list[str]] = {}
    for name, (_v, unit) in ys.items():
        units.setdefault(unit, []).append(name)
    increasing = bool(np.all(np.diff(xv) > 0))
    fig, axes = new_figure(len(units), 1, figsize=(10, 2.6 * len(units) + 1.2), sharex=True, squeeze=False)
    data: dict = {"panels": {}, "decimated": increasing, "xlabel": f"{x_name} [{x_unit}]"}
    # a pair's series in the pair's colour, any other in a colour no pair has
    others = [c for c in SERIES_COLOURS if c not in PAIR_COLOURS.values()]
    colours = {}
    for name in ys:
        pair = pair_of(name)
        colours[name] = PAIR_COLOURS[pair] if pair in PAIR_COLOURS else others[len(colours) % len(others)]
    for ax, (unit, names) in zip(axes[:, 0], units.items()):
        values = {n: np.asarray(ys[n][0], float) for n in names}
        xd, yd = decimate_minmax_shared(xv, values, n_bins) if increasing else (xv, values)
        panel = data["panels"][unit] = {}
        for name in names:
            ax.plot(xd, yd[name], label=name, color=colours[name], linewidth=1.0)
            panel[name] = {"x": xd, "y": yd[name], **_extremes(yd[name]),
                           "input_peak_abs": float(np.max(np.abs(values[name])))}
        label_axes(ax, ylabel=f"{', '.join(names) if len(names) <= 3 else 'signals'} [{unit}]")
        ax.grid(alpha=0.3)
        if len(names) > 1:
            legend_outside(ax)
    label_axes(axes[-1, 0], xlabel=data["xlabel"])
    if title:
        fig.suptitle(title, fontsize=11)
    path = Path(path)
    fit_canvas(fig)
    write_bytes_atomic(path, rendered(fig, path.suffix.lstrip(".").lower(), dpi=PRINT_DPI))
    written([path])
    data["path"] = str(path)
    if return_figure:
        data["figure"] = fig
    else:
        pyplot().close(fig)
    return data
