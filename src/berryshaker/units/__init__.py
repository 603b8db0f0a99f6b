"""Strict, unit-aware reading of every quantity a user types ("0.25 mm", "120 rpm", "1.1 GPa", "30 m/min").

Inside berryshaker every number is SI (m, kg, s, rad, N).  Machine files and the command line give every
dimensional value as a string "number unit"; a bare number is an error there (``units_required``: the message
shows the fix, ``speed = "120 rpm"``), and only dimensionless values (coefficients, fractions, counts, ratios)
are plain numbers.  Inside the package (descriptions rebuilt from their SI dump) a plain number is SI.  This
module is the one entry point for every field, option and sheet cell:

* :func:`parse_quantity` reads one value, checks its physical dimension and returns an SI float
  (:mod:`berryshaker.units.parsing`: the grammar, the dimension table, single values and units);
  :func:`check_limits` and :data:`LIMITS` bound it to what berryshaker can compute with
  (:mod:`berryshaker.units.limits`).
* :func:`parse_value_list` reads sweep / command-line value lists (``0.1..0.3mm``, ``100,120,140rpm``,
  ``0.25mm+-0.05mm``) into a :class:`ValueSpec` (:mod:`berryshaker.units.value_lists`).
* :data:`PLAUSIBLE`, :func:`plausible_range` and :func:`plausibility_warning` flag values that are orders
  of magnitude away from anything a harvester drive has (a unit slip such as metres for millimetres;
  :mod:`berryshaker.units.limits`).
* :func:`format_quantity` and :data:`ENGINEERING_FACTORS` print SI values in engineering units
  (:mod:`berryshaker.units.formatting`).

Every public name of those modules is importable from ``berryshaker.units``.

Safety rules (issue "never compute on a misread input"):

* No expression evaluation.  A string is accepted only as ``[sign] decimal-number [exponent] [unit]`` where
  the unit is unit names joined by ``*``, ``/``, ``·`` or spaces, with small integer powers (``^2``, ``**-1``,
  ``²``) and at most one level of parentheses.  No decimal comma ("1,5 kW" is refused, not read as 15 kW).  The grammar is checked by a tokeniser (:mod:`berryshaker.units.parsing`); pint (a maintained
  units library) is only asked to look up single unit *names* (``ureg.Unit("mm")``), never to evaluate the
  raw text, so ``"9**9**9 mm"`` is refused at once instead of hanging.  Input length is bounded.
* Only linear (multiplicative) units are accepted: offset and logarithmic units (degC, dB) are refused.
* Angles and angular speeds: pint treats the radian as dimensionless, so "2 Hz" (= 2/s) would silently become
  2 rad/s.  Here, for an ``angular_speed``, a unit without an angle in it (``Hz``, ``1/s``, ``s^-1``, ``1/min``)
  counts **revolutions** per time, like ``rps`` and ``rpm``: "2 Hz" is 2 rev/s = 4 pi rad/s.  ``rad/s`` and
  ``deg/s`` are taken as written.  An ``angle`` string must carry an angle unit ("180 deg", "3.1 rad",
  "0.5 turn"); "180" alone is refused.  A plain number (not a string) given inside the package stays SI
  (rad, rad/s); in a machine file it is refused (``units_required``).
* ``dimensionless`` takes plain numbers and percentages ("5 %" -> 0.05).
"""

from berryshaker.units.formatting import ENGINEERING_FACTORS, format_quantity, format_tolerance
from berryshaker.units.limits import LIMITS, PLAUSIBLE, check_limits, plausibility_warning, plausible_range
from berryshaker.units.parsing import (
    DIMENSIONS,
    DISPLAY_UNITS,
    EXAMPLES,
    MAX_LIST_CHARS,
    MAX_QUANTITY_CHARS,
    MAX_UNIT_POWER,
    UNIT_ALIASES,
    bare_number_message,
    parse_quantity,
    parse_unit,
    unit_dimension,
    unit_factor,
)
from berryshaker.units.value_lists import ValueSpec, parse_value_list

__all__ = [
    "DIMENSIONS", "DISPLAY_UNITS", "ENGINEERING_FACTORS", "EXAMPLES", "LIMITS", "MAX_LIST_CHARS",
    "MAX_QUANTITY_CHARS", "MAX_UNIT_POWER", "PLAUSIBLE", "UNIT_ALIASES", "ValueSpec", "bare_number_message",
    "check_limits", "format_quantity", "format_tolerance", "parse_quantity", "parse_unit", "parse_value_list",
    "plausibility_warning", "plausible_range", "unit_dimension", "unit_factor",
]
