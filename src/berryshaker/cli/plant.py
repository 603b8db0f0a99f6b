"""The plant: ``plant`` (branch modes) and ``fruit-force`` (drive past a branch)."""

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
    check_range,
    command,
    err,
    out,
    print_table,
)
from berryshaker.errors import BerryshakerError
from berryshaker.outputs import write_provenance


def _branch_of(machine):
    from berryshaker.plant.branch import Branch

    if machine.plant is None:
        raise BerryshakerError("the machine description has no [plant] block (see `berryshaker config init`)")
    b = machine.plant.branch
    return Branch(b.root_diameter, b.tip_diameter, b.length, b.elastic_modulus, b.density, b.damping_ratio)


@command(app)
def plant(
    config: Optional[Path] = ConfigOpt,
    as_json: bool = JsonOpt,
    n_modes: int = typer.Option(4, "--modes", min=1, max=20, help="Number of bending modes."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Write the mode-shape figure (PNG) to DIR."),
    convergence: bool = typer.Option(False, "--convergence", help="Instead: the peak stem forces against the "
                                     "branch modes kept in the coupled run (replicate means, docs/plant.md)."),
    convergence_modes: str = typer.Option("4,8,16,32", "--convergence-modes",
                                          help="Mode counts for --convergence, e.g. 4,8,16,32 (the last the reference)."),
    replicates: Optional[int] = typer.Option(None, "--replicates", min=2,
                                             help="Replicates for --convergence (default: harvest.replicates; at most "
                                                  "1000)."),
    separate_runs: bool = typer.Option(False, "--separate-runs", help="--convergence: one run per mode count and "
                                       "seed instead of every mode count as a probe of one run."),
):
    """Bending modes of the tapered branch: the Bessel solution (eq. 15) checked against finite elements.

    With --convergence: the replicate mean (with its standard error) of the peak stem force at the root, middle
    and end fruit against the number of branch modes kept in the coupled drive-past, the difference from the
    most modes with its noise, the verdict and the smallest converged mode count.
    \f

    Parameters
    ----------
    config : Path, optional
        ``--config``: Machine description (TOML). Default: built-in reference machine.
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    n_modes : int
        ``--modes``: Number of bending modes.
    plot : Path, optional
        ``--plot``: Write the mode-shape figure (PNG) to DIR.
    convergence : bool
        ``--convergence``: Instead: the peak stem forces against the branch modes kept in the coupled run (replicate
        means, docs/plant.md).
    convergence_modes : str
        ``--convergence-modes``: Mode counts for --convergence, e.g. 4,8,16,32 (the last the reference).
    replicates : int, optional
        ``--replicates``: Replicates for --convergence (default: harvest.replicates; at most 1000).
    separate_runs : bool
        ``--separate-runs``: --convergence: one run per mode count and seed instead of every mode count as a probe
        of one run.
    """
    if convergence:
        _convergence(config, as_json, convergence_modes, replicates, separate_runs)
        return
    try:
        from berryshaker.outputs import prepare_output_dir
        from berryshaker.plant.modes import analytic_modes, fe_modes

        if plot is not None:
            prepare_output_dir(plot, kind="plant --plot")

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
            from berryshaker.outputs import staged_directory
            from berryshaker.report.plots import plot_mode_shapes

            with staged_directory(plot, kind="plant --plot") as stage:
                plot_mode_shapes(ma, mf, stage / "mode_shapes.png")
                write_provenance(stage, machine)
            res["plots"] = [str(plot / "mode_shapes.png")]
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json(res)
        return
    rows = [[str(i + 1), f"{a['frequency_hz']:.4f} Hz", f"{f['frequency_hz']:.4f} Hz",
             f"{abs(f['frequency_hz'] - a['frequency_hz']) / a['frequency_hz']:.1e}"]
            for i, (a, f) in enumerate(zip(res["modes"], res["modes_fe"]))]
    print_table(("mode", "Bessel (eq. 15)", "finite elements", "relative difference (1)"), rows,
                title=f"Branch modes (alpha = {res['alpha']:.3f}, mass {res['branch_mass_kg'] * 1e3:.1f} g)",
                justify=("right",) * 4)
    _print_written(res)


def _convergence(config, as_json: bool, modes_text: str, replicates, separate_runs: bool) -> None:
    """``plant --convergence``: :func:`berryshaker.harvest.convergence.fruit_force_convergence` as a table."""
    try:
        from berryshaker.harvest.convergence import fruit_force_convergence, smallest_converged_modes

        try:
            modes = [int(v) for v in modes_text.split(",") if v.strip()]
        except ValueError:
            raise BerryshakerError(f"--convergence-modes {modes_text!r}: give whole numbers separated by commas, "
                                   "e.g. 4,8,16,32") from None
        if len(modes) < 2 or any(not 1 <= n <= 64 for n in modes):
            raise BerryshakerError(f"--convergence-modes {modes_text!r}: give two or more mode counts in 1..64")
        if replicates is not None:
            from berryshaker.harvest.spec import MAX_COUNT

            check_range("--replicates", replicates, 2, MAX_COUNT, "coupled drive-pasts of the convergence table")
        machine = _load(config)
        if machine.plant is None:
            raise BerryshakerError("the machine description has no [plant] block (see `berryshaker config init`)")
        status = None if as_json else err.status("plant --convergence: starting")
        if status is not None:
            status.start()
        try:
            res = fruit_force_convergence(machine, modes=sorted(modes), replicates=replicates,
                                          shared_run=not separate_runs,
                                          say=(lambda m: status.update(f"plant --convergence: {m}")) if status
                                          is not None else None)
        finally:
            if status is not None:
                status.stop()
        try:
            res["smallest_converged_modes"] = smallest_converged_modes(res)
        except BerryshakerError:
            res["smallest_converged_modes"] = None
        res["configured_modes"] = machine.plant.contact.n_modes
        res["version"] = __version__
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json(res)
        return
    ref = max(r["n_modes"] for r in res["rows"])
    names = [k[:-len("_stem_N")] for k in res["rows"][0] if k.endswith("_stem_N")]
    rows = []
    for r in res["rows"]:
        for i, name in enumerate(names):
            first = i == 0
            rel = "reference" if r["n_modes"] == ref else f"{100 * r[name + '_stem_rel']:+.2f} %"
            se_d = "" if r["n_modes"] == ref else f"{100 * r[name + '_stem_rel_se']:.2f} %"
            verdict = "" if r["n_modes"] == ref else (
                "no difference" if r[name + "_verdict"] == "converged" and r[name + "_no_difference"] else
                r[name + "_verdict"] + (" (inside SE)" if r[name + "_no_difference"] else ""))
            rows.append([str(r["n_modes"]) if first else "", f"{r['highest_mode_hz']:.0f} Hz" if first else "", name,
                         f"{r[name + '_stem_N']:.4f} ± {r[name + '_stem_se_N']:.4f}", rel, se_d, verdict])
    print_table(("modes", "top mode", "fruit", "mean ± SE (N)", f"vs {ref}", "SE diff.", "verdict"), rows,
                title=f"Peak stem force against branch modes: mean of {res['replicates']} replicates from perturbed "
                      f"starts ({res['load_model']} load)", justify=("right",) * 7)
    out.print(f"{res['method']}.  converged: |difference| + {res['t_factor']:.2f} SE(difference) <= "
              f"{100 * res['tolerance']:g} % ({100 * res['confidence']:g} % t bound); no difference: converged, and "
              "the difference is inside the replicate mean's standard error (the harvest statistic's own noise)")
    small = res["smallest_converged_modes"]
    out.print(f"smallest converged: {small if small is not None else 'none'}; configured plant.contact.n_modes = "
              f"{res['configured_modes']}; {res['runs']} coupled runs, {res['cpu_s']:.0f} s CPU")


def _print_written(res: dict) -> None:
    """One "wrote ..." line per written figure or folder (on stderr, like every other command's)."""
    for p in res.get("plots", []):
        err.print(f"wrote {p}", markup=False, highlight=False)
    if res.get("out"):
        err.print(f"wrote {res['out']} (fruit_force.csv, summary.json)", markup=False, highlight=False)


@command(app, "fruit-force")
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
    \f

    Parameters
    ----------
    clearance : str, optional
        ``--clearance``: Clearance set, as for simulate.
    config : Path, optional
        ``--config``: Machine description (TOML). Default: built-in reference machine.
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    plot : Path, optional
        ``--plot``: Write fruit force vs distance (Figs. 24-26) to DIR.
    out_dir : Path, optional
        ``--out``: Write the time series (CSV) and summary.
    """
    try:
        from berryshaker.experiment.clearance_sets import parse_clearance_spec
        from berryshaker.harvest.coupled import simulate_fruit_force
        from berryshaker.outputs import prepare_output_dir
        from berryshaker.reference_study import FRUIT_FORCE_N as STUDY_FRUIT_FORCE_N

        for folder, flag in ((plot, "--plot"), (out_dir, "--out")):
            if folder is not None:
                prepare_output_dir(folder, kind=f"fruit-force {flag}")

        machine = _load(config)
        sizes = parse_clearance_spec(clearance, machine)
        res = simulate_fruit_force(machine, sizes)
        summary = res.summary()
        summary["version"] = __version__
        if plot is not None or out_dir is not None:
            import numpy as np

            from berryshaker.outputs import provenance, staged_directory, write_json_atomic, write_text_atomic
            from berryshaker.report.plots import plot_fruit_force
            from berryshaker.report.tables import csv_text

            if plot is not None:
                with staged_directory(plot, kind="fruit-force --plot") as stage:
                    plot_fruit_force(res.distance, res.fruit_force, STUDY_FRUIT_FORCE_N, stage / "fruit_force.png",
                                     peaks={n: d["peak_force_N"] for n, d in summary["positions"].items()})
                    write_provenance(stage, res.machine)
                summary["plots"] = [str(plot / "fruit_force.png")]
            if out_dir is not None:
                with staged_directory(out_dir, kind="fruit-force --out") as stage:
                    cols = ["time_s", "distance_m"] + [f"fruit_{n}_N" for n in res.fruit_force] + \
                        [f"{n}_contact_N" for n in res.contact_force]
                    arr = np.column_stack([res.t, res.distance, *res.fruit_force.values(), *res.contact_force.values()])
                    write_text_atomic(stage / "fruit_force.csv", csv_text(cols, arr[::5].tolist(), ".7g"))
                    write_json_atomic(stage / "summary.json", {**summary, "provenance": provenance(res.machine)})
                summary["out"] = str(out_dir)
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json(summary)
        return
    rows = []
    for name, p in summary["positions"].items():
        rng = p.get("study_range_N")
        rows.append([name, f"{p['z_m']:.2f} m", f"{p['peak_force_N']:.3f} N",
                     f"{rng[0]}-{rng[1]} N" if rng else "", p["eq17"]["ripe"], p["eq17"]["unripe"]])
    print_table(("fruit", "z", "peak", "study range", "ripe fruit", "unripe fruit"), rows,
                title="Fruit harvesting force (eq. 16-17)", justify=("right",) * 6)
    out.print(f"force rises from root to end: {'yes' if summary['rises_root_to_end'] else 'no'}; "
              f"{summary['steps']} steps in {summary['wall_time_s']:.2f} s")
    _print_written(summary)
