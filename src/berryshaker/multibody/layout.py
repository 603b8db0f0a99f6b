"""The array layout of a compiled mechanism: type codes and named slots of its parameter records.

The compiled core (docs/multibody.md) takes a mechanism as flat arrays, one row per constraint block and per force
element, because numba reads a row of a float array far faster than any object: ``cint`` / ``cflt`` for the
constraints, ``fint`` / ``fflt`` for the force elements (integer and float parameters).  Each row is a *record* whose
fields are the named slots below, and every element type has its own record (:data:`CONSTRAINT_RECORDS`,
:data:`FORCE_RECORDS`): a slot's name says what is stored there.  Two element types that store different things
at the same index use different names (a pin in a bore keeps its bore centre where a modal-body contact keeps its
row offset); a name is shared only where the meaning is (the contact law's parameters of every contact element,
the pin centre of every clearance joint).  :func:`force_record` and :func:`constraint_record` fill a row from
slot names and refuse a slot that is not in the element type's record; tests/multibody/test_engine.py checks that no two
slots of a record overlap and that each compiled element function reads only its own record's slots.

Also here: the layout of the element outputs, of the integrator's ``info``, ``first`` and ``resume`` arrays, of a
cam's row and of the modal body's drive-past parameters.  This module does not import numba (the description
checks read :data:`MAX_TABLE` without compiling anything), but numba freezes its slots into the compiled core as
constants: its mention of numba puts it in the compiled sources' digest
(:func:`berryshaker.compiled_cache.compiled_sources_digest`), so a change of a slot recompiles the core.
"""

from __future__ import annotations

import numpy as np

# --- constraints -------------------------------------------------------------------------------------------------
CON_REVOLUTE, CON_PRISMATIC, CON_POINT_LINE, CON_CAM_ROLLER, CON_DRIVER = 1, 2, 3, 4, 5
#: rows of each constraint type's block
CON_ROWS = {CON_REVOLUTE: 2, CON_PRISMATIC: 2, CON_POINT_LINE: 1, CON_CAM_ROLLER: 1, CON_DRIVER: 1}

# integer slots of a constraint block (``cint``): its two bodies (-1: ground) and the cam of a cam-roller joint
CI_BODY_I, CI_BODY_J, CI_CAM = 0, 1, 2
N_CI = 3
# float slots of a constraint block (``cflt``): the joint points on bodies i and j (body frames), the line's unit
# axis (prismatic: in body i's frame, the line through s_i; point on line: in body j's frame, through s_j), the
# prismatic joint's relative angle phi_j - phi_i, a driver's angle at t = 0 and speed (rad/s), and the prismatic
# guide's friction coefficient and its two supports' positions along the axis
CF_SIX, CF_SIY, CF_SJX, CF_SJY, CF_UX, CF_UY = range(6)
CF_REL_ANGLE, CF_MU, CF_XIG, CF_XIH = 6, 8, 9, 10  # prismatic
CF_ANGLE0, CF_SPEED = 6, 7  # driver
N_CF = 12

#: the slots each constraint type reads (besides its rows, ``crow``; the block's two bodies are read for every block)
CONSTRAINT_RECORDS = {
    CON_REVOLUTE: ("CI_BODY_I", "CI_BODY_J", "CF_SIX", "CF_SIY", "CF_SJX", "CF_SJY"),
    CON_PRISMATIC: ("CI_BODY_I", "CI_BODY_J", "CF_SIX", "CF_SIY", "CF_SJX", "CF_SJY", "CF_UX", "CF_UY",
                    "CF_REL_ANGLE", "CF_MU", "CF_XIG", "CF_XIH"),
    CON_POINT_LINE: ("CI_BODY_I", "CI_BODY_J", "CF_SIX", "CF_SIY", "CF_SJX", "CF_SJY", "CF_UX", "CF_UY"),
    CON_CAM_ROLLER: ("CI_BODY_I", "CI_BODY_J", "CI_CAM", "CF_SIX", "CF_SIY"),
    CON_DRIVER: ("CI_BODY_I", "CI_BODY_J", "CF_ANGLE0", "CF_SPEED"),  # body j: the ground (-1)
}

# --- force elements ----------------------------------------------------------------------------------------------
FRC_REV_CL, FRC_SLOT_CL, FRC_GROOVE_CL = 11, 12, 13  # clearance joints: pin in bore, pin in slot, roller in groove
FRC_ROT_SD, FRC_TORQUE, FRC_FORCE = 20, 21, 22  # rotational spring-damper, constant torque, constant point force
# powered drives (docs/multibody.md "Powered drives"): a torque-speed source on body i (reaction on body j or
# ground), T = table(w_i - w_j) with linear interpolation and end values held; and a geared torsional
# spring-damper from body i (input) to body j (output) with ratio r = w_i / w_j, efficiencies by the direction of
# power flow, belt creep and a slip cap, whose windup psi is an element state (an auxiliary coordinate)
FRC_TORQUE_SPEED, FRC_GEAR_SD = 23, 24
FRC_BRANCH = 30  # a point of a body striking a modal body (a branch of the plant)
#: the force elements that are contacts (a normal law of berryshaker.contact, onsets located by the integrator)
CONTACT_TYPES = (FRC_REV_CL, FRC_SLOT_CL, FRC_GROOVE_CL, FRC_BRANCH)

# integer slots of a force element (``fint``)
FI_BODY_I = 0  # the body the element acts on (every type)
FI_BODY_J = 1  # the second body of a two-body element (-1: ground)
FI_CAM = 2  # roller in groove: the cam (row of the cam array) whose groove it runs in
FI_WINDUP = 2  # geared spring-damper: the coordinate of its windup state (whose velocity slot holds psi)
FI_LAW = 3  # contacts: the normal law's number in the registry (berryshaker.contact.laws)
FI_BRANCH_ROW = 1  # modal-body contact: its row of the mode-shape table (its station on the branch)
FI_BRANCH_MODE0, FI_BRANCH_MODE_END = 2, 4  # modal-body contact: that row's nonzero columns (its member's modes)
N_FI = 5

# float slots of a force element (``fflt``)
# the contact law (every contact): the law's parameters (berryshaker.contact.laws) and whether its force never
# decreases as the penetration or its rate grows (1.0; the registry's ``monotone`` flag)
FF_K, FF_N, FF_E, FF_C, FF_D = 7, 8, 9, 10, 11
FF_MONOTONE = 15
# clearance joints (pin in bore, pin in slot, roller in groove): the pin's (roller's) centre on body i, the joint's
# clearance (radial for a pin in a bore, the total free travel of a slot or groove), Coulomb friction coefficient
FF_PIN_X, FF_PIN_Y, FF_CLEARANCE, FF_MU = 0, 1, 6, 12
FF_BORE_X, FF_BORE_Y, FF_PIN_RADIUS = 2, 3, 13  # pin in bore: the bore's centre on body j, the pin's radius
FF_SLOT_X, FF_SLOT_Y, FF_SLOT_UX, FF_SLOT_UY = 2, 3, 4, 5  # pin in slot: a point of its centre line, its unit axis
# modal-body contact: the striking point on body i, the contact's position along the row (m, added to the plant's
# start distance: a bush of branches at different places), the multiple of the contact force that acts back on the
# striking body (1: two-way; 0: the body is driven, the mechanism feels nothing; w: the contact stands for w like
# branches of a sampled population), the contact's unit axis, its engagement (m), the side it strikes from (+-1)
# and the lateral position of the branch's middle (m)
FF_FINGER_X, FF_FINGER_Y, FF_ROW_OFFSET, FF_REACTION, FF_BRANCH_UX, FF_BRANCH_UY = 0, 1, 2, 3, 4, 5
FF_ENGAGEMENT, FF_SIDE, FF_MID_LATERAL = 6, 13, 14
# rotational spring-damper (T = -k (phi_i - phi_j - phi0) - c (w_i - w_j)): N m/rad, N m s/rad, rad
FF_RSD_K, FF_RSD_C, FF_RSD_ANGLE0 = 7, 10, 14
FF_TORQUE = 15  # constant torque on body i (N m)
FF_POINT_X, FF_POINT_Y, FF_FORCE_X, FF_FORCE_Y = 0, 1, 4, 5  # constant force: its point on body i, components (N)
# torque-speed source: the number of table points, then the speeds (rad/s, increasing) and the torques (N m)
MAX_TABLE = 64  # most points of a torque-speed table
FF_TABLE_N, FF_TABLE_SPEEDS, FF_TABLE_TORQUES = 21, 22, 22 + MAX_TABLE
# geared spring-damper: stiffness (N m/rad) and damping (N m s/rad) of the windup, ratio w_i / w_j, efficiencies
# forward / back-driven, creep compliance (1/(N m)), slip torque (N m, 0: none)
FF_GEAR_K, FF_GEAR_C = 7, 10
FF_RATIO, FF_ETA_F, FF_ETA_B, FF_CREEP, FF_SLIP = 16, 17, 18, 19, 20
N_FF = FF_TABLE_TORQUES + MAX_TABLE
#: slots that hold more than one value: their width
SLOT_WIDTH = {"FF_TABLE_SPEEDS": MAX_TABLE, "FF_TABLE_TORQUES": MAX_TABLE}

_CONTACT_LAW = ("FI_LAW", "FF_K", "FF_N", "FF_E", "FF_C", "FF_D", "FF_MONOTONE")
_CLEARANCE = ("FI_BODY_I", "FI_BODY_J", "FF_PIN_X", "FF_PIN_Y", "FF_CLEARANCE", "FF_MU") + _CONTACT_LAW
#: the slots each force element type reads
FORCE_RECORDS = {
    FRC_REV_CL: _CLEARANCE + ("FF_BORE_X", "FF_BORE_Y", "FF_PIN_RADIUS"),
    FRC_SLOT_CL: _CLEARANCE + ("FF_SLOT_X", "FF_SLOT_Y", "FF_SLOT_UX", "FF_SLOT_UY"),
    FRC_GROOVE_CL: _CLEARANCE + ("FI_CAM",),
    FRC_BRANCH: ("FI_BODY_I", "FI_BRANCH_ROW", "FI_BRANCH_MODE0", "FI_BRANCH_MODE_END", "FF_FINGER_X",
                 "FF_FINGER_Y", "FF_ROW_OFFSET", "FF_REACTION", "FF_BRANCH_UX", "FF_BRANCH_UY", "FF_ENGAGEMENT",
                 "FF_SIDE", "FF_MID_LATERAL") + _CONTACT_LAW,
    FRC_ROT_SD: ("FI_BODY_I", "FI_BODY_J", "FF_RSD_K", "FF_RSD_C", "FF_RSD_ANGLE0"),
    FRC_TORQUE: ("FI_BODY_I", "FF_TORQUE"),
    FRC_FORCE: ("FI_BODY_I", "FF_POINT_X", "FF_POINT_Y", "FF_FORCE_X", "FF_FORCE_Y"),
    FRC_TORQUE_SPEED: ("FI_BODY_I", "FI_BODY_J", "FF_TABLE_N", "FF_TABLE_SPEEDS", "FF_TABLE_TORQUES"),
    FRC_GEAR_SD: ("FI_BODY_I", "FI_BODY_J", "FI_WINDUP", "FF_GEAR_K", "FF_GEAR_C", "FF_RATIO", "FF_ETA_F",
                  "FF_ETA_B", "FF_CREEP", "FF_SLIP"),
}

# element outputs (``eout``, per force element): normal force (or the element's torque), penetration, its rate,
# tangential force (or a geared element's input torque)
EO_FN, EO_PEN, EO_PENDOT, EO_FT = range(4)
N_EO = 4

# a cam's row (``cams``): follower law (berryshaker.kinematics.cam.FOLLOWER_LAWS), stroke, rise, far-dwell and
# return angles, s0 = sqrt(base radius^2 - offset^2), offset
CAM_LAW, CAM_STROKE, CAM_RISE, CAM_FAR, CAM_RETURN, CAM_S0, CAM_OFFSET = range(7)
N_CAM = 7
# the modal body's drive-past (``plant_p``): walking speed (m/s), start distance (m), half span and ramp of the
# reach (m), depth of the ramp (m)
PLANT_SPEED, PLANT_START, PLANT_HALF_SPAN, PLANT_RAMP, PLANT_RAMP_DEPTH = range(5)
N_PLANT = 5

# --- the integrator's outputs and loop state --------------------------------------------------------------------
#: entries of integrate's ``info``; a longer array gets the step-size histogram (STEP_* in step_control)
(INFO_ACCEPTED, INFO_REJECTED, INFO_CUTS, INFO_T_FAIL, INFO_STATUS, INFO_MAX_RESIDUAL) = range(6)
N_INFO = 6
#: ``info[INFO_STATUS]``: finished, step underflow, non-finite state, projection failed, step budget spent, paused
#: at a chunk's end (``resume``)
(STATUS_OK, STATUS_UNDERFLOW, STATUS_NONFINITE, STATUS_PROJECTION, STATUS_BUDGET, STATUS_PAUSED) = range(6)
#: columns of integrate's ``first``: first onset time, its impact velocity, the first episode's peak force, done
#: flag (0 not yet, 1 in the first episode, 2 after it), impacts counted over the statistics window
FIRST_TIME, FIRST_V_IMP, FIRST_PEAK, FIRST_DONE, FIRST_IMPACTS = range(5)
N_FIRST = 5
#: a ``first`` wider than N_FIRST also keeps the contact-episode log of each contact element over the statistics
#: window (:func:`berryshaker.multibody.contact_events.record_contacts`): episodes logged so far (every closed one,
#: also those beyond the log's capacity), the open episode's flag (1 open), onset time, approach speed, peak force
#: and impulse so far; then the log from column :data:`FIRST_LOG` on, :data:`N_EP` entries per closed episode
(FIRST_EP_COUNT, FIRST_EP_OPEN, FIRST_EP_T0, FIRST_EP_V, FIRST_EP_PEAK, FIRST_EP_IMPULSE) = range(5, 11)
FIRST_LOG = 11
#: one logged episode: onset time (s), approach speed at onset (m/s), peak |normal force| (N, interior peaks
#: included), impulse (N s, the trapezoid over the accepted steps) and duration (s, onset to the first step end
#: found open)
EP_T0, EP_V, EP_PEAK, EP_IMPULSE, EP_DURATION = range(5)
N_EP = 5
#: capacity of the episode log per second of statistics window (episodes/s): the reference harvester's busiest
#: joint closes about 300 times a second, chatter included
EPISODES_PER_SECOND = 2000


def first_columns(window: float) -> int:
    """Columns of integrate's ``first`` with an episode log for a statistics window of ``window`` seconds.

    Parameters
    ----------
    window : float
        Length of the statistics window (s).

    Returns
    -------
    int
        :data:`FIRST_LOG` plus :data:`N_EP` entries for each of max(64, ``EPISODES_PER_SECOND x window``) episodes.
    """
    return FIRST_LOG + N_EP * max(64, int(np.ceil(EPISODES_PER_SECOND * max(window, 0.0))))
#: layout of integrate's optional ``resume`` array (a run in chunks): the step count at which to pause (<= 0:
#: none), started flag, then the loop's state (time, step size, the size to resume with after an onset cut, the
#: PI controller's last error, last step rejected, accepted / rejected / cut steps, largest constraint residual,
#: next output sample), then the state y, the derivative at y (k[0]) and per force element the penetration, force
#: and penetration rate at the last accepted step; :func:`resume_size` entries in all
(RS_LIMIT, RS_STARTED, RS_T, RS_H, RS_H_RESUME, RS_ERR_OLD, RS_LAST_REJ, RS_ACC, RS_REJ, RS_CUTS, RS_MAX_RES,
 RS_IO) = range(12)
N_RESUME = 12


def resume_size(ny: int, nf: int) -> int:
    """Length of integrate's ``resume`` array for ``ny`` states and ``nf`` force elements.

    Parameters
    ----------
    ny : int
        Number of states.
    nf : int
        Number of force elements.

    Returns
    -------
    int
        Entries of the ``resume`` array.
    """
    return N_RESUME + 2 * ny + 3 * nf


def _fill(record: tuple[str, ...], what: str, n_int: int, n_flt: int, values: dict) -> tuple[list[int], np.ndarray]:
    ints = [0] * n_int
    flts = np.zeros(n_flt)
    for key, v in values.items():
        name = next((p + key.upper() for p in ("FI_", "CI_", "FF_", "CF_") if p + key.upper() in record), None)
        if name is None:
            raise ValueError(f"{what} has no slot {key!r}; its record: {', '.join(record)}")
        slot = globals()[name]
        if name[1] == "I":
            ints[slot] = int(v)
        elif name in SLOT_WIDTH:
            v = np.asarray(v, float)
            if v.size > SLOT_WIDTH[name]:
                raise ValueError(f"{what}: {key} holds at most {SLOT_WIDTH[name]} values, got {v.size}")
            flts[slot:slot + v.size] = v
        else:
            flts[slot] = v
    return ints, flts


def force_record(typ: int, **values) -> tuple[list[int], np.ndarray]:
    """The ``fint`` and ``fflt`` rows of a force element of type ``typ`` (``FRC_*``): each keyword names a slot of
    its record (:data:`FORCE_RECORDS`) without the ``FI_`` / ``FF_`` prefix, any case (``pin_x=...``, ``law=...``);
    slots not given are 0.  A table slot (``table_speeds``) takes a sequence.

    Parameters
    ----------
    typ : int
        The element type (``FRC_*``).
    **values : float, int or sequence of float
        A value per slot of the record, by the slot's name without its prefix (SI: m, rad, N, N m, s).

    Returns
    -------
    tuple of (list of int, numpy.ndarray)
        The ``fint`` row and the ``fflt`` row (SI).


    Raises
    ------
    ValueError
        A keyword that is no slot of the type's record.
    """
    return _fill(FORCE_RECORDS[typ], f"force element type {typ}", N_FI, N_FF, values)


def constraint_record(typ: int, **values) -> tuple[list[int], np.ndarray]:
    """The ``cint`` and ``cflt`` rows of a constraint block of type ``typ`` (``CON_*``), as :func:`force_record`
    (slots of :data:`CONSTRAINT_RECORDS` without the ``CI_`` / ``CF_`` prefix).

    Parameters
    ----------
    typ : int
        The constraint type (``CON_*``).
    **values : float or int
        A value per slot of the record, by the slot's name without its prefix (SI: m, rad, rad/s).

    Returns
    -------
    tuple of (list of int, numpy.ndarray)
        The ``cint`` row and the ``cflt`` row (SI).


    Raises
    ------
    ValueError
        A keyword that is no slot of the type's record.
    """
    return _fill(CONSTRAINT_RECORDS[typ], f"constraint type {typ}", N_CI, N_CF, values)
