"""The simulator with common random numbers: the virtual harvest at a field sheet's settings as an exact, cheap
function of the calibrated parameters (:class:`Simulator`), and the start seeds it runs from.

Every setting of the sheet (its factors mapped to the machine,
:func:`~berryshaker.study.field_calibration.sheet.factor_target`) is run from R perturbed starts through the cached
:class:`~berryshaker.runs.runner.SweepRunner` (:func:`berryshaker.study.l9.replicate_jobs`,
:func:`berryshaker.study.runs.replicate_run`).  A response at
(setting, start, theta) is then exact and cheap: the pull-shear load ratio channels ``CH_RIPE``/``CH_UNRIPE`` of a
table are homogeneous of degree -1 in the class's mean strengths (sqrt((F_p/aP)^2 + (F_s/aS)^2) =
(1/a) sqrt((F_p/P)^2 + (F_s/S)^2), and the peak over time commutes with a > 0), so a strength scaled by a divides
its channel by a; the population is the one of :func:`berryshaker.harvest.virtual.sample_population` with the same
seed (same uniforms and normals for every theta), so the replicate mean mu_s(theta) is smooth in theta; the picked
mass is proportional to the yield per bush (the count of sampled fruit stays that of the described yield, as
``sample_population(..., yield_per_bush=)``), so the efficiency is exactly yield x (efficiency per kg of yield).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from berryshaker.config import Machine, machine_from_dict
from berryshaker.errors import ConfigError
from berryshaker.study.field_calibration.sheet import FactorTarget, setting_data


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
            (n, 6) parameter values in :data:`~berryshaker.study.field_calibration.priors.PARAMETER_NAMES` order (SI).
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
