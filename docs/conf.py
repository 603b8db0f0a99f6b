"""Sphinx configuration of the berryshaker documentation site.

Build (what CI runs; the gallery pages show the scripts' code and text without running them)::

    .venv/bin/python -m pip install -e ".[test,docs]"
    .venv/bin/sphinx-build -W --keep-going -b html docs /tmp/docs_html

Build with the gallery executed (figures and printed output on the pages; a few seconds per example)::

    .venv/bin/sphinx-build -W --keep-going -b html -D plot_gallery=1 docs /tmp/docs_html

CI executes the same scripts once in ``tests/test_examples.py`` instead, so they are not run twice.
The user guide is the Markdown pages of ``docs/`` as they are (myst-parser); the API reference is generated from
the docstrings (autodoc + autosummary, numpydoc format) into ``docs/api/generated/`` at build time, the gallery
from ``examples/gallery/plot_*.py`` into ``docs/gallery/`` (both ignored by git).
"""

from __future__ import annotations

import logging
import re
import sys
from pathlib import Path

from sphinx.util import logging as sphinx_logging

ROOT = Path(__file__).resolve().parents[1]
if not any(Path(p).resolve() == ROOT / "src" for p in sys.path if p):
    sys.path.insert(0, str(ROOT / "src"))  # a source checkout without installation still documents itself

import berryshaker  # noqa: E402

project = "berryshaker"
author = "berryshaker developers"
copyright = "berryshaker developers, MIT licence"
release = berryshaker.__version__
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
# sg_execution_times: sphinx-gallery's table of run times, empty while the gallery is not executed
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "gallery/*.ipynb", "gallery/*.py", "gallery/*.zip",
                    "sg_execution_times.rst"]
templates_path = ["_templates"]

# Markdown: the pages of docs/ use $...$ maths, tables and ``{eq}``-free plain headings
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence"]
myst_heading_anchors = 3

# API reference: one page per public module, members defined in that module only
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": False}
autodoc_typehints = "none"  # the signatures carry the types; numpydoc sections carry the units
autodoc_member_order = "bysource"
numpydoc_show_class_members = False  # autosummary lists the members; numpydoc would list them twice
numpydoc_class_members_toctree = False
numpydoc_validation_checks: set[str] = set()  # tests/test_docstrings.py validates the docstrings

# Gallery: examples/gallery/plot_*.py.  Not executed by default (CI runs them in tests/test_examples.py);
# ``-D plot_gallery=1`` executes them into the pages.
sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples" / "gallery"),
    "gallery_dirs": "gallery",
    "filename_pattern": r"/plot_",
    "plot_gallery": "False",
    "download_all_examples": False,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "within_subsection_order": "FileNameSortKey",
}

html_theme = "alabaster"
html_title = f"berryshaker {release}"
html_static_path: list[str] = []


def _escape_bars(app, what, name, obj, options, lines):
    """The docstrings write absolute values and norms as plain text (``|v|``, ``|F_A|``), which reStructuredText
    would read as substitution references: escape every bar that is not part of a table or a line block."""
    for i, line in enumerate(lines):
        stripped = line.strip()
        table_row = stripped.startswith("+-") or stripped.startswith("+=") or (
            len(stripped) > 1 and stripped[0] == stripped[-1] == "|" and stripped[1] == " ")
        if "|" in line and not table_row:
            lines[i] = line.replace("\\|", "|").replace("|", "\\|")


def _typer_app(app, what, name, obj, options, lines):
    """The command-line application object (``berryshaker.cli.app``, a :class:`typer.Typer`) carries Typer's own
    Markdown docstring, which is not reStructuredText: describe it in one line instead."""
    import typer

    if isinstance(obj, typer.Typer):
        lines[:] = ["The ``berryshaker`` command-line application (a Typer app); its commands are listed by",
                    "``berryshaker --help``."]


def _pending() -> tuple[frozenset[str], frozenset[str]]:
    """``PENDING`` and ``PENDING_EXCEPT`` of tests/test_docstrings.py (the one list of modules being rewritten)."""
    import ast

    found = {"PENDING": frozenset(), "PENDING_EXCEPT": frozenset()}
    tree = ast.parse((ROOT / "tests" / "test_docstrings.py").read_text(encoding="utf-8"))
    for node in tree.body:
        if isinstance(node, ast.Assign):
            for target in node.targets:
                if getattr(target, "id", "") in found:
                    found[target.id] = frozenset(ast.literal_eval(node.value))
    return found["PENDING"], found["PENDING_EXCEPT"]


class _PendingMarkup(logging.Filter):
    """Reads docutils' complaints about the docstrings of a pending module as notes, not warnings: those
    modules are being rewritten, and the API pages of what they hold now still build.  Counted and named at
    the end of the build; empty ``PENDING`` and every warning counts again."""

    def __init__(self):
        super().__init__()
        self.pending, self.excepted = _pending()
        self.held: list[str] = []

    def _is_pending(self, name: str) -> bool:
        covering = [e for e in self.pending | self.excepted if name == e or name.startswith(e + ".")]
        return bool(covering) and max(covering, key=len) in self.pending

    def filter(self, record: logging.LogRecord) -> bool:
        where = str(getattr(record, "location", "") or "")
        name = re.search(r"berryshaker(?:\.\w+)+", where)
        if name is not None and self._is_pending(name.group(0)):
            self.held.append(f"{where}: {record.getMessage()}")
            return False
        return True


def setup(app):
    app.connect("autodoc-process-docstring", _typer_app, priority=90)
    app.connect("autodoc-process-docstring", _escape_bars, priority=100)  # before numpydoc (500) parses it
    held = _PendingMarkup()
    for handler in logging.getLogger("sphinx").handlers:
        if handler.level >= logging.WARNING:  # the warning stream: ahead of Sphinx's own count
            handler.filters.insert(0, held)

    def report(app, exc):
        if held.held:
            sphinx_logging.getLogger(__name__).info(
                f"{len(held.held)} markup notes in the docstrings of pending modules (tests/test_docstrings.py "
                "PENDING) were not counted as warnings:\n  " + "\n  ".join(held.held))

    app.connect("build-finished", report)
