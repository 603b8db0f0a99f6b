"""Planar mechanisms built in Exudyn (independent open-source multibody code, PyPI ``exudyn``) from a
berryshaker :class:`~berryshaker.multibody.spec.MechanismSpec`, using only Exudyn's built-in C++ items
(no Python user functions in the solve unless a prescribed non-uniform motion is asked for).

Item mapping (Exudyn 1.13 item names):

* body                 -> ``NodeRigidBody2D`` + ``ObjectRigidBody2D`` (x, y, phi; same as ours)
* revolute             -> ``ObjectJointRevolute2D`` (index-3 constraint)
* prismatic            -> ``ObjectJointPrismatic2D`` (axis in body_i's frame, rotation locked)
* revolute_clearance   -> ``ObjectContactSphereSphere`` with ``isHollowSphere1=True``: the journal
  (body_i point, radius r) inside the bore (body_j point, radius r + c).  In the plane the sphere-in-
  hollow-sphere gap ``c - |d|`` is exactly the pin-in-bore gap.  Normal law: Exudyn's
  ``impactModel=1`` (Hunt-Crossley), F = k delta^n [1 + 3(1 - e)/2 * delta'/delta'(-)], the same law
  as berryshaker's ``hunt_crossley``; the impact velocity delta'(-) is stored by Exudyn at the end of
  the first step in contact (ours at the located onset).  Departure: Exudyn does not clamp F >= 0
  (ours does); with e = 0.9 the damping term never exceeds the elastic one during an impact, so the
  clamp is inactive except in near-grazing contacts.
* angle driver         -> ``CoordinateConstraint`` on the body's angle at velocity level
  (``velocityLevel=True``, offset = speed): phi' = omega, phi(0) = phi0, pure C++.
* rotational spring-damper -> ``CoordinateSpringDamper`` between the angle coordinates.
* groove / slot clearances, cam rollers, point-on-line: not mapped (Exudyn has no planar groove-cam
  clearance element); :func:`build_exudyn_mechanism` raises ``NotImplementedError`` for them.

Reference for the items: J. Gerstmayr, "Exudyn - a C++-based Python package for flexible multibody
systems", Multibody System Dynamics 60 (2024) 533-570, and the Exudyn item documentation
(docs/RST/items/ObjectContactSphereSphere.rst, version 1.13).
"""

from __future__ import annotations

import time

import numpy as np


def build_exudyn_mechanism(spec, y0, prescribed=None):
    """Build the Exudyn system of a berryshaker mechanism description.

    Parameters
    ----------
    spec : MechanismSpec
        Bodies, joints (revolute, prismatic, revolute_clearance), drivers (angle), forces
        (rotational_spring_damper).  Clearance joints must use ``law = "hunt_crossley"``.
    y0 : ndarray
        Initial (q, q') from :func:`berryshaker.multibody.engine.initial_state` (q = x, y, phi per body).
    prescribed : dict, optional
        ``{body name: (t_table, phi_table)}``: prescribe that body's angle from a periodic table
        (Python offset user function, np.interp; slows Exudyn down, say so when timing).

    Returns
    -------
    tuple
        (SystemContainer, MainSystem, dict of contact object indices by joint name).
    """
    import exudyn as exu
    from exudyn.itemInterface import (
        CoordinateConstraint,
        CoordinateSpringDamper,
        MarkerBodyPosition,
        MarkerBodyRigid,
        MarkerNodeCoordinate,
        NodeGenericData,
        NodePointGround,
        NodeRigidBody2D,
        ObjectContactSphereSphere,
        ObjectGround,
        ObjectJointPrismatic2D,
        ObjectJointRevolute2D,
        ObjectRigidBody2D,
    )

    from berryshaker.contact.pin_in_bore import pin_in_bore_stiffness

    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground = mbs.AddObject(ObjectGround(referencePosition=[0, 0, 0]))
    gnode = mbs.AddNode(NodePointGround(referenceCoordinates=[0, 0, 0]))
    mg = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=gnode, coordinate=0))
    nb = len(spec.bodies)
    nodes, objs = {}, {"ground": ground}
    ref_angle = {"ground": 0.0}  # MarkerNodeCoordinate acts on the displacement from the reference coordinate
    for i, b in enumerate(spec.bodies):
        q = [float(v) for v in y0[3 * i:3 * i + 3]]
        v = [float(v) for v in y0[3 * nb + 3 * i:3 * nb + 3 * i + 3]]
        nodes[b.name] = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=q, initialVelocities=v))
        ref_angle[b.name] = q[2]
        objs[b.name] = mbs.AddObject(ObjectRigidBody2D(mass=b.mass, inertia=b.inertia, nodeNumber=nodes[b.name]))

    def marker(body, point, rigid=False):
        kind = MarkerBodyRigid if rigid else MarkerBodyPosition
        return mbs.AddMarker(kind(bodyNumber=objs[body], localPosition=[point[0], point[1], 0.0]))

    def angle_marker(body):
        return mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[body], coordinate=2))

    contacts = {}
    for j in spec.joints:
        if j.type == "revolute":
            mbs.AddObject(ObjectJointRevolute2D(markerNumbers=[marker(j.body_i, j.point_i),
                                                               marker(j.body_j, j.point_j)]))
        elif j.type == "prismatic":
            if j.friction_coefficient:
                raise NotImplementedError(f"joint {j.name!r}: prismatic friction is not mapped to Exudyn")
            u = np.asarray(j.axis, float) / np.hypot(*j.axis)
            mbs.AddObject(ObjectJointPrismatic2D(
                markerNumbers=[marker(j.body_i, j.point_i, True), marker(j.body_j, j.point_j, True)],
                axisMarker0=[u[0], u[1], 0.0], normalMarker1=[-u[1], u[0], 0.0], constrainRotation=True))
        elif j.type == "revolute_clearance":
            c = j.contact
            if c.law != "hunt_crossley":
                raise NotImplementedError(f"joint {j.name!r}: law {c.law!r}; Exudyn's built-in sphere contact "
                                          "is mapped for hunt_crossley only")
            k = c.stiffness
            if k == "hertz":
                k = pin_in_bore_stiffness(c.elastic_modulus, c.poisson_ratio, c.elastic_modulus, c.poisson_ratio,
                                          j.pin_radius, j.pin_radius + j.clearance)
            ndata = mbs.AddNode(NodeGenericData(initialCoordinates=[j.clearance, 0, 0, 0],
                                                numberOfDataCoordinates=4))
            contacts[j.name] = mbs.AddObject(ObjectContactSphereSphere(
                markerNumbers=[marker(j.body_i, j.point_i, True), marker(j.body_j, j.point_j, True)],
                nodeNumber=ndata, spheresRadii=[j.pin_radius, j.pin_radius + j.clearance], isHollowSphere1=True,
                contactStiffness=float(k), contactStiffnessExponent=c.exponent, restitutionCoefficient=c.restitution,
                impactModel=1, dynamicFriction=j.friction_coefficient))
        else:
            raise NotImplementedError(f"joint {j.name!r}: type {j.type!r} has no Exudyn built-in here")
    prescribed = prescribed or {}
    for d in spec.drivers:
        if d.type != "angle":
            raise NotImplementedError(f"driver {d.name!r}: only angle drivers are mapped")
        if d.body in prescribed:
            continue
        mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, angle_marker(d.body)], offset=d.speed,
                                           velocityLevel=True))
    for body, (tt, pp) in prescribed.items():
        period = float(tt[-1])

        def offset(mbs_, t, item, l_offset, tt=tt, pp=pp - ref_angle[body], period=period):
            return float(np.interp(t % period, tt, pp))

        mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, angle_marker(body)], offsetUserFunction=offset))
    for f in spec.forces:
        if f.type != "rotational_spring_damper":
            raise NotImplementedError(f"force {f.name!r}: only rotational spring-dampers are mapped")
        mj = mg if f.body_j == "ground" else angle_marker(f.body_j)
        # Exudyn: F = k (q1 - q0 - offset) + d (q1' - q0'), marker 0 = body_j, marker 1 = body_i
        mbs.AddObject(CoordinateSpringDamper(markerNumbers=[mj, angle_marker(f.body_i)], stiffness=f.stiffness,
                                             damping=f.damping,
                                             offset=f.angle0 - (ref_angle[f.body_i] - ref_angle[f.body_j])))
    return sc, mbs, contacts


def solve_exudyn(mbs, contacts, duration, step, output_step=None, spectral_radius=0.9, modified_newton=True):
    """Solve with Exudyn's implicit generalised-alpha at a fixed step (its recommended contact settings).

    Settings follow Exudyn's contact examples (newtonsCradle.py, contactSphereSphereTest.py):
    generalised-alpha, spectral radius 0.9, modified Newton, discontinuous (PostNewton) iterations with
    the defaults (tolerance 1, up to 5 iterations) except ``useRecommendedStepSize = False`` (with it the
    step collapses at the first impact and the solver aborts), adaptive step (on failure only) on.
    Contact forces are recorded by C++ sensors (``storeInternal``), not by Python callbacks.

    Parameters
    ----------
    mbs : MainSystem
        From :func:`build_exudyn_mechanism` (not yet assembled).
    contacts : dict
        Contact objects by joint name (sensors are attached to them).
    duration, step : float
        End time and step size (s).
    output_step : float, optional
        Sensor write period (s); default = step.

    Returns
    -------
    tuple
        ({joint: (t, |F|) arrays}, wall time of ``SolveDynamic`` (s, time.perf_counter), its CPU time
        (s, time.process_time; robust when other processes share the cores)).
    """
    import exudyn as exu
    from exudyn.itemInterface import SensorObject

    sensors = {name: mbs.AddSensor(SensorObject(objectNumber=obj, storeInternal=True, writeToFile=False,
                                                outputVariableType=exu.OutputVariableType.Force))
               for name, obj in contacts.items()}
    mbs.Assemble()
    ss = exu.SimulationSettings()
    ss.timeIntegration.endTime = duration
    ss.timeIntegration.numberOfSteps = int(round(duration / step))
    ss.timeIntegration.generalizedAlpha.spectralRadius = spectral_radius
    ss.timeIntegration.newton.useModifiedNewton = modified_newton
    # the recommended-step-size option of the discontinuous iteration makes the step collapse to the
    # minimum at the first impact of this model (solver abort); off, the contact is resolved by
    # discontinuous iterations at the fixed step
    ss.timeIntegration.discontinuous.useRecommendedStepSize = False
    ss.timeIntegration.verboseMode = 0
    ss.solutionSettings.writeSolutionToFile = False
    ss.solutionSettings.sensorsWritePeriod = step if output_step is None else output_step
    ss.displayComputationTime = False
    ss.displayStatistics = False
    t0, c0 = time.perf_counter(), time.process_time()
    mbs.SolveDynamic(ss)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    out = {}
    for name, s in sensors.items():
        d = mbs.GetSensorStoredData(s)
        out[name] = (d[:, 0], np.hypot(d[:, 1], d[:, 2]))
    return out, wall, cpu


def run_exudyn(spec, y0, duration, step, output_step=None, prescribed=None, **kw):
    """Build and solve (see :func:`build_exudyn_mechanism`, :func:`solve_exudyn`); returns (forces, wall, cpu)."""
    sc, mbs, contacts = build_exudyn_mechanism(spec, y0, prescribed)
    return solve_exudyn(mbs, contacts, duration, step, output_step, **kw)
