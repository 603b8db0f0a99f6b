"""A start's harvest post-processing: the bruise probability of its detached fruit (``harvest.bruising.impact_damage``)
at ``calibrate``'s parameter rows: each place on the branch once, gathered for the fruit there, against every fruit
evaluated.

A start's 6,120 fruit sit at 68 places (its nodes); ``impact_damage`` evaluates the probability, elementwise in the fall
height, once per place when the parameters are constant along the branch.  The per-fruit evaluation is the same
function given the positions as a (1, fruit) row, which it evaluates fruit by fruit; each case checks the two are
equal bit for bit, and the ratio after the run says whether the gather keeps paying.

A study reading a start's run from the cache reads the harvest responses the run keeps (``study.runs.start_harvest``)
instead of computing them from its tables; the ratio says whether keeping them pays.
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


@pytest.fixture(scope="module")
def start_output():
    """A replicate start's run output (study.runs.replicate_run's form): three branch classes' stem-load tables
    (seeded load ratios of the tables' shape), its impact peaks, and the harvest responses the run keeps."""
    from berryshaker.harvest.virtual import MASS_FACTORS, Z_GRID
    from berryshaker.study.runs import start_harvest

    m = reference_machine()
    rng = np.random.default_rng(5)
    tables = [rng.random((Z_GRID.size, MASS_FACTORS.size, 15)) for _ in range(3)]
    out = {"envelopes": tables, "impact_peaks_N": {p: rng.random(400) * 1e3 for p in m.pair_names},
           "peak_force_N": {p: 1e3 for p in m.pair_names}}
    out["harvest"] = start_harvest(m.model_dump(mode="json"), m, tables, 5)
    return m, out


@pytest.mark.parametrize("path", ["stored", "computed"])
def test_start_cell(benchmark, start_output, path):
    """A start's responses as a study reads them from its cached run: the harvest responses the run keeps
    (``stored``), against computing them from its tables (``computed``, what a warm study did for every start)."""
    from berryshaker.study.replicate_responses import cells_from_outputs

    m, out = start_output
    given = out if path == "stored" else {k: v for k, v in out.items() if k != "harvest"}
    other = {k: v for k, v in out.items() if k != "harvest"} if path == "stored" else out
    cell = benchmark.pedantic(cells_from_outputs, args=(m, [given], [5]), rounds=10, iterations=1,
                              warmup_rounds=1)[0]
    want = cells_from_outputs(m, [other], [5])[0]
    assert cell.keys() == want.keys()
    assert all(a == b or (np.isnan(a) and np.isnan(b)) for a, b in ((float(cell[k]), float(want[k])) for k in cell))
