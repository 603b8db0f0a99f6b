"""Fuzzing (hypothesis) of the faults of issue 59, so that a regression fails the build:

* cache folders: whatever the folder given (missing, a file, a FIFO, a symlink, any mode, in a folder others may
  write), the run cache is a private folder of this user or one message naming it; never a folder others can
  write (a forged entry would be served);
* full disks: whatever write fills the disk, every writer (a pair of files, a table's CSV and workbook, a staged
  folder, `doe plan`) ends with one WriteError and leaves the destination as it was;
* special files: a FIFO, a socket, a device, a folder, a file too large, anything behind a symlink, given as a
  machine description, a mechanism or a field sheet, is one ConfigError at once, never a hang;
* flag ranges: out-of-range numbers for the flags of the issue's list are one message naming the flag (exit 2)
  before any work.

Fixed, derandomised examples in CI (about 10-20 s in all); ``BERRYSHAKER_FUZZ_EXAMPLES=5000`` explores further."""

from __future__ import annotations

import errno
import hashlib
import math
import os
import signal
import socket
import stat
from contextlib import contextmanager
from pathlib import Path

from fuzzing import fuzz, work_dir
from hypothesis import HealthCheck, given
from hypothesis import strategies as st
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.errors import BerryshakerError, ConfigError, OutputError, WriteError
from berryshaker.outputs import atomic_files, staged_directory, write_files_atomic

runner = CliRunner()
WORK = work_dir("faults")
_counter = iter(range(10**9))


def _fresh() -> Path:
    d = WORK / f"case{next(_counter)}"
    d.mkdir()
    return d


def _tree(root: Path) -> dict[str, str]:
    out = {}
    for p in sorted(root.rglob("*")):
        st_ = os.lstat(p)
        out[p.relative_to(root).as_posix()] = (hashlib.sha256(p.read_bytes()).hexdigest()
                                               if stat.S_ISREG(st_.st_mode) else stat.filemode(st_.st_mode))
    return out


@contextmanager
def hang_guard(seconds: int = 20):
    """Fail instead of hanging (a FIFO read without O_NONBLOCK blocks for ever)."""
    def fire(*_):
        raise TimeoutError(f"hung for {seconds} s")

    old = signal.signal(signal.SIGALRM, fire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


# ---- cache folders ------------------------------------------------------------------------------------------
@fuzz(60)
@given(kind=st.sampled_from(["missing", "dir", "file", "fifo", "link_dir", "link_file", "dangling", "nested_missing"]),
       mode=st.integers(0, 0o777), parent_mode=st.sampled_from([0o700, 0o755, 0o777, 0o1777]),
       how=st.sampled_from(["flag", "env"]))
def test_the_cache_is_private_or_refused(kind, mode, parent_mode, how):
    from berryshaker.runs.cache import run_cache_dir

    case = _fresh()
    parent = case / "parent"
    parent.mkdir()
    target = parent / ("x/y/cache" if kind == "nested_missing" else "cache")
    if kind == "dir":
        target.mkdir()
        os.chmod(target, mode)
    elif kind == "file":
        target.write_text("the user's")
    elif kind == "fifo":
        os.mkfifo(target)
    elif kind in ("link_dir", "link_file", "dangling"):
        real = case / "real"
        if kind == "link_dir":
            real.mkdir()
            os.chmod(real, mode)
        elif kind == "link_file":
            real.write_text("the user's")
        target.symlink_to(real)
    os.chmod(parent, parent_mode)
    before = _tree(case)
    old_env = os.environ.get("BERRYSHAKER_CACHE")
    try:
        if how == "env":
            os.environ["BERRYSHAKER_CACHE"] = str(target)
            chosen = None
        else:
            chosen = str(target)
        try:
            folder = run_cache_dir(chosen)
        except ConfigError as exc:
            assert str(exc).startswith("run cache") or "--cache" in str(exc), str(exc)
            for rel, state in before.items():  # a refusal removes and changes nothing
                assert _tree(case).get(rel) == state, rel
            return
    finally:
        os.chmod(parent, 0o755)
        if old_env is None:
            os.environ.pop("BERRYSHAKER_CACHE", None)
        else:
            os.environ["BERRYSHAKER_CACHE"] = old_env
    for p in [folder, *[q for q in folder.parents if case in q.parents or q == case]][:3]:
        st_ = os.lstat(p)
        if p == folder or p.name == "cache" or p.name == "runs":
            assert stat.S_ISDIR(st_.st_mode) and st_.st_uid == os.geteuid(), p
            assert not st_.st_mode & 0o022, (p, oct(st_.st_mode))
    top_parent = os.stat((folder.parent if how == "flag" else folder.parent.parent))
    assert not top_parent.st_mode & 0o002 or top_parent.st_mode & stat.S_ISVTX


# ---- full disks ---------------------------------------------------------------------------------------------
class _Full:
    def __init__(self, at: int):
        self.at, self.count, self.real = at, 0, atomic_files._fill

    def __call__(self, fd, data):
        self.count += 1
        if self.count >= self.at:
            os.write(fd, data[: len(data) // 3])
            os.close(fd)
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        self.real(fd, data)


@fuzz(40, HealthCheck.function_scoped_fixture)
@given(writer=st.sampled_from(["pair", "table", "staged", "staged_again", "doe plan"]), at=st.integers(1, 6),
       existing=st.booleans())
def test_a_full_disk_leaves_the_destination_as_it_was(writer, at, existing, monkeypatch):
    case = _fresh()
    dest = case / "out"
    if writer == "staged_again":  # an earlier output of the same command, replaced file by file
        with staged_directory(dest, kind="kinematics --plot") as stage:
            for n in ("a.png", "b.png"):
                (stage / n).write_text(f"old {n}")
    elif existing:
        dest.mkdir()
        (dest / "plan.csv").write_text("the user's sheet")
    before = _tree(case)
    full = _Full(at)
    with monkeypatch.context() as patched:  # each example its own patch (the fixture outlives the examples)
        patched.setattr(atomic_files, "_fill", full)
        try:
            _write(writer, dest, full, at)
        except OutputError as exc:  # staging refuses a folder with the user's files before writing
            assert isinstance(exc, WriteError) or writer == "staged", exc
            assert _tree(case) == before, (writer, at)
            return
    assert full.count < at, (writer, at)  # no error: the disk never filled


def _write(writer: str, dest: Path, full: _Full, at: int) -> None:
    from berryshaker.report.table_files import write_table

    if writer == "pair":
        write_files_atomic({dest / "plan.csv": b"sheet", dest / "plan.html": b"page", dest / "x.svg": b"svg"})
    elif writer == "table":
        write_table(dest / "t.csv", ["a", "b"], [[1, "x"], [2, "y"]])
    elif writer in ("staged", "staged_again"):
        with staged_directory(dest, kind="kinematics --plot") as stage:
            write_files_atomic({stage / "a.png": b"png", stage / "a.svg": b"svg"})
            write_files_atomic({stage / "b.png": b"png2"})
    else:
        r = runner.invoke(app, ["doe", "plan", "--array", "L4", "--factor", "A=1,2mm", "--factor", "B=1,2mm",
                                "--out", str(dest / "p.csv")])
        if full.count >= at:
            assert r.exit_code == 2 and "the disk is full" in r.output and "Traceback" not in r.output, r.output
            assert r.output.count("\n") == 1, r.output  # one line
            raise WriteError("the command said so")


# ---- special files ------------------------------------------------------------------------------------------
@fuzz(30)
@given(kind=st.sampled_from(["fifo", "socket", "dir", "dev_null", "big", "link_fifo", "link_dir", "empty",
                             "binary"]),
       reader=st.sampled_from(["machine", "mechanism", "sheet", "calibrate sheet"]))
def test_special_files_are_one_message_at_once(kind, reader):
    from berryshaker.config import load_machine, reference_machine
    from berryshaker.experiment.field_cells import sheet_table
    from berryshaker.multibody.spec import load_mechanism
    from berryshaker.study.field_calibration import read_sheet

    case = _fresh()
    p = case / "input"
    if kind == "fifo":
        os.mkfifo(p)
    elif kind == "socket":
        s = socket.socket(socket.AF_UNIX)
        s.bind(str(p))
    elif kind == "dir":
        p.mkdir()
    elif kind == "dev_null":  # (endless devices such as /dev/zero: in a child with a memory limit,
        p = Path("/dev/null")  # tests/test_input_files.py, so that a regression cannot exhaust the machine)
    elif kind == "big":
        with open(p, "wb") as fh:
            fh.truncate(70_000_000)  # sparse: larger than any bound, no disk used
    elif kind == "link_fifo":
        os.mkfifo(case / "fifo")
        p.symlink_to(case / "fifo")
    elif kind == "link_dir":
        p.symlink_to(case, target_is_directory=True)
    elif kind == "empty":
        p.write_bytes(b"")
    else:
        p.write_bytes(bytes(range(256)) * 4)
    read = {"machine": lambda: load_machine(p), "mechanism": lambda: load_mechanism(p), "sheet": lambda: sheet_table(p),
            "calibrate sheet": lambda: read_sheet(p, reference_machine())}[reader]
    with hang_guard():
        try:
            read()
        except ConfigError as exc:
            assert str(exc).strip() and str(p) in str(exc) or kind in ("empty", "binary"), str(exc)
            return
    assert kind == "empty" and reader == "machine", (kind, reader)  # an empty description: every default


# ---- flag ranges --------------------------------------------------------------------------------------------
bad_float = st.one_of(st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -0.0, -1.0, 1e308, -1e-300]),
                      st.floats(max_value=0.0), st.floats(min_value=1e12, allow_infinity=True))


def _text(v: float) -> str:
    return repr(v)


@fuzz(40)
@given(which=st.sampled_from(["compare --alpha", "--clearance", "wear --limit", "wear --slip", "tolerance --limit",
                              "calibrate-free --weights", "compare --starts", "plant --replicates"]),
       v=bad_float, i=st.integers(min_value=1_001, max_value=10**12))
def test_out_of_range_numbers_are_one_message_naming_the_flag(which, v, i):
    if which == "compare --alpha":
        args, flag = ["compare", "--starts", "0", "--alpha", _text(v if not 0 < v < 1 else 2.0)], "--alpha"
    elif which == "--clearance":
        size = f"{v:g}mm" if not (1e-3 <= v <= 1e5 or v == 0) else "1e-400mm"
        args, flag = ["simulate", "-n", "2", "--clearance", f"A={size}"], "clearance"
    elif which == "wear --limit":
        args, flag = ["wear", "--hours", "1", "--limit", f"clearance:C={v!r}mm"], "--limit"
    elif which == "wear --slip":
        args, flag = ["wear", "--hours", "1", "--slip", _text(v if not 0 <= v <= 1 else 2.0)], "--slip"
    elif which == "tolerance --limit":
        args, flag = ["tolerance", "--points", "2", "--limit", f"clearance:C={v!r}mm"], "--limit"
    elif which == "calibrate-free --weights":
        args, flag = ["doe", "analyze", str(WORK / "none.csv"), "--maximize", "efficiency", "--weights",
                      f"efficiency=1,efficiency={v!r}"], "--weights"
    elif which == "compare --starts":
        args, flag = ["compare", "--starts", str(i)], "--starts"
    else:
        args, flag = ["plant", "--convergence", "--replicates", str(i)], "--replicates"
    r = runner.invoke(app, args)
    assert r.exit_code == 2, (args, r.output, r.exception)
    assert flag in r.output and "Traceback" not in r.output, (args, r.output)
    assert isinstance(r.exception, SystemExit) and not isinstance(r.exception, BerryshakerError)
