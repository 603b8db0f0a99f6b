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
