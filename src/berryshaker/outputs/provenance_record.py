"""What every output records about where it came from: the package version, the code fingerprint (sha256 of the
package's source, also the run cache's key) and the resolved machine description in SI (``provenance.json``).
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

from berryshaker import __version__
from berryshaker.outputs.atomic_files import write_json_atomic


def provenance(machine=None, **extra) -> dict:
    """Package version, code fingerprint and resolved config (SI) recorded with every output.

    Parameters
    ----------
    machine : MachineBase, optional
        The machine description the output was made from.
    **extra
        Further inputs to record.

    Returns
    -------
    dict
        The provenance (JSON-ready).
    """
    out = {"package": "berryshaker", "version": __version__, "code_sha256": code_fingerprint()}
    if machine is not None:
        out["machine_si"] = machine.model_dump(mode="json")
    out.update(extra)
    return out


def write_provenance(folder: str | Path, machine=None, **extra) -> None:
    """``provenance.json`` (package version, resolved config in SI, extra inputs) beside outputs.

    Parameters
    ----------
    folder : str or Path
        Where to write it.
    machine : MachineBase, optional
        The machine description the outputs were made from.
    **extra
        Further inputs to record.
    """
    write_json_atomic(Path(folder) / "provenance.json", provenance(machine, **extra))


@functools.lru_cache(maxsize=None)
def code_fingerprint() -> str:
    """sha256 over every ``.py`` file of the installed berryshaker package (relative path and content,
    sorted by path); computed once per process.  Any edit to the code gives new cache keys."""
    import berryshaker

    root = Path(berryshaker.__file__).resolve().parent
    h = hashlib.sha256()
    for p in sorted(root.rglob("*.py"), key=lambda q: q.relative_to(root).as_posix()):
        if "__pycache__" in p.parts:
            continue
        h.update(p.relative_to(root).as_posix().encode() + b"\0")
        h.update(p.read_bytes() + b"\0")
    return h.hexdigest()
