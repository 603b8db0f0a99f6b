"""Module-level run functions of the clearance-life work for the cached sweep runner
(:class:`berryshaker.runs.runner.SweepRunner`): each takes JSON-able keyword arguments (the machine as a dict,
SI numbers) and returns a JSON-compatible dict, so a run is cached under the hash of its inputs and the code.
"""

from __future__ import annotations

import json
import math

import numpy as np

from berryshaker.life.joint_loads import DEFAULT_SLIP


def machine_with_overrides(machine_data: dict, overrides: dict | None = None):
    """A validated machine from its JSON dict with SI overrides at dotted keys (``clearance.A.size``).

    Parameters
    ----------
    machine_data : dict
        Machine description (SI, ``model_dump(mode="json")``); not modified (a deep copy is changed).
    overrides : dict, optional
        Dotted key -> SI value; each key must already exist in the description.

    Returns
    -------
    MachineBase
        The machine description validated with the overrides applied.

    Raises
    ------
    ConfigError
        A key that is not in the description, or a value the description refuses.
    """
    from berryshaker.config import machine_from_dict
    from berryshaker.errors import ConfigError

    data = json.loads(json.dumps(machine_data))
    for key, value in (overrides or {}).items():
        node = data
        parts = key.split(".")
        for k in parts[:-1]:
            if not isinstance(node, dict) or k not in node:
                raise ConfigError(f"unknown parameter {key!r} (no {k!r} in the machine description); "
                                  "use a dotted key of `berryshaker config show --json`, e.g. clearance.A.size")
            node = node[k]
        if not isinstance(node, dict) or parts[-1] not in node:
            raise ConfigError(f"unknown parameter {key!r}; use a dotted key of `berryshaker config show --json`")
        node[parts[-1]] = value
    return machine_from_dict(data, "(parameter override)")


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def joint_loads_run(machine_data: dict, clearance: dict, revolutions: int = 2, slip: float = DEFAULT_SLIP) -> dict:
    """One multibody run of :func:`berryshaker.life.joint_loads.joint_loads` in JSON form.

    Parameters
    ----------
    machine_data : dict
        Machine description (SI, ``model_dump(mode="json")``).
    clearance : dict
        Clearance size (m) per pair; missing pairs keep the description's value.
    revolutions : int
        Drive revolutions (>= 2); loads over revolutions 2..N.
    slip : float
        Roller slip ratio (dimensionless).

    Returns
    -------
    dict
        ``loads[pair] = {"t": [...], "force": [...], "speed": [...]}`` (s, N, m/s) and ``outputs`` (name ->
        float or None); :func:`loads_from_json` turns it back into arrays.
    """
    from berryshaker.life.joint_loads import joint_loads

    machine = machine_with_overrides(machine_data)
    loads, outputs = joint_loads(machine, clearance, revolutions=revolutions, slip=slip)
    return {"loads": {j: {"t": t.tolist(), "force": f.tolist(), "speed": v.tolist()} for j, (t, f, v) in loads.items()},
            "outputs": {k: _finite(v) for k, v in outputs.items()}}


def loads_from_json(value: dict) -> tuple[dict, dict]:
    """``(loads, outputs)`` of a :func:`joint_loads_run` value, as the wear loop takes them.

    Parameters
    ----------
    value : dict
        The value of :func:`joint_loads_run`.

    Returns
    -------
    loads : dict
        Pair -> (t, normal_force, sliding_speed) arrays (s, N, m/s).
    outputs : dict
        Name -> float, NaN where the run stored None.
    """
    loads = {j: (np.asarray(d["t"], float), np.asarray(d["force"], float), np.asarray(d["speed"], float))
             for j, d in value["loads"].items()}
    outputs = {k: (math.nan if v is None else float(v)) for k, v in value["outputs"].items()}
    return loads, outputs


def wear_rate_run(machine_data: dict, clearance: dict, revolutions: int = 2, slip: float = DEFAULT_SLIP,
                  load_direction: str = "fixed", seed: list | None = None) -> dict:
    """Clearance growth rate, peak and mean force of every pair at one clearance state (one multibody run).

    ``seed``: start from the seeded perturbation (a replicate: clearance eccentricities uniform over
    ``harvest.initial_eccentricity`` of each free radius, drive turned by up to ``harvest.start_phase_spread``,
    :class:`berryshaker.multibody.perturbation.RandomInitialPerturbation`); default the centred start.

    Parameters
    ----------
    machine_data : dict
        Machine description (SI, ``model_dump(mode="json")``).
    clearance : dict
        Clearance size (m) per pair; missing pairs keep the description's value.
    revolutions : int
        Drive revolutions (>= 2); loads over revolutions 2..N.
    slip : float
        Roller slip ratio (dimensionless).
    load_direction : {"fixed", "rotating"}
        Pins' wear depth model (:func:`berryshaker.life.joint_loads.joint_wear_model`).
    seed : list of int, optional
        Seed sequence of the replicate's perturbation (see above).

    Returns
    -------
    dict
        ``growth_rate_m_per_h[pair]`` (Archard, :func:`berryshaker.life.joint_loads.joint_wear_model` with the
        description's geometry and material), ``peak_force_N[pair]`` (over every integrator step),
        ``mean_force_N[pair]``, ``clearance_m[pair]`` and the flat ``outputs``.
    """
    from berryshaker.life.joint_loads import joint_loads, joint_wear_models
    from berryshaker.life.wear import SECONDS_PER_HOUR

    machine = machine_with_overrides(machine_data)
    pert = None
    if seed is not None:
        from berryshaker.harvest.virtual import machine_start

        pert = machine_start(machine, seed)
    loads, outputs = joint_loads(machine, clearance, revolutions=revolutions, slip=slip, initial_perturbation=pert)
    models = joint_wear_models(machine, load_direction=load_direction)
    sized = machine.with_clearances(clearance)
    rate, peak, mean = {}, {}, {}
    for j, (t, f, v) in loads.items():
        rate[j] = models[j].growth_rate(t, f, v) * SECONDS_PER_HOUR
        peak[j] = outputs.get(f"collision_force_{j}_peak", float(np.max(f)))
        mean[j] = float(np.trapezoid(f, t) / (t[-1] - t[0]))
    return {"growth_rate_m_per_h": rate, "peak_force_N": peak, "mean_force_N": mean,
            "clearance_m": sized.clearance_sizes(), "outputs": {k: _finite(v) for k, v in outputs.items()}}


def summary_outputs_run(machine_data: dict, overrides: dict, model: str = "mlsd", revolutions: int = 2) -> dict:
    """Flat scalar outputs of one run at SI parameter overrides (for Sobol sensitivity).

    Parameters
    ----------
    machine_data : dict
        Machine description (SI, ``model_dump(mode="json")``).
    overrides : dict
        Dotted key -> SI value, e.g. ``{"clearance.A.size": 3e-4}``.
    model : {"mlsd", "multibody"}
        The drive's reduced model (fast) or the multibody engine (then the comb swings and sliding speeds are
        outputs too).
    revolutions : int
        Drive revolutions; statistics over 2..N.

    Returns
    -------
    dict
        name -> float (None where not finite); see :func:`berryshaker.life.joint_loads.flat_outputs`.
    """
    from berryshaker.drives import drive_of
    from berryshaker.errors import ConfigError
    from berryshaker.life.joint_loads import flat_outputs, joint_loads

    machine = machine_with_overrides(machine_data, overrides)
    drive = drive_of(machine)
    if model == "mlsd":
        if drive.reduced_model is None:
            raise ConfigError(f"the {drive.name} drive has no reduced model; use --model multibody")
        outputs = flat_outputs(drive.reduced_model(machine, {}, revolutions=revolutions).summary())
    elif model == "multibody":
        outputs = joint_loads(machine, {}, revolutions=revolutions)[1]
    else:
        raise ConfigError(f"--model {model!r}: choose mlsd or multibody")
    return {k: _finite(v) for k, v in outputs.items()}
