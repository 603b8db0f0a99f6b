"""The Python API of field tests: :func:`plan_field_sheet` (``berryshaker doe plan``), :func:`analyze_field_sheet`
(``doe analyze``) and :func:`validate` (``validate``: the harvest model against published field measurements), laid
out as :class:`pandas.DataFrame` objects whose column names carry their units in brackets (see
:mod:`berryshaker.api`)."""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from berryshaker.api.names import _names
from berryshaker.errors import ConfigError


# ---- field tests -----------------------------------------------------------------------------------------
def plan_field_sheet(factors: Mapping[str, str], array: str = "L9", replicates: int = 3, randomize: bool = False,
                     seed: int | None = None) -> pd.DataFrame:
    """The field sheet of an orthogonal test, as ``berryshaker doe plan`` writes it.

    A thin call of :func:`berryshaker.experiment.field_sheet.parse_factor` and
    :func:`berryshaker.experiment.field_sheet.plan_table`.

    Parameters
    ----------
    factors : dict
        Factor name -> its levels with their unit, e.g. ``{"A": "0.25,0.5,0.75mm"}`` (``--factor A=...``).
    array : str
        Orthogonal array: L4, L8, L9, L16, L18 or L27.
    replicates : int
        Times each run is tested (>= 2 lets :func:`analyze_field_sheet` judge effects against the replicate spread).
    randomize : bool
        Draw a random test order (needs ``seed``).
    seed : int, optional
        Seed of the random order.

    Returns
    -------
    pandas.DataFrame
        One row per run and replicate: ``run``, ``replicate``, ``order``, per factor ``<name>_level`` and
        ``<name>_<unit>`` (its value, e.g. ``A_mm``), and the empty response columns to fill in
        (``duration_s``, ``picked_mass_kg``... or the ready indexes ``efficiency_kg_min``, ``unripe_rate_pct``,
        ``damage_rate_pct``): the sheet's own layout, units after the last underscore, as ``doe plan`` writes it.

    Raises
    ------
    ConfigError
        A factor that is not ``v1,v2,...unit``, repeated names, or an unknown array.

    Examples
    --------
    >>> from berryshaker import api
    >>> sheet = api.plan_field_sheet({"A": "0.25,0.5,0.75mm", "B": "0.1,0.2,0.3mm"}, replicates=2)
    >>> len(sheet)
    18
    """
    from berryshaker.experiment.field_sheet import parse_factor, plan_table

    if not isinstance(factors, Mapping) or not factors:
        raise ConfigError(f"factors={factors!r}: give a dict name -> levels, e.g. {{'A': '0.25,0.5,0.75mm'}}")
    return plan_table(array, [parse_factor(f"{k}={v}") for k, v in factors.items()], randomize, seed,
                      replicates=replicates)


def _bracket_units(header: str) -> str:
    """``k1 (kg/min)`` -> ``k1 [kg/min]``."""
    return re.sub(r"\s*\(([^()]*)\)$", r" [\1]", header)


def analyze_field_sheet(sheet, maximize: str | Sequence[str] = (), minimize: str | Sequence[str] = (),
                        weights: Mapping[str, float] | None = None, worksheet: str | None = None,
                        desirability: str | None = None) -> dict[str, pd.DataFrame]:
    """Range analysis, ANOVA and weighted optimum of a filled field sheet, as ``berryshaker doe analyze``.

    A thin call of :func:`berryshaker.experiment.field_results.analyze_sheet`; the tables are those
    ``doe analyze --plot`` writes (:func:`berryshaker.report.table_files.doe_tables`).

    Parameters
    ----------
    sheet : str, Path or pandas.DataFrame
        The filled sheet: a CSV or .xlsx file, a CSV's text, or a DataFrame in the same layout
        (:func:`plan_field_sheet`'s, a statistics package's worksheet with units in the header such as
        ``"Speed (rpm)"``).  A replicated sheet that lost plots (a blank response, a deleted row) is analysed by
        least squares on the plots present (``doe analyze``).
    maximize : str or sequence of str
        Responses where larger is better, e.g. ``"efficiency"``.
    minimize : str or sequence of str
        Responses where smaller is better, e.g. ``["unripe", "damage"]``.
    weights : dict, optional
        Weights of the composite score per response (1, each > 0; default equal).
    worksheet : str, optional
        The worksheet of an .xlsx workbook (``--sheet``; default its first).
    desirability : str, optional
        Goals of the desirability optimiser (``--desirability``), e.g. ``"efficiency=max:2..5kg/min,damage=min:0..5%"``.

    Returns
    -------
    dict of str to pandas.DataFrame
        ``"range_<response>"`` per response: one row per factor (index ``factor``), the level means
        ``k1 [<unit>]`` .. ``kn [<unit>]`` and range ``R [<unit>]`` in the response's unit (``[1]`` when the sheet
        gives none), ``best_level``, ``anova_F [1]`` (NaN: pooled into the error) and ``p [1]``;
        ``"optimum_levels"``: per factor (index ``factor``) the ``level`` chosen (<NA>: no meaningful
        difference) and its ``setting``; ``"optimum_predicted"``: per response (index ``response``) its
        predicted ``value`` at the optimum, its 95 % interval ``lo``, ``hi`` and its ``unit``; with ``desirability``,
        ``"desirability_levels"`` (per factor the ``level`` and ``setting`` of the desirability optimum) and
        ``"desirability_predicted"`` (per response ``value``, ``lo``, ``hi``, ``unit``, the goal's ``d``; its
        ``attrs["overall"]`` is D).

    Raises
    ------
    BerryshakerError
        An unreadable sheet, a response it lacks, a response named in both senses, or none named.

    Examples
    --------
    >>> from berryshaker import api
    >>> tables = api.analyze_field_sheet("sheet.csv", maximize="efficiency",
    ...                                  minimize=["unripe", "damage"])  # doctest: +SKIP
    >>> tables["range_efficiency"]["R [kg/min]"].idxmax()  # the factor that matters most  # doctest: +SKIP
    """
    from berryshaker.experiment.field_results import analyze_sheet
    from berryshaker.report.table_files import doe_tables

    up, down = _names(maximize, "maximize"), _names(minimize, "minimize")
    both = sorted(set(up) & set(down))
    if both:
        raise ConfigError(f"{', '.join(both)} is named in both maximize and minimize; name it once")
    senses = {**{r: True for r in up}, **{r: False for r in down}}
    if not senses:
        raise ConfigError("name at least one response in maximize or minimize, e.g. maximize='efficiency', "
                          "minimize=['unripe', 'damage']")
    if isinstance(sheet, pd.DataFrame):
        sheet = sheet.to_csv(index=False)
    elif isinstance(sheet, Path):
        sheet = str(sheet)
    _, res = analyze_sheet(sheet, senses, dict(weights) if weights is not None else None, sheet=worksheet,
                           desirability=desirability)
    out = {}
    units = res.response_units or {}
    for stem, (header, rows) in doe_tables(res).items():
        if stem == "optimum":
            continue
        unit = units.get(stem.removeprefix("range_")) or "1"
        names = ["factor"] + [_bracket_units(h) if "(" in h else f"{h} [{unit}]" for h in header[1:-4]]
        names += [f"R [{unit}]", "best_level", "anova_F [1]", "p [1]"]
        df = pd.DataFrame(rows, columns=names).set_index("factor")
        df["anova_F [1]"] = pd.to_numeric(df["anova_F [1]"].replace("pooled", np.nan))
        df["p [1]"] = pd.to_numeric(df["p [1]"])
        out[stem] = df
    o = res.optimum
    out["optimum_levels"] = pd.DataFrame(
        [{"factor": f, "level": n, "setting": o.settings.get(f)} for f, n in o.levels.items()],
        columns=["factor", "level", "setting"]).astype({"level": "Int64"}).set_index("factor")
    iv = o.intervals or {}
    out["optimum_predicted"] = pd.DataFrame(
        [{"response": r, "value": v, "lo": iv.get(r, [np.nan, np.nan])[0], "hi": iv.get(r, [np.nan, np.nan])[1],
          "unit": units.get(r, "")} for r, v in o.values.items()],
        columns=["response", "value", "lo", "hi", "unit"]).set_index("response")
    d = res.desirability
    if d is not None:
        out["desirability_levels"] = pd.DataFrame(
            [{"factor": f, "level": n, "setting": d.settings.get(f)} for f, n in d.levels.items()],
            columns=["factor", "level", "setting"]).astype({"level": "Int64"}).set_index("factor")
        out["desirability_predicted"] = pd.DataFrame(
            [{"response": r, "value": v, "lo": d.intervals[r][0], "hi": d.intervals[r][1], "unit": units.get(r, ""),
              "d": d.desirability[r]} for r, v in d.values.items()],
            columns=["response", "value", "lo", "hi", "unit", "d"]).set_index("response")
        out["desirability_predicted"].attrs["overall"] = d.overall
    return out


# ---- validation ------------------------------------------------------------------------------------------
def validate(machine, replicates: int | None = None, workers: int | None = None, cache: str | Path | None = None,
             progress: bool = False) -> pd.DataFrame:
    """The harvest model against the published record, as ``berryshaker validate``: one row per published number.

    A thin call of :func:`berryshaker.study.validation.validate` through a
    :class:`berryshaker.runs.runner.SweepRunner`.  Cost: every case is ``replicates`` coupled machine-plant
    runs (multibody drive past the explicit bush), minutes on the reference machine over two cores; the runs are
    cached, so a repeated call is fast.

    Parameters
    ----------
    machine : MachineBase
        A machine description with a ``[plant]`` block (:func:`~berryshaker.api.load_machine`).
    replicates : int, optional
        Perturbed starts per case (default ``harvest.replicates`` of the description).
    workers : int, optional
        Local processes (default every core this process may run on).
    cache : str or Path, optional
        Run cache folder (default ``~/.cache/berryshaker/runs`` or ``$BERRYSHAKER_CACHE``).
    progress : bool
        Show a progress bar on stderr.

    Returns
    -------
    pandas.DataFrame
        One row per published number (index ``id``): ``quantity``, ``case``, ``source`` (citation),
        ``source_key``, ``unit`` (the unit of that row's numbers, which differ from row to row), ``published``,
        ``model``, ``lo``, ``hi`` (the interval the verdict uses), ``noise_lo``, ``noise_hi`` (start-to-start noise
        only), all in the row's ``unit`` (NaN where the model does not represent the number), ``verdict``,
        ``held_out``, ``how`` and ``confidence``.  ``attrs["summary"]`` counts the verdicts of the held-out rows;
        ``attrs["replicates"]`` is the starts per case.

    Raises
    ------
    BerryshakerError
        A description without a ``[plant]`` block.

    Examples
    --------
    >>> from berryshaker import api
    >>> rows = api.validate(api.load_machine())  # minutes: coupled runs  # doctest: +SKIP
    >>> rows["verdict"].value_counts()  # doctest: +SKIP
    """
    from berryshaker.errors import BerryshakerError
    from berryshaker.runs.runner import SweepRunner
    from berryshaker.study.validation import validate as run_validation

    if machine.plant is None:
        raise BerryshakerError("validate needs a [plant] block in the machine description (the harvest model runs "
                               "on it); add one, e.g. from the reference machine (berryshaker config init)")
    with SweepRunner(workers=workers, cache_dir=cache, progress=progress) as runner:
        res = run_validation(machine, runner, replicates)
    df = pd.DataFrame(res["rows"])
    first = ["id", "quantity", "case", "source", "source_key", "unit", "published", "model", "lo", "hi", "noise_lo",
             "noise_hi", "verdict", "held_out", "how", "confidence"]
    df = df[[c for c in first if c in df.columns] + [c for c in df.columns if c not in first]]
    for c in ("published", "model", "lo", "hi", "noise_lo", "noise_hi"):
        if c in df.columns:
            df[c] = pd.to_numeric(df[c], errors="coerce")
    df = df.set_index("id")
    df.attrs["summary"] = res["summary"]
    df.attrs["replicates"] = res["replicates"]
    return df
