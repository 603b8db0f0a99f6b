"""The command-line application object, shared options, output consoles and the one error wrapper.

``berryshaker --help``.

Every command works on the built-in reference machine unless ``--config FILE`` names another machine
description (TOML, every dimensional value with its unit: "0.25 mm", "120 rpm").  ``--json`` prints one JSON object
on stdout (never NaN: a non-finite value is null, listed under "null_values") for
scripts; errors go to stderr as one clear message with exit code 2 and nothing written.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Optional

import typer
from rich.console import Console

from berryshaker import __version__
from berryshaker.cli.flag_help import show_flags_as_flags  # importing it patches the help of every command
from berryshaker.errors import BerryshakerError
from berryshaker.user_text import visible

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



class SafeConsole(Console):
    """The command line's console: every string printed has its control characters made visible
    (:func:`berryshaker.user_text.visible`: an ESC, OSC or BEL from a machine name or a sheet header shows as
    ``\\x1b``, never acts on the terminal), and nothing is highlighted (rich's highlighter regex is super-linear
    on long text, and it colours user text as if it were code).  User text inside a markup string still goes
    through :func:`berryshaker.user_text.markup_text` (``[red]plots`` is a folder name, not a style).

    Parameters
    ----------
    **kwargs
        Passed to :class:`rich.console.Console` (``highlight`` and ``emoji`` are off).
    """

    def __init__(self, **kwargs):
        super().__init__(highlight=False, emoji=False, **kwargs)

    def render_str(self, text: str, **kwargs):
        """A string to print as :class:`rich.text.Text`, its control characters first made visible (line feeds
        and tabs kept).

        Parameters
        ----------
        text : str
            The string (markup when ``markup`` is on).
        **kwargs
            Passed to :meth:`rich.console.Console.render_str`.

        Returns
        -------
        rich.text.Text
            The text to render.
        """
        return super().render_str(visible(text, keep_lines=True), **kwargs)


out = SafeConsole()  # user text such as "peak_force:A" is never an emoji code
err = SafeConsole(stderr=True, soft_wrap=True)

ConfigOpt = typer.Option(None, "--config", "-c", help="Machine description (TOML). Default: built-in reference machine.",
                         exists=False, dir_okay=False)
JsonOpt = typer.Option(False, "--json", help="Print one JSON object on stdout instead of tables.")


def _fail(exc: Exception) -> None:
    from rich.text import Text

    err.print(Text.assemble(("error:", "bold red"), " ", visible(str(exc), keep_lines=True)), highlight=False)
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


def _print_json(obj) -> None:
    """``obj`` as JSON on stdout.  Never ``NaN`` or ``Infinity`` (not JSON): such a value is written as null and
    its key listed with the reason under ``"null_values"`` (a top-level object), or the command fails naming it
    (:func:`berryshaker.outputs.strict_json_text`)."""
    from berryshaker.outputs import strict_json_text

    sys.stdout.write(strict_json_text(obj) + "\n")


def check_range(flag: str, value: int, lo: int, hi: int, what: str) -> int:
    """``value`` if ``lo <= value <= hi``; else a :class:`ConfigError` naming the flag, the range and its meaning
    (exit code 2 instead of a traceback or a huge allocation deep inside a library).

    Parameters
    ----------
    flag : str
        The command-line flag, named in the message.
    value : int
        The value given.
    lo, hi : int
        Smallest and largest value accepted.
    what : str
        What the value means, named in the message.

    Returns
    -------
    int
        ``value``, unchanged.

    Raises
    ------
    BerryshakerError
        ``value`` is outside ``lo .. hi``.
    """
    if not lo <= value <= hi:
        raise BerryshakerError(f"{flag} {value}: expected a whole number in {lo}..{hi} ({what})")
    return value


def check_number(flag: str, value: float, lo: float | None = None, hi: float | None = None, *, what: str,
                 lo_open: bool = False, hi_open: bool = False) -> float:
    """``value`` if it is a finite number in the range (``lo`` .. ``hi``, either end open or absent); else one
    :class:`BerryshakerError` naming the flag, the value, the range and what the value means, before any work.

    Parameters
    ----------
    flag : str
        The command-line flag, named in the message.
    value : float
        The value given, in the flag's unit (NaN and infinities are refused).
    lo, hi : float, optional
        The range's ends, in the flag's unit (None: no bound on that side).
    what : str
        What the value means, named in the message.
    lo_open, hi_open : bool
        The end itself is refused (``--alpha`` lies in (0, 1)).

    Returns
    -------
    float
        ``value``, in the flag's unit.

    Raises
    ------
    BerryshakerError
        Not finite, or outside the range.
    """
    v = float(value)
    low_ok = lo is None or (v > lo if lo_open else v >= lo)
    high_ok = hi is None or (v < hi if hi_open else v <= hi)
    if not (math.isfinite(v) and low_ok and high_ok):
        left = "" if lo is None else ("(" if lo_open else "[") + f"{lo:g}"
        right = "" if hi is None else f"{hi:g}" + (")" if hi_open else "]")
        span = (f"{left}, {right}" if lo is not None and hi is not None else
                f"{'>' if lo_open else '>='} {lo:g}" if lo is not None else f"{'<' if hi_open else '<='} {hi:g}")
        raise BerryshakerError(f"{flag} {value!r}: expected a finite number {'in ' if lo is not None and hi is not None else ''}"
                               f"{span} ({what})")
    return v


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
        out: list[str] = []
        for ln in lines:
            if out and not re.match(r"([-*]|\d+\.)\s", ln):
                out[-1] += " " + ln
            else:
                out.append(ln)
        paragraphs.append("\n".join(out))
    return "\n\n".join(paragraphs)


def command(parent: typer.Typer, name: str | None = None, **kwargs):
    """Register a command on ``parent`` with the one error wrapper: a :class:`BerryshakerError` (and a full or
    read-only disk, :data:`berryshaker.outputs.WRITE_ERRNOS`) becomes one clear message on stderr and exit code 2;
    Ctrl-C stops with a message and exit code 130 (finished runs stay in the
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
            except OSError as exc:  # a full disk met where no writer named it: still one line, never a traceback
                from berryshaker.outputs import WRITE_ERRNOS, write_error

                if exc.errno not in WRITE_ERRNOS:
                    raise
                _fail(write_error(exc.filename or "an output", exc))
            except KeyboardInterrupt:
                err.print("[bold red]interrupted[/]: stopped; finished runs are kept in the cache", highlight=False)
                raise typer.Exit(code=130) from None

        return parent.command(name, **kwargs)(wrapped)

    return deco
