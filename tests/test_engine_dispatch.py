"""The engine's direct calls of compiled specialisations (multibody.engine.call_compiled) and the per-run
memos of the sweep path (groove-cam geometry check, geometric contact laws): same results, errors every time."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from numba import njit, typeof

from berryshaker.config import reference_machine
from berryshaker.contact.laws import law_table
from berryshaker.contact.pair_law import _geometric_contact_law, geometric_contact_law, pair_geometry
from berryshaker.drives.groove_cam.kinematics import require_buildable
from berryshaker.drives.groove_cam.mechanism import harvester_mechanism
from berryshaker.errors import GeometryError
from berryshaker.multibody import engine, kernel
from berryshaker.multibody.engine import _type_key, call_compiled


@njit
def _strided_sum(a):
    s = 0.0
    for i in range(a.shape[0]):
        s += a[i]
    return s


@njit
def _row_sums(t, scale):
    a, b = t
    return a.sum() * scale + b[0, 0]


def test_call_compiled_keeps_layouts_apart():
    # numba addresses a C-layout array from its shape alone: a strided view run by the C specialisation would
    # read the wrong elements, so a key that ignored the layout fails here
    x = np.arange(10.0)
    for _ in range(2):  # first through the dispatcher, then the remembered entry point
        assert call_compiled(_strided_sum, x) == 45.0
        assert call_compiled(_strided_sum, x[::2]) == 20.0
        ro = x.copy()
        ro.flags.writeable = False
        assert call_compiled(_strided_sum, ro) == 45.0
    assert (_strided_sum, _type_key((x,))) in engine._ENTRY_POINTS
    assert (_strided_sum, _type_key((x[::2],))) in engine._ENTRY_POINTS


def test_call_compiled_tuples_and_scalars():
    a, b = np.ones(3), np.full((2, 2), 5.0)
    for scale in (2.0, 2, np.float64(2.0), 2.0, 2):
        assert call_compiled(_row_sums, (a, b), scale) == 11.0
    assert call_compiled(_row_sums, (a, np.asfortranarray(np.full((2, 2), 7.0))), 1.0) == 10.0


def test_type_key_follows_numbas_typing():
    """Equal keys only where numba's typeof is equal (what makes the direct call safe)."""
    base = np.zeros((3, 4))
    law = law_table()[0]
    values = [base, base[:, ::2], np.asfortranarray(base), base.T, base[0], base.astype(np.float32),
              np.zeros(4, np.int64), np.zeros(4, np.bool_), 1.0, 1, True, np.float64(1.0), np.int64(1),
              np.float32(1.0), 2**63, -(2**63), (base, 1.0), (base, base), (base, base[0]), (1.0, 1)]
    ro = np.zeros((3, 4))
    ro.flags.writeable = False
    values.append(ro)
    values += [law, (law, law), (law, law_table()[1])]
    for u, v in itertools.combinations(values, 2):
        ku, kv = _type_key(u), _type_key(v)
        if ku is not None and ku == kv:
            assert typeof(u) == typeof(v), (u, v)
    assert _type_key(object()) is None and _type_key((1.0, object())) is None


def test_harvester_run_through_entry_points_is_the_dispatchers():
    spec = harvester_mechanism(reference_machine())
    runs = []
    for _ in range(2):
        run = engine.prepare_run(spec, duration=0.02, output_step=1e-3)
        run.info[0] = run.budget
        runs.append(run)
    kernel.integrate(runs[0].y, runs[0].t_out, runs[0].cm.model, runs[0].state, runs[0].work, runs[0].rtol,
                     runs[0].atol, runs[0].max_step, runs[0].stats_from, runs[0].out_y, runs[0].out_e,
                     runs[0].out_lam, runs[0].peaks, runs[0].first, runs[0].info)
    r = runs[1]
    for _ in range(2):
        call_compiled(kernel.integrate, r.y.copy(), r.t_out, r.cm.model, r.state, r.work, r.rtol, r.atol, r.max_step,
                      r.stats_from, r.out_y, r.out_e, r.out_lam, r.peaks, r.first, r.info)
    np.testing.assert_array_equal(runs[0].out_y, r.out_y)
    np.testing.assert_array_equal(runs[0].out_e, r.out_e)


def test_geometry_check_is_remembered_per_geometry_and_fails_every_time():
    m = reference_machine()
    require_buildable(m)  # passes (and is remembered)
    # the same geometry vector with a roller too large for the pitch curve: part of the key, so it is checked
    fat = m.model_copy(update={"cam": m.cam.model_copy(update={"roller_radius": 0.2})})
    for _ in range(2):
        with pytest.raises(GeometryError, match="undercuts"):
            require_buildable(fat)
        with pytest.raises(GeometryError, match="undercuts"):
            harvester_mechanism(fat)
    require_buildable(fat, allow_undercut=True)


def test_geometric_contact_law_is_shared_and_equal_to_a_fresh_fit():
    g = pair_geometry("pin-in-bore", 2e-4)
    law = geometric_contact_law(g)
    assert geometric_contact_law(pair_geometry("pin-in-bore", 2e-4)) is law
    assert geometric_contact_law(g, [100.0, 2.0e4]) is law  # a list range is the same range
    assert _geometric_contact_law.__wrapped__(g, (100.0, 2.0e4)) == law  # what a fresh fit gives
    other = geometric_contact_law(pair_geometry("pin-in-bore", 3e-4))
    assert other.fit.stiffness != law.fit.stiffness


def test_call_compiled_passes_plain_functions_through():
    """A function that is not a numba dispatcher (NUMBA_DISABLE_JIT, a timing wrapper) is simply called."""
    calls = []

    def plain(a, b):
        calls.append((a, b))
        return a + b

    for _ in range(2):
        assert call_compiled(plain, 1.0, 2.0) == 3.0
    assert len(calls) == 2 and not any(k[0] is plain for k in engine._ENTRY_POINTS)
