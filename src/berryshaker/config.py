"""Typed machine description (pydantic), loaded from TOML with unit-aware values.

Every numeric field accepts a plain SI number or a string with a unit ("0.25 mm", "120 rpm"); the
model stores SI floats.  The reference machine of STUDY.md section 4 ships as
``berryshaker/data/reference_machine.toml`` and is the default everywhere; each of its values is
annotated there as taken from the study or assumed by us.

Geometric feasibility (the linkage assembles over the whole cycle, the cam does not undercut) needs the
kinematics and is checked by :func:`berryshaker.drives.groove_cam.kinematics.check_machine`, which
``berryshaker config validate`` and every simulation call before doing any work.
"""

from __future__ import annotations

import math
import tomllib
from importlib import resources
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, Field, ValidationError, model_validator

from berryshaker.errors import ConfigError
from berryshaker.units import parse_quantity
from berryshaker.quantity_fields import (  # noqa: F401  (re-exported for description modules)
    Angle, AngularSpeed, Coefficient, Damping, Inertia, Length, LengthNonNeg, Mass, NonNegAngle, PositiveAngle,
    Stiffness, StrictModel as _Strict, TorsionalDamping, TorsionalStiffness, _d, _q, format_validation_error,
)
from berryshaker.plant.spec import BranchSpec, CombContactSpec, FruitSpec, PlantSpec  # noqa: F401
from berryshaker.harvest.spec import HarvestSpec  # noqa: F401

PAIR_NAMES = ("A", "B", "C", "F")


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
    bearing_G_x: float = Field(default=0.18, json_schema_extra=_d("mm"))  # frame x of bearing G (m)
    bearing_H_x: float = Field(default=0.32, json_schema_extra=_d("mm"))  # frame x of bearing H (m)

    @model_validator(mode="before")
    @classmethod
    def _units(cls, data: Any) -> Any:
        if isinstance(data, dict):
            data = dict(data)
            for key in ("bearing_G_x", "bearing_H_x"):
                if key in data:
                    try:
                        data[key] = parse_quantity(data[key], "length", key)
                    except ConfigError as exc:
                        raise ValueError(str(exc)) from None
        return data

    @model_validator(mode="after")
    def _check(self) -> "PushRod":
        if abs(self.bearing_G_x - self.bearing_H_x) < 1e-6:
            raise ValueError("bearing_G_x and bearing_H_x must be distinct points of the guide")
        return self


class Rocker(_Strict):
    """Left comb rocker: slot through shaft D in which push-rod roller B slides; arm DC (eq. 3)."""

    shaft_D_x: float | None = Field(default=None, json_schema_extra=_d("mm"))  # None: below B at mid-stroke
    shaft_D_drop: Length  # y_D = e - drop
    arm_CD: Length  # l_CD
    arm_angle: Angle = math.pi  # angle of D->C measured from the slot direction D->B

    @model_validator(mode="before")
    @classmethod
    def _units(cls, data: Any) -> Any:
        if isinstance(data, dict) and data.get("shaft_D_x") is not None:
            data = dict(data)
            if data["shaft_D_x"] == "mid-stroke":
                data["shaft_D_x"] = None
            else:
                try:
                    data["shaft_D_x"] = parse_quantity(data["shaft_D_x"], "length", "shaft_D_x")
                except ConfigError as exc:
                    raise ValueError(str(exc)) from None
        return data


class FourBar(_Strict):
    """Double rocker D-C-F-E: ground DE (horizontal), left arm DC, coupler CF, right arm FE (eq. 3)."""

    ground_DE: Length  # l_DE, E = D + (l_DE, 0)
    coupler_CF: Length  # l_CF (= l_4)
    arm_FE: Length  # l_FE
    branch: Literal[-1, 1] = 1  # sign of the rotation from E->C to E->F
    coupler_mass: Mass  # m4


class Combs(_Strict):
    """The two combs (nylon finger banks) swinging about shafts D and E."""

    length: Length  # l3 = l5
    left_mass: Mass  # m3
    right_mass: Mass  # m5
    plant_friction_coefficient: Coefficient = 0.3  # mu3
    load_stiffness: TorsionalStiffness = 200.0  # bush reaction on a comb about its shaft
    load_damping: TorsionalDamping = 20.0

    @property
    def left_inertia(self) -> float:
        """m3 l3^2 / 3 (slender bar about its end), kg m^2."""
        return self.left_mass * self.length**2 / 3.0

    @property
    def right_inertia(self) -> float:
        """m5 l5^2 / 3 (slender bar about its end), kg m^2."""
        return self.right_mass * self.length**2 / 3.0


class ClearancePair(_Strict):
    """One clearance joint of the drive (study eq. 8 parameters).

    ``size`` is the total free travel across the groove (groove width minus roller diameter) for the
    point-line pairs A and B, and the radial clearance (bore radius minus pin radius) for the
    pin-in-bore pairs C and F.
    """

    kind: Literal["point-line", "revolute"]
    size: LengthNonNeg
    stiffness: Stiffness  # K_i
    damping: Damping  # C_i


class Clearances(_Strict):
    A: ClearancePair
    B: ClearancePair
    C: ClearancePair
    F: ClearancePair

    def sizes(self) -> dict[str, float]:
        return {p: getattr(self, p).size for p in PAIR_NAMES}


class OperationSpec(_Strict):
    walking_speed: Annotated[float, _q("speed"), Field(gt=0, json_schema_extra=_d("m/min"))] = 0.5  # 30 m/min
    plant_spacing: Length = 1.5
    test_duration: Annotated[float, _q("time"), Field(gt=0, json_schema_extra=_d("s"))] = 10.0


class MachineInfo(_Strict):
    name: str = "unnamed machine"
    description: str = ""


class Machine(_Strict):
    """A complete harvester drive description.  All values SI."""

    machine: MachineInfo = MachineInfo()
    cam: Cam
    push_rod: PushRod
    rocker: Rocker
    four_bar: FourBar
    combs: Combs
    clearance: Clearances
    plant: PlantSpec | None = None
    operation: OperationSpec = OperationSpec()
    harvest: HarvestSpec = HarvestSpec()

    # ---- derived geometry -------------------------------------------------------------------
    @property
    def shaft_D(self) -> tuple[float, float]:
        """Frame coordinates of the left comb shaft D (m); O is the cam centre."""
        x = self.rocker.shaft_D_x
        if x is None:
            x = self.cam.s0 + self.cam.stroke / 2 + self.push_rod.length
        return (x, self.cam.offset - self.rocker.shaft_D_drop)

    @property
    def shaft_E(self) -> tuple[float, float]:
        """Frame coordinates of the right comb shaft E (m): D and E on a horizontal line (theta_DE = 0)."""
        xd, yd = self.shaft_D
        return (xd + self.four_bar.ground_DE, yd)

    def with_clearances(self, sizes: dict[str, float]) -> "Machine":
        """A copy with the clearance sizes (m) replaced for the named pairs."""
        data = self.model_dump()
        for pair, size in sizes.items():
            if pair not in PAIR_NAMES:
                raise ConfigError(f"unknown clearance pair {pair!r}; pairs are A, B, C, F")
            if not (size >= 0 and math.isfinite(size)):
                raise ConfigError(f"clearance {pair}: size must be >= 0, got {size * 1e3:g} mm")
            data["clearance"][pair]["size"] = size
        return Machine.model_validate(data)


def machine_from_dict(data: dict[str, Any], source: str = "<dict>") -> Machine:
    """Validate a nested dict (as read from TOML) into a :class:`Machine`."""
    try:
        return Machine.model_validate(data)
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, source)) from None


def reference_toml_text() -> str:
    """Text of the built-in reference machine TOML (with its source annotations)."""
    return resources.files("berryshaker.drives.groove_cam").joinpath("reference.toml").read_text("utf-8")


def load_machine(path: str | Path | None = None) -> Machine:
    """Load a machine description from TOML; ``None`` gives the built-in reference machine."""
    if path is None:
        text, source = reference_toml_text(), "(built-in reference machine)"
    else:
        p = Path(path)
        if not p.is_file():
            raise ConfigError(f"config file not found: {p}")
        text, source = p.read_text("utf-8"), str(p)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source}: not valid TOML ({exc})") from None
    return machine_from_dict(data, source)


def reference_machine() -> Machine:
    """The built-in reference machine of STUDY.md section 4."""
    return load_machine(None)


def machine_table(machine: Machine) -> list[tuple[str, str]]:
    """(dotted key, value in engineering units) for every field of the machine, in file order."""
    from berryshaker.units import ENGINEERING_FACTORS

    rows: list[tuple[str, str]] = []

    def walk(model: BaseModel, prefix: str) -> None:
        for name, info in type(model).model_fields.items():
            value = getattr(model, name)
            key = f"{prefix}{name}"
            if isinstance(value, BaseModel):
                walk(value, key + ".")
                continue
            extra = info.json_schema_extra if isinstance(info.json_schema_extra, dict) else {}
            unit = extra.get("display")
            if value is None:
                text = "auto"
            elif unit and isinstance(value, float):
                text = f"{value / ENGINEERING_FACTORS[unit]:.6g}" + ("" if unit == "1" else f" {unit}")
            else:
                text = str(value)
            rows.append((key, text))

    walk(machine, "")
    return rows
