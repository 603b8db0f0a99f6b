"""The crank-rocker double rocker's machine description: a crank on the drive shaft and a connecting rod swing
the left comb's rocker in place of the groove cam and push rod; the four-bar D-C-F-E to the right comb is the
same as the groove-cam drive's.

Frame: origin O at the crank centre, x towards the combs, y up.  The crank turns clockwise (as the groove cam).
Clearance pairs: ``crank_pin`` (crank pin in the connecting-rod bore), ``rocker_pin`` (rod pin in the rocker
bore), ``C`` and ``F`` (connecting-rod pins of the four-bar), all pin-in-bore.
"""

from __future__ import annotations

import math
from typing import ClassVar, Literal

from pydantic import model_validator

from berryshaker.drives.base import MachineBase, PairInfo
from berryshaker.quantity_fields import Angle, AngularSpeed, Inertia, Length, Mass, SignedLength, check_drive_speed
from berryshaker.quantity_fields import StrictModel as _Strict


class Crank(_Strict):
    """The crank on the drive shaft (replaces the groove cam)."""

    radius: Length  # r, crank pin from O
    speed: AngularSpeed  # omega, drive shaft
    inertia: Inertia  # drive shaft + crank about O
    mass: Mass = 3.0  # loads only the shaft bearing (the shaft is driven at constant speed)

    @model_validator(mode="after")
    def _speed(self) -> "Crank":
        check_drive_speed(self.speed, "crank.speed")
        return self


class ConnectingRod(_Strict):
    """Rod from the crank pin to the rocker pin R."""

    length: Length  # l
    mass: Mass


class CrankRocker(_Strict):
    """Left comb rocker: shaft D, pin R at ``arm_R`` from D, arm DC to the connecting rod of the four-bar."""

    shaft_D_x: SignedLength  # frame x of shaft D (may be negative)
    shaft_D_y: SignedLength
    arm_R: Length  # D->R
    arm_R_angle: Angle = 0.0  # direction of D->R from the comb direction
    arm_CD: Length  # D->C
    arm_angle: Angle = math.pi  # direction of D->C from the comb direction
    assembly: Literal[-1, 1] = 1  # which of the two rod-rocker closures


class CrankRockerMachine(MachineBase):
    """A harvester whose left comb is swung by a crank and connecting rod."""

    DRIVE: ClassVar[str] = "crank_rocker"
    PAIRS: ClassVar[tuple[PairInfo, ...]] = (
        PairInfo("crank_pin", "pin-in-bore", "crank pin in the connecting-rod bore",
                 lambda m: (0.2 * m.crank.radius, "20 % of the crank radius")),
        PairInfo("rocker_pin", "pin-in-bore", "connecting-rod pin in the rocker bore",
                 lambda m: (0.1 * m.rocker.arm_R, "10 % of arm DR")),
        PairInfo("C", "pin-in-bore", "connecting-rod pin on the left comb",
                 lambda m: (0.1 * m.rocker.arm_CD, "10 % of arm CD")),
        PairInfo("F", "pin-in-bore", "connecting-rod pin on the right comb",
                 lambda m: (0.1 * m.four_bar.arm_FE, "10 % of arm FE")),
    )

    crank: Crank
    rod: ConnectingRod
    rocker: CrankRocker

    @property
    def shaft_D(self) -> tuple[float, float]:
        """Frame coordinates of the left comb shaft D (m); O is the crank centre."""
        return (self.rocker.shaft_D_x, self.rocker.shaft_D_y)

    @property
    def drive_speed(self) -> float:
        """Crank speed (rad/s)."""
        return self.crank.speed

    @property
    def drive_inertia(self) -> float:
        """Crank and shaft inertia about O (kg m^2)."""
        return self.crank.inertia
