"""Help panels that show flags as flags, print help texts as written and never cut a default.

Typer 0.29's rich help panel prints a type placeholder for every option, so a flag such as ``--json`` (and
``--help`` itself) reads ``--json <bool>`` as if it took a value -- it does not: ``--json`` switches it on.
(Typer's plain-text help already leaves flags without a placeholder; only
``typer.rich_utils._print_options_panel`` asks :meth:`typer.core.TyperOption.display_type_rich` for every
option.)  :func:`show_flags_as_flags` makes that method return nothing for flags, so the panel's type column
is empty for them, as in click's own help.  Options that take a value are unchanged.

Typer's rich help also reads every help text as rich markup, so a bracketed word such as ``[driveline]``,
``[assumed]`` or ``[unit]`` vanished ("the motor, belt, CVT and worm of  turn it"), and it laid an option's help
and its ``[default: ...]`` out as columns that cut a long default with an ellipsis.
:func:`help_as_written` makes the help texts plain text (no markup is used in any help) and stacks an option's
help, default and "required" as wrapped lines that fold rather than cut.
"""

from __future__ import annotations


def show_flags_as_flags() -> None:
    """Patch :meth:`typer.core.TyperOption.display_type_rich` once: no type placeholder for a flag (an
    option that takes no value, e.g. ``--json``, ``--force``, ``--help``) unless it sets its own metavar."""
    from typer.core import TyperOption

    original = TyperOption.display_type_rich
    if getattr(original, "_berryshaker_flags", False):
        return

    def display_type_rich(self, ctx):
        if getattr(self, "is_flag", False) and not getattr(self, "count", False) and self.metavar is None:
            return None
        return original(self, ctx)

    display_type_rich._berryshaker_flags = True  # type: ignore[attr-defined]
    TyperOption.display_type_rich = display_type_rich  # type: ignore[method-assign]  # the patch is the point


def help_as_written() -> None:
    """Patch ``typer.rich_utils`` once: help texts are plain text (brackets print as written) and an option's
    help, environment variable, default and "required" are lines that wrap and fold, never an ellipsis."""
    from rich.console import Group
    from rich.text import Text
    from typer import rich_utils

    if getattr(rich_utils._make_rich_text, "_berryshaker_plain", False):
        return
    original_text = rich_utils._make_rich_text
    original_param = rich_utils._get_parameter_help

    def _make_rich_text(*, text: str, style: str = "", markup_mode):
        if markup_mode != "rich":
            return original_text(text=text, style=style, markup_mode=markup_mode)
        import inspect

        return rich_utils.highlighter(Text(inspect.cleandoc(text), style=style, overflow="fold"))

    def _get_parameter_help(*, param, ctx, markup_mode):
        cols = original_param(param=param, ctx=ctx, markup_mode=markup_mode)
        items = list(getattr(cols, "renderables", [cols]))
        for it in items:
            if isinstance(it, Text):
                it.overflow = "fold"
                it.no_wrap = False
        return Group(*items)

    _make_rich_text._berryshaker_plain = True  # type: ignore[attr-defined]
    rich_utils._make_rich_text = _make_rich_text
    rich_utils._get_parameter_help = _get_parameter_help


show_flags_as_flags()
help_as_written()
