"""Drive dynamics: ``simulate`` (reduced or multibody model, or any mechanism file) and ``compare``."""

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
    check_number,
    check_range,
    command,
    err,
    out,
    print_table,
)
from berryshaker.errors import BerryshakerError
from berryshaker.outputs import write_provenance
from berryshaker.user_text import markup_text


def _check_folders(*folders, kind: str = "simulate --out") -> None:
    """Refuse output folders that hold files berryshaker did not write, before any work."""
    from berryshaker.outputs import prepare_output_dir

    for f in folders:
        if f is not None:
            prepare_output_dir(f, kind=kind)


@command(app)
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
    driveline: Optional[str] = typer.Option(None, "--driveline",
                                            help="imposed: the drive shaft turns at its nominal speed; powered: the "
                                                 "motor, belt, CVT and worm of [driveline] turn it (multibody model; "
                                                 "cam speed, ripple, input power, energy lost per joint). Default: "
                                                 "the description's [driveline] mode (imposed without one)."),
    config: Optional[Path] = ConfigOpt,
    as_json: bool = JsonOpt,
    out_dir: Optional[Path] = typer.Option(None, "--out", help="Write time series (CSV, units in the header), "
                                           "summary.json with the resolved input and version, and plots."),
):
    """Collision forces of the clearance joints, comb load moments and drive moment over time.

    Statistics (peak, mean, rms of force magnitudes) are over whole cam revolutions after the first;
    peaks are taken over every integrator step.  The multibody model also gives each pair's static-equivalent
    load, the p95 of its impact peaks: the load to size from (a run's single peak is an extreme).
    \f

    Parameters
    ----------
    model : str
        ``--model``: mlsd: the study's massless-link clearance model (eq. 4-12); multibody: the planar contact
        simulation (the study's ADAMS role).
    clearance : str, optional
        ``--clearance``: Clearance sizes, e.g. A=0.25mm,B=0.2mm,C=0.1mm,F=0.2mm (missing pairs keep the config's
        value); or row1..row16 of the reconstructed Table 5; level1..level3; none.
    revolutions : int
        ``--revolutions``: Cam revolutions; statistics use 2..N.
    mechanism : Path, optional
        ``--mechanism``: Simulate any mechanism description (TOML) instead of the harvester, e.g.
        examples/slider_crank_clearance.toml.
    duration : float, optional
        ``--duration``: With --mechanism: simulated time (s).
    driveline : str, optional
        ``--driveline``: imposed: the drive shaft turns at its nominal speed; powered: the motor, belt, CVT and worm
        of [driveline] turn it (multibody model; cam speed, ripple, input power, energy lost per joint). Default:
        the description's [driveline] mode (imposed without one).
    config : Path, optional
        ``--config``: Machine description (TOML). Default: built-in reference machine.
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    out_dir : Path, optional
        ``--out``: Write time series (CSV, units in the header), summary.json with the resolved input and version,
        and plots.
    """
    try:
        from berryshaker.experiment.clearance_sets import parse_clearance_spec

        _check_folders(out_dir)
        if mechanism is not None:
            _simulate_mechanism_file(mechanism, duration, as_json, out_dir)
            return
        from berryshaker.drives import drive_of

        machine = _load(config)
        drive = drive_of(machine)
        if model not in ("mlsd", "multibody", "reduced"):
            raise BerryshakerError(f"--model {model!r} is not available; choose mlsd (reduced) or multibody")
        if model in ("mlsd", "reduced") and drive.reduced_model is None:
            raise BerryshakerError(f"the {drive.name} drive has no reduced model; use --model multibody")
        sizes = parse_clearance_spec(clearance, machine)
        from berryshaker.drives.powered import is_powered, with_driveline_mode

        machine = with_driveline_mode(machine, driveline)
        if is_powered(machine) and model != "multibody":
            raise BerryshakerError("the powered driveline runs in the multibody model: add --model multibody "
                                   "(or --driveline imposed)")
        import math

        from berryshaker.multibody.engine import check_output_samples

        # simulate -n 100000000 would allocate terabytes: refuse before any work
        check_output_samples(revolutions * 2 * math.pi / machine.drive_speed, 1e-4, "use fewer --revolutions")
        if model in ("mlsd", "reduced"):
            model = "mlsd"
            result = drive.reduced_model(machine, sizes, revolutions=revolutions)
            summary = result.summary()
        else:
            from berryshaker.drives.simulation import simulate_multibody

            result, summary = simulate_multibody(machine, sizes, revolutions=revolutions)
            summary.setdefault("driveline_mode", "imposed")
            guide = _guide_reaction(result)
            if guide is not None:
                summary["guide_reaction_N"] = guide
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
    rows = []
    for pair, st in summary["collision_force_N"].items():
        design = f"{st['static_equivalent']:.1f} N" if "static_equivalent" in st else "-"
        rows.append([f"collision force {pair}", f"{summary['clearance_mm'][pair]:.3g} mm", design, f"{st['peak']:.1f} N",
                     f"{st['mean']:.1f} N", f"{st['rms']:.1f} N"])
    for side, st in summary["load_moment_Nm"].items():
        rows.append([f"{side} comb load moment", "", "", f"{st['peak']:.2f} N·m", f"{st['mean']:.2f} N·m",
                     f"{st['rms']:.2f} N·m"])
    st = summary["drive_moment_Nm"]
    design = f"{st['design']:.2f} N·m" if "design" in st else "-"
    rows.append([f"{drive.driver} drive moment", "", design, f"{st['peak']:.2f} N·m", f"{st['mean']:.2f} N·m",
                 f"{st['rms']:.2f} N·m"])
    for b, st in summary.get("bearing_reaction_N", {}).items():
        rows.append([f"guide reaction {b}", "", "", f"{st['peak']:.1f} N", f"{st['mean']:.1f} N", f"{st['rms']:.1f} N"])
    for b, st in summary.get("guide_reaction_N", {}).items():
        if isinstance(st, dict):
            rows.append([f"guide reaction {b}", "", "", f"{st['peak']:.1f} N", f"{st['mean']:.1f} N",
                         f"{st['rms']:.1f} N"])
    print_table(("quantity", "clearance", "design (p95)", "peak (extreme)", "mean", "rms"), rows,
                title=f"{model} model - {machine.machine.name}")
    if any("static_equivalent" in st for st in summary["collision_force_N"].values()):
        out.print("design (p95): a pair's static-equivalent load, the p95 of its impact peaks over the statistics "
                  "window, and the drive's design torque, the p95 of its per-revolution peaks (the loads to size from, "
                  "docs/life.md \"Sizing loads\"); peak: the run's single largest value, an extreme",
                  markup=False, highlight=False)
    if summary.get("load_moment_Nm"):
        out.print(load_moment_note(summary.get("load_model") or "aggregate (no plant in this run)"), markup=False,
                  highlight=False)
    if summary.get("driveline_mode") == "powered":
        sp = summary["cam_speed_rpm"]
        out.print(f"powered driveline: drive-shaft speed {sp['min']:.2f} .. {sp['max']:.2f} r/min (mean {sp['mean']:.2f}), "
                  f"ripple {summary['speed_ripple_percent']:.2f} %, input power {summary['input_power_W']:.1f} W; "
                  "energy lost per revolution: " + ", ".join(
                      f"{k} {v:.3g} J" for k, v in summary["energy_per_revolution_J"].items()))
    out.print(f"{summary['statistics_over']}; {summary['steps']} steps in {summary['wall_time_s'] * 1e3:.0f} ms"
              + (f"; wrote {out_dir}" if out_dir is not None else ""))


def load_moment_note(load_model: str) -> str:
    """What a printed comb load moment is: per comb, about its shaft, and under which load model.

    The aggregate bush spring-damper (every run without a plant: ``simulate``, ``compare``, the study's rows) loads
    the combs about 40 times more than the explicit bush of branches (the study report's bush section: peaks
    14-18 N m, about 1 N m rms, against about 81 N m peak and 48 N m rms here; docs/plant.md, "the explicit bush
    loads the combs about 40 times less").

    Parameters
    ----------
    load_model : str
        The run's load model description; one starting with "aggregate" is the aggregate bush spring-damper.

    Returns
    -------
    str
        One line for the terminal naming the load model and, for the aggregate bush, how its moments compare
        with the explicit bush's.
    """
    if load_model.startswith("aggregate"):
        return ("comb load moment: the load's moment about each comb's shaft, one comb at a time; load model: the "
                "aggregate bush spring-damper (200 N m/rad, 20 N m s/rad [assumed], no plant in this run), which loads "
                "the combs about 40 times more than the explicit bush of branches (peaks 14-18 N m, about 1 N m rms; "
                "docs/plant.md)")
    return (f"comb load moment: the load's moment about each comb's shaft, one comb at a time; load model: "
            f"{load_model}")


def _guide_reaction(result) -> dict | None:
    """Reaction of the push-rod guide (a prismatic joint named "guide") in the multibody model: the net force
    normal to the guide, G + H of the MLSD table (the engine does not split it between the two bearings), with
    peak, mean and rms of its magnitude over the statistics window, from the written samples.  None when the
    mechanism has no joint "guide"."""
    import numpy as np

    if "guide" not in result.compiled.con_names:
        return None
    sel = result.t >= result.stats_from - 1e-12
    y = np.abs(np.asarray(result.reaction("guide"), float)[sel])
    return {"G+H (net normal)": {"peak": float(y.max()), "mean": float(y.mean()),
                                 "rms": float(np.sqrt(np.mean(y**2)))},
            "note": "net force normal to the push-rod guide (G + H); peaks from the written samples"}


def _simulate_mechanism_file(path: Path, duration, as_json: bool, out_dir) -> None:
    from berryshaker.multibody.engine import simulate_mechanism
    from berryshaker.multibody.spec import load_mechanism

    spec = load_mechanism(path)
    result = simulate_mechanism(spec, duration=duration)
    summary = result.summary()
    summary["version"] = __version__
    if out_dir is not None:
        import numpy as np

        from berryshaker.outputs import provenance, staged_directory, write_json_atomic, write_text_atomic
        from berryshaker.report.tables import csv_text

        cm = result.compiled
        with staged_directory(out_dir, kind="simulate --out") as stage:
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
            write_text_atomic(stage / "timeseries.csv", csv_text(cols, arr.tolist(), ".9g"))
            write_json_atomic(stage / "summary.json", {**summary, "provenance": {
                **provenance(), "mechanism_si": spec.model_dump(mode="json")}})
        summary["out"] = str(out_dir)
    if as_json:
        _print_json(summary)
        return
    rows = [[name, j["type"], *(f"{j['force_N'][k]:.1f} N" for k in ("peak", "mean", "rms", "p95"))]
            for name, j in summary["joints"].items()]
    print_table(("joint", "type", "peak", "mean", "rms", "p95"), rows, title=f"multibody - {spec.mechanism.name}",
                justify=("left",) * 2 + ("right",) * 4)
    for name, j in summary["joints"].items():
        if "first_impact" in j:
            fi = j["first_impact"]
            out.print(f"{name}: first impact at {fi['time_s'] * 1e3:.4f} ms, {fi['impact_velocity_m_s']:.3f} m/s, "
                      f"peak {fi['peak_force_N']:.1f} N")
    out.print(f"{summary['statistics_over']}; {summary['steps']} steps in {summary['wall_time_s'] * 1e3:.0f} ms")


def _write_multibody(out_dir: Path, result, summary: dict, machine) -> None:
    import numpy as np

    from berryshaker.outputs import provenance, staged_directory, write_json_atomic, write_text_atomic
    from berryshaker.report.plots import plot_joint_forces
    from berryshaker.report.tables import csv_text

    cm = result.compiled
    with staged_directory(out_dir, kind="simulate --out") as stage:
        cols, data = ["time_s"], [result.t]
        pairs = machine.pair_names
        for p in pairs:
            cols.append(f"F_{p}_N")
            data.append(result.element_force(p) if p in cm.frc_names else result.reaction(p))
        cols += ["T_l_Nm", "T_r_Nm", "drive_moment_Nm"]
        from berryshaker.drives.simulation import drive_moment

        data += [result.element_force("bush_left"), result.element_force("bush_right"), drive_moment(result)]
        if "mesh" in cm.frc_names:  # powered driveline: the drive shaft's speed
            shaft = int(cm.model.fint[cm.frc_names.index("mesh"), 1])
            cols.append("drive_shaft_speed_rpm")
            data.append(np.abs(result.y[:, cm.n + 3 * shaft + 2]) * 30.0 / np.pi)
        if "guide" in cm.con_names:
            cols.append("guide_normal_N")
            data.append(result.reaction("guide"))
        arr = np.column_stack(data)
        write_text_atomic(stage / "timeseries.csv", csv_text(cols, arr.tolist(), ".9g"))
        write_json_atomic(stage / "summary.json", {**summary, "provenance": provenance(machine)})
        sel = result.t >= result.stats_from
        sizes_txt = ", ".join(f"{p} {v * 1e3:g} mm" for p, v in machine.clearance_sizes().items())
        plot_joint_forces(result.t[sel], {p: np.abs(arr[sel, 1 + i]) for i, p in enumerate(pairs)},
                          stage / "collision_forces.png",
                          f"Clearance collision forces (multibody), clearances {sizes_txt}",
                          peaks={p: st["peak"] for p, st in summary["collision_force_N"].items()})


@command(app)
def compare(
    clearance: Optional[str] = typer.Option("level2", "--clearance",
                                            help="Clearance set (default level2, the study's model check, Table 3)."),
    revolutions: int = typer.Option(3, "--revolutions", "-n", min=2, max=200, help="Cam revolutions (2..200)."),
    points: int = typer.Option(10, "--points", min=4, max=10_000,
                               help="Samples per curve for the F test (study: about 10; 4..10000)."),
    alpha: float = typer.Option(0.05, "--alpha", help="Significance level of the F test."),
    config: Optional[Path] = ConfigOpt,
    as_json: bool = JsonOpt,
    plot: Optional[Path] = typer.Option(None, "--plot", help="Write overlay plots (PNG) of both models per pair."),
    starts: int = typer.Option(8, "--starts", min=0,
                               help="Replicate starts of each model for the verdict (multibody: clearances eccentric, "
                                    "drive turned; MLSD: cam turned); 0: only the centred runs (one draw of a "
                                    "chaotic impact sequence, no verdict on the statistics)."),
    workers: Optional[int] = typer.Option(None, "--workers", help="Local processes for the replicate starts "
                                          "(default: every core this process may run on)."),
    cache: Optional[str] = typer.Option(None, "--cache", help="Run cache folder of the replicate starts "
                                         "(default ~/.cache/berryshaker/runs or $BERRYSHAKER_CACHE)."),
):
    """Run the MLSD and multibody models on the same machine and clearances; compare per pair (eq. 18).

    The curves: one run of each model from the centred start, the study's F statistic with the critical F value
    of scipy.stats at the stated significance and (points-1, points-1) degrees of freedom, and plainer measures
    (NRMSE, correlation, peak ratio).  The verdict: the mean, RMS and p95 of each pair's force averaged over
    --starts replicate starts of each model, their difference within 10 / 15 / 20 % beyond its 95 % noise band
    ('agree'), beyond them outside ('differ'), or 'within noise' (these starts cannot tell).  The replicate runs
    are cached as the study's (berryshaker cache).
    \f

    Parameters
    ----------
    clearance : str, optional
        ``--clearance``: Clearance set (default level2, the study's model check, Table 3).
    revolutions : int
        ``--revolutions``: Cam revolutions (2..200).
    points : int
        ``--points``: Samples per curve for the F test (study: about 10; 4..10000).
    alpha : float
        ``--alpha``: Significance level of the F test (dimensionless).
    config : Path, optional
        ``--config``: Machine description (TOML). Default: built-in reference machine.
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    plot : Path, optional
        ``--plot``: Write overlay plots (PNG) of both models per pair.
    starts : int
        ``--starts``: Replicate starts of each model for the verdict (multibody: clearances eccentric, drive turned;
        MLSD: cam turned); 0: only the centred runs (one draw of a chaotic impact sequence, no verdict on the
        statistics).
    workers : int, optional
        ``--workers``: Local processes for the replicate starts (default: every core this process may run on).
    cache : str, optional
        ``--cache``: Run cache folder of the replicate starts (default ~/.cache/berryshaker/runs or
        $BERRYSHAKER_CACHE).
    """
    try:
        from berryshaker.experiment.agreement import model_agreement, model_check
        from berryshaker.experiment.clearance_sets import parse_clearance_spec

        check_number("--alpha", alpha, 0.0, 1.0, lo_open=True, hi_open=True,
                     what="the significance level of the F test, e.g. 0.05")
        if starts == 1:
            raise BerryshakerError("--starts 1 has no spread to measure: give 0 (centred runs only) or >= 2")
        from berryshaker.harvest.spec import MAX_COUNT

        check_range("--starts", starts, 0, MAX_COUNT, "replicate starts of each model, two runs each")
        if starts:
            from berryshaker.runs.cache import run_cache_dir

            run_cache_dir(cache)  # the cache policy before any work
        _check_folders(plot, kind="compare --plot")
        machine = _load(config)
        sizes = parse_clearance_spec(clearance, machine)
        res = model_agreement(machine, sizes, revolutions=revolutions, points=points, alpha=alpha)
        series, t = res.pop("series"), res.pop("t")
        if starts:
            from berryshaker.runs.runner import SweepRunner
            from berryshaker.study.runs import model_check_jobs, multibody_row, reduced_row

            jobs = model_check_jobs(machine, sizes, starts, revolutions)
            with SweepRunner(workers=workers, cache_dir=cache, progress=True, console=err) as runner:
                mb = runner.map(multibody_row, jobs, f"{starts} perturbed starts, multibody")
                ml = runner.map(reduced_row, jobs, f"{starts} turned starts, MLSD")
            res["model_check"] = model_check([o.value for o in mb], [o.value for o in ml], machine.pair_names)
            res["failed_starts"] = [{"model": model, "start": o.index + 1, "error": o.error}
                                    for model, outs in (("multibody", mb), ("MLSD", ml)) for o in outs if o.error]
            for f in res["failed_starts"]:
                err.print(f"[yellow]{f['model']} start {f['start']} failed[/]: {markup_text(f['error'])}")
            if res["model_check"] is None:
                raise BerryshakerError("fewer than two replicate starts of a model ran: no spread to judge by")
        res["version"] = __version__
        if plot is not None:
            from berryshaker.outputs import staged_directory
            from berryshaker.report.plots import plot_time_series

            with staged_directory(plot, kind="compare --plot") as stage:
                write_provenance(stage, machine, clearance_mm=res["clearance_mm"])
                for p, (a, b) in series.items():
                    plot_time_series(t, {"multibody": a, "MLSD": b}, f"collision force at {p} [N]",
                                     stage / f"compare_{p}.png", f"Pair {p}: MLSD vs multibody (study Figs. 14-17)",
                                     zoom="peak")
            res["plots"] = [str(plot / f"compare_{p}.png") for p in series]
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json(res)
        return
    rows = [[p, f"{r['f_statistic']:.3f}", f"{r['f_critical']:.3f}", "yes" if r["eq18_agree"] else "no",
             f"{r['nrmse']:.3f}", f"{r['correlation']:.3f}", f"{r['peak_ratio']:.3f}"] for p, r in res["pairs"].items()]
    print_table(("pair", "F", "F crit", "eq. 18 agrees", "NRMSE", "corr", "peak ratio"), rows,
                title="MLSD vs multibody, centred runs (study eq. 18)", justify=("right",) * 7)
    check = res.get("model_check")
    if check is None:
        out.print("no verdict on the statistics: one run per model is one draw of a chaotic impact sequence "
                  "(give --starts >= 2)")
        return
    st = check["starts"]
    rows = []
    for p, c in check["pairs"].items():
        for k in c["tolerance"]:
            rows.append([p, k, f"{c['a'][k]['mean']:.1f} +- {c['a'][k]['se']:.1f}",
                       f"{c['b'][k]['mean']:.1f} +- {c['b'][k]['se']:.1f}",
                       f"{100 * c['relative_difference'][k]:.1f} +- {100 * c['noise'][k]:.1f} %",
                         f"{100 * c['tolerance'][k]:.0f} %", c["verdicts"][k]])
    print_table(("pair", "statistic", "multibody [N]", "MLSD [N]", "difference", "tolerance", "verdict"), rows,
                title=f"Verdict: means over {st['multibody']} multibody / {st['reduced']} MLSD starts (+- SE), "
                      "difference +- its 95 % band against the tolerance", justify=("right",) * 7)


def _write_simulation(out_dir: Path, result, summary: dict) -> None:
    import numpy as np

    from berryshaker.drives.groove_cam.mlsd import RESULT_COLUMNS
    from berryshaker.outputs import provenance, staged_directory, write_json_atomic, write_text_atomic
    from berryshaker.report.plots import plot_joint_forces, plot_time_series
    from berryshaker.report.tables import csv_text

    with staged_directory(out_dir, kind="simulate --out") as stage:
        cols = ["time_s", "cam_angle_deg", "x_m", "theta_D_rad", "u_m", "theta_E_rad"] + list(RESULT_COLUMNS)
        data = [result.t, np.degrees(result.t * result.machine.cam.speed)] + [result.state[:, i] for i in range(4)]
        data += [result.results[:, idx] for idx, _ in RESULT_COLUMNS.values()]
        arr = np.column_stack(data)
        write_text_atomic(stage / "timeseries.csv", csv_text(cols, arr.tolist(), ".9g"))
        write_json_atomic(stage / "summary.json", {**summary, "provenance": provenance(result.machine)})
        sel = result.t >= result.stats_from
        sizes_txt = ", ".join(f"{p} {v * 1e3:g} mm" for p, v in result.clearance.items())
        plot_joint_forces(result.t[sel], {p: np.abs(result.series(f"F_{p}_N"))[sel] for p in result.clearance},
                          stage / "collision_forces.png",
                          f"Clearance collision forces (MLSD, study eq. 8), clearances {sizes_txt}",
                          peaks={p: st["peak"] for p, st in summary["collision_force_N"].items()})
        plot_time_series(result.t[sel], {"T_l": result.series("T_l_Nm")[sel], "T_r": result.series("T_r_Nm")[sel],
                                         "M (cam)": result.series("drive_moment_Nm")[sel]},
                         "moment [N m]", stage / "moments.png", "Comb load moments and cam drive moment")


@command(app, "compare-machines")
def compare_machines_cmd(
    configs: list[Path] = typer.Argument(..., help="Two or more machine descriptions (TOML); 'reference' for the "
                                         "built-in groove-cam machine."),
    revolutions: int = typer.Option(3, "--revolutions", "-n", min=2, max=200, help="Drive-shaft revolutions."),
    fruit_force: bool = typer.Option(True, "--fruit-force/--no-fruit-force",
                                     help="Also drive each machine past its branch (one coupled run each)."),
    as_json: bool = JsonOpt,
):
    """Machines side by side: comb swing, collision force per clearance pair, drive moment, comb load moments
    and fruit force.  The drives may differ, e.g. the groove cam beside examples/crank_rocker_harvester.toml.
    \f

    Parameters
    ----------
    configs : list[Path]
        Argument: Two or more machine descriptions (TOML); 'reference' for the built-in groove-cam machine.
    revolutions : int
        ``--revolutions``: Drive-shaft revolutions.
    fruit_force : bool
        ``--fruit-force/--no-fruit-force``: Also drive each machine past its branch (one coupled run each).
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    """
    from berryshaker.experiment.machine_comparison import compare_machines

    if len(configs) < 2:
        raise BerryshakerError("give at least two machine descriptions to compare")
    machines = {}
    for c in configs:
        label = c.stem if str(c) != "reference" else "reference"
        if label in machines:
            label = str(c)
        machines[label] = _load(None if str(c) == "reference" else c)
    res = compare_machines(machines, revolutions=revolutions, fruit_force=fruit_force)
    res_out = {"machines": res, "version": __version__}
    if as_json:
        _print_json(res_out)
        return
    labels = list(res)
    rows = []
    rows.append(["comb swing left / right", *[f"{r['comb_swing_deg']['left']:.2f} / {r['comb_swing_deg']['right']:.2f} deg"
                                           for r in res.values()]])
    rows.append(["comb frequency", *[f"{r['comb_frequency_hz']:.3f} Hz" for r in res.values()]])
    n_pairs = max(len(r["collision_force_N"]) for r in res.values())
    for k in range(n_pairs):
        cells = []
        for r in res.values():
            items = list(r["collision_force_N"].items())
            if k < len(items):
                p, st = items[k]
                design = f"static-equivalent {st['static_equivalent']:.0f} N, " if "static_equivalent" in st else ""
                cells.append(f"{p} ({r['clearance_mm'][p]:g} mm): {design}mean {st['mean']:.0f} N, "
                             f"extreme {st['peak']:.0f} N")
            else:
                cells.append("")
        rows.append([f"clearance pair {k + 1} (in chain order)", *cells])
    rows.append(["drive moment design (p95) / rms / extreme",
                 *[f"{r['drive_moment_Nm'].get('design', float('nan')):.1f} / {r['drive_moment_Nm']['rms']:.1f} / "
                   f"{r['drive_moment_Nm']['peak']:.1f} N m" for r in res.values()]])
    rows.append(["comb load moment rms L / R (aggregate bush spring, per comb)", *[f"{r['load_moment_Nm']['left']:.1f} / {r['load_moment_Nm']['right']:.1f} N m"
                                                 for r in res.values()]])
    if fruit_force:
        for pos in ("root", "middle", "end"):
            rows.append([f"fruit force peak, {pos}", *[f"{r.get('fruit_force_peak_N', {}).get(pos, float('nan')):.3f} N"
                                                      for r in res.values()]])
    print_table(["quantity"] + [f"{lab}\n({res[lab]['drive']})" for lab in labels], rows,
                title="Machines side by side (multibody, configured clearances)")
    out.print(load_moment_note("aggregate"), markup=False, highlight=False)
