"""The groove cam drive as a multibody mechanism, with UNEQUAL rise and return angles.

Every built-in machine has rise = return, so the cam's row of the compiled mechanism (drives/groove_cam/mechanism.py
-> the multibody cam table) could carry the rise angle in the return slot and every other test would pass.  With
every clearance zero the mechanism is the ideal one: the roller centre stays on the pitch curve, so the push rod's
position is a constant plus the follower law written out in tests/kinematics/test_cam_return.py,

    s(phi) = h P(phi / rise)                          on the rise,
    s(phi) = h (1 - P((phi - rise - far) / return))   on the return,      phi = omega t (mod 2 pi).

Rise 100 deg, far dwell 40, return 150, near dwell 70: the same law with the return normalised by the rise angle moves
the push rod 16 mm away from this over the return.
"""

from __future__ import annotations

import math

import numpy as np

from berryshaker.config import machine_from_dict
from berryshaker.drives.simulation import simulate_multibody
from berryshaker.kinematics.cam import follower_svaj

RISE, FAR, RET, NEAR = (math.radians(x) for x in (100.0, 40.0, 150.0, 70.0))


def test_rigid_push_rod_follows_an_asymmetric_cam(machine):
    d = machine.model_dump()
    d["cam"].update(rise_angle=RISE, far_dwell_angle=FAR, return_angle=RET, near_dwell_angle=NEAR)
    asym = machine_from_dict(d)
    result, _ = simulate_multibody(asym, clearance=dict(A=0.0, B=0.0, C=0.0, F=0.0), revolutions=2,
                                   output_step=1e-3)
    x = result.y[:, 3 * result.compiled.body_index["push_rod"]]
    c = asym.cam
    phi = np.mod(c.speed * result.t, 2 * math.pi)
    on_return = (phi > RISE + FAR) & (phi < RISE + FAR + RET)
    assert on_return.sum() > 300  # two revolutions sampled every ms: about 420 samples on the return
    s = follower_svaj(phi, c.stroke, RISE, FAR, RET, c.law)[0]
    offset = x - s
    assert np.ptp(offset) < 1e-7  # m: constant (2.5e-12 m here; the stroke is 40 mm)
    assert np.ptp(x[on_return]) > 0.9 * c.stroke  # the return really is travelled
