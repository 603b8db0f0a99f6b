"""``berryshaker plot`` and ``berryshaker animate``: a run saved by ``simulate --out`` as a figure of any of its
signals, and as an animation of its comb drive to keep."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from berryshaker.cli.app import JsonOpt, _print_json, app, command, out

RunDirArg = typer.Argument(..., help="Folder of a run written by `berryshaker simulate --out DIR`.")


def _names(text: str) -> list[str]:
    return [n.strip() for n in text.split(",") if n.strip()]


@command(app, "plot")
def plot(
    run_dir: Path = RunDirArg,
    y: str = typer.Option(..., "--y", help="Signals to plot, comma-separated (e.g. F_A,F_C or drive_moment); "
                          "one panel per unit.  Names as in timeseries.csv, with or without their unit "
                          "(F_A or F_A_N)."),
    x: str = typer.Option("time", "--x", help="Abscissa: time (default), or any signal (a phase plot, e.g. "
                          "theta_D)."),
    out_file: Optional[Path] = typer.Option(None, "--out", help="Figure file (.png, .svg or .pdf); default "
                                            "<y>_vs_<x>.png in the current folder."),
    force: bool = typer.Option(False, "--force", help="Replace an existing --out file."),
    as_json: bool = JsonOpt,
):
    """Plot any signals of a saved run (simulate --out) against time or another signal, units on the axes.

    One panel per unit; against time the series are thinned by peak-preserving decimation (the drawn peak is the
    saved series' peak).  A name the run does not have is refused with the run's signals listed.
    \f

    Parameters
    ----------
    run_dir : Path
        Folder of a run written by `berryshaker simulate --out DIR`.
    y : str
        ``--y``: Signals to plot, comma-separated (e.g. F_A,F_C or drive_moment); one panel per unit.  Names as
        in timeseries.csv, with or without their unit (F_A or F_A_N).
    x : str
        ``--x``: Abscissa: time (default), or any signal (a phase plot, e.g. theta_D).
    out_file : Path, optional
        ``--out``: Figure file (.png, .svg or .pdf); default <y>_vs_<x>.png in the current folder.
    force : bool
        ``--force``: Replace an existing --out file.
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    """
    from berryshaker.errors import ConfigError
    from berryshaker.outputs import check_output_file, read_saved_run, split_unit

    names = _names(y)
    if not names:
        raise ConfigError("--y: give at least one signal, e.g. --y F_A,F_C")
    if len(names) > 12:
        raise ConfigError(f"--y: {len(names)} signals; plot at most 12 in one figure")
    saved = read_saved_run(run_dir)
    x_col = saved.column(x)
    y_cols = [saved.column(n) for n in names]
    if len(set(y_cols)) != len(y_cols):
        raise ConfigError(f"--y {y}: a signal named twice")
    x_name, x_unit = split_unit(x_col)
    default = f"{'_'.join(split_unit(c)[0] for c in y_cols)}_vs_{x_name}.png".replace("/", "_")
    path = check_output_file(out_file or Path(default[:120]), [".png", ".svg", ".pdf"], overwrite=force)
    from berryshaker.report.plots import plot_signals

    ys = {split_unit(c)[0]: (saved.signals[c], split_unit(c)[1]) for c in y_cols}
    model = saved.summary.get("model", "")
    title = f"{saved.folder.name}: {model + ' model, ' if model else ''}{', '.join(ys)} against {x_name}"
    data = plot_signals((x_name, saved.signals[x_col], x_unit), ys, path, title)
    peaks = {n: {"peak_abs": s["input_peak_abs"], "unit": u}
             for u, panel in data["panels"].items() for n, s in panel.items()}
    if as_json:
        _print_json({"path": str(path), "x": {"signal": x_col, "unit": x_unit}, "y": peaks,
                     "decimated": data["decimated"], "samples": int(len(saved.signals[x_col]))})
        return
    out.print(f"wrote {path}: " + ", ".join(f"{n} (peak |value| {p['peak_abs']:.4g} {p['unit']})"
                                             for n, p in peaks.items()) + f" against {x_name} [{x_unit}]",
              markup=False, highlight=False)


@command(app, "animate")
def animate(
    run_dir: Path = RunDirArg,
    out_file: Path = typer.Option(..., "--out", help="Animation file: .gif, or .mp4 where ffmpeg is installed."),
    frames: int = typer.Option(60, "--frames", help="Frames over the last revolution (2..1000)."),
    fps: int = typer.Option(15, "--fps", help="Frames per second (1..60)."),
    magnify: Optional[float] = typer.Option(None, "--magnify", help="Clearance magnification in the drawing "
                                            "(1..1000; default chosen from the clearances so the linkage stays "
                                            "joined, as in explore)."),
    force: bool = typer.Option(False, "--force", help="Replace an existing --out file."),
    as_json: bool = JsonOpt,
):
    """An animation of a saved run's comb drive (GIF, or MP4 with ffmpeg) to keep.

    The drawing of `berryshaker explore` over the last revolution: clearances magnified, joints in contact marked.
    The run's simulation is run again from its summary.json and checked against its saved joint forces first: a
    run saved by a version whose model differs is refused.
    \f

    Parameters
    ----------
    run_dir : Path
        Folder of a run written by `berryshaker simulate --out DIR`.
    out_file : Path
        ``--out``: Animation file: .gif, or .mp4 where ffmpeg is installed.
    frames : int
        ``--frames``: Frames over the last revolution (2..1000).
    fps : int
        ``--fps``: Frames per second (1..60).
    magnify : float, optional
        ``--magnify``: Clearance magnification in the drawing (1..1000; default chosen from the clearances so the
        linkage stays joined, as in explore).
    force : bool
        ``--force``: Replace an existing --out file.
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    """
    from berryshaker.explore.animation import animation_writer, redraw_saved_run, write_animation
    from berryshaker.outputs import check_output_file, read_saved_run

    path = check_output_file(out_file, [".gif", ".mp4"], overwrite=force)
    animation_writer(path, 1)  # an MP4 without ffmpeg is refused before the run
    saved = read_saved_run(run_dir)
    drawing = redraw_saved_run(saved, frames)
    res = write_animation(drawing, path, magnify=magnify, fps=fps)
    res["reproduced_max_force_difference_N"] = drawing.max_force_difference_N
    if as_json:
        _print_json(res)
        return
    out.print(f"wrote {path}: {res['frames']} frames at {fps} fps over the last revolution (slowed "
              f"{res['slow_down']:.0f} x), clearances x{res['magnify']:g}; the re-run reproduced the saved joint "
              f"forces to {drawing.max_force_difference_N:.2g} N", markup=False, highlight=False)
