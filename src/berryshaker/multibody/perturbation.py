"""Perturbed initial states of a mechanism (docs/multibody.md, "Perturbed initial states"): clearance joints
started off centre and drivers turned, explicitly or drawn from a seed, for replicates whose spread measures the
sensitivity of impact dynamics to the start."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from berryshaker.errors import ConfigError
from berryshaker.multibody.assembly import Assembly
from berryshaker.multibody.spec import MechanismSpec, mechanism_from_dict

#: largest driver rotation (rad) between two Newton assemblies when a perturbation turns a driver's start angle
PHASE_CONTINUATION_STEP = 0.2
#: joint types whose clearance a perturbation may use, with the free radius (m) as a fraction of ``clearance``
#: (pin in bore: radial clearance; pin in slot, roller in groove: half the free travel, docs/multibody.md)
_FREE_RADIUS = {"revolute_clearance": 1.0, "slot_clearance": 0.5, "groove_clearance": 0.5}


@dataclass(frozen=True)
class InitialPerturbation:
    """A small additive change of a mechanism's initial state (docs/multibody.md, "Perturbed initial states").

    Attributes
    ----------
    joint_offsets : dict joint name -> (dx, dy)
        Initial eccentricity of a clearance joint (m), in the frame of its ``body_i``: the pin (or roller)
        centre starts at its centred position plus A_i d instead of centred.  The mechanism is assembled with
        each such joint held at that offset (an ideal joint through the shifted point), so every ideal joint
        still closes exactly; |d| must stay inside the joint's free radius (radial clearance of a pin in a
        bore, half the free travel of a slot or groove).
    driver_phases : dict driver name -> dphi
        Change of a driver's start angle (rad): an angle driver then prescribes phi0 + dphi + omega t for
        the whole run; a torque-driven body starts dphi further on.  Large changes are assembled by
        continuation in steps of at most :data:`PHASE_CONTINUATION_STEP`.
    """

    joint_offsets: dict = field(default_factory=dict)
    driver_phases: dict = field(default_factory=dict)

    def for_spec(self, spec: MechanismSpec) -> "InitialPerturbation":
        """Check the named joints and drivers against ``spec``; returns self.

        Parameters
        ----------
        spec : MechanismSpec
            The mechanism.

        Returns
        -------
        InitialPerturbation
            This perturbation, checked.
        """
        joints = {j.name: j for j in spec.joints}
        for name, d in self.joint_offsets.items():
            j = joints.get(name)
            if j is None or j.type not in _FREE_RADIUS:
                raise ConfigError(f"initial perturbation: {name!r} is not a clearance joint of the mechanism "
                                  f"(clearance joints: {', '.join(n for n, j in joints.items() if j.type in _FREE_RADIUS) or 'none'})")
            free = _FREE_RADIUS[j.type] * j.clearance
            if not math.hypot(*d) < free:
                raise ConfigError(f"initial perturbation of joint {name!r}: offset {math.hypot(*d) * 1e3:.4g} mm is not "
                                  f"inside its free radius {free * 1e3:.4g} mm")
        drivers = {d.name for d in spec.drivers}
        for name, dphi in self.driver_phases.items():
            if name not in drivers or not math.isfinite(dphi):
                raise ConfigError(f"initial perturbation: {name!r} is not a driver of the mechanism, or its phase "
                                  f"{dphi!r} is not finite (drivers: {', '.join(sorted(drivers)) or 'none'})")
        return self

    def shifted_drivers(self, spec: MechanismSpec) -> MechanismSpec:
        """``spec`` with every perturbed driver's start angle ``angle0`` turned by its ``driver_phases`` entry.

        Parameters
        ----------
        spec : MechanismSpec
            The mechanism.

        Returns
        -------
        MechanismSpec
            The description with the drivers turned.
        """
        if not self.driver_phases:
            return spec
        data = spec.model_dump()
        for d, b in zip(data["drivers"], spec.drivers):
            if b.name in self.driver_phases:
                base = next(x.angle for x in spec.bodies if x.name == b.body) if b.angle0 is None else b.angle0
                d["angle0"] = base + float(self.driver_phases[b.name])
        return mechanism_from_dict(data, "(perturbed drivers)")

    def assemble(self, spec: MechanismSpec) -> np.ndarray:
        """Initial state of ``spec`` (drivers already turned, :meth:`shifted_drivers`) with the joint offsets.

        Each offset joint is assembled as an ideal joint through its pin point moved by -d (so that the pin
        centre sits A_i d from the bore centre); the driver turn is followed by continuation from the
        unperturbed assembly (Newton from the previous configuration at each step).  The assembly's mechanism
        is compiled once (:class:`berryshaker.multibody.assembly.Assembly`); the offsets and each step's
        driver angles are moved in its compiled records.

        Parameters
        ----------
        spec : MechanismSpec
            The mechanism, drivers already turned.

        Returns
        -------
        numpy.ndarray
            Positions, then velocities (m, rad; m/s, rad/s).
        """
        assembly = Assembly(spec)
        for j in spec.joints:
            if j.name in self.joint_offsets:
                dx, dy = self.joint_offsets[j.name]
                assembly.move_joint_point(j.name, (j.point_i[0] - float(dx), j.point_i[1] - float(dy)))
        turn = max((abs(float(v)) for v in self.driver_phases.values()), default=0.0)
        n = max(1, int(math.ceil(turn / PHASE_CONTINUATION_STEP)))
        q = None
        for k in range(n + 1) if turn > 0 else (n,):
            for d in spec.drivers:
                if d.name in self.driver_phases:
                    assembly.turn_driver(d.name, d.angle0 - float(self.driver_phases[d.name]) * (1 - k / n))
            y = assembly.state(q)
            q = y[:len(y) // 2]
        return y


@dataclass(frozen=True)
class RandomInitialPerturbation:
    """Seeded draw of an :class:`InitialPerturbation` for any mechanism (docs/multibody.md).

    Every clearance joint gets an eccentricity uniform over the disc of radius ``eccentricity_fraction`` x
    its free radius (magnitude free r sqrt(u), direction uniform; a slot or groove uses the same disc, whose
    component across the slot is what its walls see); every driver a start-angle change uniform in
    [-``phase_spread``, +``phase_spread``] rad.  The same seed gives the same draw for the same mechanism.

    Attributes
    ----------
    seed : int or tuple of int
        Seed (numpy SeedSequence entropy).
    eccentricity_fraction : float
        Radius of the eccentricity disc as a fraction of each joint's free radius (dimensionless).
    phase_spread : float
        Half width of the drivers' start-angle change (rad).
    """

    seed: int | tuple  # an int, or a tuple of ints (numpy SeedSequence entropy, e.g. (replicate seed, class))
    eccentricity_fraction: float = 1.0
    phase_spread: float = 0.0

    def for_spec(self, spec: MechanismSpec) -> InitialPerturbation:
        """The drawn perturbation of ``spec`` (joints and drivers in their order in ``spec``).

        Parameters
        ----------
        spec : MechanismSpec
            The mechanism.

        Returns
        -------
        InitialPerturbation
            The drawn perturbation (offsets m, turns rad).
        """
        if not 0 <= self.eccentricity_fraction <= 1:
            raise ConfigError(f"eccentricity_fraction={self.eccentricity_fraction!r}: give a fraction in [0, 1] "
                              "of each joint's free radius")
        if not (math.isfinite(self.phase_spread) and self.phase_spread >= 0):
            raise ConfigError(f"phase_spread={self.phase_spread!r}: give a finite angle >= 0 rad")
        rng = np.random.default_rng(self.seed)
        offsets = {}
        for j in spec.joints:
            if j.type in _FREE_RADIUS and j.clearance > 0:
                r = self.eccentricity_fraction * _FREE_RADIUS[j.type] * j.clearance * math.sqrt(rng.random())
                a = 2 * math.pi * rng.random()
                offsets[j.name] = (r * math.cos(a), r * math.sin(a))
        phases = {d.name: float(rng.uniform(-self.phase_spread, self.phase_spread)) for d in spec.drivers}
        return InitialPerturbation(offsets, phases).for_spec(spec)
