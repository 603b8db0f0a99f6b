"""Bruising from impacts (berryshaker.harvest.bruising): the lognormal threshold law against its closed form, the
medians read from what the drop tests report (Brown et al. 1996: a safe height is a low fractile, not the median),
the cumulative drop height over the strike and the fall against direct quadrature, and the impact damage's
dependence on the fall and the finger speed."""

import math

import numpy as np
import pytest
from scipy import integrate, stats

from berryshaker.config import load_machine, machine_from_dict
from berryshaker.errors import ConfigError
from berryshaker.harvest.bruising import (
    GRAVITY,
    bruise_medians,
    bruise_probability,
    cumulative_damage,
    finger_speed,
    impact_damage,
    median_height,
)


def test_bruise_probability_is_the_lognormal_threshold_law():
    """P(h) = Phi(ln(h/h50)/sigma), sigma^2 = ln(1 + cv^2): scipy's lognormal CDF with the same median and CV."""
    h = np.array([0.0, 0.05, 0.15, 0.3, 1.0])
    cv = 0.3
    ref = stats.lognorm(s=math.sqrt(math.log1p(cv**2)), scale=0.15).cdf(h)
    np.testing.assert_allclose(bruise_probability(h, 0.15, cv), ref, rtol=1e-12, atol=1e-15)
    assert bruise_probability(0.15, 0.15, cv) == pytest.approx(0.5)


def test_a_safe_height_is_a_low_fractile_not_the_median():
    """h_50 = h_p exp(-z_p sigma): at the safe height the law gives back the stated fractile; Brown's cushioned 1.2 m
    at 5 % and cv 0.3 is a median of 1.2 exp(1.6449 x 0.29356) = 1.945 m (hand arithmetic)."""
    cv = 0.3
    h50 = float(median_height(1.2, 0.05, cv))
    assert h50 == pytest.approx(1.2 * math.exp(1.6448536 * math.sqrt(math.log1p(0.09))), rel=1e-6)
    assert h50 == pytest.approx(1.945, abs=1e-3)
    assert bruise_probability(1.2, h50, cv) == pytest.approx(0.05, rel=1e-9)
    assert float(median_height(0.15, 0.5, cv)) == pytest.approx(0.15)


def test_the_reference_thresholds_say_what_the_drop_tests_say():
    """Brown et al. 1996: extensive bruising above 150 mm onto a hard surface (half the fruit there, above 99 % at
    twice it), cushioning that prevented bruising up to 0.6-1.2 m (5 % at 1.2 m, under 0.1 % at 0.6 m)."""
    h = load_machine(None).harvest
    hard, padded = bruise_medians(h)
    assert bruise_probability(0.15, hard, h.bruise_cv) == pytest.approx(0.5)
    assert bruise_probability(0.3, hard, h.bruise_cv) > 0.99
    assert bruise_probability(1.2, padded, h.bruise_cv) == pytest.approx(0.05)
    assert bruise_probability(0.6, padded, h.bruise_cv) < 1e-3


def test_the_cumulative_drop_height_against_quadrature():
    """Struck fruit: E_phi P(h_f + r h_max cos^2 phi), phi uniform, against scipy.integrate.quad; the impacts add up
    (two impacts each below the median bruise more than half the fruit when together above it); no strike is the
    fall alone."""
    cv, c50, hard50, h_max, fall = 0.3, 1.9, 0.15, 0.12, 0.8
    sig = math.sqrt(math.log1p(cv * cv))
    f = lambda phi: stats.norm.cdf(math.log((fall + c50 / hard50 * h_max * math.cos(phi) ** 2) / c50) / sig)  # noqa: E731
    ref = integrate.quad(f, 0.0, math.pi / 2, epsabs=1e-12)[0] / (math.pi / 2)
    assert float(cumulative_damage(fall, h_max, c50, hard50, cv, 1.0)) == pytest.approx(ref, abs=1e-6)
    p_fall = float(bruise_probability(fall, c50, cv))
    assert float(cumulative_damage(fall, h_max, c50, hard50, cv, 0.3)) == pytest.approx(0.3 * ref + 0.7 * p_fall)
    assert float(cumulative_damage(fall, h_max, c50, hard50, cv, 0.0)) == pytest.approx(
        float(bruise_probability(fall, c50, cv)))
    # adding up: a strike at 0.6 of the hard median plus a fall at 0.6 of the padded one, struck at the peak
    both = float(bruise_probability(0.6 * c50 + c50 / hard50 * 0.6 * hard50, c50, cv))
    assert both > 0.5 > float(bruise_probability(0.6 * c50, c50, cv))


def test_impact_damage_grows_with_the_fall_and_with_the_finger_speed():
    """Fruit higher on the branch fall farther (more bruising); a faster drive strikes harder (finger speed omega
    A_f, proportional to the drive speed); a hard catcher bruises more than a padded one; every fruit struck is more
    than half of them."""
    m = load_machine(None)
    z = np.linspace(0.1, 0.95, 9)
    p = impact_damage(m, z)
    assert np.all(np.diff(p) > 0) and 0 <= p[0] < p[-1] < 1
    assert finger_speed(m) == pytest.approx(m.drive_speed * 0.0743169, rel=1e-3)  # 74.3 mm finger amplitude
    d = m.model_dump()
    d["cam"]["speed"] *= 2.5
    fast = machine_from_dict(d)
    assert np.all(impact_damage(fast, z) > p)
    d = m.model_dump()
    d["harvest"]["catcher_surface"] = "hard"
    assert np.all(impact_damage(machine_from_dict(d), z) >= p)
    d = m.model_dump()
    d["harvest"]["strike_probability"] = 1.0
    assert np.all(impact_damage(machine_from_dict(d), z) > p)
    # the former bound (every fruit struck at the fingers' peak speed) is above the phase-averaged strike
    h = m.harvest
    hard, padded = bruise_medians(h)
    v = finger_speed(m)
    fall = z * m.plant.branch.length
    bound = bruise_probability(fall + padded / hard * v * v / (2 * GRAVITY), padded, h.bruise_cv)
    assert np.all(impact_damage(machine_from_dict(d), z) < bound)


def test_the_former_median_heights_are_refused_naming_their_replacement():
    """A description with bruise_height_padded (a median) is refused with the field that replaces it."""
    d = load_machine(None).model_dump(mode="json")
    d["harvest"]["bruise_height_padded"] = 1.2
    with pytest.raises(ConfigError, match="safe_drop_height_padded"):
        machine_from_dict(d)


@pytest.mark.parametrize("surface", ["padded", "hard"])
def test_impact_damage_of_fruit_sharing_places_is_the_full_evaluation_bit_for_bit(surface):
    """A start's fruit sit at a few dozen places: impact_damage evaluates each place once and gathers, giving the
    numbers of cumulative_damage evaluated at every fruit (bit for bit), for one parameter row and for rows of
    (n, 1) parameters; an array along z is evaluated fruit by fruit."""
    d = load_machine(None).model_dump()
    d["harvest"]["catcher_surface"] = surface
    m = machine_from_dict(d)
    h = m.harvest
    rng = np.random.default_rng(3)
    z = rng.choice(np.linspace(0.05, 0.95, 17), size=500)
    hard, _ = bruise_medians(h)
    v = finger_speed(m)
    c50 = np.array([[0.05], [0.12], [0.3]])
    sp = np.array([[0.0], [0.4], [1.0]])
    hard_h50 = c50 if surface == "hard" else hard
    fall = h.catcher_drop + z * m.plant.branch.length
    f, c, hh = np.broadcast_arrays(fall, c50, hard_h50)
    full = cumulative_damage(f, v * v / (2 * GRAVITY), c, hh, h.bruise_cv, sp)
    got = impact_damage(m, z, c50, sp)
    assert got.shape == (3, 500) and np.array_equal(got, full)
    one = impact_damage(m, z)
    assert one.shape == (500,) and np.array_equal(one, impact_damage(m, z[:, None])[:, 0])
    along = rng.uniform(0.05, 0.3, size=z.shape)  # a threshold per fruit: no places shared
    assert np.array_equal(impact_damage(m, z, along)[:10], [impact_damage(m, z[i], along[i]) for i in range(10)])
