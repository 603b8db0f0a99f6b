"""What ``berryshaker explore`` computes, without the web page: the settings a user changes (clearances, drive
speed, stroke, travel speed) applied to a machine description, and the library runs behind each view.

Nothing here is new physics: the mechanism and force view is the drive's reduced model
(``Drive.reduced_model``, the groove cam's MLSD model, :func:`berryshaker.drives.groove_cam.mlsd.simulate_mlsd`)
or, for a drive without one, the multibody model (:func:`berryshaker.drives.simulation.simulate_multibody`);
removal against frequency is the virtual harvest (:func:`berryshaker.harvest.virtual.harvest_response` through
:func:`berryshaker.runs.sweep.model_run`, the ``sweep --model harvest`` run, cached by
:class:`berryshaker.runs.runner.SweepRunner`); wear and the service interval are
:func:`berryshaker.life.service.machine_wear` (``berryshaker wear``).  The drawing of the groove-cam drive
(:func:`groove_cam_frames`) places the links from the reduced model's coordinates and magnifies the joints'
clearance vectors.  SI inside; mm, r/min and m/min only in :class:`Settings` (the page's units).
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from berryshaker.errors import ConfigError

#: the machine-description field that sets the stroke, per drive: (dotted key, label, factor from the field to the
#: shown value); a drive not listed has no stroke field in the page
STROKE_FIELDS: dict[str, tuple[str, str]] = {
    "groove_cam": ("cam.stroke", "cam stroke (push-rod travel)"),
    "crank_rocker": ("crank.radius", "crank radius (sets the stroke)"),
}
#: drive-shaft revolutions of a mechanism/force run; statistics over revolutions 2..N (the first is start-up)
REVOLUTIONS = 3
#: mechanism runs kept in memory (a run holds ~15 000 samples x 39 columns, about 5 MB)
RUN_CACHE_SIZE = 16
RPM = 2 * math.pi / 60.0  # rad/s per r/min


@dataclass(frozen=True)
class Settings:
    """What the page changes on the machine, in the page's units.

    Attributes
    ----------
    clearance_mm : tuple of (str, float)
        Clearance size per pair (mm): radial for a pin in a bore, free travel for a roller.
    speed_rpm : float
        Drive-shaft speed (r/min).
    stroke_mm : float or None
        The stroke field of the drive (:data:`STROKE_FIELDS`, mm); None where the drive has none.
    walking_speed_m_min : float
        Travel speed along the row (m/min).
    """

    clearance_mm: tuple[tuple[str, float], ...]
    speed_rpm: float
    stroke_mm: float | None
    walking_speed_m_min: float

    def clearances_m(self) -> dict[str, float]:
        """Clearance size per pair in SI.

        Returns
        -------
        dict pair -> float
            Sizes (m).
        """
        return {p: v * 1e-3 for p, v in self.clearance_mm}


def stroke_field(machine) -> tuple[str, str] | None:
    """The description field that sets the machine's stroke (:data:`STROKE_FIELDS`).

    Parameters
    ----------
    machine : MachineBase
        Any drive's machine.

    Returns
    -------
    (str, str) or None
        (dotted key, label); None where the drive has no stroke field.
    """
    return STROKE_FIELDS.get(machine.DRIVE)


def speed_key(machine) -> str:
    """Dotted key of the drive-shaft speed in the description (``cam.speed``, ``crank.speed``, ...): the
    section whose ``speed`` is the machine's drive speed (as :func:`berryshaker.harvest.virtual.with_drive_speed`).

    Parameters
    ----------
    machine : MachineBase
        Any drive's machine.

    Returns
    -------
    str
        The dotted key.

    Raises
    ------
    ConfigError
        No section holds the drive speed.
    """
    for key, sec in machine.model_dump().items():
        if isinstance(sec, dict) and isinstance(sec.get("speed"), (int, float)) and \
                math.isclose(sec["speed"], machine.drive_speed, rel_tol=1e-12):
            return f"{key}.speed"
    raise ConfigError("the machine description has no section whose speed is the drive speed")


def _get(machine, key: str) -> float:
    obj = machine
    for part in key.split("."):
        obj = getattr(obj, part)
    return float(obj)


def settings_of(machine) -> Settings:
    """The page's settings of a machine as described.

    Parameters
    ----------
    machine : MachineBase
        Any drive's machine.

    Returns
    -------
    Settings
        Clearances, drive speed, stroke and travel speed as described.
    """
    sf = stroke_field(machine)
    return Settings(clearance_mm=tuple((p, v * 1e3) for p, v in machine.clearance_sizes().items()),
                    speed_rpm=machine.drive_speed / RPM, stroke_mm=_get(machine, sf[0]) * 1e3 if sf else None,
                    walking_speed_m_min=machine.operation.walking_speed * 60.0)


def overrides_of(machine, settings: Settings) -> dict[str, float]:
    """The settings as SI overrides of dotted description keys (the sweep's form,
    :func:`berryshaker.runs.sweep.apply_overrides`), clearances excluded.

    Parameters
    ----------
    machine : MachineBase
        The described machine (which keys its drive has).
    settings : Settings
        The page's settings.

    Returns
    -------
    dict
        ``{"cam.speed": rad/s, "cam.stroke": m, "operation.walking_speed": m/s}`` (keys of the machine's drive).
    """
    out = {speed_key(machine): settings.speed_rpm * RPM,
           "operation.walking_speed": settings.walking_speed_m_min / 60.0}
    sf = stroke_field(machine)
    if sf is not None and settings.stroke_mm is not None:
        out[sf[0]] = settings.stroke_mm * 1e-3
    return out


def _finite(name: str, value, unit: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"{name}: give a finite number in {unit}, got {value!r}")
    return float(value)


def build_machine(base, settings: Settings):
    """The base machine with the page's settings, validated as a machine file is.

    Speed, stroke and travel speed go through :func:`berryshaker.runs.sweep.point_machine` (the description
    validated, the drive's geometry checked over the cycle); the clearances through
    :meth:`~berryshaker.drives.base.MachineBase.with_clearances` (limits per pair).

    Parameters
    ----------
    base : MachineBase
        The machine as described (its file or the reference machine).
    settings : Settings
        The page's settings.

    Returns
    -------
    MachineBase
        The validated machine.

    Raises
    ------
    ConfigError, GeometryError
        A value the description refuses; the message names the field and what to change.
    """
    from berryshaker.runs.sweep import point_machine

    _finite("drive speed [r/min]", settings.speed_rpm, "r/min")
    _finite("travel speed [m/min]", settings.walking_speed_m_min, "m/min")
    if settings.stroke_mm is not None:
        _finite(f"{stroke_field(base)[0]} [mm]", settings.stroke_mm, "mm")
    for p, v in settings.clearance_mm:
        _finite(f"clearance {p} [mm]", v, "mm")
    if not settings.speed_rpm > 0:
        raise ConfigError(f"drive speed {settings.speed_rpm:g} r/min: give a speed > 0 r/min")
    if not settings.walking_speed_m_min > 0:
        raise ConfigError(f"travel speed {settings.walking_speed_m_min:g} m/min: give a speed > 0 m/min")
    machine = point_machine(base.model_dump(mode="json"), overrides_of(base, settings), REVOLUTIONS, check=True)
    return machine.with_clearances(settings.clearances_m())


def changed_keys(base, settings: Settings) -> set[str]:
    """Dotted description keys whose value the page changed from the description (their provenance is then
    "set here", not the file's tag).

    Parameters
    ----------
    base : MachineBase
        The machine as described.
    settings : Settings
        The page's settings.

    Returns
    -------
    set of str
        The changed keys, e.g. ``{"clearance.A.size", "cam.speed"}``.
    """
    ref = settings_of(base)
    out = {f"clearance.{p}.size" for (p, v), (_, v0) in zip(settings.clearance_mm, ref.clearance_mm)
           if not math.isclose(v, v0, rel_tol=1e-9, abs_tol=1e-12)}
    if not math.isclose(settings.speed_rpm, ref.speed_rpm, rel_tol=1e-9):
        out.add(speed_key(base))
    if settings.stroke_mm is not None and not math.isclose(settings.stroke_mm, ref.stroke_mm, rel_tol=1e-9):
        out.add(stroke_field(base)[0])
    if not math.isclose(settings.walking_speed_m_min, ref.walking_speed_m_min, rel_tol=1e-9):
        out.add("operation.walking_speed")
    return out


def provenance_tag(base, key: str, changed: set[str]) -> str:
    """The provenance tag shown beside a value: "set here" when the page changed it, else the description's tag
    (study, published, assumed, ...; ``__provenance__`` of the loaded machine), else "from the file".

    Parameters
    ----------
    base : MachineBase
        The machine as described (its ``__provenance__`` tags).
    key : str
        Dotted description key.
    changed : set of str
        :func:`changed_keys`.

    Returns
    -------
    str
        The tag.
    """
    if key in changed:
        return "set here"
    return (getattr(base, "__provenance__", None) or {}).get(key, "from the file")


@dataclass
class MechanismRun:
    """One mechanism/force run of the page: the model's result and what the views draw from it (SI).

    Attributes
    ----------
    model : str
        "mlsd" (the drive's reduced model) or "multibody".
    machine : MachineBase
        The machine run.
    summary : dict
        The model's summary (the JSON of ``berryshaker simulate``).
    t : ndarray
        Time (s) of the force series, revolutions 2..N.
    forces : dict
        |collision force| (N) per pair over ``t``.
    frames : dict or None
        The drawing of the drive (:func:`groove_cam_frames`), None where the drive has no drawing.
    wall_time_s : float
        Wall time of the run (s).
    """

    model: str
    machine: object
    summary: dict
    t: np.ndarray
    forces: dict
    frames: dict | None
    wall_time_s: float


def run_mechanism(machine, n_frames: int = 120) -> MechanismRun:
    """Run the machine's drive for the mechanism and force views: the reduced model where the drive has one (the
    groove cam's MLSD model, about a second), else the multibody model (several seconds).

    Parameters
    ----------
    machine : MachineBase
        A validated machine (:func:`build_machine`).
    n_frames : int
        Frames of the drawing over the last revolution.

    Returns
    -------
    MechanismRun
        The model's summary, the force series over revolutions 2..N and the drawing.
    """
    import time

    from berryshaker.drives import drive_of

    drive = drive_of(machine)
    t0 = time.perf_counter()
    if drive.reduced_model is not None:
        res = drive.reduced_model(machine, {}, revolutions=REVOLUTIONS)
        summary = res.summary()
        sel = res.t >= res.stats_from - 1e-12
        forces = {p: np.abs(res.series(f"F_{p}_N"))[sel] for p in machine.pair_names}
        frames = groove_cam_frames(res, n_frames) if machine.DRIVE == "groove_cam" else None
        return MechanismRun(drive.reduced_model_name or "reduced", machine, summary, res.t[sel], forces, frames,
                            time.perf_counter() - t0)
    from berryshaker.drives.simulation import simulate_multibody

    res, summary = simulate_multibody(machine, {}, revolutions=REVOLUTIONS)
    sel = res.t >= res.stats_from - 1e-12
    cm = res.compiled
    forces = {p: np.abs(np.asarray(res.element_force(p) if p in cm.frc_names else res.reaction(p), float))[sel]
              for p in machine.pair_names}
    return MechanismRun("multibody", machine, summary, res.t[sel], forces, None, time.perf_counter() - t0)


class RunCache:
    """Mechanism runs kept in memory by their settings (least recently used dropped beyond ``size``); safe to
    share between the page's sessions and threads.

    Parameters
    ----------
    size : int
        Runs kept.
    """

    def __init__(self, size: int = RUN_CACHE_SIZE):
        self.size = size
        self._runs: OrderedDict = OrderedDict()
        self._lock = threading.Lock()

    def get(self, base, settings: Settings) -> tuple[MechanismRun, bool]:
        """The run of ``settings`` on ``base`` and whether it came from the cache.

        Parameters
        ----------
        base : MachineBase
            The machine as described.
        settings : Settings
            The page's settings.

        Returns
        -------
        (MechanismRun, bool)
            The run, and True when it was kept from an earlier call.

        Raises
        ------
        BerryshakerError
            The settings are refused (:func:`build_machine`) or the run failed.
        """
        key = (id(base), settings)
        with self._lock:
            if key in self._runs:
                self._runs.move_to_end(key)
                return self._runs[key], True
        run = run_mechanism(build_machine(base, settings))
        with self._lock:
            self._runs[key] = run
            while len(self._runs) > self.size:
                self._runs.popitem(last=False)
        return run, False


def groove_cam_frames(result, n_frames: int = 120) -> dict:
    """The groove-cam drive drawn from an MLSD result over its last revolution: link lines, joint positions and
    each joint's clearance vector (for magnified drawing), and whether the joint is in contact.

    The points follow docs/mlsd.md: roller A at x = s0 + x on the guide line y = e (its pitch point at
    s0 + s(phi)); roller B at s0 + x + l_AB; the left comb from D along its angle theta_D, arm DC at theta_D +
    gamma; pin F at E + l_FE (cos theta_E, sin theta_E), the right comb from E along theta_E; the clearance vectors
    r_A, r_B (roller minus its foot on the slot line), r_C, r_F (rod bore minus comb pin) are the model's
    (eq. 4).  A joint is in contact where its link length |d_i| exceeds its free play c_i (half the size for a
    roller, the radial clearance for a pin).

    Parameters
    ----------
    result : MLSDResult
        A groove-cam MLSD run (:func:`berryshaker.drives.groove_cam.mlsd.simulate_mlsd`).
    n_frames : int
        Frames, equally spaced over the last revolution.

    Returns
    -------
    dict
        ``phi_deg`` (cam angle per frame, deg), ``t`` (s), ``points`` (name -> (n_frames, 2) array, m: O, A, B, D,
        C, F, E, the comb tips L and R), ``clearance_vector`` (pair -> (n_frames, 2), m), ``free_play`` (pair -> m),
        ``contact`` (pair -> bool per frame), ``groove`` (the cam's pitch curve in the cam frame, (2, n), m) and
        ``cam_angle`` (rad per frame, the cam turning clockwise).
    """
    from berryshaker.drives.groove_cam.kinematics import cam_groove
    from berryshaker.drives.groove_cam.mlsd_kernel import R_DA, R_RBX, R_RBY, R_RCX, R_RCY, R_RFX, R_RFY
    from berryshaker.kinematics.cam import follower_svaj

    m = result.machine
    c = m.cam
    period = 2 * math.pi / c.speed
    t_last = result.t[-1] - period
    idx = np.unique(np.searchsorted(result.t, np.linspace(t_last, result.t[-1], n_frames, endpoint=False)))
    idx = np.clip(idx, 0, len(result.t) - 1)
    t = result.t[idx]
    phi = c.speed * t
    st, rs = result.state[idx], result.results[idx]
    x, thd, the = st[:, 0], st[:, 1], st[:, 3]
    s = follower_svaj(phi % (2 * math.pi), c.stroke, c.rise_angle, c.far_dwell_angle, c.return_angle, c.law)[0]
    e, s0, lab = c.offset, c.s0, m.push_rod.length
    xd, yd = m.shaft_D
    xe, ye = m.shaft_E
    lcd, gam, lfe, lc = m.rocker.arm_CD, m.rocker.arm_angle, m.four_bar.arm_FE, m.combs.length
    n = len(idx)
    one = np.ones(n)
    pts = {
        "O": np.zeros((n, 2)),
        "A": np.column_stack([s0 + x, e * one]),
        "A0": np.column_stack([s0 + s, e * one]),  # pitch point of the groove
        "B": np.column_stack([s0 + x + lab, e * one]),
        "D": np.column_stack([xd * one, yd * one]),
        "C": np.column_stack([xd + lcd * np.cos(thd + gam), yd + lcd * np.sin(thd + gam)]),
        "L": np.column_stack([xd + lc * np.cos(thd), yd + lc * np.sin(thd)]),
        "E": np.column_stack([xe * one, ye * one]),
        "F": np.column_stack([xe + lfe * np.cos(the), ye + lfe * np.sin(the)]),
        "R": np.column_stack([xe + lc * np.cos(the), ye + lc * np.sin(the)]),
    }
    vec = {"A": np.column_stack([x - s, 0 * one]), "B": np.column_stack([rs[:, R_RBX], rs[:, R_RBY]]),
           "C": np.column_stack([rs[:, R_RCX], rs[:, R_RCY]]), "F": np.column_stack([rs[:, R_RFX], rs[:, R_RFY]])}
    play = {p: result.clearance[p] * (1.0 if m.clearance[p].kind == "pin-in-bore" else 0.5) for p in vec}
    contact = {p: np.abs(rs[:, R_DA + k]) > play[p] for k, p in enumerate(("A", "B", "C", "F"))}
    _, pitch, _, _ = cam_groove(m, n=181)
    return {"phi_deg": np.degrees(phi % (2 * math.pi)), "t": t, "points": pts, "clearance_vector": vec,
            "free_play": play, "contact": contact, "groove": pitch, "cam_angle": -phi}
