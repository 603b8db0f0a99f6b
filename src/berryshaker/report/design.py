"""The design report of the machine a study was run on: the answers an engineer brings to the study, each with its
interval and the step it comes from.

:func:`design_answers` reads the study's results (the dict ``summary.json`` holds, the one
:func:`berryshaker.report.html.study_report` is rendered from) and the machine description, and returns:

* per joint: the recommended clearance (virtual L9) with its level-set name, the recommended ISO 286 fit with its
  clearance range and service interval (clearance life), and the static-equivalent collision force at the recommended set
  (virtual L9, every start of that set);
* the drive torque (peak, RMS) and the harvest indexes at the recommended set, with their intervals;
* the operating point and why this efficiency (:mod:`berryshaker.report.harvest_answers`);
* what differs beyond the noise and what does not: the L9's paired differences of each factor's extreme levels.

The answers are a :class:`berryshaker.report.design_records.DesignAnswers` record, read by attribute; every
number is a :class:`berryshaker.report.design_quantity.Quantity`: value, unit, interval (lo, hi and what it is),
source (step) and provenance tag.  :func:`berryshaker.report.design_html.design_answers_html` renders the answers
as the report's opening section, naming each number's report section by the report's numbering.
"""

from __future__ import annotations

from dataclasses import replace

from berryshaker.report.design_quantity import ALPHA, _estimate, _recommended, _results, quantity
from berryshaker.report.design_records import (
    DesignAnswers,
    Difference,
    JointAnswers,
    Loads,
    PublishedReference,
    Recommended,
    Tradeoff,
    TradeoffCandidate,
    WhyEfficiency,
)
from berryshaker.report.harvest_answers import (
    DAMAGE_LIMIT_PCT,
    UNRIPE_LIMIT_PCT,
    _harvest,
    compare_efficiency,
    operating_point,
    published_reference,
    why_efficiency,
)


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


def _joint_answers(summary: dict, machine) -> dict[str, JointAnswers]:
    """Per joint: recommended clearance (L9), fit and service life (life), static-equivalent collision force (L9)."""
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
        force = _estimate(reps.get(f"design_force_{p}"), "N", "virtual_l9", f"recommended.replicates.design_force_{p}")
        if force:
            j["design_force"] = force
        j.update(fits.get(p, {}))
        out[p] = JointAnswers(**j)
    return out


def _fit_answers(life: dict, machine) -> dict:
    """Per joint: the recommended fit's clearance range and its service interval from the clearance-life step (the
    fields of :class:`JointAnswers` it gives, by name).

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
    if life.get("recommended_fits"):
        return _fits_with_life(life)
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
            r = ClearanceResponse(p, np.asarray(s["clearance_mm"]) * 1e-3, np.asarray(s["design_force_N"]),
                                  np.asarray(s["growth_rate_um_per_h"]) * 1e-6,
                                  None if s.get("design_force_se_N") is None else np.asarray(s["design_force_se_N"]),
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
            if r.design_force_se is not None and r.starts > 1:
                from scipy import stats

                f0 = float(r.force(c0))
                se = float(np.interp(c0, r.clearance, r.design_force_se))
                t = float(stats.t.ppf(1 - ALPHA / 2, r.starts - 1))
                d["fit_design_force"] = quantity(f0, "N", f0 - t * se, f0 + t * se,
                                               f"95 % t-interval of the mean of {r.starts} starts, machine without "
                                               "the bush (the life step's surrogate, interpolated)",
                                               "clearance_life", "surrogate.design_force_N", "[computed]")
        out[p] = d
    return out


def _life_quantity(life: dict, where: str):
    """A joint's service life (:class:`berryshaker.life.service_life.JointLife` as JSON) as a quantity: the hours
    of its governing mechanism with that mechanism's interval, no number beyond the design life (``reads``)."""
    design = life["design_life_h"]

    def within(x):
        return x if x is not None and x <= design else None

    value = within(life["hours"])
    return quantity(value, "h", within(life["lo"]) if value is not None else None,
                    within(life["hi"]) if value is not None else None,
                    f"{life['reads']}; governing: {life['governing']}; interval: {life['uncertainty']}",
                    "clearance_life", where, "[computed; wear k [assumed]]", limit_mm=float(life["limit_mm"]),
                    reads=life["reads"], mechanism=life["governing"])


def _fit_quantities(fl: dict, where: str) -> dict:
    """A fit evaluated by the life step (:class:`berryshaker.study.life_drive_records.FitLife` as JSON) as the
    answers' quantities: its new-machine clearance, the static-equivalent force there and the service life."""
    from scipy import stats

    out = {"fit_clearance": quantity(fl["clearance_mm"], "mm", fl["clearance_min_mm"], fl["clearance_max_mm"],
                                     "the fit's new-machine clearance (ISO 286 limits); value: its mean",
                                     "clearance_life", where, "[computed]"),
           "service_interval": _life_quantity(fl["life"], where + ".life")}
    se, n = fl.get("design_force_se_N"), fl.get("starts")
    f0 = fl["design_force_N"]
    if se is not None and n:
        t = float(stats.t.ppf(1 - ALPHA / 2, n - 1))
        out["fit_design_force"] = quantity(f0, "N", f0 - t * se, f0 + t * se, "static-equivalent force (p95 of the "
                                           f"impact peaks) at the fit's mean clearance, machine without the bush; "
                                           f"95 % t-interval of the mean of {n} starts", "clearance_life", where,
                                           "[computed]", n=n)
    else:
        out["fit_design_force"] = quantity(f0, "N", None, None, "static-equivalent force at the fit's mean "
                                           "clearance (one start)", "clearance_life", where, "[computed]")
    return out


def _fits_with_life(life: dict) -> dict:
    """Per joint: the recommended fit and the drawing's, each with its new-machine clearance, load and life."""
    out = {}
    for p, fl in life["recommended_fits"].items():
        d = {"fit": fl["fit"], **_fit_quantities(fl, f"recommended_fits.{p}")}
        dr = (life.get("drawing_fits") or {}).get(p)
        if dr is not None:
            q = _fit_quantities(dr, f"drawing_fits.{p}")
            d.update(drawing_fit=dr["fit"], drawing_fit_clearance=q["fit_clearance"],
                     drawing_service_interval=q["service_interval"])
        out[p] = d
    return out


def _machine_loads(summary: dict) -> Loads:
    rec = _recommended(summary)
    reps = rec.get("replicates") or (summary.get("optimum") or {}).get("intervals") or {}
    out = {}
    for key, name in (("drive_torque_design", "drive torque, design (p95 of the per-revolution peaks)"), ("drive_torque_rms", "drive torque, RMS")):
        q = _estimate(reps.get(key), "N m", "virtual_l9", f"recommended.replicates.{key}")
        if q:
            out[key] = replace(q, label=name)
    return Loads(**out)


def differences(summary: dict) -> list[Difference]:
    """The L9's paired differences: each factor's last minus first level over the blocked starts, per response.

    Parameters
    ----------
    summary : dict
        The study's summary (or its ``results``).

    Returns
    -------
    list of Difference
        ``response``, ``factor``, ``levels``, ``beyond_noise``, ``verdict`` ("differs" or "no difference"), ``p``
        and ``difference`` (a :func:`quantity` in the response's unit with its 95 % interval and ``se``).
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
            out.append(Difference(n, f, [a, b], bool(q["beyond_noise"]),
                                  "differs" if q["beyond_noise"] else "no difference", float(q["p"]),
                                  quantity(q["difference"], units.get(n, ""), q["ci"][0], q["ci"][1],
                                           f"95 % interval of the paired difference {f}{b} - {f}{a} over the "
                                           f"starts (SE {q['se']:.3g})", "virtual_l9", f"paired.{n}.{f}",
                                           se=float(q["se"]))))
    return out


def _tradeoff(summary: dict) -> Tradeoff:
    recs = summary.get("tradeoff") or (_results(summary).get("l9") or {}).get("tradeoff") or []
    rec = next((r for r in recs if "recommended" in str(r.get("name", ""))), None)
    pairs = [c.split(":", 1)[1] for c in (recs[0] if recs else {}) if c.startswith("clearance_mm:")]
    named = [TradeoffCandidate(r["name"], level_set_name({p: r[f"clearance_mm:{p}"] for p in pairs}),
                               bool(r.get("dominated"))) for r in recs]
    return Tradeoff(len(recs), sum(1 for r in named if r.dominated), None if rec is None else rec["name"], named,
                    (_recommended(summary).get("check") or {}).get("statement", ""))


# ----------------------------------------------------------------------------------------------------- the whole


def design_answers(summary: dict, machine,
                   reference: WhyEfficiency | PublishedReference | dict | str | None = "published",
                   damage_limit_pct: float = DAMAGE_LIMIT_PCT,
                   unripe_limit_pct: float = UNRIPE_LIMIT_PCT) -> DesignAnswers:
    """The answers an engineer brings to the study of their machine, each number with its interval and source.

    Parameters
    ----------
    summary : dict
        The study's summary.json (its ``results``, ``optimum`` and ``tradeoff``), or the results dict alone.
    machine : Machine
        The machine description the study ran on.
    reference : WhyEfficiency or PublishedReference or dict or "published" or None
        What this machine's efficiency is compared with (:func:`compare_efficiency`): :func:`why_efficiency` of
        another machine's study (the record, or its JSON form), "published" (default) for
        :func:`published_reference` on a machine whose pairs are not the reference study's (:func:`claims_apply`;
        on the reference machine itself nothing is compared), or None.
    damage_limit_pct, unripe_limit_pct : float
        Limits of the operating-point rule, in % of the picked mass and of the unripe mass [assumed].

    Returns
    -------
    DesignAnswers
        ``machine``, ``drive``, ``pairs``, ``claims_apply``, ``recommended`` (code, ``name``: the clearances'
        name, statement), ``joints`` (per pair: clearance, design_force, fit, fit_clearance, service_interval,
        fit_design_force), ``loads`` (drive torque), ``harvest`` (indexes at the recommended set), ``operating_point``
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
    if isinstance(reference, str) and reference == "published":
        reference = None if claims_apply(machine) or why is None else published_reference()
    elif isinstance(reference, dict):  # the JSON form of either
        reference = (PublishedReference if "machine" in reference else WhyEfficiency).from_json(reference)
    comparison = None
    if isinstance(reference, (WhyEfficiency, PublishedReference)) and why is not None:
        comparison = compare_efficiency(why, reference, machine.machine.name, reference.machine if isinstance(
            reference, PublishedReference) else "the reference")
    return DesignAnswers(
        machine=machine.machine.name, drive=machine.DRIVE, pairs=list(machine.pair_names),
        claims_apply=claims_apply(machine),
        recommended=None if not cl else Recommended(
            rec.get("code") or opt.get("code"), level_set_name(cl), rec.get("statement") or opt.get("statement") or "",
            rec.get("starts") or opt.get("starts"), rec.get("l9_run")),
        joints=_joint_answers(summary, machine), loads=_machine_loads(summary), harvest=_harvest(summary),
        operating_point=operating_point(summary, machine, damage_limit_pct, unripe_limit_pct),
        differences=differences(summary), tradeoff=_tradeoff(summary), why_efficiency=why, comparison=comparison,
        missing=missing)


