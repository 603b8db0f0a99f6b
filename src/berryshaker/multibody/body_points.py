"""Points of the bodies in the compiled core: a body point's global position and velocity, a body's origin, and a
force applied at a point (the kinematics every constraint row and force element starts from).

Absolute planar coordinates q = (x, y, phi) per body (docs/multibody.md, "Formulation"); body -1 is the ground.

Reference counting.  The compiled core's functions but the integrator's loop are
compiled with ``_nrt=False``: none of them allocates, and without the numba runtime a call no longer increments and
decrements the reference count of every array it receives (an atomic operation each; ``accelerations`` takes the
31 arrays of the model, state and work tuples and passes most of them on to ``constraints`` and ``forces``): ~1/3
of the cost of a right-hand side.  Arrays stay owned by the integrator (or the Python caller) for the whole call,
so nothing is freed early.  Such a function must not allocate (np.empty, copies, array expressions) or return an
array: numba refuses to compile it without the runtime.  Integer arguments between compiled functions are passed
as np.int64 (not literals such as 3): numba compiles a separate specialisation for every literal value (``project``
was compiled twice, ``_write_sample`` three times), time the first run on a fresh install pays.
"""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True, _nrt=False)
def _point(q, qd, b, sx, sy):
    """Global position, velocity and rotated offset A s of body point s; ground if b < 0."""
    if b < 0:
        return sx, sy, 0.0, 0.0, sx, sy, 0.0
    c = math.cos(q[3 * b + 2])
    s = math.sin(q[3 * b + 2])
    ax = c * sx - s * sy
    ay = s * sx + c * sy
    w = qd[3 * b + 2]
    return q[3 * b] + ax, q[3 * b + 1] + ay, qd[3 * b] - w * ay, qd[3 * b + 1] + w * ax, ax, ay, w


@njit(cache=True, _nrt=False)
def _body_origin(q, qd, b):
    """Position, velocity, angle and angular velocity of body b's origin (all 0 for the ground, b < 0)."""
    if b < 0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    return q[3 * b], q[3 * b + 1], qd[3 * b], qd[3 * b + 1], q[3 * b + 2], qd[3 * b + 2]


@njit(cache=True, _nrt=False)
def _apply(Q, b, fx, fy, armx, army):
    """Add the force (fx, fy) acting at arm (armx, army) from body b's origin to its generalised forces Q (nothing
    for the ground, b < 0)."""
    if b >= 0:
        Q[3 * b] += fx
        Q[3 * b + 1] += fy
        Q[3 * b + 2] += armx * fy - army * fx
