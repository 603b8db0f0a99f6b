"""The integrator's contact-episode log and the sizing loads read from it (berryshaker.multibody.impacts): the log
against the same run's finely written series (an independent path: the dense output's samples, not the steps'
trapezoid), the statistics against closed forms."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from berryshaker.multibody.engine import simulate_mechanism
from berryshaker.multibody.impacts import ContactEpisodes, fatigue_equivalent_load, impact_loads, static_equivalent_load
from berryshaker.multibody.spec import load_mechanism

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "slider_crank_clearance.toml"


def _episodes_from_series(r, name):
    """Onset time, peak and trapezoid impulse of every episode in the written series that opens in the window."""
    k = r.compiled.frc_names.index(name)
    f, on, t = np.abs(r.elements[:, k, 0]), r.elements[:, k, 1] > 0, r.t
    out = []
    for a in range(1, t.size):
        if on[a] and not on[a - 1] and t[a] >= r.stats_from:
            b = a
            while b < t.size and on[b]:
                b += 1
            if b == t.size:  # still open at the end: not logged
                break
            out.append((t[a], f[a - 1:b + 1].max(), np.trapezoid(f[a - 1:b + 1], t[a - 1:b + 1])))
    return np.array(out)


def test_the_episode_log_is_the_written_series_episodes():
    """The slider-crank's clearance joint over two crank revolutions after the first, written every 1 us (about 50
    samples per impact): every logged episode is one in the series, its peak within 0.1 % (the log has the steps'
    interior peaks, the series its samples) and its impulse within 0.5 % (the log's trapezoid over ~10 steps per
    impact against one over 1 us samples); onsets agree to the sample spacing."""
    r = simulate_mechanism(load_mechanism(EXAMPLE), duration=0.036, output_step=1e-6)
    ep = r.contact_episodes("rod_slider")
    ref = _episodes_from_series(r, "rod_slider")
    assert ep.lost == 0 and len(ep.peak_N) == len(ref) >= 10
    assert np.max(np.abs(ep.onset_s - ref[:, 0])) < 2e-6
    assert np.max(np.abs(ep.peak_N / ref[:, 1] - 1)) < 1e-3
    assert np.max(np.abs(ep.impulse_Ns / ref[:, 2] - 1)) < 5e-3
    assert np.all(ep.duration_s > 0) and np.all(ep.speed_m_s > 0)
    # the log changes no step: the run's overall peak is the largest episode's (all in the window here)
    assert r.peaks[r.compiled.frc_names.index("rod_slider")] == pytest.approx(ep.peak_N.max(), rel=1e-12)


def _train(peaks, speeds=None, window=2.0):
    peaks = np.asarray(peaks, float)
    speeds = np.full(peaks.size, 0.1) if speeds is None else np.asarray(speeds, float)
    z = np.zeros(peaks.size)
    return ContactEpisodes(z, speeds, peaks, peaks * 1e-4, z + 1e-4, window)


def test_sizing_loads_of_an_impact_train_by_closed_forms():
    """A two-level train: 90 impacts of 1 kN and 10 of 5 kN in 2 s, and 50 slow closings (a pin settling, below
    the impact speed) that do not count.  p95 = 5 kN (order statistics), the fatigue-equivalent load
    (0.9 x 1^3 + 0.1 x 5^3)^(1/3) kN, the spectrum 90 / 10 impacts per 2 s in the 1-2 kN and 5-10 kN bands."""
    peaks = [1000.0] * 90 + [5000.0] * 10 + [20000.0] * 50
    speeds = [0.1] * 100 + [1e-4] * 50
    il = impact_loads([_train(peaks, speeds)])
    assert il.impacts == 100 and il.rate_per_s == pytest.approx(50.0)
    assert il.static_equivalent_N == pytest.approx(np.quantile([1000.0] * 90 + [5000.0] * 10, 0.95))
    assert il.fatigue_equivalent_N == pytest.approx(1000.0 * (0.9 + 0.1 * 125) ** (1 / 3))
    assert il.extreme_N == 5000.0 and il.peak_N["p50"] == 1000.0
    levels = [10.0, 20.0, 50.0, 100.0, 200.0, 500.0, 1000.0, 2000.0, 5000.0, 10000.0]
    per_h = dict(zip(levels, il.spectrum_per_h))
    assert per_h[1000.0] == pytest.approx(90 * 1800.0) and per_h[5000.0] == pytest.approx(10 * 1800.0)
    assert sum(il.spectrum_per_h) == pytest.approx(100 * 1800.0)


def test_pooled_runs_count_every_impact_once_and_empty_runs_are_nan():
    """Two runs pool into one distribution over their summed window; a run without impacts gives NaN loads."""
    a, b = _train([1000.0] * 10, window=1.0), _train([3000.0] * 10, window=1.0)
    il = impact_loads([a, b])
    assert il.impacts == 20 and il.window_s == 2.0 and il.rate_per_s == 10.0
    assert il.fatigue_equivalent_N == pytest.approx(fatigue_equivalent_load([1000.0] * 10 + [3000.0] * 10))
    none = impact_loads([_train([])])
    assert none.impacts == 0 and np.isnan(none.static_equivalent_N) and np.isnan(static_equivalent_load([]))


def test_the_log_changes_no_step(monkeypatch):
    """The episode log's extra interior-peak evaluations leave the state alone: a run without the log (``first``
    of N_FIRST columns) takes the same steps and writes the same samples, peaks and first contacts."""
    import berryshaker.multibody.layout as L

    spec = load_mechanism(EXAMPLE)
    with_log = simulate_mechanism(spec, duration=0.036)
    monkeypatch.setattr(L, "first_columns", lambda window: L.N_FIRST)
    without = simulate_mechanism(spec, duration=0.036)
    assert without.first.shape[1] == L.N_FIRST < with_log.first.shape[1]
    assert np.array_equal(with_log.info[:3], without.info[:3]) and np.array_equal(with_log.y, without.y)
    assert np.array_equal(with_log.peaks, without.peaks)
    assert np.array_equal(with_log.first[:, :L.N_FIRST], without.first)
    assert len(without.contact_episodes("rod_slider").peak_N) == 0
