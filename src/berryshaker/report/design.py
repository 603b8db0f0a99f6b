"""The design report of the machine a study was run on: the answers an engineer brings to the study, each with its
interval and the step it comes from (issue 45, item 1).

:func:`design_answers` reads the study's results (the dict ``summary.json`` holds, the one
:func:`berryshaker.report.html.study_report` is rendered from) and the machine description, and returns:

* per joint: the recommended clearance (virtual L9, section 6) with its level-set name, the recommended ISO 286 fit
  with its clearance range and service interval (clearance life, section 7), and the peak collision force at the
  recommended set (virtual L9, every start of that set);
* the drive torque (peak, RMS) and the harvest indexes at the recommended set, with their intervals;
* the operating point: the drive speed to run with, chosen from the harvest-response step (section 9) by a stated
  rule on the replicate means and SDs (:data:`SPEED_RULE`), and the stroke the geometry sets;
* what differs beyond the noise and what does not: the L9's paired differences of each factor's extreme levels;
* why this efficiency: efficiency = ripe removal x ripe yield per bush x bushes per minute (+ the unripe shed),
  with the kinematic quantities that set the removal (finger amplitude, shaking frequency, peak finger speed and
  acceleration against those of a sinusoid of the same amplitude and frequency); :func:`compare_efficiency` splits
  the ratio of two machines' efficiencies into the same factors.

Every number is a :func:`quantity` dict: value, unit, interval (lo, hi and what it is), source (step and report
section) and provenance tag.  Tags: ``[computed]`` a result of this study's runs; ``[assumed]``, ``[calibrated]``,
``[study]``, ``[published]``, ``[default]`` the inputs' tags (``berryshaker.config.value_tag``) where a number is
an input.  :func:`design_answers_html` renders the answers as the report's opening section (tables of at most
:data:`MAX_COLUMNS` columns with fixed widths, so nothing is wider than an A4 page, 794 CSS px).

long module: every answer is read from the same results in the same :func:`quantity` form, and its HTML renders
them all; splitting it would scatter one section over files.
"""

from __future__ import annotations

import html
import math

#: the report's sections the answers come from (berryshaker.report.html.study_report's numbering)
SECTIONS = {"virtual_l9": "6. Virtual L9", "clearance_life": "7. Clearance life", "powered_drive": "8. Powered drive",
            "harvest_response": "9. Harvest response", "kinematics": "1. Kinematics", "machine": "Configuration"}
#: widest table of the section (columns); with fixed column widths every table fits an A4 page
MAX_COLUMNS = 6
#: default limits of the operating-point rule (replicate means, %): [assumed], ours, not the study's
DAMAGE_LIMIT_PCT = 5.0
UNRIPE_LIMIT_PCT = 5.0
#: how the drive speed is chosen (docs: this module)
SPEED_RULE = ("among the drive speeds of the harvest-response step whose mean damage and mean unripe shedding are "
              "within their limits, the one with the highest mean ripe removal; a speed whose removal differs from "
              "it by less than the noise (Welch t test on the replicates, two-sided p >= 0.05) is 'no difference', "
              "and among those the configured speed is kept if it is one of them, else the slowest (least power "
              "and wear).  If no speed is within the limits, the same among the speeds whose damage is within the "
              "noise of the lowest.  The means rest on the replicates of each speed (perturbed starts), with their SD")
ALPHA = 0.05


def quantity(value, unit: str, lo=None, hi=None, interval: str = "", step: str = "", where: str = "",
             tag: str = "[computed]", **extra) -> dict:
    """One answer's number: value, unit, interval (lo, hi, what it is), its source and its provenance tag.

    Parameters
    ----------
    value : float
        The value, in ``unit`` (e.g. mm, N, h; dimensionless when ``unit`` is "").
    unit : str
        Its unit ("mm", "N", "h", "kg/min", "%", ...; "" for a dimensionless number).
    lo, hi : float, optional
        The interval's ends, in ``unit`` (e.g. mm, N, h); None where there is none (``interval`` then says why).
    interval : str
        What the interval is (e.g. "95 % t-interval of the mean of 32 starts").
    step : str
        The study step the number comes from (a key of :data:`SECTIONS`).
    where : str
        Where in that step's results (e.g. "recommended.replicates.peak_force_A").
    tag : str
        Provenance tag.
    **extra
        Further fields (sd, n, ...).

    Returns
    -------
    dict
        ``value``, ``unit``, ``lo``, ``hi``, ``interval``, ``source`` {step, section, where}, ``tag`` and ``extra``'s.
    """
    return {"value": None if value is None else float(value), "unit": unit,
            "lo": None if lo is None else float(lo), "hi": None if hi is None else float(hi),
            "interval": interval, "source": {"step": step, "section": SECTIONS.get(step, step), "where": where},
            "tag": tag, **extra}


def _estimate(est: dict | None, unit: str, step: str, where: str, tag: str = "[computed]") -> dict | None:
    """:func:`quantity` of a {mean, sd, ci, n, interval_from} estimate (study/l9.py ``interval``)."""
    if not est:
        return None
    n = est.get("n")
    return quantity(est["mean"], unit, est["ci"][0], est["ci"][1],
                    f"95 % interval of the mean of {n} starts ({est.get('interval_from', 'its replicates')}), "
                    f"SD {est['sd']:.3g} {unit}".rstrip(), step, where, tag, sd=est.get("sd"), n=n)


def level_set_name(clearances_mm: dict, unit: str = "mm") -> str:
    """A level set named by its clearances: ``{"A": 0.25, "B": 0.2}`` -> ``"A 0.25 mm, B 0.2 mm"``.

    Parameters
    ----------
    clearances_mm : dict pair -> float
        Clearance of each pair (mm), in the pairs' order.
    unit : str
        Unit written after each value.

    Returns
    -------
    str
        The name (values to 6 significant digits, no float noise: 0.15000000000000002 -> 0.15).
    """
    return ", ".join(f"{p} {float(f'{float(v):.6g}'):g} {unit}" for p, v in clearances_mm.items())


def claims_apply(machine) -> bool:
    """Whether the reference study's claims can be checked on the machine.

    Parameters
    ----------
    machine : Machine
        The machine description.

    Returns
    -------
    bool
        True where its pairs are the study's (A, B, C, F), the rule of
        :func:`berryshaker.study.claims.check_claims` (elsewhere six of eight claims are "not comparable").
    """
    from berryshaker.reference_study import PAIRS

    return tuple(machine.pair_names) == tuple(PAIRS)


# ---------------------------------------------------------------------------------------------------- answers


def _results(summary: dict) -> dict:
    return summary.get("results", summary)


def _recommended(summary: dict) -> dict:
    l9 = _results(summary).get("l9") or {}
    return l9.get("recommended") or {}


def _joint_answers(summary: dict, machine) -> dict:
    """Per joint: recommended clearance (L9), fit and service interval (life), peak collision force (L9)."""
    res = _results(summary)
    rec = _recommended(summary)
    opt = summary.get("optimum") or {}
    reps = rec.get("replicates") or opt.get("intervals") or {}
    basis = rec.get("basis") or opt.get("basis") or {}
    life = res.get("clearance_life") or {}
    cl = rec.get("clearance_mm") or opt.get("clearance_mm") or {}
    fits = _fit_answers(life, machine)
    out = {}
    for p in machine.pair_names:
        j = {}
        if p in cl:
            levels = (rec.get("levels") or {}).get(p)
            j["clearance"] = quantity(cl[p], "mm", cl[p], cl[p],
                                      "a design value: the L9 test level chosen" + (f" (level {levels})" if levels else ""),
                                      "virtual_l9", "recommended.clearance_mm", "[computed]",
                                      basis=str(basis.get(p, "")))
        force = _estimate(reps.get(f"peak_force_{p}"), "N", "virtual_l9", f"recommended.replicates.peak_force_{p}")
        if force:
            j["peak_force"] = force
        j.update(fits.get(p, {}))
        out[p] = j
    return out


def _fit_answers(life: dict, machine) -> dict:
    """Per joint: the recommended fit's clearance range and its service interval from the clearance-life step.

    The service interval is the Archard growth from the fit's mean clearance to the joint's service limit on the
    step's surrogate (:class:`berryshaker.life.tolerance.ClearanceResponse`, as ``berryshaker tolerance``); its
    interval is the wear coefficient k over the material pair's plausible range (the growth rate is proportional to
    k, so the hours to the limit scale as 1/k): k is the dominant uncertainty (docs/life.md)."""
    import numpy as np

    from berryshaker.contact.wear import MATERIAL_PAIRS
    from berryshaker.life.tolerance import ClearanceResponse, joint_candidates

    rec = (life or {}).get("recommended") or {}
    fits = rec.get("fits") or {}
    sur = (life or {}).get("surrogate") or {}
    if not fits:
        return {}
    joints = [p for p in machine.pair_names if p in fits]
    try:
        cands = joint_candidates(machine, joints, tuple(sorted({fits[p] for p in joints})))
    except Exception:  # noqa: BLE001 - a fit this machine cannot take: the life section shows the designation
        cands = {}
    out = {}
    for p in joints:
        d = {"fit": fits[p]}
        c = cands.get(p)
        if c is None:
            out[p] = d
            continue
        i = [f.designation for f in c.fits].index(fits[p])
        fit = c.fits[i]
        kind = "pin-in-bore" if machine.clearance[p].kind == "pin-in-bore" else "roller-in-groove"
        from berryshaker.life.wear import clearance_size_from_fit

        lo, hi = (clearance_size_from_fit(fit, kind, w) * 1e3 for w in ("min", "max"))
        c0 = float(c.size[i])
        conv = "radial" if kind == "pin-in-bore" else "free travel"
        d["fit_clearance"] = quantity(c0 * 1e3, "mm", lo, hi, f"the fit's clearance range ({conv}, ISO 286 limits "
                                      f"at {c.diameter_mm:g} mm); value: its mean", "clearance_life",
                                      "recommended.fits", "[computed]")
        s, limit = sur.get(p), (life.get("clearance_limit_mm") or {}).get(p)
        if s and limit is not None:
            r = ClearanceResponse(p, np.asarray(s["clearance_mm"]) * 1e-3, np.asarray(s["peak_force_N"]),
                                  np.asarray(s["growth_rate_um_per_h"]) * 1e-6,
                                  None if s.get("peak_force_se_N") is None else np.asarray(s["peak_force_se_N"]),
                                  starts=int(s.get("starts", 1)))
            hours = r.hours_to(c0, limit * 1e-3)
            mat = machine.clearance[p].geometry().material_pair
            mp = MATERIAL_PAIRS.get(mat)
            if mp is not None and hours > 0:
                k, (k_lo, k_hi) = mp.wear_coefficient, mp.wear_coefficient_range
                tag = "[assumed]" if mp.assumed else "[published]"
                d["service_interval"] = quantity(
                    hours, "h", hours * k / k_hi, hours * k / k_lo,
                    f"Archard k of {mat} over its range {k_lo:.0e}..{k_hi:.0e} (nominal {k:.0e}, {tag}): the hours "
                    "scale as 1/k", "clearance_life", "surrogate (growth from the fit's mean clearance to the limit "
                    f"{limit:.3g} mm)", f"[computed; k {tag}]", material_pair=mat, limit_mm=float(limit))
            if r.peak_force_se is not None and r.starts > 1:
                from scipy import stats

                f0 = float(r.force(c0))
                se = float(np.interp(c0, r.clearance, r.peak_force_se))
                t = float(stats.t.ppf(1 - ALPHA / 2, r.starts - 1))
                d["fit_peak_force"] = quantity(f0, "N", f0 - t * se, f0 + t * se,
                                               f"95 % t-interval of the mean of {r.starts} starts, machine without "
                                               "the bush (the life step's surrogate, interpolated)",
                                               "clearance_life", "surrogate.peak_force_N", "[computed]")
        out[p] = d
    return out


def _machine_loads(summary: dict) -> dict:
    rec = _recommended(summary)
    reps = rec.get("replicates") or (summary.get("optimum") or {}).get("intervals") or {}
    out = {}
    for key, name in (("drive_torque_peak", "drive torque, peak"), ("drive_torque_rms", "drive torque, RMS")):
        q = _estimate(reps.get(key), "N m", "virtual_l9", f"recommended.replicates.{key}")
        if q:
            out[key] = dict(q, label=name)
    return out


#: harvest indexes of the recommended set: key of the L9's replicates -> (label, unit)
HARVEST_LABELS = {"efficiency": ("efficiency", "kg/min"), "ripe_removal": ("ripe removal", "%"),
                  "unripe_shed": ("unripe shedding", "%"), "unripe": ("unripe rate (of the picked mass)", "%"),
                  "damage": ("damage", "%")}


def _harvest(summary: dict) -> dict:
    rec = _recommended(summary)
    opt = summary.get("optimum") or {}
    reps = rec.get("replicates") or opt.get("intervals") or {}
    fitted = set(rec.get("fitted") or opt.get("fitted") or [])
    out = {}
    for key, (label, unit) in HARVEST_LABELS.items():
        q = _estimate(reps.get(key), unit, "virtual_l9", f"recommended.replicates.{key}")
        if q:
            if key in fitted:
                q["tag"] = "[calibrated]"
                q["interval"] += "; fitted: the harvest model was calibrated to this value here, not evidence"
            out[key] = dict(q, label=label)
    return out


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
                    unripe_limit_pct: float = UNRIPE_LIMIT_PCT) -> dict | None:
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
    dict or None
        ``speed`` (r/min), ``frequency`` (Hz), ``ripe_removal``, ``unripe_shed``, ``damage``, ``efficiency``
        (quantities), ``finger_amplitude`` (mm) and ``comb_swing`` (deg) of the stroke, ``rule``, ``limits``,
        ``no_difference`` (speeds whose removal is within the noise of the best), ``excluded`` (speeds over a limit,
        with the reason), ``statement``; None without the step.
    """
    hr = _results(summary).get("harvest_response") or {}
    rows = [r for r in hr.get("rows") or [] if "ripe_removal_pct" in r]
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
    limits = {"damage_pct": damage_limit_pct, "unripe_shed_pct": unripe_limit_pct, "tag": "[assumed]"}
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
    out["within_limits"] = within
    out["rule"] = SPEED_RULE
    out["limits"] = limits
    out["no_difference"] = [r["speed_rpm"] for r in same if r is not chosen]
    out["excluded"] = [{"speed_rpm": r["speed_rpm"], "why": w_} for r, w_ in excluded]
    sd = chosen.get("ripe_removal_pct_sd", 0.0)
    why = ("the configured speed, whose removal is within the noise of the best" if kept is not None and
           kept is not best else "the highest mean removal" if chosen is best else
           "the slowest speed whose removal is within the noise of the best")
    out["statement"] = prefix + (f"{'Run' if within else 'run'} at {chosen['speed_rpm']:.0f} r/min ({chosen['shaking_frequency_hz']:.3g} Hz): {why} "
                        f"({chosen['ripe_removal_pct']:.3g} +- {sd:.2g} % ripe removal, mean +- SD of "
                        f"{chosen.get('replicates', 1)} replicates)"
                        + (f"; no difference from {', '.join(f'{s:.0f}' for s in out['no_difference'])} r/min"
                           if out["no_difference"] else "")
                        + (("; over the limits: " if within else "; damage beyond the noise of the lowest: ") + ", ".join(f"{e['speed_rpm']:.0f}" for e in out["excluded"])
                           + " r/min" if out["excluded"] else "") + ".  The stroke is the drive geometry's (the study does not "
                        "vary it).")
    return out


def differences(summary: dict) -> list[dict]:
    """The L9's paired differences: each factor's last minus first level over the blocked starts, per response.

    Parameters
    ----------
    summary : dict
        The study's summary (or its ``results``).

    Returns
    -------
    list of dict
        ``response``, ``factor``, ``levels``, ``difference`` (a :func:`quantity` in the response's unit with its
        95 % interval and ``se``), ``p``, ``beyond_noise`` and ``verdict`` ("differs" or "no difference").
    """
    res = _results(summary)
    l9 = res.get("l9") or {}
    paired = l9.get("paired") or {n: v.get("paired") for n, v in
                                  ((summary.get("l9_replicates") or {}).get("responses") or {}).items()}
    units = l9.get("response_units") or (l9.get("replicated") or {}).get("units") or {}
    out = []
    for n, per in (paired or {}).items():
        for f, q in (per or {}).items():
            a, b = q["levels"]
            out.append({"response": n, "factor": f, "levels": [a, b], "beyond_noise": bool(q["beyond_noise"]),
                        "verdict": "differs" if q["beyond_noise"] else "no difference", "p": float(q["p"]),
                        "difference": quantity(q["difference"], units.get(n, ""), q["ci"][0], q["ci"][1],
                                               f"95 % interval of the paired difference {f}{b} - {f}{a} over the "
                                               f"starts (SE {q['se']:.3g})", "virtual_l9", f"paired.{n}.{f}",
                                               se=float(q["se"]))})
    return out


def _tradeoff(summary: dict) -> dict:
    recs = summary.get("tradeoff") or (_results(summary).get("l9") or {}).get("tradeoff") or []
    rec = next((r for r in recs if "recommended" in str(r.get("name", ""))), None)
    pairs = [c.split(":", 1)[1] for c in (recs[0] if recs else {}) if c.startswith("clearance_mm:")]
    named = [{"candidate": r["name"], "name": level_set_name({p: r[f"clearance_mm:{p}"] for p in pairs}),
              "dominated": bool(r.get("dominated"))} for r in recs]
    return {"candidates": len(recs), "dominated": sum(1 for r in named if r["dominated"]),
            "recommended": None if rec is None else rec["name"], "named": named,
            "statement": (_recommended(summary).get("check") or {}).get("statement", "")}


# ------------------------------------------------------------------------------------------- why this efficiency


def _kinematic_drivers(kin: dict | None, machine, frequency_hz: float | None) -> dict:
    """Finger amplitude, frequency, peak finger speed and acceleration, and those over a sinusoid's of the same
    amplitude and frequency (the waveform's factors), from the kinematics step's combs (or the machine)."""
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
    return out


def _as_run(summary: dict, machine) -> tuple[float, float, float, float]:
    """Walking speed (m/s), plant spacing (m), yield per bush (kg) and unripe fraction the study ran with: its
    ``machine_si`` (summary.json) where present (a refit yield is there), else the description's."""
    si = summary.get("machine_si") or {}
    op, h = si.get("operation") or {}, si.get("harvest") or {}
    return (float(op.get("walking_speed", machine.operation.walking_speed)),
            float(op.get("plant_spacing", machine.operation.plant_spacing)),
            float(h.get("yield_per_bush", machine.harvest.yield_per_bush)),
            float(h.get("unripe_fraction", machine.harvest.unripe_fraction)))


def why_efficiency(summary: dict, machine) -> dict | None:
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
    dict or None
        ``efficiency`` and ``ripe_removal`` (quantities at the recommended set), ``yield_per_bush_kg`` and
        ``unripe_fraction`` (with their input tags), ``bushes_per_min``, ``product_kg_min`` (the decomposition's
        value, which equals the efficiency up to the sampled ripe fraction), ``drivers``
        (:func:`_kinematic_drivers`), ``statement``.
    """
    from berryshaker.config import value_tag

    hv = _harvest(summary)
    eff, rem = hv.get("efficiency"), hv.get("ripe_removal")
    if eff is None or rem is None:
        return None
    shed = hv.get("unripe_shed")
    walk, spacing, y, uf = _as_run(summary, machine)
    bpm = walk / spacing * 60.0
    ripe_part = rem["value"] / 100 * y * (1 - uf) * bpm
    unripe_part = (shed["value"] if shed else 0.0) / 100 * y * uf * bpm
    hr = _results(summary).get("harvest_response") or {}
    own = next((r for r in hr.get("rows") or [] if hr.get("configured_rpm") is not None
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
    if "finger_amplitude_mm" in d and d.get("frequency_hz"):
        kin_text = (f"  The removal is set by the finger's motion: amplitude {d['finger_amplitude_mm']:.3g} mm "
                    f"(comb swing +-{d['comb_swing_deg']:.3g} deg) at {d['frequency_hz']:.3g} Hz")
        if "finger_speed_m_s" in d:
            kin_text += (f", peak finger speed {d['finger_speed_m_s']:.3g} m/s ({d['speed_over_sinusoid']:.2f} x a "
                         "sinusoid's of that amplitude and frequency)")
        if "finger_acceleration_m_s2" in d:
            kin_text += (f" and peak acceleration {d['finger_acceleration_m_s2']:.3g} m/s² "
                         f"({d['acceleration_over_sinusoid']:.2f} x the sinusoid's)")
        kin_text += "."
    statement = (f"{eff['value']:.3g} kg/min [{eff['lo']:.3g}, {eff['hi']:.3g}] = ripe removal {rem['value']:.3g} % "
                 f"x ripe yield {y * (1 - uf):.3g} kg/bush ({y:g} kg {tags['yield']} x {1 - uf:g} ripe) x "
                 f"{bpm:.3g} bushes/min (walking {walk * 60:g} m/min / spacing {spacing:g} m)"
                 + (f" + unripe shedding {shed['value']:.2g} % x {y * uf:.3g} kg/bush" if shed else "")
                 + f" = {ripe_part + unripe_part:.3g} kg/min (the model samples the ripe fraction per bush)."
                 + kin_text)
    gap = (ripe_part + unripe_part) / eff["value"] - 1 if eff["value"] else float("nan")
    if not abs(gap) <= 0.05:
        statement += (f"  The product differs from the efficiency by {100 * gap:+.0f} %: the yield or field settings "
                      "used here are not those the study ran with (summary.json without machine_si?).")
    return {"efficiency": eff, "ripe_removal": rem, "unripe_shed": shed,
            "yield_per_bush_kg": quantity(y, "kg", y, y, "an input", "machine", "harvest.yield_per_bush",
                                          tags["yield"]),
            "unripe_fraction": quantity(uf, "", uf, uf, "an input", "machine", "harvest.unripe_fraction",
                                        tags["unripe_fraction"]),
            "bushes_per_min": quantity(bpm, "1/min", bpm, bpm, "an input: walking speed / plant spacing", "machine",
                                       "operation", f"{tags['walking_speed']} / {tags['plant_spacing']}"),
            "product_kg_min": ripe_part + unripe_part, "ripe_part_kg_min": ripe_part,
            "unripe_part_kg_min": unripe_part, "drivers": drivers, "statement": statement}


def compare_efficiency(a: dict, b: dict, name_a: str = "this machine", name_b: str = "the other") -> dict:
    """Why machine a's efficiency differs from machine b's: the ratio split into removal, ripe yield per bush and
    bushes per minute, and the removal's kinematic drivers side by side.

    Parameters
    ----------
    a, b : dict
        :func:`why_efficiency` of the two machines.
    name_a, name_b : str
        Their names in the statement.

    Returns
    -------
    dict
        ``ratio`` (efficiency a / b), ``factors`` {removal, ripe_yield, bushes_per_min}: ratios whose product is
        the ratio of the decompositions, ``drivers`` {name: (a, b, a / b)}, ``dominant`` (the factor furthest
        from 1), ``statement``.
    """
    def ripe_yield(w):
        return w["yield_per_bush_kg"]["value"] * (1 - w["unripe_fraction"]["value"])

    fac = {"ripe removal": a["ripe_removal"]["value"] / b["ripe_removal"]["value"],
           "ripe yield per bush": ripe_yield(a) / ripe_yield(b),
           "bushes per minute": a["bushes_per_min"]["value"] / b["bushes_per_min"]["value"]}
    ratio = a["efficiency"]["value"] / b["efficiency"]["value"]
    dom = max(fac, key=lambda k: abs(math.log(fac[k])) if fac[k] > 0 else math.inf)
    drv = {}
    for k, label in (("finger_amplitude_mm", "finger amplitude (mm)"), ("frequency_hz", "frequency (Hz)"),
                     ("finger_speed_m_s", "peak finger speed (m/s)"),
                     ("finger_acceleration_m_s2", "peak finger acceleration (m/s²)")):
        va, vb = a["drivers"].get(k), b["drivers"].get(k)
        if va is not None and vb:
            drv[label] = (va, vb, va / vb)
    def text(q):
        iv = "" if q["lo"] is None or q["lo"] == q["hi"] else f" [{q['lo']:.3g}, {q['hi']:.3g}]"
        return f"{q['value']:.3g} kg/min{iv}"

    close = abs(math.log(ratio)) < math.log(1.05) if ratio > 0 else False
    statement = (f"{name_a} {text(a['efficiency'])} against {name_b} {text(b['efficiency'])}: x{ratio:.2f} = "
                 + " x ".join(f"{k} x{v:.2f}" for k, v in fac.items())
                 + f" (the decompositions' product x{math.prod(fac.values()):.2f}); "
                 + ("the efficiencies are within 5 % of each other" if close else f"the {dom} makes the difference")
                 + (".  Its drivers, " + name_a + " / " + name_b + ": " + "; ".join(
                     f"{k} {va:.3g} / {vb:.3g} (x{r:.2f})" for k, (va, vb, r) in drv.items()) + "." if drv else "."))
    return {"ratio": ratio, "factors": fac, "drivers": drv, "dominant": None if close else dom,
            "statement": statement}


def published_reference() -> dict:
    """The reference machine's efficiency as published, split like :func:`why_efficiency`: the study's field result
    (3.93 kg/min [study]) over the reference description's ripe yield and bushes per minute gives the ripe removal
    it implies; the finger's motion from the reference description's kinematics.  What a study of another machine
    compares itself with when no study of the reference is at hand (:func:`compare_efficiency`).

    Returns
    -------
    dict
        The keys of :func:`why_efficiency` that :func:`compare_efficiency` reads, and ``machine``.
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
    return {"machine": f"{m.machine.name} (published field result)",
            "efficiency": quantity(eff, "kg/min", eff, eff, "the study's field result, published without an interval",
                                   "machine", "reference_study.FIELD_RESULT", "[study]"),
            "ripe_removal": quantity(removal, "%", removal, removal, "implied: the published efficiency over the "
                                     "reference description's ripe yield and bushes per minute (unripe shedding "
                                     "neglected)", "machine", "reference_study.FIELD_RESULT / harvest.yield_per_bush",
                                     f"[study] / {ytag}"),
            "yield_per_bush_kg": quantity(y, "kg", y, y, "an input", "machine", "harvest.yield_per_bush", ytag),
            "unripe_fraction": quantity(uf, "", uf, uf, "an input", "machine", "harvest.unripe_fraction",
                                        f"[{value_tag(m, 'harvest.unripe_fraction')}]"),
            "bushes_per_min": quantity(bpm, "1/min", bpm, bpm, "an input: walking speed / plant spacing", "machine",
                                       "operation", "[study]"),
            "drivers": _kinematic_drivers(None, m, None)}


# ----------------------------------------------------------------------------------------------------- the whole


def design_answers(summary: dict, machine, reference: dict | str | None = "published",
                   damage_limit_pct: float = DAMAGE_LIMIT_PCT,
                   unripe_limit_pct: float = UNRIPE_LIMIT_PCT) -> dict:
    """The answers an engineer brings to the study of their machine, each number with its interval and source.

    Parameters
    ----------
    summary : dict
        The study's summary.json (its ``results``, ``optimum`` and ``tradeoff``), or the results dict alone.
    machine : Machine
        The machine description the study ran on.
    reference : dict or "published" or None
        What this machine's efficiency is compared with (:func:`compare_efficiency`): :func:`why_efficiency` of
        another machine's study, "published" (default) for :func:`published_reference` on a machine whose pairs
        are not the reference study's (:func:`claims_apply`; on the reference machine itself nothing is
        compared), or None.
    damage_limit_pct, unripe_limit_pct : float
        Limits of the operating-point rule, in % of the picked mass and of the unripe mass [assumed].

    Returns
    -------
    dict
        ``machine``, ``drive``, ``pairs``, ``claims_apply``, ``recommended`` (code, ``name``: the clearances'
        name, statement), ``joints`` (per pair: clearance, peak_force, fit, fit_clearance, service_interval,
        fit_peak_force), ``loads`` (drive torque), ``harvest`` (indexes at the recommended set), ``operating_point``
        (:func:`operating_point`), ``differences`` (:func:`differences`), ``tradeoff``, ``why_efficiency``
        (:func:`why_efficiency`), ``comparison`` (with ``reference``) and ``missing`` (steps without results).
    """
    res = _results(summary)
    rec = _recommended(summary)
    opt = summary.get("optimum") or {}
    cl = rec.get("clearance_mm") or opt.get("clearance_mm")
    missing = [s for s, k in (("virtual_l9", "l9"), ("clearance_life", "clearance_life"),
                              ("harvest_response", "harvest_response")) if not res.get(k)]
    why = why_efficiency(summary, machine)
    out = {"machine": machine.machine.name, "drive": machine.DRIVE, "pairs": list(machine.pair_names),
           "claims_apply": claims_apply(machine),
           "recommended": None if not cl else {
               "code": rec.get("code") or opt.get("code"), "name": level_set_name(cl),
               "statement": rec.get("statement") or opt.get("statement") or "",
               "starts": rec.get("starts") or opt.get("starts"), "l9_run": rec.get("l9_run")},
           "joints": _joint_answers(summary, machine), "loads": _machine_loads(summary), "harvest": _harvest(summary),
           "operating_point": operating_point(summary, machine, damage_limit_pct, unripe_limit_pct),
           "differences": differences(summary), "tradeoff": _tradeoff(summary), "why_efficiency": why,
           "comparison": None, "missing": missing}
    if reference == "published":
        reference = None if claims_apply(machine) or why is None else published_reference()
    if isinstance(reference, dict) and why is not None:
        out["comparison"] = compare_efficiency(why, reference, machine.machine.name,
                                               reference.get("machine", "the reference"))
    return out


# ------------------------------------------------------------------------------------------------------ HTML


def _num(v) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    v = float(v)
    return f"{v:.0f}" if abs(v) >= 100 else f"{v:.3g}"  # whole newtons and hours, no "9.92e+03"


def _cell(q: dict | None):
    """A quantity as a table cell: value, and its interval on a second line."""
    from berryshaker.report.html import _Raw

    if not q:
        return "-"
    iv = "" if q["lo"] is None or q["hi"] is None or q["lo"] == q["hi"] else \
        f"<span class='ci'>[{_num(q['lo'])}, {_num(q['hi'])}]</span>"
    return _Raw(f"{html.escape(_num(q['value']))}{iv}")


def _src(q: dict | None) -> str:
    return "" if not q else q["source"]["section"]


def design_answers_html(answers: dict) -> str:
    """The design answers as the report's opening section: HTML fragments (h2, p, tables of at most
    :data:`MAX_COLUMNS` columns with fixed widths), to go first in the report of every machine.

    Parameters
    ----------
    answers : dict
        :func:`design_answers`.

    Returns
    -------
    str
        HTML (no document head; the report's CSS styles it).
    """
    from berryshaker.report.html import _Raw, _table

    a = answers
    parts = [f"<h2>Design answers for {html.escape(a['machine'])}</h2>"]
    rec = a.get("recommended")
    if rec:
        parts.append(f"<p>Recommended clearances: <b>{html.escape(rec['name'])}</b> (L9 code "
                     f"<code>{html.escape(str(rec['code']))}</code>"
                     + (f", {rec['starts']} starts" if rec.get("starts") else "") + ").  Each number below is the "
                     "mean with its 95 % interval under it; the last column names the report section it comes "
                     "from.</p>")
    else:
        parts.append("<p>No recommended clearances: the virtual L9 did not run (see Failed runs).</p>")
    if a.get("missing"):
        parts.append(f"<p class='small'>Steps without results: {html.escape(', '.join(a['missing']))}.</p>")
    joints = a.get("joints") or {}
    if joints:
        parts.append("<h3>Per joint</h3>")
        rows = []
        for p, j in joints.items():
            fit = j.get("fit", "-")
            q = j.get("fit_clearance")
            rng = "" if not q else f"<span class='ci'>{_num(q['lo'])} .. {_num(q['hi'])} mm</span>"
            rows.append([p, _cell(j.get("clearance")), _cell(j.get("peak_force")),
                         _Raw(html.escape(str(fit)) + rng), _cell(j.get("service_interval")),
                         "6, 7" if j.get("fit") else "6"])
        parts.append(_table(["joint", "clearance (mm)", "peak collision force (N)", "ISO fit, clearance (mm)",
                             "service interval (h)", "section"], rows, left=(0, 3),
                            widths=(13, 15, 20, 22, 18, 12)))
        mats = {j["service_interval"]["material_pair"]: j["service_interval"]["interval"]
                for j in joints.values() if j.get("service_interval")}
        parts.append("<p class='small'>Clearance: the L9's recommended level; peak force: mean over the recommended "
                     "set's starts (coupled with the bush); fit and service interval: the clearance-life step "
                     "(hours from the fit's mean clearance to the service limit, on its surrogate).  Service "
                     "interval range: " + html.escape("; ".join(mats.values()) or "not available") + ".</p>")
    loads = list((a.get("loads") or {}).values()) + list((a.get("harvest") or {}).values())
    if loads:
        parts.append("<h3>At the recommended set</h3>")
        parts.append(_table(["quantity", "unit", "mean [95 % interval]", "SD", "tag", "section"],
                            [[q["label"], q["unit"], _cell(q), _num(q.get("sd")), q["tag"], _src(q)] for q in loads],
                            left=(0, 1, 4, 5), widths=(28, 10, 20, 10, 15, 17)))
    op = a.get("operating_point")
    if op:
        parts.append("<h3>Operating point</h3>")
        parts.append(f"<p>{html.escape(op['statement'])}</p>")
        if op.get("speed"):
            items = [("drive speed", op["speed"]), ("shaking frequency", op["frequency"]),
                     *[(k.replace("_", " "), op[k]) for k in ("finger_amplitude", "comb_swing", "ripe_removal",
                                                              "unripe_shed", "damage", "efficiency") if op.get(k)]]
            parts.append(_table(["quantity", "unit", "mean [95 % interval]", "SD", "section"],
                                [[n, q["unit"], _cell(q), _num(q.get("sd")), _src(q)] for n, q in items],
                                left=(0, 1, 4), widths=(30, 12, 22, 14, 22)))
        parts.append(f"<p class='small'>Rule: {html.escape(op['rule'])}; limits: damage "
                     f"{op['limits']['damage_pct']:g} %, unripe shedding {op['limits']['unripe_shed_pct']:g} % "
                     f"{op['limits']['tag']}.</p>")
    diffs = a.get("differences") or []
    if diffs:
        parts.append("<h3>What differs beyond the noise, and what does not</h3>")
        factors = list(dict.fromkeys(d["factor"] for d in diffs))[:MAX_COLUMNS - 1]
        by = {(d["response"], d["factor"]): d for d in diffs}
        rows = []
        for n in dict.fromkeys(d["response"] for d in diffs):
            unit = next(d["difference"]["unit"] for d in diffs if d["response"] == n)
            cells = []
            for f in factors:
                d = by.get((n, f))
                if d is None:
                    cells.append("-")
                    continue
                q = d["difference"]
                verdict = "<b>differs</b>" if d["beyond_noise"] else "no difference"
                cells.append(_Raw(html.escape(("+" if q["value"] >= 0 else "") + _num(q["value"])) + f"<span class='ci'>[{_num(q['lo'])}, "
                                  f"{_num(q['hi'])}] {verdict}</span>"))
            rows.append([f"{n} ({unit})" if unit else n, *cells])
        levels = diffs[0]["levels"]
        parts.append(_table(["response", *[f"{f}{levels[1]} - {f}{levels[0]}" for f in factors]], rows, left=(0,),
                            widths=(100 - 18 * len(factors), *[18] * len(factors))))
        parts.append("<p class='small'>Paired difference of each factor's last and first level over the L9's starts "
                     "(section 6) with its 95 % interval: 'no difference' where the paired t test cannot tell the "
                     "levels apart (p >= 0.05); such a difference is noise and is not ranked.</p>")
    to = a.get("tradeoff") or {}
    if to.get("candidates"):
        parts.append(f"<p class='small'>Trade-off table (section 6): {to['candidates']} candidates, "
                     f"{to['dominated']} dominated beyond the noise.  {html.escape(to.get('statement') or '')}</p>")
    why = a.get("why_efficiency")
    if why:
        parts.append("<h3>Why this efficiency</h3>")
        parts.append(f"<p>{html.escape(why['statement'])}</p>")
        cmp_ = a.get("comparison")
        if cmp_:
            parts.append(f"<p>{html.escape(cmp_['statement'])}</p>")
    return "\n".join(parts)

