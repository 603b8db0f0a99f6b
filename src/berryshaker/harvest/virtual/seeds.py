"""Seeds of the virtual tests: one seed family per description, numbered starts, and one independent stream per kind
of draw of a start (docs/harvest.md, "Replicates").

A **family** is the description's ``harvest.seed``; a **start** is numbered k = 0, 1, 2, ... within it; every draw a
start makes comes from its own stream, ``numpy.random.SeedSequence(entropy=harvest.seed, spawn_key=(k, stream,
*extra))`` (numpy's spawning: every (family, key) gives a statistically independent generator, O'Neill 2015, PCG;
numpy's SeedSequence documentation).  The streams:

* :data:`MACHINE` ``(k, MACHINE, c)``: the machine start of branch class c (clearance eccentricities, drive phase
  at which the class's branch meets the comb); start k's one drive-past starts from one class's and carries every
  class's branch where it meets the comb at its own phase (berryshaker.harvest.virtual.class_tables_run);
* :data:`FIELD` ``(k, FIELD)``: the bushes and fruit one field test passes, and every fruit's outcome (picked,
  bruised) that is counted;
* :data:`ROWS` ``(k, ROWS)``: the machine-only starts of the clearance rows;
* :data:`MODEL_CHECK` ``(k, MODEL_CHECK, level)``: the model check's starts (both models);
* :data:`POWERED` ``(k, POWERED, level)``: the powered drive's starts.

Keys of different streams never coincide, and no key is a prefix-padded copy of another (an integer seed s and the
tuple (s, 0) give numpy the same entropy, so seeding one draw with s and another with (s, 0) draws both from one
stream).  A run function receives its key as a list of ints (JSON, the runner's cache key) and builds its generator
with :func:`seed_sequence`.
"""

from __future__ import annotations

import numpy as np

#: the streams of a start (the second element of a spawn key)
MACHINE, FIELD, ROWS, MODEL_CHECK, POWERED = 1, 2, 3, 4, 5
#: first start number of the starts that calibration checks and synthetic field sheets draw (never a training or
#: L9 start: those are numbered from 0 and bounded by ``harvest.max_replicates`` <= 1000)
FRESH_STARTS = 1_000_000


def start_numbers(count: int, first: int = 0) -> list[int]:
    """The numbers of ``count`` starts of a family, from ``first``.

    Parameters
    ----------
    count : int
        Starts (>= 0).
    first : int
        Number of the first start.

    Returns
    -------
    list of int
        ``first .. first + count - 1``.
    """
    return list(range(int(first), int(first) + int(count)))


def seed_sequence(family: int, key) -> np.random.SeedSequence:
    """The seed sequence of spawn key ``key`` in seed family ``family``.

    Parameters
    ----------
    family : int
        The family's entropy (``harvest.seed``).
    key : sequence of int
        Spawn key, e.g. ``(k, MACHINE, c)`` (module docstring).

    Returns
    -------
    numpy.random.SeedSequence
        ``SeedSequence(family, spawn_key=tuple(key))``.
    """
    return np.random.SeedSequence(int(family), spawn_key=tuple(int(x) for x in key))


def stream(family: int, start: int, kind: int, *extra: int) -> np.random.Generator:
    """The generator of stream ``kind`` of start ``start`` in family ``family``.

    Parameters
    ----------
    family : int
        The family's entropy (``harvest.seed``).
    start : int
        Start number k.
    kind : int
        One of the streams (:data:`MACHINE`, :data:`FIELD`, ...).
    *extra : int
        Further key elements (the branch class, the model-check level).

    Returns
    -------
    numpy.random.Generator
        PCG64 seeded with :func:`seed_sequence` of ``(start, kind, *extra)``.
    """
    return np.random.default_rng(seed_sequence(family, (start, kind, *extra)))
