"""What the fuzz tests (``tests/test_fuzz*.py``) share: hypothesis settings, a scratch folder outside the repository,
the reference machine descriptions and the leaves of a TOML text.

``BERRYSHAKER_FUZZ_EXAMPLES=5000`` explores further with random seeds (CI runs the fixed, derandomised examples).
"""

from __future__ import annotations

import os
import re
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, settings
from hypothesis.configuration import set_hypothesis_home_dir

from berryshaker.config import reference_toml_text

#: scratch folder of the fuzz tests (each module takes a subfolder of its own, :func:`work_dir`)
WORK = Path(tempfile.mkdtemp(prefix="berryshaker-fuzz-"))
set_hypothesis_home_dir(WORK / "hypothesis")  # hypothesis's caches outside the repository
#: BERRYSHAKER_FUZZ_EXAMPLES=5000 explores further with random seeds (CI runs the fixed, derandomised examples)
EXPLORE = int(os.environ.get("BERRYSHAKER_FUZZ_EXAMPLES", "0"))
#: the reference description of each drive, as TOML text
REFERENCE = {d: reference_toml_text(d) for d in ("groove_cam", "crank_rocker")}


def fuzz(n: int, *suppress: HealthCheck) -> settings:
    """Settings of a fuzz test: ``n`` fixed examples in CI, or ``EXPLORE`` random ones; the ``too_slow`` health check
    and those in ``suppress`` are off."""
    return settings(deadline=None, max_examples=EXPLORE or n, derandomize=not EXPLORE, database=None,
                    suppress_health_check=[HealthCheck.too_slow, *suppress])


def work_dir(name: str) -> Path:
    """The scratch folder ``name`` inside :data:`WORK`, created."""
    path = WORK / name
    path.mkdir(exist_ok=True)
    return path


def toml_leaves(text: str, scalars_only: bool = False) -> list[tuple[int, str, str]]:
    """(line number, dotted key, value text) of every ``key = value`` line of a TOML text; with ``scalars_only``,
    only the lines whose value is a scalar (no ``[``), its text without a trailing comment."""
    out, section = [], ""
    for i, line in enumerate(text.splitlines()):
        m = re.match(r"^\[([^\]]+)\]", line)
        if m:
            section = m.group(1)
            continue
        m = re.match(r"^([A-Za-z0-9_]+)\s*=\s*(.*)$", line)
        if not m:
            continue
        value = m.group(2)
        if scalars_only:
            scalar = re.fullmatch(r"([^#\[]+?)\s*(#.*)?", value)
            if scalar is None:
                continue
            value = scalar.group(1)
        out.append((i, f"{section}.{m.group(1)}", value))
    return out
