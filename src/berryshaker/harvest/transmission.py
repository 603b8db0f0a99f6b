"""Where the clearance impacts are filtered on their way from the pins to the fruit (docs/harvest.md,
"From the pin to the fruit").

A clearance impact is a force pulse of a fraction of a millisecond: its energy lies in the kHz range.  The fruit
is shaken by the comb's swing (the drive speed and its harmonics, a few Hz) through the fingers, the branch and the
pedicel, a chain of low-pass elements (the pedicel alone: a mass-spring of natural frequency
f_p = sqrt(k / m0) / (2 pi), about 12 Hz on the reference plant; docs/plant.md).  Splitting each signal of a coupled
drive-past at a cutoff f_c between the two ranges,

    x(t) - mean(x) = x_shaking(t) + x_impact(t),   x_impact = high-pass_{f_c}(x),

shows what reaches each link: the impact band's RMS (the part the clearances make) and its share of the signal's
fluctuation, impact_rms^2 / (shaking_rms^2 + impact_rms^2).  The high-pass is a 4th-order Butterworth filter run
forward and backward (zero phase, 8th-order magnitude response; scipy.signal.sosfiltfilt) over the whole run, and
the statistics are taken while the branch is inside the comb, away from the run's ends.  The two bands are
orthogonal to within the filter's transition band, so their mean squares add up to the fluctuation's (tested).

References
----------
Butterworth, S. (1930).  On the theory of filter amplifiers.  Wireless Engineer 7, 536-541.
Gustafsson, F. (1996).  Determining the initial states in forward-backward filtering.  IEEE Transactions on Signal
Processing 44(4), 988-992 (scipy.signal.filtfilt's edge handling).
"""

from __future__ import annotations

import numpy as np

from berryshaker.harvest.fruit_force import FruitForceResult

#: cutoff between the shaking band (drive harmonics, branch modes, the pedicel's resonance) and the impact band of
#: the clearance contacts (Hz) [assumed]: 50 harmonics of the reference drive's 2 Hz, 8x the pedicel's 12 Hz, a
#: tenth of the kHz range the steel impacts excite
IMPACT_BAND_HZ = 100.0
#: order of the Butterworth high-pass (run twice: forward and backward)
FILTER_ORDER = 4


def band_split(x: np.ndarray, dt: float, cutoff_hz: float = IMPACT_BAND_HZ) -> tuple[np.ndarray, np.ndarray]:
    """Split a uniformly sampled signal's fluctuation into its shaking band (below ``cutoff_hz``) and its impact
    band (above), ``x - mean(x) = low + high``.

    Parameters
    ----------
    x : numpy.ndarray
        The signal at uniform steps (any unit).
    dt : float
        Sampling step (s).
    cutoff_hz : float
        Cutoff frequency (Hz), below the Nyquist frequency 1 / (2 dt).

    Returns
    -------
    low, high : numpy.ndarray
        The shaking band and the impact band (unit of ``x``); ``high`` is the zero-phase Butterworth high-pass of
        order :data:`FILTER_ORDER` (module docstring), ``low`` the rest of the fluctuation.

    Raises
    ------
    ValueError
        ``cutoff_hz`` not between 0 and the Nyquist frequency, or fewer samples than the filter needs.
    """
    x = np.asarray(x, float)
    nyquist = 0.5 / dt
    if not 0.0 < cutoff_hz < nyquist:
        raise ValueError(f"cutoff_hz = {cutoff_hz:g} Hz must lie between 0 and the Nyquist frequency {nyquist:g} Hz")
    from scipy import signal  # here, not at the top: importing scipy.signal takes ~1 s a warm study never needs
    sos = signal.butter(FILTER_ORDER, cutoff_hz, btype="highpass", fs=1.0 / dt, output="sos")
    centred = x - x.mean()
    high = signal.sosfiltfilt(sos, centred)
    return centred - high, high


def _row(x: np.ndarray, dt: float, sel: np.ndarray, unit: str, cutoff_hz: float) -> dict:
    low, high = band_split(x, dt, cutoff_hz)
    low = low[sel] - low[sel].mean()
    high = high[sel]
    ms_low, ms_high = float(np.mean(low**2)), float(np.mean(high**2))
    total = ms_low + ms_high
    return {"unit": unit, "shaking_band_rms": ms_low**0.5, "impact_band_rms": ms_high**0.5,
            "impact_share": ms_high / total if total > 0 else 0.0}


def impact_transmission(result: FruitForceResult, cutoff_hz: float = IMPACT_BAND_HZ) -> dict[str, dict]:
    """The shaking and impact bands of each link of a coupled drive-past, from the pins to the fruit, while the
    branch is inside the comb (module docstring).

    Parameters
    ----------
    result : FruitForceResult
        A drive-past (:func:`berryshaker.harvest.coupled.simulate_fruit_force`).
    cutoff_hz : float
        Cutoff between the bands (Hz).

    Returns
    -------
    dict
        In chain order, per link: ``unit``, ``shaking_band_rms`` and ``impact_band_rms`` (in ``unit``) and
        ``impact_share`` (the impact band's share of the mean-square fluctuation, 0..1).  Links: ``pin <pair>``
        (each clearance pair's collision force, N), ``fingers`` (the comb-branch contact force on the branch, both
        combs, N), ``branch at <fruit>`` (the branch's lateral acceleration at the fruit, m/s^2) and ``stem
        <fruit>`` (the stem force the bond resists, N).
    """
    res = result.result
    plant, spec = result.machine.plant, res.compiled.spec.plant
    if plant is None or spec is None:
        raise ValueError("impact_transmission needs a coupled drive-past (a run with a plant)")
    dt = float(result.t[1] - result.t[0])
    sel = np.abs(result.distance) <= spec.half_span
    names = res.compiled.frc_names
    out = {}
    for pair in result.machine.pair_names:
        if pair in names:
            out[f"pin {pair}"] = _row(res.elements[:, names.index(pair), 0], dt, sel, "N", cutoff_hz)
    out["fingers"] = _row(np.sum(list(result.contact_force.values()), axis=0), dt, sel, "N", cutoff_hz)
    m0 = plant.fruit.mass
    for name, f in result.rigid_force.items():
        out[f"branch at {name}"] = _row(f / m0, dt, sel, "m/s^2", cutoff_hz)
    for name, f in result.fruit_force.items():
        out[f"stem {name}"] = _row(f, dt, sel, "N", cutoff_hz)
    return out


__all__ = ["FILTER_ORDER", "IMPACT_BAND_HZ", "band_split", "impact_transmission"]
