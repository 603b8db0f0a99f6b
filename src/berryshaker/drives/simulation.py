"""Running any drive's mechanism through the generic multibody engine and summarising it the same way for
every drive (collision force per clearance pair, comb load moments, drive moment)."""

from __future__ import annotations

import math

import numpy as np

from berryshaker.drives import drive_of
from berryshaker.errors import ConfigError
from berryshaker.multibody.engine import MultibodyResult, simulate_mechanism


def _stats(series: np.ndarray, sel: np.ndarray, peak: float = 0.0) -> dict:
    y = np.abs(series[sel])
    return {"peak": float(max(peak, y.max())), "mean": float(y.mean()), "rms": float(np.sqrt(np.mean(y**2)))}


def multibody_summary(machine, result: MultibodyResult) -> dict:
    """The JSON of ``simulate --model multibody``: collision force per pair (N), comb load moments (N m), drive
    moment (N m; ``mean`` signed, in the direction of rotation), integrator statistics.

    Statistics are over revolutions 2..N (the first is the start-up from the centred joints).  A pair with zero
    clearance reports its ideal joint's reaction force, not a collision force (``pair_state`` says which).
    """
    cm = result.compiled
    sel = result.t >= result.stats_from - 1e-12
    n_rev = int(round(result.t[-1] * machine.drive_speed / (2 * math.pi)))
    out = {"model": "multibody", "drive": machine.DRIVE,
           "clearance_mm": {p: v * 1e3 for p, v in machine.clearance_sizes().items()},
           "collision_force_N": {}, "pair_state": {}, "load_moment_Nm": {}, "drive_moment_Nm": {}}
    for p in machine.pair_names:
        if p in cm.frc_names:
            k = cm.frc_names.index(p)
            out["collision_force_N"][p] = _stats(result.elements[:, k, 0], sel, result.peaks[k])
            out["pair_state"][p] = "clearance"
        else:
            out["collision_force_N"][p] = _stats(result.reaction(p), sel)
            out["pair_state"][p] = "ideal joint (reaction force)"
    for side, name in (("left", "bush_left"), ("right", "bush_right")):
        if name in cm.frc_names:
            out["load_moment_Nm"][side] = _stats(result.elements[:, cm.frc_names.index(name), 0], sel)
    if out["load_moment_Nm"]:  # a run without a plant: the comb's load is the aggregate model (docs/plant.md)
        out["load_model"] = "aggregate (no plant in this run)"
    torque = -result.reaction("drive")  # moment in the direction of rotation
    out["drive_moment_Nm"] = _stats(torque, sel)
    out["drive_moment_Nm"]["mean"] = float(np.mean(torque[sel]))
    out.update(steps=int(result.info[0]), rejected_steps=int(result.info[1]),
               contact_onsets_located=int(result.info[2]), wall_time_s=result.wall_time_s,
               revolutions=n_rev, statistics_over=f"revolutions 2..{n_rev}")
    return out


def simulate_multibody(machine, clearance: dict[str, float] | None = None, revolutions: int = 2,
                       rtol: float = 1e-6, output_step: float = 1e-4) -> tuple[MultibodyResult, dict]:
    """Simulate a machine's drive in the multibody engine.

    Parameters
    ----------
    machine : MachineBase
        Any drive's machine description.
    clearance : dict, optional
        Clearance sizes (m) per pair name; missing pairs keep the description's value.
    revolutions : int
        Drive-shaft revolutions (>= 2; statistics exclude the first).
    rtol : float
        Relative tolerance of the integrator.
    output_step : float
        Spacing of the written series (s); peaks are taken over every step.

    Returns
    -------
    (MultibodyResult, dict)
        The full result and :func:`multibody_summary`.
    """
    if revolutions < 2:
        raise ConfigError("--revolutions must be >= 2 (statistics exclude the first revolution)")
    machine = machine.with_clearances(clearance)
    spec = drive_of(machine).mechanism(machine, revolutions=revolutions)
    result = simulate_mechanism(spec, rtol=rtol, output_step=output_step)
    return result, multibody_summary(machine, result)
