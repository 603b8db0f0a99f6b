"""Output destinations: refusals before any work, marker-based replacement that never touches the user's
files, staging folders that never outlive their run."""

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from berryshaker.errors import OutputError
from berryshaker.outputs import (
    MARKER_NAME,
    _host_tag,
    _umask,
    check_output_file,
    clean_stale_staging,
    prepare_output_dir,
    provenance,
    read_output_marker,
    staged_directory,
)


def _snapshot(folder: Path) -> dict:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _staging_left(parent: Path) -> list:
    return [p.name for p in parent.iterdir() if "staging" in p.name]


@pytest.fixture
def user_dir(tmp_path):
    d = tmp_path / "mine"
    (d / "sub").mkdir(parents=True)
    (d / "thesis.docx").write_bytes(b"years of work")
    (d / "sub" / "data.csv").write_text("a,b\n1,2\n")
    return d


def test_new_and_empty_folders_are_allowed(tmp_path):
    p = prepare_output_dir(tmp_path / "a" / "b")
    assert p == tmp_path / "a" / "b" and not p.exists()  # nothing created by the check
    (tmp_path / "empty").mkdir()
    assert prepare_output_dir(tmp_path / "empty") == tmp_path / "empty"


def test_user_folder_is_refused_and_untouched(user_dir):
    before = _snapshot(user_dir)
    with pytest.raises(OutputError, match="not written by berryshaker.*new folder"):
        prepare_output_dir(user_dir)
    ran = []
    with pytest.raises(OutputError):
        with staged_directory(user_dir, kind="study") as stage:
            ran.append(stage)  # never reached: refused before any work
    assert ran == []
    assert _snapshot(user_dir) == before
    assert sorted(p.name for p in user_dir.iterdir()) == ["sub", "thesis.docx"]
    assert _staging_left(user_dir.parent) == []


def test_out_dot_in_a_folder_with_user_files_is_refused(user_dir, monkeypatch):
    monkeypatch.chdir(user_dir)
    with pytest.raises(OutputError, match="mine"):
        prepare_output_dir(".")
    assert (user_dir / "thesis.docx").read_bytes() == b"years of work"


def test_existing_file_and_impossible_parent_are_refused(tmp_path):
    f = tmp_path / "report.html"
    f.write_text("keep me")
    with pytest.raises(OutputError, match="existing file"):
        prepare_output_dir(f)
    with pytest.raises(OutputError, match="is a file"):
        prepare_output_dir(f / "out")
    assert f.read_text() == "keep me"


def test_damaged_marker_is_refused(tmp_path):
    d = tmp_path / "o"
    d.mkdir()
    (d / MARKER_NAME).write_text("{not json")
    (d / "x.txt").write_text("x")
    with pytest.raises(OutputError, match="damaged"):
        prepare_output_dir(d)


def test_check_output_file(tmp_path):
    assert check_output_file(tmp_path / "new" / "s.csv", [".csv"]) == tmp_path / "new" / "s.csv"
    assert not (tmp_path / "new").exists()
    with pytest.raises(OutputError, match="is a folder"):
        check_output_file(tmp_path, [".csv"])
    with pytest.raises(OutputError, match=r"\.csv or \.parquet"):
        check_output_file(tmp_path / "s.xlsx", [".csv", "parquet"])
    with pytest.raises(OutputError, match=r"\.csv"):
        check_output_file(tmp_path / ".csv", [".csv"])  # a bare suffix is not a name
    existing = tmp_path / "s.csv"
    existing.write_text("old")
    with pytest.raises(OutputError, match="--force"):
        check_output_file(existing, [".csv"])
    assert check_output_file(existing, [".CSV"], overwrite=True) == existing
    assert existing.read_text() == "old"
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(OutputError, match="is a file"):
        check_output_file(blocker / "deeper" / "s.csv")


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="permissions do not bind root")
def test_unwritable_parent_is_refused(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        with pytest.raises(OutputError, match="permission"):
            check_output_file(ro / "s.csv")
        with pytest.raises(OutputError, match="permission"):
            prepare_output_dir(ro / "out")
    finally:
        ro.chmod(0o700)


def test_staged_directory_writes_marker_and_leaves_no_staging(tmp_path):
    out = tmp_path / "out"
    with staged_directory(out, kind="study") as stage:
        assert stage.parent == tmp_path and stage.name.startswith(".out.berryshaker-staging.")
        (stage / "report.html").write_text("r1")
        (stage / "figures").mkdir()
        (stage / "figures" / "f1.png").write_bytes(b"png")
    assert (out / "report.html").read_text() == "r1"
    m = read_output_marker(out)
    assert m["kind"] == "study" and m["files"] == ["figures/f1.png", "report.html"] and m["version"] and m["written"]
    assert _staging_left(tmp_path) == []
    assert out.stat().st_mode & 0o777 == 0o777 & ~_umask()  # an ordinary folder, not mkdtemp's 0700


@pytest.mark.parametrize("exc", [RuntimeError, KeyboardInterrupt])
def test_error_inside_the_block_changes_nothing(tmp_path, exc):
    out = tmp_path / "out"
    with staged_directory(out) as stage:
        (stage / "report.html").write_text("first")
    before = _snapshot(out)
    with pytest.raises(exc):
        with staged_directory(out) as stage:
            (stage / "report.html").write_text("second, half-written")
            raise exc()
    assert _snapshot(out) == before
    assert _staging_left(tmp_path) == []
    new = tmp_path / "new"
    with pytest.raises(exc):
        with staged_directory(new) as stage:
            (stage / "a.txt").write_text("a")
            raise exc()
    assert not new.exists() and _staging_left(tmp_path) == []


def test_replacing_a_previous_output_keeps_user_files(tmp_path):
    out = tmp_path / "out"
    with staged_directory(out) as stage:
        (stage / "report.html").write_text("r1")
        (stage / "old_only.csv").write_text("gone next time")
        (stage / "figs").mkdir()
        (stage / "figs" / "a.png").write_text("a1")
    (out / "my_notes.txt").write_text("user notes")  # the user adds files to the output folder
    (out / "figs" / "my_sketch.png").write_text("user sketch")
    with staged_directory(out) as stage:
        (stage / "report.html").write_text("r2")
        (stage / "figs").mkdir()
        (stage / "figs" / "b.png").write_text("b2")
    assert (out / "report.html").read_text() == "r2"
    assert (out / "figs" / "b.png").read_text() == "b2"
    assert not (out / "old_only.csv").exists() and not (out / "figs" / "a.png").exists()  # ours, not rewritten
    assert (out / "my_notes.txt").read_text() == "user notes"
    assert (out / "figs" / "my_sketch.png").read_text() == "user sketch"
    assert read_output_marker(out)["files"] == ["figs/b.png", "report.html"]


def test_user_file_with_an_output_name_stops_the_commit(tmp_path):
    out = tmp_path / "out"
    with staged_directory(out) as stage:
        (stage / "report.html").write_text("r1")
    (out / "summary.json").write_text("the user's own summary")
    before = _snapshot(out)
    with pytest.raises(OutputError, match="summary.json"):
        with staged_directory(out) as stage:
            (stage / "report.html").write_text("r2")
            (stage / "summary.json").write_text("{}")
    assert _snapshot(out) == before and _staging_left(tmp_path) == []


def test_edited_marker_cannot_delete_outside_files(tmp_path):
    out = tmp_path / "out"
    with staged_directory(out) as stage:
        (stage / "a.txt").write_text("a")
    precious = tmp_path / "precious.txt"
    precious.write_text("p")
    m = json.loads((out / MARKER_NAME).read_text())
    m["files"] += ["../precious.txt", str(precious)]
    (out / MARKER_NAME).write_text(json.dumps(m))
    with staged_directory(out) as stage:
        (stage / "b.txt").write_text("b")
    assert precious.read_text() == "p" and (out / "b.txt").exists() and not (out / "a.txt").exists()


def test_stale_staging_folders_are_cleaned(tmp_path):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True).stdout.strip()
    host = _host_tag()
    killed = tmp_path / f".out.berryshaker-staging.{host}-{dead}.abc123"
    old_live = tmp_path / f".out.berryshaker-staging.{host}-{os.getppid()}.old999"
    live = tmp_path / f".out.berryshaker-staging.{host}-{os.getppid()}.new111"
    foreign = tmp_path / ".out.berryshaker-staging.zzzzzz-1.xyz"  # another host tag: not hex, never ours
    other_host = tmp_path / ".out.berryshaker-staging.0a0a0a-1.xyz"
    user = tmp_path / ".out.staging.mine"  # not our pattern
    for d in (killed, old_live, live, foreign, other_host, user):
        d.mkdir()
        (d / "f").write_text("x")
    past = time.time() - 10 * 3600
    os.utime(old_live, (past, past))
    if host == "0a0a0a":
        pytest.skip("hash collision with the test's foreign host tag")
    removed = clean_stale_staging(tmp_path)
    assert sorted(p.name for p in removed) == sorted([killed.name, old_live.name])
    assert live.exists() and foreign.exists() and other_host.exists() and user.exists()
    with staged_directory(tmp_path / "out") as stage:  # a run cleans up before it stages
        (stage / "a").write_text("a")
    assert not killed.exists()


def test_provenance_names_the_code():
    p = provenance(extra_input=1)
    assert p["package"] == "berryshaker" and len(p["code_sha256"]) == 64 and p["extra_input"] == 1
