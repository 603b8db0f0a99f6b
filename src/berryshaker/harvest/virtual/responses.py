"""The harvest responses: one table (:data:`RESPONSES`) that the virtual harvest, the L9 and its trade-off, the
validation, ``calibrate``, the report and the command line all read, and the tally of a harvested stretch every
response is computed from.

A **tally** (:class:`Tally`) is what a field test weighs: the ripe and unripe fruit mass on the stretch the machine
passed, the part of each it picked, the picked mass that is bruised, and the time it took.  A **response** is a
function of a tally (its row of :data:`RESPONSES`: name, unit, direction, resolution, definition).  The same function
gives the model's expectation (a tally of expected masses, :func:`berryshaker.harvest.virtual.field_test.expected_tally`)
and one field result (a tally of counted fruit, :func:`berryshaker.harvest.virtual.field_test.field_tally`).

The study's indexes (Lyu et al. 2024, sec. 2.6): picking efficiency = picked mass / test time (kg/min); unripe
(shedding) rate = unripe picked mass / picked mass (%), unripe meaning green, pink and red fruit, what a field test
counts as unripe (berryshaker.harvest.ripeness); damage rate = damaged mass / picked mass (%); the shaker
literature's removal fractions (ripe removal = ripe picked / ripe on the bush, unripe shed = unripe picked / unripe on
the bush, %) beside them.

Adding a response: one :func:`register_response` call (its value a function of the tally's fields, vectorised);
every consumer lists :data:`RESPONSES`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np


@dataclass(frozen=True)
class Tally:
    """Masses of a harvested stretch (kg) and its duration (s); fields may be arrays of equal shape (one tally per
    element: starts, parameter points).

    Attributes
    ----------
    ripe : float or numpy.ndarray
        Ripe fruit mass on the stretch (kg).
    unripe : float or numpy.ndarray
        Unripe fruit mass on the stretch (kg).
    ripe_picked : float or numpy.ndarray
        Ripe mass detached (kg).
    unripe_picked : float or numpy.ndarray
        Unripe mass detached (kg).
    damaged : float or numpy.ndarray
        Detached mass that is bruised (kg).
    duration : float or numpy.ndarray
        Time the machine took over the stretch (s).
    """

    ripe: float | np.ndarray
    unripe: float | np.ndarray
    ripe_picked: float | np.ndarray
    unripe_picked: float | np.ndarray
    damaged: float | np.ndarray
    duration: float | np.ndarray

    @property
    def picked(self):
        """Detached mass, ripe and unripe (kg)."""
        return self.ripe_picked + self.unripe_picked


def _ratio(num, den, scale=100.0):
    num, den = np.asarray(num, float), np.asarray(den, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(den > 0, scale * num / np.where(den > 0, den, 1.0), np.nan)
    return out if out.ndim else float(out)


@dataclass(frozen=True)
class HarvestResponse:
    """One harvest response: a row of :data:`RESPONSES`.

    Attributes
    ----------
    name : str
        Name (a sheet column, a ``--maximize`` value, a JSON key).
    unit : str
        Unit of its values ("kg/min", "%").
    maximize : bool
        Whether larger is better.
    resolution : float
        Smallest meaningful value in its unit: a mean below it is "none" (a relative precision target is not chased
        below it).
    label : str
        Short label for tables and figures.
    definition : str
        What it is, in words.
    value : callable
        ``value(tally) -> float or numpy.ndarray`` (the unit above; NaN where undefined, e.g. a rate of nothing picked).
    study_index : bool
        One of the study's three indexes (its Table 8, the field sheet's default responses).
    calibrated : bool
        A field sheet's column of this name is calibrated against (``berryshaker calibrate``).
    floor : float
        Floor c of the calibration emulator's log(mean + c) (its unit): keeps a near-zero rate, a count of a few fruit,
        from dominating the log scale.
    column : str
        Its column in wide tables (sweeps, the harvest-response rows): the name with its unit, e.g.
        ``efficiency_kg_min`` (default ``<name>_<unit>``).
    """

    name: str
    unit: str
    maximize: bool
    resolution: float
    label: str
    definition: str
    value: Callable
    study_index: bool = False
    calibrated: bool = False
    floor: float = 0.5
    column: str = ""

    def __post_init__(self):
        if not self.column:
            unit = self.unit.replace("%", "pct").replace("/", "_").replace(" ", "_")
            object.__setattr__(self, "column", f"{self.name}_{unit}")


#: the harvest responses, in the order they are reported
RESPONSES: dict[str, HarvestResponse] = {}


def register_response(response: HarvestResponse) -> HarvestResponse:
    """Add a response to :data:`RESPONSES` (a name already there is an error).

    Parameters
    ----------
    response : HarvestResponse
        The row.

    Returns
    -------
    HarvestResponse
        The row, registered.
    """
    if response.name in RESPONSES:
        raise ValueError(f"harvest response {response.name!r} is already registered")
    RESPONSES[response.name] = response
    return response


register_response(HarvestResponse(
    "efficiency", "kg/min", True, 0.01, "picking efficiency",
    "picked mass (ripe and unripe) per minute of harvesting (the study's Y1)",
    lambda t: _ratio(t.picked, t.duration, 60.0), study_index=True, calibrated=True, floor=0.05,
    column="efficiency_kg_min"))
register_response(HarvestResponse(
    "ripe_removal", "%", True, 0.05, "ripe removal",
    "ripe mass detached / ripe mass on the stretch", lambda t: _ratio(t.ripe_picked, t.ripe)))
register_response(HarvestResponse(
    "unripe", "%", False, 0.05, "unripe rate",
    "unripe (green, pink and red) mass detached / mass detached (the study's Y2)",
    lambda t: _ratio(t.unripe_picked, t.picked),
    study_index=True, calibrated=True, column="unripe_rate_pct"))
register_response(HarvestResponse(
    "unripe_shed", "%", False, 0.05, "unripe shed",
    "unripe (green, pink and red) mass detached / unripe mass on the stretch",
    lambda t: _ratio(t.unripe_picked, t.unripe)))
register_response(HarvestResponse(
    "damage", "%", False, 0.05, "damage rate",
    "bruised mass / mass detached (the study's Y3)", lambda t: _ratio(t.damaged, t.picked),
    study_index=True, calibrated=True, column="damage_rate_pct"))


def response_values(tally: Tally, names=None) -> dict:
    """Every response (or those named) of a tally.

    Parameters
    ----------
    tally : Tally
        Masses (kg) and duration (s).
    names : iterable of str, optional
        Responses to compute (default all of :data:`RESPONSES`).

    Returns
    -------
    dict
        Name -> value (float, or array of the tally's shape), in the response's unit.
    """
    return {n: RESPONSES[n].value(tally) for n in (RESPONSES if names is None else names)}


def response_units() -> dict[str, str]:
    """Unit of every harvest response.

    Returns
    -------
    dict of str to str
        Name -> unit.
    """
    return {n: r.unit for n, r in RESPONSES.items()}


def response_labels() -> dict[str, str]:
    """Short label of every harvest response (tables, figures).

    Returns
    -------
    dict of str to str
        Name -> label.
    """
    return {n: r.label for n, r in RESPONSES.items()}


def sheet_responses() -> dict[str, str]:
    """The responses a field sheet carries as columns (the study's indexes and every calibrated response): name ->
    column (``efficiency`` -> ``efficiency_kg_min``).

    Returns
    -------
    dict of str to str
        Name -> column, in the table's order.
    """
    return {n: r.column for n, r in RESPONSES.items() if r.study_index or r.calibrated}
