"""Where numba keeps the package's compiled kernels: one folder per version of the compiled sources.

numba's on-disk cache (``@njit(cache=True)``) checks only the source file of the function it loads: a kernel that
calls a compiled function of *another* file carries that callee's machine code in its own cache entry and keeps
using it after the callee's file changes (https://github.com/numba/numba/issues/6845).  The package has such calls (the multibody engine's
compiled modules -> ``kinematics.cam`` and ``contact.friction``, ``multibody.kernel.integrate`` ->
``multibody.dynamics``, ``drives.groove_cam.kinematics`` -> ``kinematics.cam`` / ``kinematics.linkage``,
``drives.groove_cam.mlsd_kernel`` -> ``drives.groove_cam.kinematics`` and ``contact.force_laws``, ...;
tests/test_compiled_cache.py finds them), and a
stale entry silently runs the old code: after a change to ``kernel.integrate`` the batched sweep path (removed in
0.2.0) still ran the old one from its own entry.

So the package points numba at a folder named by a digest of every source file that mentions numba
(:func:`compiled_sources_digest`): a change to any of them starts an empty folder, and an unchanged package finds
its kernels again.  Where:

* base folder: ``$NUMBA_CACHE_DIR/berryshaker`` if the user set ``NUMBA_CACHE_DIR``, else
  ``$BERRYSHAKER_CACHE/numba``, else ``$XDG_CACHE_HOME/berryshaker/numba`` (``~/.cache/berryshaker/numba``;
  :func:`cache_home` is the one home of the package's cache, the run cache's too); if it cannot be created or is
  not private, ``<temp dir>/berryshaker-<uid>/numba``; generated kernel sources go inside the chosen folder
  (:func:`kernel_source_folder`);
* private folders only: numba's cache entries are pickles and the generated kernel sources are imported, so a
  folder another local user can write would run their code as you.  Every folder of the cache is created with
  mode 0700 and used only if it is a real folder (not a symlink) owned by this user and not writable by group or
  others, its parent not writable by others unless sticky (:func:`private_folder`); otherwise the next location is
  tried, and with none a warning says so;
* inside it, ``berryshaker-numba-<digest>`` with a marker file; the :data:`KEEP_FOLDERS` most recently used such
  folders are kept and older ones removed when a new one is started.  Only folders with that exact name pattern
  *and* the marker are ever removed, so nothing else in the base folder is touched.

Side effects of ``import berryshaker`` (stdlib only, before any kernel is decorated): the environment variables
``NUMBA_CACHE_DIR`` (the digest folder; child processes and Dask workers started from this one inherit it) and
``BERRYSHAKER_NUMBA_BASE`` (the base, so that a child keeps it), and numba's live ``config.CACHE_DIR`` if numba is
imported already.  Other numba code in the same process then caches into the same folder.  When no folder can be
written, a warning says so and numba falls back to its own locations (where stale entries are possible again).

The choice between the generic and a specialised compiled multibody kernel has its one rule here too
(:func:`resolve_kernel`: what the run asks for, then ``BERRYSHAKER_KERNEL``, then whether this machine has compiled
it), beside the folders that decide whether it is compiled.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import stat
import sys
import tempfile
import warnings
from pathlib import Path
from typing import Callable

#: name of a digest folder: the prefix and 16 hex digits of the digest
FOLDER_PREFIX = "berryshaker-numba-"
FOLDER_PATTERN = re.compile(r"berryshaker-numba-[0-9a-f]{16}")
#: file written into every digest folder at its creation; a folder without it is never removed
MARKER = "BERRYSHAKER_NUMBA_CACHE"
#: digest folders kept (most recently used first, the current one included)
KEEP_FOLDERS = 4


def compiled_sources_digest(root: Path) -> str:
    """Digest of the sources whose change can change compiled code.

    Parameters
    ----------
    root : Path
        The package folder.

    Returns
    -------
    str
        sha256 (hex, first 16 digits) over the ``.py`` files under ``root`` that mention numba (relative path and
        content, sorted by path).
    """
    h = hashlib.sha256()
    for p in sorted(root.rglob("*.py"), key=lambda q: q.relative_to(root).as_posix()):
        if "__pycache__" in p.parts:
            continue
        data = p.read_bytes()
        if b"numba" in data or b"njit" in data:
            h.update(p.relative_to(root).as_posix().encode() + b"\0" + data + b"\0")
    return h.hexdigest()[:16]


def cache_home() -> Path:
    """The package's cache folder: ``$BERRYSHAKER_CACHE``, else ``$XDG_CACHE_HOME/berryshaker``, else
    ``~/.cache/berryshaker`` (an empty variable counts as unset).  The one home of this rule: numba's kernels go
    to ``numba/`` in it (:func:`numba_cache_base`), the sweep runner's results to ``runs/``
    (:func:`berryshaker.runs.cache.default_cache_dir`).

    Returns
    -------
    Path
        The folder, absolute (not created here).
    """
    base = os.environ.get("BERRYSHAKER_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "berryshaker")
    return Path(base).expanduser().resolve()


def temp_cache_home() -> Path:
    """The per-user fallback in the system's temporary folder (use it only through :func:`private_folder`:
    anyone may create that name first).

    Returns
    -------
    Path
        ``<temp dir>/berryshaker-<uid>``, absolute.
    """
    user = os.getuid() if hasattr(os, "getuid") else "user"
    return Path(tempfile.gettempdir()).resolve() / f"berryshaker-{user}"


class UnsafeCacheFolder(OSError):
    """A cache folder that another user could write (or that is not a plain folder of this user)."""


def _check_private(path: Path) -> None:
    st = os.lstat(path)
    if stat.S_ISLNK(st.st_mode) or not stat.S_ISDIR(st.st_mode):
        raise UnsafeCacheFolder(f"{path} is {'a symlink' if stat.S_ISLNK(st.st_mode) else 'not a folder'}")
    if hasattr(os, "geteuid") and st.st_uid != os.geteuid():
        raise UnsafeCacheFolder(f"{path} is owned by another user (uid {st.st_uid})")
    if st.st_mode & 0o022:
        raise UnsafeCacheFolder(f"{path} is writable by group or others (mode {stat.S_IMODE(st.st_mode):o}; "
                                f"chmod go-w {path} if it is yours)")


def private_folder(folder: Path, top: Path) -> Path:
    """Create ``folder`` (and the folders from ``top`` down to it) with mode 0700 and check that every one of them is
    private: a real folder (not a symlink), owned by this user, not writable by group or others; and that ``top``'s
    parent is not writable by others unless it is sticky (as /tmp).

    Parameters
    ----------
    folder : Path
        The folder wanted.
    top : Path
        The topmost folder of the package's own above it (or ``folder`` itself).

    Returns
    -------
    Path
        ``folder``.

    Raises
    ------
    UnsafeCacheFolder
        One of them is not private (the message names it and why); nothing is written into it.
    OSError
        A folder cannot be created.
    """
    folder, top = Path(folder), Path(top)
    if folder != top and top not in folder.parents:
        raise ValueError(f"{folder} is not inside {top}")
    chain = [top] + [p for p in reversed(folder.parents) if top in p.parents] + ([folder] if folder != top else [])
    top.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
    pst = os.stat(top.parent)
    if pst.st_mode & 0o002 and not pst.st_mode & stat.S_ISVTX:
        raise UnsafeCacheFolder(f"{top.parent} is writable by others and not sticky")
    for p in chain:
        try:
            os.mkdir(p, 0o700)  # the umask cannot widen 0700
        except FileExistsError:
            pass
        _check_private(p)
    return folder


def numba_cache_base() -> Path:
    """The folder holding the digest folders (see the module docstring).

    Returns
    -------
    Path
        The folder, absolute.
    """
    return _numba_base()[0]


def _numba_base() -> tuple[Path, Path]:
    """(base, top): the base folder and the topmost folder of the package's own that holds it (checked private)."""
    inherited = os.environ.get("BERRYSHAKER_NUMBA_BASE")
    given = os.environ.get("NUMBA_CACHE_DIR")
    if given:
        g = Path(given).expanduser().resolve()
        if inherited and FOLDER_PATTERN.fullmatch(g.name) and g.parent == Path(inherited):
            return g.parent, g.parent  # pointed by a parent process: keep its base
        return g / "berryshaker", g / "berryshaker"  # the user's (or a test's) own folder
    return cache_home() / "numba", cache_home()


def _prepare(folder: Path, top: Path) -> str | None:
    """Create ``folder`` (private, with its marker) or mark it used; prune old siblings when it is new.  None when
    done, else why not."""
    try:
        private_folder(folder, top)
        new = not (folder / MARKER).exists()
        (folder / MARKER).touch()  # most recently used
        if new:
            _prune(folder)
        return None
    except OSError as exc:
        return str(exc) if isinstance(exc, UnsafeCacheFolder) else f"{folder}: {exc.strerror or exc}"


def point_numba_cache() -> Path | None:
    """Point numba's cache at this package version's digest folder.

    Returns
    -------
    Path or None
        The digest folder, None when no private folder can be written (a warning says so).
    """
    name = FOLDER_PREFIX + compiled_sources_digest(Path(__file__).resolve().parent)
    base, top = _numba_base()
    folder = base / name
    why = _prepare(folder, top)
    if why is not None:
        first = why
        top = temp_cache_home()
        base = top / "numba"
        folder = base / name
        why = _prepare(folder, top)
        if why is not None:
            warnings.warn(f"berryshaker: no private writable folder for numba's cache ({first}; {why}); numba falls "
                          "back to its own, where a kernel can keep stale code after an update "
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
    """The multibody kernel of runs left to choose, from :data:`KERNEL_ENV`.

    Returns
    -------
    str
        "auto" (unset or empty), "generic" or "specialised" (any case, spaces ignored).

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


#: :func:`resolve_kernel`'s reason when this machine has compiled the structure's specialised kernel already
COMPILED_ALREADY = "compiled on this machine for this structure"


def resolve_kernel(explicit: bool | None, compiled: Callable[[], bool],
                   pays: Callable[[], tuple[bool, str]] | None = None, asked: str = "asked for") -> tuple[bool, str]:
    """The multibody kernel of a run or a sweep: True for the kernel specialised to the mechanism's structure
    (:mod:`berryshaker.multibody.specialised`; bitwise the same results), False for the generic one; and why.

    The one precedence of the ways to choose it, first that decides:

    1. ``explicit`` (True or False): what the run or sweep asks for -- ``berryshaker sweep --specialised`` /
       ``--generic``, the ``specialised=`` argument of ``simulate_mechanism`` / ``simulate_multibody``, else the
       mechanism description's ``[simulation] specialised`` (the caller passes the first of them given); the reason
       is ``asked``;
    2. the environment variable :data:`KERNEL_ENV` set to "generic" or "specialised" (:func:`kernel_choice`);
    3. "auto" (the default): the specialised kernel when ``compiled()`` says this machine has compiled it for the
       structure (the marker :func:`berryshaker.multibody.specialised.mark_compiled` writes; a load, not a
       compilation), :data:`COMPILED_ALREADY`;
    4. else ``pays()`` when given (a sweep: enough runs per worker to pay for compiling it,
       :func:`berryshaker.runs.sweep.choose_specialised`), else the generic kernel.

    Parameters
    ----------
    explicit : bool or None
        The choice asked for, None when none is (rule 1).
    compiled : callable
        ``compiled() -> bool``: whether this machine has compiled the structure's kernel (rule 3); called only when
        that rule is reached.
    pays : callable, optional
        ``pays() -> (choice, why)``: the sweep's rule (rule 4); called only when that rule is reached.
    asked : str
        The reason given for an explicit choice.

    Returns
    -------
    specialised : bool
        True for the specialised kernel.
    why : str
        The rule that decided, for the user.

    Raises
    ------
    ConfigError
        A bad :data:`KERNEL_ENV` (:func:`kernel_choice`) when ``explicit`` is None.
    """
    if explicit is not None:
        return bool(explicit), asked
    choice = kernel_choice()
    if choice != "auto":
        return choice == "specialised", f"{KERNEL_ENV}={choice}"
    if compiled():
        return True, COMPILED_ALREADY
    if pays is not None:
        return pays()
    return False, "not compiled on this machine for this structure"


def kernel_source_folder(name: str) -> Path:
    """Where generated kernel sources (the specialised multibody kernels) go: the folder ``name`` in numba's cache
    folder (``$NUMBA_CACHE_DIR``: the digest folder :func:`point_numba_cache` chose, or the user's own), else, when
    numba has none, in the per-user temporary folder (:func:`temp_cache_home`), created private
    (:func:`private_folder`).  Generated sources are imported, so a folder someone else made first is refused.

    Parameters
    ----------
    name : str
        The folder's name (a digest of the sources the generated code calls).

    Returns
    -------
    Path
        The folder (created only in the temporary fallback).

    Raises
    ------
    UnsafeCacheFolder
        The temporary folder is not private (an ``OSError``: callers then run the generic kernel).
    OSError
        It cannot be created.
    """
    base = os.environ.get("NUMBA_CACHE_DIR")
    if base:
        return Path(base) / name
    top = temp_cache_home()
    return private_folder(top / name, top)
