"""The groove cam drive's compiled kinematics with UNEQUAL rise and return angles.

Every built-in machine has rise = return (120 deg each), so the compiled path (``geometry_vector`` packing the cam
into ``G_*`` slots, ``ideal_state`` reading them) could take the rise angle for the return angle and nothing would
show.  Here rise = 100 deg, far dwell = 40 deg, return = 150 deg, near dwell = 70 deg, and the push rod's motion
from ``ideal_state`` on the return is checked against the closed form written out below (Norton, Cam Design and
Manufacturing Handbook, 2nd ed., 2009, ch. 3):

    u = (phi - rise - far) / return,   P(u) = 10u^3 - 15u^4 + 6u^5  (3-4-5),
    s = h (1 - P(u)),   v = -h P'(u) omega / return,   a = -h P''(u) omega^2 / return^2.

The 3-4-5 law is symmetric, P(1 - u) = 1 - P(u) and P'(1 - u) = P'(u), so at return fraction u the push rod is where
it was at rise fraction 1 - u, moving back at RISE / RETURN of that speed: the left comb (a function of the push-rod
position alone) has the same angle there and the rate scaled by -RISE / RETURN.
"""

from __future__ import annotations

import math

import pytest

from berryshaker.config import machine_from_dict
from berryshaker.drives.groove_cam.kinematics import geometry_vector, ideal_state

RISE, FAR, RET, NEAR = (math.radians(x) for x in (100.0, 40.0, 150.0, 70.0))


@pytest.fixture(scope="module")
def asymmetric(machine):
    d = machine.model_dump()
    d["cam"].update(law="3-4-5", rise_angle=RISE, far_dwell_angle=FAR, return_angle=RET, near_dwell_angle=NEAR)
    return machine_from_dict(d)


def _p345(u):
    return (10 * u**3 - 15 * u**4 + 6 * u**5, 30 * u**2 - 60 * u**3 + 30 * u**4, 60 * u - 180 * u**2 + 120 * u**3)


def test_compiled_push_rod_motion_on_the_return_is_the_closed_form(asymmetric):
    g = geometry_vector(asymmetric)
    h, w = asymmetric.cam.stroke, asymmetric.cam.speed
    for u in (0.1, 0.25, 0.4, 0.6, 0.85):
        ok, s, v, a = ideal_state(RISE + FAR + u * RET, g)[:4]
        p, p1, p2 = _p345(u)
        assert ok
        assert s == pytest.approx(h * (1 - p), rel=1e-12), u
        assert v == pytest.approx(-h * p1 * w / RET, rel=1e-12), u
        assert a == pytest.approx(-h * p2 * w**2 / RET**2, rel=1e-12), u


def test_left_comb_on_the_return_retraces_the_rise(asymmetric):
    g = geometry_vector(asymmetric)
    for u in (0.2, 0.45, 0.7):
        rise = ideal_state((1 - u) * RISE, g)
        back = ideal_state(RISE + FAR + u * RET, g)
        assert back[4] == pytest.approx(rise[4], rel=1e-12, abs=1e-12)  # theta_D
        assert back[5] == pytest.approx(-rise[5] * RISE / RET, rel=1e-9)  # omega_D
        assert abs(back[5]) > 0
