"""Where the studies write the data the package's defaults cite: one JSON per study in benchmarks/studies/results/."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
#: the repository's root: paths under it are written relative to it, so a result names no folder of one machine
ROOT = RESULTS.parents[2]


def _in_repo(value):
    """``value`` with every path under :data:`ROOT` written relative to it (strings, and the items of lists and dicts)."""
    if isinstance(value, str):
        return value.replace(str(ROOT) + os.sep, "")
    if isinstance(value, (list, tuple)):
        return [_in_repo(v) for v in value]
    if isinstance(value, dict):
        return {k: _in_repo(v) for k, v in value.items()}
    return value


def default_out(name: str) -> Path:
    """benchmarks/studies/results/<name>.json."""
    return RESULTS / f"{name}.json"


def write_results(path: Path | str, study: str, arguments: dict, data: dict) -> Path:
    """Write ``data`` with what reproduces it (the study, its arguments, the commit, the machine, the date)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                                cwd=Path(__file__).resolve().parent, check=False).stdout.strip() or None
    except OSError:
        commit = None
    doc = {"study": study, "command": " ".join([Path(sys.executable).name, *_in_repo(sys.argv)]),
           "arguments": _in_repo(arguments),
           "commit": commit, "date": time.strftime("%Y-%m-%d"), "python": platform.python_version(),
           "cores": os.cpu_count(), "data": data}
    path.write_text(json.dumps(doc, indent=1, default=float) + "\n", encoding="utf-8")
    print(f"wrote {path}")
    return path
