"""Figures (matplotlib, Agg backend: no display needed), all in the style of
:mod:`berryshaker.report.style`: units on every axis and colour bar, shared scales where panels compare,
legends outside the data, fixed colours per clearance pair and line styles per model, peak-preserving
decimation, no offset tick labels.

Every function saves a PNG and returns the data it drew as a dict (decimated series, their extremes,
colour scales...), so a test or the report can check a figure against its table.  With
``return_figure=True`` the matplotlib figure is left open and returned under ``"figure"`` (the caller
closes it).

long module: one function per figure of the study and the commands, each short, over the one style module.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np

from berryshaker.report.style import (
    BAND_ALPHA,
    FRUIT_COLOURS,
    LEVEL_COLOURS,
    MODEL_STYLES,
    PAIR_COLOURS,
    RESPONSE_NAMES,
    RESPONSE_UNITS,
    SERIES_COLOURS,
    colour_bar,
    decimate_minmax,
    finish,
    label_axes,
    legend_outside,
    lighter,
    model_of,
    new_figure,
    pair_of,
    plain_ticks,
    require_unit,
    widen_span,
)


def _extremes(y: np.ndarray) -> dict:
    y = np.asarray(y, float)
    return {"max": float(np.max(y)), "min": float(np.min(y)), "peak_abs": float(np.max(np.abs(y)))}


def _out(fig, path, data: dict, return_figure: bool, dpi: int = 110) -> dict:
    data["path"] = str(path)
    kept = finish(fig, path, dpi=dpi, keep=return_figure)
    if kept is not None:
        data["figure"] = kept
    return data


# ---- kinematics ------------------------------------------------------------------------------------
def plot_svaj(kin, path: Path, title: str = "", *, return_figure: bool = False) -> dict:
    """Push-rod displacement, velocity, acceleration and jerk over the cam cycle (study eq. 1)."""
    deg = np.degrees(kin.phi)
    fig, axes = new_figure(4, 1, figsize=(8, 9), sharex=True)
    data = {"series": {}}
    for ax, y, lab, key in zip(axes, (kin.s * 1e3, kin.v, kin.a, kin.j),
                               ("s [mm]", "v [m/s]", "a [m/s$^2$]", "j [m/s$^3$]"), "svaj"):
        ax.plot(deg, y, lw=1.4, color=PAIR_COLOURS["A"])
        label_axes(ax, ylabel=lab)
        ax.grid(alpha=0.3)
        data["series"][key] = {"x": deg, "y": np.asarray(y), **_extremes(y)}
    label_axes(axes[-1], xlabel="cam angle [deg]")
    axes[-1].set_xlim(0, 360)
    axes[0].set_title(title or "Push-rod SVAJ (study eq. 1)")
    return _out(fig, path, data, return_figure)


def plot_groove(pitch, inner, outer, base_radius: float, path: Path, title: str = "", *,
                return_figure: bool = False) -> dict:
    """Cam groove: pitch curve and inner/outer walls (study eq. 2, corrected: docs/study.md, eq. 2)."""
    fig, ax = new_figure(figsize=(8, 6.5))
    ax.plot(pitch[0] * 1e3, pitch[1] * 1e3, "k--", lw=1, label="pitch curve (roller centre)")
    ax.plot(inner[0] * 1e3, inner[1] * 1e3, lw=1.5, color=PAIR_COLOURS["A"], label="inner wall")
    ax.plot(outer[0] * 1e3, outer[1] * 1e3, lw=1.5, color=PAIR_COLOURS["B"], label="outer wall")
    t = np.linspace(0, 2 * math.pi, 200)
    ax.plot(base_radius * 1e3 * np.cos(t), base_radius * 1e3 * np.sin(t), ":", color="grey", lw=1,
            label="base circle")
    ax.plot([0], [0], "k+", label="cam centre O")
    ax.set_aspect("equal")
    label_axes(ax, "x [mm]", "y [mm]")
    legend_outside(ax)
    ax.set_title(title or "Groove cam profile")
    ax.grid(alpha=0.3)
    return _out(fig, path, {"base_radius_mm": base_radius * 1e3}, return_figure)


def plot_comb_angles(kin, theta_d0: float, theta_e0: float, comb_length: float, path: Path, *,
                     return_figure: bool = False) -> dict:
    """Comb swing angles, tip speeds and transmission angle over the cycle (study eq. 3)."""
    deg = np.degrees(kin.phi)
    fig, axes = new_figure(3, 1, figsize=(9, 8), sharex=True)
    left, right = PAIR_COLOURS["C"], PAIR_COLOURS["F"]
    axes[0].plot(deg, np.degrees(kin.theta_d - theta_d0), color=left, label="left comb (shaft D)")
    axes[0].plot(deg, np.degrees(kin.theta_e - theta_e0), color=right, label="right comb (shaft E)")
    label_axes(axes[0], ylabel="swing [deg]")
    legend_outside(axes[0])
    axes[1].plot(deg, comb_length * kin.omega_d, color=left, label="left tip")
    axes[1].plot(deg, comb_length * kin.omega_e, color=right, label="right tip")
    label_axes(axes[1], ylabel="tip speed [m/s]")
    legend_outside(axes[1])
    axes[2].plot(deg, np.degrees(kin.transmission_angle), color="#444444")
    label_axes(axes[2], "drive-shaft angle [deg]", "transmission angle [deg]")
    axes[2].set_xlim(0, 360)
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].set_title("Double rocker (study eq. 3)")
    return _out(fig, path, {}, return_figure)


def plot_mode_shapes(modes, modes_fe, path: Path, *, return_figure: bool = False) -> dict:
    """Analytic (lines) and finite-element (dots) mass-normalised mode shapes of the branch (eq. 15)."""
    fig, ax = new_figure(figsize=(10, 4.5))
    for i in range(len(modes.omega)):
        colour = SERIES_COLOURS[i % len(SERIES_COLOURS)]
        ax.plot(modes.z, modes.shapes[i], lw=1.5, color=colour,
                label=f"mode {i + 1}: {modes.frequency_hz[i]:.3f} Hz (FE {modes_fe.frequency_hz[i]:.3f} Hz)")
        step = max(1, len(modes_fe.z) // 25)
        ax.plot(modes_fe.z[::step], modes_fe.shapes[i][::step], "o", ms=3, color=colour)
    ax.axhline(0, color="k", lw=0.5)
    label_axes(ax, "position along the branch z [m]", r"mode shape [kg$^{-1/2}$]")
    ax.set_title("Tapered branch modes: Bessel solution (lines, eq. 15) and finite elements (dots)")
    legend_outside(ax)
    ax.grid(alpha=0.3)
    return _out(fig, path, {}, return_figure)


# ---- time series -----------------------------------------------------------------------------------
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
        Named series.  Names containing "multibody" / "MLSD" get :data:`MODEL_STYLES` (multibody solid,
        thick and underneath; MLSD dashed on top, so neither hides the other); names naming a clearance
        pair ("|F_A|") get that pair's colour.
    ylabel : str
        Quantity with unit, e.g. ``"collision force at A [N]"`` (a label without unit is flagged).
    zoom : (t0, t1) or "peak" or None
        Adds a second panel showing [t0, t1] (seconds) at full resolution; "peak": 4 % of the record
        around the largest |value| of the first series.  The window is shaded on the main panel.
    n_bins : int
        Decimation bins (:func:`berryshaker.report.style.decimate_minmax`).

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
                      n_bins: int = 2000, return_figure: bool = False) -> dict:
    """One panel per joint (shared time axis), e.g. the four clearance collision forces of
    ``simulate --plot``; each panel in its pair's colour with its peak in the panel title.

    Parameters
    ----------
    t : array_like (n,)
        Time [s].
    forces : dict joint -> array (n,)
        Keys naming the pair ("A", "|F_A|"...).  Plotted as given (pass magnitudes if wanted).
    title : str
        Figure title; put the clearance set here (e.g. "A 0.25 mm, B 0.2 mm, C 0.1 mm, F 0.2 mm").
    quantity, unit : str
        Y labels read "<quantity> at <joint> [<unit>]".
    sharey : bool
        One y scale for all panels (compare magnitudes) or one per panel (default: see each waveform).

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
        ax.set_title(f"{joint}: peak |value| {ex['peak_abs']:.4g} {unit}", loc="right", fontsize=8)
        ax.grid(alpha=0.3)
        data["series"][name] = {"x": xd, "y": yd, **ex, "input_peak_abs": float(np.max(np.abs(y)))}
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
        Peak |force| of the table the figure accompanies.  If the drawn peak differs (the series was
        thinned before it got here), the legend says so and ``peak_matches_table`` is False.
    bonds : bool
        Draw the ripe bond band Fa and the lower end of the unripe bond Fb (eq. 17; values from
        :mod:`berryshaker.reference_study`).

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


# ---- field test ------------------------------------------------------------------------------------
def _level_values(analysis: dict, factors: list[str], level_values: dict | None) -> dict:
    """Factor value per level: the argument, else ``analysis["factors"][f]["values"]`` (``analyze`` with
    known level values), else the virtual L9's ``runs``; factors without known values are left out."""
    if level_values:
        return {f: [float(v) for v in level_values[f]] for f in factors if f in level_values}
    out = {}
    for f, rep in (analysis.get("factors") or {}).items():
        if isinstance(rep, dict) and rep.get("values") is not None and f in factors:
            out[f] = [float(v) for v in rep["values"]]
    if out:
        return out
    runs = analysis.get("runs")
    if runs and all("levels" in r and "clearance_mm" in r for r in runs):
        for f in factors:
            pairs = sorted({(r["levels"][f], r["clearance_mm"][f]) for r in runs if f in r["levels"]})
            if pairs:
                out[f] = [v for _, v in pairs]
    return out


def _standard_errors(analysis: dict, ra: dict, n_levels: int) -> tuple[float | None, str]:
    """Standard error of a level mean, sqrt(MS_error / n_j), from the (pooled) ANOVA error."""
    err = ra.get("anova", {}).get("error", {})
    n_runs = len(analysis.get("composite", {}).get("score", [])) or len(analysis.get("runs", []))
    if not err or not err.get("df") or not n_runs:
        return None, ""
    n_j = n_runs / n_levels
    se = math.sqrt(max(err["ms"], 0.0) / n_j)
    pooled = ra["anova"].get("pooled") or []
    how = (f"error bars: +-1 standard error of a level mean, sqrt(MS_e / {n_j:g}), MS_e from the ANOVA "
           f"error ({err['df']} df" + (f", {', '.join(pooled)} pooled" if pooled else "") + ")")
    return se, how


def plot_main_effects(analysis: dict, path: Path, title: str = "", *, level_values: dict | None = None,
                      factor_unit: str = "mm", response_units: dict | None = None, errors="anova",
                      noise_span: float = 4.0, return_figure: bool = False) -> dict:
    """Main-effect plots: level means of every factor for every response (range analysis), with error
    bars and a y range that does not blow noise up into an effect.

    Parameters
    ----------
    analysis : dict
        Output of :func:`berryshaker.experiment.analysis.analyze` (``responses`` -> ``factors`` ->
        ``level_means``, ``best_level``, ``range``; ``anova``); may carry ``runs`` with ``levels`` and
        ``clearance_mm`` (the virtual L9), from which the level values are taken.
    level_values : dict factor -> list, optional
        Factor value at each level (in ``factor_unit``) for the x axis; default from ``analysis["runs"]``,
        else level numbers.
    response_units : dict response -> unit, optional
        Default :data:`berryshaker.report.style.RESPONSE_UNITS` (efficiency kg/min, unripe %, damage %).
    errors : "anova", None, or dict response -> float | list per level | dict factor -> list
        Error-bar half-widths.  "anova": one standard error of a level mean, sqrt(MS_e / n_j) with the
        pooled-ANOVA error mean square; None: no bars.  Explicit values are drawn as given (say what they
        are in ``title``).
    noise_span : float
        Each row's y range is at least +-``noise_span`` error half-widths about the grand mean, and a
        grey band marks grand mean +-1 half-width: differences inside it are not distinguishable from
        noise.

    Returns
    -------
    dict
        ``responses``: per response the x values, level means, errors and y limits per factor; ``path``.
    """
    response_units = {**RESPONSE_UNITS, **(response_units or {})}
    responses = list(analysis["responses"])
    factors = list(next(iter(analysis["responses"].values()))["factors"])
    lv = _level_values(analysis, factors, level_values)
    fig, axes = new_figure(len(responses), len(factors), figsize=(2.6 * len(factors) + 2.6, 2.5 * len(responses)
                                                                    + 1.0), squeeze=False, sharey="row")
    data = {"responses": {}}
    notes = set()
    for i, r in enumerate(responses):
        ra = analysis["responses"][r]
        unit = response_units.get(r)
        rows = {}
        half = None
        if errors == "anova":
            half, how = _standard_errors(analysis, ra, len(ra["factors"][factors[0]]["level_means"]))
            if how:
                notes.add(how)
        lows, highs, halves = [], [], []
        for j, f in enumerate(factors):
            k = np.asarray(ra["factors"][f]["level_means"], float)
            if isinstance(errors, dict) and r in errors:
                e = errors[r][f] if isinstance(errors[r], dict) else errors[r]
                e = np.broadcast_to(np.asarray(e, float), k.shape)
            elif half is not None:
                e = np.full_like(k, half)
            else:
                e = None
            xs = np.asarray(lv.get(f, np.arange(1, len(k) + 1)), float)
            ax = axes[i, j]
            colour = PAIR_COLOURS.get(f, SERIES_COLOURS[j % len(SERIES_COLOURS)])
            ax.errorbar(xs, k, yerr=e, fmt="o-", color=colour, ms=5, capsize=3, lw=1.3,
                        label="level mean" + (" +- error bar" if e is not None else ""))
            # ring the best level; levels tied with it are ringed too, and a flat factor (R = 0) gets none
            best = ra["factors"][f]["best_level"]
            tie = 1e-9 * max(1.0, float(np.max(np.abs(k))))
            tied = np.flatnonzero(np.abs(k - k[best - 1]) <= tie)
            if len(tied) < len(k):
                ax.plot(xs[tied], k[tied], "o", ls="none", ms=12, mfc="none", mec="#C00000", mew=1.5)
            ax.set_xticks(xs)
            ax.set_xticklabels([f"{v:g}" for v in xs] if f in lv else [str(n) for n in range(1, len(k) + 1)])
            ax.margins(x=0.15)
            ax.grid(alpha=0.3)
            sense = ("; higher is better" if ra.get("maximize", True) else "; lower is better") if j == 0 else ""
            ax.set_title(f"{f}: R = {ra['factors'][f]['range']:.3g}" + (f" {unit}" if unit else "") + sense,
                         fontsize=8)
            if i == len(responses) - 1:
                rep = (analysis.get("factors") or {}).get(f)
                fu = (rep.get("unit") if isinstance(rep, dict) else None) or factor_unit
                ax.set_xlabel(f"{f} [{fu}]" if f in lv else f"{f} level [-]")
            lows.append(np.min(k - (e if e is not None else 0)))
            highs.append(np.max(k + (e if e is not None else 0)))
            if e is not None:
                halves.append(float(np.max(e)))
            rows[f] = {"x": xs, "level_means": k, "errors": None if e is None else np.asarray(e)}
        name = RESPONSE_NAMES.get(r, r)
        axes[i, 0].set_ylabel(require_unit(f"{name} [{unit}]" if unit else name, strict=False))
        lo, hi = min(lows), max(highs)
        mean = float(np.mean(ra["factors"][factors[0]]["level_means"]))
        if halves:
            h = max(halves)
            lo, hi = min(lo, mean - noise_span * h), max(hi, mean + noise_span * h)
            for ax in axes[i]:
                ax.axhspan(mean - h, mean + h, color="#888888", alpha=BAND_ALPHA, lw=0,
                           label="grand mean +- 1 error half-width")
        flat = hi - lo <= 1e-12 * max(1.0, abs(hi))
        # a response that does not change at all (e.g. no unripe fruit shed) gets one display unit of span
        lo, hi = widen_span(lo, hi, rel=0.02, abs_min=1.0 if flat else 1e-12)
        pad = 0.08 * (hi - lo)
        axes[i, 0].set_ylim(lo - pad, hi + pad)
        for ax in axes[i]:
            plain_ticks(ax)
        data["responses"][r] = {"factors": rows, "ylim": axes[i, 0].get_ylim(), "unit": unit}
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = [Line2D([], [], color="#555555", marker="o", ms=5, lw=1.3, label="level mean"
                      + (" +- error bar (see title)" if notes or isinstance(errors, dict) else "")),
               Line2D([], [], ls="none", marker="o", ms=12, mfc="none", mec="#C00000", mew=1.5,
                      label="best level (range analysis)")]
    if any(d["factors"][factors[0]]["errors"] is not None for d in data["responses"].values()):
        handles.append(Patch(color="#888888", alpha=BAND_ALPHA, label="grand mean +- 1 error half-width"))
    legend_outside(axes[0, -1], handles=handles, labels=[h.get_label() for h in handles])
    import textwrap

    note = sorted(notes)[0] if notes else ""  # one explanation of the error bars (they differ only in dof)
    fig.suptitle((title or "Main effects (range analysis)")
                 + ("\n" + "\n".join(textwrap.wrap(note, 150)) if note else ""), fontsize=9)
    return _out(fig, path, data, return_figure, dpi=100)


def plot_response_surfaces(values, y, names, reg, response: str, path: Path, *, unit: str | None = None,
                           factor_unit: str = "mm", margin: float = 0.08, model=None,
                           return_figure: bool = False) -> dict:
    """Response surfaces of the identifiable main-effects quadratic model for factor pairs (study
    Figs. 27-29; the study's full eq. 19 is not identifiable from 9 runs, docs/study.md, eq. 19).

    All panels share one colour scale and one labelled colour bar; the design points are inside the
    axes (the plotted area extends ``margin`` of each factor's span beyond the tested levels).

    Parameters
    ----------
    values : array (runs, factors)
        Factor values of the runs [``factor_unit``].
    y : array (runs,)
        Response per run (not drawn; the model is).
    names : list of str
        Factor names.
    reg : dict
        :func:`berryshaker.experiment.analysis.quadratic_regression` output (with ``_scaling``).
    response : str
        Response name; its unit from ``unit`` or :data:`berryshaker.report.style.RESPONSE_UNITS`.
    model : callable, optional
        ``model(X) -> y`` for X (points, factors) in factor units, instead of the main-effects quadratic
        of ``reg`` (``reg`` may then be None).

    Returns
    -------
    dict
        ``panels`` (factor pair, model min/max), ``vmin``, ``vmax``, ``n_colorbars`` (1), ``path``.
    """
    if model is None:
        from berryshaker.experiment.analysis import predict_main_quadratic

        def model(X):
            return predict_main_quadratic(reg, X, names)

    values = np.asarray(values, float)
    pairs = list(itertools.combinations(range(len(names)), 2))[:6] or [(0, 0)]
    ncols = min(3, len(pairs))
    nrows = -(-len(pairs) // ncols)
    fig, axes = new_figure(nrows, ncols, figsize=(4.0 * ncols + 1.4, 3.6 * nrows + 0.6), squeeze=False)
    mid = np.median(values, axis=0)
    grids = []
    for a, b in pairs:
        spans = []
        for c in (a, b):
            lo, hi = values[:, c].min(), values[:, c].max()
            span = (hi - lo) or max(abs(lo), 1.0) * 0.1
            spans.append(np.linspace(lo - margin * span, hi + margin * span, 50))
        A, B = np.meshgrid(*spans)
        X = np.tile(mid, (A.size, 1))
        X[:, a], X[:, b] = A.ravel(), B.ravel()
        grids.append((A, B, np.asarray(model(X), float).reshape(A.shape)))
    vmin, vmax = widen_span(min(float(g[2].min()) for g in grids), max(float(g[2].max()) for g in grids))
    levels = np.linspace(vmin, vmax, 15)
    data = {"panels": [], "vmin": vmin, "vmax": vmax}
    cs = None
    for ax, (a, b), (A, B, Z) in zip(axes.ravel(), pairs, grids):
        cs = ax.contourf(A, B, np.clip(Z, vmin, vmax), levels=levels, cmap="viridis", vmin=vmin, vmax=vmax)
        ax.scatter(values[:, a], values[:, b], c="w", edgecolors="k", s=28, zorder=3, clip_on=False,
                   label="test runs")
        ax.set_xlim(A.min(), A.max())
        ax.set_ylim(B.min(), B.max())
        label_axes(ax, f"{names[a]} [{factor_unit}]", f"{names[b]} [{factor_unit}]")
        data["panels"].append({"x": names[a], "y": names[b], "z_min": float(Z.min()), "z_max": float(Z.max())})
    for ax in axes.ravel()[len(pairs):]:
        ax.set_visible(False)
    used = list(axes.ravel()[: len(pairs)])
    u = unit or RESPONSE_UNITS.get(response)
    long = RESPONSE_NAMES.get(response, response)
    colour_bar(fig, cs, used, f"{long} [{u}]" if u else long, strict=False)
    data["n_colorbars"] = 1
    fig.suptitle(f"{long}: main-effects quadratic model, other factors at their middle level; "
                 "white dots = test runs (all levels of the other factors)", fontsize=10)
    return _out(fig, path, data, return_figure, dpi=90)


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
    return _out(fig, path, data, return_figure, dpi=100)


#: the three picking indexes against a machine setting, as the vibratory-harvesting literature draws them
HARVEST_RESPONSE_SERIES = {"ripe_removal_pct": ("ripe removal (% of ripe mass)", "#1b7837", "o", "-"),
                           "unripe_shed_pct": ("unripe shedding (% of unripe mass)", "#762a83", "s", "--"),
                           "damage_rate_pct": ("damage rate (% of picked mass)", "#b2182b", "^", ":")}


def plot_harvest_response(x, rows: list[dict], xlabel: str, path: Path, title: str = "", *,
                          frequency_hz=None, amplitude_mm=None, return_figure: bool = False) -> dict:
    """Ripe removal, unripe shedding and damage against one machine setting (e.g. the cam speed).

    Parameters
    ----------
    x : sequence of float
        The swept values (in the unit named in ``xlabel``).
    rows : list of dict
        One :func:`berryshaker.harvest.virtual.harvest_response` per value.
    xlabel : str
        Axis label with unit, e.g. ``"cam speed [rpm]"``.
    frequency_hz : sequence of float, optional
        The shaking frequency of each point: drawn as a second x axis on top (drive speeds only).
    amplitude_mm : sequence of float, optional
        The finger amplitude of each point (:func:`berryshaker.harvest.virtual.shaking_amplitude`): drawn as a
        second x axis on top when it is strictly monotonic in x and no frequency axis is drawn (drive geometry).

    Each index is drawn as its replicate mean with +- one SD bars (the rows' ``<index>_sd``) where present.

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


def write_kinematics_figures(machine, kin, folder: Path) -> list[str]:
    """Kinematics figures of a machine's drive into ``folder`` (comb angles for every drive; SVAJ and the groove
    profile for a groove cam); returns the file names."""
    from berryshaker.drives import drive_of

    d0, e0 = drive_of(machine).mid_stroke_angles(machine)
    if not hasattr(machine, "cam"):
        plot_comb_angles(kin, d0, e0, machine.combs.length, folder / "comb_angles.png")
        return ["comb_angles.png"]
    from berryshaker.drives.groove_cam.kinematics import cam_groove

    plot_svaj(kin, folder / "svaj.png", f"Push-rod SVAJ, {machine.cam.law} law (study eq. 1)")
    _, pitch, inner, outer = cam_groove(machine)
    plot_groove(pitch, inner, outer, machine.cam.base_radius, folder / "groove_profile.png")
    plot_comb_angles(kin, d0, e0, machine.combs.length, folder / "comb_angles.png")
    return ["svaj.png", "groove_profile.png", "comb_angles.png"]


def _place_point_labels(ax, items: list[tuple[float, float, str | None, float]],
                        fontsize: float = 7.0) -> list[tuple[float, float] | None]:
    """Annotate points so that no label covers another label or a marker.

    ``items``: (x, y, text, marker radius in points); text None = a marker to keep clear, not labelled.  Per
    label the first of twelve offsets (beside the corners, the sides, then farther out) with the least overlap
    with the markers and the labels placed before, in display coordinates after the layout is drawn; a label
    set farther out gets a thin leader line.  Returns the chosen offsets (points; None for unlabelled items)."""
    fig = ax.figure
    fig.canvas.draw()  # constrained layout and autoscale settle the transforms
    px = fig.dpi / 72.0
    xy = ax.transData.transform([(x, y) for x, y, _, _ in items]) if items else np.zeros((0, 2))
    boxes = [(X - r * px, Y - r * px, X + r * px, Y + r * px) for (X, Y), (_, _, _, r) in zip(xy, items)]
    frame = ax.get_window_extent()
    chosen = []

    def overlap(b, c):
        return max(0.0, min(b[2], c[2]) - max(b[0], c[0])) * max(0.0, min(b[3], c[3]) - max(b[1], c[1]))

    for (X, Y), (_, _, text, r) in zip(xy, items):
        if text is None:
            chosen.append(None)
            continue
        g = max(r - 3.0, 0.0)  # a larger marker pushes its label out
        w, h = 0.62 * fontsize * len(text) + 2.0, fontsize + 2.0  # points
        offsets = [(5 + g, 4 + g), (5 + g, -4 - g - h), (-5 - g - w, 4 + g), (-5 - g - w, -4 - g - h),
                   (7 + g, -h / 2), (-7 - g - w, -h / 2), (-w / 2, 9 + g), (-w / 2, -9 - g - h),
                   (12 + g, 14 + g), (-12 - g - w, 14 + g), (12 + g, -14 - g - h), (-12 - g - w, -14 - g - h)]
        best, cost = offsets[0], math.inf
        for dx, dy in offsets:
            b = (X + dx * px, Y + dy * px, X + (dx + w) * px, Y + (dy + h) * px)
            c = sum(overlap(b, o) for o in boxes)
            outside = (max(0.0, frame.x0 - b[0]) + max(0.0, b[2] - frame.x1) + max(0.0, frame.y0 - b[1])
                       + max(0.0, b[3] - frame.y1))
            c += 1e3 * outside
            if c < cost - 1e-9:
                best, cost = (dx, dy), c
        dx, dy = best
        boxes.append((X + dx * px, Y + dy * px, X + (dx + w) * px, Y + (dy + h) * px))
        chosen.append(best)
    for (x, y, text, _), off in zip(items, chosen):
        if off is None:
            continue
        dx, dy = off
        far = abs(dx) > 10 and abs(dy) > 10
        ax.annotate(text, (x, y), textcoords="offset points", xytext=(dx, dy), fontsize=fontsize, ha="left",
                    va="bottom", arrowprops={"arrowstyle": "-", "lw": 0.5, "color": "#777777"} if far else None)
    return chosen


def plot_tradeoff(records: list[dict], path: Path, title: str = "", *, return_figure: bool = False) -> dict:
    """Trade-off of the candidate clearance sets: picking efficiency (mean and 95 % interval) against the
    largest peak collision force over the joints and against the peak drive torque (means and intervals).

    Parameters
    ----------
    records : list of dict
        Rows of :func:`berryshaker.study.l9.tradeoff_records` (``efficiency``, ``efficiency_lo``/``_hi``,
        ``peak_force_N:<joint>`` with ``_lo``/``_hi``, ``drive_torque_peak_Nm``, ``dominated``, ``name``).
        Filled markers: not dominated beyond noise; open: dominated; a star: the recommended candidate (its
        name contains "recommended").  Force panel: colour of the joint with the largest peak force; torque
        panel: one colour.  Labels are placed clear of the markers and of each other.

    Returns
    -------
    dict
        ``points``: per candidate the x/y values drawn in each panel; ``label_offsets`` (points, per panel);
        ``path``.
    """
    forces = sorted({k for r in records for k in r if k.startswith("peak_force_N:")
                     and not k.endswith(("_lo", "_hi", "_noise"))})
    panels = [("largest peak collision force [N]", "force")]
    if all("drive_torque_peak_Nm" in r for r in records):
        panels.append(("peak drive torque [N m]", "torque"))
    torque_colour = SERIES_COLOURS[4]
    fig, axes = new_figure(1, len(panels), figsize=(5.2 * len(panels) + 1.8, 4.2), squeeze=False, sharey="row")
    data = {"points": []}
    labels = [[] for _ in panels]
    rec_name, used = None, set()
    for rec in records:
        y = rec["efficiency"]
        yerr = [[y - rec.get("efficiency_lo", y)], [rec.get("efficiency_hi", y) - y]]
        label = rec["name"].split(" (")[0]
        is_rec = "recommended" in rec["name"]
        if is_rec:
            rec_name = rec["name"].replace(", recommended", "")
            if rec_name.startswith("recommended ("):  # "recommended (A1B1C1F3)" -> "A1B1C1F3"
                rec_name = rec_name[len("recommended ("):].rstrip(")")
        point = {"name": rec["name"], "efficiency": y}
        for j, (_, kind) in enumerate(panels):
            key = max(forces, key=lambda k: rec[k]) if kind == "force" else "drive_torque_peak_Nm"
            used.add(key)
            x = rec[key]
            xerr = [[x - rec.get(f"{key}_lo", x)], [rec.get(f"{key}_hi", x) - x]]
            colour = PAIR_COLOURS.get(key.split(":")[-1], SERIES_COLOURS[0]) if kind == "force" else torque_colour
            ax = axes[0, j]
            ax.errorbar([x], [y], xerr=xerr, yerr=yerr, fmt="*" if is_rec else "o", ms=13 if is_rec else 6, capsize=3,
                        color=colour, mfc="white" if rec.get("dominated") else colour,
                        mec="black" if is_rec else colour, zorder=4 if is_rec else 3)
            # an L9 run keeps its run label; an extra recommended set is the star of the legend, unlabelled
            labels[j].append((x, y, None if (is_rec and label == "recommended") else label, 6.5 if is_rec else 3.5))
            point[kind] = {"column": key, "x": x}
        data["points"].append(point)
    for j, (xl, kind) in enumerate(panels):
        ax = axes[0, j]
        ax.grid(alpha=0.3)
        label_axes(ax, xl, "picking efficiency [kg/min]" if j == 0 else None)
        plain_ticks(ax)
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], ls="none", marker="o", color="#555555", label="not dominated beyond noise"),
               Line2D([], [], ls="none", marker="o", color="#555555", mfc="white", label="dominated beyond noise"),
               Line2D([], [], color="#555555", label="95 % interval of the replicate mean")]
    if rec_name is not None:
        handles.append(Line2D([], [], ls="none", marker="*", ms=11, color="#555555", mec="black",
                              label=f"recommended: {rec_name}"))
    handles += [Line2D([], [], ls="none", marker="o", color=PAIR_COLOURS.get(k.split(":")[-1], SERIES_COLOURS[0]),
                       label=f"left: largest force at joint {k.split(':')[-1]}") for k in forces if k in used]
    if len(panels) > 1:
        handles.append(Line2D([], [], ls="none", marker="o", color=torque_colour, label="right: peak drive torque"))
    legend_outside(axes[0, -1], handles=handles, labels=[h.get_label() for h in handles])
    fig.suptitle(title or "Trade-off of the candidate clearance sets (star = recommended)", fontsize=9)
    data["label_offsets"] = [_place_point_labels(axes[0, j], labels[j]) for j in range(len(panels))]
    return _out(fig, path, data, return_figure, dpi=100)


def plot_replicated_effects(rep: dict, responses: list[str], path: Path, title: str = "", *,
                            level_values: dict | None = None, units: dict | None = None,
                            return_figure: bool = False) -> dict:
    """Main effects of a replicated test with 95 % intervals of the level means (pure error, t with its dof).

    ``rep``: :func:`berryshaker.experiment.replicates.analyze_replicated` output; ``responses``: which rows to
    draw.  Drawn by :func:`plot_main_effects` with the interval half-widths as error bars (the grey band is
    grand mean +- one half-width: level means inside it do not differ from the average beyond noise).
    """
    sub = {"responses": {n: rep["responses"][n] for n in responses if n in rep["responses"]},
           "factors": rep.get("factors", {})}
    errors = {n: {f: [(hi - lo) / 2 for lo, hi in d["level_ci"]] for f, d in ra["factors"].items()}
              for n, ra in sub["responses"].items()}
    conf = 100 * rep.get("confidence", 0.95)
    return plot_main_effects(sub, path, (title or "Main effects") + f" (error bars: {conf:g} % interval of the level "
                             f"mean from the pure error, {rep['runs']} runs x {rep['replicates']} replicates)",
                             level_values=level_values, response_units=units, errors=errors,
                             return_figure=return_figure)
