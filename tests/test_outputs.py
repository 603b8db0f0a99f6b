"""Output destinations: refusals before any work, marker-based replacement that never touches the user's
files, staging folders that never outlive their run."""

import json
import os
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest

from berryshaker.errors import OutputError
from berryshaker.outputs import (
    MARKER_NAME,
    check_output_file,
    clean_stale_staging,
    current_umask,
    prepare_output_dir,
    provenance,
    read_output_marker,
    staged_directory,
)
from berryshaker.outputs.staging import _host_tag


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


def test_unwritable_parent_is_refused(tmp_path):
    """A folder the process may not write into is refused before any work.  Permission bits do not bind root (CI
    runs as root), so as root the folder is made immutable (``chattr +i``: not even root may create a file in it)."""
    import shutil

    ro = tmp_path / "ro"
    ro.mkdir()
    if os.geteuid() == 0:
        assert shutil.which("chattr"), "chattr (e2fsprogs) is needed to make a folder unwritable for root"
        subprocess.run(["chattr", "+i", str(ro)], check=True)
        undo = ["chattr", "-i", str(ro)]
    else:
        ro.chmod(0o500)
        undo = ["chmod", "700", str(ro)]
    try:
        with pytest.raises(OSError):  # the precondition: this process really cannot write there
            (ro / "probe").write_text("")
        with pytest.raises(OutputError, match="permission"):
            check_output_file(ro / "s.csv")
        with pytest.raises(OutputError, match="permission"):
            prepare_output_dir(ro / "out")
    finally:
        subprocess.run(undo, check=True)


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
    assert out.stat().st_mode & 0o777 == 0o777 & ~current_umask()  # an ordinary folder, not mkdtemp's 0700


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
    other_tag = "0a0a0a" if host != "0a0a0a" else "0b0b0b"  # a hex tag that is not this host's
    other_host = tmp_path / f".out.berryshaker-staging.{other_tag}-1.xyz"
    user = tmp_path / ".out.staging.mine"  # not our pattern
    for d in (killed, old_live, live, foreign, other_host, user):
        d.mkdir()
        (d / "f").write_text("x")
    past = time.time() - 10 * 3600
    os.utime(old_live, (past, past))
    removed = clean_stale_staging(tmp_path)
    assert sorted(p.name for p in removed) == sorted([killed.name, old_live.name])
    assert live.exists() and foreign.exists() and other_host.exists() and user.exists()
    with staged_directory(tmp_path / "out") as stage:  # a run cleans up before it stages
        (stage / "a").write_text("a")
    assert not killed.exists()


def test_provenance_names_the_code():
    p = provenance(extra_input=1)
    assert p["package"] == "berryshaker" and len(p["code_sha256"]) == 64 and p["extra_input"] == 1


# ---- markers own only their command's files, by digest (issue 42) ----------------------------------------------
def _files(folder: Path) -> dict:
    return {k: v for k, v in _snapshot(folder).items() if k != MARKER_NAME}


def _write(kind, out, files):
    with staged_directory(out, kind=kind) as stage:
        for rel, text in files.items():
            (stage / rel).parent.mkdir(parents=True, exist_ok=True)
            (stage / rel).write_text(text)


def test_marker_records_the_command_and_a_digest_per_file(tmp_path):
    import hashlib

    out = tmp_path / "out"
    _write("kinematics --plot", out, {"svaj.png": "s", "figs/g.png": "g"})
    m = read_output_marker(out)
    files = m["outputs"]["kinematics --plot"]["files"]
    assert files == {"figs/g.png": hashlib.sha256(b"g").hexdigest(), "svaj.png": hashlib.sha256(b"s").hexdigest()}
    assert m["kind"] == "kinematics --plot" and m["files"] == ["figs/g.png", "svaj.png"]


def test_another_command_keeps_the_first_commands_files(tmp_path):
    out = tmp_path / "out"
    _write("kinematics --plot", out, {"svaj.png": "s", "provenance.json": "p"})
    _write("simulate --out", out, {"timeseries.csv": "t", "summary.json": "j"})
    assert _files(out) == {"svaj.png": b"s", "provenance.json": b"p", "timeseries.csv": b"t",
                              "summary.json": b"j"}
    _write("simulate --out", out, {"timeseries.csv": "t2"})  # its own summary.json goes, the figures stay
    assert _files(out) == {"svaj.png": b"s", "provenance.json": b"p", "timeseries.csv": b"t2"}
    owners = read_output_marker(out)["outputs"]
    assert set(owners["kinematics --plot"]["files"]) == {"svaj.png", "provenance.json"}
    assert set(owners["simulate --out"]["files"]) == {"timeseries.csv"}
    before = _snapshot(out)
    with pytest.raises(OutputError, match=r"provenance.json \(kinematics --plot\)"):
        _write("plant --plot", out, {"mode_shapes.png": "m", "provenance.json": "p2"})
    assert _snapshot(out) == before and _staging_left(tmp_path) == []


def test_a_changed_file_is_never_replaced_nor_removed(tmp_path):
    out = tmp_path / "out"
    _write("sensitivity --plot", out, {"sobol_a.png": "a", "sobol_b.png": "b"})
    (out / "sobol_a.png").write_text("the user's edit")
    before = _snapshot(out)
    with pytest.raises(OutputError, match="sobol_a.png changed"):
        prepare_output_dir(out, kind="sensitivity --plot")  # refused before any work
    for files in ({"sobol_a.png": "a2"}, {"sobol_b.png": "b2"}):  # replaced, or left over and removed
        with pytest.raises(OutputError, match="sobol_a.png"):
            _write("sensitivity --plot", out, files)
        assert _snapshot(out) == before
    prepare_output_dir(out, kind="tolerance --plot")  # another command may write beside it


def test_a_marker_entry_through_a_symlink_is_never_removed(tmp_path):
    out, outside = tmp_path / "out", tmp_path / "outside"
    _write("compare --plot", out, {"sub/x.png": "x", "a.png": "a"})
    outside.mkdir()
    (outside / "x.png").write_text("x")  # the same bytes: only the link stands between it and removal
    (out / "sub" / "x.png").unlink()
    (out / "sub").rmdir()
    (out / "sub").symlink_to(outside, target_is_directory=True)
    with pytest.raises(OutputError, match="sub/x.png"):
        _write("compare --plot", out, {"a.png": "a2"})
    assert (outside / "x.png").read_text() == "x" and (out / "a.png").read_text() == "a"
    # a marker edited to name the outside file directly (absolute, .., through the link) removes nothing either
    m = json.loads((out / MARKER_NAME).read_text())
    m["outputs"]["compare --plot"]["files"] = {"../outside/x.png": None, str(outside / "x.png"): None, "a.png":
                                               m["outputs"]["compare --plot"]["files"]["a.png"]}
    (out / MARKER_NAME).write_text(json.dumps(m))
    _write("compare --plot", out, {"b.png": "b"})
    assert (outside / "x.png").read_text() == "x" and not (out / "a.png").exists()


def test_a_marker_entry_that_is_a_symlink_is_kept(tmp_path):
    out, precious = tmp_path / "out", tmp_path / "precious.txt"
    _write("wear --plot", out, {"w.png": "w"})
    precious.write_text("p")
    (out / "w.png").unlink()
    (out / "w.png").symlink_to(precious)
    with pytest.raises(OutputError, match="w.png"):
        _write("wear --plot", out, {"other.png": "o"})
    assert precious.read_text() == "p" and (out / "w.png").is_symlink()


def test_an_older_marker_without_digests(tmp_path):
    """A marker of the earlier format lists files without checksums: whatever the file times say (older than the
    marker, a marker dated in the future), none of them is replaced or removed (issue 59: svaj.png overwritten and
    notes.txt deleted); the folder is refused naming them, until they are moved away."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.html").write_text("old")
    (out / "gone.csv").write_text("old")
    old = {"package": "berryshaker", "kind": "study", "version": "0.0.9", "files": ["report.html", "gone.csv"],
           "written": "2026-01-01T00:00:00+00:00"}
    past = time.time() - 400 * 86400  # before the marker was written: the old rule trusted these
    for written in (old["written"], "2999-01-01T00:00:00+00:00"):  # a marker date in the future trusted every file
        (out / MARKER_NAME).write_text(json.dumps({**old, "written": written}))
        for f in ("report.html", "gone.csv"):
            os.utime(out / f, (past, past))
        before = _files(out)
        with pytest.raises(OutputError, match="without checksums") as e:
            _write("study", out, {"report.html": "new"})
        assert "gone.csv" in str(e.value) and "report.html" in str(e.value)
        assert _files(out) == before
    (out / "gone.csv").unlink()  # the user moved them away: the folder is written
    (out / "report.html").unlink()
    _write("study", out, {"report.html": "new"})
    assert _files(out) == {"report.html": b"new"}
    # the files of an older marker of another kind are kept, and block their names
    (out / MARKER_NAME).write_text(json.dumps({**old, "kind": "plots", "files": ["report.html"]}))
    with pytest.raises(OutputError, match="report.html"):
        _write("study", out, {"report.html": "newer"})
    assert (out / "report.html").read_text() == "new"


def test_outputs_under_proc_are_refused_before_any_work(tmp_path):
    if not Path("/proc/self").is_dir():
        pytest.skip("no /proc")
    for bad in ("/proc/berryshaker-test", "/proc/self/berryshaker-test/sub"):
        with pytest.raises(OutputError):
            prepare_output_dir(bad, kind="kinematics --plot")
        with pytest.raises(OutputError):
            check_output_file(bad + ".csv", allowed_suffixes=(".csv",))


def test_doe_plan_force_replaces_only_the_named_sheet(tmp_path):
    from typer.testing import CliRunner

    from berryshaker.cli import app

    cli = CliRunner()
    args = ["doe", "plan", "--array", "L4", "--factor", "A=1,2mm", "--factor", "B=1,2mm"]
    csv, html = tmp_path / "trial.csv", tmp_path / "trial.html"
    assert cli.invoke(app, args + ["--out", str(html)]).exit_code == 0
    assert cli.invoke(app, args + ["--out", str(html), "--force"]).exit_code == 0  # its own pair: replaced
    csv.write_text(csv.read_text() + "filled in the field\n")
    before = _snapshot(tmp_path)
    r = cli.invoke(app, args + ["--out", str(html), "--force"])
    assert r.exit_code == 2 and "trial.csv" in r.output and _snapshot(tmp_path) == before
    r = cli.invoke(app, args + ["--out", str(csv), "--force"])  # named: replaced
    assert r.exit_code == 0 and "filled" not in csv.read_text()
    html.write_text(html.read_text().replace("field sheet", "my notes"))
    before = _snapshot(tmp_path)
    r = cli.invoke(app, args + ["--out", str(csv), "--force"])
    assert r.exit_code == 2 and "trial.html" in r.output and _snapshot(tmp_path) == before


@pytest.mark.parametrize("make", ["fifo", "folder", "device"])
def test_config_init_refuses_a_non_regular_destination_even_with_force(tmp_path, make):
    from typer.testing import CliRunner

    from berryshaker.cli import app

    dest = tmp_path / "dest.toml"
    if make == "fifo":
        os.mkfifo(dest)
    elif make == "folder":
        dest.mkdir()
    else:  # a device node of its own (never /dev/null: a regression would replace the system's)
        try:
            os.mknod(dest, 0o600 | stat.S_IFCHR, os.makedev(1, 3))
        except PermissionError:  # not root: a socket is another non-regular file
            import socket

            sock = socket.socket(socket.AF_UNIX)
            sock.bind(str(dest))
            sock.close()
    r = CliRunner().invoke(app, ["config", "init", str(dest), "--force"])
    assert r.exit_code == 2 and "Traceback" not in r.output, r.output
    assert dest.exists() and not dest.is_file()
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    r = CliRunner().invoke(app, ["config", "init", str(blocker / "x.toml")])
    assert r.exit_code == 2 and "is a file, not a folder" in r.output and blocker.read_text() == "x"
