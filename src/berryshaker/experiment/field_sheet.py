"""Field sheets: writing a test plan (CSV + printable HTML) and reading it back with results.

Reading a filled sheet back (strict: issue "never compute on a misread input") lives in
:mod:`berryshaker.experiment.field_results` (:func:`read_results`, re-exported here); the columns and records both
share are in :mod:`berryshaker.experiment.field_columns`.  Units (of a
``--factor``, of a sheet's ``A_mm`` column, in a cell) are read by the one strict quantity grammar of
:mod:`berryshaker.units`, never by pint's expression evaluator.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pandas as pd

from berryshaker import __version__
from berryshaker.errors import ConfigError
from berryshaker.experiment.designs import ARRAYS, assign_factors, orthogonal_array
from berryshaker.experiment.field_columns import (
    MAX_ROWS,
    META_COLUMNS,
    RAW_COLUMNS,
    Factor,
    FieldResults,
    compute_indexes,
    index_columns,
    reserved_columns,
)
from berryshaker.experiment.field_results import read_results
from berryshaker.units import MAX_LIST_CHARS, unit_dimension
from berryshaker.user_text import html_text


def _short(text: str, limit: int = 60) -> str:
    text = repr(text)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def parse_factor(spec: str) -> Factor:
    """``A=0.25,0.5,0.75mm`` -> Factor('A', (0.25, 0.5, 0.75), 'mm').  A unit on the last value applies to all.

    The unit is read by the strict quantity grammar (:func:`berryshaker.units.unit_dimension`): a unit name with
    small whole powers, never an expression (``mm*1000``, ``9**9**9`` are refused at once).

    Parameters
    ----------
    spec : str
        ``NAME=v1,v2,...[unit]``.

    Returns
    -------
    Factor
        The factor, its levels in the unit given.

    Raises
    ------
    ConfigError
        Not ``NAME=v1,v2,...[unit]``, fewer than two or repeated levels, a level that is not a finite number, a
        unit that is not one, or a name whose columns are reserved.
    """
    if not isinstance(spec, str) or len(spec) > MAX_LIST_CHARS:
        raise ConfigError(f"--factor {_short(spec)}: too long (at most {MAX_LIST_CHARS} characters); expected "
                          "NAME=v1,v2,v3[unit], e.g. A=0.25,0.5,0.75mm")
    if "=" not in spec:
        raise ConfigError(f"--factor {_short(spec)}: expected NAME=v1,v2,v3[unit], e.g. A=0.25,0.5,0.75mm")
    name, values = (s.strip() for s in spec.split("=", 1))
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name):
        raise ConfigError(f"--factor {_short(spec)}: factor name must be a word (letters, digits, _)")
    parts = [p.strip() for p in values.split(",") if p.strip()]
    m = re.fullmatch(r"([-+]?[\d.]+(?:e[-+]?\d+)?)\s*([A-Za-z/%^*0-9]*)", parts[-1] if parts else "", re.I)
    if not parts or not m:
        raise ConfigError(f"--factor {_short(spec)}: cannot read the levels")
    unit = m.group(2)
    levels = []
    for p in parts[:-1] + [m.group(1)]:
        try:
            levels.append(float(p))
        except ValueError:
            raise ConfigError(f"--factor {_short(spec)}: level {_short(p)} is not a number") from None
    if len(levels) < 2:
        raise ConfigError(f"--factor {_short(spec)}: a factor needs at least two levels")
    if not all(math.isfinite(v) for v in levels):
        raise ConfigError(f"--factor {_short(spec)}: levels must be finite numbers")
    if unit and unit != "%" and unit_dimension(unit) is None:  # the strict grammar: no expression evaluation
        raise ConfigError(f"--factor {_short(spec)}: {_short(unit)} is not a unit berryshaker reads (a unit name "
                          f"with powers such as 'mm', 'rpm', 'm/s^2'; no arithmetic)")
    if len(set(levels)) != len(levels):
        raise ConfigError(f"--factor {_short(spec)}: levels must be distinct")
    f = Factor(name, tuple(levels), unit)
    _check_factor_name(f)
    return f


def _check_factor_name(f: Factor) -> None:
    reserved = reserved_columns()
    for col in (f.name, f.column, f"{f.name}_level"):
        if col in reserved:
            raise ConfigError(f"factor {f.name!r}: its column {col!r} is a reserved field-sheet column (run, order, "
                              "responses, raw masses, notes); rename the factor, e.g. "
                              f"{f.name + '_x'!r}")


def plan_table(array: str, factors: list[Factor], randomize: bool = False, seed: int | None = None,
               replicates: int = 1) -> pd.DataFrame:
    """The field sheet: run, replicate, test order, one column per factor (level values with unit), empty
    responses.

    Columns: ``run`` (the design's run number), ``replicate`` (1 .. ``replicates``: each run is tested that
    many times, so the analysis can judge the effects against the replicate spread, the pure error),
    ``order`` (the order to test the row in), per factor ``<name>_level`` (1-based level number) and
    ``<name>_<unit>`` (level value), then the raw measurements and the ready indexes, left empty.  Rows are
    runs x replicates, sorted by run and replicate; ``plan_html`` prints them in the ``order`` column's
    order.  The test order is replicate by replicate (every run once, then again): replicate k is block k of the
    analysis (``doe analyze``: a field day or a row of bushes shared by every run), so each block is tested whole
    before the next.  With ``randomize`` the runs are in a random order within each block, a new one per block,
    drawn from ``numpy.random.default_rng(seed)`` (randomised complete blocks, Montgomery 2013 sec. 4.1; with one
    replicate the order is the one earlier versions drew).

    Parameters
    ----------
    array : str
        Orthogonal array: L4, L8, L9, L16, L18 or L27.
    factors : list of Factor
        The factors, assigned to the array's columns in order.
    randomize : bool
        Draw a random test order (needs ``seed``).
    seed : int, optional
        Seed of the random order.
    replicates : int
        Times each run is tested.

    Returns
    -------
    pandas.DataFrame
        One row per run and replicate.
    """
    names = [f.name for f in factors]
    if len(set(names)) != len(names):
        raise ConfigError("factor names must be distinct")
    for f in factors:
        _check_factor_name(f)
    if isinstance(replicates, bool) or not isinstance(replicates, (int, np.integer)) or replicates < 1:
        raise ConfigError(f"replicates={replicates!r}: give the number of times each run is tested, an integer "
                          ">= 1 (>= 2 for an analysis against the replicate spread)")
    a = orthogonal_array(array)
    cols = assign_factors(array, [len(f.levels) for f in factors])
    n, r = a.shape[0], int(replicates)
    run = np.repeat(np.arange(1, n + 1), r)
    rep = np.tile(np.arange(1, r + 1), n)
    df = pd.DataFrame({"run": run, "replicate": rep})
    if randomize:
        if seed is None:
            raise ConfigError("--randomize needs --seed N (so the order can be reproduced)")
        rng = np.random.default_rng(seed)
        # within each replicate block: block k's runs are tests (k - 1) n + 1 .. k n in a random order of their own
        # (with one replicate the order earlier versions drew)
        perm = np.concatenate([rng.permutation(n) + 1 + k * n for k in range(r)])
        df["order"] = perm[(rep - 1) * n + run - 1]
    else:
        df["order"] = (rep - 1) * n + run
    rows = run - 1
    for f, c in zip(factors, cols):
        df[f"{f.name}_level"] = a[rows, c] + 1
        df[f.column] = [f.levels[i] for i in a[rows, c]]
    for name in RAW_COLUMNS + index_columns():
        df[name] = np.nan
    return df


# ------------------------------------------------------------------------------------------ printing
_LABELS = {
    "order": "order", "run": "run", "replicate": "repli-<br>cate",
    "duration_s": "duration<br>s", "picked_mass_kg": "picked mass<br>kg", "unripe_mass_kg": "unripe mass<br>kg",
    "damaged_mass_kg": "damaged mass<br>kg", "efficiency_kg_min": "efficiency<br>kg/min",
    "unripe_rate_pct": "unripe rate<br>%", "damage_rate_pct": "damage rate<br>%",
}


def _cell_text(v) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return ""
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return str(int(v)) if float(v).is_integer() else f"{float(v):.6g}"
    return str(v)


def plan_html(df: pd.DataFrame, title: str) -> str:
    """A printable field sheet (self-contained HTML).

    Rows are sorted in the order to run them (the ``order`` column; the design's run number is kept in
    ``run``).  Run, order and level numbers print as integers, level values with up to six significant
    digits.  The page is set up for landscape printing on A4 or Letter (``@page {size: landscape}``; the
    printer's paper size is kept), the table is fixed-width with narrow design columns and wide, wrapping
    columns for the crew to fill in, the header repeats on every page and rows are not split across pages.
    A block for date, site, operator, weather, machine settings and notes sits above and below the table.

    Parameters
    ----------
    df : pandas.DataFrame
        The plan (:func:`plan_table`).
    title : str
        Heading of the sheet.

    Returns
    -------
    str
        The HTML document.
    """
    rows = df.sort_values("order" if "order" in df.columns else "run", kind="stable")
    cols = list(rows.columns)
    if "order" in cols and "run" in cols:  # the crew reads the sheet by order: put it first
        first = ["order", "run"] + (["replicate"] if "replicate" in cols else [])
        cols = first + [c for c in cols if c not in first]
    fill = [c for c in cols if c in RAW_COLUMNS or c in index_columns()]
    design = [c for c in cols if c not in fill]
    n_fill = len(fill) + 1  # + notes
    width_design = 4.5  # % of the page per design column
    width_fill = max(5.0, (100.0 - width_design * len(design) - 12.0) / max(n_fill - 1, 1))
    colgroup = "".join(f"<col style='width:{width_design:.2f}%'>" for _ in design)
    colgroup += "".join(f"<col style='width:{width_fill:.2f}%'>" for _ in fill) + "<col>"

    def label(c: str) -> str:
        if c in _LABELS:
            return _LABELS[c]
        if c.endswith("_level"):
            return f"{html_text(c[:-6])}<br>level"
        if "_" in c:
            name, unit = c.split("_", 1)
            return f"{html_text(name)}<br>{html_text(unit)}"
        return html_text(c)

    head = "".join(f"<th class='{'fill' if c in fill else 'design'}'>{label(c)}</th>" for c in cols)
    head += "<th class='fill'>notes</th>"
    body = []
    for rec in rows[cols].itertuples(index=False, name=None):
        cells = "".join(f"<td class='{'fill' if c in fill else 'design'}'>{html_text(_cell_text(v))}</td>"
                        for c, v in zip(cols, rec))
        body.append(f"<tr>{cells}<td class='fill'></td></tr>")
    blank = "<span class='blank'></span>"
    meta = "".join(f"<div class='meta'><b>{k}</b> {blank}</div>"
                   for k in ("Date", "Site / field", "Operator", "Weather", "Crop / variety", "Machine settings",
                             "Start time", "End time"))
    css = ("@page{size:landscape;margin:10mm}"
           "body{font-family:sans-serif;font-size:10pt;margin:1em}h2{font-size:13pt;margin:0 0 .4em}"
           ".metas{display:flex;flex-wrap:wrap;gap:.3em 1.5em;margin-bottom:.6em}"
           ".meta{min-width:22%}.blank{display:inline-block;border-bottom:1px solid #444;width:11em;height:1em}"
           "table{border-collapse:collapse;width:100%;table-layout:fixed}"
           "thead{display:table-header-group}tr{page-break-inside:avoid;break-inside:avoid}"
           "td,th{border:1px solid #444;padding:3px 4px;text-align:center;overflow-wrap:anywhere;"
           "word-break:break-word;vertical-align:middle}"
           "th{background:#eee;font-size:8.5pt;font-weight:600}td.fill{height:2.2em}"
           ".notes{border:1px solid #444;height:5em;margin-top:.6em;padding:3px}"
           "@media print{body{margin:0}th{-webkit-print-color-adjust:exact;print-color-adjust:exact}}")
    return (f"<!doctype html><html><head><meta charset='utf-8'><title>{html_text(title)}</title>"
            f"<style>{css}</style></head><body>"
            f"<h2>{html_text(title)}</h2><div class='metas'>{meta}</div>"
            "<p>Run the tests top to bottom (the <b>order</b> column; <b>run</b> is the design's run number, "
            "<b>replicate</b> which repeat of it this row is). "
            "Fill in either the raw masses and duration or the ready indexes; use a decimal point.</p>"
            f"<table><colgroup>{colgroup}</colgroup><thead><tr>{head}</tr></thead>"
            f"<tbody>{''.join(body)}</tbody></table>"
            "<div class='notes'><b>Notes</b> (deviations, breakdowns, re-runs):</div>"
            f"<p style='font-size:8pt'>berryshaker {html_text(__version__)}</p></body></html>")


__all__ = ["ARRAYS", "Factor", "FieldResults", "MAX_ROWS", "META_COLUMNS", "RAW_COLUMNS",
           "parse_factor", "plan_table", "plan_html", "read_results", "compute_indexes"]
