"""Best-of-N CPU time of a call, the one timer of the before/after benchmark scripts (never a timed test)."""

from __future__ import annotations

import math
import time


def best_cpu_time(fn, repeat: int):
    """``(result, seconds)``: the result of the last call and the least CPU time (``time.process_time``) of
    ``repeat`` calls of ``fn()``, after one warm-up call (numba compilation or cache load, first allocations)."""
    out, cpu = fn(), math.inf
    for _ in range(repeat):
        c0 = time.process_time()
        out = fn()
        cpu = min(cpu, time.process_time() - c0)
    return out, cpu
