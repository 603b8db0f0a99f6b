"""Command line: ``berryshaker --help``.

Every command works on the built-in reference machine unless ``--config FILE`` names another machine
description (TOML, units allowed: "0.25 mm", "120 rpm").  ``--json`` prints one JSON object on stdout for
scripts; errors go to stderr as one clear message with exit code 2 and nothing written.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Optional

import typer
from rich.console import Console
from rich.table import Table

from . import __version__
from .errors import BerryshakerError

app = typer.Typer(
    name="berryshaker",
    help="Design and tune comb-oscillation blueberry harvesters with transmission clearance.\n\n"
    "Start with `berryshaker kinematics` (the reference machine) or `berryshaker config init my.toml` "
    "to get an editable machine description.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
config_app = typer.Typer(help="Show, create and check machine descriptions (TOML).", no_args_is_help=True)
app.add_typer(config_app, name="config")

out = Console()
err = Console(stderr=True, soft_wrap=True)

ConfigOpt = typer.Option(None, "--config", "-c", help="Machine description (TOML). Default: built-in reference machine.",
                         exists=False, dir_okay=False)
JsonOpt = typer.Option(False, "--json", help="Print one JSON object on stdout instead of tables.")


def _fail(exc: Exception) -> None:
    err.print(f"[bold red]error:[/] {exc}", highlight=False, markup=True)
    raise typer.Exit(code=2)


def _load(config: Optional[Path]):
    from .config import load_machine

    return load_machine(config)


def _version_cb(value: bool):
    if value:
        print(f"berryshaker {__version__}")
        raise typer.Exit()


@app.callback()
def main(version: bool = typer.Option(False, "--version", callback=_version_cb, is_eager=True,
                                      help="Print the version and exit.")):
    """berryshaker: harvester drive kinematics, clearance dynamics, plant response and field tests."""


def _print_json(obj) -> None:
    sys.stdout.write(json.dumps(obj, indent=2) + "\n")


# ----------------------------------------------------------------------------------------------
@app.command()
def kinematics(
    config: Optional[Path] = ConfigOpt,
    as_json: bool = JsonOpt,
    plot: Optional[Path] = typer.Option(None, "--plot", help="Write SVAJ, groove and comb-angle PNGs to DIR."),
    allow_undercut: bool = typer.Option(False, "--allow-undercut",
                                        help="Report an undercutting cam instead of refusing it."),
):
    """Kinematics of the ideal drive (study eq. 1-3): cam SVAJ, groove, pressure angle, comb swing.

    Checks that the four-bar assembles over the whole cycle and the groove does not undercut.
    """
    try:
        from .kinematics.mechanism import check_machine, kinematics_summary, mid_stroke_angles, cam_groove

        machine = _load(config)
        kin = check_machine(machine, allow_undercut=allow_undercut)
        summary = kinematics_summary(machine, kin)
        summary["machine"] = machine.machine.name
        summary["version"] = __version__
        if plot is not None:
            from .report.files import staged_directory
            from .report.plots import plot_comb_angles, plot_groove, plot_svaj

            with staged_directory(plot) as stage:
                plot_svaj(kin, stage / "svaj.png", f"Push-rod SVAJ, {machine.cam.law} law (study eq. 1)")
                _, pitch, inner, outer = cam_groove(machine)
                plot_groove(pitch, inner, outer, machine.cam.base_radius, stage / "groove_profile.png")
                d0, e0 = mid_stroke_angles(machine)
                plot_comb_angles(kin, d0, e0, machine.combs.length, stage / "comb_angles.png")
            summary["plots"] = [str(plot / n) for n in ("svaj.png", "groove_profile.png", "comb_angles.png")]
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json(summary)
        return
    _print_kinematics(summary)


def _print_kinematics(s: dict) -> None:
    c = s["cam"]
    t = Table(title=f"Kinematics - {s['machine']}", show_header=True, header_style="bold")
    t.add_column("quantity")
    t.add_column("value", justify="right")
    t.add_column("closed form", justify="right")
    cf = c.get("closed_form", {})
    t.add_row("follower law", c["law"], "")
    t.add_row("stroke", f"{c['stroke_mm']:.3f} mm", "")
    t.add_row("max push-rod velocity", f"{c['max_velocity_m_s']:.4f} m/s",
              f"{cf.get('max_velocity_m_s', float('nan')):.4f} m/s")
    t.add_row("max push-rod acceleration", f"{c['max_acceleration_m_s2']:.3f} m/s²",
              f"{cf.get('max_acceleration_m_s2', float('nan')):.3f} m/s²")
    t.add_row("max push-rod jerk", f"{c['max_jerk_m_s3']:.1f} m/s³", f"{cf.get('max_jerk_m_s3', float('nan')):.1f} m/s³")
    t.add_row("pressure angle", f"{c['pressure_angle_deg']['min']:.2f} .. {c['pressure_angle_deg']['max']:.2f} deg", "")
    t.add_row("min pitch radius of curvature", f"{c['min_radius_of_curvature_mm']:.2f} mm",
              f"roller {c['roller_radius_mm']:.2f} mm")
    t.add_row("undercut", "YES" if c["undercut"] else "no", "")
    for side in ("left", "right"):
        cm = s["combs"][side]
        t.add_row(f"{side} comb swing", f"{cm['swing_deg']['min']:.2f} .. {cm['swing_deg']['max']:.2f} deg", "")
        t.add_row(f"{side} comb max tip speed", f"{cm['max_tip_speed_m_s']:.3f} m/s", "")
        t.add_row(f"{side} comb max tip acceleration", f"{cm['max_tip_acceleration_m_s2']:.2f} m/s²", "")
    ta = s["linkage"]["transmission_angle_deg"]
    t.add_row("transmission angle", f"{ta['min']:.2f} .. {ta['max']:.2f} deg", "")
    t.add_row("cam speed", f"{s['drive']['cam_speed_rpm']:.1f} r/min", "")
    t.add_row("comb frequency", f"{s['drive']['comb_frequency_hz']:.3f} Hz", "")
    out.print(t)
    for p in s.get("plots", []):
        out.print(f"wrote {p}")


# ----------------------------------------------------------------------------------------------
@app.command("cam-profile")
def cam_profile(
    out_file: Path = typer.Option(..., "--out", "-o", help="Output file."),
    fmt: str = typer.Option("csv", "--format", "-f", help="csv (angle + pitch/inner/outer in mm) or dxf "
                            "(closed polylines, mm, layers PITCH/INNER_WALL/OUTER_WALL)."),
    config: Optional[Path] = ConfigOpt,
    points: int = typer.Option(1441, "--points", min=90, help="Points per revolution."),
):
    """Export the groove walls of the cam (study eq. 2, corrected) for CAM."""
    try:
        from .kinematics.mechanism import check_machine
        from .kinematics.profile_export import write_groove_csv, write_groove_dxf

        if fmt not in ("csv", "dxf"):
            raise BerryshakerError(f"--format must be csv or dxf, got {fmt!r}")
        machine = _load(config)
        check_machine(machine)
        if fmt == "csv":
            write_groove_csv(machine, out_file, points)
        else:
            write_groove_dxf(machine, out_file, points)
    except BerryshakerError as exc:
        _fail(exc)
        return
    err.print(f"wrote {out_file} ({fmt}, {points} points per wall)")


# ----------------------------------------------------------------------------------------------
@config_app.command("show")
def config_show(config: Optional[Path] = ConfigOpt, as_json: bool = JsonOpt):
    """Print the resolved machine description (engineering units; --json gives SI)."""
    try:
        from .config import machine_table

        machine = _load(config)
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json({"machine_si": machine.model_dump(mode="json"), "version": __version__})
        return
    t = Table(title=f"{machine.machine.name}", header_style="bold")
    t.add_column("key")
    t.add_column("value", justify="right")
    for k, v in machine_table(machine):
        t.add_row(k, v)
    xd, yd = machine.shaft_D
    t.add_row("(derived) shaft D", f"({xd * 1e3:.3f}, {yd * 1e3:.3f}) mm")
    t.add_row("(derived) shaft E", f"({machine.shaft_E[0] * 1e3:.3f}, {machine.shaft_E[1] * 1e3:.3f}) mm")
    t.add_row("(derived) s0", f"{machine.cam.s0 * 1e3:.4f} mm")
    out.print(t)


@config_app.command("init")
def config_init(path: Path = typer.Argument(..., help="Where to write the editable copy."),
                force: bool = typer.Option(False, "--force", help="Overwrite an existing file.")):
    """Write an editable copy of the reference machine (annotated: [study] or [assumed])."""
    from .config import reference_toml_text
    from .report.files import write_text_atomic

    if path.exists() and not force:
        _fail(BerryshakerError(f"{path} exists; use --force to overwrite"))
    write_text_atomic(path, reference_toml_text())
    err.print(f"wrote {path}")


@config_app.command("validate")
def config_validate(path: Path = typer.Argument(..., help="Machine description to check."),
                    as_json: bool = JsonOpt):
    """Check a machine description: values, units, assembly over the cycle, cam undercut."""
    try:
        from .kinematics.mechanism import check_machine

        machine = _load(path)
        check_machine(machine)
    except BerryshakerError as exc:
        if as_json:
            _print_json({"valid": False, "error": str(exc)})
            raise typer.Exit(code=2)
        _fail(exc)
        return
    if as_json:
        _print_json({"valid": True, "machine": machine.machine.name})
    else:
        out.print(f"[green]valid[/]: {path} ({machine.machine.name})")


def run() -> None:  # console-script entry point
    app()


if __name__ == "__main__":
    run()
