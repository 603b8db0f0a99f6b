"""numba's cache folder follows the compiled sources (berryshaker.compiled_cache).

numba checks only a cached function's own file, so an entry whose kernel calls a compiled function of another file
runs the callee's old code after that file changes.  The package therefore names numba's cache folder by a digest
of every source that mentions numba.  Checked here: the digest moves with a compiled source and not with the rest,
every cached kernel that calls across files has both files in the digest, a child process keeps its parent's folder,
and old folders are pruned.
"""

from __future__ import annotations

import importlib
import os
import pkgutil
import shutil
import subprocess
import sys
import time
import types
from pathlib import Path

import berryshaker
from berryshaker.compiled_cache import FOLDER_PREFIX, KEEP_FOLDERS, compiled_sources_digest

ROOT = Path(berryshaker.__file__).resolve().parent


def _copy_package(tmp_path: Path) -> Path:
    dst = tmp_path / "berryshaker"
    shutil.copytree(ROOT, dst, ignore=shutil.ignore_patterns("__pycache__"))
    return dst


def test_digest_follows_compiled_sources_only(tmp_path):
    pkg = _copy_package(tmp_path)
    d0 = compiled_sources_digest(pkg)
    cli = pkg / "cli" / "app.py"
    assert b"numba" not in cli.read_bytes()
    cli.write_text(cli.read_text() + "\n# an edit that compiles nothing\n")
    assert compiled_sources_digest(pkg) == d0
    cam = pkg / "kinematics" / "cam.py"  # called from multibody.kernel's cached integrator
    cam.write_text(cam.read_text() + "\n# an edit of a compiled callee\n")
    assert compiled_sources_digest(pkg) != d0


def _cross_file_cached_calls() -> set[tuple[str, str]]:
    """(caller module, callee module) of every cached dispatcher calling a dispatcher of another module."""
    from numba.core.registry import CPUDispatcher

    mods = [importlib.import_module(m.name) for m in pkgutil.walk_packages(berryshaker.__path__, "berryshaker.")
            if not m.name.startswith("berryshaker.cli")]
    out = set()
    for mod in mods:
        for obj in vars(mod).values():
            if not (isinstance(obj, CPUDispatcher) and obj.__module__ == mod.__name__
                    and type(obj._cache).__name__ != "NullCache"):
                continue
            code = obj.py_func.__code__
            names = set(code.co_names).union(*(c.co_names for c in code.co_consts if isinstance(c, types.CodeType)))
            for n in names:
                target = obj.py_func.__globals__.get(n)
                found = [target] if isinstance(target, CPUDispatcher) else (
                    [getattr(target, a, None) for a in names] if isinstance(target, types.ModuleType) else [])
                for d in found:
                    if isinstance(d, CPUDispatcher) and d.py_func.__module__ != mod.__name__:
                        out.add((mod.__name__, d.py_func.__module__))
    return out


def test_every_cross_file_cached_call_is_in_the_digest():
    calls = _cross_file_cached_calls()
    # the calls that make the digest necessary (module docstring); the scan must see them, or it checks nothing
    assert ("berryshaker.multibody.batch", "berryshaker.multibody.kernel") in calls
    assert ("berryshaker.multibody.kernel", "berryshaker.kinematics.cam") in calls
    for caller, callee in calls:
        for name in (caller, callee):
            src = Path(sys.modules[name].__file__).read_bytes()
            assert b"numba" in src or b"njit" in src, name


def _folder_in_child(env: dict) -> str:
    code = "import os, berryshaker, numba; print(os.environ['NUMBA_CACHE_DIR'] + '|' + numba.config.CACHE_DIR)"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    a, b = out.stdout.strip().split("|")
    assert a == b
    return a


def test_child_processes_keep_the_folder_and_old_folders_are_pruned(tmp_path):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    stale = []
    for k in range(KEEP_FOLDERS + 2):
        p = tmp_path / f"{FOLDER_PREFIX}{k:016d}"
        p.mkdir()
        t = time.time() - 1000 * (k + 1)
        os.utime(p, (t, t))
        stale.append(p)
    folder = _folder_in_child(env)
    assert Path(folder).parent == tmp_path and Path(folder).name == FOLDER_PREFIX + compiled_sources_digest(ROOT)
    # a worker started with the parent's environment uses the same folder (no folder inside the folder)
    assert _folder_in_child({**os.environ, "NUMBA_CACHE_DIR": folder}) == folder
    kept = [p for p in stale if p.exists()]
    assert kept == stale[:KEEP_FOLDERS - 1]  # the newest ones, with the current folder KEEP_FOLDERS in all
