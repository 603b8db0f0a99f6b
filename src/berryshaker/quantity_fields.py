"""Pydantic field types for physical quantities: each accepts a string with a unit (parsed by
:func:`berryshaker.units.parse_quantity`, dimension checked, bounded by :data:`berryshaker.units.LIMITS`) and
stores an SI float; a plain number is SI only inside the package (a user's file is validated with
:data:`UNITS_REQUIRED`, where a bare number is an error showing the fix).  The display unit travels in the
field's schema (``display``) so every view prints engineering units.

Also the strict base model every description section derives from (unknown keys, infinities and NaN refused;
a plain numeric field refuses ``true`` and lists or tables with the field named), the formatter that turns
pydantic's errors into located messages (``cam.stroke: must be > 0 ...``), the lookup of a field's physical
dimension and display unit (:func:`field_dimension`, :func:`field_display_unit`, :func:`field_info_at`: sweeps
read values with them, ``config show`` prints them), the plausibility walk over a description
(:func:`plausibility_warnings`) and the drive-speed limits (:func:`check_drive_speed`); the
types of the names and free text a description holds (:data:`Name`, :data:`FreeText`: bounded, no control
characters, :func:`berryshaker.user_text.check_user_text`).

long module: the field types, the strict base model, the error formatter and the lookups of a field's dimension
and unit all read the same field metadata (:class:`QuantityValidator`, the ``display`` unit).
"""

from __future__ import annotations

import dataclasses
import math
import re
import types
import typing
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, ValidationInfo
from pydantic.fields import FieldInfo

from berryshaker.errors import ConfigError
from berryshaker.units import (
    DISPLAY_UNITS,
    bare_number_message,
    check_limits,
    parse_quantity,
    plausibility_warning,
    unit_dimension,
)
from berryshaker.user_text import MAX_NAME_CHARS, MAX_TEXT_CHARS, check_user_text


@dataclasses.dataclass(frozen=True, slots=True)
class QuantityValidator(BeforeValidator):
    """The before-validator of a quantity field; it also records the field's physical ``dimension``
    (read back by :func:`field_dimension` for plausibility checks and sweep value lists).

    Attributes
    ----------
    func : callable
        The conversion to SI, ``func(value, info) -> float`` (pydantic's before-validator function).
    json_schema_input_type : Any
        The input type shown in the JSON schema (pydantic's; default Any).
    dimension : str
        The field's physical dimension, a key of :data:`berryshaker.units.DIMENSIONS`.
    """

    dimension: str = "dimensionless"


#: validation-context key: the values come from a user's file (a bare number in a dimensional field is an
#: error, :func:`berryshaker.units.parse_quantity` ``units_required``); descriptions rebuilt inside the package
#: from their SI dump are validated without it
UNITS_REQUIRED = "units_required"


def units_required(info: ValidationInfo | None) -> bool:
    """True when the validation context says the values are a user's (see :data:`UNITS_REQUIRED`).

    Parameters
    ----------
    info : ValidationInfo or None
        pydantic's validation info (its ``context``).

    Returns
    -------
    bool
        Whether a bare number in a dimensional field is an error.
    """
    ctx = getattr(info, "context", None)
    return bool(isinstance(ctx, dict) and ctx.get(UNITS_REQUIRED))


def read_quantity(v: Any, dimension: str, info: ValidationInfo | None = None, display: str | None = None) -> float:
    """One quantity of a description field: parsed strictly, bounded by :data:`berryshaker.units.LIMITS`
    (a user's value both ways, :func:`units_required`; one computed inside the package from above only).

    Parameters
    ----------
    v : Any
        The value: a number (SI) or a text with its unit ("80 mm").
    dimension : str
        Its physical dimension, a key of :data:`berryshaker.units.DIMENSIONS`.
    info : ValidationInfo, optional
        pydantic's validation info (field name, context).
    display : str, optional
        The unit a bare number's error message suggests, e.g. "mm".

    Returns
    -------
    float
        The value in SI units of its dimension.

    Raises
    ------
    ValueError
        For pydantic to locate (the field's dotted key is put in front of the message).
    """
    key = (getattr(info, "field_name", None) or "value") if info is not None else "value"
    user = units_required(info)
    if user and display and isinstance(v, (int, float)) and not isinstance(v, bool) and v != 0 and math.isfinite(v):
        raise ValueError(bare_number_message(v, dimension, key, display))  # the field's own unit in the fix
    try:
        return check_limits(parse_quantity(v, dimension, key, units_required=user), dimension, key, lower=user)
    except ConfigError as exc:
        # pydantic turns ValueError into a located validation error; drop our prefix (the key is in front)
        raise ValueError(str(exc).removeprefix(f"{key}: ")) from None


def quantity_validator(dimension: str, display: str | None = None) -> QuantityValidator:
    """The validator of a quantity field of ``dimension`` (the ``Annotated`` metadata of a field type).

    Parameters
    ----------
    dimension : str
        The field's dimension (a name of :data:`berryshaker.units.DIMENSIONS`, e.g. ``"length"``).
    display : str, optional
        The unit the fix of a bare number suggests (default :data:`berryshaker.units.DISPLAY_UNITS`), e.g.
        ``"m/min"`` for a walking speed.

    Returns
    -------
    QuantityValidator
        A pydantic before-validator reading a value with its unit to SI (:func:`read_quantity`).
    """

    def convert(v: Any, info: ValidationInfo) -> float:
        return read_quantity(v, dimension, info, display)

    return QuantityValidator(convert, dimension=dimension)


def display_unit(unit: str) -> dict:
    """The JSON-schema extra of a quantity field: the unit it is shown in (``config show``, ``config init``).

    Parameters
    ----------
    unit : str
        The display unit, e.g. ``"mm"``.

    Returns
    -------
    dict
        ``{"display": unit}``.
    """
    return {"display": unit}


Length = Annotated[float, quantity_validator("length"), Field(gt=0, json_schema_extra=display_unit("mm"))]
SignedLength = Annotated[float, quantity_validator("length"), Field(json_schema_extra=display_unit("mm"))]  # a coordinate
LengthNonNeg = Annotated[float, quantity_validator("length"), Field(ge=0, json_schema_extra=display_unit("mm"))]
Angle = Annotated[float, quantity_validator("angle"), Field(json_schema_extra=display_unit("deg"))]
PositiveAngle = Annotated[float, quantity_validator("angle"), Field(gt=0, json_schema_extra=display_unit("deg"))]
NonNegAngle = Annotated[float, quantity_validator("angle"), Field(ge=0, json_schema_extra=display_unit("deg"))]
AngularSpeed = Annotated[float, quantity_validator("angular_speed"), Field(gt=0, json_schema_extra=display_unit("rpm"))]
Mass = Annotated[float, quantity_validator("mass"), Field(gt=0, json_schema_extra=display_unit("kg"))]
Inertia = Annotated[float, quantity_validator("inertia"), Field(gt=0, json_schema_extra=display_unit("kg*m^2"))]
Force = Annotated[float, quantity_validator("force"), Field(gt=0, json_schema_extra=display_unit("kN"))]
Stiffness = Annotated[float, quantity_validator("stiffness"), Field(gt=0, json_schema_extra=display_unit("N/m"))]
Damping = Annotated[float, quantity_validator("damping"), Field(ge=0, json_schema_extra=display_unit("N*s/m"))]
TorsionalStiffness = Annotated[float, quantity_validator("torsional_stiffness"), Field(ge=0, json_schema_extra=display_unit("N*m/rad"))]
TorsionalDamping = Annotated[float, quantity_validator("torsional_damping"), Field(ge=0, json_schema_extra=display_unit("N*m*s/rad"))]
#: a friction coefficient: 0 .. 2 (dry rubber on rough steel stays below ~1.5; above 2 is a slip of the number)
Coefficient = Annotated[float, quantity_validator("dimensionless"), Field(ge=0, le=2, json_schema_extra=display_unit("1"))]



# ---- names and free text a description holds: bounded, no control characters ------------------------------
def _user_text(max_chars: int, lines: bool) -> AfterValidator:
    def check(v: str, info: ValidationInfo) -> str:
        key = (getattr(info, "field_name", None) or "value") if info is not None else "value"
        try:
            return check_user_text(v, key, max_chars, lines=lines)
        except ConfigError as exc:  # pydantic puts the field's dotted key in front
            raise ValueError(str(exc).removeprefix(f"{key}: ")) from None

    return AfterValidator(check)


#: a name in a description (machine, body, joint, force): at most MAX_NAME_CHARS characters, no control characters
Name = Annotated[str, _user_text(MAX_NAME_CHARS, lines=False)]
#: free text in a description (a description): at most MAX_TEXT_CHARS characters, line feeds and tabs allowed
FreeText = Annotated[str, _user_text(MAX_TEXT_CHARS, lines=True)]

# ---- plain numeric fields: no booleans, no lists or tables where one number belongs ----------------------
_NUMBER_TYPES = (int, float)


def _strip(annotation: Any) -> tuple[Any, list[Any]]:
    """(core type, metadata) of an annotation, looking through ``Annotated``."""
    meta: list[Any] = []
    while typing.get_origin(annotation) is Annotated:
        args = typing.get_args(annotation)
        annotation, meta = args[0], meta + list(args[1:])
    return annotation, meta


def _union_members(annotation: Any) -> tuple[list[Any], bool]:
    """Members of a union annotation without ``None``, and whether ``None`` was one of them."""
    origin = typing.get_origin(annotation)
    if origin is typing.Union or origin is types.UnionType:
        members = [a for a in typing.get_args(annotation) if a is not type(None)]
        return members, len(members) < len(typing.get_args(annotation))
    return [annotation], False


def _is_number_type(annotation: Any) -> bool:
    core, _ = _strip(annotation)
    if core in _NUMBER_TYPES:
        return True
    if typing.get_origin(core) is Literal:
        return all(isinstance(a, _NUMBER_TYPES) and not isinstance(a, bool) for a in typing.get_args(core))
    return False


def _number_shape(annotation: Any) -> tuple[str, bool] | None:
    """("scalar" | "sequence", None allowed) for a field that holds a number or a sequence of numbers."""
    core, _ = _strip(annotation)
    members, optional = _union_members(core)
    if len(members) != 1:
        return None
    member, _ = _strip(members[0])
    if _is_number_type(member):
        return "scalar", optional
    if typing.get_origin(member) in (tuple, list):
        args = [a for a in typing.get_args(member) if a is not Ellipsis]
        if args and all(_is_number_type(a) for a in args):
            return "sequence", optional
    return None


def describe_value(v: Any) -> str:
    """A value as an error message names it: a short repr with its type ("a table", "a list" for containers).

    Parameters
    ----------
    v : Any
        The value read from the user's file or command line.

    Returns
    -------
    str
        E.g. ``"'12' (str)"``, ``"true (a boolean)"``, ``"a table"``.
    """
    if isinstance(v, bool):
        return f"{str(v).lower()} (a boolean)"
    if isinstance(v, dict):
        return "a table"
    if isinstance(v, (list, tuple)):
        return "a list"
    text = repr(v)
    return f"{text if len(text) <= 40 else text[:37] + '...'} ({type(v).__name__})"


def _check_number(v: Any, where: str = "") -> None:
    if isinstance(v, bool) or not isinstance(v, (int, float, str)):
        raise ValueError(f"{where}got {describe_value(v)}; expected a number")


@dataclasses.dataclass(frozen=True, slots=True)
class _NumberScreen(BeforeValidator):
    """Runs before any other validator of a plain numeric field: a TOML ``true`` is not 1.0, a list or a
    table is not a number (pydantic's lax mode would coerce the first and crash a ``float(v)`` on the
    second)."""

    shape: str = "scalar"


def _number_screen(shape: str, optional: bool) -> _NumberScreen:
    def screen(v: Any) -> Any:
        if v is None and optional:
            return v
        if shape == "scalar":
            _check_number(v)
        elif isinstance(v, (list, tuple)):
            for i, item in enumerate(v):
                _check_number(item, f"item {i + 1}: ")
        elif isinstance(v, bool) or isinstance(v, (int, float, dict)):
            raise ValueError(f"got {describe_value(v)}; expected a list of numbers, e.g. [0.85, 1.0, 1.15]")
        return v

    return _NumberScreen(screen, shape=shape)


class StrictModel(BaseModel):
    """Base of every description section: unknown keys are errors, values are frozen, infinities and NaN are
    refused in every float field, and a plain numeric field (``float``, ``int``, a ``Literal`` of numbers or a
    tuple of them) refuses booleans, lists and tables with the field named."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    @classmethod
    def __pydantic_init_subclass__(cls, **kwargs: Any) -> None:
        super().__pydantic_init_subclass__(**kwargs)
        changed = False
        for info in cls.model_fields.values():
            if any(isinstance(m, (_NumberScreen, QuantityValidator)) for m in info.metadata):
                continue  # screened already, or a quantity (parse_quantity refuses bools and lists itself)
            shape = _number_shape(info.annotation)
            if shape is not None:
                info.metadata.append(_number_screen(*shape))  # the last before-validator runs first
                changed = True
        if changed:
            cls.model_rebuild(force=True)


def _located(loc: str, msg: str) -> str:
    # a model-level validator's message that already starts with its dotted key ("clearance.A.size = ...",
    # "cam.speed = ..."): print it once, without the section's location in front
    m = re.match(r"^([A-Za-z_]\w*(?:\.\w+)+)\b", msg)
    if m and (loc == "(top level)" or m.group(1).startswith(loc + ".")):
        return msg
    return f"{loc}: {msg}"


#: longest line of a validation message: a longer one (a 100 kB value echoed by a validator) keeps its start
#: (the field) and its end (the fix) around "..."
MAX_MESSAGE_LINE = 400


def _clip(line: str, limit: int = MAX_MESSAGE_LINE) -> str:
    if len(line) <= limit:
        return line
    head = limit * 3 // 5
    return f"{line[:head]} ... {line[-(limit - head - 5):]}"


def format_validation_error(err: ValidationError, source: str) -> str:
    """pydantic's errors as one message, a line per error, each starting with the dotted key of the field
    (``cam.stroke: must be > 0 ...``); each line at most :data:`MAX_MESSAGE_LINE` characters, at most 20 lines.

    Parameters
    ----------
    err : pydantic.ValidationError
        The errors of one validation.
    source : str
        Where the description came from (a file name), named in the message.

    Returns
    -------
    str
        The message.
    """
    lines = []
    for e in err.errors():
        loc = ".".join(str(p) for p in e["loc"]) or "(top level)"
        msg = e["msg"].removeprefix("Value error, ")
        ctx = e.get("ctx") or {}
        typ = e["type"]
        if typ == "missing":
            msg = "missing value"
        elif typ == "extra_forbidden":
            msg = "unknown key (check the spelling against `berryshaker config show`)"
        elif typ in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
            op = {"greater_than": ">", "greater_than_equal": ">=", "less_than": "<", "less_than_equal": "<="}[typ]
            limit = ctx.get({"greater_than": "gt", "greater_than_equal": "ge", "less_than": "lt",
                             "less_than_equal": "le"}[typ])
            msg = f"must be {op} {limit} (SI), got {e.get('input')!r}"
        elif typ == "finite_number":
            msg = f"must be a finite number, got {e.get('input')!r}"
        elif typ.endswith("_parsing") or typ.endswith("_type") or typ == "int_from_float":
            msg = f"{msg}, got {describe_value(e.get('input'))}"
        lines.append(_clip(_located(loc, msg)))
    if len(lines) > 20:
        lines = lines[:20] + [f"... and {len(lines) - 20} more"]
    return f"invalid machine description {_clip(source, 200)}:\n  " + "\n  ".join(lines)


# ---- the physical dimension of a field, and plausibility -----------------------------------------------
def field_dimension(info: FieldInfo) -> str | None:
    """Physical dimension of a description field (a key of :data:`berryshaker.units.DIMENSIONS`).

    A quantity field (declared with one of the types above) carries it; a plain float with a ``display``
    unit in its schema gets the dimension of that unit; a plain number without one is ``"dimensionless"``;
    anything else (lists, text, flags, sections) is None.

    Parameters
    ----------
    info : pydantic.fields.FieldInfo
        The field.

    Returns
    -------
    str or None
        Its dimension.
    """
    for m in info.metadata:
        if isinstance(m, QuantityValidator):
            return m.dimension
    extra = info.json_schema_extra if isinstance(info.json_schema_extra, dict) else {}
    for arg in typing.get_args(info.annotation):  # an optional quantity: ``Length | None``
        for m in getattr(arg, "__metadata__", ()):
            if isinstance(m, QuantityValidator):
                return m.dimension
            if not extra and isinstance(m, FieldInfo) and isinstance(m.json_schema_extra, dict):
                extra = m.json_schema_extra
    unit = extra.get("display")
    if isinstance(unit, str) and unit_dimension(unit) is not None:
        return unit_dimension(unit)
    shape = _number_shape(info.annotation)
    if shape is not None and shape[0] == "scalar":
        return "dimensionless"
    return None


def _display_in(annotation: Any) -> str | None:
    """The ``display`` unit in an annotation's metadata, or in that of its members (``Length | None``, a tuple of
    lengths)."""
    for m in getattr(annotation, "__metadata__", ()):
        extra = m.json_schema_extra if isinstance(m, FieldInfo) else None
        if isinstance(extra, dict) and isinstance(extra.get("display"), str):
            return extra["display"]
    for arg in typing.get_args(annotation):
        unit = _display_in(arg)
        if unit is not None:
            return unit
    return None


def field_display_unit(info: FieldInfo) -> str | None:
    """The engineering unit a description field is shown in (``"mm"`` for a length, ``"deg"`` for an angle...):
    its ``display`` unit, also that of an optional quantity or of the elements of a tuple of quantities, else the
    engineering unit of its dimension.

    Parameters
    ----------
    info : pydantic.fields.FieldInfo
        The field.

    Returns
    -------
    str or None
        The unit, ``"1"`` for a dimensionless number, None for text, flags and sections.
    """
    extra = info.json_schema_extra if isinstance(info.json_schema_extra, dict) else {}
    unit = extra.get("display") if isinstance(extra.get("display"), str) else _display_in(info.annotation)
    if unit is not None:
        return unit
    return DISPLAY_UNITS.get(field_dimension(info))


def _section_class(annotation: Any) -> tuple[type[BaseModel] | None, bool]:
    """The model class of a section annotation and whether it is a table of them (``dict[str, Model]``)."""
    core, _ = _strip(annotation)
    members, _ = _union_members(core)
    for m in members:
        m, _ = _strip(m)
        if isinstance(m, type) and issubclass(m, BaseModel):
            return m, False
        if typing.get_origin(m) is dict:
            args = typing.get_args(m)
            if len(args) == 2 and isinstance(args[1], type) and issubclass(args[1], BaseModel):
                return args[1], True
    return None, False


def field_info_at(model_class: type[BaseModel], key: str) -> FieldInfo:
    """The pydantic field of a dotted key of a description class (``clearance.A.size``, ``cam.speed``).

    Parameters
    ----------
    model_class : type of pydantic.BaseModel
        The description class, e.g. the groove-cam machine's.
    key : str
        The dotted key.

    Returns
    -------
    pydantic.fields.FieldInfo
        The field.

    Raises
    ------
    ConfigError
        A part of the key is not a field (the known fields at that level are listed).
    """
    cls: type[BaseModel] | None = model_class
    parts = key.split(".")
    i = 0
    while i < len(parts):
        name = parts[i]
        if cls is None or name not in cls.model_fields:
            known = ", ".join(cls.model_fields) if cls is not None else "(none)"
            where = ".".join(parts[:i]) or "the machine description"
            raise ConfigError(f"unknown parameter {key!r}: {where} has no {name!r} (its keys: {known})")
        info = cls.model_fields[name]
        if i == len(parts) - 1:
            return info
        sub, is_table = _section_class(info.annotation)
        if sub is None:
            raise ConfigError(f"unknown parameter {key!r}: {'.'.join(parts[:i + 1])} is a value, not a section")
        i += 2 if is_table else 1  # a table of sections: the next part is its entry name (clearance.A.size)
        cls = sub
        if is_table and i > len(parts) - 1:
            raise ConfigError(f"unknown parameter {key!r}: name a value inside {'.'.join(parts[:i])}")
    raise ConfigError(f"unknown parameter {key!r}")  # pragma: no cover - loop always returns


def plausibility_warnings(model: BaseModel, prefix: str = "") -> list[str]:
    """Warnings for every quantity of a description whose value lies orders of magnitude outside
    engineering ranges (:func:`berryshaker.units.plausibility_warning`, e.g. a length in metres written
    for millimetres), walking the nested sections; one message per field, naming its dotted key.

    Parameters
    ----------
    model : pydantic.BaseModel
        A validated description or one of its sections.
    prefix : str
        Dotted key of ``model`` in the whole description ("" at the top, "cam." for a section).

    Returns
    -------
    list of str
        The warnings.
    """
    out: list[str] = []
    for name, info in type(model).model_fields.items():
        value = getattr(model, name)
        key = f"{prefix}{name}"
        if isinstance(value, BaseModel):
            out += plausibility_warnings(value, key + ".")
            continue
        if isinstance(value, dict):
            for k, v in value.items():
                if isinstance(v, BaseModel):
                    out += plausibility_warnings(v, f"{key}.{k}.")
            continue
        dim = field_dimension(info)
        if dim is None or dim == "dimensionless":
            continue  # plain numbers (exponents, fractions, counts) have no engineering scale to check
        values = value if isinstance(value, tuple) else (value,)
        for j, v in enumerate(values):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                continue
            w = plausibility_warning(float(v), dim, key if len(values) == 1 else f"{key}[{j + 1}]")
            if w:
                out.append(w)
    return out


#: drive-shaft speeds a machine description may have (rpm).  Outside, a run cannot be simulated within the
#: engines' budgets: below 1 rpm three revolutions take over 3 min of simulated time (> 1.8 million output
#: samples at the 0.1 ms output step), above 100 000 rpm a revolution is shorter than a few integrator steps.
DRIVE_SPEED_RANGE_RPM = (1.0, 1.0e5)


def check_drive_speed(speed: float, field: str) -> None:
    """Refuse a drive-shaft speed (rad/s) outside :data:`DRIVE_SPEED_RANGE_RPM`.

    Parameters
    ----------
    speed : float
        The speed (rad/s).
    field : str
        Its dotted key, named in the message.

    Raises
    ------
    ValueError
        With the field, the speed in rpm and the accepted range (pydantic locates it).
    """
    rpm = speed * 60.0 / (2.0 * math.pi)
    lo, hi = DRIVE_SPEED_RANGE_RPM
    if not lo <= rpm <= hi:
        raise ValueError(f"{field} = {rpm:.4g} rpm is outside the speeds berryshaker can simulate "
                         f"({lo:g} .. {hi:g} rpm); check the number and its unit (e.g. '120 rpm', '2 Hz')")
