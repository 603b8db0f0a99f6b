"""Clearance levels and the rows of the study's Table 5 as reconstructed in STUDY.md section 4.

Levels 1/2/3 (mm): A 0.25/0.50/0.75, B 0.2/0.4/0.6, C 0.10/0.15/0.20, F 0.10/0.15/0.20.
Row 1: no clearance.  Rows 2-13: one pair at level 1, 2, 3 (A: rows 2-4, B: 5-7, C: 8-10, F: 11-13),
the others zero.  Rows 14-16: all pairs at level 1, 2, 3.  The study's model check (Table 3): level 2.
"""

from __future__ import annotations

import re

from berryshaker.config import PAIR_NAMES
from berryshaker.errors import ConfigError
from berryshaker.units import parse_quantity

CLEARANCE_LEVELS_MM: dict[str, tuple[float, float, float]] = {
    "A": (0.25, 0.50, 0.75),
    "B": (0.20, 0.40, 0.60),
    "C": (0.10, 0.15, 0.20),
    "F": (0.10, 0.15, 0.20),
}


def clearance_row(row: int) -> dict[str, float]:
    """Clearance sizes (m) of row 1..16 of the reconstructed Table 5."""
    if row == 1:
        return {p: 0.0 for p in PAIR_NAMES}
    if 2 <= row <= 13:
        pair = PAIR_NAMES[(row - 2) // 3]
        level = (row - 2) % 3
        out = {p: 0.0 for p in PAIR_NAMES}
        out[pair] = CLEARANCE_LEVELS_MM[pair][level] * 1e-3
        return out
    if 14 <= row <= 16:
        return {p: CLEARANCE_LEVELS_MM[p][row - 14] * 1e-3 for p in PAIR_NAMES}
    raise ConfigError(f"row{row}: the reconstructed Table 5 has rows 1 to 16")


def parse_clearance_spec(spec: str | None) -> dict[str, float]:
    """Parse ``A=0.25mm,B=0.2mm,C=0.1mm,F=0.2mm``, ``row5``, ``level2`` or ``none`` into sizes (m).

    Plain numbers without a unit are refused (a clearance of "0.25" is ambiguous between m and mm).
    """
    if spec is None or not spec.strip():
        return {}
    text = spec.strip()
    m = re.fullmatch(r"row\s*(\d+)", text, re.IGNORECASE)
    if m:
        return clearance_row(int(m.group(1)))
    m = re.fullmatch(r"level\s*([123])", text, re.IGNORECASE)
    if m:
        return {p: CLEARANCE_LEVELS_MM[p][int(m.group(1)) - 1] * 1e-3 for p in PAIR_NAMES}
    if text.lower() in ("none", "zero", "ideal"):
        return {p: 0.0 for p in PAIR_NAMES}
    out: dict[str, float] = {}
    for part in text.split(","):
        if not part.strip():
            continue
        if "=" not in part:
            raise ConfigError(f"--clearance: {part.strip()!r} is not PAIR=VALUE (e.g. A=0.25mm)")
        name, value = (s.strip() for s in part.split("=", 1))
        name = name.upper()
        if name not in PAIR_NAMES:
            raise ConfigError(f"--clearance: unknown pair {name!r}; the pairs are A, B, C, F")
        if re.fullmatch(r"[-+]?[\d.]+(e[-+]?\d+)?", value, re.IGNORECASE):
            raise ConfigError(f"--clearance: {name}={value} needs a unit, e.g. {name}={value}mm")
        size = parse_quantity(value, "length", f"clearance {name}")
        if size < 0:
            raise ConfigError(f"--clearance: {name} = {value} is negative; a clearance must be >= 0")
        out[name] = size
    return out
