"""`doe analyze --out analysis.html` (issue 58 item 4): self-contained with its figures embedded, the ANOVA table
(source, SS, df, MS, F, p), the optimum's 95 % intervals, the desirability optimum and Minitab's four-in-one
residual plots; it fits a 1280 px window in Chromium."""

import base64
import html
import re
import shutil

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from berryshaker.experiment.field_sheet import parse_factor, plan_table


def _sheet(tmp_path, lost=False):
    df = plan_table("L4", [parse_factor("A=0.25,0.5mm"), parse_factor("B=0.2,0.4mm")], randomize=True, seed=2,
                    replicates=3)
    noise = np.random.default_rng(1).normal(0.0, 0.05, len(df))
    df["efficiency_kg_min"] = 4.0 - 1.2 * df["A_mm"] + 0.1 * df["replicate"] + noise
    if lost:
        df.loc[df.index[4], "efficiency_kg_min"] = np.nan
    path = tmp_path / ("lost.csv" if lost else "sheet.csv")
    df.to_csv(path, index=False)
    return path


def _analyse(tmp_path, sheet, *extra):
    from berryshaker.cli import app

    out = tmp_path / (sheet.stem + ".html")
    r = CliRunner().invoke(app, ["doe", "analyze", str(sheet), "--maximize", "efficiency", "--out", str(out),
                                 *extra])
    assert r.exit_code == 0, r.output
    return out.read_text(encoding="utf-8")


def _table(page: str, heading: str) -> pd.DataFrame:
    """The first table after ``heading``, cells as text."""
    start = page.index(heading)
    inside = page.rfind("<table", 0, start) > page.rfind("</table>", 0, start)  # the heading is a header cell
    first = page.rfind("<table", 0, start) if inside else page.index("<table", start)
    body = page[first:page.index("</table>", start)]
    rows = [[html.unescape(re.sub(r"<[^>]+>", "", c)) for c in re.findall(r"<t[hd][^>]*>(.*?)</t[hd]>", r, re.S)]
            for r in re.findall(r"<tr>(.*?)</tr>", body, re.S)]
    return pd.DataFrame(rows[1:], columns=rows[0])


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    """The page of a complete blocked L4 x 3 sheet with a desirability goal, written by the command (drawing its
    figures is most of this file's time), and the sheet's path."""
    tmp = tmp_path_factory.mktemp("doe_page")
    sheet = _sheet(tmp)
    return _analyse(tmp, sheet, "--desirability", "efficiency=max:3..4kg/min"), sheet, tmp / "sheet.html"


def test_the_page_holds_its_figures_the_anova_table_and_the_intervals(page):
    """Before: no figures, no ANOVA table (SS, df, MS), no interval at the optimum.  Now every figure is an embedded
    PNG (no file beside the page, no link out), the ANOVA rows add up to the total (a complete blocked sheet is
    orthogonal), F = MS / MS_error, and the optimum's row has its interval."""
    from berryshaker.experiment.field_results import analyze_sheet

    page, sheet, _ = page
    _, res = analyze_sheet(sheet, {"efficiency": True})
    images = re.findall(r'src="data:image/png;base64,([^"]+)"', page)
    assert len(images) >= 5 and all(base64.b64decode(i)[:8] == b"\x89PNG\r\n\x1a\n" for i in images)
    assert "src=\"http" not in page and "<script" not in page and "<link" not in page
    for caption in ("Main effects", "Pareto chart", "Residual plots (four in one)", "Interaction plots",
                    "Response surface"):
        assert caption in page
    anova = _table(page, "<h3>ANOVA")
    assert list(anova.columns) == ["source", "SS [kg/min²]", "df", "MS [kg/min²]", "F", "p"]
    rows = anova.set_index("source")
    an = res.responses["efficiency"].anova
    assert list(rows.index) == ["A", "A x blocks (its error)", "B", "B x blocks (its error)", "blocks", "lack of fit",
                                "error", "total"]
    ss = pd.to_numeric(rows["SS [kg/min²]"])
    own = ss[[i for i in rows.index if i.endswith("(its error)")]].sum()
    assert ss.drop("total").sum() - own == pytest.approx(ss["total"], rel=2e-3)  # four significant digits printed
    assert ss["total"] == pytest.approx(an.total_ss, rel=1e-3)
    assert int(rows.loc["error", "df"]) == an.error.df == 6 and int(rows.loc["total", "df"]) == 11
    # each factor against its own interaction with the blocks
    assert float(rows.loc["A", "F"]) == pytest.approx(an.factors["A"].ms / an.factors["A"].error.ms, rel=1e-3)
    opt = _table(page, "predicted at the optimum")
    lo, hi = res.optimum.intervals["efficiency"]
    shown = [float(v) for v in opt.loc[0, "95 % interval"].split(" .. ")]
    np.testing.assert_allclose(shown, [lo, hi], rtol=1e-3)
    assert lo < float(opt.loc[0, "predicted at the optimum"]) < hi
    assert "<h2>Desirability optimum</h2>" in page and "Overall desirability D = " in page
    assert "<details><summary>The analysis as text</summary>" in page


def test_a_sheet_with_lost_plots_says_so(tmp_path):
    """The page of a sheet with a lost plot states it and the error degrees of freedom left."""
    from berryshaker.experiment.field_results import analyze_sheet
    from berryshaker.report.doe_page import doe_report

    _, res = analyze_sheet(_sheet(tmp_path, lost=True), {"efficiency": True})
    text = doe_report(res, "lost <plot>", results_file="a&b.csv")
    lost = _table(text, "<h2>Lost plots")
    assert lost.loc[0, "plots with a value"] == "11 of 12"
    assert lost.loc[0, "error degrees of freedom"] == "5 (of 6; 1 lost)"
    assert "Type II" in text and "lost &lt;plot&gt;" in text and "a&amp;b.csv" in text


def test_the_page_fits_1280_px(page):
    """Rendered by Chromium at 1280 px the page scrolls only down, every image decoded; its height is stated below
    (measured: 5,100 px for this L4 x 3 sheet, under six screens of 900 px; 9,900 px for an L9 with two responses)."""
    from playwright import sync_api  # the test extra

    _, _, path = page

    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    with sync_api.sync_playwright() as p:
        try:
            browser = p.chromium.launch()
        except sync_api.Error:
            if exe is None:
                pytest.skip("no Chromium for Playwright (apt-get install chromium)")
            browser = p.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        try:
            view = browser.new_page(viewport={"width": 1280, "height": 900})
            view.goto(path.resolve().as_uri())
            got = view.evaluate("() => [document.documentElement.scrollWidth, window.innerWidth, "
                                "document.documentElement.scrollHeight, [...document.images].every(i => i.complete "
                                "&& i.naturalWidth > 0)]")
        finally:
            browser.close()
    width, inner, height, loaded = got
    assert width <= inner == 1280 and loaded
    print(f"doe analyze page: {height} px tall at 1280 px")
    assert 3000 < height < 8000, height
