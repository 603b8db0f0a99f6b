"""Reading a filled field sheet back, strictly (issue "never compute on a misread input"), and analysing it as
``doe analyze`` does.

Every cell that is used is parsed and checked, and anything that cannot be read unambiguously stops with a
:class:`ConfigError` naming the row (line of the file, header = line 1), the run and the column, and
saying how to fix it.  Level cells are matched by value or by level number whatever the coding; factor
columns may be the planner's ``<name>_level`` / ``<name>_<unit>`` pair or plain value columns as
statistics packages write them.  :func:`read_results` puts together the sheet's cells
(:mod:`berryshaker.experiment.field_cells`), factors (:mod:`~berryshaker.experiment.field_factors`), runs
(:mod:`~berryshaker.experiment.field_runs`) and responses (:mod:`~berryshaker.experiment.field_responses`);
:func:`analyze_sheet` analyses what it read.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd

from berryshaker.errors import ConfigError
from berryshaker.experiment.analysis_records import DoeAnalysis
from berryshaker.experiment.designs import is_orthogonal
from berryshaker.experiment.field_cells import BOOKKEEPING_COLUMNS, _load_sheet, block_column, is_bookkeeping
from berryshaker.experiment.field_columns import META_COLUMNS, Factor, FieldResults
from berryshaker.experiment.field_factors import _find_factors, _resolve_factor
from berryshaker.experiment.field_responses import _response, _response_column, _response_unit
from berryshaker.experiment.field_runs import _check_runs, _orthogonality_problem, _runs_from_settings, _settings_text
from berryshaker.experiment.replicated_records import SheetReplicatedAnalysis
from berryshaker.records import fields_of


def read_results(path_or_text, responses: list[str], factors: list[Factor] | None = None,
                 sheet: str | None = None) -> FieldResults:
    """Read a filled field sheet; compute indexes from raw masses where the index cells are empty.

    Parameters
    ----------
    path_or_text : path or str
        CSV or .xlsx file (or a CSV's text).  A workbook's cells are read as strictly as a CSV's
        (:mod:`berryshaker.experiment.sheet_files`: a formula is an error naming the cell, a date or a boolean is
        refused where a number belongs).  Comma-, semicolon- or tab-separated; in semicolon- and tab-separated
        sheets a decimal comma is read as a decimal point (it cannot be a separator there); in
        comma-separated sheets a cell such as "3,9" is refused with a hint.
    responses : list of str
        ``efficiency``, ``unripe``, ``damage`` (from the index columns, or computed from the raw masses
        where those are empty) or the name of any other numeric column.
    factors : list of Factor, optional
        The plan's factors.  Without them the factors are found in the sheet: ``<name>_level`` columns
        (with an optional ``<name>_<unit>`` or ``<name>`` value column), or else every column that is not
        run, order, a response, a raw measurement, a note (``date``, ``operator``, ``weather``,
        ``notes``, ...) or a statistics package's bookkeeping (:data:`BOOKKEEPING_COLUMNS`) is a factor holding level
        values, as statistics packages write them; a column whose values differ in more than half the rows is a
        measurement (a response not analysed), not a factor.  Without a ``run`` column the runs are told apart by
        their factor settings (rows with the same settings are replicates).  Units come from the header
        ("Speed (rpm)", "Speed [r/min]", ``A_mm``) or a units row under it.
    sheet : str, optional
        The worksheet of an .xlsx workbook (default its first; refused for a CSV).

    Notes
    -----
    Level cells are matched by value or by level number, whatever the coding: 1/2/3, 0/1/2 or the level
    values themselves ("0.25" or "0.25 mm"); a coding that reads two ways is refused.  A value that
    matches no level is an error naming the row and column.  Checked as well: run numbers 1..n once
    each, levels forming an orthogonal (balanced) design, finite non-negative masses, duration > 0,
    unripe and damaged mass not above the picked mass, rates within 0-100 %, efficiency >= 0, a factor
    that would take a response column, an unknown response name, a header-only sheet.  Every error is a
    :class:`ConfigError` naming the row (line of the file; header = line 1), run and column.

    Returns
    -------
    FieldResults
        The sheet as read and checked.
    """
    sheet = _load_sheet(path_or_text, sheet)
    df = sheet.df
    if len(df) == 0:
        raise ConfigError(f"{sheet.label} has a header but no rows; fill in the field sheet (one row per run)")
    has_run = "run" in df.columns
    runs = reps = None
    if has_run:
        runs, reps = _check_runs(sheet)
    resp_col = {r: _response_column(sheet, r) for r in responses}
    response_cols = set(resp_col.values()) | set(responses)
    found, ignored = _find_factors(sheet, factors, response_cols)
    # responses named like a factor column
    factor_cols = {c for f in found for c in (f[0], f[1], f[2]) if c}
    for r in responses:
        if r in factor_cols or resp_col[r] in factor_cols:
            raise ConfigError(f"response {r!r} is also a factor column of the sheet; analyse another column or "
                              "rename the factor")
    names, codes, level_values, units, values = [], [], {}, {}, []
    for name, code_col, value_col, unit, given in found:
        c, lv, v, unit = _resolve_factor(sheet, name, code_col, value_col, unit, given)
        names.append(name)
        codes.append(c)
        level_values[name] = lv
        units[name] = unit
        values.append(v if v is not None else c.astype(float))
    levels = np.column_stack(codes).astype(int)
    valuearr = np.column_stack(values).astype(float)
    how = "run column"
    if not has_run:
        runs, reps, how = _runs_from_settings(sheet, levels, names, level_values, units)
    r = 1 if reps is None else int(reps.max())
    order = np.lexsort((np.ones_like(runs) if reps is None else reps, runs))  # by run, then replicate
    levels, valuearr = levels[order], valuearr[order]
    runs_o = runs[order]
    first = np.searchsorted(runs_o, np.arange(1, int(runs_o.max()) + 1))  # each run's first row (sorted)
    if r > 1:  # the replicates of a run are the same design point
        off = np.flatnonzero((levels != levels[first[runs_o - 1]]).any(axis=1))
        if len(off):
            k = int(off[0])
            run = int(runs_o[k])
            i = int(order[k])
            name = names[int(np.argmax(levels[k] != levels[first[run - 1]]))]
            col = next(c for f in found if f[0] == name for c in (f[1], f[2]) if c)
            rep0 = int(reps[order][first[run - 1]])
            raise ConfigError(f"{sheet.where(i, col)}: the levels differ from replicate {rep0} of run {run}; the "
                              "replicates of a run repeat the same settings - correct the level or the run number")
    run_levels, run_values = levels[first], valuearr[first]
    if levels.shape[1] > 1 and not is_orthogonal(run_levels):
        raise ConfigError(f"{sheet.label}: the factor level columns do not form an orthogonal (balanced) design ("
                          + _orthogonality_problem(run_levels, names) + "); was a row edited or a run duplicated?")
    out = {resp: _response(sheet, resp, factor_cols, resp_col[resp], lost=r > 1)[order] for resp in responses}
    # the table: sorted by run (and replicate), numbers where the sheet's cells are numbers, level numbers
    # normalised
    table = df.iloc[order].reset_index(drop=True).copy()
    for c in table.columns:
        if c.lower() in META_COLUMNS:
            continue
        conv = pd.to_numeric(table[c].str.replace(",", ".", regex=False) if sheet.decimal_comma else table[c],
                             errors="coerce")
        if (conv.notna() | table[c].isna()).all():
            table[c] = conv.astype(float)
    table["run"] = runs[order]
    level_cols = []
    for j, name in enumerate(names):
        col = f"{name}_level"
        table[col] = levels[:, j]
        level_cols.append(col)
        vcol = next((f[2] for f in found if f[0] == name), None)
        if level_values[name] is not None:
            if vcol is None or vcol == name:  # give the values a column ``<name>_<unit>`` / ``<name>_value``
                table[f"{name}_{units[name] or 'value'}"] = valuearr[:, j]
            else:
                table[vcol] = valuearr[:, j]
    if reps is not None:
        table["replicate"] = reps[order]
    replicated, lost = None, {}
    if reps is not None:
        what = "block" if block_column(df) not in (None, "replicate") else "replicate"
        replicated = {}
        for k, v in out.items():
            y = np.full((len(first), r), np.nan)
            y[runs_o - 1, reps[order] - 1] = v
            none = np.flatnonzero(~np.isfinite(y).any(axis=1))
            if len(none):
                raise ConfigError(f"{sheet.label}: run {int(none[0]) + 1} has no {k} value in any {what} (every "
                                  f"plot of it lost); the analysis needs at least one {what} of every run - fill "
                                  f"in its {k} or leave {k} out of the analysis")
            replicated[k] = y
            lost[k] = [[int(i) + 1, int(j) + 1] for i, j in np.argwhere(~np.isfinite(y))]
    means = ({k: (np.nanmean(v, axis=1) if lost[k] else v.mean(axis=1)) for k, v in replicated.items()}
             if replicated is not None else out)
    blk = block_column(df) if reps is not None else None
    if not has_run and reps is not None and not how.startswith("factor settings; repeats numbered by the blocks"):
        blk = None  # a constant Blocks column (Minitab's 1 everywhere) numbers no blocks
    return FieldResults(table, level_cols, names, means, run_levels, run_values, level_values, units,
                        ignored, replicates=r, responses_replicated=replicated, block_column=blk,
                        response_units={resp: _response_unit(sheet, resp_col[resp]) for resp in responses},
                        runs_identified_by=how, lost={k: v for k, v in lost.items() if v})


def _check_analysable(fr: FieldResults) -> None:
    """Refuse a sheet too small to analyse, with the reason: a factor with one level (one run, or a column that
    never changes), or an unreplicated sheet whose factors use every degree of freedom even with one pooled."""
    if len(fr.levels) == 1:
        raise ConfigError(f"the sheet cannot be analysed: it holds one run ("
                          f"{_settings_text(fr.factor_names, fr.levels[0], fr.level_values, fr.units)}"
                          + (f", {fr.replicates} replicates" if fr.replicates > 1 else "") + "), so every factor has "
                          "one level; a test compares at least two levels of every factor (the runs of `doe plan`)")
    for j, name in enumerate(fr.factor_names):
        ks = np.unique(fr.levels[:, j])
        if len(ks) < 2:
            lv = fr.level_values.get(name)
            shown = (f"{lv[int(ks[0]) - 1]:g}{(' ' + fr.units[name]) if fr.units.get(name) else ''}" if lv is not None
                     else f"level {int(ks[0])}")
            raise ConfigError(f"the sheet cannot be analysed: factor {name!r} has one level ({shown}) in all "
                              f"{len(fr.levels)} runs, so its effect cannot be "
                              "estimated; a test needs at least two levels of every factor (the runs of the plan: "
                              "`doe plan`), or leave the column out")
    if fr.replicates < 2:
        n = len(fr.levels)
        dof = sorted(len(np.unique(fr.levels[:, j])) - 1 for j in range(len(fr.factor_names)))
        left = n - 1 - sum(dof)
        if left < 1 and len(dof) > 1:  # a saturated array: the weakest factor is pooled into the error
            left += dof[0]
        if left < 1:
            raise ConfigError(f"the sheet cannot be analysed: {n} runs without replicates and factors "
                              f"{', '.join(fr.factor_names)} using {sum(dof)} degrees of freedom leave none for the "
                              "error, even with the weakest factor pooled; test every run at least twice (a "
                              "'replicate' column, `doe plan --replicates 2`) or use a larger array")


def analyze_sheet(path_or_text, senses: dict[str, bool], weights: dict[str, float] | None = None,
                  factors: list[Factor] | None = None, sheet: str | None = None,
                  desirability: str | None = None) -> tuple[FieldResults, DoeAnalysis | SheetReplicatedAnalysis]:
    """Read a filled sheet (:func:`read_results`) and analyse it as ``doe analyze`` does.

    A sheet with repeats (a ``replicate`` or ``block`` column, or repeated factor settings) is analysed as
    randomised complete blocks (:func:`berryshaker.experiment.replicates.analyze_replicated`), or, when it lost plots
    (a blank response, a deleted row), by least squares on the plots present
    (:func:`berryshaker.experiment.unbalanced.analyze_unbalanced`, ``lost_plots`` says what was lost); one without by
    range analysis with the weakest factor pooled (:func:`berryshaker.experiment.analysis.analyze`, the optimum's
    intervals from the pooled error).  A sheet too small to analyse (one run, a factor with one level, no error
    degrees of freedom left) is refused with the reason.  The plan's format
    and a statistics package's worksheet of the same data give the same analysis.

    Parameters
    ----------
    path_or_text : path or str
        The sheet (CSV or .xlsx) or a CSV's text.
    senses : dict response -> bool
        True where larger is better; the keys are the responses analysed.
    weights : dict response -> float, optional
        Weights of the composite score (1; default equal).
    factors : list of Factor, optional
        The plan's factors (default: found in the sheet).
    sheet : str, optional
        The worksheet of an .xlsx workbook (default its first).
    desirability : str, optional
        Goals of the desirability optimiser, e.g. ``efficiency=max:2..5kg/min,damage=min:0..5%``
        (:func:`berryshaker.experiment.desirability.parse_desirability`): the analysis then has ``desirability``.

    Returns
    -------
    (FieldResults, DoeAnalysis or SheetReplicatedAnalysis)
        The sheet as read, and the analysis with ``replicates``, ``weights_given``, ``response_units`` (unit per
        response, '' where the sheet gives none), ``block_column`` and ``text`` (replicated) and
        ``runs_identified_by`` (:mod:`berryshaker.experiment.analysis_records`,
        :mod:`~berryshaker.experiment.replicated_records`).
    """
    from berryshaker.experiment.analysis import analyze
    from berryshaker.experiment.replicates import analyze_replicated, describe_replicated

    fr = read_results(path_or_text, list(senses), factors, sheet=sheet)
    _check_analysable(fr)
    extra = {"weights_given": weights is not None, "response_units": dict(fr.response_units),
             "runs_identified_by": fr.runs_identified_by}
    if fr.replicates >= 2 and fr.lost:  # lost plots: least squares on the plots present
        from berryshaker.experiment.replicated_records import LostPlots
        from berryshaker.experiment.unbalanced import analyze_unbalanced, describe_lost

        rep, info = analyze_unbalanced(fr.levels, fr.values, fr.factor_names, fr.responses_replicated, senses,
                                       weights, level_values=fr.level_values, units=fr.units)
        what = "replicate" if fr.block_column in (None, "replicate") else "block"
        text = "\n".join(describe_lost(info, what) + [describe_replicated(rep)])
        res = SheetReplicatedAnalysis(**fields_of(rep), block_column=fr.block_column, text=text,
                                      lost_plots=LostPlots(**info), **extra)
    elif fr.replicates >= 2:
        rep = analyze_replicated(fr.levels, fr.values, fr.factor_names, fr.responses_replicated, senses, weights,
                                 level_values=fr.level_values, units=fr.units, blocks=True)
        res = SheetReplicatedAnalysis(**fields_of(rep),
                                      block_column=fr.block_column, text=describe_replicated(rep), **extra)
    else:
        from berryshaker.experiment.desirability import level_set_prediction

        res = replace(analyze(fr.levels, fr.values, fr.factor_names, fr.responses, senses, weights,
                              level_values=fr.level_values, units=fr.units), replicates=fr.replicates, **extra)
        res = replace(res, optimum=replace(res.optimum, intervals=level_set_prediction(fr, res, res.optimum.levels)[1]))
    if desirability is not None:
        from berryshaker.experiment.desirability import desirability_optimum, parse_desirability

        goals = parse_desirability(desirability, list(senses), fr.response_units)
        res = replace(res, desirability=desirability_optimum(fr, res, goals))
    return fr, res


__all__ = ["BOOKKEEPING_COLUMNS", "analyze_sheet", "is_bookkeeping", "read_results"]
