"""Command line: ``berryshaker --help``.  Thin command modules over library functions, one per area
(:mod:`.machine`, :mod:`.simulate`, :mod:`.plant`, :mod:`.doe`, :mod:`.study`, :mod:`.life`, :mod:`.validate`, :mod:`.calibrate`); the application,
shared options and the error wrapper are in :mod:`.app`.

Every command works on the built-in reference machine unless ``--config FILE`` names another machine
description.  ``--json`` prints one JSON object on stdout for scripts; errors go to stderr as one clear
message with exit code 2 and nothing written.
"""

from __future__ import annotations

from berryshaker.cli import calibrate, doe, explore, life, machine, plant, plot, simulate, study, validate  # noqa: F401  (register the commands)
from berryshaker.cli.app import app

__all__ = ["app", "run"]


def run() -> None:
    """Console-script entry point."""
    app()


if __name__ == "__main__":
    run()
