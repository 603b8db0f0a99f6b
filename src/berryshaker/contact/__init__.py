"""Contact physics: normal force laws, friction, Hertz stiffness helpers, clearance-joint geometry.

The ``*_kernel`` functions are scalar numba kernels for compiled code; their Python wrappers broadcast.
"""

from berryshaker.contact.force_laws import (
    adams_step,
    flores,
    hertz,
    hunt_crossley,
    impact,
    lankarani_nikravesh,
    mlsd,
)
from berryshaker.contact.friction import coulomb_friction, viscous_friction
from berryshaker.contact.joints import (
    ContactKinematics,
    closest_point_on_curve,
    point_line_clearance,
    revolute_clearance,
)
from berryshaker.contact.pin_in_bore import pin_in_bore_stiffness
from berryshaker.contact.stiffness import effective_modulus, roller_on_flat_stiffness

__all__ = [
    "adams_step", "flores", "hertz", "hunt_crossley", "impact", "lankarani_nikravesh", "mlsd",
    "coulomb_friction", "viscous_friction",
    "ContactKinematics", "closest_point_on_curve", "point_line_clearance", "revolute_clearance",
    "effective_modulus", "pin_in_bore_stiffness", "roller_on_flat_stiffness",
]
