"""A saved run's comb drive as an animation to keep (``berryshaker animate``): the explore page's drawing
(:mod:`berryshaker.explore.drawing`) over the last revolution, written as a GIF (matplotlib's ``PillowWriter``) or,
where ffmpeg is installed, an MP4.

``simulate --out`` saves the joint forces, not every body's motion, so the drawing comes from the same simulation
run again from what the run saved (the machine in SI, the clearances, the model, the revolutions, the driveline
mode): the simulations are deterministic, and the re-run's joint forces are checked against the saved series
before anything is drawn.  A run that does not reproduce (saved by a version whose models differ) is refused.
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from berryshaker.errors import ConfigError
from berryshaker.explore.drawing import groove_cam_frames, magnification_range, multibody_frames
from berryshaker.explore.views import frame_at, frame_data

#: the re-run's joint forces may differ from the saved ones by this share of their largest |value| (the CSV keeps
#: nine significant digits; a model that changed differs by far more)
REPRODUCE_RTOL = 1e-6
#: the animation's formats: suffix -> matplotlib writer name
WRITERS = {".gif": "pillow", ".mp4": "ffmpeg"}


@dataclass(frozen=True)
class RunDrawing:
    """A saved run drawn again: the drawing of its last revolution and what it was made from.

    Attributes
    ----------
    frames : dict
        The drawing (:func:`berryshaker.explore.drawing.groove_cam_frames` or
        :func:`~berryshaker.explore.drawing.multibody_frames`).
    model : str
        "mlsd" or "multibody".
    machine_name : str
        The machine's ``[machine] name``.
    max_force_difference_N : float
        Largest difference between the re-run's and the saved joint forces (N).
    """

    frames: dict
    model: str
    machine_name: str
    max_force_difference_N: float


def redraw_saved_run(saved, n_frames: int = 60) -> RunDrawing:
    """Run a saved run's simulation again, check it against the saved joint forces and draw its last revolution.

    Parameters
    ----------
    saved : SavedRun
        The run (:func:`berryshaker.outputs.read_saved_run`).
    n_frames : int
        Frames over the last revolution (2..1000).

    Returns
    -------
    RunDrawing
        The drawing and the check.

    Raises
    ------
    ConfigError
        Not a comb-drive run (a mechanism file's run, or a summary without its machine), a multibody run of a drive
        drawn from its reduced model (the groove cam: animate its MLSD run), or a re-run that does not reproduce
        the saved forces.
    """
    from berryshaker.config import machine_from_dict
    from berryshaker.drives import drive_of
    from berryshaker.drives.powered import with_driveline_mode

    if isinstance(n_frames, bool) or not isinstance(n_frames, int) or not 2 <= n_frames <= 1000:
        raise ConfigError(f"--frames {n_frames!r}: give a whole number of frames in 2..1000")
    s, where = saved.summary, saved.folder / "summary.json"
    prov = s.get("provenance") if isinstance(s.get("provenance"), dict) else {}
    if "machine_si" not in prov:
        what = "a mechanism file's run (simulate --mechanism)" if "mechanism_si" in prov else "not a comb-drive run"
        raise ConfigError(f"{where}: {what}; animate draws the comb drive of a run of simulate --out")
    model = s.get("model")
    if model not in ("mlsd", "multibody") or not isinstance(s.get("clearance_mm"), dict):
        raise ConfigError(f"{where}: no model (mlsd or multibody) and clearances; not a run of simulate --out")
    revolutions = s.get("revolutions")
    if isinstance(revolutions, bool) or not isinstance(revolutions, int) or revolutions < 2:
        raise ConfigError(f"{where}: revolutions {revolutions!r} is not a run of simulate --out")
    machine = machine_from_dict(prov["machine_si"], str(where))
    machine = with_driveline_mode(machine, s.get("driveline_mode") if model == "multibody" else None)
    sizes = {p: float(v) * 1e-3 for p, v in s["clearance_mm"].items()}
    if model == "mlsd":
        result = drive_of(machine).reduced_model(machine, sizes, revolutions=revolutions)
        t, forces = result.t, {p: result.series(f"F_{p}_N") for p in sizes}
        frames = groove_cam_frames(result, n_frames)
    elif drive_of(machine).reduced_model is not None:
        # the explore page draws such a drive from its reduced model: the generic drawing of multibody_frames is
        # for the drives without one
        raise ConfigError(f"{where}: a multibody run of the {machine.DRIVE} drive; its drawing comes from its "
                          f"reduced model: animate a run of simulate --model {drive_of(machine).reduced_model_name} "
                          "--out DIR")
    else:
        from berryshaker.drives.simulation import simulate_multibody

        result, _summary = simulate_multibody(machine, sizes, revolutions=revolutions)
        cm = result.compiled
        t = result.t
        forces = {p: result.element_force(p) if p in cm.frc_names else result.reaction(p) for p in sizes}
        frames = multibody_frames(machine.with_clearances(sizes), result, n_frames)
    diff = _check_reproduced(saved, t, forces)
    if frames is None:
        raise ConfigError(f"{where}: the {machine.DRIVE} drive's run has no drawing")
    return RunDrawing(frames, model, str(machine.machine.name), diff)


def _check_reproduced(saved, t: np.ndarray, forces: dict) -> float:
    """The largest difference (N) between the re-run's joint forces and the saved ones; refuse a run that does
    not reproduce."""
    saved_t = saved.signals["time_s"]
    if len(saved_t) != len(t) or not np.allclose(saved_t, t, rtol=1e-9, atol=1e-12):
        raise ConfigError(f"{saved.folder}: the run could not be reproduced (its time samples differ from a "
                          "re-run's); run simulate --out again with this version")
    worst = 0.0
    for pair, f in forces.items():
        column = f"F_{pair}_N"
        if column not in saved.signals:
            raise ConfigError(f"{saved.folder}: {column} is missing from timeseries.csv")
        ref = saved.signals[column]
        d = float(np.max(np.abs(np.asarray(f, float) - ref)))
        scale = float(np.max(np.abs(ref))) or 1.0
        if d > REPRODUCE_RTOL * scale + 1e-6:
            version = saved.summary.get("version", "?")
            raise ConfigError(f"{saved.folder}: a re-run's collision force at {pair} differs from the saved one by "
                              f"{d:.4g} N (of {scale:.4g} N): the run was saved by berryshaker {version}, whose "
                              "model differs; run simulate --out again with this version")
        worst = max(worst, d)
    return worst


def animation_writer(path: Path, fps: int):
    """The matplotlib writer of an animation file, refused before any work where it cannot be written.

    Parameters
    ----------
    path : Path
        A .gif (Pillow) or .mp4 (ffmpeg) file.
    fps : int
        Frames per second.

    Returns
    -------
    matplotlib.animation.AbstractMovieWriter
        The writer.

    Raises
    ------
    ConfigError
        Another suffix, or an MP4 where ffmpeg is not installed.
    """
    from matplotlib import animation

    suffix = path.suffix.lower()
    if suffix not in WRITERS:
        raise ConfigError(f"--out {path}: give a .gif or .mp4 file")
    if suffix == ".mp4" and (shutil.which("ffmpeg") is None or not animation.writers.is_available("ffmpeg")):
        raise ConfigError(f"--out {path}: an MP4 needs ffmpeg, which is not installed here; write a .gif instead "
                          "(or install ffmpeg)")
    return animation.PillowWriter(fps=fps) if suffix == ".gif" else animation.FFMpegWriter(fps=fps)


def write_animation(drawing: RunDrawing, path: str | Path, *, magnify: float | None = None, fps: int = 15,
                    dpi: int = 80) -> dict:
    """Write the drawing as an animation, one frame per drawn instant, the clearances magnified.

    Parameters
    ----------
    drawing : RunDrawing
        :func:`redraw_saved_run`.
    path : str or Path
        A .gif (Pillow) or .mp4 (ffmpeg) file, written atomically (checked before: :func:`berryshaker.outputs.check_output_file`).
    magnify : float, optional
        Clearance magnification (default the page's, :func:`berryshaker.explore.drawing.magnification_range`,
        which keeps the linkage joined).
    fps : int
        Frames per second (1..60).
    dpi : int
        Resolution (40..300 dots per inch; the figure is 8 x 5.6 in).

    Returns
    -------
    dict
        ``frames``, ``magnify``, ``fps``, ``slow_down`` (the animation's duration over the revolution's), ``path``.

    Raises
    ------
    ConfigError
        A format without its writer, or a value out of range.
    """
    from matplotlib.animation import FuncAnimation
    from matplotlib.collections import LineCollection
    from matplotlib.patches import Circle

    from berryshaker.outputs import write_bytes_atomic
    from berryshaker.report.style import label_axes, new_figure, pyplot

    path = Path(path)
    for name, v, lo, hi in (("--fps", fps, 1, 60), ("--dpi", dpi, 40, 300)):
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            raise ConfigError(f"{name} {v!r}: give a whole number in {lo}..{hi}")
    default, largest = magnification_range(drawing.frames)
    if magnify is None:
        magnify = default
    elif not (isinstance(magnify, (int, float)) and math.isfinite(magnify) and 1 <= magnify <= 1000):
        raise ConfigError(f"--magnify {magnify!r}: give a magnification in 1..1000 (default {default:g})")
    writer = animation_writer(path, fps)
    data = frame_data(drawing.frames, float(magnify))
    n = len(data["t"])
    xs = np.concatenate([np.ravel(a) for a in (*data["lx"], *data["jx"], *data["gx"])])
    ys = np.concatenate([np.ravel(a) for a in (*data["ly"], *data["jy"], *data["gy"])])
    pad = 0.05 * max(np.ptp(xs), np.ptp(ys))
    fig, ax = new_figure(figsize=(8.0, 5.6))
    ax.set_xlim(xs.min() - pad, xs.max() + pad)
    ax.set_ylim(ys.min() - pad, ys.max() + pad)
    ax.set_aspect("equal")
    label_axes(ax, "x [m]", "y [m]")
    ax.grid(alpha=0.3)
    groove, = ax.plot([], [], color="#999999", linewidth=1.0, label="cam pitch curve")
    links = LineCollection([], linewidths=3.0)
    ax.add_collection(links)
    names = list(data["joint_name"][0])
    rings = [ax.add_patch(Circle((0, 0), 0.0, fill=False, linewidth=2.0)) for _ in names]
    dots, = ax.plot([], [], "o", color="black", markersize=3)
    stars, = ax.plot([], [], "*", color="#D62728", markersize=12, label="joint in contact")
    period = float(data["t"][-1] - data["t"][0]) * n / max(n - 1, 1)
    slow = (n / fps) / period if period > 0 else math.nan
    ax.legend(handles=[groove, stars] if len(data["gx"][0]) else [stars], loc="upper left",
              bbox_to_anchor=(1.01, 1.0), fontsize=8)

    def draw(k: int):
        lk, jk, ik, gk = frame_at(data, k)
        links.set_segments([np.column_stack([x, y]) for x, y in zip(lk["xs"], lk["ys"])])
        links.set_color(lk["colour"])
        for ring, x, y, r, c in zip(rings, jk["x"], jk["y"], jk["r"], jk["colour"]):
            ring.set_center((x, y))
            ring.set_radius(r)
            ring.set_edgecolor(c)
        dots.set_data(jk["px"], jk["py"])
        stars.set_data(ik["x"], ik["y"])
        groove.set_data(gk["x"], gk["y"])
        ax.set_title(f"{drawing.machine_name}: {drawing.model} model, t = {data['t'][k]:.4f} s, drive angle "
                     f"{data['phi_deg'][k]:.0f} deg; clearances x{magnify:g} (slowed {slow:.0f} x)", fontsize=9)
        return [links, dots, stars, groove, *rings]

    anim = FuncAnimation(fig, draw, frames=n, blit=False)
    fd, tmp = tempfile.mkstemp(suffix=path.suffix, prefix=".berryshaker-animation-", dir=path.parent)
    os.close(fd)
    try:
        anim.save(tmp, writer=writer, dpi=dpi)
        write_bytes_atomic(path, Path(tmp).read_bytes())
    finally:
        Path(tmp).unlink(missing_ok=True)
        pyplot().close(fig)
    return {"frames": n, "magnify": float(magnify), "largest_magnify": largest, "fps": fps, "slow_down": slow,
            "path": str(path)}
