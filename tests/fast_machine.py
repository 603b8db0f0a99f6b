"""One way to make a machine description cheap for a test: set keys of its TOML text (values and provenance comments
kept), each key found exactly once in its section or the test fails (a text replacement that silently matches
nothing left a test running the full machine)."""

from __future__ import annotations

import re

#: the cheap machine of the study-level tests: one branch class, two starts, one tolerance replicate
FAST = {"harvest.branch_classes": "[1.0]", "harvest.replicates": "2", "harvest.max_replicates": "2",
        "harvest.tolerance_replicates": "1"}


def with_values(text: str, values: dict[str, str]) -> str:
    """The TOML ``text`` with each ``section.key`` set to its (TOML) value, the line's comment kept.

    Raises AssertionError naming a key that is not in its section (or that is there more than once)."""
    out = text
    for dotted, value in values.items():
        section, key = dotted.rsplit(".", 1)
        head = re.search(rf"(?m)^\[{re.escape(section)}\]\s*$", out)
        assert head, f"with_values: no [{section}] section"
        nxt = re.search(r"(?m)^\[", out[head.end():])
        end = head.end() + (nxt.start() if nxt else len(out) - head.end())
        body = out[head.end():end]
        pat = re.compile(rf"(?m)^{re.escape(key)}\s*=\s*(\[[^\]]*\]|\"[^\"]*\"|[^#\n]*?)(\s*(#.*)?)$")
        hits = pat.findall(body)
        assert len(hits) == 1, f"with_values: {dotted} found {len(hits)} times"
        body = pat.sub(lambda m: f"{key} = {value}{m.group(2)}", body, count=1)
        out = out[:head.end()] + body + out[end:]
    return out


def fast_text(text: str, **extra: str) -> str:
    """``text`` made cheap (:data:`FAST`) with ``extra`` keys (``section__key="value"``) on top."""
    return with_values(text, {**FAST, **{k.replace("__", "."): v for k, v in extra.items()}})
