"""The user's input files are read only if they are regular files of bounded size (berryshaker.input_files): a FIFO
as a machine description or a field sheet used to block `config validate`, `doe analyze` and `calibrate` for ever,
/dev/zero grew memory until the process was killed.  Both readers (the machine-description loader and the
field-sheet reader) go through the one function; each refusal is one message naming the file and the fix."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from berryshaker.config import load_machine
from berryshaker.errors import ConfigError
from berryshaker.experiment.field_cells import sheet_table


def test_a_regular_file_is_read_whole(tmp_path):
    from berryshaker.input_files import read_input_file

    p = tmp_path / "a.txt"
    p.write_bytes(b"x" * 1000)
    assert read_input_file(p, "config file", 1000) == b"x" * 1000
    with pytest.raises(ConfigError, match=r"config file .*a.txt: 1,000 bytes, more than the 999 bytes"):
        read_input_file(p, "config file", 999)


@pytest.mark.parametrize("kind", ["fifo", "folder", "socket", "missing", "dev_zero", "dev_null", "symlink_to_fifo"])
def test_special_files_are_refused_at_once(tmp_path, kind):
    p = tmp_path / "input"
    if kind == "fifo":
        os.mkfifo(p)
    elif kind == "folder":
        p.mkdir()
    elif kind == "socket":
        s = socket.socket(socket.AF_UNIX)
        s.bind(str(p))
    elif kind == "dev_zero":
        p = Path("/dev/zero")
    elif kind == "dev_null":
        p = Path("/dev/null")
    elif kind == "symlink_to_fifo":
        os.mkfifo(tmp_path / "fifo")
        p.symlink_to(tmp_path / "fifo")
    expect = {"fifo": "FIFO", "folder": "folder", "socket": "socket", "missing": "not found",
              "dev_zero": "character device", "dev_null": "character device", "symlink_to_fifo": "FIFO"}[kind]
    for read in (lambda: load_machine(p), lambda: sheet_table(p)):
        with pytest.raises(ConfigError, match=expect):
            read()


def test_a_file_that_grows_past_its_bound_is_refused(tmp_path):
    """/proc files report size 0: the bound holds on what is read, not on what fstat says."""
    from berryshaker.input_files import read_input_file

    if not Path("/proc/self/environ").exists():
        pytest.skip("no /proc")
    with pytest.raises(ConfigError, match="more than the 10 bytes"):
        read_input_file("/proc/self/environ", "config file", 10)


def test_fifos_and_devices_are_one_message_not_a_hang_or_endless_memory(tmp_path):
    """The reproducers of issue 59: `doe analyze FIFO` and `calibrate FIFO` blocked for ever, `/dev/zero` as a sheet
    grew memory until the process was killed; now exit 2 with one line each.  They run in a child process under a
    hang guard (60 s) and a memory limit (3 GB of address space), so a regression fails instead of taking the
    machine down."""
    fifo = tmp_path / "sheet.csv"
    os.mkfifo(fifo)
    runs = []
    for f, what in ((str(fifo), "FIFO"), ("/dev/zero", "character device")):
        runs += [(["doe", "analyze", f, "--maximize", "efficiency"], what), (["calibrate", f], what),
                 (["config", "validate", f], what), (["kinematics", "--config", f], what)]
    code = f"""
import json, resource
resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))
from typer.testing import CliRunner
from berryshaker.cli import app
out = []
for args, _ in {runs!r}:
    r = CliRunner().invoke(app, args)
    out.append([r.exit_code, r.output])
print(json.dumps(out))
"""
    src = str(Path(__file__).resolve().parents[1] / "src")
    env = dict(os.environ, PYTHONPATH=src + os.pathsep + os.environ.get("PYTHONPATH", ""))
    try:
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, env=env)
    except subprocess.TimeoutExpired:
        pytest.fail("a FIFO as a sheet or description hangs")
    assert r.returncode == 0 and r.stdout.strip(), r.stderr[-2000:]  # a MemoryError or a kill ends it otherwise
    for (args, what), (code_, output) in zip(runs, json.loads(r.stdout.strip().splitlines()[-1])):
        assert code_ == 2 and what in output and "Traceback" not in output, (args, output)
