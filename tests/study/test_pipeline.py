"""The whole study, the sweep runner (cache, resume, failures, Dask with a worker killed), the report in
headless Chromium, atomic outputs."""

import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from conftest import linear_spring_toml_text
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.config import reference_toml_text
from berryshaker.runs.runner import SweepRunner
from berryshaker.runs.sweep import model_run, parse_param, sample_params
from berryshaker.study.claims import check_claims
from berryshaker.study.step_result import StudyResults

runner_cli = CliRunner()


@pytest.fixture(scope="module")
def fast_config(tmp_path_factory):
    # the pipeline on a cheaper machine: one branch class, two replicates, linear clearance springs
    from fast_machine import fast_text

    text = fast_text(linear_spring_toml_text(reference_toml_text()))
    p = tmp_path_factory.mktemp("cfg") / "fast.toml"
    p.write_text(text)
    return p


def test_runner_caches_isolates_failures_and_resumes(tmp_path, machine):
    data = machine.model_dump(mode="json")
    jobs = [dict(machine_data=data, overrides={"clearance.A.size": a}, revolutions=2) for a in (1e-4, 2e-4, -1e-4)]
    r = SweepRunner(workers=2, cache_dir=tmp_path / "c", progress=False)
    first = r.map(model_run, jobs)
    assert [x.error is None for x in first] == [True, True, False]
    assert "must be >= 0" in first[2].error  # recorded with its error; the others finished
    again = SweepRunner(workers=2, cache_dir=tmp_path / "c", progress=False)
    second = again.map(model_run, jobs)
    assert [x.cached for x in second] == [True, True, False]  # finished runs are not recomputed
    assert second[0].value == first[0].value


def test_sweep_sampling():
    a = parse_param("clearance.A.size=0.1..0.5mm")
    b = parse_param("cam.speed=100,120rpm")
    c = parse_param("clearance.C.size=0.1+-0.02mm")
    assert a.factor == pytest.approx(1e-3) and b.factor == pytest.approx(2 * 3.141592653589793 / 60)
    assert len(sample_params([a, b], "grid", 3, 0)) == 6
    lhs = sample_params([a, c], "lhs", 20, 1)
    assert len(lhs) == 20 and all(0.1 <= p[0] <= 0.5 for p in lhs)
    assert sample_params([a, c], "lhs", 20, 1) == lhs  # seeded


def test_sweep_cli_table(tmp_path):
    bad = runner_cli.invoke(app, ["sweep", "--param", "clearance.A.size=0.1..0.3mm", "--param",
                                  "clearance.F.size=0.1,0.6,-1mm", "--points", "2", "--json", "--cache",
                                  str(tmp_path / "c"), "--out", str(tmp_path / "s.csv")])
    assert bad.exit_code == 2 and "nothing was run" in bad.output  # every point is checked before launching
    assert not (tmp_path / "s.csv").exists()
    r = runner_cli.invoke(app, ["sweep", "--param", "clearance.A.size=0.1..0.3mm", "--param", "clearance.F.size=0.1,0.6mm",
                                "--points", "3", "--json", "--cache", str(tmp_path / "c"), "--out", str(tmp_path / "s.csv")])
    assert r.exit_code == 0, r.output
    s = json.loads(r.stdout)
    assert s["runs"] == 6 and s["failed"] == 0
    assert "collision_force_A_peak_N" in s["columns"]
    assert (tmp_path / "s.csv").read_text().startswith("run,clearance.A.size[mm],clearance.F.size[mm],status")


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.slow
def test_dask_cluster_survives_a_killed_worker(tmp_path, machine):
    # the command-line tool comes with dask[distributed], a dependency: next to this Python in a virtual environment
    dask = Path(sys.executable).parent / "dask"
    if not dask.exists():
        dask = Path(shutil.which("dask") or dask)
    assert dask.exists(), "the dask command-line tool of dask[distributed] is not installed"
    port = _free_port()
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    procs = [subprocess.Popen([str(dask), "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, start_new_session=True)]
    try:
        time.sleep(2.0)
        for k in range(2):
            procs.append(subprocess.Popen([str(dask), "worker", f"tcp://127.0.0.1:{port}", "--nthreads", "1",
                                           "--no-nanny", "--no-dashboard", "--name", f"w{k}"],
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env,
                                          start_new_session=True))
        from distributed import Client

        with Client(f"tcp://127.0.0.1:{port}", timeout="30s") as c:
            c.wait_for_workers(2, timeout=60)
        data = machine.model_dump(mode="json")
        jobs = [dict(machine_data=data, overrides={"clearance.A.size": 1e-4 * (1 + i)}, revolutions=30)
                for i in range(12)]
        cache = tmp_path / "cache"
        killed = {}

        def killer():
            t0 = time.time()
            while time.time() - t0 < 120:
                if cache.exists() and any(cache.rglob("*.json")):
                    os.killpg(procs[1].pid, signal.SIGKILL)
                    killed["at"] = time.time()
                    return
                time.sleep(0.05)

        th = threading.Thread(target=killer)
        th.start()
        r = SweepRunner(scheduler=f"tcp://127.0.0.1:{port}", cache_dir=cache, progress=False)
        out = r.map(model_run, jobs)
        th.join()
        assert "at" in killed, "the worker was not killed mid-sweep"
        assert procs[1].wait(timeout=10) is not None
        assert [o.index for o in out] == list(range(12))  # every run exactly once, in order
        assert all(o.error is None for o in out), [o.error for o in out if o.error]
        # the cluster's numbers are the same as a local run's
        local = model_run(**jobs[5])
        assert out[5].value["collision_force_N"]["A"]["peak"] == pytest.approx(local["collision_force_N"]["A"]["peak"])
    finally:
        for p in procs:
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass


@pytest.fixture(scope="module")
def study_out(fast_config, tmp_path_factory):
    base = tmp_path_factory.mktemp("study")
    out = base / "out"
    cache = base / "cache"
    r = runner_cli.invoke(app, ["study", "--config", str(fast_config), "--out", str(out), "--cache", str(cache),
                                "--workers", "2", "--json"])
    assert r.exit_code == 0, r.output
    return out, cache, json.loads(r.stdout)


def test_study_outputs(study_out):
    out, cache, s = study_out
    assert (out / "report.html").stat().st_size > 100_000
    saved = json.loads((out / "summary.json").read_text())
    assert [c["id"] for c in saved["claims"]] == list(range(1, 9))
    # the verdicts follow from the numbers the summary saves (the claim rules themselves: tests/study/test_claims.py)
    assert [(c["verdict"], c["detail"]) for c in saved["claims"]] == [
        (c.verdict, c.detail) for c in check_claims(StudyResults.from_json(saved["results"]))]
    # and they are the ones this input gives where its numbers decide by far (claim 2 turns on steps near the
    # noise of two starts, so only the rule above holds it):
    # 1: the four pairs agree at the model-check level (3-6 % against 20 %) but many single-run rows differ;
    # 3: judged on the static-equivalent loads (p95 of the impact peaks): every step from no clearance to level 1
    #    and A's and B's later steps rise by 1.7-3.5 kN far beyond the noise, but C's and F's later steps (0.3-0.5
    #    kN) stay inside the paired t test's band with two starts (one degree of freedom): partly;
    # 4: holds by construction of the aggregate load (not tested);
    # 5: fruit peak forces of 0.07-0.33 N, each below its study range (root 0.25-0.4 N ... end 0.8-1.2 N);
    # 6: the end fruit's 0.3 N keeps the unripe fruit (mean pull strength 2.05 N), which eq. 17 wants picked;
    # 7, 8: with two replicates no harvest index differs beyond the noise (A's effect on efficiency: p ~ 0.5)
    verdicts = {c["id"]: c["verdict"] for c in saved["claims"]}
    assert verdicts == {**verdicts, 1: "partly reproduced", 3: "partly reproduced", 4: "not tested", 5: "not reproduced",
                        6: "not reproduced", 7: "not reproduced", 8: "not reproduced"}
    assert all(c["detail"] for c in saved["claims"])
    assert set(saved["optimum"]["clearance_mm"]) == set("ABCF")
    for k in ("efficiency_kg_min", "damage_rate_pct"):
        assert saved["optimum"][k] > 0
    assert saved["optimum"]["unripe_rate_pct"] >= 0
    assert saved["timings_s"]["total"] > 0 and saved["version"]
    # the runs the study started ahead (the steps' plans, Step.plan) are the ones its steps asked for: none ran unused
    assert len(list(cache.rglob("*.json"))) == saved["runs"]["computed"] > 0
    assert saved["machine_si"]["cam"]["base_radius"] == 0.08
    for t in ("collision_force_rows.csv", "load_moment_rows.csv", "model_agreement.csv", "model_check.csv",
              "fruit_force.csv", "l9_runs.csv", "claims.csv"):
        assert (out / "tables" / t).stat().st_size > 50
    assert len(list((out / "figures").glob("*.png"))) >= 19
    html = (out / "report.html").read_text()
    assert "berryshaker" in html and html.count("data:image/png;base64,") >= 19 and "<script" not in html


def test_every_step_has_its_field_in_the_study_results():
    """The study's own steps' results are the fields of StudyResults, in the step table's order (summary.json's
    ``results`` in the steps' order); a step added without a field keeps its data in ``other``
    (tests/study/test_steps.py)."""
    from berryshaker.records import field_names
    from berryshaker.study.steps import STEPS

    assert [s.result for s in STEPS] == [f for f in field_names(StudyResults) if f not in ("claims", "failures", "other")]


def test_saved_results_read_back_as_the_typed_records(study_out):
    """summary.json's ``results`` is StudyResults.to_json(): read back (validated, nested records included) it
    writes the same JSON, key for key and in the same order; a key no record has is refused, naming it."""
    import pydantic

    out, _, _ = study_out
    saved = json.loads((out / "summary.json").read_text())["results"]
    from berryshaker.outputs import finite_json

    typed = StudyResults.from_json(saved)
    again = finite_json(typed.to_json())  # as written: strict JSON, a non-finite number (an F of 0/0) is null
    assert again == saved
    assert json.dumps(again) == json.dumps(saved)  # the keys' order too
    with pytest.raises(pydantic.ValidationError, match="not_a_step"):
        StudyResults.from_json({**saved, "not_a_step": {}})


def test_repeated_study_comes_from_the_cache(study_out, fast_config, tmp_path):
    out, cache, first = study_out
    r = runner_cli.invoke(app, ["study", "--config", str(fast_config), "--out", str(tmp_path / "again"),
                                "--cache", str(cache), "--json"])
    assert r.exit_code == 0, r.output
    s = json.loads(r.stdout)
    assert s["runs"]["cached"] == s["runs"]["runs"] and s["runs"]["failed"] == 0
    assert s["optimum"] == first["optimum"]  # same config, same numbers


def test_failed_study_leaves_an_existing_folder_untouched(fast_config, tmp_path, monkeypatch):
    import berryshaker.study.steps.virtual_l9 as st  # the module whose run calls virtual_l9

    out = tmp_path / "out"
    out.mkdir()
    (out / "report.html").write_text("previous report")

    def boom(*a, **k):
        raise RuntimeError("simulated failure in the L9 step")

    monkeypatch.setattr(st, "virtual_l9", boom)
    r = runner_cli.invoke(app, ["study", "--config", str(fast_config), "--out", str(out), "--cache",
                                str(tmp_path / "c"), "--workers", "1"])
    assert r.exit_code != 0
    assert (out / "report.html").read_text() == "previous report"
    assert not [p for p in tmp_path.iterdir() if "staging" in p.name]


def test_invalid_config_stops_before_any_simulation(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(reference_toml_text().replace('stroke = "40 mm"', 'stroke = "-40 mm"'))
    r = runner_cli.invoke(app, ["study", "--config", str(bad), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and "cam.stroke" in r.stderr
    assert not (tmp_path / "o").exists()


def test_workers_started_before_the_geometry_check_are_ended_when_it_fails(fast_config, tmp_path, monkeypatch):
    """The study starts its workers before the description's geometry check (they import while it runs); a check
    that fails ends them and reports the check's error, and nothing is written."""
    import dataclasses

    import berryshaker.drives as drives
    from berryshaker.errors import ConfigError
    from berryshaker.runs.runner import SweepRunner

    real_drive_of, real_abort = drives.drive_of, SweepRunner.abort
    aborted = []

    def boom(machine):
        raise ConfigError("cam.stroke: the follower leaves the groove (a check that fails on purpose)")

    def abort(self, *a, **k):
        aborted.append(self._executor is not None)  # a pool was running
        return real_abort(self, *a, **k)

    monkeypatch.setattr(drives, "drive_of", lambda m: dataclasses.replace(real_drive_of(m), check=boom))
    monkeypatch.setattr(SweepRunner, "abort", abort)
    r = runner_cli.invoke(app, ["study", "--config", str(fast_config), "--out", str(tmp_path / "o"), "--cache",
                                str(tmp_path / "c"), "--workers", "2"])
    assert r.exit_code == 2 and "on purpose" in r.stderr
    assert aborted == [True]
    assert not (tmp_path / "o").exists() and not list((tmp_path).glob("*staging*"))


def test_report_sections_are_numbered_in_the_steps_order(study_out, fast_config):
    """Each step names the renderers of its report sections (study/steps/, its STEP.sections); the report
    numbers them 1, 2, ... in the steps' order, so no title carries a number, and the design answers' references
    to sections (report.design_html.STEP_SECTIONS) are the numbers the report gives."""
    import html as H
    import re

    from berryshaker.config import load_machine
    from berryshaker.report.design_html import STEP_SECTIONS, section_label
    from berryshaker.report.sections import SectionInput, section_numbers
    from berryshaker.study.pipeline import report_sections
    from berryshaker.study.steps import STEPS

    out, _, _ = study_out
    text = (out / "report.html").read_text()
    saved = json.loads((out / "summary.json").read_text())
    steps = report_sections()
    numbers = section_numbers(steps)
    inp = SectionInput(StudyResults.from_json(saved["results"]), load_machine(fast_config), out / "figures", numbers)
    titles = [render(inp)[0] for _, renderers in steps for render in renderers]
    assert not [t for t in titles if re.match(r"\s*\d", t)], "a section title with a typed number"
    headings = re.findall(r"<h2>(\d+)\. ([^<]*)</h2>", text)
    assert headings == [(str(i + 1), H.escape(t, quote=False)) for i, t in enumerate(titles)]
    assert len(re.findall(r"<h2>\s*\d", text)) == len(titles)  # no other numbered heading
    first = {s.key: numbers[s.sections[0]] for s in STEPS if s.sections}
    for key, (_, name) in STEP_SECTIONS.items():
        if key in first:
            assert section_label(key, numbers) == f"{first[key]}. {name}", key


def test_report_renders_in_headless_chromium(study_out):
    out, _, _ = study_out
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("Debian's chromium is not installed (.ci/run installs it)")
    from playwright import sync_api as pw  # the test extra
    errors = []
    with pw.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=[
            "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
            "--disable-component-update", "--disable-sync"])
        page = browser.new_page()
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto((out / "report.html").resolve().as_uri())
        page.wait_for_load_state("load")
        imgs = page.evaluate("Array.from(document.images).map(i => [i.complete, i.naturalWidth])")
        title = page.title()
        browser.close()
    assert len(imgs) >= 19
    assert all(done and width > 100 for done, width in imgs)
    assert errors == []
    assert "berryshaker study" in title


#: measured on a report at 1280 x 900 px: its height up to the appendix, every box's right edge, what the first screen
#: says, the figures shown (not folded) and where the preformatted statistics are
_REPORT_JS = """() => {
  const W = window.innerWidth, a = document.getElementById('appendix');
  const shown = (el) => { for (let e = el.parentElement; e; e = e.parentElement) {
      if (e.tagName === 'DETAILS' && !e.open) return false; } return true; };
  const over = [...document.querySelectorAll('body *')].filter(el => {
      const r = el.getBoundingClientRect(); return r.width > 0 && r.right > W + 0.5; }).map(el => el.tagName);
  const first = [...document.querySelectorAll('p, td, th, h1, h2, h3, li')].filter(el => {
      const r = el.getBoundingClientRect(); return r.top + window.scrollY < 900 && shown(el); })
      .map(el => el.textContent).join(' ');
  return {appendix: a ? a.getBoundingClientRect().top + window.scrollY : null,
          height: document.documentElement.scrollHeight, scroll: document.documentElement.scrollWidth, over: over,
          first: first, figures: [...document.querySelectorAll('figure img')].filter(shown).map(i => i.alt),
          pre_folded: [...document.querySelectorAll('pre')].every(p => !shown(p))};
}"""
#: the study report's body up to its appendix, at most (#58: the report was 50,378 px, 56 screens): 15 screens of
#: 900 px.  Measured: 13,061 px for the reference study (`berryshaker study`), this test's fast study a little less
REPORT_BODY_MAX_PX = 15 * 900


def test_report_reads_in_15_screens_at_one_operating_point(study_out):
    """#58: the report was 56 screens at 1280 px, with two screens of raw monospace statistics, main effects drawn
    twice and a first screen that mixed operating points (loads at 120 r/min beside "run at 150 r/min")."""
    out, _, _ = study_out
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("Debian's chromium is not installed (.ci/run installs it)")
    from playwright import sync_api as pw  # the test extra

    with pw.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox", "--disable-gpu"])
        page = browser.new_page(viewport={"width": 1280, "height": 900})
        page.goto((out / "report.html").resolve().as_uri())
        page.wait_for_load_state("load")
        got = page.evaluate(_REPORT_JS)
        browser.close()
    assert got["scroll"] <= 1280 and not got["over"], got["over"][:5]
    assert got["appendix"] is not None and got["appendix"] <= REPORT_BODY_MAX_PX, got["appendix"]
    assert got["height"] > got["appendix"]  # the claims and the configuration follow
    # the first screen: one operating point, the described one (the reference machine's 120 r/min)
    speeds = set(re.findall(r"(\d+(?:\.\d+)?) r/min", got["first"]))
    assert "One operating point" in got["first"] and speeds == {"120"}, speeds
    # the main effects drawn once, with their intervals; the statistics as text folded
    assert [a for a in got["figures"] if "Main effects" in a] == ["Main effects on the harvest indexes with 95 % "
                                                                   "intervals"]
    assert got["pre_folded"]
    html = (out / "report.html").read_text()
    assert "<pre" in html and html.count("<details>") >= 8  # folded, not dropped


def test_failed_runs_are_listed_and_the_rest_finishes(fast_config, study_out, tmp_path, monkeypatch):
    """A run that fails inside a sweep is recorded with its error; the study finishes and lists it."""
    import berryshaker.study.steps.clearance_rows as st  # the module whose plan and run call multibody_row

    real = st.multibody_row

    def flaky(machine_data, clearance, revolutions=3, seed=None):
        if clearance.get("B", 0.0) == pytest.approx(0.6e-3) and clearance.get("A", 0.0) == 0.0:
            raise RuntimeError("solver exploded on purpose")
        return real(machine_data, clearance, revolutions, seed)

    flaky.__module__, flaky.__qualname__ = real.__module__, "flaky_multibody_row_for_test"
    monkeypatch.setattr(st, "multibody_row", flaky)
    _, cache, _ = study_out  # everything but the patched rows comes from the cache
    r = runner_cli.invoke(app, ["study", "--config", str(fast_config), "--out", str(tmp_path / "o"), "--cache",
                                str(cache), "--workers", "1", "--json"])
    assert r.exit_code == 0, r.output
    s = json.loads(r.stdout)
    # row 7 fails, alone and from each of its perturbed starts (harvest.replicates = 2 in the fast description)
    assert len(s["failures"]) == 3 and all("exploded" in f["error"] for f in s["failures"])
    assert "row 7" in s["failures"][0]["inputs"] and all("B 0.6 mm" in f["inputs"] for f in s["failures"])
    verdicts = {c["id"]: c["verdict"] for c in s["claims"]}
    assert verdicts[3] == "not comparable"  # needs row 7
    assert verdicts[1] != "not comparable" and s["optimum"] is not None
    html = (tmp_path / "o" / "report.html").read_text()
    assert "Failed runs" in html and "exploded on purpose" in html


def test_model_check_replicates_are_seeded():
    """The model check's perturbed starts (claim 1): a seed gives the same summary every time and differs from the
    centred start; the MLSD's turned starts likewise."""
    from berryshaker.config import reference_machine
    from berryshaker.experiment.clearance_sets import level_set
    from berryshaker.study.runs import multibody_row, reduced_row

    m = reference_machine()
    data, lvl = m.model_dump(mode="json"), level_set(m, 2)
    def numbers(summary):  # (the run's wall time differs)
        return {k: v for k, v in summary.items() if k != "wall_time_s"}

    seeded = multibody_row(data, lvl, 2, [7, 2])
    assert numbers(multibody_row(data, lvl, 2, [7, 2])) == numbers(seeded)
    assert seeded["collision_force_N"]["C"] != multibody_row(data, lvl, 2)["collision_force_N"]["C"]
    turned = reduced_row(data, lvl, 2, [7, 2])
    assert numbers(turned) == numbers(reduced_row(data, lvl, 2, [7, 2]))
    assert turned["collision_force_N"]["C"] != reduced_row(data, lvl, 2)["collision_force_N"]["C"]
