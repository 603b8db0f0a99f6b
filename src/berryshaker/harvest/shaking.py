"""The combs' shaking amplitude set by the drive geometry: the comb swing and the finger amplitude a harvest
response reports (berryshaker.harvest.virtual) and the finger speed the bruising model strikes the fruit with
(berryshaker.harvest.bruising)."""

from __future__ import annotations

import math

from berryshaker.config import Machine


def shaking_amplitude(machine: Machine) -> dict:
    """The combs' shaking amplitude set by the drive geometry (the harvester designer's second knob).

    Parameters
    ----------
    machine : Machine
        Machine description (any drive).

    Returns
    -------
    dict
        ``comb_swing_deg``: half the swing range (max - min) of the left and right comb angles over one
        drive-shaft revolution of the ideal mechanism (deg; the drive's kinematics summary, docs/kinematics.md),
        the larger of the two; ``finger_amplitude_mm``: the same swing times the striking finger radius
        ``plant.contact.finger_radius`` (mm; the arc R theta -- the straight-line excursion R sin theta is
        0.5 % smaller at 10 deg).  A geometric quantity: the clearances and the bush change
        the real swing by well under a per cent (docs/plant.md), which is left out here.
    """
    from berryshaker.drives import drive_of

    drive = drive_of(machine)
    combs = drive.kinematics_summary(machine, drive.check(machine))["combs"]
    half = max(0.5 * (c["swing_deg"]["max"] - c["swing_deg"]["min"]) for c in combs.values())
    out = {"comb_swing_deg": float(half)}
    if machine.plant is not None:
        out["finger_amplitude_mm"] = float(math.radians(half) * machine.plant.contact.finger_radius * 1e3)
    return out
