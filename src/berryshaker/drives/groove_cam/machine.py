"""The groove-cam double rocker's machine description (docs/study.md sec. 1 and eq. 1-3).

Engine -> belt -> CVT -> worm reducer -> groove cam (O) -> cam roller in the groove (pair A) -> push rod in a
linear bearing -> push-rod roller in the slot of the left comb's rocker (pair B) -> left comb about D ->
connecting rod CF (pins C and F) -> right comb about E.  Frame: origin O at the cam centre, x along the push
rod, y up.  Values SI inside; a machine file gives every dimensional value with its unit.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar, Literal

from pydantic import model_validator

from berryshaker.drives.base import MachineBase, PairInfo
from berryshaker.quantity_fields import (
    Angle,
    AngularSpeed,
    Coefficient,
    Inertia,
    Length,
    LengthNonNeg,
    Mass,
    NonNegAngle,
    PositiveAngle,
    SignedLength,
    check_drive_speed,
)
from berryshaker.quantity_fields import StrictModel as _Strict
from berryshaker.reference_study import CLEARANCE_LEVELS_MM


class Cam(_Strict):
    """Groove cam and its follower law (study eq. 1-2, Fig. 5)."""

    law: Literal["3-4-5", "cycloidal", "4-5-6-7"] = "3-4-5"
    base_radius: Length  # r0
    offset: LengthNonNeg  # e
    stroke: Length  # h
    roller_radius: Length  # r_r
    rise_angle: PositiveAngle  # delta_0
    far_dwell_angle: NonNegAngle  # delta_01
    return_angle: PositiveAngle  # delta_0'
    near_dwell_angle: NonNegAngle  # delta_02
    speed: AngularSpeed  # omega
    inertia: Inertia  # J_O

    @model_validator(mode="after")
    def _check(self) -> "Cam":
        total = self.rise_angle + self.far_dwell_angle + self.return_angle + self.near_dwell_angle
        if abs(total - 2 * math.pi) > 1e-6:
            raise ValueError(
                "rise_angle + far_dwell_angle + return_angle + near_dwell_angle must be 360 deg, "
                f"got {math.degrees(total):.4g} deg"
            )
        check_drive_speed(self.speed, "cam.speed")
        if self.offset >= self.base_radius:
            raise ValueError(
                f"offset e = {self.offset * 1e3:.4g} mm must be smaller than base_radius "
                f"r0 = {self.base_radius * 1e3:.4g} mm (s0 = sqrt(r0^2 - e^2))"
            )
        return self

    @property
    def s0(self) -> float:
        """Distance along the push-rod axis from O's foot to the roller centre at s = 0 (m)."""
        return math.sqrt(self.base_radius**2 - self.offset**2)


class PushRod(_Strict):
    """Push rod sliding in a linear bearing along y = e (study eq. 10)."""

    length: Length  # l_AB, roller A centre to roller B centre
    mass: Mass  # m2
    friction_coefficient: Coefficient = 0.05  # mu2, push rod in its linear bearing
    bearing_G_x: SignedLength = 0.18  # frame x of bearing G (m)
    bearing_H_x: SignedLength = 0.32  # frame x of bearing H (m)

    @model_validator(mode="after")
    def _check(self) -> "PushRod":
        if abs(self.bearing_G_x - self.bearing_H_x) < 1e-6:
            raise ValueError("bearing_G_x and bearing_H_x must be distinct points of the guide")
        return self


class Rocker(_Strict):
    """Left comb rocker: slot through shaft D in which push-rod roller B slides; arm DC (eq. 3)."""

    shaft_D_x: SignedLength | None = None  # None (or "mid-stroke"): below B at mid-stroke
    shaft_D_drop: Length  # y_D = e - drop
    arm_CD: Length  # l_CD
    arm_angle: Angle = math.pi  # angle of D->C measured from the slot direction D->B

    @model_validator(mode="before")
    @classmethod
    def _mid_stroke(cls, data: Any) -> Any:
        if isinstance(data, dict) and data.get("shaft_D_x") == "mid-stroke":
            data = dict(data, shaft_D_x=None)
        return data


class GrooveCamMachine(MachineBase):
    """A harvester whose left comb is swung by a groove cam and push rod (the reference study's machine)."""

    DRIVE: ClassVar[str] = "groove_cam"
    PAIRS: ClassVar[tuple[PairInfo, ...]] = (
        PairInfo("A", "roller-in-groove", "cam roller in the cam groove",
                 lambda m: (0.2 * m.cam.roller_radius, "20 % of the cam roller radius"),
                 # contact law: the convex inner groove wall at the base circle, r0 - r_r [derived]; the concave
                 # outer wall (r0 + r_r) gives a 3-5 % softer law (docs/contact.md sec. 6)
                 wall_radius=lambda m: (m.cam.base_radius - m.cam.roller_radius if m.cam.base_radius > 2 * m.cam.roller_radius
                                      else math.inf)),  # an undercut cam is refused by its check
        PairInfo("B", "roller-in-slot", "push-rod roller in the rocker slot",
                 lambda m: (0.2 * m.cam.roller_radius, "20 % of the roller radius")),
        PairInfo("C", "pin-in-bore", "connecting-rod pin on the left comb",
                 lambda m: (0.1 * m.rocker.arm_CD, "10 % of arm CD")),
        PairInfo("F", "pin-in-bore", "connecting-rod pin on the right comb",
                 lambda m: (0.1 * m.four_bar.arm_FE, "10 % of arm FE")),
    )
    LEGACY_KINDS: ClassVar[dict[str, str]] = {"A": "roller-in-groove", "B": "roller-in-slot"}
    DEFAULT_LEVELS_MM: ClassVar[dict[str, tuple[float, float, float]]] = CLEARANCE_LEVELS_MM

    cam: Cam
    push_rod: PushRod
    rocker: Rocker

    @model_validator(mode="after")
    def _roller_clears_shaft_D(self) -> "GrooveCamMachine":
        # B runs along y = e from x = s0 + l_AB to s0 + h + l_AB; the slot pivots on shaft D, so the roller
        # must stay more than its radius from D (closer, the left comb's rate -v dy / |BD|^2 blows up)
        xd, yd = self.shaft_D
        x0 = self.cam.s0 + self.push_rod.length
        dx = max(x0 - xd, 0.0, xd - (x0 + self.cam.stroke))
        dist = math.hypot(dx, self.cam.offset - yd)
        if not dist > self.cam.roller_radius:
            raise ValueError(f"rocker.shaft_D_drop = {self.rocker.shaft_D_drop * 1e3:.4g} mm: the push-rod roller B "
                             f"passes {dist * 1e3:.4g} mm from shaft D, closer than the roller radius "
                             f"{self.cam.roller_radius * 1e3:.4g} mm (the slot pivots on D); increase shaft_D_drop "
                             f"or move shaft_D_x")
        return self

    @property
    def shaft_D(self) -> tuple[float, float]:
        """Frame coordinates of the left comb shaft D (m); O is the cam centre."""
        x = self.rocker.shaft_D_x
        if x is None:
            x = self.cam.s0 + self.cam.stroke / 2 + self.push_rod.length
        return (x, self.cam.offset - self.rocker.shaft_D_drop)

    @property
    def drive_speed(self) -> float:
        """Cam shaft speed (rad/s)."""
        return self.cam.speed

    @property
    def drive_inertia(self) -> float:
        """Cam inertia J_O (kg m^2)."""
        return self.cam.inertia
