"""Runs started by a script: whether worker processes can start without running the script again.

Under the ``spawn`` and ``forkserver`` start methods (berryshaker's default, :mod:`berryshaker.runs.local_pool`)
every worker process imports the main module again before it runs anything, as ``__mp_main__``
(Python's "Safe importing of main module", https://docs.python.org/3/library/multiprocessing.html).  A script
whose top level calls :func:`berryshaker.api.sweep` without the ``if __name__ == "__main__":`` idiom would then
start the sweep again in every worker; multiprocessing refuses that with a bootstrapping error, the workers die
and every run fails.

:func:`unguarded_main_line` finds such a call before any worker starts (the runner then runs the map in its own
process, :class:`berryshaker.runs.runner.SweepRunner`); :func:`leave_if_bootstrapping` ends, at once and with one
line, a worker that meets one while it imports the script (a case the first check missed); the pool then fails
fast with :class:`WorkerStartError` (:meth:`berryshaker.runs.local_pool.LocalPool.run`).
"""

from __future__ import annotations

import ast
import multiprocessing
import os
import sys
from functools import lru_cache

from berryshaker.errors import BerryshakerError

#: the idiom a script needs to run its runs on several cores, as the messages and docs/python_api.md show it
SCRIPT_IDIOM = 'put the script\'s work under `if __name__ == "__main__":`'
#: exit code of a worker process that met runs being started while it imported the main script
BOOTSTRAP_EXIT_CODE = 3


class WorkerStartError(BerryshakerError):
    """The local pool's worker processes ended before any of them started (while importing the main module)."""


def _is_main_test(node: ast.expr) -> bool:
    """``__name__ == "__main__"`` (either side)."""
    if not (isinstance(node, ast.Compare) and len(node.ops) == 1 and isinstance(node.ops[0], ast.Eq)):
        return False
    sides = (node.left, node.comparators[0])
    names = [s for s in sides if isinstance(s, ast.Name) and s.id == "__name__"]
    texts = [s for s in sides if isinstance(s, ast.Constant) and s.value == "__main__"]
    return len(names) == 1 and len(texts) == 1


@lru_cache(maxsize=8)
def _guarded_lines(path: str, mtime_ns: int) -> tuple[tuple[int, int], ...] | None:
    """The line ranges of the bodies of ``if __name__ == "__main__":`` blocks in the file ``path``; None when it
    cannot be read or parsed (``mtime_ns`` keys the cache)."""
    try:
        with open(path, encoding="utf-8") as fh:
            tree = ast.parse(fh.read(), filename=path)
    except (OSError, SyntaxError, ValueError, UnicodeDecodeError):
        return None
    return tuple((n.body[0].lineno, n.body[-1].end_lineno or n.body[-1].lineno)
                 for n in ast.walk(tree) if isinstance(n, ast.If) and _is_main_test(n.test))


def unguarded_main_line(start_method: str) -> tuple[str, int] | None:
    """Where the main script calls this code outside ``if __name__ == "__main__":``, if worker processes started
    with ``start_method`` would run that line again.

    The workers of ``spawn`` and ``forkserver`` import the main module again when it is a file (a script, or
    ``python -m``); ``fork`` copies the process and an interactive session or ``python -c`` has no file to import.
    The outermost frame of the main module's top-level code on the call stack is the line that leads here; it is
    safe when it lies in the body of an ``if __name__ == "__main__":`` block of that file.

    Parameters
    ----------
    start_method : str
        ``forkserver``, ``spawn`` or ``fork``.

    Returns
    -------
    tuple of (str, int) or None
        The script's path and the line, or None when starting workers is safe (or the source cannot be read: the
        workers then meet :func:`leave_if_bootstrapping`).
    """
    if start_method == "fork" or multiprocessing.parent_process() is not None:
        return None
    main = sys.modules.get("__main__")
    main_file = getattr(main, "__file__", None)
    spec = getattr(main, "__spec__", None)
    if main is None or (main_file is None and getattr(spec, "name", None) is None):
        return None
    frame, found = sys._getframe(1), None
    while frame is not None:
        if frame.f_globals is main.__dict__ and frame.f_code.co_name == "<module>":
            found = frame
        frame = frame.f_back
    if found is None:
        return None
    path, line = found.f_code.co_filename, found.f_lineno
    try:
        mtime = os.stat(path).st_mtime_ns
    except OSError:
        return None
    guarded = _guarded_lines(path, mtime)
    if guarded is None or any(lo <= line <= hi for lo, hi in guarded):
        return None
    return path, line


def in_bootstrap() -> bool:
    """Whether this process is a worker still importing the main module (multiprocessing's bootstrapping phase).

    Returns
    -------
    bool
        True while a ``spawn`` or ``forkserver`` child prepares itself.
    """
    return bool(getattr(multiprocessing.current_process(), "_inheriting", False))


def leave_if_bootstrapping() -> None:
    """End this process with one line on stderr if it is a worker that is importing the main script and met runs
    being started (the script lacks the ``if __name__ == "__main__":`` idiom): its parent's pool then reports
    :class:`WorkerStartError` instead of every run failing after retries."""
    if in_bootstrap():
        print(f"berryshaker: a worker process imported the main script and met runs started there; {SCRIPT_IDIOM}",
              file=sys.stderr, flush=True)
        os._exit(BOOTSTRAP_EXIT_CODE)


def worker_start_message(start_method: str, lost: int) -> str:
    """The message of :class:`WorkerStartError`.

    Parameters
    ----------
    start_method : str
        The pool's start method.
    lost : int
        Runs that could not run.

    Returns
    -------
    str
        What happened and the two fixes.
    """
    main = sys.modules.get("__main__")
    script = getattr(main, "__file__", None)
    where = f" ({script})" if script else ""
    return (f"the worker processes ended before any of them started, so {lost} run(s) could not run: under the "
            f"'{start_method}' start method each worker imports the main script{where} again, and a script that "
            f"starts runs at its top level starts them again there.  {SCRIPT_IDIOM[0].upper()}{SCRIPT_IDIOM[1:]} "
            "(docs/python_api.md, 'Scripts'), or pass workers=1 to run in this process")
