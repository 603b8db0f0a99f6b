"""Figures of the drive's kinematics (study eq. 1-3) and the branch's modes (eq. 15)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from berryshaker.report.plots.figure_files import _extremes, _out
from berryshaker.report.style import (
    PAIR_COLOURS,
    SERIES_COLOURS,
    label_axes,
    legend_outside,
    new_figure,
)


def plot_svaj(kin, path: Path, title: str = "", *, return_figure: bool = False) -> dict:
    """Push-rod displacement, velocity, acceleration and jerk over the cam cycle (study eq. 1).

    Parameters
    ----------
    kin : Kinematics
        The drive's kinematics over a cycle (SI).
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    title : str
        Figure title (a default when empty).
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        What was drawn (see the module docstring), ``path`` and ``svg``.
    """
    deg = np.degrees(kin.phi)
    fig, axes = new_figure(4, 1, figsize=(8, 9), sharex=True)
    data: dict[str, dict] = {"series": {}}
    for ax, y, lab, key in zip(axes, (kin.s * 1e3, kin.v, kin.a, kin.j),
                               ("s [mm]", "v [m/s]", "a [m/s²]", "j [m/s³]"), "svaj"):
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
    """Cam groove: pitch curve and inner/outer walls (study eq. 2, corrected: docs/study.md, eq. 2).

    Parameters
    ----------
    pitch, inner, outer : ndarray (2, n)
        Pitch curve and walls [m].
    base_radius : float
        Base-circle radius [m].
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    title : str
        Figure title (a default when empty).
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        What was drawn (see the module docstring), ``path`` and ``svg``.
    """
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
    """Comb swing angles, tip speeds and transmission angle over the cycle (study eq. 3).

    Parameters
    ----------
    kin : Kinematics
        The drive's kinematics over a cycle (SI).
    theta_d0, theta_e0 : float
        Mid-stroke angles of the comb shafts [rad].
    comb_length : float
        Comb length [m].
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        What was drawn (see the module docstring), ``path`` and ``svg``.
    """
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
    """Analytic (lines) and finite-element (dots) mass-normalised mode shapes of the branch (eq. 15).

    Parameters
    ----------
    modes : BranchModes
        Analytic modes (SI).
    modes_fe : BranchModes
        Finite-element modes (SI).
    path : Path
        PNG file (300 dpi; an SVG of the figure is written beside it).
    return_figure : bool
        Leave the figure open and return it under ``"figure"``.

    Returns
    -------
    dict
        What was drawn (see the module docstring), ``path`` and ``svg``.
    """
    fig, ax = new_figure(figsize=(10, 4.5))
    for i in range(len(modes.omega)):
        colour = SERIES_COLOURS[i % len(SERIES_COLOURS)]
        ax.plot(modes.z, modes.shapes[i], lw=1.5, color=colour,
                label=f"mode {i + 1}: {modes.frequency_hz[i]:.3f} Hz (FE {modes_fe.frequency_hz[i]:.3f} Hz)")
        step = max(1, len(modes_fe.z) // 25)
        ax.plot(modes_fe.z[::step], modes_fe.shapes[i][::step], "o", ms=3, color=colour)
    ax.axhline(0, color="k", lw=0.5)
    label_axes(ax, "position along the branch z [m]", "mode shape [1/√kg]")
    ax.set_title("Tapered branch modes: Bessel solution (lines, eq. 15) and finite elements (dots)")
    legend_outside(ax)
    ax.grid(alpha=0.3)
    return _out(fig, path, {}, return_figure)



def write_kinematics_figures(machine, kin, folder: Path, draw=None) -> list[str]:
    """Kinematics figures of a machine's drive into ``folder`` (comb angles for every drive; SVAJ and the groove
    profile for a groove cam); returns the file names.

    Parameters
    ----------
    machine : Machine
        The machine.
    kin : Kinematics
        Its kinematics (SI).
    folder : Path
        Where the figures go.
    draw : callable, optional
        ``draw(fn, *args, **kwargs)`` draws one figure (the study's ``StudyContext.draw``: cached, in a worker);
        default: call ``fn`` here.

    Returns
    -------
    list of str
        The PNG file names written.
    """
    from berryshaker.drives import drive_of

    if draw is None:
        def draw(fn, *args, **kwargs):
            fn(*args, **kwargs)

    d0, e0 = drive_of(machine).mid_stroke_angles(machine)
    if not hasattr(machine, "cam"):
        draw(plot_comb_angles, kin, d0, e0, machine.combs.length, folder / "comb_angles.png")
        return ["comb_angles.png"]
    from berryshaker.drives.groove_cam.kinematics import cam_groove

    draw(plot_svaj, kin, folder / "svaj.png", f"Push-rod SVAJ, {machine.cam.law} law (study eq. 1)")
    _, pitch, inner, outer = cam_groove(machine)
    draw(plot_groove, pitch, inner, outer, machine.cam.base_radius, folder / "groove_profile.png")
    draw(plot_comb_angles, kin, d0, e0, machine.combs.length, folder / "comb_angles.png")
    return ["svaj.png", "groove_profile.png", "comb_angles.png"]


