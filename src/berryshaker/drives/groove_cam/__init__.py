"""The groove-cam double rocker (the reference study's comb drive): a groove cam drives a push rod whose roller
swings the left comb's rocker; a four-bar carries the swing to the right comb.  Clearance pairs A (cam roller
in the groove), B (push-rod roller in the rocker slot), C and F (connecting-rod pins).  Reduced model: MLSD
(docs/mlsd.md)."""

from __future__ import annotations

from berryshaker.drives.base import Drive
from berryshaker.drives.groove_cam.machine import GrooveCamMachine


def _check(machine, allow_undercut: bool = False):
    from berryshaker.drives.groove_cam.kinematics import check_machine

    return check_machine(machine, allow_undercut=allow_undercut)


def _summary(machine, kin) -> dict:
    from berryshaker.drives.groove_cam.kinematics import kinematics_summary

    return kinematics_summary(machine, kin)


def _mechanism(machine, revolutions: int = 2):
    from berryshaker.drives.groove_cam.mechanism import harvester_mechanism

    return harvester_mechanism(machine, revolutions=revolutions)


def _mid(machine):
    from berryshaker.drives.groove_cam.kinematics import mid_stroke_angles

    return mid_stroke_angles(machine)


def _mlsd(machine, clearance=None, revolutions: int = 3, **kw):
    from berryshaker.drives.groove_cam.mlsd import simulate_mlsd

    return simulate_mlsd(machine, clearance, revolutions=revolutions, **kw)


DRIVE = Drive(
    name="groove_cam", title="groove cam + push rod + double rocker", machine_class=GrooveCamMachine,
    reference_package="berryshaker.drives.groove_cam", check=_check, kinematics_summary=_summary,
    mechanism=_mechanism, mid_stroke_angles=_mid, reduced_model=_mlsd, reduced_model_name="mlsd", driver="cam",
)
