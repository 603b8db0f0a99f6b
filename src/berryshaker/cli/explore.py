"""``berryshaker explore``: the interactive web page on a machine description (docs/explore.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from berryshaker.cli.app import ConfigOpt, _load, app, command, err, out


@command(app)
def explore(
    config: Optional[Path] = ConfigOpt,
    port: int = typer.Option(5006, "--port", help="TCP port of the page (1..65535; must be free)."),
    host: str = typer.Option("127.0.0.1", "--host", help="Loopback address to serve on (127.0.0.1 or "
                             "localhost); any other address is refused."),
    workers: int = typer.Option(1, "--workers", min=1, help="Local processes of the harvest runs (>= 1)."),
    cache: Optional[Path] = typer.Option(None, "--cache", help="Run cache folder of the harvest and wear runs "
                                         "(default ~/.cache/berryshaker/runs or $BERRYSHAKER_CACHE)."),
):
    """A local web page to explore the machine: clearances, drive speed, stroke and travel speed as fields and
    sliders; the comb drive animated with its clearances magnified and impacts marked; collision forces per
    joint (reduced model, about a second per change); removal against frequency (virtual harvest) and wear with
    the service interval (background runs, cached).  Serves on 127.0.0.1 only; Ctrl-C stops it.
    \f

    Parameters
    ----------
    config : Path, optional
        ``--config``: Machine description (TOML). Default: built-in reference machine.
    port : int
        ``--port``: TCP port of the page (1..65535; must be free).
    host : str
        ``--host``: Loopback address to serve on (127.0.0.1 or localhost); any other address is refused.
    workers : int
        ``--workers``: Local processes of the harvest runs (>= 1).
    cache : Path, optional
        ``--cache``: Run cache folder of the harvest and wear runs (default ~/.cache/berryshaker/runs or
        $BERRYSHAKER_CACHE).
    """
    from berryshaker.explore import check_loopback, check_port

    check_loopback(host)
    check_port(host, port)
    machine = _load(config)
    source = f"machine description {config}" if config is not None else "built-in reference machine"
    err.print("loading the web framework and the drive's model ...", highlight=False)
    from berryshaker.explore.server import serve

    out.print(f"berryshaker explore: open http://{host}:{port}/explore  (Ctrl-C stops)", markup=False,
              highlight=False)
    try:
        serve(machine, port, host=host, cache_dir=cache, workers=workers, source=source)
    except KeyboardInterrupt:
        pass
    out.print("berryshaker explore: stopped", markup=False, highlight=False)
