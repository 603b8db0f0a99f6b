"""Pydantic field types for physical quantities: each accepts a plain SI number or a string with a unit
(parsed by :func:`berryshaker.units.parse_quantity`, dimension checked) and stores an SI float; the display
unit travels in the field's schema (``display``) so every view prints engineering units.

Also the strict base model every description section derives from, and the formatter that turns pydantic's
errors into located messages (``cam.stroke: must be > 0 ...``).
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError

from berryshaker.errors import ConfigError
from berryshaker.units import parse_quantity


def _q(dimension: str):
    def convert(v: Any) -> float:
        try:
            return parse_quantity(v, dimension)
        except ConfigError as exc:
            # pydantic turns ValueError into a located validation error; drop our generic prefix
            raise ValueError(str(exc).removeprefix("value: ")) from None

    return BeforeValidator(convert)


def _d(unit: str) -> dict:
    return {"display": unit}


Length = Annotated[float, _q("length"), Field(gt=0, json_schema_extra=_d("mm"))]
LengthNonNeg = Annotated[float, _q("length"), Field(ge=0, json_schema_extra=_d("mm"))]
Angle = Annotated[float, _q("angle"), Field(json_schema_extra=_d("deg"))]
PositiveAngle = Annotated[float, _q("angle"), Field(gt=0, json_schema_extra=_d("deg"))]
NonNegAngle = Annotated[float, _q("angle"), Field(ge=0, json_schema_extra=_d("deg"))]
AngularSpeed = Annotated[float, _q("angular_speed"), Field(gt=0, json_schema_extra=_d("rpm"))]
Mass = Annotated[float, _q("mass"), Field(gt=0, json_schema_extra=_d("kg"))]
Inertia = Annotated[float, _q("inertia"), Field(gt=0, json_schema_extra=_d("kg*m^2"))]
Stiffness = Annotated[float, _q("stiffness"), Field(gt=0, json_schema_extra=_d("N/m"))]
Damping = Annotated[float, _q("damping"), Field(ge=0, json_schema_extra=_d("N*s/m"))]
TorsionalStiffness = Annotated[float, _q("torsional_stiffness"), Field(ge=0, json_schema_extra=_d("N*m/rad"))]
TorsionalDamping = Annotated[float, _q("torsional_damping"), Field(ge=0, json_schema_extra=_d("N*m*s/rad"))]
Coefficient = Annotated[float, _q("dimensionless"), Field(ge=0, json_schema_extra=_d("1"))]


class StrictModel(BaseModel):
    """Base of every description section: unknown keys are errors, values are frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True)



def format_validation_error(err: ValidationError, source: str) -> str:
    lines = []
    for e in err.errors():
        loc = ".".join(str(p) for p in e["loc"]) or "(top level)"
        msg = e["msg"].removeprefix("Value error, ")
        if e["type"] == "missing":
            msg = "missing value"
        elif e["type"] == "extra_forbidden":
            msg = "unknown key (check the spelling against `berryshaker config show`)"
        elif e["type"] in ("greater_than", "greater_than_equal"):
            limit = e.get("ctx", {}).get("gt", e.get("ctx", {}).get("ge"))
            msg = f"must be {'>' if e['type'] == 'greater_than' else '>='} {limit} (SI), got {e.get('input')!r}"
        lines.append(f"{loc}: {msg}")
    return f"invalid machine description {source}:\n  " + "\n  ".join(lines)
