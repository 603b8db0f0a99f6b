"""Where numba keeps the package's compiled kernels: one folder per version of the compiled sources.

numba's on-disk cache (``@njit(cache=True)``) checks only the source file of the function it loads: a kernel that
calls a compiled function of *another* file carries that callee's machine code in its own cache entry and keeps
using it after the callee's file changes (numba issue #6845).  The package has such calls (``multibody.kernel`` ->
``kinematics.cam`` and ``contact.friction``, ``multibody.batch.integrate_sets`` -> ``multibody.kernel.integrate``,
``drives.groove_cam.kinematics`` -> ``kinematics.cam`` / ``kinematics.linkage``, ``drives.groove_cam.mlsd`` ->
``drives.groove_cam.kinematics`` and ``contact.force_laws``, ...; tests/test_compiled_cache.py finds them), and a
stale entry silently runs the old code: after a change to ``kernel.integrate`` the batched sweep path still ran
the old one from ``integrate_sets``' entry (benchmarks/README.md sec. 21).

So the package points numba at a folder named by a digest of every source file that mentions numba
(:func:`compiled_sources_digest`): a change to any of them starts an empty folder, and an unchanged package finds
its kernels again.  Where:

* base folder: ``$NUMBA_CACHE_DIR/berryshaker`` if the user set ``NUMBA_CACHE_DIR``, else
  ``$BERRYSHAKER_CACHE/numba``, else ``$XDG_CACHE_HOME/berryshaker/numba`` (``~/.cache/berryshaker/numba``);
  if it cannot be created, ``<temp dir>/berryshaker-<uid>/numba``;
* inside it, ``berryshaker-numba-<digest>`` with a marker file; the :data:`KEEP_FOLDERS` most recently used such
  folders are kept and older ones removed when a new one is started.  Only folders with that exact name pattern
  *and* the marker are ever removed, so nothing else in the base folder is touched.

Side effects of ``import berryshaker`` (stdlib only, before any kernel is decorated): the environment variables
``NUMBA_CACHE_DIR`` (the digest folder; child processes and Dask workers started from this one inherit it) and
``BERRYSHAKER_NUMBA_BASE`` (the base, so that a child keeps it), and numba's live ``config.CACHE_DIR`` if numba is
imported already.  Other numba code in the same process then caches into the same folder.  When no folder can be
written, a warning says so and numba falls back to its own locations (where stale entries are possible again).
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

#: name of a digest folder: the prefix and 16 hex digits of the digest
FOLDER_PREFIX = "berryshaker-numba-"
FOLDER_PATTERN = re.compile(r"berryshaker-numba-[0-9a-f]{16}")
#: file written into every digest folder at its creation; a folder without it is never removed
MARKER = "BERRYSHAKER_NUMBA_CACHE"
#: digest folders kept (most recently used first, the current one included)
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
    """The folder holding the digest folders (see the module docstring); absolute."""
    inherited = os.environ.get("BERRYSHAKER_NUMBA_BASE")
    given = os.environ.get("NUMBA_CACHE_DIR")
    if given:
        g = Path(given).expanduser().resolve()
        if inherited and FOLDER_PATTERN.fullmatch(g.name) and g.parent == Path(inherited):
            return g.parent  # pointed by a parent process: keep its base
        return g / "berryshaker"  # the user's (or a test's) own folder
    cache_home = os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache")
    base = os.environ.get("BERRYSHAKER_CACHE") or os.path.join(cache_home, "berryshaker")
    return Path(base).expanduser().resolve() / "numba"


def _prepare(folder: Path) -> bool:
    """Create ``folder`` (with its marker) or mark it used; prune old siblings when it is new.  False if not
    writable."""
    try:
        new = not (folder / MARKER).exists()
        folder.mkdir(parents=True, exist_ok=True)
        (folder / MARKER).touch()  # most recently used
        if new:
            _prune(folder)
        return True
    except OSError:
        return False


def point_numba_cache() -> Path | None:
    """Point numba's cache at this package version's digest folder; returns it (None when nothing is
    writable)."""
    name = FOLDER_PREFIX + compiled_sources_digest(Path(__file__).resolve().parent)
    base = numba_cache_base()
    folder = base / name
    if not _prepare(folder):
        base = Path(tempfile.gettempdir()) / f"berryshaker-{os.getuid() if hasattr(os, 'getuid') else 'user'}" / "numba"
        folder = base / name
        if not _prepare(folder):
            warnings.warn(f"berryshaker: no writable folder for numba's cache ({numba_cache_base()}, {base}); numba "
                          "falls back to its own, where a kernel can keep stale code after an update "
                          "(berryshaker.compiled_cache)", RuntimeWarning, stacklevel=2)
            return None
    os.environ["BERRYSHAKER_NUMBA_BASE"] = str(base)
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    if "numba" in sys.modules:
        from numba.core import config

        config.CACHE_DIR = str(folder)
    return folder


def _prune(current: Path) -> None:
    """Remove all but the :data:`KEEP_FOLDERS` most recently used digest folders beside ``current`` (only folders
    named like one and holding the marker)."""
    others = []
    for p in current.parent.iterdir():
        if p != current and p.is_dir() and FOLDER_PATTERN.fullmatch(p.name) and (p / MARKER).is_file():
            others.append(((p / MARKER).stat().st_mtime, p))
    others.sort(reverse=True)
    for _, p in others[KEEP_FOLDERS - 1:]:
        shutil.rmtree(p, ignore_errors=True)


#: environment variable choosing the multibody kernel of runs left to choose (``simulation.specialised`` unset):
#: "auto" (default: the structure's specialised kernel when this machine has compiled it, else the generic one),
#: "generic" (e.g. to time the generic kernel) or "specialised" (compile every structure run)
KERNEL_ENV = "BERRYSHAKER_KERNEL"
KERNEL_CHOICES = ("auto", "generic", "specialised")


def kernel_choice() -> str:
    """The multibody kernel of runs left to choose, from :data:`KERNEL_ENV`: "auto" (unset or empty), "generic" or
    "specialised" (any case, spaces ignored).

    Raises
    ------
    ConfigError
        Another value, naming the variable and the fix.
    """
    choice = os.environ.get(KERNEL_ENV, "").strip().lower() or "auto"
    if choice not in KERNEL_CHOICES:
        from berryshaker.errors import ConfigError

        raise ConfigError(f"environment variable {KERNEL_ENV}={os.environ[KERNEL_ENV]!r}: expected one of "
                          f"{', '.join(KERNEL_CHOICES)} (the multibody kernel of runs left to choose); unset it for "
                          "auto")
    return choice
