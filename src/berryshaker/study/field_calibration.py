"""Calibrate the harvest model to a user's own field sheet and predict the settings it did not test
(``berryshaker calibrate``, docs/calibration.md, issue #44).

long module: the parameter table, the exact post-processing, the emulator, the likelihood and the sampler are one
method read together (docs/calibration.md); each part's inputs are the previous part's outputs.

Chain:

1. **Parameters and priors** (:data:`PARAMETERS`): the harvest parameters that act only in the post-processing of
   the coupled runs' stem-load tables -- ripe and unripe mean pull strength (the shear strength scales with it at
   the described shear/pull ratio), the ripe strengths' CV, the unripe mass fraction, the yield per bush and the
   bruise-threshold height of the described catching surface -- each with a prior from the cited ranges
   (docs/harvest.md, ``harvest/published/record.toml``).  Pedicel stiffness is *not* calibrated: the tables are
   computed at the described stiffness, and changing it needs new coupled post-processing.
2. **Simulator with common random numbers** (:class:`Simulator`): every setting of the sheet (its factors mapped
   to the machine, :func:`factor_targets`) is run from R perturbed starts through the cached
   :class:`~berryshaker.runs.runner.SweepRunner` (:func:`berryshaker.study.l9.replicate_jobs`,
   :func:`berryshaker.study.runs.replicate_run`).  A response at (setting, start, theta) is then exact and cheap:
   the pull-shear load ratio channels ``CH_RIPE``/``CH_UNRIPE`` of a table are homogeneous of degree -1 in the
   class's mean strengths (sqrt((F_p/aP)^2 + (F_s/aS)^2) = (1/a) sqrt((F_p/P)^2 + (F_s/S)^2), and the peak over
   time commutes with a > 0), so a strength scaled by a divides its channel by a; the population is the one of
   :func:`berryshaker.harvest.virtual.sample_population` with the same seed (same uniforms and normals for every
   theta), so the replicate mean mu_s(theta) is smooth in theta; the picked mass is proportional to the yield per
   bush (the count of sampled fruit stays that of the described yield, as ``sample_population(...,
   yield_per_bush=)``), so the efficiency is exactly yield x (efficiency per kg of yield).
3. **Emulator** (:class:`Emulator`): per response a scikit-learn ``GaussianProcessRegressor`` (ARD Matern 5/2 +
   white noise, normalised targets) over (coded setting, theta on the prior's unit cube) for log(mean + c) and
   log(SD) of the replicate results, trained on a Latin hypercube of theta (scipy.stats.qmc) at the simulated
   settings; its error is checked on held-out theta points and on held-out (untested) settings.
4. **Likelihood** (:func:`log_likelihood`): the replicates y_{s,1..R} of sheet run s are jointly normal, each
   y_{s,r} = mu_s(theta) + e_c + e_r with e_r ~ N(0, sigma_s(theta)^2) (the simulator's start-to-start SD) and a
   term common to the run e_c ~ N(0, sigma_s^2 / R_sim + sigma_emu^2 + (delta mu_s)^2) (the simulated mean's own
   error over R_sim starts, the emulator's error, the optional model discrepancy delta as a fraction of the mean);
   responses independent given theta.  Sampled with ``emcee`` in the prior's standard-normal coordinates.
5. **Identifiability, checks, predictions** (:func:`calibrate`): prior against posterior 90 % intervals,
   posterior predictive checks per run, a held-out run, predictions of every level set of the sheet's factors
   (and named settings) with 90 % intervals of a future field result, and a recommendation made on them
   (:data:`RECOMMENDATION_RULE`).
"""

from __future__ import annotations

import itertools
import math
import re
import time
from dataclasses import dataclass, field

import numpy as np
from scipy import special

from berryshaker.config import Machine, machine_from_dict
from berryshaker.errors import ConfigError

# ----------------------------------------------------------------------------------------------- parameters
Z90 = 1.6448536269514722  # standard normal 95th percentile: a lognormal's central 90 % is median exp(+-Z90 s)


@dataclass(frozen=True)
class Parameter:
    """One calibrated harvest parameter and its prior.

    Attributes
    ----------
    name : str
        Name (the ``harvest`` key it sets; ``bruise_height`` sets the described catching surface's threshold).
    unit : str
        SI unit of its values ("" for a fraction).
    distribution : str
        "lognormal" (``lo``, ``hi`` its central 90 %) or "uniform" (``lo``, ``hi`` its bounds).
    lo, hi : float
        See ``distribution`` (SI).
    source : str
        Where the range comes from.
    tag : str
        [published], [assumed] or how the two mix.
    """

    name: str
    unit: str
    distribution: str
    lo: float
    hi: float
    source: str
    tag: str

    def ppf(self, u):
        """Value (SI) at prior probability ``u`` (the prior's quantile function).

        Parameters
        ----------
        u : array_like
            Probabilities in (0, 1).

        Returns
        -------
        numpy.ndarray
            Quantiles (SI, the parameter's unit).
        """
        u = np.asarray(u, float)
        if self.distribution == "uniform":
            return self.lo + u * (self.hi - self.lo)
        mu, s = self.log_median_sigma()
        return np.exp(mu + s * special.ndtri(u))

    def log_median_sigma(self) -> tuple[float, float]:
        """ln(median) and sigma of a lognormal prior from its central 90 % (lo, hi).

        Returns
        -------
        (float, float)
            (ln sqrt(lo hi), ln(hi / lo) / (2 x 1.645)).
        """
        return 0.5 * math.log(self.lo * self.hi), math.log(self.hi / self.lo) / (2 * Z90)

    def interval90(self) -> tuple[float, float]:
        """The prior's central 90 % interval (SI).

        Returns
        -------
        (float, float)
            5 % and 95 % quantiles (SI, the parameter's unit).
        """
        return float(self.ppf(0.05)), float(self.ppf(0.95))

    def describe(self) -> str:
        """The prior in words with its unit, e.g. "lognormal, central 90 % 0.26-0.72 N".

        Returns
        -------
        str
            The text.
        """
        what = "central 90 %" if self.distribution == "lognormal" else "bounds"
        return f"{self.distribution}, {what} {self.lo:.3g}-{self.hi:.3g}{(' ' + self.unit) if self.unit else ''}"


#: the calibrated parameters (docs/calibration.md "Priors").  Order = the sampler's coordinates.
PARAMETERS: tuple[Parameter, ...] = (
    Parameter("ripe_pull", "N", "lognormal", 0.26, 0.72,
              "Kong et al. 2014 (ripe pull 0.44-0.53 N, 0.53-0.72 N over ripening) and Lyu et al. 2024 eq. 17 "
              "(ripe bond 0.26-0.30 N): lowest to highest published ripe bond as the central 90 %",
              "[published range; its reading as a central 90 % is assumed]"),
    Parameter("unripe_pull", "N", "lognormal", 1.0, 3.6,
              "Lyu et al. 2024 eq. 17 unripe band 1.0-3.6 N (the only unripe bond found) as the central 90 %",
              "[published range; its reading as a central 90 % is assumed]"),
    Parameter("bond_cv", "", "uniform", 0.10, 0.45,
              "around 0.24, Kong et al. 2014's shear range over ripening read as a central 90 % (docs/harvest.md "
              "'Bond'); the width is our choice", "[assumed width]"),
    Parameter("unripe_fraction", "", "uniform", 0.02, 0.30,
              "unripe share of the fruit mass at a pass: described 0.10 [assumed]; Malladi et al. 2013 found up to "
              "23 % immature fruit among the detached; the bounds are our choice", "[assumed]"),
    Parameter("yield_per_bush", "kg", "lognormal", 0.30, 1.51,
              "MSU Extension 2013: 2-10 lb (0.9-4.5 kg) per highbush bush and season, over three machine passes "
              "[assumed], as the central 90 %", "[published range; passes and reading assumed]"),
    Parameter("bruise_height", "m", "lognormal", 0.60, 2.40,
              "Brown et al. 1996: cushioning prevented bruising for drops up to 0.6-1.2 m (padded catcher); the "
              "central 90 % from the smallest safe height to twice the largest is our choice; a hard catcher: "
              "0.075-0.30 m about Brown's 0.15 m", "[published lower end; upper end assumed]"),
)
PARAMETER_NAMES = tuple(p.name for p in PARAMETERS)
#: the hard catching surface's bruise-threshold prior (replaces the padded one when the description's surface is hard)
HARD_BRUISE = Parameter("bruise_height", "m", "lognormal", 0.075, 0.30,
                        "Brown et al. 1996: extensive bruising above 150 mm onto a hard surface; central 90 % half to "
                        "twice that [assumed width]", "[published median; width assumed]")


def parameters_for(machine: Machine) -> tuple[Parameter, ...]:
    """The calibrated parameters of this description (the bruise prior of its catching surface).

    Parameters
    ----------
    machine : Machine
        Machine description with a [harvest] block (``catcher_surface``).

    Returns
    -------
    tuple of Parameter
        :data:`PARAMETERS`, the hard-surface bruise prior when ``harvest.catcher_surface = "hard"``.
    """
    if machine.harvest.catcher_surface == "hard":
        return PARAMETERS[:-1] + (HARD_BRUISE,)
    return PARAMETERS


def described_values(machine: Machine) -> dict[str, float]:
    """The description's own value of every calibrated parameter (SI).

    Parameters
    ----------
    machine : Machine
        Machine description with a [harvest] block.

    Returns
    -------
    dict of str to float
        Name -> value (N, fractions, kg, m).
    """
    h = machine.harvest
    bruise = h.bruise_height_hard if h.catcher_surface == "hard" else h.bruise_height_padded
    return {"ripe_pull": h.ripe_pull, "unripe_pull": h.unripe_pull, "bond_cv": h.bond_cv,
            "unripe_fraction": h.unripe_fraction, "yield_per_bush": h.yield_per_bush, "bruise_height": bruise}


def prior_rows(machine: Machine | None = None) -> list[dict]:
    """The priors as rows (``config show``, the report): name, harvest key, unit, prior, 90 % interval, source, tag.

    Parameters
    ----------
    machine : Machine, optional
        Its catching surface picks the bruise prior (default: padded).

    Returns
    -------
    list of dict
        One row per parameter: ``name``, ``key`` (the harvest key it sets), ``unit``, ``prior`` (text),
        ``lo90``, ``hi90`` (SI), ``source``, ``tag``.
    """
    params = parameters_for(machine) if machine is not None else PARAMETERS
    hard = machine is not None and machine.harvest.catcher_surface == "hard"
    keys = {"bruise_height": "bruise_height_hard" if hard else "bruise_height_padded"}
    return [{"name": p.name, "key": f"harvest.{keys.get(p.name, p.name)}", "unit": p.unit, "prior": p.describe(),
             "lo90": p.interval90()[0], "hi90": p.interval90()[1], "source": p.source, "tag": p.tag} for p in params]


#: responses of a field sheet the calibration uses: sheet name -> (unit, floor c of the emulated log(mean + c))
#: (the floor keeps a rate near 0, a count of a few fruit that jumps as single fruit cross their thresholds, from
#: dominating the log scale: 0.5 % is below a rate's replicate SD on the reference machine, docs/harvest.md)
RESPONSES = {"efficiency": ("kg/min", 0.05), "unripe": ("%", 0.5), "damage": ("%", 0.5)}
#: parameters each response depends on (besides the setting); the yield scales the efficiency exactly and is not
#: emulated; the bruise threshold changes only the damage
RESPONSE_PARAMETERS = {"efficiency": ("ripe_pull", "unripe_pull", "bond_cv", "unripe_fraction"),
                       "unripe": ("ripe_pull", "unripe_pull", "bond_cv", "unripe_fraction"),
                       "damage": ("ripe_pull", "unripe_pull", "bond_cv", "unripe_fraction", "bruise_height")}
#: factor names (lower case) read as the drive speed when their unit is an angular speed
DRIVE_SPEED_NAMES = ("speed", "drive_speed", "shaft_speed", "cam_speed", "crank_speed", "rotational_speed", "n")
IDENTIFIED_RULE = ("identified: the posterior's central 90 % interval is narrower than half the prior's "
                   "(width ratio < 0.5)")
CONFOUNDED_RULE = "confounded: |posterior correlation| >= 0.5 between two parameters (on the prior's normal scores)"
RECOMMENDATION_RULE = (
    "a level set beats another on a response when the 90 % interval of the difference of their expected field "
    "results (same posterior draws at both, emulator errors independent) lies on the better side of zero; a level "
    "set is dominated when another beats it on at least one response and is beaten on none; the recommendation is "
    "the undominated level set with the best weighted score of the predicted means (each response scaled 0..1 over "
    "the level sets, weights efficiency 0.5, damage 0.3, unripe 0.2, the study's priority); the other undominated "
    "level sets are listed as 'no difference beyond the intervals'")
LIMITS = (
    "pedicel stiffness is not calibrated: the stem-load tables are computed at the described stiffness",
    "unripe bond CV, fruit mass, branch geometry and every machine value stay as described",
    "model discrepancy is off unless --discrepancy is given: the posterior then assumes the model can reproduce the "
    "field means exactly up to the replicate noise and the emulator's error",
    "predictions at settings outside the sheet's level ranges extrapolate the emulator (flagged 'extrapolated')",
    "responses are treated as independent given the parameters (their correlation over starts is left out)",
    "replicates of a run are exchangeable: a sheet's block effects are not modelled",
)


# --------------------------------------------------------------------------------------------- settings
@dataclass(frozen=True)
class FactorTarget:
    """What a sheet factor sets on the machine.

    Attributes
    ----------
    name : str
        The factor's name in the sheet.
    kind : str
        "clearance" (a clearance pair's size) or "drive_speed".
    pair : str
        The clearance pair ("" for the drive speed).
    unit : str
        The sheet's unit of the factor.
    to_si : float
        SI value of one ``unit`` (m or rad/s).
    levels_si : tuple of float
        The sheet's level values (SI).
    """

    name: str
    kind: str
    pair: str
    unit: str
    to_si: float
    levels_si: tuple[float, ...]


def factor_target(machine: Machine, name: str, unit: str, levels: tuple[float, ...] | None) -> FactorTarget:
    """Map one sheet factor to the machine: a clearance pair's name with a length unit sets that clearance; a
    drive-speed name (:data:`DRIVE_SPEED_NAMES`) with an angular-speed unit (rpm, rad/s) sets the drive speed.

    Parameters
    ----------
    machine : Machine
        The machine description (its clearance pairs).
    name : str
        Factor name.
    unit : str
        Its unit in the sheet.
    levels : tuple of float or None
        Level values in ``unit`` (its units; None: the sheet gives only level numbers).

    Returns
    -------
    FactorTarget
        The mapping with the levels in SI.

    Raises
    ------
    ConfigError
        A name the calibration does not understand, a unit of the wrong kind, or level numbers without values.
    """
    from berryshaker.units import parse_unit, unit_dimension

    pairs = list(machine.pair_names)
    understood = (f"a clearance pair of the machine ({', '.join(pairs)}) with a length unit, e.g. A_mm, or the "
                  f"drive speed ({', '.join(DRIVE_SPEED_NAMES[:3])} ...) with a speed unit, e.g. speed_rpm")
    if levels is None:
        raise ConfigError(f"factor {name!r}: the sheet gives level numbers only; calibrate needs the level values with "
                          f"their unit (a column {name}_mm or '{name} (mm)')")
    dim = unit_dimension(unit) if unit else None
    if name in pairs or name.upper() in pairs and len(name) == 1:
        pair = name if name in pairs else name.upper()
        if dim != "length":
            raise ConfigError(f"factor {name!r} names clearance pair {pair} but its unit is {unit or 'missing'!r}; "
                              "give its levels in a length unit (column {name}_mm)")
        f = parse_unit(unit, "length", f"factor {name}")
        return FactorTarget(name, "clearance", pair, unit, f, tuple(v * f for v in levels))
    if name.lower() in DRIVE_SPEED_NAMES:
        if dim != "angular_speed":
            raise ConfigError(f"factor {name!r} reads as the drive speed but its unit is {unit or 'missing'!r}; give "
                              "its levels in rpm or rad/s (column speed_rpm)")
        f = parse_unit(unit, "angular_speed", f"factor {name}")
        return FactorTarget(name, "drive_speed", "", unit, f, tuple(v * f for v in levels))
    raise ConfigError(f"factor {name!r} is not a setting calibrate can simulate; it understands {understood}. "
                      "Rename the column or leave the factor out of the sheet")


def setting_data(data: dict, machine: Machine, targets: list[FactorTarget], values_si) -> tuple[dict, dict]:
    """The machine (JSON dict) and clearance set (m per pair) of one setting.

    Parameters
    ----------
    data : dict
        The machine as JSON (``model_dump(mode="json")``).
    machine : Machine
        The same machine.
    targets : list of FactorTarget
        The sheet's factors.
    values_si : sequence of float
        One value per factor (SI).

    Returns
    -------
    (dict, dict)
        Machine data (drive speed replaced where a factor sets it) and the clearance sizes (m).
    """
    from berryshaker.harvest.virtual import with_drive_speed

    clearance = dict(machine.clearance_sizes())
    d = data
    for t, v in zip(targets, values_si):
        if t.kind == "clearance":
            clearance[t.pair] = float(v)
        else:
            d = with_drive_speed(d, float(v))
    return d, clearance


# --------------------------------------------------------------------------------------------- simulator
@dataclass
class _Population:
    """Per-fruit draws of one population seed (the same at every theta and setting: common random numbers)."""

    mass: np.ndarray
    u_ripe: np.ndarray  # uniform: unripe when u < unripe fraction
    z: np.ndarray  # fraction of the branch length
    cls: np.ndarray
    normal: np.ndarray  # standard normal of the strength factor
    mass_total: float


def _population(machine: Machine, seed: int) -> _Population:
    """The draws of :func:`berryshaker.harvest.virtual.sample_population` for ``seed``, in its order (the test
    ``test_field_calibration`` checks the responses against :func:`~berryshaker.harvest.virtual.response_indexes`)."""
    from berryshaker.harvest.virtual import fruit_per_bush

    h = machine.harvest
    rng = np.random.default_rng(seed)
    n = fruit_per_bush(machine) * h.bushes
    sigma = math.sqrt(math.log(1 + h.fruit_mass_cv**2))
    mass = machine.plant.fruit.mass * rng.lognormal(-0.5 * sigma**2, sigma, n)
    u = rng.random(n)
    rng.random(n)  # the eq. 17 bond draw
    z = rng.uniform(*h.fruit_zone, n)
    cls = rng.integers(0, len(h.branch_classes), n)
    normal = rng.standard_normal(n)
    return _Population(mass, u, z, cls, normal, float(mass.sum()))


@dataclass
class _Start:
    """One (setting, start): every fruit's peak load ratio at the described ripe and unripe strengths."""

    pop_seed: int
    load_ripe: np.ndarray
    load_unripe: np.ndarray


class Simulator:
    """The virtual harvest at the sheet's settings as an exact, cheap function of the harvest parameters.

    Built from cached coupled runs (:meth:`run`); :meth:`responses` post-processes them at any theta.

    Parameters
    ----------
    machine : Machine
        The machine description (described harvest values are the reference of the strength scaling).
    targets : list of FactorTarget
        The sheet's factors.
    """

    def __init__(self, machine: Machine, targets: list[FactorTarget]):
        from berryshaker.harvest.bruising import finger_speed

        self.machine = machine
        self.data = machine.model_dump(mode="json")
        self.targets = list(targets)
        self.settings: list[tuple[float, ...]] = []
        self.starts: dict[tuple[int, int, int], _Start] = {}
        self._envelopes: dict[tuple[int, int], list] = {}  # (setting, start seed) -> stem-load tables per class
        self._pops: dict[int, _Population] = {}
        h = machine.harvest
        self._ripe0 = h.ripe_pull
        self._unripe0 = h.unripe_pull
        self._finger_speed = finger_speed
        self.runs = 0

    def setting_index(self, values_si) -> int:
        """Index of a setting (added if new).

        Parameters
        ----------
        values_si : sequence of float
            One value per factor (SI).

        Returns
        -------
        int
            Its index in :attr:`settings`.
        """
        key = tuple(float(v) for v in values_si)
        for i, s in enumerate(self.settings):
            if np.allclose(s, key, rtol=1e-12, atol=0):
                return i
        self.settings.append(key)
        return len(self.settings) - 1

    def run(self, runner, settings: list[int], seeds: list[int], label: str = "calibration runs",
            pop_seeds: list[int] | None = None) -> None:
        """Run (or read from the cache) the coupled starts ``seeds`` at ``settings`` and keep their loads.

        Parameters
        ----------
        runner : SweepRunner
            The cached runner.
        settings : list of int
            Setting indexes.
        seeds : list of int
            Start seeds (each start's drive-pasts start from RandomInitialPerturbation((seed, class))).
        label : str
            Progress label.
        pop_seeds : list of int, optional
            Population seed of each start (default: the start's own seed, as the virtual L9).
        """
        pop_seeds = list(seeds) if pop_seeds is None else list(pop_seeds)
        self.run_starts(runner, [(s, sd, ps) for s in settings for sd, ps in zip(seeds, pop_seeds)], label)

    def run_starts(self, runner, starts: list[tuple[int, int, int]], label: str = "calibration runs") -> None:
        """Run (or read from the cache) the coupled starts ``(setting, start seed, population seed)`` and keep every
        fruit's peak loads (one runner call: the starts run in parallel).

        Parameters
        ----------
        runner : SweepRunner
            The cached runner.
        starts : list of (int, int, int)
            Setting index, start seed, population seed.
        label : str
            Progress label.

        Raises
        ------
        ConfigError
            A coupled start failed.
        """
        from berryshaker.harvest.virtual import fruit_peak_load
        from berryshaker.study.l9 import replicate_envelopes, replicate_jobs
        from berryshaker.study.runs import replicate_run

        todo = [t for t in dict.fromkeys(starts) if t not in self.starts]
        need = list(dict.fromkeys((s, sd) for s, sd, _ in todo if (s, sd) not in self._envelopes))
        jobs, spans = [], []
        for s in sorted({t[0] for t in need}):
            d, cl = setting_data(self.data, self.machine, self.targets, self.settings[s])
            m = machine_from_dict(d)
            mine = [sd for s2, sd in need if s2 == s]
            j = replicate_jobs(m, cl, mine, data=d)
            spans.append((s, m, mine, len(jobs), len(jobs) + len(j)))
            jobs.extend(j)
        outs = runner.values(replicate_run, jobs, label) if jobs else []
        self.runs += len(jobs)
        for s, m, mine, a, b in spans:
            nc = len(m.harvest.branch_classes)
            for k, seed in enumerate(mine):
                reps = replicate_envelopes(m, outs[a + k * nc:a + (k + 1) * nc], [seed])
                if not reps:
                    raise ConfigError(f"calibrate: the coupled start {seed} failed at setting {self.setting_text(s)}; "
                                      "see the runner's messages (a machine that does not run at a setting cannot be "
                                      "calibrated there)")
                self._envelopes[(s, seed)] = reps[0][0]
        m0 = self.machine.plant.fruit.mass
        st = [(self._ripe0, self.machine.harvest.ripe_shear), (self._unripe0, self.machine.harvest.unripe_shear)]
        for s, seed, ps in todo:
            pop = self.population(ps)
            lr, lu = np.zeros(pop.mass.size), np.zeros(pop.mass.size)
            for c, e in enumerate(self._envelopes[(s, seed)]):
                sel = pop.cls == c
                lr[sel] = fruit_peak_load(e, pop.z[sel], pop.mass[sel], m0, np.ones(sel.sum(), bool), st)
                lu[sel] = fruit_peak_load(e, pop.z[sel], pop.mass[sel], m0, np.zeros(sel.sum(), bool), st)
            self.starts[(s, seed, ps)] = _Start(ps, lr, lu)

    def population(self, seed: int) -> _Population:
        """The per-fruit draws of a population seed (cached).

        Parameters
        ----------
        seed : int
            Population seed.

        Returns
        -------
        _Population
            Masses (kg), ripeness uniforms, positions (fractions), branch classes, strength normals.
        """
        if seed not in self._pops:
            self._pops[seed] = _population(self.machine, seed)
        return self._pops[seed]

    def setting_text(self, s: int) -> str:
        """A setting in the sheet's units, e.g. "A=0.25mm, speed=120rpm".

        Parameters
        ----------
        s : int
            Setting index.

        Returns
        -------
        str
            The text.
        """
        return ", ".join(f"{t.name}={v / t.to_si:.6g}{t.unit}" for t, v in zip(self.targets, self.settings[s]))

    def responses(self, s: int, seeds: list[int], theta: np.ndarray, pop_seeds: list[int] | None = None,
                  chunk: int = 32) -> np.ndarray:
        """Field responses of the starts ``seeds`` at setting ``s`` for every parameter row of ``theta``.

        Exact post-processing (module docstring): fruit off when load / a >= strength factor (a = theta's strength
        over the described one), strength factor exp(-sigma^2/2 + sigma n) with the population's normal n,
        unripe when its uniform < the unripe fraction, bruising of berryshaker.harvest.bruising at theta's
        threshold, picked mass x yield / the sampled mass.

        Parameters
        ----------
        s : int
            Setting index.
        seeds : list of int
            Start seeds (run before with :meth:`run`).
        theta : numpy.ndarray
            (n, 6) parameter values in :data:`PARAMETER_NAMES` order (SI).
        pop_seeds : list of int, optional
            Population seed of each start (default its own seed), as given to :meth:`run`.
        chunk : int
            Parameter rows evaluated at once (memory: chunk x fruit).

        Returns
        -------
        numpy.ndarray
            (n, len(seeds), 3): efficiency (kg/min), unripe rate (%), damage rate (%) of each start; a rate is
            NaN where nothing is picked.
        """
        from berryshaker.harvest.bruising import GRAVITY, bruise_probability

        h = self.machine.harvest
        theta = np.atleast_2d(np.asarray(theta, float))
        d, _ = setting_data(self.data, self.machine, self.targets, self.settings[s])
        m = machine_from_dict(d)
        v_f = self._finger_speed(m)
        hard = h.catcher_surface == "hard"
        per_min = m.operation.walking_speed / m.operation.plant_spacing * 60.0
        sig_u = math.sqrt(math.log(1 + h.unripe_bond_cv**2))
        fall_len = m.plant.branch.length
        out = np.empty((theta.shape[0], len(seeds), 3))
        pop_seeds = list(seeds) if pop_seeds is None else list(pop_seeds)
        for k, seed in enumerate(seeds):
            st = self.starts[(s, seed, pop_seeds[k])]
            pop = self.population(st.pop_seed)
            fall = h.catcher_drop + pop.z * fall_len
            for a in range(0, theta.shape[0], chunk):
                th = theta[a:a + chunk]
                rp, up, cv, uf, yb, hb = (th[:, i:i + 1] for i in range(6))
                ripe = pop.u_ripe[None, :] >= uf
                sig = np.where(ripe, np.sqrt(np.log1p(cv**2)), sig_u)
                strength = np.exp(-0.5 * sig**2 + sig * pop.normal[None, :])
                load = np.where(ripe, st.load_ripe[None, :] * (self._ripe0 / rp),
                                st.load_unripe[None, :] * (self._unripe0 / up))
                picked_mass = np.where(load >= strength, pop.mass[None, :], 0.0)
                picked = picked_mass.sum(axis=1)
                unripe = np.where(ripe, 0.0, picked_mass).sum(axis=1)
                hard_h = hb[:, 0] if hard else np.full(th.shape[0], h.bruise_height_hard)
                p_strike = np.array([bruise_probability(v_f * v_f / (2 * GRAVITY), x, h.bruise_cv) for x in hard_h])
                p_fall = bruise_probability(fall[None, :], hb, h.bruise_cv)
                p_dmg = 1.0 - (1.0 - p_strike[:, None]) * (1.0 - p_fall)
                damaged = (picked_mass * p_dmg).sum(axis=1)
                with np.errstate(invalid="ignore", divide="ignore"):
                    out[a:a + chunk, k, 0] = yb[:, 0] * h.bushes / pop.mass_total * picked / h.bushes * per_min
                    out[a:a + chunk, k, 1] = np.where(picked > 0, 100.0 * unripe / picked, np.nan)
                    out[a:a + chunk, k, 2] = np.where(picked > 0, 100.0 * damaged / picked, np.nan)
        return out


def start_statistics(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Replicate mean and SD (ddof 1) over starts of :meth:`Simulator.responses`, NaN starts (nothing picked) left out;
    a response with no finite start is 0 with SD 0.

    Parameters
    ----------
    values : numpy.ndarray
        (n, starts, responses) in the responses' units (kg/min, %).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        Means and SDs, (n, responses), same units as ``values``.
    """
    import warnings

    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a response with no finite start: handled below
        mean = np.nanmean(values, axis=1)
        sd = np.nanstd(values, axis=1, ddof=1)
    return np.nan_to_num(mean, nan=0.0), np.nan_to_num(sd, nan=0.0)


# --------------------------------------------------------------------------------------------- emulator
#: most L-BFGS-B iterations of a GP's marginal-likelihood fit: scikit-learn's default (15000) let one fit of the
#: joint GP on clustered posterior points take over a minute on the reference L9; its hyperparameters converge in far
#: fewer iterations on the hypercube
GP_FIT_ITERATIONS = 200


def _bounded_lbfgs(obj_func, initial_theta, bounds):
    """scikit-learn's GP optimiser (L-BFGS-B on the log marginal likelihood) with at most :data:`GP_FIT_ITERATIONS`
    iterations: returns (theta_opt, func_min)."""
    from scipy.optimize import minimize

    res = minimize(obj_func, initial_theta, method="L-BFGS-B", jac=True, bounds=bounds,
                   options={"maxiter": GP_FIT_ITERATIONS})
    return res.x, res.fun


class FittedGP:
    """A fitted scikit-learn ``GaussianProcessRegressor`` with a batched predictive variance.

    ``GaussianProcessRegressor.predict(return_std=True)`` costs ~10 ms per call whatever the size; the sampler calls
    it thousands of times, so the prediction is computed here from the fitted kernel's hyperparameters, ``alpha_``
    and the Cholesky factor ``L_``, the same formulas (Rasmussen & Williams 2006, alg. 2.1): mean = k(x, X) alpha,
    var = k(x, x) - |L^-1 k(X, x)|^2 with the white-noise term left out (it is the training targets' noise, not the
    emulator's); k the Matern 5/2 kernel c (1 + sqrt5 r + 5 r^2 / 3) exp(-sqrt5 r), r the ARD-scaled distance.
    The test checks it against ``predict``.

    Parameters
    ----------
    x : numpy.ndarray
        (n, d) training inputs (dimensionless: coded settings, prior probabilities).
    y : numpy.ndarray
        (n,) training targets (their units: logs of responses, dimensionless).
    seed : int
        Seed of the optimiser.
    noise : float, optional
        Known variance of the targets (their units squared) added to the kernel's diagonal; default: learned by a
        WhiteKernel.
    """

    def __init__(self, x: np.ndarray, y: np.ndarray, seed: int, noise: float | None = None):
        from sklearn.gaussian_process import GaussianProcessRegressor
        from sklearn.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel

        k = ConstantKernel(1.0, (1e-3, 1e3)) * Matern(np.ones(x.shape[1]), (1e-2, 1e3), nu=2.5)
        ystd = float(np.std(y)) or 1.0
        if noise is None:
            k = k + WhiteKernel(1e-3, (1e-8, 1.0))
            alpha = 1e-10
        else:
            alpha = max(noise / ystd**2, 1e-10)  # normalize_y: the diagonal is in units of the targets' variance
        import warnings

        from sklearn.exceptions import ConvergenceWarning

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)  # a length scale at its bound: an irrelevant input
            self.gp = GaussianProcessRegressor(k, alpha=alpha, normalize_y=True, n_restarts_optimizer=0,
                                               optimizer=_bounded_lbfgs, random_state=seed).fit(x, y)
        kern = self.gp.kernel_
        latent = kern.k1 if noise is None else kern  # ConstantKernel x Matern
        self.amplitude = float(latent.k1.constant_value)
        self.length = np.asarray(latent.k2.length_scale, float)
        self.x_scaled = self.gp.X_train_ / self.length
        from scipy.linalg import solve_triangular

        # L^-1 once: a triangular solve per call costs milliseconds of threading overhead on small systems
        self.l_inv = solve_triangular(self.gp.L_, np.eye(len(x)), lower=True)
        self.scale = float(np.atleast_1d(self.gp._y_train_std)[0])
        self.offset = float(np.atleast_1d(self.gp._y_train_mean)[0])

    def predict(self, x: np.ndarray, with_var: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Mean and latent variance at ``x``.

        Parameters
        ----------
        x : numpy.ndarray
            (m, d) inputs.
        with_var : bool
            Compute the variance (else zeros).

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)
            Mean (their units: the targets') and variance (their units squared).
        """
        xs = np.asarray(x, float) / self.length
        d2 = (np.sum(xs**2, axis=1)[:, None] + np.sum(self.x_scaled**2, axis=1)[None, :] - 2.0 * xs @ self.x_scaled.T)
        r = math.sqrt(5.0) * np.sqrt(np.maximum(d2, 0.0))
        ks = self.amplitude * (1.0 + r + r * r / 3.0) * np.exp(-r)  # Matern 5/2 (sklearn's Matern, nu = 2.5)
        mean = ks @ self.gp.alpha_ * self.scale + self.offset
        if not with_var:
            return mean.ravel(), np.zeros(len(x))
        v = self.l_inv @ ks.T
        var = np.maximum(self.amplitude - np.einsum("ij,ij->j", v, v), 0.0) * self.scale**2
        return mean.ravel(), var


@dataclass
class _ResponseGP:
    """The two Gaussian processes of one response (log(mean + c) and log SD) on one input layout."""

    mean_gp: FittedGP
    logsd_gp: FittedGP
    columns: list[int]  # theta columns used (indexes into PARAMETER_NAMES)
    floor: float
    mse_log_mean: float = 0.0  # held-out MSE of log(mean + c)


class Emulator:
    """Gaussian-process emulator of the replicate mean and log SD of every response (efficiency per kg of yield: the
    yield scales it exactly).

    Two layouts, both scikit-learn ``GaussianProcessRegressor`` with an ARD Matern 5/2 kernel on log(mean + c)
    (learned white noise) and on log SD (noise fixed at the sampling variance of a log SD over R starts,
    1 / (2 (R - 1))):

    * **per setting** over theta on the prior's unit cube (the parameters the response depends on,
      :data:`RESPONSE_PARAMETERS`): the likelihood at the sheet's settings and the predictions there;
    * **joint** over (setting coded to -1 .. 1 over the sheet's level ranges, theta), of the setting's effect: the
      difference of log(mean + c) and log SD from the average of the per-setting GPs at the same theta, trained on up
      to :attr:`joint_points` of the simulated points (half of them, with :meth:`fit_joint`'s ``focus``, simulated at
      posterior draws): predictions at settings that were not simulated (far from every simulated setting it falls
      back to that average, not to the prior's mean).

    Parameters
    ----------
    targets : list of FactorTarget
        The sheet's factors.
    responses : list of str
        Response names (:data:`RESPONSES`).
    seed : int
        Seed of the optimisers and of the joint GP's subsample.
    r_sim : int
        Starts behind every simulated mean and SD.
    joint_points : int
        Most training points of the joint GP (its cost grows as their cube).
    """

    def __init__(self, targets: list[FactorTarget], responses: list[str], seed: int, r_sim: int,
                 joint_points: int = 160):
        self.lo = np.array([min(t.levels_si) for t in targets])
        self.hi = np.array([max(t.levels_si) for t in targets])
        self.responses = list(responses)
        self.seed = seed
        self.r_sim = r_sim
        self.joint_points = joint_points
        self.settings: list[tuple[float, ...]] = []
        self.local: list[dict[str, _ResponseGP]] = []
        self.joint: dict[str, _ResponseGP] | None = None
        self._data = None
        self.fit_seconds = 0.0
        self.training_points = 0

    def code(self, settings_si) -> np.ndarray:
        """Settings (SI, rows) coded to -1 .. 1 over the sheet's level ranges.

        Parameters
        ----------
        settings_si : array_like
            (n, factors) SI values.

        Returns
        -------
        numpy.ndarray
            Coded settings (dimensionless).
        """
        x = np.atleast_2d(np.asarray(settings_si, float))
        span = np.where(self.hi > self.lo, self.hi - self.lo, 1.0)
        return 2.0 * (x - self.lo) / span - 1.0

    def _pair(self, x, mean, sd, r, base: tuple | None = None) -> _ResponseGP:
        """GPs of log(mean + c) and log SD at inputs ``x``; with ``base`` = (log-mean, log-SD) per point, of the
        differences from it (the joint GP's setting effect)."""
        floor = RESPONSES[r][1]
        cols = [PARAMETER_NAMES.index(p) for p in RESPONSE_PARAMETERS[r]]
        b_mean, b_sd = base if base is not None else (0.0, 0.0)
        g_mean = FittedGP(x, np.log(mean + floor) - b_mean, self.seed)
        g_sd = FittedGP(x, np.log(np.maximum(sd, 1e-3 * floor)) - b_sd, self.seed,
                        noise=1.0 / (2 * (self.r_sim - 1)))
        return _ResponseGP(g_mean, g_sd, cols, floor)

    def _local_average(self, u: np.ndarray, r: str) -> tuple[np.ndarray, np.ndarray]:
        """Average over the simulated settings of the per-setting GPs' log(mean + c) and log SD at ``u``: the
        baseline of the joint GP, which models only the setting's effect on top of it."""
        cols = [PARAMETER_NAMES.index(p) for p in RESPONSE_PARAMETERS[r]]
        lm = np.mean([g[r].mean_gp.predict(u[:, cols], False)[0] for g in self.local], axis=0)
        ls = np.mean([g[r].logsd_gp.predict(u[:, cols], False)[0] for g in self.local], axis=0)
        return lm, ls

    def fit(self, settings_si: list, u: np.ndarray, mean: np.ndarray, sd: np.ndarray) -> None:
        """Train the per-setting GPs of every response.

        Parameters
        ----------
        settings_si : list of tuple of float
            The simulated settings (SI).
        u : numpy.ndarray
            (n, 6) theta on the prior's unit cube (the same points at every setting).
        mean, sd : numpy.ndarray
            (settings, n, responses) replicate mean and SD over the starts, the responses' units (%; efficiency in
            kg/min per kg of yield).
        """
        t0 = time.perf_counter()
        self.settings = [tuple(float(v) for v in s) for s in settings_si]
        self._lookup: dict = {}
        self.local = []
        for i in range(len(self.settings)):
            gps = {}
            for j, r in enumerate(self.responses):
                cols = [PARAMETER_NAMES.index(p) for p in RESPONSE_PARAMETERS[r]]
                gps[r] = self._pair(u[:, cols], mean[i, :, j], sd[i, :, j], r)
            self.local.append(gps)
        self._data = (np.array(self.settings, float), u, mean, sd)
        self.joint = None
        self.training_points = int(len(self.settings) * len(u))
        self.fit_seconds = time.perf_counter() - t0

    def fit_joint(self, focus: tuple | None = None) -> None:
        """Train the joint GPs (coded setting, theta) on a seeded subsample of the simulated Latin-hypercube points and,
        with ``focus``, on simulated points at posterior draws (where the predictions are made).

        Parameters
        ----------
        focus : (numpy.ndarray, numpy.ndarray, numpy.ndarray), optional
            ``(u, mean, sd)``: (k, 6) unit-cube points (dimensionless) and their simulated replicate means and SDs
            at every simulated setting, (settings, k, responses) in the responses' units (efficiency per kg of
            yield); they take half of :attr:`joint_points`.
        """
        t0 = time.perf_counter()
        s_all, u, mean, sd = self._data
        ns, nu = len(s_all), len(u)
        budget = min(self.joint_points // max(ns, 1), nu)  # per setting: no more than its hypercube
        nf = 0 if focus is None else min(len(focus[0]), budget // 2)
        per = max(4, min(nu, budget - nf))
        rng = np.random.default_rng(self.seed)
        self.joint = {}
        for j, r in enumerate(self.responses):
            cols = [PARAMETER_NAMES.index(p) for p in RESPONSE_PARAMETERS[r]]
            xs, uus, ms, ss = [], [], [], []
            for i in range(ns):
                pick = rng.choice(nu, size=per, replace=False)
                code = self.code(s_all[i:i + 1])
                xs.append(np.hstack([np.repeat(code, per, axis=0), u[pick][:, cols]]))
                uus.append(u[pick])
                ms.append(mean[i, pick, j])
                ss.append(sd[i, pick, j])
                if nf:
                    xs.append(np.hstack([np.repeat(code, nf, axis=0), focus[0][:nf][:, cols]]))
                    uus.append(focus[0][:nf])
                    ms.append(focus[1][i, :nf, j])
                    ss.append(focus[2][i, :nf, j])
            base = self._local_average(np.vstack(uus), r)
            self.joint[r] = self._pair(np.vstack(xs), np.concatenate(ms), np.concatenate(ss), r, base)
        self.fit_seconds += time.perf_counter() - t0

    def _index(self, setting) -> int | None:
        key = tuple(float(v) for v in setting)
        if key in self._lookup:
            return self._lookup[key]
        hit = next((i for i, s in enumerate(self.settings) if np.allclose(s, key, rtol=1e-12, atol=0)), None)
        self._lookup[key] = hit
        return hit

    def predict(self, settings_si: np.ndarray, u: np.ndarray, response: str, with_var: bool = True,
                joint: bool = False):
        """Emulated replicate mean, its emulator variance and the replicate SD of one response.

        Rows at a simulated setting use its per-setting GP (unless ``joint``), the others the joint GP.

        Parameters
        ----------
        settings_si : numpy.ndarray
            (n, factors) SI.
        u : numpy.ndarray
            (n, 6) theta on the prior's unit cube.
        response : str
            Response name.
        with_var : bool
            Compute the emulator's variance (else only its held-out MSE).
        joint : bool
            Use the joint GP everywhere (its held-out check at simulated settings).

        Returns
        -------
        (numpy.ndarray, numpy.ndarray, numpy.ndarray)
            Mean (the response's unit; efficiency per kg of yield), the emulator's variance of it (delta method on
            the log scale: (mean + c)^2 max(GP variance, held-out MSE); unit squared) and the replicate SD.
        """
        settings_si = np.atleast_2d(settings_si)
        u = np.atleast_2d(u)
        n = len(u)
        lm, var_log, lsd = np.empty(n), np.empty(n), np.empty(n)
        uniq, inverse = np.unique(settings_si, axis=0, return_inverse=True)
        groups: dict = {}
        for j, x in enumerate(uniq):
            key = None if joint else self._index(x)
            groups.setdefault(key, []).extend(np.flatnonzero(inverse.ravel() == j).tolist())
        floor = RESPONSES[response][1]
        for key, rows in groups.items():
            rows = np.array(rows)
            if key is None:
                if self.joint is None:
                    self.fit_joint()
                g = self.joint[response]
                x = np.hstack([self.code(settings_si[rows]), u[rows][:, g.columns]])
                b_mean, b_sd = self._local_average(u[rows], response)
            else:
                g = self.local[key][response]
                x = u[rows][:, g.columns]
                b_mean, b_sd = 0.0, 0.0
            m, v = g.mean_gp.predict(x, with_var)
            lm[rows] = b_mean + m
            var_log[rows] = np.maximum(v, g.mse_log_mean)
            lsd[rows] = b_sd + g.logsd_gp.predict(x, False)[0]
        mean = np.maximum(np.exp(lm) - floor, 0.0)
        return mean, (mean + floor) ** 2 * var_log, np.exp(lsd)


def latin_hypercube(n: int, seed: int, d: int = len(PARAMETERS)) -> np.ndarray:
    """A scrambled Latin hypercube of ``n`` points in (0, 1)^d (scipy.stats.qmc.LatinHypercube, seeded).

    Parameters
    ----------
    n : int
        Points.
    seed : int
        Seed.
    d : int
        Dimension.

    Returns
    -------
    numpy.ndarray
        (n, d) points strictly inside the unit cube (dimensionless).
    """
    from scipy.stats import qmc

    return np.clip(qmc.LatinHypercube(d=d, seed=seed).random(n), 1e-6, 1 - 1e-6)


def theta_of(u: np.ndarray, params: tuple[Parameter, ...]) -> np.ndarray:
    """Parameter values (SI) of unit-cube points through the priors' quantile functions.

    Parameters
    ----------
    u : numpy.ndarray
        (n, 6) prior probabilities (dimensionless).
    params : tuple of Parameter
        The parameters (:func:`parameters_for`).

    Returns
    -------
    numpy.ndarray
        (n, 6) values (SI).
    """
    u = np.atleast_2d(u)
    return np.column_stack([p.ppf(u[:, i]) for i, p in enumerate(params)])


def unit_of(theta: np.ndarray, params: tuple[Parameter, ...]) -> np.ndarray:
    """Prior probabilities (unit cube) of parameter values (SI): the inverse of :func:`theta_of`.

    Parameters
    ----------
    theta : numpy.ndarray
        (n, 6) values (SI).
    params : tuple of Parameter
        The parameters.

    Returns
    -------
    numpy.ndarray
        (n, 6) prior probabilities (values outside a uniform prior's bounds are clipped to it).
    """
    theta = np.atleast_2d(np.asarray(theta, float))
    cols = []
    for i, p in enumerate(params):
        if p.distribution == "uniform":
            cols.append(np.clip((theta[:, i] - p.lo) / (p.hi - p.lo), 1e-9, 1 - 1e-9))
        else:
            mu, s = p.log_median_sigma()
            cols.append(special.ndtr((np.log(theta[:, i]) - mu) / s))
    return np.column_stack(cols)


# --------------------------------------------------------------------------------------------- sheet
@dataclass
class Sheet:
    """A field sheet as the calibration reads it.

    Attributes
    ----------
    targets : list of FactorTarget
        Its factors, mapped to the machine.
    settings_si : numpy.ndarray
        (runs, factors) each run's setting (SI).
    observations : dict of str to numpy.ndarray
        Response -> (runs, replicates) field results (kg/min, %).
    replicates : int
        Replicates per run.
    runs_identified_by : str
        How the runs were told apart.
    level_values : dict
        Factor -> its level values in the sheet's units (None where the sheet gives level numbers only).
    """

    targets: list[FactorTarget]
    settings_si: np.ndarray
    observations: dict[str, np.ndarray]
    replicates: int
    runs_identified_by: str = "run column"
    level_values: dict = field(default_factory=dict)


def _filled_responses(path_or_text) -> list[str]:
    """The responses of :data:`RESPONSES` a sheet has values for (an index column with a number, or the raw masses)."""
    from berryshaker.experiment.field_columns import INDEX_NAMES, RAW_COLUMNS
    from berryshaker.experiment.field_results import _load_sheet

    df = _load_sheet(path_or_text).df
    cols = {c.lower(): c for c in df.columns}
    raw = all(c in df.columns and df[c].notna().any() and (df[c].astype(str).str.strip() != "").any()
              for c in RAW_COLUMNS)
    out = []
    for r in RESPONSES:
        col = INDEX_NAMES[r] if INDEX_NAMES[r] in df.columns else cols.get(r)
        filled = col is not None and df[col].notna().any() and (df[col].astype(str).str.strip() != "").any()
        if filled or raw:
            out.append(r)
    return out


def read_sheet(path_or_text, machine: Machine) -> Sheet:
    """Read a field sheet (``doe plan`` layout or a statistics package's worksheet with a replicate or block column)
    for the calibration (:func:`berryshaker.experiment.field_results.read_results`, strict) and map its factors to
    the machine (:func:`factor_target`).

    Parameters
    ----------
    path_or_text : path or str
        The sheet (CSV) or its text.
    machine : Machine
        The machine description.

    Returns
    -------
    Sheet
        Settings and replicate results.

    Raises
    ------
    ConfigError
        No response filled in, a factor calibrate cannot simulate, or any error of ``read_results``.
    """
    from berryshaker.experiment.field_results import read_results

    responses = _filled_responses(path_or_text)
    if not responses:
        raise ConfigError("the sheet has no field results: fill in efficiency_kg_min, unripe_rate_pct or "
                          "damage_rate_pct (or the raw masses duration_s, picked_mass_kg, unripe_mass_kg, "
                          "damaged_mass_kg) for every run; calibrate needs at least one response")
    fr = read_results(path_or_text, responses)
    targets = [factor_target(machine, n, fr.units.get(n, ""), fr.level_values.get(n)) for n in fr.factor_names]
    settings = np.column_stack([np.asarray(fr.values[:, j], float) * t.to_si for j, t in enumerate(targets)])
    if fr.responses_replicated is not None:
        obs = {r: np.asarray(v, float) for r, v in fr.responses_replicated.items()}
    else:
        obs = {r: np.asarray(v, float)[:, None] for r, v in fr.responses.items()}
    return Sheet(targets, settings, obs, fr.replicates, fr.runs_identified_by, dict(fr.level_values))


def level_sets(targets: list[FactorTarget]) -> np.ndarray:
    """Every level set of the factors (the full factorial of their levels), SI.

    Parameters
    ----------
    targets : list of FactorTarget
        The factors.

    Returns
    -------
    numpy.ndarray
        (prod of level counts, factors) settings (SI), the first factor slowest.
    """
    return np.array(list(itertools.product(*[t.levels_si for t in targets])), float)


def parse_setting(spec: str, targets: list[FactorTarget], machine: Machine) -> np.ndarray:
    """A setting named by the user, ``A=0.1mm,speed=130rpm`` (unit on every value, read by the strict quantity
    grammar of berryshaker.units, no expression evaluation); a factor not named keeps the described value.

    Parameters
    ----------
    spec : str
        ``NAME=value unit[,NAME=value unit ...]``.
    targets : list of FactorTarget
        The sheet's factors (only they can be named).
    machine : Machine
        The machine description (values of factors not named).

    Returns
    -------
    numpy.ndarray
        (factors,) the setting (SI).

    Raises
    ------
    ConfigError
        Not NAME=value pairs, a name that is not a factor of the sheet, a value without or with a wrong unit.
    """
    from berryshaker.units import parse_quantity

    if not isinstance(spec, str) or len(spec) > 400 or not spec.strip():
        raise ConfigError(f"--predict {spec!r}: expected NAME=value unit,..., e.g. A=0.1mm,C=0.2mm")
    names = {t.name: i for i, t in enumerate(targets)}
    values = [machine.clearance_sizes()[t.pair] if t.kind == "clearance" else machine.drive_speed for t in targets]
    for part in spec.split(","):
        if "=" not in part:
            raise ConfigError(f"--predict {spec!r}: {part.strip()!r} is not NAME=value unit (e.g. A=0.1mm)")
        name, value = (x.strip() for x in part.split("=", 1))
        if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name) or name not in names:
            raise ConfigError(f"--predict {spec!r}: {name!r} is not a factor of the sheet (factors: "
                              f"{', '.join(names)}); the emulator knows only the settings the sheet varies")
        t = targets[names[name]]
        dim = "length" if t.kind == "clearance" else "angular_speed"
        v = parse_quantity(value, dim, f"--predict {name}", units_required=True)
        if not v > 0:
            raise ConfigError(f"--predict {name}={value}: must be > 0")
        values[names[name]] = v
    return np.array(values, float)


# --------------------------------------------------------------------------------------------- likelihood
def log_likelihood(emulator: Emulator, sheet_settings: np.ndarray, obs: dict[str, np.ndarray], u: np.ndarray,
                   params: tuple[Parameter, ...], r_sim: int, discrepancy: float = 0.0) -> np.ndarray:
    """Log-likelihood of the sheet's results at parameter points ``u`` (module docstring, item 4).

    The replicates y_1..R of a run are y = mu 1 + e_c 1 + e with e ~ N(0, sigma^2 I) (sigma the simulator's
    start-to-start SD) and e_c common to the run, variance tau^2 = sigma^2 / R_sim + sigma_emu^2 + (delta mu)^2.
    sigma itself is estimated from the R_sim simulated starts, so the density is the multivariate Student t with
    nu = R_sim - 1 degrees of freedom that this gives under the reference prior p(mu, sigma^2) ~ 1 / sigma^2
    (Gelman et al., Bayesian Data Analysis, 3rd ed. 2013, sec. 3.2: the predictive of new draws from a normal
    sample), scale matrix Sigma = sigma^2 I + tau^2 1 1^T:

        ln p = ln G((nu + R)/2) - ln G(nu/2) - R/2 ln(nu pi) - 1/2 ln|Sigma| - (nu + R)/2 ln(1 + Q / nu),
        |Sigma| = sigma^(2 (R - 1)) (sigma^2 + R tau^2),  Q = SS_w / sigma^2 + R (ybar - mu)^2 / (sigma^2 + R tau^2),

    ybar and SS_w the run's replicate mean and within sum of squares.  (A normal density with sigma taken as known
    made a sheet from the reference parameters exclude them: with R_sim = 3 an SD is known to a factor of two.)

    Parameters
    ----------
    emulator : Emulator
        The trained emulator.
    sheet_settings : numpy.ndarray
        (runs, factors) SI.
    obs : dict of str to numpy.ndarray
        Response -> (runs, replicates) field results (kg/min, %).
    u : numpy.ndarray
        (walkers, 6) parameter points on the prior's unit cube.
    params : tuple of Parameter
        The parameters (the yield's quantile function).
    r_sim : int
        Starts behind the simulated means and SDs (>= 2).
    discrepancy : float
        delta, the model discrepancy's SD as a fraction of the mean (0: off).

    Returns
    -------
    numpy.ndarray
        (walkers,) log-likelihoods (dimensionless).
    """
    nw, ns = u.shape[0], sheet_settings.shape[0]
    uu = np.repeat(u, ns, axis=0)
    xx = np.tile(sheet_settings, (nw, 1))
    yi = PARAMETER_NAMES.index("yield_per_bush")
    yb = params[yi].ppf(uu[:, yi])
    nu = r_sim - 1.0
    total = np.zeros(nw)
    for r, y in obs.items():
        mean, var_emu, sd = emulator.predict(xx, uu, r)
        if r == "efficiency":
            mean, var_emu, sd = mean * yb, var_emu * yb**2, sd * yb
        R = y.shape[1]
        ybar = np.tile(y.mean(axis=1), nw)
        ssw = np.tile(((y - y.mean(axis=1, keepdims=True)) ** 2).sum(axis=1), nw)
        s2 = np.maximum(sd, 1e-6) ** 2
        tau2 = s2 / r_sim + var_emu + (discrepancy * mean) ** 2
        big = s2 + R * tau2
        q = ssw / s2 + R * (ybar - mean) ** 2 / big
        ll = (special.gammaln((nu + R) / 2) - special.gammaln(nu / 2) - R / 2 * math.log(nu * math.pi)
              - 0.5 * ((R - 1) * np.log(s2) + np.log(big)) - (nu + R) / 2 * np.log1p(q / nu))
        total += ll.reshape(nw, ns).sum(axis=1)
    return total


def sample_posterior(emulator: Emulator, sheet: Sheet, params: tuple[Parameter, ...], r_sim: int, seed: int,
                     discrepancy: float = 0.0, steps: int | None = None, walkers: int | None = None,
                     obs: dict | None = None, settings: np.ndarray | None = None, progress=None) -> dict:
    """Posterior draws of the parameters with ``emcee`` (affine-invariant ensemble, vectorised log-probability) in the
    priors' standard-normal coordinates (prior N(0, 1) per coordinate; theta = prior quantile of Phi(z)).

    Without ``steps`` the chain runs in blocks of 500 steps until it is 50 integrated autocorrelation times long (at
    most 4000 steps); burn-in = 3 tau, thinning = tau / 2 (tau the largest over the parameters).

    Parameters
    ----------
    emulator : Emulator
        The trained emulator.
    sheet : Sheet
        The sheet (settings and results).
    params : tuple of Parameter
        The parameters.
    r_sim : int
        Starts behind the simulated means.
    seed : int
        Seed of the walkers' start and moves.
    discrepancy : float
        Model discrepancy (fraction of the mean).
    steps : int, optional
        Fixed steps per walker.
    walkers : int, optional
        Walkers (default 4 x dimension, at least 24).
    obs : dict, optional
        Results to use instead of the sheet's (a held-out run left out).
    settings : numpy.ndarray, optional
        Settings of ``obs`` (default the sheet's).
    progress : callable, optional
        ``progress(steps_done, steps_planned)``.

    Returns
    -------
    dict
        ``z`` (draws, 6) normal scores, ``u`` unit-cube points, ``theta`` (SI), ``acceptance_fraction``,
        ``autocorrelation_steps`` (per parameter), ``steps``, ``walkers``, ``burn``, ``thin``, ``converged``
        (chain >= 50 tau).
    """
    import emcee

    obs = sheet.observations if obs is None else obs
    settings = sheet.settings_si if settings is None else settings
    dim = len(params)
    nw = walkers or max(24, 4 * dim)
    rng = np.random.default_rng(seed)

    def log_prob(z):
        u = special.ndtr(z)
        u = np.clip(u, 1e-12, 1 - 1e-12)
        return -0.5 * np.sum(z**2, axis=1) + log_likelihood(emulator, settings, obs, u, params, r_sim,
                                                              discrepancy)

    sampler = emcee.EnsembleSampler(nw, dim, log_prob, vectorize=True,
                                    moves=[(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)])
    sampler.random_state = np.random.RandomState(seed).get_state()
    state = rng.standard_normal((nw, dim))
    planned = steps or 4000
    done, tau = 0, np.full(dim, np.nan)
    block = steps or 500
    while True:
        state = sampler.run_mcmc(state, block, progress=False)
        done += block
        if progress:
            progress(done, planned)
        tau = sampler.get_autocorr_time(tol=0)
        if steps or done >= planned or done >= 50 * float(np.nanmax(tau)):
            break
    t = float(np.nanmax(tau)) if np.all(np.isfinite(tau)) else done / 50
    burn = min(int(math.ceil(3 * t)), done // 2)
    thin = max(1, int(t / 2))
    z = sampler.get_chain(discard=burn, thin=thin, flat=True)
    u = np.clip(special.ndtr(z), 1e-12, 1 - 1e-12)
    return {"z": z, "u": u, "theta": theta_of(u, params),
            "acceptance_fraction": float(np.mean(sampler.acceptance_fraction)),
            "autocorrelation_steps": [float(x) for x in tau], "steps": done, "walkers": nw, "burn": burn,
            "thin": thin, "converged": bool(done >= 50 * t)}


def predictive(emulator: Emulator, settings_si: np.ndarray, u: np.ndarray, params: tuple[Parameter, ...],
               response: str, rng: np.random.Generator, replicates: int = 1, r_sim: int | None = None,
               discrepancy: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Draws of a future field result (the mean of ``replicates`` results) at settings, over posterior draws: the
    emulated mean + emulator error + the simulated mean's own error + discrepancy + replicate noise.

    Parameters
    ----------
    emulator : Emulator
        The trained emulator.
    settings_si : numpy.ndarray
        (settings, factors) SI.
    u : numpy.ndarray
        (draws, 6) posterior draws on the unit cube (prior probabilities, dimensionless).
    params : tuple of Parameter
        The parameters.
    response : str
        Response name.
    rng : numpy.random.Generator
        Noise draws.
    replicates : int
        Results averaged (1: one future field result).
    r_sim : int, optional
        Starts behind the simulated means: adds sigma^2 / R_sim to the emulator error, and sigma is drawn as known
        from R_sim starts (x sqrt(nu / chi2_nu), nu = R_sim - 1).
    discrepancy : float
        Model discrepancy (fraction of the mean).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        (settings, draws) expected result (mean) and future result draws, the response's unit; both clipped at 0
        (an efficiency or a rate is never negative).
    """
    ns, nd = settings_si.shape[0], u.shape[0]
    uu = np.tile(u, (ns, 1))
    xx = np.repeat(settings_si, nd, axis=0)
    mean, var_emu, sd = emulator.predict(xx, uu, response)
    if response == "efficiency":
        yb = params[PARAMETER_NAMES.index("yield_per_bush")].ppf(uu[:, PARAMETER_NAMES.index("yield_per_bush")])
        mean, var_emu, sd = mean * yb, var_emu * yb**2, sd * yb
    if r_sim:  # sigma known from R_sim starts: scaled by sqrt(nu / chi2_nu) per draw (the t of log_likelihood)
        sd = sd * np.sqrt((r_sim - 1) / rng.chisquare(r_sim - 1, mean.size))
    common = var_emu + (sd**2 / r_sim if r_sim else 0.0) + (discrepancy * mean) ** 2
    expected = np.maximum(mean + np.sqrt(common) * rng.standard_normal(mean.size), 0.0)
    future = np.maximum(expected + sd / math.sqrt(replicates) * rng.standard_normal(mean.size), 0.0)  # rates >= 0
    return expected.reshape(ns, nd), future.reshape(ns, nd)


# --------------------------------------------------------------------------------------------- the whole method
@dataclass
class CalibrationSettings:
    """Sizes of the method (defaults: the command's).

    Attributes
    ----------
    replicates : int or None
        Simulated starts per setting (default ``harvest.replicates``).
    theta_points : int
        Latin-hypercube parameter points per simulated setting (emulator training).
    check_points : int
        Held-out parameter points per setting for the emulator's check.
    check_settings : int
        Untested settings simulated for the emulator's check.
    steps : int or None
        MCMC steps per walker (None: until 50 autocorrelation times).
    walkers : int or None
        Walkers (None: 4 x dimension, at least 24).
    draws : int
        Posterior draws used for predictions and checks.
    held_out_run : bool
        Calibrate once more without one run and predict it (when runs > parameters + 2).
    seed : int
        Seed of everything random in the method (the simulator's starts use the description's seeds).
    discrepancy : float
        Model discrepancy, fraction of the mean (0: off).
    """

    replicates: int | None = None
    theta_points: int = 40
    check_points: int = 8
    check_settings: int = 2
    steps: int | None = None
    walkers: int | None = None
    draws: int = 400
    held_out_run: bool = True
    seed: int = 0
    discrepancy: float = 0.0


def training_seeds(machine: Machine, replicates: int) -> list[int]:
    """The simulator's start seeds: the virtual L9's, ``harvest.seed + 1000 k`` (shared with the study's cache).

    Parameters
    ----------
    machine : Machine
        The description.
    replicates : int
        Starts.

    Returns
    -------
    list of int
        Seeds.
    """
    from berryshaker.harvest.virtual import replicate_seeds

    return replicate_seeds(machine, replicates)


def fresh_seeds(machine: Machine, count: int, offset: int = 0) -> list[int]:
    """Start seeds never used by the simulator's training (``harvest.seed + 1000 k + 500``): synthetic field results.

    Parameters
    ----------
    machine : Machine
        The description.
    count : int
        Seeds.
    offset : int
        First k.

    Returns
    -------
    list of int
        Seeds.
    """
    return [machine.harvest.seed + 1000 * (offset + k) + 500 for k in range(count)]


def _check_settings(targets: list[FactorTarget], tested: np.ndarray, count: int, seed: int) -> np.ndarray:
    """Untested settings for the emulator's check: untested level sets of the full factorial first (seeded choice),
    then points drawn uniformly inside the level ranges."""
    if count <= 0:
        return np.zeros((0, len(targets)))
    rng = np.random.default_rng(seed)
    full = level_sets(targets)
    untested = [x for x in full if not any(np.allclose(x, t, rtol=1e-12, atol=0) for t in tested)]
    pick = [untested[i] for i in rng.permutation(len(untested))[:count]]
    while len(pick) < count:
        pick.append(np.array([rng.uniform(min(t.levels_si), max(t.levels_si)) for t in targets]))
    return np.array(pick, float)


def _train(sim: Simulator, responses: list[str], settings: list[int], seeds: list[int], u: np.ndarray,
           params) -> tuple[np.ndarray, np.ndarray]:
    """Simulated replicate means and SDs at every setting and unit-cube point: (settings, points, responses) each,
    the efficiency per kg of yield."""
    theta = theta_of(u, params)
    theta[:, PARAMETER_NAMES.index("yield_per_bush")] = 1.0  # efficiency per kg of yield
    cols = [list(RESPONSES).index(r) for r in responses]
    means, sds = [], []
    for s in settings:
        m, sd = start_statistics(sim.responses(s, seeds, theta))
        means.append(m[:, cols])
        sds.append(sd[:, cols])
    return np.stack(means), np.stack(sds)


def _emulator_check(sim, emulator: Emulator, settings, seeds, u, params) -> dict:
    """Held-out error of the emulator at ``settings`` and points ``u`` (neither trained on): RMSE of the mean, over the
    RMS replicate SD; RMSE of log SD; MSE of log(mean + c) and its root (``relative_rmse``, about the relative error
    of mean + c)."""
    mean, sd = _train(sim, emulator.responses, settings, seeds, u, params)
    x = np.repeat(np.array([sim.settings[s] for s in settings]), len(u), axis=0)
    uu = np.tile(u, (len(settings), 1))
    out = {}
    for j, r in enumerate(emulator.responses):
        pm, _, psd = emulator.predict(x, uu, r, with_var=False)
        floor = RESPONSES[r][1]
        m, s_ = mean[:, :, j].ravel(), sd[:, :, j].ravel()
        rms_sd = float(np.sqrt(np.mean(s_**2)))
        rmse = float(np.sqrt(np.mean((pm - m) ** 2)))
        out[r] = {"rmse": rmse, "replicate_sd_rms": rms_sd,
                  "rmse_over_sd": rmse / rms_sd if rms_sd > 0 else float("nan"),
                  "log_sd_rmse": float(np.sqrt(np.mean((np.log(np.maximum(psd, 1e-3 * floor))
                                                        - np.log(np.maximum(s_, 1e-3 * floor))) ** 2))),
                  "mse_log_mean": float(np.mean((np.log(pm + floor) - np.log(m + floor)) ** 2)),
                  "relative_rmse": float(np.sqrt(np.mean((np.log(pm + floor) - np.log(m + floor)) ** 2))),
                  "points": int(len(m)), "unit": "kg/min per kg of yield per bush" if r == "efficiency" else "%"}
    return out


def _summaries(draws: np.ndarray, params, described: dict) -> dict:
    out = {}
    for i, p in enumerate(params):
        v = draws[:, i]
        plo, phi = p.interval90()
        lo, hi = (float(x) for x in np.quantile(v, [0.05, 0.95]))
        ratio = (hi - lo) / (phi - plo)
        out[p.name] = {"unit": p.unit, "prior": {"distribution": p.distribution, "text": p.describe(), "lo90": plo,
                                                 "hi90": phi, "source": p.source, "tag": p.tag},
                       "described": float(described[p.name]), "posterior_mean": float(np.mean(v)),
                       "posterior_median": float(np.median(v)), "lo90": lo, "hi90": hi, "width_ratio": float(ratio),
                       "identified": bool(ratio < 0.5)}
    return out


def _confounded(z: np.ndarray, params) -> list[dict]:
    c = np.corrcoef(z.T)
    out = []
    for i, j in itertools.combinations(range(len(params)), 2):
        if abs(c[i, j]) >= 0.5:
            out.append({"parameters": [params[i].name, params[j].name], "correlation": float(c[i, j])})
    return out


def _recommend(names: list[str], expected: dict[str, np.ndarray], responses: list[str]) -> dict:
    """:data:`RECOMMENDATION_RULE` on the expected-result draws (level sets x draws) per response."""
    from berryshaker.reference_study import PRIORITY_WEIGHTS, SENSES

    n = len(names)
    beats = np.zeros((n, n), bool)  # beats[a, b]: a better than b on some response
    worse = np.zeros((n, n), bool)
    for r in responses:
        e = expected[r] if SENSES[r] else -expected[r]
        d = e[:, None, :] - e[None, :, :]
        lo, hi = np.quantile(d, 0.05, axis=2), np.quantile(d, 0.95, axis=2)
        beats |= lo > 0
        worse |= hi < 0
    dominated = [bool(np.any(beats[:, b] & ~worse[:, b])) for b in range(n)]
    w = {r: PRIORITY_WEIGHTS[r] for r in responses}
    total = sum(w.values())
    score = np.zeros(n)
    for r in responses:
        m = expected[r].mean(axis=1)
        m = m if SENSES[r] else -m
        span = m.max() - m.min()
        score += w[r] / total * ((m - m.min()) / span if span > 0 else 0.0)
    free = [i for i in range(n) if not dominated[i]]
    best = max(free, key=lambda i: score[i])
    return {"level_set": names[best], "score": float(score[best]),
            "no_difference": [names[i] for i in free if i != best],
            "dominated": int(sum(dominated)), "candidates": n, "rule": RECOMMENDATION_RULE,
            "weights": {r: w[r] / total for r in responses}}


def calibrate(machine: Machine, sheet: Sheet, runner, options: CalibrationSettings | None = None,
              predict: list[np.ndarray] | None = None, progress=None) -> dict:
    """Posterior of the harvest parameters given a field sheet, its checks and its predictions (module docstring).

    Parameters
    ----------
    machine : Machine
        The machine description (with [plant] and [harvest]).
    sheet : Sheet
        The field sheet (:func:`read_sheet`).
    runner : SweepRunner
        Cached runner of the coupled starts.
    options : CalibrationSettings, optional
        Sizes and seed.
    predict : list of numpy.ndarray, optional
        Further settings to predict (SI, :func:`parse_setting`).
    progress : callable, optional
        ``progress(stage, done, total)``: "emulator", "sampling", "held-out run".

    Returns
    -------
    dict
        ``parameters`` (per name: unit, prior, described, posterior_mean, posterior_median, lo90, hi90, width_ratio,
        identified), ``identified_rule``, ``confounded``, ``predictions`` (per level set: setting, tested,
        extrapolated, responses with mean, lo90, hi90, unit), ``recommendation``, ``emulator``, ``checks``,
        ``sampler``, ``simulator``, ``sheet``, ``likelihood``, ``discrepancy``, ``limits``; all values SI except the
        responses (kg/min, %).
    """
    opt = options or CalibrationSettings()
    if machine.plant is None:
        raise ConfigError("calibrate needs a [plant] block in the machine description (the harvest model runs on "
                          "it); add one, e.g. from the reference machine (config init)")
    if machine.harvest.bond_model != "pull_shear" or machine.harvest.damage_model != "impact":
        raise ConfigError("calibrate works on the published-strength model: set harvest.bond_model = \"pull_shear\" "
                          "and harvest.damage_model = \"impact\" (the defaults)")
    if not 0 <= opt.discrepancy < 1:
        raise ConfigError(f"--discrepancy {opt.discrepancy}: give a fraction of the mean in 0 .. 1 (0 = off)")
    params = parameters_for(machine)
    responses = [r for r in RESPONSES if r in sheet.observations]
    r_sim = int(opt.replicates or machine.harvest.replicates)
    if r_sim < 2:
        raise ConfigError("--replicates must be at least 2 (the replicate SD needs two starts)")
    sim = Simulator(machine, sheet.targets)
    sheet_idx = [sim.setting_index(x) for x in sheet.settings_si]
    unique = sorted(set(sheet_idx))
    checks = _check_settings(sheet.targets, np.array([sim.settings[i] for i in unique]), opt.check_settings,
                             opt.seed + 7)
    check_idx = [sim.setting_index(x) for x in checks]
    seeds = training_seeds(machine, r_sim)
    t0 = time.perf_counter()
    sim.run(runner, unique + check_idx, seeds, "calibration: simulator starts")
    t_sim = time.perf_counter() - t0
    # emulator
    if progress:
        progress("emulator", 0, 1)
    emulator = Emulator(sheet.targets, responses, opt.seed, r_sim)
    u_train = latin_hypercube(opt.theta_points, opt.seed + 1)
    u_check = latin_hypercube(opt.check_points, opt.seed + 2)
    t1 = time.perf_counter()
    emulator.fit([sim.settings[i] for i in unique], u_train, *_train(sim, responses, unique, seeds, u_train, params))
    held_theta = _emulator_check(sim, emulator, unique, seeds, u_check, params)
    for gps in emulator.local:
        for r in responses:
            gps[r].mse_log_mean = held_theta[r]["mse_log_mean"]
    t_emu = time.perf_counter() - t1
    if progress:
        progress("emulator", 1, 1)
    # posterior
    t2 = time.perf_counter()
    post = sample_posterior(emulator, sheet, params, r_sim, opt.seed + 3, opt.discrepancy, opt.steps, opt.walkers,
                            progress=(lambda d, n: progress("sampling", d, n)) if progress else None)
    t_mcmc = time.perf_counter() - t2
    rng = np.random.default_rng(opt.seed + 4)
    pick = rng.choice(len(post["u"]), size=min(opt.draws, len(post["u"])), replace=False)
    u_draws = post["u"][pick]
    # the joint GP (settings not simulated): trained with simulated points at posterior draws as well, then checked
    # at the untested check settings on other posterior draws (where its predictions are used)
    t3 = time.perf_counter()
    focus_u = post["u"][rng.choice(len(post["u"]), size=min(16, len(post["u"])), replace=False)]
    emulator.fit_joint((focus_u, *_train(sim, responses, unique, seeds, focus_u, params)))
    held_settings = {}
    if check_idx:
        check_u = post["u"][rng.choice(len(post["u"]), size=min(opt.check_points, len(post["u"])), replace=False)]
        held_settings = _emulator_check(sim, emulator, check_idx, seeds, check_u, params)
        for r in responses:
            emulator.joint[r].mse_log_mean = held_settings[r]["mse_log_mean"]
    t_emu += time.perf_counter() - t3
    described = described_values(machine)
    parameters = _summaries(post["theta"], params, described)
    # posterior predictive checks on the sheet's runs
    ppc = []
    run_settings = sheet.settings_si
    for r in responses:
        _, fut = predictive(emulator, run_settings, u_draws, params, r, rng, sheet.replicates, r_sim, opt.discrepancy)
        for i in range(len(run_settings)):
            lo, hi = np.quantile(fut[i], [0.05, 0.95])
            ob = float(np.mean(sheet.observations[r][i]))
            ppc.append({"run": i + 1, "setting": sim.setting_text(sheet_idx[i]), "response": r, "observed_mean": ob,
                        "lo90": float(lo), "hi90": float(hi), "inside": bool(lo <= ob <= hi)})
    held_run = _held_out_run(emulator, sheet, params, r_sim, opt, sim, sheet_idx, responses, progress)
    # predictions
    full = level_sets(sheet.targets)
    extra = [np.asarray(x, float) for x in (predict or [])]
    pred_settings = np.vstack([full] + [x[None, :] for x in extra]) if extra else full
    names = [", ".join(f"{t.name}={v / t.to_si:.6g}{t.unit}" for t, v in zip(sheet.targets, x)) for x in pred_settings]
    tested = {tuple(np.round(x, 15)) for x in sheet.settings_si}
    lo_b, hi_b = emulator.lo, emulator.hi
    expected, predictions = {}, []
    for r in responses:
        e, fut = predictive(emulator, pred_settings, u_draws, params, r, rng, 1, r_sim, opt.discrepancy)
        expected[r] = e
        for i in range(len(pred_settings)):
            if len(predictions) <= i:
                x = pred_settings[i]
                predictions.append({"level_set": names[i], "setting": {
                    t.name: {"value": float(v / t.to_si), "unit": t.unit} for t, v in zip(sheet.targets, x)},
                    "tested": tuple(np.round(x, 15)) in tested, "named": i >= len(full),
                    "extrapolated": bool(np.any(x < lo_b - 1e-15) or np.any(x > hi_b + 1e-15)), "responses": {}})
            lo, hi = np.quantile(fut[i], [0.05, 0.95])
            predictions[i]["responses"][r] = {"mean": float(np.mean(e[i])), "lo90": float(lo), "hi90": float(hi),
                                              "unit": RESPONSES[r][0]}
    recommendation = _recommend(names, expected, responses)
    inside = sum(c["inside"] for c in ppc)
    return {
        "parameters": parameters, "identified_rule": IDENTIFIED_RULE,
        "confounded": _confounded(post["z"], params), "confounded_rule": CONFOUNDED_RULE,
        "predictions": predictions, "recommendation": recommendation,
        "emulator": {"kind": "scikit-learn GaussianProcessRegressor per response on log(mean + c) and log(SD): "
                             "ConstantKernel x Matern(nu=2.5, ARD) + WhiteKernel, normalize_y; per simulated setting "
                             "over theta on the prior's unit cube (the likelihood, predictions there) and one joint GP "
                             "over (coded setting, theta) for settings not simulated",
                     "joint_fitted": emulator.joint is not None, "joint_points": emulator.joint_points,
                     "training_points": emulator.training_points, "theta_points_per_setting": opt.theta_points,
                     "held_out_theta": held_theta, "held_out_settings": held_settings,
                     "held_out_settings_at": "posterior draws not used in training, at untested settings simulated "
                                             "for the check (the joint GP's error where it predicts)",
                     "check_settings": [sim.setting_text(i) for i in check_idx], "fit_s": emulator.fit_seconds},
        "checks": {"posterior_predictive": ppc,
                   "summary": {"inside": int(inside), "total": len(ppc),
                               "rule": "observed replicate mean inside the 90 % predictive interval of the mean of "
                                       f"{sheet.replicates} future result(s)"},
                   "held_out_run": held_run},
        "sampler": {k: post[k] for k in ("walkers", "steps", "burn", "thin", "acceptance_fraction",
                                         "autocorrelation_steps", "converged")} | {
            "draws": int(len(post["u"])), "package": "emcee (DEMove 0.8, DESnookerMove 0.2)"},
        "simulator": {"starts_per_setting": r_sim, "seeds": seeds, "settings_simulated": len(sim.settings),
                      "coupled_runs": sim.runs, "exact": "post-processing of the cached stem-load tables at every "
                                                         "theta with common random numbers"},
        "sheet": {"runs": int(len(sheet.settings_si)), "replicates": sheet.replicates, "responses": responses,
                  "factors": {t.name: {"sets": t.pair or "drive speed", "unit": t.unit,
                                       "levels": [v / t.to_si for v in t.levels_si]} for t in sheet.targets},
                  "runs_identified_by": sheet.runs_identified_by},
        "likelihood": ("replicates of a run jointly normal: mean mu(theta) (emulated), per-result SD sigma(theta) (the "
                       "simulator's start-to-start SD), a term common to the run with variance sigma^2/R_sim + "
                       "emulator variance + (discrepancy x mu)^2; responses independent given theta"),
        "discrepancy": opt.discrepancy,
        "discrepancy_text": ("off (0): no model-discrepancy term" if opt.discrepancy == 0 else
                             f"on: SD {opt.discrepancy:g} x the mean, common to a run's replicates"),
        "limits": list(LIMITS), "timings_s": {"simulator": t_sim, "emulator": t_emu, "sampling": t_mcmc},
    }


def _held_out_run(emulator, sheet: Sheet, params, r_sim, opt: CalibrationSettings, sim, sheet_idx, responses,
                  progress) -> dict:
    """Calibrate without the sheet's first run and predict it (when runs > parameters + 2 and asked for)."""
    n = len(sheet.settings_si)
    if not opt.held_out_run or n <= len(params) + 2:
        return {"done": False, "reason": f"{n} runs: a held-out run needs more than {len(params) + 2} (parameters + 2)"
                if n <= len(params) + 2 else "not asked for"}
    keep = np.arange(1, n)
    obs = {r: v[keep] for r, v in sheet.observations.items()}
    if progress:
        progress("held-out run", 0, 1)
    post = sample_posterior(emulator, sheet, params, r_sim, opt.seed + 5, opt.discrepancy,
                            opt.steps or 1000, opt.walkers, obs=obs, settings=sheet.settings_si[keep])
    rng = np.random.default_rng(opt.seed + 6)
    u = post["u"][rng.choice(len(post["u"]), size=min(opt.draws, len(post["u"])), replace=False)]
    rows = []
    for r in responses:
        _, fut = predictive(emulator, sheet.settings_si[:1], u, params, r, rng, sheet.replicates, r_sim,
                            opt.discrepancy)
        lo, hi = np.quantile(fut[0], [0.05, 0.95])
        ob = float(np.mean(sheet.observations[r][0]))
        rows.append({"run": 1, "setting": sim.setting_text(sheet_idx[0]), "response": r, "observed_mean": ob,
                     "lo90": float(lo), "hi90": float(hi), "inside": bool(lo <= ob <= hi)})
    if progress:
        progress("held-out run", 1, 1)
    return {"done": True, "run": 1, "rows": rows, "steps": post["steps"]}


# --------------------------------------------------------------------------------------------- synthetic sheets
def synthetic_results(sim: Simulator, settings: list[int], theta: dict[str, float], seeds: list[int],
                      pop_seeds: list[int] | None = None) -> np.ndarray:
    """Field results of the simulator at ``theta`` from starts ``seeds`` (run before with :meth:`Simulator.run`, with
    the same ``pop_seeds``): one result per setting and start, with the replicate noise of the coupled runs and the
    populations.

    Parameters
    ----------
    sim : Simulator
        The simulator.
    settings : list of int
        Setting indexes.
    theta : dict of str to float
        Parameter values (SI) by name.
    seeds : list of int
        Start seeds.
    pop_seeds : list of int, optional
        Population seeds (as given to :meth:`Simulator.run`).

    Returns
    -------
    numpy.ndarray
        (settings, starts, 3) efficiency (kg/min), unripe rate (%), damage rate (%); a rate that is undefined
        (nothing picked) is 0.
    """
    th = np.array([[theta[n] for n in PARAMETER_NAMES]], float)
    return np.nan_to_num(np.stack([sim.responses(s, seeds, th, pop_seeds)[0] for s in settings]), nan=0.0)


def synthetic_sheet(machine: Machine, runner, factors, theta: dict[str, float] | None = None, array: str = "L9",
                    replicates: int = 3, seed_offset: int = 0, responses=tuple(RESPONSES)):
    """A filled field sheet (``doe plan`` layout) from the simulator at known parameters: the plan of
    :func:`berryshaker.experiment.field_sheet.plan_table` with its index columns filled by the virtual harvest at
    ``theta`` from starts the calibration never trains on (:func:`fresh_seeds`), so it carries the real replicate
    noise.  The docs' example and the test calibrate such sheets.

    Parameters
    ----------
    machine : Machine
        The machine description.
    runner : SweepRunner
        Cached runner of the coupled starts.
    factors : list of Factor
        The plan's factors (berryshaker.experiment.field_sheet.parse_factor), named as :func:`factor_target` reads
        them.
    theta : dict of str to float, optional
        Parameter values (SI) by name; missing ones take the description's (:func:`described_values`).
    array : str
        Orthogonal array of the plan.
    replicates : int
        Replicates per run.
    seed_offset : int
        First fresh start (k of :func:`fresh_seeds`); every row has its own start and population (row i: k =
        seed_offset + i), so sheets with offsets apart by the row count share none.
    responses : sequence of str
        Responses filled in (the others are left empty).

    Returns
    -------
    pandas.DataFrame
        The filled sheet (write it with ``to_csv(path, index=False)``).
    """
    from berryshaker.experiment.field_sheet import plan_table

    plan = plan_table(array, list(factors), replicates=replicates)
    targets = [factor_target(machine, f.name, f.unit, f.levels) for f in factors]
    sim = Simulator(machine, targets)
    idx = [sim.setting_index([row[f.column] * t.to_si for f, t in zip(factors, targets)]) for _, row in plan.iterrows()]
    seeds = fresh_seeds(machine, len(plan), seed_offset)  # every row its own start and bushes, as in a field
    sim.run_starts(runner, [(s, sd, sd) for s, sd in zip(idx, seeds)], "synthetic sheet: fresh starts")
    vals = {**described_values(machine), **(theta or {})}
    th = np.array([[vals[n] for n in PARAMETER_NAMES]], float)
    res = np.nan_to_num(np.array([sim.responses(s, [sd], th)[0, 0] for s, sd in zip(idx, seeds)]), nan=0.0)
    cols = {"efficiency": "efficiency_kg_min", "unripe": "unripe_rate_pct", "damage": "damage_rate_pct"}
    for j, r in enumerate(RESPONSES):
        if r in responses:
            plan[cols[r]] = res[:, j]
    return plan
