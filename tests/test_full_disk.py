"""A full disk is one clear error and nothing half-written (issue 59: a traceback in 13 of 18 output commands, and
`doe plan` left plan.csv without plan.html).  The disk fills at the Nth file berryshaker writes (the atomic
writer's temporary file gets half its bytes, then ENOSPC, as a real full disk does); whatever N, every command
exits 2 with one line naming the file and "the disk is full", no traceback, and the destination is as it was: no
new file, no temporary or staging file, a pair of files written together or not at all.  (That the commands write
when there is space: tests/fuzz/test_outputs_fuzz.py.)"""

from __future__ import annotations

import errno
import hashlib
import os
import subprocess
from pathlib import Path

import pytest
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.outputs import atomic_files

runner = CliRunner()


class DiskFull:
    """Patches the atomic writer so that the ``at``-th file written (from 1) fills the disk."""

    def __init__(self, monkeypatch, at: int):
        self.at, self.count = at, 0
        real = atomic_files._fill

        def fill(fd, data):
            self.count += 1
            if self.count >= self.at:
                os.write(fd, data[:len(data) // 2])
                os.close(fd)
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            real(fd, data)

        monkeypatch.setattr(atomic_files, "_fill", fill)


def _tree(root: Path) -> dict[str, str]:
    out = {}
    for p in sorted(root.rglob("*")):
        out[p.relative_to(root).as_posix()] = hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "dir"
    return out


def _sheet(folder: Path) -> Path:
    """A filled L4 sheet (doe plan, responses filled in)."""
    p = folder / "sheet.csv"
    r = runner.invoke(app, ["doe", "plan", "--array", "L4", "--factor", "A=1,2mm", "--factor", "B=1,2mm",
                            "--replicates", "1", "--out", str(p)])
    assert r.exit_code == 0, r.output
    lines = p.read_text().strip().split("\n")
    head = lines[0].split(",")
    rows = [ln.split(",") for ln in lines[1:]]
    for k, row in enumerate(rows):
        for i, h in enumerate(head):
            if h in ("efficiency_kg_min", "unripe_rate_pct", "damage_rate_pct"):
                row[i] = str(1.0 + 0.3 * k + 0.1 * i + 0.05 * (k % 2))
    p.write_text(",".join(head) + "\n" + "\n".join(",".join(r) for r in rows) + "\n")
    (folder / "sheet.html").unlink()
    return p


COMMANDS = {  # name -> arguments (DEST: the destination inside the case folder; SHEET: a filled sheet)
    "kinematics --plot": ["kinematics", "--plot", "DEST/figs"],
    "doe plan": ["doe", "plan", "--array", "L4", "--factor", "A=1,2mm", "--factor", "B=1,2mm", "--out",
                 "DEST/plan.csv"],
    "cam-profile csv": ["cam-profile", "--out", "DEST/cam.csv", "--points", "90"],
    "cam-profile dxf": ["cam-profile", "--out", "DEST/cam.dxf", "--points", "90"],
    "config init": ["config", "init", "DEST/m.toml"],
    "doe analyze --out html": ["doe", "analyze", "SHEET", "--maximize", "efficiency", "--out", "DEST/a.html"],
    "doe analyze --out json": ["doe", "analyze", "SHEET", "--maximize", "efficiency", "--out", "DEST/a.json"],
    "doe analyze --plot": ["doe", "analyze", "SHEET", "--maximize", "efficiency", "--minimize", "damage", "--plot",
                           "DEST/plots"],
    "simulate --out": ["simulate", "-n", "2", "--out", "DEST/run"],
    "plant --plot": ["plant", "--plot", "DEST/modes"],
}


@pytest.fixture(scope="module")
def sheet(tmp_path_factory):
    return _sheet(tmp_path_factory.mktemp("sheet"))


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_a_full_disk_is_one_message_and_nothing_half_written(name, sheet, tmp_path, monkeypatch):
    dest = tmp_path / "dest"
    dest.mkdir()
    (dest / "notes.txt").write_text("the user's")
    args = [a.replace("DEST", str(dest)).replace("SHEET", str(sheet)) for a in COMMANDS[name]]
    before = _tree(tmp_path)
    for at in (1, 2):  # the disk fills at the first or the second file (a pair's second half)
        full = DiskFull(monkeypatch, at)
        r = runner.invoke(app, args)
        if full.count < at:  # the command writes fewer files: nothing to fill
            continue
        assert r.exit_code == 2, (name, at, r.output, r.exception)
        assert "the disk is full (ENOSPC)" in r.output and "Traceback" not in r.output, r.output
        assert r.output.count("error:") == 1
        assert _tree(tmp_path) == before, (name, at)


def test_a_pair_is_written_together_or_not_at_all(tmp_path, monkeypatch):
    from berryshaker.outputs import write_files_atomic

    a, b = tmp_path / "plan.csv", tmp_path / "plan.html"
    a.write_text("old sheet")
    for at in (1, 2):
        DiskFull(monkeypatch, at)
        with pytest.raises(OSError, match="none of its files was written"):
            write_files_atomic({a: b"new sheet", b: b"new page"})
        assert a.read_text() == "old sheet" and not b.exists()
        assert sorted(p.name for p in tmp_path.iterdir()) == ["plan.csv"]
    monkeypatch.undo()

    real = os.replace  # the second rename fails: the first is undone, the earlier file back

    def replace(src, dst):
        if str(dst) == str(b):
            raise OSError(errno.EIO, "I/O error")
        return real(src, dst)

    monkeypatch.setattr(atomic_files.os, "replace", replace)
    with pytest.raises(OSError, match="input/output error"):
        write_files_atomic({a: b"new sheet", b: b"new page"})
    monkeypatch.undo()
    assert a.read_text() == "old sheet" and not b.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan.csv"]


@pytest.fixture(scope="module")
def full_disk(tmp_path_factory):
    """A real full disk: a small tmpfs filled to the last byte (needs the right to mount, e.g. root; else skipped:
    the tests above simulate it everywhere)."""
    mnt = tmp_path_factory.mktemp("full")
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=512k", "tmpfs", str(mnt)], capture_output=True).returncode:
        pytest.skip("no permission to mount a tmpfs")
    try:
        (mnt / "dest").mkdir()
        (mnt / "dest" / "notes.txt").write_text("the user's")
        fd = os.open(mnt / "filler", os.O_WRONLY | os.O_CREAT)
        try:  # every free block taken
            while True:
                os.write(fd, b"\0" * 4096)
        except OSError as exc:
            assert exc.errno == errno.ENOSPC
        finally:
            os.close(fd)
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


@pytest.mark.parametrize("name", ["kinematics --plot", "doe plan", "cam-profile csv", "config init",
                                  "doe analyze --out html", "doe analyze --plot"])
def test_a_real_full_disk_is_one_message_and_nothing_half_written(name, sheet, full_disk):
    dest = full_disk / "dest"
    args = [a.replace("DEST", str(dest)).replace("SHEET", str(sheet)) for a in COMMANDS[name]]
    before = _tree(full_disk)
    r = runner.invoke(app, args)
    assert r.exit_code == 2, (name, r.output, r.exception)
    assert "the disk is full (ENOSPC)" in r.output and "Traceback" not in r.output, r.output
    assert _tree(full_disk) == before
