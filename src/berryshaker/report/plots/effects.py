"""Effect figures of an orthogonal test as Minitab draws them: the Pareto chart of standardized effects, the four-in-one
residual plots (normal probability plot, residuals against fitted values, histogram, residuals against the order) and
the interaction plots; drawn for ``doe analyze``
and the study's virtual L9 from :mod:`berryshaker.experiment.analysis` (standardized_effects,
main_effect_residuals, interaction_means), whose tables they draw.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from berryshaker.report.plots.figure_files import _out
from berryshaker.report.style import (
    LEVEL_COLOURS,
    SERIES_COLOURS,
    label_axes,
    legend_outside,
    new_figure,
    response_names,
    response_units,
)
from berryshaker.user_text import file_part

_LEVEL_LINES = (LEVEL_COLOURS["level 1"], LEVEL_COLOURS["level 2"], LEVEL_COLOURS["level 3"], *SERIES_COLOURS[4:])
_LEVEL_MARKERS = ("o", "s", "^", "D", "v", "P")


def _unit_label(quantity: str, unit: str | None) -> str:
    return f"{quantity} [{unit}]" if unit else f"{quantity} [-]"


def plot_pareto_effects(effects: dict, path: Path, title: str = "", *, return_figure: bool = False) -> dict:
    """Pareto chart of standardized effects: |t| of every contrast, largest on top, with the reference line
    t(1 - alpha/2, df) of the error; bars beyond it are significant (darker).

    Parameters
    ----------
    effects : dict
        :func:`berryshaker.experiment.analysis.standardized_effects` output.
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    title : str
        Figure title (a default when empty).
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        ``terms`` (top to bottom), ``values`` (|t| drawn), ``significant``, ``critical_t``; ``path``, ``svg``.
    """
    terms = sorted(effects["terms"], key=lambda r: abs(r["t"]), reverse=True)
    vals = np.array([abs(r["t"]) for r in terms], float)
    finite = vals[np.isfinite(vals)]
    top = float(max(finite.max() if finite.size else 0.0, effects["critical_t"]))
    drawn = np.where(np.isfinite(vals), vals, 1.05 * top)  # an exact effect (zero error) is drawn at the edge
    fig, ax = new_figure(figsize=(7.5, 0.32 * len(terms) + 1.8))
    y = np.arange(len(terms))[::-1]
    colours = [SERIES_COLOURS[0] if r["significant"] else "#9ECAE1" for r in terms]
    ax.barh(y, drawn, color=colours, edgecolor="#333333", linewidth=0.6)
    ax.set_yticks(y, [r["term"] for r in terms], fontsize=8)
    crit = effects["critical_t"]
    err = effects["error"]
    ax.axvline(crit, color="#C00000", ls="--", lw=1.2,
               label=f"t = {crit:.3g} (alpha = {effects['alpha']:g}, {err['df']} df, {err['method']})")
    label_axes(ax, xlabel="standardized effect |t| [-]")
    ax.set_ylabel("term [-]")
    ax.grid(alpha=0.3, axis="x")
    ax.set_title(title or "Pareto chart of the standardized effects", fontsize=10)
    from matplotlib.patches import Patch

    handles = [ax.get_lines()[0], Patch(color=SERIES_COLOURS[0], label="significant"),
               Patch(color="#9ECAE1", label="not significant")]
    legend_outside(ax, where="below", handles=handles, labels=[h.get_label() for h in handles], ncol=1)
    return _out(fig, path, {"terms": [r["term"] for r in terms], "values": vals,
                            "significant": [r["significant"] for r in terms], "critical_t": crit}, return_figure)


def plot_residuals(resid: dict, path: Path, title: str = "", *, unit: str | None = None, order=None,
                   order_label: str = "", return_figure: bool = False) -> dict:
    """Minitab's four-in-one residual plots of the main-effects model: normal probability plot of the residuals
    (with the line through their quartiles), residuals against fitted values, their histogram and residuals against
    the observation order (a drift over the test days shows there).

    Parameters
    ----------
    resid : dict
        :func:`berryshaker.experiment.analysis.main_effect_residuals` output.
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    title : str
        Figure title (a default when empty).
    unit : str, optional
        Unit of the response (and so of residuals and fitted values).
    order : array_like, optional
        The test order of each residual (a field sheet's ``order`` column); default the observations' order (run by
        run).
    order_label : str
        What ``order`` is, for the x axis (default "test order" with ``order``, else "observation (run by run)").
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        ``fitted``, ``residuals``, ``normal_quantiles``, ``sorted_residuals``, ``histogram`` (counts, edges) and
        ``order`` as drawn; ``path``, ``svg``.
    """
    fig, axes = new_figure(2, 2, figsize=(9.5, 7.2))
    (axn, axf), (axh, axo) = axes
    q, s = np.asarray(resid["normal_quantiles"]), np.asarray(resid["sorted_residuals"])
    axn.plot(s, q, "o", ms=4, color=SERIES_COLOURS[0])
    q1, q3 = np.percentile(s, [25, 75])
    if q3 > q1:  # the normal line through the quartiles (z = -0.674, 0.674)
        z = 0.6744897501960817
        xs = np.array([s.min(), s.max()])
        axn.plot(xs, -z + (xs - q1) * 2 * z / (q3 - q1), color="#C00000", lw=1)
    label_axes(axn, _unit_label("residual", unit), "normal quantile [-]")
    axn.set_title("Normal probability plot (red: the normal line through the quartiles)", fontsize=8)
    axn.grid(alpha=0.3)
    f, r = np.asarray(resid["fitted"]), np.asarray(resid["residuals"])
    axf.plot(f, r, "o", ms=4, color=SERIES_COLOURS[0])
    axf.axhline(0.0, color="#555555", lw=0.8)
    label_axes(axf, _unit_label("fitted value", unit), _unit_label("residual", unit))
    axf.set_title("Residuals against fitted values", fontsize=9)
    axf.grid(alpha=0.3)
    bins = int(np.clip(np.ceil(np.sqrt(len(r))), 3, 20))  # the square-root rule, as Minitab's default bins
    counts, edges, _ = axh.hist(r, bins=bins, color=SERIES_COLOURS[0], edgecolor="#333333", linewidth=0.6)
    label_axes(axh, _unit_label("residual", unit), "count [-]")
    axh.set_title("Histogram of the residuals", fontsize=9)
    axh.grid(alpha=0.3, axis="y")
    x = np.arange(1, len(r) + 1, dtype=float) if order is None else np.asarray(order, float)
    idx = np.argsort(x, kind="stable")
    axo.plot(x[idx], r[idx], "o-", ms=4, lw=0.8, color=SERIES_COLOURS[0])
    axo.axhline(0.0, color="#555555", lw=0.8)
    label_axes(axo, order_label or ("test order [-]" if order is not None else "observation (run by run) [-]"),
               _unit_label("residual", unit))
    axo.set_title("Residuals against the order", fontsize=9)
    axo.grid(alpha=0.3)
    fig.suptitle(title or "Residual plots", fontsize=10)
    return _out(fig, path, {"fitted": f, "residuals": r, "normal_quantiles": q, "sorted_residuals": s,
                            "histogram": (counts, edges), "order": x}, return_figure)


def plot_interactions(cells: dict, path: Path, title: str = "", *, unit: str | None = None,
                      level_values: dict | None = None, factor_units: dict | None = None,
                      return_figure: bool = False) -> dict:
    """Interaction plots: for every pair of factors the mean response at each level of the first (x axis), one line
    per level of the second; parallel lines mean no interaction.

    Parameters
    ----------
    cells : dict
        :func:`berryshaker.experiment.analysis.interaction_means` output.
    unit : str, optional
        Unit of the response.
    level_values, factor_units : dict, optional
        Factor value per level and unit per factor for the x axes and the line labels (default level numbers).
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    title : str
        Figure title (a default when empty).
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        ``pairs``: per pair the drawn x values and the means (levels of the first x levels of the second);
        ``path``, ``svg``.
    """
    level_values, factor_units = level_values or {}, factor_units or {}
    names = list(cells)
    ncols = min(3, len(names)) or 1
    nrows = max(1, math.ceil(len(names) / ncols))
    fig, axes = new_figure(nrows, ncols, figsize=(3.3 * ncols + 1.6, 2.8 * nrows + 0.9), squeeze=False,
                           sharey=True)
    data: dict[str, dict] = {"pairs": {}}
    nlines = 0

    def shown(f, k):
        vals = level_values.get(f)
        u = factor_units.get(f) or ""
        return f"{vals[k - 1]:g}{(' ' + u) if u else ''}" if vals is not None else f"level {k}"

    for ax, name in zip(axes.ravel(), names):
        c = cells[name]
        fa, fb = c["factors"]
        ka, kb = c["levels"]
        xs = np.asarray([level_values[fa][k - 1] for k in ka] if fa in level_values and level_values[fa] is not None
                        else ka, float)
        m = np.asarray(c["means"], float)
        for b_, k in enumerate(kb):
            ax.plot(xs, m[:, b_], marker=_LEVEL_MARKERS[b_ % len(_LEVEL_MARKERS)], ms=4, lw=1.2,
                    color=_LEVEL_LINES[b_ % len(_LEVEL_LINES)], label=f"{fb} = {shown(fb, k)}")
        nlines = max(nlines, len(kb))
        ax.set_xticks(xs, [f"{v:g}" for v in xs])
        ax.margins(x=0.12)
        fu = factor_units.get(fa) if fa in level_values and level_values[fa] is not None else None
        label_axes(ax, f"{fa} [{fu}]" if fu else f"{fa} level [-]")
        ax.set_title(f"{fa} x {fb} (lines: {fb} levels)", fontsize=8)
        ax.grid(alpha=0.3)
        data["pairs"][name] = {"x": xs, "means": m}
    for ax in axes.ravel()[len(names):]:
        ax.set_visible(False)
    for row in axes:
        label_axes(row[0], ylabel=_unit_label("mean response", unit))
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color=_LEVEL_LINES[i % len(_LEVEL_LINES)], marker=_LEVEL_MARKERS[i % len(_LEVEL_MARKERS)],
                      ms=4, label=f"second factor at its level {i + 1}") for i in range(nlines)]
    legend_outside(axes[0, ncols - 1], handles=handles, labels=[h.get_label() for h in handles])
    fig.suptitle(title or "Interaction plots (means of the observations at each pair of levels)", fontsize=10)
    return _out(fig, path, data, return_figure)


def write_effect_figures(levels, observations: dict, factor_names: list[str], analysis: dict, folder: Path,
                         prefix: str = "", *, units: dict | None = None, level_values: dict | None = None,
                         factor_units: dict | None = None, blocks: bool = False, order=None) -> list[str]:
    """Pareto chart of standardized effects, residual plots and interaction plots of every response; a response
    with lost plots (NaN) is drawn from the least-squares model of its analysis
    (:mod:`berryshaker.experiment.unbalanced`).

    Parameters
    ----------
    levels : array (runs, factors)
        1-based level numbers (1).
    observations : dict response -> array (runs,) or (runs, replicates)
        The observations the analysis was made of (each in its response's unit, ``units``).
    factor_names : list of str
        Names of the factors, one per column of ``levels``.
    analysis : dict
        :func:`berryshaker.experiment.analysis.analyze` or
        :func:`berryshaker.experiment.replicates.analyze_replicated` output: each response's ANOVA error (and
        pooled factors) is the error of the effects and the model of the residuals.
    folder, prefix : Path, str
        Files ``<prefix>pareto_<response>.png``, ``<prefix>residuals_<response>.png``,
        ``<prefix>interactions_<response>.png`` (SVG beside each).
    units : dict response -> unit, optional
        Default :func:`berryshaker.report.style.response_units`.
    level_values, factor_units : dict, optional
        Level values (the factor's units) and unit per factor, for the interaction plots' axes.
    blocks : bool
        Replicate k of every run in block k: the residuals' model has the block effects (as the analysis).
    order : array_like (runs,) or (runs, replicates), optional
        The test order of each observation (a field sheet's ``order`` column), for the residuals against the order.

    Returns
    -------
    list of str
        The PNG file names written.
    """
    from berryshaker.experiment.analysis import interaction_means, main_effect_residuals, standardized_effects
    from berryshaker.experiment.unbalanced import residuals_unbalanced, standardized_effects_unbalanced

    units = {**response_units(), **(units or {})}
    names = []
    for name, y in observations.items():
        ra = (analysis.get("responses") or {}).get(name)
        if ra is None:
            continue
        an = ra.get("anova") or {}
        err = an.get("error") or {}
        long = response_names().get(name, name)
        lost = np.ndim(y) == 2 and not np.isfinite(y).all()  # lost plots: the least-squares model of the analysis
        if lost:
            eff = standardized_effects_unbalanced(levels, y, factor_names, analysis.get("alpha", 0.05))
        else:
            own = {f: (e["error"]["ms"], e["error"]["df"]) for f, e in (an.get("factors") or {}).items()
                   if isinstance(e, dict) and e.get("error")}
            eff = standardized_effects(levels, y, factor_names, err.get("ms"), err.get("df"),
                                       analysis.get("alpha", 0.05), factor_errors=own or None)
        n = f"{prefix}pareto_{file_part(name)}.png"
        plot_pareto_effects(eff, Path(folder) / n, f"{long}: Pareto chart of the standardized effects")
        names.append(n)
        pooled = set(an.get("pooled") or [])
        if lost:
            res = residuals_unbalanced(levels, y)
        else:
            res = main_effect_residuals(levels, y, factor_names, [f for f in factor_names if f not in pooled],
                                        blocks=blocks and np.ndim(y) == 2)
        n = f"{prefix}residuals_{file_part(name)}.png"
        seq = None
        if order is not None:  # the test order of each observation, run by run, the lost ones left out
            o = np.asarray(order, float).reshape(np.shape(y))
            seq = o.reshape(-1)[np.isfinite(np.asarray(y, float)).reshape(-1)]
            seq = seq if np.isfinite(seq).all() else None
        plot_residuals(res, Path(folder) / n, f"{long}: residuals of the main-effects model"
                       + (f" ({', '.join(sorted(pooled))} pooled)" if pooled else ""), unit=units.get(name),
                       order=seq)
        names.append(n)
        if len(factor_names) >= 2:
            n = f"{prefix}interactions_{file_part(name)}.png"
            plot_interactions(interaction_means(levels, y, factor_names), Path(folder) / n,
                              f"{long}: interaction plots", unit=units.get(name), level_values=level_values,
                              factor_units=factor_units)
            names.append(n)
    return names


def observation_order(fr) -> np.ndarray | None:
    """The test order of every observation of a field sheet, (runs,) or (runs, replicates) as its observations (NaN
    where a plot was lost), from the sheet's ``order`` column; None without one.

    Parameters
    ----------
    fr : FieldResults
        The sheet as read.

    Returns
    -------
    ndarray or None
        The order (dimensionless).
    """
    t = fr.table
    if "order" not in t.columns or not np.issubdtype(t["order"].dtype, np.number):
        return None
    n = len(fr.levels)
    r = fr.replicates if fr.responses_replicated is not None else 1
    out = np.full((n, r), np.nan)
    rep = t["replicate"].to_numpy(int) if "replicate" in t.columns and r > 1 else np.ones(len(t), int)
    out[t["run"].to_numpy(int) - 1, rep - 1] = t["order"].to_numpy(float)
    return out if r > 1 else out[:, 0]


def write_doe_figures(fr, res, folder: Path) -> list[str]:
    """Every figure of ``doe analyze --plot`` into ``folder``: main effects (with 95 % intervals when replicated),
    response surfaces (two factors or more), and per response the Pareto chart of standardized effects, residual
    plots and interaction plots; axes in the sheet's units (factors and responses).

    Parameters
    ----------
    fr : FieldResults
        The sheet as read (:func:`berryshaker.experiment.field_results.read_results`).
    res : DoeAnalysis or SheetReplicatedAnalysis
        Its analysis (:func:`berryshaker.experiment.field_results.analyze_sheet`); the figures read its JSON form
        (:meth:`~berryshaker.records.JsonRecord.to_json`), as they read the study's L9 from summary.json's.
    folder : Path
        Where the figures go.

    Returns
    -------
    list of str
        The PNG file names written (an SVG beside each).
    """
    from berryshaker.experiment.analysis import quadratic_regression
    from berryshaker.report.plots.doe import plot_main_effects, plot_replicated_effects, plot_response_surfaces

    folder = Path(folder)
    res = res.to_json()
    units = {**response_units(), **(getattr(fr, "response_units", None) or {})}
    known = {f: v for f, v in fr.level_values.items() if v is not None}
    if fr.replicates >= 2:  # error bars: 95 % intervals from the replicate (blocked) error
        plot_replicated_effects(res, list(res["responses"]), folder / "main_effects.png", level_values=known or None,
                                units=units)
    else:
        plot_main_effects(res, folder / "main_effects.png", level_values=known or None, factor_unit="-",
                          response_units=units)
    names = ["main_effects.png"]
    if len(fr.factor_names) >= 2:
        fu = {f: (fr.units.get(f) or "-") if f in known else "-" for f in fr.factor_names}
        for r, y in fr.responses.items():
            if fr.replicates >= 2:  # the analysis' run means (least-squares means where plots were lost)
                y = np.asarray(res["responses"][r]["run_means"], float)
            plot_response_surfaces(fr.values, y, fr.factor_names, quadratic_regression(fr.values, y, fr.factor_names),
                                   r, folder / f"surface_{file_part(r)}.png", unit=units.get(r) or None,
                                   factor_unit=fu)
            names.append(f"surface_{file_part(r)}.png")
    obs = fr.responses_replicated if fr.replicates >= 2 else fr.responses
    names += write_effect_figures(fr.levels, obs, fr.factor_names, res, folder, units=units, level_values=known,
                                  factor_units=fr.units, blocks=fr.replicates >= 2, order=observation_order(fr))
    return names
