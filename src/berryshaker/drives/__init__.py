"""Comb drives as plug-ins: one sub-package per drive (its description, kinematics, mechanism, clearance pairs,
optional reduced model and reference machine), found by name in :data:`DRIVES`.  See
:mod:`berryshaker.drives.base` for the interface and docs/architecture.md for adding a drive."""

from __future__ import annotations

import importlib

from berryshaker.errors import ConfigError

#: registry name -> sub-package; a new drive is one sub-package and one line here
DRIVE_PACKAGES = {
    "groove_cam": "berryshaker.drives.groove_cam",
    "crank_rocker": "berryshaker.drives.crank_rocker",
}


def get_drive(name: str):
    """The :class:`~berryshaker.drives.base.Drive` registered as ``name``.

    Parameters
    ----------
    name : str
        A key of :data:`DRIVE_PACKAGES`, e.g. "groove_cam".

    Returns
    -------
    Drive
        The drive's plug-in (its sub-package's ``DRIVE``).

    Raises
    ------
    ConfigError
        If no drive has that name (the message lists the drives).
    """
    if name not in DRIVE_PACKAGES:
        shown = repr(name) if len(repr(name)) <= 80 else f"{repr(name)[:60]}... ({len(str(name))} characters)"
        raise ConfigError(f"unknown comb drive {shown} in [machine] drive; drives: {', '.join(DRIVE_PACKAGES)}")
    return importlib.import_module(DRIVE_PACKAGES[name]).DRIVE


def drive_of(machine):
    """The drive of a machine description.

    Parameters
    ----------
    machine : MachineBase
        The machine description (its class's ``DRIVE``).

    Returns
    -------
    Drive
        Its drive's plug-in.
    """
    return get_drive(machine.DRIVE)
