"""Figures of the clearance life (docs/life.md): clearance growth by wear against operating hours, Sobol sensitivity
indices, and the Pareto front of fit choices.  Drawn by ``berryshaker wear|sensitivity|tolerance --plot`` and the
study's clearance-life step."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from berryshaker.report.plots.figure_files import _out
from berryshaker.report.style import (
    PAIR_COLOURS,
    SERIES_COLOURS,
    colour_bar,
    label_axes,
    legend_outside,
    new_figure,
)


def plot_clearance_growth(growth: dict, limits_mm: dict, path: Path, title: str = "", *,
                          labels: dict | None = None, markers: bool = False, return_figure: bool = False) -> dict:
    """Clearance of each joint against operating hours, with its service limit as a dotted line of its colour.

    Parameters
    ----------
    growth : dict joint -> {"hours": [h], "clearance_mm": [mm]}
        Operating hours [h] and clearance [mm] per joint.
    limits_mm : dict joint -> float or None
        Service limit [mm] per joint (None or missing: no line).
    labels : dict joint -> str, optional
        Legend text per joint (default the joint's name).
    markers : bool
        Mark each computed state (``wear`` re-simulates at each).
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    title : str
        Figure title (a default when empty).
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        ``series``: per joint the drawn hours and clearance; ``limits``: the drawn limits [mm]; ``path``, ``svg``.
    """
    fig, ax = new_figure(figsize=(7.5, 4.5))
    data: dict[str, dict] = {"series": {}, "limits": {}}
    for i, (j, d) in enumerate(growth.items()):
        colour = PAIR_COLOURS.get(j, SERIES_COLOURS[i % len(SERIES_COLOURS)])
        h, c = np.asarray(d["hours"], float), np.asarray(d["clearance_mm"], float)
        ax.plot(h, c, marker="." if markers else None, color=colour, label=(labels or {}).get(j, j))
        data["series"][j] = {"hours": h, "clearance_mm": c}
        lim = limits_mm.get(j)
        if lim is not None:
            ax.axhline(lim, color=colour, ls=":", lw=1)
            data["limits"][j] = float(lim)
    label_axes(ax, "operating hours [h]", "clearance [mm]")
    ax.grid(alpha=0.3)
    ax.set_title(title or "Clearance growth by wear (dotted: service limits)", fontsize=10)
    legend_outside(ax)
    return _out(fig, path, data, return_figure)


def plot_sobol(indices: dict, output: str, path: Path, *, return_figure: bool = False) -> dict:
    """First-order and total Sobol indices of one output with their 95 % confidence half-widths.

    Parameters
    ----------
    indices : dict parameter -> {"S1", "S1_conf", "ST", "ST_conf"}
        Indices (share of the output's variance [-]); a None index is drawn as 0.
    output : str
        Name of the output (title).
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        ``bars``: {"S1": [...], "ST": [...]} in parameter order, ``errors`` likewise, ``parameters``; ``path``.
    """
    keys = list(indices)
    x = np.arange(len(keys))
    fig, ax = new_figure(figsize=(max(4.5, 1.3 * len(keys) + 2.5), 4.2))
    data: dict = {"parameters": keys, "bars": {}, "errors": {}}
    for off, (s, lab), colour in zip((-0.2, 0.2), (("S1", "first order S1"), ("ST", "total ST")), SERIES_COLOURS):
        v = [indices[k][s] if indices[k][s] is not None else 0.0 for k in keys]
        e = [indices[k][s + "_conf"] if indices[k][s + "_conf"] is not None else 0.0 for k in keys]
        ax.bar(x + off, v, 0.4, yerr=e, capsize=3, label=lab, color=colour)
        data["bars"][s], data["errors"][s] = v, e
    ax.set_xticks(x, keys, rotation=20, ha="right")
    label_axes(ax, ylabel="Sobol index (share of variance) [-]")
    ax.set_title(f"Sensitivity of {output} (95 % CI)", fontsize=10)
    ax.grid(alpha=0.3, axis="y")
    legend_outside(ax)
    return _out(fig, path, data, return_figure)


def sobol_file_name(output: str) -> str:
    """File name of an output's Sobol figure: ``sobol_<output>.png`` with anything but letters, digits and '_' as
    '_'.

    Parameters
    ----------
    output : str
        Output name.

    Returns
    -------
    str
        The file name.
    """
    return f"sobol_{re.sub(r'[^A-Za-z0-9_]+', '_', output)}.png"


def plot_fit_front(front: list[dict], recommended: dict, path: Path, *, return_figure: bool = False) -> dict:
    """Pareto front of fit choices: manufacturing cost against static-equivalent collision force, coloured by the maintenance
    interval, the recommended choice ringed.

    Parameters
    ----------
    front : list of {"cost", "design_force_N", "life_h"}
        Non-dominated fit choices (cost in relative units [-], force [N], interval [h]).
    recommended : dict
        ``cost``, ``design_force_N`` and ``fits`` (joint -> ISO 286 fit) of the chosen compromise.
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        ``points``: cost, force and life arrays drawn; ``recommended``: (cost, force); ``path``.
    """
    cost = np.array([d["cost"] for d in front], float)
    force = np.array([d["design_force_N"] for d in front], float)
    life = np.array([d["life_h"] for d in front], float)
    fig, ax = new_figure(figsize=(7.5, 4.5))
    sc = ax.scatter(cost, force, c=life, cmap="viridis")
    ax.scatter([recommended["cost"]], [recommended["design_force_N"]], s=160, facecolors="none", edgecolors="red",
               label="recommended: " + ", ".join(f"{j} {f}" for j, f in recommended["fits"].items()))
    colour_bar(fig, sc, ax, "maintenance interval [h]")
    label_axes(ax, "manufacturing cost (relative units) [-]", "static-equivalent collision force [N]")
    ax.set_title("Pareto front of fit choices (NSGA-II on the surrogate)", fontsize=10)
    ax.grid(alpha=0.3)
    legend_outside(ax, where="below")
    return _out(fig, path, {"points": {"cost": cost, "design_force_N": force, "life_h": life},
                            "recommended": (float(recommended["cost"]), float(recommended["design_force_N"]))},
                return_figure)
