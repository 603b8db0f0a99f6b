"""Faults of a Dask cluster on loopback (issue 59): a lost scheduler used to end the sweep with exit 0, distributed's
traceback on stderr and twelve multi-line FutureCancelledError messages as "failed" rows; now it is one error
naming the rows that did not finish, the finished ones cached, so the same map resumes.  A worker killed mid-map
loses nothing: its runs are computed again elsewhere and every value is right."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest
import runner_jobs

from berryshaker.errors import SimulationError
from berryshaker.runs.runner import SweepRunner

distributed = pytest.importorskip("distributed")

JOBS = [{"x": float(i), "delay": 0.4} for i in range(12)]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _cluster_process(port: int) -> subprocess.Popen:
    """A scheduler with one two-thread worker (in the same child process) on 127.0.0.1:``port``; killing the child
    loses the scheduler at once."""
    code = textwrap.dedent(f"""
        import time
        import distributed
        cluster = distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, host="127.0.0.1",
                                           scheduler_port={port}, dashboard_address=None)
        print("ready", flush=True)
        time.sleep(600)
    """)
    tests = str(Path(__file__).resolve().parents[1])
    src = str(Path(__file__).resolve().parents[2] / "src")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([src, tests, os.environ.get("PYTHONPATH", "")]))
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                         env=env)
    assert p.stdout.readline().strip() == "ready"
    return p


def test_a_lost_scheduler_is_one_error_naming_the_unfinished_rows_and_the_map_resumes(tmp_path, capfd):
    port = _free_port()
    cluster = _cluster_process(port)
    try:
        r = SweepRunner(scheduler=f"127.0.0.1:{port}", cache_dir=tmp_path / "cache", progress=False)
        threading.Timer(1.5, cluster.kill).start()  # the scheduler goes away mid-map
        with pytest.raises(SimulationError) as lost:
            r.map(runner_jobs.slow_square, JOBS)
    finally:
        cluster.kill()
        cluster.wait()
    msg = str(lost.value)
    assert f"the Dask scheduler tcp://127.0.0.1:{port} was lost" in msg and "run the same command again" in msg
    assert "\n" not in msg and "did not finish (rows " in msg, msg
    err = capfd.readouterr().err
    assert "Traceback" not in err and "FutureCancelledError" not in err, err
    done = r.stats["computed"]
    assert 0 < done < len(JOBS), r.stats
    port = _free_port()  # a new scheduler: the finished runs come from the cache
    cluster = _cluster_process(port)
    try:
        again = SweepRunner(scheduler=f"127.0.0.1:{port}", cache_dir=tmp_path / "cache", progress=False)
        out = again.map(runner_jobs.slow_square, JOBS)
    finally:
        cluster.kill()
        cluster.wait()
    assert [o.value["y"] for o in out] == [j["x"] ** 2 for j in JOBS]
    assert again.stats["cached"] == done and not any(o.error for o in out)


def test_a_killed_worker_loses_no_run(tmp_path):
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  host="127.0.0.1") as cluster, distributed.Client(cluster) as client:
        victim = next(iter(client.run(os.getpid).values()))
        threading.Timer(1.2, os.kill, (victim, signal.SIGKILL)).start()
        t0 = time.monotonic()
        r = SweepRunner(scheduler=cluster.scheduler_address, cache_dir=tmp_path / "cache", progress=False)
        out = r.map(runner_jobs.slow_square, JOBS)
        assert time.monotonic() - t0 > 1.2  # the worker died while the map ran
    assert not any(o.error for o in out), [o.error for o in out if o.error]
    assert [o.value["y"] for o in out] == [j["x"] ** 2 for j in JOBS]
