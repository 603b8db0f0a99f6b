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
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.config import load_machine
from berryshaker.errors import ConfigError
from berryshaker.experiment.field_cells import sheet_table
from berryshaker.input_files import read_input_file

runner = CliRunner()


def test_a_regular_file_is_read_whole(tmp_path):
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
    if not Path("/proc/self/environ").exists():
        pytest.skip("no /proc")
    with pytest.raises(ConfigError, match="more than the 10 bytes"):
        read_input_file("/proc/self/environ", "config file", 10)


def test_a_fifo_as_description_or_sheet_is_one_message_not_a_hang(tmp_path):
    """The reproducers of issue 59: `doe analyze FIFO` and `calibrate FIFO` blocked for ever; now exit 2 with one
    line each (run in a child process under a hang guard)."""
    fifo = tmp_path / "sheet.csv"
    os.mkfifo(fifo)
    code = f"""
import json
from typer.testing import CliRunner
from berryshaker.cli import app
out = []
for args in (["doe", "analyze", {str(fifo)!r}, "--maximize", "efficiency"], ["calibrate", {str(fifo)!r}],
             ["config", "validate", {str(fifo)!r}]):
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
    for code_, output in json.loads(r.stdout.strip().splitlines()[-1]):
        assert code_ == 2 and "FIFO" in output and "Traceback" not in output, output


def test_dev_zero_is_refused_before_reading(tmp_path):
    for args in (["doe", "analyze", "/dev/zero", "--maximize", "efficiency"], ["config", "validate", "/dev/zero"],
                 ["kinematics", "--config", "/dev/zero"]):
        r = runner.invoke(app, args)
        assert r.exit_code == 2 and "character device" in r.output, (args, r.output)
