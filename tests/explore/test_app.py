"""``berryshaker explore``: the page served in-process on the reference machine and driven in Chromium.

A changed clearance reruns the reduced model and changes the plotted forces and the printed peak; an invalid
clearance is a message in the page, not a traceback; the animation plays; the browser logs no error.  The harvest
and wear views' long runs are not started here (minutes); their jobs and tables are tested as data.
"""

from __future__ import annotations

import socket
from pathlib import Path

import numpy as np
import pytest

from berryshaker.config import load_machine
from berryshaker.errors import ConfigError

CHROMIUM = Path("/usr/bin/chromium")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_the_command_refuses_a_remote_host_and_a_busy_port():
    from berryshaker.explore import check_loopback, check_port

    assert check_loopback("127.0.0.1") == "127.0.0.1" and check_loopback("localhost") == "localhost"
    with pytest.raises(ConfigError, match="loopback"):
        check_loopback("0.0.0.0")
    with pytest.raises(ConfigError, match="loopback"):
        check_loopback("192.168.1.10")
    with pytest.raises(ConfigError, match="IPv6"):
        check_loopback("::1")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        busy = s.getsockname()[1]
        with pytest.raises(ConfigError, match=f"port {busy} .* not free.*--port"):
            check_port("127.0.0.1", busy)
    with pytest.raises(ConfigError, match="1..65535"):
        check_port("127.0.0.1", 0)


def test_settings_reach_the_machine_with_their_tags_and_errors_name_the_field():
    from berryshaker.explore import model as em
    from berryshaker.explore.views import harvest_jobs

    base = load_machine(None)
    ref = em.settings_of(base)
    assert dict(ref.clearance_mm) == pytest.approx({p: v * 1e3 for p, v in base.clearance_sizes().items()})
    assert ref.speed_rpm == pytest.approx(base.cam.speed * 60 / (2 * 3.141592653589793))
    s = em.Settings(clearance_mm=(("A", 0.3), *ref.clearance_mm[1:]), speed_rpm=100.0, stroke_mm=35.0,
                    walking_speed_m_min=20.0)
    m = em.build_machine(base, s)
    assert m.clearance_sizes()["A"] == pytest.approx(0.3e-3)
    assert m.cam.speed == pytest.approx(100 * em.RPM) and m.cam.stroke == pytest.approx(0.035)
    assert m.operation.walking_speed == pytest.approx(20 / 60)
    changed = em.changed_keys(base, s)
    assert changed == {"clearance.A.size", "cam.speed", "cam.stroke", "operation.walking_speed"}
    assert em.provenance_tag(base, "clearance.A.size", changed) == "set here"
    assert em.provenance_tag(base, "clearance.B.size", changed) == base.__provenance__["clearance.B.size"]
    with pytest.raises(ConfigError, match="clearance.A.size = 9 mm is larger than the geometry allows"):
        em.build_machine(base, em.Settings((("A", 9.0), *ref.clearance_mm[1:]), 120.0, 40.0, 30.0))
    with pytest.raises(ConfigError, match="drive speed"):
        em.build_machine(base, em.Settings(ref.clearance_mm, -5.0, 40.0, 30.0))
    jobs, speeds = harvest_jobs(m, (80, 160), 3)
    assert speeds == [80.0, 120.0, 160.0]
    assert [j["overrides"]["cam.speed"] for j in jobs] == pytest.approx([v * em.RPM for v in speeds])
    assert all(j["model"] == "harvest" and j["machine_data"]["clearance"]["A"]["size"] == pytest.approx(0.3e-3)
               for j in jobs)


def test_a_drive_without_a_reduced_model_is_drawn_from_its_multibody_run():
    from berryshaker.explore import model as em
    from berryshaker.explore.views import frame_at, frame_data

    base = load_machine(Path(__file__).parents[2] / "examples" / "crank_rocker_harvester.toml")
    run = em.run_mechanism(em.build_machine(base, em.settings_of(base)), n_frames=12)
    assert run.model == "multibody" and set(run.forces) == set(base.pair_names)
    data = frame_data(run.frames, 100.0)
    links, joints, impacts, groove = frame_at(data, 3)
    assert joints["name"] == list(base.pair_names) and not groove["x"]
    assert joints["r"] == pytest.approx([100 * base.clearance_sizes()[p] for p in base.pair_names])
    # the element sits in its housing: at most the magnified clearance plus the contact's deflection off its centre
    for x, y, r, px, py in zip(joints["x"], joints["y"], joints["r"], joints["px"], joints["py"]):
        assert np.hypot(px - x, py - y) <= 1.05 * r
    left = run.frames["points"]["shaft_D:i"][0]  # the comb shaft stands still
    assert np.ptp(left[:, 0]) == 0 and np.ptp(left[:, 1]) == 0


JS_FORCES = "() => { if (!window.Bokeh || !Bokeh.documents.length) { return null; } " \
            "const s = Bokeh.documents[0].get_model_by_name('explore_forces'); " \
            "return s && s.data.C && s.data.C.length ? Math.max(...s.data.C) : null; }"


def test_the_page_reruns_the_drive_when_a_clearance_changes(tmp_path):
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} is missing: install it (apt-get install -y chromium) to run the browser test")
    from playwright.sync_api import sync_playwright  # the test extra

    from berryshaker.explore.server import serve

    port = _free_port()
    server = serve(load_machine(None), port, cache_dir=tmp_path / "cache", threaded=True)
    errors = []
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=str(CHROMIUM), args=["--no-sandbox"])
            page = browser.new_page(viewport={"width": 1500, "height": 1100})
            page.on("console", lambda msg: errors.append(f"console: {msg.text}") if msg.type == "error" else None)
            page.on("pageerror", lambda exc: errors.append(f"page error: {exc}"))
            page.goto(f"http://127.0.0.1:{port}/explore")
            # the first run loads (or, on a fresh install, compiles) the MLSD kernels
            page.wait_for_function(f"({JS_FORCES})() !== null", timeout=180_000)
            peak_before = page.evaluate(JS_FORCES)
            text_before = page.locator("#peak-C").inner_text()
            # the printed peak is over every integrator step, the plotted one over the written samples
            assert peak_before * 0.999 <= float(text_before) <= peak_before * 1.5
            # clearance C from 0.1 mm to 0.3 mm, typed into its field as a user would
            field = page.locator("input").nth(2)
            assert float(field.input_value()) == pytest.approx(0.1)
            field.fill("0.3")
            field.press("Enter")
            page.wait_for_function(f"({JS_FORCES})() !== {peak_before}", timeout=30_000)
            page.get_by_text("0.300 mm [set here]").wait_for(timeout=10_000)  # the table's clearance and its tag
            assert page.locator("#peak-C").inner_text() != text_before
            # an invalid clearance: a message in the page naming the field, the plots kept
            field_a = page.locator("input").nth(0)
            field_a.fill("9")
            field_a.press("Enter")
            alert = page.get_by_text("These settings are refused")
            alert.wait_for(timeout=15_000)
            assert page.get_by_text("clearance.A.size = 9 mm is larger than the geometry allows").count() == 1
            assert page.evaluate(JS_FORCES) is not None
            # the animation plays: the frame advances and the drawn links move
            links = "() => JSON.stringify(Bokeh.documents[0].get_model_by_name('explore_links').data.xs)"
            before = page.evaluate(links)
            page.get_by_role("button", name="play / pause").click()
            page.wait_for_function("Bokeh.documents[0].get_model_by_name('explore_frame').value >= 3", timeout=10_000)
            page.get_by_role("button", name="play / pause").click()
            assert page.evaluate(links) != before
            browser.close()
    finally:
        server.stop()
    assert not errors, "the browser logged errors:\n" + "\n".join(errors)
