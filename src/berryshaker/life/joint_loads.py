"""Joint loads for wear: the normal force and the sliding speed of every clearance joint from ONE multibody run.

The wear loop (:func:`berryshaker.life.wear.wear_life`) needs, per joint, ``(t, normal_force, sliding_speed)``
over a steady window of whole drive revolutions.  :func:`joint_loads` simulates the machine's drive in the
generic multibody engine (:func:`berryshaker.drives.simulation.simulate_multibody`) and reads both from the
result:

* normal force: the clearance force element of the pair (``elements[:, k, 0]``), or the reaction of the ideal
  joint when the pair's clearance is zero;
* sliding speed, pin in a bore: ``|omega_i - omega_j| * d / 2`` -- the pin turns in the bore at the relative
  angular velocity of the two bodies it joins, and the surfaces slide past each other at the pin radius
  (Flores 2009 uses the same relative tangential velocity at the contact point for his wear integral);
* sliding speed, roller in a groove or slot: ``slip * v_roll``, where ``v_roll`` is the relative tangential
  velocity at the contact (the roller centre relative to the material point of the groove/slot body under
  it, less its normal component).  The roller's own spin is not a degree of freedom of the model, so a
  rolling contact with a slip ratio ``slip`` is assumed: default 5 % **[assumed]**.  A roller that reverses
  from one flank of a groove to the other must spin up again, which is why a finite slip is expected; the
  value is an engineering assumption, not a measurement, and the roller wear scales with it linearly.

Joint geometry (``[clearance.<pair>]`` ``diameter``, ``bearing_length``, ``material_pair``; defaults below,
all **[assumed]**) turns the loads into clearance growth with :func:`joint_wear_model`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from berryshaker.drives.base import HARVESTER_RTOL
from berryshaker.errors import ConfigError
from berryshaker.life.wear import JointWear

#: Pin or roller diameter when ``[clearance.<pair>] diameter`` is not given (m) [assumed].
DEFAULT_DIAMETER = 0.020
#: Bush length or roller width when ``bearing_length`` is not given (m) [assumed].
DEFAULT_BEARING_LENGTH = 0.020
#: Material pair when ``material_pair`` is not given [assumed]: a greased steel pin in a bronze bush.
DEFAULT_MATERIAL_PAIR = "steel-on-bronze-greased"
#: Slip ratio of a roller rolling on a groove flank or slot wall [assumed].
DEFAULT_SLIP = 0.05

_PIN_TYPES = ("revolute_clearance", "revolute")
_ROLLER_TYPES = ("groove_clearance", "slot_clearance", "cam_roller", "point_on_line")


@dataclass(frozen=True)
class JointGeometry:
    """What the wear of one clearance pair depends on besides its loads.

    Attributes
    ----------
    name, kind : str
        Pair name and kind ("pin-in-bore", "roller-in-groove", "roller-in-slot").
    diameter : float
        Pin or roller diameter (m).
    bearing_length : float
        Axial contact length: bush length or roller width (m).
    material_pair : str
        Key of :data:`berryshaker.contact.wear.MATERIAL_PAIRS`.
    fit : str or None
        ISO 286 fit on the drawing ("H8/f7"), if given.
    assumed : tuple of str
        The fields that fell back to the module defaults.
    """

    name: str
    kind: str
    diameter: float
    bearing_length: float
    material_pair: str
    fit: str | None
    assumed: tuple[str, ...]

    @property
    def is_pin(self) -> bool:
        """True for a pin in a bore (radial clearance), False for a roller (free travel)."""
        return self.kind == "pin-in-bore"


def joint_geometry(machine, pair: str) -> JointGeometry:
    """Wear geometry of a clearance pair from ``[clearance.<pair>]``, with the [assumed] defaults filled in.

    Parameters
    ----------
    machine : MachineBase
        Any drive's machine description.
    pair : str
        Clearance pair name (one of ``machine.pair_names``).

    Returns
    -------
    JointGeometry
        Diameter and bearing length (m) and material pair from the description, or :data:`DEFAULT_DIAMETER`,
        :data:`DEFAULT_BEARING_LENGTH` and :data:`DEFAULT_MATERIAL_PAIR` (named in ``assumed``).

    Raises
    ------
    ConfigError
        Unknown pair or unknown ``material_pair``.
    """
    from berryshaker.contact.wear import MATERIAL_PAIRS

    if pair not in machine.pair_names:
        raise ConfigError(f"unknown clearance pair {pair!r}; the {machine.DRIVE} drive's pairs are "
                          f"{', '.join(machine.pair_names)}")
    p = machine.clearance[pair]
    assumed = []
    diameter = getattr(p, "diameter", None)
    if diameter is None:
        diameter = DEFAULT_DIAMETER
        assumed.append("diameter")
    length = getattr(p, "bearing_length", None)
    if length is None:
        length = DEFAULT_BEARING_LENGTH
        assumed.append("bearing_length")
    material = getattr(p, "material_pair", None)
    if material is None:
        material = DEFAULT_MATERIAL_PAIR
        assumed.append("material_pair")
    if material not in MATERIAL_PAIRS:
        raise ConfigError(f"clearance.{pair}.material_pair = {material!r} is not known; use one of "
                          f"{', '.join(MATERIAL_PAIRS)}")
    return JointGeometry(pair, p.kind, float(diameter), float(length), material, getattr(p, "fit", None),
                         tuple(assumed))


def joint_wear_model(geometry: JointGeometry, load_direction: str = "fixed") -> JointWear:
    """How a pair's loads grow its clearance ``size`` (:class:`berryshaker.life.wear.JointWear`).

    Parameters
    ----------
    geometry : JointGeometry
        From :func:`joint_geometry`.
    load_direction : {"fixed", "rotating"}
        Pins only: the conservative fixed-direction depth (default) or the circumferential mean
        (:func:`berryshaker.contact.wear.pin_in_bore_clearance_growth`).

    Returns
    -------
    JointWear
        Pin in a bore: ``geometry="pin-in-bore"`` with d and L; the radial clearance grows by
        4 V / (pi d L) (fixed) or V / (pi d L) (rotating).  Roller: ``geometry="area"`` with
        ``wear_area = pi d w / 2``: the worn volume V is attributed to the roller rim (the smaller of the two
        rubbing surfaces, so the larger depth: conservative), which wears uniformly around its circumference
        pi d over its width w as it turns; its diameter falls by 2 V / (pi d w), and the free travel
        (groove width - roller diameter) grows by the same.

    Notes
    -----
    Departure: wear of the groove flank or slot wall is not added (its track is long, so its depth is small
    compared with the roller's; lumping k for the pair already mixes the two materials).
    """
    if geometry.is_pin:
        return JointWear(geometry.material_pair, "pin-in-bore", pin_diameter=geometry.diameter,
                         bearing_length=geometry.bearing_length, load_direction=load_direction)
    return JointWear(geometry.material_pair, "area",
                     wear_area=math.pi * geometry.diameter * geometry.bearing_length / 2.0)


def joint_wear_models(machine, joints=None, load_direction: str = "fixed") -> dict[str, JointWear]:
    """:func:`joint_wear_model` for the named pairs (default: every pair of the drive).

    Parameters
    ----------
    machine : MachineBase
        Any drive's machine description.
    joints : iterable of str, optional
        Pair names (default every pair of the drive).
    load_direction : {"fixed", "rotating"}
        Pins only (see :func:`joint_wear_model`).

    Returns
    -------
    dict of str to JointWear
        One wear model per pair, in the order given.
    """
    names = list(joints) if joints else list(machine.pair_names)
    return {j: joint_wear_model(joint_geometry(machine, j), load_direction) for j in names}


# ---- reading the multibody result ----------------------------------------------------------------------
def _joint_spec(result, name: str):
    for j in result.compiled.spec.joints:
        if j.name == name:
            return j
    raise ConfigError(f"the mechanism has no joint {name!r}; joints: "
                      f"{', '.join(j.name for j in result.compiled.spec.joints)}")


def _body_motion(result, body: str):
    """Positions (x, y, angle) and velocities (vx, vy, omega) of a body over the written samples; zeros for
    ground."""
    n_out = result.t.size
    if body == "ground":
        z = np.zeros(n_out)
        return (z, z, z), (z, z, z)
    b = result.compiled.body_index[body]
    n = result.compiled.n
    q = tuple(result.y[:, 3 * b + k] for k in range(3))
    v = tuple(result.y[:, n + 3 * b + k] for k in range(3))
    return q, v


def normal_force(result, pair: str) -> np.ndarray:
    """Normal contact force series of a pair (N): its clearance element, or the ideal joint's reaction.

    Parameters
    ----------
    result : MultibodyResult
        The drive's multibody run.
    pair : str
        Joint name in the mechanism (= the clearance pair's name).

    Returns
    -------
    numpy.ndarray
        |F_n| (N) over the written samples: the clearance element's normal force, or the magnitude of the
        ideal joint's reaction when the pair has no clearance element.
    """
    cm = result.compiled
    if pair in cm.frc_names:
        return np.abs(result.elements[:, cm.frc_names.index(pair), 0])
    return np.abs(result.reaction(pair))


def sliding_speed(result, pair: str, diameter: float, slip: float = DEFAULT_SLIP) -> np.ndarray:
    """Sliding speed at the contact of a pair over the written samples (m/s).

    Parameters
    ----------
    result : MultibodyResult
        The drive's multibody run.
    pair : str
        Joint name in the mechanism (= the clearance pair's name).
    diameter : float
        Pin diameter (m); unused for rollers.
    slip : float
        Slip ratio of a roller (0..1).

    Returns
    -------
    numpy.ndarray
        Sliding speed (m/s).  Pin in a bore: |omega_i - omega_j| d / 2.  Roller: slip * sqrt(|v_rel|^2 - (n . v_rel)^2), with
        v_rel the velocity of the roller centre relative to the material point of the other body under it and
        n . v_rel the penetration rate of the contact element (zero for an ideal joint).
    """
    j = _joint_spec(result, pair)
    (xi, yi, pi_), (vxi, vyi, wi) = _body_motion(result, j.body_i)
    (xj, yj, _pj), (vxj, vyj, wj) = _body_motion(result, j.body_j)
    if j.type in _PIN_TYPES:
        return np.abs(wi - wj) * diameter / 2.0
    if j.type not in _ROLLER_TYPES:
        raise ConfigError(f"joint {pair!r} of type {j.type} has no sliding-speed model")
    if not 0.0 <= slip <= 1.0:
        raise ConfigError(f"slip ratio must be within 0..1, got {slip!r}")
    sx, sy = j.point_i
    c, s = np.cos(pi_), np.sin(pi_)
    rx, ry = c * sx - s * sy, s * sx + c * sy  # point_i from the centre of mass of body i, frame axes
    px, py = xi + rx, yi + ry
    vpx, vpy = vxi - wi * ry, vyi + wi * rx
    vmx, vmy = vxj - wj * (py - yj), vyj + wj * (px - xj)  # material point of body j under the roller
    relx, rely = vpx - vmx, vpy - vmy
    cm = result.compiled
    rate = result.elements[:, cm.frc_names.index(pair), 2] if pair in cm.frc_names else 0.0
    vt2 = np.maximum(relx**2 + rely**2 - np.asarray(rate) ** 2, 0.0)
    return slip * np.sqrt(vt2)


def _comb_swing_deg(result, body: str, sel: np.ndarray) -> float:
    if body not in result.compiled.body_index:
        return math.nan
    ang = np.unwrap(result.y[sel, 3 * result.compiled.body_index[body] + 2])
    return float(np.degrees(ang.max() - ang.min()))


def flat_outputs(summary: dict) -> dict[str, float]:
    """Scalar outputs of a drive summary (multibody or reduced model) under flat names.

    Parameters
    ----------
    summary : dict
        A run summary with ``collision_force_N`` (pair -> stat -> N), ``load_moment_Nm`` (side -> stat -> N m)
        and ``drive_moment_Nm`` (stat -> N m), any of them optional.

    Returns
    -------
    dict
        ``collision_force_<pair>_<peak|mean|rms>`` (N), ``load_moment_<side>_<stat>`` (N m),
        ``drive_moment_<stat>`` (N m) -- whatever the summary has.
    """
    out: dict[str, float] = {}
    for pair, st in summary.get("collision_force_N", {}).items():
        for stat, v in st.items():
            out[f"collision_force_{pair}_{stat}"] = float(v)
    for side, st in summary.get("load_moment_Nm", {}).items():
        for stat, v in st.items():
            out[f"load_moment_{side}_{stat}"] = float(v)
    for stat, v in summary.get("drive_moment_Nm", {}).items():
        if isinstance(v, (int, float)):
            out[f"drive_moment_{stat}"] = float(v)
    return out


def joint_loads(machine, clearances_m: dict[str, float] | None, revolutions: int = 2, slip: float = DEFAULT_SLIP,
                rtol: float = HARVESTER_RTOL, initial_perturbation=None
                ) -> tuple[dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]], dict[str, float]]:
    """Loads of every clearance pair and the scalar outputs of one multibody run (the ``simulate`` callable of
    :func:`berryshaker.life.wear.wear_life`).

    Parameters
    ----------
    machine : MachineBase
        Any drive's machine description.
    clearances_m : dict, optional
        Clearance sizes (m) per pair (machine convention: radial for pins, free travel for rollers); missing
        pairs keep the description's value.
    revolutions : int
        Drive revolutions (>= 2); the loads are over revolutions 2..N (the first is the start-up).
    slip : float
        Roller slip ratio [assumed default 5 %].
    rtol : float
        Relative integrator tolerance (dimensionless; default: the harvester runs', :data:`berryshaker.drives.base.HARVESTER_RTOL`).
    initial_perturbation : InitialPerturbation or RandomInitialPerturbation, optional
        Start off centre in the clearances and at another drive phase (a replicate,
        :mod:`berryshaker.multibody.perturbation`); default the centred start.

    Returns
    -------
    (loads, outputs)
        ``loads[pair] = (t, normal_force, sliding_speed)`` (s, N, m/s) over the steady window, at the
        engine's output step (1e-4 s).  ``outputs``: :func:`flat_outputs` of the run's summary (peaks over
        every integrator step), ``comb_swing_left_deg`` / ``comb_swing_right_deg`` (peak-to-peak comb angle)
        and ``sliding_speed_<pair>_mean`` (m/s).

    Notes
    -----
    Sampling: impacts of the stiff pairs last a few tenths of a millisecond, i.e. a few output samples; the
    window integral of |F| |v| (what Archard's law needs) is less sensitive to this than the peak, which the
    engine takes over every step.
    """
    from berryshaker.drives.simulation import simulate_multibody

    result, summary = simulate_multibody(machine, clearances_m or {}, revolutions=revolutions, rtol=rtol,
                                         initial_perturbation=initial_perturbation)
    sized = machine.with_clearances(clearances_m or {})
    sel = result.t >= result.stats_from - 1e-12
    t = result.t[sel]
    loads = {}
    outputs = flat_outputs(summary)
    for pair in sized.pair_names:
        geo = joint_geometry(sized, pair)
        f = normal_force(result, pair)[sel]
        v = sliding_speed(result, pair, geo.diameter, slip)[sel]
        loads[pair] = (t, f, v)
        outputs[f"sliding_speed_{pair}_mean"] = float(np.mean(v))
    outputs["comb_swing_left_deg"] = _comb_swing_deg(result, "left_comb", sel)
    outputs["comb_swing_right_deg"] = _comb_swing_deg(result, "right_comb", sel)
    return loads, outputs
