"""The plant section of a machine description: branch (study eq. 13-15), fruit (eq. 16-17) and the comb-branch
contact.  Values SI; strings with units accepted (see :mod:`berryshaker.quantity_fields`)."""

from __future__ import annotations

from typing import Annotated

from pydantic import BeforeValidator, Field, model_validator

from berryshaker.quantity_fields import Length, LengthNonNeg, StrictModel as _Strict, _d, _q


class BranchSpec(_Strict):
    """Tapered round branch (study eq. 13-15)."""

    root_diameter: Length  # d0
    tip_diameter: Length  # dm
    length: Length  # l
    elastic_modulus: Annotated[float, _q("pressure"), Field(gt=0, json_schema_extra=_d("GPa"))]
    density: Annotated[float, _q("density"), Field(gt=0, json_schema_extra=_d("kg/m^3"))]
    damping_ratio: Annotated[float, _q("dimensionless"), Field(ge=0, lt=1, json_schema_extra=_d("1"))] = 0.07

    @model_validator(mode="after")
    def _check(self) -> "BranchSpec":
        if self.tip_diameter > self.root_diameter:
            raise ValueError(f"tip_diameter {self.tip_diameter * 1e3:g} mm is larger than root_diameter "
                             f"{self.root_diameter * 1e3:g} mm")
        return self


class FruitSpec(_Strict):
    mass: Annotated[float, _q("mass"), Field(gt=0, json_schema_extra=_d("g"))]  # m0
    positions: tuple[float, ...] = (0.2, 0.5, 0.85)  # fractions of the branch length
    names: tuple[str, ...] = ("root", "middle", "end")

    @model_validator(mode="after")
    def _check(self) -> "FruitSpec":
        for f in self.positions:
            if not 0.0 <= f <= 1.0:
                raise ValueError(f"fruit position {f} is outside the branch (fractions of its length, 0 .. 1)")
        if len(self.names) != len(self.positions):
            raise ValueError("fruit.names and fruit.positions must have the same length")
        return self


class CombContactSpec(_Strict):
    """Comb fingers striking the branch (ADAMS IMPACT function, nylon on wood)."""

    stiffness: Annotated[float, BeforeValidator(lambda v: float(v)), Field(gt=0)] = 3.0e4  # N/m^1.5
    exponent: float = Field(1.5, gt=0)
    damping: Annotated[float, _q("damping"), Field(ge=0, json_schema_extra=_d("N*s/m"))] = 7.8  # cmax
    penetration_depth: Length = 1e-4  # d of IMPACT: full damping reached [STUDY.md]
    station_left: float = Field(0.7, gt=0, le=1)  # z_l / l, where the left comb meets the branch
    station_right: float = Field(0.7, gt=0, le=1)  # z_r / l
    finger_radius: Length = 0.45  # distance from the comb shaft to the striking finger section (m)
    engagement: LengthNonNeg = 0.0  # finger overlap with the branch surface at mid-stroke (m)
    span: Length = 0.8  # length of the comb along the row (m): the plant is struck while inside it
    n_modes: int = Field(8, ge=1, le=30)


class PlantSpec(_Strict):
    branch: BranchSpec
    fruit: FruitSpec
    contact: CombContactSpec = CombContactSpec()
