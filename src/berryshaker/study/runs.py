"""Run functions of the study's sweeps.  The cached runner (:mod:`berryshaker.runs.runner`) executes them,
possibly on other machines: each is module-level, takes the machine as a JSON-compatible dict and returns
JSON-compatible values."""

from __future__ import annotations

import math

import numpy as np

from berryshaker.config import machine_from_dict
from berryshaker.harvest.spec import COUPLED_RTOL


def multibody_row(machine_data: dict, clearance: dict, revolutions: int = 3, seed: list | None = None) -> dict:
    """Multibody summary of one clearance set.  ``seed``: start from the seeded perturbation (clearance
    eccentricities uniform over ``harvest.initial_eccentricity`` of each free radius, drive turned by up to
    ``harvest.start_phase_spread``: berryshaker.multibody.perturbation.RandomInitialPerturbation), a replicate.

    Parameters
    ----------
    machine_data : dict
        Machine description (SI, ``model_dump(mode="json")``).
    clearance : dict
        Clearance size (m) per pair; missing pairs keep the description's.
    revolutions : int
        Drive revolutions; statistics over 2..N.
    seed : list of int, optional
        Seed sequence of the replicate's perturbation (default the centred start).

    Returns
    -------
    dict
        The multibody summary (:func:`berryshaker.drives.simulation.simulate_multibody`, statistics only).
    """
    from berryshaker.drives.simulation import simulate_multibody
    from berryshaker.harvest.virtual import machine_start

    machine = machine_from_dict(machine_data)
    pert = None if seed is None else machine_start(machine, seed)
    return simulate_multibody(machine, clearance, revolutions=revolutions, initial_perturbation=pert,
                              series="statistics")[1]


def powered_row(machine_data: dict, clearance: dict, revolutions: int = 3, seed: list | None = None) -> dict:
    """Multibody summary of one clearance set with the powered driveline turning the drive shaft
    (drives/powered.py: cam speed, ripple, input power, energy lost per revolution in each joint).  ``seed``:
    start from the seeded perturbation (clearance eccentricities uniform over ``harvest.initial_eccentricity`` of
    each free radius, berryshaker.multibody.perturbation.RandomInitialPerturbation), a replicate.

    Parameters
    ----------
    machine_data : dict
        Machine description (SI, ``model_dump(mode="json")``).
    clearance : dict
        Clearance size (m) per pair; missing pairs keep the description's.
    revolutions : int
        Drive revolutions; statistics over 2..N.
    seed : list of int, optional
        Seed sequence of the replicate's perturbation (default the centred start).

    Returns
    -------
    dict
        The multibody summary with the driveline's statistics.
    """
    from berryshaker.drives.simulation import simulate_multibody
    from berryshaker.harvest.virtual.seeds import seed_sequence
    from berryshaker.multibody.perturbation import RandomInitialPerturbation

    machine = machine_from_dict(machine_data)
    # eccentricities only: the powered drive starts at rest on the motor's side of the belt, and a turned cam would
    # not be the state the driveline's own start-up assembles (a turned start assembles and runs since 0.2.0:
    # tests/multibody/test_assembly.py)
    pert = None if seed is None else RandomInitialPerturbation(seed_sequence(machine.harvest.seed, seed),
                                                               machine.harvest.initial_eccentricity)
    return simulate_multibody(machine, clearance, revolutions=revolutions, driveline="powered",
                              initial_perturbation=pert, series="statistics")[1]


def model_check_jobs(machine, clearance: dict, starts: int, revolutions: int = 3) -> list[dict]:
    """Arguments of :func:`multibody_row` and :func:`reduced_row` for the model check's replicate starts (claim 1;
    ``berryshaker compare``): seeds (seed_k, MODEL_CHECK_LEVEL) with seed_k of
    :func:`berryshaker.harvest.virtual.replicate_starts`, at ``clearance``.

    Parameters
    ----------
    machine : MachineBase
        The machine description.
    clearance : dict
        Clearance size (m) per pair.
    starts : int
        Number of replicate starts.
    revolutions : int
        Drive revolutions per run.

    Returns
    -------
    list of dict
        One keyword-argument dict per start (``machine_data``, ``clearance``, ``revolutions``, ``seed``).

    Raises
    ------
    ConfigError
        ``harvest.start_phase_spread`` is 0 (every start would be the same run).
    """
    from berryshaker.errors import ConfigError
    from berryshaker.harvest.virtual import MODEL_CHECK, replicate_starts
    from berryshaker.reference_study import MODEL_CHECK_LEVEL

    if machine.harvest.start_phase_spread == 0:
        raise ConfigError("harvest.start_phase_spread is 0: the reduced model's replicate starts (turned by up to "
                          "it; its joints start centred) would all be the same run, and copies show no noise; give "
                          "an angle > 0 (the reference: 180 deg)")
    data = machine.model_dump(mode="json")
    return [dict(machine_data=data, clearance=dict(clearance), revolutions=revolutions,
                 seed=[k, MODEL_CHECK, MODEL_CHECK_LEVEL]) for k in replicate_starts(machine, starts)]


def reduced_row(machine_data: dict, clearance: dict, revolutions: int = 3, seed: list | None = None) -> dict:
    """Summary of the drive's reduced model (the groove cam's MLSD) for one clearance set.  ``seed``: a replicate,
    started at a cam angle drawn uniform in +-``harvest.start_phase_spread`` (numpy's generator seeded with it; the
    reduced model's joints start centred).

    Parameters
    ----------
    machine_data : dict
        Machine description (SI, ``model_dump(mode="json")``).
    clearance : dict
        Clearance size (m) per pair; missing pairs keep the description's.
    revolutions : int
        Drive revolutions; statistics over 2..N.
    seed : list of int, optional
        Seed sequence of the replicate's perturbation (default the centred start).

    Returns
    -------
    dict
        The reduced model's summary.
    """
    from berryshaker.drives import drive_of

    machine = machine_from_dict(machine_data)
    kw = {}
    if seed is not None:
        spread = machine.harvest.start_phase_spread
        from berryshaker.harvest.virtual.seeds import seed_sequence

        kw["start_angle"] = float(np.random.default_rng(seed_sequence(machine.harvest.seed, seed)).uniform(-spread,
                                                                                                         spread))
    return drive_of(machine).reduced_model(machine, clearance, revolutions=revolutions, **kw).summary()


def fruit_force_run(machine_data: dict, clearance: dict) -> dict:
    """Coupled drive-past run: summary, force series thinned by peak-preserving min-max decimation for figures,
    exact peaks.

    Parameters
    ----------
    machine_data : dict
        Machine description (SI, ``model_dump(mode="json")``) with a [plant] block.
    clearance : dict
        Clearance size (m) per pair.

    Returns
    -------
    dict
        ``summary`` (:meth:`berryshaker.harvest.coupled.FruitForceResult.summary`), ``distance`` (m) and
        ``forces`` (N per fruit) decimated to about 2000 points, ``peaks_exact`` (N per fruit), ``transmission``
        (:func:`berryshaker.harvest.transmission.impact_transmission`).
    """
    from berryshaker.harvest.coupled import simulate_fruit_force
    from berryshaker.harvest.transmission import impact_transmission
    from berryshaker.report.style import decimate_minmax_shared

    r = simulate_fruit_force(machine_from_dict(machine_data), clearance)
    # min-max decimation keeps every series' peaks (a strided series could miss an impact peak)
    distance, forces = decimate_minmax_shared(r.distance, r.fruit_force, 2000)
    return {"summary": r.summary(), "distance": distance.tolist(),
            "forces": {k: v.tolist() for k, v in forces.items()},
            "peaks_exact": {k: float(np.max(np.abs(v))) for k, v in r.fruit_force.items()},
            "transmission": impact_transmission(r)}


def replicate_run(machine_data: dict, clearance: dict, seed: list, rtol: float = COUPLED_RTOL) -> dict:
    """One replicate start of a virtual test run: the coupled drive-past carrying every branch class as a probe.

    Branch class c's machine start is the spawn key ``[*seed, c]`` (``seed`` = ``[k, MACHINE]`` for start k,
    berryshaker.harvest.virtual.seeds): clearance eccentricities and a drive phase
    (:class:`berryshaker.multibody.perturbation.RandomInitialPerturbation` with the description's
    ``harvest.initial_eccentricity`` / ``harvest.start_phase_spread``).  The run starts from one class's start and
    carries every class's branch as a one-way probe meeting the comb at its own class's drive phase
    (:func:`berryshaker.harvest.virtual.class_tables_run`).  Returns every class's stem-load table (peaks and
    Miner-Basquin equivalent load ratios) and the run's machine loads (:func:`replicate_record`).

    Parameters
    ----------
    machine_data : dict
        Machine description (SI, ``model_dump(mode="json")``) with [plant] and [harvest].
    clearance : dict
        Clearance size (m) per pair.
    seed : list of int
        Spawn key of the start; class c's machine start is ``[*seed, c]``.
    rtol : float
        Relative integrator tolerance (dimensionless).

    Returns
    -------
    dict
        :func:`replicate_record` of the run and ``harvest``, the start's harvest responses (:func:`start_harvest`).
    """
    from berryshaker.harvest.virtual import class_tables_run, machine_start

    machine = machine_from_dict(machine_data)
    starts = [machine_start(machine, [*seed, c]) for c in range(len(machine.harvest.branch_classes))]
    tables, res = class_tables_run(machine, clearance, starts, rtol)
    out = replicate_record(machine, tables, res)
    out["harvest"] = start_harvest(machine_data, machine, tables, int(seed[0]))
    return out


def start_harvest(machine_data: dict, machine, tables: list, start: int) -> dict:
    """The harvest responses of a start (:func:`berryshaker.harvest.virtual.start_responses`: expectation, field
    test, counting SD), computed where its drive-past ran and kept with it, so that a study reading the run from the
    cache reads them too.  They are read back (:func:`stored_harvest`) only for the same description, start and
    response table.

    Parameters
    ----------
    machine_data : dict
        The description the run was computed with (SI, ``model_dump(mode="json")``).
    machine : Machine
        The same description, validated.
    tables : list of numpy.ndarray
        The start's stem-load table per branch class (N, dimensionless load ratios).
    start : int
        The start's number (its field test's stream).

    Returns
    -------
    dict
        ``start``, ``description`` (:func:`berryshaker.runs.cache.value_digest` of ``machine_data``), ``responses`` (the table's names, in order) and
        :func:`~berryshaker.harvest.virtual.start_responses`' ``expected``, ``field`` and ``count_sd``.
    """
    from berryshaker.harvest.virtual import RESPONSES, start_responses
    from berryshaker.runs.cache import value_digest

    return {"start": start, "description": value_digest(machine_data), "responses": list(RESPONSES),
            **start_responses(machine, tables, start)}


def stored_harvest(out: dict, digest: str, start: int) -> dict | None:
    """The harvest responses a run output keeps (:func:`start_harvest`) if they are of description ``digest``, start
    ``start`` and today's response table (every row defined in the package, whose code the run's cache key covers),
    else None: the caller computes them.

    Parameters
    ----------
    out : dict
        A :func:`replicate_run` output.
    digest : str
        :func:`berryshaker.runs.cache.value_digest` of the description the caller reads the responses for.
    start : int
        The start's number.

    Returns
    -------
    dict or None
        ``expected``, ``field`` and ``count_sd`` (response name -> value), or None.
    """
    from berryshaker.harvest.virtual import RESPONSES

    h = out.get("harvest")
    if (not isinstance(h, dict) or h.get("description") != digest or h.get("start") != start
            or h.get("responses") != list(RESPONSES)
            or any(not getattr(r.value, "__module__", "").startswith("berryshaker.") for r in RESPONSES.values())):
        return None
    return {k: h[k] for k in ("expected", "field", "count_sd")}


def replicate_record(machine, tables, res) -> dict:
    """What :func:`replicate_run` keeps of one start's drive-past: the stem-load tables ``tables`` (one per branch
    class: peaks and Miner-Basquin equivalent load ratios) and, from the run ``res``, the peak force of every
    clearance pair, each impact's peak and the drive torque's peak and RMS.

    Parameters
    ----------
    machine : MachineBase
        The machine description (its pair names).
    tables : list of numpy.ndarray
        Peak stem-force table of each branch class (N, dimensionless load ratios).
    res : MultibodyResult
        The coupled run.

    Returns
    -------
    dict
        ``envelopes`` (the tables, numpy.ndarray each, in ``harvest.branch_classes`` order), ``peak_force_N`` (N per
        pair: the run's single largest force, an extreme), ``impact_peaks_N`` (per clearance pair, the peak of each
        of its impacts over the statistics window, N: berryshaker.multibody.impacts) and, for a speed-driven machine,
        ``drive_torque_Nm`` (``peak``: the run's single largest moment, an extreme; ``rms``; ``revolution_peaks``: the
        peak |M| of each whole revolution; ``fatigue_equivalent``: berryshaker.multibody.drive_loads; all N m).
    """
    s = res.summary()
    out = {"envelopes": [np.asarray(t, float) for t in tables],
           "peak_force_N": {p: s["joints"][p]["force_N"]["peak"] for p in machine.pair_names if p in s["joints"]},
           "impact_peaks_N": {}}
    for p in machine.pair_names:
        if p in res.compiled.frc_names:
            out["impact_peaks_N"][p] = np.asarray(res.contact_episodes(p).impacts().peak_N, float)
    if s["drivers"]:
        from berryshaker.multibody.drive_loads import fatigue_equivalent_torque, revolution_peaks

        name = next(iter(s["drivers"]))
        tq = s["drivers"][name]["torque_Nm"]
        sel = res.t >= res.stats_from - 1e-12
        m = res.reaction(name)[sel]
        out["drive_torque_Nm"] = {"peak": tq["peak"], "rms": tq["rms"],
                                  "revolution_peaks": revolution_peaks(res.t[sel], m, res.stats_from,
                                                                       2 * math.pi / machine.drive_speed),
                                  "fatigue_equivalent": fatigue_equivalent_torque(m)}
    return out


def import_run_modules() -> None:
    """Import the modules the study's runs need (a worker prime, :meth:`SweepRunner.start_workers`: a started
    worker imports them while the study's process loads and checks the description, not when its first run
    comes)."""
    import berryshaker.drives.simulation  # noqa: F401 - imported for its side effect, the module cache
    import berryshaker.harvest.coupled  # noqa: F401
    import berryshaker.harvest.virtual  # noqa: F401
    import berryshaker.multibody.engine  # noqa: F401
    import berryshaker.multibody.perturbation  # noqa: F401


def warm_worker(machine_data: dict) -> dict:
    """Compile, in a pool worker at the start of a study, the multibody engine's force evaluation (every force
    element and contact law) and the step helpers that evaluate the laws
    (:func:`berryshaker.multibody.engine.compile_engine`, parts ``"forces"`` and ``"step_forces"``) while the
    study's process compiles the projection and the event helpers: both land in numba's on-disk cache, and the
    study's process then compiles the right-hand side and the integrator on top of them.  Returns CPU seconds.

    Parameters
    ----------
    machine_data : dict
        Machine description (SI, ``model_dump(mode="json")``): its drive's mechanism is compiled.

    Returns
    -------
    dict
        CPU seconds (s) per compiled part (:func:`berryshaker.multibody.engine.compile_engine`).
    """
    from berryshaker.drives import drive_of
    from berryshaker.multibody.engine import compile_engine

    machine = machine_from_dict(machine_data)
    return compile_engine(drive_of(machine).mechanism(machine, revolutions=2), ("forces", "step_forces"))
