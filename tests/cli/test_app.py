"""Python warnings reach the user as one clean line (the message, no file, line number or source line; issue 45)."""

from __future__ import annotations

import warnings

import typer
from typer.testing import CliRunner

from berryshaker.cli.app import command

cli = CliRunner()


def test_a_library_warning_is_one_clean_line():
    demo = typer.Typer()

    @command(demo, "noisy")
    def noisy():
        """Warn like pandas or statsmodels do, then finish."""
        warnings.warn("covariance of constraints does not have full\n   rank", UserWarning, stacklevel=1)
        print("done")

    @command(demo, "other")
    def other():
        """A second command so that typer keeps the command names."""

    r = cli.invoke(demo, ["noisy"])
    assert r.exit_code == 0, r.output
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert "warning: covariance of constraints does not have full rank" in lines, r.output
    assert "UserWarning" not in r.output and "warnings.warn" not in r.output and ".py:" not in r.output, r.output
    assert lines[-1] == "done"
    assert warnings.showwarning.__module__ == "warnings"  # the handler is restored after the command
