"""numba's cache folder follows the compiled sources (berryshaker.compiled_cache).

numba checks only a cached function's own file, so an entry whose kernel calls a compiled function of another file
runs the callee's old code after that file changes.  The package therefore names numba's cache folder by a digest
of every source that mentions numba.  Checked here: the digest moves with every callee file a cached kernel calls
across files (found by a scan of the package) and not with the rest; a child process keeps its parent's folder
while a new ``NUMBA_CACHE_DIR`` gets its own; old digest folders are pruned and nothing else is; an unwritable base
falls back to the temp folder; the cache lives only in private folders (mode 0700, this user's, no symlinks, not
writable by group or others; a folder another user made first, the temp fallback's included, is refused), and the
numba and run caches share one home (``cache_home``).
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

import pytest

import berryshaker
from berryshaker.compiled_cache import FOLDER_PREFIX, KEEP_FOLDERS, MARKER, compiled_sources_digest

ROOT = Path(berryshaker.__file__).resolve().parent


def _copy_package(tmp_path: Path) -> Path:
    dst = tmp_path / "berryshaker"
    shutil.copytree(ROOT, dst, ignore=shutil.ignore_patterns("__pycache__"))
    return dst


def _edit(path: Path) -> None:
    path.write_text(path.read_text() + "\n# an edit\n")


def _cross_file_cached_calls() -> set[tuple[str, str]]:
    """(caller module, callee module) of every cached dispatcher that names a compiled function (dispatcher or
    numba ufunc) of another module."""
    from numba.core.registry import CPUDispatcher
    from numba.np.ufunc.dufunc import DUFunc

    def home(obj):
        if isinstance(obj, CPUDispatcher):
            return obj.py_func.__module__
        if isinstance(obj, DUFunc):
            return obj._dispatcher.py_func.__module__
        return None

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
                found = [target] if home(target) else (
                    [getattr(target, a, None) for a in names] if isinstance(target, types.ModuleType) else [])
                for d in found:
                    where = home(d)
                    if where and where != mod.__name__:
                        out.add((mod.__name__, where))
    return out


def test_digest_follows_every_compiled_callee_and_nothing_else(tmp_path):
    calls = _cross_file_cached_calls()
    # the calls that make the digest necessary (module docstring of berryshaker.compiled_cache): the scan must see
    # them, or it checks nothing
    assert {("berryshaker.multibody.kernel", "berryshaker.multibody.dynamics"),
            ("berryshaker.drives.groove_cam.mlsd_kernel", "berryshaker.drives.groove_cam.kinematics")} <= calls
    for callee in ("berryshaker.kinematics.cam", "berryshaker.contact.friction"):  # from whichever engine module
        assert any(a.startswith("berryshaker.multibody.") and b == callee for a, b in calls), callee
    pkg = _copy_package(tmp_path)
    d0 = compiled_sources_digest(pkg)
    cli = pkg / "cli" / "app.py"
    assert b"numba" not in cli.read_bytes()
    _edit(cli)
    assert compiled_sources_digest(pkg) == d0  # an edit that compiles nothing keeps the kernels
    for callee in sorted({c for _, c in calls}):
        copy = pkg / Path(*callee.split(".")[1:]).with_suffix(".py")
        before = compiled_sources_digest(pkg)
        _edit(copy)
        assert compiled_sources_digest(pkg) != before, callee


def _folder_in_child(env: dict) -> str:
    code = "import os, berryshaker, numba; print(os.environ['NUMBA_CACHE_DIR'] + '|' + numba.config.CACHE_DIR)"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    a, b = out.stdout.strip().splitlines()[-1].split("|")
    assert a == b
    return a


def _env(**kw) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "BERRYSHAKER_NUMBA_BASE")}
    env.update(kw)
    return env


def test_child_processes_keep_the_folder_and_only_old_digest_folders_are_pruned(tmp_path):
    base = tmp_path / "berryshaker"  # a given NUMBA_CACHE_DIR holds the digest folders in a subfolder
    base.mkdir()
    stale = []
    for k in range(KEEP_FOLDERS + 2):
        p = base / f"{FOLDER_PREFIX}{k:016x}"
        p.mkdir()
        (p / MARKER).touch()
        t = time.time() - 1000 * (k + 1)
        os.utime(p / MARKER, (t, t))
        stale.append(p)
    # what is not a digest folder of ours survives: a user's study output, a look-alike without the marker
    mine = [tmp_path / "berryshaker-study", base / "berryshaker-study", base / f"{FOLDER_PREFIX}{'f' * 16}"]
    for p in mine:
        p.mkdir()
        (p / "report.html").write_text("the user's")
        os.utime(p, (0, 0))
    folder = Path(_folder_in_child(_env(NUMBA_CACHE_DIR=str(tmp_path))))
    assert folder.parent == base and folder.name == FOLDER_PREFIX + compiled_sources_digest(ROOT)
    assert [p for p in stale if p.exists()] == stale[:KEEP_FOLDERS - 1]  # the newest, KEEP_FOLDERS with the current
    assert all((p / "report.html").read_text() == "the user's" for p in mine)
    # a worker started with the parent's environment uses the same folder (no folder inside the folder) ...
    inherited = _env(NUMBA_CACHE_DIR=str(folder), BERRYSHAKER_NUMBA_BASE=str(base))
    assert _folder_in_child(inherited) == str(folder)
    # ... and a process given another NUMBA_CACHE_DIR (an empty cache for a cold compile) gets its own
    other = tmp_path / "cold"
    assert Path(_folder_in_child({**inherited, "NUMBA_CACHE_DIR": str(other)})).parent == other / "berryshaker"


def test_an_unwritable_base_falls_back_to_the_temp_folder(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    temp = tmp_path / "tmp"
    temp.mkdir()
    folder = Path(_folder_in_child(_env(NUMBA_CACHE_DIR=str(blocker / "cache"), TMPDIR=str(temp))))
    assert temp in folder.parents and (folder / MARKER).is_file()


# ---- private folders only (issue 42): numba's entries are pickles and generated sources are imported -------------
def _cache_in_child(env: dict) -> tuple[str, str]:
    """(NUMBA_CACHE_DIR or "none", stderr) of a fresh process importing berryshaker with ``env``."""
    code = "import os, berryshaker; print(os.environ.get('NUMBA_CACHE_DIR') or 'none')"
    out = subprocess.run([sys.executable, "-W", "always", "-c", code], env=env, capture_output=True, text=True,
                         check=True)
    return out.stdout.strip().splitlines()[-1], out.stderr


def _mode(p: Path) -> int:
    return p.stat().st_mode & 0o777


def test_new_cache_folders_are_private(tmp_path):
    home = tmp_path / "home"
    folder = Path(_cache_in_child(_env(BERRYSHAKER_CACHE=str(home), TMPDIR=str(tmp_path)))[0])
    assert folder.parent == home / "numba"
    assert _mode(home) == _mode(home / "numba") == _mode(folder) == 0o700


OTHER_UID = 65534  # nobody


@pytest.mark.parametrize("how", ["owner", "group-writable", "symlink"])
def test_a_cache_someone_else_can_write_is_never_used(tmp_path, how):
    home = tmp_path / "home"  # what another local user prepared where the cache goes
    if how == "symlink":  # a link inside the cache could be swapped for another folder: never followed
        home.mkdir(mode=0o700)
        (tmp_path / "elsewhere").mkdir(mode=0o700)
        (home / "numba").symlink_to(tmp_path / "elsewhere")
    else:
        home.mkdir(mode=0o700)
        if how == "owner":
            if os.geteuid() != 0:
                pytest.skip("making a folder another user owns needs root (CI runs as root)")
            os.chown(home, OTHER_UID, OTHER_UID)
        else:
            os.chmod(home, 0o770)
    temp = tmp_path / "tmp"
    temp.mkdir()
    folder, _ = _cache_in_child(_env(BERRYSHAKER_CACHE=str(home), TMPDIR=str(temp)))
    # the per-user fallback in the temporary folder, private, instead
    assert Path(folder).parents[1] == (temp / f"berryshaker-{os.getuid()}").resolve()
    assert _mode(temp / f"berryshaker-{os.getuid()}") == 0o700
    assert not any(p.name.startswith("berryshaker-numba-") for p in home.rglob("*"))
    assert not any(p.name.startswith("berryshaker-numba-") for p in tmp_path.glob("elsewhere/*"))


def test_a_temp_fallback_made_by_another_user_is_refused(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("making a folder another user owns needs root (CI runs as root)")
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    temp = tmp_path / "tmp"
    temp.mkdir()
    planted = temp / f"berryshaker-{os.getuid()}"  # created first by someone else
    planted.mkdir(mode=0o777)
    os.chown(planted, OTHER_UID, OTHER_UID)
    folder, stderr = _cache_in_child(_env(BERRYSHAKER_CACHE=str(blocker / "cache"), TMPDIR=str(temp)))
    assert folder == "none" and "owned by another user" in stderr
    assert list(planted.iterdir()) == []


def test_one_cache_home_for_numba_and_runs(tmp_path, monkeypatch):
    from berryshaker.compiled_cache import cache_home, numba_cache_base
    from berryshaker.errors import ConfigError
    from berryshaker.runs.runner import default_cache_dir

    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.delenv("BERRYSHAKER_NUMBA_BASE", raising=False)
    monkeypatch.delenv("BERRYSHAKER_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_home() == tmp_path / "xdg" / "berryshaker"
    assert numba_cache_base() == cache_home() / "numba" and default_cache_dir() == cache_home() / "runs"
    assert _mode(cache_home() / "runs") == 0o700
    shared = tmp_path / "shared"
    shared.mkdir()
    os.chmod(shared, 0o777)
    monkeypatch.setenv("BERRYSHAKER_CACHE", str(shared))
    with pytest.raises(ConfigError, match="writable by group or others"):
        default_cache_dir()
    assert not (shared / "runs").exists()


def test_generated_kernel_sources_go_only_to_a_private_temp_folder(tmp_path, monkeypatch):
    """Without a numba cache folder the specialised kernels' generated sources (imported as code) would go to the
    per-user temp folder: one that another user created first is refused, and the kernel is then not picked."""
    import berryshaker.compiled_cache as cc
    from berryshaker.compiled_cache import UnsafeCacheFolder
    from berryshaker.multibody import specialised as sp

    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setattr(cc.tempfile, "gettempdir", lambda: str(tmp_path))
    own = sp.source_folder()  # created private: 0700, ours
    assert own.is_dir() and own.parent == cc.temp_cache_home() and (own.stat().st_mode & 0o077) == 0
    if os.geteuid() == 0:  # someone else's folder of that name (as root: hand it to uid 65534)
        os.chown(cc.temp_cache_home(), 65534, 65534)
    else:
        cc.temp_cache_home().chmod(0o777)
    with pytest.raises(UnsafeCacheFolder):
        sp.source_folder()
    assert sp.is_compiled((), 1) is False


def test_generated_kernel_sources_go_into_numba_s_folder_when_it_has_one(tmp_path, monkeypatch):
    from berryshaker.compiled_cache import kernel_source_folder

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba"))
    assert kernel_source_folder("specialised-x") == tmp_path / "numba" / "specialised-x"


def test_one_rule_chooses_the_multibody_kernel(monkeypatch):
    """What the run asks for, then BERRYSHAKER_KERNEL, then whether this machine compiled it, then the sweep's
    own rule (or the generic kernel); a rule is asked only when it is reached."""
    from berryshaker.compiled_cache import COMPILED_ALREADY, resolve_kernel
    from berryshaker.errors import ConfigError

    def never():
        raise AssertionError("a rule asked after the choice was made")

    monkeypatch.setenv("BERRYSHAKER_KERNEL", "specialised")
    assert resolve_kernel(False, never, never) == (False, "asked for")
    assert resolve_kernel(True, never, asked="--specialised") == (True, "--specialised")
    assert resolve_kernel(None, never, never) == (True, "BERRYSHAKER_KERNEL=specialised")
    monkeypatch.setenv("BERRYSHAKER_KERNEL", " Generic ")
    assert resolve_kernel(None, never, never) == (False, "BERRYSHAKER_KERNEL=generic")
    monkeypatch.delenv("BERRYSHAKER_KERNEL")
    assert resolve_kernel(None, lambda: True, never) == (True, COMPILED_ALREADY)
    assert resolve_kernel(None, lambda: False, lambda: (True, "it pays")) == (True, "it pays")
    assert resolve_kernel(None, lambda: False)[0] is False
    monkeypatch.setenv("BERRYSHAKER_KERNEL", "fast")
    with pytest.raises(ConfigError, match="BERRYSHAKER_KERNEL"):
        resolve_kernel(None, never)
    assert resolve_kernel(True, never) == (True, "asked for")  # an explicit choice needs no variable
