"""User text at the edges (berryshaker.user_text): HTML escaping, the OWASP rule for spreadsheet cells, control
characters made visible for the terminal, names bounded where they are read, names as file-name parts; all in
linear time.  Expected values are the OWASP rule and the HTML/rich escapes written out by hand."""

from __future__ import annotations

import time

import pytest

from berryshaker.errors import ConfigError
from berryshaker.user_text import (
    cell_text,
    check_user_text,
    control_character,
    file_part,
    html_text,
    markup_text,
    terminal_text,
    visible,
)


def test_html_text_escapes_markup_and_quotes():
    assert html_text('<script>alert("x")</script>') == "&lt;script&gt;alert(&quot;x&quot;)&lt;/script&gt;"
    assert html_text("a 'b' & c") == "a &#x27;b&#x27; &amp; c"
    assert html_text("it's", quote=False) == "it's"
    assert html_text("\x1b]0;title\x07") == "\\x1b]0;title\\x07"  # control characters shown, not passed on
    assert html_text(3.5) == "3.5"


@pytest.mark.parametrize("text, written", [
    ("=HYPERLINK(\"http://x\",\"y\")", "'=HYPERLINK(\"http://x\",\"y\")"),
    ("+1+2", "'+1+2"), ("-2+3", "'-2+3"), ("@SUM(A1)", "'@SUM(A1)"), ("\tx", "'\tx"), ("\rx", "'\\x0dx"),
    ("efficiency", "efficiency"), ("a=b", "a=b"), ("a\x1bb", "a\\x1bb"), ("two\nlines", "two\nlines"),
])
def test_cell_text_follows_the_owasp_rule(text, written):
    assert cell_text(text) == written


def test_cell_text_keeps_numbers_numbers():
    for v in (-1.5, 0, 3, None):
        assert cell_text(v) == v


def test_visible_and_the_terminal():
    assert visible("a\x1b[31mred\x07\x9b\u202e") == "a\\x1b[31mred\\x07\\x9b\\u202e"
    assert visible("tab\tline\n", keep_lines=True) == "tab\tline\n"
    assert visible("tab\tline\n") == "tab\\x09line\\x0a"
    assert terminal_text("\x1b]0;x\x07") == "\\x1b]0;x\\x07"
    assert markup_text("[red]plots/a[/]b") == "\\[red]plots/a\\[/]b"
    assert control_character("ab\x1bc") == (3, "U+001B (ESC)") and control_character("abc") is None


def test_check_user_text_names_the_field_and_the_fix():
    assert check_user_text("harvester 2", "machine.name") == "harvester 2"
    with pytest.raises(ConfigError, match=r"machine\.name: 100,000 characters, more than the 200"):
        check_user_text("a" * 100_000, "machine.name")
    with pytest.raises(ConfigError, match=r"machine\.name: holds the control character U\+001B \(ESC\) at "
                                          r"character 5 .*remove it"):
        check_user_text("evil\x1b]0;x\x07", "machine.name")
    assert check_user_text("two\nlines\tand a tab", "machine.description", 4000, lines=True)
    with pytest.raises(ConfigError, match="U\\+0007"):
        check_user_text("bell\x07", "machine.description", 4000, lines=True)


def test_file_part_never_leaves_its_folder():
    assert file_part("efficiency") == "efficiency"
    for bad in ("../../etc/passwd", "a/b", "<script>", ".hidden", "..", "", "x\x00y"):
        part = file_part(bad)
        assert "/" not in part and not part.startswith(".") and part, (bad, part)
        assert all(c.isalnum() or c in "._-" for c in part), part
    assert file_part("a/b") != file_part("a_b")  # two names never share a file


def test_everything_is_linear_in_the_length():
    """A megabyte of text through every helper in well under a second (rich's highlighter took 60 CPU-s on a
    100k-character name)."""
    text = ("[red]a\x1b" + "x" * 97 + "<=") * 10_000
    t0 = time.process_time()
    for f in (visible, html_text, cell_text, markup_text, file_part, control_character):
        f(text)
    with pytest.raises(ConfigError):
        check_user_text(text, "name")
    assert time.process_time() - t0 < 2.0
