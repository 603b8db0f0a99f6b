"""The slider-crank with a rod-slider revolute clearance built in Exudyn (an independent open-source
multibody code, PyPI ``exudyn``), for validating berryshaker's engine (tests/multibody/test_engine.py; the
benchmark suite's Exudyn models, with Exudyn's built-in contact, are benchmarks/suite/exudyn_models.py).

Exudyn is a test-and-benchmark dependency only.  The model mirrors ``examples/slider_crank_clearance.toml``
with Exudyn's own rigid bodies, revolute joints and coordinate constraints (index-3 DAE, implicit
generalised-alpha integrator); only the clearance contact force (Lankarani-Nikravesh with Hertz
stiffness) is a Python user function, as Exudyn has no revolute-clearance element.  Both codes start
from the same assembled state (journal centred, ideal velocities).
"""

from __future__ import annotations

import math
import time

import numpy as np


def run_exudyn_slider_crank(spec, y0, duration: float, step: float, spectral_radius: float = 0.9):
    """Simulate with Exudyn at a fixed step; returns dict of arrays (t, slider_acc, force) and wall time.

    Parameters
    ----------
    spec : MechanismSpec
        The slider-crank description (bodies crank, rod, slider; joint rod_slider).
    y0 : ndarray
        Initial (q, q') from :func:`berryshaker.multibody.engine.initial_state`.
    duration, step : float
        End time and fixed time step (s).
    """
    import exudyn as exu
    from exudyn.itemInterface import (
        CoordinateConstraint,
        MarkerBodyPosition,
        MarkerNodeCoordinate,
        NodePointGround,
        NodeRigidBody2D,
        ObjectConnectorCartesianSpringDamper,
        ObjectGround,
        ObjectJointRevolute2D,
        ObjectRigidBody2D,
    )

    from berryshaker.contact.pin_in_bore import pin_in_bore_stiffness

    bodies = {b.name: b for b in spec.bodies}
    joint = next(j for j in spec.joints if j.name == "rod_slider")
    drv = spec.drivers[0]
    c = joint.clearance
    rpin = joint.pin_radius
    k = pin_in_bore_stiffness(joint.contact.elastic_modulus, joint.contact.poisson_ratio,
                              joint.contact.elastic_modulus, joint.contact.poisson_ratio, rpin, rpin + c)
    e_rest = joint.contact.restitution
    n_exp = joint.contact.exponent

    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground = mbs.AddObject(ObjectGround(referencePosition=[0, 0, 0]))
    names = [b.name for b in spec.bodies]
    nodes, objs = {}, {}
    for i, name in enumerate(names):
        b = bodies[name]
        q = y0[3 * i:3 * i + 3]
        v = y0[9 + 3 * i:9 + 3 * i + 3]
        nodes[name] = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=list(q), initialVelocities=list(v)))
        objs[name] = mbs.AddObject(ObjectRigidBody2D(mass=b.mass, inertia=b.inertia, nodeNumber=nodes[name]))
    # local points in the body frames (the TOML points)
    jmap = {j.name: j for j in spec.joints}

    def mpos(body, point):
        if body == "ground":
            return mbs.AddMarker(MarkerBodyPosition(bodyNumber=ground, localPosition=[point[0], point[1], 0.0]))
        return mbs.AddMarker(MarkerBodyPosition(bodyNumber=objs[body], localPosition=[point[0], point[1], 0.0]))

    for name in ("crank_ground", "crank_rod"):
        j = jmap[name]
        mbs.AddObject(ObjectJointRevolute2D(markerNumbers=[mpos(j.body_i, j.point_i), mpos(j.body_j, j.point_j)]))
    gnode = mbs.AddNode(NodePointGround(referenceCoordinates=[0, 0, 0]))
    mg = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=gnode, coordinate=0))
    # slider: y = 0 and no rotation
    for coord in (1, 2):
        ms = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes["slider"], coordinate=coord))
        mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, ms]))
    # crank driven at constant speed: phi = phi0 + omega t
    omega = drv.speed
    phi0 = float(y0[2])
    mc = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes["crank"], coordinate=2))
    mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, mc], offset=phi0,
                                       offsetUserFunction=lambda mbs_, t, itemNumber, lOffset: lOffset + omega * t))
    # clearance contact: journal (rod) vs bearing (slider)
    m_bore = mpos(joint.body_j, joint.point_j)
    m_pin = mpos(joint.body_i, joint.point_i)
    contact = {"on": False, "v0": 1e-6}

    def contact_force(mbs_, t, itemNumber, displacement, velocity, stiffness, damping, offset):
        ex, ey = displacement[0], displacement[1]
        mag = math.hypot(ex, ey)
        pen = mag - c
        if pen <= 0.0 or mag == 0.0:
            return [0.0, 0.0, 0.0]
        nx, ny = ex / mag, ey / mag
        pd = nx * velocity[0] + ny * velocity[1]
        v0 = contact["v0"] if contact["on"] else max(pd, 1e-6)
        fn = k * pen**n_exp * (1.0 + 0.75 * (1.0 - e_rest**2) * pd / v0)
        fn = max(fn, 0.0)
        # the connector applies +f on marker 0 (bore) and -f on marker 1 (journal): push them apart
        return [fn * nx, fn * ny, 0.0]

    csd = mbs.AddObject(ObjectConnectorCartesianSpringDamper(markerNumbers=[m_bore, m_pin],
                                                             springForceUserFunction=contact_force))
    rec = {"t": [], "slider_acc": [], "force": []}
    n_slider = nodes["slider"]

    def pre_step(mbs_, t):
        d = mbs_.GetObjectOutput(csd, exu.OutputVariableType.Displacement)
        v = mbs_.GetObjectOutput(csd, exu.OutputVariableType.Velocity)
        mag = math.hypot(d[0], d[1])
        pen = mag - c
        if pen > 0 and not contact["on"]:
            contact["on"] = True
            contact["v0"] = max((d[0] * v[0] + d[1] * v[1]) / mag, 1e-6)
        elif pen <= 0:
            contact["on"] = False
        f = contact_force(mbs_, t, 0, d, v, 0, 0, 0)
        rec["t"].append(t)
        rec["force"].append(math.hypot(f[0], f[1]))
        rec["slider_acc"].append(mbs_.GetNodeOutput(n_slider, exu.OutputVariableType.Coordinates_tt)[0])
        return True

    mbs.SetPreStepUserFunction(pre_step)
    mbs.Assemble()
    ss = exu.SimulationSettings()
    ss.timeIntegration.endTime = duration
    ss.timeIntegration.numberOfSteps = int(round(duration / step))
    ss.timeIntegration.generalizedAlpha.spectralRadius = spectral_radius
    ss.timeIntegration.newton.useModifiedNewton = False
    ss.timeIntegration.verboseMode = 0
    ss.solution.file.write = False
    ss.show.computationTime = False
    ss.show.statistics = False
    t0 = time.perf_counter()
    exu.SolveDynamic(mbs, ss)
    wall = time.perf_counter() - t0
    return {k_: np.asarray(v_) for k_, v_ in rec.items()}, wall
