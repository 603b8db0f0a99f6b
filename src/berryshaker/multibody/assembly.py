"""The initial state of a mechanism: positions assembled onto the constraints (Newton, mass-weighted) with every
clearance joint centred, and consistent velocities.  :class:`Assembly` compiles a description's assembly once;
its joint points and driver start angles can then be moved in the compiled arrays and the state assembled again
(a perturbed start, :mod:`berryshaker.multibody.perturbation`, assembles through it).
"""

from __future__ import annotations

import numpy as np

from berryshaker.errors import GeometryError
from berryshaker.multibody import layout as L
from berryshaker.multibody.compiled import _state_and_work, compile_mechanism
from berryshaker.multibody.constraint_rows import constraints
from berryshaker.multibody.dispatch import call_compiled
from berryshaker.multibody.dynamics import project
from berryshaker.multibody.sparsity import solve_plan
from berryshaker.multibody.spec import MechanismSpec, mechanism_from_dict


def initial_state(spec: MechanismSpec, q_start: np.ndarray | None = None) -> np.ndarray:
    """Assembled positions and consistent velocities with every clearance joint centred (ideal).

    Torque-driven bodies start at their driver's ``speed``.  Powered drives: a ``torque_speed`` driver's body
    starts at its ``speed``, and a body driven through a geared spring-damper at the speed that keeps the windup
    constant, omega_j = omega_i (1 - creep k psi0) / ratio (propagated along the chain of gears); every windup
    starts at its ``windup0`` and every energy accumulator at zero.
    ``q_start``: positions the Newton assembly starts from (default: the bodies' positions and angles in
    ``spec``; the body coordinates only).

    Parameters
    ----------
    spec : MechanismSpec
        The mechanism description.
    q_start : numpy.ndarray, optional
        Starting guess of the positions (m, rad); default the description's.

    Returns
    -------
    numpy.ndarray
        Positions, then velocities (m, rad; m/s, rad/s).
    """
    return Assembly(spec).state(q_start)


class Assembly:
    """A description's assembly compiled once (:func:`initial_state`'s mechanisms: every clearance joint ideal,
    temporary speed drivers for torque-driven bodies), whose joint points and driver start angles can be moved
    in place and the state assembled again.

    A moved point or angle gives bitwise the state :func:`initial_state` assembles for the description with that
    point or angle: both write the same float into the same slot of the same compiled record, and the multiplier
    solve's plan is derived again from the moved records (a start angle does not enter it).

    Parameters
    ----------
    spec : MechanismSpec
        The mechanism description.
    """

    def __init__(self, spec: MechanismSpec):
        ideal = compile_mechanism(spec, ideal_clearances=True)
        target = compile_mechanism(spec) if ideal.n > ideal.n_base else ideal  # layout of the auxiliary coordinates
        # temporary speed constraints for torque-driven bodies, so that the velocity projection is determined
        data = _speed_driver_spec(spec)
        if data is not None:
            ideal = compile_mechanism(mechanism_from_dict(data), ideal_clearances=True)
        self._ideal = ideal
        self._n_target = target.n
        self._n_base_target = target.n_base
        self._windup0 = list(target.state_windup0)
        self._blocks: dict[tuple[bool, str], int] = {}  # (is a driver, name) -> constraint block
        for k, name in enumerate(ideal.con_names):
            self._blocks.setdefault((int(ideal.model.ctype[k]) == L.CON_DRIVER, name), k)
        self._plan_stale = False

    def move_joint_point(self, name: str, point_i: tuple[float, float]) -> None:
        """Put joint ``name``'s point on its ``body_i`` at ``point_i`` (body frame, m) in the compiled records.

        Parameters
        ----------
        name : str
            A joint of the description (a clearance joint is assembled as its ideal counterpart).
        point_i : tuple of float
            The point on ``body_i`` (m).
        """
        f = self._ideal.model.cflt[self._blocks[(False, name)]]
        f[L.CF_SIX], f[L.CF_SIY] = float(point_i[0]), float(point_i[1])
        self._plan_stale = True

    def turn_driver(self, name: str, angle0: float) -> None:
        """Set driver ``name``'s start angle to ``angle0`` (rad) in the compiled records.

        A driver absent from the assembly's mechanisms (a torque driver on a body another driver already sets
        the speed of: a load there) is left alone, as :func:`initial_state` leaves it out.

        Parameters
        ----------
        name : str
            A driver of the description.
        angle0 : float
            Its start angle (rad).
        """
        k = self._blocks.get((True, name))
        if k is not None:
            self._ideal.model.cflt[k, L.CF_ANGLE0] = float(angle0)

    def state(self, q_start: np.ndarray | None = None) -> np.ndarray:
        """Assembled positions and consistent velocities (:func:`initial_state`) of the mechanism as it stands.

        Parameters
        ----------
        q_start : numpy.ndarray, optional
            Starting guess of the positions (m, rad); default the description's.  Its first coordinates are
            taken: the bodies' (and the windups'), as many as the assembly's mechanism has, the rest the
            description's; a state of the description, auxiliary coordinates and all, may be given.

        Returns
        -------
        numpy.ndarray
            Positions, then velocities (m, rad; m/s, rad/s).

        Raises
        ------
        GeometryError
            The mechanism cannot assemble.
        """
        ideal = self._ideal
        if self._plan_stale:
            md = ideal.model
            ideal.model = md._replace(plan=solve_plan(md.ctype, md.cint, md.cflt, md.crow, ideal.m, ideal.n_base))
            self._plan_stale = False
        state, work = _state_and_work(ideal)
        q = ideal.q0.copy()
        if q_start is not None:
            # the positions the assembly's own mechanism has: a state of the description (a continuation step's
            # start, :meth:`state`'s last result) also carries the coordinates only the description has (the
            # powered driveline's energy accumulators, after its windups), which the assembly leaves out
            given = np.array(q_start, float)[:ideal.n]
            q[:len(given)] = given
        y = np.concatenate([q, np.zeros(ideal.n)])
        res = 0.0
        if ideal.m:
            res = call_compiled(project, 0.0, y, ideal.model, state, work, 60)
            if not (res < 1e-9):
                md = ideal.model
                constraints(0.0, y[:ideal.n], y[ideal.n:], md.ctype, md.cint, md.cflt, md.crow, md.cams, state[2],
                            work[0], work[1], work[2], work[3])
                worst = int(np.argmax(np.abs(work[0])))
                name = next(n for n, (r0, nr) in zip(ideal.con_names, ideal.con_rows) if r0 <= worst < r0 + nr)
                raise GeometryError(f"the mechanism cannot assemble: joint {name!r} stays {abs(work[0][worst]):.3g} "
                                    "(m or rad) from closing; check its points and the bodies' initial positions")
        if ideal.n != self._n_target or self._windup0:
            # the temporary mechanism has no energy accumulators (they come last): pad, then set the windups
            n_t, n = ideal.n, self._n_target
            full = np.zeros(2 * n)
            full[:n_t] = y[:n_t]
            full[n:n + n_t] = y[n_t:]
            for i, psi0 in enumerate(self._windup0):
                full[n + self._n_base_target + i] = psi0
            y = full
        return y


def _speed_driver_spec(spec: MechanismSpec) -> dict | None:
    """The description as a dict with temporary ``angle`` drivers that fix the initial speeds (see
    :func:`initial_state`), energy audit off; None when no driver needs it.

    Speeds come from the ``angle`` and ``torque_speed`` drivers first, spread along the geared spring-dampers,
    then from ``torque`` drivers on bodies still without a speed (a torque driver on a body that already has one
    is a load and is left out of the temporary description)."""
    if not any(d.type in ("torque", "torque_speed") for d in spec.drivers):
        return None
    data = spec.model_dump()
    data["simulation"]["energy_audit"] = False
    speeds: dict[str, float] = {}
    drivers = []
    geared = [f for f in spec.forces if f.type == "geared_spring_damper"]

    def spread():
        changed = True
        while changed:
            changed = False
            for f in geared:
                drift = 1.0 - f.creep_compliance * f.stiffness * f.windup0
                if f.body_i in speeds and f.body_j not in speeds and f.body_j != "ground":
                    new, speeds[f.body_j] = f.body_j, speeds[f.body_i] * drift / f.ratio
                elif f.body_j in speeds and f.body_i not in speeds and f.body_i != "ground":
                    new, speeds[f.body_i] = f.body_i, speeds[f.body_j] * f.ratio / drift
                else:
                    continue
                drivers.append(dict(name=f"initial speed of {new}", type="angle", body=new, speed=speeds[new]))
                changed = True

    for d in data["drivers"]:
        if d["type"] in ("angle", "torque_speed") and d["body"] not in speeds:
            speeds[d["body"]] = d["speed"]
            drivers.append(dict(d, type="angle", speeds=[], torques=[]))
    spread()
    for d in data["drivers"]:
        if d["type"] == "torque" and d["body"] not in speeds:
            speeds[d["body"]] = d["speed"]
            drivers.append(dict(d, type="angle"))
            spread()
    data["drivers"] = drivers
    return data
