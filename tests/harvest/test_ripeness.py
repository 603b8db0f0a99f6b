"""Ripeness stages (berryshaker.harvest.ripeness): the interpolation rule against hand arithmetic and its published
ends, the stage mix, and the unripe index as the mixture of green, pink and red fruit (the expectation over a stem-load
table made by hand is the share-weighted sum of the pure stages)."""

import math

import numpy as np
import pytest

from berryshaker.config import machine_from_dict, reference_machine
from berryshaker.errors import ConfigError
from berryshaker.harvest.ripeness import STAGES, stage_cvs, stage_fractions, stage_pulls
from berryshaker.harvest.virtual import expected_tally, load_grid, response_values
from berryshaker.harvest.virtual.stem_force_tables import MASS_FACTORS, Z_GRID


def test_stage_pulls_interpolate_between_the_published_neighbours():
    """Green 2.05 N (eq. 17 band's lognormal mean), blue 0.47 N (Kong et al. 2014): pink 2.05^(2/3) 0.47^(1/3) =
    1.255 N, red 2.05^(1/3) 0.47^(2/3) = 0.768 N (hand arithmetic); a stated pull replaces the rule."""
    g, p, r = stage_pulls(0.47, 2.05)
    assert float(g) == 2.05
    assert float(p) == pytest.approx(math.exp((2 * math.log(2.05) + math.log(0.47)) / 3), rel=1e-12)
    assert float(p) == pytest.approx(1.255, abs=1e-3) and float(r) == pytest.approx(0.768, abs=1e-3)
    assert float(p) / float(r) == pytest.approx(float(g) / float(p))  # one ratio per stage
    assert float(stage_pulls(0.47, 2.05, red_pull=0.7)[2]) == 0.7
    cv = stage_cvs(0.24, 0.40)
    assert [float(c) for c in cv] == pytest.approx([0.40, 0.40 - 0.16 / 3, 0.40 - 0.32 / 3])


def test_stage_mix_shares_and_refusal():
    """The shares sum to 1, the unripe share is green + pink + red; a mix not summing to 1 is refused."""
    h = reference_machine().harvest
    f = stage_fractions(h)
    assert list(f) == list(STAGES)
    assert sum(f.values()) == pytest.approx(1.0)
    assert f["green"] + f["pink"] + f["red"] == pytest.approx(h.unripe_fraction)
    d = reference_machine().model_dump(mode="json")
    d["harvest"]["unripe_stage_mix"] = [0.5, 0.5, 0.5]
    with pytest.raises(ConfigError, match="unripe_stage_mix"):
        machine_from_dict(d)


def _with_mix(mix):
    d = reference_machine().model_dump(mode="json")
    d["harvest"]["unripe_stage_mix"] = list(mix)
    return machine_from_dict(d)


def test_the_unripe_index_is_the_mixture_of_the_stages():
    """Unripe shedding is linear in the stage mix: the default mix's is the share-weighted sum of the pure green,
    pink and red ones, and a riper stage sheds more at the same load (its bond is weaker)."""
    z, m = np.meshgrid(Z_GRID, MASS_FACTORS, indexing="ij")
    ripe = 0.3 + 1.4 * z**1.5 * m**0.6
    table = np.stack([0.2 * ripe, ripe, ripe * 0.47 / 2.05], axis=-1)
    shed = {}
    for k, mix in enumerate(((1, 0, 0), (0, 1, 0), (0, 0, 1))):
        mach = _with_mix(mix)
        shed[k] = response_values(expected_tally(mach, load_grid(mach, [table] * 3)))["unripe_shed"]
    assert shed[0] < shed[1] < shed[2]
    mach = reference_machine()
    got = response_values(expected_tally(mach, load_grid(mach, [table] * 3)))["unripe_shed"]
    assert got == pytest.approx(sum(c * shed[k] for k, c in enumerate(mach.harvest.unripe_stage_mix)), rel=1e-9)
