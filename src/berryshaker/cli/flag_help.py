"""Help panels that show flags as flags.

Typer 0.29's rich help panel prints a type placeholder for every option, so a flag such as ``--json`` (and
``--help`` itself) reads ``--json <bool>`` as if it took a value -- it does not: ``--json`` switches it on.
(Typer's plain-text help already leaves flags without a placeholder; only
``typer.rich_utils._print_options_panel`` asks :meth:`typer.core.TyperOption.display_type_rich` for every
option.)  :func:`show_flags_as_flags` makes that method return nothing for flags, so the panel's type column
is empty for them, as in click's own help.  Options that take a value are unchanged.
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
    TyperOption.display_type_rich = display_type_rich


show_flags_as_flags()
