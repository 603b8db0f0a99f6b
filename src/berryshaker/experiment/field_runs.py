"""The runs of a filled field sheet (:func:`berryshaker.experiment.field_results.read_results`): run and repeat
numbers from the ``run`` and ``block`` / ``replicate`` columns, or told apart by their factor settings where the
sheet has no ``run`` column (a statistics package's worksheet), every run with the same repeats; and what makes a
plan not orthogonal.
"""

from __future__ import annotations

import re

import numpy as np

from berryshaker.errors import ConfigError
from berryshaker.experiment.field_cells import _Sheet, block_column


def _check_runs(sheet: _Sheet) -> tuple[np.ndarray, np.ndarray | None]:
    """Run numbers per row (1..n) and, if the sheet has a ``block`` or ``replicate`` column
    (:func:`block_column`), repeat numbers per row: every run then has each of the repeats 1..R at most once
    (:func:`_check_repeats`; a missing one is a lost plot)."""
    if "run" not in sheet.df.columns:
        raise ConfigError(f"{sheet.label}: no 'run' column (the field sheet from `berryshaker doe plan` has one)")
    runs, empty = sheet.numbers("run")
    if empty.any():
        i = int(np.argmax(empty))
        raise ConfigError(f"{sheet.where(i, 'run')}: empty run number; fill it in")
    bad = ~np.isfinite(runs) | (runs != np.round(runs)) | (runs < 1)
    if bad.any():
        i = int(np.argmax(bad))
        raise ConfigError(f"{sheet.where(i, 'run')}: {sheet.df['run'].iloc[i]!r} is not a run "
                          "number (1, 2, 3, ...)")
    runs = runs.astype(np.int64)
    sheet.run_label = [f"run {r}" for r in runs]
    reps = None
    col = block_column(sheet.df)
    what = "block" if col != "replicate" else "replicate"
    if col is not None:
        reps, empty = sheet.numbers(col)
        bad = empty | ~np.isfinite(reps) | (reps != np.round(reps)) | (reps < 1)
        if bad.any():
            i = int(np.argmax(bad))
            raise ConfigError(f"{sheet.where(i, col)}: "
                              f"{sheet.df[col].iloc[i]!r} is not a {what} number (1, 2, 3, ...); fill it in")
        reps = reps.astype(np.int64)
        if reps.max() > 1:
            sheet.run_label = [f"run {r}, {what} {k}" for r, k in zip(runs, reps)]
    _check_repeats(sheet, runs, reps, what)
    n = int(runs.max())
    present = set(runs.tolist())
    if len(present) != n:
        missing = sorted(set(range(1, n + 1)) - present)[:10]
        raise ConfigError(f"{sheet.label}: runs must be numbered 1..{n} once each"
                          + (f"; missing run(s) {missing}" if missing else ""))
    return runs, reps


def _check_repeats(sheet: _Sheet, runs: np.ndarray, reps: np.ndarray | None, what: str) -> None:
    """Each run once (per repeat); with repeats, the repeat numbers 1..R all used and every repeat (a block: a field
    day, a row of bushes) holding at least two runs.  A run may lack some repeats (a lost plot: a deleted row); the
    analysis then states what was lost (:mod:`berryshaker.experiment.unbalanced`)."""
    key = runs if reps is None else runs * (int(reps.max()) + 1) + reps
    _, counts = np.unique(key, return_counts=True)
    if (counts > 1).any():
        dup = int(np.unique(key)[np.argmax(counts > 1)])
        rows = [sheet.line(int(i)) for i in np.flatnonzero(key == dup)]
        if reps is None:
            raise ConfigError(f"{sheet.label}: run {dup} appears {len(rows)} times (rows {', '.join(map(str, rows))}); "
                              "keep one row per run, or number the repeats of a run in a 'replicate' column "
                              "(`doe plan --replicates`)")
        i = int(np.flatnonzero(key == dup)[0])
        raise ConfigError(f"{sheet.label}: run {runs[i]} appears {len(rows)} times (rows {', '.join(map(str, rows))}) "
                          f"as {what} {reps[i]}; keep one row per run and {what}")
    if reps is None or len(set(runs.tolist())) < 2:
        return
    r = int(reps.max())
    gaps = sorted(set(range(1, r + 1)) - set(reps.tolist()))
    if gaps:
        raise ConfigError(f"{sheet.label}: no row has {what} {', '.join(map(str, gaps))}, but {what} {r} exists; "
                          f"number the {what}s 1..{r} (a typo in a {what} number?)")
    for k in range(1, r + 1):
        rows = np.flatnonzero(reps == k)
        if len(rows) < 2:
            i = int(rows[0])
            raise ConfigError(f"{sheet.row(i)}: {what} {k} holds this row only; a {what} (a field day, a row of "
                              f"bushes) needs at least two runs to compare within it - correct the {what} number "
                              "(a typo?) or delete the row")


def _settings_text(names: list[str], levels_row, level_values: dict, units: dict) -> str:
    """"A = 0.25 mm, B = 2" of one run's settings (level values where known, else level numbers)."""
    out = []
    for name, k in zip(names, levels_row):
        lv = level_values.get(name)
        out.append(f"{name} = {lv[int(k) - 1]:g}{(' ' + units[name]) if units.get(name) else ''}" if lv is not None
                   else f"{name} level {int(k)}")
    return ", ".join(out)


def _bookkeeping_column(sheet: _Sheet, *keys: str) -> str | None:
    """The first column whose normalised name is one of ``keys`` (e.g. "stdorder", "runorder")."""
    for key in keys:
        for c in sheet.df.columns:
            if re.sub(r"[\s_.]", "", str(c)).lower() == key:
                return c
    return None


def _runs_from_settings(sheet: _Sheet, levels: np.ndarray, names: list[str], level_values: dict,
                        units: dict) -> tuple[np.ndarray, np.ndarray | None, str]:
    """Run and repeat numbers per row of a sheet without a ``run`` column (Minitab's worksheet, a statistics
    package's export): a run is a distinct combination of factor levels, and rows with the same settings are its
    replicates.

    Runs are numbered in the design's standard order: by the smallest StdOrder (Minitab's standard order) of their
    rows where the sheet has that column, else by their levels (an orthogonal array's standard order).  Repeats
    are numbered by the block column where it holds more than one block (Minitab's Blocks: each run once per block),
    else in standard order (StdOrder), else in test order (RunOrder), else in the order of the rows; every run needs
    the same number of them.
    """
    keys = [tuple(int(v) for v in row) for row in levels]
    std = _bookkeeping_column(sheet, "stdorder", "standardorder", "std")
    test = _bookkeeping_column(sheet, "runorder")
    order_of = {}
    for name, col in (("std", std), ("test", test)):
        if col is None:
            continue
        v, empty = sheet.numbers(col)
        bad = empty | ~np.isfinite(v)
        if bad.any():
            i = int(np.argmax(bad))
            raise ConfigError(f"{sheet.where(i, col)}: empty or not a number; fill in the order (1, 2, 3, ...) or "
                              "delete the column")
        order_of[name] = v
    settings = sorted(set(keys))
    if "std" in order_of:
        first = {k: min(order_of["std"][i] for i, kk in enumerate(keys) if kk == k) for k in settings}
        settings.sort(key=lambda k: (first[k], k))
    run_of = {k: i + 1 for i, k in enumerate(settings)}
    runs = np.array([run_of[k] for k in keys], dtype=np.int64)
    sheet.run_label = [f"run {r}" for r in runs]
    counts = np.bincount(runs)[1:]
    blk = block_column(sheet.df)
    blocks = None
    if blk is not None:
        b, empty = sheet.numbers(blk)
        bad = empty | ~np.isfinite(b) | (b != np.round(b)) | (b < 1)
        if bad.any():
            i = int(np.argmax(bad))
            raise ConfigError(f"{sheet.where(i, blk)}: {sheet.df[blk].iloc[i]!r} is not a block number (1, 2, 3, "
                              "...); fill it in")
        if len(np.unique(b)) > 1:
            blocks = b.astype(np.int64)
    if blocks is not None:
        reps, how = blocks, f"factor settings; repeats numbered by the blocks in {sheet.original.get(blk, blk)!r}"
        what = "block"
    else:
        by = order_of.get("std", order_of.get("test"))
        col = std if "std" in order_of else test
        rank = np.arange(len(keys), dtype=float) if by is None else by
        reps = np.zeros(len(keys), dtype=np.int64)
        for run in range(1, len(settings) + 1):
            rows = np.flatnonzero(runs == run)
            reps[rows[np.argsort(rank[rows], kind="stable")]] = np.arange(1, len(rows) + 1)
        how = ("factor settings; repeats numbered in " + (f"the order of {sheet.original.get(col, col)!r}"
                                                          if col else "the order of the rows"))
        what = "replicate"
        if counts.max() != counts.min():
            few = int(np.argmin(counts)) + 1
            many = int(np.argmax(counts)) + 1
            i = int(np.flatnonzero(runs == few)[0])
            j = int(np.flatnonzero(runs == many)[0])
            raise ConfigError(
                f"{sheet.label}: the settings {_settings_text(names, levels[i], level_values, units)} occur in "
                f"{counts[few - 1]} row(s), the settings {_settings_text(names, levels[j], level_values, units)} in "
                f"{counts[many - 1]}; rows with the same factor settings are replicates of one run, and every run "
                "needs the same number of them - add the missing replicates or delete the extra rows (a typo in a "
                "factor cell also makes a new setting)")
    if counts.max() == 1 and blocks is None:
        return runs, None, "factor settings (one row per run)"
    sheet.run_label = [f"run {r}, {what} {k}" for r, k in zip(runs, reps)]
    _check_repeats(sheet, runs, reps, what)
    return runs, reps, how


def _orthogonality_problem(levels: np.ndarray, names: list[str]) -> str:
    import itertools

    n = len(levels)
    for i, j in itertools.combinations(range(levels.shape[1]), 2):
        li, lj = np.unique(levels[:, i]), np.unique(levels[:, j])
        expected = n / (len(li) * len(lj))
        for x in li:
            for y in lj:
                c = int(np.sum((levels[:, i] == x) & (levels[:, j] == y)))
                if c != expected:
                    return (f"levels {names[i]}{x} with {names[j]}{y} occur {c} time(s), expected {expected:g}")
    return ""
