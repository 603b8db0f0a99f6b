"""The Python API: berryshaker for engineers working in Python or Jupyter, results as pandas objects.

Each function is a thin call of the library function the matching command of ``berryshaker --help`` uses (the
same numbers as the command's ``--json``), its result laid out as a :class:`pandas.DataFrame` whose column names
carry their units in brackets, e.g. ``"peak_force [N]"`` or ``"clearance.A.size [mm]"``: SI unless the bracket
names an engineering unit (mm, deg, um, h, %, kg/min).  ``[1]`` is a dimensionless number; a column without
brackets holds names, flags or counts.  Nothing here computes physics of its own.

===========================  ===========================  ======================================================
function                     command                      cost
===========================  ===========================  ======================================================
:func:`load_machine`         ``--config FILE``            milliseconds
:func:`kinematics`           ``kinematics``               about 0.1 s
:func:`simulate`             ``simulate``                 about 0.2 s per revolution (mlsd); seconds (multibody)
:func:`sweep`                ``sweep``                    one simulation per point, cached, in parallel
:func:`fit_table`            ``fits``                     milliseconds
:func:`service_limits`       (``wear``'s default limits)  milliseconds
:func:`wear`                 ``wear``                     several multibody runs (cached): tens of seconds
:func:`plan_field_sheet`     ``doe plan``                 milliseconds
:func:`analyze_field_sheet`  ``doe analyze``              under a second
:func:`validate`             ``validate``                 coupled machine-plant runs: minutes
===========================  ===========================  ======================================================

Docs: docs/python_api.md; a worked example: examples/gallery/plot_05_python_api.py.

The functions live by area, all importable from here: :mod:`.simulation` (kinematics, simulate, sweep),
:mod:`.life` (fit_table, service_limits, wear), :mod:`.field` (plan_field_sheet, analyze_field_sheet, validate);
:mod:`.names` lays out argument name lists and column names with their units.
"""

from __future__ import annotations

from berryshaker.api.field import analyze_field_sheet, plan_field_sheet, validate
from berryshaker.api.life import fit_table, service_limits, wear
from berryshaker.api.simulation import kinematics, simulate, sweep
from berryshaker.config import load_machine

__all__ = ["analyze_field_sheet", "fit_table", "kinematics", "load_machine", "plan_field_sheet", "service_limits",
           "simulate", "sweep", "validate", "wear"]
