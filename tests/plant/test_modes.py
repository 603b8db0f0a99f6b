"""The analytic branch modes' root scan (plant/modes.py): the vectorised determinant equals the scalar one it
replaced, and every user shares one computation of a branch's modes per process."""

from __future__ import annotations

import numpy as np

from berryshaker.config import reference_machine
from berryshaker.plant.branch import Branch
from berryshaker.plant.modes import _det, _dets, analytic_modes, cached_analytic_modes


def _key(scale: float = 1.0) -> tuple:
    b = reference_machine().plant.branch
    return (b.root_diameter * scale, b.tip_diameter * scale, b.length, b.elastic_modulus, b.density,
            b.damping_ratio)


def test_vectorised_scan_equals_the_scalar_determinant():
    for scale in (0.85, 1.0, 1.15):
        br = Branch(*_key(scale))
        grid = np.linspace(0.3, 31.6, 700)
        scalar = np.array([_det(b, br) for b in grid])
        vector = _dets(grid, br)
        assert np.allclose(vector, scalar, rtol=1e-12, atol=1e-14)
        # the scan brackets the roots: the same sign at every point
        assert np.array_equal(np.sign(vector), np.sign(scalar))


def test_modes_are_computed_once_per_branch_and_process():
    key = _key(0.9)
    a = cached_analytic_modes(key, 6)
    assert cached_analytic_modes(key, 6) is a
    ref = analytic_modes(Branch(*key), 6)
    assert np.array_equal(a.omega, ref.omega) and np.array_equal(a.shapes, ref.shapes)
