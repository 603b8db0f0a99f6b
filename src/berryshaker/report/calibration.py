"""The report of ``berryshaker calibrate`` (docs/calibration.md): figures in the style of
:mod:`berryshaker.report.style` (units on every axis, nothing cut at the canvas' edge) and a self-contained HTML page
with the prior against the posterior of every parameter, the posterior predictive against the observed run means,
the predictions of every level set with their 90 % intervals, the emulator's held-out error and the method's limits.
Tables go through the project's table writer (:func:`berryshaker.report.table_files.write_table`).

The result is the :class:`~berryshaker.study.field_calibration.result.CalibrationResult` of
:func:`berryshaker.study.field_calibration.calibrate`, read by attribute: this module does not import its classes
(the study layer is above the report layer; duck typing).
"""

from __future__ import annotations

from pathlib import Path

from berryshaker.user_text import html_text

#: unit shown for a parameter without one (a fraction)
NO_UNIT = "-"


def _unit(u: str) -> str:
    return u or NO_UNIT


def plot_parameters(res, path: Path) -> dict:
    """Prior 90 % interval against posterior 90 % interval and mean for every parameter (one panel each), with the
    description's value.

    Parameters
    ----------
    res : CalibrationResult
        The calibration (``parameters``).
    path : Path
        PNG file (an SVG is written beside it).

    Returns
    -------
    dict
        Per parameter the intervals drawn (SI units of the parameter).
    """
    from berryshaker.report.style import finish, label_axes, new_figure

    params = res.parameters
    n = len(params)
    fig, axes = new_figure(n, 1, figsize=(7.0, 0.95 * n + 0.6), squeeze=False)
    drawn = {}
    for ax, (name, p) in zip(axes[:, 0], params.items()):
        pr = p.prior
        ax.plot([pr.lo90, pr.hi90], [1, 1], lw=6, color="#b8c4d6", solid_capstyle="butt", label="prior 90 %")
        ax.plot([p.lo90, p.hi90], [0, 0], lw=6, color="#2b6cb0", solid_capstyle="butt",
                label="posterior 90 %")
        ax.plot([p.posterior_mean], [0], "o", color="#1a365d", label="posterior mean")
        ax.plot([p.described], [0.5], "d", color="#c05621", label="described value")
        ax.set_yticks([0, 1], ["posterior", "prior"])
        ax.set_ylim(-0.6, 1.6)
        ident = "identified" if p.identified else "not identified"
        ax.set_title(f"{name}: {ident} (width ratio {p.width_ratio:.2f})", fontsize=9, loc="left")
        label_axes(ax, f"{name} [{_unit(p.unit)}]")
        drawn[name] = {"prior": [pr.lo90, pr.hi90], "posterior": [p.lo90, p.hi90]}
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, loc="outside upper center", ncols=4)
    finish(fig, path)
    return drawn


def plot_predictive_checks(res, path: Path) -> dict:
    """Observed replicate mean of every sheet run against its 90 % posterior predictive interval, one panel per
    response.

    Parameters
    ----------
    res : CalibrationResult
        The calibration (``checks.posterior_predictive``).
    path : Path
        PNG file.

    Returns
    -------
    dict
        Per response the runs, intervals and observed means drawn (the response's unit).
    """
    from berryshaker.report.style import finish, label_axes, new_figure

    rows = res.checks.posterior_predictive
    responses = list(dict.fromkeys(r.response for r in rows))
    units = {r: res.predictions[0].responses[r].unit for r in responses} if res.predictions else {}
    fig, axes = new_figure(len(responses), 1, figsize=(7.0, 2.2 * len(responses)), squeeze=False)
    drawn = {}
    for ax, resp in zip(axes[:, 0], responses):
        mine = [r for r in rows if r.response == resp]
        x = [r.run for r in mine]
        lo = [r.lo90 for r in mine]
        hi = [r.hi90 for r in mine]
        ax.vlines(x, lo, hi, lw=5, color="#b8c4d6", label="90 % predictive interval")
        ax.plot(x, [r.observed_mean for r in mine], "o", color="#1a365d", label="observed replicate mean")
        ax.set_xticks(x)
        label_axes(ax, "sheet run [-]", f"{resp} [{units.get(resp, '-')}]")
        drawn[resp] = {"runs": x, "lo": lo, "hi": hi, "observed": [r.observed_mean for r in mine]}
    axes[0, 0].legend(fontsize=7, loc="lower right", bbox_to_anchor=(1.0, 1.02), ncols=2)
    finish(fig, path)
    return drawn


def plot_predictions(res, path: Path) -> dict:
    """Predicted mean and 90 % interval of a future field result at every level set, one panel per response; tested
    level sets filled, untested open.

    Parameters
    ----------
    res : CalibrationResult
        The calibration (``predictions``).
    path : Path
        PNG file.

    Returns
    -------
    dict
        Per response the means and intervals drawn (the response's unit).
    """
    from berryshaker.report.style import finish, label_axes, new_figure

    preds = res.predictions
    responses = list(preds[0].responses) if preds else []
    n = len(preds)
    named = n <= 20  # up to 20 level sets are named under the axis; more are numbered as the predictions table's rows
    fig, axes = new_figure(len(responses), 1, figsize=(7.0, 2.4 * len(responses) + (1.2 if named else 0.4)),
                           squeeze=False, sharex=True)
    drawn = {}
    x = list(range(1, n + 1))
    for ax, resp in zip(axes[:, 0], responses):
        m = [p.responses[resp].mean for p in preds]
        lo = [p.responses[resp].lo90 for p in preds]
        hi = [p.responses[resp].hi90 for p in preds]
        ax.vlines(x, lo, hi, lw=2, color="#b8c4d6")
        tested = [i for i, p in enumerate(preds) if p.tested]
        other = [i for i, p in enumerate(preds) if not p.tested]
        ax.plot([x[i] for i in tested], [m[i] for i in tested], "o", color="#1a365d", ms=4, label="tested")
        ax.plot([x[i] for i in other], [m[i] for i in other], "o", mfc="white", color="#1a365d", ms=4,
                label="not tested")
        label_axes(ax, None, f"{resp} [{preds[0].responses[resp].unit}]")
        drawn[resp] = {"mean": m, "lo": lo, "hi": hi}
    ax = axes[-1, 0]
    if named:
        ax.set_xticks(x, [p.level_set for p in preds], rotation=90, fontsize=6)
        label_axes(ax, "level set [-]")
    else:
        label_axes(ax, "level set: row of the predictions table [-]")
    axes[0, 0].legend(fontsize=7, loc="lower right", bbox_to_anchor=(1.0, 1.02), ncols=2)
    finish(fig, path)
    return drawn


def calibration_tables(res) -> dict[str, tuple[list[str], list[list]]]:
    """The calibration's tables: parameters, predictions, posterior predictive checks, emulator error.

    Parameters
    ----------
    res : CalibrationResult
        The calibration.

    Returns
    -------
    dict of str to (list of str, list of list)
        Table name -> (header with units, rows).
    """
    par = [[n, _unit(p.unit), p.prior.text, p.prior.lo90, p.prior.hi90, p.described,
            p.posterior_mean, p.lo90, p.hi90, p.width_ratio, p.identified, p.prior.tag]
           for n, p in res.parameters.items()]
    responses = list(res.predictions[0].responses) if res.predictions else []
    pred_header = ["level set", "tested", "extrapolated"]
    for r in responses:
        u = res.predictions[0].responses[r].unit
        pred_header += [f"{r} mean ({u})", f"{r} lo90 ({u})", f"{r} hi90 ({u})"]
    preds = [[p.level_set, p.tested, p.extrapolated,
              *[v for r in responses for v in (p.responses[r].mean, p.responses[r].lo90,
                                               p.responses[r].hi90)]] for p in res.predictions]
    checks = [[c.run, c.setting, c.response, c.observed_mean, c.lo90, c.hi90, c.inside]
              for c in res.checks.posterior_predictive]
    emu = []
    for where in ("held_out_theta", "held_out_settings"):
        for r, e in (getattr(res.emulator, where) or {}).items():
            emu.append([where, r, e.rmse, e.replicate_sd_rms, e.rmse_over_sd, e.relative_rmse,
                        e.log_sd_rmse, e.points])
    return {
        "parameters": (["parameter", "unit", "prior", "prior lo90", "prior hi90", "described", "posterior mean",
                        "posterior lo90", "posterior hi90", "width ratio (-)", "identified", "prior tag"], par),
        "predictions": (pred_header, preds),
        "posterior_predictive": (["run", "setting", "response", "observed mean", "lo90", "hi90", "inside"], checks),
        "emulator_error": (["check", "response", "RMSE of the mean", "replicate SD (RMS)", "RMSE / SD (-)",
                            "relative RMSE (-)", "RMSE of log SD (-)", "points"], emu),
    }


def write_calibration_outputs(res, folder: Path, title: str) -> list[Path]:
    """Figures, tables (CSV + xlsx) and the HTML page of a calibration into ``folder`` (a staging folder).

    Parameters
    ----------
    res : CalibrationResult
        The calibration.
    folder : Path
        Where to write.
    title : str
        Title of the page.

    Returns
    -------
    list of Path
        The files written.
    """
    from berryshaker.report.table_files import write_table

    folder = Path(folder)
    figs = {"parameters": folder / "prior_posterior.png", "checks": folder / "predictive_checks.png",
            "predictions": folder / "predictions.png"}
    plot_parameters(res, figs["parameters"])
    plot_predictive_checks(res, figs["checks"])
    plot_predictions(res, figs["predictions"])
    written = list(figs.values())
    for name, (header, rows) in calibration_tables(res).items():
        written += list(write_table(folder / f"{name}.csv", header, rows))
    from berryshaker.outputs import write_text_atomic

    write_text_atomic(folder / "report.html", calibration_html(res, title, figs))
    return written + [folder / "report.html"]


def calibration_html(res, title: str, figs: dict[str, Path]) -> str:
    """Self-contained HTML page of a calibration (figures embedded).

    Parameters
    ----------
    res : CalibrationResult
        The calibration.
    title : str
        Title of the page.
    figs : dict of str to Path
        The figures of :func:`write_calibration_outputs` (``parameters``, ``checks``, ``predictions``).

    Returns
    -------
    str
        The HTML document.
    """
    from berryshaker.report.html_blocks import CSS, _img, _table

    e = html_text
    parts = [f"<!doctype html><html lang='en'><head><meta charset='utf-8'><title>{e(title)}</title>"
             f"<style>{CSS}</style></head><body><h1>{e(title)}</h1>"]
    sh = res.sheet
    fac = "; ".join(f"{n} ({d.sets}): {', '.join(f'{v:g}' for v in d.levels)} {d.unit}"
                    for n, d in sh.factors.items())
    version = "" if res.version is None else str(res.version)
    parts.append(f"<p>{sh.runs} runs x {sh.replicates} replicates; responses {e(', '.join(sh.responses))}; "
                 f"factors {e(fac)}.  Simulator: {res.simulator.starts_per_setting} perturbed starts per "
                 f"setting ({res.simulator.coupled_runs} coupled runs made or read from the cache).  "
                 f"Model discrepancy: {e(res.discrepancy_text)}.  berryshaker {e(version)}.</p>")
    parts.append("<h2>What the sheet can tell: prior against posterior</h2>")
    parts.append(f"<p class='small'>{e(res.identified_rule)}.  {e(res.confounded_rule)}.</p>")
    parts.append(_table(["parameter", "unit", "prior (source tag)", "described", "posterior mean",
                         "posterior 90 %", "width ratio", "identified"],
                        [[n, _unit(p.unit), f"{p.prior.text} {p.prior.tag}", p.described,
                          p.posterior_mean, f"{p.lo90:.4g} .. {p.hi90:.4g}", p.width_ratio,
                          p.identified] for n, p in res.parameters.items()], left=(0, 2)))
    conf = res.confounded
    parts.append("<p>Confounded: " + (e("; ".join(f"{c.parameters[0]} with {c.parameters[1]} (r = "
                                                  f"{c.correlation:+.2f})" for c in conf)) if conf else "none")
                 + ".</p>")
    parts.append(_img(figs["parameters"], "Prior and posterior 90 % intervals per parameter, posterior mean and the "
                                          "description's value"))
    parts.append("<h2>Posterior predictive checks</h2>")
    s = res.checks.summary
    parts.append(f"<p>{s.inside} of {s.total} observed run means inside their 90 % predictive interval "
                 f"({e(s.rule)}).</p>")
    parts.append(_img(figs["checks"], "Observed replicate mean of each sheet run against its 90 % predictive "
                                      "interval"))
    ho = res.checks.held_out_run
    if ho.done:
        parts.append("<p>Held-out run: calibrated without run 1, then run 1 predicted:</p>")
        parts.append(_table(["response", "observed mean", "90 % predictive interval", "inside"],
                            [[r.response, r.observed_mean, f"{r.lo90:.4g} .. {r.hi90:.4g}", r.inside]
                             for r in ho.rows]))
    else:
        parts.append(f"<p>No held-out run: {e(ho.reason or '')}.</p>")
    parts.append("<h2>Predictions of every level set</h2>")
    rec = res.recommendation
    parts.append(f"<p><b>Recommended: {e(rec.level_set)}</b>" +
                 (f"; no difference beyond the intervals from: {e(', '.join(rec.no_difference))}"
                  if rec.no_difference else "") + f".  <span class='small'>{e(rec.rule)}.</span></p>")
    preds = res.predictions
    responses = list(preds[0].responses) if preds else []
    parts.append(_table(["row", "level set", "tested",
                         *[f"{r} ({preds[0].responses[r].unit}): mean [90 %]" for r in responses]],
                        [[i, p.level_set + (" (extrapolated)" if p.extrapolated else ""), p.tested,
                          *[f"{p.responses[r].mean:.3g} [{p.responses[r].lo90:.3g}, "
                            f"{p.responses[r].hi90:.3g}]" for r in responses]] for i, p in enumerate(preds, 1)]))
    parts.append(_img(figs["predictions"], "Predicted mean and 90 % interval of a future field result per level set"))
    parts.append("<h2>Emulator and sampler</h2>")
    em = res.emulator
    parts.append(f"<p>{e(em.kind)}; {em.training_points} training points.</p>")
    rows = []
    for where, label in (("held_out_theta", "held-out parameters"), ("held_out_settings", "held-out settings")):
        for r, x in (getattr(em, where) or {}).items():
            rows.append([label, r, x.rmse, x.replicate_sd_rms, x.rmse_over_sd, x.relative_rmse,
                         x.log_sd_rmse])
    parts.append(_table(["check", "response", "RMSE of the mean", "replicate SD", "RMSE / SD", "relative RMSE",
                         "RMSE of log SD"], rows))
    if em.untested_relative_rmse:
        parts.append("<p>Emulator error at settings that were not simulated (relative RMSE of mean + c): "
                     + ", ".join(f"{e(r)} {v:.3g}" for r, v in em.untested_relative_rmse.items())
                     + f"; {e(em.untested_error_rule)}.</p>")
    sm = res.sampler
    parts.append(f"<p>{e(sm.package)}: {sm.walkers} walkers x {sm.steps} steps, burn-in {sm.burn}, "
                 f"thinning {sm.thin}, acceptance fraction {sm.acceptance_fraction:.2f}, autocorrelation time "
                 f"{max(sm.autocorrelation_steps):.0f} steps ({'at least' if sm.converged else 'fewer than'} "
                 f"50 of them).  Likelihood: {e(res.likelihood)}.</p>")
    parts.append("<h2>Limits</h2><ul>" + "".join(f"<li>{e(x)}</li>" for x in res.limits) + "</ul>")
    parts.append("</body></html>")
    return "\n".join(parts)
