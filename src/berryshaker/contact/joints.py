"""Geometry of clearance joints: pin in bore (revolute) and roller in a groove or slot (point-line).

All functions are numpy-vectorised over leading dimensions: points and velocities are arrays of shape
(..., 2) in m and m/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ContactKinematics:
    """Kinematic state of a clearance joint.

    Attributes
    ----------
    penetration : ndarray
        Penetration delta beyond the clearance (m), > 0 in contact.
    normal : ndarray (..., 2)
        Unit normal (dimensionless): direction of the force on the moving element (pin / roller).
    normal_velocity : ndarray
        d(delta)/dt (m/s), > 0 while approaching.
    tangential_velocity : ndarray
        Sliding velocity along t = rot90(normal) (m/s).
    eccentricity : ndarray (..., 2)
        Vector from the bore centre / groove centre line to the pin / roller centre (m).
    """

    penetration: np.ndarray  # delta (m), > 0 in contact
    normal: np.ndarray  # unit normal (..., 2): direction of the force on the moving element (pin / roller)
    normal_velocity: np.ndarray  # d(delta)/dt (m/s), > 0 approaching
    tangential_velocity: np.ndarray  # sliding velocity along t = rot90(normal) (m/s)
    eccentricity: np.ndarray  # (..., 2) vector from the bore centre / groove centre line (m)


def _perp(v):
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


def revolute_clearance(pin_position, pin_velocity, bore_position, bore_velocity, clearance,
                       pin_radius=0.0, pin_omega=0.0, bore_omega=0.0):
    """Pin (journal) in a bore with radial clearance c.

    Parameters
    ----------
    pin_position, pin_velocity : array_like (..., 2)
        Journal centre (m) and its velocity (m/s).
    bore_position, bore_velocity : array_like (..., 2)
        Bearing centre (m) and its velocity (m/s).
    clearance : float
        Radial clearance c = R_bore - R_pin (m), >= 0.
    pin_radius : float
        R_pin (m), for the sliding velocity at the contact point.
    pin_omega, bore_omega : array_like
        Angular velocities of pin and bore bodies (rad/s).

    Returns
    -------
    ContactKinematics
        eccentricity e = r_pin - r_bore; penetration delta = |e| - c; normal n = e/|e| (outward, the
        force on the pin acts along -n); normal velocity d(delta)/dt = n . (v_pin - v_bore);
        tangential velocity of the pin's contact point relative to the bore's, along t = rot90(n).

    Notes
    -----
    Flores & Ambrosio (2004), eqs. 1-8.  At e = 0 the normal is undefined; it is set to (1, 0) with
    penetration -c (no contact).

    References
    ----------
    P. Flores, J. Ambrosio, Comput. Struct. 82 (2004) 1359-1369.
    """
    if np.any(np.asarray(clearance) < 0):
        raise ValueError(f"clearance must be >= 0, got {clearance}")
    e = np.asarray(pin_position, float) - np.asarray(bore_position, float)
    de = np.asarray(pin_velocity, float) - np.asarray(bore_velocity, float)
    mag = np.linalg.norm(e, axis=-1)
    safe = np.where(mag > 0, mag, 1.0)
    n = np.where((mag > 0)[..., None], e / safe[..., None], np.array([1.0, 0.0]))
    t = _perp(n)
    vn = np.sum(n * de, axis=-1)
    r_b = pin_radius + np.asarray(clearance, float)
    # contact point: pin centre + R_pin n (pin material) and bore centre + R_bore n (bore material)
    vt = np.sum(t * de, axis=-1) + pin_radius * np.asarray(pin_omega, float) - r_b * np.asarray(bore_omega, float)
    return ContactKinematics(mag - clearance, n, vn, vt, e)


def point_line_clearance(point, point_velocity, line_point, line_direction, line_velocity, line_omega, gap):
    """Roller centre between the two walls of a straight slot (or a locally straight groove).

    Parameters
    ----------
    point, point_velocity : array_like (..., 2)
        Roller centre (m) and velocity (m/s).
    line_point : array_like (..., 2)
        A point of the slot centre line (m), moving with velocity ``line_velocity``.
    line_direction : array_like (..., 2)
        Unit direction of the centre line (dimensionless).
    line_velocity : array_like (..., 2)
        Velocity of the material point of the slot body at ``line_point`` (m/s).
    line_omega : array_like
        Angular velocity of the slot body (rad/s).
    gap : float
        Total free travel across the slot: slot width minus roller diameter (m), >= 0.

    Returns
    -------
    ContactKinematics
        With d = n0 . (P - Q) the signed offset from the centre line (n0 = rot90(direction)): the
        roller touches the wall on the +n0 side when d > gap/2 (penetration d - gap/2, normal +n0) and
        the other wall when d < -gap/2 (penetration -d - gap/2, normal -n0).  Penetration is the larger
        of the two (negative while the roller floats).

    Notes
    -----
    Velocities: d' = n0 . (v_P - v_Q - omega x (P - Q)) (the relative velocity seen from the slot body).
    """
    if np.any(np.asarray(gap) < 0):
        raise ValueError(f"gap must be >= 0, got {gap}")
    p = np.asarray(point, float)
    q = np.asarray(line_point, float)
    u = np.asarray(line_direction, float)
    u = u / np.linalg.norm(u, axis=-1, keepdims=True)
    n0 = _perp(u)
    r = p - q
    w = np.asarray(line_omega, float)
    v_rel = np.asarray(point_velocity, float) - np.asarray(line_velocity, float) - w[..., None] * _perp(r) \
        if np.ndim(w) else np.asarray(point_velocity, float) - np.asarray(line_velocity, float) - w * _perp(r)
    d = np.sum(n0 * r, axis=-1)
    dd = np.sum(n0 * v_rel, axis=-1)
    side = np.where(d >= 0, 1.0, -1.0)
    pen = np.abs(d) - 0.5 * np.asarray(gap, float)
    normal = side[..., None] * n0
    vt = np.sum(u * v_rel, axis=-1)
    return ContactKinematics(pen, normal, side * dd, vt, d[..., None] * n0)


def closest_point_on_curve(points, curve):
    """Closest point of a densely sampled closed curve (the cam pitch curve) to each query point.

    Parameters
    ----------
    points : array_like (m, 2)
        Query points (m), e.g. roller centres in the cam frame.
    curve : array_like (n, 2)
        Closed polyline (m; the first point may repeat as last).

    Returns
    -------
    foot : ndarray (m, 2)
        Closest point on the polyline.
    normal : ndarray (m, 2)
        Unit normal of the segment at the foot pointing towards the query point's side ("outward" for
        a point outside).
    distance : ndarray (m,)
        Signed distance along ``normal`` of the outward side (m): > 0 outside the closed curve.
    segment : ndarray (m,)
        Index of the segment.

    Notes
    -----
    Candidates come from a k-d tree of the vertices (scipy.spatial.cKDTree); the exact foot is the
    projection on the two segments around the nearest vertex.  The outward normal assumes the curve
    runs counter-clockwise (as the pitch curve does in cam angle).
    """
    from scipy.spatial import cKDTree

    c = np.asarray(curve, float)
    if np.allclose(c[0], c[-1]):
        c = c[:-1]
    n = len(c)
    pts = np.atleast_2d(np.asarray(points, float))
    _, idx = cKDTree(c).query(pts)
    best_d = np.full(len(pts), np.inf)
    foot = np.zeros_like(pts)
    seg = np.zeros(len(pts), int)
    for offset in (-1, 0):
        i0 = (idx + offset) % n
        a, b = c[i0], c[(i0 + 1) % n]
        ab = b - a
        tpar = np.clip(np.sum((pts - a) * ab, axis=1) / np.sum(ab * ab, axis=1), 0.0, 1.0)
        f = a + tpar[:, None] * ab
        d = np.linalg.norm(pts - f, axis=1)
        better = d < best_d
        best_d = np.where(better, d, best_d)
        foot = np.where(better[:, None], f, foot)
        seg = np.where(better, i0, seg)
    a, b = c[seg], c[(seg + 1) % n]
    tang = (b - a) / np.linalg.norm(b - a, axis=1, keepdims=True)
    outward = np.stack([tang[:, 1], -tang[:, 0]], axis=1)
    signed = np.sum((pts - foot) * outward, axis=1)
    return foot, outward, signed, seg
