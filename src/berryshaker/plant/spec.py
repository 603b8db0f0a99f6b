"""The plant section of a machine description: branch (study eq. 13-15), fruit (eq. 16-17) and the comb-branch
contact.  Values SI inside; a machine file gives every dimensional value with its unit
(:mod:`berryshaker.quantity_fields`)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BeforeValidator, Field, ValidationInfo, model_validator

from berryshaker.quantity_fields import Length, LengthNonNeg, describe_value, display_unit, quantity_validator
from berryshaker.quantity_fields import StrictModel as _Strict


class BranchSpec(_Strict):
    """Tapered round branch (study eq. 13-15)."""

    root_diameter: Length  # d0
    tip_diameter: Length  # dm
    length: Length  # l
    elastic_modulus: Annotated[float, quantity_validator("pressure", "GPa"), Field(gt=0, json_schema_extra=display_unit("GPa"))]
    density: Annotated[float, quantity_validator("density"), Field(gt=0, json_schema_extra=display_unit("kg/m^3"))]
    damping_ratio: Annotated[float, quantity_validator("dimensionless"), Field(ge=0, lt=1, json_schema_extra=display_unit("1"))] = 0.07

    @model_validator(mode="after")
    def _check(self) -> "BranchSpec":
        if self.tip_diameter > self.root_diameter:
            raise ValueError(f"tip_diameter {self.tip_diameter * 1e3:g} mm is larger than root_diameter "
                             f"{self.root_diameter * 1e3:g} mm")
        return self


class PedicelSpec(_Strict):
    """The fruit's stem as a spring-damper between branch and berry (berryshaker.plant.pedicel).

    Defaults [assumed, by analogy]: no blueberry fruit-stem frequency is known to us; the nearest
    measured system of the same fruit size, the coffee fruit-stem, has 7.1-8.6 N/m, 0.025-0.029 N s/m,
    11.6-13.3 Hz, damping ratio about 0.1 (Villibor et al. 2016, Acta Scientiarum Technology 38(1)).
    k = 10 N/m and c = 0.027 N s/m give 11.9 Hz and 0.10 for a 1.8 g berry.  ``coupling = "two_way"``
    puts the named fruit into the branch's modal model (their mass loads the thin end of the branch:
    berryshaker.plant.pedicel.modal_mass_ratio); ``rigid = true`` restores the study's eq. 16.
    """

    stiffness: Annotated[float, quantity_validator("stiffness"), Field(gt=0, json_schema_extra=display_unit("N/m"))] = 10.0
    damping: Annotated[float, quantity_validator("damping"), Field(ge=0, json_schema_extra=display_unit("N*s/m"))] = 0.027
    include_weight: bool = True  # the stem also carries m0 g along the branch axis (upright branch)
    coupling: Literal["two_way", "one_way"] = "two_way"  # named fruit inside the modal model, or post-processed
    rigid: bool = False


class FruitSpec(_Strict):
    """Fruit on the branch: mass m0, positions (fractions of the length) and names (study eq. 16-17)."""
    mass: Annotated[float, quantity_validator("mass", "g"), Field(gt=0, json_schema_extra=display_unit("g"))]  # m0
    pedicel: PedicelSpec = PedicelSpec()
    positions: tuple[float, ...] = Field((0.2, 0.5, 0.85), max_length=20)  # fractions of the branch length
    names: tuple[str, ...] = Field(("root", "middle", "end"), max_length=20)

    @model_validator(mode="after")
    def _check(self) -> "FruitSpec":
        for f in self.positions:
            if not 0.0 <= f <= 1.0:
                raise ValueError(f"fruit position {f} is outside the branch (fractions of its length, 0 .. 1)")
        if len(self.names) != len(self.positions):
            raise ValueError("fruit.names and fruit.positions must have the same length")
        return self


class FingerSpec(_Strict):
    """A nylon comb finger: a round cantilever rod struck at ``free_length`` from its clamp
    (berryshaker.plant.finger).  Geometry [assumed]; PA6 modulus 2.5 GPa [assumed: dry-as-moulded PA6/PA66
    2-3 GPa in manufacturers' data sheets, lower when moisture-conditioned]."""

    diameter: Length = 0.012
    free_length: Length = 0.2  # clamp to the striking section (m)
    elastic_modulus: Annotated[float, quantity_validator("pressure", "GPa"), Field(gt=0, json_schema_extra=display_unit("GPa"))] = 2.5e9
    poisson_ratio: float = Field(0.39, ge=0, lt=0.5)
    wood_transverse_modulus: Annotated[float, quantity_validator("pressure", "GPa"), Field(gt=0, json_schema_extra=display_unit("GPa"))] = 1.0e8
    wood_poisson_ratio: float = Field(0.3, ge=0, lt=0.5)
    reference_force: Annotated[float, quantity_validator("force"), Field(gt=0, json_schema_extra=display_unit("N"))] = 5.0  # Hertz linearised


class CombContactSpec(_Strict):
    """Comb fingers striking the branch (ADAMS IMPACT function, nylon on wood).

    ``stiffness`` (N/m^exponent, a plain SI number: no unit is written for it) given explicitly wins (backwards
    compatible, exponent default 1.5);
    left out, the contact is linear (exponent 1) with K = the finger cantilever in series with the
    linearised Hertz contact (berryshaker.plant.finger.finger_contact)."""

    # K in N/m^exponent: a plain SI number (its unit depends on the exponent, which need not be whole)
    stiffness: Annotated[float, Field(gt=0, le=1e15)] | None = None
    exponent: Annotated[float, Field(gt=0, le=3)] | None = None
    finger: FingerSpec = FingerSpec()
    damping: Annotated[float, quantity_validator("damping"), Field(ge=0, json_schema_extra=display_unit("N*s/m"))] = 7.8  # cmax
    penetration_depth: Length = 1e-4  # d of IMPACT: full damping reached [assumed; docs/study.md sec. 6]
    station_left: float = Field(0.7, gt=0, le=1)  # z_l / l, where the left comb meets the branch
    station_right: float = Field(0.7, gt=0, le=1)  # z_r / l
    finger_radius: Length = 0.45  # distance from the comb shaft to the striking finger section (m)
    engagement: LengthNonNeg = 0.0  # finger overlap with the branch surface at mid-stroke (m)
    span: Length = 0.8  # length of the comb along the row (m): the plant is struck while inside it
    @model_validator(mode="after")
    def _check_law(self) -> "CombContactSpec":
        if self.stiffness is None and self.exponent not in (None, 1.0):
            raise ValueError(f"exponent {self.exponent} given without stiffness: the finger-derived contact is "
                             "linear (exponent 1); give both stiffness and exponent, or neither")
        return self

    # branch modes (two-way fruit add one mode each); 8: the smallest converged count (tests/harvest/test_coupled.py)
    n_modes: int = Field(8, ge=1, le=64)

    def impact_stiffness(self, branch_diameter: float | None = None) -> tuple[float, float]:
        """(K, exponent) of the IMPACT law: the explicit ``stiffness`` if given, else the finger's.

        Parameters
        ----------
        branch_diameter : float, optional
            Branch diameter at the struck station (m), for the finger's Hertz contact; default 8 mm.

        Returns
        -------
        (K, exponent) : tuple of float
            F = K delta^exponent: K in N/m^exponent, the exponent dimensionless (1 for the finger's series
            stiffness).
        """
        if self.stiffness is not None:
            return float(self.stiffness), float(1.5 if self.exponent is None else self.exponent)
        from berryshaker.plant.finger import finger_contact

        k = finger_contact(self.finger, branch_diameter or 0.008)["series_stiffness_N_m"]
        return k, 1.0


def _range(kind: str):
    """A (low, high) pair of quantities of one dimension, low <= high."""
    from berryshaker.quantity_fields import read_quantity

    def convert(v, info: ValidationInfo):
        if not isinstance(v, (list, tuple)) or len(v) != 2:
            raise ValueError(f"expected a range [low, high] of {kind} values, got {describe_value(v)}")
        lo, hi = (read_quantity(c, kind, info) for c in v)
        if lo > hi:
            raise ValueError(f"range [{lo:g}, {hi:g}] (SI) has low > high")
        return (float(lo), float(hi))

    return BeforeValidator(convert)


LengthRange = Annotated[tuple[float, float], _range("length"), Field(json_schema_extra=display_unit("mm"))]
AngleRange = Annotated[tuple[float, float], _range("angle"), Field(json_schema_extra=display_unit("deg"))]


class BushSpec(_Strict):
    """The bush the combs engage: a seeded population of branches (berryshaker.plant.bush).

    Every value is [assumed] unless marked: the study gives the bush as 1.5-1.7 m tall [study] ('Bluecrop',
    7 years) and 1.6-1.9 m in the literature it cites (docs/study.md sec. 7); no cane count, diameter or
    lean distribution is published for it.  Diameters span the reference branch (12 mm) by a third either
    way; lengths stay below the bush height; ``finger_height`` puts the reference branch's contact at
    0.7 of its 1.2 m length.  ``branches`` and ``n_modes`` come from the convergence check in
    tests/plant/test_bush.py (docs/plant.md, "The bush is the load").

    ``branches`` is the bush's physical count of branches the fingers engage; ``members`` of them are
    sampled and simulated, each standing for branches / members like branches in the comb's load (its
    reaction is weighted by that), so the load converges with ``members`` while the bush keeps its size.
    The instrumented fruit branch is one of the bush's branches, represented in the load by the sample: it
    is driven by the combs without acting back (a probe), so its own modal model cannot change the combs'
    motion.
    """

    branches: int = Field(12, ge=1, le=200)  # engaged branches per bush, as harvest.branches_per_bush [assumed]
    members: int = Field(6, ge=0, le=64)  # simulated sample of the other branches (convergence: tests/plant/test_bush.py)
    seed: int = Field(12, ge=0, le=2**32 - 1)
    n_modes: int = Field(2, ge=1, le=16)  # bending modes per member (the fruit branch keeps plant.contact.n_modes)
    root_diameter: LengthRange = (0.008, 0.016)  # d0, uniform (m)
    tip_ratio: float = Field(0.3333, gt=0, le=1)  # dm / d0, as the reference branch (4 / 12 mm)
    length: LengthRange = (0.9, 1.6)  # l, uniform (m); bush 1.5-1.7 m tall [study]
    base_height: LengthRange = (0.0, 0.15)  # where the cane leaves the crown, above the reference base (m)
    lean: AngleRange = (0.0, 0.5236)  # |angle from vertical| in the combs' plane, uniform (rad; 0-30 deg)
    row_spread: LengthNonNeg = 0.3  # branches spread uniformly over this length along the row (m)
    lateral_spread: LengthNonNeg = 0.04  # branch surface within +-this of the finger's mid-stroke position (m)
    finger_height: Length = 0.84  # height of the striking finger section above the reference branch base (m)


class PlantSpec(_Strict):
    """The plant section of a machine description: branch, fruit, the comb-branch contact and the bush."""
    branch: BranchSpec
    fruit: FruitSpec
    contact: CombContactSpec = CombContactSpec()
    bush: BushSpec = BushSpec()
