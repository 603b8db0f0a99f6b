"""Mechanism-specialised integrators: the constraint equations and the multiplier solve written out for one
mechanism's structure, compiled once per structure and cached on disk.

The generic kernel (:mod:`berryshaker.multibody.kernel`) serves every mechanism with one compiled integrator: its
constraint loop and multiplier solve follow index arrays (``ctype``, ``cint``, ``crow`` and the solve plan of
:func:`berryshaker.multibody.sparsity.solve_plan`).  In a right-hand side those index loads sit on the chain of
dependent operations that bounds each stage: a hand-written slider-crank
right-hand side with the same arithmetic ran the step 38 % faster.  This module writes that code for any
mechanism, from the structure alone:

* ``constraints``: per constraint block, :func:`~berryshaker.multibody.constraint_rows.block_start` and the block
  type's ``constraint_rows.*_rows`` function with its rows and bodies as literals (the generic loop of
  ``constraint_rows.constraints`` calls the same functions: one home for the formulas);
* ``_constrained_solve``: the driven bodies' substitution, the Schur complement's structurally nonzero entries,
  its L D L^T factorisation over each row's envelope, the driven rows' multipliers and Phi_q^T lambda, in the
  same operations and order as the generic :func:`~berryshaker.multibody.linear_solve._constrained_solve` (so the
  results are bitwise those of the generic kernel; tests/multibody/test_specialised.py), with every index a
  literal and every entry of W a local variable;
* the right-hand side ``dynamics.accelerations`` and everything on the integrator's path that calls it
  (:data:`GENERIC_SOURCES`: the loop ``kernel.integrate_resumable``, which alone evaluates it, and
  ``kernel.integrate``): the generic kernel's own source, compiled in the generated module so that they call the
  two functions above; every other name they use is imported from its generic module (the constraint projection after a step stays generic).  The generator refuses to
  write a module in which a generic function it imports would reach the generic constraints or solve
  (:func:`_check_generic_sources`), so a new caller of ``accelerations`` cannot leave the specialised kernel
  quietly running the generic one.

Every sum of the solve is emitted as a sequence of statements, one term each, in the generic loops' order (no
expression nests deeper than one term, whatever the structure's size).

The values (masses, lengths, stiffnesses, speeds) stay arguments: every mechanism of one structure (a clearance
sweep, a tolerance study, perturbed starts) shares one compiled integrator.  The source is written to
``<numba cache>/specialised/`` (the package's digest folder, :mod:`berryshaker.compiled_cache`, so an update of
the package starts afresh) and numba caches its compiled code beside the package's; a structure costs about
10-20 s of compilation once per machine and about 0.1 s to load after that.  Asked
for with ``[simulation] specialised = true``, ``simulate_mechanism(..., specialised=True)`` or by ``berryshaker
sweep`` when a sweep has the runs to pay for it; a run left to choose (the default) takes it once this machine has
compiled it (:func:`is_compiled`, :func:`berryshaker.multibody.engine.integrator`), so no run waits for a
compilation it did not ask for.
"""

from __future__ import annotations

import hashlib
import importlib.util
import inspect
import os
import sys
import tempfile
import types
from pathlib import Path

import numpy as np

from berryshaker.multibody import constraint_rows, dynamics, kernel, linear_solve
from berryshaker.multibody.layout import CON_CAM_ROLLER, CON_DRIVER, CON_POINT_LINE, CON_PRISMATIC, CON_REVOLUTE
from berryshaker.multibody.model import MechanismModel

#: the generated module's format; part of every structure key, so a change of the generator starts new files
GENERATOR_VERSION = 4
#: the generic functions compiled again in the generated module (their source as it is): every function of the
#: integrator's path that calls ``accelerations`` (and so the constraint rows and the solve), callers after callees
GENERIC_SOURCES = (dynamics.accelerations, kernel.integrate_resumable, kernel.integrate)
#: the generic functions that call the constraint rows or the solve and stay generic in the generated module: the
#: projection after a step (specialising it cost 3.8 s more compilation for little)
GENERIC_KEPT = (dynamics.project,)

_LOADED: dict[str, object] = {}


def structure_key(model: MechanismModel, n: int) -> str:
    """Digest (hex, 16 digits) of what the generated code depends on: the constraint types, bodies and rows, the
    solve plan, the number of coordinates and the generator's version (not any value).

    Parameters
    ----------
    model : MechanismModel
        A compiled mechanism's model record (:mod:`berryshaker.multibody.model`).
    n : int
        Number of coordinates.

    Returns
    -------
    str
        The digest (16 hex digits).
    """
    ctype, cint, crow, plan = model.ctype, model.cint, model.crow, model.plan
    h = hashlib.sha256(f"v{GENERATOR_VERSION};n{int(n)};".encode())
    for a in (ctype, cint, crow, plan):
        a = np.ascontiguousarray(a, dtype=np.int64)
        h.update(repr(a.shape).encode() + a.tobytes())
    return h.hexdigest()[:16]


def _constraints_source(ctype, cint, crow, m: int) -> list[str]:
    lines = ["@njit(cache=True, _nrt=False, inline=\"always\")",
             "def constraints(t, q, qd, ctype, cint, cflt, crow, cams, psi_mem, phi, jac, nu, gam):",
             "    \"\"\"constraint_rows.constraints with this structure's blocks as literals.\"\"\""]
    nc = len(ctype)
    for k in range(nc):
        r, r_end = int(crow[k]), (int(crow[k + 1]) if k + 1 < nc else m)
        bi, bj, typ = int(cint[k, 0]), int(cint[k, 1]), int(ctype[k])
        i64 = "np.int64"
        lines.append(f"    block_start({i64}({r}), {i64}({r_end}), {i64}({bi}), {i64}({bj}), jac, nu, gam)")
        if typ == CON_REVOLUTE:
            call = f"revolute_rows({i64}({k}), {i64}({r}), {i64}({bi}), {i64}({bj}), q, qd, cflt, phi, jac, nu, gam)"
        elif typ in (CON_PRISMATIC, CON_POINT_LINE):
            call = (f"line_rows({i64}({k}), {i64}({typ}), {i64}({r}), {i64}({bi}), {i64}({bj}), q, qd, cflt, phi, "
                    "jac, nu, gam)")
        elif typ == CON_CAM_ROLLER:
            call = (f"cam_roller_rows({i64}({k}), {i64}({r}), {i64}({bi}), {i64}({bj}), q, qd, cint, cflt, cams, "
                    "psi_mem, phi, jac, nu, gam)")
        elif typ == CON_DRIVER:
            call = f"driver_rows({i64}({k}), {i64}({r}), {i64}({bi}), t, q, cflt, phi, jac, nu)"
        else:
            raise ValueError(f"constraint block {k}: unknown constraint type {typ}")
        lines.append("    " + call)
    if nc == 0:
        lines.append("    pass")
    return lines


def _solve_source(cint, crow, plan, m: int) -> list[str]:
    """The generic ``linear_solve._constrained_solve`` (with ``_row_dot_at``, ``_schur``, ``_spd_solve`` and
    ``_add_jac_t``) unrolled for one plan: the same floating-point operations in the same order."""
    nc = len(crow)
    ne = int(plan[0, 3]) if m > 0 else 0
    driven = [tuple(int(v) for v in plan[e, :3]) for e in range(m + ne, plan.shape[0])]
    blocks = [(int(crow[k]), int(crow[k + 1]) if k + 1 < nc else m, int(cint[k, 0]), int(cint[k, 1]))
              for k in range(nc)]
    L = ["@njit(cache=True, _nrt=False, inline=\"always\")",
         "def _constrained_solve(plan, mass, inertia, cint, crow, jac, minv, W, rhs, u, off, g, lam, m):",
         "    \"\"\"linear_solve._constrained_solve unrolled for this structure (same operations, same order).\"\"\""]
    if m == 0:
        return L + ["    return"]
    # driven bodies: accelerations by substitution; the residuals u - x kept for their multipliers
    for b, r, d in driven:
        cj = 3 * b
        L += [f"    x2_{b} = g[{d}]",
              f"    x0_{b} = (g[{r}] - jac[{r}, {cj + 2}] * x2_{b}) * jac[{r}, {cj}]",
              f"    x1_{b} = (g[{r + 1}] - jac[{r + 1}, {cj + 2}] * x2_{b}) * jac[{r + 1}, {cj + 1}]",
              f"    e0_{b} = u[off + {cj}] - x0_{b}",
              f"    e1_{b} = u[off + {cj + 1}] - x1_{b}",
              f"    e2_{b} = u[off + {cj + 2}] - x2_{b}",
              f"    u[off + {cj}] = x0_{b}",
              f"    u[off + {cj + 1}] = x1_{b}",
              f"    u[off + {cj + 2}] = x2_{b}"]

    # every sum is a sequence of statements (x = x + term), as the generic loops accumulate: the same operations
    # in the same order, and no expression nests deeper than one term (Python's parser limits nesting)
    for r0, r1, bi, bj in blocks:
        bodies = ([bi] if bi >= 0 else []) + ([bj] if bj >= 0 and bj != bi else [])  # as linear_solve._row_dot_at
        for a in range(r0, r1):
            L.append(f"    b_{a} = 0.0")
            for body in bodies:
                c = 3 * body
                L.append(f"    b_{a} = b_{a} + (jac[{a}, {c}] * u[off + {c}] + jac[{a}, {c + 1}] * u[off + {c + 1}] "
                         f"+ jac[{a}, {c + 2}] * u[off + {c + 2}])")
            L.append(f"    b_{a} = b_{a} - g[{a}]")
    # Schur complement: structurally nonzero entries of the upper triangle (linear_solve._schur)
    wnz = set()
    for e in range(m, m + ne):
        a, b, b1, b2 = (int(v) for v in plan[e])
        wnz.add((a, b))
        if b1 == -2:
            L.append(f"    W_{a}_{b} = 1.0")
            continue
        L.append(f"    W_{a}_{b} = 0.0")
        for body in (b1, b2):
            if body >= 0:
                i = 3 * body
                L.append(f"    W_{a}_{b} = W_{a}_{b} + (jac[{a}, {i}] * minv[{i}] * jac[{b}, {i}] + jac[{a}, {i + 1}] "
                         f"* minv[{i + 1}] * jac[{b}, {i + 1}] + jac[{a}, {i + 2}] * minv[{i + 2}] * jac[{b}, {i + 2}])")

    def w_upper(j, i):
        return f"W_{j}_{i}" if (j, i) in wnz else "0.0"

    # L D L^T row by row over the envelopes, forward substitution per row, then back substitution
    # (linear_solve._spd_solve; L_i_k holds c_ik, then L_ik; D_i = 1 / d_i)
    for i in range(m):
        lo = int(plan[i, 0])
        for j in range(lo, i):
            L.append(f"    L_{i}_{j} = {w_upper(j, i)}")
            for k in range(max(lo, int(plan[j, 0])), j):
                L.append(f"    L_{i}_{j} = L_{i}_{j} - L_{i}_{k} * L_{j}_{k}")
        L.append(f"    d_{i} = {w_upper(i, i)}")
        for k in range(lo, i):
            L += [f"    c_{i}_{k} = L_{i}_{k}",
                  f"    L_{i}_{k} = c_{i}_{k} * D_{k}",
                  f"    d_{i} = d_{i} - c_{i}_{k} * L_{i}_{k}"]
        L += [f"    if d_{i} <= 0.0:", f"        d_{i} = 1e-300", f"    D_{i} = 1.0 / d_{i}"]
        L += [f"    b_{i} = b_{i} - L_{i}_{k} * b_{k}" for k in range(lo, i)]
    for i in range(m - 1, -1, -1):
        L.append(f"    b_{i} = b_{i} * D_{i}")
        L += [f"    b_{i} = b_{i} - L_{k}_{i} * b_{k}" for k in range(i + 1, int(plan[i, 1]) + 1)
              if int(plan[k, 0]) <= i]
    # the driven rows' multipliers from the driven bodies' equations of motion
    for b, r, d in driven:
        cj = 3 * b
        L += [f"    t0_{b} = mass[{b}] * e0_{b}", f"    t1_{b} = mass[{b}] * e1_{b}",
              f"    t2_{b} = inertia[{b}] * e2_{b}"]
        for r0, r1, bi, bj in blocks:
            if bi != b and bj != b:
                continue
            for a in range(r0, r1):
                if int(plan[a, 2]) == 0:
                    L += [f"    t{i}_{b} = t{i}_{b} - jac[{a}, {cj + i}] * b_{a}" for i in range(3)]
        L += [f"    b_{r} = t0_{b} * jac[{r}, {cj}]",
              f"    b_{r + 1} = t1_{b} * jac[{r + 1}, {cj + 1}]",
              f"    b_{d} = t2_{b} - jac[{r}, {cj + 2}] * b_{r} - jac[{r + 1}, {cj + 2}] * b_{r + 1}"]
    # x = u - M^-1 Phi_q^T lambda over the other bodies (linear_solve._add_jac_t; a driven body keeps its x from the
    # substitution, which the generic code writes back over its update)
    gone = {b for b, _, _ in driven}
    nb = 0
    for _, _, bi, bj in blocks:
        nb = max(nb, bi + 1, bj + 1)
    for b in range(nb):
        rows = [a for r0, r1, bi, bj in blocks if b in (bi, bj) for a in range(r0, r1)]
        if b in gone or not rows:
            continue
        c = 3 * b
        L += [f"    o_{c + i} = u[off + {c + i}]" for i in range(3)]
        for a in rows:
            L += [f"    o_{c + i} = o_{c + i} + minv[{c + i}] * jac[{a}, {c + i}] * (-1.0 * b_{a})" for i in range(3)]
        L += [f"    u[off + {c + i}] = o_{c + i}" for i in range(3)]
    L += [f"    lam[{a}] = b_{a}" for a in range(m)]
    return L


def specialised_integrator(model: MechanismModel, n: int, m: int):
    """The integrator (``kernel.integrate``'s signature and results) specialised to ``model``'s structure:
    generated and imported on first use in a process, loaded from the disk cache after the first compilation
    on this machine.

    Parameters
    ----------
    model : MechanismModel
        A compiled mechanism's model record (:attr:`berryshaker.multibody.compiled.CompiledMechanism.model`).
    n, m : int
        Its coordinates and constraint rows.

    Returns
    -------
    numba dispatcher
        Called exactly like :func:`berryshaker.multibody.kernel.integrate`.
    """
    return specialised_module(model, n, m).integrate


def specialised_module(model: MechanismModel, n: int, m: int):
    """The generated module of ``model``'s structure (its functions ``constraints``, ``_constrained_solve`` and
    those of :data:`GENERIC_SOURCES`), written to :func:`source_folder` if missing or different and imported once
    per process.

    Parameters
    ----------
    model : MechanismModel
        A compiled mechanism's model record (:mod:`berryshaker.multibody.model`).
    n : int
        Number of coordinates.
    m : int
        Number of constraint rows.

    Returns
    -------
    module
        The imported generated module.
    """
    key = structure_key(model, n)
    mod = _LOADED.get(key)
    if mod is None:
        path = write_source(source_folder() / f"bs_specialised_{key}.py", specialised_source(model, n, m))
        name = f"berryshaker_specialised_{key}"
        spec = importlib.util.spec_from_file_location(name, path)
        if spec is None or spec.loader is None:
            raise ImportError(f"cannot import the generated kernel {path}")
        mod = importlib.util.module_from_spec(spec)
        sys.modules[name] = mod
        try:
            spec.loader.exec_module(mod)
        except BaseException:
            del sys.modules[name]  # no half-built module left behind
            raise
        _LOADED[key] = mod
    return mod


def is_compiled(model: MechanismModel, n: int) -> bool:
    """True when this machine has compiled the structure's specialised kernel with this package version, numba
    version and CPU (a run with it finished its first call and numba saved it: :func:`mark_compiled`), so running
    it costs a load from numba's cache (~0.1 s), not a compilation.  ~15 us (the structure's digest and a file's
    existence); False where no private folder can hold the generated sources (:func:`source_folder`).

    Parameters
    ----------
    model : MechanismModel
        A compiled mechanism's model record (:mod:`berryshaker.multibody.model`).
    n : int
        Number of coordinates.

    Returns
    -------
    bool
        Whether it is compiled here.
    """
    try:
        return _compiled_marker(model, n).is_file()
    except OSError:
        return False


def mark_compiled(model: MechanismModel, n: int, integrate=None) -> None:
    """Record that the structure's specialised kernel compiled and numba cached it on this machine: an empty
    ``bs_specialised_<key>.<target>.compiled`` beside the generated source, ``<target>`` a digest of numba's
    version and the CPU's name and features (numba's cache entries depend on both, so a numba update or a cache
    folder shared by other CPUs finds no marker rather than a wrong one).  Written after the first call returned,
    not with the source, so that a process starting while another one compiles does not take it for compiled;
    and, given the ``integrate`` dispatcher, only when numba's index file for it exists (numba may fail to save).
    A folder that cannot be written is no error: the kernel is then just not picked by default.

    Parameters
    ----------
    model : MechanismModel
        A compiled mechanism's model record (:mod:`berryshaker.multibody.model`).
    n : int
        Number of coordinates.
    integrate : numba dispatcher
        The specialised integrator that ran.
    """
    try:
        path = _compiled_marker(model, n)
    except OSError:  # no private folder for it: the kernel is then just not picked by default
        return
    if path.is_file():
        return
    cache_file = getattr(getattr(integrate, "_cache", None), "_cache_file", None)
    index = getattr(cache_file, "_index_path", None)  # numba's internals: when absent, trust the finished call
    if index is not None and not Path(index).is_file():
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)  # the module may have been written elsewhere
        path.touch()
    except OSError:
        pass


def _compiled_marker(model: MechanismModel, n: int) -> Path:
    return source_folder() / f"bs_specialised_{structure_key(model, n)}.{_target_digest()}.compiled"


_TARGET: list[str] = []


def _target_digest() -> str:
    """Digest of what numba's cache entries depend on beyond the source: numba's version, the CPU's name and
    features (llvmlite; ~1 ms once per process)."""
    if not _TARGET:
        import llvmlite.binding as llvm
        import numba

        text = f"{numba.__version__}|{llvm.get_host_cpu_name()}|{llvm.get_host_cpu_features().flatten()}"
        _TARGET.append(hashlib.sha256(text.encode()).hexdigest()[:12])
    return _TARGET[0]


def source_folder() -> Path:
    """Where the generated sources go: ``specialised-<digest>/`` in numba's cache folder, the digest that of the
    package's compiled sources (:func:`berryshaker.compiled_cache.compiled_sources_digest`): the generated code
    calls the kernel's functions, so a changed kernel must not find an old module's machine code (numba checks
    only the generated file).  Without a numba cache folder, the per-user temporary one, used only when it is
    private (:func:`berryshaker.compiled_cache.private_folder`: created 0700, owned by this user, not writable by
    others; generated sources are imported, so a folder someone else made first is refused with
    :class:`~berryshaker.compiled_cache.UnsafeCacheFolder`, an ``OSError``: callers then run the generic kernel).

    Returns
    -------
    Path
        The folder (created).
    """
    from berryshaker.compiled_cache import compiled_sources_digest, private_folder, temp_cache_home

    base = os.environ.get("NUMBA_CACHE_DIR")
    name = f"specialised-{_package_digest(compiled_sources_digest)}"
    if base:
        return Path(base) / name
    top = temp_cache_home()
    return private_folder(top / name, top)


_DIGEST: list[str] = []


def _package_digest(digest_of) -> str:
    if not _DIGEST:
        _DIGEST.append(digest_of(Path(kernel.__file__).resolve().parents[1]))
    return _DIGEST[0]


def write_source(path: Path, source: str) -> Path:
    """Write ``source`` to ``path`` unless it already holds exactly that (a file left half-written or changed by
    hand is replaced); atomically, so that a process importing it concurrently reads all of it or none.

    Parameters
    ----------
    path : Path
        The file.
    source : str
        Its text.

    Returns
    -------
    Path
        ``path``.
    """
    try:
        if path.read_text() == source:
            return path
    except (OSError, UnicodeDecodeError):
        pass
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)  # unique per thread too
    try:
        with os.fdopen(fd, "w") as f:
            f.write(source)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _global_names(code: types.CodeType) -> list[str]:
    names = list(code.co_names)
    for c in code.co_consts:
        if isinstance(c, types.CodeType):
            names += _global_names(c)
    return names


def _globals_used(fn) -> dict[str, object]:
    """The module-level objects a compiled function's source names (its module's globals it reads)."""
    g = fn.py_func.__globals__
    return {name: g[name] for name in _global_names(fn.py_func.__code__) if name in g}


def _among(obj, objs: tuple) -> bool:
    return any(obj is o for o in objs)


def _reaches(fn, targets: tuple, seen: set) -> bool:
    """True when the compiled function ``fn`` calls one of ``targets``, directly or through other compiled
    functions."""
    if _among(fn, targets):
        return True
    if id(fn) in seen or not hasattr(fn, "py_func"):
        return False
    seen.add(id(fn))
    return any(_reaches(obj, targets, seen) for obj in _globals_used(fn).values() if hasattr(obj, "py_func"))


def _check_generic_sources() -> None:
    """Refuse to generate a module in which a function of :data:`GENERIC_SOURCES` would call, through a generic
    function it imports (other than :data:`GENERIC_KEPT`), the generic constraint rows or solve: that function must
    be in :data:`GENERIC_SOURCES` too."""
    targets = (constraint_rows.constraints, linear_solve._constrained_solve)
    for fn in GENERIC_SOURCES:
        for name, obj in _globals_used(fn).items():
            if _among(obj, targets + GENERIC_SOURCES + GENERIC_KEPT) or not hasattr(obj, "py_func"):
                continue  # (the generated module's own constraint rows and solve, its other copies, the kept)
            if _reaches(obj, targets, set()):
                raise RuntimeError(f"specialised kernels: {fn.py_func.__name__} calls {name}, which reaches the generic "
                                   "constraint rows or solve; add it to GENERIC_SOURCES (or GENERIC_KEPT)")


def _imports(defined: set[str]) -> list[str]:
    """Import lines for what the functions of :data:`GENERIC_SOURCES` use, each name from the module of the
    function that uses it (the names the generated module defines itself excepted)."""
    found: dict[str, tuple[str, object]] = {}
    for fn in GENERIC_SOURCES:
        for name, obj in _globals_used(fn).items():
            if name in defined:
                continue
            if inspect.ismodule(obj):
                home = obj.__name__
            else:  # a compiled function from its own module, a constant from the module that uses it
                home = getattr(getattr(obj, "py_func", None), "__module__", None) or fn.py_func.__module__
            if name in found and found[name][1] is not obj:
                raise RuntimeError(f"specialised kernels: {name!r} means two things in the generic sources")
            found[name] = (home, obj)
    modules = sorted(f"import {home}" if home == name else f"import {home} as {name}"
                     for name, (home, obj) in found.items() if inspect.ismodule(obj))
    by_home: dict[str, list[str]] = {}
    for name, (home, obj) in found.items():
        if not inspect.ismodule(obj):
            by_home.setdefault(home, []).append(name)
    lines = list(modules)
    for home, names in sorted(by_home.items()):
        line = f"from {home} import ("
        for i, name in enumerate(sorted(names)):
            item = name + (", " if i + 1 < len(names) else ")")
            if len(line) + len(item.rstrip()) > 116:
                lines.append(line.rstrip())
                line = " " * 4
            line += item
        lines.append(line)
    return lines


def specialised_source(model: MechanismModel, n: int, m: int) -> str:
    """The Python source of the specialised module for ``model`` (a compiled mechanism's model record) with ``n``
    coordinates and ``m`` constraint rows.

    Parameters
    ----------
    model : MechanismModel
        A compiled mechanism's model record (:mod:`berryshaker.multibody.model`).
    n : int
        Number of coordinates.
    m : int
        Number of constraint rows.

    Returns
    -------
    str
        The module's source.
    """
    _check_generic_sources()
    ctype, cint, crow, plan = (np.asarray(a) for a in (model.ctype, model.cint, model.crow, model.plan))
    defined = {"constraints", "_constrained_solve"} | {fn.py_func.__name__ for fn in GENERIC_SOURCES}
    head = [f'"""Generated by berryshaker.multibody.specialised (structure {structure_key(model, n)}, generator '
            f'{GENERATOR_VERSION}); do not edit: it is rewritten when it differs."""',
            "import numpy as np",
            "from numba import njit",
            "from berryshaker.multibody.constraint_rows import (block_start, cam_roller_rows, driver_rows, line_rows,",
            "                                                   revolute_rows)"]
    head += _imports(defined | {"np", "njit"}) + ["", ""]
    body = _constraints_source(ctype, cint, crow, m) + ["", ""] + _solve_source(cint, crow, plan, m)
    generic = []
    for fn in GENERIC_SOURCES:
        generic += ["", ""] + inspect.getsource(fn.py_func).rstrip("\n").split("\n")
    return "\n".join(head + body + generic) + "\n"
