"""The virtual harvest against drive speed: a machine description with another drive speed, and the harvest
response at each of a list of cam speeds.  Part of the virtual harvest (berryshaker.harvest.virtual).
"""

from __future__ import annotations

import math

from berryshaker.config import Machine, machine_from_dict
from berryshaker.harvest.virtual.replicates import harvest_response


def with_drive_speed(machine_data: dict, speed: float) -> dict:
    """A machine description (dict, SI) with the drive shaft's speed replaced (rad/s), for any drive: the
    section whose ``speed`` is the machine's drive speed (``cam.speed``, ``crank.speed``, ...).

    Parameters
    ----------
    machine_data : dict
        Machine description (SI, ``model_dump(mode="json")``); not modified.
    speed : float
        New drive speed (rad/s), > 0.

    Returns
    -------
    dict
        A shallow copy with the drive section's ``speed`` replaced.

    Raises
    ------
    ConfigError
        ``speed`` is not > 0, or no section's speed is the drive speed.
    """
    from berryshaker.errors import ConfigError

    if not speed > 0:
        raise ConfigError(f"drive speed must be > 0, got {speed} rad/s")
    current = machine_from_dict(machine_data).drive_speed
    d = dict(machine_data)
    for key, sec in machine_data.items():
        if isinstance(sec, dict) and isinstance(sec.get("speed"), (int, float)) and \
                math.isclose(sec["speed"], current, rel_tol=1e-12):
            d[key] = dict(sec, speed=float(speed))
            return d
    raise ConfigError("the machine description has no section whose speed is the drive speed")


def removal_at_speed(machine_data: dict, speed_rpm: float, clearance: dict | None = None) -> dict:
    """Virtual harvest at one drive (cam shaft) speed: a plain function of data for the cached runner.

    Parameters
    ----------
    machine_data : dict
        Machine description as a dict (``Machine.model_dump(mode="json")``).
    speed_rpm : float
        Cam shaft speed (r/min); replaces ``cam.speed``.
    clearance : dict, optional
        Clearance sizes (m).

    Returns
    -------
    dict
        speed_rpm and the indexes of :func:`~berryshaker.harvest.virtual.replicates.harvest_response`.
    """
    from berryshaker.errors import ConfigError

    d = dict(machine_data)
    if "cam" not in d:
        raise ConfigError("removal_at_speed varies cam.speed: the machine description has no [cam] section")
    if not speed_rpm > 0:
        raise ConfigError(f"cam speed must be > 0 r/min, got {speed_rpm}")
    d["cam"] = dict(d["cam"], speed=float(speed_rpm) * 2 * math.pi / 60.0)
    return {"speed_rpm": float(speed_rpm), **harvest_response(machine_from_dict(d), clearance)}


def removal_vs_frequency(machine: Machine, speeds_rpm, clearance: dict | None = None) -> list[dict]:
    """Ripe removal, unripe shedding and damage against cam speed (one :func:`removal_at_speed` row each).

    Parameters
    ----------
    machine : Machine
        Machine description with a [cam] section, [plant] and [harvest].
    speeds_rpm : iterable of float
        Cam shaft speeds (rpm).
    clearance : dict, optional
        Clearance sizes (m) per pair.

    Returns
    -------
    list of dict
        One :func:`removal_at_speed` row per speed.
    """
    data = machine.model_dump(mode="json")
    return [removal_at_speed(data, s, clearance) for s in speeds_rpm]
