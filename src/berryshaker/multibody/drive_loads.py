"""Sizing loads of a drive shaft from its moment: the torque a designer sizes the shaft, the keys and the gearbox
from, and the torques the motor and the gearbox are rated by (docs/life.md, "Sizing loads").

A run's single largest drive moment is the extreme of a chaotic signal (the cam roller's impacts in its groove).
The statistics here are over whole driver revolutions of the statistics window:

* the **design torque** :func:`design_torque`: the p95 of the per-revolution peaks of |M| (N m), the torque a
  fraction 0.05 of the revolutions exceed (a characteristic value as EN 1990:2002 sec. 4.1.2 defines one, a
  fractile of the load's distribution, here of the revolutions' peaks; the same fractile as the collision forces'
  static-equivalent load, :data:`berryshaker.multibody.impacts.STATIC_FRACTILE`);
* the **RMS torque** (N m): the thermal (continuous) rating of the motor, sqrt(mean M^2) over time;
* the **fatigue-equivalent torque** :func:`fatigue_equivalent_torque`: T_eq = (mean_t |M|^m)^(1/m) (N m), the
  constant torque of the same Palmgren-Miner damage at constant speed (load cycles of the gear teeth and shaft
  bearings proportional to time: ISO 6336-6:2019's equivalent torque of a load spectrum, with ISO 281:2007's
  exponent m = 3 of the impacts' fatigue-equivalent load).

Convergence (benchmarks/studies/drive_torque_study.py, tests/multibody/test_drive_loads_convergence.py): over 24
starts of the reference harvester's drive-pasts, one per branch class (3 per start, 9 revolutions), the design
torque is 262.0 +- 1.3 N m (mean +- SE); rtol 1e-6 moves it by -1.1 % (1.4 SE), 16 bush modes by -0.3 % (0.4 SE).
The virtual L9 runs one drive-past per start (its branch classes as probes, 3 revolutions): the per-start SD of the
design torque is 1.07x, of the RMS torque 1.60x that of the three runs (CHANGELOG, 0.2.0).
"""

from __future__ import annotations

import numpy as np

from berryshaker.multibody.impacts import FATIGUE_EXPONENT, STATIC_FRACTILE


def revolution_peaks(t: np.ndarray, moment: np.ndarray, t0: float, period: float) -> np.ndarray:
    """Peak |M| of each whole driver revolution from ``t0`` (N m); a partial last revolution is left out.

    Parameters
    ----------
    t : numpy.ndarray
        Sample times (s).
    moment : numpy.ndarray
        Drive moment at those times (N m).
    t0 : float
        Start of the statistics window (s).
    period : float
        Duration of one revolution, 2 pi / drive speed (s).

    Returns
    -------
    numpy.ndarray
        One peak per whole revolution (N m).
    """
    t, a = np.asarray(t, float), np.abs(np.asarray(moment, float))
    n = int((t[-1] - t0 + 1e-9 * period) // period) if t.size else 0
    k = np.floor((t - t0) / period + 1e-12).astype(int)
    return np.array([a[k == j].max() for j in range(n) if np.any(k == j)])


def design_torque(peaks: np.ndarray) -> float:
    """Design torque: the :data:`~berryshaker.multibody.impacts.STATIC_FRACTILE` fractile of the per-revolution
    peaks (N m); NaN without revolutions.

    A characteristic load in the sense of EN 1990:2002 sec. 4.1.2 (a stated fractile of the load's distribution);
    quantile by linear interpolation between order statistics (Hyndman and Fan 1996 type 7, numpy's default).

    Parameters
    ----------
    peaks : numpy.ndarray
        Peak |M| of each revolution (N m), :func:`revolution_peaks`.

    Returns
    -------
    float
        The torque (N m).

    References
    ----------
    EN 1990:2002, *Eurocode: Basis of structural design*, sec. 4.1.2.  R. J. Hyndman and Y. Fan, "Sample quantiles
    in statistical packages", *Am. Stat.* 50 (1996) 361-365.
    """
    peaks = np.asarray(peaks, float)
    return float(np.quantile(peaks, STATIC_FRACTILE)) if peaks.size else float("nan")


def fatigue_equivalent_torque(moment: np.ndarray, exponent: float = FATIGUE_EXPONENT) -> float:
    """Fatigue-equivalent torque of a drive moment sampled uniformly in time at constant speed (N m):
    T_eq = (mean |M|^m)^(1/m).

    At constant speed the load cycles of the gear teeth and the shaft's bearings are proportional to time, so the
    time mean is ISO 6336-6:2019's equivalent torque of a load spectrum (sum n_i T_i^m / sum n_i)^(1/m) and ISO
    281:2007's mean equivalent load (sec. 7.3) with its exponent m = 3 (point contact).

    Parameters
    ----------
    moment : numpy.ndarray
        Drive moment at uniformly spaced times (N m).
    exponent : float
        Load-life exponent m (dimensionless).

    Returns
    -------
    float
        T_eq (N m); NaN without samples.

    References
    ----------
    ISO 6336-6:2019, *Calculation of load capacity of spur and helical gears, Part 6: service life under variable
    load*.  ISO 281:2007, *Rolling bearings: Dynamic load ratings and rating life*.  M. A. Miner, "Cumulative damage
    in fatigue", *J. Appl. Mech.* 12 (1945) A159-A164.
    """
    a = np.abs(np.asarray(moment, float))
    return float(np.mean(a**exponent) ** (1.0 / exponent)) if a.size else float("nan")
