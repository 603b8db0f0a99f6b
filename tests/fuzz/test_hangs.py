"""Nothing hangs: property-based fuzzing (hypothesis, in the style of tests/fuzz/test_field_sheet_fuzz.py) of the inputs that used to
make a run loop for ever or work for minutes without a bound, and the subprocess tests of Ctrl-C.

* a push rod that self-locks in its guide is refused by ``config validate`` naming push_rod.friction_coefficient
  and the limit of its geometry; a machine that passes runs to its end (or stops within its step budget), never
  jams (drives.groove_cam.kinematics.self_locking_limit);
* a jammed MLSD run is stopped and named at run time, within its budget, not looped (drives.groove_cam.mlsd);
* a long compiled run (MLSD, multibody engine) stops on SIGINT: exit code 130 and one short message;
* the counts that multiply work (sweep --points, doe --replicates) have a bound checked before the work.

The hang guards are generous subprocess timeouts (60 s), never a wall-time assertion."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from fuzzing import fuzz, work_dir
from hypothesis import example, given
from hypothesis import strategies as st
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.config import machine_from_dict, reference_machine, validate_machine
from berryshaker.errors import ConfigError, GeometryError, SimulationError

runner = CliRunner()
WORK = work_dir("hangs")
#: the hang guard of a subprocess (s): generous; a hang is minutes
HANG_GUARD_S = 60


def _child_env() -> dict:
    """The environment of a child python: this checkout's sources first (as the tests import them)."""
    src = str(Path(__file__).resolve().parents[2] / "src")
    return dict(os.environ, PYTHONPATH=src + os.pathsep + os.environ.get("PYTHONPATH", ""))


def _run_child(code: str, timeout: float = HANG_GUARD_S) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh python with the hang guard; a child still running after it fails the test."""
    try:
        return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                              timeout=timeout, env=_child_env())
    except subprocess.TimeoutExpired:
        pytest.fail(f"the child ran for more than {timeout} s: it hangs")


def _interrupt_child(code: str, after_ready_s: float = 2.0) -> tuple[int, str, str]:
    """Start ``code`` in a fresh python, wait for the line ``ready`` on its stdout (printed just before the long
    work), send SIGINT ``after_ready_s`` later and return (exit code, stdout, stderr) under the hang guard.  The
    child restores Python's SIGINT handler itself (a shell's background job starts with SIGINT ignored)."""
    head = "import signal; signal.signal(signal.SIGINT, signal.default_int_handler)\n"
    p = subprocess.Popen([sys.executable, "-c", head + textwrap.dedent(code)], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, env=_child_env())
    try:
        line = p.stdout.readline()
        assert line.strip() == "ready", (line, p.stderr.read() if p.poll() is not None else "")
        try:
            p.wait(after_ready_s)
        except subprocess.TimeoutExpired:
            pass
        assert p.poll() is None, "the long work ended before it could be interrupted: make it longer"
        p.send_signal(signal.SIGINT)
        try:
            out, err = p.communicate(timeout=HANG_GUARD_S)
        except subprocess.TimeoutExpired:
            pytest.fail(f"the run went on for more than {HANG_GUARD_S} s after SIGINT: Ctrl-C is not seen")
        return p.returncode, out, err
    finally:
        if p.poll() is None:
            p.kill()
            p.communicate()


# ---- self-locking push rod: refused before a run, and a machine that passes runs -----------------------------
REFERENCE = reference_machine()


def _machine(friction: float, g_x: float, h_x: float, base_radius: float):
    data = REFERENCE.model_dump(mode="json")
    data["push_rod"].update(friction_coefficient=friction, bearing_G_x=g_x, bearing_H_x=h_x)
    data["cam"]["base_radius"] = base_radius
    return machine_from_dict(data, "(fuzz)")


@fuzz(25)
@given(friction=st.floats(0.0, 3.0), g_x=st.floats(-0.1, 0.6), h_x=st.floats(-0.1, 0.6),
       base_radius=st.floats(0.05, 0.2))
@example(friction=1.0, g_x=0.18, h_x=0.32, base_radius=REFERENCE.cam.base_radius)  # the fuzzer's finding
def test_guide_friction_is_refused_or_the_drive_runs(friction, g_x, h_x, base_radius):
    """Whatever the guide friction and the guide's and cam's geometry, the machine is refused (a self-locking
    push rod by name, with its limit) or a short MLSD run of it finishes or stops within its step budget, never
    with the push rod jammed behind its cam."""
    from berryshaker.drives.groove_cam.kinematics import self_locking_limit
    from berryshaker.drives.groove_cam.mlsd import simulate_mlsd

    try:
        machine = _machine(friction, g_x, h_x, base_radius)
        validate_machine(machine)
    except (ConfigError, GeometryError) as exc:
        if "self-locks" in str(exc):
            assert "push_rod.friction_coefficient" in str(exc) and "limit of this geometry" in str(exc)
            assert friction >= self_locking_limit(machine).mu_limit
        return
    assert friction < self_locking_limit(machine).mu_limit
    try:
        res = simulate_mlsd(machine, revolutions=2)
    except SimulationError as exc:  # within its budget: a stiff run may stop, a validated drive does not jam
        assert "The drive jams" not in str(exc), str(exc)
        return
    assert res.steps > 0


def test_config_validate_names_the_self_locking_limit(tmp_path):
    """The fuzzer's machine (friction 1.0 in the reference guide) is refused by `config validate`."""
    from berryshaker.config import reference_toml_text

    text = reference_toml_text().replace("friction_coefficient = 0.05   # mu2", "friction_coefficient = 1.0   # mu2")
    assert "friction_coefficient = 1.0   # mu2" in text
    path = tmp_path / "locked.toml"
    path.write_text(text)
    r = runner.invoke(app, ["config", "validate", str(path)])
    assert r.exit_code == 2
    assert "push_rod.friction_coefficient = 1 self-locks" in r.output and "limit of this geometry is 0.9" in r.output


def test_a_jammed_mlsd_run_is_stopped_and_named():
    """A self-locking drive that reaches a run (the check bypassed) is stopped at run time, within its budget, with
    the jam named, not looped for ever (the hang guard is the child's timeout)."""
    r = _run_child("""
        from berryshaker.config import reference_machine
        from berryshaker.drives.groove_cam import kinematics
        from berryshaker.drives.groove_cam.mlsd import simulate_mlsd
        from berryshaker.errors import SimulationError

        kinematics.check_self_locking = lambda machine: None  # as if the check were not there
        m = reference_machine()
        m = m.model_copy(update={"push_rod": m.push_rod.model_copy(update={"friction_coefficient": 1.0})})
        try:
            simulate_mlsd(m)
        except SimulationError as exc:
            print("SimulationError:", exc)
        else:
            print("finished")
    """)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("SimulationError:"), r.stdout
    assert "The drive jams" in r.stdout and "push_rod.friction_coefficient = 1" in r.stdout


@fuzz(10)
@given(max_steps=st.integers(1, 30_000))
def test_mlsd_step_budget_stops_the_run_with_a_clear_error(max_steps):
    """Any step budget: the run finishes within it or stops with an error that says so and what to change."""
    from berryshaker.drives.groove_cam.mlsd import simulate_mlsd

    try:
        res = simulate_mlsd(REFERENCE, revolutions=2, max_steps=max_steps)
    except SimulationError as exc:
        assert f"more than {max_steps:,} steps" in str(exc) and "max_steps" in str(exc)
        return
    assert res.steps + res.rejected <= max_steps


# ---- Ctrl-C stops a long compiled run -------------------------------------------------------------------------
def test_ctrl_c_stops_a_long_mlsd_run():
    """SIGINT reaches a long MLSD run (minutes of compiled integration in one call before chunking)."""
    code, out, err = _interrupt_child("""
        from berryshaker.config import reference_machine
        from berryshaker.drives.groove_cam.mlsd import simulate_mlsd

        m = reference_machine()
        simulate_mlsd(m, revolutions=2)  # compiled and loaded before the long run
        print("ready", flush=True)
        try:
            simulate_mlsd(m, revolutions=20_000, output_step=0.05)  # ~5e8 steps, a quarter of an hour
        except KeyboardInterrupt:
            print("interrupted", flush=True)
            raise SystemExit(130)
        print("finished", flush=True)
    """)
    assert code == 130 and out.splitlines()[-1] == "interrupted", (code, out, err)


def test_ctrl_c_stops_a_long_multibody_run():
    """SIGINT reaches a long run of the multibody engine (its integrator returns to Python between chunks)."""
    code, out, err = _interrupt_child("""
        from berryshaker.config import reference_machine
        from berryshaker.drives.groove_cam.mechanism import harvester_mechanism
        from berryshaker.multibody.engine import simulate_mechanism

        m = reference_machine()
        spec = harvester_mechanism(m, revolutions=2)
        simulate_mechanism(spec, duration=0.05)  # compiled and loaded before the long run
        print("ready", flush=True)
        try:
            simulate_mechanism(spec, duration=2_000.0, output_step=0.01)  # minutes of steps
        except KeyboardInterrupt:
            print("interrupted", flush=True)
            raise SystemExit(130)
        print("finished", flush=True)
    """)
    assert code == 130 and out.splitlines()[-1] == "interrupted", (code, out, err)


def test_ctrl_c_on_the_command_line_exits_130_with_one_line():
    """`berryshaker simulate` interrupted: exit code 130, one short message, no traceback."""
    code, out, err = _interrupt_child("""
        import sys
        from berryshaker.cli import app
        from berryshaker.config import reference_machine
        from berryshaker.drives.groove_cam.mlsd import simulate_mlsd

        simulate_mlsd(reference_machine(), revolutions=2)  # compiled and loaded before the long run
        print("ready", flush=True)
        app(["simulate", "--model", "mlsd", "--revolutions", "390", "--json"], prog_name="berryshaker")
    """)
    assert code == 130, (code, out, err)
    assert "interrupted" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert out.strip() == ""  # no partial result


# ---- counts that multiply work are bounded before the work ------------------------------------------------------
@fuzz(60)
@given(n=st.integers(1, 10**6), ranges=st.integers(1, 4), levels=st.lists(st.integers(2, 50), max_size=2),
       method=st.sampled_from(["grid", "lhs", "montecarlo"]))
@example(n=100_000, ranges=4, levels=[], method="grid")  # the fuzzer's finding
def test_sweep_size_is_bounded_before_any_work(n, ranges, levels, method):
    """Any --points and parameters: the sweep is sampled with at most MAX_SWEEP_POINTS runs, or refused before
    sampling with the flag, the count and the bound."""
    from berryshaker.runs.sweep import MAX_SWEEP_POINTS, parse_param, sample_params, sweep_size

    keys = ["clearance.A.size", "clearance.B.size", "clearance.C.size", "clearance.F.size"]
    params = [parse_param(f"{k}=0.1..0.4mm", REFERENCE) for k in keys[:ranges]]
    params += [parse_param("cam.speed=" + ",".join(str(100 + i) for i in range(k)) + "rpm", REFERENCE)
               for k in levels[:1]]
    size = sweep_size(params, method, n)
    try:
        pts = sample_params(params, method, n, seed=0)
    except ConfigError as exc:
        assert size > MAX_SWEEP_POINTS
        assert "--points" in str(exc) and f"at most {MAX_SWEEP_POINTS:,} runs per sweep" in str(exc)
        return
    assert len(pts) == size <= MAX_SWEEP_POINTS


@fuzz(12)
@given(replicates=st.integers(1, 5_000))  # (the fuzzer's 1 000 000: minutes and gigabytes without the bound)
@example(replicates=1_001)
def test_doe_plan_replicates_are_bounded(replicates, tmp_path_factory):
    """`doe plan --replicates N` writes a sheet of runs x N rows for N up to harvest.replicates' bound, and refuses
    more before any work, naming the flag and the bound."""
    from berryshaker.harvest.spec import MAX_COUNT

    out = tmp_path_factory.mktemp("plan") / "sheet.csv"
    r = runner.invoke(app, ["doe", "plan", "--factor", "A=0.25,0.5,0.75mm", "--replicates", str(replicates),
                            "--out", str(out)])
    if replicates > MAX_COUNT:
        assert r.exit_code == 2 and f"--replicates {replicates:,}" in r.output
        assert f"at most {MAX_COUNT:,}" in r.output and not out.exists()
    else:
        assert r.exit_code == 0, r.output
        assert f"= {9 * replicates} rows" in r.output


def test_doe_virtual_replicates_are_bounded(monkeypatch):
    """`doe virtual --replicates N` beyond the bound is refused before any run."""
    import berryshaker.study.l9 as l9

    def no_runs(*args, **kwargs):
        raise AssertionError("the virtual test started its runs")

    monkeypatch.setattr(l9, "virtual_l9", no_runs)
    r = runner.invoke(app, ["doe", "virtual", "--replicates", "1001", "--json"])
    assert r.exit_code == 2 and "--replicates 1,001" in r.output and "at most 1,000" in r.output, r.output
