"""The bruise probability of a start's detached fruit (``harvest.bruising.impact_damage``) at ``calibrate``'s parameter
rows: each place on the branch once, gathered for the fruit there, against every fruit evaluated.

A start's 6,120 fruit sit at 68 places (its nodes); ``impact_damage`` evaluates the probability, elementwise in the fall
height, once per place when the parameters are constant along the branch.  The per-fruit evaluation is the same
function given the positions as a (1, fruit) row, which it evaluates fruit by fruit; each case checks the two are
equal bit for bit, and the ratio after the run says whether the gather keeps paying.
"""

from __future__ import annotations

import numpy as np
import pytest

from berryshaker.config import reference_machine
from berryshaker.harvest.bruising import impact_damage

PLACES, FRUIT_PER_PLACE, ROWS = 68, 90, 12


@pytest.fixture(scope="module")
def case():
    m = reference_machine()
    z = np.repeat(np.linspace(0.05, 0.95, PLACES), FRUIT_PER_PLACE)
    rng = np.random.default_rng(0)
    c50 = rng.uniform(0.05, 0.3, size=(ROWS, 1))  # m: the catcher's median threshold per parameter row
    sp = rng.uniform(0.0, 1.0, size=(ROWS, 1))  # the finger's strike share per row
    return m, z, c50, sp


@pytest.mark.parametrize("path", ["places", "per-fruit"])
def test_impact_damage(benchmark, case, path):
    m, z, c50, sp = case
    zz = z if path == "places" else z[None, :]
    other = z[None, :] if path == "places" else z
    out = benchmark.pedantic(impact_damage, args=(m, zz, c50, sp), rounds=10, iterations=1, warmup_rounds=1)
    assert out.shape == (ROWS, len(z)) and np.array_equal(out, impact_damage(m, other, c50, sp))
    benchmark.extra_info.update(fruit=len(z), places=PLACES, rows=ROWS)
