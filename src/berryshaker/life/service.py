"""The service limit of a joint and the machine's wear loop: one rule and one loop for every caller.

:func:`service_limits` is the only place the default clearance limit of a joint is decided (``berryshaker
wear``, ``berryshaker tolerance``, the study's clearance-life step and its report all call it);
:func:`machine_wear` drives :func:`berryshaker.life.wear.wear_life` on the machine's multibody dynamics through
the cached runner (``berryshaker wear`` is a thin call to it).  The rule and its assumptions: docs/life.md,
section "Service limit".
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from berryshaker.errors import ConfigError

#: the structural part of the rule: a joint is due for service when its clearance (radial of a pin, free travel
#: of a roller) reaches this fraction of its pin (roller) diameter [assumed]: 0.5 mm on a 20 mm pin, where a
#: bronze bush has lost a third of a typical 1.5 mm wall to wear and the pin's impacts no longer meet a conformal
#: seat
SERVICE_FRACTION = 0.025
#: the rule, stated where the limits are shown
SERVICE_RULE = ("the smaller of the largest clearance at which the harvest was tested (the machine's function is "
                f"known up to it) and {SERVICE_FRACTION:.1%} of the pin (roller) diameter; never the built size")


def service_limit(largest_level: float, diameter: float) -> float:
    """Clearance (m) at which a joint is due for service: ``min(largest_level, SERVICE_FRACTION * diameter)``.

    A property of the joint's function, never of its built size: a looser build reaches it sooner, never later
    (tests/life/test_service.py).

    Parameters
    ----------
    largest_level : float
        The joint's largest test level (m): the largest clearance at which the study measured the harvest, so
        the machine is known to work as tested up to it (its function: the combs' stroke and the harvest).
    diameter : float
        The pin (roller) diameter (m).

    Returns
    -------
    float
        The limit (m; radial for a pin, free travel for a roller).
    """
    return float(min(float(largest_level), SERVICE_FRACTION * float(diameter)))


def service_limits(machine, joints: Sequence[str] | None = None) -> dict[str, float]:
    """Service limit (m) per joint of ``machine`` (default every clearance pair) by :func:`service_limit`.

    Parameters
    ----------
    machine : MachineBase
        Any drive's machine description (its clearance test levels and sizes).
    joints : sequence of str, optional
        Clearance pairs (default every pair of the machine).

    Returns
    -------
    dict of str to float
        Joint -> service limit (m): the smaller of its largest test level and :data:`SERVICE_FRACTION` of its
        diameter (:func:`service_limit`).

    Raises
    ------
    ConfigError
        A joint that is not a clearance pair of the machine.
    """
    from berryshaker.life.joint_loads import joint_geometry

    levels = machine.clearance_levels()
    joints = list(joints) if joints else list(machine.pair_names)
    unknown = [j for j in joints if j not in levels]
    if unknown:
        raise ConfigError(f"joint(s) {', '.join(unknown)}: not a clearance pair of the machine; pairs: "
                          f"{', '.join(machine.pair_names)}")
    return {j: service_limit(max(levels[j]), joint_geometry(machine, j).diameter) for j in joints}


def _start_from_fits(geos: Mapping[str, Any], joints: Sequence[str]) -> dict[str, float]:
    from berryshaker.life.fits import parse_fit
    from berryshaker.life.wear import clearance_size_from_fit

    out = {}
    for j in joints:
        if not geos[j].fit:
            raise ConfigError(f"--from-fit: clearance.{j}.fit is not set in the machine description; set it "
                              f"(e.g. fit = \"H8/f7\") or leave out --from-fit")
        fit = parse_fit(geos[j].fit, geos[j].diameter * 1e3)
        out[j] = clearance_size_from_fit(fit, "revolute" if geos[j].is_pin else "point-line", "mean")
    return out


def machine_wear(machine, hours: float, limits: Mapping[str, float] | None = None, *, runner=None,
                 revolutions: int = 2, load_direction: str = "fixed", slip: float | None = None,
                 joints: Sequence[str] | None = None, from_fit: bool = False,
                 say: Callable[[str], None] | None = None) -> dict:
    """Wear the machine's joints over ``hours`` on its multibody dynamics and return the result as JSON.

    Each state is one cached run (:func:`berryshaker.life.runs.joint_loads_run`) through ``runner``, one job at a
    time because each state depends on the one before, so a repeated call is served from the cache.

    Parameters
    ----------
    machine : MachineBase
        The machine description.
    hours : float
        Operating hours to simulate (h).
    limits : dict, optional
        Limits keyed ``clearance:<joint>`` (m), ``peak_force:<joint>`` / ``mean_force:<joint>`` (N) or an output
        name (SI); default ``clearance:<joint>`` = :func:`service_limits` of every joint that wears.
    runner : SweepRunner, optional
        Cached runner (default a local one-process runner on the default cache, closed at the end).
    revolutions : int
        Drive revolutions per simulation.
    load_direction : {"fixed", "rotating"}
        Load direction on the pins (fixed is conservative).
    slip : float, optional
        Roller slip ratio (default :data:`berryshaker.life.joint_loads.DEFAULT_SLIP`).
    joints : sequence of str, optional
        Joints that wear (default every pair); the others are listed at their size.
    from_fit : bool
        Start each wearing joint from its fit's mean clearance instead of its size.
    say : callable, optional
        Progress messages (one per simulation).

    Returns
    -------
    dict
        :meth:`berryshaker.life.wear.WearLife.to_dict` plus, for every joint, ``maintenance_interval_h`` (h or
        None), ``limits``, ``diameter_mm``, ``bearing_length_mm``, ``material_pair``, ``fit``,
        ``assumed_defaults`` and ``size_convention``; and ``limits_si``, ``horizon_h``, ``simulations``,
        ``simulations_from_cache``, ``wall_time_s`` and the run settings.
    """
    from berryshaker import __version__
    from berryshaker.life.joint_loads import DEFAULT_SLIP, joint_geometry, joint_wear_models
    from berryshaker.life.runs import joint_loads_run, loads_from_json
    from berryshaker.life.wear import wear_life

    slip = DEFAULT_SLIP if slip is None else float(slip)
    joints = list(joints) if joints else list(machine.pair_names)
    limits = dict(limits) if limits else {f"clearance:{j}": v for j, v in service_limits(machine, joints).items()}
    models = joint_wear_models(machine, joints, load_direction)
    geos = {j: joint_geometry(machine, j) for j in machine.pair_names}
    initial = _start_from_fits(geos, joints) if from_fit else None
    own_runner = runner is None
    if own_runner:
        from berryshaker.runs.runner import SweepRunner

        runner = SweepRunner(workers=1, progress=False)
    data = machine.model_dump(mode="json")
    count = {"n": 0, "cached": 0}
    t0 = time.perf_counter()

    def simulate(c):
        count["n"] += 1
        if say:
            say(f"simulation {count['n']}: " + ", ".join(f"{k} {v * 1e3:.4g} mm" for k, v in c.items()))
        before = runner.stats["cached"]
        value = runner.values(joint_loads_run, [dict(machine_data=data, clearance={k: float(v) for k, v in c.items()},
                                                     revolutions=int(revolutions), slip=float(slip))], "wear state")[0]
        count["cached"] += runner.stats["cached"] - before
        return loads_from_json(value)

    try:
        life = wear_life(machine, hours, limits, simulate=simulate, joints=models, initial_clearances=initial)
    finally:
        if own_runner:
            runner.close()
    res = life.to_dict()
    for j in res["joints"]:  # the joints that do not wear are listed too, at their size, with the same keys
        keys = [k for k in life.limits if k.partition(":")[2] == j]
        hits = [life.limits[k]["hours"] for k in keys if life.limits[k]["hours"] is not None]
        g = geos[j]
        res["joints"][j].update(
            maintenance_interval_h=min(hits) if hits else None,
            limits=keys, diameter_mm=g.diameter * 1e3, bearing_length_mm=g.bearing_length * 1e3,
            material_pair=g.material_pair, fit=g.fit, assumed_defaults=list(g.assumed),
            size_convention="radial" if g.is_pin else "free travel")
    res.update(machine=machine.machine.name, drive=machine.DRIVE, horizon_h=float(hours), simulations=count["n"],
               simulations_from_cache=count["cached"], revolutions=int(revolutions), slip=slip,
               load_direction=load_direction, wall_time_s=time.perf_counter() - t0, version=__version__,
               limits_si=dict(limits))
    return res
