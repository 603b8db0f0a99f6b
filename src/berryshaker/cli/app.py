"""The command-line application object, shared options, output consoles and the one error wrapper.

``berryshaker --help``.

Every command works on the built-in reference machine unless ``--config FILE`` names another machine
description (TOML, every dimensional value with its unit: "0.25 mm", "120 rpm").  ``--json`` prints one JSON object
on stdout (never NaN: a non-finite value is null, listed under "null_values") for
scripts; errors go to stderr as one clear message with exit code 2 and nothing written.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Optional

import typer
from rich.console import Console
from rich.markup import escape

from berryshaker import __version__
from berryshaker.cli.flag_help import show_flags_as_flags  # importing it patches the help of every command
from berryshaker.errors import BerryshakerError

app = typer.Typer(
    name="berryshaker",
    help="Design and tune comb-oscillation blueberry harvesters with transmission clearance.\n\n"
    "Start with `berryshaker kinematics` (the reference machine) or `berryshaker config init my.toml` "
    "to get an editable machine description.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
config_app = typer.Typer(help="Show, create and check machine descriptions (TOML).", no_args_is_help=True)
app.add_typer(config_app, name="config")
doe_app = typer.Typer(help="Plan, analyse and simulate orthogonal field tests (study sec. 2.6, 3.5).",
                      no_args_is_help=True)
app.add_typer(doe_app, name="doe")

show_flags_as_flags()  # boolean options show as flags in --help, not as <bool>

out = Console(emoji=False)  # user text such as "peak_force:A" is never an emoji code
err = Console(stderr=True, soft_wrap=True, emoji=False)

ConfigOpt = typer.Option(None, "--config", "-c", help="Machine description (TOML). Default: built-in reference machine.",
                         exists=False, dir_okay=False)
JsonOpt = typer.Option(False, "--json", help="Print one JSON object on stdout instead of tables.")


def _fail(exc: Exception) -> None:
    err.print(f"[bold red]error:[/] {escape(str(exc))}", highlight=False, markup=True)
    raise typer.Exit(code=2)


def _load(config: Optional[Path]):
    from berryshaker.config import load_machine

    return load_machine(config)


def _version_cb(value: bool):
    if value:
        print(f"berryshaker {__version__}")
        raise typer.Exit()


@app.callback()
def main(version: bool = typer.Option(False, "--version", callback=_version_cb, is_eager=True,
                                      help="Print the version and exit.")):
    """berryshaker: harvester drive kinematics, clearance dynamics, plant response and field tests.
    \f

    Parameters
    ----------
    version : bool
        ``--version``: Print the version and exit (handled eagerly by its callback).
    """
    from berryshaker.compiled_cache import kernel_choice
    from berryshaker.errors import BerryshakerError

    try:
        kernel_choice()  # a bad BERRYSHAKER_KERNEL is named before any work, not in every run
    except BerryshakerError as exc:
        _fail(exc)


def _finite_json(obj, path: str, nulls: dict[str, str]):
    """``obj`` with every NaN or infinity replaced by None, its JSON path and value recorded in ``nulls``."""
    if isinstance(obj, float) and not math.isfinite(obj):
        nulls[path or "(the result)"] = repr(obj)
        return None
    if isinstance(obj, dict):
        return {k: _finite_json(v, f"{path}.{k}" if path else str(k), nulls) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite_json(v, f"{path}[{i}]", nulls) for i, v in enumerate(obj)]
    return obj


def _print_json(obj) -> None:
    """``obj`` as JSON on stdout.  Never ``NaN`` or ``Infinity`` (not JSON): such a value is written as null and
    its key listed with the reason under ``"null_values"`` (a top-level object), or the command fails naming it."""
    nulls: dict[str, str] = {}
    clean = _finite_json(obj, "", nulls)
    if nulls:
        if not isinstance(clean, dict):
            raise BerryshakerError(f"result {next(iter(nulls))} is not a finite number ({nulls[next(iter(nulls))]})")
        clean["null_values"] = {k: f"not a finite number ({v}): written as null" for k, v in nulls.items()}
    sys.stdout.write(json.dumps(clean, indent=2, allow_nan=False) + "\n")




def table_width(console: Console | None = None) -> int:
    """Terminal width (cells) for tables: ``COLUMNS`` when set (read at every call, so a test or a resized shell
    is honoured), else the console's.

    Parameters
    ----------
    console : rich.console.Console, optional
        Console whose width is used when ``COLUMNS`` is not set (default the standard-output console).

    Returns
    -------
    int
        Width in terminal cells.
    """
    import os

    cols = os.environ.get("COLUMNS", "")
    return int(cols) if cols.isdigit() and int(cols) > 0 else (console or out).width


def print_table(header, rows, title: str | None = None, justify=None, console: Console | None = None,
                digits: int = 4) -> None:
    """Print rows through the one terminal table writer, :func:`berryshaker.report.tables.rich_table` (no number
    or word ever split; headers wrap at word and dot boundaries; rows stacked when the terminal is too narrow).

    Parameters
    ----------
    header : sequence of str
        Column headers.
    rows : iterable of sequences
        Cells (see :func:`berryshaker.report.tables.rich_table`).
    title : str, optional
        Table title.
    justify : sequence of {"left", "right", "center"}, optional
        Per column (default the first column left, the others right).
    console : rich.console.Console, optional
        Where to print (default the standard-output console); its width when ``COLUMNS`` is not set.
    digits : int
        Significant digits of float cells.
    """
    from berryshaker.report.tables import rich_table

    console = console or out
    console.print(rich_table(header, rows, title=title, digits=digits, justify=justify, width=table_width(console)))


def show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A Python warning (pandas, statsmodels, SciPy ... or ours) as one clean line on stderr: ``warning: <message>``,
    without the file, line number and source line Python prints by default.

    The signature of :func:`warnings.showwarning`, which it replaces while a command runs.

    Parameters
    ----------
    message : Warning or str
        The warning; its text is printed with runs of whitespace collapsed.
    category : type
        The warning's class (not printed).
    filename : str
        File that raised it (not printed).
    lineno : int
        Line that raised it (not printed).
    file : file-like, optional
        Ignored: the line goes to the stderr console.
    line : str, optional
        Source line (not printed).
    """
    text = " ".join(str(message).split())
    err.print(f"warning: {text}", markup=False, highlight=False, soft_wrap=True)


def help_text(doc: str) -> str:
    """A command's ``--help`` text from its docstring: the part before ``\\f`` (the numpydoc sections after it are for
    the API reference), each paragraph one flowing line so the terminal wraps it to its width; a line that starts a
    list item (``- ``, ``* ``, ``1. ``) keeps its own line.

    Parameters
    ----------
    doc : str
        The command function's docstring.

    Returns
    -------
    str
        The help text: paragraphs separated by a blank line.
    """
    import inspect
    import re

    text = inspect.cleandoc(doc).partition("\f")[0].strip()
    paragraphs = []
    for para in re.split(r"\n\s*\n", text):
        lines = [ln.strip() for ln in para.splitlines() if ln.strip()]
        out = []
        for ln in lines:
            if out and not re.match(r"([-*]|\d+\.)\s", ln):
                out[-1] += " " + ln
            else:
                out.append(ln)
        paragraphs.append("\n".join(out))
    return "\n\n".join(paragraphs)


def command(parent: typer.Typer, name: str | None = None, **kwargs):
    """Register a command on ``parent`` with the one error wrapper: a :class:`BerryshakerError` becomes one clear
    message on stderr and exit code 2; Ctrl-C stops with a message and exit code 130 (finished runs stay in the
    cache); a Python warning raised while the command runs is one line, ``warning: <message>``
    (:func:`show_warning`).

    Parameters
    ----------
    parent : typer.Typer
        The application or command group to register on.
    name : str, optional
        Command name (default the function's name, underscores as hyphens).
    **kwargs
        Passed to :meth:`typer.Typer.command` (``help``, ``epilog``...).

    Returns
    -------
    callable
        The decorator: it registers the wrapped function and returns what :meth:`typer.Typer.command` returns.
    """
    import functools

    def deco(fn):
        if "help" not in kwargs and fn.__doc__:
            kwargs["help"] = help_text(fn.__doc__)

        @functools.wraps(fn)
        def wrapped(*args, **kw):
            import warnings

            try:
                with warnings.catch_warnings():  # restores the previous handler when the command ends
                    warnings.showwarning = show_warning
                    return fn(*args, **kw)
            except BerryshakerError as exc:
                _fail(exc)
            except KeyboardInterrupt:
                err.print("[bold red]interrupted[/]: stopped; finished runs are kept in the cache", highlight=False)
                raise typer.Exit(code=130) from None

        return parent.command(name, **kwargs)(wrapped)

    return deco
