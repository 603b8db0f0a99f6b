"""Bruising of detached fruit from its impacts (docs/harvest.md, "Bruising").

A detached berry meets two impacts on its way to the bin:

1. **the strike**: the comb's fingers hit the fruit they shake off; the relative speed is at most the fingers' peak
   speed, v_f = omega A_f (A_f the finger amplitude of the drive geometry, omega the drive speed: the peak speed of
   a harmonic swing), onto a hard surface (a steel finger).  Every detached fruit is taken as struck once at v_f:
   an upper bound [assumed].
2. **the fall** onto the catching surface from its place on the branch: drop height h = catcher_drop + z L (an
   upright branch, as the pedicel model takes it, berryshaker.plant.pedicel; released at rest: a fruit comes off at
   its peak stem force, where the branch reverses), onto a padded or a hard surface.

An impact at speed v is equivalent to a free drop from h_eq = v^2 / (2 g).  A fruit bruises in an impact when h_eq
exceeds its own threshold, lognormal over fruit with median h_50 per surface and coefficient of variation
``bruise_cv``, so the bruise probability of one impact is

    P(h_eq) = Phi( ln(h_eq / h_50) / sigma ),     sigma = sqrt(ln(1 + cv^2)),

and of both, 1 - (1 - P_strike)(1 - P_fall).  The medians come from blueberry drop tests: extensive bruising above
150 mm onto a hard surface, none up to 0.6-1.2 m onto the cushioning materials found (Brown et al. 1996; 'Bluecrop'):
h_50 = 0.15 m (hard) and 1.2 m (padded: the largest safe height, so the median is a lower bound) [published]; the
spread cv = 0.3 is [assumed] (it keeps the hard-surface bruise probability below 1 % under 75 mm and above 99 % over
0.3 m, and the padded one below 1 % at 0.6 m, as the test describes).  Fruit-on-fruit impacts in the bin are softer
than the fall onto the catcher and are not counted separately.

References
----------
Brown, G. K., Schulte, N. L., Timm, E. J., Beaudry, R. M., Peterson, D. L., Hancock, J. F., Takeda, F. (1996).
Estimates of mechanization effects on fresh blueberry quality.  Applied Engineering in Agriculture 12(1), 21-26.
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


def bruise_probability(drop_height, median_height: float, cv: float):
    """Probability that a fruit bruises in an impact equivalent to a free drop from ``drop_height``.

    Parameters
    ----------
    drop_height : array_like
        Equivalent drop height h_eq = v^2 / (2 g) of the impact (m).
    median_height : float
        Median bruise-threshold drop height h_50 of the surface (m).
    cv : float
        Coefficient of variation of the thresholds over fruit (lognormal; dimensionless).

    Returns
    -------
    ndarray
        Phi(ln(h_eq / h_50) / sigma), sigma = sqrt(ln(1 + cv^2)); 0 for h_eq = 0 (module docstring).
    """
    h = np.asarray(drop_height, float)
    sigma = math.sqrt(math.log1p(cv * cv))
    with np.errstate(divide="ignore"):
        x = np.log(np.maximum(h, 0.0) / median_height) / sigma
    return 0.5 * special.erfc(-x / math.sqrt(2.0))


@functools.lru_cache(maxsize=64)
def _finger_speed(machine_json: str) -> float:
    from berryshaker.config import machine_from_dict
    import json

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
        Finger amplitude (m) times the drive speed (rad/s): the peak finger speed (m/s).
    """
    return _finger_speed(machine.model_dump_json())


def impact_damage(machine: Machine, z) -> np.ndarray:
    """Probability that a detached fruit at branch fractions ``z`` is bruised by its strike and its fall.

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest] (``catcher_drop``, ``catcher_surface``,
        ``bruise_height_hard``, ``bruise_height_padded``, ``bruise_cv``).
    z : array_like
        Fruit positions, fractions of the branch length.

    Returns
    -------
    ndarray
        1 - (1 - P_strike)(1 - P_fall) (module docstring).
    """
    h = machine.harvest
    v_f = finger_speed(machine)
    p_strike = bruise_probability(v_f * v_f / (2 * GRAVITY), h.bruise_height_hard, h.bruise_cv)
    fall = h.catcher_drop + np.asarray(z, float) * machine.plant.branch.length
    surface = h.bruise_height_padded if h.catcher_surface == "padded" else h.bruise_height_hard
    p_fall = bruise_probability(fall, surface, h.bruise_cv)
    return 1.0 - (1.0 - p_strike) * (1.0 - p_fall)
