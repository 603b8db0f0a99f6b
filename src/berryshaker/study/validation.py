"""The harvest model against the published record (``berryshaker validate``, docs/harvest.md "Validation").

Every published number of ``berryshaker.harvest.published`` that the model can represent is set up as a case: a
machine (the description given, at a named operating point or catching surface), the replicate harvest of its
perturbed starts (``harvest.replicates`` starts, the virtual L9's seeds and runs, through the cached runner), and
the model's value with an interval.  Machine results (efficiency, unripe rate, damage of one field test) are
compared with a 95 % **prediction interval for one field result**, mean +- t(0.975, R - 1) SD sqrt(1 + 1/R) over
the R starts: a published test is one draw of the start-to-start noise, not the model's mean.  Model inputs taken
from a publication (the bond strengths) are listed with the lognormal's central 90 % and the verdict "input": they
were used to set the model up and check nothing.  Numbers the model cannot represent (another crop, branch or leaf
damage, a machine whose operating point is not published) are listed with the reason.

The efficiency is proportional to the yield per bush, and the published yield is known only to a range (2-10 lb
per highbush bush per season about a typical 5 lb, :data:`YIELD_RANGE_ID`): an efficiency's interval is its
prediction interval scaled by that range (low end x low / typical, high end x high / typical), the noise-only
interval is given beside it (``noise_lo``, ``noise_hi``).  The indexes that are shares of the picked mass (unripe
rate, damage) do not depend on the yield.

Verdicts, on held-out numbers only, and only where they can fail: "consistent" when the published value lies inside
the interval, otherwise "not reproduced" with the ratio model / published.  A published value inside an interval
whose ends differ by more than a factor of :data:`NO_VERDICT_SPAN` (an efficiency, whose yield per bush is known
only to a factor of five) decides nothing: the row reads "no verdict" and says at which yield per bush the model
would give the published value.  A published
number whose machine or operating point this description does not represent (another shaker, an unpublished
amplitude or finger geometry) is listed as "not comparable" with the reason, and no run is made for it.

Pack-out (the packed share of the harvested fruit) is read from a start's field result as 100 - unripe rate - damage
rate: the model culls only unripe and bruised fruit (no soft, split or stemmed fruit, no debris), so its pack-out is
an upper bound of a field pack-out and the published value is consistent when it does not exceed the interval's top.
A published "no difference" between two settings is compared with the paired difference over the starts: consistent
when the model's difference lies within what one field test at each setting could resolve, +- t(0.975, R - 1)
sqrt(2) SD, SD the field results' spread at the first setting.

Nothing in the reference description is fitted to any of these numbers (docs/harvest.md "Yield"), so every number but
the model inputs is held out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from berryshaker.config import Machine, machine_from_dict

#: the published yield whose range widens an efficiency's interval
YIELD_RANGE_ID = "yield.highbush.bush_season.extension2013"

#: the record's response names that are not a harvest response's own name
RECORD_NAMES = {"removal": "ripe_removal"}

#: an interval whose ends differ by more than this factor is no verdict (dimensionless)
NO_VERDICT_SPAN = 10.0


@dataclass(frozen=True)
class Case:
    """One operating point of the model compared with published numbers.

    ``changes``: dotted description keys -> SI values applied to the description; ``post``: keys changed after the
    runs (they do not change the coupled runs: bruising, catcher); ``numbers``: record id -> response name of
    the harvest responses (berryshaker.harvest.virtual.RESPONSES; "removal" is ripe_removal) (and a factor from the published unit's meaning to the response, e.g. 100 - x);
    ``reason``: why the case cannot be set up or compared (then nothing runs); ``versus``: ``harvest`` keys of a
    second setting on the same runs, for a published difference between two settings.

    Attributes
    ----------
    name : str
        The case as the report names it.
    numbers : dict of str to (str, str)
        Record id -> (response name or "packout", how the published value reads: "value", "100 - value",
        "upper bound" (the model's value bounds the published one from above) or "difference" (``post`` minus
        ``versus``)).
    changes : dict of str to float
        Description changes before the runs (SI; e.g. ``drive_speed`` in rad/s).
    post : dict of str to object
        ``harvest`` keys changed after the runs (bruising, catcher).
    reason : str
        Why the case cannot be set up or compared (empty when it can).
    note : str
        How the case represents the published machine.
    versus : dict of str to object
        ``harvest`` keys of the second setting of a published difference (empty otherwise).
    """

    name: str
    numbers: dict[str, tuple[str, str]]
    changes: dict[str, float] = field(default_factory=dict)
    post: dict[str, object] = field(default_factory=dict)
    reason: str = ""
    note: str = ""
    versus: dict[str, object] = field(default_factory=dict)


def cases(machine: Machine) -> list[Case]:
    """The validation cases of the published record for this machine description (module docstring).  The
    reference study's field result is a case only for a groove-cam machine (the study's drive).

    Parameters
    ----------
    machine : Machine
        The machine description (its drive decides whether the reference study's case applies).

    Returns
    -------
    list of Case
        The reference study's case (groove cam only), soft and hard catch surfaces (pack-out), conventional
        harvesters on a hard surface, and the published machines this description does not represent (not
        comparable: the reason).
    """
    own = [] if getattr(machine, "DRIVE", "") != "groove_cam" else [
        Case("reference study at its chosen clearances (A1B1C1F3), 120 r/min, 30 m/min",
             {"machine.lyu2024.optimum.efficiency": ("efficiency", "value"),
              "machine.lyu2024.optimum.unripe": ("unripe", "value"),
              "machine.lyu2024.optimum.damage": ("damage", "value")},
             note="the description's clearances and operating point (the study's machine for the reference "
                  "description)")]
    return own + [
        Case("soft and hard catch surfaces under this machine (modified over-the-row harvesters, 2017)",
             {"machine.modified_otr.devetter2019.packout_duke": ("packout", "upper bound"),
              "machine.modified_otr.devetter2019.packout_draper": ("packout", "upper bound"),
              "machine.modified_otr.devetter2019.soft_vs_hard": ("packout", "difference")},
             post={"catcher_surface": "padded"}, versus={"catcher_surface": "hard"},
             note="this description's comb and plant onto a padded, then a hard catching surface (the same starts); "
                  "pack-out read as 100 - unripe rate - damage rate of the picked mass, an upper bound (the model "
                  "culls only unripe and bruised fruit)"),
        Case("conventional over-the-row harvesters on a hard catching surface (1992, 'Bluecrop')",
             {"bruise.sound_share.conventional_machine.brown1996": ("damage", "100 - value")},
             post={"catcher_surface": "hard"},
             note="this description with a hard catching surface; the published share damage-free or slightly "
                  "bruised, 22 %, read as 78 % bruised"),
        Case("GYL062 towed vibratory picker, 'Bluecrop'",
             {"machine.gyl062.hunau2014.efficiency": ("efficiency", "value"),
              "machine.gyl062.hunau2014.green_drop": ("unripe", "value"),
              "machine.gyl062.hunau2014.fruit_damage": ("damage", "value")},
             reason="not comparable: the GYL062's shaking amplitude and finger geometry are not published, so this "
                    "comb driven at its speed says nothing about it"),
        Case("Chen et al. small vibrating picker",
             {"machine.chen.picking_rate": ("removal", "value"), "machine.chen.green_shedding": ("unripe_shed", "value")},
             reason="not comparable: its shaking frequency, amplitude and finger geometry are not in the abstract "
                    "that was read"),
        Case("hand-held shakers over soft catch surfaces",
             {"machine.handheld.takeda2017.packable_max": ("packout", "value"),
              "machine.handheld_otr.sargent2020.packout_meadowlark": ("packout", "value"),
              "machine.handheld_otr.sargent2020.packout_farthing": ("packout", "value"),
              "shake.immature_fraction.malladi2013.shb_max": ("unripe", "value")},
             reason="not comparable: a hand-held shaker on single branches (its frequency, amplitude and contact are "
                    "not published) is not a comb machine"),
    ]


def _with_drive_speed(data: dict, speed: float) -> dict:
    from berryshaker.harvest.virtual import with_drive_speed

    return with_drive_speed(data, speed)


def _prediction(values: np.ndarray, confidence: float = 0.95) -> dict:
    v = values[np.isfinite(values)]
    n = v.size
    mean = float(np.mean(v)) if n else float("nan")
    sd = float(np.std(v, ddof=1)) if n > 1 else float("nan")
    half = float(stats.t.ppf(0.5 + confidence / 2, n - 1) * sd * math.sqrt(1 + 1 / n)) if n > 1 else float("nan")
    return {"mean": mean, "sd": sd, "n": int(n), "lo": max(0.0, mean - half), "hi": mean + half}


def _with_harvest(machine: Machine, changes: dict) -> Machine:
    """``machine`` with ``harvest`` keys changed after the runs (bruising, catcher); itself when none."""
    if not changes:
        return machine
    d = machine.model_dump()
    d["harvest"].update(changes)
    return machine_from_dict(d)


def _values(field_results: list[dict], key: str) -> np.ndarray:
    """One value per start: a harvest response, or the pack-out 100 - unripe - damage (%; module docstring)."""
    if key == "packout":
        return np.array([100.0 - e["unripe"] - e["damage"] for e in field_results], float)
    return np.array([e[key] for e in field_results], float)


def _difference_row(row, published: float, case: Case, first: np.ndarray, second: np.ndarray) -> dict:
    """A published difference between the case's two settings against the model's paired difference over the
    starts, with the resolution of one field test at each setting (module docstring)."""
    d = first - second
    n = int(np.isfinite(d).sum())
    mean = float(np.nanmean(d))
    sd_field = float(np.nanstd(first, ddof=1))
    half = float(stats.t.ppf(0.975, n - 1) * math.sqrt(2.0) * sd_field)
    lo, hi = mean - half, mean + half
    verdict = "consistent" if lo <= published <= hi else f"not reproduced (model difference {mean:+.3g} points)"
    how = (f"{case.note}; paired over {n} starts: {', '.join(f'{k} = {v}' for k, v in case.post.items())} minus "
           f"{', '.join(f'{k} = {v}' for k, v in case.versus.items())}, +- what one field test at each setting "
           f"resolves (t sqrt 2 x the field SD {sd_field:.3g} points)")
    return _row(row, published, mean, lo, hi, "%", verdict, True, how, case.name)


def _published(row, how: str) -> float:
    v = float(row["value"])
    return 100.0 - v if how == "100 - value" else v


def bond_rows(machine: Machine, record) -> list[dict]:
    """The bond strengths taken from the record: the model's lognormal (mean, central 90 %) beside the published
    value; verdict "input" (used to set the model up, not held out).

    Parameters
    ----------
    machine : Machine
        Machine description with a [harvest] block (ripe pull and shear strengths, ``bond_cv``, ``bond_model``).
    record : pandas.DataFrame
        The published record, indexed by id.

    Returns
    -------
    list of dict
        One validation row per bond strength in the record (none unless ``bond_model = "pull_shear"``): the
        published and model values and the interval (N).
    """
    h = machine.harvest
    s = math.sqrt(math.log1p(h.bond_cv**2))
    q05, q95 = (math.exp(-0.5 * s * s + z * s) for z in (-1.6448536269514722, 1.6448536269514722))
    out = []
    for rid, mean in (("bond.ripe.tensile.kong2014.blue5d", h.ripe_pull), ("bond.ripe.shear.kong2014.blue5d",
                                                                            h.ripe_shear)):
        if rid not in record.index or h.bond_model != "pull_shear":
            continue
        row = record.loc[rid]
        out.append(_row(row, float(row["value"]), mean, mean * q05, mean * q95, "N", "input", False,
                        "model input: the mean strength of the ripe fruit; interval: the lognormal's central 90 % "
                        f"(CV {h.bond_cv:g}, from Kong's ripening range)", "bond strength"))
    return out


def _row(row, published: float, model, lo, hi, unit: str, verdict: str, held_out: bool, how: str, case: str,
         noise: tuple | None = None) -> dict:
    return {"id": str(row["id"]), "quantity": str(row["quantity"]), "case": case, "source": str(row["citation"]),
            "source_key": str(row["source"]),
            "published": published, "unit": unit, "model": model, "lo": lo, "hi": hi,
            "noise_lo": noise[0] if noise else lo, "noise_hi": noise[1] if noise else hi, "verdict": verdict,
            "held_out": held_out, "how": how, "confidence": str(row["confidence"])}


def yield_factors(record) -> tuple[float, float]:
    """(low / typical, high / typical) of the published yield per bush (:data:`YIELD_RANGE_ID`); (1, 1) if the record
    has no such entry.

    Parameters
    ----------
    record : pandas.DataFrame
        The published record, indexed by id.

    Returns
    -------
    (float, float)
        range_low / value and range_high / value of the entry (dimensionless).
    """
    if YIELD_RANGE_ID not in record.index:
        return 1.0, 1.0
    r = record.loc[YIELD_RANGE_ID]
    return float(r["range_low"]) / float(r["value"]), float(r["range_high"]) / float(r["value"])


def case_jobs(machine: Machine, replicates: int | None = None, data: dict | None = None
              ) -> list[tuple[Case, Machine | None, list[dict], list[int]]]:
    """Per case of :func:`cases`: the case, its machine (None if it cannot be set up), the jobs of
    :func:`berryshaker.study.runs.replicate_run` (:func:`berryshaker.study.l9.replicate_jobs`: its starts at its
    clearances; the reference case's are the calibration's and the L9's, shared through the runner's cache) and the
    start seeds.

    Parameters
    ----------
    machine : Machine
        The machine description.
    replicates : int, optional
        Starts per case (default ``harvest.replicates``).
    data : dict, optional
        The machine as JSON when the caller has it, so identical runs share the cache.

    Returns
    -------
    list of (Case, Machine or None, list of dict, list of int)
        Per case: the case, its machine (``changes`` applied; None when it has a ``reason``), its run jobs
        (empty when it cannot be set up) and the start seeds.
    """
    from berryshaker.study.l9 import replicate_jobs

    data = machine.model_dump(mode="json") if data is None else data
    from berryshaker.harvest.virtual import replicate_starts

    seeds = replicate_starts(machine, replicates)
    out = []
    for case in cases(machine):
        if case.reason:
            out.append((case, None, [], seeds))
            continue
        d = _with_drive_speed(data, case.changes["drive_speed"]) if "drive_speed" in case.changes else data
        m = machine_from_dict(d)
        out.append((case, m, replicate_jobs(m, m.clearance_sizes(), seeds, data=d), seeds))
    return out


def validate(machine: Machine, runner, replicates: int | None = None, record=None, data: dict | None = None,
             collect=None) -> dict:
    """The model against every published number it can represent (module docstring).

    Parameters
    ----------
    machine : Machine
        Machine description (its configured clearances and operating point are the reference case).
    runner : berryshaker.runs.runner.SweepRunner
        Runner of the coupled replicate runs (cached, resumable).
    replicates : int, optional
        Starts per case, default ``harvest.replicates``.
    record : pandas.DataFrame, optional
        The published record (:func:`berryshaker.harvest.published_record.load_record`), default the packaged one.
    data : dict, optional
        The machine as JSON when the caller has it (the study's), so identical runs share the cache.
    collect : callable, optional
        ``collect(fn, jobs, label)`` -> outputs (None for a failed run): how the runs are made (the study's
        ``StudyContext.collect``); default ``runner.values``.

    Returns
    -------
    dict
        ``rows``: one per published number (id, quantity, case, source (the citation), source_key (its key in the
        record), published, unit, model, lo, hi (the
        interval the verdict uses), noise_lo, noise_hi (start-to-start noise only), verdict, held_out, how,
        confidence); ``replicates``; ``summary`` (held-out rows, and the counts of each verdict: consistent,
        not reproduced, no verdict, not comparable; model inputs).
    """
    from berryshaker.harvest.published_record import load_record
    from berryshaker.harvest.virtual import RESPONSES, start_responses
    from berryshaker.study.l9 import replicate_envelopes
    from berryshaker.study.runs import replicate_run

    record = load_record() if record is None else record
    collect = collect or (lambda fn, jobs, label: runner.values(fn, jobs, label))
    rows = bond_rows(machine, record)
    ylo, yhi = yield_factors(record)
    planned = case_jobs(machine, replicates, data)
    for case, m, jobs, seeds in planned:
        present = {rid: v for rid, v in case.numbers.items() if rid in record.index}
        if m is None:
            for rid, (resp, how) in present.items():
                row = record.loc[rid]
                rows.append(_row(row, _published(row, how), None, None, None, str(row["unit"]), "not comparable",
                                 True, case.reason, case.name))
            continue
        outs = collect(replicate_run, jobs, f"validation: {case.name}")
        reps = replicate_envelopes(m, outs, seeds)
        if len(reps) < 2:
            continue
        each = [start_responses(_with_harvest(m, case.post), env, k)["field"] for env, k in reps]
        other = ([start_responses(_with_harvest(m, case.versus), env, k)["field"] for env, k in reps]
                 if case.versus else None)
        for rid, (resp, how) in present.items():
            row = record.loc[rid]
            pub = _published(row, how)
            if how == "difference":
                assert other is not None
                rows.append(_difference_row(row, pub, case, _values(each, resp), _values(other, resp)))
                continue
            key = RECORD_NAMES.get(resp, resp)
            unit = "%" if key == "packout" else RESPONSES[key].unit
            p = _prediction(_values(each, key))
            if unit == "%":  # a share: the interval stays inside 0..100 %
                p["hi"] = min(p["hi"], 100.0)
            lo, hi, text = p["lo"], p["hi"], ""
            if resp == "efficiency":
                lo, hi = p["lo"] * ylo, p["hi"] * yhi
                text = f", widened by the published yield's range (x{ylo:.2g} .. x{yhi:.2g})"
            if how == "upper bound":
                inside = pub <= hi
                text += "; the model's value bounds the published one from above"
            else:
                inside = lo <= pub <= hi
            if inside and lo > 0 and hi / lo > NO_VERDICT_SPAN:  # a "consistent" that could not have failed
                y = m.harvest.yield_per_bush * pub / p["mean"] if resp == "efficiency" and p["mean"] > 0 else None
                verdict = (f"no verdict (the interval spans more than x{NO_VERDICT_SPAN:g}"
                           + (f"; the model gives the published value at {y:.2g} kg of fruit per bush, described "
                              f"{m.harvest.yield_per_bush:.2g} kg)" if y is not None else ")"))
            elif inside:
                verdict = "consistent"
            else:
                verdict = f"not reproduced (model / published = {p['mean'] / pub:.2g})"
            rows.append(_row(row, pub, p["mean"], lo, hi, unit, verdict, True,
                             f"{case.note}; 95 % prediction interval of one field result over {p['n']} starts "
                             f"(SD {p['sd']:.3g} {unit}){text}", case.name, (p["lo"], p["hi"])))
    held = [r for r in rows if r["held_out"]]
    summary = {"held_out": len(held), "consistent": sum(r["verdict"] == "consistent" for r in held),
               "not_reproduced": sum(r["verdict"].startswith("not reproduced") for r in held),
               "no_verdict": sum(r["verdict"].startswith("no verdict") for r in held),
               "not_comparable": sum(r["verdict"] == "not comparable" for r in held),
               "inputs": sum(r["verdict"] == "input" for r in rows)}
    return {"rows": rows, "replicates": len(planned[0][3]) if planned else 0, "summary": summary}
