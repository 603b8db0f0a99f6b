"""Every command's --help prints its help texts as written: a bracketed word ("[driveline]", "[assumed]",
"[unit]") is never eaten as rich markup, and a long default is never cut with an ellipsis (issue 45)."""

from __future__ import annotations

import re

import typer
from typer.testing import CliRunner

from berryshaker.cli import app

cli = CliRunner()
BRACKETED = re.compile(r"\[[^\[\]\s][^\[\]]*\]")
BOX = re.compile(r"[│╭╮╰╯─┃━]")


def _commands(cmd, path: tuple[str, ...] = ()):
    yield path, cmd
    if hasattr(cmd, "commands"):  # a group (Typer 0.29 vendors click: no isinstance on click.Group)
        for name, sub in cmd.commands.items():
            yield from _commands(sub, path + (name,))


def _flat(text: str) -> str:
    return " ".join(BOX.sub(" ", text).split())


def _sources(cmd) -> list[str]:
    texts = [(cmd.help or "").partition("\f")[0]]
    texts += [getattr(p, "help", None) or "" for p in cmd.params]
    if hasattr(cmd, "commands"):
        texts += [(sub.help or "").split("\n\n")[0] for sub in cmd.commands.values()]
    return texts


def test_every_bracketed_word_of_every_help_text_is_printed():
    root = typer.main.get_command(app)
    checked, missing = 0, []
    for path, cmd in _commands(root):
        r = cli.invoke(app, [*path, "--help"], env={"COLUMNS": "300"})
        assert r.exit_code == 0, (path, r.output)
        shown = _flat(r.output)
        for text in _sources(cmd):
            for token in BRACKETED.findall(" ".join(text.split())):
                checked += 1
                if token not in shown:
                    missing.append(f"{' '.join(path) or 'berryshaker'}: {token}")
    assert checked >= 10  # the scan sees the bracketed words ([driveline], [assumed], [unit], ...)
    assert not missing, "bracketed help words eaten as markup:\n  " + "\n  ".join(missing)


def test_help_at_80_columns_keeps_brackets_and_whole_defaults():
    r = cli.invoke(app, ["simulate", "--help"], env={"COLUMNS": "80"})
    assert r.exit_code == 0, r.output
    assert "[driveline]" in _flat(r.output)
    r = cli.invoke(app, ["tolerance", "--help"], env={"COLUMNS": "80"})
    assert "…" not in r.output, r.output
    assert "H11/c11]" in r.output  # the whole default, folded, not cut
