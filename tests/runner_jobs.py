"""Tiny module-level run functions for the sweep-runner tests (module-level so worker processes can import
them)."""

from __future__ import annotations

import os
import time


def square(x: float) -> dict:
    """``{"y": x**2}`` at once."""
    return {"y": x * x}


def slow_square(x: float, delay: float = 0.2) -> dict:
    """``{"y": x**2}`` after ``delay`` seconds."""
    time.sleep(delay)
    return {"y": x * x, "pid": os.getpid()}


def fail_on_negative(x: float) -> dict:
    """Raise for a negative ``x``."""
    if x < 0:
        raise ValueError(f"x must be >= 0, got {x}")
    return {"y": x * x}


def counted(x: float, log: str) -> dict:
    """``{"y": x**2}``, appending a line to the file ``log`` each time it really runs."""
    with open(log, "a") as fh:
        fh.write(f"{x}\n")
    return {"y": x * x}


def touch_and_sleep(x: float, folder: str, delay: float = 30.0) -> dict:
    """Create ``folder/started-<pid>-<x>`` (so a test knows the run started), then sleep ``delay`` seconds."""
    open(os.path.join(folder, f"started-{os.getpid()}-{x}"), "w").close()
    time.sleep(delay)
    return {"y": x * x}


def blas_threads(x: float) -> dict:
    """The thread count of every BLAS / OpenMP library loaded in this process (threadpoolctl), after loading
    numpy's and scipy's; ``x`` only makes the job distinct."""
    import numpy  # noqa: F401
    import scipy.linalg  # noqa: F401
    from threadpoolctl import threadpool_info

    from berryshaker.runs.local_pool import _BLAS_BEFORE

    return {"threads": sorted({int(i["num_threads"]) for i in threadpool_info()}),
            "libraries": len(threadpool_info()), "before": dict(_BLAS_BEFORE), "x": x}


def logged(x: float, log: str, tag: str, delay: float = 0.0, gate: str | None = None) -> dict:
    """``{"y": x**2}`` after ``delay`` seconds, appending ``tag`` to the file ``log`` when it ends (the order in
    which runs finished); with ``gate``, it first waits (at most 60 s) until the file ``gate`` exists."""
    t0 = time.monotonic()
    while gate is not None and not os.path.exists(gate) and time.monotonic() - t0 < 60.0:
        time.sleep(0.01)
    time.sleep(delay)
    with open(log, "a") as fh:
        fh.write(f"{tag}\n")
    return {"y": x * x}


def crash(x: float) -> dict:
    """End the worker process at once (a segfault or an out-of-memory kill, as the pool sees it)."""
    os._exit(3)


def write_marker(path: str, text, die_outside: int | None = None) -> None:
    """Write ``text`` to ``path`` (a figure's stand-in); end the process at once when run in another process than
    ``die_outside`` (a worker that dies), raise when ``text`` is "bad" (a figure function with a real error)."""
    if text == "bad":
        raise ValueError("a real error of the figure function")
    if die_outside is not None and os.getpid() != die_outside:
        os._exit(3)
    with open(path, "w") as fh:
        fh.write(f"{text} {os.getpid()}")


def crash_at(x: float, bad: float, delay: float = 0.0) -> dict:
    """``{"y": x**2}`` after ``delay`` seconds; at ``x == bad`` end the worker process at once instead."""
    time.sleep(delay)
    if x == bad:
        os._exit(3)
    return {"y": x * x}


def prime_log(log: str) -> None:
    """A worker prime: append this process's pid to the file ``log``."""
    with open(log, "a") as fh:
        fh.write(f"{os.getpid()}\n")


def prime_fails() -> None:
    """A worker prime that raises."""
    raise RuntimeError("a prime that fails")


def table(n: int, seed: int = 0) -> dict:
    """A float table, an integer vector and a flag array from ``seed`` (numpy arrays in a run's value)."""
    import numpy as np

    rng = np.random.default_rng(seed)
    return {"table": rng.normal(size=(n, 3)) * 1e-7, "counts": np.arange(n, dtype=np.int32),
            "hit": rng.random(n) > 0.5, "names": np.array(["a", "b"])}


def square_tagged(x: float) -> dict:
    """A value whose dict uses the cache's array tag as a key."""
    return {"__ndarray__": x * x}
