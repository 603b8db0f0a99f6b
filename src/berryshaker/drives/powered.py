"""The powered driveline inside the multibody engine: the machine description's ``[driveline]`` section and the
bodies, driver and force elements that replace a drive's imposed-speed driver (docs/driveline.md sec. 5).

Everything enters reflected to the drive shaft (:func:`berryshaker.drives.driveline.reflect_to_cam`):

* ``motor_rotor``: a body with inertia J_r = J_m R^2, driven by the torque-speed source ``drive``
  (R T_m(R omega) tabulated, :func:`rotor_torque_table`);
* ``belt``: a geared spring-damper rotor -> ``input_shaft`` (ratio 1, k_t, c_t, creep C, slip cap T_slip);
* ``input_shaft``: the driven pulley, CVT and worm, J_s = J_in (i_cvt i_worm)^2;
* ``mesh``: a geared spring-damper input shaft -> cam/crank with the CVT x worm efficiencies (eta_f driving,
  eta_b back-driven) and a mesh stiffness [assumed] standing for the rigid mesh of the check model (ratio +-1 sets
  the direction of rotation of the drive shaft).

The rotor and the input shaft are free bodies that only turn: their translations carry no force (the harvester
mechanisms have no gravity), so they need no bearing joint and add no constraint equations; with gravity they get
a revolute joint to ground.

Initial state: the steady state of :func:`~berryshaker.drives.driveline.steady_state_speed` under the mean drive
torque of the clearance-free mechanism at the nominal speed (one revolution of the ideal mechanism, which has no
free motion): rotor, shaft and drive shaft at their steady speeds, belt and mesh wound up to the steady belt torque.
A clearance adds impact losses to that mean, so the speed settles within a few milliseconds (the motor's slip
slope with the reflected rotor inertia), inside the first revolution that the statistics leave out.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field, model_validator

from berryshaker.drives.driveline import DrivelineSpec, reflect_to_cam, steady_state_speed
from berryshaker.errors import ConfigError, SimulationError
from berryshaker.quantity_fields import TorsionalStiffness

MODES = ("imposed", "powered")


class MachineDriveline(DrivelineSpec):
    """The ``[driveline]`` section of a machine description: a :class:`DrivelineSpec` plus how it is used.

    ``mode`` = "imposed" keeps the drive shaft at its nominal speed (a constraint; the section is then only
    described); "powered" puts the driveline into the multibody run.  ``match_speed`` sets the CVT ratio so that
    the steady state under the mean load runs at the nominal drive speed (what the operator does with the CVT);
    false keeps ``cvt_ratio`` as given.  The drive shaft's inertia is the drive's own ([cam] inertia, J_O),
    so ``cam_inertia`` is not given here.
    """

    mode: Literal["imposed", "powered"] = "imposed"  # [assumed] default: the study's imposed 120 r/min
    match_speed: bool = True  # [assumed]
    mesh_stiffness: TorsionalStiffness = 1.0e6  # N m/rad at the drive shaft, CVT + worm mesh [assumed]
    mesh_damping_ratio: Annotated[float, Field(ge=0, lt=1)] = 0.05  # of the mesh mode [assumed]
    cam_inertia: None = None  # type: ignore[assignment]  # the drive's own inertia is used

    @model_validator(mode="before")
    @classmethod
    def _no_cam_inertia(cls, data: Any) -> Any:
        if isinstance(data, dict) and data.get("cam_inertia") is not None:
            raise ValueError("driveline.cam_inertia: the drive shaft's inertia is the drive's own ([cam] inertia "
                             "J_O, or [crank] inertia); remove it from [driveline]")
        return data

    def driveline_spec(self, shaft_inertia: float) -> DrivelineSpec:
        """The plain :class:`DrivelineSpec` with the drive shaft's inertia.

        Parameters
        ----------
        shaft_inertia : float
            Inertia of the drive shaft (the cam or crank with its train) about its axis (kg m^2).

        Returns
        -------
        DrivelineSpec
            The driveline without the machine-level settings (mode, speed matching, mesh).
        """
        data = self.model_dump(exclude={"mode", "match_speed", "mesh_stiffness", "mesh_damping_ratio",
                                        "cam_inertia"})
        return DrivelineSpec.model_validate({**data, "cam_inertia": shaft_inertia})


def with_driveline_mode(machine, mode: str | None):
    """A validated copy of ``machine`` whose driveline runs in ``mode`` ("imposed" or "powered"); None: as is.

    A machine without a ``[driveline]`` section gets the documented defaults ([assumed]) when powered.

    Parameters
    ----------
    machine : MachineBase
        The machine description.
    mode : {"imposed", "powered"} or None
        The driveline mode; None keeps the description's.

    Returns
    -------
    MachineBase
        The machine (itself when nothing changes, else a validated copy with its provenance tags).
    """
    if mode is None:
        return machine
    if mode not in MODES:
        raise ConfigError(f"--driveline {mode!r}: choose imposed or powered")
    if machine.driveline is None and mode == "imposed":
        return machine
    data = machine.model_dump()
    data["driveline"] = dict(data.get("driveline") or {}, mode=mode)
    new = type(machine).model_validate(data)
    tags = getattr(machine, "__provenance__", None)
    if tags:
        object.__setattr__(new, "__provenance__", dict(tags))
    return new


def is_powered(machine) -> bool:
    """True when the machine's drive shaft is driven by its driveline (``[driveline] mode = "powered"``).

    Parameters
    ----------
    machine : MachineBase
        The machine description.

    Returns
    -------
    bool
        Whether the driveline is powered.
    """
    return getattr(machine, "driveline", None) is not None and machine.driveline.mode == "powered"


def rotor_torque_table(red, n_points: int = 64) -> tuple[np.ndarray, np.ndarray, float]:
    """The prime mover's torque-speed curve at the drive-shaft scale as a table for the engine.

    Parameters
    ----------
    red : ReflectedDriveline
        The driveline reflected to the drive shaft (:func:`berryshaker.drives.driveline.reflect_to_cam`).
    n_points : int
        Table size (the engine holds at most ``multibody.layout.MAX_TABLE`` = 64).

    Returns
    -------
    (speeds, torques, max_error) : (ndarray, ndarray, float)
        Rotor speeds (rad/s, drive-shaft scale, from standstill to above the top speed) and
        ``red.rotor_torque`` there; points are added greedily where linear interpolation of the exact curve
        (on 4001 points) errs most, weighted: 1 on the running range (stable branch, above the torque peak,
        with 0 <= T <= half the peak), 0.1 on the rest of the stable branch, 0.02 below the peak;
        ``max_error`` is the largest remaining error on the running range (N m).  A ``table`` motor of
        at most ``n_points`` points is passed as given (error 0).
    """
    from berryshaker.drives.driveline import TableCurve, _top_speed

    m = red.spec.motor
    if isinstance(m, TableCurve) and len(m.speeds) <= n_points:  # the engine interpolates it exactly as given
        return np.asarray(m.speeds) / red.ratio, red.ratio * np.asarray(m.torques), 0.0
    top = _top_speed(red.spec) / red.ratio
    fine = np.linspace(0.0, top, 4001)
    exact = red.rotor_torque(fine)
    # the drive runs on the stable branch (above the torque peak) below half the peak torque: error there counts
    # most, on the rest of the stable branch a tenth, below the peak a fiftieth
    stable = fine >= fine[int(np.argmax(exact))]
    weight = np.where(stable, np.where((exact >= 0.0) & (exact <= 0.5 * exact.max()), 1.0, 0.1), 0.02)
    idx = [0, len(fine) - 1]
    err = np.abs(np.interp(fine, fine[idx], exact[idx]) - exact)
    while len(idx) < n_points:
        idx = sorted(set(idx) | {int(np.argmax(weight * err))})
        err = np.abs(np.interp(fine, fine[idx], exact[idx]) - exact)
    return fine[idx], exact[idx], float(np.max(err[weight == 1.0]))


def mean_drive_torque(spec_data: dict) -> float:
    """Mean drive torque (N m, resisting the rotation) of the clearance-free mechanism over one revolution at its
    imposed speed.

    Parameters
    ----------
    spec_data : dict
        A drive's mechanism description (SI) with the imposed-speed driver ``drive``.

    Returns
    -------
    float
        The mean drive torque (N m), positive when it resists the rotation.

    Notes
    -----
    Clearance joints become their ideal counterparts, so the mechanism has no free motion and one revolution
    from the assembled state is already periodic; the mean is over the written samples of that revolution
    (uniform in time, the last sample left out).
    """
    from berryshaker.multibody.engine import simulate_mechanism
    from berryshaker.multibody.spec import mechanism_from_dict

    data = {k: v for k, v in spec_data.items()}
    ideal = {"revolute_clearance": "revolute", "slot_clearance": "point_on_line", "groove_clearance": "cam_roller"}
    data["joints"] = [dict(j, type=ideal.get(j["type"], j["type"])) for j in spec_data["joints"]]
    drive = next(d for d in data["drivers"] if d["name"] == "drive")
    period = 2 * math.pi / abs(drive["speed"])
    res = simulate_mechanism(mechanism_from_dict(data, "(clearance-free mechanism)"), duration=period,
                             output_step=period / 720)
    return float(np.mean(res.reaction("drive")[:-1]) * math.copysign(1.0, drive["speed"]))


def cvt_for_speed(spec: DrivelineSpec, load_torque: float, target_speed: float) -> DrivelineSpec:
    """The driveline with its CVT ratio set so that the steady state under ``load_torque`` runs at
    ``target_speed`` (rad/s): root of steady_state_speed(cvt).cam_speed - target (Brent).

    Parameters
    ----------
    spec : DrivelineSpec
        The driveline.
    load_torque : float
        Mean load torque on the drive shaft (N m, resisting).
    target_speed : float
        Drive-shaft speed to run at (rad/s).

    Returns
    -------
    DrivelineSpec
        A copy with ``cvt_ratio`` set (dimensionless).

    Raises
    ------
    ConfigError
        If no ratio near the present one reaches the speed.
    """
    from scipy.optimize import brentq

    def speed(c: float) -> float:
        return steady_state_speed(spec.model_copy(update={"cvt_ratio": c}), load_torque).cam_speed

    try:
        c0 = spec.cvt_ratio * speed(spec.cvt_ratio) / target_speed
        c = brentq(lambda c: speed(c) - target_speed, 0.8 * c0, 1.25 * c0, xtol=1e-12, rtol=1e-13)
    except (SimulationError, ValueError) as exc:
        raise ConfigError(f"driveline: no CVT ratio runs the drive at {target_speed * 30 / math.pi:.4g} r/min under "
                          f"{load_torque:.3g} N m ({exc}); check the motor and belt, or set match_speed = false") from None
    return spec.model_copy(update={"cvt_ratio": float(c)})


def driveline_elements(dspec: DrivelineSpec, load_torque: float, driven_body: str, direction: float,
                       mesh_stiffness: float, mesh_damping_ratio: float, bearings: bool = False):
    """Bodies, joints, driver and force elements of a driveline driving ``driven_body``, at its steady state.

    Parameters
    ----------
    dspec : DrivelineSpec
        The driveline (``cam_inertia`` = the driven body's inertia about its axis, kg m^2).
    load_torque : float
        Mean load on the driven body (N m, resisting) for the initial steady state.
    driven_body : str
        Name of the body the mesh turns.
    direction : float
        +1 or -1 (dimensionless): the sense in which the driven body turns (the rotor and input shaft turn
        positive).
    mesh_stiffness, mesh_damping_ratio : float
        Mesh stiffness (N m/rad at the driven body) and the damping ratio of the mesh mode (J_s against J_c).
    bearings : bool
        Pin the rotor and the input shaft to ground (needed only with gravity).

    Returns
    -------
    (parts, steady, table_error) : (dict, SteadyState, float)
        ``parts`` has lists ``bodies``, ``joints``, ``drivers``, ``forces`` (mechanism-description dicts, SI);
        the steady state they start from; the largest error of the tabulated motor curve (N m, drive-shaft
        scale).

    Raises
    ------
    ConfigError
        A self-locking worm, or a stall / belt slip at the mean load.
    """
    red = reflect_to_cam(dspec)
    if red.eta_back <= 0:
        raise ConfigError(f"driveline.worm: the worm is self-locking (back-driven efficiency {red.eta_back:.3g}); "
                          "the engine's compliant mesh needs a back-drivable set: raise lead_angle or give "
                          "efficiency_back > 0")
    try:
        ss = steady_state_speed(dspec, load_torque)
    except SimulationError as exc:
        raise ConfigError(f"driveline: {exc}") from None
    speeds, torques, tab_err = rotor_torque_table(red)
    t_b = ss.belt_torque
    j_s, j_c = red.shaft_inertia, dspec.cam_inertia
    c_mesh = 2.0 * mesh_damping_ratio * math.sqrt(mesh_stiffness * j_s * j_c / (j_s + j_c))
    parts = {
        "bodies": [dict(name="motor_rotor", mass=1.0, inertia=red.rotor_inertia),  # mass: see the module doc
                   dict(name="input_shaft", mass=1.0, inertia=j_s)],
        "joints": [dict(name="rotor_bearing", type="revolute", body_i="ground", body_j="motor_rotor"),
                   dict(name="input_shaft_bearing", type="revolute", body_i="ground", body_j="input_shaft")]
        if bearings else [],
        "drivers": [dict(name="drive", type="torque_speed", body="motor_rotor", speed=ss.motor_speed / red.ratio,
                         speeds=speeds.tolist(), torques=torques.tolist())],
        "forces": [
            dict(name="belt", type="geared_spring_damper", body_i="motor_rotor", body_j="input_shaft", ratio=1.0,
                 stiffness=red.torsional_stiffness, damping=red.torsional_damping,
                 creep_compliance=red.creep_compliance, slip_torque=red.slip_torque,
                 windup0=t_b / red.torsional_stiffness),
            dict(name="mesh", type="geared_spring_damper", body_i="input_shaft", body_j=driven_body, ratio=direction,
                 stiffness=mesh_stiffness, damping=c_mesh, efficiency_forward=red.eta_forward,
                 efficiency_back=red.eta_back, windup0=t_b / mesh_stiffness)],
    }
    return parts, ss, tab_err


def powered_mechanism(spec_data: dict, machine, driven_body: str) -> dict:
    """Replace the imposed-speed driver ``drive`` of a drive's mechanism description by the machine's driveline.

    Parameters
    ----------
    spec_data : dict
        The drive's mechanism description (SI) with the ``angle`` driver ``drive`` on ``driven_body``.
    machine : MachineBase
        Its ``driveline`` section (defaults when absent) and ``drive_inertia``.
    driven_body : str
        The drive shaft's body (the cam or the crank).

    Returns
    -------
    dict
        The description with bodies ``motor_rotor`` and ``input_shaft``, the torque-speed driver ``drive``, the
        geared spring-dampers ``belt`` and ``mesh``, and ``driveline`` notes (the steady state it starts from,
        the CVT ratio used, the table's interpolation error) under ``mechanism.description``.

    Raises
    ------
    ConfigError
        A self-locking worm (eta_b <= 0: the compliant mesh needs a back-drivable set), or no CVT setting
        reaches the nominal speed.
    """
    dl = machine.driveline if machine.driveline is not None else MachineDriveline()
    drive = next(d for d in spec_data["drivers"] if d["name"] == "drive")
    t_load = mean_drive_torque(spec_data)
    dspec = dl.driveline_spec(machine.drive_inertia)
    if dl.match_speed:
        dspec = cvt_for_speed(dspec, t_load, abs(drive["speed"]))
    gravity = spec_data.get("mechanism", {}).get("gravity", (0.0, 0.0))
    parts, ss, tab_err = driveline_elements(dspec, t_load, driven_body, math.copysign(1.0, drive["speed"]),
                                            dl.mesh_stiffness, dl.mesh_damping_ratio,
                                            bearings=any(abs(g) > 0 for g in gravity))
    out = dict(spec_data)
    out["bodies"] = list(spec_data["bodies"]) + parts["bodies"]
    out["joints"] = list(spec_data["joints"]) + parts["joints"]
    out["drivers"] = [d for d in spec_data["drivers"] if d["name"] != "drive"] + parts["drivers"]
    out["forces"] = list(spec_data.get("forces", [])) + parts["forces"]
    info = dict(spec_data.get("mechanism", {}))
    info["description"] = (f"{info.get('description', '')} powered driveline: mean load {t_load:.4g} N m, CVT ratio "
                           f"{dspec.cvt_ratio:.6g}, steady speed {ss.cam_speed * 30 / math.pi:.6g} r/min, motor "
                           f"table error {tab_err:.2g} N m").strip()
    out["mechanism"] = info
    sim = dict(spec_data.get("simulation", {}))
    sim["energy_audit"] = True
    out["simulation"] = sim
    return out


def driveline_summary(result, driven_body: str = "cam") -> dict:
    """Cam speed, ripple, input power and energy per revolution lost in each element of a powered run.

    Parameters
    ----------
    result : MultibodyResult
        A run of :func:`powered_mechanism`'s description (energy audit on).
    driven_body : str
        The drive shaft's body.

    Returns
    -------
    dict
        ``cam_speed_rpm`` {min, max, mean} over the statistics window (min/max from the written samples, mean
        = turned angle / time), ``speed_ripple_percent`` = 100 (max - min) / mean (``driveline_speed_ripple_percent``:
        the same for the motor rotor and the input shaft, against their sample means), ``input_power_W`` = motor work
        / time, ``energy_per_revolution_J`` = energy dissipated per drive-shaft revolution in each clearance joint,
        bush, the guide friction, the belt and the mesh, and ``energy_audit`` (:func:`energy_audit`).
    """
    from berryshaker.multibody.energy import energy_audit

    cm = result.compiled
    audit = energy_audit(result)
    i0 = int(np.argmin(np.abs(result.t - audit["window_s"][0])))
    b = cm.body_index[driven_body]
    w = np.abs(result.y[i0:, cm.n + 3 * b + 2])
    turned = abs(result.y[-1, 3 * b + 2] - result.y[i0, 3 * b + 2])
    dt = result.t[-1] - result.t[i0]
    mean = turned / dt
    revs = turned / (2 * math.pi)
    rpm = 30.0 / math.pi
    upstream = {}
    for name in ("motor_rotor", "input_shaft"):
        if name in cm.body_index:
            wu = np.abs(result.y[i0:, cm.n + 3 * cm.body_index[name] + 2])
            upstream[name] = float(100.0 * np.ptp(wu) / np.mean(wu))
    return {"driveline_mode": "powered",
            "driveline_speed_ripple_percent": upstream,
            "cam_speed_rpm": {"min": float(w.min() * rpm), "max": float(w.max() * rpm), "mean": float(mean * rpm)},
            "speed_ripple_percent": float(100.0 * (w.max() - w.min()) / mean),
            "input_power_W": float(audit["input_work_J"] / dt),
            "energy_per_revolution_J": {k: v / revs for k, v in audit["dissipated_J"].items()},
            "energy_audit": audit}
