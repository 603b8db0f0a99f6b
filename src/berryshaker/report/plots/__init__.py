"""Figures (matplotlib, Agg backend: no display needed), all in the style of
:mod:`berryshaker.report.style`: units on every axis and colour bar, shared scales where panels compare,
legends outside the data, fixed colours per clearance pair and line styles per model, peak-preserving
decimation, no offset tick labels, nothing cut at the canvas' edge.

Every function saves a PNG at print resolution (300 dpi) with an SVG beside it and returns the data it drew as a
dict (decimated series, their extremes, colour scales...), so a test or the report can check a figure against its
table.  With ``return_figure=True`` the matplotlib figure is left open and returned under ``"figure"`` (the caller
closes it).

The functions live in modules by subject and are all importable from here (``from berryshaker.report import plots;
plots.plot_bars(...)``): :mod:`.kinematics` (the drive, the branch's modes), :mod:`.series` (time series, fruit
force, bars, harvest against a setting), :mod:`.doe` (main effects, response surfaces, trade-off), :mod:`.effects`
(Pareto chart of standardized effects, residual and interaction plots), :mod:`.life` (wear, sensitivity, fits).
"""

from __future__ import annotations

from berryshaker.report.plots.doe import (
    plot_main_effects,
    plot_replicated_effects,
    plot_response_surfaces,
    plot_tradeoff,
)
from berryshaker.report.plots.effects import (
    plot_interactions,
    plot_pareto_effects,
    plot_residuals,
    write_doe_figures,
    write_effect_figures,
)
from berryshaker.report.plots.kinematics import (
    plot_comb_angles,
    plot_groove,
    plot_mode_shapes,
    plot_svaj,
    write_kinematics_figures,
)
from berryshaker.report.plots.life import plot_clearance_growth, plot_fit_front, plot_sobol
from berryshaker.report.plots.series import (
    HARVEST_RESPONSE_SERIES,
    plot_bars,
    plot_fruit_force,
    plot_harvest_response,
    plot_joint_forces,
    plot_signals,
    plot_time_series,
)

__all__ = ["HARVEST_RESPONSE_SERIES", "plot_bars", "plot_clearance_growth", "plot_comb_angles", "plot_fit_front",
           "plot_fruit_force", "plot_groove", "plot_harvest_response", "plot_interactions", "plot_joint_forces",
           "plot_main_effects", "plot_mode_shapes", "plot_pareto_effects", "plot_replicated_effects",
           "plot_residuals", "plot_response_surfaces", "plot_signals", "plot_sobol", "plot_svaj", "plot_time_series",
           "plot_tradeoff", "write_doe_figures", "write_effect_figures", "write_kinematics_figures"]
