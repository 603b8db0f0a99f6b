"""The model record: the arrays of a compiled mechanism that every compiled function of the engine takes, by
name.

:func:`berryshaker.multibody.compiled.compile_mechanism` builds it; everything reads its fields by name
(``model.ctype``).  It is a :class:`typing.NamedTuple`: numba takes it as a heterogeneous named tuple, whose
attribute reads compile to the same static item reads as the positional tuple it replaced (the
outputs are bitwise those of the tuple), and positional reads (``model[13]``) keep working for code that has not
moved to the names.
:func:`berryshaker.multibody.dispatch._type_key` knows the record, so calls through
:func:`~berryshaker.multibody.dispatch.call_compiled` skip numba's typing of it as they did of the tuple.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class MechanismModel(NamedTuple):
    """The compiled mechanism's arrays (SI), in the order of the positional tuple they replace (``model[0]`` is
    ``mass``, ``model[16]`` is ``plan``).

    Attributes
    ----------
    mass : numpy.ndarray
        Each body's mass (kg).
    inertia : numpy.ndarray
        Each body's moment of inertia about its centre of mass (kg m^2).
    gravity : numpy.ndarray
        Gravity, x and y (m/s^2).
    ctype : numpy.ndarray of int
        Type of each constraint block (``layout.CON_*``).
    cint, cflt : numpy.ndarray
        The constraint blocks' integer and float records (``layout.CI_*``, ``layout.CF_*``; SI).
    crow : numpy.ndarray of int
        First constraint row of each block.
    ftype : numpy.ndarray of int
        Type of each force element (``layout.FRC_*``).
    fint, fflt : numpy.ndarray
        The force elements' integer and float records (``layout.FI_*``, ``layout.FF_*``; SI).
    cams : numpy.ndarray
        A row per cam (``layout.CAM_*``; lengths m, angles rad).
    modal_w, modal_z : numpy.ndarray
        Natural angular frequency (rad/s) and damping ratio (dimensionless) of each mode of the modal body.
    phi_tab : numpy.ndarray
        Mode shapes at the modal body's contact stations (m per unit modal coordinate), a row per station.
    plant_p : numpy.ndarray
        The drive-past (``layout.PLANT_*``: speed m/s, start m, half span m, ramp m, ramp depth m).
    laws : tuple
        The registered contact laws' compiled functions (:func:`berryshaker.contact.laws.law_table`).
    plan : numpy.ndarray of int
        The multiplier solve's plan (:func:`berryshaker.multibody.sparsity.solve_plan`).
    """

    mass: np.ndarray
    inertia: np.ndarray
    gravity: np.ndarray
    ctype: np.ndarray
    cint: np.ndarray
    cflt: np.ndarray
    crow: np.ndarray
    ftype: np.ndarray
    fint: np.ndarray
    fflt: np.ndarray
    cams: np.ndarray
    modal_w: np.ndarray
    modal_z: np.ndarray
    phi_tab: np.ndarray
    plant_p: np.ndarray
    laws: tuple
    plan: np.ndarray
