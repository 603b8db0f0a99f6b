"""User text at the edges: what a name, a header, a cell or a path the user typed may become in each place it is
shown, and the bound on its length where it is read.

* :func:`html_text`: escaped for HTML (every page berryshaker writes: the study report, ``doe analyze --out``, the
  calibration page, ``doe plan``'s printable sheet); ``<script>`` in a machine name is text, never markup.
* :func:`cell_text`: a spreadsheet cell (CSV and .xlsx), neutralised against formula injection by the OWASP rule
  (a cell starting with ``=``, ``+``, ``-``, ``@``, a tab or a carriage return gets a leading ``'``), control
  characters made visible (openpyxl refuses them; a terminal would run them).
* :func:`markup_text` and :func:`terminal_text`: for the terminal, control characters (ESC, OSC, BEL, CR, the
  bidirectional overrides) made visible as ``\\x1b``-style escapes, and for a rich markup string also the markup
  escaped (``[red]plots`` and ``a[/]b`` print as written).
* :func:`file_part`: a name from a sheet as part of a file name (``surface_<response>.png``): never a path.
* :func:`check_user_text`: where a name is read (a machine description, a sheet header): a length bound and no
  control characters, else one :class:`~berryshaker.errors.ConfigError` naming the field and the fix.

Everything here is linear in the length of the text (one regular-expression pass, no backtracking).
"""

from __future__ import annotations

import html
import re

from berryshaker.errors import ConfigError

#: longest name (machine, body, joint, column header) berryshaker reads, in characters
MAX_NAME_CHARS = 200
#: longest free text (a machine's description) berryshaker reads, in characters
MAX_TEXT_CHARS = 4000

# C0 and C1 controls, DEL, the Arabic letter mark, the left-to-right/right-to-left marks, the line and paragraph
# separators and the bidirectional embeddings, overrides and isolates ("Trojan source" reordering)
_CONTROLS = "\x00-\x1f\x7f-\x9f\u061c\u200e\u200f\u2028-\u202e\u2066-\u2069"
_ANY_CONTROL = re.compile(f"[{_CONTROLS}]")
_CONTROL_BUT_LINES = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u061c\u200e\u200f\u2028-\u202e\u2066-\u2069]")
_NAMES = {0x00: "NUL", 0x07: "BEL", 0x08: "BS", 0x09: "TAB", 0x0A: "LF", 0x0D: "CR", 0x1B: "ESC", 0x7F: "DEL",
          0x9B: "CSI", 0x9D: "OSC", 0x202E: "RIGHT-TO-LEFT OVERRIDE"}
_UNSAFE_IN_FILE_NAME = re.compile(r"[^A-Za-z0-9._-]")
_MARKUP_TAG = re.compile(r"(\\*)(\[[a-z#/@][^[]*?])")  # rich.markup's tag pattern (RE_TAGS), with its escapes
#: first characters a spreadsheet reads as a formula (OWASP, "CSV injection")
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")


def _escaped(m: re.Match) -> str:
    o = ord(m.group())
    return f"\\x{o:02x}" if o < 0x100 else f"\\u{o:04x}"


def visible(text: str, keep_lines: bool = False) -> str:
    """``text`` with every control character replaced by its escape (``"\\x1b"``, ``"\\u202e"``), so that it shows
    instead of acting (colours, window titles, clearing the screen, reordering the line).

    Parameters
    ----------
    text : str
        Any text.
    keep_lines : bool
        Keep line feeds and tabs as they are (a table cell or a message of several lines).

    Returns
    -------
    str
        The text, unchanged where it has no control character.
    """
    return (_CONTROL_BUT_LINES if keep_lines else _ANY_CONTROL).sub(_escaped, str(text))


def control_character(text: str) -> tuple[int, str] | None:
    """The first control character of ``text`` (see :func:`visible`): (its position from 1, its name), or None.

    Parameters
    ----------
    text : str
        Any text.

    Returns
    -------
    tuple of (int, str) or None
        Position (1 = first character) and a name such as ``"U+001B (ESC)"``.
    """
    m = _ANY_CONTROL.search(text)
    if m is None:
        return None
    o = ord(m.group())
    return m.start() + 1, f"U+{o:04X}" + (f" ({_NAMES[o]})" if o in _NAMES else "")


def check_user_text(text: str, field: str, max_chars: int = MAX_NAME_CHARS, lines: bool = False) -> str:
    """``text`` if it is at most ``max_chars`` characters long and holds no control character; else a
    :class:`~berryshaker.errors.ConfigError` naming ``field``, what is wrong and the fix.

    Parameters
    ----------
    text : str
        A name or text the user wrote.
    field : str
        Where it was read (``"machine.name"``, ``"results CSV header, column 3"``), the start of the message.
    max_chars : int
        The bound on its length.
    lines : bool
        Line feeds and tabs are allowed (free text such as a description).

    Returns
    -------
    str
        ``text``.

    Raises
    ------
    ConfigError
        Too long, or a control character in it.
    """
    if len(text) > max_chars:
        raise ConfigError(f"{field}: {len(text):,} characters, more than the {max_chars:,} it may have; shorten it")
    bad = control_character(text if not lines else text.replace("\n", "").replace("\t", ""))
    if bad is not None:
        pos, name = bad
        raise ConfigError(f"{field}: holds the control character {name} at character {pos} "
                          f"(\"{visible(text[max(0, pos - 21):pos + 20])}\"); remove it (it would act on terminals "
                          "and files instead of showing)")
    return text


def html_text(value, quote: bool = True) -> str:
    """``value`` as text for an HTML page or attribute: ``& < >`` (and with ``quote`` ``" '``) escaped, control
    characters visible.

    Parameters
    ----------
    value : object
        Anything; its ``str``.
    quote : bool
        Escape quotes too (needed inside an attribute; inside an element they may stay).

    Returns
    -------
    str
        Safe inside an element (and, with ``quote``, inside a quoted attribute).
    """
    return html.escape(visible(str(value), keep_lines=True), quote=quote)


def cell_text(value):
    """A spreadsheet cell (CSV or .xlsx) neutralised: a string starting with ``=``, ``+``, ``-``, ``@``, a tab or a
    carriage return gets a leading ``'`` (the OWASP rule against formula injection), and control characters other
    than line feeds and tabs are made visible (:func:`visible`); any other value is returned as it is.

    Parameters
    ----------
    value : object
        A cell (a number stays a number).

    Returns
    -------
    object
        The cell as written.
    """
    if not isinstance(value, str):
        return value
    text = visible(value, keep_lines=True)
    return "'" + text if value.startswith(FORMULA_STARTS) else text


def file_part(text: str, max_chars: int = 60) -> str:
    """``text`` (a response or factor name from a sheet) as part of a file name: letters, digits, ``.``, ``-`` and
    ``_`` kept, anything else (``/``, ``..``, spaces, markup, control characters) replaced by ``_``, at most
    ``max_chars`` of it; a name changed so gets the first 8 hex digits of its sha256 appended, so that two names
    never share a file.  Never empty, never starting with a dot, never leaving its folder.

    Parameters
    ----------
    text : str
        The name.
    max_chars : int
        Longest part kept before the digest.

    Returns
    -------
    str
        The file-name part.
    """
    import hashlib

    text = str(text)
    safe = _UNSAFE_IN_FILE_NAME.sub("_", text)[:max_chars].lstrip(".") or "_"
    if safe != text:
        safe += "-" + hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()[:8]
    return safe


def terminal_text(value) -> str:
    """``value`` for the terminal, printed without markup: control characters visible (:func:`visible`; line feeds
    and tabs kept).

    Parameters
    ----------
    value : object
        Anything; its ``str``.

    Returns
    -------
    str
        The text.
    """
    return visible(str(value), keep_lines=True)


def markup_text(value) -> str:
    """``value`` inside a rich markup string: control characters visible and markup escaped, so ``[red]plots``
    and ``a[/]b`` print as written, a backslash as one backslash (rich's own ``escape`` doubles a trailing one).
    Put it where plain text follows, never directly before a markup tag (a trailing backslash would escape it).

    Parameters
    ----------
    value : object
        Anything; its ``str``.

    Returns
    -------
    str
        The text, safe inside markup.
    """
    # what rich's markup reads as a tag, with the backslashes before it: each doubled, the bracket escaped
    return _MARKUP_TAG.sub(lambda m: f"{m.group(1)}{m.group(1)}\\{m.group(2)}", terminal_text(value))


__all__ = ["FORMULA_STARTS", "MAX_NAME_CHARS", "MAX_TEXT_CHARS", "cell_text", "check_user_text", "control_character",
           "file_part", "html_text", "markup_text", "terminal_text", "visible"]
