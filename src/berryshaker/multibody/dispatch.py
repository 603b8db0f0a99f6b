"""Calling the compiled core from Python without numba's typing of the arguments at every call.

numba's dispatcher types every argument at every call, in Python for tuples: the kernel's model, state and work
tuples (~30 arrays) cost ~0.2 ms per call, against ~15 us for the call itself.
:func:`call_compiled` calls the specialisation a function used for the same argument types directly, keyed by
:func:`_type_key`, which follows numba's own typing rules (tests/multibody/test_dispatch.py).
"""

from __future__ import annotations

import numpy as np
from numba import typeof

from berryshaker.contact.laws import LawEntryPoint
from berryshaker.multibody.model import MechanismModel


def _type_key(x):
    """What numba's ``typeof`` makes of ``x``, as a hashable key, or None where this function does not know.

    Exact types only (a subclass, another named tuple or an enum member gets None): a plain ``ndarray`` by its
    dtype (fields and units included), dimensions, layout (C, F or any, numba's ``map_layout``), read-only and
    aligned flags; a plain tuple by its elements' keys, the model record
    (:class:`~berryshaker.multibody.model.MechanismModel`) by its class and its fields' keys; a Python or numpy
    scalar by its type and numba's own type of it (cheap for a scalar; ints by value range, datetimes by unit); a
    contact law's entry point by its class (typed by the one law signature,
    :class:`~berryshaker.contact.laws.LawEntryPoint`).  Equal keys give equal numba
    types (tests/multibody/test_dispatch.py), which is what makes :func:`call_compiled`'s direct call safe.
    """
    t = type(x)
    if t is np.ndarray:
        f = x.flags
        layout = "C" if f.c_contiguous else "F" if f.f_contiguous else "A"
        return ("array", x.dtype, x.ndim, layout, f.writeable, f.aligned)
    if t is tuple or t is MechanismModel:
        keys = tuple(_type_key(e) for e in x)
        return None if any(k is None for k in keys) else (t, keys)
    if t in (bool, int, float) or isinstance(x, np.generic):
        try:
            return ("scalar", t, typeof(x))
        except (TypeError, ValueError):  # numba cannot type it: leave it to the dispatcher's error
            return None
    if t is LawEntryPoint:
        return t
    return None


#: compiled entry points of kernel functions by (function, :func:`_type_key` of the arguments), see
#: :func:`call_compiled`
_ENTRY_POINTS: dict = {}


def call_compiled(fn, *args):
    """``fn(*args)`` for a numba-compiled kernel function, without numba's typing of the arguments after the
    first call with the same argument types in this process.

    numba's dispatcher types every argument at every call, in Python for tuples: the kernel's model, state and
    work tuples (~30 arrays) cost ~0.2 ms per call, against ~15 us for the call itself; a
    harvester run made two such calls, a perturbed start one per continuation step.  The first call
    goes through the dispatcher (which compiles or loads the specialisation); the specialisation it used is then
    called directly for arguments of the same :func:`_type_key`, which follows numba's own typing rules, so the
    same compiled code runs on the same arguments.  Arguments whose types the key does not cover always go
    through the dispatcher, and so does everything when ``fn`` is not a dispatcher (``NUMBA_DISABLE_JIT``).
    A function recompiled after its first call (``fn.recompile()``, nothing in berryshaker does) keeps its old
    entry point here.

    Parameters
    ----------
    fn : numba dispatcher
        A compiled function of the core.
    *args : object
        Its arguments (arrays in SI, as the function takes them).

    Returns
    -------
    object
        What ``fn`` returns.
    """
    key = _type_key(args)
    entry = _ENTRY_POINTS.get((fn, key)) if key is not None else None
    if entry is not None:
        return entry(*args)
    out = fn(*args)
    overloads = getattr(fn, "overloads", None)  # None: not a dispatcher (NUMBA_DISABLE_JIT, a wrapper)
    if key is not None and overloads is not None:
        compiled = overloads.get(tuple(typeof(a) for a in args))
        entry = getattr(compiled, "entry_point", None)  # (numba internals: without them, the dispatcher every time)
        if entry is not None:  # an exact match (a call converted to another signature is not remembered)
            _ENTRY_POINTS[(fn, key)] = entry
    return out
