"""The design report of the machine in --config (issue 45 item 1, berryshaker.report.design, .harvest_answers,
.design_html): from a study's results, the answers an engineer brings, each number with its interval and the step it
comes from; the level set named by its clearances; why this efficiency; the opening section's HTML no wider than an
A4 page, naming the sections by the report's numbers.

Built from the trimmed results of a reference study run (tests/data/report_sections.json: the virtual L9, the
clearance life, the harvest response) with the L9's paired differences added, and the same results renamed to
the crank-rocker example's pairs, so it runs in seconds and needs no simulation."""

from __future__ import annotations

import json
import math
import re
import shutil
from dataclasses import fields
from pathlib import Path

import pydantic
import pytest

from berryshaker.config import load_machine
from berryshaker.records import JsonRecord
from berryshaker.report.design import claims_apply, design_answers, level_set_name
from berryshaker.report.design_html import MAX_COLUMNS, STEP_SECTIONS, design_answers_html
from berryshaker.report.design_quantity import Quantity, Source, quantity
from berryshaker.report.design_records import (
    Comparison,
    DesignAnswers,
    Difference,
    JointAnswers,
    KinematicDrivers,
    OperatingPoint,
    PublishedReference,
    Tradeoff,
    WhyEfficiency,
)
from berryshaker.report.harvest_answers import compare_efficiency, operating_point, published_reference, why_efficiency

DATA = Path(__file__).parents[1] / "data" / "report_sections.json"
CRANK = Path(__file__).parents[1].parent / "examples" / "crank_rocker_harvester.toml"
#: the comb kinematics of the reference machine (kinematics step: left comb, 120 r/min)
KINEMATICS = {"combs": {"left": {"swing_deg": {"min": -9.4623, "max": 9.4623}, "max_tip_speed_m_s": 2.25,
                                 "max_tip_acceleration_m_s2": 41.25},
                        "right": {"swing_deg": {"min": -8.7294, "max": 8.7276}, "max_tip_speed_m_s": 2.077,
                                  "max_tip_acceleration_m_s2": 38.05}},
              "drive": {"comb_frequency_hz": 2.0}}


def _paired(pairs) -> dict:
    """Paired differences (last - first level) per response and factor: the first factor beyond the noise."""
    out = {}
    for n, unit_scale in (("efficiency", 0.1), ("ripe_removal", 1.0), ("damage", 0.2), ("design_force_C", 800.0)):
        out[n] = {p: {"levels": [1, 3], "difference": unit_scale * (1.5 if i == 0 else 0.3),
                      "se": unit_scale * 0.4, "ci": [unit_scale * (1.5 - 0.9) if i == 0 else -unit_scale * 0.6,
                                                      unit_scale * (2.4 if i == 0 else 1.2)],
                      "p": 0.01 if i == 0 else 0.45, "beyond_noise": i == 0} for i, p in enumerate(pairs)}
    return out


def _summary(rename: dict | None = None) -> dict:
    text = DATA.read_text(encoding="utf-8")
    for old, new in (rename or {}).items():  # the same results on another machine's pairs
        text = re.sub(rf'"{old}"', f'"{new}"', text)
        text = re.sub(rf'(design_force_|design_force_N:|clearance_mm:){old}"', rf'\g<1>{new}"', text)
    res = json.loads(text)
    pairs = list(res["l9"]["recommended"]["clearance_mm"])
    res["l9"]["paired"] = _paired(pairs)
    res["kinematics"] = KINEMATICS
    # the run's description: the yield it was calibrated to then (its calibration table), the rest as described
    si = {"harvest": {"yield_per_bush": 0.6081, "unripe_fraction": 0.1},
          "operation": {"walking_speed": 0.5, "plant_spacing": 1.5}}
    return {"results": res, "tradeoff": res["l9"]["tradeoff"], "optimum": None, "machine_si": si}


@pytest.fixture(scope="module")
def reference():
    machine = load_machine(None)
    summary = _summary()
    return summary, machine, design_answers(summary, machine)


@pytest.fixture(scope="module")
def crank():
    machine = load_machine(CRANK)
    summary = _summary({"A": "crank_pin", "B": "rocker_pin"})
    return summary, machine, design_answers(summary, machine)


def _quantities(obj, path=""):
    """Every number of the answers (a :class:`Quantity`) with where it is."""
    if isinstance(obj, Quantity):
        yield path, obj
    elif isinstance(obj, JsonRecord):
        for f in fields(obj):
            yield from _quantities(getattr(obj, f.name), f"{path}.{f.name}")
    elif isinstance(obj, dict):
        for k, v in obj.items():
            yield from _quantities(v, f"{path}.{k}")
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _quantities(v, f"{path}[{i}]")


@pytest.mark.parametrize("which", ["reference", "crank"])
def test_every_joint_has_its_answers(which, request):
    summary, machine, a = request.getfixturevalue(which)
    assert isinstance(a, DesignAnswers)
    assert a.pairs == list(machine.pair_names) and set(a.joints) == set(machine.pair_names)
    for p, j in a.joints.items():
        assert isinstance(j, JointAnswers)
        for key in ("clearance", "design_force", "fit", "fit_clearance", "service_interval"):
            assert getattr(j, key) is not None, (p, key)
        assert j.clearance.value == summary["results"]["l9"]["recommended"]["clearance_mm"][p]
        assert re.fullmatch(r"H\d+/[a-z]+\d+", j.fit)
        # the service interval: the life step's growth from the fit's mean clearance, k over its range
        si = j.service_interval
        assert si.lo < si.value < si.hi and "Archard k" in si.interval and "[assumed]" in si.tag
    for q in (a.loads.drive_torque_design, a.loads.drive_torque_rms):
        assert q.unit == "N m" and q.lo <= q.value and q.label.startswith("drive torque")
    assert all(getattr(a.harvest, k) is not None for k in ("efficiency", "ripe_removal", "damage"))
    assert a.recommended.name == level_set_name(summary["results"]["l9"]["recommended"]["clearance_mm"])
    assert a.missing == []


@pytest.mark.parametrize("which", ["reference", "crank"])
def test_every_number_has_an_interval_and_a_source_step(which, request):
    _, _, a = request.getfixturevalue(which)
    qs = list(_quantities(a))
    assert len(qs) > 30
    for path, q in qs:
        assert q.source.step in STEP_SECTIONS, path
        assert q.source.where and q.interval, path
        assert q.tag.startswith("["), path
        if q.value is not None:
            assert q.lo is not None and q.hi is not None, path
            assert q.lo <= q.value + 1e-12 and q.value <= q.hi + 1e-12, (path, q)
    # the C joint's service interval reproduces the life step's maintenance interval (the same surrogate and fit)
    if which == "reference":
        life = json.loads(DATA.read_text(encoding="utf-8"))["clearance_life"]
        assert min(j.service_interval.value for j in a.joints.values()) == pytest.approx(
            life["recommended"]["maintenance_interval_h"], rel=1e-3)


def test_level_set_name_formats_units():
    assert level_set_name({"A": 0.25, "B": 0.2, "C": 0.1, "F": 0.2}) == "A 0.25 mm, B 0.2 mm, C 0.1 mm, F 0.2 mm"
    assert level_set_name({"crank_pin": 0.1, "rocker_pin": 0.30000000000000004}) == \
        "crank_pin 0.1 mm, rocker_pin 0.3 mm"
    assert level_set_name({"A": 250.0}, unit="um") == "A 250 um"


def test_claims_apply_only_on_the_studys_pairs(reference, crank):
    assert reference[2].claims_apply and not crank[2].claims_apply
    assert claims_apply(reference[1]) and not claims_apply(crank[1])


def test_differences_say_what_is_beyond_the_noise(reference):
    _, machine, a = reference
    d = a.differences
    assert {x.response for x in d} == {"efficiency", "ripe_removal", "damage", "design_force_C"}
    first = machine.pair_names[0]
    for x in d:
        assert isinstance(x, Difference)
        assert x.beyond_noise == (x.factor == first)
        assert x.verdict == ("differs" if x.beyond_noise else "no difference")
        # a difference inside the noise has an interval that holds 0
        q = x.difference
        assert x.beyond_noise or q.lo <= 0 <= q.hi
        assert q.se == pytest.approx(0.4 * q.value / (1.5 if x.beyond_noise else 0.3))


def _row(rpm, removal, sd, damage=2.0, shed=0.5, n=8):
    return {"speed_rpm": rpm, "shaking_frequency_hz": rpm / 60, "ripe_removal_pct": removal,
            "ripe_removal_pct_sd": sd, "damage_rate_pct": damage, "damage_rate_pct_sd": 0.2, "unripe_shed_pct": shed,
            "unripe_shed_pct_sd": 0.1, "efficiency_kg_min": removal / 10, "efficiency_kg_min_sd": sd / 10,
            "replicates": n, "finger_amplitude_mm": 74.3, "comb_swing_deg": 9.46}


def test_operating_point_rule_rests_on_the_replicates():
    """Best removal within the limits; a speed within the noise of it is 'no difference' (the configured one is
    then kept); a speed over the damage limit is left out whatever its removal."""
    rows = [_row(90, 30.0, 5.0), _row(120, 44.0, 6.0), _row(150, 46.0, 6.0), _row(180, 70.0, 5.0, damage=9.0)]
    op = operating_point({"harvest_response": {"rows": rows, "configured_rpm": 120.0}})
    assert isinstance(op, OperatingPoint)
    assert op.speed.value == 120.0 and op.no_difference == [150.0]
    assert op.to_json()["excluded"] == [{"speed_rpm": 180.0, "why": "damage 9 % > 5 %"}]
    assert "within the noise" in op.statement and "replicates" in op.rule
    rem = op.ripe_removal
    assert rem.lo < 44.0 < rem.hi and rem.n == 8 and rem.sd == 6.0
    # beyond the noise (tight replicates): the best is taken, not the configured speed
    rows = [_row(120, 44.0, 0.5), _row(150, 46.0, 0.5)]
    op = operating_point({"harvest_response": {"rows": rows, "configured_rpm": 120.0}})
    assert op.speed.value == 150.0 and op.no_difference == []
    # nothing within the limits: the removal rule among the speeds of least damage (within its noise)
    rows = [_row(120, 40.0, 1.0, damage=9.0), _row(150, 50.0, 1.0, damage=9.1), _row(180, 70.0, 1.0, damage=15.0)]
    op = operating_point({"harvest_response": {"rows": rows, "configured_rpm": 120.0}}, damage_limit_pct=5.0)
    assert not op.within_limits and op.speed.value == 150.0
    assert op.statement.startswith("No drive speed keeps damage") and "cannot be met by the speed alone" in \
        op.statement
    assert [e.speed_rpm for e in op.excluded] == [180.0]
    assert OperatingPoint.from_json(op.to_json()) == op


def test_why_this_efficiency_is_computed(reference, crank):
    """Efficiency = (ripe removal x ripe yield + unripe shed x unripe yield) per bush x bushes per minute, and the
    ratio of two machines' efficiencies splits into those factors; the removal's drivers are the finger's motion."""
    summary, machine, a = reference
    w = a.why_efficiency
    assert isinstance(w, WhyEfficiency) and isinstance(w.drivers, KinematicDrivers)
    assert w.product_kg_min == pytest.approx(w.efficiency.value, rel=0.02)
    assert "[as run: summary.json]" in w.yield_per_bush_kg.tag or "calibrated" in w.yield_per_bush_kg.tag
    assert w.drivers.finger_amplitude_mm == pytest.approx(74.3, rel=1e-2)
    assert w.drivers.acceleration_over_sinusoid > 2  # the groove cam's law: far from a sinusoid
    for word in ("kg/min", "ripe removal", "bushes/min", "amplitude", "Hz"):
        assert word in w.statement
    # the other machine picks half as much ripe fruit, same yield and walking: the removal makes the difference
    half = json.loads(json.dumps(crank[0]))
    rec = half["results"]["l9"]["recommended"]["replicates"]
    for key in ("efficiency", "ripe_removal"):
        rec[key] = {**rec[key], "mean": rec[key]["mean"] / 2, "ci": [v / 2 for v in rec[key]["ci"]]}
    other = why_efficiency(half, crank[1])
    c = compare_efficiency(other, w, "crank-rocker", "groove cam")
    assert isinstance(c, Comparison)
    assert c.ratio == pytest.approx(0.5, rel=1e-6) and c.dominant == "ripe removal"
    assert c.factors["ripe removal"] == pytest.approx(0.5, rel=1e-6)
    assert "crank-rocker" in c.statement and "x0.50" in c.statement
    both = design_answers(half, crank[1], reference=w)
    assert both.comparison.dominant == "ripe removal"
    # another study's answer as read from a file (its JSON form): the same comparison
    assert design_answers(half, crank[1], reference=w.to_json()).comparison == both.comparison
    # without a second study: the reference's published efficiency over its description's yield and walking
    assert a.comparison is None  # the reference machine itself
    pub = crank[2].comparison
    assert "published field result" in pub.statement and "3.93 kg/min" in pub.statement
    assert pub.ratio == pytest.approx(math.prod(pub.factors.values()), rel=0.02)


def test_missing_steps_are_named_and_the_section_still_renders(reference):
    summary, machine, _ = reference
    only = {"results": {"l9": summary["results"]["l9"]}}
    a = design_answers(only, machine)
    assert a.missing == ["clearance_life", "harvest_response"] and a.operating_point is None
    assert a.joints[machine.pair_names[0]].fit is None and "fit" not in a.to_json()["joints"][machine.pair_names[0]]
    text = design_answers_html(a)
    assert "Steps without results: clearance_life, harvest_response" in text


@pytest.mark.parametrize("which", ["reference", "crank"])
def test_html_tables_fit_an_a4_page(which, request):
    _, machine, a = request.getfixturevalue(which)
    text = design_answers_html(a)
    assert text.startswith("<h2>Design answers for ") and "<pre" not in text
    assert a.recommended.name in text and "Why this efficiency" in text
    tables = re.findall(r"<table[^>]*>(.*?)</table>", text, flags=re.S)
    assert len(tables) >= 3
    for t in tables:
        head = re.search(r"<thead><tr>(.*?)</tr></thead>", t, flags=re.S).group(1)
        cols = head.count("<th")
        assert cols <= MAX_COLUMNS
        widths = [float(w) for w in re.findall(r"width:([\d.]+)%", t)]
        assert len(widths) == cols and sum(widths) == pytest.approx(100, abs=0.5)  # fixed shares of the page
    for p in machine.pair_names:
        assert f"<td class=\"l\">{p}</td>" in text


def test_sections_are_named_by_the_reports_numbers(reference):
    """The sections the numbers come from are numbered as the report numbers them (by renderer), none typed."""
    from berryshaker.study.steps.clearance_life import clearance_life_section
    from berryshaker.study.steps.harvest_response import harvest_response_section
    from berryshaker.study.steps.virtual_l9 import virtual_l9_section

    a = reference[2]
    numbered = design_answers_html(a, {virtual_l9_section: 11, clearance_life_section: 12,
                                       harvest_response_section: 14})
    assert "11. Virtual L9" in numbered and "14. Harvest response" in numbered and "(section 11)" in numbered
    assert ">11, 12</td>" in numbered
    plain = design_answers_html(a)  # no numbering given: the sections' short names
    assert "Virtual L9" in plain and not re.search(r"\d\. Virtual L9|section \d", plain)


def test_html_is_no_wider_than_a4_in_chromium(crank, tmp_path):
    """Rendered with the report's CSS at A4 width (794 CSS px): no element reaches past the page."""
    from playwright import sync_api  # the test extra

    from berryshaker.report.html_blocks import CSS

    exe = shutil.which("chromium") or shutil.which("chromium-browser") or "/usr/bin/chromium"
    if not Path(exe).exists():
        pytest.skip("no Chromium (apt-get install chromium)")
    page_html = (f"<!doctype html><html><head><meta charset='utf-8'><style>{CSS}</style></head><body>"
                 f"{design_answers_html(crank[2])}</body></html>")
    path = tmp_path / "design.html"
    path.write_text(page_html, encoding="utf-8")
    js = """() => { const W = document.documentElement.clientWidth, out = [];
      for (const el of document.querySelectorAll('body *')) { const r = el.getBoundingClientRect();
        if (r.width > 0 && (r.right > W + 0.5 || r.left < -0.5)) out.push([el.tagName, Math.round(r.right)]); }
      return {W: W, scroll: document.documentElement.scrollWidth, over: out}; }"""
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        try:
            page = browser.new_page(viewport={"width": 794, "height": 1123})
            page.goto(path.resolve().as_uri())
            got = page.evaluate(js)
        finally:
            browser.close()
    assert got["W"] == 794 and got["scroll"] <= 794 and not got["over"], got


# ------------------------------------------------------------------------------------------------------ records


@pytest.mark.parametrize("which", ["reference", "crank"])
def test_answers_round_trip_through_their_json_form(which, request):
    """The answers' JSON form (what a design report or explorer reads from a file) reads back to equal answers,
    nested records included, and renders the same HTML."""
    _, _, a = request.getfixturevalue(which)
    data = json.loads(json.dumps(a.to_json()))
    back = DesignAnswers.from_json(data)
    assert back == a and back.to_json() == a.to_json()
    assert list(data) == ["machine", "drive", "pairs", "claims_apply", "recommended", "joints", "loads", "harvest",
                          "operating_point", "differences", "tradeoff", "why_efficiency", "comparison", "missing"]
    assert isinstance(back.joints[a.pairs[0]].service_interval, Quantity) and isinstance(back.tradeoff, Tradeoff)
    assert design_answers_html(back) == design_answers_html(a)
    pub = published_reference()
    assert PublishedReference.from_json(pub.to_json()) == pub


def test_a_quantity_keeps_its_keys_and_refuses_an_unknown_extra():
    q = quantity(3, "N", 2, 4, "95 %", "virtual_l9", "recommended.replicates.design_force_A", sd=0.5, n=8)
    assert q.to_json() == {"value": 3.0, "unit": "N", "lo": 2.0, "hi": 4.0, "interval": "95 %",
                           "source": {"step": "virtual_l9", "where": "recommended.replicates.design_force_A"},
                           "tag": "[computed]", "sd": 0.5, "n": 8}
    assert isinstance(q.value, float) and q.source == Source("virtual_l9", "recommended.replicates.design_force_A")
    assert "label" not in q.to_json() and q.label is None  # an extra not given is left out
    with pytest.raises(TypeError, match="colour"):
        quantity(1.0, "mm", colour="red")
    with pytest.raises(pydantic.ValidationError, match="colour"):
        Quantity.from_json({**q.to_json(), "colour": "red"})
    with pytest.raises(pydantic.ValidationError, match="step"):
        Quantity.from_json({**q.to_json(), "source": {"where": "x"}})


def test_answer_records_refuse_unknown_keys_and_wrong_types(reference):
    a = reference[2]
    data = a.to_json()
    with pytest.raises(pydantic.ValidationError, match="colour"):
        DesignAnswers.from_json({**data, "colour": "red"})
    with pytest.raises(pydantic.ValidationError, match="peak_torque"):
        DesignAnswers.from_json({**data, "joints": {"A": {**data["joints"]["A"], "peak_torque": 1.0}}})
    with pytest.raises(pydantic.ValidationError, match="within_limits"):
        OperatingPoint.from_json({k: v for k, v in data["operating_point"].items() if k != "within_limits"})
    with pytest.raises(pydantic.ValidationError, match="ratio"):
        Comparison.from_json({"ratio": "large", "factors": {}, "drivers": {}, "dominant": None, "statement": ""})
    with pytest.raises(pydantic.ValidationError, match="finger_speed"):
        KinematicDrivers.from_json({**data["why_efficiency"]["drivers"], "finger_speed": 1.0})
    with pytest.raises(AttributeError):
        a.machine = "another"  # frozen


def test_json_form_keeps_the_keys_of_the_dicts(reference):
    """The answers' JSON form has the keys, in the order, of the dicts the answers were before they were records;
    an extra a quantity does not have is left out."""
    j = reference[2].to_json()
    joint = j["joints"]["A"]
    assert list(joint) == ["clearance", "design_force", "fit", "fit_clearance", "service_interval"]  # no peak force SE
    assert list(joint["clearance"]) == ["value", "unit", "lo", "hi", "interval", "source", "tag", "basis"]
    assert list(joint["service_interval"])[-2:] == ["material_pair", "limit_mm"]
    assert list(j["loads"]["drive_torque_design"])[-3:] == ["sd", "n", "label"]
    assert list(j["differences"][0]) == ["response", "factor", "levels", "beyond_noise", "verdict", "p", "difference"]
    assert list(j["differences"][0]["difference"])[-1] == "se"
    assert list(j["operating_point"])[-6:] == ["within_limits", "rule", "limits", "no_difference", "excluded",
                                               "statement"]
    assert list(j["why_efficiency"]) == ["efficiency", "ripe_removal", "unripe_shed", "yield_per_bush_kg",
                                         "unripe_fraction", "bushes_per_min", "product_kg_min", "ripe_part_kg_min",
                                         "unripe_part_kg_min", "drivers", "statement"]
    assert list(j["tradeoff"]) == ["candidates", "dominated", "recommended", "named", "statement"]
    assert list(j["recommended"]) == ["code", "name", "statement", "starts", "l9_run"]
