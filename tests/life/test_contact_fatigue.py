"""Contact pressure, endurance and rolling-bearing life (berryshaker.life.contact_fatigue) against closed forms and
published numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from berryshaker.errors import ConfigError
from berryshaker.life.contact_fatigue import (
    ISO281_FATIGUE_STRESS,
    basic_rating_life,
    clearance_at_pressure,
    contact_pressure,
    pair_modulus,
    reliability_factor,
    rolling_equivalent_load,
    shakedown_pressure,
)


def test_roller_on_flat_is_hertz_line_contact():
    """Johnson (1985) eq. 4.43-4.45 by the half-width: b = sqrt(4 F R / (pi L E*)), p0 = 2 F / (pi b L).  The
    issue's estimate: a 9.3 kN impact on a 30 x 15 mm steel roller is about 1.2 GPa."""
    es = pair_modulus("steel-steel-lubricated")
    assert es == pytest.approx(1 / (2 * (1 - 0.3**2) / 207e9))
    f, d, length = 9300.0, 0.030, 0.015
    b = math.sqrt(4 * f * (d / 2) / (math.pi * length * es))
    assert contact_pressure(f, False, d, length, 0.0, es) == pytest.approx(2 * f / (math.pi * b * length))
    assert 1.1e9 < contact_pressure(f, False, d, length, 0.0, es) < 1.3e9


def test_pin_pressure_grows_as_the_bore_wears_and_is_at_least_the_conformal_maximum():
    """A pin in a bore: R' = R1 (R1 + c) / c, so p0 ~ sqrt(c) at small c; never below 4 F / (pi d L), the worn-in
    cosine distribution's maximum."""
    es = pair_modulus("steel-on-bronze-greased")
    f, d, length = 10e3, 0.020, 0.025
    p = [contact_pressure(f, True, d, length, c, es) for c in (0.05e-3, 0.2e-3, 0.8e-3)]
    assert p[0] < p[1] < p[2]
    r1 = d / 2
    for c, pc in zip((0.2e-3, 0.8e-3), p[1:]):
        assert pc == pytest.approx(math.sqrt(f * es * c / (math.pi * length * r1 * (r1 + c))))
    assert contact_pressure(f, True, d, length, 1e-9, es) == pytest.approx(4 * f / (math.pi * d * length))


def test_shakedown_limit_of_hardened_steel_is_iso_281s_fatigue_stress():
    """4 k with k = (H/3)/sqrt(3): 2 GPa steel gives 1.54 GPa, within 3 % of ISO 281's independent 1.5 GPa."""
    assert shakedown_pressure(2.0e9) == pytest.approx(ISO281_FATIGUE_STRESS, rel=0.03)
    assert shakedown_pressure(1.0e9) == pytest.approx(4 / (3 * math.sqrt(3)) * 1e9)


def test_clearance_at_pressure_inverts_the_pin_closed_form():
    """With a constant load the pressure reaches p at c = A R1^2 / (1 - A R1), A = pi L p^2 / (F E*)."""
    es = pair_modulus("steel-on-bronze-greased")
    f, d, length, p = 12e3, 0.020, 0.025, 150e6
    a, r1 = math.pi * length * p**2 / (f * es), d / 2
    c = clearance_at_pressure(p, lambda c: f, True, d, length, es, 1e-5, 1e-3)
    assert c == pytest.approx(a * r1**2 / (1 - a * r1), rel=2e-3)
    assert clearance_at_pressure(5e9, lambda c: f, True, d, length, es, 1e-5, 1e-3) is None


def test_iso_281_life_and_mean_load():
    """L10 = (C/P)^(10/3) 10^6 rev; the mean load of a two-level cycle weighted by revolutions; a1(50 %) = 3.38."""
    assert basic_rating_life(10e3, 2e3) == pytest.approx(5.0 ** (10 / 3))
    assert basic_rating_life(10e3, 2e3, "ball") == pytest.approx(125.0)
    t = np.linspace(0.0, 2.0, 200001)
    f = np.where(t < 1.0, 1000.0, 3000.0)
    v = np.where(t < 1.0, 1.0, 3.0)  # three times the revolutions at the higher load
    pm, rev_h = rolling_equivalent_load(t, f, v, 0.03)
    p = 10 / 3
    assert pm == pytest.approx(((1000.0**p * 1 + 3000.0**p * 3) / 4) ** (1 / p), rel=1e-3)
    assert rev_h == pytest.approx(4.0 / (math.pi * 0.03) / 2.0 * 3600.0, rel=1e-3)
    assert reliability_factor(0.9) == pytest.approx(1.0) and reliability_factor(0.5) == pytest.approx(3.38, abs=0.01)
    with pytest.raises(ConfigError, match="kind"):
        basic_rating_life(1.0, 1.0, "needle")
