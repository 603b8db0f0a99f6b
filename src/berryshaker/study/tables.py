"""The study's tables: CSV files beside the report, and summary.json without the plotted series."""

from __future__ import annotations

from pathlib import Path


def strip_series(res: dict) -> dict:
    """Results without the plotted series (summary.json keeps numbers, figures keep curves).

    Parameters
    ----------
    res : dict
        The study's results; not modified.

    Returns
    -------
    dict
        A shallow copy whose ``fruit_force`` rows (and chosen row) drop their ``distance`` and ``forces`` series.
    """
    out = dict(res)
    ff = dict(out.get("fruit_force") or {})
    if ff:
        if ff.get("chosen"):
            ff["chosen"] = {k: v for k, v in ff["chosen"].items() if k not in ("distance", "forces")}
        ff["rows"] = {r: {k: v for k, v in d.items() if k not in ("distance", "forces")} for r, d in ff["rows"].items()}
        out["fruit_force"] = ff
    return out


def write_tables(machine, res, tables: Path) -> None:
    """The study's tables, each as CSV with an .xlsx beside it (one writer: :func:`berryshaker.report.table_files.write_table`).

    Parameters
    ----------
    machine : MachineBase
        The study's machine (its clearance pair names).
    res : StudyResults
        The study's results (``rows``, a ``ClearanceRows``, and ``agreement``, a ``ModelAgreement``, read by
        attribute: :mod:`berryshaker.study.mechanics_records`).
    tables : Path
        Folder the tables are written to (collision forces and load moments per row, model agreement ...).
    """
    pairs = machine.pair_names
    from berryshaker.report.table_files import write_table

    def write(name, header, rows):
        write_table(tables / name, header, rows)

    models = (("multibody", res.rows.multibody), ("mlsd", res.rows.mlsd)) if res.rows is not None else ()
    rows = []
    for model, runs in models:
        for r, s in runs.items():
            for p in pairs:
                f = s.collision_force_N[p]
                rows.append([model, r, p, s.clearance_mm[p], f.peak, f.mean, f.rms])
    write("collision_force_rows.csv", ["model", "row", "pair", "clearance_mm", "peak_N", "mean_N", "rms_N"], rows)
    rows = []
    for model, runs in models:
        for r, s in runs.items():
            for side in ("left", "right"):
                m = s.load_moment_Nm[side]
                rows.append([model, r, side, m.peak, m.rms])
    write("load_moment_rows.csv", ["model", "row", "comb", "peak_Nm", "rms_Nm"], rows)
    if res.agreement:
        write("model_agreement.csv", ["pair", "f_statistic", "f_critical", "eq18_agree", "statistics_agree", "nrmse",
                                      "correlation", "peak_ratio"],
              [[p, d.f_statistic, d.f_critical, d.eq18_agree, d.agree, d.nrmse, d.correlation, d.peak_ratio]
               for p, d in res.agreement.pairs.items()])
    check = res.rows.model_check if res.rows is not None else None
    if check:
        write("model_check.csv", ["pair", "statistic", "multibody_mean_N", "multibody_se_N", "multibody_starts",
                                  "reduced_mean_N", "reduced_se_N", "reduced_starts", "relative_difference",
                                  "noise_2se", "tolerance", "verdict"],
              [[p, k, c.a[k].mean, c.a[k].se, c.a[k].n, c.b[k].mean, c.b[k].se, c.b[k].n,
                c.relative_difference[k], c.noise[k], c.tolerance[k], c.verdicts[k]]
               for p, c in check.pairs.items() for k in c.tolerance])
    if res.fruit_force is not None and res.fruit_force.chosen is not None:
        pos = res.fruit_force.chosen.summary.positions
        write("fruit_force.csv", ["fruit", "z_m", "peak_N", "study_low_N", "study_high_N", "ripe", "unripe"],
              [[n, d.z_m, d.peak_force_N, *(d.study_range_N or ["", ""]), d.eq17.ripe, d.eq17.unripe]
               for n, d in pos.items()])
    if res.l9 is not None:
        write("l9_runs.csv",
              ["run", *[f"{p}_mm" for p in pairs], "efficiency_kg_min", "unripe_rate_pct", "damage_rate_pct"],
              [[r.run, *[r.clearance_mm[p] for p in pairs], r.efficiency, r.unripe, r.damage] for r in res.l9.runs])
        cols = res.l9.tradeoff_columns
        if res.l9.tradeoff:
            write("l9_tradeoff.csv", cols, [[r.get(c, "") for c in cols] for r in res.l9.tradeoff])
    write("failed_runs.csv", ["step", "run", "inputs", "error"],
          [[f.step, f.run, f.inputs, f.error] for f in res.failures])
    write("claims.csv", ["id", "verdict", "claim", "detail"],
          [[c.id, c.verdict, c.claim, c.detail] for c in res.claims])
