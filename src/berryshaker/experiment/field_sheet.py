"""Field sheets: writing a test plan (CSV + printable HTML) and reading it back with results."""

from __future__ import annotations

import html
import io
import re
from dataclasses import dataclass

import numpy as np
import pandas as pd

from berryshaker import __version__
from berryshaker.errors import ConfigError
from berryshaker.experiment.designs import ARRAYS, assign_factors, orthogonal_array

RAW_COLUMNS = ["duration_s", "picked_mass_kg", "unripe_mass_kg", "damaged_mass_kg"]
INDEX_COLUMNS = ["efficiency_kg_min", "unripe_rate_pct", "damage_rate_pct"]
INDEX_NAMES = {"efficiency": "efficiency_kg_min", "unripe": "unripe_rate_pct", "damage": "damage_rate_pct"}


@dataclass(frozen=True)
class Factor:
    name: str
    levels: tuple[float, ...]  # in ``unit``
    unit: str

    @property
    def column(self) -> str:
        return f"{self.name}_{self.unit}" if self.unit else self.name


def parse_factor(spec: str) -> Factor:
    """``A=0.25,0.5,0.75mm`` -> Factor('A', (0.25, 0.5, 0.75), 'mm').  A unit on the last value applies to all."""
    if "=" not in spec:
        raise ConfigError(f"--factor {spec!r}: expected NAME=v1,v2,v3[unit], e.g. A=0.25,0.5,0.75mm")
    name, values = (s.strip() for s in spec.split("=", 1))
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name):
        raise ConfigError(f"--factor {spec!r}: factor name must be a word (letters, digits, _)")
    parts = [p.strip() for p in values.split(",") if p.strip()]
    m = re.fullmatch(r"([-+]?[\d.]+(?:e[-+]?\d+)?)\s*([A-Za-z/%^*0-9]*)", parts[-1] if parts else "", re.I)
    if not parts or not m:
        raise ConfigError(f"--factor {spec!r}: cannot read the levels")
    unit = m.group(2)
    levels = []
    for p in parts[:-1] + [m.group(1)]:
        try:
            levels.append(float(p))
        except ValueError:
            raise ConfigError(f"--factor {spec!r}: level {p!r} is not a number") from None
    if len(levels) < 2:
        raise ConfigError(f"--factor {spec!r}: a factor needs at least two levels")
    if unit and unit != "%":
        from berryshaker.units import _registry

        try:
            _registry().Unit(unit)
        except Exception:  # noqa: BLE001 - pint raises several types
            raise ConfigError(f"--factor {spec!r}: unknown unit {unit!r}") from None
    if len(set(levels)) != len(levels):
        raise ConfigError(f"--factor {spec!r}: levels must be distinct")
    return Factor(name, tuple(levels), unit)


def plan_table(array: str, factors: list[Factor], randomize: bool = False, seed: int | None = None) -> pd.DataFrame:
    """The field sheet: run, run order, one column per factor (level values with unit), empty responses."""
    a = orthogonal_array(array)
    cols = assign_factors(array, [len(f.levels) for f in factors])
    n = a.shape[0]
    df = pd.DataFrame({"run": np.arange(1, n + 1)})
    if randomize:
        if seed is None:
            raise ConfigError("--randomize needs --seed N (so the order can be reproduced)")
        order = np.random.default_rng(seed).permutation(n) + 1
        df["order"] = order
    else:
        df["order"] = df["run"]
    for f, c in zip(factors, cols):
        df[f"{f.name}_level"] = a[:, c] + 1
        df[f.column] = [f.levels[i] for i in a[:, c]]
    for c in RAW_COLUMNS + INDEX_COLUMNS:
        df[c] = np.nan
    return df


def plan_html(df: pd.DataFrame, title: str) -> str:
    """A printable field sheet (self-contained HTML, rows in run order, blank cells to fill in)."""
    rows = df.sort_values("order")
    head = "".join(f"<th>{html.escape(c)}</th>" for c in rows.columns)
    body = []
    for _, r in rows.iterrows():
        cells = []
        for c in rows.columns:
            v = r[c]
            cells.append("<td></td>" if isinstance(v, float) and np.isnan(v) else f"<td>{html.escape(str(v))}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return (f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title><style>"
            "body{font-family:sans-serif;margin:1.5em}table{border-collapse:collapse}"
            "td,th{border:1px solid #444;padding:6px 10px;min-width:4em;text-align:center}"
            "th{background:#eee}@media print{body{margin:0}}</style></head><body>"
            f"<h2>{html.escape(title)}</h2><p>Run the tests in the <b>order</b> column.  Fill in either the raw "
            "masses and duration or the ready indexes.</p>"
            f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"
            f"<p style='font-size:small'>berryshaker {html.escape(__version__)}</p></body></html>")


@dataclass
class FieldResults:
    table: pd.DataFrame
    factors: list[str]  # factor column names
    factor_names: list[str]
    responses: dict[str, np.ndarray]  # index name -> values per run (in run order)


def read_results(path_or_text, responses: list[str]) -> FieldResults:
    """Read a filled field sheet; compute indexes from raw masses where the index cells are empty.

    Errors name the row (run) and column: non-numeric cells, missing runs, factor columns that do not
    form a balanced design, a response with neither its index nor the raw masses.
    """
    try:
        if isinstance(path_or_text, str) and "\n" in path_or_text:
            df = pd.read_csv(io.StringIO(path_or_text))
        else:
            df = pd.read_csv(path_or_text)
    except FileNotFoundError:
        raise ConfigError(f"results file not found: {path_or_text}") from None
    except Exception as exc:  # pandas parser errors
        raise ConfigError(f"cannot read the results CSV ({exc})") from None
    if "run" not in df.columns:
        raise ConfigError("results CSV: no 'run' column (the field sheet from `berryshaker doe plan` has one)")
    level_cols = [c for c in df.columns if c.endswith("_level")]
    if not level_cols:
        raise ConfigError("results CSV: no factor level columns (<FACTOR>_level) found")
    for c in df.columns:
        if c in ("order",):
            continue
        col = pd.to_numeric(df[c], errors="coerce")
        bad = df[c].notna() & col.isna()
        if bad.any():
            i = int(np.argmax(bad.to_numpy()))
            raise ConfigError(f"results CSV row {i + 2} (run {df['run'].iloc[i]}), column {c!r}: "
                              f"{df[c].iloc[i]!r} is not a number")
        df[c] = col
    runs = df["run"].to_numpy()
    expected = np.arange(1, len(df) + 1)
    if np.any(np.isnan(runs)) or sorted(runs.astype(int)) != list(expected):
        missing = sorted(set(expected) - set(runs[~np.isnan(runs)].astype(int)))
        raise ConfigError(f"results CSV: runs must be numbered 1..{len(df)} once each"
                          + (f"; missing run(s) {missing}" if missing else ""))
    df = df.sort_values("run").reset_index(drop=True)
    names = [c[:-len("_level")] for c in level_cols]
    levels = df[level_cols].to_numpy()
    if np.isnan(levels).any():
        i, j = np.argwhere(np.isnan(levels))[0]
        raise ConfigError(f"results CSV run {i + 1}, column {level_cols[j]!r}: empty level")
    from berryshaker.experiment.designs import is_orthogonal

    if not is_orthogonal(levels.astype(int)):
        raise ConfigError("results CSV: the factor level columns do not form an orthogonal (balanced) design; "
                          "was a row edited or a run duplicated?")
    out = {}
    for r in responses:
        col = INDEX_NAMES.get(r, r)
        vals = df[col].to_numpy(float) if col in df.columns else np.full(len(df), np.nan)
        if np.isnan(vals).any() and all(c in df.columns for c in RAW_COLUMNS):
            raw = compute_indexes(df["duration_s"].to_numpy(float), df["picked_mass_kg"].to_numpy(float),
                                  df["unripe_mass_kg"].to_numpy(float), df["damaged_mass_kg"].to_numpy(float))
            vals = np.where(np.isnan(vals), raw[INDEX_NAMES.get(r, r)], vals)
        if np.isnan(vals).any():
            i = int(np.argmax(np.isnan(vals)))
            raise ConfigError(f"results CSV run {i + 1}: response {r!r} is empty and cannot be computed from "
                              f"{', '.join(RAW_COLUMNS)}")
        out[r] = vals
    return FieldResults(df, level_cols, names, out)


def compute_indexes(duration_s, picked_kg, unripe_kg, damaged_kg) -> dict[str, np.ndarray]:
    """Study's test indexes: picked mass per minute, unripe and damaged mass as % of the picked mass."""
    duration_s = np.asarray(duration_s, float)
    picked = np.asarray(picked_kg, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        return {
            "efficiency_kg_min": picked / (duration_s / 60.0),
            "unripe_rate_pct": 100.0 * np.asarray(unripe_kg, float) / picked,
            "damage_rate_pct": 100.0 * np.asarray(damaged_kg, float) / picked,
        }


__all__ = ["ARRAYS", "Factor", "parse_factor", "plan_table", "plan_html", "read_results", "compute_indexes"]
