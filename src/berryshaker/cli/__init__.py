"""Command line: ``berryshaker --help``.

Every command works on the built-in reference machine unless ``--config FILE`` names another machine
description (TOML, units allowed: "0.25 mm", "120 rpm").  ``--json`` prints one JSON object on stdout for
scripts; errors go to stderr as one clear message with exit code 2 and nothing written.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Optional

import typer
from rich.console import Console
from rich.table import Table

from berryshaker import __version__
from berryshaker.errors import BerryshakerError
from berryshaker.report.files import write_provenance

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
doe_app = typer.Typer(help="Plan, analyse and simulate orthogonal field tests (study sec. 2.6, 3.5).",
                      no_args_is_help=True)
app.add_typer(doe_app, name="doe")

out = Console()
err = Console(stderr=True, soft_wrap=True)

ConfigOpt = typer.Option(None, "--config", "-c", help="Machine description (TOML). Default: built-in reference machine.",
                         exists=False, dir_okay=False)
JsonOpt = typer.Option(False, "--json", help="Print one JSON object on stdout instead of tables.")


def _fail(exc: Exception) -> None:
    err.print(f"[bold red]error:[/] {exc}", highlight=False, markup=True)
    raise typer.Exit(code=2)


def _load(config: Optional[Path]):
    from berryshaker.config import load_machine

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
        from berryshaker.drives.groove_cam.kinematics import check_machine, kinematics_summary

        machine = _load(config)
        kin = check_machine(machine, allow_undercut=allow_undercut)
        summary = kinematics_summary(machine, kin)
        summary["machine"] = machine.machine.name
        summary["version"] = __version__
        if plot is not None:
            from berryshaker.report.files import staged_directory
            from berryshaker.report.plots import write_kinematics_figures

            with staged_directory(plot) as stage:
                write_kinematics_figures(machine, kin, stage)
                write_provenance(stage, machine)
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
        from berryshaker.drives.groove_cam.kinematics import check_machine
        from berryshaker.drives.groove_cam.profile_export import write_groove_csv, write_groove_dxf

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
@app.command()
def simulate(
    model: str = typer.Option("mlsd", "--model", "-m",
                              help="mlsd: the study's massless-link clearance model (eq. 4-12); multibody: the "
                                   "planar contact simulation (the study's ADAMS role)."),
    clearance: Optional[str] = typer.Option(
        None, "--clearance",
        help="Clearance sizes, e.g. A=0.25mm,B=0.2mm,C=0.1mm,F=0.2mm (missing pairs keep the config's "
             "value); or row1..row16 of the reconstructed Table 5; level1..level3; none."),
    revolutions: int = typer.Option(3, "--revolutions", "-n", min=2, help="Cam revolutions; statistics use 2..N."),
    mechanism: Optional[Path] = typer.Option(None, "--mechanism",
                                             help="Simulate any mechanism description (TOML) instead of the harvester, "
                                                  "e.g. examples/slider_crank_clearance.toml."),
    duration: Optional[float] = typer.Option(None, "--duration", help="With --mechanism: simulated time (s)."),
    config: Optional[Path] = ConfigOpt,
    as_json: bool = JsonOpt,
    out_dir: Optional[Path] = typer.Option(None, "--out", help="Write time series (CSV, units in the header), "
                                           "summary.json with the resolved input and version, and plots."),
):
    """Collision forces of the clearance joints, comb load moments and drive moment over time.

    Statistics (peak, mean, rms of force magnitudes) are over whole cam revolutions after the first;
    peaks are taken over every integrator step.
    """
    try:
        from berryshaker.experiment.clearance_rows import parse_clearance_spec

        if mechanism is not None:
            _simulate_mechanism_file(mechanism, duration, as_json, out_dir)
            return
        if model not in ("mlsd", "multibody"):
            raise BerryshakerError(f"--model {model!r} is not available; choose mlsd or multibody")
        machine = _load(config)
        sizes = parse_clearance_spec(clearance)
        if model == "mlsd":
            from berryshaker.drives.groove_cam.mlsd import simulate_mlsd

            result = simulate_mlsd(machine, sizes, revolutions=revolutions)
            summary = result.summary()
        else:
            from berryshaker.drives.groove_cam.mechanism import simulate_harvester_multibody

            result, summary = simulate_harvester_multibody(machine, sizes, revolutions=revolutions)
            summary["clearance_mm"] = {k: v * 1e3 for k, v in
                                       machine.with_clearances(sizes).clearance.sizes().items()}
        summary["version"] = __version__
        if out_dir is not None:
            if model == "mlsd":
                _write_simulation(out_dir, result, summary)
            else:
                _write_multibody(out_dir, result, summary, machine.with_clearances(sizes))
            summary["out"] = str(out_dir)
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json(summary)
        return
    t = Table(title=f"{model} model - {machine.machine.name}", header_style="bold")
    for col in ("quantity", "clearance", "peak", "mean", "rms"):
        t.add_column(col, justify="right" if col != "quantity" else "left")
    for pair, st in summary["collision_force_N"].items():
        t.add_row(f"collision force {pair}", f"{summary['clearance_mm'][pair]:.3g} mm", f"{st['peak']:.1f} N",
                  f"{st['mean']:.1f} N", f"{st['rms']:.1f} N")
    for side, st in summary["load_moment_Nm"].items():
        t.add_row(f"{side} comb load moment", "", f"{st['peak']:.2f} N·m", f"{st['mean']:.2f} N·m", f"{st['rms']:.2f} N·m")
    st = summary["drive_moment_Nm"]
    t.add_row("cam drive moment", "", f"{st['peak']:.2f} N·m", f"{st['mean']:.2f} N·m", f"{st['rms']:.2f} N·m")
    for b, st in summary.get("bearing_reaction_N", {}).items():
        t.add_row(f"guide reaction {b}", "", f"{st['peak']:.1f} N", f"{st['mean']:.1f} N", f"{st['rms']:.1f} N")
    out.print(t)
    out.print(f"{summary['statistics_over']}; {summary['steps']} steps in {summary['wall_time_s'] * 1e3:.0f} ms"
              + (f"; wrote {out_dir}" if out_dir is not None else ""))


def _simulate_mechanism_file(path: Path, duration, as_json: bool, out_dir) -> None:
    from berryshaker.multibody.engine import simulate_mechanism
    from berryshaker.multibody.spec import load_mechanism

    spec = load_mechanism(path)
    result = simulate_mechanism(spec, duration=duration)
    summary = result.summary()
    summary["version"] = __version__
    if out_dir is not None:
        import numpy as np

        from berryshaker.report.files import provenance, staged_directory, write_json_atomic, write_text_atomic

        cm = result.compiled
        with staged_directory(out_dir) as stage:
            cols = ["time_s"]
            data = [result.t]
            for i, b in enumerate(spec.bodies):
                for k, lab in enumerate(("x_m", "y_m", "angle_rad")):
                    cols.append(f"{b.name}.{lab}")
                    data.append(result.y[:, 3 * i + k])
            for k, name in enumerate(cm.frc_names):
                cols.append(f"{name}.force_N")
                data.append(result.elements[:, k, 0])
                if cm.frc_kinds[k].endswith("_clearance"):
                    cols.append(f"{name}.penetration_m")
                    data.append(result.elements[:, k, 1])
            arr = np.column_stack(data)
            write_text_atomic(stage / "timeseries.csv", ",".join(cols) + "\n" +
                              "\n".join(",".join(f"{v:.9g}" for v in row) for row in arr) + "\n")
            write_json_atomic(stage / "summary.json", {**summary, "provenance": {
                **provenance(), "mechanism_si": spec.model_dump(mode="json")}})
        summary["out"] = str(out_dir)
    if as_json:
        _print_json(summary)
        return
    t = Table(title=f"multibody - {spec.mechanism.name}", header_style="bold")
    for col in ("joint", "type", "peak", "mean", "rms", "p95"):
        t.add_column(col, justify="left" if col in ("joint", "type") else "right")
    for name, j in summary["joints"].items():
        f = j["force_N"]
        t.add_row(name, j["type"], f"{f['peak']:.1f} N", f"{f['mean']:.1f} N", f"{f['rms']:.1f} N", f"{f['p95']:.1f} N")
    out.print(t)
    for name, j in summary["joints"].items():
        if "first_impact" in j:
            fi = j["first_impact"]
            out.print(f"{name}: first impact at {fi['time_s'] * 1e3:.4f} ms, {fi['impact_velocity_m_s']:.3f} m/s, "
                      f"peak {fi['peak_force_N']:.1f} N")
    out.print(f"{summary['statistics_over']}; {summary['steps']} steps in {summary['wall_time_s'] * 1e3:.0f} ms")


def _write_multibody(out_dir: Path, result, summary: dict, machine) -> None:
    import numpy as np

    from berryshaker.report.files import provenance, staged_directory, write_json_atomic, write_text_atomic
    from berryshaker.report.plots import plot_time_series

    cm = result.compiled
    with staged_directory(out_dir) as stage:
        cols, data = ["time_s"], [result.t]
        for p in "ABCF":
            cols.append(f"F_{p}_N")
            data.append(result.element_force(p) if p in cm.frc_names else result.reaction(p))
        cols += ["T_l_Nm", "T_r_Nm", "drive_moment_Nm"]
        data += [result.element_force("bush_left"), result.element_force("bush_right"),
                 -result.reaction("cam_drive")]
        arr = np.column_stack(data)
        write_text_atomic(stage / "timeseries.csv", ",".join(cols) + "\n" +
                          "\n".join(",".join(f"{v:.9g}" for v in row) for row in arr) + "\n")
        write_json_atomic(stage / "summary.json", {**summary, "provenance": provenance(machine)})
        sel = result.t >= result.stats_from
        plot_time_series(result.t[sel], {f"|F_{p}|": np.abs(arr[sel, 1 + i]) for i, p in enumerate("ABCF")},
                         "collision force (N)", stage / "collision_forces.png",
                         "Clearance collision forces (multibody)")


@app.command()
def compare(
    clearance: Optional[str] = typer.Option("level2", "--clearance",
                                            help="Clearance set (default level2, the study's model check, Table 3)."),
    revolutions: int = typer.Option(3, "--revolutions", "-n", min=2),
    points: int = typer.Option(10, "--points", min=4, help="Samples per curve for the F test (study: about 10)."),
    alpha: float = typer.Option(0.05, "--alpha", help="Significance level of the F test."),
    config: Optional[Path] = ConfigOpt,
    as_json: bool = JsonOpt,
    plot: Optional[Path] = typer.Option(None, "--plot", help="Write overlay plots (PNG) of both models per pair."),
):
    """Run the MLSD and multibody models on the same machine and clearances; compare per pair (eq. 18).

    Reports the study's F statistic with the critical F value of scipy.stats at the stated significance
    and (points-1, points-1) degrees of freedom, and plainer measures: NRMSE, correlation, peak ratio.
    """
    try:
        import numpy as np

        from berryshaker.drives.groove_cam.mechanism import simulate_harvester_multibody
        from berryshaker.drives.groove_cam.mlsd import simulate_mlsd
        from berryshaker.experiment.agreement import curve_agreement
        from berryshaker.experiment.clearance_rows import parse_clearance_spec

        machine = _load(config)
        sizes = parse_clearance_spec(clearance)
        ml = simulate_mlsd(machine, sizes, revolutions=revolutions)
        mbr, mbs = simulate_harvester_multibody(machine, sizes, revolutions=revolutions)
        sel = ml.t >= ml.stats_from
        t = ml.t[sel]
        res = {"clearance_mm": {k: v * 1e3 for k, v in ml.clearance.items()}, "revolutions": revolutions,
               "pairs": {}, "version": __version__}
        series = {}
        for p in "ABCF":
            b = np.abs(ml.series(f"F_{p}_N"))[sel]
            a_full = mbr.element_force(p) if p in mbr.compiled.frc_names else mbr.reaction(p)
            a = np.interp(t, mbr.t, np.abs(a_full))
            res["pairs"][p] = curve_agreement(t, a, b, points=points, alpha=alpha)
            res["pairs"][p]["peak_N"] = {"multibody": float(mbs["collision_force_N"][p]["peak"]),
                                         "mlsd": float(ml.summary()["collision_force_N"][p]["peak"])}
            series[p] = (a, b)
        if plot is not None:
            from berryshaker.report.files import staged_directory
            from berryshaker.report.plots import plot_time_series

            with staged_directory(plot) as stage:
                write_provenance(stage, machine, clearance_mm=res["clearance_mm"])
                for p, (a, b) in series.items():
                    plot_time_series(t, {"multibody": a, "MLSD": b}, "collision force (N)",
                                     stage / f"compare_{p}.png", f"Pair {p}: MLSD vs multibody (study Figs. 14-17)")
            res["plots"] = [str(plot / f"compare_{p}.png") for p in "ABCF"]
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json(res)
        return
    tb = Table(title="MLSD vs multibody (study eq. 18)", header_style="bold")
    for col in ("pair", "F", "F crit", "agree", "NRMSE", "corr", "peak ratio"):
        tb.add_column(col, justify="right")
    for p, r in res["pairs"].items():
        tb.add_row(p, f"{r['f_statistic']:.3f}", f"{r['f_critical']:.3f}", "yes" if r["agree"] else "no",
                   f"{r['nrmse']:.3f}", f"{r['correlation']:.3f}", f"{r['peak_ratio']:.3f}")
    out.print(tb)


def _write_simulation(out_dir: Path, result, summary: dict) -> None:
    import numpy as np

    from berryshaker.drives.groove_cam.mlsd import RESULT_COLUMNS
    from berryshaker.report.files import provenance, staged_directory, write_json_atomic, write_text_atomic
    from berryshaker.report.plots import plot_time_series

    with staged_directory(out_dir) as stage:
        cols = ["time_s", "cam_angle_deg", "x_m", "theta_D_rad", "u_m", "theta_E_rad"] + list(RESULT_COLUMNS)
        data = [result.t, np.degrees(result.t * result.machine.cam.speed)] + [result.state[:, i] for i in range(4)]
        data += [result.results[:, idx] for idx, _ in RESULT_COLUMNS.values()]
        arr = np.column_stack(data)
        lines = [",".join(cols)] + [",".join(f"{v:.9g}" for v in row) for row in arr]
        write_text_atomic(stage / "timeseries.csv", "\n".join(lines) + "\n")
        write_json_atomic(stage / "summary.json", {**summary, "provenance": provenance(result.machine)})
        sel = result.t >= result.stats_from
        plot_time_series(result.t[sel], {f"|F_{p}|": np.abs(result.series(f"F_{p}_N"))[sel] for p in "ABCF"},
                         "collision force (N)", stage / "collision_forces.png",
                         "Clearance collision forces (MLSD, study eq. 8)")
        plot_time_series(result.t[sel], {"T_l": result.series("T_l_Nm")[sel], "T_r": result.series("T_r_Nm")[sel],
                                         "M (cam)": result.series("drive_moment_Nm")[sel]},
                         "moment (N m)", stage / "moments.png", "Comb load moments and cam drive moment")


# ----------------------------------------------------------------------------------------------
def _branch_of(machine):
    from berryshaker.plant.branch import Branch

    if machine.plant is None:
        raise BerryshakerError("the machine description has no [plant] block (see `berryshaker config init`)")
    b = machine.plant.branch
    return Branch(b.root_diameter, b.tip_diameter, b.length, b.elastic_modulus, b.density, b.damping_ratio)


@app.command()
def plant(
    config: Optional[Path] = ConfigOpt,
    as_json: bool = JsonOpt,
    n_modes: int = typer.Option(4, "--modes", min=1, max=20, help="Number of bending modes."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Write the mode-shape figure (PNG) to DIR."),
):
    """Bending modes of the tapered branch: the Bessel solution (eq. 15) checked against finite elements."""
    try:
        from berryshaker.plant.modes import analytic_modes, fe_modes

        machine = _load(config)
        br = _branch_of(machine)
        ma = analytic_modes(br, n_modes)
        mf = fe_modes(br, n_modes)
        res = {
            "alpha": br.alpha,
            "branch_mass_kg": br.mass,
            "modes": [{"frequency_hz": float(f), "omega_rad_s": float(w)} for f, w in zip(ma.frequency_hz, ma.omega)],
            "modes_fe": [{"frequency_hz": float(f)} for f in mf.frequency_hz],
            "max_relative_difference": float(max(abs(mf.frequency_hz - ma.frequency_hz) / ma.frequency_hz)),
            "version": __version__,
        }
        if plot is not None:
            from berryshaker.report.files import staged_directory
            from berryshaker.report.plots import plot_mode_shapes

            with staged_directory(plot) as stage:
                plot_mode_shapes(ma, mf, stage / "mode_shapes.png")
                write_provenance(stage, machine)
            res["plots"] = [str(plot / "mode_shapes.png")]
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json(res)
        return
    t = Table(title=f"Branch modes (alpha = {res['alpha']:.3f}, mass {res['branch_mass_kg'] * 1e3:.1f} g)",
              header_style="bold")
    for col in ("mode", "Bessel (eq. 15)", "finite elements", "difference"):
        t.add_column(col, justify="right")
    for i, (a, f) in enumerate(zip(res["modes"], res["modes_fe"])):
        t.add_row(str(i + 1), f"{a['frequency_hz']:.4f} Hz", f"{f['frequency_hz']:.4f} Hz",
                  f"{abs(f['frequency_hz'] - a['frequency_hz']) / a['frequency_hz']:.1e}")
    out.print(t)


@app.command("fruit-force")
def fruit_force_cmd(
    clearance: Optional[str] = typer.Option(None, "--clearance", help="Clearance set, as for simulate."),
    config: Optional[Path] = ConfigOpt,
    as_json: bool = JsonOpt,
    plot: Optional[Path] = typer.Option(None, "--plot", help="Write fruit force vs distance (Figs. 24-26) to DIR."),
    out_dir: Optional[Path] = typer.Option(None, "--out", help="Write the time series (CSV) and summary."),
):
    """Drive the multibody harvester past a branch (rigid-flexible coupling) and report the fruit force.

    Fruit harvesting force F = m0 x acceleration (eq. 16) at the root, middle and end fruit against the
    machine-to-plant distance, with the eq. 17 verdict and the study's ranges beside ours.
    """
    try:
        from berryshaker.experiment.clearance_rows import parse_clearance_spec
        from berryshaker.plant.coupled import STUDY_FRUIT_FORCE_N, simulate_fruit_force

        machine = _load(config)
        sizes = parse_clearance_spec(clearance)
        res = simulate_fruit_force(machine, sizes)
        summary = res.summary()
        summary["version"] = __version__
        if plot is not None or out_dir is not None:
            import numpy as np

            from berryshaker.report.files import provenance, staged_directory, write_json_atomic, write_text_atomic
            from berryshaker.report.plots import plot_fruit_force

            if plot is not None:
                with staged_directory(plot) as stage:
                    plot_fruit_force(res.distance, res.fruit_force, STUDY_FRUIT_FORCE_N, stage / "fruit_force.png")
                    write_provenance(stage, res.machine)
                summary["plots"] = [str(plot / "fruit_force.png")]
            if out_dir is not None:
                with staged_directory(out_dir) as stage:
                    cols = ["time_s", "distance_m"] + [f"fruit_{n}_N" for n in res.fruit_force] + \
                        [f"{n}_contact_N" for n in res.contact_force]
                    arr = np.column_stack([res.t, res.distance, *res.fruit_force.values(), *res.contact_force.values()])
                    write_text_atomic(stage / "fruit_force.csv", ",".join(cols) + "\n" +
                                      "\n".join(",".join(f"{v:.7g}" for v in row) for row in arr[::5]) + "\n")
                    write_json_atomic(stage / "summary.json", {**summary, "provenance": provenance(res.machine)})
                summary["out"] = str(out_dir)
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json(summary)
        return
    t = Table(title="Fruit harvesting force (eq. 16-17)", header_style="bold")
    for col in ("fruit", "z", "peak", "study range", "ripe fruit", "unripe fruit"):
        t.add_column(col, justify="right")
    for name, p in summary["positions"].items():
        rng = p.get("study_range_N")
        t.add_row(name, f"{p['z_m']:.2f} m", f"{p['peak_force_N']:.3f} N",
                  f"{rng[0]}-{rng[1]} N" if rng else "", p["eq17"]["ripe"], p["eq17"]["unripe"])
    out.print(t)
    out.print(f"force rises from root to end: {'yes' if summary['rises_root_to_end'] else 'no'}; "
              f"{summary['steps']} steps in {summary['wall_time_s']:.2f} s")


# ----------------------------------------------------------------------------------------------
def _parse_weights(text: Optional[str]) -> Optional[dict]:
    if not text:
        return None
    out = {}
    for part in text.split(","):
        if "=" not in part:
            raise BerryshakerError(f"--weights: {part!r} is not NAME=VALUE")
        k, v = (s.strip() for s in part.split("=", 1))
        try:
            out[k] = float(v)
        except ValueError:
            raise BerryshakerError(f"--weights: {v!r} is not a number") from None
        if out[k] < 0:
            raise BerryshakerError(f"--weights: {k} must be >= 0")
    return out


@doe_app.command("plan")
def doe_plan(
    array: str = typer.Option("L9", "--array", help="L4, L8, L9, L16, L18 or L27."),
    factor: list[str] = typer.Option(..., "--factor", help="NAME=v1,v2,v3[unit], e.g. A=0.25,0.5,0.75mm; repeat."),
    randomize: bool = typer.Option(False, "--randomize", help="Randomise the run order (needs --seed)."),
    seed: Optional[int] = typer.Option(None, "--seed", help="Seed of the randomised order."),
    out_file: Path = typer.Option(..., "--out", "-o", help="Field sheet CSV; a printable .html is written beside it."),
):
    """Write a field sheet: run, run order, factor levels (units in the header), empty response columns."""
    try:
        from berryshaker.experiment.field_sheet import parse_factor, plan_html, plan_table
        from berryshaker.report.files import write_text_atomic

        factors = [parse_factor(f) for f in factor]
        names = [f.name for f in factors]
        if len(set(names)) != len(names):
            raise BerryshakerError("factor names must be distinct")
        df = plan_table(array, factors, randomize, seed)
        write_text_atomic(out_file, df.to_csv(index=False))
        write_text_atomic(out_file.with_suffix(".html"), plan_html(df, f"berryshaker field sheet: {array} test of "
                                                                       f"{', '.join(names)}"))
    except BerryshakerError as exc:
        _fail(exc)
        return
    err.print(f"wrote {out_file} and {out_file.with_suffix('.html')} ({len(df)} runs)")


@doe_app.command("analyze")
def doe_analyze(
    results: Path = typer.Argument(..., help="Filled field sheet (CSV)."),
    maximize: str = typer.Option("", "--maximize", help="Responses where larger is better, e.g. efficiency."),
    minimize: str = typer.Option("", "--minimize", help="Responses where smaller is better, e.g. unripe,damage."),
    weights: Optional[str] = typer.Option(None, "--weights", help="e.g. efficiency=0.5,damage=0.3,unripe=0.2"),
    as_json: bool = JsonOpt,
    plot: Optional[Path] = typer.Option(None, "--plot", help="Main-effect plots and response surfaces (PNG)."),
):
    """Range analysis, weighted optimum, pooled ANOVA and the eq. 19 regression of a field test.

    Responses: efficiency, unripe, damage (from indexes or raw masses in the sheet) or any numeric column.
    """
    try:
        import numpy as np

        from berryshaker.experiment.analysis import analyze
        from berryshaker.experiment.field_sheet import read_results

        senses = {r.strip(): True for r in maximize.split(",") if r.strip()}
        senses.update({r.strip(): False for r in minimize.split(",") if r.strip()})
        if not senses:
            raise BerryshakerError("name at least one response with --maximize or --minimize")
        fr = read_results(results, list(senses))
        df = fr.table
        levels = df[fr.factors].to_numpy(int)
        value_cols = [next((c for c in df.columns if c.startswith(n + "_") and not c.endswith("_level")), None)
                      for n in fr.factor_names]
        values = np.column_stack([df[c].to_numpy(float) if c else levels[:, i] for i, c in enumerate(value_cols)])
        res = analyze(levels, values, fr.factor_names, fr.responses, senses, _parse_weights(weights))
        res["version"] = __version__
        if plot is not None:
            from berryshaker.report.files import staged_directory
            from berryshaker.report.plots import plot_main_effects, plot_response_surfaces

            with staged_directory(plot) as stage:
                plot_main_effects(res, stage / "main_effects.png")
                write_provenance(stage, results_file=str(results))
                from berryshaker.experiment.analysis import quadratic_regression

                for r, y in fr.responses.items():
                    if len(fr.factor_names) >= 2:
                        plot_response_surfaces(values, y, fr.factor_names,
                                               quadratic_regression(values, y, fr.factor_names), r,
                                               stage / f"surface_{r}.png")
            res["plots"] = sorted(str(p) for p in plot.glob("*.png"))
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json(res)
        return
    _print_doe(res)


def _print_doe(res: dict) -> None:
    for name, ra in res["responses"].items():
        t = Table(title=f"{name} ({'maximise' if ra['maximize'] else 'minimise'}): range analysis", header_style="bold")
        t.add_column("factor")
        nlev = len(next(iter(ra["factors"].values()))["level_means"])
        for j in range(nlev):
            t.add_column(f"k{j + 1}", justify="right")
        for col in ("R", "best", "ANOVA F", "p"):
            t.add_column(col, justify="right")
        an = ra["anova"]["factors"]
        for f, d in ra["factors"].items():
            a = an.get(f)
            t.add_row(f, *[f"{v:.4g}" for v in d["level_means"]], f"{d['range']:.4g}", str(d["best_level"]),
                      f"{a['f']:.3g}" if a else "pooled", f"{a['p']:.3g}" if a else "")
        out.print(t)
        reg = ra["regression"]
        out.print(f"  ranking {' > '.join(ra['ranking'])}; eq. 19 full quadratic: rank {reg['full_model_rank']} "
                  f"of {len(reg['full_model_terms'])} terms, aliased: {', '.join(reg['aliased_terms']) or 'none'}; "
                  f"main-effects quadratic R² = {reg['main_effects_quadratic']['r2']:.3f} with "
                  f"{reg['main_effects_quadratic']['residual_df']} residual df")
    o = res["optimum"]
    out.print("[bold]weighted optimum[/]: " + " ".join(f"{f}{lv}" for f, lv in o["levels"].items()) + "  predicted "
              + ", ".join(f"{k} {v:.3g}" for k, v in o["values"].items()))


@doe_app.command("virtual")
def doe_virtual(
    config: Optional[Path] = ConfigOpt,
    as_json: bool = JsonOpt,
    workers: Optional[int] = typer.Option(None, "--workers", help="Processes (default: all cores)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="Dask scheduler address."),
    cache: Optional[Path] = typer.Option(None, "--cache", help="Run cache folder."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Main-effect plots and response surfaces (PNG)."),
):
    """The study's L9 clearance test run through the virtual harvest and analysed like field data.

    The 27 coupled machine-plant runs go through the cached sweep runner (a repeat is instant).
    """
    try:
        from berryshaker.experiment.virtual_test import virtual_orthogonal_test
        from berryshaker.runs.runner import SweepRunner

        machine = _load(config)
        runner = SweepRunner(workers=workers, scheduler=scheduler, cache_dir=cache, progress=not as_json, console=err)
        res = virtual_orthogonal_test(machine, runner)
        res["version"] = __version__
        if plot is not None:
            import numpy as np

            from berryshaker.experiment.analysis import quadratic_regression
            from berryshaker.report.files import staged_directory
            from berryshaker.report.plots import plot_main_effects, plot_response_surfaces

            values = np.array([[r["clearance_mm"][p] for p in "ABCF"] for r in res["runs"]])
            with staged_directory(plot) as stage:
                plot_main_effects(res, stage / "main_effects.png", "Virtual L9 test: main effects")
                write_provenance(stage, machine)
                for r in ("efficiency", "unripe", "damage"):
                    y = np.array([run[r] for run in res["runs"]])
                    plot_response_surfaces(values, y, list("ABCF"), quadratic_regression(values, y, list("ABCF")),
                                           r, stage / f"surface_{r}.png")
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json(res)
        return
    t = Table(title="Virtual L9 field test", header_style="bold")
    for col in ("run", "A", "B", "C", "F", "efficiency", "unripe", "damage"):
        t.add_column(col, justify="right")
    for r in res["runs"]:
        t.add_row(str(r["run"]), *[f"{r['clearance_mm'][p]:g}" for p in "ABCF"], f"{r['efficiency']:.3f} kg/min",
                  f"{r['unripe']:.2f} %", f"{r['damage']:.2f} %")
    out.print(t)
    _print_doe(res)
    rec = res["recommended"]
    out.print(f"recommended {rec['code']} ({', '.join(f'{k} {v} mm' for k, v in rec['clearance_mm'].items())}); "
              f"study: {rec['study']['code']}")


# ----------------------------------------------------------------------------------------------
CacheOpt = typer.Option(None, "--cache", help="Run cache folder (default ~/.cache/berryshaker/runs or $BERRYSHAKER_CACHE).")


@app.command()
def study(
    config: Optional[Path] = ConfigOpt,
    out_dir: Path = typer.Option(Path("berryshaker-study"), "--out", help="Output folder (replaced atomically)."),
    workers: Optional[int] = typer.Option(None, "--workers", help="Local processes (default: all cores)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="Dask scheduler, e.g. tcp://10.0.0.5:8786."),
    cache: Optional[Path] = CacheOpt,
    no_cache: bool = typer.Option(False, "--no-cache", help="Recompute every run."),
    as_json: bool = JsonOpt,
):
    """The whole study on the reference machine (or --config): report.html, summary.json, tables, figures.

    Kinematics; MLSD vs multibody agreement (eq. 18); clearance rows 1-16; comb moments; fruit force;
    the virtual L9 field test with range analysis and regression; a claims table with verdicts.
    Interrupted? Run it again: finished runs come from the cache.
    """
    try:
        from berryshaker.drives.groove_cam.kinematics import check_machine
        from berryshaker.study.pipeline import run_study
        from berryshaker.runs.runner import SweepRunner

        machine = _load(config)  # a config that fails validation stops here, before any simulation
        check_machine(machine)
        if machine.plant is None:
            raise BerryshakerError("the study needs a [plant] block in the machine description")
        runner = SweepRunner(workers=workers, scheduler=scheduler, cache_dir=cache, use_cache=not no_cache,
                             progress=not as_json, console=err)
        summary = run_study(machine, out_dir, runner, console=None if as_json else err)
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json(summary)
        return
    t = Table(title="Claims of the study", header_style="bold")
    t.add_column("#")
    t.add_column("verdict")
    t.add_column("claim")
    for c in summary["claims"]:
        color = {"reproduced": "green", "not reproduced": "red"}.get(c["verdict"], "yellow")
        t.add_row(str(c["id"]), f"[{color}]{c['verdict']}[/]", c["claim"])
    out.print(t)
    o = summary["optimum"]
    if o is not None:
        out.print(f"recommended {o['code']}: " + ", ".join(f"{p} {v:g} mm" for p, v in o["clearance_mm"].items())
                  + f" -> {o['efficiency_kg_min']:.2f} kg/min, {o['unripe_rate_pct']:.2f} % unripe, "
                    f"{o['damage_rate_pct']:.2f} % damage (study A1B1C1F3: 3.93 kg/min, 3.1 %, 2.8 %)")
    for f in summary.get("failures", []):
        out.print(f"[red]failed[/] {f['step']} run {f['run']} ({f['inputs']}): {f['error']}")
    out.print(f"report: {out_dir / 'report.html'}  ({summary['timings_s']['total']:.0f} s)")


# ----------------------------------------------------------------------------------------------
@app.command()
def sweep(
    param: list[str] = typer.Option(..., "--param", help="KEY=LO..HI[unit], KEY=v1,v2,...[unit] or KEY=MEAN+-SD[unit]; "
                                    "KEY is a dotted path of the machine description, e.g. clearance.A.size. Repeat."),
    method: str = typer.Option("grid", "--method", help="grid (ranges get --points levels), lhs or montecarlo."),
    points: int = typer.Option(3, "--points", "-n", min=1, help="Grid levels per range, or samples for lhs/montecarlo."),
    seed: int = typer.Option(0, "--seed", help="Seed of lhs / montecarlo sampling."),
    model: str = typer.Option("mlsd", "--model", help="mlsd or multibody."),
    revolutions: int = typer.Option(3, "--revolutions", min=2),
    config: Optional[Path] = ConfigOpt,
    out_file: Optional[Path] = typer.Option(None, "--out", help="Tidy results table (CSV)."),
    workers: Optional[int] = typer.Option(None, "--workers"),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="Dask scheduler address."),
    cache: Optional[Path] = CacheOpt,
    as_json: bool = JsonOpt,
):
    """Factor grid, Latin hypercube or Monte Carlo (tolerances, wear) over any machine parameter.

    Every point is validated and simulated through the cached sweep runner; a failed point is recorded
    with its error and the others finish.
    """
    try:
        import csv
        import io

        from berryshaker.runs.runner import SweepRunner
        from berryshaker.runs.sweep import model_run, parse_param, sample_params, tidy_rows

        if model not in ("mlsd", "multibody"):
            raise BerryshakerError(f"--model {model!r}: choose mlsd or multibody")
        machine = _load(config)
        params = [parse_param(p) for p in param]
        pts = sample_params(params, method, points, seed)
        data = machine.model_dump(mode="json")
        jobs = [dict(machine_data=data, overrides={p.key: v * p.factor for p, v in zip(params, pt)},
                     model=model, revolutions=revolutions) for pt in pts]
        runner = SweepRunner(workers=workers, scheduler=scheduler, cache_dir=cache, progress=not as_json, console=err)
        results = runner.map(model_run, jobs, f"sweep ({method}, {len(jobs)} runs)")
        header, rows = tidy_rows(params, pts, results)
        if out_file is not None:
            from berryshaker.report.files import write_text_atomic

            buf = io.StringIO()
            w = csv.writer(buf)
            w.writerow(header)
            w.writerows(rows)
            write_text_atomic(out_file, buf.getvalue())
    except BerryshakerError as exc:
        _fail(exc)
        return
    failed = sum(1 for r in results if r.error)
    if as_json:
        _print_json({"columns": header, "rows": rows, "failed": failed, "runs": len(rows), "version": __version__})
        return
    t = Table(title=f"sweep: {len(rows)} runs, {failed} failed", header_style="bold")
    show = header[: len(params) + 2] + [c for c in header if c.endswith("_peak_N")][:4]
    for c in show:
        t.add_column(c, justify="right")
    for row in rows[:40]:
        d = dict(zip(header, row))
        t.add_row(*[f"{d[c]:.4g}" if isinstance(d[c], float) else str(d[c]) for c in show])
    out.print(t)
    if failed:
        for r in results:
            if r.error:
                out.print(f"[red]run {r.index + 1} failed[/]: {r.error}")
    if out_file is not None:
        out.print(f"wrote {out_file}")


# ----------------------------------------------------------------------------------------------
@config_app.command("show")
def config_show(config: Optional[Path] = ConfigOpt, as_json: bool = JsonOpt):
    """Print the resolved machine description (engineering units; --json gives SI)."""
    try:
        from berryshaker.config import machine_table

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
    from berryshaker.config import reference_toml_text
    from berryshaker.report.files import write_text_atomic

    if path.exists() and not force:
        _fail(BerryshakerError(f"{path} exists; use --force to overwrite"))
    write_text_atomic(path, reference_toml_text())
    err.print(f"wrote {path}")


@config_app.command("validate")
def config_validate(path: Path = typer.Argument(..., help="Machine description to check."),
                    as_json: bool = JsonOpt):
    """Check a machine description: values, units, assembly over the cycle, cam undercut."""
    try:
        from berryshaker.drives.groove_cam.kinematics import check_machine

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
