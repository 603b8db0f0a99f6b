"""Stem-force tables of the branch classes: a coupled drive-past of a branch class (the reference branch with its
diameters scaled) gives a table of peak stem loads over position along the branch (:data:`Z_GRID`) and fruit mass
(:data:`MASS_FACTORS` x m0), and the reading of a table at each fruit of a population (peak force, peak and
Miner-Basquin equivalent pull-shear load ratios).  A replicate start's classes are one-way probes of one drive-past,
each meeting the comb at its own class's drive phase (:func:`class_tables_run`); one class alone is
:func:`stem_force_envelope_run` (berryshaker.harvest.coupled.drive_past).  Part of the virtual harvest
(berryshaker.harvest.virtual).  long module: the tables, their one-run computation for a start's classes and their
reading at a fruit are one idea, the stem-load table; its axes and channels are defined once here.

**A table read at another pedicel stiffness** (``stiffness_scale`` a of :func:`fruit_load_channels`,
:func:`fruit_peak_force`, :func:`fruit_peak_load`; ``calibrate`` learns the stiffness this way).  The fruit are
one-way coupled (the branch motion y(t) does not depend on them), and the pedicel's damping is taken proportional to
its stiffness (c / k = 2.7 ms fixed, the stiffness-proportional damping of one viscoelastic material; the damping
ratio then grows as sqrt(a)).  A fruit of mass m on a pedicel (a k, a c) obeys m x'' + a c (x' - y') + a k (x - y)
= 0, which divided by a is the equation of a fruit of mass m / a on the described pedicel (k, c): the same motion
x(t).  Its stem force a [k (y - x) + c (y' - x')] plus its weight m g is a times the force of the fruit of mass
m / a, weight (m / a) g included.  So every force channel at (a k, m) is a times the table's at (k, m / a), and
every load ratio (homogeneous of degree 1 in the forces: the pull-shear ratio, its clipping of compression, the
relative reversal gate and the Miner-Basquin sum) likewise: exact, tested, up to the interpolation in log mass.
The named fruit of a two-way coupled run load the branch at the described stiffness; their effect on the branch
motion (a few per cent at the named fruit's own forces, docs/plant.md) is not rescaled.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from berryshaker.config import Machine, machine_from_dict
from berryshaker.harvest.spec import COUPLED_RTOL

Z_GRID = np.linspace(0.0, 1.0, 41)


def acceleration_envelope(machine: Machine, clearance: dict[str, float] | None, scale: float) -> np.ndarray:
    """Peak |acceleration| (m/s^2) along the branch (at Z_GRID fractions) for one branch class.

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    clearance : dict of str to float or None
        Clearance sizes (m) per pair; None keeps the description's.
    scale : float
        Diameter scale of the branch class (dimensionless).

    Returns
    -------
    numpy.ndarray
        Peak lateral acceleration (m/s^2) over the drive-past at each fraction of :data:`Z_GRID`.
    """
    from berryshaker.harvest.coupled import drive_past

    m = branch_class_machine(machine, scale)
    _, motion = drive_past(m, clearance)
    # fruit forces are m0 * acceleration; recover accelerations on the grid from the modal solution
    acc = motion.lateral(Z_GRID * m.plant.branch.length)[2]  # (nz, n_t)
    return np.max(np.abs(acc), axis=1)


#: the factor by which a pedicel's stiffness may differ from the description's when a table is read
#: (:func:`fruit_load_channels`, ``stiffness_scale``): the tables' mass axis covers the fruit masses of the
#: description (0.4-2.5 m0, beyond 4.5 standard deviations of the fruit-mass CV 0.2) divided by every stiffness scale
#: from 1 / STIFFNESS_RANGE to STIFFNESS_RANGE, which bounds ``calibrate``'s pedicel-stiffness prior
STIFFNESS_RANGE = 2.5

#: fruit-mass factors (of m0) of the stem-force table: 0.4-2.5 m0 in 16 equal steps of log mass (0.115) and eight
#: steps more on each side (0.16-6.25 m0), so a stiffness scaled by up to :data:`STIFFNESS_RANGE` either way is read
#: inside the table; fruit in between are interpolated in log mass.  The interpolation's error is second order in
#: the step: a start's expected harvest responses differ from those of a 129-factor axis by at most 0.7 % at this
#: step (unripe shedding; efficiency +0.4 %) and by up to 2.9 % at twice the step (17 factors), which the test's 1 %
#: criterion refuses (tests/harvest/test_virtual_sampling.py)
MASS_FACTORS = np.exp(np.linspace(math.log(0.4 / STIFFNESS_RANGE), math.log(2.5 * STIFFNESS_RANGE), 33))


def stem_force_envelope(machine: Machine, clearance: dict[str, float] | None, scale: float) -> np.ndarray:
    """Peak stem force (N) of fruit on compliant pedicels, table over Z_GRID (rows) x MASS_FACTORS * m0
    (:func:`stem_force_envelope_run` from the centred initial state).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    clearance : dict of str to float or None
        Clearance sizes (m) per pair; None keeps the description's.
    scale : float
        Diameter scale of the branch class (dimensionless).

    Returns
    -------
    numpy.ndarray
        The table of :func:`stem_force_table`: (Z_GRID, MASS_FACTORS, channels), force in N and load ratios
        dimensionless.
    """
    return stem_force_envelope_run(machine, clearance, scale)[0]


#: output step (s) of the coupled drive-past behind a stem-force envelope (and a replicate's drive torque):
#: the integrator's step cap, so at most one written sample per step.  Chosen by
#: tests/harvest/test_virtual_sampling.py: on one trajectory (the engine's steps do not depend on the output grid)
#: the envelope at 1e-4 s is within 1.2e-4 of a 1e-5 s grid (1.2e-4 of 2e-5 s) and the sampled drive-torque peak and RMS within
#: 0.7 %, far inside a replicate's scatter (drive torque peak: SD ~7 %); 5e-4 s misses (torque RMS 3 %).
#: It was 2e-5 s with every 5th sample used: the same envelope, 14 % more CPU per run.
ENVELOPE_OUTPUT_STEP = 1e-4


#: sampling step (s) of the fruit oscillators behind a stem-force table (compliant pedicels): every
#: ``TABLE_STEP / ENVELOPE_OUTPUT_STEP``-th sample of the branch motion, first-order hold between samples.  The fruit
#: is a 12 Hz oscillator (k = 10 N/m, m0 = 1.8 g), 170 samples per period at this step; the discretisation is second
#: order (the table's error grows 4x per doubling of the step).  Chosen by tests/harvest/test_virtual_sampling.py:
#: every table entry of at least a tenth of its channel's maximum (the loads that can detach a fruit) within 1e-3 of
#: the table at :data:`ENVELOPE_OUTPUT_STEP` (measured 1.4e-4 on the reference drive-past; 6.5e-4 at 1e-3 s, 2.0e-3 at
#: 2e-3 s, which misses); the pass over the motion costs a fifth of the run's grid.  The rigid-fruit force (m x the
#: branch acceleration, whose impact spikes last a few samples) is read at every sample.
TABLE_STEP = 5e-4


def stem_force_envelope_run(machine: Machine, clearance: dict[str, float] | None, scale: float,
                            initial_perturbation=None, rtol: float = COUPLED_RTOL):
    """Peak stem-force table of one branch class and the coupled run it came from: ``(table, result)``.

    Table: :func:`stem_force_table` of the branch class ``scale`` (diameters scaled); ``result``: the
    run's :class:`~berryshaker.multibody.engine.MultibodyResult` (collision forces, drive torque).
    ``initial_perturbation`` and ``rtol`` go to the coupled run
    (:func:`berryshaker.harvest.coupled.drive_past`, the run of
    :func:`berryshaker.harvest.coupled.simulate_fruit_force` without its named fruit): a replicate starts the
    machine off centre in its clearances and at another drive phase.

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    clearance : dict of str to float or None
        Clearance sizes (m) per pair; None keeps the description's.
    scale : float
        Diameter scale of the branch class (dimensionless).
    initial_perturbation : InitialPerturbation or RandomInitialPerturbation, optional
        Start of a replicate (default the centred start).
    rtol : float
        Relative integrator tolerance (dimensionless).

    Returns
    -------
    table : numpy.ndarray
        :func:`stem_force_table` (N for the force channel, dimensionless load ratios).
    result : MultibodyResult
        The coupled run, written every :data:`ENVELOPE_OUTPUT_STEP`.
    """
    from berryshaker.harvest.coupled import drive_past

    m = branch_class_machine(machine, scale)
    res, motion = drive_past(m, clearance, rtol=rtol, initial_perturbation=initial_perturbation,
                             output_step=ENVELOPE_OUTPUT_STEP)
    return stem_force_table(m, motion), res


def class_phase_offsets(machine: Machine, clearance: dict[str, float] | None, perturbations,
                        step: float = ENVELOPE_OUTPUT_STEP) -> tuple[int, list, list]:
    """Where each branch class's probe stands in the one drive-past of a start (:func:`class_tables_run`).

    Each class c has its own machine start (``perturbations[c]``, e.g. :func:`berryshaker.harvest.virtual.machine_start`
    ``(k, MACHINE, c)``) and so its own drive phase phi_c at the bush.  The run starts from the start of one class
    c0; a probe at row offset d meets the comb d / v later (v the walking speed), when the drive has turned omega d /
    v further, so class c's probe stands at d_c = v ((phi_c - phi_c0) / omega mod 2 pi / |omega|) and meets the comb
    at its own phase.  c0 is the class that makes the largest offset the smallest (the run the shortest).  Each
    offset is rounded to a whole number of output steps (``step``: the probe's passage starts on a sample of the
    run; the phase then is its class's within omega step / 2, 6e-4 rad at 2 Hz and 0.1 ms).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant], [harvest] and [operation].
    clearance : dict of str to float or None
        Clearance sizes (m) per pair; None keeps the description's.
    perturbations : sequence of RandomInitialPerturbation or InitialPerturbation
        One machine start per branch class.
    step : float
        Output step of the run (s).

    Returns
    -------
    first : int
        c0, the class whose machine start the run starts from.
    offsets : list of float
        d_c per class (m, >= 0; 0 for c0).
    drawn : list of InitialPerturbation
        Each class's drawn start (eccentricities m, drive phase rad).
    """
    from berryshaker.drives import drive_of

    m = machine.with_clearances(clearance)
    base = drive_of(m).mechanism(m, revolutions=2)
    drawn = [p.for_spec(base) for p in perturbations]
    driver = base.drivers[0]
    omega = driver.speed if driver.speed else machine.drive_speed
    period = 2 * math.pi / abs(omega)
    v = m.operation.walking_speed
    phase = [d.driver_phases.get(driver.name, 0.0) for d in drawn]
    rows = [[v * step * round((((p - p0) / omega) % period) / step) for p in phase] for p0 in phase]
    first = int(np.argmin([max(r) for r in rows]))
    return first, rows[first], drawn


def class_tables_run(machine: Machine, clearance: dict[str, float] | None, perturbations,
                     rtol: float = COUPLED_RTOL) -> tuple[list[np.ndarray], object]:
    """Stem-force tables of every branch class from one coupled drive-past: ``(tables, result)``.

    The branch classes (:func:`branch_class_machine` of each ``harvest.branch_classes`` scale) are one-way probes of
    one run (:func:`berryshaker.harvest.coupled.coupled_mechanism`: driven by the combs, acting back on nothing; the
    bush members act back and are the same for every class, the bush not depending on the class), each at its own
    row offset so that it meets the comb at its own class's drive phase (:func:`class_phase_offsets`).  The run starts
    from the machine start of the class at offset 0 (its eccentricities and drive phase); each table is
    :func:`stem_force_table` of its class over its own passage (the duration of one branch's drive-past, from its
    offset on).  No probe acts back, so the combs' motion depends on the probes only through the integrator's step
    sequence (their contact onsets are events; their modal states are out of its error norm, ``plant.probe_modes``).
    With one class the run and its table are :func:`stem_force_envelope_run`'s from the same start, bit for bit.

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    clearance : dict of str to float or None
        Clearance sizes (m) per pair; None keeps the description's.
    perturbations : sequence of RandomInitialPerturbation or InitialPerturbation
        One machine start per branch class, in ``harvest.branch_classes`` order.
    rtol : float
        Relative integrator tolerance (dimensionless).

    Returns
    -------
    tables : list of numpy.ndarray
        One :func:`stem_force_table` per branch class (N for the force channel, dimensionless load ratios).
    result : MultibodyResult
        The run, written every :data:`ENVELOPE_OUTPUT_STEP` (the machine loads of the start).
    """
    from berryshaker.harvest.coupled import bush_members, coupled_mechanism
    from berryshaker.harvest.coupled_branch import branch_motion, plant_modes
    from berryshaker.multibody.engine import simulate_mechanism

    classes = [branch_class_machine(machine, s) for s in machine.harvest.branch_classes]
    if len(perturbations) != len(classes):
        raise ValueError(f"class_tables_run: {len(perturbations)} machine starts for {len(classes)} branch classes")
    first, offsets, drawn = class_phase_offsets(machine, clearance, perturbations)
    others = [c for c in range(len(classes)) if c != first]
    spec, m = coupled_mechanism(classes[first], clearance, probes=tuple(classes[c] for c in others),
                                probe_offsets=tuple(offsets[c] for c in others), probes_in_error_norm=False)
    res = simulate_mechanism(spec, rtol=rtol, output_step=ENVELOPE_OUTPUT_STEP, initial_perturbation=drawn[first])
    v = m.operation.walking_speed
    # one branch's drive-past (the run of one branch: from margin before its span to margin after), in samples
    n_pass = int(round(-2 * spec.plant.start_distance / v / ENVELOPE_OUTPUT_STEP)) + 1
    tables: list = [None] * len(classes)
    col = 0
    for c in (first, *others):
        modes, _ = plant_modes(classes[c])
        motion = branch_motion(res, modes, col)
        if len(classes) > 1:
            i0 = int(round(offsets[c] / v / ENVELOPE_OUTPUT_STEP))
            # timed from the passage's first sample on the nominal grid (offsets and run are whole output steps):
            # the same sampling step at every start, so the fruit oscillators are discretised once
            n = min(n_pass, len(res.t) - i0)  # the run ends with the last passage (a sample less at a rounding tie)
            motion = dataclasses.replace(motion.window(i0, i0 + n), t=np.arange(n) * ENVELOPE_OUTPUT_STEP)
        tables[c] = stem_force_table(classes[c], motion)
        col += len(modes.omega) + (sum(len(mm.omega) for _, mm in bush_members(m)) if c == first else 0)
    return tables, res


def branch_class_machine(machine: Machine, scale: float) -> Machine:
    """The machine with its branch's root and tip diameters scaled by ``scale`` (one branch class).

    Parameters
    ----------
    machine : Machine
        Machine description with a [plant] block.
    scale : float
        Diameter scale (dimensionless).

    Returns
    -------
    Machine
        A validated copy with ``plant.branch.root_diameter`` and ``tip_diameter`` multiplied by ``scale``.
    """
    d = machine.model_dump()
    d["plant"]["branch"]["root_diameter"] *= scale
    d["plant"]["branch"]["tip_diameter"] *= scale
    return machine_from_dict(d)


#: channels of a stem-force table (last axis): the peak stem-force magnitude (N) and the peak pull-shear load ratio
#: of the ripe and of the unripe fruit (dimensionless, berryshaker.plant.pedicel.peak_stem_loads); then the
#: Miner-Basquin equivalent load ratios of the ripe and of the unripe fruit at
#: berryshaker.plant.pedicel.MINER_EXPONENTS (:func:`miner_channels`)
CH_FORCE, CH_RIPE, CH_UNRIPE = 0, 1, 2


def miner_channels(ripe: bool) -> np.ndarray:
    """Channels of a stem-force table holding the peak and the Miner-Basquin equivalent load ratios of a class.

    Parameters
    ----------
    ripe : bool
        The ripe (True) or the unripe (False) fruit.

    Returns
    -------
    numpy.ndarray of int
        [peak channel, then g_eq at each of berryshaker.plant.pedicel.MINER_EXPONENTS].
    """
    from berryshaker.plant.pedicel import MINER_EXPONENTS

    c, k = (0 if ripe else 1), MINER_EXPONENTS.size
    return np.concatenate([[CH_RIPE + c], 3 + c * k + np.arange(k)])


def bond_strengths(machine: Machine) -> list[tuple[float, float]]:
    """Mean (pull, shear) strengths (N) of the ripe and the unripe fruit (``harvest.ripe_pull`` ... ``unripe_shear``).

    Parameters
    ----------
    machine : Machine
        Machine description with a [harvest] block.

    Returns
    -------
    list of (float, float)
        [(ripe pull, ripe shear), (unripe pull, unripe shear)] (N).
    """
    h = machine.harvest
    return [(h.ripe_pull, h.ripe_shear), (h.unripe_pull, h.unripe_shear)]


def stem_force_table(machine: Machine, motion) -> np.ndarray:
    """Peak stem loads of fruit on compliant pedicels over Z_GRID x MASS_FACTORS * m0 x channels.

    ``motion``: the branch's :class:`~berryshaker.harvest.coupled_branch.BranchMotion` of a drive-past.  The fruit
    is one-way coupled, so every (position, mass) is a post-processing of the same branch motion (computed for the
    whole table at once by berryshaker.plant.pedicel.peak_stem_loads, on the motion sampled every
    :data:`TABLE_STEP`).  Channels (:data:`CH_FORCE` ...):
    max |F| (N, the magnitude of berryshaker.harvest.coupled.stem_forces), the peak pull-shear load ratio of
    the ripe and of the unripe fruit's mean strengths (:func:`bond_strengths`), then their Miner-Basquin equivalent
    load ratios g_eq = (sum_i g_i^beta)^(1/beta) over the load cycles at berryshaker.plant.pedicel.MINER_EXPONENTS
    (:func:`miner_channels`; Miner 1945, Basquin 1910: berryshaker.plant.pedicel.miner).  With ``pedicel.rigid``
    the force is m x the branch acceleration (study eq. 16), taken as pure shear (lateral) for the load ratios.

    Parameters
    ----------
    machine : Machine
        Machine description (the branch class's) with [plant] and [harvest].
    motion : BranchMotion
        The branch's modal solution of a drive-past.

    Returns
    -------
    numpy.ndarray
        Shape (len(Z_GRID), len(MASS_FACTORS), 3 + 2 len(MINER_EXPONENTS)): channel :data:`CH_FORCE` peak |F|
        (N), :data:`CH_RIPE` and :data:`CH_UNRIPE` peak pull-shear load ratios, then the equivalent load ratios of
        the ripe and of the unripe fruit (dimensionless).
    """
    from berryshaker.plant.pedicel import MINER_EXPONENTS, miner_equivalent, peak_stem_loads

    pl = machine.plant
    z = Z_GRID * pl.branch.length
    masses = MASS_FACTORS * pl.fruit.mass
    st = bond_strengths(machine)
    if pl.fruit.pedicel.rigid:
        acc = miner_equivalent(np.abs(motion.lateral(z)[2]))  # (n_z, 1 + n_k): peak and g_eq of |a(t)| (m/s^2)
        per = [np.einsum("zk,m->zmk", acc, masses / sh) for _, sh in st]  # m |a| / S: homogeneous of degree 1
        return np.concatenate([(acc[:, 0:1] * masses)[..., None], per[0][..., :1], per[1][..., :1],
                               per[0][..., 1:], per[1][..., 1:]], axis=-1)
    dt = motion.t[1] - motion.t[0] if len(motion.t) > 1 else TABLE_STEP
    every = max(int(round(TABLE_STEP / dt)), 1)
    if every > 1:
        motion = motion.every(every)
    y, v, _ = motion.lateral(z, acceleration=False)
    ped = pl.fruit.pedicel
    return peak_stem_loads(motion.t, (y, v), motion.axial(z), masses, ped.stiffness, ped.damping,
                           ped.include_weight, st, MINER_EXPONENTS)


def mass_weights(mass_factor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where fruit of mass ``mass_factor`` x m0 fall on the tables' mass axis: the column j below and the weight w
    of column j + 1 of the interpolation linear in log mass (masses beyond the axis take its end column).

    Parameters
    ----------
    mass_factor : numpy.ndarray
        Fruit mass over the description's mean mass m0 (dimensionless).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        Column indexes j (int) and weights w in [0, 1] (dimensionless): value = (1 - w) T[j] + w T[j + 1].
    """
    lm = np.log(np.clip(mass_factor, MASS_FACTORS[0], MASS_FACTORS[-1]))
    lg = np.log(MASS_FACTORS)
    j = np.clip(np.searchsorted(lg, lm) - 1, 0, len(lg) - 2)
    return j, (lm - lg[j]) / (lg[j + 1] - lg[j])


def _z_cells(z: np.ndarray):
    """Each fraction's cell of Z_GRID (index i, z - Z_GRID[i], cell width) and whether it lies at or beyond an end."""
    i = np.clip(np.searchsorted(Z_GRID, z, side="right") - 1, 0, Z_GRID.size - 2)
    return i, z - Z_GRID[i], Z_GRID[i + 1] - Z_GRID[i], z <= Z_GRID[0], z >= Z_GRID[-1]


def along_branch(values: np.ndarray, z) -> np.ndarray:
    """Finite values on Z_GRID (axis 0, any trailing axes) at fractions z: numpy.interp of every trailing column, bit
    for bit (the same arithmetic: slope x offset + left value; ends held; a node's own value on it).

    Parameters
    ----------
    values : numpy.ndarray (len(Z_GRID), ...)
        Values at the grid's fractions (any unit).
    z : array_like (n,)
        Fractions of the branch length (dimensionless).

    Returns
    -------
    numpy.ndarray (n, ...)
        The values at z (the unit of ``values``).
    """
    z = np.asarray(z, float)
    i, dz, dx, low, high = _z_cells(z)
    col = (slice(None),) + (None,) * (values.ndim - 1)
    v = (values[i + 1] - values[i]) / dx[col] * dz[col] + values[i]
    v[low], v[high] = values[0], values[-1]
    return v


def _interp_table(table: np.ndarray, z: np.ndarray, mass: np.ndarray, m0: float) -> np.ndarray:
    """A (Z_GRID x MASS_FACTORS [x channels]) table of finite values at fractions z and masses ``mass``: linear in z
    (:func:`along_branch`'s arithmetic) and in log mass; (n,) or (n, channels)."""
    z = np.asarray(z, float)
    mass = np.broadcast_to(np.asarray(mass, float), z.shape)
    i, dz, dx, low, high = _z_cells(z)
    j, w = mass_weights(mass / m0)
    extra = (slice(None),) * (table.ndim - 2)
    col = (slice(None),) + (None,) * (table.ndim - 2)

    def along_z(k):  # column k of the table (one per fruit) at each fruit's z
        f0 = table[(i, k) + extra]
        v = (table[(i + 1, k) + extra] - f0) / dx[col] * dz[col] + f0
        v[low], v[high] = table[(0, k[low]) + extra], table[(-1, k[high]) + extra]
        return v

    return (1 - w[col]) * along_z(j) + w[col] * along_z(j + 1)


def fruit_peak_force(envelope: np.ndarray, z: np.ndarray, mass: np.ndarray, m0: float,
                     stiffness_scale: float = 1.0) -> np.ndarray:
    """Peak stem force (N) on fruit at fractions z with masses ``mass`` from one branch class's envelope.

    A 1-D envelope is a peak acceleration (m/s^2) on Z_GRID (eq. 16: force = m a); a 2-D envelope a stem-force table
    over Z_GRID x MASS_FACTORS m0, a 3-D one the channels of :func:`stem_force_table` (the force channel is read);
    tables are interpolated linearly in z and in log mass.

    Parameters
    ----------
    envelope : numpy.ndarray
        Acceleration envelope (m/s^2, 1-D), force table (N, 2-D) or :func:`stem_force_table` (3-D).
    z : numpy.ndarray
        Fruit positions, fractions of the branch length (dimensionless).
    mass : numpy.ndarray
        Fruit masses (kg).
    m0 : float
        Mean fruit mass of the table's mass factors (kg).
    stiffness_scale : float
        Pedicel stiffness (and damping) over the table's (dimensionless; module docstring: the table at mass / scale,
        times the scale).

    Returns
    -------
    numpy.ndarray
        Peak stem force of each fruit (N); masses outside the table's range take its nearest column.
    """
    env = np.asarray(envelope, float)
    if env.ndim == 1:  # a rigid stem: m a, with no stiffness to scale
        return mass * np.interp(z, Z_GRID, env)
    a = float(stiffness_scale)
    return a * _interp_table(env[..., CH_FORCE] if env.ndim == 3 else env, z, mass / a, m0)


def fruit_load_channels(envelope: np.ndarray, z: np.ndarray, mass: np.ndarray, m0: float, ripe: bool,
                        strengths: list[tuple[float, float]], stiffness_scale: float = 1.0) -> np.ndarray:
    """The peak and the Miner-Basquin equivalent load ratios of fruit of one class against its mean strengths.

    From the channels of :func:`stem_force_table` (:func:`miner_channels`), interpolated linearly in z and in log
    mass.  A table of peaks only (three channels) gives its peak channel alone, and one without load channels (1-D
    acceleration envelope or 2-D force table) is read as pure shear: ratio = peak force / mean shear strength
    ``strengths[c][1]`` (c = 0 ripe, 1 unripe).

    Parameters
    ----------
    envelope : numpy.ndarray
        Acceleration envelope (m/s^2, 1-D), force table (N, 2-D) or :func:`stem_force_table` (3-D).
    z : numpy.ndarray
        Fruit positions, fractions of the branch length (dimensionless).
    mass : numpy.ndarray
        Fruit masses (kg).
    m0 : float
        Mean fruit mass of the table's mass factors (kg).
    ripe : bool
        The ripe (True) or the unripe (False) fruit.
    strengths : list of (float, float)
        Mean (pull, shear) strengths (N) of the ripe and the unripe fruit (:func:`bond_strengths`).
    stiffness_scale : float
        Pedicel stiffness (and damping) over the table's (dimensionless; module docstring).

    Returns
    -------
    numpy.ndarray (1 + len(MINER_EXPONENTS), n) or (1, n)
        Row 0 the peak load ratio, rows 1 + k g_eq at berryshaker.plant.pedicel.MINER_EXPONENTS[k] (dimensionless;
        read at any exponent by berryshaker.plant.pedicel.miner_load).
    """
    env = np.asarray(envelope, float)
    if env.ndim == 3:
        a = float(stiffness_scale)
        chans = miner_channels(ripe) if env.shape[-1] > 3 else [CH_RIPE if ripe else CH_UNRIPE]
        return a * _interp_table(env[..., chans], z, mass / a, m0).T
    return (fruit_peak_force(env, z, mass, m0, stiffness_scale) / strengths[0 if ripe else 1][1])[None]


def fruit_peak_load(envelope: np.ndarray, z: np.ndarray, mass: np.ndarray, m0: float, ripe: np.ndarray,
                    strengths: list[tuple[float, float]], exponent: float = math.inf,
                    stiffness_scale: float = 1.0) -> np.ndarray:
    """Equivalent pull-shear load ratio (dimensionless) of each fruit against its class's mean strengths.

    The Miner-Basquin equivalent g_eq(beta) = (sum_i g_i^beta)^(1/beta) over the drive-past's load cycles
    (berryshaker.plant.pedicel.miner, eq. 1; Miner 1945, Basquin 1910) at ``exponent`` beta, read from the
    channels of :func:`fruit_load_channels` (the ripe or the unripe class by ``ripe``); beta = inf is the peak.

    Parameters
    ----------
    envelope : numpy.ndarray
        Acceleration envelope (m/s^2, 1-D), force table (N, 2-D) or :func:`stem_force_table` (3-D).
    z : numpy.ndarray
        Fruit positions, fractions of the branch length (dimensionless).
    mass : numpy.ndarray
        Fruit masses (kg).
    m0 : float
        Mean fruit mass of the table's mass factors (kg).
    ripe : numpy.ndarray of bool
        Whether each fruit is ripe.
    strengths : list of (float, float)
        Mean (pull, shear) strengths (N) of the ripe and the unripe fruit (:func:`bond_strengths`).
    exponent : float
        Basquin exponent beta (dimensionless; ``harvest.miner_exponent``; inf: the peak-only law).
    stiffness_scale : float
        Pedicel stiffness (and damping) over the table's (dimensionless; module docstring).

    Returns
    -------
    numpy.ndarray
        Load ratio of each fruit (dimensionless); it comes off when this reaches its strength factor.
    """
    from berryshaker.plant.pedicel import miner_load

    return miner_load(_fruit_channels(envelope, z, mass, m0, ripe, strengths, stiffness_scale), exponent)


def _fruit_channels(envelope: np.ndarray, z: np.ndarray, mass: np.ndarray, m0: float, ripe: np.ndarray,
                    strengths: list[tuple[float, float]], stiffness_scale: float = 1.0) -> np.ndarray:
    """Each fruit's load channels (:func:`fruit_load_channels`) of its own ripeness class, (1 + n_k, n) or (1, n),
    dimensionless: what :func:`fruit_peak_load` (the same arguments) reads at an exponent.  The reading is per fruit,
    so the fruit of several tables are read together."""
    ripe = np.asarray(ripe, bool)
    a = stiffness_scale
    return np.where(ripe, fruit_load_channels(envelope, z, mass, m0, True, strengths, a),
                    fruit_load_channels(envelope, z, mass, m0, False, strengths, a))


def envelopes_for(machine: Machine, clearance: dict[str, float] | None) -> list[np.ndarray]:
    """Stem-force envelopes (:func:`stem_force_envelope`) of every branch class.

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    clearance : dict of str to float or None
        Clearance sizes (m) per pair; None keeps the description's.

    Returns
    -------
    list of numpy.ndarray
        One :func:`stem_force_table` per ``harvest.branch_classes`` entry (N, dimensionless load ratios).
    """
    return [stem_force_envelope(machine, clearance, s) for s in machine.harvest.branch_classes]
