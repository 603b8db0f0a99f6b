"""The crank-rocker double rocker: a crank on the drive shaft and a connecting rod swing the left comb's rocker;
the four-bar D-C-F-E carries the swing to the right comb.  Clearance pairs crank_pin, rocker_pin, C, F (all
pin-in-bore).  No reduced model: the multibody model is its only dynamics."""

from __future__ import annotations

from berryshaker.drives.base import Drive
from berryshaker.drives.crank_rocker.machine import CrankRockerMachine


def _check(machine, allow_undercut: bool = False):
    from berryshaker.drives.crank_rocker.kinematics import check_machine

    return check_machine(machine)


def _summary(machine, kin) -> dict:
    from berryshaker.drives.crank_rocker.kinematics import kinematics_summary

    return kinematics_summary(machine, kin)


def _mechanism(machine, revolutions: int = 2):
    from berryshaker.drives.crank_rocker.mechanism import crank_rocker_mechanism

    return crank_rocker_mechanism(machine, revolutions=revolutions)


def _mid(machine):
    from berryshaker.drives.crank_rocker.kinematics import mid_stroke_angles

    return mid_stroke_angles(machine)


DRIVE = Drive(
    name="crank_rocker", title="crank + connecting rod + double rocker", machine_class=CrankRockerMachine,
    reference_package="berryshaker.drives.crank_rocker", check=_check, kinematics_summary=_summary,
    mechanism=_mechanism, mid_stroke_angles=_mid, reduced_model=None, driver="crank",
)
