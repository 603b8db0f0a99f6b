"""Calibration of the comb-branch contact damping.

Status (docs/plant.md): with the fruit on compliant stems (berryshaker.plant.pedicel, the default) the
peak stem force hardly depends on the contact damping (the branch is pushed by the fingers' kinematics),
so this calibration no longer identifies cmax and raises when the target is out of reach; it applies to
the study's rigid-fruit model (``plant.fruit.pedicel.rigid = true``), whose eq. 16 force it was built for.
The history below describes that model.

The study's contact parameters (its Table 6) were lost.  The fingers are slender nylon rods whose bending
compliance, not the local Hertz contact of nylon on wood (about 8e7 N/m^1.5), limits the elastic force
on the branch; we fix the effective IMPACT stiffness at 3e4 N/m^1.5 [assumed] (the fruit forces change by
under 10 % between 1e4 and 2e5).  What sets the fruit force is the impulse at first touch, cmax times
the finger speed (the IMPACT damping ramps in over 0.1 mm), so the damping cmax is the one calibrated
parameter.  It is fitted to one published number only: the peak harvesting force of the fruit at the
END of the branch, 0.8-1.2 N [study], target its middle, 1.0 N, on the reference machine at the study's
chosen clearances.  The root and middle forces are then predictions, compared with the study's ranges
in every output.
"""

from __future__ import annotations

import math

from scipy import optimize

from berryshaker.config import Machine, machine_from_dict
from berryshaker.errors import ConfigError
from berryshaker.harvest.coupled import simulate_fruit_force


def calibrate_contact_damping(machine: Machine, target_end_force: float = 1.0, bracket=(2.0, 40.0),
                              rel_tol: float = 0.02) -> tuple[float, dict]:
    """IMPACT damping cmax (N s/m) giving ``target_end_force`` at the end fruit.

    Brent's method on log10(cmax); each evaluation is one coupled drive-past simulation (about 3 s).
    Returns the damping and the summary of the final run.

    Parameters
    ----------
    machine : Machine
        Machine description with a [plant] block; its ``plant.contact.damping`` is replaced in each run.
    target_end_force : float
        Peak force at the end fruit to reach (N).
    bracket : (float, float)
        Lowest and highest contact damping searched (N s/m); the end force minus the target must change sign
        between them.
    rel_tol : float
        Relative tolerance of the damping (dimensionless): Brent's step tolerance is log10(1 + rel_tol).

    Returns
    -------
    damping : float
        The contact damping (N s/m).
    summary : dict
        :meth:`berryshaker.harvest.coupled.FruitForceResult.summary` of the run at that damping.

    Raises
    ------
    ConfigError
        The end fruit's peak force does not cross the target within the bracket.
    """
    cache: dict[float, dict] = {}

    def run(log_k):
        d = machine.model_dump()
        d["plant"]["contact"]["damping"] = 10.0**log_k
        s = simulate_fruit_force(machine_from_dict(d)).summary()
        cache[log_k] = s
        return s["positions"]["end"]["peak_force_N"] - target_end_force

    lo, hi = (math.log10(b) for b in bracket)
    f_lo, f_hi = run(lo), run(hi)
    if f_lo * f_hi > 0:
        raise ConfigError(
            f"the end fruit's peak force stays {'above' if f_lo > 0 else 'below'} {target_end_force} N for contact "
            f"damping {bracket[0]}-{bracket[1]} N s/m ({f_lo + target_end_force:.3g} and {f_hi + target_end_force:.3g} N): "
            "with the stem model the force is set by the comb's kinematics, not by the contact damping "
            "(docs/plant.md, calibration)")
    log_k = optimize.brentq(run, lo, hi, rtol=1e-3, xtol=math.log10(1 + rel_tol))
    if log_k not in cache:
        run(log_k)
    return 10.0**log_k, cache[log_k]



def calibration_table(machine: Machine, fruit_summary: dict | None = None, harvest_fit: dict | None = None) -> dict:
    """Every plant and picking parameter with its value, provenance tag and target or source, and the held-out
    comparisons with the study (docs/plant.md, "Calibration").

    Parameters
    ----------
    machine : Machine
        The machine description (values as described).
    fruit_summary : dict, optional
        :meth:`berryshaker.harvest.coupled.FruitForceResult.summary` at the chosen clearances: the stem forces
        at root, middle and end, compared with the study's ranges (held out: nothing is fitted to them).
    harvest_fit : dict, optional
        :func:`berryshaker.harvest.virtual.calibrate_harvest` at the chosen clearances: the refitted values
        (they should equal the described ones) and the held-out indexes.

    Returns
    -------
    dict
        ``parameters``: rows (parameter, value, unit, tag, target or source); ``held_out``: rows (quantity,
        model, study, and for a published range whether the model is inside it; None for a single value).
    """
    from berryshaker.harvest.coupled import STUDY_FRUIT_FORCE_N
    from berryshaker.harvest.virtual import STUDY_TARGETS
    from berryshaker.plant.response import RIPE_BOND_N, UNRIPE_BOND_N

    pl, h = machine.plant, machine.harvest
    b, f, ped, ct, bush = pl.branch, pl.fruit, pl.fruit.pedicel, pl.contact, pl.bush
    fit = harvest_fit or {}

    over = f", replicate mean of {fit['replicates']} replicates, perturbed starts" if fit.get("replicates") else ""

    def refit(key):
        if key not in fit:
            return ""
        se = (fit.get("uncertainty") or {}).get(key)
        return f" (refit here{over}: {fit[key]:.4g}" + (f" +- {se:.2g} SE" if se is not None else "") + ")"

    rows = [
        ("branch E", b.elastic_modulus / 1e9, "GPa", "[assumed, cited range]",
         "goji 0.29-0.83 GPa (docs/study.md sec. 7)"),
        ("branch density", b.density, "kg/m^3", "[assumed, cited range]", "0.8-0.93 t/m^3 (docs/study.md sec. 7)"),
        ("branch damping ratio", b.damping_ratio, "1", "[assumed, cited]", "blackcurrant 7.1 % (docs/study.md sec. 7)"),
        ("branch d0 / dm / l", f"{b.root_diameter * 1e3:g} / {b.tip_diameter * 1e3:g} / {b.length:g}", "mm, mm, m",
         "[assumed]", "reference sheet (docs/study.md sec. 6)"),
        ("fruit mass m0", f.mass * 1e3, "g", "[assumed, cited range]", "blueberry 0.5-2.5 g (docs/study.md sec. 7)"),
        ("pedicel k / c", f"{ped.stiffness:g} / {ped.damping:g}", "N/m, N s/m", "[assumed]",
         "coffee fruit-stem analogue (docs/plant.md)"),
        ("finger d / L / E", f"{ct.finger.diameter * 1e3:g} / {ct.finger.free_length * 1e3:g} / "
         f"{ct.finger.elastic_modulus / 1e9:g}", "mm, mm, GPa", "[assumed]", "PA6 data-sheet range (docs/plant.md)"),
        ("contact cmax", ct.damping, "N s/m", "[assumed]", "not identifiable with stems (docs/plant.md)"),
        ("bush branches / members / modes", f"{bush.branches} / {bush.members} / {bush.n_modes}", "1",
         "[assumed] / [convergence]", "tests/plant/test_bush.py"),
        ("bush d0, l, lean ranges", f"{bush.root_diameter[0] * 1e3:g}-{bush.root_diameter[1] * 1e3:g} mm, "
         f"{bush.length[0]:g}-{bush.length[1]:g} m, {math.degrees(bush.lean[0]):g}-{math.degrees(bush.lean[1]):g} deg",
         "", "[assumed]", "bush 1.5-1.7 m tall [study]"),
    ]
    if h.bond_model == "pull_shear":
        from berryshaker.harvest.ripeness import stage_pulls

        pulls = stage_pulls(h.ripe_pull, h.unripe_pull, h.pink_pull, h.red_pull)
        rows += [
            ("ripe pull / shear strength", f"{h.ripe_pull:g} / {h.ripe_shear:g}", "N", "[published]",
             "Kong et al. 2014 (docs/harvest.md, Bond)"),
            ("unripe (green) pull / shear strength", f"{h.unripe_pull:g} / {h.unripe_shear:g}", "N",
             "[study] / [assumed]", "eq. 17's 1.0-3.6 N as a lognormal's central 90 %; the ripe shear/pull ratio"),
            ("pink / red pull strength", f"{float(pulls[1]):.3g} / {float(pulls[2]):.3g}", "N",
             "[assumed]" if h.pink_pull is None and h.red_pull is None else "[described]",
             "geometric interpolation between green and blue in the stage index (docs/harvest.md, Ripeness "
             "stages)"),
            ("strength CV ripe / unripe (lognormal)", f"{h.bond_cv:g} / {h.unripe_bond_cv:g}", "1",
             "[published] / [study]", "Kong et al. 2014 shear 0.22-0.48 N over ripening / eq. 17's band, each as "
             "a central 90 %"),
        ]
    else:
        rows.append(("ripe / unripe bond", f"{RIPE_BOND_N[0]:g}-{RIPE_BOND_N[1]:g} / "
                     f"{UNRIPE_BOND_N[0]:g}-{UNRIPE_BOND_N[1]:g}", "N", "[study]", "eq. 17"))
    yield_tag = "[calibrated]" if "efficiency_kg_min" in fit.get("fitted", {}) else "[published]"
    rows.append(("yield per bush", h.yield_per_bush, "kg", yield_tag,
                 (f"efficiency {STUDY_TARGETS['efficiency_kg_min']} kg/min at the chosen clearances [study]"
                  if yield_tag == "[calibrated]" else "2.3 kg per highbush bush per season over 3 passes "
                  "(docs/harvest.md, Yield)") + refit("yield_per_bush_kg")))
    if h.damage_model == "impact":
        from berryshaker.harvest.bruising import bruise_medians

        hard50, pad50 = bruise_medians(h)
        rows += [
            ("bruising: extensive above (hard) / safe up to (padded)",
             f"{h.extensive_drop_height_hard:g} / {h.safe_drop_height_padded:g}", "m",
             "[published]", "Brown et al. 1996 drop tests (docs/harvest.md, Bruising)"),
            ("bruising: P(bruise) at those heights; median hard / padded",
             f"{h.extensive_fractile:g} / {h.safe_fractile:g}; {hard50:.3g} / {pad50:.3g} m", "", "[assumed]",
             "lognormal thresholds (docs/harvest.md, Bruising)"),
            ("fruit struck by a finger", h.strike_probability, "1", "[assumed]",
             "at a phase of the swing uniform over the cycle (docs/harvest.md, Bruising)"),
            ("bruising threshold CV, catcher", f"{h.bruise_cv:g}, {h.catcher_surface} at "
             f"{h.catcher_drop:g} m below the branch root", "", "[assumed]", "docs/harvest.md"),
        ]
    else:
        rows += [
            ("damage scale a_d", h.damage_acceleration, "m/s^2", "[calibrated]",
             f"damage {STUDY_TARGETS['damage_rate_pct']} % at the chosen clearances [study]"
             + refit("damage_acceleration_m_s2")),
            ("damage shape", h.damage_shape, "1", "[assumed]", "docs/harvest.md"),
        ]
    rows += [
        ("unripe fraction (green + pink + red)", h.unripe_fraction, "1", "[assumed]",
         f"not fitted: the unripe rate ({STUDY_TARGETS['unripe_rate_pct']} % [study]) is held out"),
        ("unripe stage mix green / pink / red", " / ".join(f"{c:g}" for c in h.unripe_stage_mix), "1",
         "[assumed]", "green for weeks, the coloured stages a few days each (docs/harvest.md, Ripeness stages)"),
        ("fruit-mass CV", h.fruit_mass_cv, "1", "[assumed]", "docs/harvest.md"),
    ]
    params = [{"parameter": r[0], "value": r[1], "unit": r[2], "tag": r[3], "target_or_source": r[4]} for r in rows]
    held = []
    for name, (lo, hi) in STUDY_FRUIT_FORCE_N.items():
        pos = (fruit_summary or {}).get("positions", {}).get(name)
        if pos is not None:
            v = pos["peak_force_N"]
            held.append({"quantity": f"{name} fruit peak force (N)", "model": v, "study": f"{lo:g}-{hi:g}",
                         "inside": bool(lo <= v <= hi)})
    for key, cmp_ in fit.get("held_out", {}).items():
        held.append({"quantity": key, "model": cmp_["model"], "study": f"{cmp_['study']:g}", "inside": None})
    for key in fit.get("fitted", {}):
        held.append({"quantity": key + " (fitted, not evidence)", "model": fit["check"][key],
                     "study": f"{STUDY_TARGETS[key]:g}", "inside": None})
    return {"parameters": params, "held_out": held}
