"""What every comb drive shares: the machine-description sections common to all drives, the clearance pair
and the :class:`Drive` interface a drive sub-package implements.

A comb drive turns the drive shaft into the swing of two combs.  Every drive here ends in the same double
rocker to the right comb (left comb about shaft D, arm DC, connecting rod CF, right comb about shaft E,
docs/study.md eq. 3), so the combs, the four-bar and the plant/operation/harvest sections are common; what
differs is how the left comb is swung (groove cam + push rod, crank + connecting rod, ...) and so the drive's
own sections, clearance pairs, kinematics and mechanism.

A drive sub-package (``berryshaker.drives.<name>``) provides a :class:`Drive` instance called ``DRIVE``:

- ``machine_class``: its typed description (a subclass of :class:`MachineBase`, SI inside, units at the edges);
- ``pairs``: its clearance pairs (:class:`PairInfo`: name, kind, what it is, the geometric limit of its size);
- ``check(machine)``: kinematics over one drive-shaft revolution, raising ``GeometryError`` where it cannot run;
- ``kinematics_summary(machine, kin)``: the JSON of ``berryshaker kinematics``;
- ``mechanism(machine, revolutions)``: the :class:`~berryshaker.multibody.spec.MechanismSpec` handed to the
  generic multibody engine (bodies ``left_comb`` and ``right_comb`` and the driver ``drive`` are required names);
- ``mid_stroke_angles(machine)``: the combs' reference angles (rad);
- optionally ``reduced_model(machine, clearance, revolutions, start_angle=0.0)``: a faster model of the same
  drive returning an object with ``summary()`` (the groove cam's MLSD model), started at drive-shaft angle
  ``start_angle`` (rad: the replicates of the study's model check); ``None`` where the drive has none.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Any, Callable, ClassVar, Literal

from pydantic import Field, model_validator

from berryshaker.drives.powered import MachineDriveline
from berryshaker.errors import ConfigError
from berryshaker.harvest.spec import HarvestSpec
from berryshaker.plant.spec import PlantSpec
from berryshaker.quantity_fields import (
    Coefficient,
    Damping,
    Force,
    FreeText,
    Length,
    LengthNonNeg,
    Mass,
    Name,
    Stiffness,
    StrictModel,
    TorsionalDamping,
    TorsionalStiffness,
    display_unit,
    quantity_validator,
)
from berryshaker.units import check_limits

#: default relative tolerance of a harvester's multibody run (every drive), chosen by the convergence study in
#: tests/multibody/test_perturbation.py: over 8 perturbed starts and 6 revolutions, the loosest rtol at which no
#: statistic of the run's summary differs from rtol 1e-7 beyond 2 standard errors (docs/multibody.md, "Integrator")
HARVESTER_RTOL = 1e-5
#: velocity scale (m/s) of a harvester run's error control (``simulation.velocity_scale``: a velocity's error is
#: held below rtol x (this + |v|)), chosen by the same criterion (benchmarks/studies/velocity_scale_study.py):
#: against rtol 1e-7 over 8 perturbed starts and 6 revolutions,
#: 1 m/s (the combs' speed scale) shifts no statistic by more than 0.03 % beyond 2 standard errors, on both drives,
#: for 5-9 % fewer steps than the engine's 0.1 m/s; 3 m/s shifts p95s by 3 % and the drive moment's peak by 5 %
HARVESTER_VELOCITY_SCALE = 1.0

#: the kinds of clearance joint a drive can have
PAIR_KINDS = ("pin-in-bore", "roller-in-groove", "roller-in-slot")


def _law_name(v: Any) -> str:
    from berryshaker.contact.laws import law_names

    if not isinstance(v, str) or v not in law_names():
        raise ValueError(f"unknown contact law {v!r}; registered laws: {', '.join(law_names())}")
    return v


#: largest radial clearance of a pin-in-bore pair as a fraction of its pin diameter that a description may give (a
#: bound against a misread value, far above any service limit: berryshaker.life.service.SERVICE_FRACTION)
MAX_CLEARANCE_FRACTION = 0.1


class ClearancePair(StrictModel):
    """One clearance joint of a drive: its size, geometry and the contact law of its collisions.

    ``size`` is the radial clearance (bore radius minus pin radius) of a pin-in-bore pair and the total free
    travel across the groove or slot (width minus roller diameter) of a roller pair.  ``law`` names a law of
    :mod:`berryshaker.contact.laws`.

    The contact law by default comes from the geometry (``diameter``, ``bearing_length``) and the materials
    (``material_pair``): K and n of the power law fitted to Johnson's line-contact relation with hysteresis
    damping for the coefficient of ``restitution`` (:mod:`berryshaker.contact.pair_law`, docs/contact.md
    sec. 6).  Giving ``stiffness`` (K in N/m^n; ``exponent`` n, default 1) overrides the geometry; a pair
    that gives its stiffness but no ``law`` is a berryshaker 0.1.0/0.2 pair and keeps their law, the IMPACT
    function with the linear spring K_i, cmax = ``damping`` and full damping at ``damping_depth``.  The
    linear spring-damper of the study's eq. 8 is ``law = "mlsd"``.  ``fit``, ``diameter``,
    ``bearing_length`` and ``material_pair`` also describe the joint for its wear life (:mod:`berryshaker.life`).
    """

    kind: Literal["pin-in-bore", "roller-in-groove", "roller-in-slot"]
    size: LengthNonNeg
    law: str = "lankarani_nikravesh"  # berryshaker.contact.pair_law.DEFAULT_LAW
    stiffness: Stiffness | None = None  # K_i: None = from geometry; N/m for exponent 1, a plain SI number (N/m^n)
    damping: Damping | None = None  # viscous C_i (mlsd) or cmax (impact); not used by the hysteresis laws
    exponent: float | None = Field(None, gt=0, le=3)  # None: from geometry (or 1 with a given stiffness)
    damping_depth: Length = 1e-5
    restitution: float = Field(0.9, gt=0, le=1)  # [assumed] steel on steel (Flores & Ambrosio 2004 use 0.9)
    # v_ref (m/s) of the hysteresis laws: ``restitution`` holds from this impact speed up, slower impacts get the
    # damping of one at v_ref (restitution -> 1 as the speed -> 0); None: pair_law.default_restitution_velocity
    # (the yield velocity of a dry pair, the numerical floor LUBRICATED_RESTITUTION_VELOCITY of a lubricated one)
    restitution_velocity: Annotated[float, quantity_validator("speed"), Field(ge=0, json_schema_extra=display_unit("m/s"))] | None = None
    levels: tuple[LengthNonNeg, LengthNonNeg, LengthNonNeg] | None = None  # test levels 1/2/3 (virtual L9, rows)
    fit: str | None = None  # ISO 286 fit on the drawing, e.g. "H8/f7" (hole/shaft at ``diameter``)
    diameter: Length | None = None  # pin diameter (pin-in-bore) or roller diameter (roller pairs)
    bearing_length: Length | None = None  # axial length of the contact (bush length, roller width)
    material_pair: str | None = None  # key of berryshaker.contact.wear.MATERIAL_PAIRS
    # a roller pair whose roller runs on a rolling bearing (track roller, cam follower): its basic dynamic load
    # rating C, for the ISO 281 basic rating life (berryshaker.life.contact_fatigue)
    dynamic_load_rating: Force | None = None

    @model_validator(mode="before")
    @classmethod
    def _law(cls, data: Any) -> Any:
        if isinstance(data, dict):
            if "law" in data:
                try:
                    _law_name(data["law"])
                except ValueError as exc:
                    raise ValueError(str(exc)) from None
            elif data.get("stiffness") is not None:  # a 0.1.0/0.2 pair: its linear spring with IMPACT
                from berryshaker.contact.pair_law import LEGACY_LAW

                data = dict(data, law=LEGACY_LAW)
        return data

    @model_validator(mode="after")
    def _rolling_bearing_only_on_rollers(self) -> "ClearancePair":
        if self.dynamic_load_rating is not None and self.kind == "pin-in-bore":
            raise ValueError("dynamic_load_rating: a pin in a bore is a plain bearing, not a rolling bearing; give it "
                             "only for a roller pair whose roller runs on a rolling bearing, or leave it out")
        return self

    @model_validator(mode="after")
    def _fit_readable(self) -> "ClearancePair":
        # read here, where the description is built, so `config validate` refuses what `life` could not read
        if self.fit is not None:
            from berryshaker.life.fits import parse_fit

            try:
                parse_fit(self.fit, self.geometry().diameter * 1e3)
            except ConfigError as exc:
                raise ValueError(f"fit: {exc}".replace("fit: fit ", "fit ")) from None
        return self

    def geometry(self, wall_radius: float = math.inf):
        """The pair's :class:`~berryshaker.contact.pair_law.PairGeometry` ([assumed] defaults filled in).

        Parameters
        ----------
        wall_radius : float
            Radius of curvature of the wall a roller runs on (m); inf for a straight slot or a pin.

        Returns
        -------
        PairGeometry
            Kind, clearance, diameter, bearing length, materials and wall radius (SI).
        """
        from berryshaker.contact.pair_law import pair_geometry

        return pair_geometry(self.kind, self.size, self.diameter, self.bearing_length, self.material_pair,
                             wall_radius)

    def contact(self, wall_radius: float = math.inf, tags: dict | None = None, field_prefix: str = "clearance"):
        """The resolved contact law (:class:`~berryshaker.contact.pair_law.PairContact`) at the pair's size.

        Parameters
        ----------
        wall_radius : float
            Radius of curvature of the wall a roller runs on (m); inf for a straight slot or a pin.
        tags : dict, optional
            Provenance tags of the pair's fields (field name -> tag).
        field_prefix : str
            Dotted key of the pair in the description, named in messages.

        Returns
        -------
        PairContact
            The law, K (N/m^n), n, damping and their provenance.
        """
        from berryshaker.contact.pair_law import resolve_pair_contact

        return resolve_pair_contact(self.law, self.geometry(wall_radius), self.stiffness, self.exponent,
                                    self.damping, self.damping_depth, self.restitution, tags, field_prefix,
                                    self.restitution_velocity)


class Combs(StrictModel):
    """The two combs (nylon finger banks) swinging about shafts D and E."""

    length: Length  # l3 = l5
    left_mass: Mass  # m3
    right_mass: Mass  # m5
    plant_friction_coefficient: Coefficient = 0.3  # mu3
    load_stiffness: TorsionalStiffness = 200.0  # aggregate bush reaction on a comb about its shaft
    load_damping: TorsionalDamping = 20.0
    # the comb's load in runs with a plant: "branches" = the bush population of [plant.bush] (its reactions are
    # the load; the aggregate spring-damper is left out), "aggregate" = the spring-damper above (the plant's
    # branch is then driven without acting back).  Runs without a plant always use the aggregate.
    load_model: Literal["branches", "aggregate"] = "branches"

    @property
    def left_inertia(self) -> float:
        """m3 l3^2 / 3 (slender bar about its end), kg m^2."""
        return self.left_mass * self.length**2 / 3.0

    @property
    def right_inertia(self) -> float:
        """m5 l5^2 / 3 (slender bar about its end), kg m^2."""
        return self.right_mass * self.length**2 / 3.0


class FourBar(StrictModel):
    """Double rocker D-C-F-E: ground DE (horizontal), left arm DC, coupler CF, right arm FE (eq. 3)."""

    ground_DE: Length  # l_DE, E = D + (l_DE, 0)
    coupler_CF: Length  # l_CF (= l_4)
    arm_FE: Length  # l_FE
    branch: Literal[-1, 1] = 1  # sign of the rotation from E->C to E->F
    coupler_mass: Mass  # m4


class OperationSpec(StrictModel):
    """How the machine is run in the field (study field settings)."""

    walking_speed: Annotated[float, quantity_validator("speed", "m/min"), Field(gt=0, json_schema_extra=display_unit("m/min"))] = 0.5  # 30 m/min
    plant_spacing: Length = 1.5
    test_duration: Annotated[float, quantity_validator("time"), Field(gt=0, json_schema_extra=display_unit("s"))] = 10.0


class MachineInfo(StrictModel):
    """Name, description and the comb drive of a machine description."""

    name: Name = "unnamed machine"
    description: FreeText = ""
    drive: str = "groove_cam"


@dataclass(frozen=True)
class PairInfo:
    """A clearance pair of a drive: its name, kind, what it joins, and the geometric limit of its size.

    Attributes
    ----------
    name : str
        The pair's name, e.g. "A".
    kind : str
        "pin-in-bore", "roller-in-groove" or "roller-in-slot".
    joins : str
        What it joins, in words.
    limit : callable
        ``limit(machine) -> (largest size in m, what the limit is)``.
    wall_radius : callable, optional
        Roller pairs: ``wall_radius(machine)`` -> the wall's radius of curvature (m).
    """

    name: str
    kind: str
    joins: str
    limit: Callable[[Any], tuple[float, str]]  # machine -> (largest size in m, what the limit is)
    wall_radius: Callable[[Any], float] | None = None  # roller pairs: machine -> wall curvature radius (m)


class MachineBase(StrictModel):
    """Sections every drive's machine description has.  Subclasses add the drive's own sections and set
    ``DRIVE`` (the drive's registry name) and ``PAIRS`` (its clearance pairs)."""

    DRIVE: ClassVar[str] = ""
    PAIRS: ClassVar[tuple[PairInfo, ...]] = ()
    LEGACY_KINDS: ClassVar[dict[str, str]] = {}  # pair name -> kind, for 0.1.0 files ("point-line")
    DEFAULT_LEVELS_MM: ClassVar[dict[str, tuple[float, float, float]]] = {}  # where a pair gives no levels

    machine: MachineInfo = MachineInfo()
    four_bar: FourBar
    combs: Combs
    clearance: dict[str, ClearancePair]
    plant: PlantSpec | None = None
    operation: OperationSpec = OperationSpec()
    harvest: HarvestSpec = HarvestSpec()
    driveline: MachineDriveline | None = None  # powered drive (docs/driveline.md); None: imposed speed

    @model_validator(mode="before")
    @classmethod
    def _legacy_and_pairs(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            return data
        data = dict(data)
        cl = data.get("clearance")
        if isinstance(cl, dict):
            cl = {k: dict(v) if isinstance(v, dict) else v for k, v in cl.items()}
            for name, pair in cl.items():
                if isinstance(pair, dict):
                    kind = pair.get("kind")
                    if kind == "revolute":  # berryshaker 0.1.0
                        pair["kind"] = "pin-in-bore"
                    elif kind == "point-line":  # berryshaker 0.1.0
                        if name not in cls.LEGACY_KINDS:
                            raise ValueError(f"clearance.{name}.kind = 'point-line' (0.1.0): rename to one of "
                                             f"{', '.join(PAIR_KINDS)}")
                        pair["kind"] = cls.LEGACY_KINDS[name]
            names = [p.name for p in cls.PAIRS]
            unknown = [k for k in cl if k not in names]
            missing = [k for k in names if k not in cl]
            if unknown:
                raise ValueError(f"unknown clearance pair(s) {', '.join(unknown)} for the {cls.DRIVE} drive; "
                                 f"its pairs are {', '.join(names)}")
            if missing:
                raise ValueError(f"clearance pair(s) {', '.join(missing)} missing: the {cls.DRIVE} drive has "
                                 f"pairs {', '.join(names)} (each needs a [clearance.<name>] table)")
            data["clearance"] = {k: cl[k] for k in names}
        return data

    @model_validator(mode="after")
    def _pair_sizes(self) -> "MachineBase":
        for p in self.PAIRS:
            pair = self.clearance[p.name]
            if pair.kind != p.kind:
                raise ValueError(f"clearance.{p.name}.kind must be {p.kind!r} ({p.joins}), got {pair.kind!r}")
            lim, what = p.limit(self)
            d = pair.geometry().diameter
            if pair.kind == "pin-in-bore" and MAX_CLEARANCE_FRACTION * d < lim:
                # a pin's clearance is a fraction of the pin: beyond it the joint is no joint (12 mm radial on a
                # 20 mm pin, which 10 % of a 120 mm arm allows, is a pin loose in a hole twice its size); a roller's
                # free travel is bounded by its drive's limit (20 % of the roller radius)
                lim = MAX_CLEARANCE_FRACTION * d
                what = (f"{MAX_CLEARANCE_FRACTION:.0%} of the {d * 1e3:g} mm pin diameter"
                        + ("" if pair.diameter is not None else " (assumed; give diameter = \"20 mm\")"))
            if pair.size > lim:
                raise ValueError(f"clearance.{p.name}.size = {pair.size * 1e3:g} mm is larger than the geometry "
                                 f"allows ({what} = {lim * 1e3:g} mm)")
        return self

    @model_validator(mode="after")
    def _harvest_population(self) -> "MachineBase":
        h = self.harvest  # checked here so that every drive's description refuses it the same way
        if not h.branch_classes or any(not c > 0 for c in h.branch_classes):
            raise ValueError(f"harvest.branch_classes must list at least one diameter scale > 0, e.g. "
                             f"[0.85, 1.0, 1.15]; got {list(h.branch_classes)}")
        if h.seed < 0:
            raise ValueError(f"harvest.seed must be a whole number >= 0, got {h.seed}")
        if not 0.0 <= h.fruit_zone[0] < h.fruit_zone[1] <= 1.0:
            raise ValueError(f"harvest.fruit_zone must be two fractions of the branch length, start < end, both in "
                             f"0 .. 1; got {list(h.fruit_zone)}")
        return self

    @model_validator(mode="after")
    def _pair_contacts(self) -> "MachineBase":
        for p in self.PAIRS:
            if self.clearance[p.name].size > 0:
                try:
                    self.pair_contact(p.name)
                except ConfigError as exc:
                    raise ValueError(f"clearance.{p.name}: {exc}") from None
        return self

    def pair_contact(self, name: str):
        """The resolved contact law of clearance pair ``name`` at its size
        (:class:`~berryshaker.contact.pair_law.PairContact`: law, K, n, damping, with provenance tags).

        What the multibody mechanism and the reduced model run with and ``berryshaker config show`` prints.

        Parameters
        ----------
        name : str
            The pair's name.

        Returns
        -------
        PairContact
            The law, K (N/m^n), n, damping and their provenance.
        """
        info = next(p for p in self.PAIRS if p.name == name)
        wall = info.wall_radius(self) if info.wall_radius is not None else math.inf
        tags = getattr(self, "__provenance__", None) or {}
        own = {k.rsplit(".", 1)[1]: v for k, v in tags.items() if k.startswith(f"clearance.{name}.")}
        return self.clearance[name].contact(wall, own, f"clearance.{name}")

    # ---- clearances: the one owner of their validation ------------------------------------------
    @property
    def pair_names(self) -> tuple[str, ...]:
        """Names of the drive's clearance pairs, in transmission order."""
        return tuple(p.name for p in self.PAIRS)

    def clearance_sizes(self) -> dict[str, float]:
        """Clearance size (m) per pair.

        Returns
        -------
        dict pair -> float
            The sizes (m): radial for a pin in a bore, free travel for a roller.
        """
        return {p: self.clearance[p].size for p in self.pair_names}

    def clearance_levels(self) -> dict[str, tuple[float, float, float]]:
        """Test levels 1/2/3 (m) per pair: ``[clearance.<pair>] levels`` or the drive's defaults.

        Returns
        -------
        dict pair -> (float, float, float)
            The three levels of each pair (m).
        """
        out = {}
        for p in self.pair_names:
            lv = self.clearance[p].levels
            if lv is None:
                if p not in self.DEFAULT_LEVELS_MM:
                    raise ConfigError(f"clearance.{p}.levels is not set and the {self.DRIVE} drive has no default "
                                      "levels; give three sizes, e.g. levels = [\"0.1 mm\", \"0.2 mm\", \"0.3 mm\"]")
                lv = tuple(v * 1e-3 for v in self.DEFAULT_LEVELS_MM[p])
            out[p] = tuple(float(v) for v in lv)
        return out

    def with_clearances(self, sizes: dict[str, float] | None) -> "MachineBase":
        """A validated copy with the clearance sizes (m) replaced for the named pairs.

        Every clearance a run uses passes through here (or through loading the description): unknown pairs,
        negative or non-finite sizes, sizes outside a description's bounds (0, or 1 um .. 100 m:
        :data:`berryshaker.units.LIMITS`) and sizes the geometry cannot hold are refused with the pair named.

        Parameters
        ----------
        sizes : dict pair -> float, optional
            New sizes (m); None or empty gives the machine itself.

        Returns
        -------
        MachineBase
            The validated copy.
        """
        if not sizes:
            return self
        data = self.model_dump()
        for pair, size in sizes.items():
            if pair not in self.pair_names:
                raise ConfigError(f"unknown clearance pair {pair!r}; the {self.DRIVE} drive's pairs are "
                                  f"{', '.join(self.pair_names)}")
            if isinstance(size, bool) or not isinstance(size, (int, float)) or not math.isfinite(size) or size < 0:
                raise ConfigError(f"clearance {pair}: size must be a finite length >= 0, got {size!r}")
            check_limits(float(size), "length", f"clearance {pair}")  # 0, or 1 um .. 100 m, as in a machine file
            data["clearance"][pair]["size"] = float(size)
        from pydantic import ValidationError

        from berryshaker.quantity_fields import format_validation_error

        try:
            machine = type(self).model_validate(data)
        except ValidationError as err:
            raise ConfigError(format_validation_error(err, "(clearance override)")) from None
        tags = getattr(self, "__provenance__", None)
        if tags:
            object.__setattr__(machine, "__provenance__", dict(tags))
        return machine

    # ---- geometry every drive provides ------------------------------------------------------------
    @property
    def shaft_D(self) -> tuple[float, float]:  # pragma: no cover - abstract
        """Frame coordinates of the left comb shaft D (m)."""
        raise NotImplementedError

    @property
    def shaft_E(self) -> tuple[float, float]:
        """Frame coordinates of the right comb shaft E (m): D and E on a horizontal line (theta_DE = 0)."""
        xd, yd = self.shaft_D
        return (xd + self.four_bar.ground_DE, yd)

    @property
    def drive_speed(self) -> float:  # pragma: no cover - abstract
        """Drive-shaft speed (rad/s)."""
        raise NotImplementedError

    @property
    def drive_inertia(self) -> float:  # pragma: no cover - abstract
        """Moment of inertia of the driven shaft (kg m^2)."""
        raise NotImplementedError


@dataclass(frozen=True)
class Drive:
    """A comb drive plug-in (see the module docstring for what each member does).

    Attributes
    ----------
    name : str
        Registry name, e.g. "groove_cam".
    title : str
        Name in words.
    machine_class : type
        Its description class (a :class:`MachineBase` subclass).
    reference_package : str
        The package holding its ``reference.toml``.
    check : callable
        ``check(machine)``: kinematics over one revolution, raising ``GeometryError`` where it cannot run.
    kinematics_summary : callable
        ``kinematics_summary(machine, kin)``: the JSON of ``berryshaker kinematics``.
    mechanism : callable
        ``mechanism(machine, revolutions)``: the multibody mechanism description.
    mid_stroke_angles : callable
        ``mid_stroke_angles(machine)``: the combs' reference angles (rad).
    reduced_model : callable, optional
        ``reduced_model(machine, clearance, revolutions, start_angle=0.0)``, or None.
    reduced_model_name : str
        Name of the reduced model ("mlsd").
    driver : str
        The member the drive shaft turns and the drive moment acts on, in words ("cam", "crank"): the label of the
        drive moment in tables and figures.
    """

    name: str
    title: str
    machine_class: type
    reference_package: str  # package holding reference.toml
    check: Callable[..., Any]
    kinematics_summary: Callable[..., dict]
    mechanism: Callable[..., Any]
    mid_stroke_angles: Callable[..., tuple[float, float]]
    reduced_model: Callable[..., Any] | None = None
    reduced_model_name: str = ""
    driver: str = "drive shaft"

    @property
    def pairs(self) -> tuple[PairInfo, ...]:
        """The drive's clearance pairs."""
        return self.machine_class.PAIRS

    def reference_toml_text(self) -> str:
        """Text of the drive's annotated reference machine.

        Returns
        -------
        str
            The ``reference.toml`` text.
        """
        from importlib import resources

        return resources.files(self.reference_package).joinpath("reference.toml").read_text("utf-8")
