"""Where numba keeps the package's compiled kernels: one folder per version of the compiled sources.

numba's on-disk cache (``@njit(cache=True)``) checks only the source file of the function it loads: a kernel that
calls a compiled function of *another* file carries that callee's machine code in its own cache entry and keeps
using it after the callee's file changes (numba issue #6845).  The package has such calls
(``multibody.kernel`` -> ``kinematics.cam``, ``multibody.batch.integrate_sets`` -> ``multibody.kernel.integrate``,
``drives.groove_cam.kinematics`` -> ``kinematics.cam`` / ``kinematics.linkage``, ``drives.groove_cam.mlsd`` ->
``drives.groove_cam.kinematics``; tests/test_compiled_cache.py lists them), and a stale entry silently runs the old
code: after the contact-onset step of ``kernel.integrate`` changed, the batched sweep path still ran the old one
from ``integrate_sets``' entry (benchmarks/README.md sec. 21).

So the package points numba at a folder named by a digest of every source file that defines or imports compiled
code (:func:`compiled_sources_digest`): a change to any of them starts an empty folder, and an unchanged package
finds its kernels again.  Base folder: ``$NUMBA_CACHE_DIR`` if set, else ``$BERRYSHAKER_CACHE/numba``, else
``$XDG_CACHE_HOME/berryshaker/numba`` (``~/.cache/berryshaker/numba``); the four most recently used digest folders
are kept, older ones removed when a new one is started.  Stdlib only: it runs when ``berryshaker`` is imported,
before any kernel is decorated.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
from pathlib import Path

#: prefix of the digest folders inside the base folder
FOLDER_PREFIX = "berryshaker-"
#: digest folders kept (most recently used first); older ones are removed when a new one is started
KEEP_FOLDERS = 4


def compiled_sources_digest(root: Path) -> str:
    """sha256 (hex, first 16 digits) over the ``.py`` files under ``root`` that mention numba (relative path and
    content, sorted by path): the sources whose change can change compiled code."""
    h = hashlib.sha256()
    for p in sorted(root.rglob("*.py"), key=lambda q: q.relative_to(root).as_posix()):
        if "__pycache__" in p.parts:
            continue
        data = p.read_bytes()
        if b"numba" in data or b"njit" in data:
            h.update(p.relative_to(root).as_posix().encode() + b"\0" + data + b"\0")
    return h.hexdigest()[:16]


def numba_cache_base() -> Path:
    """The folder holding the digest folders (see the module docstring)."""
    given = os.environ.get("NUMBA_CACHE_DIR")
    if given:
        p = Path(given)
        return p.parent if p.name.startswith(FOLDER_PREFIX) else p  # a parent process pointed it already
    base = os.environ.get("BERRYSHAKER_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME", os.path.expanduser("~/.cache")), "berryshaker")
    return Path(base) / "numba"


def point_numba_cache() -> Path:
    """Point numba's cache at this package version's digest folder (environment variable for numba imported later
    and for child processes; numba's live setting if it is imported already); returns the folder."""
    folder = numba_cache_base() / (FOLDER_PREFIX + compiled_sources_digest(Path(__file__).resolve().parent))
    try:
        new = not folder.exists()
        folder.mkdir(parents=True, exist_ok=True)
        os.utime(folder)  # most recently used
        if new:
            _prune(folder)
    except OSError:
        pass  # not writable: numba falls back to its own locations
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    if "numba" in sys.modules:
        from numba.core import config

        config.CACHE_DIR = str(folder)
    return folder


def _prune(current: Path) -> None:
    """Remove all but the :data:`KEEP_FOLDERS` most recently used digest folders beside ``current``."""
    others = [p for p in current.parent.glob(FOLDER_PREFIX + "*") if p.is_dir() and p != current]
    others.sort(key=lambda p: p.stat().st_mtime, reverse=True)
    for p in others[KEEP_FOLDERS - 1:]:
        shutil.rmtree(p, ignore_errors=True)
