"""The harvest model against the published record: ``validate``."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from berryshaker import __version__
from berryshaker.cli.app import ConfigOpt, JsonOpt, _fail, _load, _print_json, app, command, err, out
from berryshaker.cli.study import SCHEDULER_HELP
from berryshaker.errors import BerryshakerError


@command(app, "validate")
def validate(
    config: Optional[Path] = ConfigOpt,
    as_json: bool = JsonOpt,
    workers: Optional[int] = typer.Option(None, "--workers", help="Processes (default: every core this process "
                                          "may run on)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help=SCHEDULER_HELP),
    cache: Optional[str] = typer.Option(None, "--cache", help="Run cache folder."),
    replicates: Optional[int] = typer.Option(None, "--replicates", min=2, max=64,
                                             help="Starts per case (default harvest.replicates)."),
):
    """The harvest model against published numbers: one row per number, its source, the model's value with an
    interval and a verdict.

    Every published number the model can represent is set up as a case on the machine description (its
    configured clearances and speed for the reference study's field result; the same comb and plant onto soft
    and hard catching surfaces for other published harvests) and run from harvest.replicates perturbed starts
    through the cached runner.  A machine result is compared with the 95 % prediction interval of one field
    result (mean +- t SD sqrt(1 + 1/R)); an interval wider than a factor of ten reads "no verdict" (an
    efficiency, whose yield per bush is known only to x5, says at which yield the model would match);
    published model inputs (bond strengths) read "input"; a machine or operating point the description does not
    represent reads "not comparable" with the reason.  Nothing is fitted to any of these numbers: every row but
    the inputs is held out.  Sources and how far each number can be trusted: docs/published_record.md.

    --json keys: rows (id, quantity, case, source (citation), source_key, published, unit, model, lo, hi: the interval the verdict uses,
    noise_lo, noise_hi: start-to-start noise only, verdict, held_out, how, confidence), replicates, summary (held_out, consistent, not_reproduced, no_verdict, not_comparable, inputs), version.
    \f

    Parameters
    ----------
    config : Path, optional
        ``--config``: Machine description (TOML). Default: built-in reference machine.
    as_json : bool
        ``--json``: Print one JSON object on stdout instead of tables.
    workers : int, optional
        ``--workers``: Processes (default: every core this process may run on).
    scheduler : str, optional
        ``--scheduler``: Dask scheduler address, e.g. tls://10.0.0.5:8786. Runs and results travel as pickles (code
        runs where they are loaded): give only a scheduler you trust, on a trusted network or over TLS (tls://).
    cache : str, optional
        ``--cache``: Run cache folder.
    replicates : int, optional
        ``--replicates``: Starts per case (default harvest.replicates).
    """
    try:
        from berryshaker.runs.runner import SweepRunner
        from berryshaker.study.validation import validate as run_validation

        machine = _load(config)
        if machine.plant is None:
            raise BerryshakerError("validate needs a [plant] block in the machine description (the harvest model "
                                   "runs on it); add one, e.g. from the reference machine (config init)")
        with SweepRunner(workers=workers, scheduler=scheduler, cache_dir=cache, progress=True,
                         console=err) as runner:
            res = run_validation(machine, runner, replicates)
        res["version"] = __version__
    except BerryshakerError as exc:
        _fail(exc)
        return
    if as_json:
        _print_json(res)
        return
    from berryshaker.report.tables import rich_table

    def num(v):
        return "" if v is None else f"{v:.3g}"

    rows = [[r["quantity"], r["case"], f"{num(r['published'])} {r['unit']}",
             "" if r["model"] is None else f"{num(r['model'])} [{num(r['lo'])}, {num(r['hi'])}] {r['unit']}",
             r["verdict"] + ("" if r["held_out"] else " (not held out)")] for r in res["rows"]]
    out.print(rich_table(["published number", "case", "published", "model [interval]", "verdict"], rows,
                         title=f"The harvest model against the published record ({res['replicates']} starts per case)"))
    s = res["summary"]
    out.print(f"held out: {s['held_out']} numbers: {s['consistent']} consistent, {s['not_reproduced']} not "
              f"reproduced, {s['no_verdict']} without a verdict, {s['not_comparable']} not comparable; "
              f"{s['inputs']} model inputs.  Sources: "
              "validate --json (source), docs/published_record.md.", markup=False, highlight=False)
