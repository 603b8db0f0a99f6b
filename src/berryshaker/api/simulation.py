"""The Python API of a machine's dynamics: :func:`kinematics` (``berryshaker kinematics``), :func:`simulate`
(``simulate``) and :func:`sweep` (``sweep``), each laid out as :class:`pandas.DataFrame` objects whose column names
carry their units in brackets (see :mod:`berryshaker.api`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from berryshaker.api.names import _unit_name
from berryshaker.errors import ConfigError

#: kinematics fields of the drives (berryshaker.drives.*.kinematics) -> column name with its unit
_KINEMATICS_COLUMNS = {
    "t": "time [s]",
    "s": "push_rod_displacement [m]",
    "ds": "push_rod_ds_dphi [m/rad]",
    "d2s": "push_rod_d2s_dphi2 [m/rad^2]",
    "d3s": "push_rod_d3s_dphi3 [m/rad^3]",
    "v": "push_rod_velocity [m/s]",
    "a": "push_rod_acceleration [m/s^2]",
    "j": "push_rod_jerk [m/s^3]",
    "theta_r": "rod_angle [rad]",
    "theta_d": "left_comb_angle [rad]",
    "omega_d": "left_comb_rate [rad/s]",
    "alpha_d": "left_comb_acceleration [rad/s^2]",
    "theta_4": "coupler_angle [rad]",
    "omega_4": "coupler_rate [rad/s]",
    "alpha_4": "coupler_acceleration [rad/s^2]",
    "theta_e": "right_comb_angle [rad]",
    "omega_e": "right_comb_rate [rad/s]",
    "alpha_e": "right_comb_acceleration [rad/s^2]",
    "assembled": "assembled",
    "pressure_angle": "pressure_angle [rad]",
    "curvature": "pitch_curvature [1/m]",
    "rod_transmission_angle": "rod_transmission_angle [rad]",
    "transmission_angle": "transmission_angle [rad]",
}


# ---- kinematics ------------------------------------------------------------------------------------------
def kinematics(machine, allow_undercut: bool = False) -> pd.DataFrame:
    """Ideal kinematics of the drive over one drive-shaft revolution, as ``berryshaker kinematics`` computes it.

    A thin call of the drive's ``check`` (:func:`berryshaker.drives.groove_cam.kinematics.check_machine` for the
    groove cam): it refuses a four-bar that does not assemble over the cycle or a groove that undercuts.

    Parameters
    ----------
    machine : MachineBase
        A machine description (:func:`~berryshaker.api.load_machine`).
    allow_undercut : bool
        Return an undercutting cam's kinematics instead of refusing it.

    Returns
    -------
    pandas.DataFrame
        One row per sampled drive angle, indexed by ``drive_angle [deg]`` (cam angle of the groove cam, crank angle
        turned of the crank-rocker).  Columns, SI: ``time [s]``; the groove cam's push rod
        ``push_rod_displacement [m]``, ``push_rod_velocity [m/s]``, ``push_rod_acceleration [m/s^2]``,
        ``push_rod_jerk [m/s^3]`` and its derivatives by the cam angle (``push_rod_ds_dphi [m/rad]``...),
        ``pressure_angle [rad]``, ``pitch_curvature [1/m]``; the crank-rocker's ``rod_angle [rad]`` and
        ``rod_transmission_angle [rad]``; for both ``left_comb_angle [rad]``, ``left_comb_rate [rad/s]``,
        ``left_comb_acceleration [rad/s^2]``, the same of ``right_comb_`` (and ``coupler_``),
        ``transmission_angle [rad]`` and ``assembled`` (bool).

    Raises
    ------
    GeometryError
        The linkage does not assemble, or the cam undercuts (without ``allow_undercut``).

    Examples
    --------
    >>> from berryshaker import api
    >>> kin = api.kinematics(api.load_machine())
    >>> swing = kin["left_comb_angle [rad]"]
    >>> bool(swing.max() > swing.min())
    True
    """
    import dataclasses

    from berryshaker.drives import drive_of

    kin = drive_of(machine).check(machine, allow_undercut=allow_undercut)
    cols = {}
    for f in dataclasses.fields(kin):
        if f.name == "phi":
            continue
        cols[_KINEMATICS_COLUMNS.get(f.name, f"{f.name} [SI]")] = np.asarray(getattr(kin, f.name))
    index = pd.Index(np.degrees(np.asarray(kin.phi)), name="drive_angle [deg]")
    return pd.DataFrame(cols, index=index)


# ---- simulate --------------------------------------------------------------------------------------------
def _clearance_spec(clearance, machine) -> dict[str, float]:
    """``simulate``'s clearance argument -> sizes (m) through the ``--clearance`` parser."""
    from berryshaker.experiment.clearance_sets import parse_clearance_spec

    if clearance is None or isinstance(clearance, str):
        return parse_clearance_spec(clearance, machine)
    if not isinstance(clearance, Mapping):
        raise ConfigError(f"clearance={clearance!r}: give a dict pair -> size (m, or a str with its unit such as "
                          "'0.25 mm'), a --clearance text such as 'A=0.25mm,C=0.1mm', 'row5', 'level2', or None")
    parts = []
    for pair, size in clearance.items():
        if isinstance(size, str):
            parts.append(f"{pair}={size}")
        elif isinstance(size, (int, float, np.floating, np.integer)) and not isinstance(size, bool):
            parts.append(f"{pair}={float(size)!r}m")
        else:
            raise ConfigError(f"clearance[{pair!r}]={size!r}: give a size in m (float) or a str with its unit")
    return parse_clearance_spec(",".join(parts), machine) if parts else {}


#: the multibody summary's ``pair_state`` -> the summary table's ``kind``
_PAIR_KIND = {"clearance": "clearance pair", "ideal joint (reaction force)": "ideal joint (reaction force)"}


def _joint_summary(summary: dict) -> pd.DataFrame:
    """The per-joint table of a simulation summary (``simulate --json``)."""
    rows = []
    onsets = summary.get("contact_onsets") or {}
    states = summary.get("pair_state") or {}
    for group, kind in (("collision_force_N", "clearance pair"), ("bearing_reaction_N", "guide bearing")):
        for joint, st in (summary.get(group) or {}).items():
            if not isinstance(st, dict):
                continue
            rows.append({"joint": joint,
                         "kind": _PAIR_KIND.get(states.get(joint), states.get(joint)) or kind,
                         "clearance [mm]": (summary.get("clearance_mm") or {}).get(joint, math.nan),
                         "static_equivalent_force [N]": st.get("static_equivalent", math.nan),
                         "peak_force [N]": st["peak"], "mean_force [N]": st["mean"], "rms_force [N]": st["rms"],
                         "p95_force [N]": st.get("p95", math.nan),
                         "contact_onsets": onsets.get(joint, pd.NA) if group == "collision_force_N" else pd.NA})
    df = pd.DataFrame(rows).set_index("joint")
    df["contact_onsets"] = df["contact_onsets"].astype("Int64")
    df.attrs["summary"] = summary
    return df


def _mlsd_series(result) -> pd.DataFrame:
    from berryshaker.drives.groove_cam.mlsd import RESULT_COLUMNS

    cols = {"cam_angle [deg]": np.degrees(result.t * result.machine.cam.speed)}
    for k, name in enumerate(("push_rod_x [m]", "left_comb_theta_D [rad]", "coupler_u [m]",
                              "right_comb_theta_E [rad]")):
        cols[name] = result.state[:, k]
    for key, (idx, unit) in RESULT_COLUMNS.items():
        base = key
        for suffix in ("_Nm", "_N", "_m"):
            if key.endswith(suffix):
                base = key[: -len(suffix)]
                break
        cols[f"{base} [{unit}]"] = result.results[:, idx]
    return pd.DataFrame(cols, index=pd.Index(result.t, name="time [s]"))


def _multibody_series(result, machine) -> pd.DataFrame:
    from berryshaker.drives.simulation import drive_moment

    cm = result.compiled
    cols = {}
    for p in machine.pair_names:
        cols[f"F_{p} [N]"] = result.element_force(p) if p in cm.frc_names else result.reaction(p)
    for side, name in (("T_l", "bush_left"), ("T_r", "bush_right")):
        if name in cm.frc_names:
            cols[f"{side} [N m]"] = result.element_force(name)
    cols["drive_moment [N m]"] = drive_moment(result)
    if "guide" in cm.con_names:
        cols["guide_normal [N]"] = result.reaction("guide")
    return pd.DataFrame(cols, index=pd.Index(result.t, name="time [s]"))


def simulate(machine, clearance=None, model: str = "mlsd", revolutions: int = 3,
             driveline: str | None = None) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Collision forces of the clearance joints over ``revolutions`` drive revolutions, as ``berryshaker simulate``.

    ``model="mlsd"`` calls the drive's reduced model (:func:`berryshaker.drives.groove_cam.mlsd.simulate_mlsd`,
    about 0.2 s per revolution), ``"multibody"`` :func:`berryshaker.drives.simulation.simulate_multibody` (seconds).
    Statistics are over revolutions 2..N; peaks over every integrator step.

    Parameters
    ----------
    machine : MachineBase
        A machine description (:func:`~berryshaker.api.load_machine`).
    clearance : dict or str, optional
        Clearance size per pair: a dict such as ``{"A": 0.25e-3}`` (m) or ``{"A": "0.25 mm"}``, or the text of
        ``--clearance`` (``"A=0.25mm,C=0.1mm"``, ``"row5"``, ``"level2"``, ``"none"``); pairs left out keep the
        description's size.  None: the description's sizes.
    model : {"mlsd", "multibody"}
        The reduced model (groove cam only) or the planar multibody contact simulation.
    revolutions : int
        Drive-shaft revolutions (>= 2; statistics exclude the first).
    driveline : {"imposed", "powered"}, optional
        Override of the description's ``[driveline] mode`` ("powered" needs ``model="multibody"``).

    Returns
    -------
    summary : pandas.DataFrame
        One row per joint (index ``joint``): the clearance pairs, then for the MLSD the guide bearings G and H.
        Columns: ``kind`` ("clearance pair", "guide bearing", or "ideal joint (reaction force)" for a pair of zero
        clearance in the multibody model), ``clearance [mm]`` (NaN for a bearing), ``static_equivalent_force [N]``
        (the p95 of the pair's impact peaks, the load to size from; multibody model only, else NaN),
        ``peak_force [N]`` (the run's single largest force, an extreme), ``mean_force [N]``, ``rms_force [N]``,
        ``p95_force [N]`` (magnitudes of the samples) and ``contact_onsets`` (impacts per pair).  The
        command's whole summary (drive and comb load moments in N m, integrator statistics) is in
        ``summary.attrs["summary"]``.
    series : pandas.DataFrame
        The written time series (every 0.1 ms), indexed by ``time [s]``.  MLSD: ``cam_angle [deg]``, the state
        (``push_rod_x [m]``, ``left_comb_theta_D [rad]``...), ``F_A [N]`` .. ``F_F [N]`` (collision forces),
        ``d_A [m]``.. (joint eccentricities), ``F_G [N]``, ``F_H [N]``, ``guide_friction [N]``,
        ``drive_moment [N m]``, ``T_l [N m]``, ``T_r [N m]`` (comb load moments), ``r_A_x [m]``...  Multibody:
        ``F_<pair> [N]``, ``T_l [N m]``, ``T_r [N m]``, ``drive_moment [N m]`` and ``guide_normal [N]``.

    Raises
    ------
    BerryshakerError
        An unknown model, a drive without a reduced model, a powered driveline outside the multibody model, or a
        clearance the geometry refuses.

    Examples
    --------
    >>> from berryshaker import api
    >>> summary, series = api.simulate(api.load_machine(), clearance={"A": "0.25 mm"}, revolutions=2)
    >>> float(summary.loc["A", "clearance [mm]"])
    0.25
    >>> bool(series["F_A [N]"].abs().max() <= summary.loc["A", "peak_force [N]"])
    True
    """
    from berryshaker.drives import drive_of
    from berryshaker.drives.powered import is_powered, with_driveline_mode
    from berryshaker.errors import BerryshakerError
    from berryshaker.multibody.engine import check_output_samples

    drive = drive_of(machine)
    if model not in ("mlsd", "multibody", "reduced"):
        raise BerryshakerError(f"model={model!r} is not available; choose 'mlsd' (reduced) or 'multibody'")
    if model in ("mlsd", "reduced") and drive.reduced_model is None:
        raise BerryshakerError(f"the {drive.name} drive has no reduced model; use model='multibody'")
    if isinstance(revolutions, bool) or not isinstance(revolutions, (int, np.integer)) or revolutions < 2:
        raise ConfigError(f"revolutions={revolutions!r}: give a whole number >= 2 (statistics exclude the first)")
    sizes = _clearance_spec(clearance, machine)
    machine = with_driveline_mode(machine, driveline)
    if is_powered(machine) and model != "multibody":
        raise BerryshakerError("the powered driveline runs in the multibody model: give model='multibody' "
                               "(or driveline='imposed')")
    check_output_samples(revolutions * 2 * math.pi / machine.drive_speed, 1e-4, "use fewer revolutions")
    if model in ("mlsd", "reduced"):
        result = drive.reduced_model(machine, sizes, revolutions=int(revolutions))
        return _joint_summary(result.summary()), _mlsd_series(result)
    from berryshaker.drives.simulation import simulate_multibody

    result, summary = simulate_multibody(machine, sizes, revolutions=int(revolutions))
    summary.setdefault("driveline_mode", "imposed")
    return _joint_summary(summary), _multibody_series(result, machine.with_clearances(sizes))


# ---- sweep -----------------------------------------------------------------------------------------------
def _param_spec(key: str, values, machine) -> str:
    """One ``params`` entry -> the ``--param KEY=VALUES`` text."""
    from berryshaker.quantity_fields import field_dimension, field_info_at
    from berryshaker.units.parsing import DIMENSIONS

    if isinstance(values, str):
        return f"{key}={values}"
    if not isinstance(values, Sequence) or not values:
        raise ConfigError(f"params[{key!r}]={values!r}: give a list of values (e.g. ['0.1 mm', '0.3 mm'], or "
                          "numbers in SI) or a str such as '0.1..0.3 mm'")
    if all(isinstance(v, str) for v in values):
        return f"{key}={','.join(v.strip() for v in values)}"
    if all(isinstance(v, (int, float, np.floating, np.integer)) and not isinstance(v, bool) for v in values):
        dim = field_dimension(field_info_at(type(machine), key))
        unit = DIMENSIONS[dim][1] if dim in DIMENSIONS else ""
        unit = "" if unit == "1" else unit
        return f"{key}={','.join(repr(float(v)) for v in values)} {unit}".rstrip()
    raise ConfigError(f"params[{key!r}]={values!r}: give every value as a str with its unit ('0.2 mm') or every "
                      "value as a number in SI (m, rad, rad/s, kg...), not a mix")


def sweep(machine, params: Mapping[str, Any], model: str = "mlsd", revolutions: int = 3, method: str = "grid",
          points: int = 3, seed: int = 0, driveline: str | None = None, workers: int | None = None,
          cache: str | Path | None = None, progress: bool = False) -> pd.DataFrame:
    """A parameter sweep, as ``berryshaker sweep``: one simulation per point through the cached sweep runner.

    Every point's machine is validated before the first run (:func:`berryshaker.runs.sweep.validate_points`);
    each point runs :func:`berryshaker.runs.sweep.model_run` through :class:`berryshaker.runs.runner.SweepRunner`
    (cached in ``cache``, in parallel over ``workers``), and the table is
    :func:`berryshaker.runs.sweep.tidy_rows`'s.  Cost: one simulation per point (about 0.2 s per revolution with
    the MLSD, seconds with the multibody model, tens of seconds for ``model="harvest"``); a point run before comes
    from the cache.

    Parameters
    ----------
    machine : MachineBase
        The machine swept (:func:`~berryshaker.api.load_machine`).
    params : dict
        Dotted key of the machine description -> its values: a list of str with units (``["0.1 mm", "0.3 mm"]``),
        a list of numbers in SI (m, rad, rad/s...), or one ``--param`` text (``"0.1..0.3 mm"``, a range of
        ``points`` levels; ``"0.25mm+-0.05mm"``, a normal distribution for ``method="montecarlo"``).
    model : {"mlsd", "multibody", "harvest"}
        Simulation of each point.
    revolutions : int
        Drive-shaft revolutions per run.
    method : {"grid", "lhs", "montecarlo"}
        Full grid, Latin hypercube or Monte Carlo sampling.
    points : int
        Grid levels per range, or samples of ``lhs`` / ``montecarlo``.
    seed : int
        Seed of ``lhs`` / ``montecarlo``.
    driveline : {"imposed", "powered"}, optional
        Override of ``[driveline] mode`` (powered: ``model="multibody"``).
    workers : int, optional
        Local processes (default every core this process may run on).
    cache : str or Path, optional
        Run cache folder (default ``~/.cache/berryshaker/runs`` or ``$BERRYSHAKER_CACHE``).
    progress : bool
        Show a progress bar on stderr.

    Returns
    -------
    pandas.DataFrame
        One row per point: ``run``, each parameter as ``<key> [<unit>]`` in the unit it was given in (SI for
        numbers), ``status`` ("ok" or "failed"), ``error``, then the outputs, NaN for a failed point:
        multibody: ``collision_force_<pair>_static_equivalent [N]`` (the p95 of the pair's impact peaks, the load
        to size from) and ``drive_moment_design [N m]`` (the p95 of the per-revolution peaks); every model:
        ``collision_force_<pair>_peak [N]`` and ``drive_moment_peak [N m]`` (the run's single largest value, an
        extreme, not a sizing load), ``collision_force_<pair>_mean [N]`` (and ``_rms``),
        ``load_moment_<side>_peak [N m]``, ``drive_moment_rms [N m]``; powered: ``cam_speed_mean [rpm]``,
        ``speed_ripple [%]``, ``input_power [W]``, ``energy_lost_<joint> [J/rev]``; harvest:
        ``ripe_removal [%]``, ``unripe_shed [%]``, ``damage_rate [%]``, ``efficiency [kg/min]`` and their
        ``_sd`` over the replicate starts, ``shaking_frequency [Hz]``, ``comb_swing [deg]``...

    Raises
    ------
    ConfigError
        An unknown key, a value of the wrong dimension, or a point the machine's validation refuses (the message
        lists the points).
    SimulationError
        Every point failed (the message gives the first one's error); a table with some failed points has NaN in
        their rows.
    WorkerStartError
        The worker processes could not start (:mod:`berryshaker.runs.main_guard`).

    Notes
    -----
    In a script, call it under ``if __name__ == "__main__":``: worker processes import the main script again
    (``spawn`` and ``forkserver`` start methods).  A call outside that block runs its points in this process, one
    at a time, with a warning (docs/python_api.md, "Scripts").

    Examples
    --------
    >>> from berryshaker import api
    >>> table = api.sweep(api.load_machine(), {"clearance.A.size": ["0.1 mm", "0.3 mm"]}, revolutions=2)
    >>> list(table["clearance.A.size [mm]"])
    [0.1, 0.3]
    """
    from berryshaker.drives.powered import is_powered, with_driveline_mode
    from berryshaker.runs.runner import SweepRunner
    from berryshaker.runs.sweep import (
        check_params,
        model_run,
        overrides_of,
        parse_param,
        sample_params,
        tidy_rows,
        validate_points,
    )

    if model not in ("mlsd", "multibody", "harvest"):
        raise ConfigError(f"model={model!r}: choose 'mlsd', 'multibody' or 'harvest'")
    if driveline is not None and driveline not in ("imposed", "powered"):
        raise ConfigError(f"driveline={driveline!r}: choose 'imposed' or 'powered'")
    if not isinstance(params, Mapping) or not params:
        raise ConfigError(f"params={params!r}: give a dict key -> values, e.g. {{'clearance.A.size': ['0.1 mm', "
                          "'0.3 mm']}")
    if is_powered(with_driveline_mode(machine, driveline)) and model != "multibody":
        raise ConfigError("the powered driveline runs in the multibody model: give model='multibody' "
                          "(or driveline='imposed')")
    parsed = [parse_param(_param_spec(k, v, machine), machine) for k, v in params.items()]
    check_params(parsed)
    pts = sample_params(parsed, method, points, seed)
    validate_points(machine, parsed, pts, revolutions)
    data = machine.model_dump(mode="json")
    with SweepRunner(workers=workers, cache_dir=cache, progress=progress) as runner:
        kernel_arg = {}
        if model == "multibody":
            from berryshaker.runs.sweep import COMPILED_ALREADY, choose_specialised

            specialised, why = choose_specialised(data, overrides_of(parsed, pts[0]), revolutions, driveline,
                                                  len(pts), runner.workers)
            kernel_arg = {"specialised": None if why == COMPILED_ALREADY else specialised}
        jobs = [dict(machine_data=data, overrides=overrides_of(parsed, pt), model=model, revolutions=revolutions,
                     **({"driveline": driveline} if driveline else {}), **kernel_arg) for pt in pts]
        results = runner.map(model_run, jobs, f"sweep ({method}, {len(jobs)} runs)")
    if results and all(r.error for r in results):  # no output columns to give: say why instead
        from berryshaker.errors import SimulationError

        raise SimulationError(f"every one of the {len(results)} points failed; the first: {results[0].error}")
    header, rows = tidy_rows(parsed, pts, results)
    n_fixed = 1 + len(parsed) + 2
    names = (["run"] + [f"{p.key} [{p.unit}]" if p.unit else f"{p.key} [1]" for p in parsed] + ["status", "error"]
             + [_unit_name(c) for c in header[n_fixed:]])
    df = pd.DataFrame(rows, columns=names)
    for c in names[n_fixed:]:
        df[c] = pd.to_numeric(df[c], errors="coerce")  # a failed point's "" -> NaN
    return df
