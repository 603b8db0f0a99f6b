"""A calibration saved to its output folder and read back (``berryshaker calibrate --from DIR --predict ...``): the
trained emulator (every Gaussian process's training data and fitted hyperparameters), the posterior draws, the
sheet's statistics and the settings' coding, in one ``calibration_state.npz`` (numpy arrays only, read with
``allow_pickle=False``: nothing in the file is executed) beside ``calibration.json``.

Reading it back rebuilds the same emulator without refitting, so predictions from a saved calibration are those
the calibration itself would make with the same draws.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from berryshaker.errors import ConfigError

#: the state file in a calibration's output folder
STATE_FILE = "calibration_state.npz"
#: its format: a file of another format is refused with the fix
STATE_FORMAT = 1


def _flatten(obj, prefix: str, arrays: dict, meta):
    """Arrays of a nested state into ``arrays`` (keys joined with '/'), everything else into the returned JSON."""
    if isinstance(obj, np.ndarray):
        arrays[prefix] = obj
        return {"__array__": prefix}
    if isinstance(obj, dict):
        return {k: _flatten(v, f"{prefix}/{k}", arrays, meta) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_flatten(v, f"{prefix}/{i}", arrays, meta) for i, v in enumerate(obj)]
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    return obj


def _unflatten(obj, arrays):
    if isinstance(obj, dict):
        if set(obj) == {"__array__"}:
            return np.asarray(arrays[obj["__array__"]])
        return {k: _unflatten(v, arrays) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_unflatten(v, arrays) for v in obj]
    return obj


def save_state(path: Path, state: dict) -> None:
    """Write a calibration's state (nested dicts and lists of arrays and JSON values) to ``path`` (an .npz).

    Parameters
    ----------
    path : Path
        The file (written whole: the caller stages it, berryshaker.outputs).
    state : dict
        The state (:func:`berryshaker.study.field_calibration.workflow.calibrate`'s ``state_out``).
    """
    arrays: dict = {}
    tree = _flatten(state, "s", arrays, None)
    header = json.dumps({"format": STATE_FORMAT, "tree": tree}, allow_nan=False)
    with open(path, "wb") as fh:
        np.savez_compressed(fh, __header__=np.frombuffer(header.encode(), dtype=np.uint8), **arrays)


def load_state(folder: Path) -> dict:
    """The state of the calibration saved in ``folder`` (:data:`STATE_FILE`).

    Parameters
    ----------
    folder : Path
        A ``berryshaker calibrate --out`` folder.

    Returns
    -------
    dict
        The state as :func:`save_state` took it.

    Raises
    ------
    ConfigError
        No state file there, or one this version cannot read.
    """
    p = Path(folder) / STATE_FILE
    if not p.is_file():
        raise ConfigError(f"--from {folder}: no {STATE_FILE} there; give the --out folder of a calibrate run "
                          "(berryshaker 0.2 or later)")
    try:
        with np.load(p, allow_pickle=False) as data:
            header = json.loads(bytes(data["__header__"]).decode())
            arrays = {k: data[k] for k in data.files if k != "__header__"}
    except (OSError, ValueError, KeyError) as exc:
        raise ConfigError(f"--from {folder}: {STATE_FILE} cannot be read ({exc}); run calibrate again with --out")
    if header.get("format") != STATE_FORMAT:
        raise ConfigError(f"--from {folder}: {STATE_FILE} has format {header.get('format')!r}, this version reads "
                          f"{STATE_FORMAT}; run calibrate again with --out")
    return _unflatten(header["tree"], arrays)
