"""The design answers about the harvest (:mod:`berryshaker.report.design`): the harvest indexes at the recommended
set, the operating point and why this efficiency.

* :func:`operating_point`: the drive speed to run with, chosen from the harvest-response step by a stated rule on
  the replicate means and SDs (:data:`SPEED_RULE`), and the stroke the geometry sets;
* :func:`why_efficiency`: efficiency = ripe removal x ripe yield per bush x bushes per minute (+ the unripe shed),
  with the kinematic quantities that set the removal (finger amplitude, shaking frequency, peak finger speed and
  acceleration against those of a sinusoid of the same amplitude and frequency); :func:`compare_efficiency` splits
  the ratio of two machines' efficiencies into the same factors, against another study or
  :func:`published_reference`.

Each answer is a record of :mod:`berryshaker.report.design_records` (:class:`HarvestIndexes`,
:class:`OperatingPoint`, :class:`WhyEfficiency` with its :class:`KinematicDrivers`, :class:`Comparison`,
:class:`PublishedReference`), read by attribute; its JSON form is ``to_json()``.
"""

from __future__ import annotations

import math
from dataclasses import replace

from berryshaker.report.design_quantity import ALPHA, _estimate, _recommended, _results, quantity
from berryshaker.report.design_records import (
    Comparison,
    ExcludedSpeed,
    HarvestIndexes,
    KinematicDrivers,
    OperatingPoint,
    PublishedReference,
    SpeedLimits,
    WhyEfficiency,
)

#: default limits of the operating-point rule (replicate means, %): [assumed], ours, not the study's
DAMAGE_LIMIT_PCT = 5.0
UNRIPE_LIMIT_PCT = 5.0
#: how the drive speed is chosen (:func:`operating_point`)
SPEED_RULE = ("among the drive speeds of the harvest-response step whose mean damage and mean unripe shedding are "
              "within their limits, the one with the highest mean ripe removal; a speed whose removal differs from "
              "it by less than the noise (Welch t test on the replicates, two-sided p >= 0.05) is 'no difference', "
              "and among those the configured speed is kept if it is one of them, else the slowest (least power "
              "and wear).  If no speed is within the limits, the same among the speeds whose damage is within the "
              "noise of the lowest.  The means rest on the replicates of each speed (perturbed starts), with their SD")

#: harvest indexes of the recommended set: key of the L9's replicates -> (label, unit)
HARVEST_LABELS = {"efficiency": ("efficiency", "kg/min"), "ripe_removal": ("ripe removal", "%"),
                  "unripe_shed": ("unripe shedding", "%"), "unripe": ("unripe rate (of the picked mass)", "%"),
                  "damage": ("damage", "%")}


def _harvest(summary: dict) -> HarvestIndexes:
    rec = _recommended(summary)
    opt = summary.get("optimum") or {}
    reps = rec.get("replicates") or opt.get("intervals") or {}
    fitted = set(rec.get("fitted") or opt.get("fitted") or [])
    out = {}
    for key, (label, unit) in HARVEST_LABELS.items():
        q = _estimate(reps.get(key), unit, "virtual_l9", f"recommended.replicates.{key}")
        if q:
            if key in fitted:
                q = replace(q, tag="[calibrated]", interval=q.interval + "; fitted: the harvest model was calibrated "
                            "to this value here, not evidence")
            out[key] = replace(q, label=label)
    return HarvestIndexes(**out)


def _welch_p(m1, s1, n1, m2, s2, n2) -> float:
    """Two-sided p of Welch's t test from means, SDs and counts (1 when there is no spread to judge by)."""
    from scipy import stats

    v1, v2 = s1 * s1 / n1, s2 * s2 / n2
    if v1 + v2 <= 0:
        return 0.0 if m1 != m2 else 1.0
    t = (m1 - m2) / math.sqrt(v1 + v2)
    den = (v1 * v1 / (n1 - 1) if n1 > 1 else 0.0) + (v2 * v2 / (n2 - 1) if n2 > 1 else 0.0)
    dof = (v1 + v2) ** 2 / den if den > 0 else max(n1 + n2 - 2, 1)
    return float(2 * stats.t.sf(abs(t), dof))


def _speed_rows(hr: dict) -> list[dict]:
    """The harvest-response step's rows (JSON) as flat columns: per response its column (``ripe_removal_pct`` ...)
    holding the model's mean and ``<column>_sd`` the model's start-to-start SD
    (berryshaker.harvest.virtual.replicate_response)."""
    from berryshaker.harvest.virtual import RESPONSES

    out = []
    for r in hr.get("rows") or []:
        flat = {k: v for k, v in r.items() if k != "responses"}
        for n, sp in (r.get("responses") or {}).items():
            if n in RESPONSES:
                col = RESPONSES[n].column
                flat[col], flat[col + "_sd"], flat[col + "_field_sd"] = sp["mean"], sp["sd"], sp["field_sd"]
        out.append(flat)
    return out


def _differs(a: dict, b: dict, key: str) -> bool | None:
    """Whether two harvest-response rows' means of ``key`` differ beyond the noise (Welch, two-sided p < 0.05, on
    their replicates' SDs); None when a row has fewer than 2 replicates (no noise to judge by)."""
    n1, n2 = int(a.get("replicates") or 1), int(b.get("replicates") or 1)
    if n1 < 2 or n2 < 2:
        return None
    return _welch_p(a[key], a.get(key + "_sd", 0.0), n1, b[key], b.get(key + "_sd", 0.0), n2) < ALPHA


def _row_q(r: dict, key: str, unit: str, where: str) -> dict:
    """One harvest-response row's index: mean with the 95 % t-interval of the mean of its replicates."""
    from scipy import stats

    m, sd, n = r[key], r.get(key + "_sd", 0.0), int(r.get("replicates") or 1)
    hw = float(stats.t.ppf(1 - ALPHA / 2, n - 1)) * sd / math.sqrt(n) if n > 1 else float("nan")
    return quantity(m, unit, max(m - hw, 0.0) if n > 1 else None, m + hw if n > 1 else None,
                    f"95 % t-interval of the mean of {n} replicates, SD {sd:.3g} {unit}" if n > 1 else
                    "one replicate: no interval", "harvest_response", where, sd=sd, n=n)


def operating_point(summary: dict, machine=None, damage_limit_pct: float = DAMAGE_LIMIT_PCT,
                    unripe_limit_pct: float = UNRIPE_LIMIT_PCT) -> OperatingPoint | None:
    """The drive speed to run with, by :data:`SPEED_RULE`, from the harvest-response step's rows.

    Parameters
    ----------
    summary : dict
        The study's summary (or its ``results``).
    machine : Machine, optional
        For the stroke's note (unused otherwise).
    damage_limit_pct, unripe_limit_pct : float
        Limits on the mean damage and mean unripe shedding, in % of the picked mass and of the unripe mass
        [assumed].

    Returns
    -------
    OperatingPoint or None
        ``speed`` (r/min), ``frequency`` (Hz), ``ripe_removal``, ``unripe_shed``, ``damage``, ``efficiency``
        (quantities), ``finger_amplitude`` (mm) and ``comb_swing`` (deg) of the stroke, ``rule``, ``limits``,
        ``no_difference`` (speeds whose removal is within the noise of the best), ``excluded`` (speeds over a limit,
        with the reason), ``statement``; None without the step.
    """
    hr = _results(summary).get("harvest_response") or {}
    rows = [r for r in _speed_rows(hr) if "ripe_removal_pct" in r]
    if not rows:
        return None
    own = hr.get("configured_rpm")
    ok, excluded = [], []
    for r in rows:
        why = []
        if r.get("damage_rate_pct", 0.0) > damage_limit_pct:
            why.append(f"damage {r['damage_rate_pct']:.3g} % > {damage_limit_pct:g} %")
        if r.get("unripe_shed_pct", 0.0) > unripe_limit_pct:
            why.append(f"unripe shedding {r['unripe_shed_pct']:.3g} % > {unripe_limit_pct:g} %")
        (excluded if why else ok).append((r, "; ".join(why)))
    limits = SpeedLimits(damage_limit_pct, unripe_limit_pct, "[assumed]")
    within = bool(ok)
    prefix = ""
    if not ok:  # no speed within the limits: the removal rule among the speeds of least damage (within its noise)
        low = min(rows, key=lambda r: r.get("damage_rate_pct", 0.0))
        ok = [(r, "") for r in rows if r is low or _differs(r, low, "damage_rate_pct") is False]
        prefix = ("No drive speed keeps damage and unripe shedding within the limits ("
                  + "; ".join(f"{r['speed_rpm']:.0f} r/min: {w}" for r, w in excluded) + "): the limits cannot be "
                  "met by the speed alone.  Among the speeds whose damage is within the noise of the lowest ("
                  f"{low['damage_rate_pct']:.3g} +- {low.get('damage_rate_pct_sd', 0.0):.2g} % at "
                  f"{low['speed_rpm']:.0f} r/min): ")
        excluded = [(r, w) for r, w in excluded if all(r is not o for o, _ in ok)]
    ok = [r for r, _ in ok]
    best = max(ok, key=lambda r: r["ripe_removal_pct"])

    same = [r for r in ok if r is best or _differs(r, best, "ripe_removal_pct") is False]
    kept = next((r for r in same if own is not None and math.isclose(r["speed_rpm"], own, rel_tol=1e-6)), None)
    chosen = kept or min(same, key=lambda r: r["speed_rpm"])
    w = f"rows[speed_rpm={chosen['speed_rpm']:.0f}]"
    out = {"speed": quantity(chosen["speed_rpm"], "r/min", chosen["speed_rpm"], chosen["speed_rpm"],
                             "a design value: one of the step's drive speeds", "harvest_response", w),
           "frequency": quantity(chosen["shaking_frequency_hz"], "Hz", chosen["shaking_frequency_hz"],
                                 chosen["shaking_frequency_hz"], "a design value (one comb cycle per revolution)",
                                 "harvest_response", w)}
    for key, name, unit in (("ripe_removal_pct", "ripe_removal", "%"), ("unripe_shed_pct", "unripe_shed", "%"),
                            ("damage_rate_pct", "damage", "%"), ("efficiency_kg_min", "efficiency", "kg/min")):
        if key in chosen:
            out[name] = _row_q(chosen, key, unit, f"{w}.{key}")
    for key, unit in (("finger_amplitude_mm", "mm"), ("comb_swing_deg", "deg")):
        if key in chosen:
            v = chosen[key]
            out[key.rsplit("_", 1)[0]] = quantity(
                v, unit, 0.99 * v, 1.01 * v, "geometric, of the ideal mechanism; the clearances and the bush change "
                "the swing by under 1 % (harvest.virtual.shaking_amplitude)", "harvest_response", f"{w}.{key}")
    no_difference = [r["speed_rpm"] for r in same if r is not chosen]
    excluded = [ExcludedSpeed(r["speed_rpm"], w_) for r, w_ in excluded]
    sd = chosen.get("ripe_removal_pct_sd", 0.0)
    why = ("the configured speed, whose removal is within the noise of the best" if kept is not None and
           kept is not best else "the highest mean removal" if chosen is best else
           "the slowest speed whose removal is within the noise of the best")
    statement = prefix + (f"{'Run' if within else 'run'} at {chosen['speed_rpm']:.0f} r/min ({chosen['shaking_frequency_hz']:.3g} Hz): {why} "
                        f"({chosen['ripe_removal_pct']:.3g} +- {sd:.2g} % ripe removal, mean +- SD of "
                        f"{chosen.get('replicates', 1)} replicates)"
                        + (f"; no difference from {', '.join(f'{s:.0f}' for s in no_difference)} r/min"
                           if no_difference else "")
                        + (("; over the limits: " if within else "; damage beyond the noise of the lowest: ") + ", ".join(f"{e.speed_rpm:.0f}" for e in excluded)
                           + " r/min" if excluded else "") + ".  The stroke is the drive geometry's (the study does not "
                        "vary it).")
    return OperatingPoint(**out, within_limits=within, rule=SPEED_RULE, limits=limits, no_difference=no_difference,
                          excluded=excluded, statement=statement)


# ------------------------------------------------------------------------------------------- why this efficiency


def _kinematic_drivers(kin: dict | None, machine, frequency_hz: float | None) -> KinematicDrivers:
    """Finger amplitude, frequency, peak finger speed and acceleration, and those over a sinusoid's of the same
    amplitude and frequency (the waveform's factors), from the kinematics step's combs (or the machine), as a
    :class:`KinematicDrivers`."""
    if not kin or "combs" not in kin:
        from berryshaker.drives import drive_of

        drive = drive_of(machine)
        kin = drive.kinematics_summary(machine, drive.check(machine))
    combs = kin["combs"]
    side = max(combs, key=lambda s: combs[s]["swing_deg"]["max"] - combs[s]["swing_deg"]["min"])
    c = combs[side]
    half = math.radians(0.5 * (c["swing_deg"]["max"] - c["swing_deg"]["min"]))
    f = frequency_hz if frequency_hz is not None else (kin.get("drive") or {}).get("comb_frequency_hz")
    out = {"comb": side, "comb_swing_deg": math.degrees(half), "frequency_hz": f}
    radius = machine.plant.contact.finger_radius if getattr(machine, "plant", None) is not None else None
    if radius is not None:
        out["finger_amplitude_mm"] = half * radius * 1e3
    length = getattr(getattr(machine, "combs", None), "length", None)
    if length and "max_tip_speed_m_s" in c and f:
        w = 2 * math.pi * f
        out["tip_speed_m_s"] = c["max_tip_speed_m_s"]
        out["tip_acceleration_m_s2"] = c.get("max_tip_acceleration_m_s2")
        out["speed_over_sinusoid"] = c["max_tip_speed_m_s"] / (half * length * w)
        if c.get("max_tip_acceleration_m_s2") is not None:
            out["acceleration_over_sinusoid"] = c["max_tip_acceleration_m_s2"] / (half * length * w * w)
        if radius is not None:  # the finger's peak speed and acceleration: the comb's angular ones times its radius
            out["finger_speed_m_s"] = c["max_tip_speed_m_s"] * radius / length
            if c.get("max_tip_acceleration_m_s2") is not None:
                out["finger_acceleration_m_s2"] = c["max_tip_acceleration_m_s2"] * radius / length
    return KinematicDrivers(**out)


def _as_run(summary: dict, machine) -> tuple[float, float, float, float]:
    """Walking speed (m/s), plant spacing (m), yield per bush (kg) and unripe fraction the study ran with: its
    ``machine_si`` (summary.json) where present (a refit yield is there), else the description's."""
    si = summary.get("machine_si") or {}
    op, h = si.get("operation") or {}, si.get("harvest") or {}
    return (float(op.get("walking_speed", machine.operation.walking_speed)),
            float(op.get("plant_spacing", machine.operation.plant_spacing)),
            float(h.get("yield_per_bush", machine.harvest.yield_per_bush)),
            float(h.get("unripe_fraction", machine.harvest.unripe_fraction)))


def why_efficiency(summary: dict, machine) -> WhyEfficiency | None:
    """Efficiency decomposed: picked mass per minute = (ripe removal x ripe yield + unripe shedding x unripe yield)
    per bush x bushes per minute, with the kinematic quantities that set the removal.

    Parameters
    ----------
    summary : dict
        The study's summary (its ``machine_si`` gives the yield and field settings it ran with).
    machine : Machine
        The machine description.

    Returns
    -------
    WhyEfficiency or None
        ``efficiency`` and ``ripe_removal`` (quantities at the recommended set), ``yield_per_bush_kg`` and
        ``unripe_fraction`` (with their input tags), ``bushes_per_min``, ``product_kg_min`` (the decomposition's
        value, which equals the efficiency up to the sampled ripe fraction), ``drivers``
        (:class:`KinematicDrivers`), ``statement``; None without the efficiency or the removal.
    """
    from berryshaker.config import value_tag

    hv = _harvest(summary)
    eff, rem = hv.efficiency, hv.ripe_removal
    if eff is None or rem is None:
        return None
    shed = hv.unripe_shed
    walk, spacing, y, uf = _as_run(summary, machine)
    bpm = walk / spacing * 60.0
    ripe_part = rem.value / 100 * y * (1 - uf) * bpm
    unripe_part = (shed.value if shed else 0.0) / 100 * y * uf * bpm
    hr = _results(summary).get("harvest_response") or {}
    own = next((r for r in _speed_rows(hr) if hr.get("configured_rpm") is not None
                and math.isclose(r["speed_rpm"], hr["configured_rpm"], rel_tol=1e-6)), None)
    freq = own["shaking_frequency_hz"] if own else None
    drivers = _kinematic_drivers(_results(summary).get("kinematics"), machine, freq)
    own_values = (machine.operation.walking_speed, machine.operation.plant_spacing, machine.harvest.yield_per_bush,
                  machine.harvest.unripe_fraction)
    tags = {k: (f"[{value_tag(machine, key)}]" if math.isclose(v, own, rel_tol=1e-9) else "[as run: summary.json]")
            for (k, key), v, own in zip((("walking_speed", "operation.walking_speed"),
                                         ("plant_spacing", "operation.plant_spacing"),
                                         ("yield", "harvest.yield_per_bush"),
                                         ("unripe_fraction", "harvest.unripe_fraction")),
                                        (walk, spacing, y, uf), own_values)}
    cal = {r.get("parameter"): r.get("tag") for r in ((_results(summary).get("harvest_response") or {}).get(
        "calibration") or {}).get("parameters") or []}
    if cal.get("yield per bush"):  # the calibration table's tag: [calibrated] where the yield was refit in this study
        tags["yield"] = cal["yield per bush"]
    d = drivers
    kin_text = ""
    if d.finger_amplitude_mm is not None and d.frequency_hz:
        kin_text = (f"  The removal is set by the finger's motion: amplitude {d.finger_amplitude_mm:.3g} mm "
                    f"(comb swing +-{d.comb_swing_deg:.3g} deg) at {d.frequency_hz:.3g} Hz")
        if d.finger_speed_m_s is not None:
            kin_text += (f", peak finger speed {d.finger_speed_m_s:.3g} m/s ({d.speed_over_sinusoid:.2f} x a "
                         "sinusoid's of that amplitude and frequency)")
        if d.finger_acceleration_m_s2 is not None:
            kin_text += (f" and peak acceleration {d.finger_acceleration_m_s2:.3g} m/s² "
                         f"({d.acceleration_over_sinusoid:.2f} x the sinusoid's)")
        kin_text += "."
    statement = (f"{eff.value:.3g} kg/min [{eff.lo:.3g}, {eff.hi:.3g}] = ripe removal {rem.value:.3g} % "
                 f"x ripe yield {y * (1 - uf):.3g} kg/bush ({y:g} kg {tags['yield']} x {1 - uf:g} ripe) x "
                 f"{bpm:.3g} bushes/min (walking {walk * 60:g} m/min / spacing {spacing:g} m)"
                 + (f" + unripe shedding {shed.value:.2g} % x {y * uf:.3g} kg/bush" if shed else "")
                 + f" = {ripe_part + unripe_part:.3g} kg/min (the model samples the ripe fraction per bush)."
                 + kin_text)
    gap = (ripe_part + unripe_part) / eff.value - 1 if eff.value else float("nan")
    if not abs(gap) <= 0.05:
        statement += (f"  The product differs from the efficiency by {100 * gap:+.0f} %: the yield or field settings "
                      "used here are not those the study ran with (summary.json without machine_si?).")
    return WhyEfficiency(
        efficiency=eff, ripe_removal=rem, unripe_shed=shed,
        yield_per_bush_kg=quantity(y, "kg", y, y, "an input", "machine", "harvest.yield_per_bush", tags["yield"]),
        unripe_fraction=quantity(uf, "", uf, uf, "an input", "machine", "harvest.unripe_fraction",
                                 tags["unripe_fraction"]),
        bushes_per_min=quantity(bpm, "1/min", bpm, bpm, "an input: walking speed / plant spacing", "machine",
                                "operation", f"{tags['walking_speed']} / {tags['plant_spacing']}"),
        product_kg_min=ripe_part + unripe_part, ripe_part_kg_min=ripe_part, unripe_part_kg_min=unripe_part,
        drivers=drivers, statement=statement)


def compare_efficiency(a: WhyEfficiency | PublishedReference, b: WhyEfficiency | PublishedReference,
                       name_a: str = "this machine", name_b: str = "the other") -> Comparison:
    """Why machine a's efficiency differs from machine b's: the ratio split into removal, ripe yield per bush and
    bushes per minute, and the removal's kinematic drivers side by side.

    Parameters
    ----------
    a, b : WhyEfficiency or PublishedReference
        :func:`why_efficiency` of the two machines (or :func:`published_reference`).
    name_a, name_b : str
        Their names in the statement.

    Returns
    -------
    Comparison
        ``ratio`` (efficiency a / b), ``factors`` {removal, ripe_yield, bushes_per_min}: ratios whose product is
        the ratio of the decompositions, ``drivers`` {name: (a, b, a / b)}, ``dominant`` (the factor furthest
        from 1), ``statement``.
    """
    def ripe_yield(w):
        return w.yield_per_bush_kg.value * (1 - w.unripe_fraction.value)

    fac = {"ripe removal": a.ripe_removal.value / b.ripe_removal.value,
           "ripe yield per bush": ripe_yield(a) / ripe_yield(b),
           "bushes per minute": a.bushes_per_min.value / b.bushes_per_min.value}
    ratio = a.efficiency.value / b.efficiency.value
    dom = max(fac, key=lambda k: abs(math.log(fac[k])) if fac[k] > 0 else math.inf)
    drv = {}
    for k, label in (("finger_amplitude_mm", "finger amplitude (mm)"), ("frequency_hz", "frequency (Hz)"),
                     ("finger_speed_m_s", "peak finger speed (m/s)"),
                     ("finger_acceleration_m_s2", "peak finger acceleration (m/s²)")):
        va, vb = getattr(a.drivers, k), getattr(b.drivers, k)
        if va is not None and vb:
            drv[label] = (va, vb, va / vb)
    def text(q):
        iv = "" if q.lo is None or q.lo == q.hi else f" [{q.lo:.3g}, {q.hi:.3g}]"
        return f"{q.value:.3g} kg/min{iv}"

    close = abs(math.log(ratio)) < math.log(1.05) if ratio > 0 else False
    statement = (f"{name_a} {text(a.efficiency)} against {name_b} {text(b.efficiency)}: x{ratio:.2f} = "
                 + " x ".join(f"{k} x{v:.2f}" for k, v in fac.items())
                 + f" (the decompositions' product x{math.prod(fac.values()):.2f}); "
                 + ("the efficiencies are within 5 % of each other" if close else f"the {dom} makes the difference")
                 + (".  Its drivers, " + name_a + " / " + name_b + ": " + "; ".join(
                     f"{k} {va:.3g} / {vb:.3g} (x{r:.2f})" for k, (va, vb, r) in drv.items()) + "." if drv else "."))
    return Comparison(ratio, fac, drv, None if close else dom, statement)


def published_reference() -> PublishedReference:
    """The reference machine's efficiency as published, split like :func:`why_efficiency`: the study's field result
    (3.93 kg/min [study]) over the reference description's ripe yield and bushes per minute gives the ripe removal
    it implies; the finger's motion from the reference description's kinematics.  What a study of another machine
    compares itself with when no study of the reference is at hand (:func:`compare_efficiency`).

    Returns
    -------
    PublishedReference
        The fields of :class:`WhyEfficiency` that :func:`compare_efficiency` reads, and ``machine``.
    """
    from berryshaker.config import reference_machine, value_tag
    from berryshaker.reference_study import FIELD_RESULT

    m = reference_machine()
    walk, spacing, y, uf = (float(m.operation.walking_speed), float(m.operation.plant_spacing),
                            float(m.harvest.yield_per_bush), float(m.harvest.unripe_fraction))
    bpm = walk / spacing * 60.0
    eff = float(FIELD_RESULT["efficiency_kg_min"])
    removal = 100.0 * eff / (y * (1 - uf) * bpm)
    ytag = f"[{value_tag(m, 'harvest.yield_per_bush')}]"
    return PublishedReference(
        machine=f"{m.machine.name} (published field result)",
        efficiency=quantity(eff, "kg/min", eff, eff, "the study's field result, published without an interval",
                            "machine", "reference_study.FIELD_RESULT", "[study]"),
        ripe_removal=quantity(removal, "%", removal, removal, "implied: the published efficiency over the "
                              "reference description's ripe yield and bushes per minute (unripe shedding "
                              "neglected)", "machine", "reference_study.FIELD_RESULT / harvest.yield_per_bush",
                              f"[study] / {ytag}"),
        yield_per_bush_kg=quantity(y, "kg", y, y, "an input", "machine", "harvest.yield_per_bush", ytag),
        unripe_fraction=quantity(uf, "", uf, uf, "an input", "machine", "harvest.unripe_fraction",
                                 f"[{value_tag(m, 'harvest.unripe_fraction')}]"),
        bushes_per_min=quantity(bpm, "1/min", bpm, bpm, "an input: walking speed / plant spacing", "machine",
                                "operation", "[study]"),
        drivers=_kinematic_drivers(None, m, None))

