"""The published record: numbers from the literature a harvest model can be checked against.

The data live in ``harvest/published/record.toml`` (package data): a table of sources (full citations, with
the fields that could not be seen listed in ``citation_gaps``) and one ``[[entry]]`` per published number
with its unit, spread, conditions, where in the source it was read and how far to trust it
(``confidence``: ``checked``, ``secondary`` or ``unverified``).  ``docs/published_record.md`` describes every
number.

:func:`load_record` validates the file and returns a :class:`pandas.DataFrame`, one row per entry, with the
printed values and their SI equivalents (read through :func:`berryshaker.units.parse_quantity`, so a unit
slip in the file fails loudly).  :func:`load_sources` returns the citations.  Nothing here computes a model;
``berryshaker validate`` (the lead engineer's) compares model outputs with these rows.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any

import pandas as pd

from berryshaker.errors import ConfigError
from berryshaker.units import DIMENSIONS, parse_quantity

#: schema version of record.toml this module reads
SCHEMA = 1

#: allowed ``confidence`` values: read in the source (its abstract or text), quoted by another source, or a
#: claim that could not be confirmed
CONFIDENCE = ("checked", "secondary", "unverified")

#: allowed ``topic`` values: bond forces, other harvesters' results, bruising, yield, frequency response
TOPICS = ("bond_force", "harvester_result", "bruise", "yield", "frequency_response")

#: dimensions the record uses that :data:`berryshaker.units.DIMENSIONS` does not name, mapped to the one
#: with the same physical dimensionality used for the unit check ("kg/min" is [mass]/[time], like a damping
#: coefficient in kg/s); the SI value is then in kg/s
EXTRA_DIMENSIONS: dict[str, str] = {"mass_flow": "damping"}

#: citation fields every source carries (an empty or zero one must be named in ``citation_gaps``)
CITATION_FIELDS = ("authors", "year", "title", "journal")

#: fields every entry must have
REQUIRED_ENTRY_FIELDS = ("id", "topic", "quantity", "unit", "dimension", "statistic", "source", "where",
                         "confidence")

#: spread and value fields read as numbers in the entry's unit
_NUMBER_FIELDS = ("value", "range_low", "range_high", "sd")

#: columns of the frame :func:`load_record` returns, in order
COLUMNS = ("id", "topic", "quantity", "unit", "dimension", "statistic", "value", "sd", "cv", "range_low",
           "range_high", "n", "value_si", "sd_si", "range_low_si", "range_high_si", "si_unit", "conditions",
           "source", "citation", "where", "confidence", "quoted_by", "note")


def default_path() -> Path:
    """Path of the packaged ``record.toml`` (``berryshaker/harvest/published/record.toml``).

    Returns
    -------
    pathlib.Path
        The file inside the installed package.
    """
    return Path(str(resources.files("berryshaker.harvest").joinpath("published", "record.toml")))


def _read(path: str | Path | None) -> dict[str, Any]:
    file = default_path() if path is None else Path(path)
    try:
        with open(file, "rb") as handle:
            raw = tomllib.load(handle)
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"published record {file}: cannot be read ({exc})") from None
    if raw.get("schema") != SCHEMA:
        raise ConfigError(f"published record {file}: schema {raw.get('schema')!r}, this reader knows {SCHEMA}")
    return raw


def _gaps(source: Mapping[str, Any]) -> list[str]:
    gaps = source.get("citation_gaps", [])
    if not isinstance(gaps, list) or not all(isinstance(g, str) for g in gaps):
        return ["<citation_gaps is not a list of strings>"]
    return gaps


def citation_text(source: Mapping[str, Any]) -> str:
    """One-line citation of a source table: authors (year) title. journal volume(issue), pages. doi.

    Parameters
    ----------
    source : mapping
        One ``[sources.<key>]`` table of the record.

    Returns
    -------
    str
        The citation; missing parts are left out (the record lists them in ``citation_gaps``).
    """
    parts = []
    year = source.get("year")
    parts.append(f"{source.get('authors') or '[authors not seen]'} ({year if year else 'year not seen'})")
    parts.append(source.get("title") or "[title not seen]")
    journal = " ".join(str(source.get(k, "")).strip() for k in ("journal", "volume_issue")).strip()
    if journal:
        parts.append(journal + (f", {source['pages']}" if source.get("pages") else ""))
    if source.get("doi"):
        parts.append(f"doi:{source['doi']}")
    elif source.get("url"):
        parts.append(str(source["url"]))
    return ". ".join(parts)


def check_sources(sources: Mapping[str, Mapping[str, Any]]) -> list[str]:
    """Problems with the source tables: a citation field empty without being named in ``citation_gaps``.

    Parameters
    ----------
    sources : mapping
        The ``sources`` table of the record, key -> source table.

    Returns
    -------
    list of str
        One message per problem; empty when every citation is complete or its gaps are declared.
    """
    problems = []
    for key, source in sources.items():
        gaps = " ".join(_gaps(source))
        if "<" in gaps:
            problems.append(f"source {key}: citation_gaps must be a list of strings")
        for field in CITATION_FIELDS:
            value = source.get(field)
            missing = value is None or (isinstance(value, str) and not value.strip()) or value == 0
            if missing and field not in gaps:
                problems.append(f"source {key}: {field} is empty and not listed in citation_gaps")
        year = source.get("year", 0)
        if not isinstance(year, int) or (year != 0 and not 1900 <= year <= 2100):
            problems.append(f"source {key}: year {year!r} is not a year")
        if not (source.get("doi") or source.get("url")) and "url" not in gaps:
            problems.append(f"source {key}: neither a doi nor a url, and url not listed in citation_gaps")
    return problems


def _number(entry: Mapping[str, Any], field: str, problems: list[str]) -> float:
    value = entry.get(field)
    if value is None:
        return math.nan
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        problems.append(f"entry {entry.get('id')}: {field} = {value!r} is not a finite number")
        return math.nan
    return float(value)


def _si(entry: Mapping[str, Any], value: float, problems: list[str]) -> float:
    """SI value of a number printed in the entry's unit, through the strict unit grammar."""
    if math.isnan(value):
        return math.nan
    dimension = EXTRA_DIMENSIONS.get(entry["dimension"], entry["dimension"])
    unit = str(entry["unit"]).strip()
    try:
        if not unit:
            if dimension != "dimensionless":
                raise ConfigError(f"an empty unit is only allowed for a dimensionless quantity, not {dimension}")
            return float(value)
        return parse_quantity(f"{value!r} {unit}", dimension, field=str(entry.get("id")))
    except ConfigError as exc:
        problems.append(f"entry {entry.get('id')}: {exc}")
        return math.nan


def _si_unit(dimension: str) -> str:
    if dimension == "mass_flow":
        return "kg/s"
    return DIMENSIONS[dimension][1] if dimension in DIMENSIONS else "?"


def check_entry(entry: Mapping[str, Any], sources: Mapping[str, Any]) -> tuple[dict[str, Any], list[str]]:
    """Validate one ``[[entry]]`` and build its row.

    Parameters
    ----------
    entry : mapping
        One ``[[entry]]`` table.
    sources : mapping
        The record's ``sources`` table (the entry's ``source`` must be one of its keys).

    Returns
    -------
    row : dict
        The entry's fields with SI values (``value_si``, ``sd_si``, ``range_low_si``, ``range_high_si``) and
        the source's one-line citation.
    problems : list of str
        What is missing or inconsistent: a required field, an unknown topic / confidence / dimension / source,
        a unit that does not measure the declared dimension, no value and no range, ``range_low > value`` or
        ``value > range_high``, a negative SD, a CV outside [0, 10], ``n`` not a positive integer, a
        ``secondary`` entry without ``quoted_by``, an ``unverified`` one without a note saying where it comes
        from.
    """
    problems: list[str] = []
    name = entry.get("id", "<no id>")
    for field in REQUIRED_ENTRY_FIELDS:
        if field not in entry or (isinstance(entry[field], str) and not entry[field].strip()
                                  and field != "unit"):
            problems.append(f"entry {name}: missing {field}")
    if problems:
        return {}, problems
    if entry["topic"] not in TOPICS:
        problems.append(f"entry {name}: topic {entry['topic']!r} is not one of {TOPICS}")
    if entry["confidence"] not in CONFIDENCE:
        problems.append(f"entry {name}: confidence {entry['confidence']!r} is not one of {CONFIDENCE}")
    if entry["dimension"] not in DIMENSIONS and entry["dimension"] not in EXTRA_DIMENSIONS:
        problems.append(f"entry {name}: dimension {entry['dimension']!r} is not a berryshaker dimension")
        return {}, problems
    if entry["source"] not in sources:
        problems.append(f"entry {name}: source {entry['source']!r} is not in [sources]")
    if entry["confidence"] == "secondary" and not entry.get("quoted_by"):
        problems.append(f"entry {name}: a secondary number must say who quotes it (quoted_by)")
    if entry["confidence"] == "unverified" and not entry.get("note"):
        problems.append(f"entry {name}: an unverified number must say where the claim comes from (note)")
    numbers = {field: _number(entry, field, problems) for field in _NUMBER_FIELDS}
    value, low, high, sd = (numbers[f] for f in _NUMBER_FIELDS)
    cv = _number(entry, "cv", problems)
    if math.isnan(value) and (math.isnan(low) or math.isnan(high)):
        problems.append(f"entry {name}: needs a value or a full range (range_low and range_high)")
    if not math.isnan(low) and not math.isnan(high) and low > high:
        problems.append(f"entry {name}: range_low {low} > range_high {high}")
    if not math.isnan(value) and not math.isnan(low) and value < low:
        problems.append(f"entry {name}: value {value} < range_low {low}")
    if not math.isnan(value) and not math.isnan(high) and value > high:
        problems.append(f"entry {name}: value {value} > range_high {high}")
    if not math.isnan(sd) and sd < 0:
        problems.append(f"entry {name}: sd {sd} is negative")
    if not math.isnan(cv) and not 0 <= cv <= 10:
        problems.append(f"entry {name}: cv {cv} is not a coefficient of variation (a fraction, 0-10)")
    n = entry.get("n")
    if n is not None and (isinstance(n, bool) or not isinstance(n, int) or n < 1):
        problems.append(f"entry {name}: n = {n!r} is not a positive count")
    conditions = entry.get("conditions", {})
    if not isinstance(conditions, dict):
        problems.append(f"entry {name}: conditions must be a table")
        conditions = {}
    si = {f"{field}_si": _si(entry, numbers[field], problems) for field in _NUMBER_FIELDS}
    source = sources.get(entry["source"], {})
    row = {field: entry.get(field) for field in ("id", "topic", "quantity", "unit", "dimension", "statistic",
                                                 "source", "where", "confidence")}
    row.update(numbers)
    row.update(si)
    row.update(cv=cv, n=n, si_unit=_si_unit(entry["dimension"]), conditions=dict(conditions),
               citation=citation_text(source) if source else "", quoted_by=entry.get("quoted_by", ""),
               note=entry.get("note", ""))
    return row, problems


def load_sources(path: str | Path | None = None) -> dict[str, dict[str, Any]]:
    """The record's sources, key -> citation table, after checking every citation.

    Parameters
    ----------
    path : str or pathlib.Path, optional
        A record file; default the packaged ``record.toml``.

    Returns
    -------
    dict
        ``{key: {"authors", "year", "title", "journal", "volume_issue", "pages", "doi", "url", "read",
        "citation_gaps", "citation"}}``; ``citation`` is the one-line text of :func:`citation_text`.

    Raises
    ------
    berryshaker.errors.ConfigError
        The file cannot be read, has another schema, or a citation field is empty without being declared a
        gap.
    """
    raw = _read(path)
    sources = raw.get("sources", {})
    problems = check_sources(sources)
    if problems:
        raise ConfigError("published record: " + "; ".join(problems))
    return {key: {**dict(src), "citation": citation_text(src)} for key, src in sources.items()}


def load_record(path: str | Path | None = None) -> pd.DataFrame:
    """Read and validate the published record; one row per published number.

    Parameters
    ----------
    path : str or pathlib.Path, optional
        A record file; default the packaged ``record.toml``.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`COLUMNS`: the printed ``value``, ``sd``, ``range_low``, ``range_high`` in ``unit``
        (NaN where not reported), ``cv`` (a fraction), ``n`` (None where not reported), their SI values
        (``*_si``, in ``si_unit``; percentages become fractions), ``conditions`` (a dict: cultivar, ripeness,
        loading mode, frequency, surface...), ``source`` (key of :func:`load_sources`), ``citation``,
        ``where``, ``confidence``, ``quoted_by`` and ``note``.  Indexed by ``id``, in file order.

    Raises
    ------
    berryshaker.errors.ConfigError
        Every problem found (see :func:`check_entry`, :func:`check_sources`), all in one message; or
        duplicate ids.
    """
    raw = _read(path)
    sources = raw.get("sources", {})
    entries = raw.get("entry", [])
    problems = check_sources(sources)
    rows = []
    seen: set[str] = set()
    for entry in entries:
        row, entry_problems = check_entry(entry, sources)
        problems.extend(entry_problems)
        name = entry.get("id")
        if name in seen:
            problems.append(f"entry {name}: duplicate id")
        seen.add(name)
        if row:
            rows.append(row)
    if not entries:
        problems.append("no [[entry]] in the record")
    if problems:
        raise ConfigError("published record: " + "; ".join(problems))
    frame = pd.DataFrame(rows, columns=list(COLUMNS))
    return frame.set_index("id", drop=False)
