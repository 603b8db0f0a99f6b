"""The calibrated harvest parameters and their priors (docs/calibration.md "Priors"), the field responses they are
calibrated against, and the prior's unit cube the emulator and the sampler work on.

The parameters (:data:`PARAMETERS`) act only in the post-processing of the coupled runs' stem-load tables -- ripe
and unripe mean pull strength (the shear strength scales with it at the described shear/pull ratio), the ripe
strengths' CV, the unripe mass fraction, the yield per bush, the bruise-threshold height of the described
catching surface, the Miner exponent of the cumulative detachment (the tables carry the equivalent load ratios at
exponents 3-30, berryshaker.plant.pedicel.miner), the share of the detached fruit a finger strikes and the pedicel
stiffness (a table at stiffness a k is a times the table at mass m / a, its damping scaled with it:
berryshaker.harvest.virtual.stem_force_tables) -- each with a prior from the cited ranges (docs/harvest.md,
``harvest/published/record.toml``) or, where nothing is published, bounds of our choice.

A point of the unit cube holds each parameter's prior probability: :func:`theta_of` and :func:`unit_of` map between
it and the values (SI), :func:`latin_hypercube` draws the emulator's training points on it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import special

from berryshaker.config import Machine

Z90 = 1.6448536269514722  # standard normal 95th percentile: a lognormal's central 90 % is median exp(+-Z90 s)


@dataclass(frozen=True)
class Parameter:
    """One calibrated harvest parameter and its prior.

    Attributes
    ----------
    name : str
        Name (the ``harvest`` key it sets; ``bruise_height`` sets the described catching surface's median
        threshold, berryshaker.harvest.bruising.catcher_median).
    unit : str
        SI unit of its values ("" for a fraction).
    distribution : str
        "lognormal" (``lo``, ``hi`` its central 90 %), "uniform" or "loguniform" (``lo``, ``hi`` its bounds).
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
        if self.distribution == "loguniform":
            return np.exp(math.log(self.lo) + u * math.log(self.hi / self.lo))
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
        what = "central 90 %" if self.distribution == "lognormal" else "bounds"  # uniform, loguniform
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
    Parameter("bruise_height", "m", "lognormal", 0.97, 3.90,
              "median bruise height of a padded catcher: Brown et al. 1996's cushioning prevented bruising for drops "
              "up to 0.6-1.2 m, safe heights read as the 5 % fractile at CV 0.3 (median x 1.62: 0.97-1.95 m); the "
              "central 90 % from the smaller's median to twice the larger's is our choice; a hard catcher: "
              "0.075-0.30 m about Brown's 0.15 m", "[published lower end; fractile and upper end assumed]"),
    Parameter("miner_exponent", "", "loguniform", 3.0, 30.0,
              "Basquin exponent of the cumulative detachment (Basquin 1910, Miner 1945; docs/harvest.md 'Bond'): "
              "described 8 [assumed]; no blueberry pedicel fatigue exponent is published; the bounds are our choice, "
              "from a steep law (8 cycles at half the strength break a fruit) to nearly the peak-only law", "[assumed]"),
    Parameter("strike_probability", "", "uniform", 0.1, 0.9,
              "share of the detached fruit a comb finger strikes (docs/harvest.md 'Bruising'): described 0.5 "
              "[assumed]; the bounds are our choice", "[assumed]"),
    Parameter("pedicel_stiffness", "N/m", "loguniform", 4.0, 25.0,
              "no blueberry fruit-stem stiffness is published; the coffee fruit-stem system of the same fruit size "
              "measured 7.1-8.6 N/m (Villibor et al. 2016), described 10 N/m [assumed, by analogy]; bounds a factor "
              "2.5 either way of the described stiffness (7.5-18.8 Hz at 1.8 g), where the stem-load tables end; "
              "damping scaled with it", "[assumed]"),
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
        :data:`PARAMETERS`, the hard-surface bruise prior when ``harvest.catcher_surface = "hard"``, the pedicel
        stiffness's bounds a factor STIFFNESS_RANGE about ``plant.fruit.pedicel.stiffness``.
    """
    from dataclasses import replace

    from berryshaker.harvest.virtual import STIFFNESS_RANGE

    k = machine.plant.fruit.pedicel.stiffness if machine.plant is not None else 10.0
    out = []
    for p in PARAMETERS:
        if p.name == "bruise_height" and machine.harvest.catcher_surface == "hard":
            p = HARD_BRUISE
        elif p.name == "pedicel_stiffness" and k != 10.0:  # a factor STIFFNESS_RANGE about the described stiffness
            p = replace(p, lo=k / STIFFNESS_RANGE, hi=k * STIFFNESS_RANGE,
                        source=f"a factor {STIFFNESS_RANGE:g} either way of the described {k:.4g} N/m, where the "
                               "stem-load tables end; damping scaled with it")
        out.append(p)
    return tuple(out)


def described_values(machine: Machine) -> dict[str, float]:
    """The description's own value of every calibrated parameter (SI).

    Parameters
    ----------
    machine : Machine
        Machine description with a [harvest] block.

    Returns
    -------
    dict of str to float
        Name -> value (N, fractions, kg, m, the dimensionless Miner exponent, N/m).
    """
    from berryshaker.harvest.bruising import catcher_median

    h = machine.harvest
    bruise = catcher_median(h)
    return {"ripe_pull": h.ripe_pull, "unripe_pull": h.unripe_pull, "bond_cv": h.bond_cv,
            "unripe_fraction": h.unripe_fraction, "yield_per_bush": h.yield_per_bush, "bruise_height": bruise,
            "miner_exponent": h.miner_exponent, "strike_probability": h.strike_probability,
            "pedicel_stiffness": machine.plant.fruit.pedicel.stiffness if machine.plant is not None else 10.0}


def prior_rows(machine: Machine | None = None) -> list[dict]:
    """The priors as rows (``config show``, the report): name, harvest key, unit, prior, 90 % interval, source, tag.

    Parameters
    ----------
    machine : Machine, optional
        Its catching surface picks the bruise prior (default: padded).

    Returns
    -------
    list of dict
        One row per parameter: ``name``, ``key`` (the description key it sets), ``unit``, ``prior`` (text),
        ``lo90``, ``hi90`` (SI), ``source``, ``tag``.
    """
    params = parameters_for(machine) if machine is not None else PARAMETERS
    hard = machine is not None and machine.harvest.catcher_surface == "hard"
    keys = {"bruise_height": ("harvest.median bruise height of extensive_drop_height_hard" if hard else
                              "harvest.median bruise height of safe_drop_height_padded"),
            "pedicel_stiffness": "plant.fruit.pedicel.stiffness (damping scaled with it)"}
    return [{"name": p.name, "key": keys.get(p.name, f"harvest.{p.name}"), "unit": p.unit, "prior": p.describe(),
             "lo90": p.interval90()[0], "hi90": p.interval90()[1], "source": p.source, "tag": p.tag} for p in params]


def calibrated_responses() -> dict:
    """The responses of a field sheet the calibration uses: the rows of the harvest-response table marked
    ``calibrated`` (berryshaker.harvest.virtual.RESPONSES: unit, floor c of the emulated log(mean + c)).

    Returns
    -------
    dict of str to HarvestResponse
        Name -> row, in the table's order.
    """
    from berryshaker.harvest.virtual import RESPONSES

    return {n: r for n, r in RESPONSES.items() if r.calibrated}


#: parameters the mean and the model's spread of a response depend on (besides the setting); the yield scales the
#: efficiency exactly and is not emulated there; the bruise threshold and the finger's strike share change only the
#: damage.  A response not listed
#: depends on every parameter but the yield.  The counting noise of a field test depends on the yield too
#: (:func:`count_parameters`).
RESPONSE_PARAMETERS = {"efficiency": ("ripe_pull", "unripe_pull", "bond_cv", "unripe_fraction", "miner_exponent",
                                      "pedicel_stiffness"),
                       "unripe": ("ripe_pull", "unripe_pull", "bond_cv", "unripe_fraction", "miner_exponent",
                                  "pedicel_stiffness"),
                       "damage": ("ripe_pull", "unripe_pull", "bond_cv", "unripe_fraction", "bruise_height",
                                  "miner_exponent", "strike_probability", "pedicel_stiffness")}


def mean_parameters(response: str) -> tuple[str, ...]:
    """The parameters the mean and the model's spread of ``response`` depend on (:data:`RESPONSE_PARAMETERS`).

    Parameters
    ----------
    response : str
        Response name.

    Returns
    -------
    tuple of str
        Parameter names.
    """
    return RESPONSE_PARAMETERS.get(response, tuple(n for n in PARAMETER_NAMES if n != "yield_per_bush"))


def count_parameters(response: str) -> tuple[str, ...]:
    """The parameters the counting noise of one field test of ``response`` depends on: the mean's and the yield
    (more fruit per test, a smaller relative counting noise).

    Parameters
    ----------
    response : str
        Response name.

    Returns
    -------
    tuple of str
        Parameter names.
    """
    return (*mean_parameters(response), "yield_per_bush")


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
        (n, len(PARAMETERS)) prior probabilities (dimensionless).
    params : tuple of Parameter
        The parameters (:func:`parameters_for`).

    Returns
    -------
    numpy.ndarray
        (n, len(PARAMETERS)) values (SI).
    """
    u = np.atleast_2d(u)
    return np.column_stack([p.ppf(u[:, i]) for i, p in enumerate(params)])


def unit_of(theta: np.ndarray, params: tuple[Parameter, ...]) -> np.ndarray:
    """Prior probabilities (unit cube) of parameter values (SI): the inverse of :func:`theta_of`.

    Parameters
    ----------
    theta : numpy.ndarray
        (n, len(PARAMETERS)) values (SI).
    params : tuple of Parameter
        The parameters.

    Returns
    -------
    numpy.ndarray
        (n, len(PARAMETERS)) prior probabilities (values outside a uniform prior's bounds are clipped to it).
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
