"""Bending modes of the tapered branch: the analytic Bessel-function solution (study eq. 15) and an
independent finite-element solution; each checks the other (tested to < 0.1 % on four frequencies).

Analytic solution.  With xi = l/alpha - z the distance from the cone's virtual apex, EI ~ xi^4 and
rho A ~ xi^2, and the free vibration equation (EI w'')'' = rho A omega^2 w becomes
(xi^4 w'')'' = k^4 xi^2 w,  k^4 = omega^2 (rho A0 / E I0) (l/alpha)^2.  Its general solution is

    w(xi) = xi^-1 [C1 J2(x) + C2 Y2(x) + C3 I2(x) + C4 K2(x)],   x = 2 k sqrt(xi)

(Kirchhoff 1879 for the cone; Conway, Becker & Dubil 1964).  The study's eq. 15 writes the same Bessel
functions of order 2 of an argument ~ sqrt(1 - alpha z/l), but its normalisation and argument are not
dimensionally consistent; the form above is derived from the equation and checked by it.  Derivatives
follow from d/dxi[xi^(-n/2) Z_n(x)] = -+ k xi^(-(n+1)/2) Z_(n+1)(x) (minus for J, Y, K; plus for I):

    w'   = k   xi^-3/2 [-C1 J3 - C2 Y3 + C3 I3 - C4 K3]
    w''  = k^2 xi^-2   [ C1 J4 + C2 Y4 + C3 I4 + C4 K4]
    w''' = k^3 xi^-5/2 [-C1 J5 - C2 Y5 + C3 I5 - C4 K5]

Clamped root (w = w' = 0 at xi0 = l/alpha) and free tip (w'' = w''' = 0 at xi1 = xi0 - l) give a 4x4
determinant in k.  I and K are evaluated scaled (scipy.special.ive, kve) and their columns multiplied by
e^-x0 and e^x1, which removes the overflow without moving the roots; roots are bracketed on a grid much
finer than their spacing and refined with brentq.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy import linalg, optimize, special

from berryshaker.errors import ConfigError
from berryshaker.plant.branch import Branch


@dataclass(frozen=True)
class Modes:
    """Mass-normalised bending modes: int rho A phi_i phi_j dz = delta_ij.

    Attributes
    ----------
    branch : Branch
        The branch.
    omega : ndarray
        Natural angular frequencies (rad/s).
    z : ndarray
        Sample points along the branch (m from the root).
    shapes : ndarray, shape (n_modes, n_z)
        Mode shapes at ``z`` (1/sqrt(kg), mass-normalised).
    method : str
        How they were found ("analytic" or "finite elements").
    """

    branch: Branch
    omega: np.ndarray  # rad/s
    z: np.ndarray  # sample points along the branch (m)
    shapes: np.ndarray  # (n_modes, n_z) mode shapes at z (m / sqrt(kg) units: 1/sqrt(kg))
    method: str

    @property
    def frequency_hz(self) -> np.ndarray:
        """Natural frequencies omega / 2 pi (Hz)."""
        return self.omega / (2 * math.pi)

    def shape_at(self, z) -> np.ndarray:
        """Mode shapes at arbitrary positions (linear interpolation of the dense samples).

        Parameters
        ----------
        z : float or array_like
            Positions along the branch (m from the root).

        Returns
        -------
        ndarray, shape (n_modes, ...)
            phi_k(z) (1/sqrt(kg)).
        """
        z = self.branch.check_position(z)
        return np.array([np.interp(z, self.z, s) for s in self.shapes])

    @functools.cached_property
    def slope_product_integral(self) -> np.ndarray:
        """G_ij(z) = int_0^z phi_i'(s) phi_j'(s) ds at the sample points z, (n_modes, n_modes, n_z), 1/(kg m).

        The kernel of the branch's axial foreshortening u(z) = -1/2 eta^T G(z) eta (second order in the
        deflection, berryshaker.harvest.coupled_branch.BranchMotion.axial); slopes by central differences, the integral
        by the cumulative trapezoidal rule.  Computed once per modes object (the modes are cached per process,
        so every replicate of a branch class shares it; ~1.9 MB for 11 modes at 2001 points, read-only).
        """
        from scipy.integrate import cumulative_trapezoid

        slope = np.array([np.gradient(s, self.z) for s in self.shapes])  # (n_modes, n_z)
        prod = slope[:, None, :] * slope[None, :, :]
        g = cumulative_trapezoid(prod, self.z, axis=-1, initial=0.0)
        g.setflags(write=False)
        return g


def _columns(x, k, xi, order_shift):
    """Scaled Bessel terms of w (shift 0), w' (1), w'' (2), w''' (3) at x, with the xi power."""
    n = 2 + order_shift
    sign_jyk = -1.0 if order_shift % 2 == 1 else 1.0
    p = k**order_shift * xi ** (-(2 + order_shift) / 2.0)
    return p * np.array([sign_jyk * special.jv(n, x), sign_jyk * special.yv(n, x), special.ive(n, x),
                         sign_jyk * special.kve(n, x)])


def _bessel_arguments(beta_l, br: Branch):
    """k, the Bessel arguments x0 (root) and x1 (tip), and xi0, xi1 of the frequency parameter beta_l (a number
    or an array): xi0 = l / alpha, xi1 = xi0 - l, k = (beta_l / l) sqrt(xi0), x = 2 k sqrt(xi)."""
    xi0 = br.length / br.alpha
    xi1 = xi0 - br.length
    k = beta_l / br.length * math.sqrt(xi0)
    return k, 2 * k * math.sqrt(xi0), 2 * k * math.sqrt(xi1), xi0, xi1


def _matrix(beta_l, br: Branch):
    k, x0, x1, xi0, xi1 = _bessel_arguments(beta_l, br)
    rows = [_columns(x0, k, xi0, 0), _columns(x0, k, xi0, 1), _columns(x1, k, xi1, 2), _columns(x1, k, xi1, 3)]
    m = np.array(rows)
    # undo the scaling of ive/kve consistently per column: I column ~ e^x, K column ~ e^-x
    m[0, 2] *= 1.0
    m[1, 2] *= 1.0
    m[2, 2] *= math.exp(x1 - x0)
    m[3, 2] *= math.exp(x1 - x0)
    m[0, 3] *= math.exp(x1 - x0)
    m[1, 3] *= math.exp(x1 - x0)
    # row scaling (does not move roots): make each row O(1)
    m /= np.max(np.abs(m), axis=1, keepdims=True)
    return m, k, x0, x1, xi0, xi1


def _det(beta_l, br):
    return np.linalg.det(_matrix(beta_l, br)[0])


def _dets(beta_l: np.ndarray, br: Branch) -> np.ndarray:
    """:func:`_det` at every frequency parameter of ``beta_l`` in one vectorised pass (the root scan of
    :func:`analytic_modes`: ~12 000 points, 0.6 s one by one).  The same operations element by element
    (scipy's Bessel ufuncs, a stacked LAPACK determinant); the roots are refined with the scalar :func:`_det`."""
    k, x0, x1, xi0, xi1 = _bessel_arguments(beta_l, br)
    m = np.empty((beta_l.shape[0], 4, 4))
    for r, (x, xi, shift) in enumerate(((x0, xi0, 0), (x0, xi0, 1), (x1, xi1, 2), (x1, xi1, 3))):
        m[:, r, :] = _columns(x, k, xi, shift).T
    e = np.exp(x1 - x0)
    m[:, 2, 2] *= e
    m[:, 3, 2] *= e
    m[:, 0, 3] *= e
    m[:, 1, 3] *= e
    m /= np.max(np.abs(m), axis=2, keepdims=True)
    return np.linalg.det(m)


def analytic_modes(branch: Branch, n_modes: int = 4, n_points: int = 2001, beta_l_max: float | None = None) -> Modes:
    """Analytic modes of the tapered cantilever (study eq. 15, corrected), mass-normalised.

    Parameters
    ----------
    branch : Branch
        The tapered branch (alpha > 0).
    n_modes : int
        Number of modes.
    n_points : int
        Samples of the mode shapes along the branch.
    beta_l_max : float, optional
        Upper end of the search for the roots beta l (dimensionless); default 3.2 n_modes + 6, doubled until
        ``n_modes`` roots are found.

    Returns
    -------
    Modes
        omega_i = (beta_i l)^2 sqrt(E I0 / (rho A0 l^4)), beta_i l the roots of the 4x4 determinant.

    Notes
    -----
    beta l is the frequency parameter referred to the root section: k = (beta l / l) sqrt(l/alpha).  For
    alpha -> 0 the roots tend to the uniform cantilever's 1.8751, 4.6941, 7.8548 (tested).
    """
    br = branch
    if br.alpha < 1e-6:
        raise ConfigError("the analytic tapered solution needs a taper (alpha >= 1e-6); for a uniform branch "
                          "use fe_modes or a tip diameter slightly below the root diameter")
    if br.alpha >= 1.0:
        raise ConfigError("tip diameter must be > 0")
    hi = beta_l_max or (3.2 * n_modes + 6.0)
    grid = np.linspace(0.3, hi, int(400 * hi))
    vals = _dets(grid, br)
    roots = []
    for b0, b1, v0, v1 in zip(grid[:-1], grid[1:], vals[:-1], vals[1:]):
        if np.sign(v0) != np.sign(v1) and np.isfinite(v0) and np.isfinite(v1):
            r = optimize.brentq(_det, b0, b1, args=(br,), xtol=1e-14, rtol=1e-14)
            # reject sign changes through a pole (the determinant does not vanish there)
            m = _matrix(r, br)[0]
            s = np.linalg.svd(m, compute_uv=False)
            if s[-1] / s[0] < 1e-6:
                roots.append(r)
        if len(roots) == n_modes:
            break
    if len(roots) < n_modes:
        return analytic_modes(branch, n_modes, n_points, beta_l_max=hi * 2)
    z = np.linspace(0.0, br.length, n_points)
    a0 = br.area(0.0)
    i0 = br.second_moment(0.0)
    omegas, shapes = [], []
    for bl in roots:
        m, k, x0, x1, xi0, xi1 = _matrix(bl, br)
        _, _, vt = np.linalg.svd(m)
        c = vt[-1]
        xi = xi0 - z
        x = 2 * k * np.sqrt(xi)
        w = (c[0] * special.jv(2, x) + c[1] * special.yv(2, x) + c[2] * special.ive(2, x) * np.exp(x - x0)
             + c[3] * special.kve(2, x) * np.exp(x1 - x)) / xi
        norm = math.sqrt(_trapz(br.density * br.area(z) * w * w, z))
        w = w / norm
        if w[-1] < 0:
            w = -w
        omegas.append(bl**2 * math.sqrt(br.elastic_modulus * i0 / (br.density * a0 * br.length**4)))
        shapes.append(w)
    return Modes(br, np.array(omegas), z, np.array(shapes), "analytic (Bessel, eq. 15)")


def _trapz(y, x):
    """Simpson's rule (scipy.integrate.simpson) on the dense samples: O(h^4) normalisation."""
    from scipy.integrate import simpson

    return float(simpson(y, x=x))


def fe_matrices(branch: Branch, n_elements: int = 120):
    """Stiffness and mass matrices of the tapered cantilever with cubic Hermite beam elements.

    EI(z) (quartic) and rho A(z) (quadratic) are integrated exactly with 6-point Gauss-Legendre
    quadrature per element; the root is clamped (its two degrees of freedom removed).  Degrees of
    freedom per node: deflection w (m) and slope w' (rad).

    Parameters
    ----------
    branch : Branch
        The branch.
    n_elements : int
        Number of beam elements.

    Returns
    -------
    K : ndarray
        Stiffness matrix (N/m, N/rad and N m/rad by degree of freedom).
    M : ndarray
        Mass matrix (kg, kg m and kg m^2 by degree of freedom).
    nodes : ndarray
        Node positions (m from the root), the clamped root included.

    References
    ----------
    J. S. Przemieniecki, *Theory of Matrix Structural Analysis*, McGraw-Hill, 1968, ch. 5 and 11.
    """
    br = branch
    nodes = np.linspace(0.0, br.length, n_elements + 1)
    ndof = 2 * (n_elements + 1)
    K = np.zeros((ndof, ndof))
    M = np.zeros((ndof, ndof))
    gx, gw = np.polynomial.legendre.leggauss(6)
    for e in range(n_elements):
        z0, z1 = nodes[e], nodes[e + 1]
        h = z1 - z0
        s = 0.5 * (gx + 1.0)
        w = 0.5 * gw * h
        zq = z0 + s * h
        ei = br.elastic_modulus * br.second_moment(zq)
        ra = br.density * br.area(zq)
        # Hermite shape functions and their second derivatives in z
        N = np.array([1 - 3 * s**2 + 2 * s**3, h * (s - 2 * s**2 + s**3), 3 * s**2 - 2 * s**3, h * (-s**2 + s**3)])
        B = np.array([(-6 + 12 * s) / h**2, (-4 + 6 * s) / h, (6 - 12 * s) / h**2, (-2 + 6 * s) / h])
        ke = (B * (ei * w)) @ B.T
        me = (N * (ra * w)) @ N.T
        idx = slice(2 * e, 2 * e + 4)
        K[idx, idx] += ke
        M[idx, idx] += me
    return K[2:, 2:], M[2:, 2:], nodes


def fe_modes(branch: Branch, n_modes: int = 4, n_elements: int = 120) -> Modes:
    """Finite-element modes (the open counterpart of the study's ANSYS flexible body), mass-normalised.

    Solved with scipy.linalg.eigh on the generalised problem K v = omega^2 M v.

    Parameters
    ----------
    branch : Branch
        The branch.
    n_modes : int
        Number of modes.
    n_elements : int
        Number of beam elements (:func:`fe_matrices`).

    Returns
    -------
    Modes
        The lowest ``n_modes`` modes, mass-normalised.
    """
    K, M, nodes = fe_matrices(branch, n_elements)
    # symmetric diagonal scaling: same eigenvalues, far better conditioning for fine meshes
    s = 1.0 / np.sqrt(np.diag(K))
    vals, vecs = linalg.eigh(K * np.outer(s, s), M * np.outer(s, s), subset_by_index=[0, n_modes - 1])
    vecs = vecs * s[:, None]
    shapes = np.zeros((n_modes, len(nodes)))
    shapes[:, 1:] = vecs[0::2, :].T  # deflection dofs (root clamped = 0); eigh returns M-normalised vectors
    for i in range(n_modes):
        if shapes[i, -1] < 0:
            shapes[i] = -shapes[i]
    # dense samples by Hermite interpolation within elements
    z = np.linspace(0.0, branch.length, 2001)
    dense = np.array([_hermite_sample(nodes, np.concatenate([[0.0, 0.0], vecs[:, i] * np.sign(shapes[i, -1] or 1)]), z)
                      for i in range(n_modes)])
    for i in range(n_modes):
        if dense[i, -1] < 0:
            dense[i] = -dense[i]
    return Modes(branch, np.sqrt(vals), z, dense, f"finite elements ({n_elements} tapered Euler-Bernoulli elements)")


def _hermite_sample(nodes, dofs, z):
    e = np.clip(np.searchsorted(nodes, z, side="right") - 1, 0, len(nodes) - 2)
    h = nodes[e + 1] - nodes[e]
    s = (z - nodes[e]) / h
    w0, t0, w1, t1 = dofs[2 * e], dofs[2 * e + 1], dofs[2 * e + 2], dofs[2 * e + 3]
    return ((1 - 3 * s**2 + 2 * s**3) * w0 + h * (s - 2 * s**2 + s**3) * t0 + (3 * s**2 - 2 * s**3) * w1
            + h * (-s**2 + s**3) * t1)


@functools.lru_cache(maxsize=256)
def cached_analytic_modes(key: tuple, n_modes: int) -> Modes:
    """:func:`analytic_modes` of ``Branch(*key)``, computed once per process for every user (the fruit branch,
    the bush members, sweeps): key = (root diameter, tip diameter, length, E, density, damping ratio).  The
    returned :class:`Modes` is shared: read it, never modify it.

    Parameters
    ----------
    key : tuple of float
        (root diameter (m), tip diameter (m), length (m), E (Pa), density (kg/m^3), damping ratio (1)).
    n_modes : int
        Number of modes.

    Returns
    -------
    Modes
        The shared modes.
    """
    return analytic_modes(Branch(*key), n_modes)


def branch_modes(branch_spec, n_modes: int) -> Modes:
    """Analytic modes (study eq. 15) of a branch description (:class:`~berryshaker.plant.spec.BranchSpec`),
    cached per process so sweeps reuse them.

    Parameters
    ----------
    branch_spec : BranchSpec
        The ``[plant.branch]`` section.
    n_modes : int
        Number of modes.

    Returns
    -------
    Modes
        The analytic modes.
    """
    b = branch_spec
    key = (b.root_diameter, b.tip_diameter, b.length, b.elastic_modulus, b.density, b.damping_ratio)
    return cached_analytic_modes(key, n_modes)
