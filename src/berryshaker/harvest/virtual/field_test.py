"""One field test of the virtual harvest: the model's expectation and one counted field result (docs/harvest.md,
"Virtual field test").

long module: the expectation, the counting noise and the counted field result are one field test; they share the
parameters, the nodes and the reading of the tables at the parameters (strengths, Miner exponent, pedicel stiffness),
and split apart each would re-derive them.

A field test runs the machine for ``operation.test_duration`` T at the walking speed v: it passes B = v T / s bushes
(s the plant spacing; 3.33 on the reference machine: 10 s at 30 m/min, 1.5 m spacing), fractions included.  What it
weighs is a :class:`~berryshaker.harvest.virtual.responses.Tally` of those bushes' fruit.  For one start (the
stem-load tables of its branch classes, from its coupled drive-past) this module gives

* the **model's expectation** (:func:`expected_tally`): the large-sample mean, by quadrature over what a fruit can
  be -- branch class (equally likely), position z along the fruit zone (uniform), mass (lognormal, mean m0, CV
  ``fruit_mass_cv``; Gauss-Legendre nodes in every cell of the stem-load tables, :func:`load_grid`), ripe or unripe (mass fraction
  ``unripe_fraction``; an unripe fruit green, pink or red by ``unripe_stage_mix``, berryshaker.harvest.ripeness) -- of the probability that it comes off and that it bruises (:func:`node_probabilities`);
  no sampling noise;
* the **counting noise of one field test** about that expectation (:func:`expectation`): each bush its own yield,
  lognormal with mean ``yield_per_bush`` and CV ``bush_yield_cv``; its fruit a Poisson count of yield / mean mass on
  the covered part; every fruit picked or not, bruised or not (Bernoulli).  The tally's sums are then a Poisson
  mixture, Var(S) = E[N] E[g g'] + Var(lambda) E[g] E[g]' (g a fruit's contribution, lambda the covered fruit
  count's mean), and each response's variance is the delta method's J Var(S) J' (J its gradient in the sums;
  Cochran 1977, Sampling Techniques, sec. 6.3 for a ratio), so a rate's counting noise falls as 1 / (fruit picked);
* **one field result** (:func:`field_tally`): the test drawn fruit by fruit from the start's :data:`FIELD` stream --
  the test's start within the row uniform over one plant spacing, the bushes it covers with their fractions, each
  bush's yield, each fruit's class, position, mass, ripeness, strength factor, whether it comes off and whether it
  bruises.  Its spread over starts is a field test's test-to-test spread (the model's start-to-start spread plus
  the counting noise); :func:`expectation`'s variance is checked against it in the tests.

Detachment and bruising are those of :mod:`berryshaker.harvest.virtual.indexes`' models: ``bond_model`` "pull_shear"
(a fruit comes off when the Miner-Basquin equivalent g_eq = (sum_i g_i^beta)^(1/beta) of the pull-shear load ratios
of its class's mean strengths over the drive-past's load cycles, beta = ``miner_exponent`` (Miner 1945, Basquin
1910; berryshaker.plant.pedicel.miner), reaches its strength factor,
lognormal with mean 1 and CV ``bond_cv`` or its stage's: P = Phi((ln g + sigma^2/2) / sigma), mixed over the
unripe stages by their shares) or "study_eq17"
(the peak stem force against a bond uniform in the study's band); ``damage_model`` "impact" (berryshaker.harvest.
bruising) or "stem_acceleration" (1 - exp(-(a / a_d)^k)).

The quadrature's node counts are chosen by ``tests/harvest/test_field_test.py`` (every response within 1e-3 of its
value at twice the nodes).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy import special

from berryshaker.config import Machine
from berryshaker.harvest.virtual.responses import RESPONSES, Tally
from berryshaker.harvest.virtual.seeds import FIELD, stream
from berryshaker.harvest.virtual.stem_force_tables import (
    MASS_FACTORS,
    Z_GRID,
    _fruit_channels,
    along_branch,
    bond_strengths,
    fruit_load_channels,
    fruit_peak_force,
)

#: Gauss-Legendre nodes per stem-load table cell along the fruit zone and in log fruit mass of the expectation's
#: quadrature (chosen by tests/harvest/test_field_test.py: every response within 1e-4 relative of twice the nodes)
Z_NODES, MASS_NODES = 2, 2


@dataclass(frozen=True)
class HarvestParameters:
    """The harvest parameters a tally depends on beyond the stem-load tables (the ones ``calibrate`` learns); each a
    float or an array of shape (n, 1) (n parameter points, broadcast against the nodes).

    Attributes
    ----------
    ripe_pull, unripe_pull : float or numpy.ndarray
        Mean pull strength of ripe and unripe fruit (N); the shear strength scales with it.
    bond_cv : float or numpy.ndarray
        CV of a ripe fruit's strength factor (dimensionless).
    unripe_fraction : float or numpy.ndarray
        Unripe share of the fruit (dimensionless).
    yield_per_bush : float or numpy.ndarray
        Fruit mass on a bush at the pass (kg).
    bruise_height : float or numpy.ndarray
        Median bruise-threshold drop height of the described catching surface (m).
    miner_exponent : float or numpy.ndarray or None
        Basquin exponent beta of the cumulative detachment (dimensionless; berryshaker.plant.pedicel.miner; None:
        ``harvest.miner_exponent``).
    strike_probability : float or numpy.ndarray or None
        Share of the detached fruit a finger strikes (dimensionless; None: ``harvest.strike_probability``).
    pedicel_stiffness : float or numpy.ndarray or None
        Pedicel stiffness (N/m), its damping scaled with it (berryshaker.harvest.virtual.stem_force_tables: the tables
        read at another stiffness); None: ``plant.fruit.pedicel.stiffness``.  No effect on a rigid stem.
    """

    ripe_pull: float | np.ndarray
    unripe_pull: float | np.ndarray
    bond_cv: float | np.ndarray
    unripe_fraction: float | np.ndarray
    yield_per_bush: float | np.ndarray
    bruise_height: float | np.ndarray
    miner_exponent: float | np.ndarray | None = None
    strike_probability: float | np.ndarray | None = None
    pedicel_stiffness: float | np.ndarray | None = None

    @classmethod
    def described(cls, machine: Machine) -> "HarvestParameters":
        """The description's own values.

        Parameters
        ----------
        machine : Machine
            Machine description with a [harvest] block.

        Returns
        -------
        HarvestParameters
            ``harvest.ripe_pull`` ... (the median bruise height of ``harvest.catcher_surface``,
            berryshaker.harvest.bruising.catcher_median), ``harvest.miner_exponent``, ``harvest.strike_probability``,
            ``plant.fruit.pedicel.stiffness``.
        """
        from berryshaker.harvest.bruising import catcher_median

        h = machine.harvest
        return cls(h.ripe_pull, h.unripe_pull, h.bond_cv, h.unripe_fraction, h.yield_per_bush, catcher_median(h),
                   h.miner_exponent, h.strike_probability, machine.plant.fruit.pedicel.stiffness)


def stiffness_scale(machine: Machine, params: HarvestParameters | None) -> float | np.ndarray:
    """The pedicel stiffness of ``params`` over the description's, the scale at which the stem-load tables are read
    (berryshaker.harvest.virtual.stem_force_tables, module docstring).

    Parameters
    ----------
    machine : Machine
        Machine description with a [plant] block.
    params : HarvestParameters or None
        Parameter values (None, or no ``pedicel_stiffness``: the description's).

    Returns
    -------
    float or numpy.ndarray
        k / k_described (dimensionless; (n, 1) for n parameter rows); 1 for a rigid stem (eq. 16 has no stiffness).

    Raises
    ------
    ConfigError
        A scale outside 1 / STIFFNESS_RANGE .. STIFFNESS_RANGE, where the tables' mass axis ends.
    """
    from berryshaker.errors import ConfigError
    from berryshaker.harvest.virtual.stem_force_tables import STIFFNESS_RANGE

    ped = machine.plant.fruit.pedicel
    if params is None or params.pedicel_stiffness is None or ped.rigid:
        return 1.0
    a = np.asarray(params.pedicel_stiffness, float) / ped.stiffness
    if np.any(~((a >= (1 - 1e-9) / STIFFNESS_RANGE) & (a <= STIFFNESS_RANGE * (1 + 1e-9)))):
        raise ConfigError(f"pedicel_stiffness: {np.min(a) * ped.stiffness:.4g}-{np.max(a) * ped.stiffness:.4g} N/m "
                          f"lies outside {ped.stiffness / STIFFNESS_RANGE:.4g}-{ped.stiffness * STIFFNESS_RANGE:.4g} "
                          f"N/m, a factor {STIFFNESS_RANGE:g} about plant.fruit.pedicel.stiffness, where the "
                          "stem-load tables end; describe a pedicel stiffness nearer the one to be read")
    return float(a) if a.ndim == 0 else a


@dataclass(frozen=True)
class LoadGrid:
    """The quadrature nodes of one start's fruit (branch class x position x mass, flattened) with each node's peak
    loads from the start's stem-load tables.

    Attributes
    ----------
    weight : numpy.ndarray
        Probability of each node (sums to 1; dimensionless).
    z : numpy.ndarray
        Position along the branch (fraction of its length).
    mass : numpy.ndarray
        Fruit mass (kg).
    load_ripe, load_unripe : numpy.ndarray
        Equivalent pull-shear load ratio of a ripe / an unripe fruit there at the described mean strengths and Miner
        exponent (dimensionless).
    force : numpy.ndarray
        Peak stem-force magnitude (N).
    channels_ripe, channels_unripe : numpy.ndarray or None
        The peak and the equivalent load ratios at berryshaker.plant.pedicel.MINER_EXPONENTS of a ripe / an unripe
        fruit there ((1 + n_k, nodes), dimensionless; :func:`~berryshaker.harvest.virtual.stem_force_tables.
        fruit_load_channels`), read at any exponent by :meth:`loads`; None: ``load_ripe`` / ``load_unripe`` at
        every exponent.
    tables : NodeTables or None
        The start's tables at the nodes' positions, to read them at another pedicel stiffness (:meth:`loads`,
        :meth:`forces`); None: at the described stiffness only.
    exponent : float
        The Miner exponent of ``load_ripe`` and ``load_unripe`` (dimensionless).
    """

    weight: np.ndarray
    z: np.ndarray
    mass: np.ndarray
    load_ripe: np.ndarray
    load_unripe: np.ndarray
    force: np.ndarray
    channels_ripe: np.ndarray | None = None
    channels_unripe: np.ndarray | None = None
    tables: "NodeTables | None" = None
    exponent: float = math.inf

    def loads(self, exponent, stiffness_scale=1.0) -> tuple[np.ndarray, np.ndarray]:
        """Equivalent load ratios of a ripe and an unripe fruit at each node at Miner exponent ``exponent`` and
        pedicel stiffness scale ``stiffness_scale``.

        Parameters
        ----------
        exponent : float or numpy.ndarray or None
            Basquin exponent beta (dimensionless; (n, 1) gives n rows; None: the grid's own).
        stiffness_scale : float or numpy.ndarray
            Pedicel stiffness over the description's (dimensionless; (n, 1) gives n rows;
            :func:`stiffness_scale`).

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)
            Ripe and unripe load ratios ((nodes,) or (n, nodes); dimensionless).

        Raises
        ------
        ConfigError
            A stiffness scale other than 1 on a grid without :attr:`tables`.
        """
        from berryshaker.plant.pedicel import miner_load

        a = np.asarray(stiffness_scale, float)
        if np.all(a == 1.0):
            if exponent is None or self.channels_ripe is None or self.channels_unripe is None:
                return self.load_ripe, self.load_unripe
            return miner_load(self.channels_ripe, exponent), miner_load(self.channels_unripe, exponent)
        beta = np.asarray(self.exponent if exponent is None else exponent, float)
        if a.size == 1:
            cr, cu, _ = self._tables().read(float(a.reshape(-1)[0]))
            return miner_load(cr, beta), miner_load(cu, beta)
        rows = [self._tables().read(float(ar)) for ar in a.reshape(-1)]  # one reading per parameter row
        b = np.broadcast_to(beta.reshape(-1), (len(rows),))
        return (np.array([miner_load(r[0], float(bi)) for r, bi in zip(rows, b)]),
                np.array([miner_load(r[1], float(bi)) for r, bi in zip(rows, b)]))

    def forces(self, stiffness_scale=1.0) -> np.ndarray:
        """Peak stem-force magnitude (N) at each node at pedicel stiffness scale ``stiffness_scale``.

        Parameters
        ----------
        stiffness_scale : float or numpy.ndarray
            Pedicel stiffness over the description's (dimensionless; (n, 1) gives n rows).

        Returns
        -------
        numpy.ndarray
            (nodes,) or (n, nodes) forces (N).
        """
        a = np.asarray(stiffness_scale, float)
        if np.all(a == 1.0):
            return self.force
        out = np.array([self._tables().read(float(ar))[2][0] for ar in a.reshape(-1)])
        return out[0] if a.ndim == 0 else out

    def _tables(self) -> "NodeTables":
        from berryshaker.errors import ConfigError

        if self.tables is None:
            raise ConfigError("these stem-load tables cannot be read at another pedicel stiffness (not tables of "
                              "peak stem loads over position and fruit mass); leave pedicel_stiffness at the "
                              "description's")
        return self.tables


@dataclass(frozen=True)
class NodeTables:
    """One start's stem-load tables interpolated to its quadrature nodes' positions, still over the tables' mass
    axis, so they are read at any pedicel stiffness scale a by the interpolation in log mass alone
    (berryshaker.harvest.virtual.stem_force_tables, module docstring: a x the table at mass / a).

    Attributes
    ----------
    columns : numpy.ndarray
        (channels, classes, z nodes, len(MASS_FACTORS)) table values at the nodes' positions (N for the force
        channel, dimensionless load ratios).
    mass_factor : numpy.ndarray
        (mass nodes,) node mass over m0 (dimensionless).
    ripe, unripe, force : numpy.ndarray of int
        The channels of the ripe and the unripe fruit's load ratios (:func:`~berryshaker.harvest.virtual.
        stem_force_tables.miner_channels`, or the peak alone) and of the peak force.
    """

    columns: np.ndarray
    mass_factor: np.ndarray
    ripe: np.ndarray
    unripe: np.ndarray
    force: np.ndarray

    def read(self, scale: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The ripe and the unripe load channels and the peak force at every node, at stiffness scale ``scale``.

        Parameters
        ----------
        scale : float
            Pedicel stiffness over the tables' (dimensionless).

        Returns
        -------
        (numpy.ndarray, numpy.ndarray, numpy.ndarray)
            (len(ripe), nodes), (len(unripe), nodes) load ratios (dimensionless) and (1, nodes) forces (N), nodes in
            the order class, position, mass.
        """
        from berryshaker.harvest.virtual.stem_force_tables import mass_weights

        j, w = mass_weights(self.mass_factor / scale)
        c = self.columns
        v = scale * ((1 - w) * c[..., j] + w * c[..., j + 1])  # (channels, classes, z nodes, mass nodes)
        v = v.reshape(c.shape[0], -1)
        return v[self.ripe], v[self.unripe], v[self.force]


def _piecewise_gauss(edges: np.ndarray, per_cell: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights, ``per_cell`` in each interval between consecutive ``edges``."""
    x, w = np.polynomial.legendre.leggauss(int(per_cell))
    lo, hi = edges[:-1, None], edges[1:, None]
    return (0.5 * (lo + hi) + 0.5 * (hi - lo) * x).ravel(), (0.5 * (hi - lo) * w).ravel()


def load_grid(machine: Machine, envelopes: list, z_per_cell: int = Z_NODES, mass_per_cell: int = MASS_NODES
              ) -> LoadGrid:
    """Quadrature nodes of the fruit of one start and their peak loads (module docstring).

    The tables are linear between their grid lines (:data:`~berryshaker.harvest.virtual.stem_force_tables.Z_GRID`
    in z, :data:`~berryshaker.harvest.virtual.stem_force_tables.MASS_FACTORS` in log mass), so the nodes are
    Gauss-Legendre within each cell of the fruit zone and of the log-mass normal (out to 8 standard deviations),
    weighted by the uniform and the normal density: the integrand is smooth inside a cell.

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    envelopes : list of numpy.ndarray
        One stem-load table per branch class
        (:func:`~berryshaker.harvest.virtual.stem_force_tables.stem_force_table`; N, dimensionless load ratios).
    z_per_cell, mass_per_cell : int
        Gauss-Legendre nodes per table cell in z and in log mass.

    Returns
    -------
    LoadGrid
        One node per branch class, position and mass.
    """
    h = machine.harvest
    m0 = machine.plant.fruit.mass
    a, b = h.fruit_zone
    ze = np.unique(np.concatenate([[a, b], Z_GRID[(Z_GRID > a) & (Z_GRID < b)]]))
    z, wz = _piecewise_gauss(ze, z_per_cell)
    wz = wz / (b - a) if b > a else np.full(1, 1.0)
    z = z if b > a else np.full(1, a)
    sigma = math.sqrt(math.log1p(h.fruit_mass_cv**2))
    if sigma > 0:  # ln m = ln m0 - sigma^2 / 2 + sigma x, x standard normal; cells at the table's mass factors
        xb = (np.log(MASS_FACTORS) + 0.5 * sigma**2) / sigma
        xe = np.unique(np.clip(np.concatenate([[-8.0, 8.0], xb]), -8.0, 8.0))
        xm, wm = _piecewise_gauss(xe, mass_per_cell)
        wm = wm * np.exp(-0.5 * xm * xm) / math.sqrt(2 * math.pi)
        wm = wm / wm.sum()
        mass = m0 * np.exp(-0.5 * sigma**2 + sigma * xm)
    else:
        mass, wm = np.full(1, m0), np.ones(1)
    zz, mm = np.meshgrid(z, mass, indexing="ij")
    ww = np.outer(wz, wm)
    zz, mm, ww = zz.ravel(), mm.ravel(), ww.ravel()
    from berryshaker.plant.pedicel import miner_load

    nc = len(envelopes)
    envs = [np.asarray(env, float) for env in envelopes]
    beta = machine.harvest.miner_exponent
    if all(e.ndim == 3 and e.shape == envs[0].shape for e in envs):  # tables over position x mass x channels
        tables = NodeTables(np.stack([along_branch(e, z) for e in envs]).transpose(3, 0, 1, 2),  # (c, class, z, m)
            mass / m0, *(np.asarray(x) for x in _table_channels(envs[0].shape[-1])))
        cr, cu, force = tables.read(1.0)
        force = force[0]
    else:  # an acceleration envelope or a force table: read at the nodes, no other stiffness
        st = bond_strengths(machine)
        tables = None
        parts = [(fruit_load_channels(e, zz, mm, m0, True, st), fruit_load_channels(e, zz, mm, m0, False, st),
                  fruit_peak_force(e, zz, mm, m0)) for e in envs]
        cr, cu, force = (np.concatenate([p[i] for p in parts], axis=-1) for i in range(3))
    both = miner_load(np.concatenate([cr, cu], axis=1), beta) if cr.shape[0] == cu.shape[0] else None  # per node
    lr, lu = (both[:cr.shape[1]], both[cr.shape[1]:]) if both is not None else (miner_load(cr, beta),
                                                                                miner_load(cu, beta))
    return LoadGrid(np.tile(ww, nc) / nc, np.tile(zz, nc), np.tile(mm, nc), lr, lu, force, cr, cu, tables, float(beta))


def _table_channels(n_channels: int) -> tuple[list, list, list]:
    """The ripe and the unripe load channels and the force channel of a table with ``n_channels`` channels."""
    from berryshaker.harvest.virtual.stem_force_tables import CH_FORCE, CH_RIPE, CH_UNRIPE, miner_channels

    if n_channels > 3:
        return list(miner_channels(True)), list(miner_channels(False)), [CH_FORCE]
    return [CH_RIPE], [CH_UNRIPE], [CH_FORCE]


def _p_below(x, cv):
    """P(s <= x) for s lognormal with mean 1 and CV cv (cv = 0: a step at 1)."""
    cv = np.asarray(cv, float)
    sig = np.sqrt(np.log1p(cv * cv))
    with np.errstate(divide="ignore", invalid="ignore"):
        p = special.ndtr((np.log(np.maximum(x, 1e-300)) + 0.5 * sig**2) / np.where(sig > 0, sig, 1.0))
    return np.where(sig > 0, p, (np.asarray(x) >= 1.0).astype(float))


def node_probabilities(machine: Machine, grid: LoadGrid, params: HarvestParameters | None = None):
    """Probability that a ripe and an unripe fruit at each node comes off, and that a detached fruit there bruises.

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest] (the models, the catching surface, the finger speed).
    grid : LoadGrid
        The start's nodes.
    params : HarvestParameters, optional
        Parameter values (default the description's); arrays of shape (n, 1) give n rows.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray, numpy.ndarray)
        P(off | ripe), P(off | unripe), P(bruised | off) per node (shape (nodes,) or (n, nodes); dimensionless).
    """
    from berryshaker.harvest.bruising import impact_damage
    from berryshaker.harvest.ripeness import unripe_stage_strengths
    from berryshaker.reference_study import RIPE_BOND_N, UNRIPE_BOND_N

    h = machine.harvest
    p = params or HarvestParameters.described(machine)
    a = stiffness_scale(machine, p)
    if h.bond_model == "pull_shear":
        load_r, load_u = grid.loads(p.miner_exponent, a)
        off_r = _p_below(load_r * (h.ripe_pull / np.asarray(p.ripe_pull, float)), p.bond_cv)
        off_u = sum(c * _p_below(load_u * f, cv) for c, f, cv in  # green, pink, red by their shares
                    unripe_stage_strengths(h, p.ripe_pull, p.unripe_pull, p.bond_cv))
    else:  # the study's eq. 17: the peak stem force against a bond uniform in the class's band
        force = grid.forces(a)
        off_r = np.clip((force - RIPE_BOND_N[0]) / (RIPE_BOND_N[1] - RIPE_BOND_N[0]), 0.0, 1.0)
        off_u = np.clip((force - UNRIPE_BOND_N[0]) / (UNRIPE_BOND_N[1] - UNRIPE_BOND_N[0]), 0.0, 1.0)
    if h.damage_model == "impact":
        q = impact_damage(machine, grid.z, p.bruise_height, p.strike_probability)
    else:
        q = 1.0 - np.exp(-((grid.forces(a) / grid.mass) / h.damage_acceleration) ** h.damage_shape)
    shape = np.broadcast_shapes(np.shape(off_r), np.shape(off_u), np.shape(q))
    return tuple(np.broadcast_to(x, shape) for x in (off_r, off_u, q))


def bushes_per_test(machine: Machine) -> float:
    """Bushes one field test passes: walking speed x test duration / plant spacing (fractions included).

    Parameters
    ----------
    machine : Machine
        Machine description ([operation]).

    Returns
    -------
    float
        B (dimensionless; 3.33 on the reference machine).
    """
    op = machine.operation
    return op.walking_speed * op.test_duration / op.plant_spacing


def covered_fractions(bushes: float, offset: float) -> np.ndarray:
    """Fractions of the bushes a stretch of ``bushes`` plant spacings covers when it starts ``offset`` spacings into
    the first.

    Parameters
    ----------
    bushes : float
        Length of the stretch in plant spacings (> 0; dimensionless).
    offset : float
        Where it starts within the first bush's spacing, in [0, 1) (dimensionless).

    Returns
    -------
    numpy.ndarray
        Covered fraction of each bush touched (each in (0, 1], summing to ``bushes``).
    """
    edges = np.arange(0, math.ceil(offset + bushes) + 1, dtype=float)
    lo = np.maximum(edges[:-1], offset)
    hi = np.minimum(edges[1:], offset + bushes)
    f = hi - lo
    return f[f > 1e-12]


@functools.lru_cache(maxsize=64)
def _mean_square_fraction(bushes: float, points: int = 2000) -> float:
    """E over a uniform start offset of the sum of squared covered fractions (midpoint rule)."""
    u = (np.arange(points) + 0.5) / points
    return float(np.mean([np.sum(covered_fractions(bushes, x) ** 2) for x in u]))


def _row(x):
    """A parameter as one value per parameter point: (n, 1) -> (n,), a scalar unchanged."""
    x = np.asarray(x, float)
    return x[..., 0] if x.ndim >= 2 else x


def _moments(machine: Machine, grid: LoadGrid, params: HarvestParameters):
    """Per fruit: E[g] (..., 5) and E[g g'] (..., 5, 5) of its contribution g to the tally's masses (kg, kg^2), and the
    mean fruit mass (kg)."""
    off_r, off_u, q = node_probabilities(machine, grid, params)
    uf = _row(params.unripe_fraction)
    w, m = grid.weight, grid.mass
    wm, wm2 = w * m, w * m * m
    pr, pu = 1.0 - uf, uf
    s = lambda x, ww: np.sum(ww * x, axis=-1)  # noqa: E731
    one = np.ones_like(off_r)
    # g = m (r, 1 - r, r o, (1 - r) o, o d): means
    eg = np.stack([pr * s(one, wm), pu * s(one, wm), pr * s(off_r, wm), pu * s(off_u, wm),
                   pr * s(off_r * q, wm) + pu * s(off_u * q, wm)], axis=-1)
    # second moments (r, o, d indicators: r^2 = r, r (1 - r) = 0, o^2 = o, d^2 = d)
    shape = eg.shape[:-1] + (5, 5)
    egg = np.zeros(shape)
    rr = [(0, 0, pr, one), (0, 2, pr, off_r), (0, 4, pr, off_r * q), (2, 2, pr, off_r), (2, 4, pr, off_r * q),
          (1, 1, pu, one), (1, 3, pu, off_u), (1, 4, pu, off_u * q), (3, 3, pu, off_u), (3, 4, pu, off_u * q)]
    for i, j, pi, x in rr:
        v = pi * s(x, wm2)
        egg[..., i, j] += v
        if i != j:
            egg[..., j, i] += v
    egg[..., 4, 4] = pr * s(off_r * q, wm2) + pu * s(off_u * q, wm2)  # both ripeness classes
    return eg, egg, float(np.sum(wm))


def expected_tally(machine: Machine, grid: LoadGrid, params: HarvestParameters | None = None) -> Tally:
    """The model's expectation of one field test's tally at this start (module docstring).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant], [harvest] and [operation].
    grid : LoadGrid
        The start's nodes (:func:`load_grid`).
    params : HarvestParameters, optional
        Parameter values (default the description's).

    Returns
    -------
    Tally
        Expected masses (kg) of the B bushes a test passes and the test's duration (s).
    """
    p = params or HarvestParameters.described(machine)
    return _expected(machine, _moments(machine, grid, p), p)


def _expected(machine: Machine, moments, p: HarvestParameters) -> Tally:
    s = moments[0] * np.asarray(bushes_per_test(machine) * _row(p.yield_per_bush) / moments[2])[..., None]
    return Tally(*(s[..., i] for i in range(5)), np.broadcast_to(machine.operation.test_duration, s.shape[:-1]) * 1.0)


def expectation(machine: Machine, grid: LoadGrid, params: HarvestParameters | None = None,
                names=None) -> tuple[Tally, dict]:
    """The model's expectation of one field test's tally (:func:`expected_tally`) and the variance of each response
    of one field test about it: the counting noise (module docstring: Poisson mixture of the covered bushes' fruit,
    delta method), from one evaluation of the nodes' probabilities.

    Parameters
    ----------
    machine : Machine
        Machine description with [plant], [harvest] and [operation].
    grid : LoadGrid
        The start's nodes.
    params : HarvestParameters, optional
        Parameter values (default the description's).
    names : iterable of str, optional
        Responses of the variances (default every one of :data:`~berryshaker.harvest.virtual.responses.RESPONSES`).

    Returns
    -------
    (Tally, dict)
        The expected tally (kg, s) and name -> counting variance (the response's unit squared).
    """
    p = params or HarvestParameters.described(machine)
    moments = _moments(machine, grid, p)
    return _expected(machine, moments, p), _count_variance(machine, moments, p, names)


def _count_variance(machine: Machine, moments, p: HarvestParameters, names) -> dict:
    eg, egg, m_mean = moments
    bushes = bushes_per_test(machine)
    yb = _row(p.yield_per_bush)
    lam = bushes * yb / m_mean
    var_lam = (machine.harvest.bush_yield_cv * yb / m_mean) ** 2 * _mean_square_fraction(bushes)
    lam, var_lam = np.asarray(lam)[..., None, None], np.asarray(var_lam)[..., None, None]
    cov = lam * egg + var_lam * eg[..., :, None] * eg[..., None, :]
    mean = eg * lam[..., 0]
    dur = machine.operation.test_duration
    out = {}
    for n in (RESPONSES if names is None else names):
        f = RESPONSES[n].value
        grad = []
        for j in range(5):
            step = 1e-6 * np.maximum(np.abs(mean[..., j]), 1e-12)
            up, dn = mean.copy(), mean.copy()
            up[..., j] += step
            dn[..., j] -= step
            tu, td = (Tally(*(x[..., i] for i in range(5)), dur) for x in (up, dn))
            grad.append((np.asarray(f(tu), float) - np.asarray(f(td), float)) / (2 * step))
        jac = np.stack(grad, axis=-1)
        v = np.einsum("...i,...ij,...j->...", jac, cov, jac)
        out[n] = float(v) if np.ndim(v) == 0 else v
    return out


def field_tally(machine: Machine, envelopes: list, start: int, params: HarvestParameters | None = None,
                draw: int = 0) -> Tally:
    """One field test drawn fruit by fruit from start ``start``'s :data:`~berryshaker.harvest.virtual.seeds.FIELD`
    stream (module docstring).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant], [harvest] and [operation].
    envelopes : list of numpy.ndarray
        The start's stem-load table per branch class (N, dimensionless load ratios).
    start : int
        Start number k (its stream of the description's seed family).
    params : HarvestParameters, optional
        Parameter values (scalars; default the description's).
    draw : int
        Which field test of that machine start (0: the start's own; others: further bushes behind the same drive-past,
        spawn key (start, FIELD, draw)).

    Returns
    -------
    Tally
        Counted masses (kg) and the test's duration (s).
    """
    from berryshaker.harvest.ripeness import unripe_stage_strengths
    from berryshaker.reference_study import RIPE_BOND_N, UNRIPE_BOND_N

    h = machine.harvest
    p = params or HarvestParameters.described(machine)
    rng = stream(h.seed, start, FIELD, *((draw,) if draw else ()))
    m0 = machine.plant.fruit.mass
    frac = covered_fractions(bushes_per_test(machine), rng.random())
    cvb = h.bush_yield_cv
    sb = math.sqrt(math.log1p(cvb * cvb))
    bush_yield = float(p.yield_per_bush) * np.exp(-0.5 * sb * sb + sb * rng.standard_normal(frac.size))
    n = int(np.sum(rng.poisson(frac * bush_yield / m0)))
    sm = math.sqrt(math.log1p(h.fruit_mass_cv**2))
    mass = m0 * np.exp(-0.5 * sm * sm + sm * rng.standard_normal(n))
    ripe = rng.random(n) >= float(p.unripe_fraction)
    z = rng.uniform(*h.fruit_zone, n)
    cls = rng.integers(0, len(envelopes), n)
    u_strength = rng.standard_normal(n)
    u_bond = rng.random(n)
    u_bruise = rng.random(n)
    st = bond_strengths(machine)
    a = float(stiffness_scale(machine, p))
    from berryshaker.plant.pedicel import miner_load

    beta = h.miner_exponent if p.miner_exponent is None else float(p.miner_exponent)
    load, force, chans = np.zeros(n), np.zeros(n), []
    for c, env in enumerate(envelopes):
        sel = cls == c
        e = np.asarray(env, float)
        chans.append((sel, _fruit_channels(e, z[sel], mass[sel], m0, ripe[sel], st, a)))
        force[sel] = fruit_peak_force(e, z[sel], mass[sel], m0, a)
    if len({ch.shape[0] for _, ch in chans}) == 1:  # every class's fruit in one Miner reading (it is per fruit)
        every = np.zeros((chans[0][1].shape[0], n))
        for sel, ch in chans:
            every[:, sel] = ch
        load = miner_load(every, beta)
    else:
        for sel, ch in chans:
            load[sel] = miner_load(ch, beta)
    u_stage = rng.random(n)  # drawn last: the earlier draws are those of a model without stages
    if h.bond_model == "pull_shear":
        stages = unripe_stage_strengths(h, float(p.ripe_pull), float(p.unripe_pull), float(p.bond_cv))
        edges = np.cumsum([c for c, _, _ in stages])
        k = np.minimum(np.searchsorted(edges, u_stage, side="right"), len(stages) - 1)  # green, pink, red
        f_u = np.array([float(f) for _, f, _ in stages])[k]
        cv_u = np.array([float(cv) for _, _, cv in stages])[k]
        load = load * np.where(ripe, h.ripe_pull / float(p.ripe_pull), f_u)
        cv = np.where(ripe, float(p.bond_cv), cv_u)
        sig = np.sqrt(np.log1p(cv * cv))
        off = load >= np.exp(-0.5 * sig * sig + sig * u_strength)
    else:
        lo = np.where(ripe, RIPE_BOND_N[0], UNRIPE_BOND_N[0])
        hi = np.where(ripe, RIPE_BOND_N[1], UNRIPE_BOND_N[1])
        off = force >= lo + u_bond * (hi - lo)
    # the loads above are read at the pedicel's stiffness already
    q = node_probabilities(machine, LoadGrid(np.ones(n), z, mass, load, load, force),
                           dataclasses.replace(p, pedicel_stiffness=None))[2]
    bruised = off & (u_bruise < q)
    tot = lambda sel: float(np.sum(mass[sel]))  # noqa: E731
    return Tally(tot(ripe), tot(~ripe), tot(off & ripe), tot(off & ~ripe), tot(bruised),
                 float(machine.operation.test_duration))

