"""Bruising from impacts (berryshaker.harvest.bruising): the lognormal threshold law against its closed form and the
drop tests it comes from (Brown et al. 1996), and the impact damage's dependence on the fall and the finger speed."""

import math

import numpy as np
import pytest
from scipy import stats

from berryshaker.config import load_machine, machine_from_dict
from berryshaker.harvest.bruising import bruise_probability, finger_speed, impact_damage


def test_bruise_probability_is_the_lognormal_threshold_law():
    """P(h) = Phi(ln(h/h50)/sigma), sigma^2 = ln(1 + cv^2): scipy's lognormal CDF with the same median and CV."""
    h = np.array([0.0, 0.05, 0.15, 0.3, 1.0])
    cv = 0.3
    ref = stats.lognorm(s=math.sqrt(math.log1p(cv**2)), scale=0.15).cdf(h)
    np.testing.assert_allclose(bruise_probability(h, 0.15, cv), ref, rtol=1e-12, atol=1e-15)
    assert bruise_probability(0.15, 0.15, cv) == pytest.approx(0.5)


def test_the_reference_thresholds_say_what_the_drop_tests_say():
    """Brown et al. 1996: extensive bruising above 150 mm onto a hard surface, none up to 0.6-1.2 m onto the
    cushioning found.  With the description's medians and CV: hard below 1 % at 75 mm and above 99 % at 0.3 m;
    padded below 1 % at 0.6 m."""
    h = load_machine(None).harvest
    assert bruise_probability(0.075, h.bruise_height_hard, h.bruise_cv) < 0.01
    assert bruise_probability(0.3, h.bruise_height_hard, h.bruise_cv) > 0.99
    assert bruise_probability(0.6, h.bruise_height_padded, h.bruise_cv) < 0.01


def test_impact_damage_grows_with_the_fall_and_with_the_finger_speed():
    """Fruit higher on the branch fall farther (more bruising); a faster drive strikes harder (finger speed omega
    A_f, proportional to the drive speed); a hard catcher bruises more than a padded one."""
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
