"""The typed-results base (berryshaker.records): JSON form in field order, optional keys left out when None,
read back with validation."""

from __future__ import annotations

from dataclasses import dataclass, field

import pydantic
import pytest

from berryshaker.records import JsonRecord, field_names, optional, to_json


@dataclass(frozen=True)
class _Peak(JsonRecord):
    peak: float
    rms: float


@dataclass(frozen=True)
class _Row(JsonRecord):
    clearance_mm: dict[str, float]
    force_N: dict[str, _Peak]
    count: int
    note: str | None
    series: list | None = optional()
    tags: list[str] = field(default_factory=list)


def _row(**kw):
    return _Row(**{"clearance_mm": {"B": 0.2, "A": 0.1}, "force_N": {"A": _Peak(3.0, 1.5)}, "count": 3,
                   "note": None, **kw})


def test_json_form_keeps_the_field_order_and_leaves_out_an_optional_none():
    r = _row()
    assert r.to_json() == {"clearance_mm": {"B": 0.2, "A": 0.1}, "force_N": {"A": {"peak": 3.0, "rms": 1.5}},
                           "count": 3, "note": None, "tags": []}
    assert list(r.to_json()) == ["clearance_mm", "force_N", "count", "note", "tags"]
    assert list(r.to_json()["clearance_mm"]) == ["B", "A"]  # a map keyed by data keeps its order
    assert "series" in _row(series=[1, 2]).to_json()
    assert field_names(_Row) == ("clearance_mm", "force_N", "count", "note", "series", "tags")


def test_read_back_builds_the_nested_records_and_round_trips():
    r = _row(series=[0.5, 1.0], tags=["x"])
    back = _Row.from_json(r.to_json())
    assert back == r and isinstance(back.force_N["A"], _Peak)
    assert to_json([r, (1, 2)]) == [r.to_json(), [1, 2]]


def test_read_back_refuses_an_unknown_key_a_missing_field_and_a_wrong_type():
    good = _row().to_json()
    with pytest.raises(pydantic.ValidationError, match="colour"):
        _Row.from_json({**good, "colour": "red"})
    with pytest.raises(pydantic.ValidationError, match="count"):
        _Row.from_json({k: v for k, v in good.items() if k != "count"})
    with pytest.raises(pydantic.ValidationError, match="peak"):
        _Row.from_json({**good, "force_N": {"A": {"peak": "high", "rms": 1.0}}})


def test_records_are_frozen():
    with pytest.raises(AttributeError):
        _row().count = 4
