"""Orthogonal arrays for field tests: L4(2^3), L8(2^7), L9(3^4), L16(4^5), L18(2^1 3^7), L27(3^13).

L4, L8, L9 and L16(4^5) come from pyDOE3 (a maintained design-of-experiments library).  pyDOE3's L18 is
the 6^1 3^6 variant and its L27 the 2^1 3^12 one, so the two classical Taguchi arrays are built here by
their standard constructions: L18(2^1 3^7) splits the 6-level column of L18(6^1 3^6) into a 2-level and
a 3-level column (6 = 2 x 3 levels; each pair of the split columns is balanced), and L27(3^13) takes the
13 non-proportional linear combinations of three base columns over GF(3) (Bose 1938; Hedayat, Sloane &
Stufken, *Orthogonal Arrays*, 1999, sec. 3.1).  Every array is checked for strength 2 (tested).
Levels are 0-based here and 1-based in field sheets.
"""

from __future__ import annotations

import itertools

import numpy as np

from berryshaker.errors import ConfigError

ARRAYS = {
    "L4": "L4(2^3)",
    "L8": "L8(2^7)",
    "L9": "L9(3^4)",
    "L16": "L16(4^5)",
    "L18": "L18(2^1 3^7)",
    "L27": "L27(3^13)",
}


def _l27() -> np.ndarray:
    base = np.array(list(itertools.product(range(3), repeat=3)))  # 27 x 3
    vecs = []
    for t in itertools.product(range(3), repeat=3):
        v = np.array(t)
        if not v.any():
            continue
        if v[np.nonzero(v)[0][0]] != 1:  # one representative per line through the origin
            continue
        vecs.append(v)
    vecs.sort(key=lambda v: (np.count_nonzero(v), tuple(v[::-1])))
    return np.array([(base @ v) % 3 for v in vecs]).T


def orthogonal_array(name: str) -> np.ndarray:
    """The array (runs x columns, levels 0-based) by short (``"L9"``) or full (``"L9(3^4)"``) name.

    Parameters
    ----------
    name : str
        L4, L8, L9, L16, L18 or L27, with or without its full designation.

    Returns
    -------
    ndarray of int, shape (runs, columns)
        Level codes 0, 1, 2... of each run in each column.
    """
    key = name.strip().upper().split("(")[0]
    if key not in ARRAYS:
        raise ConfigError(f"unknown orthogonal array {name!r}; choose one of {', '.join(ARRAYS)}")
    if key == "L27":
        return _l27()
    import pyDOE3

    if key == "L18":
        a = np.asarray(pyDOE3.get_orthogonal_array("L18(6^1 3^6)"), int)
        a = a - a.min(axis=0)
        six = a[:, 0]
        return np.column_stack([six // 3, six % 3, a[:, 1:]])
    a = np.asarray(pyDOE3.get_orthogonal_array(ARRAYS[key]), int)
    return a - a.min(axis=0)


def is_orthogonal(array) -> bool:
    """Strength-2 orthogonality: in every pair of columns every level combination occurs equally often.

    Parameters
    ----------
    array : array_like of int, shape (runs, columns)
        Level codes.

    Returns
    -------
    bool
        True when the array is orthogonal.
    """
    a = np.asarray(array)
    n = a.shape[0]
    for i, j in itertools.combinations(range(a.shape[1]), 2):
        li, lj = np.unique(a[:, i]), np.unique(a[:, j])
        expected = n / (len(li) * len(lj))
        for x in li:
            for y in lj:
                if np.sum((a[:, i] == x) & (a[:, j] == y)) != expected:
                    return False
    return True


def assign_factors(array_name: str, levels: list[int]) -> list[int]:
    """Columns for factors with the given numbers of levels (first matching columns, left to right).

    Parameters
    ----------
    array_name : str
        The orthogonal array (:func:`orthogonal_array`).
    levels : list of int
        Number of levels of each factor, in order.

    Returns
    -------
    list of int
        The column of each factor.
    """
    a = orthogonal_array(array_name)
    col_levels = [len(np.unique(a[:, j])) for j in range(a.shape[1])]
    used, out = set(), []
    for k, nl in enumerate(levels):
        for j, cl in enumerate(col_levels):
            if j not in used and cl == nl:
                used.add(j)
                out.append(j)
                break
        else:
            raise ConfigError(f"{ARRAYS[array_name.upper().split('(')[0]]} has no free {nl}-level column for "
                              f"factor {k + 1} (columns: {col_levels})")
    return out
