"""What ``berryshaker explore`` computes, without the web page: the settings a user changes (clearances, drive
speed, stroke, travel speed) applied to a machine description, and the library runs behind each view.

Nothing here is new physics: the mechanism and force view is the drive's reduced model
(``Drive.reduced_model``, the groove cam's MLSD model, :func:`berryshaker.drives.groove_cam.mlsd.simulate_mlsd`)
or, for a drive without one, the multibody model (:func:`berryshaker.drives.simulation.simulate_multibody`);
removal against frequency is the virtual harvest (:func:`berryshaker.harvest.virtual.harvest_response` through
:func:`berryshaker.runs.sweep.model_run`, the ``sweep --model harvest`` run, cached by
:class:`berryshaker.runs.runner.SweepRunner`); wear and the service interval are
:func:`berryshaker.life.service.machine_wear` (``berryshaker wear``).  The drive's drawing
(:mod:`berryshaker.explore.drawing`) places the links from the run's coordinates and magnifies the joints'
clearance vectors.  SI inside; mm, r/min and m/min only in :class:`Settings` (the page's units).
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from berryshaker.errors import ConfigError
from berryshaker.explore import drawing

#: the machine-description field that sets the stroke, per drive: (dotted key, label); a drive not listed has no
#: stroke field in the page
STROKE_FIELDS: dict[str, tuple[str, str]] = {
    "groove_cam": ("cam.stroke", "cam stroke (push-rod travel)"),
    "crank_rocker": ("crank.radius", "crank radius (sets the stroke)"),
}
#: drive-shaft revolutions of a mechanism/force run; statistics over revolutions 2..N (the first is start-up)
REVOLUTIONS = drawing.REVOLUTIONS
#: mechanism runs kept in memory (a run holds ~15 000 samples x 39 columns, about 5 MB)
RUN_CACHE_SIZE = 16
RPM = 2 * math.pi / 60.0  # rad/s per r/min


@dataclass(frozen=True)
class Settings:
    """What the page changes on the machine, in the page's units.

    Attributes
    ----------
    clearance_mm : tuple of (str, float)
        Clearance size per pair (mm, :doc:`/nomenclature`).
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


#: a clearance slider spans 0 .. this many times the largest of the pair's test levels, service limit and size
SLIDER_REACH = 1.5
#: slider positions over a clearance slider's range (the step is the 1-2-5 value at or below range / this)
SLIDER_STEPS = 250


def _nice_ceil(x: float) -> float:
    """``x`` rounded up to two significant digits."""
    scale = 10.0 ** (math.floor(math.log10(x)) - 1)
    return round(math.ceil(x / scale - 1e-9) * scale, 12)


def _step_125(x: float) -> float:
    """The largest 1-2-5 value (..., 0.001, 0.002, 0.005, 0.01, ...) at or below ``x``."""
    decade = 10.0 ** math.floor(math.log10(x))
    return round(max(m for m in (1.0, 2.0, 5.0) if m * decade <= x * (1 + 1e-9)) * decade, 12)


def clearance_slider(machine, pair: str) -> tuple[float, float]:
    """The range and step of a pair's clearance slider (mm): the sizes worth sliding through.

    The slider runs from 0 to :data:`SLIDER_REACH` times the largest of the pair's test levels
    (:meth:`~berryshaker.drives.base.MachineBase.clearance_levels`), its service limit
    (:func:`berryshaker.life.service.service_limits`) and its size, rounded up to two digits and never beyond its
    geometric limit; its step is a 1-2-5 value of at most 1/:data:`SLIDER_STEPS` of that range.  A size beyond
    the slider's end is typed into its field (and the description's limits still apply).

    Parameters
    ----------
    machine : MachineBase
        The machine as described.
    pair : str
        A clearance pair of its drive.

    Returns
    -------
    (float, float)
        The slider's end and step (mm).
    """
    from berryshaker.life.service import service_limits

    info = next(i for i in machine.PAIRS if i.name == pair)
    geometric = info.limit(machine)[0] * 1e3
    largest = max(max(machine.clearance_levels()[pair]), service_limits(machine, [pair])[pair],
                  machine.clearance_sizes()[pair]) * 1e3
    end = min(_nice_ceil(SLIDER_REACH * largest), geometric) if largest > 0 else geometric
    return end, _step_125(end / SLIDER_STEPS)


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
        The drawing of the drive (:mod:`berryshaker.explore.drawing`), None where there is none.
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
        frames = drawing.groove_cam_frames(res, n_frames) if machine.DRIVE == "groove_cam" else None
        return MechanismRun(drive.reduced_model_name or "reduced", machine, summary, res.t[sel], forces, frames,
                            time.perf_counter() - t0)
    from berryshaker.drives.simulation import simulate_multibody

    res, summary = simulate_multibody(machine, {}, revolutions=REVOLUTIONS)
    sel = res.t >= res.stats_from - 1e-12
    cm = res.compiled
    forces = {p: np.abs(np.asarray(res.element_force(p) if p in cm.frc_names else res.reaction(p), float))[sel]
              for p in machine.pair_names}
    return MechanismRun("multibody", machine, summary, res.t[sel], forces, drawing.multibody_frames(machine, res, n_frames),
                        time.perf_counter() - t0)


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
