"""Trade-off table of candidate designs (clearance sets) and which of them are dominated beyond noise.

A candidate *dominates* another if it is no worse beyond noise in every judged column and better beyond
noise in at least one (Pareto dominance, e.g. Deb, *Multi-Objective Optimization Using Evolutionary
Algorithms*, 2001, ch. 2, with "better" replaced by "better by more than the noise").  "Beyond noise"
for two values a, b with confidence half-widths h_a, h_b (from their intervals) means
|a - b| > sqrt(h_a^2 + h_b^2), the half-width of the interval of the difference of two independent
estimates at the same confidence; a column without intervals (a deterministic model output) uses the
relative tolerance ``rtol`` of the larger magnitude instead.

An estimate may carry its own *comparison half-width* ``noise`` (``{"mean", "ci", "noise"}``, column
``<col>_noise``): the margin is then sqrt(noise_a^2 + noise_b^2) instead of the one from the intervals, while
the interval stays the one reported.  With noise = q(conf; k, dof) / sqrt(2) sqrt(MS_E / n) (q the studentized
range of k candidates) this margin is exactly the Tukey-Kramer simultaneous margin q / sqrt(2) sqrt(MS_E (1/n_a
+ 1/n_b)) (Montgomery, *Design and Analysis of Experiments*, 8th ed., 2013, sec. 3.5.7): the comparison of
all candidates then has the family-wise error of one test, as the level comparisons of a replicated ANOVA do
(:func:`berryshaker.experiment.error_terms.comparison_half_width`).
"""

from __future__ import annotations

import math
import numbers

import numpy as np
import pandas as pd

from berryshaker.errors import ConfigError

#: substrings of a column name -> True (larger is better) / False (smaller is better) / None (descriptive)
SENSE_PATTERNS: tuple[tuple[str, bool | None], ...] = (
    ("clearance", None), ("efficiency", True), ("unripe", False), ("damage", False), ("force", False),
    ("torque", False), ("energy", False), ("power", False), ("lost", False), ("loss", False),
)


def column_sense(column: str, senses: dict[str, bool | None] | None = None) -> bool | None:
    """Whether larger is better (True), smaller (False) or the column is descriptive (None).

    ``senses`` (exact column or its group, the part before ':') overrides :data:`SENSE_PATTERNS`.

    Parameters
    ----------
    column : str
        The column name.
    senses : dict, optional
        Overrides: column or group name -> True / False / None.

    Returns
    -------
    bool or None
        True: larger is better; False: smaller is better; None: descriptive.
    """
    senses = senses or {}
    for key in (column, column.split(":")[0]):
        if key in senses:
            return senses[key]
    low = column.lower()
    for pat, s in SENSE_PATTERNS:
        if pat in low:
            return s
    return None


def _number(x, where: str) -> float:
    if isinstance(x, bool) or not isinstance(x, numbers.Real):
        raise ConfigError(f"trade-off candidate {where}: {x!r} is not a number")
    x = float(x)
    if not math.isfinite(x):
        raise ConfigError(f"trade-off candidate {where}: value is not finite")
    return x


def _noise(x, where: str) -> float | None:
    """The comparison half-width ``noise`` of a dict estimate (>= 0), or None."""
    if not isinstance(x, dict) or x.get("noise") is None:
        return None
    v = _number(x["noise"], where + " noise")
    if v < 0:
        raise ConfigError(f"trade-off candidate {where}: noise {v:g} must be >= 0 (a half-width)")
    return v


def _estimate(x, where: str) -> tuple[float, float | None, float | None]:
    """A number, or a dict {mean, ci: [lo, hi]} / {mean, lo, hi} -> (mean, lo, hi)."""
    if isinstance(x, dict):
        if "mean" not in x:
            raise ConfigError(f"trade-off candidate {where}: a dict needs 'mean' (and 'ci': [lo, hi])")
        m = _number(x["mean"], where)
        lo, hi = x.get("ci", (x.get("lo"), x.get("hi")))
        if lo is None or hi is None:
            return m, None, None
        lo, hi = _number(lo, where + " ci"), _number(hi, where + " ci")
        if not lo <= m <= hi:
            raise ConfigError(f"trade-off candidate {where}: interval [{lo:g}, {hi:g}] does not contain {m:g}")
        return m, lo, hi
    return _number(x, where), None, None


def _is_estimate(x) -> bool:
    return isinstance(x, numbers.Real) or (isinstance(x, dict) and "mean" in x)


def _flatten(c: dict) -> dict:
    if "name" not in c:
        raise ConfigError("trade-off candidate without 'name'")
    name = str(c["name"])
    row: dict = {"name": name}

    def put(col: str, x, where: str) -> None:
        m, lo, hi = _estimate(x, where)
        row[col] = m
        if lo is not None:
            row[f"{col}_lo"], row[f"{col}_hi"] = lo, hi
        nz = _noise(x, where)
        if nz is not None:
            row[f"{col}_noise"] = nz

    for key, x in c.items():
        if key == "name":
            continue
        where = f"{name!r}, {key!r}"
        if key == "harvest" and isinstance(x, dict):  # harvest indexes become top-level columns
            for idx, v in x.items():
                put(idx, v, f"{where}[{idx!r}]")
        elif isinstance(x, dict) and not _is_estimate(x):  # per joint
            for sub, v in x.items():
                put(f"{key}:{sub}", v, f"{where}[{sub!r}]")
        elif isinstance(x, str):
            row[key] = x
        else:
            put(key, x, where)
    return row


def _judged_columns(df: pd.DataFrame, senses) -> dict[str, bool]:
    out = {}
    for col in df.columns:
        if col in ("name", "dominated", "dominated_by") or col.endswith(("_lo", "_hi", "_noise")):
            continue
        if not pd.api.types.is_numeric_dtype(df[col]):
            continue
        s = column_sense(col, senses)
        if s is not None:
            out[col] = s
    return out


def _column_comparisons(df: pd.DataFrame, senses, rtol: float):
    """Per judged column: (column, d, margin) with ``d[i, j]`` how much better candidate i is than j (signed by
    the column's sense) and ``margin[i, j]`` the noise of that difference (module docstring)."""
    n = len(df)
    for col, maximize in _judged_columns(df, senses).items():
        v = df[col].to_numpy(float)
        if f"{col}_noise" in df.columns:
            h = df[f"{col}_noise"].to_numpy(float)
            h = np.where(np.isnan(h), 0.0, h)
            margin = np.sqrt(h[:, None] ** 2 + h[None, :] ** 2)
        elif f"{col}_lo" in df.columns:
            h = (df[f"{col}_hi"].to_numpy(float) - df[f"{col}_lo"].to_numpy(float)) / 2
            h = np.where(np.isnan(h), 0.0, h)
            margin = np.sqrt(h[:, None] ** 2 + h[None, :] ** 2)
        else:
            margin = np.zeros((n, n))
        margin = np.maximum(margin, np.where(margin > 0, 0.0, rtol * np.maximum(np.abs(v)[:, None],
                                                                                 np.abs(v)[None, :])))
        d = v[:, None] - v[None, :]
        yield col, (d if maximize else -d), margin


def dominance_matrix(df: pd.DataFrame, senses: dict[str, bool | None] | None = None,
                     rtol: float = 0.01) -> np.ndarray:
    """``D[i, j]`` True where candidate i dominates candidate j beyond noise (see the module docstring).

    Parameters
    ----------
    df : pandas.DataFrame
        The trade-off table (:func:`tradeoff_table`), one row per candidate.
    senses : dict, optional
        Overrides of :func:`column_sense`.
    rtol : float
        Relative noise of columns without intervals (dimensionless).

    Returns
    -------
    ndarray of bool, shape (n, n)
        The dominance matrix.
    """
    n = len(df)
    no_worse = np.ones((n, n), bool)
    better = np.zeros((n, n), bool)
    for _col, d, margin in _column_comparisons(df, senses, rtol):
        better |= d > margin
        no_worse &= ~(-d > margin)
    dom = no_worse & better
    np.fill_diagonal(dom, False)
    return dom


def better_columns(df: pd.DataFrame, i: int, j: int, senses: dict[str, bool | None] | None = None,
                   rtol: float = 0.01) -> list[str]:
    """The judged columns in which row i of a trade-off table is better than row j beyond noise (the same
    margins as :func:`dominance_matrix`).

    Parameters
    ----------
    df : pandas.DataFrame
        The trade-off table.
    i, j : int
        Row positions of the two candidates.
    senses : dict, optional
        Overrides of :func:`column_sense`.
    rtol : float
        Relative noise of columns without intervals (dimensionless).

    Returns
    -------
    list of str
        The columns in which row i is better.
    """
    return [col for col, d, margin in _column_comparisons(df, senses, rtol) if d[i, j] > margin[i, j]]


def mark_dominated(df: pd.DataFrame, senses: dict[str, bool | None] | None = None, rtol: float = 0.01) -> pd.DataFrame:
    """A copy of a trade-off table with ``dominated`` (bool) and ``dominated_by`` (names, separated by "; ": a name
    may hold commas, "A 0.25 mm, B 0.2 mm").

    Judged columns: those with a sense (:func:`column_sense`: harvest efficiency larger is better;
    unripe and damage rates, forces, torque, energy smaller is better; clearances descriptive).  Columns
    ``<col>_lo`` / ``<col>_hi`` are the interval of ``<col>``, ``<col>_noise`` (if present) the comparison
    half-width that replaces the interval's half-width in the margin; without either ``rtol`` is the noise.

    Parameters
    ----------
    df : pandas.DataFrame
        The trade-off table.
    senses : dict, optional
        Overrides of :func:`column_sense`.
    rtol : float
        Relative noise of columns without intervals (dimensionless), in [0, 1).

    Returns
    -------
    pandas.DataFrame
        The copy with the two columns added.
    """
    if not 0 <= rtol < 1:
        raise ConfigError(f"rtol={rtol!r}: give a relative tolerance between 0 and 1")
    out = df.copy()
    dom = dominance_matrix(out, senses, rtol)
    names = out["name"].astype(str).to_numpy()
    out["dominated"] = dom.any(axis=0)
    out["dominated_by"] = ["; ".join(names[dom[:, j]]) for j in range(len(out))]
    return out


def tradeoff_table(candidates: list[dict], senses: dict[str, bool | None] | None = None,
                   rtol: float = 0.01) -> pd.DataFrame:
    """One row per candidate, the non-dominated ones first.

    Parameters
    ----------
    candidates : list of dict
        Each with ``name`` and any of: ``clearance_mm`` {joint: value}; ``harvest`` {index: {"mean": m,
        "ci": [lo, hi]}} (indexes become columns ``efficiency``, ``unripe``, ``damage`` with ``_lo`` /
        ``_hi``; an optional ``"noise"``, the comparison half-width of the module docstring, becomes ``_noise``); ``peak_force_N`` {joint: value or {mean, ci}}; ``drive_torque_Nm``; ``energy_lost_J``;
        any other number or {mean, ci}.  Per-joint dicts become columns ``<key>:<joint>``.
    senses : dict, optional
        Overrides of :func:`column_sense` (column or group name -> True / False / None).
    rtol : float
        Relative noise of columns without intervals (deterministic model outputs; dimensionless).

    Returns
    -------
    pandas.DataFrame
        Sorted by ``dominated`` (False first), then by the first larger-is-better column (descending),
        then by name; with ``dominated`` and ``dominated_by`` (see :func:`mark_dominated`).
    """
    if not candidates:
        raise ConfigError("trade-off table: no candidates")
    rows = [_flatten(c) for c in candidates]
    names = [r["name"] for r in rows]
    if len(set(names)) != len(names):
        raise ConfigError(f"trade-off table: candidate names must be distinct ({names})")
    df = mark_dominated(pd.DataFrame(rows), senses, rtol)
    keys, asc = ["dominated"], [True]
    first_max = next((c for c, s in _judged_columns(df, senses).items() if s), None)
    if first_max is not None:
        keys.append(first_max)
        asc.append(False)
    keys.append("name")
    asc.append(True)
    return df.sort_values(keys, ascending=asc, kind="stable").reset_index(drop=True)


__all__ = ["SENSE_PATTERNS", "better_columns", "column_sense", "dominance_matrix", "mark_dominated", "tradeoff_table"]
