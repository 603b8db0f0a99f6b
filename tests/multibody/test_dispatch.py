"""The engine's direct calls of compiled specialisations (multibody.dispatch.call_compiled) and the per-run
memos of the sweep path (groove-cam geometry check, geometric contact laws): same results, errors every time."""

from __future__ import annotations

import collections
import enum
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
from berryshaker.multibody import dispatch, engine, kernel
from berryshaker.multibody.dispatch import _type_key, call_compiled


@njit
def _strided_sum(a):
    s = 0.0
    for i in range(a.shape[0]):
        s += a[i]
    return s


@njit
def _row_sums(t, scale):
    a, b = t
    return a.sum() * scale + b[1, 0]


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
    assert (_strided_sum, _type_key((x,))) in dispatch._ENTRY_POINTS
    assert (_strided_sum, _type_key((x[::2],))) in dispatch._ENTRY_POINTS


def test_call_compiled_tuples_and_scalars():
    a = np.ones(3)
    b = np.arange(4.0).reshape(2, 2)  # b[1, 0] = 2
    for _ in range(2):
        # an int scale compiles an int64 specialisation: a key that mixed ints and floats would truncate 2.5
        assert call_compiled(_row_sums, (a, b), 2) == 8.0
        assert call_compiled(_row_sums, (a, b), 2.5) == 9.5
        assert call_compiled(_row_sums, (a, b), np.float32(2.5)) == 9.5
        # a Fortran-ordered b: its [1, 0] element is at another offset than a C array's of the same shape
        assert call_compiled(_row_sums, (a, np.asfortranarray(b)), 1.0) == 5.0


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
    # what numba types apart by more than dtype size or class: structured dtypes of one itemsize, units,
    # named tuples, enum members, array subclasses
    p_t = collections.namedtuple("P", "u v")
    q_t = collections.namedtuple("Q", "u v")

    class Level(enum.IntEnum):
        LOW = 1

    values += [np.zeros(2, [("a", "f8"), ("b", "f8")]), np.zeros(2, [("x", "i8"), ("y", "f8")]),
               np.timedelta64(3, "ms"), np.timedelta64(3, "s"), np.datetime64(3, "D"), p_t(1.0, 2.0),
               q_t(1.0, 2.0), (1.0, 2.0), Level.LOW, np.ma.masked_array([1.0, 2.0], [True, False]),
               np.zeros(2, np.dtype(">f8")), np.zeros((0,)), ()]
    for u, v in itertools.combinations(values, 2):
        ku, kv = _type_key(u), _type_key(v)
        if ku is not None and ku == kv:
            assert typeof(u) == typeof(v), (u, v)
    for unknown in (object(), (1.0, object()), p_t(1.0, 2.0), Level.LOW, np.ma.masked_array([1.0])):
        assert _type_key(unknown) is None


def test_harvester_run_through_entry_points_is_the_dispatchers():
    spec = harvester_mechanism(reference_machine())
    runs = []
    for _ in range(3):
        run = engine.prepare_run(spec, duration=0.02, output_step=1e-3)
        run.info[0] = run.budget
        runs.append(run)

    def args(r):
        return (r.y, r.t_out, r.cm.model, r.state, r.work, r.rtol, r.atol, r.max_step, r.stats_from, r.out_y,
                r.out_e, r.out_lam, r.peaks, r.first, r.info)

    kernel.integrate(*args(runs[0]))
    call_compiled(kernel.integrate, *args(runs[1]))  # the dispatcher, or the entry point if a run came first
    assert (kernel.integrate, _type_key(args(runs[2]))) in dispatch._ENTRY_POINTS
    call_compiled(kernel.integrate, *args(runs[2]))  # the entry point
    for r in runs[1:]:
        for name in ("out_y", "out_e", "out_lam", "peaks", "first", "info"):
            np.testing.assert_array_equal(getattr(runs[0], name), getattr(r, name))


def test_geometry_check_is_remembered_per_geometry_and_fails_every_time():
    m = reference_machine()
    require_buildable(m)  # passes (and is remembered)
    # the same geometry vector with a roller too large for the pitch curve: part of the key, so it is checked
    fat = m.model_copy(update={"cam": m.cam.model_copy(update={"roller_radius": 0.2})})
    require_buildable(fat, allow_undercut=True)  # passes, and must not let the undercut through below
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
    assert len(calls) == 2 and not any(k[0] is plain for k in dispatch._ENTRY_POINTS)


def test_type_key_knows_the_model_record():
    """The model record (a named tuple) is keyed by its class and fields, apart from a plain tuple of the same
    arrays (numba types the two apart), so the engine's calls skip numba's typing of it."""
    from berryshaker.multibody.compiled import compile_mechanism
    from berryshaker.multibody.model import MechanismModel

    model = compile_mechanism(harvester_mechanism(reference_machine())).model
    assert type(model) is MechanismModel and model[13] is model.phi_tab  # index reads keep their old meaning
    key = _type_key(model)
    assert key is not None and key != _type_key(tuple(model))
    assert typeof(model) != typeof(tuple(model))
    other = model._replace(mass=model.mass.astype(np.float32))
    assert _type_key(other) != key and typeof(other) != typeof(model)
    same = model._replace(mass=model.mass * 2.0)
    assert _type_key(same) == key and typeof(same) == typeof(model)
