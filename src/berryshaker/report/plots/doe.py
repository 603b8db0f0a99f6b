"""Figures of the field test and the virtual L9: main effects (range analysis) with error bars, response surfaces
(Figs. 27-29), the trade-off of the candidate clearance sets and the replicated main effects."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np

from berryshaker.report.plots.figure_files import _out
from berryshaker.report.style import (
    BAND_ALPHA,
    PAIR_COLOURS,
    SERIES_COLOURS,
    colour_bar,
    label_axes,
    legend_outside,
    new_figure,
    plain_ticks,
    require_unit,
    response_names,
    widen_span,
)
from berryshaker.report.style import response_units as table_units


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
        Default :func:`berryshaker.report.style.response_units` (efficiency kg/min, unripe %, damage %).
    errors : "anova", None, or dict response -> float | list per level | dict factor -> list
        Error-bar half-widths (same units as the response).  "anova": one standard error of a level mean, sqrt(MS_e / n_j) with the
        pooled-ANOVA error mean square; None: no bars.  Explicit values are drawn as given (say what they
        are in ``title``).
    noise_span : float
        Each row's y range is at least +-``noise_span`` error half-widths (1) about the grand mean, and a
        grey band marks grand mean +-1 half-width: differences inside it are not distinguishable from
        noise.
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    title : str
        Figure title (a default when empty).
    factor_unit : str
        Unit of the factors' values when the analysis gives none.
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        ``responses``: per response the x values, level means, errors and y limits per factor; ``path``.
    """
    response_units = {**table_units(), **(response_units or {})}
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
        name = response_names().get(r, r)
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
    return _out(fig, path, data, return_figure)


def _unit_of(factor_unit, name: str) -> str:
    """The unit of factor ``name``: ``factor_unit`` itself, or its entry when it is a dict per factor ('-' if none)."""
    return factor_unit if isinstance(factor_unit, str) else (factor_unit.get(name) or "-")


def plot_response_surfaces(values, y, names, reg, response: str, path: Path, *, unit: str | None = None,
                           factor_unit: str | dict[str, str] = "mm", margin: float = 0.08, model=None,
                           return_figure: bool = False) -> dict:
    """Response surfaces of the identifiable main-effects quadratic model for factor pairs (study
    Figs. 27-29; the study's full eq. 19 is not identifiable from 9 runs, docs/study.md, eq. 19).

    All panels share one colour scale and one labelled colour bar; the design points are inside the
    axes (the plotted area extends ``margin`` of each factor's span beyond the tested levels).

    Parameters
    ----------
    values : array (runs, factors)
        Factor values of the runs (their units: ``factor_unit``, one for all, or a dict factor -> unit).
    y : array (runs,)
        Response per run (its units; not drawn, the model is).
    names : list of str
        Factor names.
    reg : dict
        :func:`berryshaker.experiment.analysis.quadratic_regression` output (with ``_scaling``).
    response : str
        Response name; its unit from ``unit`` or :func:`berryshaker.report.style.response_units`.
    model : callable, optional
        ``model(X) -> y`` for X (points, factors) in factor units, instead of the main-effects quadratic
        of ``reg`` (``reg`` may then be None).
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    unit : str, optional
        Unit of the response.
    factor_unit : str or dict factor -> str
        Unit of the factors' values.
    margin : float
        Share of each factor's span drawn beyond the tested levels (1).
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

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
        label_axes(ax, f"{names[a]} [{_unit_of(factor_unit, names[a])}]", f"{names[b]} [{_unit_of(factor_unit, names[b])}]")
        data["panels"].append({"x": names[a], "y": names[b], "z_min": float(Z.min()), "z_max": float(Z.max())})
    for ax in axes.ravel()[len(pairs):]:
        ax.set_visible(False)
    used = list(axes.ravel()[: len(pairs)])
    u = unit or table_units().get(response)
    long = response_names().get(response, response)
    colour_bar(fig, cs, used, f"{long} [{u}]" if u else long, strict=False)
    data["n_colorbars"] = 1
    fig.suptitle(f"{long}: main-effects quadratic model, other factors at their middle level; "
                 "white dots = test runs (all levels of the other factors)", fontsize=10)
    return _out(fig, path, data, return_figure)


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
    largest peak collision force over the joints and against the design drive torque (p95 of the per-revolution peaks; means and intervals).

    Parameters
    ----------
    records : list of dict
        Rows of :func:`berryshaker.study.l9.tradeoff_records` (``efficiency``, ``efficiency_lo``/``_hi``,
        ``design_force_N:<joint>`` (or ``peak_force_N:<joint>``) with ``_lo``/``_hi``, ``drive_torque_design_Nm``,
        ``dominated``, ``name``).
        Filled markers: not dominated beyond noise; open: dominated; a star: the recommended candidate (its
        name contains "recommended").  Force panel: colour of the joint with the largest peak force; torque
        panel: one colour.  Labels are placed clear of the markers and of each other.
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    title : str
        Figure title (a default when empty).
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        ``points``: per candidate the x/y values drawn in each panel; ``label_offsets`` (points, per panel);
        ``path``.
    """
    forces = sorted({k for r in records for k in r if k.startswith(("design_force_N:", "peak_force_N:"))
                     and not k.endswith(("_lo", "_hi", "_noise"))})
    panels = [("largest static-equivalent collision force [N]" if any(k.startswith("design_force_N:") for k in forces)
               else "largest peak collision force [N]", "force")]
    if all("drive_torque_design_Nm" in r for r in records):
        panels.append(("design drive torque (p95 of the per-revolution peaks) [N m]", "torque"))
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
            key = max(forces, key=lambda k: rec[k]) if kind == "force" else "drive_torque_design_Nm"
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
        handles.append(Line2D([], [], ls="none", marker="o", color=torque_colour, label="right: design drive torque"))
    legend_outside(axes[0, -1], handles=handles, labels=[h.get_label() for h in handles])
    fig.suptitle(title or "Trade-off of the candidate clearance sets (star = recommended)", fontsize=9)
    data["label_offsets"] = [_place_point_labels(axes[0, j], labels[j]) for j in range(len(panels))]
    return _out(fig, path, data, return_figure)


def plot_replicated_effects(rep: dict, responses: list[str], path: Path, title: str = "", *,
                            level_values: dict | None = None, units: dict | None = None,
                            return_figure: bool = False) -> dict:
    """Main effects of a replicated test with 95 % intervals of the level means (the analysis' error: pure, or with
    blocks the run x block interaction; t with its dof).

    ``rep``: :func:`berryshaker.experiment.replicates.analyze_replicated` output; ``responses``: which rows to
    draw.  Drawn by :func:`plot_main_effects` with the interval half-widths as error bars (the grey band is
    grand mean +- one half-width: level means inside it do not differ from the average beyond noise).

    Parameters
    ----------
    rep : dict
        The replicated analysis.
    responses : list of str
        Responses drawn, one row each.
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    title : str
        Figure title (a default when empty).
    level_values : dict factor -> list of float, optional
        Level values (their units: the factors').
    units : dict response -> str, optional
        Unit per response.
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        What :func:`plot_main_effects` drew.
    """
    sub = {"responses": {n: rep["responses"][n] for n in responses if n in rep["responses"]},
           "factors": rep.get("factors", {})}
    errors = {n: {f: [(hi - lo) / 2 for lo, hi in d["level_ci"]] for f, d in ra["factors"].items()}
              for n, ra in sub["responses"].items()}
    conf = 100 * rep.get("confidence", 0.95)
    error = "the run x block error, for comparing levels" if rep.get("blocks") else "the pure error"
    return plot_main_effects(sub, path, (title or "Main effects") + f" (error bars: {conf:g} % interval of the level "
                             f"mean from {error}, {rep['runs']} runs x {rep['replicates']} replicates)",
                             level_values=level_values, response_units=units, errors=errors,
                             return_figure=return_figure)
