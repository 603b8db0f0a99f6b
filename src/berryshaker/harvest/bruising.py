"""Bruising of detached fruit from its impacts, added up over the impacts (docs/harvest.md, "Bruising").

A detached berry meets up to two impacts on its way to the bin:

1. **the strike**: a comb finger meets the fruit it shook off.  The fruit comes off at its peak stem force, where the
   branch reverses, so it is taken at rest, and a finger meets it at a phase phi of its harmonic swing uniform over
   the cycle [assumed]: relative speed v = v_f |cos phi|, v_f = omega A_f the fingers' peak speed (A_f the finger
   amplitude of the drive geometry, omega the drive speed), onto a hard surface (the finger).  Only a share
   ``strike_probability`` of the detached fruit is struck [assumed]: the coupled drive-past does not follow a
   finger to a detached fruit.  (Every fruit struck at v_f, the bound the model used before, is
   ``strike_probability = 1`` with every phase at the peak: an upper bound.)
2. **the fall** onto the catching surface from its place on the branch: drop height h_f = catcher_drop + z L (an
   upright branch, as the pedicel model takes it, berryshaker.plant.pedicel; released at rest), onto a padded or a
   hard surface.

An impact at speed v is equivalent to a free drop from h = v^2 / (2 g).  **Bruising adds up over impacts**
(Ballinger et al. 1973: repeated drops bruise as their cumulative drop height, small increments as much as large
ones at the same total): each impact is expressed as the drop
onto the catching surface that does the same damage, h x h_50,catcher / h_50,surface (the ratio of the two
surfaces' median thresholds [assumed]), and the fruit bruises when the sum, the cumulative equivalent drop height

    H = h_f + (h_50,c / h_50,hard) v^2 / (2 g),

exceeds its own threshold, lognormal over fruit with median h_50,c and coefficient of variation ``bruise_cv``:

    P(H) = Phi( ln(H / h_50,c) / sigma ),   sigma = sqrt(ln(1 + cv^2)),
    damage = p_s E_phi[ P(H(phi)) ] + (1 - p_s) P(h_f).

**The medians from what the drop tests give** (Brown et al. 1996, 'Bluecrop'):

* padded: cushioning "prevented bruising for drop heights as great as 0.6 to 1.2 m": a *safe* height, a low fractile
  of the thresholds, not their median.  With P(bruise) = p at the safe height h_s (``safe_fractile`` p = 0.05
  [assumed]), h_50 = h_s exp(-z_p sigma) (z_p the standard normal p-quantile; 1.2 m at p = 0.05, cv 0.3: 1.95 m);
* hard: "extensive bruising resulted when drop height to a hard surface exceeded 150 mm": a threshold at which
  bruising becomes extensive, not a safe height; read as the height at which half the fruit bruise
  (``extensive_fractile`` = 0.5 [assumed]: "extensive" read as most of the fruit, so the median lies at or below
  150 mm and 0.5 is the least damaging reading), the same conversion with p = 0.5 (h_50 = 0.15 m).

The spread cv = 0.3 is [assumed].  Fruit-on-fruit impacts in the bin are softer than the fall onto the catcher and
are not counted separately.

References
----------
Brown, G. K., Schulte, N. L., Timm, E. J., Beaudry, R. M., Peterson, D. L., Hancock, J. F., Takeda, F. (1996).
Estimates of mechanization effects on fresh blueberry quality.  Applied Engineering in Agriculture 12(1), 21-26.

Ballinger, W. E., Kushman, L. J., Hamann, D. D. (1973).  Factors affecting the firmness of highbush blueberries.
Journal of the American Society for Horticultural Science 98(6), 583-587, doi:10.21273/jashs.98.6.583 (abstract:
fruit dropped on hard boards bruised in proportion to the distance of fall, and 10.2 cm increments bruised as much as
40.6 cm increments at the same total fall; the published record's ``bruise.cumulative_fall.ballinger1973``).
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy import special

from berryshaker.config import Machine
from berryshaker.harvest.shaking import shaking_amplitude

#: standard gravity (m/s^2)
GRAVITY = 9.80665

#: Gauss-Legendre nodes over the finger's phase phi in [0, pi/2] (|cos phi| is symmetric over the cycle): the
#: struck fruit's bruise probability is within 1e-6 of scipy.integrate.quad (tests/harvest/test_bruising.py)
PHASE_NODES = 24


def _sigma(cv) -> np.ndarray:
    cv = np.asarray(cv, float)
    return np.sqrt(np.log1p(cv * cv))


def median_height(height, fractile, cv):
    """Median bruise-threshold drop height h_50 from a height at which a known share of the fruit bruises.

    Parameters
    ----------
    height : array_like
        Drop height h_p at which a share ``fractile`` of the fruit bruises (m): a safe height (a low fractile) or a
        height of extensive bruising.
    fractile : array_like
        p = P(bruise) at ``height`` (0 < p < 1; dimensionless).
    cv : array_like
        Coefficient of variation of the thresholds over fruit (lognormal; dimensionless).

    Returns
    -------
    ndarray
        h_50 = h_p exp(-z_p sigma) (m), z_p = Phi^-1(p), sigma = sqrt(ln(1 + cv^2)).

    Notes
    -----
    The thresholds are lognormal, ln h_p = ln h_50 + z_p sigma (module docstring).  A safe height read at p = 0.05
    lies 1.645 sigma below the median: the cushioned 1.2 m of Brown et al. (1996) gives h_50 = 1.95 m at cv 0.3.
    """
    return np.asarray(height, float) * np.exp(-special.ndtri(np.asarray(fractile, float)) * _sigma(cv))


def bruise_medians(harvest) -> tuple[float, float]:
    """The described median bruise-threshold heights of a hard and a padded surface (m).

    Parameters
    ----------
    harvest : berryshaker.harvest.spec.HarvestSpec
        ``extensive_drop_height_hard``, ``extensive_fractile``, ``safe_drop_height_padded``, ``safe_fractile``,
        ``bruise_cv``.

    Returns
    -------
    (float, float)
        h_50 hard, h_50 padded (m), each :func:`median_height` of the height the drop tests give.
    """
    h = harvest
    return (float(median_height(h.extensive_drop_height_hard, h.extensive_fractile, h.bruise_cv)),
            float(median_height(h.safe_drop_height_padded, h.safe_fractile, h.bruise_cv)))


def catcher_median(harvest) -> float:
    """Median bruise-threshold height of the described catching surface (m): :func:`bruise_medians` of
    ``catcher_surface``.

    Parameters
    ----------
    harvest : berryshaker.harvest.spec.HarvestSpec
        The [harvest] block.

    Returns
    -------
    float
        h_50 of the catcher (m).
    """
    hard, padded = bruise_medians(harvest)
    return hard if harvest.catcher_surface == "hard" else padded


def bruise_probability(drop_height, median_height: float, cv: float):
    """Probability that a fruit bruises in an impact (or impacts) equivalent to a free drop from ``drop_height``.

    Parameters
    ----------
    drop_height : array_like
        Equivalent (cumulative) drop height H of the impacts (m).
    median_height : float or array_like
        Median bruise-threshold drop height h_50 of the surface (m).
    cv : float
        Coefficient of variation of the thresholds over fruit (lognormal; dimensionless).

    Returns
    -------
    ndarray
        Phi(ln(H / h_50) / sigma), sigma = sqrt(ln(1 + cv^2)); 0 for H = 0.

    Notes
    -----
    The lognormal threshold law of the module docstring (Brown et al. 1996 for the medians).
    """
    h = np.asarray(drop_height, float)
    sigma = _sigma(cv)
    with np.errstate(divide="ignore"):
        x = np.log(np.maximum(h, 0.0) / np.asarray(median_height, float)) / sigma
    return 0.5 * special.erfc(-x / math.sqrt(2.0))


@functools.lru_cache(maxsize=64)
def _finger_speed(machine_json: str) -> float:
    import json

    from berryshaker.config import machine_from_dict

    m = machine_from_dict(json.loads(machine_json))
    return shaking_amplitude(m)["finger_amplitude_mm"] * 1e-3 * m.drive_speed


def finger_speed(machine: Machine) -> float:
    """Peak speed of the striking fingers (m/s): omega x the finger amplitude of the drive geometry
    (berryshaker.harvest.shaking.shaking_amplitude), the peak speed of a harmonic swing.

    Parameters
    ----------
    machine : Machine
        Machine description (drive speed and geometry).

    Returns
    -------
    float
        v_f = omega A_f: the finger amplitude (m) times the drive speed (rad/s) (m/s).
    """
    return _finger_speed(machine.model_dump_json())


@functools.lru_cache(maxsize=1)
def _phase_nodes() -> tuple[np.ndarray, np.ndarray]:
    """cos^2 phi at Gauss-Legendre nodes over phi in [0, pi/2] and their weights (summing to 1)."""
    x, w = np.polynomial.legendre.leggauss(PHASE_NODES)
    phi = 0.25 * np.pi * (x + 1.0)
    return np.cos(phi) ** 2, 0.5 * w


def cumulative_damage(fall, strike_max, catcher_h50, hard_h50, cv, strike_probability):
    """Probability that a detached fruit is bruised by its fall and, if struck, the finger's strike, added up as a
    cumulative equivalent drop height onto the catching surface.

    Parameters
    ----------
    fall : array_like
        Fall height onto the catching surface h_f (m).
    strike_max : float
        Equivalent drop height of a strike at the fingers' peak speed, v_f^2 / (2 g) (m).
    catcher_h50, hard_h50 : float or array_like
        Median bruise-threshold heights of the catching surface and of a hard surface (the finger) (m).
    cv : float
        CV of the fruit's thresholds (dimensionless).
    strike_probability : float or array_like
        Share p_s of the detached fruit a finger strikes (dimensionless; an array broadcasts with the others).

    Returns
    -------
    ndarray
        p_s E_phi[P(h_f + (h_50,c / h_50,hard) (v_f^2 / 2 g) cos^2 phi)] + (1 - p_s) P(h_f), P the lognormal law of
        :func:`bruise_probability` on the catcher (dimensionless; broadcast over the arguments).

    Notes
    -----
    Cumulative drop height (Ballinger et al. 1973) with each impact scaled to the catching surface by the ratio of
    the medians (module docstring); phi uniform, Gauss-Legendre over [0, pi/2] (:data:`PHASE_NODES`).
    """
    fall = np.asarray(fall, float)
    c50 = np.asarray(catcher_h50, float)
    p_fall = bruise_probability(fall, c50, cv)
    sp = np.asarray(strike_probability, float)
    if np.all(sp <= 0.0) or strike_max <= 0.0:
        return p_fall + 0.0 * sp
    c2, w = _phase_nodes()
    scale = (c50 / np.asarray(hard_h50, float))[..., None]
    h = fall[..., None] + scale * strike_max * c2
    p_struck = np.sum(w * bruise_probability(h, c50[..., None], cv), axis=-1)
    return sp * p_struck + (1.0 - sp) * p_fall


def impact_damage(machine: Machine, z, catcher_h50=None, strike_probability=None) -> np.ndarray:
    """Probability that a detached fruit at branch fractions ``z`` is bruised by its impacts (module docstring).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest] (``catcher_drop``, ``catcher_surface``, the drop-test heights
        and fractiles, ``bruise_cv``, ``strike_probability``).
    z : array_like
        Fruit positions, fractions of the branch length.
    catcher_h50 : float or array_like, optional
        Median threshold of the catching surface (m; default the description's, :func:`catcher_median`); an array of
        shape (n, 1) gives n rows.  On a hard catcher the strike's surface is the same one.
    strike_probability : float or array_like, optional
        Share of the detached fruit a finger strikes (dimensionless; default ``harvest.strike_probability``); an
        array of shape (n, 1) gives n rows.

    Returns
    -------
    ndarray
        :func:`cumulative_damage` at h_f = catcher_drop + z L (dimensionless).
    """
    h = machine.harvest
    hard, _ = bruise_medians(h)
    c50 = catcher_median(h) if catcher_h50 is None else np.asarray(catcher_h50, float)
    hard_h50 = c50 if h.catcher_surface == "hard" else hard
    v_f = finger_speed(machine)
    # a start's thousands of fruit sit at a few dozen places (its nodes): the probability, elementwise in the fall
    # height, is evaluated once per place and gathered (the same numbers, bit for bit)
    z = np.asarray(z, float)
    sp = h.strike_probability if strike_probability is None else strike_probability
    rows = all(np.shape(x)[-1:] in ((), (1,)) for x in (c50, hard_h50, sp))  # parameters constant along z
    places, where = np.unique(z, return_inverse=True) if z.ndim == 1 and rows else (z, None)
    fall = h.catcher_drop + places * machine.plant.branch.length
    fall, c50, hard_h50 = np.broadcast_arrays(fall, c50, hard_h50)
    q = cumulative_damage(fall, v_f * v_f / (2 * GRAVITY), c50, hard_h50, h.bruise_cv, sp)
    return q if where is None else q[..., where]
