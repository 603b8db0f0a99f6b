"""The impact band's path from the pins to the fruit (berryshaker.harvest.transmission): the band split against a
closed form, and the filtering the report states, at every cutoff a reader might choose."""

from __future__ import annotations

import numpy as np
import pytest

from berryshaker.config import reference_machine
from berryshaker.harvest.coupled import simulate_fruit_force
from berryshaker.harvest.transmission import IMPACT_BAND_HZ, band_split, impact_transmission


def test_band_split_of_two_tones_is_their_amplitudes():
    """x = 3 + 2 sin(2 pi 5 t) + 0.5 sin(2 pi 1000 t): the shaking band's RMS is 2 / sqrt 2, the impact band's
    0.5 / sqrt 2 (a Butterworth high-pass at 100 Hz passes 1 kHz and stops 5 Hz to 1e-8 in magnitude), and the
    two bands sum to the fluctuation."""
    dt = 2e-5
    t = np.arange(0.0, 1.2, dt)
    x = 3.0 + 2.0 * np.sin(2 * np.pi * 5 * t) + 0.5 * np.sin(2 * np.pi * 1000 * t)
    low, high = band_split(x, dt)
    inner = slice(5000, 55000)  # 0.1-1.1 s: whole periods of both tones, away from the run's ends
    assert np.sqrt(np.mean(low[inner] ** 2)) == pytest.approx(2.0 / np.sqrt(2), rel=1e-3)
    assert np.sqrt(np.mean(high[inner] ** 2)) == pytest.approx(0.5 / np.sqrt(2), rel=1e-3)
    np.testing.assert_allclose(low + high, x - x.mean(), atol=1e-12)


def test_band_split_refuses_a_cutoff_above_nyquist():
    with pytest.raises(ValueError, match="Nyquist"):
        band_split(np.zeros(100), 1e-3, cutoff_hz=600.0)


@pytest.fixture(scope="module")
def drive_past():
    m = reference_machine()
    return simulate_fruit_force(m, {"A": 0.75e-3, "B": 0.6e-3, "C": 0.2e-3, "F": 0.2e-3})


@pytest.mark.parametrize("cutoff", [IMPACT_BAND_HZ / 2, IMPACT_BAND_HZ, 2 * IMPACT_BAND_HZ])
def test_the_impacts_are_filtered_between_the_pins_and_the_fruit(drive_past, cutoff):
    """At the largest clearances of the study's levels the impact band is most of every pin's force fluctuation,
    a few per cent of the fingers' force on the branch and far below one per cent of any stem force; the
    statement holds at half and twice the default cutoff."""
    tr = impact_transmission(drive_past, cutoff)
    pins = [v["impact_share"] for k, v in tr.items() if k.startswith("pin ")]
    stems = [v["impact_share"] for k, v in tr.items() if k.startswith("stem ")]
    assert len(pins) == 4 and len(stems) == 3
    assert min(pins) > 0.5
    assert tr["fingers"]["impact_share"] < 0.1 < min(pins)
    assert max(stems) < min(0.01, tr["fingers"]["impact_share"])
    for v in tr.values():
        assert v["shaking_band_rms"] > 0 and v["impact_band_rms"] > 0


def test_the_report_states_the_filtering_it_measured():
    """The fruit-force section's table and sentence read the level sets' records (level set 1 -> 3)."""
    from types import SimpleNamespace

    from berryshaker.study.fruit_force_records import BandLevels
    from berryshaker.study.steps.fruit_force import transmission_parts

    def past(pin, fingers, stem):
        return SimpleNamespace(transmission={
            "pin A": BandLevels("N", 400.0, 800.0, pin), "fingers": BandLevels("N", 2.0, 0.3, fingers),
            "stem end": BandLevels("N", 0.06, 0.0007, stem)})

    ff = SimpleNamespace(level_rows=[14, 15, 16], rows={"14": past(0.75, 0.014, 1e-4), "16": past(0.86, 0.021, 1.3e-4)})
    html = "".join(transmission_parts(ff))
    assert "are 86 % of the pins' force fluctuation at level set 3, 2.1 % of the fingers'" in html
    assert "at most 0.013 % of a stem force" in html
    assert "75 → 86" in html
    ff.rows.pop("16")
    assert transmission_parts(ff) == []
