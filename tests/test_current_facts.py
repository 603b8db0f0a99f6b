"""Comments and docstrings state current facts: none cites a section of benchmarks/HISTORY.md or an issue number (the
history is in CHANGELOG.md and benchmarks/HISTORY.md themselves), and no file of the repository names a folder outside
it (a path on the machine that wrote it)."""

from __future__ import annotations

import ast
import io
import re
import tokenize
from pathlib import Path

import berryshaker

SRC = Path(berryshaker.__file__).parent
ROOT = Path(__file__).resolve().parents[1]

#: a history citation: HISTORY.md, "issue 45", "issue #43", "(#58)"; an upstream bug is cited by its address
HISTORY = re.compile(r"HISTORY\.md|\bissues?\s+#?\d+|\(#\d+\)", re.IGNORECASE)
#: a folder of one machine (home and work folders, a Windows user's); /tmp in a shown command is anyone's
OUTSIDE = re.compile(r"(?<![\w.~-])/(?:home|work|Users|root|mnt)/\w|\b[A-Z]:\\Users\\")


def _comments_and_docstrings(path: Path):
    """(line, text) of every comment and docstring of a Python file."""
    text = path.read_text(encoding="utf-8")
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type == tokenize.COMMENT:
            yield tok.start[0], tok.string
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                yield node.body[0].lineno, doc


def _toml_comments(path: Path):
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if "#" in line:
            yield n, line[line.index("#"):]


def _cites(pattern: re.Pattern) -> list[str]:
    found = []
    for path in sorted(SRC.rglob("*.py")):
        for line, text in _comments_and_docstrings(path):
            found += [f"{path.relative_to(SRC)}:{line}: {m.group(0)}" for m in pattern.finditer(text)]
    for path in sorted(SRC.rglob("*.toml")):
        for line, text in _toml_comments(path):
            found += [f"{path.relative_to(SRC)}:{line}: {m.group(0)}" for m in pattern.finditer(text)]
    return found


def test_no_comment_or_docstring_cites_history_or_an_issue():
    assert not _cites(HISTORY), "state the current fact instead: " + "; ".join(_cites(HISTORY))


def test_no_comment_or_docstring_names_a_path_outside_the_repository():
    assert not _cites(OUTSIDE), "; ".join(_cites(OUTSIDE))


def test_no_file_of_the_repository_names_a_folder_of_one_machine():
    """Package data, docs, benchmarks' stored results, tests: a path under a home or work folder is one machine's."""
    roots = [ROOT / d for d in ("src", "docs", "benchmarks", "examples", "tests", ".ci")] + [ROOT]
    found = []
    for base in roots:
        files = base.glob("*") if base == ROOT else base.rglob("*")
        for path in files:
            if not path.is_file() or path.suffix not in {".py", ".toml", ".json", ".md", ".rst", ".csv", ""}:
                continue
            if path == Path(__file__).resolve() or any(p.startswith(".") and p != ".ci" for p in path.parts[-3:]):
                continue
            try:
                text = path.read_text(encoding="utf-8")
            except (UnicodeDecodeError, OSError):
                continue
            found += [f"{path.relative_to(ROOT)}: {m.group(0)}" for m in OUTSIDE.finditer(text)]
    assert not found, "; ".join(found)


def test_the_patterns_catch_what_they_are_for():
    """The checks are not vacuous: each pattern finds its kind of text and passes the current facts beside it."""
    for cited in ("benchmarks/HISTORY.md sec. 22", "(issue 45, item 1)", "issue #43", "checked (#58).",
                  "Issues 12"):
        assert HISTORY.search(cited), cited
    for fact in ("(https://github.com/numba/numba/issues/6845)", "color:#444", "study eq. 12", "docs/study.md sec. 7"):
        assert not HISTORY.search(fact), fact
    for path in ("/work/shared/reference/x.txt", "python /work/wt43/benchmarks/a.py", "/home/me/a", r"C:\Users\me"):
        assert OUTSIDE.search(path), path
    for path in ("--out /tmp/docs_html", "benchmarks/studies/results/x.json", "~/.cache/berryshaker", "m/work/s"):
        assert not OUTSIDE.search(path), path


#: a page citing a history section ("benchmarks/HISTORY.md sec. 12", "(benchmarks/HISTORY.md)"); naming the file
#: where the rule is stated is not citing it
DOC_HISTORY = re.compile(r"HISTORY\.md(?:[;,]?\s*sec\.|\))")


def test_no_doc_page_cites_a_history_section():
    """docs/*.md state the current fact, or name the benchmark study or stored result that measures it
    (benchmarks/README.md), never a section of benchmarks/HISTORY.md."""
    found = []
    for path in sorted((ROOT / "docs").rglob("*.md")):
        text = path.read_text(encoding="utf-8")
        found += [f"{path.relative_to(ROOT)}:{text.count(chr(10), 0, m.start()) + 1}" for m in DOC_HISTORY.finditer(text)]
    assert not found, "state the current fact or name the study that measures it: " + ", ".join(found)
