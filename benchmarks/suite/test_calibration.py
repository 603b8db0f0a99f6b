"""The calibration's emulator at the sampler's inputs: every response at (walkers x an L9 sheet's 9 settings).

``calibrate``'s sampler evaluates the likelihood thousands of times, each at every walker and every sheet setting
(``posterior.log_likelihood``); at the simulated settings the emulator's per-setting GPs are stacked and evaluated
in one batch (``Emulator.predict_grid``, ``GPStack``) instead of a call per setting and GP (``Emulator.predict`` on the
tiled rows).  Both are timed here on the same emulator and inputs, and each case checks that the two agree, so the
stacking keeps its place only while the ratio printed after the run shows it paying.

The emulator is trained on smooth synthetic responses (no coupled runs: what is timed is the GP evaluation, whose
cost does not depend on the values), 48 Latin-hypercube points per setting as ``calibrate``'s default.
"""

from __future__ import annotations

import numpy as np
import pytest

from berryshaker.experiment.designs import orthogonal_array
from berryshaker.study import field_calibration as fc
from berryshaker.study.field_calibration.priors import calibrated_responses
from berryshaker.study.field_calibration.sheet import FactorTarget

WALKERS = 20  # half of calibrate's default ensemble: emcee evaluates one half of it per move
LEVELS_M = (1e-4, 2e-4, 3e-4)


@pytest.fixture(scope="module")
def trained():
    targets = [FactorTarget(p, "clearance", p, "mm", 1e-3, LEVELS_M) for p in "ABCF"]
    settings = [tuple(LEVELS_M[i] for i in row) for row in orthogonal_array("L9")]
    responses = list(calibrated_responses())
    u = fc.latin_hypercube(48, 1)
    rng = np.random.default_rng(0)
    s = (np.array(settings) - 2e-4) / 1e-4  # coded -1 .. 1
    w_u, w_s = rng.normal(size=(u.shape[1], len(responses))), rng.normal(size=(4, len(responses)))
    phase = (s @ w_s)[:, None, :] + (u @ w_u)[None, :, :]  # (settings, points, responses)
    mean = 10.0 + 4.0 * np.sin(phase)
    sd = 1.0 + 0.3 * np.cos(phase)
    csd = 0.5 + 0.1 * np.sin(2 * phase)
    em = fc.Emulator(targets, responses, 0, 8)
    em.fit(settings, u, mean, sd, csd)
    walkers = fc.latin_hypercube(WALKERS, 7)
    return em, np.array(settings), walkers, responses


def _per_setting(em, settings, walkers, responses):
    n, k = len(walkers), len(settings)
    xx, uu = np.tile(settings, (n, 1)), np.repeat(walkers, k, axis=0)
    return [tuple(a.reshape(n, k) for a in em.predict(xx, uu, r)) for r in responses]


def _stacked(em, settings, walkers, responses):
    return [em.predict_grid(settings, walkers, r) for r in responses]


@pytest.mark.parametrize("path", ["stacked", "per-setting"])
def test_emulator_at_walkers(benchmark, trained, path):
    em, settings, walkers, responses = trained
    run = {"stacked": _stacked, "per-setting": _per_setting}[path]
    ref = (_per_setting if path == "stacked" else _stacked)(em, settings, walkers, responses)
    out = benchmark.pedantic(run, args=(em, settings, walkers, responses), rounds=50, iterations=5,
                             warmup_rounds=1)
    for got, want in zip(out, ref):
        for a, b in zip(got, want):
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)
    benchmark.extra_info.update(walkers=WALKERS, settings=len(settings), responses=len(responses))
