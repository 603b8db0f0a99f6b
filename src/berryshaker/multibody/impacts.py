"""Sizing loads of a clearance joint from its impacts: each contact episode of a run (the integrator's episode
log, :func:`berryshaker.multibody.contact_events.record_contacts`) with its peak force and impulse, and the
statistics a designer sizes from (docs/life.md, "Sizing loads").

A run's single largest force is the extreme of a chaotic signal: it moved by +15 % under a tighter solver
tolerance and by -11 % with more bush modes on the reference harvester.  The statistics here are over the run's
*impacts* (episodes that close at >= :data:`~berryshaker.multibody.contact_events.IMPACT_COUNT_SPEED`, the
engine's impact count: slower closings are a pin settling into its bore, whose number moves with the tolerance):

* the distribution of each impact's peak force and impulse over the run: median, p95, p99;
* the **static-equivalent load** :func:`static_equivalent_load`: the p95 of the impact peaks, the load a
  fraction 0.05 of the impacts exceed (a characteristic value as EN 1990:2002 sec. 4.1.2 defines one, a fractile
  of the load's distribution, applied to the impacts of a run; the single maximum stays beside it, labelled the
  extreme);
* the **fatigue-equivalent load** :func:`fatigue_equivalent_load`: the constant load that, applied once per impact
  at the impact rate, does the same Palmgren-Miner damage as the spectrum, F_eq = (sum F_i^m / N)^(1/m) (the mean
  equivalent load of ISO 281:2007 eq. for a variable load, with its life exponent m = 3 for point contact, 10/3
  for line contact);
* the **load spectrum**: impacts per operating hour per force level (a 1-2-5 series of levels), the counting of
  an impact train: every impact is one load cycle from zero to its peak and back, which is what rainflow counting
  (ASTM E1049-85) gives for a force that returns to zero between peaks.  The fluctuation of a force during a long
  continuous contact (a loaded roller) is not counted as cycles here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from berryshaker.multibody import layout as L
from berryshaker.records import JsonRecord

#: quantiles of the per-impact distributions (median, p95, p99)
QUANTILES = (0.5, 0.95, 0.99)
#: fractile of the impact peaks taken as the static-equivalent load
STATIC_FRACTILE = 0.95
#: life exponent of the fatigue-equivalent load (ISO 281: 3 for point contact, ball bearings)
FATIGUE_EXPONENT = 3.0
#: force levels of the load spectrum (N): a 1-2-5 series from 10 N to 1 MN
SPECTRUM_LEVELS_N = tuple(float(m * 10.0**e) for e in range(1, 6) for m in (1, 2, 5)) + (1e6,)


@dataclass(frozen=True)
class ContactEpisodes:
    """The contact episodes of one element over a run's statistics window (the integrator's log).

    Attributes
    ----------
    onset_s : numpy.ndarray
        Onset time of each episode (s).
    speed_m_s : numpy.ndarray
        Approach speed at the onset (m/s).
    peak_N : numpy.ndarray
        Peak normal force of the episode (N).
    impulse_Ns : numpy.ndarray
        Impulse of the normal force over the episode (N s).
    duration_s : numpy.ndarray
        Duration (s).
    window_s : float
        Length of the statistics window (s).
    lost : int
        Episodes that closed after the log was full (not in the arrays).
    """

    onset_s: np.ndarray
    speed_m_s: np.ndarray
    peak_N: np.ndarray
    impulse_Ns: np.ndarray
    duration_s: np.ndarray
    window_s: float
    lost: int = 0

    def impacts(self, speed: float | None = None) -> "ContactEpisodes":
        """The episodes that are impacts: approach speed at least ``speed``.

        Parameters
        ----------
        speed : float, optional
            Smallest approach speed (m/s); default
            :data:`berryshaker.multibody.contact_events.IMPACT_COUNT_SPEED`.

        Returns
        -------
        ContactEpisodes
            The impacts (same window).
        """
        if speed is None:
            from berryshaker.multibody.contact_events import IMPACT_COUNT_SPEED

            speed = IMPACT_COUNT_SPEED
        sel = self.speed_m_s >= speed
        return ContactEpisodes(self.onset_s[sel], self.speed_m_s[sel], self.peak_N[sel], self.impulse_Ns[sel],
                               self.duration_s[sel], self.window_s, self.lost)


def episodes_from_log(first_row: np.ndarray, window: float) -> ContactEpisodes:
    """Read one element's row of the integrator's ``first`` array (``layout.FIRST_*``, the log from
    ``layout.FIRST_LOG``).

    Parameters
    ----------
    first_row : numpy.ndarray
        The element's row (``layout.FIRST_*``: s, m/s, N, N s; a row of N_FIRST columns has no log: no episodes).
    window : float
        Length of the statistics window (s).

    Returns
    -------
    ContactEpisodes
        Its closed episodes, in order.
    """
    if first_row.shape[0] <= L.FIRST_LOG:
        e = np.zeros(0)
        return ContactEpisodes(e, e, e, e, e, float(window), 0)
    cap = (first_row.shape[0] - L.FIRST_LOG) // L.N_EP
    n = int(first_row[L.FIRST_EP_COUNT])
    log = first_row[L.FIRST_LOG:L.FIRST_LOG + L.N_EP * min(n, cap)].reshape(-1, L.N_EP)
    return ContactEpisodes(log[:, L.EP_T0].copy(), log[:, L.EP_V].copy(), log[:, L.EP_PEAK].copy(),
                           log[:, L.EP_IMPULSE].copy(), log[:, L.EP_DURATION].copy(), float(window),
                           max(0, n - cap))


def static_equivalent_load(peaks: np.ndarray) -> float:
    """Static-equivalent load of an impact train: the :data:`STATIC_FRACTILE` fractile of the impact peaks (N).

    A characteristic load in the sense of EN 1990:2002 sec. 4.1.2 (a stated fractile of the load's distribution),
    here of the distribution of peaks over a run's impacts: a fraction 1 - STATIC_FRACTILE of the impacts exceed
    it.  Quantile: linear interpolation between order statistics (Hyndman and Fan 1996 type 7, numpy's default).

    Parameters
    ----------
    peaks : numpy.ndarray
        Peak force of each impact (N).

    Returns
    -------
    float
        The load (N); NaN without impacts.

    References
    ----------
    EN 1990:2002, *Eurocode: Basis of structural design*, sec. 4.1.2.  R. J. Hyndman and Y. Fan, "Sample quantiles
    in statistical packages", *Am. Stat.* 50 (1996) 361-365.
    """
    peaks = np.asarray(peaks, float)
    return float(np.quantile(peaks, STATIC_FRACTILE)) if peaks.size else float("nan")


def fatigue_equivalent_load(peaks: np.ndarray, exponent: float = FATIGUE_EXPONENT) -> float:
    """Fatigue-equivalent load of an impact train (N): F_eq = (sum_i F_i^m / N)^(1/m).

    The constant force that, repeated once per impact, gives the same Palmgren-Miner damage as the impacts' peaks
    F_i under a load-life law N_f ∝ F^-m: ISO 281:2007's mean equivalent load of a variable load (sec. 7.3,
    P_m = (sum P_i^p N_i / sum N_i)^(1/p)), with its exponent p = 3 for point contact (10/3 line contact).

    Parameters
    ----------
    peaks : numpy.ndarray
        Peak force of each impact (N).
    exponent : float
        Load-life exponent m (dimensionless).

    Returns
    -------
    float
        F_eq (N); NaN without impacts.

    References
    ----------
    ISO 281:2007, *Rolling bearings: Dynamic load ratings and rating life*.  M. A. Miner, "Cumulative damage in
    fatigue", *J. Appl. Mech.* 12 (1945) A159-A164.
    """
    peaks = np.asarray(peaks, float)
    if not peaks.size:
        return float("nan")
    return float(np.mean(peaks**exponent) ** (1.0 / exponent))


@dataclass(frozen=True)
class ImpactLoads(JsonRecord):
    """The sizing loads of one joint from its impacts over one or more runs (module docstring).

    Attributes
    ----------
    impacts : int
        Impacts counted (approach speed >= IMPACT_COUNT_SPEED).
    window_s : float
        Statistics window they came from (s, summed over the runs).
    rate_per_s : float
        Impacts per second of operation (1/s).
    peak_N : dict
        Quantiles of the impact peaks: ``p50``, ``p95``, ``p99`` (N).
    impulse_Ns : dict
        Quantiles of the impact impulses: ``p50``, ``p95``, ``p99`` (N s).
    static_equivalent_N : float
        :func:`static_equivalent_load` (N).
    fatigue_equivalent_N : float
        :func:`fatigue_equivalent_load` (N).
    extreme_N : float
        The largest impact peak: the extreme of the runs, not a design load (N).
    spectrum_per_h : list of float
        Impacts per operating hour with a peak in each band of :data:`SPECTRUM_LEVELS_N` (1/h; one fewer entries
        than levels).
    lost : int
        Episodes beyond the integrator's log (not counted; 0 in a sound run).
    """

    impacts: int
    window_s: float
    rate_per_s: float
    peak_N: dict[str, float]
    impulse_Ns: dict[str, float]
    static_equivalent_N: float
    fatigue_equivalent_N: float
    extreme_N: float
    spectrum_per_h: list[float]
    lost: int = 0


def impact_loads(runs: list[ContactEpisodes]) -> ImpactLoads:
    """The sizing loads of a joint from its episodes in one or more runs (pooled: every impact counts once).

    Parameters
    ----------
    runs : list of ContactEpisodes
        The joint's episodes in each run.

    Returns
    -------
    ImpactLoads
        Counts, rate, quantiles, equivalent loads, extreme and spectrum.
    """
    imp = [r.impacts() for r in runs]
    peaks = np.concatenate([r.peak_N for r in imp]) if imp else np.zeros(0)
    impulses = np.concatenate([r.impulse_Ns for r in imp]) if imp else np.zeros(0)
    window = float(sum(r.window_s for r in runs))
    nan = float("nan")

    def quant(x):
        return {f"p{int(round(100 * q))}": (float(np.quantile(x, q)) if x.size else nan) for q in QUANTILES}

    counts = np.histogram(peaks, bins=np.asarray(SPECTRUM_LEVELS_N))[0] if peaks.size else np.zeros(
        len(SPECTRUM_LEVELS_N) - 1)
    per_h = 3600.0 / window if window > 0 else nan
    return ImpactLoads(int(peaks.size), window, peaks.size / window if window > 0 else nan, quant(peaks),
                       quant(impulses), static_equivalent_load(peaks), fatigue_equivalent_load(peaks),
                       float(peaks.max()) if peaks.size else nan, [float(c * per_h) for c in counts],
                       int(sum(r.lost for r in runs)))
