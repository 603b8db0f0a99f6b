"""The sweep runner's Dask backend: runs on a Dask distributed cluster when a scheduler address is given.

Runs go to the cluster as tasks (one run each); the workers read the cache (a shared disk, if any) but do not
write it: the client stores every finished run (:class:`DaskBackend`).  A
worker lost mid-run is Dask's to handle (its runs go to another worker, up to ``retries``); a lost scheduler ends
the map with :class:`SchedulerLost` (never a "failed" run), the finished runs stored.
"""

from __future__ import annotations

from typing import Callable
from urllib.parse import urlsplit

from berryshaker.runs.jobs import failed_outcome, run_jobs

#: Seconds to wait for a Dask scheduler before giving up with a ConfigError.
SCHEDULER_TIMEOUT_S = 5.0
_DASK_SCHEMES = ("tcp", "tls", "ucx", "ws", "wss", "inproc")


def check_scheduler_address(address: str) -> str:
    """Validate a Dask scheduler address without connecting.

    Parameters
    ----------
    address : str
        ``tcp://host:port``, ``host:port``, ``tls://...``, ``inproc://...``.

    Returns
    -------
    str
        The address with its protocol (``tcp://`` when none is given).

    Raises
    ------
    ConfigError
        Empty, unreadable, an unknown protocol, or no host and port.
    """
    from berryshaker.errors import ConfigError

    addr = (address or "").strip()
    hint = "give the scheduler as tcp://HOST:PORT (e.g. tcp://10.0.0.5:8786), or omit --scheduler to run locally"
    if not addr:
        raise ConfigError(f"--scheduler is empty; {hint}")
    full = addr if "://" in addr else f"tcp://{addr}"
    try:
        parts = urlsplit(full)
        port = parts.port
    except ValueError:
        raise ConfigError(f"--scheduler {address!r} is not a valid address; {hint}") from None
    if parts.scheme not in _DASK_SCHEMES:
        raise ConfigError(f"--scheduler {address!r}: unknown protocol {parts.scheme!r} "
                          f"(use one of {', '.join(_DASK_SCHEMES)}); {hint}")
    if parts.scheme != "inproc" and (not parts.hostname or port is None or parts.path not in ("", "/")
                                     or parts.query or parts.fragment):
        raise ConfigError(f"--scheduler {address!r} needs a host and a port; {hint}")
    return full


def connect(scheduler: str | None, timeout_s: float = SCHEDULER_TIMEOUT_S):
    """A client of the Dask scheduler.

    Parameters
    ----------
    scheduler : str or None
        The scheduler's address (:func:`check_scheduler_address`).
    timeout_s : float
        Seconds to wait for it (s).

    Returns
    -------
    distributed.Client
        Connected.

    Raises
    ------
    ConfigError
        No scheduler given, dask.distributed not installed, or no scheduler answered within ``timeout_s``.
    """
    from berryshaker.errors import ConfigError

    if scheduler is None:
        raise ConfigError("no --scheduler given")
    try:
        from distributed import Client
    except ImportError:
        raise ConfigError("--scheduler needs dask.distributed (pip install 'dask[distributed]')") from None
    import logging

    quiet = [logging.getLogger(n) for n in ("distributed.client", "distributed.comm.core", "distributed.core")]
    levels = [lg.level for lg in quiet]
    for lg in quiet:
        lg.setLevel(logging.CRITICAL)
    try:
        return Client(scheduler, timeout=f"{timeout_s}s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise ConfigError(f"--scheduler {scheduler}: no Dask scheduler answered within "
                          f"{timeout_s:g} s ({type(exc).__name__}); check that `dask scheduler` "
                          "runs there and the host and port, or omit --scheduler to run locally") from None
    finally:
        for lg, lv in zip(quiet, levels):
            lg.setLevel(lv)


class SchedulerLost(Exception):
    """The Dask scheduler went away while a map's runs were on the cluster (its connection lost, the runs
    cancelled): not a failure of any run.  The runner turns it into one message naming the runs not finished
    (:meth:`berryshaker.runs.runner.SweepRunner.map`).

    Parameters
    ----------
    reason : str
        What Dask said, in a few words (e.g. ``"scheduler-connection-lost"``).
    """

    def __init__(self, reason: str):
        super().__init__(reason)
        self.reason = reason


#: the loggers whose tracebacks a lost scheduler prints (silenced while a map runs: the runner says it in one line)
_QUIET = ("distributed", "tornado", "asyncio")


class DaskBackend:
    """Runs a map's jobs on a Dask cluster; the workers read the cache, the client stores each finished run.

    Parameters
    ----------
    connect : callable
        Returns a connected client (:func:`connect`); it is closed after the map.
    """

    def __init__(self, connect: Callable):
        self._connect = connect

    def run(self, ctx: dict, finish: Callable) -> None:
        """Run every job of the map on the cluster; Ctrl-C or an error cancels the tasks sent.

        Parameters
        ----------
        ctx : dict
            The map's state (see :mod:`berryshaker.runs.jobs`).
        finish : callable
            Called with each outcome as its task completes.
        """
        import logging
        from concurrent.futures import CancelledError

        from distributed import as_completed

        client = self._connect()
        futs = {}
        loggers = [logging.getLogger(n) for n in list(logging.root.manager.loggerDict)
                   if n.split(".")[0] in _QUIET] + [logging.getLogger(n) for n in _QUIET]
        levels = [lg.level for lg in loggers]
        for lg in loggers:
            lg.setLevel(logging.CRITICAL + 1)
        try:
            keys = list(ctx["jobs"])
            for k in keys:
                f = client.submit(run_jobs, ctx["fn"], [(k, ctx["jobs"][k])], ctx["cache"], ctx["fp"], False,
                                  key=f"berryshaker-{k}-1", pure=False, retries=3)
                futs[f] = [k]
            for f in as_completed(list(futs)):
                chunk = futs[f]
                try:
                    outs = f.result()
                except CancelledError as exc:  # the scheduler is gone (or cancelled the runs): nothing failed
                    raise SchedulerLost(getattr(exc, "reason", None) or "its runs were cancelled") from None
                except Exception as exc:  # noqa: BLE001 - a run that raised, or lost beyond its retries
                    if client.status not in ("running", "newly-created"):
                        raise SchedulerLost(f"the client's connection is {client.status}") from None
                    outs = [failed_outcome(k, f"{type(exc).__name__}: {exc}") for k in chunk]
                for out in outs:
                    finish(out)
        except BaseException:
            try:
                client.cancel(list(futs), force=True)
            except Exception:  # noqa: BLE001 - best effort while stopping
                pass
            raise
        finally:
            try:
                client.close(timeout=2)
            except Exception:  # noqa: BLE001 - a client whose scheduler is gone may not close cleanly
                pass
            for lg, lv in zip(loggers, levels):
                lg.setLevel(lv)
