"""Named clearance sets of a machine: the rows of the study's Table 5 layout, level sets, the L9 runs, and the
``--clearance`` syntax of the command line.

Levels 1/2/3 per pair come from the machine (``[clearance.<pair>] levels``, or the drive's defaults; for the
groove cam the study's levels, :mod:`berryshaker.reference_study`).  Row 1: no clearance.  Rows 2..(1+3P):
one pair at level 1, 2, 3 in pair order, the others zero.  The last three rows: all pairs at level 1, 2, 3.
"""

from __future__ import annotations

import re

from berryshaker.errors import ConfigError
from berryshaker.experiment.designs import orthogonal_array
from berryshaker.units import parse_quantity


def n_rows(machine) -> int:
    """Number of rows of the Table 5 layout for the machine's pairs (16 for four pairs).

    Parameters
    ----------
    machine : MachineBase
        The machine description (its clearance pairs).

    Returns
    -------
    int
        1 (no clearance) + 3 per pair (each alone at its three levels) + 3 (all pairs at each level).
    """
    return 1 + 3 * len(machine.pair_names) + 3


def clearance_row(machine, row: int) -> dict[str, float]:
    """Clearance sizes (m) of row 1..n_rows(machine) of the Table 5 layout.

    Parameters
    ----------
    machine : MachineBase
        The machine description (its pairs and their test levels).
    row : int
        The row, 1 .. :func:`n_rows`.

    Returns
    -------
    dict pair -> float
        Clearance size of each pair (m).
    """
    pairs = machine.pair_names
    levels = machine.clearance_levels()
    last = n_rows(machine)
    if row == 1:
        return {p: 0.0 for p in pairs}
    if 2 <= row <= last - 3:
        pair = pairs[(row - 2) // 3]
        out = {p: 0.0 for p in pairs}
        out[pair] = levels[pair][(row - 2) % 3]
        return out
    if last - 2 <= row <= last:
        return {p: levels[p][row - (last - 2)] for p in pairs}
    raise ConfigError(f"row{row}: the clearance rows of this machine are row1 to row{last}")


def level_set(machine, level: int) -> dict[str, float]:
    """Every pair at test level 1, 2 or 3 (m).

    Parameters
    ----------
    machine : MachineBase
        The machine description (its pairs' test levels).
    level : {1, 2, 3}
        The level.

    Returns
    -------
    dict pair -> float
        Clearance size of each pair (m).
    """
    if level not in (1, 2, 3):
        raise ConfigError(f"level{level}: levels are 1, 2 and 3")
    return {p: v[level - 1] for p, v in machine.clearance_levels().items()}


def l9_runs(machine) -> tuple[list[dict[str, float]], list[dict[str, int]]]:
    """Clearance sets (m) and level codes of the L9 runs over the machine's (up to four) pairs.

    Parameters
    ----------
    machine : MachineBase
        The machine description (its pairs' test levels).

    Returns
    -------
    sets : list of dict pair -> float
        Clearance size of each pair in each of the 9 runs (m).
    codes : list of dict pair -> int
        Level 1, 2 or 3 of each pair in each run.
    """
    pairs = machine.pair_names
    if len(pairs) > 4:
        raise ConfigError("the L9 array takes at most four factors; this drive has more clearance pairs")
    a = orthogonal_array("L9")
    levels = machine.clearance_levels()
    sets = [{p: levels[p][a[i, j]] for j, p in enumerate(pairs)} for i in range(9)]
    codes = [{p: int(a[i, j]) + 1 for j, p in enumerate(pairs)} for i in range(9)]
    return sets, codes


def level_code(levels: dict[str, int]) -> str:
    """``{"A": 1, "B": 1, ...}`` -> ``"A1B1..."``.

    Parameters
    ----------
    levels : dict pair -> int
        Level of each pair.

    Returns
    -------
    str
        The run's code.
    """
    return "".join(f"{p}{v}" for p, v in levels.items())


def parse_clearance_spec(spec: str | None, machine) -> dict[str, float]:
    """Parse ``A=0.25mm,B=0.2mm``, ``row5``, ``level2`` or ``none`` into sizes (m) for the machine's pairs.

    Plain numbers without a unit are refused (a clearance of "0.25" is ambiguous between m and mm); a pair
    named twice is refused.  The sizes are validated against the geometry when they are applied
    (:meth:`~berryshaker.drives.base.MachineBase.with_clearances`).

    Parameters
    ----------
    spec : str or None
        The ``--clearance`` text; None or blank gives no change.
    machine : MachineBase
        The machine description (its pairs and test levels).

    Returns
    -------
    dict pair -> float
        Clearance size of each pair named (m).
    """
    if spec is None or not spec.strip():
        return {}
    text = spec.strip()
    pairs = machine.pair_names
    m = re.fullmatch(r"row\s*(\d+)", text, re.IGNORECASE)
    if m:
        return clearance_row(machine, int(m.group(1)))
    m = re.fullmatch(r"level\s*(\d+)", text, re.IGNORECASE)
    if m:
        return level_set(machine, int(m.group(1)))
    if text.lower() in ("none", "zero", "ideal"):
        return {p: 0.0 for p in pairs}
    lookup = {p.upper(): p for p in pairs}
    out: dict[str, float] = {}
    for part in text.split(","):
        if not part.strip():
            continue
        if "=" not in part:
            raise ConfigError(f"--clearance: {part.strip()!r} is not PAIR=VALUE (e.g. {pairs[0]}=0.25mm)")
        name, value = (s.strip() for s in part.split("=", 1))
        if name.upper() not in lookup:
            raise ConfigError(f"--clearance: unknown pair {name!r}; this machine's pairs are {', '.join(pairs)}")
        name = lookup[name.upper()]
        if name in out:
            raise ConfigError(f"--clearance: pair {name} is given twice; give each pair once")
        if re.fullmatch(r"[-+]?[\d.]+(e[-+]?\d+)?", value, re.IGNORECASE):
            raise ConfigError(f"--clearance: {name}={value} needs a unit, e.g. {name}={value}mm")
        size = parse_quantity(value, "length", f"clearance {name}")
        if size < 0:
            raise ConfigError(f"--clearance: {name} = {value} is negative; a clearance must be >= 0")
        out[name] = size
    return out
