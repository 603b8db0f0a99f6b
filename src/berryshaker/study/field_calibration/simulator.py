"""The simulator: the virtual harvest at a field sheet's settings as an exact, cheap function of the calibrated
parameters (:class:`Simulator`), through the virtual harvest's own implementation
(:mod:`berryshaker.harvest.virtual.field_test`).

Every setting of the sheet (its factors mapped to the machine,
:func:`~berryshaker.study.field_calibration.sheet.factor_target`) is run from R perturbed starts through the cached
:class:`~berryshaker.runs.runner.SweepRunner` (:func:`berryshaker.study.l9.replicate_jobs`,
:func:`berryshaker.study.runs.replicate_run`).  Each (setting, start) keeps the quadrature nodes of its fruit with
their peak loads (:func:`~berryshaker.harvest.virtual.field_test.load_grid`); at any parameter point theta the
start's model expectation and the counting variance of one field test are then exact post-processing
(:func:`~berryshaker.harvest.virtual.field_test.expected_tally`,
:func:`~berryshaker.harvest.virtual.field_test.expectation` with
:class:`~berryshaker.harvest.virtual.field_test.HarvestParameters`): a strength scaled by a divides its load ratio by
a (the pull-shear ratio is homogeneous of degree -1 in the strengths), the strength spread, the unripe share, the
yield and the bruise threshold enter the quadrature directly, with no sampling noise.  The efficiency's expectation is
exactly proportional to the yield per bush.
"""

from __future__ import annotations

import numpy as np

from berryshaker.config import Machine, machine_from_dict
from berryshaker.errors import ConfigError
from berryshaker.study.field_calibration.sheet import FactorTarget, setting_data


def parameter_rows(theta: np.ndarray):
    """:class:`~berryshaker.harvest.virtual.field_test.HarvestParameters` of parameter rows.

    Parameters
    ----------
    theta : numpy.ndarray
        (n, len(PARAMETERS)) values in :data:`~berryshaker.study.field_calibration.priors.PARAMETER_NAMES` order (SI).

    Returns
    -------
    HarvestParameters
        Each field an (n, 1) array.
    """
    from berryshaker.harvest.virtual import HarvestParameters
    from berryshaker.study.field_calibration.priors import PARAMETER_NAMES

    theta = np.atleast_2d(np.asarray(theta, float))
    return HarvestParameters(**{n: theta[:, i:i + 1] for i, n in enumerate(PARAMETER_NAMES)})


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
        self.machine = machine
        self.data = machine.model_dump(mode="json")
        self.targets = list(targets)
        self.settings: list[tuple[float, ...]] = []
        self.grids: dict[tuple[int, int], object] = {}  # (setting, start) -> LoadGrid
        self._envelopes: dict[tuple[int, int], list] = {}
        self._machines: dict[int, Machine] = {}
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

    def machine_at(self, s: int) -> Machine:
        """The machine description of setting ``s`` (drive speed set where a factor sets it; cached).

        Parameters
        ----------
        s : int
            Setting index.

        Returns
        -------
        Machine
            The description.
        """
        if s not in self._machines:
            self._machines[s] = machine_from_dict(setting_data(self.data, self.machine, self.targets,
                                                              self.settings[s])[0])
        return self._machines[s]

    def run(self, runner, settings: list[int], starts: list[int], label: str = "calibration runs") -> None:
        """Run (or read from the cache) the coupled starts ``starts`` at ``settings`` and keep their fruit's loads.

        Parameters
        ----------
        runner : SweepRunner
            The cached runner.
        settings : list of int
            Setting indexes.
        starts : list of int
            Start numbers (start k's drive-past carries class c from the spawn key (k, MACHINE, c)).
        label : str
            Progress label.
        """
        self.run_starts(runner, [(s, k) for s in settings for k in starts], label)

    def run_starts(self, runner, starts: list[tuple[int, int]], label: str = "calibration runs") -> None:
        """Run (or read from the cache) the coupled starts ``(setting, start number)`` and keep every start's
        quadrature nodes with their peak loads (one runner call: the starts run in parallel).

        Parameters
        ----------
        runner : SweepRunner
            The cached runner.
        starts : list of (int, int)
            Setting index and start number.
        label : str
            Progress label.

        Raises
        ------
        ConfigError
            A coupled start failed.
        """
        from berryshaker.harvest.virtual import load_grid
        from berryshaker.study.l9 import replicate_envelopes, replicate_jobs
        from berryshaker.study.runs import replicate_run

        todo = [t for t in dict.fromkeys(starts) if t not in self.grids]
        jobs: list = []
        spans: list = []
        for s in sorted({t[0] for t in todo}):
            d, cl = setting_data(self.data, self.machine, self.targets, self.settings[s])
            m = self.machine_at(s)
            mine = [k for s2, k in todo if s2 == s]
            j = replicate_jobs(m, cl, mine, data=d)
            spans.append((s, m, mine, len(jobs), len(jobs) + len(j)))
            jobs.extend(j)
        outs = runner.values(replicate_run, jobs, label) if jobs else []
        self.runs += len(jobs)
        for s, m, mine, a, _b in spans:
            for i, k in enumerate(mine):
                reps = replicate_envelopes(m, outs[a + i:a + i + 1], [k])
                if not reps:
                    raise ConfigError(f"calibrate: the coupled start {k} failed at setting {self.setting_text(s)}; "
                                      "see the runner's messages (a machine that does not run at a setting cannot be "
                                      "calibrated there)")
                self._envelopes[(s, k)] = reps[0][0]
                self.grids[(s, k)] = load_grid(m, reps[0][0])

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

    def responses(self, s: int, starts: list[int], theta: np.ndarray, names) -> tuple[np.ndarray, np.ndarray]:
        """The model's expectation and the counting variance of one field test at setting ``s`` for each start and
        every parameter row of ``theta`` (module docstring).

        Parameters
        ----------
        s : int
            Setting index.
        starts : list of int
            Start numbers (run before with :meth:`run`).
        theta : numpy.ndarray
            (n, len(PARAMETERS)) parameter values in :data:`~berryshaker.study.field_calibration.priors.PARAMETER_NAMES` order (SI).
        names : sequence of str
            Harvest responses (berryshaker.harvest.virtual.RESPONSES).

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)
            (n, starts, responses) expectations (the responses' units, kg/min and %; NaN where undefined) and
            counting variances (those units squared).
        """
        from berryshaker.harvest.virtual import expectation, response_values

        m = self.machine_at(s)
        p = parameter_rows(theta)
        n = p.ripe_pull.shape[0]
        mean = np.empty((n, len(starts), len(names)))
        var = np.empty_like(mean)
        for i, k in enumerate(starts):
            g = self.grids[(s, k)]
            tally, v = expectation(m, g, p, names)
            e = response_values(tally, names)
            for j, r in enumerate(names):
                mean[:, i, j] = np.broadcast_to(e[r], (n,))
                var[:, i, j] = np.broadcast_to(v[r], (n,))
        return mean, var

    def field_results(self, s: int, starts: list[int], values: dict[str, float], names, draw: int = 0) -> np.ndarray:
        """One counted field test per start at setting ``s`` and parameter values ``values``
        (:func:`~berryshaker.harvest.virtual.field_test.field_tally`): synthetic field results.

        Parameters
        ----------
        s : int
            Setting index.
        starts : list of int
            Start numbers (run before with :meth:`run`).
        values : dict of str to float
            Parameter values (SI) by name.
        names : sequence of str
            Harvest responses.
        draw : int
            Which field test of each machine start (:func:`~berryshaker.harvest.virtual.field_test.field_tally`).

        Returns
        -------
        numpy.ndarray
            (starts, responses) field results (the responses' units, kg/min and %; NaN where undefined).
        """
        from berryshaker.harvest.virtual import HarvestParameters, field_tally, response_values

        m = self.machine_at(s)
        p = HarvestParameters(**values)
        out = np.empty((len(starts), len(names)))
        for i, k in enumerate(starts):
            r = response_values(field_tally(m, self._envelopes[(s, k)], k, p, draw), names)
            out[i] = [r[n] for n in names]
        return out


def start_statistics(mean: np.ndarray, var: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Over the starts of :meth:`Simulator.responses`: the mean of the expectation, the model's start-to-start SD and
    the counting SD of one field test (RMS over the starts); undefined starts (nothing picked) left out, a response
    with no defined start 0.

    Parameters
    ----------
    mean : numpy.ndarray
        (n, starts, responses) expectations (their units).
    var : numpy.ndarray
        (n, starts, responses) counting variances (the units squared: (kg/min)^2, %^2).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray, numpy.ndarray)
        Means, model SDs and counting SDs, (n, responses), the responses' units (kg/min, %).
    """
    import warnings

    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a response with no finite start: handled below
        m = np.nanmean(mean, axis=1)
        sd = np.nanstd(mean, axis=1, ddof=1)
        csd = np.sqrt(np.nanmean(np.where(np.isfinite(mean), var, np.nan), axis=1))
    return np.nan_to_num(m, nan=0.0), np.nan_to_num(sd, nan=0.0), np.nan_to_num(csd, nan=0.0)


def training_starts(machine: Machine, replicates: int) -> list[int]:
    """The simulator's start numbers: the virtual L9's (0 .. R - 1 of the description's family; shared with the
    study's cache).

    Parameters
    ----------
    machine : Machine
        The description.
    replicates : int
        Starts.

    Returns
    -------
    list of int
        Start numbers.
    """
    from berryshaker.harvest.virtual import replicate_starts

    return replicate_starts(machine, replicates)


def fresh_starts(count: int, offset: int = 0) -> list[int]:
    """Start numbers the simulator's training never uses (from
    :data:`~berryshaker.harvest.virtual.seeds.FRESH_STARTS`): synthetic field results.

    Parameters
    ----------
    count : int
        Starts.
    offset : int
        First one (from the fresh range's start).

    Returns
    -------
    list of int
        Start numbers.
    """
    from berryshaker.harvest.virtual import FRESH_STARTS, start_numbers

    return start_numbers(count, FRESH_STARTS + offset)
