"""Names in and out of the Python API: the list of names an argument takes (one comma-separated str or a sequence of
str) and a library key's column name with its unit in brackets (``peak_force_N`` -> ``peak_force [N]``)."""

from __future__ import annotations

from collections.abc import Sequence

from berryshaker.errors import ConfigError

#: unit suffixes of the library's JSON keys and CSV columns -> the unit written in brackets
_SUFFIX_UNITS = (
    ("_J_per_rev", "J/rev"), ("_um_per_h", "um/h"), ("_kg_min", "kg/min"), ("_percent", "%"), ("_pct", "%"),
    ("_Nm", "N m"), ("_rpm", "rpm"), ("_deg", "deg"), ("_hz", "Hz"), ("_mm", "mm"), ("_rad", "rad"),
    ("_N", "N"), ("_W", "W"), ("_m", "m"),
)


def _unit_name(key: str) -> str:
    """``collision_force_A_peak_N`` -> ``collision_force_A_peak [N]``, ``ripe_removal_pct_sd`` ->
    ``ripe_removal_sd [%]``; a key without a unit suffix is returned unchanged."""
    sd = key.endswith("_sd")
    base = key[:-3] if sd else key
    for suffix, unit in _SUFFIX_UNITS:
        if base.endswith(suffix) and len(base) > len(suffix):
            return f"{base[: -len(suffix)]}{'_sd' if sd else ''} [{unit}]"
    return key


def _names(value: str | Sequence[str] | None, arg: str) -> list[str]:
    """A comma-separated string or a sequence of names -> list of names."""
    if value is None:
        return []
    if isinstance(value, str):
        return [v.strip() for v in value.split(",") if v.strip()]
    if not all(isinstance(v, str) for v in value):
        raise ConfigError(f"{arg}={value!r}: give names as a list of str or one comma-separated str")
    return [v.strip() for v in value if v.strip()]
