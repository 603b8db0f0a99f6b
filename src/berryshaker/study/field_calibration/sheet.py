"""A field sheet as the calibration reads it: its factors mapped to the machine (a clearance pair's size or the
drive speed, :func:`factor_target`), the machine and clearances of one setting (:func:`setting_data`), its runs'
settings and replicate results (:func:`read_sheet`), every level set of its factors (:func:`level_sets`) and a
setting the user names (:func:`parse_setting`)."""

from __future__ import annotations

import itertools
import re
from dataclasses import dataclass, field

import numpy as np

from berryshaker.config import Machine
from berryshaker.errors import ConfigError
from berryshaker.study.field_calibration.priors import calibrated_responses

#: factor names (lower case) read as the drive speed when their unit is an angular speed
DRIVE_SPEED_NAMES = ("speed", "drive_speed", "shaft_speed", "cam_speed", "crank_speed", "rotational_speed", "n")


@dataclass(frozen=True)
class FactorTarget:
    """What a sheet factor sets on the machine.

    Attributes
    ----------
    name : str
        The factor's name in the sheet.
    kind : str
        "clearance" (a clearance pair's size) or "drive_speed".
    pair : str
        The clearance pair ("" for the drive speed).
    unit : str
        The sheet's unit of the factor.
    to_si : float
        SI value of one ``unit`` (m or rad/s).
    levels_si : tuple of float
        The sheet's level values (SI).
    """

    name: str
    kind: str
    pair: str
    unit: str
    to_si: float
    levels_si: tuple[float, ...]


def factor_target(machine: Machine, name: str, unit: str, levels: tuple[float, ...] | None) -> FactorTarget:
    """Map one sheet factor to the machine: a clearance pair's name with a length unit sets that clearance; a
    drive-speed name (:data:`DRIVE_SPEED_NAMES`) with an angular-speed unit (rpm, rad/s) sets the drive speed.

    Parameters
    ----------
    machine : Machine
        The machine description (its clearance pairs).
    name : str
        Factor name.
    unit : str
        Its unit in the sheet.
    levels : tuple of float or None
        Level values in ``unit`` (its units; None: the sheet gives only level numbers).

    Returns
    -------
    FactorTarget
        The mapping with the levels in SI.

    Raises
    ------
    ConfigError
        A name the calibration does not understand, a unit of the wrong kind, or level numbers without values.
    """
    from berryshaker.units import parse_unit, unit_dimension

    pairs = list(machine.pair_names)
    understood = (f"a clearance pair of the machine ({', '.join(pairs)}) with a length unit, e.g. A_mm, or the "
                  f"drive speed ({', '.join(DRIVE_SPEED_NAMES[:3])} ...) with a speed unit, e.g. speed_rpm")
    if levels is None:
        raise ConfigError(f"factor {name!r}: the sheet gives level numbers only; calibrate needs the level values with "
                          f"their unit (a column {name}_mm or '{name} (mm)')")
    dim = unit_dimension(unit) if unit else None
    if name in pairs or name.upper() in pairs and len(name) == 1:
        pair = name if name in pairs else name.upper()
        if dim != "length":
            raise ConfigError(f"factor {name!r} names clearance pair {pair} but its unit is {unit or 'missing'!r}; "
                              "give its levels in a length unit (column {name}_mm)")
        f = parse_unit(unit, "length", f"factor {name}")
        return FactorTarget(name, "clearance", pair, unit, f, tuple(v * f for v in levels))
    if name.lower() in DRIVE_SPEED_NAMES:
        if dim != "angular_speed":
            raise ConfigError(f"factor {name!r} reads as the drive speed but its unit is {unit or 'missing'!r}; give "
                              "its levels in rpm or rad/s (column speed_rpm)")
        f = parse_unit(unit, "angular_speed", f"factor {name}")
        return FactorTarget(name, "drive_speed", "", unit, f, tuple(v * f for v in levels))
    raise ConfigError(f"factor {name!r} is not a setting calibrate can simulate; it understands {understood}. "
                      "Rename the column or leave the factor out of the sheet")


def setting_data(data: dict, machine: Machine, targets: list[FactorTarget], values_si) -> tuple[dict, dict]:
    """The machine (JSON dict) and clearance set (m per pair) of one setting.

    Parameters
    ----------
    data : dict
        The machine as JSON (``model_dump(mode="json")``).
    machine : Machine
        The same machine.
    targets : list of FactorTarget
        The sheet's factors.
    values_si : sequence of float
        One value per factor (SI).

    Returns
    -------
    (dict, dict)
        Machine data (drive speed replaced where a factor sets it) and the clearance sizes (m).
    """
    from berryshaker.harvest.virtual import with_drive_speed

    clearance = dict(machine.clearance_sizes())
    d = data
    for t, v in zip(targets, values_si):
        if t.kind == "clearance":
            clearance[t.pair] = float(v)
        else:
            d = with_drive_speed(d, float(v))
    return d, clearance


@dataclass
class Sheet:
    """A field sheet as the calibration reads it.

    Attributes
    ----------
    targets : list of FactorTarget
        Its factors, mapped to the machine.
    settings_si : numpy.ndarray
        (runs, factors) each run's setting (SI).
    observations : dict of str to numpy.ndarray
        Response -> (runs, replicates) field results (kg/min, %).
    replicates : int
        Replicates per run.
    runs_identified_by : str
        How the runs were told apart.
    level_values : dict
        Factor -> its level values in the sheet's units (None where the sheet gives level numbers only).
    """

    targets: list[FactorTarget]
    settings_si: np.ndarray
    observations: dict[str, np.ndarray]
    replicates: int
    runs_identified_by: str = "run column"
    level_values: dict = field(default_factory=dict)


def _filled_responses(path_or_text, worksheet: str | None = None) -> list[str]:
    """The calibrated responses a sheet has values for (an index column with a number, or the raw masses)."""
    from berryshaker.experiment.field_cells import sheet_table
    from berryshaker.experiment.field_columns import RAW_COLUMNS, index_names

    df = sheet_table(path_or_text, worksheet)
    cols = {c.lower(): c for c in df.columns}
    raw = all(c in df.columns and df[c].notna().any() and (df[c].astype(str).str.strip() != "").any()
              for c in RAW_COLUMNS)
    out = []
    for r in calibrated_responses():
        col = index_names()[r] if index_names()[r] in df.columns else cols.get(r)
        filled = col is not None and df[col].notna().any() and (df[col].astype(str).str.strip() != "").any()
        if filled or raw:
            out.append(r)
    return out


def read_sheet(path_or_text, machine: Machine, worksheet: str | None = None) -> Sheet:
    """Read a field sheet (``doe plan`` layout or a statistics package's worksheet with a replicate or block column)
    for the calibration (:func:`berryshaker.experiment.field_results.read_results`, strict) and map its factors to
    the machine (:func:`factor_target`).

    Parameters
    ----------
    path_or_text : path or str
        The sheet (CSV or .xlsx) or a CSV's text.
    machine : Machine
        The machine description.
    worksheet : str, optional
        The worksheet of an .xlsx workbook (default its first).

    Returns
    -------
    Sheet
        Settings and replicate results.

    Raises
    ------
    ConfigError
        No response filled in, a factor calibrate cannot simulate, a lost plot (the likelihood takes every run's
        replicates), or any error of ``read_results``.
    """
    from berryshaker.experiment.field_results import read_results

    responses = _filled_responses(path_or_text, worksheet)
    if not responses:
        raise ConfigError("the sheet has no field results: fill in efficiency_kg_min, unripe_rate_pct or "
                          "damage_rate_pct (or the raw masses duration_s, picked_mass_kg, unripe_mass_kg, "
                          "damaged_mass_kg) for every run; calibrate needs at least one response")
    fr = read_results(path_or_text, responses, sheet=worksheet)
    for r, cells in fr.lost.items():
        where = ", ".join(f"run {i} replicate {k}" for i, k in cells[:6]) + (" ..." if len(cells) > 6 else "")
        raise ConfigError(f"the sheet lost plots of {r} ({where}); calibrate's likelihood takes every run's "
                          "replicates, the same number for every run: fill them in (`doe analyze` analyses a sheet "
                          "with lost plots)")
    targets = [factor_target(machine, n, fr.units.get(n, ""), fr.level_values.get(n)) for n in fr.factor_names]
    settings = np.column_stack([np.asarray(fr.values[:, j], float) * t.to_si for j, t in enumerate(targets)])
    if fr.responses_replicated is not None:
        obs = {r: np.asarray(v, float) for r, v in fr.responses_replicated.items()}
    else:
        obs = {r: np.asarray(v, float)[:, None] for r, v in fr.responses.items()}
    return Sheet(targets, settings, obs, fr.replicates, fr.runs_identified_by, dict(fr.level_values))


def level_sets(targets: list[FactorTarget]) -> np.ndarray:
    """Every level set of the factors (the full factorial of their levels), SI.

    Parameters
    ----------
    targets : list of FactorTarget
        The factors.

    Returns
    -------
    numpy.ndarray
        (prod of level counts, factors) settings (SI), the first factor slowest.
    """
    return np.array(list(itertools.product(*[t.levels_si for t in targets])), float)


def parse_setting(spec: str, targets: list[FactorTarget], machine: Machine) -> np.ndarray:
    """A setting named by the user, ``A=0.1mm,speed=130rpm`` (unit on every value, read by the strict quantity
    grammar of berryshaker.units, no expression evaluation); a factor not named keeps the described value.

    Parameters
    ----------
    spec : str
        ``NAME=value unit[,NAME=value unit ...]``.
    targets : list of FactorTarget
        The sheet's factors (only they can be named).
    machine : Machine
        The machine description (values of factors not named).

    Returns
    -------
    numpy.ndarray
        (factors,) the setting (SI).

    Raises
    ------
    ConfigError
        Not NAME=value pairs, a name that is not a factor of the sheet, a value without or with a wrong unit, a
        clearance the machine cannot hold (:meth:`~berryshaker.drives.base.MachineBase.with_clearances`) or a speed
        outside the simulated range.
    """
    from berryshaker.quantity_fields import check_drive_speed
    from berryshaker.units import parse_quantity

    if not isinstance(spec, str) or len(spec) > 400 or not spec.strip():
        raise ConfigError(f"--predict {spec!r}: expected NAME=value unit,..., e.g. A=0.1mm,C=0.2mm")
    names = {t.name: i for i, t in enumerate(targets)}
    values = [machine.clearance_sizes()[t.pair] if t.kind == "clearance" else machine.drive_speed for t in targets]
    for part in spec.split(","):
        if "=" not in part:
            raise ConfigError(f"--predict {spec!r}: {part.strip()!r} is not NAME=value unit (e.g. A=0.1mm)")
        name, value = (x.strip() for x in part.split("=", 1))
        if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name) or name not in names:
            raise ConfigError(f"--predict {spec!r}: {name!r} is not a factor of the sheet (factors: "
                              f"{', '.join(names)}); the emulator knows only the settings the sheet varies")
        t = targets[names[name]]
        dim = "length" if t.kind == "clearance" else "angular_speed"
        v = parse_quantity(value, dim, f"--predict {name}", units_required=True)
        if not v > 0:
            raise ConfigError(f"--predict {name}={value}: must be > 0")
        try:  # a setting the machine can run, checked as the description's own values are, before any work
            if t.kind == "clearance":
                machine.with_clearances({t.pair: v})
            else:
                check_drive_speed(v, f"--predict {name}")
        except (ConfigError, ValueError) as exc:
            raise ConfigError(f"--predict {spec!r}: {exc}") from None
        values[names[name]] = v
    return np.array(values, float)
