"""The branch side of the rigid-flexible coupling (berryshaker.harvest.coupled): the modal bodies a coupled run
integrates (the instrumented fruit branch, with its fruit on stems when they are two-way coupled, and the reached
members of the bush population) and the branch motion read back from a run (:class:`BranchMotion`: lateral motion,
axial foreshortening) with the stem forces of fruit on compliant pedicels driven by it.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from berryshaker.config import Machine
from berryshaker.multibody import layout as mb
from berryshaker.multibody.engine import MultibodyResult
from berryshaker.plant.modes import branch_modes


@functools.lru_cache(maxsize=32)
def _fruit_branch(branch_key: tuple, n_modes: int, z: tuple, mass: float, stiffness: float, damping: float):
    from berryshaker.plant.modes import cached_analytic_modes
    from berryshaker.plant.pedicel import fruit_branch_modes

    return fruit_branch_modes(cached_analytic_modes(branch_key, n_modes), np.array(z), mass, stiffness, damping)


def plant_modes(machine: Machine):
    """Modes the coupled run integrates: ``(modes, fruit_branch)``.

    With the pedicel model and ``pedicel.coupling = "two_way"`` (default) the named fruit sit on their
    stems inside the modal model (berryshaker.plant.pedicel.fruit_branch_modes: n_modes branch modes
    + one mode per fruit); ``fruit_branch`` then gives the fruit displacements.  Otherwise the branch's
    own modes (study eq. 15) and ``None``.

    Parameters
    ----------
    machine : Machine
        Machine description with a [plant] block.

    Returns
    -------
    modes : Modes
        The modes integrated: the branch's ``plant.contact.n_modes`` modes, or the combined branch-and-fruit
        modes (branch part, mass-normalised).
    fruit_branch : FruitBranchModes or None
        The combined modes with their fruit part (two-way pedicel), else None.
    """
    pl = machine.plant
    modes = branch_modes(pl.branch, pl.contact.n_modes)
    ped = pl.fruit.pedicel
    if ped.rigid or ped.coupling == "one_way":
        return modes, None
    b = pl.branch
    key = (b.root_diameter, b.tip_diameter, b.length, b.elastic_modulus, b.density, b.damping_ratio)
    z = tuple(float(f * b.length) for f in pl.fruit.positions)
    fb = _fruit_branch(key, pl.contact.n_modes, z, pl.fruit.mass, ped.stiffness, ped.damping)
    return fb.modes, fb


def bush_members(machine: Machine):
    """The reached members of the machine's bush population (berryshaker.plant.bush), with their modes.

    Parameters
    ----------
    machine : Machine
        Machine description with a [plant] block.

    Returns
    -------
    list of (BushBranch, Modes)
        The members the fingers reach (a station on the branch), in drawing order, each with its
        ``plant.bush.n_modes`` modes; empty when ``combs.load_model = "aggregate"`` or
        ``plant.bush.members = 0``.
    """
    from berryshaker.plant.bush import member_modes, sample_bush

    if machine.combs.load_model != "branches":
        return []
    return [(mb_, member_modes(mb_, machine.plant.bush.n_modes)) for mb_ in sample_bush(machine.plant)
            if mb_.station is not None]


#: samples per block of :meth:`BranchMotion.axial` (a few MB of pair products; 3000-8000 all measured alike)
AXIAL_BLOCK = 4096


@dataclass(frozen=True)
class BranchMotion:
    """Modal solution of a coupled run, ready for evaluation anywhere on the branch.

    Frozen: :attr:`_rows` keeps per-mode copies of the series, so the series must not change after construction
    (``eta`` and ``etad`` are views of the run's state array: do not write into ``res.y`` either).

    Attributes
    ----------
    t : numpy.ndarray
        Output times (s), uniform.
    modes : Modes
        The branch's mass-normalised modes (shapes 1/sqrt(kg)).
    eta : numpy.ndarray
        Modal displacements, (n_t, n_modes) (sqrt(kg) m).
    etad : numpy.ndarray
        Modal velocities (sqrt(kg) m/s).
    etadd : numpy.ndarray
        Modal accelerations from the branch's stiffness, damping and the comb contacts (sqrt(kg) m/s^2).
    contact_force : dict of str to numpy.ndarray
        Normal force of each comb contact that loads this branch (N).
    """

    t: np.ndarray
    modes: object  # berryshaker.plant.modes.Modes
    eta: np.ndarray  # (n_t, n_modes) modal displacements
    etad: np.ndarray  # modal velocities
    etadd: np.ndarray  # modal accelerations (branch stiffness, damping and the comb contacts)
    contact_force: dict[str, np.ndarray]

    def every(self, n: int) -> "BranchMotion":
        """Every n-th sample (for post-processing on a coarser, still uniform, time grid).

        Parameters
        ----------
        n : int
            Keep samples 0, n, 2n, ...

        Returns
        -------
        BranchMotion
            The same motion on the coarser grid.
        """
        return BranchMotion(self.t[::n], self.modes, self.eta[::n], self.etad[::n], self.etadd[::n],
                            {k: v[::n] for k, v in self.contact_force.items()})

    def window(self, start: int, stop: int) -> "BranchMotion":
        """Samples ``start`` to ``stop`` - 1 (one branch's passage in a run carrying several).

        Parameters
        ----------
        start, stop : int
            Sample indexes (as a slice).

        Returns
        -------
        BranchMotion
            The same motion over those samples.
        """
        s = slice(start, stop)
        return BranchMotion(self.t[s], self.modes, self.eta[s], self.etad[s], self.etadd[s],
                            {k: v[s] for k, v in self.contact_force.items()})

    @functools.cached_property
    def _rows(self) -> tuple[np.ndarray, np.ndarray]:
        """eta and eta' as contiguous rows per mode, (n_modes, n_t) each (the series are strided columns of the
        run's state array; per-mode rows make the products below contiguous).  Copied row-block first, then
        transposed in cache (a direct transposed copy of the strided columns misses the cache at every sample)."""
        return tuple(np.ascontiguousarray(x).T.copy() for x in (self.eta, self.etad))

    @functools.cached_property
    def _acceleration_rows(self) -> np.ndarray:
        """eta'' as contiguous rows per mode, (n_modes, n_t)."""
        return np.ascontiguousarray(self.etadd.T)

    def lateral(self, z, acceleration: bool = True):
        """Lateral displacement (m), velocity (m/s), acceleration (m/s^2) at positions z, each (n_z, n_t).

        ``acceleration=False``: the third is None (not computed: the stem forces need only the first two).

        Parameters
        ----------
        z : float or array_like
            Positions along the branch (m from the root).
        acceleration : bool
            Also compute the acceleration.

        Returns
        -------
        displacement : numpy.ndarray
            (n_z, n_t) lateral displacement (m).
        velocity : numpy.ndarray
            (n_z, n_t) lateral velocity (m/s).
        acceleration : numpy.ndarray or None
            (n_z, n_t) lateral acceleration (m/s^2), or None.
        """
        phi_t = self.modes.shape_at(np.atleast_1d(z)).T  # (n_z, n_modes)
        e, ed = self._rows
        return phi_t @ e, phi_t @ ed, (phi_t @ self._acceleration_rows if acceleration else None)

    def axial(self, z):
        """Axial (along-branch) displacement and velocity at z from the bending's foreshortening (m, m/s).

        u(z, t) = -1/2 int_0^z (dw/ds)^2 ds = -1/2 eta^T G(z) eta,  G_ij(z) = int_0^z phi_i' phi_j' ds
        (second order in the deflection; the Euler-Bernoulli branch has no first-order axial motion).

        Parameters
        ----------
        z : float or array_like
            Positions along the branch (m from the root).

        Returns
        -------
        displacement : numpy.ndarray
            (n_z, n_t) axial displacement u (m), <= 0 (towards the root).
        velocity : numpy.ndarray
            (n_z, n_t) axial velocity (m/s).
        """
        zs = np.atleast_1d(np.asarray(z, float))
        m = self.modes
        cum = m.slope_product_integral  # (n_modes, n_modes, n_s), cached with the modes
        j = np.clip(np.searchsorted(m.z, zs) - 1, 0, len(m.z) - 2)
        wgt = (zs - m.z[j]) / (m.z[j + 1] - m.z[j])
        g = (1 - wgt) * cum[:, :, j] + wgt * cum[:, :, j + 1]  # (n_modes, n_modes, n_z), symmetric in the modes
        # eta^T G eta and eta^T G eta' for every time and position: two matrix products over the mode pairs i <= j
        # (G is symmetric: the products slope_i slope_j and their running integral are the same numbers for (j, i)),
        # eta^T G eta = sum_{i<=j} (2 - delta_ij) G_ij eta_i eta_j,
        # eta^T G eta' = sum_{i<=j} G_ij (eta_i eta'_j + eta_j eta'_i) (1 - delta_ij / 2)
        # (the modal series as contiguous rows per mode; the pair products row block by row block, i fixed and
        # j = i ... n - 1, in the order of numpy.triu_indices: no gathered copies)
        nm = g.shape[0]
        iu, ju = np.triu_indices(nm)
        diag = iu == ju
        gp = g[iu, ju, :].T  # (n_z, pairs)
        wu = -0.5 * (gp * np.where(diag, 1.0, 2.0))  # (the factors -1/2 and -1 are exact: as if applied after)
        wv = -(gp * np.where(diag, 0.5, 1.0))
        e, ed = self._rows
        nt = e.shape[1]
        u = np.empty((len(zs), nt))
        v = np.empty((len(zs), nt))
        # in blocks of AXIAL_BLOCK samples: the pair products (66 rows for 11 modes) stay in cache and their
        # buffers are reused (one pass over the whole series wrote ~23 MB of fresh memory per call; the matrix
        # products give each column the same sums either way)
        ee = np.empty((len(iu), min(AXIAL_BLOCK + 1, nt)))
        eed = np.empty_like(ee)
        s0 = 0
        while s0 < nt:
            s1 = min(s0 + AXIAL_BLOCK, nt)
            if nt - s1 == 1:
                s1 = nt  # no one-sample block: numpy would hand it to a matrix-vector product, summing in another order
            w = s1 - s0
            k = 0
            for i in range(nm):
                rows = slice(k, k + nm - i)
                np.multiply(e[i, s0:s1], e[i:, s0:s1], out=ee[rows, :w])
                np.multiply(e[i, s0:s1], ed[i:, s0:s1], out=eed[rows, :w])
                eed[rows, :w] += e[i:, s0:s1] * ed[i, s0:s1]
                k += nm - i
            np.matmul(wu, ee[:, :w], out=u[:, s0:s1])
            np.matmul(wv, eed[:, :w], out=v[:, s0:s1])
            s0 = s1
        return u, v


def branch_motion(res: MultibodyResult, modes, offset: int = 0) -> BranchMotion:
    """Modal displacements, velocities and accelerations of the branch from a coupled multibody result
    (``modes``: the :class:`~berryshaker.plant.modes.Modes` the run was built with; ``offset``: index of its
    first modal coordinate in the plant's block-diagonal modal body, 0 for the instrumented branch, another for
    a probe of :func:`berryshaker.harvest.coupled.coupled_mechanism`).

    Parameters
    ----------
    res : MultibodyResult
        A coupled run.
    modes : Modes
        The modes the branch was built with.
    offset : int
        Index of the branch's first modal coordinate in the plant's modal body.

    Returns
    -------
    BranchMotion
        Modal displacements and velocities from the run's state, accelerations from the modal equations
        (stiffness, damping and the contacts that load this branch), and those contacts' normal forces.
    """
    cm = res.compiled
    spec = cm.spec
    nb3 = 3 * len(spec.bodies)
    nm = len(modes.omega)
    n = cm.n
    cols = slice(offset, offset + nm)
    eta = res.y[:, nb3 + offset:nb3 + offset + nm]
    etad = res.y[:, n + nb3 + offset:n + nb3 + offset + nm]
    w = modes.omega
    zeta = np.asarray(spec.plant.damping_ratio, float)  # one ratio, or one per mode
    zeta = zeta[cols] if zeta.ndim else zeta  # the other blocks' modes follow (block-diagonal)
    etadd = -(w**2) * eta - 2 * zeta * w * etad
    phi_tab = cm.model.phi_tab
    contact_force = {}
    for row, c in enumerate(spec.plant.contacts):
        if not np.any(phi_tab[row, cols]):
            continue  # another branch's contact (a bush member, a probe): it does not load this branch
        k = cm.frc_names.index(c.name)
        f = res.elements[:, k, mb.EO_FN]
        contact_force[c.name] = f
        etadd = etadd + np.outer(c.side * f, phi_tab[row, cols])
    return BranchMotion(res.t, modes, eta, etad, etadd, contact_force)


def stem_forces(motion: BranchMotion, z, mass, pedicel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stem force on fruit of mass ``mass`` at positions z (berryshaker.plant.pedicel).

    ``z``: positions (m), or a tuple (y, v, y_axial, v_axial) of branch motions already evaluated there
    (BranchMotion.lateral / axial), to reuse them for several masses.
    The axial force includes the weight m0 g when ``pedicel.include_weight`` (upright branch: its axis is
    vertical).  Lateral: driven by the branch's lateral displacement and velocity (absolute-coordinate form,
    smooth inputs); axial: by the foreshortening displacement and velocity (BranchMotion.axial).

    Parameters
    ----------
    motion : BranchMotion
        The branch's modal solution (its time grid, and the motion when ``z`` is positions).
    z : array_like or tuple
        Fruit positions (m from the root), or (y, v, y_axial, v_axial) already evaluated there (m, m/s).
    mass : float
        Fruit mass m0 (kg).
    pedicel : PedicelSpec
        The pedicel description (``stiffness`` N/m, ``damping`` N s/m, ``include_weight``).

    Returns
    -------
    lateral, axial, magnitude : numpy.ndarray
        Stem force on the fruit, each (n_z, n_t) (N): lateral, axial and the in-plane magnitude.
    """
    from berryshaker.plant.pedicel import GRAVITY, stem_response

    if isinstance(z, tuple) and len(z) == 4:  # precomputed (y, v, y_axial, v_axial): many masses, one motion
        y, v, ya, va = z
    else:
        y, v, _ = motion.lateral(z, acceleration=False)
        ya, va = motion.axial(z)
    _, f_lat = stem_response(motion.t, y, v, mass=mass, stiffness=pedicel.stiffness, damping=pedicel.damping,
                             displacement=False)
    _, f_ax = stem_response(motion.t, ya, va, mass=mass, stiffness=pedicel.stiffness, damping=pedicel.damping,
                            displacement=False)
    if pedicel.include_weight:
        f_ax = f_ax + mass * GRAVITY
    return f_lat, f_ax, np.hypot(f_lat, f_ax)
