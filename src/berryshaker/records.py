"""Typed results that travel: a result read far from where it is made (a study step's data, read by the report,
the tables, the claims and ``summary.json``) is a frozen dataclass deriving :class:`JsonRecord`, not a dict read by
key.  Its readers use attributes, so a misspelt or missing field fails where it is read; its JSON form
(:meth:`JsonRecord.to_json`) has one key per field, in the order the fields are declared, and is read back with
validation (:meth:`JsonRecord.from_json`, through pydantic: an unknown key or a value of the wrong type is an
error naming the field).

A field declared with :func:`optional` is left out of the JSON when it is None (a key the result has only
sometimes).  Maps keyed by data (per clearance pair, per response, per row) stay ``dict`` fields: their keys are
the user's names, not the record's.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from functools import cache
from typing import Any, Mapping, TypeVar

from pydantic import ConfigDict

R = TypeVar("R", bound="JsonRecord")

_OMIT_NONE = "omit_when_none"


def optional(default: Any = None) -> Any:
    """A record field left out of the JSON form when it is None (a key its result has only sometimes).

    Parameters
    ----------
    default : object
        The field's default (None).

    Returns
    -------
    dataclasses.Field
        The field, for a dataclass declaration.
    """
    return field(default=default, metadata={_OMIT_NONE: True})


def to_json(value: Any) -> Any:
    """The JSON form of a value: records as dicts (fields in declaration order), tuples as lists, maps and lists
    element by element; anything else as it is (numbers, strings, None, NumPy arrays for figure data).

    Parameters
    ----------
    value : object
        A record, a dict, a list or tuple, or a plain value.

    Returns
    -------
    object
        The same data with every record converted; nothing is copied that need not be.
    """
    if isinstance(value, JsonRecord):
        out = {}
        for f in fields(value):
            v = getattr(value, f.name)
            if v is None and f.metadata.get(_OMIT_NONE):
                continue
            out[f.name] = to_json(v)
        return out
    if isinstance(value, dict):
        return {k: to_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_json(v) for v in value]
    return value


@cache
def _adapter(cls: type):
    from pydantic import TypeAdapter

    return TypeAdapter(cls)


@dataclass(frozen=True)
class JsonRecord:
    """Base of the typed results: :meth:`to_json` writes one, :meth:`from_json` reads one back."""

    #: read back strictly as to keys: a key that is not a field is an error, not dropped
    __pydantic_config__ = ConfigDict(extra="forbid")

    def to_json(self) -> dict:
        """The record as a JSON-able dict (:func:`to_json`).

        Returns
        -------
        dict
            One key per field, in declaration order; an :func:`optional` field that is None is left out.
        """
        return to_json(self)

    @classmethod
    def from_json(cls: type[R], data: Mapping) -> R:
        """The record read back from its JSON form (e.g. a result of ``summary.json``), validated.

        Parameters
        ----------
        data : mapping
            The JSON form (:meth:`to_json`), e.g. parsed from a file.

        Returns
        -------
        JsonRecord
            The record, nested records included.

        Raises
        ------
        pydantic.ValidationError
            A key that is not a field, a missing required field, or a value of the wrong type; the message
            names the field.

        Notes
        -----
        Strict JSON has no NaN: a non-finite number is written as null (:func:`berryshaker.outputs.strict_json_text`),
        and a null read back where the field is a plain ``float`` is NaN again.
        """
        return _adapter(cls).validate_python(_nan_for_null(cls, dict(data)))


@cache
def _hints(cls: type) -> dict[str, Any]:
    import typing

    try:
        return typing.get_type_hints(cls)
    except Exception:  # noqa: BLE001 - a hint that does not resolve here: that record's nulls stay None
        return {}


def _nan_for_null(annotation: Any, value: Any) -> Any:
    """``value`` with every None that sits where ``annotation`` wants a plain ``float`` (not an optional one) made
    NaN: the strict JSON writer's null for a non-finite number, read back."""
    import dataclasses
    import math
    import types
    import typing

    if value is None:
        return math.nan if annotation is float else None
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _nan_for_null(typing.get_args(annotation)[0], value)
    if isinstance(annotation, type) and dataclasses.is_dataclass(annotation) and isinstance(value, dict):
        hints = _hints(annotation)
        return {k: _nan_for_null(hints.get(k, Any), v) for k, v in value.items()}
    args = typing.get_args(annotation)
    if origin in (dict, Mapping) and isinstance(value, dict) and len(args) == 2:
        return {k: _nan_for_null(args[1], v) for k, v in value.items()}
    if origin in (list, tuple) and isinstance(value, (list, tuple)) and args:
        if origin is tuple and not (len(args) == 2 and args[1] is Ellipsis):
            return [_nan_for_null(a, v) for a, v in zip(args, value)] + list(value[len(args):])
        return [_nan_for_null(args[0], v) for v in value]
    if origin in (typing.Union, types.UnionType):  # X | None keeps its None (above); a record inside is walked
        records = [a for a in args if isinstance(a, type) and dataclasses.is_dataclass(a)]
        if len(records) == 1 and isinstance(value, dict):
            return _nan_for_null(records[0], value)
    return value


def field_names(record_type: type) -> tuple[str, ...]:
    """The JSON keys a record type writes, in order (:func:`optional` ones included).

    Parameters
    ----------
    record_type : type
        A :class:`JsonRecord` subclass.

    Returns
    -------
    tuple of str
        Its field names.
    """
    return tuple(f.name for f in fields(record_type))


def fields_of(record: JsonRecord) -> dict[str, Any]:
    """A record's fields by name, shallow (nested records stay records): to make a record of a subclass that adds
    fields (``Sub(**fields_of(rec), extra=...)``).

    Parameters
    ----------
    record : JsonRecord
        The record.

    Returns
    -------
    dict
        Field name -> value, in declaration order (None-valued :func:`optional` fields included).
    """
    return {f.name: getattr(record, f.name) for f in fields(record)}


__all__ = ["JsonRecord", "optional", "to_json", "field_names", "fields_of"]
