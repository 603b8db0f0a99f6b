"""Machine descriptions and kinematics: ``kinematics``, ``cam-profile``, ``config show|init|validate``."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from berryshaker import __version__
from berryshaker.cli.app import (
    ConfigOpt,
    JsonOpt,
    _fail,
    _load,
    _print_json,
    app,
    command,
    config_app,
    err,
    out,
    print_table,
)
from berryshaker.errors import BerryshakerError
from berryshaker.outputs import write_provenance
from berryshaker.user_text import markup_text


@command(app)
def kinematics(
    config: Optional[Path] = ConfigOpt,
    as_json: bool = JsonOpt,
    plot: Optional[Path] = typer.Option(None, "--plot", help="Write SVAJ, groove and comb-angle PNGs to DIR."),
    allow_undercut: bool = typer.Option(False, "--allow-undercut",
                                        help="Report an undercutting cam instead of refusing it."),
):
    """Kinematics of the ideal drive (study eq. 1-3): cam SVAJ, groove, pressure angle, comb swing.

    Checks that the four-bar assembles over the whole cycle and the groove does not undercut.
    \f

    Parameters
    ----------
    config : Path, optional
        ``--config``: Machine description (TOML). Default: built-in reference machine.
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    plot : Path, optional
        ``--plot``: Write SVAJ, groove and comb-angle PNGs to DIR.
    allow_undercut : bool
        ``--allow-undercut``: Report an undercutting cam instead of refusing it.
    """
    try:
        from berryshaker.drives import drive_of
        from berryshaker.outputs import prepare_output_dir

        if plot is not None:
            prepare_output_dir(plot, kind="kinematics --plot")
        machine = _load(config)
        drive = drive_of(machine)
        kin = drive.check(machine, allow_undercut=allow_undercut)
        summary = drive.kinematics_summary(machine, kin)
        summary["machine"] = machine.machine.name
        summary["version"] = __version__
        if plot is not None:
            from berryshaker.outputs import staged_directory
            from berryshaker.report.plots import write_kinematics_figures

            with staged_directory(plot, kind="kinematics --plot") as stage:
                fig_names = write_kinematics_figures(machine, kin, stage)
                write_provenance(stage, machine)
            summary["plots"] = [str(plot / n) for n in fig_names]
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json(summary)
        return
    _print_kinematics(summary)


class _Rows(list):
    """Rows collected for :func:`berryshaker.cli.app.print_table` by helpers that add them one at a time."""

    def add_row(self, *cells) -> None:
        """Append one row."""
        self.append(list(cells))


def _print_kinematics(s: dict) -> None:
    t = _Rows()
    for key, val in (s.get("drive_specific") or {}).items():
        t.add_row(key.replace("_", " "), str(val), "")
    if "cam" in s:
        _print_cam_rows(t, s["cam"])
    _print_comb_rows(t, s)
    print_table(("quantity", "value", "closed form"), t, title=f"Kinematics - {s['machine']}")
    for p in s.get("plots", []):
        out.print(f"wrote {p}", markup=False, soft_wrap=True)


def _print_cam_rows(t, c: dict) -> None:
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


def _print_comb_rows(t, s: dict) -> None:
    for side in ("left", "right"):
        cm = s["combs"][side]
        t.add_row(f"{side} comb swing", f"{cm['swing_deg']['min']:.2f} .. {cm['swing_deg']['max']:.2f} deg", "")
        t.add_row(f"{side} comb max tip speed", f"{cm['max_tip_speed_m_s']:.3f} m/s", "")
        t.add_row(f"{side} comb max tip acceleration", f"{cm['max_tip_acceleration_m_s2']:.2f} m/s²", "")
    ta = s["linkage"]["transmission_angle_deg"]
    t.add_row("transmission angle", f"{ta['min']:.2f} .. {ta['max']:.2f} deg", "")
    d = s["drive"]
    t.add_row("drive shaft speed", f"{d.get('cam_speed_rpm', d.get('shaft_speed_rpm', float('nan'))):.1f} r/min", "")
    t.add_row("comb frequency", f"{d['comb_frequency_hz']:.3f} Hz", "")


CAM_PROFILE_FORMATS = {".csv": "csv", ".dxf": "dxf"}
#: most points per revolution of ``cam-profile`` (0.0036 deg apart; ~10 MB of CSV, far finer than any CAM needs)
CAM_PROFILE_MAX_POINTS = 100_000


def _cam_profile_format(out_file: Path, fmt: Optional[str]) -> str:
    """The export format: ``--format`` if given, else from the file name's extension; a mismatch is an error."""
    ext = out_file.suffix.lower()
    if fmt is not None:
        fmt = fmt.strip().lower()
        if fmt not in CAM_PROFILE_FORMATS.values():
            raise BerryshakerError(f"--format must be csv or dxf, got {fmt!r}")
        if ext in CAM_PROFILE_FORMATS and CAM_PROFILE_FORMATS[ext] != fmt:
            raise BerryshakerError(f"--format {fmt} does not match the file name {out_file.name} ({ext}); "
                                   f"name the file *.{fmt} or drop --format")
        if ext not in CAM_PROFILE_FORMATS:
            raise BerryshakerError(f"--out {out_file}: name the file *.{fmt} (the extension says the format)")
        return fmt
    if ext not in CAM_PROFILE_FORMATS:
        raise BerryshakerError(f"--out {out_file}: cannot tell the format from {ext or 'a name without extension'}; "
                               "name the file *.csv or *.dxf")
    return CAM_PROFILE_FORMATS[ext]


@command(app, "cam-profile")
def cam_profile(
    out_file: Path = typer.Option(..., "--out", "-o", help="Output file, *.csv or *.dxf (the extension sets the "
                                  "format)."),
    fmt: Optional[str] = typer.Option(None, "--format", "-f", help="csv (angle + pitch/inner/outer in mm, the tolerance "
                                      "band's walls and the width and running clearance) or dxf (closed polylines, mm, "
                                      "layers PITCH/INNER_WALL/OUTER_WALL, the band on *_MIN/*_MAX, the numbers on "
                                      "NOTES). Default: from the extension of --out."),
    config: Optional[Path] = ConfigOpt,
    points: int = typer.Option(1441, "--points", min=90, max=CAM_PROFILE_MAX_POINTS,
                               help=f"Points per revolution (90..{CAM_PROFILE_MAX_POINTS})."),
    force: bool = typer.Option(False, "--force", help="Replace an existing file."),
):
    """Export the groove walls of the cam (study eq. 2, corrected) for CAM, at the groove width of the drawing.

    The width is the roller diameter plus the running clearance with its tolerance band: from the cam pair's fit
    (clearance.A.fit, hole = groove, shaft = roller), else the described clearance plus an H8-wide band [assumed].
    The walls are at the band's middle; the band's limits and the numbers are written beside them.
    \f

    Parameters
    ----------
    out_file : Path
        ``--out``: Output file, ``*.csv`` or ``*.dxf`` (the extension sets the format).
    fmt : str, optional
        ``--format``: csv (angle + pitch/inner/outer in mm, the tolerance band's walls and the width and running
        clearance) or dxf (closed polylines, mm, layers PITCH/INNER_WALL/OUTER_WALL, the band on ``*_MIN``/``*_MAX``, the
        numbers on NOTES). Default: from the extension of --out.
    config : Path, optional
        ``--config``: Machine description (TOML). Default: built-in reference machine.
    points : int
        ``--points``: Points per revolution (90..100000).
    force : bool
        ``--force``: Replace an existing file.
    """
    try:
        import os

        from berryshaker.drives.groove_cam.kinematics import check_machine
        from berryshaker.drives.groove_cam.profile_export import write_groove_csv, write_groove_dxf
        from berryshaker.outputs import check_output_file

        if out_file.is_dir():
            raise BerryshakerError(f"--out {out_file} is a folder; give a file name, e.g. {out_file / 'cam.dxf'}")
        fmt = _cam_profile_format(out_file, fmt)
        check_output_file(out_file, allowed_suffixes=(f".{fmt}",), overwrite=force)
        machine = _load(config)
        if machine.DRIVE != "groove_cam":
            raise BerryshakerError(f"cam-profile exports a groove cam; the {machine.DRIVE} drive has none")
        check_machine(machine)
        from berryshaker.life.drawing import groove_width

        width = groove_width(machine)
        if fmt == "csv":
            write_groove_csv(machine, out_file, points, width)
        else:
            write_groove_dxf(machine, out_file, points, width)
            # the DXF writer saves through tempfile.mkstemp (mode 0600) and renames: give it the mode of every
            # other output, 0666 less the umask (as report.files.write_text_atomic does for the CSV)
            mask = os.umask(0)
            os.umask(mask)
            os.chmod(out_file, 0o666 & ~mask)
    except BerryshakerError as exc:
        _fail(exc)
        return
    err.print(f"wrote {out_file} ({fmt}, {points} points per wall; {width.note()})", markup=False, highlight=False)


@command(config_app, "show")
def config_show(config: Optional[Path] = ConfigOpt, as_json: bool = JsonOpt):
    """Print the resolved machine description (engineering units; --json gives SI) and the priors of the harvest
    parameters `calibrate` fits (--json: calibration_priors).
    \f

    Parameters
    ----------
    config : Path, optional
        ``--config``: Machine description (TOML). Default: built-in reference machine.
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    """
    try:
        from berryshaker.config import machine_table

        machine = _load(config)
    except BerryshakerError as exc:
        _fail(exc)
        return
    from berryshaker.study.field_calibration import prior_rows

    priors = prior_rows(machine) if machine.plant is not None else []  # the priors of `calibrate` (docs/calibration.md)
    if as_json:
        _print_json({"machine_si": machine.model_dump(mode="json"),
                     "provenance": {k: tag for k, _v, tag in machine_table(machine)}, "calibration_priors": priors,
                     "version": __version__})
        return
    t = _Rows()
    for k, v, tag in machine_table(machine):
        t.add_row(k, v, f"[{tag}]")
    for p in priors:
        t.add_row(f"(calibrate prior) {p['key']}", p["prior"], p["tag"])
    xd, yd = machine.shaft_D
    t.add_row("(derived) shaft D", f"({xd * 1e3:.3f}, {yd * 1e3:.3f}) mm")
    t.add_row("(derived) shaft E", f"({machine.shaft_E[0] * 1e3:.3f}, {machine.shaft_E[1] * 1e3:.3f}) mm")
    if hasattr(machine, "cam"):
        t.add_row("(derived) s0", f"{machine.cam.s0 * 1e3:.4f} mm")
    from berryshaker.config import pair_contact_rows

    for key, value, tag in pair_contact_rows(machine):
        t.add_row(key, value, f"[{tag}]")
    print_table(("key", "value", "source"), t, title=f"{machine.machine.name} ({machine.DRIVE} drive)",
                justify=("left", "right", "left"))


@command(config_app, "init")
def config_init(path: Path = typer.Argument(..., help="Where to write the editable copy."),
                force: bool = typer.Option(False, "--force", help="Overwrite an existing file."),
                drive: str = typer.Option("groove_cam", "--drive", help="Comb drive: groove_cam or crank_rocker.")):
    """Write an editable copy of a drive's reference machine (each value annotated [study], [assumed] or
    [calibrated]).
    \f

    Parameters
    ----------
    path : Path
        Argument: Where to write the editable copy.
    force : bool
        ``--force``: Overwrite an existing file.
    drive : str
        ``--drive``: Comb drive: groove_cam or crank_rocker.
    """
    from berryshaker.config import reference_toml_text
    from berryshaker.outputs import check_output_file, write_text_atomic

    if path.is_dir():
        _fail(BerryshakerError(f"{path} is a folder; give a file name, e.g. {path / 'machine.toml'}"))
    if (path.exists() or path.is_symlink()) and not force:
        _fail(BerryshakerError(f"{path} exists; use --force to overwrite"))
    # a FIFO, device or folder is refused even with --force; so is a parent that is a file or cannot be written
    check_output_file(path, overwrite=force)
    write_text_atomic(path, reference_toml_text(drive))  # a failed write is one WriteError naming the file
    err.print(f"wrote {path}", markup=False)


@command(config_app, "validate")
def config_validate(path: Path = typer.Argument(..., help="Machine description to check."),
                    strict: bool = typer.Option(False, "--strict", help="Implausible values are errors, not "
                                                "warnings."),
                    as_json: bool = JsonOpt):
    """Check a machine description: values, units, assembly over the cycle, cam undercut, and values orders of
    magnitude outside engineering ranges (warnings; errors with --strict).

    Clearances and fits: a pin's radial clearance beyond 10 % of its diameter and a fit whose smallest clearance is
    larger than the described size (no part made to it is that tight) are errors; a size larger than the fit gives
    new is a worn state of it, a size beyond the pair's service limit a worn-out joint (notes).
    \f

    Parameters
    ----------
    path : Path
        Argument: Machine description to check.
    strict : bool
        ``--strict``: Implausible values are errors, not warnings.
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    """
    try:
        from berryshaker.config import validate_machine
        from berryshaker.life.drawing import fit_checks

        machine = _load(path)
        warnings = validate_machine(machine, strict=strict)
        errors, notes = fit_checks(machine)
        if errors:
            raise BerryshakerError(f"{path}: " + "; ".join(errors))
    except BerryshakerError as exc:
        if as_json:
            _print_json({"valid": False, "error": str(exc)})
            raise typer.Exit(code=2)
        _fail(exc)
        return
    if as_json:
        _print_json({"valid": True, "machine": machine.machine.name, "warnings": warnings, "notes": notes})
    else:
        for w in warnings:
            err.print(f"[yellow]warning:[/] {markup_text(w)}", highlight=False)
        for n in notes:
            err.print(f"note: {markup_text(n)}", highlight=False)
        out.print(f"[green]valid[/]: {markup_text(path)} ({markup_text(machine.machine.name)})"
                  + (f" with {len(warnings)} warning(s)" if warnings else ""))
