"""The Python API: berryshaker for engineers working in Python or Jupyter, results as pandas objects.

Each function is a thin call of the library function the matching command of ``berryshaker --help`` uses (the
same numbers as the command's ``--json``), its result laid out as a :class:`pandas.DataFrame` whose column names
carry their units in brackets, e.g. ``"peak_force [N]"`` or ``"clearance.A.size [mm]"``: SI unless the bracket
names an engineering unit (mm, deg, um, h, %, kg/min).  ``[1]`` is a dimensionless number; a column without
brackets holds names, flags or counts.  Nothing here computes physics of its own.

===========================  ===========================  ======================================================
function                     command                      cost
===========================  ===========================  ======================================================
:func:`load_machine`         ``--config FILE``            milliseconds
:func:`kinematics`           ``kinematics``               about 0.1 s
:func:`simulate`             ``simulate``                 about 0.2 s per revolution (mlsd); seconds (multibody)
:func:`sweep`                ``sweep``                    one simulation per point, cached, in parallel
:func:`fit_table`            ``fits``                     milliseconds
:func:`service_limits`       (``wear``'s default limits)  milliseconds
:func:`wear`                 ``wear``                     several multibody runs (cached): tens of seconds
:func:`plan_field_sheet`     ``doe plan``                 milliseconds
:func:`analyze_field_sheet`  ``doe analyze``              under a second
:func:`validate`             ``validate``                 coupled machine-plant runs: minutes
===========================  ===========================  ======================================================

Docs: docs/python_api.md; a worked example: examples/gallery/plot_05_python_api.py.

long module: its length is numpydoc sections (parameters and columns with their units) of ten thin functions.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from berryshaker.config import load_machine
from berryshaker.errors import ConfigError

__all__ = ["analyze_field_sheet", "fit_table", "kinematics", "load_machine", "plan_field_sheet", "service_limits",
           "simulate", "sweep", "validate", "wear"]

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

#: unit suffixes of the library's JSON keys and CSV columns -> the unit written in brackets
_SUFFIX_UNITS = (
    ("_J_per_rev", "J/rev"), ("_um_per_h", "um/h"), ("_kg_min", "kg/min"), ("_percent", "%"), ("_pct", "%"),
    ("_Nm", "N m"), ("_rpm", "rpm"), ("_deg", "deg"), ("_hz", "Hz"), ("_mm", "mm"), ("_rad", "rad"),
    ("_N", "N"), ("_W", "W"), ("_m", "m"),
)


def _unit_name(key: str) -> str:
    """``collision_force_A_peak_N`` -> ``collision_force_A_peak [N]``, ``ripe_removal_pct_sd`` ->
    ``ripe_removal_sd [%]``; a key without a unit suffix is returned unchanged."""
    sd = key.endswith("_sd")
    base = key[:-3] if sd else key
    for suffix, unit in _SUFFIX_UNITS:
        if base.endswith(suffix) and len(base) > len(suffix):
            return f"{base[: -len(suffix)]}{'_sd' if sd else ''} [{unit}]"
    return key


def _names(value: str | Sequence[str] | None, arg: str) -> list[str]:
    """A comma-separated string or a sequence of names -> list of names."""
    if value is None:
        return []
    if isinstance(value, str):
        return [v.strip() for v in value.split(",") if v.strip()]
    if not all(isinstance(v, str) for v in value):
        raise ConfigError(f"{arg}={value!r}: give names as a list of str or one comma-separated str")
    return [v.strip() for v in value if v.strip()]


# ---- kinematics ------------------------------------------------------------------------------------------
def kinematics(machine, allow_undercut: bool = False) -> pd.DataFrame:
    """Ideal kinematics of the drive over one drive-shaft revolution, as ``berryshaker kinematics`` computes it.

    A thin call of the drive's ``check`` (:func:`berryshaker.drives.groove_cam.kinematics.check_machine` for the
    groove cam): it refuses a four-bar that does not assemble over the cycle or a groove that undercuts.

    Parameters
    ----------
    machine : MachineBase
        A machine description (:func:`load_machine`).
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
        A machine description (:func:`load_machine`).
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
        clearance in the multibody model), ``clearance [mm]`` (NaN for a bearing), ``peak_force [N]``, ``mean_force [N]``,
        ``rms_force [N]``, ``p95_force [N]`` (magnitudes) and ``contact_onsets`` (impacts per pair).  The
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
        The machine swept (:func:`load_machine`).
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
        ``collision_force_<pair>_peak [N]`` (and ``_mean``, ``_rms``), ``load_moment_<side>_peak [N m]``,
        ``drive_moment_peak [N m]``, ``drive_moment_rms [N m]``; powered: ``cam_speed_mean [rpm]``,
        ``speed_ripple [%]``, ``input_power [W]``, ``energy_lost_<joint> [J/rev]``; harvest:
        ``ripe_removal [%]``, ``unripe_shed [%]``, ``damage_rate [%]``, ``efficiency [kg/min]`` and their
        ``_sd`` over the replicate starts, ``shaking_frequency [Hz]``, ``comb_swing [deg]``...

    Raises
    ------
    ConfigError
        An unknown key, a value of the wrong dimension, or a point the machine's validation refuses (the message
        lists the points).

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
    header, rows = tidy_rows(parsed, pts, results)
    n_fixed = 1 + len(parsed) + 2
    names = (["run"] + [f"{p.key} [{p.unit}]" if p.unit else f"{p.key} [1]" for p in parsed] + ["status", "error"]
             + [_unit_name(c) for c in header[n_fixed:]])
    df = pd.DataFrame(rows, columns=names)
    for c in names[n_fixed:]:
        df[c] = pd.to_numeric(df[c], errors="coerce")  # a failed point's "" -> NaN
    return df


# ---- life: fits, service limits, wear --------------------------------------------------------------------
def fit_table(size_mm: float, fits: str | Sequence[str] | None = None) -> pd.DataFrame:
    """Limits and clearances of ISO 286 fits at one nominal diameter, as ``berryshaker fits`` (one row per fit).

    A thin call of :func:`berryshaker.life.fits.parse_fit` and :func:`berryshaker.life.fits.fit_summary`.

    Parameters
    ----------
    size_mm : float
        Nominal diameter (mm), 0 < size_mm <= 500.
    fits : str or sequence of str, optional
        Fit designations, e.g. ``["H7/f7", "H8/e8"]`` or ``"H7/f7,H8/e8"``, or explicit diametral ranges
        (``"0.02..0.06 mm"``); default the candidates of ``berryshaker tolerance``
        (:data:`berryshaker.life.tolerance.CANDIDATE_FITS`).

    Returns
    -------
    pandas.DataFrame
        One row per fit (index ``fit``): ``nominal [mm]``, ``kind`` (clearance, transition...), ``basis``,
        ``hole``, ``hole_upper_deviation [um]``, ``hole_lower_deviation [um]``, ``hole_tolerance [um]``, the same
        of the ``shaft`` (NaN for a range), then the DIAMETRAL clearance ``clearance_min [mm]``,
        ``clearance_max [mm]``, ``clearance_mean [mm]`` and the RADIAL one (half; the ``size`` of a pin in a bore
        in a machine description) ``radial_clearance_min [mm]``, ``radial_clearance_max [mm]``.

    Raises
    ------
    ConfigError
        A designation ISO 286 does not define here, or a size outside 0..500 mm.

    Examples
    --------
    >>> from berryshaker import api
    >>> float(api.fit_table(20.0, ["H7/f7"]).loc["H7/f7", "clearance_max [mm]"])
    0.062
    """
    from berryshaker.life.fits import fit_summary, parse_fit

    if fits is None:
        from berryshaker.life.tolerance import CANDIDATE_FITS

        fits = list(CANDIDATE_FITS)
    names = _names(fits, "fits")
    if not names:
        raise ConfigError("fits: name at least one fit, e.g. ['H7/f7', 'H8/e8']")
    if isinstance(size_mm, bool) or not isinstance(size_mm, (int, float, np.floating, np.integer)):
        raise ConfigError(f"size_mm={size_mm!r}: give the nominal diameter in mm as a number, e.g. 20.0")
    rows = []
    for name in names:
        s = fit_summary(parse_fit(name, float(size_mm)))
        row = {"fit": name, "nominal [mm]": math.nan if s["nominal_mm"] is None else s["nominal_mm"],
               "kind": s["kind"], "basis": s["basis"]}
        for part in ("hole", "shaft"):
            z = s[part] or {}
            row[part] = z.get("class")
            row[f"{part}_upper_deviation [um]"] = z.get("upper_deviation_um", math.nan)
            row[f"{part}_lower_deviation [um]"] = z.get("lower_deviation_um", math.nan)
            row[f"{part}_tolerance [um]"] = z.get("tolerance_um", math.nan)
        for key in ("clearance_min", "clearance_max", "clearance_mean", "radial_clearance_min",
                    "radial_clearance_max"):
            row[f"{key} [mm]"] = s[f"{key}_mm"]
        rows.append(row)
    return pd.DataFrame(rows).set_index("fit")


def service_limits(machine, joints: str | Sequence[str] | None = None) -> pd.DataFrame:
    """The clearance at which each joint is due for service, the default limit of ``berryshaker wear``.

    A thin call of :func:`berryshaker.life.service.service_limits`: the larger of the joint's largest test level
    and twice its design size (docs/life.md, "Service limit").

    Parameters
    ----------
    machine : MachineBase
        A machine description (:func:`load_machine`).
    joints : str or sequence of str, optional
        Clearance pairs (default every pair).

    Returns
    -------
    pandas.DataFrame
        One row per joint (index ``joint``): ``design_size [mm]`` (radial for a pin, free travel for a roller),
        ``largest_test_level [mm]`` and ``service_limit [mm]``.

    Raises
    ------
    ConfigError
        A joint that is not a clearance pair of the machine.

    Examples
    --------
    >>> from berryshaker import api
    >>> limits = api.service_limits(api.load_machine())
    >>> bool((limits["service_limit [mm]"] > limits["design_size [mm]"]).all())
    True
    """
    from berryshaker.life.service import service_limits as limits_of

    limits = limits_of(machine, _names(joints, "joints") or None)
    sizes, levels = machine.clearance_sizes(), machine.clearance_levels()
    return pd.DataFrame([{"joint": j, "design_size [mm]": sizes[j] * 1e3,
                          "largest_test_level [mm]": max(levels[j]) * 1e3, "service_limit [mm]": v * 1e3}
                         for j, v in limits.items()]).set_index("joint")


def wear(machine, hours: float = 2000.0, joints: str | Sequence[str] | None = None,
         limits: Mapping[str, float] | None = None, revolutions: int = 2, load_direction: str = "fixed",
         slip: float | None = None, from_fit: bool = False,
         cache: str | Path | None = None) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Clearance growth of the joints by Archard wear and the maintenance interval, as ``berryshaker wear``.

    A thin call of :func:`berryshaker.life.service.machine_wear`: it simulates the multibody drive, wears the
    joints in adaptive steps of operating hours and re-simulates.  Cost: one multibody run per wear state (a few
    seconds each, often ten or more states); each is cached, so a repeated call is fast.

    Parameters
    ----------
    machine : MachineBase
        A machine description (:func:`load_machine`).
    hours : float
        Operating hours to simulate (h).
    joints : str or sequence of str, optional
        Joints that wear (default every pair); the others stay at their size.
    limits : dict, optional
        Limits keyed ``"clearance:<joint>"`` (m), ``"peak_force:<joint>"`` or ``"mean_force:<joint>"`` (N), or an
        output name (SI); default each wearing joint's :func:`service_limits`.
    revolutions : int
        Drive revolutions per simulation.
    load_direction : {"fixed", "rotating"}
        Load direction on the pins (fixed is conservative).
    slip : float, optional
        Roller slip ratio (1; default :data:`berryshaker.life.joint_loads.DEFAULT_SLIP`).
    from_fit : bool
        Start each wearing joint from its fit's mean clearance, not its size.
    cache : str or Path, optional
        Run cache folder (default ``~/.cache/berryshaker/runs``).

    Returns
    -------
    joints : pandas.DataFrame
        One row per joint (index ``joint``): ``wears``, ``material_pair``, ``size_convention``, ``fit``,
        ``diameter [mm]``, ``bearing_length [mm]``, ``start_clearance [mm]``, ``end_clearance [mm]`` and
        ``maintenance_interval [h]`` (NaN: not reached).  ``joints.attrs["result"]`` holds the command's whole
        result (limits, governing limit, simulations, message).
    history : pandas.DataFrame
        One row per joint and wear state: ``joint``, ``hours [h]``, ``clearance [mm]`` and, for a wearing joint,
        ``peak_force [N]``, ``mean_force [N]``, ``growth_rate [um/h]``.

    Raises
    ------
    ConfigError
        Hours outside (0, 1e7], or a joint that is not a clearance pair.

    Examples
    --------
    >>> from berryshaker import api
    >>> joints, history = api.wear(api.load_machine(), hours=500.0, joints=["C"])  # doctest: +SKIP
    >>> history[history["joint"] == "C"].plot(x="hours [h]", y="clearance [mm]")  # doctest: +SKIP
    """
    from berryshaker.life.service import machine_wear
    from berryshaker.runs.runner import SweepRunner

    if isinstance(hours, bool) or not isinstance(hours, (int, float, np.floating, np.integer)) or not (
            math.isfinite(hours) and 0 < hours <= 1e7):
        raise ConfigError(f"hours={hours!r}: expected operating hours in (0, 1e7]")
    names = _names(joints, "joints")
    unknown = [j for j in names if j not in machine.pair_names]
    if unknown:
        raise ConfigError(f"joints: {', '.join(unknown)} not a clearance pair of {machine.machine.name}; pairs: "
                          f"{', '.join(machine.pair_names)}")
    with SweepRunner(workers=1, cache_dir=cache, progress=False) as runner:
        res = machine_wear(machine, float(hours), dict(limits) if limits else None, runner=runner,
                           revolutions=revolutions, load_direction=load_direction, slip=slip,
                           joints=names or None, from_fit=from_fit)
    rows, hist = [], []
    for j, d in res["joints"].items():
        mi = d["maintenance_interval_h"]
        rows.append({"joint": j, "wears": d["wears"], "material_pair": d["material_pair"],
                     "size_convention": d["size_convention"], "fit": d["fit"], "diameter [mm]": d["diameter_mm"],
                     "bearing_length [mm]": d["bearing_length_mm"], "start_clearance [mm]": d["clearance_mm"][0],
                     "end_clearance [mm]": d["clearance_mm"][-1],
                     "maintenance_interval [h]": math.nan if mi is None else mi})
        for k, h in enumerate(d["hours"]):
            hist.append({"joint": j, "hours [h]": h, "clearance [mm]": d["clearance_mm"][k],
                         "peak_force [N]": d["peak_force_N"][k] if d["wears"] else math.nan,
                         "mean_force [N]": d["mean_force_N"][k] if d["wears"] else math.nan,
                         "growth_rate [um/h]": d["growth_rate_um_per_h"][k] if d["wears"] else math.nan})
    summary = pd.DataFrame(rows).set_index("joint")
    summary.attrs["result"] = res
    return summary, pd.DataFrame(hist)


# ---- field tests -----------------------------------------------------------------------------------------
def plan_field_sheet(factors: Mapping[str, str], array: str = "L9", replicates: int = 3, randomize: bool = False,
                     seed: int | None = None) -> pd.DataFrame:
    """The field sheet of an orthogonal test, as ``berryshaker doe plan`` writes it.

    A thin call of :func:`berryshaker.experiment.field_sheet.parse_factor` and
    :func:`berryshaker.experiment.field_sheet.plan_table`.

    Parameters
    ----------
    factors : dict
        Factor name -> its levels with their unit, e.g. ``{"A": "0.25,0.5,0.75mm"}`` (``--factor A=...``).
    array : str
        Orthogonal array: L4, L8, L9, L16, L18 or L27.
    replicates : int
        Times each run is tested (>= 2 lets :func:`analyze_field_sheet` judge effects against the replicate spread).
    randomize : bool
        Draw a random test order (needs ``seed``).
    seed : int, optional
        Seed of the random order.

    Returns
    -------
    pandas.DataFrame
        One row per run and replicate: ``run``, ``replicate``, ``order``, per factor ``<name>_level`` and
        ``<name>_<unit>`` (its value, e.g. ``A_mm``), and the empty response columns to fill in
        (``duration_s``, ``picked_mass_kg``... or the ready indexes ``efficiency_kg_min``, ``unripe_rate_pct``,
        ``damage_rate_pct``): the sheet's own layout, units after the last underscore, as ``doe plan`` writes it.

    Raises
    ------
    ConfigError
        A factor that is not ``v1,v2,...unit``, repeated names, or an unknown array.

    Examples
    --------
    >>> from berryshaker import api
    >>> sheet = api.plan_field_sheet({"A": "0.25,0.5,0.75mm", "B": "0.1,0.2,0.3mm"}, replicates=2)
    >>> len(sheet)
    18
    """
    from berryshaker.experiment.field_sheet import parse_factor, plan_table

    if not isinstance(factors, Mapping) or not factors:
        raise ConfigError(f"factors={factors!r}: give a dict name -> levels, e.g. {{'A': '0.25,0.5,0.75mm'}}")
    return plan_table(array, [parse_factor(f"{k}={v}") for k, v in factors.items()], randomize, seed,
                      replicates=replicates)


def _bracket_units(header: str) -> str:
    """``k1 (kg/min)`` -> ``k1 [kg/min]``."""
    return re.sub(r"\s*\(([^()]*)\)$", r" [\1]", header)


def analyze_field_sheet(sheet, maximize: str | Sequence[str] = (), minimize: str | Sequence[str] = (),
                        weights: Mapping[str, float] | None = None) -> dict[str, pd.DataFrame]:
    """Range analysis, ANOVA and weighted optimum of a filled field sheet, as ``berryshaker doe analyze``.

    A thin call of :func:`berryshaker.experiment.field_results.analyze_sheet`; the tables are those
    ``doe analyze --plot`` writes (:func:`berryshaker.report.table_files.doe_tables`).

    Parameters
    ----------
    sheet : str, Path or pandas.DataFrame
        The filled sheet: a CSV file, its text, or a DataFrame in the same layout (:func:`plan_field_sheet`'s, a
        statistics package's worksheet with units in the header such as ``"Speed (rpm)"``).
    maximize : str or sequence of str
        Responses where larger is better, e.g. ``"efficiency"``.
    minimize : str or sequence of str
        Responses where smaller is better, e.g. ``["unripe", "damage"]``.
    weights : dict, optional
        Weights of the composite score per response (1, each > 0; default equal).

    Returns
    -------
    dict of str to pandas.DataFrame
        ``"range_<response>"`` per response: one row per factor (index ``factor``), the level means
        ``k1 [<unit>]`` .. ``kn [<unit>]`` and range ``R [<unit>]`` in the response's unit (``[1]`` when the sheet
        gives none), ``best_level``, ``anova_F [1]`` (NaN: pooled into the error) and ``p [1]``;
        ``"optimum_levels"``: per factor (index ``factor``) the ``level`` chosen (<NA>: no meaningful
        difference) and its ``setting``; ``"optimum_predicted"``: per response (index ``response``) its
        predicted ``value`` at the optimum and its ``unit``.

    Raises
    ------
    BerryshakerError
        An unreadable sheet, a response it lacks, a response named in both senses, or none named.

    Examples
    --------
    >>> from berryshaker import api
    >>> tables = api.analyze_field_sheet("sheet.csv", maximize="efficiency",
    ...                                  minimize=["unripe", "damage"])  # doctest: +SKIP
    >>> tables["range_efficiency"]["R [kg/min]"].idxmax()  # the factor that matters most  # doctest: +SKIP
    """
    from berryshaker.experiment.field_results import analyze_sheet
    from berryshaker.report.table_files import doe_tables

    up, down = _names(maximize, "maximize"), _names(minimize, "minimize")
    both = sorted(set(up) & set(down))
    if both:
        raise ConfigError(f"{', '.join(both)} is named in both maximize and minimize; name it once")
    senses = {**{r: True for r in up}, **{r: False for r in down}}
    if not senses:
        raise ConfigError("name at least one response in maximize or minimize, e.g. maximize='efficiency', "
                          "minimize=['unripe', 'damage']")
    if isinstance(sheet, pd.DataFrame):
        sheet = sheet.to_csv(index=False)
    elif isinstance(sheet, Path):
        sheet = str(sheet)
    _, res = analyze_sheet(sheet, senses, dict(weights) if weights is not None else None)
    out = {}
    units = res.get("response_units") or {}
    for stem, (header, rows) in doe_tables(res).items():
        if stem == "optimum":
            continue
        unit = units.get(stem.removeprefix("range_")) or "1"
        names = ["factor"] + [_bracket_units(h) if "(" in h else f"{h} [{unit}]" for h in header[1:-4]]
        names += [f"R [{unit}]", "best_level", "anova_F [1]", "p [1]"]
        df = pd.DataFrame(rows, columns=names).set_index("factor")
        df["anova_F [1]"] = pd.to_numeric(df["anova_F [1]"].replace("pooled", np.nan))
        df["p [1]"] = pd.to_numeric(df["p [1]"])
        out[stem] = df
    o = res["optimum"]
    out["optimum_levels"] = pd.DataFrame(
        [{"factor": f, "level": n, "setting": (o.get("settings") or {}).get(f)} for f, n in o["levels"].items()],
        columns=["factor", "level", "setting"]).astype({"level": "Int64"}).set_index("factor")
    out["optimum_predicted"] = pd.DataFrame(
        [{"response": r, "value": v, "unit": units.get(r, "")} for r, v in o["values"].items()],
        columns=["response", "value", "unit"]).set_index("response")
    return out


# ---- validation ------------------------------------------------------------------------------------------
def validate(machine, replicates: int | None = None, workers: int | None = None, cache: str | Path | None = None,
             progress: bool = False) -> pd.DataFrame:
    """The harvest model against the published record, as ``berryshaker validate``: one row per published number.

    A thin call of :func:`berryshaker.study.validation.validate` through a
    :class:`berryshaker.runs.runner.SweepRunner`.  Cost: every case is ``replicates`` coupled machine-plant
    runs (multibody drive past the explicit bush), minutes on the reference machine over two cores; the runs are
    cached, so a repeated call is fast.

    Parameters
    ----------
    machine : MachineBase
        A machine description with a ``[plant]`` block (:func:`load_machine`).
    replicates : int, optional
        Perturbed starts per case (default ``harvest.replicates`` of the description).
    workers : int, optional
        Local processes (default every core this process may run on).
    cache : str or Path, optional
        Run cache folder (default ``~/.cache/berryshaker/runs`` or ``$BERRYSHAKER_CACHE``).
    progress : bool
        Show a progress bar on stderr.

    Returns
    -------
    pandas.DataFrame
        One row per published number (index ``id``): ``quantity``, ``case``, ``source`` (citation),
        ``source_key``, ``unit`` (the unit of that row's numbers, which differ from row to row), ``published``,
        ``model``, ``lo``, ``hi`` (the interval the verdict uses), ``noise_lo``, ``noise_hi`` (start-to-start noise
        only), all in the row's ``unit`` (NaN where the model does not represent the number), ``verdict``,
        ``held_out``, ``how`` and ``confidence``.  ``attrs["summary"]`` counts the verdicts of the held-out rows;
        ``attrs["replicates"]`` is the starts per case.

    Raises
    ------
    BerryshakerError
        A description without a ``[plant]`` block.

    Examples
    --------
    >>> from berryshaker import api
    >>> rows = api.validate(api.load_machine())  # minutes: coupled runs  # doctest: +SKIP
    >>> rows["verdict"].value_counts()  # doctest: +SKIP
    """
    from berryshaker.errors import BerryshakerError
    from berryshaker.runs.runner import SweepRunner
    from berryshaker.study.validation import validate as run_validation

    if machine.plant is None:
        raise BerryshakerError("validate needs a [plant] block in the machine description (the harvest model runs "
                               "on it); add one, e.g. from the reference machine (berryshaker config init)")
    with SweepRunner(workers=workers, cache_dir=cache, progress=progress) as runner:
        res = run_validation(machine, runner, replicates)
    df = pd.DataFrame(res["rows"])
    first = ["id", "quantity", "case", "source", "source_key", "unit", "published", "model", "lo", "hi", "noise_lo",
             "noise_hi", "verdict", "held_out", "how", "confidence"]
    df = df[[c for c in first if c in df.columns] + [c for c in df.columns if c not in first]]
    for c in ("published", "model", "lo", "hi", "noise_lo", "noise_hi"):
        if c in df.columns:
            df[c] = pd.to_numeric(df[c], errors="coerce")
    df = df.set_index("id")
    df.attrs["summary"] = res["summary"]
    df.attrs["replicates"] = res["replicates"]
    return df
