"""The study report prints to PDF (A4) without losing a table: rendered by Debian's Chromium (print-to-PDF),
then read back with poppler's pdftotext.  Built from a synthetic results dict with the real machine's
configuration table, so it runs in seconds and needs no simulation."""

from __future__ import annotations

import html
import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from l9_records_data import l9_record

from berryshaker.config import load_machine, machine_table
from berryshaker.report.html import report_title, runs_text, study_report
from berryshaker.study.claims import ClaimVerdict
from berryshaker.study.pipeline import report_sections
from berryshaker.study.step_result import StudyResults, StudySummary

PAIRS = ("A", "B", "C", "F")
#: the virtual L9 (replicated, with its significance text and trade-off table), the powered drive, the clearance
#: life and the harvest response of a reference study run, trimmed to what the report reads (so the report's widest
#: sections are rendered without running the study)
SECTIONS = Path(__file__).parents[1] / "data" / "report_sections.json"


def _row(r: int) -> dict:
    """A multibody row's summary (the JSON form of ``berryshaker.study.mechanics_records.MultibodyRow``)."""
    rng = np.random.default_rng(r)

    def force(peak, mean):
        return {"peak": peak, "mean": mean, "rms": 1.2 * mean, "p95": 0.9 * peak}

    return {"model": "multibody", "drive": "groove_cam",
            "clearance_mm": {p: round(0.1 * ((r + i) % 4), 2) for i, p in enumerate(PAIRS)},
            "collision_force_N": {p: force(float(1000 + 400 * rng.random()), float(200 * rng.random()))
                                  for p in PAIRS},
            "pair_state": {p: "clearance" for p in PAIRS},
            "load_moment_Nm": {s: force(80.0 + r, 40.0) | {"rms": 45.0 - r / 10} for s in ("left", "right")},
            "drive_moment_Nm": {**force(45.0, 11.4), "mean_abs": 11.5}, "load_model": "aggregate (no plant in this run)",
            "steps": 7500, "rejected_steps": 0, "contact_onsets": {p: 0 for p in PAIRS}, "contact_onsets_located": 0,
            "event_cuts": 0, "wall_time_s": 0.2, "revolutions": 3, "statistics_over": "revolutions 2..3"}


def _agreement_pair() -> dict:
    """One pair of the model-agreement step (the JSON form of ``berryshaker.study.mechanics_records.PairAgreement``)."""
    st = {"mean": 600.0, "rms": 1100.0, "p95": 1800.0, "impulse_per_revolution": 300.0}
    return {"f_statistic": 1.1, "f_critical": 3.18, "alpha": 0.05, "points": 10, "eq18_agree": True, "agree": True,
            "statistics": {"a": st, "b": st, "relative_difference": {k: 0.0 for k in st}, "tolerance": dict(st),
                           "agree": True},
            "nrmse": 0.2, "correlation": 0.9, "peak_ratio": 1.1, "mean_ratio": 1.0,
            "peak_N": {"multibody": 11000.0, "reduced": 10000.0}}


def _claims(verdicts) -> list[dict]:
    return [{"id": i + 1, "claim": f"Claim number {i + 1} of the study, stated at some length so that the cell "
             "wraps over several lines in print", "verdict": v,
             "detail": f"row 14: peaks A 5227 / B 4982 / C 2914 / F 2838 N; left > right: {i % 2 == 0}, "
                       f"falls with clearance: {i % 3 == 0}; the harvest model is calibrated to the study's values at "
                       "A1B1C1F3 (docs/harvest.md, docs/plant.md, clearance.A.bearing_length)", "criterion": ""}
            for i, v in enumerate(verdicts)]


def _report_text(machine, figs: Path) -> tuple[str, StudyResults]:
    """The report of the synthetic results on ``machine`` (figures from ``figs``)."""
    from berryshaker.report.plots import plot_bars

    plot_bars({"multibody peak": [1.0, 2.0, 3.0, 4.0], "multibody mean": [0.5, 1.0, 1.5, 2.0]},
              ["none", "0.25 mm", "0.5 mm", "0.75 mm"], "collision force at joint A [N]",
              figs / "fig18_rows_A.png", "Clearance A alone", pair="A", reference_index=0)
    res = {
        "kinematics": {"combs": {s: {"swing_deg": {"min": -5.0, "max": 5.0}, "max_tip_speed_m_s": 2.0,
                                     "max_tip_acceleration_m_s2": 40.0, "mid_stroke_angle_deg": 90.0}
                                 for s in ("left", "right")},
                       "linkage": {"transmission_angle_deg": {"min": 40.0, "max": 120.0}, "shaft_D_mm": [0.0, 0.0],
                                   "shaft_E_mm": [300.0, 0.0]},
                       "drive": {"cam_speed_rpm": 240.0, "comb_frequency_hz": 4.0}},
        "agreement": {"clearance_mm": {p: 0.25 for p in PAIRS}, "pairs": {p: _agreement_pair() for p in PAIRS}},
        "rows": {"multibody": {str(r): _row(r) for r in range(1, 17)}, "mlsd": {}, "starts": {}},
        "fruit_force": None, **json.loads(SECTIONS.read_text(encoding="utf-8")),
        "claims": _claims(["reproduced", "reproduced", "partly reproduced", "not reproduced", "reproduced",
                           "reproduced", "partly reproduced", "not comparable"]),
    }
    # the trimmed L9 completed to a VirtualL9's JSON form (neutral values where the report reads nothing)
    res["l9"] = l9_record(res["l9"]).to_json()
    res = StudyResults.from_json(res)
    summary = StudySummary(package="berryshaker", version="0.0-test", machine=machine.machine.name,
                           drive=machine.DRIVE, claims=res.claims, optimum=None, failures=[],
                           timings_s={"total": 3.2, "kinematics": 0.1},
                           runs={"runs": 40, "cached": 40, "computed": 0, "failed": 0, "compute_s": 0.0,
                                 "cached_compute_s": 93.4, "cold_compute_s": 93.4, "elapsed_s": 0.5})
    return study_report(res, summary, machine, figs, sections=report_sections()), res


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    machine = load_machine(None)
    text, res = _report_text(machine, tmp_path_factory.mktemp("figs"))
    out = tmp_path_factory.mktemp("report") / "report.html"
    out.write_text(text, encoding="utf-8")
    return out, text, res, machine


#: what a hostile machine description puts in every free-text field (issue 59: a script in [machine] name ran)
PAYLOAD = """<script>alert("name")</script><img src=x onerror=alert(1)>"'&"""


def _tags(text: str) -> list[tuple[str, list]]:
    from html.parser import HTMLParser

    seen = []

    class Tags(HTMLParser):
        def handle_starttag(self, tag, attrs):
            seen.append((tag, attrs))

    Tags().feed(text)
    return seen


def test_user_text_in_the_report_is_escaped(tmp_path):
    """The machine's name and description carry a script and an image with an onerror handler: the report shows
    them as text; it has no script element, no event-handler attribute and no image that is not an embedded
    figure."""
    import tomllib

    from berryshaker.config import machine_from_dict, reference_toml_text

    data = tomllib.loads(reference_toml_text())
    data["machine"].update(name=PAYLOAD, description=PAYLOAD)
    machine = machine_from_dict(data, "hostile", units_required=True)
    text, _ = _report_text(machine, tmp_path)
    assert PAYLOAD not in text and html.escape(PAYLOAD) in text
    tags = _tags(text)
    assert "script" not in {t for t, _ in tags}
    assert not [(t, a) for t, attrs in tags for a, _ in attrs if a.lower().startswith("on")]
    assert all((dict(a).get("src") or "").startswith("data:image/") for t, a in tags if t == "img")


def test_report_header_and_claims_table(report):
    _, text, res, machine = report
    assert "the reference study, checked" in text and "reproduced</h1>" not in text
    assert report_title([ClaimVerdict(1, "", "reproduced", "", "")] * 8).endswith("reproduced")
    # a cached rerun keeps the cold cost in the header
    assert "40 runs (40 from the cache; cold compute 93.4 s)" in text
    assert runs_text({"runs": 3, "cached": 0, "compute_s": 2.0, "cached_compute_s": 0.0}) == \
        "3 runs (0 from the cache; cold compute 2.0 s)"
    claims = text[text.index("<h2>Appendix: claims"):text.index("<h2>Configuration and provenance")]
    assert not re.search(r"\b(True|False)\b", claims)
    assert "left &gt; right: yes" in claims and "falls with clearance: no" in claims
    # provenance tags of the configuration table
    for _k, _v, tag in machine_table(machine)[:5]:
        assert f"[{tag}]" in text
    assert "@page{size:A4" in text and "tr{page-break-inside:avoid" in text


def _words_bbox(pdf: Path) -> tuple[list[tuple[float, float]], list[tuple[float, float, float, float]]]:
    """Page sizes and word boxes (xmin, ymin, xmax, ymax) from ``pdftotext -bbox``."""
    out = subprocess.run(["pdftotext", "-bbox", str(pdf), "-"], capture_output=True, text=True, check=True).stdout
    pages = [(float(w), float(h)) for w, h in re.findall(r'<page width="([\d.]+)" height="([\d.]+)"', out)]
    words = [tuple(float(v) for v in m) for m in
             re.findall(r'<word xMin="([-\d.]+)" yMin="([-\d.]+)" xMax="([-\d.]+)" yMax="([-\d.]+)"', out)]
    return pages, words


def test_report_prints_to_a4_without_cutting_tables(report, tmp_path):
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("Debian's chromium is not installed (.ci/run installs it)")
    if shutil.which("pdftotext") is None:
        pytest.skip("pdftotext (poppler-utils) is not installed: apt-get install -y poppler-utils")
    path, text, res, machine = report
    pdf = tmp_path / "report.pdf"
    cmd = [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           f"--user-data-dir={tmp_path / 'profile'}", "--no-pdf-header-footer", f"--print-to-pdf={pdf}",
           path.resolve().as_uri()]
    try:  # a hang guard (printing takes a few seconds): a report that hangs the printer fails, never skips
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
    except subprocess.TimeoutExpired:
        pytest.fail("chromium did not finish printing the report within 300 s")
    assert pdf.exists(), f"chromium wrote no PDF of the report (exit {done.returncode}): {done.stderr[-2000:]}"
    pages, words = _words_bbox(pdf)
    assert 2 <= len(pages) <= 25, f"{len(pages)} pages"
    for w, h in pages:  # A4 portrait in points
        assert w == pytest.approx(595, abs=3) and h == pytest.approx(842, abs=3)
    # nothing runs off the right edge of the page (a wide table would be cut there)
    width = pages[0][0]
    assert words and max(x1 for _, _, x1, _ in words) <= width + 0.5
    assert min(x0 for x0, _, _, _ in words) >= -0.5
    flat = re.sub(r"\s+", "", subprocess.run(["pdftotext", str(pdf), "-"], capture_output=True, text=True,
                                             check=True).stdout)

    bare = flat.replace("-", "")

    def present(s) -> bool:
        """Every word of ``s`` is in the PDF: a cell wrapped over lines is read line by line across its row, and a
        word broken after its hyphen is read back without it."""
        return all(w.replace("-", "") in bare for w in str(s).split())

    # every table's header cells and every row's first cell are in the PDF
    for table in re.findall(r"<table[^>]*>(.*?)</table>", text, flags=re.S):
        heads = [re.sub(r"<[^>]+>", "", h) for h in re.findall(r"<th[^>]*>(.*?)</th>", table, flags=re.S)]
        for h in heads:
            assert present(html.unescape(h)), f"header {h!r} missing from the PDF"
        for row in re.findall(r"<tr><td[^>]*>(.*?)</td>", table, flags=re.S):
            cell = html.unescape(re.sub(r"<[^>]+>", "", row))
            assert present(cell), f"row {cell!r} missing from the PDF"
    for key, _v, _t in machine_table(machine):
        assert present(key)


#: elements whose box reaches beyond the page's width (or left of it), with their tag, class, edges and text
_OVERFLOW_JS = """() => {
  const W = document.documentElement.clientWidth, out = [];
  for (const el of document.querySelectorAll('body *')) {
    const r = el.getBoundingClientRect();
    if (r.width > 0 && (r.right > W + 0.5 || r.left < -0.5))
      out.push([el.tagName, el.className, Math.round(r.left), Math.round(r.right), (el.textContent || '').slice(0, 60)]);
  }
  return {scroll: document.body.scrollWidth, client: document.body.clientWidth, doc: document.documentElement.scrollWidth,
          width: W, over: out, rows: [...document.querySelectorAll('tr')].map(t => t.getBoundingClientRect().height)};
}"""


def test_report_fits_an_a4_page_width_on_screen(report):
    """Issue 45: a preformatted significance block made the page ~8000 px wide and the trade-off table's last column
    ran off-screen.  At A4 width (794 CSS px) nothing may reach beyond the page: no horizontal scroll, no element's
    box past the right edge (a table in a scrolling div counts: it is cut in print)."""
    from playwright import sync_api  # the test extra

    path, text, res, _ = report
    assert "<pre" in text and "dominated by" in text  # the sections of the issue are in the page
    with sync_api.sync_playwright() as p:
        try:
            browser = p.chromium.launch()
        except sync_api.Error:  # Playwright's own browser is not installed: Debian's Chromium (.ci/run installs it)
            exe = shutil.which("chromium") or shutil.which("chromium-browser")
            if exe is None:
                pytest.skip("no Chromium for Playwright (apt-get install chromium)")
            browser = p.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        try:
            page = browser.new_page(viewport={"width": 794, "height": 1123})
            page.goto(path.resolve().as_uri())
            got = page.evaluate(_OVERFLOW_JS)
        finally:
            browser.close()
    assert got["width"] == 794
    assert got["scroll"] <= got["client"] and got["doc"] <= got["width"], got["over"][:5]
    assert not got["over"], "elements beyond the page width: " + "; ".join(map(str, got["over"][:8]))
    # the trade-off table's rows stay short (they were ~300 px tall with its last column squeezed)
    trade = text[text.index("<h3>Trade-off"):]
    assert trade.count("<tr>") >= 2 * len(res.l9.tradeoff)  # indexes and machine loads: two tables


def test_a_kept_page_figure_is_the_scaled_one(tmp_path):
    """A figure's page PNG read from the page-figure folder is the bytes the scaling gives; a figure scaled once is
    read back, not scaled again, and a changed figure file is scaled anew."""
    import berryshaker.report.html_blocks as hb
    from berryshaker.report.plots.figure_files import _out
    from berryshaker.report.style import new_figure

    def figure(name, y):
        fig, ax = new_figure()
        ax.plot([0.0, 1.0, 2.0], y)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        return Path(_out(fig, tmp_path / name, {}, False)["path"])

    a, b = figure("a.png", [0.0, 1.0, 0.5]), figure("b.png", [0.0, 2.0, 0.5])
    scaled = hb._png_for_page(a)
    folder = tmp_path / "kept"
    with hb.page_figure_cache(folder):
        assert hb._png_for_page(a) == scaled
        kept = list(folder.rglob("*.png"))
        assert len(kept) == 1
        scale = hb._scaled_png
        try:
            hb._scaled_png = None  # read back, not scaled
            assert hb._png_for_page(a) == scaled
        finally:
            hb._scaled_png = scale
        assert hb._png_for_page(b) == hb._png_for_page(b) != scaled
        assert len(list(folder.rglob("*.png"))) == 2
