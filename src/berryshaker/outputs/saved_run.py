"""A run saved by ``berryshaker simulate --out DIR``, read back: its time series (``timeseries.csv``, the unit of
every column at the end of its name: ``F_A_N``, ``drive_moment_Nm``, ``theta_D_rad``) and its summary
(``summary.json``: the resolved machine in SI, the clearances, the model and the revolutions).

Read strictly, as every input: only regular files of bounded size, a header of names with a known unit, a row of
finite numbers per sample, times increasing; anything else is an error naming the file and the line.
"""

from __future__ import annotations

import json
import os
import stat
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from berryshaker.errors import ConfigError

#: the unit written at the end of a column's name -> the unit printed on an axis
UNIT_SUFFIXES = {"Nm": "N m", "N": "N", "m": "m", "rad": "rad", "deg": "deg", "s": "s", "rpm": "r/min"}
#: the files of a saved run, and the largest of each read (a 100-revolution MLSD run is about 150 MB of CSV)
SERIES_FILE, SUMMARY_FILE = "timeseries.csv", "summary.json"
MAX_SERIES_BYTES, MAX_SUMMARY_BYTES = 1_000_000_000, 10_000_000


def split_unit(column: str) -> tuple[str, str]:
    """A column's name without its unit, and the unit (:data:`UNIT_SUFFIXES`).

    Parameters
    ----------
    column : str
        E.g. ``"F_A_N"``, ``"crank.angle_rad"``.

    Returns
    -------
    (str, str)
        E.g. ``("F_A", "N")``, ``("crank.angle", "rad")``.

    Raises
    ------
    ConfigError
        The name does not end in a known unit.
    """
    base, _, suffix = column.rpartition("_")
    if not base or suffix not in UNIT_SUFFIXES:
        raise ConfigError(f"column {column!r} does not end in a unit (_{', _'.join(UNIT_SUFFIXES)}): not a "
                          "berryshaker simulate --out series")
    return base, UNIT_SUFFIXES[suffix]


@dataclass(frozen=True)
class SavedRun:
    """A saved run: its signals (SI, one array per column) and its summary.

    Attributes
    ----------
    folder : Path
        The run's folder.
    signals : dict
        Column name (as written, with its unit) -> values (SI), in file order; ``time_s`` first.
    summary : dict
        ``summary.json``.
    """

    folder: Path
    signals: dict[str, np.ndarray] = field(repr=False)
    summary: dict = field(repr=False)

    def names(self) -> list[str]:
        """The signals' names without their units (what ``--x`` and ``--y`` take).

        Returns
        -------
        list of str
            E.g. ``["time", "cam_angle", "x", ..., "F_A", ...]``.
        """
        return [split_unit(c)[0] for c in self.signals]

    def column(self, name: str) -> str:
        """The column a name given on the command line means: the column itself (``F_A_N``) or its name without
        the unit (``F_A``); case-insensitive when that is unambiguous.

        Parameters
        ----------
        name : str
            The name given.

        Returns
        -------
        str
            The column's name as written.

        Raises
        ------
        ConfigError
            No such signal (the message lists them).
        """
        if name in self.signals:
            return name
        bases = {split_unit(c)[0]: c for c in self.signals}
        if name in bases:
            return bases[name]
        folded = [c for b, c in bases.items() if b.lower() == name.lower() or c.lower() == name.lower()]
        if len(folded) == 1:
            return folded[0]
        raise ConfigError(f"{name!r} is not a signal of the run in {self.folder}; its signals: "
                          f"{', '.join(self.names())}")


def _regular_file(path: Path, limit: int) -> Path:
    try:
        st = path.stat()
    except FileNotFoundError:
        raise ConfigError(f"{path} is missing: give the folder of a run written by berryshaker simulate --out DIR "
                          "(it holds timeseries.csv and summary.json)") from None
    if not stat.S_ISREG(st.st_mode):
        raise ConfigError(f"{path} is not a regular file")
    if st.st_size > limit:
        raise ConfigError(f"{path}: {st.st_size} bytes is more than a saved run holds (limit {limit} bytes)")
    return path


def _read_series(path: Path) -> dict[str, np.ndarray]:
    with open(path, encoding="utf-8", newline="") as fh:
        header = fh.readline().rstrip("\r\n").split(",")
        for c in header:
            split_unit(c)  # every column has its unit
        if header[0] != "time_s" or len(set(header)) != len(header):
            raise ConfigError(f"{path}: the first column must be time_s and every column named once; not a "
                              "berryshaker simulate --out series")
        try:
            data = np.loadtxt(fh, delimiter=",", ndmin=2, dtype=float, comments=None)
        except ValueError as exc:  # numpy names the line and the value
            raise ConfigError(f"{path}: {exc}") from None
    if data.shape[0] < 2 or data.shape[1] != len(header):
        raise ConfigError(f"{path}: {data.shape[0]} samples of {data.shape[1]} values for {len(header)} columns; "
                          "expected at least two samples of one value per column")
    bad = np.argwhere(~np.isfinite(data))
    if len(bad):
        raise ConfigError(f"{path}, line {int(bad[0][0]) + 2}: a value that is not finite ({header[bad[0][1]]})")
    if not np.all(np.diff(data[:, 0]) > 0):
        raise ConfigError(f"{path}: the times (time_s) do not increase")
    return {c: data[:, k] for k, c in enumerate(header)}


def read_saved_run(folder: str | Path) -> SavedRun:
    """Read the run ``simulate --out`` wrote to ``folder``.

    Parameters
    ----------
    folder : str or Path
        The run's folder.

    Returns
    -------
    SavedRun
        Its signals and summary.

    Raises
    ------
    ConfigError
        Not such a folder, a file missing, too large or not a regular file, a column without its unit, a value
        that is not a finite number, times that do not increase; the message names the file (and the line).
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise ConfigError(f"{folder} is not a folder: give the folder of a run written by berryshaker simulate "
                          "--out DIR")
    summary_path = _regular_file(folder / SUMMARY_FILE, MAX_SUMMARY_BYTES)
    try:
        summary = json.loads(summary_path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ConfigError(f"{summary_path}: not the JSON simulate writes ({type(exc).__name__})") from None
    if not isinstance(summary, dict):
        raise ConfigError(f"{summary_path}: not the JSON simulate writes (expected an object)")
    signals = _read_series(_regular_file(folder / SERIES_FILE, MAX_SERIES_BYTES))
    return SavedRun(Path(os.path.abspath(folder)), signals, summary)
