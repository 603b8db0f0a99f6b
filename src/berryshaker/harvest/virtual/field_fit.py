"""The fit of the picking model to field values (:func:`calibrate_harvest`): the yield per bush, the unripe fraction
and the Weibull damage scale fitted to some of the study's indexes, the others held out, with the standard error
of every fitted parameter from the replicate noise.  Nothing is fitted by default (docs/harvest.md, "Yield").  Part
of the virtual harvest (berryshaker.harvest.virtual).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize

from berryshaker.config import Machine
from berryshaker.harvest.virtual.field_test import HarvestParameters, expected_tally, load_grid
from berryshaker.harvest.virtual.responses import RESPONSES, response_values
from berryshaker.harvest.virtual.stem_force_tables import envelopes_for

STUDY_TARGETS = {"efficiency_kg_min": 3.93, "unripe_rate_pct": 3.1, "damage_rate_pct": 2.8}


def calibrate_harvest(machine: Machine, targets: dict | None = None, fit: tuple[str, ...] = (),
                      envelopes: list[np.ndarray] | None = None,
                      replicates: list[tuple[list[np.ndarray], int]] | None = None) -> dict:
    """Fit the picking model to some of the study's field values at the machine's (chosen) clearances and hold
    the others out.

    Parameters
    ----------
    machine : Machine
        Machine description at the study's chosen clearances (A1B1C1F3 on the reference machine).
    targets : dict, optional
        The study's values (:data:`STUDY_TARGETS`: 3.93 kg/min, 3.1 % unripe, 2.8 % damage [study]).
    fit : tuple of {"efficiency", "unripe", "damage"}
        What is fitted: "efficiency" -> ``yield_per_bush`` (the efficiency is proportional to it, one step),
        "damage" -> ``damage_acceleration`` (Brent's method), "unripe" -> ``unripe_fraction`` (Brent's
        method, when reachable).  Every value not fitted keeps its description value and its index is
        reported as a held-out prediction.  Default: nothing fitted (the description's values come from published
        data, docs/harvest.md), every index held out.  "damage" needs ``damage_model = "stem_acceleration"`` (the
        impact model has no free scale).
    envelopes : list of ndarray, optional
        Stem-force envelopes (:func:`~berryshaker.harvest.virtual.stem_force_tables.envelopes_for`; N,
        dimensionless load ratios) already computed at these clearances: one drive-past per branch class from
        the unperturbed start, with the description's population (``harvest.seed``).
    replicates : list of (envelopes, start number), optional
        Starts of the virtual test run at these clearances (the replicated L9's statistic, docs/harvest.md
        "Replicates"): per start the stem-force envelopes of its perturbed drive-pasts
        (:func:`berryshaker.study.runs.replicate_run`) and its number.  Every index is then the mean over the starts
        of the model's expectation, I = (1/R) sum_k E_k, and the fit is on that mean (the efficiency stays
        proportional to the yield per bush, so its fit is still one step).  Takes precedence over ``envelopes``.

    Returns
    -------
    dict
        ``yield_per_bush_kg``, ``unripe_fraction``, ``damage_acceleration_m_s2`` (fitted or as described),
        ``fitted`` (index -> parameter), ``held_out`` (index -> {"model", "study"}), ``check`` (the indexes
        with the returned values; replicate means with ``replicates``), ``reachable``, ``uncertainty`` (standard
        error of every fitted parameter from the replicate noise, :func:`_calibration_uncertainty`; empty for a
        single run), ``replicates`` (number of replicates averaged; 0 for the single unperturbed drive-past).
    """
    from berryshaker.errors import ConfigError

    targets = targets or STUDY_TARGETS
    unknown = set(fit) - {"efficiency", "unripe", "damage"}
    if unknown:
        raise ConfigError(f"calibrate_harvest: unknown index {sorted(unknown)} in fit; choose from efficiency, "
                          "unripe, damage")
    if "damage" in fit and machine.harvest.damage_model != "stem_acceleration":
        raise ConfigError("calibrate_harvest: damage can only be fitted with harvest.damage_model = "
                          "\"stem_acceleration\" (its scale damage_acceleration); the impact model's bruise "
                          "thresholds come from drop tests")
    if replicates is not None:
        if not replicates:
            raise ConfigError("calibrate_harvest: replicates is empty; give at least one (envelopes, seed) pair")
        runs = [([np.asarray(e) for e in env_k], int(seed_k)) for env_k, seed_k in replicates]
    else:
        runs = [(envelopes if envelopes is not None else envelopes_for(machine, None), None)]

    grids = [load_grid(machine, env_k) for env_k, _ in runs]
    described = HarvestParameters.described(machine)

    def idx(yb=None, uf=None, ad=None, per_replicate=False):
        """The expectation's indexes averaged over the starts (one run: that run's); with ``per_replicate`` also
        each start's."""
        from dataclasses import replace

        m = machine if ad is None else machine.model_copy(
            update={"harvest": machine.harvest.model_copy(update={"damage_acceleration": ad})})
        p = replace(described, **{k: v for k, v in (("yield_per_bush", yb), ("unripe_fraction", uf)) if v is not None})
        each = [{RESPONSES[n].column: v for n, v in response_values(expected_tally(m, g, p)).items()} for g in grids]
        mean = {k: float(np.nanmean([e[k] for e in each])) for k in each[0]}
        return (mean, each) if per_replicate else mean

    yb, uf, ad = machine.harvest.yield_per_bush, machine.harvest.unripe_fraction, machine.harvest.damage_acceleration
    if idx(yb=yb, uf=uf)["efficiency_kg_min"] <= 0:
        raise ConfigError("no fruit comes off in the virtual harvest (every peak stem force is below its bond): "
                          "the picking indexes cannot be calibrated")
    reachable = {"unripe_rate_pct": idx(yb=yb, uf=0.95)["unripe_rate_pct"] > targets["unripe_rate_pct"]}
    for _ in range(4):  # the unripe fraction moves the efficiency and the yield nothing else: a few sweeps
        if "unripe" in fit and reachable["unripe_rate_pct"]:
            uf = optimize.brentq(lambda u: idx(yb=yb, uf=u)["unripe_rate_pct"] - targets["unripe_rate_pct"],
                                 1e-3, 0.95, xtol=1e-6)
        if "efficiency" in fit:
            yb = yb * targets["efficiency_kg_min"] / idx(yb=yb, uf=uf)["efficiency_kg_min"]
        if "damage" in fit:
            ad = optimize.brentq(lambda a: idx(yb=yb, uf=uf, ad=a)["damage_rate_pct"] - targets["damage_rate_pct"],
                                 1.0, 1e5, xtol=1e-3)
    check, each = idx(yb=yb, uf=uf, ad=ad, per_replicate=True)
    names = {"efficiency": ("efficiency_kg_min", "yield_per_bush"), "unripe": ("unripe_rate_pct", "unripe_fraction"),
             "damage": ("damage_rate_pct", "damage_acceleration")}
    fitted = {names[k][0]: names[k][1] for k in fit if k != "unripe" or reachable["unripe_rate_pct"]}
    held_out = {key: {"model": check[key], "study": targets[key]} for key in targets if key not in fitted}
    unc = _calibration_uncertainty(idx, each, fitted, yb, uf, ad) if len(runs) > 1 else {}
    return {"yield_per_bush_kg": yb, "unripe_fraction": uf, "damage_acceleration_m_s2": ad, "check": check,
            "fitted": fitted, "held_out": held_out, "reachable": reachable, "uncertainty": unc,
            "replicates": len(runs) if replicates is not None else 0}


def _calibration_uncertainty(idx, each: list[dict], fitted: dict, yb: float, uf: float, ad: float) -> dict:
    """Standard error of every fitted parameter from the replicate noise of the mean it was fitted to.

    The fit solves mean_k I_k(theta) = target; the replicate mean has standard error SE(I) = sd_k(I_k) / sqrt(R),
    so, to first order (delta method), SE(theta) = SE(I) / |d mean I / d theta|.  The efficiency is proportional to
    the yield per bush, so SE(yield) / yield = SE(efficiency) / efficiency exactly; the damage rate's slope in the
    Weibull scale and the unripe rate's in the unripe fraction are central differences of +-1 %.
    """
    R = len(each)

    def se(key):
        v = np.array([e[key] for e in each], float)
        v = v[np.isfinite(v)]
        return float(np.std(v, ddof=1) / math.sqrt(v.size)) if v.size > 1 else float("nan")

    out = {}
    if "efficiency_kg_min" in fitted:
        m = float(np.mean([e["efficiency_kg_min"] for e in each]))
        out["yield_per_bush_kg"] = yb * se("efficiency_kg_min") / m if m > 0 else float("nan")
    if "damage_rate_pct" in fitted:
        slope = (idx(yb=yb, uf=uf, ad=ad * 1.01)["damage_rate_pct"] - idx(yb=yb, uf=uf, ad=ad / 1.01)["damage_rate_pct"]
                 ) / (ad * (1.01 - 1 / 1.01))
        out["damage_acceleration_m_s2"] = se("damage_rate_pct") / abs(slope) if slope else float("nan")
    if "unripe_rate_pct" in fitted:
        slope = (idx(yb=yb, uf=uf * 1.01)["unripe_rate_pct"] - idx(yb=yb, uf=uf / 1.01)["unripe_rate_pct"]
                 ) / (uf * (1.01 - 1 / 1.01))
        out["unripe_fraction"] = se("unripe_rate_pct") / abs(slope) if slope else float("nan")
    out["method"] = (f"delta method on the replicate mean of {R} starts: SE(parameter) = SE(fitted index) / |slope of "
                     "the mean index in the parameter|")
    return out
