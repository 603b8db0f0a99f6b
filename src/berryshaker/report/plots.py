"""Figures (matplotlib, Agg backend: no display needed)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_svaj(kin, path: Path, title: str = "") -> None:
    """Push-rod displacement, velocity, acceleration and jerk over the cam cycle."""
    plt = _plt()
    deg = np.degrees(kin.phi)
    fig, axes = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    for ax, y, lab in zip(axes, (kin.s * 1e3, kin.v, kin.a, kin.j),
                          ("s (mm)", "v (m/s)", "a (m/s$^2$)", "j (m/s$^3$)")):
        ax.plot(deg, y, lw=1.4)
        ax.set_ylabel(lab)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("cam angle (deg)")
    axes[-1].set_xlim(0, 360)
    axes[0].set_title(title or "Push-rod SVAJ (study eq. 1)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_groove(pitch, inner, outer, base_radius: float, path: Path, title: str = "") -> None:
    """Cam groove: pitch curve and inner/outer walls (study eq. 2, corrected)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    ax.plot(pitch[0] * 1e3, pitch[1] * 1e3, "k--", lw=1, label="pitch curve (roller centre)")
    ax.plot(inner[0] * 1e3, inner[1] * 1e3, lw=1.5, label="inner wall")
    ax.plot(outer[0] * 1e3, outer[1] * 1e3, lw=1.5, label="outer wall")
    t = np.linspace(0, 2 * math.pi, 200)
    ax.plot(base_radius * 1e3 * np.cos(t), base_radius * 1e3 * np.sin(t), ":", color="grey", lw=1,
            label="base circle")
    ax.plot([0], [0], "k+")
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(title or "Groove cam profile")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_comb_angles(kin, theta_d0: float, theta_e0: float, comb_length: float, path: Path) -> None:
    """Comb swing angles, tip speeds and transmission angle over the cycle."""
    plt = _plt()
    deg = np.degrees(kin.phi)
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    axes[0].plot(deg, np.degrees(kin.theta_d - theta_d0), label="left comb")
    axes[0].plot(deg, np.degrees(kin.theta_e - theta_e0), label="right comb")
    axes[0].set_ylabel("swing (deg)")
    axes[0].legend()
    axes[1].plot(deg, comb_length * kin.omega_d, label="left tip")
    axes[1].plot(deg, comb_length * kin.omega_e, label="right tip")
    axes[1].set_ylabel("tip speed (m/s)")
    axes[1].legend()
    axes[2].plot(deg, np.degrees(kin.transmission_angle), color="C2")
    axes[2].set_ylabel("transmission angle (deg)")
    axes[2].set_xlabel("cam angle (deg)")
    axes[2].set_xlim(0, 360)
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].set_title("Double rocker (study eq. 3)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_time_series(t, series: dict[str, np.ndarray], ylabel: str, path: Path, title: str = "") -> None:
    """Overlay of several time series sharing one axis."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(9, 4))
    for name, y in series.items():
        ax.plot(t, y, lw=1.0, label=name)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_mode_shapes(modes, modes_fe, path: Path) -> None:
    """Analytic (lines) and finite-element (dots) mass-normalised mode shapes of the branch."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for i in range(len(modes.omega)):
        line, = ax.plot(modes.z, modes.shapes[i], lw=1.5,
                        label=f"mode {i + 1}: {modes.frequency_hz[i]:.3f} Hz (FE {modes_fe.frequency_hz[i]:.3f} Hz)")
        ax.plot(modes_fe.z[::80], modes_fe.shapes[i][::80], "o", ms=3, color=line.get_color())
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel("position along the branch z (m)")
    ax.set_ylabel(r"mode shape (kg$^{-1/2}$)")
    ax.set_title("Tapered branch modes: Bessel solution (lines, eq. 15) and finite elements (dots)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_fruit_force(distance, forces: dict, ranges: dict, path: Path, title: str = "") -> None:
    """Fruit harvesting force against machine-to-plant distance (study Figs. 24-26), one panel per fruit,
    with the study's range and the eq. 17 bond forces."""
    plt = _plt()
    names = list(forces)
    fig, axes = plt.subplots(len(names), 1, figsize=(9, 2.6 * len(names)), sharex=True)
    axes = np.atleast_1d(axes)
    for ax, name in zip(axes, names):
        ax.plot(distance, forces[name], lw=0.8, color="C0", label=f"{name} fruit")
        if name in ranges:
            lo, hi = ranges[name]
            ax.axhspan(lo, hi, color="C2", alpha=0.15, label=f"study {lo}-{hi} N")
            ax.axhspan(-hi, -lo, color="C2", alpha=0.15)
        ax.axhline(0.26, color="C1", ls="--", lw=0.8, label="ripe bond 0.26-0.30 N (eq. 17)")
        ax.axhline(-0.26, color="C1", ls="--", lw=0.8)
        ax.axhline(1.0, color="C3", ls=":", lw=0.8, label="unripe bond from 1.0 N")
        ax.axhline(-1.0, color="C3", ls=":", lw=0.8)
        ax.set_ylabel("force (N)")
        ax.legend(fontsize=7, loc="upper right")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("machine-to-plant distance along the row (m)")
    axes[0].set_title(title or "Fruit harvesting force (study eq. 16, Figs. 24-26)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_main_effects(analysis: dict, path: Path, title: str = "") -> None:
    """Level means of every factor for every response (main-effect plots)."""
    plt = _plt()
    responses = list(analysis["responses"])
    factors = list(next(iter(analysis["responses"].values()))["factors"])
    fig, axes = plt.subplots(len(responses), len(factors), figsize=(3.0 * len(factors), 2.4 * len(responses)),
                             squeeze=False, sharey="row")
    for i, r in enumerate(responses):
        ra = analysis["responses"][r]
        for j, f in enumerate(factors):
            k = ra["factors"][f]["level_means"]
            ax = axes[i, j]
            ax.plot(range(1, len(k) + 1), k, "o-")
            best = ra["factors"][f]["best_level"]
            ax.plot([best], [k[best - 1]], "o", ms=10, mfc="none", mec="C3")
            ax.set_xticks(range(1, len(k) + 1))
            ax.grid(alpha=0.3)
            if i == len(responses) - 1:
                ax.set_xlabel(f"level of {f}")
            if j == 0:
                ax.set_ylabel(r)
            ax.set_title(f"R = {ra['factors'][f]['range']:.3g}", fontsize=8)
    fig.suptitle(title or "Main effects (range analysis); red ring = best level")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_response_surfaces(values, y, names, reg, response: str, path: Path) -> None:
    """Response surfaces of the identifiable main-effects quadratic model for factor pairs (Figs. 27-29)."""
    from berryshaker.experiment.analysis import predict_main_quadratic

    plt = _plt()
    pairs = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)][: max(1, len(names) * (len(names) - 1) // 2)]
    values = np.asarray(values, float)
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5))
    mid = np.median(values, axis=0)
    for ax, (a, b) in zip(axes.ravel(), pairs):
        ga = np.linspace(values[:, a].min(), values[:, a].max(), 40)
        gb = np.linspace(values[:, b].min(), values[:, b].max(), 40)
        A, B = np.meshgrid(ga, gb)
        X = np.tile(mid, (A.size, 1))
        X[:, a], X[:, b] = A.ravel(), B.ravel()
        Z = predict_main_quadratic(reg, X, names).reshape(A.shape)
        cs = ax.contourf(A, B, Z, levels=14, cmap="viridis")
        fig.colorbar(cs, ax=ax)
        ax.scatter(values[:, a], values[:, b], c="w", edgecolors="k", s=25)
        ax.set_xlabel(f"{names[a]} (mm)")
        ax.set_ylabel(f"{names[b]} (mm)")
    fig.suptitle(f"{response}: main-effects quadratic model (other factors at their middle level); "
                 "dots = test runs")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_bars(series: dict, labels: list, ylabel: str, path: Path, title: str = "") -> None:
    """Grouped bars: one group per label, one bar per series."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8, 4))
    n = len(series)
    width = 0.8 / max(n, 1)
    x = np.arange(len(labels))
    for i, (name, vals) in enumerate(series.items()):
        ax.bar(x + (i - (n - 1) / 2) * width, vals, width, label=name)
    ax.set_xticks(x)
    ax.set_xticklabels(labels)
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def write_kinematics_figures(machine, kin, folder: Path) -> list[str]:
    """SVAJ, groove profile and comb-angle figures of a machine's drive into ``folder``; returns names."""
    from berryshaker.drives.groove_cam.kinematics import cam_groove, mid_stroke_angles

    plot_svaj(kin, folder / "svaj.png", f"Push-rod SVAJ, {machine.cam.law} law (study eq. 1)")
    _, pitch, inner, outer = cam_groove(machine)
    plot_groove(pitch, inner, outer, machine.cam.base_radius, folder / "groove_profile.png")
    d0, e0 = mid_stroke_angles(machine)
    plot_comb_angles(kin, d0, e0, machine.combs.length, folder / "comb_angles.png")
    return ["svaj.png", "groove_profile.png", "comb_angles.png"]
