"""One cache policy for every way the run cache is chosen (issue 59): ``--cache DIR`` was used even when another
user could write it (the environment variable was refused for the same folder), so a forged entry with a
recomputed digest was served (a peak of 87,372 N instead of 8,737 N, no warning); ``--cache ''`` used the current
folder; a FIFO or /dev/null was accepted with a warning per run.  Now the flag, $BERRYSHAKER_CACHE and the
default pass the same check (berryshaker.runs.cache.run_cache_dir) before any work, and an entry that is not the
user's own regular file is never served."""

from __future__ import annotations

import json
import os
import stat

import pytest
import runner_jobs
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.errors import ConfigError
from berryshaker.outputs import code_fingerprint
from berryshaker.runs.cache import _sha256, cache_entry_path, run_key, value_text, write_cache_entry
from berryshaker.runs.runner import SweepRunner

cli = CliRunner()


def _forge(cache, fn, kw, value) -> None:
    """Write an entry for ``fn(**kw)`` holding ``value`` with a checksum recomputed for it (what another user who
    can write the folder could do)."""
    key = run_key(fn, kw)
    path = write_cache_entry(cache, key, "forged", kw, {"y": 0.0}, 0.1, code_fingerprint())
    entry = json.loads(path.read_text().split("\n", 1)[0])
    body = value_text(value)
    entry["value_sha256"] = _sha256(body)
    path.write_text(json.dumps(entry) + "\n" + body)


def test_a_folder_others_can_write_is_refused_whichever_way_it_is_chosen(tmp_path, monkeypatch):
    shared = tmp_path / "shared"
    shared.mkdir()
    _forge(shared, runner_jobs.square, {"x": 3.0}, {"y": 87372.0})
    os.chmod(shared, 0o777)
    with pytest.raises(ConfigError, match="writable by group or others") as flag:
        SweepRunner(workers=1, cache_dir=shared, progress=False)
    monkeypatch.setenv("BERRYSHAKER_CACHE", str(tmp_path))  # the environment names the same folder: same verdict
    os.chmod(tmp_path, 0o777)
    try:
        with pytest.raises(ConfigError, match="writable by group or others"):
            SweepRunner(workers=1, progress=False)
    finally:
        os.chmod(tmp_path, 0o700)
    assert "--cache" in str(flag.value)
    os.chmod(shared, 0o700)  # the user's own private folder: its entries are theirs
    r = SweepRunner(workers=1, cache_dir=shared, progress=False)
    assert r.map(runner_jobs.square, [{"x": 3.0}])[0].value == {"y": 87372.0}


@pytest.mark.parametrize("kind", ["empty", "blank", "fifo", "dev_null", "file", "symlink_to_shared", "under_a_file"])
def test_impossible_cache_folders_are_one_message_before_any_work(tmp_path, kind):
    target = {"empty": "", "blank": "  ", "fifo": str(tmp_path / "fifo"), "dev_null": "/dev/null",
              "file": str(tmp_path / "file"), "symlink_to_shared": str(tmp_path / "link"),
              "under_a_file": str(tmp_path / "file" / "sub")}[kind]
    if kind == "fifo":
        os.mkfifo(target)
    if kind in ("file", "under_a_file"):
        (tmp_path / "file").write_text("the user's")
    if kind == "symlink_to_shared":
        (tmp_path / "shared").mkdir(mode=0o777)
        os.chmod(tmp_path / "shared", 0o777)
        os.symlink(tmp_path / "shared", target)
    from berryshaker.runs.cache import run_cache_dir

    with pytest.raises(ConfigError, match="--cache|run cache"):
        run_cache_dir(target)
    r = cli.invoke(app, ["wear", "--hours", "1", "--cache", target])
    assert r.exit_code == 2 and "Traceback" not in r.output, r.output
    assert not (tmp_path / "file").is_dir() and not list(tmp_path.glob("*.json"))
    if kind == "file":
        assert (tmp_path / "file").read_text() == "the user's"


def test_a_new_cache_folder_is_private(tmp_path):
    from berryshaker.runs.cache import run_cache_dir

    folder = run_cache_dir(tmp_path / "new" / "cache")
    assert stat.S_IMODE(os.stat(folder).st_mode) == 0o700
    assert run_cache_dir(str(folder)) == folder


def test_an_entry_of_another_user_is_never_served(tmp_path):
    """A run's entry owned by another user (in a private folder only root can do that) is recomputed, with a
    warning naming it."""
    from berryshaker.runs.cache import run_cache_dir

    if os.geteuid() != 0:
        pytest.skip("making a file of another user needs root")
    cache = run_cache_dir(tmp_path / "cache")
    _forge(cache, runner_jobs.square, {"x": 3.0}, {"y": 87372.0})
    os.chown(cache_entry_path(cache, run_key(runner_jobs.square, {"x": 3.0})), 12345, 12345)
    r = SweepRunner(workers=1, cache_dir=cache, progress=False)
    assert r.map(runner_jobs.square, [{"x": 3.0}])[0].value == {"y": 9.0}
    assert any("owned by another user" in w for w in r.warnings), r.warnings
