"""Property-based fuzzing (hypothesis) of where outputs go and of the flags that once gave tracebacks (issue 42).

* Output destinations: a folder filled at random (the user's files, symlinks to files and folders outside it, FIFOs,
  subfolders, an earlier berryshaker output of some command, a marker edited by hand), then a writer (the staging
  of every command, and the cheap commands themselves): whatever happens, no file the writer did not write is
  removed or changed (digests before and after), nothing outside the folder is touched, and a refusal changes
  nothing.  The slow writers run once each, into folders prepared the same way.
* Flag values: out-of-range values of the flags of the traceback list are one message naming the flag (exit 2)
  before any work, never a traceback, a hang or a huge allocation.

Kept small (about 30-60 s in all) so that it runs in CI with every change; ``BERRYSHAKER_FUZZ_EXAMPLES=5000``
explores further with random seeds (CI runs the fixed, derandomised examples)."""

from __future__ import annotations

import hashlib
import json
import os
import stat
from pathlib import Path, PurePosixPath

import pytest
from fuzzing import fuzz, work_dir
from hypothesis import HealthCheck, given
from hypothesis import strategies as st
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.errors import OutputError
from berryshaker.outputs import MARKER_NAME, read_output_marker, staged_directory

runner = CliRunner()
WORK = work_dir("outputs")


_counter = iter(range(10**9))


def _fresh() -> Path:
    """A new case folder (hypothesis runs many examples in one test call: tmp_path is shared)."""
    d = WORK / f"case{next(_counter)}"
    d.mkdir()
    return d


# ---- the state of a tree, by entry: what "removed or changed" means -------------------------------------------
def _state(path: Path):
    st_ = os.lstat(path)
    if stat.S_ISLNK(st_.st_mode):
        return ("link", os.readlink(path))
    if stat.S_ISREG(st_.st_mode):
        return ("file", hashlib.sha256(path.read_bytes()).hexdigest())
    if stat.S_ISFIFO(st_.st_mode):
        return ("fifo",)
    if stat.S_ISDIR(st_.st_mode):
        return ("dir",)
    return ("other", stat.S_IFMT(st_.st_mode))


def _tree(root: Path) -> dict[str, tuple]:
    """Every entry under ``root`` (symlinks not followed) -> its state."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            out[p.relative_to(root).as_posix()] = _state(p)
    return out


def _replaceable(folder: Path, kind: str) -> set[str]:
    """Files the writer ``kind`` may replace or remove: listed for ``kind`` in the marker, a regular file reached
    without any symlink, with the digest the marker recorded (an independent reading of the marker)."""
    try:
        m = json.loads((folder / MARKER_NAME).read_text())
        files = m["outputs"][kind]["files"]
    except (OSError, ValueError, KeyError, TypeError):
        return set()
    ok = set()
    for rel, digest in files.items() if isinstance(files, dict) else ():
        parts = PurePosixPath(rel).parts
        if not parts or PurePosixPath(rel).is_absolute() or ".." in parts or not isinstance(digest, str):
            continue
        p, safe = folder, True
        for part in parts:
            p = p / part
            try:
                st_ = os.lstat(p)
            except OSError:
                safe = False
                break
            if stat.S_ISLNK(st_.st_mode):
                safe = False
                break
        if safe and stat.S_ISREG(os.lstat(p).st_mode) and hashlib.sha256(p.read_bytes()).hexdigest() == digest:
            ok.add(PurePosixPath(rel).as_posix())
    return ok


def _assert_only_own_files_changed(case: Path, folder: Path, kind: str, before: dict, may: set[str],
                                   written: set[str], refused: bool) -> None:
    after = _tree(case)
    name = folder.relative_to(case).as_posix()
    if refused:  # nothing anywhere changed (a staging folder is gone again)
        assert after == before, _diff(before, after)
        return
    for rel, state in before.items():
        inside = rel.startswith(name + "/")
        sub = rel[len(name) + 1:] if inside else None
        if inside and (sub in may or sub in written or sub == MARKER_NAME):
            continue
        if inside and state == ("dir",) and rel not in after:  # an emptied folder of ours may go
            assert not any(k.startswith(rel + "/") for k, s in before.items() if s != ("dir",)
                           and k[len(name) + 1:] not in may), rel
            continue
        assert after.get(rel) == state, f"{rel}: {state} -> {after.get(rel)} (writer {kind})"
    for rel in written:
        assert after.get(f"{name}/{rel}", ("?",))[0] == "file", rel
    assert not [k for k in after if "berryshaker-staging" in k]


def _diff(a: dict, b: dict) -> str:
    keys = sorted(set(a) | set(b))
    return "; ".join(f"{k}: {a.get(k)} -> {b.get(k)}" for k in keys if a.get(k) != b.get(k))


# ---- a destination filled at random ----------------------------------------------------------------------------
KINDS = ["kinematics --plot", "simulate --out", "plant --plot", "sensitivity --plot", "tolerance --plot",
         "wear --plot", "compare --plot", "study"]
NAMES = ["svaj.png", "provenance.json", "summary.json", "timeseries.csv", "mode_shapes.png", "figs/a.png",
         "figs/b.png", "sub/x.png", "wear_clearance.png", "notes.txt", "tolerance_pareto.png"]

entry = st.tuples(st.sampled_from(NAMES), st.sampled_from(["file", "link_file", "link_dir", "fifo", "dir"]))
mutation = st.tuples(st.sampled_from(["edit", "to_link", "to_fifo", "delete", "dir_to_link", "add_entry",
                                      "add_outside", "add_through_link", "damage", "other_kind"]),
                     st.sampled_from(NAMES))


def _make(case: Path, folder: Path, rel: str, how: str) -> None:
    p = folder / rel
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        return
    if p.exists() or p.is_symlink():
        return
    outside = case / "outside"
    if how == "file":
        p.write_text(f"the user's {rel}")
    elif how == "link_file":
        p.symlink_to(outside / "precious.txt")
    elif how == "link_dir":
        p.symlink_to(outside, target_is_directory=True)
    elif how == "fifo":
        os.mkfifo(p)
    else:
        p.mkdir()
        (p / "inside.txt").write_text("the user's")


def _populate(case: Path, earlier: tuple | None, extra: list, mutations: list) -> Path:
    """``case/out``: an earlier output (kind, names) or none, the user's entries, then mutations; and
    ``case/outside`` with files that must never change."""
    outside = case / "outside"
    outside.mkdir()
    (outside / "precious.txt").write_text("outside the output folder")
    for n in NAMES:  # same names outside: a link or a hand-edited marker entry could reach them
        q = outside / n
        q.parent.mkdir(parents=True, exist_ok=True)
        q.write_text(f"outside {n}")
    folder = case / "out"
    if earlier is not None:
        kind, names = earlier
        with staged_directory(folder, kind=kind) as stage:
            for n in names:
                (stage / n).parent.mkdir(parents=True, exist_ok=True)
                (stage / n).write_text(f"{kind} wrote {n}")
    else:
        folder.mkdir()
    for rel, how in extra:
        _make(case, folder, rel, how)
    marker_path = folder / MARKER_NAME
    for what, rel in mutations:
        p = folder / rel
        m = read_output_marker(folder)
        if what == "edit" and p.is_file() and not p.is_symlink():
            p.write_text("changed by the user")
        elif what == "to_link" and (p.is_file() or p.is_symlink()):
            if p.is_file():  # the same bytes outside: only the link stands between them and removal
                (outside / rel).write_bytes(p.read_bytes())
            p.unlink()
            p.symlink_to(outside / rel)
        elif what == "to_fifo" and p.is_file() and not p.is_symlink():
            p.unlink()
            os.mkfifo(p)
        elif what == "delete" and p.is_file() and not p.is_symlink():
            p.unlink()
        elif what == "dir_to_link" and "/" in rel and p.parent.is_dir() and not p.parent.is_symlink():
            import shutil

            twin = outside / rel.split("/")[0]  # a copy outside, the same bytes, reached through the link
            shutil.rmtree(twin)
            shutil.copytree(p.parent, twin, symlinks=True, ignore=lambda d, names: [
                n for n in names if not (Path(d) / n).is_dir() and not (Path(d) / n).is_file()])  # no FIFOs
            shutil.rmtree(p.parent)
            p.parent.symlink_to(twin, target_is_directory=True)
        elif m is not None and what in ("add_entry", "add_outside", "add_through_link", "other_kind"):
            outs = m.setdefault("outputs", {})
            kind = m.get("kind", "study") if what != "other_kind" else "plant --plot"
            files = outs.setdefault(kind, {"files": {}}).setdefault("files", {})
            target = {"add_entry": rel, "add_outside": f"../outside/{rel}", "other_kind": rel,
                      "add_through_link": rel}[what]
            if what == "add_outside":
                digest = hashlib.sha256((outside / rel).read_bytes()).hexdigest()
            elif p.is_file():
                digest = hashlib.sha256(p.read_bytes()).hexdigest()
            else:
                digest = "0" * 64
            files[target] = digest
            files[str(outside / rel)] = hashlib.sha256((outside / rel).read_bytes()).hexdigest()
            m["files"] = sorted(set(m["files"]) | {target})
            marker_path.write_text(json.dumps(m))
        elif what == "damage" and marker_path.exists():
            marker_path.write_text(marker_path.read_text()[:20])
    return folder


earlier_outputs = st.one_of(st.none(), st.tuples(st.sampled_from(KINDS),
                                                 st.lists(st.sampled_from(NAMES), min_size=1, max_size=4,
                                                          unique=True)))


@fuzz(150, HealthCheck.function_scoped_fixture)
@given(earlier=earlier_outputs, extra=st.lists(entry, max_size=4), data=st.data(), same_kind=st.booleans(),
       new=st.lists(st.sampled_from(NAMES), min_size=1, max_size=4, unique=True))
def test_a_writer_changes_only_its_own_files(earlier, extra, data, same_kind, new):
    """Any destination, any writer (the staging every command writes through): the files it may replace are
    its own unchanged ones; everything else -- the user's, another command's, changed files, what symlinks
    point to, the folder's neighbours -- is the same afterwards, and a refusal changes nothing."""
    # half the time the writer is the earlier output's own command, and mutations hit the earlier output's files
    kind = earlier[0] if same_kind and earlier else data.draw(st.sampled_from(KINDS))
    names = st.sampled_from(earlier[1]) if earlier else st.sampled_from(NAMES)
    mutations = data.draw(st.lists(st.tuples(mutation.map(lambda m: m[0]), st.one_of(names, st.sampled_from(NAMES))),
                                   max_size=3))
    case = _fresh()
    folder = _populate(case, earlier, extra, mutations)
    before = _tree(case)
    may = _replaceable(folder, kind)
    refused = False
    try:
        with staged_directory(folder, kind=kind) as stage:
            for n in new:
                (stage / n).parent.mkdir(parents=True, exist_ok=True)
                (stage / n).write_text(f"{kind} now wrote {n}")
    except OutputError:
        refused = True
    _assert_only_own_files_changed(case, folder, kind, before, may, set(new), refused)
    if not refused:
        m = read_output_marker(folder)
        assert set(m["outputs"][kind]["files"]) == set(new)
        for n in new:
            assert (folder / n).read_text() == f"{kind} now wrote {n}"


# ---- the cheap commands themselves -------------------------------------------------------------------------------
def _cheap_command(which: str, folder: Path, force: bool) -> tuple[list[str], str, set[str]]:
    """(arguments, kind, files it writes relative to ``folder``) of a cheap writing command."""
    if which == "kinematics":
        return ["kinematics", "--plot", str(folder)], "kinematics --plot", {
            "svaj.png", "groove_profile.png", "comb_angles.png", "provenance.json"}
    if which == "plant":
        return ["plant", "--plot", str(folder)], "plant --plot", {"mode_shapes.png", "provenance.json"}
    f = ["--force"] if force else []
    if which == "config init":
        return ["config", "init", str(folder / "summary.json"), *f], "", {"summary.json"}
    if which == "cam-profile":
        return ["cam-profile", "--out", str(folder / "timeseries.csv"), "--points", "90", *f], "", {"timeseries.csv"}
    return ["doe", "plan", "--array", "L4", "--factor", "A=1,2mm", "--factor", "B=1,2mm", "--out",
            str(folder / "notes.html"), *f], "", {"notes.html", "notes.csv"}


@fuzz(8, HealthCheck.function_scoped_fixture)
@given(earlier=earlier_outputs, extra=st.lists(entry, max_size=4), mutations=st.lists(mutation, max_size=2),
       which=st.sampled_from(["kinematics", "plant", "config init", "cam-profile", "doe plan"]),
       force=st.booleans())
def test_cheap_commands_change_only_their_own_files(earlier, extra, mutations, which, force):
    case = _fresh()
    folder = _populate(case, earlier, extra, mutations)
    args, kind, written = _cheap_command(which, folder, force)
    before = _tree(case)
    may = _replaceable(folder, kind) if kind else set()
    if force and not kind:  # --force replaces the named file if it is a regular file, never anything else
        named = folder / Path(args[args.index("--out") + 1] if "--out" in args else args[2]).name
        if named.is_file() and not named.is_symlink():
            may.add(named.name)
    r = runner.invoke(app, args)
    assert r.exit_code in (0, 2), f"{args}: exit {r.exit_code}\n{r.output}\n{r.exception!r}"
    assert "Traceback" not in r.output
    after = _tree(case)
    if r.exit_code == 2:
        assert after == before, _diff(before, after)
        return
    if not kind:  # a single file: what existed before is unchanged unless it was the named, replaced file
        for rel, state in before.items():
            name = rel.split("/", 1)[1] if rel.startswith("out/") else None
            if name in may or name in written and state[0] != "file":
                continue
            if name in written:  # an existing file is replaced only when named with --force
                assert force and name in may, (rel, args)
                continue
            assert after.get(rel) == state, f"{rel}: {state} -> {after.get(rel)} ({args})"
        return
    _assert_only_own_files_changed(case, folder, kind, before, may, written, refused=False)


# ---- the slow writers, once each -------------------------------------------------------------------------------
def _filled_sheet(case: Path) -> Path:
    sheet = case / "sheet.csv"
    r = runner.invoke(app, ["doe", "plan", "--array", "L4", "--factor", "A=1,2mm", "--factor", "B=1,2mm",
                            "--replicates", "1", "--out", str(sheet)])
    assert r.exit_code == 0, r.output
    lines = sheet.read_text().strip().split("\n")
    head = lines[0].split(",")
    rows = [ln.split(",") for ln in lines[1:]]
    for k, row in enumerate(rows):
        for i, h in enumerate(head):
            if h.startswith(("efficiency", "unripe", "damage", "duration", "picked")):
                row[i] = str(1.0 + 0.3 * k + 0.1 * i)
    sheet.write_text(",".join(head) + "\n" + "\n".join(",".join(r) for r in rows) + "\n")
    return sheet


SLOW = {  # command -> (arguments before the destination flag, flag, kind, files written)
    "simulate": (["simulate", "-n", "2"], "--out", "simulate --out",
                 {"timeseries.csv", "summary.json", "collision_forces.png", "moments.png"}),
    "simulate multibody": (["simulate", "-m", "multibody", "-n", "2"], "--out", "simulate --out",
                           {"timeseries.csv", "summary.json", "collision_forces.png"}),
    "compare": (["compare", "--starts", "0", "-n", "2"], "--plot", "compare --plot",
                {"compare_A.png", "compare_B.png", "compare_C.png", "compare_F.png", "provenance.json"}),
    "fruit-force --plot": (["fruit-force"], "--plot", "fruit-force --plot", {"fruit_force.png", "provenance.json"}),
    "fruit-force --out": (["fruit-force"], "--out", "fruit-force --out", {"fruit_force.csv", "summary.json"}),
    "sensitivity": (["sensitivity", "--samples", "2"], "--plot", "sensitivity --plot",
                    {f"sobol_collision_force_{p}_peak.png" for p in "ABCF"}),
    "tolerance": (["tolerance", "--points", "2", "--pop-size", "4", "--generations", "2"], "--plot",
                  "tolerance --plot", {"tolerance_pareto.png"}),
    "wear": (["wear", "--hours", "1"], "--plot", "wear --plot", {"wear_clearance.png"}),
    "doe analyze": (["doe", "analyze", "SHEET", "--maximize", "efficiency", "--minimize", "unripe,damage"],
                    "--plot", "doe analyze --plot", {"main_effects.png", "provenance.json", "surface_efficiency.png",
                                                     "surface_unripe.png", "surface_damage.png"}),
}


@pytest.mark.parametrize("name", sorted(SLOW))
def test_every_slow_writer_once_keeps_what_it_did_not_write(name, tmp_path):
    """Each slow writer once into a folder holding an earlier kinematics output, the user's notes, a FIFO, links to
    a file and a folder outside, and (a second time) into its own earlier output with one figure changed."""
    case = tmp_path / "case"
    case.mkdir()
    folder = _populate(case, ("kinematics --plot", ["svaj.png", "provenance.json", "figs/a.png"]),
                       [("notes.txt", "file"), ("figs/b.png", "fifo"), ("sub/x.png", "link_file"),
                        ("tolerance_pareto.png".replace(".png", "_old"), "link_dir")], [])
    head, flag, kind, written = SLOW[name]
    head = [str(_filled_sheet(case)) if a == "SHEET" else a for a in head]
    args = head + [flag, str(folder), "--cache", str(tmp_path / "cache")] if name != "doe analyze" else \
        head + [flag, str(folder)]
    if name in ("simulate", "simulate multibody", "fruit-force --plot", "fruit-force --out", "doe analyze"):
        args = [a for a in args if a != "--cache" and a != str(tmp_path / "cache")]
    before = _tree(case)
    may = _replaceable(folder, kind)
    r = runner.invoke(app, args)
    assert r.exit_code in (0, 2), f"{args}: exit {r.exit_code}\n{r.output}\n{r.exception!r}"
    if "provenance.json" in written:  # the kinematics output's own provenance.json: kept, the writer refused
        assert r.exit_code == 2 and "provenance.json (kinematics --plot)" in r.output, r.output
    else:
        assert r.exit_code == 0, r.output
    _assert_only_own_files_changed(case, folder, kind, before, may, written, refused=r.exit_code == 2)
    if r.exit_code == 0:  # again, with one of its files changed by the user: refused, nothing changed
        changed = folder / sorted(written)[0]
        changed.write_bytes(b"edited")
        before = _tree(case)
        r = runner.invoke(app, args)
        assert r.exit_code == 2 and sorted(written)[0] in r.output, r.output
        assert _tree(case) == before


# ---- flag values of the traceback list -------------------------------------------------------------------------
def _out_of(lo: int, hi: int):
    return st.one_of(st.integers(max_value=lo - 1), st.integers(min_value=hi + 1),
                     st.sampled_from([lo - 1, hi + 1, -(2**63), 2**63]))


FLAGS = {  # command, flag, invalid values
    "sensitivity --seed": (["sensitivity"], "--seed", _out_of(0, 2**32 - 1)),
    "sensitivity --samples": (["sensitivity"], "--samples", _out_of(2, 2**16)),
    "tolerance --pop-size": (["tolerance"], "--pop-size", _out_of(2, 10_000)),
    "tolerance --generations": (["tolerance"], "--generations", _out_of(1, 100_000)),
    "tolerance --points": (["tolerance"], "--points", _out_of(2, 64)),
    "tolerance --seed": (["tolerance"], "--seed", _out_of(0, 2**32 - 1)),
    "cam-profile --points": (["cam-profile", "--out", "CASE/cam.csv"], "--points", _out_of(90, 100_000)),
    "wear --revolutions": (["wear", "--hours", "1"], "--revolutions", _out_of(2, 200)),
    "sensitivity --revolutions": (["sensitivity"], "--revolutions", _out_of(2, 200)),
    "compare --points": (["compare", "--starts", "0"], "--points", _out_of(4, 10_000)),
    "wear --joint": (["wear", "--hours", "1"], "--joint",
                     st.text(min_size=1, max_size=6).filter(lambda s: s not in ("A", "B", "C", "F")
                                                            and not s.startswith("-"))),
}


@fuzz(40, HealthCheck.function_scoped_fixture)
@given(which=st.sampled_from(sorted(FLAGS)), data=st.data())
def test_out_of_range_flags_are_one_message_before_any_work(which, data):
    head, flag, values = FLAGS[which]
    value = data.draw(values)
    case = _fresh()
    args = [a.replace("CASE", str(case)) for a in head] + [flag, str(value), "--cache", str(case / "cache")]
    if which.startswith(("cam-profile", "compare")):
        args = args[:-2]
    r = runner.invoke(app, args)
    assert r.exit_code == 2, f"{args}: exit {r.exit_code}\n{r.output}\n{r.exception!r}"
    assert "Traceback" not in r.output and flag in r.output, (args, r.output)
    assert not (case / "cam.csv").exists()


@fuzz(20, HealthCheck.function_scoped_fixture)
@given(where=st.sampled_from(["file_parent", "fifo", "folder", "device", "proc", "proc_self", "deep_new"]),
       force=st.booleans(), command=st.sampled_from(["config init", "kinematics --plot", "plant --plot",
                                                     "cam-profile", "doe plan"]))
def test_impossible_destinations_are_one_message(where, force, command):
    """A destination under a file, a FIFO, a folder given for a file, a device, /proc: exit 2 and nothing changed;
    a new nested path is created."""
    case = _fresh()
    (case / "a_file").write_text("x")
    dest = {"file_parent": case / "a_file" / "x", "fifo": case / "fifo", "folder": case / "folder",
            "device": case / "device", "proc": Path("/proc/berryshaker-fuzz"),
            "proc_self": Path("/proc/self/berryshaker-fuzz"), "deep_new": case / "new" / "deeper" / "x"}[where]
    if where == "fifo":
        os.mkfifo(dest)
    elif where == "folder":
        dest.mkdir()
        (dest / "mine.txt").write_text("the user's")
    elif where == "device":
        try:
            os.mknod(dest, 0o600 | stat.S_IFCHR, os.makedev(1, 3))  # never /dev/null itself
        except PermissionError:
            os.mkfifo(dest)
    if str(dest).startswith("/proc") and not Path("/proc/self").is_dir():
        return
    suffix = {"config init": ".toml", "cam-profile": ".csv", "doe plan": ".csv"}.get(command, "")
    target = dest if where in ("fifo", "device", "folder") or not suffix else dest.with_name(dest.name + suffix)
    f = ["--force"] if force else []
    args = {"config init": ["config", "init", str(target), *f],
            "kinematics --plot": ["kinematics", "--plot", str(target)],
            "plant --plot": ["plant", "--plot", str(target)],
            "cam-profile": ["cam-profile", "--out", str(target), "--points", "90", *f],
            "doe plan": ["doe", "plan", "--array", "L4", "--factor", "A=1,2mm", "--factor", "B=1,2mm", "--out",
                         str(target), *f]}[command]
    before = _tree(case)
    r = runner.invoke(app, args)
    assert r.exit_code in (0, 2), f"{args}: exit {r.exit_code}\n{r.output}\n{r.exception!r}"
    assert "Traceback" not in r.output
    if where == "deep_new":
        assert r.exit_code == 0 or command == "cam-profile" and r.exit_code == 2, r.output
        return
    if where == "folder" and command.endswith("--plot"):  # the user's folder: refused
        assert r.exit_code == 2
    if where != "folder" or not command.endswith("--plot"):
        assert r.exit_code == 2, (args, r.output)
    assert _tree(case) == before, _diff(before, _tree(case))
