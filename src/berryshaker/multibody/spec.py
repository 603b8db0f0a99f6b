"""Planar mechanisms described as data (TOML): bodies, joints (ideal and with clearance), drivers and
force elements.  Like a machine description, a file gives every dimensional value with its unit ("0.5 mm",
"5000 rpm"; a bare number other than 0 is an error there); contact stiffness K (N/m^n) is a plain SI number.

A body's ``position`` is its centre of mass in the frame and ``angle`` its orientation; joint points
are given in the body frames (origin at the centre of mass).  ``ground`` is the fixed frame.

Joint types
-----------
revolute            ideal pin joint (2 equations)
prismatic           ideal slider: body_j slides along ``axis`` (in body_i's frame) without turning
point_on_line       ideal pin of body_i in a straight slot of body_j (1 equation)
cam_roller          ideal roller of body_i on the pitch curve of cam ``cam`` fixed to body_j (1 equation)
revolute_clearance  pin of body_i (``point_i``) in a bore of body_j (``point_j``), radial clearance
slot_clearance      pin of body_i in a straight slot of body_j, ``clearance`` = total free travel
groove_clearance    roller of body_i in the groove of cam ``cam`` on body_j, ``clearance`` = total free travel

Drivers: ``angle`` (prescribed constant speed, a constraint), ``torque`` (constant motor torque) or
``torque_speed`` (a motor's torque-speed table T(omega), linear interpolation, end values held; ``speed`` is the
body's initial speed).
Forces: ``rotational_spring_damper`` between a body and ground or another body; ``geared_spring_damper`` from
body_i (input) to body_j (output) with ``ratio`` = omega_i / omega_j, stiffness and damping on the windup
psi (psi' = omega_i - ratio omega_j - creep), efficiencies by the direction of power flow, belt creep and a slip
cap (docs/multibody.md "Powered drives"); gravity on the whole.  ``simulation.energy_audit`` integrates every
force element's power with the state (on by default when a ``torque_speed`` driver is present).
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, ValidationInfo, model_validator

from berryshaker.errors import ConfigError
from berryshaker.multibody.layout import MAX_TABLE
from berryshaker.quantity_fields import (
    UNITS_REQUIRED,
    Angle,
    Coefficient,
    FreeText,
    Name,
    SignedLength,
    describe_value,
    quantity_validator,
    read_quantity,
)
from berryshaker.quantity_fields import format_validation_error as _format_validation_error

Mass = Annotated[float, quantity_validator("mass"), Field(gt=0)]
Inertia = Annotated[float, quantity_validator("inertia"), Field(gt=0)]
LengthNN = Annotated[float, quantity_validator("length"), Field(ge=0)]
LengthPos = Annotated[float, quantity_validator("length"), Field(gt=0)]
Real = Annotated[float, BeforeValidator(lambda v: _num(v))]


def _num(v):
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ValueError(f"expected a plain number (SI), got {v!r}")
    return float(v)


def _vec(dimension: str):
    def convert(v: Any, info: ValidationInfo) -> tuple[float, float]:
        if not isinstance(v, (list, tuple)) or len(v) != 2:
            raise ValueError(f"expected a pair [x, y], got {describe_value(v)}")
        return tuple(read_quantity(c, dimension, info) for c in v)  # type: ignore[return-value]

    return BeforeValidator(convert)


Point = Annotated[tuple[float, float], _vec("length")]
Direction = Annotated[tuple[float, float], _vec("dimensionless")]
Accel = Annotated[tuple[float, float], _vec("acceleration")]  # gravity: '9.81 m/s^2', strict parser
ForcePair = Annotated[tuple[float, float], _vec("force")]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class BodySpec(_Strict):
    """A rigid body: mass (kg), central inertia (kg m^2), initial position of its centre (m) and angle (rad)."""
    name: Name
    mass: Mass
    inertia: Inertia  # about the centre of mass
    position: Point = (0.0, 0.0)
    angle: Angle = 0.0


def _registered_law(v):
    """A contact-law name checked against the registry (berryshaker.contact.laws)."""
    from berryshaker.contact.laws import law_names

    if not isinstance(v, str) or v not in law_names():
        raise ValueError(f"unknown contact law {v!r}; registered laws: {', '.join(law_names())}")
    return v


LawName = Annotated[str, BeforeValidator(_registered_law)]


class ContactSpec(_Strict):
    """Normal contact law of a clearance joint (see berryshaker.contact)."""

    law: LawName = "lankarani_nikravesh"
    stiffness: Real | Literal["hertz"] = "hertz"  # N/m^n; "hertz": from materials and radii
    exponent: float = Field(1.5, gt=0)
    restitution: float = Field(0.9, gt=0, le=1)
    damping: Annotated[float, quantity_validator("damping"), Field(ge=0)] = 0.0  # N s/m: mlsd damping, or cmax of impact
    damping_depth: LengthPos = 1e-4  # d of impact: penetration of full damping
    # v_ref of the hysteresis laws (m/s): restitution holds from this impact speed up, slower impacts get the
    # damping of one at v_ref (docs/contact.md sec. 6.4).  0 (default here): the published laws, as the validation
    # cases use them; machine descriptions default to berryshaker.contact.pair_law.DEFAULT_RESTITUTION_VELOCITY
    restitution_velocity: Annotated[float, quantity_validator("speed"), Field(ge=0)] = 0.0
    elastic_modulus: Annotated[float, quantity_validator("pressure"), Field(gt=0)] = 207e9
    poisson_ratio: float = Field(0.3, gt=-1, lt=0.5)


class JointSpec(_Strict):
    """A joint between two bodies (or a body and ground): ideal or with clearance and a contact law."""
    name: Name
    type: Literal["revolute", "prismatic", "point_on_line", "cam_roller",
                  "revolute_clearance", "slot_clearance", "groove_clearance"]
    body_i: str
    body_j: str
    point_i: Point = (0.0, 0.0)
    point_j: Point = (0.0, 0.0)
    axis: Direction = (1.0, 0.0)  # slot / slide direction in body_j's frame (prismatic: body_i's)
    cam: str | None = None
    clearance: LengthNN = 0.0
    pin_radius: LengthNN = 0.0
    contact: ContactSpec = ContactSpec()
    friction_coefficient: Coefficient = 0.0
    supports: tuple[SignedLength, SignedLength] | None = None  # prismatic: axial positions of two guide supports

    @model_validator(mode="after")
    def _check(self) -> "JointSpec":
        if self.type in ("cam_roller", "groove_clearance") and not self.cam:
            raise ValueError(f"joint {self.name!r}: type {self.type} needs cam = <name of a [[cams]] entry>")
        if self.type.endswith("_clearance") and self.type == "revolute_clearance" and self.clearance <= 0:
            raise ValueError(f"joint {self.name!r}: a revolute_clearance needs clearance > 0 (use revolute for none)")
        if self.type in ("slot_clearance", "groove_clearance") and self.clearance < 0:
            raise ValueError(f"joint {self.name!r}: clearance must be >= 0")
        if math.hypot(*self.axis) == 0:
            raise ValueError(f"joint {self.name!r}: axis must not be zero")
        return self


class CamSpec(_Strict):
    """A groove cam's pitch curve (study eq. 1-2) in its body frame (origin = rotation centre)."""

    name: Name
    law: Literal["3-4-5", "cycloidal", "4-5-6-7"] = "3-4-5"
    base_radius: LengthPos
    offset: LengthNN
    stroke: LengthPos
    rise_angle: Annotated[float, quantity_validator("angle"), Field(gt=0)]
    far_dwell_angle: Annotated[float, quantity_validator("angle"), Field(ge=0)]
    return_angle: Annotated[float, quantity_validator("angle"), Field(gt=0)]


class DriverSpec(_Strict):
    """A driver: imposed angle (constant speed), applied torque, or a torque-speed source on a body."""
    name: Name
    type: Literal["angle", "torque", "torque_speed"] = "angle"
    body: str
    speed: Annotated[float, quantity_validator("angular_speed")] = 0.0  # rad/s, signed (angle: prescribed; otherwise: initial)
    angle0: Angle | None = None  # default: the body's initial angle
    torque: Annotated[float, quantity_validator("torsional_stiffness")] = 0.0  # N m (torque driver)
    speeds: list[Annotated[float, quantity_validator("angular_speed")]] = []  # torque_speed: table speeds (rad/s, increasing)
    torques: list[Annotated[float, quantity_validator("torsional_stiffness")]] = []  # torque_speed: table torques (N m)

    @model_validator(mode="after")
    def _table(self) -> "DriverSpec":
        if self.type == "torque_speed":
            n = len(self.speeds)
            if n < 2 or n != len(self.torques) or n > MAX_TABLE:
                raise ValueError(f"driver {self.name!r}: a torque_speed driver needs speeds and torques of the same "
                                 f"length, 2 to {MAX_TABLE} points (got {n} and {len(self.torques)})")
            if any(b <= a for a, b in zip(self.speeds, self.speeds[1:])):
                raise ValueError(f"driver {self.name!r}: speeds must increase")
        elif self.speeds or self.torques:
            raise ValueError(f"driver {self.name!r}: speeds/torques belong to type = \"torque_speed\"")
        return self


class ForceSpec(_Strict):
    """A rotational spring-damper between body_i and body_j (or ground), or a constant applied force
    (``force`` = [Fx, Fy] in the frame, N) at ``point`` of body_i."""

    name: Name
    type: Literal["rotational_spring_damper", "force", "geared_spring_damper"] = "rotational_spring_damper"
    body_i: str
    body_j: str = "ground"
    stiffness: Annotated[float, quantity_validator("torsional_stiffness"), Field(ge=0)] = 0.0
    damping: Annotated[float, quantity_validator("torsional_damping"), Field(ge=0)] = 0.0
    angle0: Angle = 0.0  # free angle phi_i - phi_j
    point: Point = (0.0, 0.0)
    force: ForcePair = (0.0, 0.0)
    # geared_spring_damper: omega_i / omega_j, efficiencies (power into body_j / out of it), creep compliance
    # (fractional speed loss per N m of elastic torque, 1/(N m)), slip torque (N m, 0 = never slips), and the
    # initial windup psi (rad at the input)
    ratio: Real = 1.0
    efficiency_forward: Annotated[float, Field(gt=0, le=1)] = 1.0
    efficiency_back: Annotated[float, Field(gt=0, le=1)] = 1.0
    creep_compliance: Annotated[float, Field(ge=0)] = 0.0
    slip_torque: Annotated[float, quantity_validator("torsional_stiffness"), Field(ge=0)] = 0.0
    windup0: Angle = 0.0

    @model_validator(mode="after")
    def _geared(self) -> "ForceSpec":
        if self.type == "geared_spring_damper":
            if self.ratio == 0 or not math.isfinite(self.ratio):
                raise ValueError(f"force {self.name!r}: ratio must be a finite number other than 0")
            if self.stiffness <= 0:
                raise ValueError(f"force {self.name!r}: a geared_spring_damper needs stiffness > 0 (N m/rad)")
            if self.body_i == self.body_j:
                raise ValueError(f"force {self.name!r}: body_i and body_j are the same body")
        return self


class SimulationSpec(_Strict):
    """Integration settings: duration (s), relative tolerance, output step and largest step (s), and the
    velocity scale of the error control (m/s).

    The integrator holds each state's local error below ``atol + rtol |y|``, with ``atol = rtol x 1 mm`` for
    positions (m, rad) and ``atol = rtol x velocity_scale`` for velocities (m/s, rad/s): below
    ``velocity_scale`` a velocity's error is held absolutely, as if it moved at that speed.  The engine's default
    (0.1 m/s) suits small test mechanisms; the harvester drives and the coupled machine-plant runs use the scales
    their convergence studies chose (:data:`berryshaker.drives.base.HARVESTER_VELOCITY_SCALE`,
    :data:`berryshaker.harvest.spec.COUPLED_VELOCITY_SCALE`; docs/multibody.md "Error control").
    """
    duration: Annotated[float, quantity_validator("time"), Field(gt=0)] = 0.05
    rtol: float = Field(1e-7, gt=0, lt=1)
    velocity_scale: Annotated[float, quantity_validator("speed"), Field(gt=0)] = 0.1
    output_step: Annotated[float, quantity_validator("time"), Field(gt=0)] = 1e-5
    max_step: Annotated[float, quantity_validator("time"), Field(gt=0)] = 1e-4
    energy_audit: bool | None = None  # work of every force element; None: on when a torque_speed driver exists
    # integrate with the kernel specialised to this mechanism's structure (multibody.specialised): the same
    # results, ~1/3 less time per step (~1/4 per harvester run), 10-20 s of compilation once per structure and
    # machine; None (default): when this machine has compiled it already, else the generic kernel; false: generic
    specialised: bool | None = None


class BranchContactSpec(_Strict):
    """A point of a body striking the modal body at one station (lateral contact)."""

    name: Name
    body: str
    finger_point: Point  # in the body's frame
    station: float = Field(gt=0, le=1)  # fraction of the branch length
    side: Literal[-1, 1] = 1  # +1: the finger pushes the branch towards +lateral_axis
    mid_lateral: Annotated[float, quantity_validator("length")]  # lateral coordinate of the finger where it just touches
    engagement: Annotated[float, quantity_validator("length"), Field(ge=0)] = 0.0  # overlap already at mid_lateral (m)
    # appended for a body of several branches (a bush): where this contact's branch stands along the row
    # relative to the body's start distance (m), its own contact direction (default: the body's lateral_axis;
    # mid_lateral is then measured along it), its own contact law (default: the body's), and the multiple of
    # its force that acts back on the striking body (1: two-way; 0: the branch is driven, the mechanism feels
    # nothing; w > 1: it stands for w like branches of a sampled population)
    row_offset: Annotated[float, quantity_validator("length")] = 0.0
    axis: Direction | None = None
    contact: ContactSpec | None = None
    reaction_weight: float = Field(1.0, ge=0)

    @model_validator(mode="after")
    def _check_axis(self) -> "BranchContactSpec":
        if self.axis is not None and math.hypot(*self.axis) == 0:
            raise ValueError(f"plant contact {self.name!r}: axis must not be zero")
        return self


class ModalBodySpec(_Strict):
    """A linear flexible body in mass-normalised modal coordinates, carried past the mechanism along the row
    and struck by points of its bodies (the engine knows nothing else about it).

    Each mode k obeys eta_k'' + 2 zeta omega_k eta_k' + omega_k^2 eta_k = sum_c phi_k(c) F_c, with F_c the
    normal force of contact c; ``shapes[c][k]`` is phi_k at contact c's station (1/sqrt(kg)), lateral
    deflection at the station = sum_k phi_k eta_k.  A plant branch is one such body
    (:mod:`berryshaker.harvest.coupled` builds it from the branch's modes).
    """

    omega: list[Annotated[float, Field(gt=0)]]  # rad/s
    damping_ratio: Annotated[float, Field(ge=0, lt=1)] | list[Annotated[float, Field(ge=0, lt=1)]]  # one, or per mode
    shapes: list[list[float]]  # per contact, per mode
    lateral_axis: Direction = (1.0, 0.0)
    walking_speed: Annotated[float, quantity_validator("speed"), Field(gt=0)] = 0.5
    start_distance: Annotated[float, quantity_validator("length")] = -0.5  # plant position along the row at t = 0 (m)
    half_span: Annotated[float, quantity_validator("length"), Field(gt=0)] = 0.4
    ramp: Annotated[float, quantity_validator("length"), Field(gt=0)] = 0.1
    ramp_depth: Annotated[float, quantity_validator("length"), Field(gt=0)] = 0.2
    contact: ContactSpec = ContactSpec(law="impact", stiffness=8e7, exponent=1.5, damping=20.0)
    contacts: list[BranchContactSpec]
    # the last this many modes belong to one-way probes: every contact that moves them has reaction_weight 0, so the
    # mechanism's motion does not depend on them, and they are left out of the integrator's step-size control
    # (their error does not dilute the error norm of what the steps are chosen for; berryshaker.multibody.engine)
    probe_modes: int = Field(0, ge=0)

    @model_validator(mode="after")
    def _check_probes(self) -> "ModalBodySpec":
        n = len(self.omega)
        if self.probe_modes > n:
            raise ValueError(f"plant: probe_modes = {self.probe_modes} but the body has {n} modes")
        if self.probe_modes:
            for c, row in zip(self.contacts, self.shapes):
                if c.reaction_weight != 0 and any(v != 0 for v in row[n - self.probe_modes:]):
                    raise ValueError(f"plant contact {c.name!r} moves a probe mode and acts back "
                                     f"(reaction_weight {c.reaction_weight:g}): a probe's contacts need weight 0")
        return self


class MechanismInfo(_Strict):
    """Name, description and gravity (m/s^2) of a mechanism."""
    name: Name = "mechanism"
    description: FreeText = ""
    gravity: Accel = (0.0, 0.0)


class MechanismSpec(_Strict):
    """A complete planar mechanism description (bodies, joints, drivers, forces, cams, an optional modal body)."""
    mechanism: MechanismInfo = MechanismInfo()
    bodies: list[BodySpec]
    joints: list[JointSpec] = []
    drivers: list[DriverSpec] = []
    forces: list[ForceSpec] = []
    cams: list[CamSpec] = []
    plant: ModalBodySpec | None = None  # a flexible body struck by the mechanism (e.g. a branch)
    simulation: SimulationSpec = SimulationSpec()

    @model_validator(mode="after")
    def _names(self) -> "MechanismSpec":
        bodies = [b.name for b in self.bodies]
        if "ground" in bodies:
            raise ValueError("'ground' is the fixed frame and cannot be a body name")
        dup = {n for n in bodies if bodies.count(n) > 1}
        if dup:
            raise ValueError(f"duplicate body names: {sorted(dup)}")
        known = set(bodies) | {"ground"}
        cams = {c.name for c in self.cams}
        for j in self.joints:
            for b in (j.body_i, j.body_j):
                if b not in known:
                    raise ValueError(f"joint {j.name!r}: unknown body {b!r} (bodies: {', '.join(bodies)}, ground)")
            if j.body_i == j.body_j:
                raise ValueError(f"joint {j.name!r}: body_i and body_j are the same body")
            if j.cam and j.cam not in cams:
                raise ValueError(f"joint {j.name!r}: unknown cam {j.cam!r}")
        for d in self.drivers:
            if d.body not in bodies:
                raise ValueError(f"driver {d.name!r}: unknown body {d.body!r}")
        for f in self.forces:
            for b in (f.body_i, f.body_j):
                if b not in known:
                    raise ValueError(f"force {f.name!r}: unknown body {b!r}")
        if self.plant is not None:
            if len(self.plant.shapes) != len(self.plant.contacts) or any(
                    len(row) != len(self.plant.omega) for row in self.plant.shapes):
                raise ValueError("plant.shapes needs one row per contact with one value per mode")
            for c in self.plant.contacts:
                if c.body not in bodies:
                    raise ValueError(f"plant contact {c.name!r}: unknown body {c.body!r}")
        names = [j.name for j in self.joints]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ValueError(f"duplicate joint names: {sorted(dup)}")
        return self




def mechanism_from_dict(data: dict, source: str = "<dict>", units_required: bool = False) -> MechanismSpec:
    """Validate a nested dict into a :class:`MechanismSpec`; errors are located (``joints.2.clearance: ...``).

    ``units_required``: the data is a user's file, a bare number in a dimensional field is an error.

    Parameters
    ----------
    data : dict
        The description's tables (values with units, or SI numbers).
    source : str
        Where it came from, for the messages.
    units_required : bool
        A bare number in a dimensional field is an error (a user's file).

    Returns
    -------
    MechanismSpec
        The validated description (SI inside).
    """
    try:
        return MechanismSpec.model_validate(data, context={UNITS_REQUIRED: units_required})
    except RecursionError:
        raise ConfigError(f"invalid mechanism description {source}: values nested too deeply") from None
    except ValidationError as err:
        raise ConfigError(_format_validation_error(err, source).replace("machine description", "mechanism description")) from None


#: largest mechanism description read (bytes), as for a machine description
MAX_MECHANISM_BYTES = 1_000_000


def load_mechanism(path: str | Path) -> MechanismSpec:
    """Read a mechanism description from TOML (every dimensional value with its unit) and validate it.

    Parameters
    ----------
    path : str or Path
        The TOML file.

    Returns
    -------
    MechanismSpec
        The validated description (SI inside).

    Raises
    ------
    ConfigError
        Not a regular file of at most 1 MB (:func:`berryshaker.input_files.read_input_file`), not UTF-8 TOML, or
        invalid values.
    """
    from berryshaker.input_files import read_input_file

    p = Path(path)
    raw = read_input_file(p, "mechanism file", MAX_MECHANISM_BYTES)  # a regular file of bounded size, never blocking
    try:
        data = tomllib.loads(raw.decode("utf-8-sig"))
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{p}: not UTF-8 text (byte {exc.start}); save the file as UTF-8") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{p}: not valid TOML ({str(exc)[:200]})") from None
    except RecursionError:
        raise ConfigError(f"{p}: not valid TOML (arrays or tables nested too deeply)") from None
    return mechanism_from_dict(data, str(p), units_required=True)
