"""Atomic output: a file appears complete or not at all; a directory of outputs is filled in a staging
directory and moved into place only when everything succeeded."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Iterator

from berryshaker import __version__


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_text_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` via a temporary file in the same folder and an atomic rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; outputs are ordinary files
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def write_json_atomic(path: str | Path, obj) -> None:
    write_text_atomic(path, json.dumps(obj, indent=2, sort_keys=False) + "\n")


@contextlib.contextmanager
def staged_directory(final: str | Path) -> Iterator[Path]:
    """Yield a staging directory; on success its files are moved into ``final`` (created if needed).

    Files already in ``final`` with other names are left alone; files of the same name are replaced
    one by one with atomic renames, so ``final`` never holds a half-written file.  On error nothing in
    ``final`` changes.
    """
    final = Path(final)
    parent = final.parent if final.parent != Path("") else Path(".")
    parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".{final.name}.staging.", dir=parent))
    try:
        yield stage
        final.mkdir(parents=True, exist_ok=True)
        for item in sorted(stage.rglob("*")):
            rel = item.relative_to(stage)
            target = final / rel
            if item.is_dir():
                target.mkdir(parents=True, exist_ok=True)
            else:
                target.parent.mkdir(parents=True, exist_ok=True)
                os.replace(item, target)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def provenance(machine=None, **extra) -> dict:
    """Package version and resolved config (SI) recorded with every output."""
    out = {"package": "berryshaker", "version": __version__}
    if machine is not None:
        out["machine_si"] = machine.model_dump(mode="json")
    out.update(extra)
    return out


def write_provenance(folder: str | Path, machine=None, **extra) -> None:
    """``provenance.json`` (package version, resolved config in SI, extra inputs) beside outputs."""
    write_json_atomic(Path(folder) / "provenance.json", provenance(machine, **extra))
