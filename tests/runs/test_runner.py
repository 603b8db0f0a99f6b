"""The sweep runner: code-aware cache keys, validated cache entries, shared-cache reuse, cold-cost stats,
chunked local pools, runs started ahead (prefetch), Ctrl-C and a killed parent, clear errors for bad --workers / --scheduler."""

import functools
import io
import json
import os
import signal
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
import runner_jobs as J

import berryshaker.runs.cache as C
import berryshaker.runs.jobs as JOBS
import berryshaker.runs.runner as R
from berryshaker.errors import ConfigError
from berryshaker.runs.runner import SweepRunner, cache_entry_path, read_cache_entry, run_jobs, run_key

TESTS = Path(__file__).resolve().parents[1]


def _runner(tmp_path, **kw):
    kw.setdefault("workers", 1)
    return SweepRunner(cache_dir=tmp_path / "cache", progress=False, **kw)


def _calls(log: Path) -> int:
    return len(log.read_text().splitlines()) if log.exists() else 0


def _code_fingerprint(monkeypatch, fp: str) -> None:
    """As if the package's code had the fingerprint ``fp``: in the keys (runs.cache) and in the maps (runs.runner)."""
    monkeypatch.setattr(C, "code_fingerprint", lambda: fp)
    monkeypatch.setattr(R, "code_fingerprint", lambda: fp)


def test_key_covers_function_arguments_and_code(monkeypatch):
    k = run_key(J.square, {"x": 1.0})
    assert k == run_key(J.square, {"x": 1.0}) and len(k) == 64
    assert k != run_key(J.square, {"x": 2.0}) and k != run_key(J.slow_square, {"x": 1.0})
    _code_fingerprint(monkeypatch, "0" * 64)
    assert run_key(J.square, {"x": 1.0}) != k


def test_code_fingerprint_is_a_hash_of_the_package_sources():
    import hashlib

    import berryshaker

    root = Path(berryshaker.__file__).resolve().parent
    h = hashlib.sha256()
    for p in sorted(root.rglob("*.py"), key=lambda q: q.relative_to(root).as_posix()):
        if "__pycache__" not in p.parts:
            h.update(p.relative_to(root).as_posix().encode() + b"\0" + p.read_bytes() + b"\0")
    assert R.code_fingerprint() == h.hexdigest()


def test_code_change_invalidates_the_cache(tmp_path, monkeypatch):
    log = tmp_path / "log"
    jobs = [dict(x=float(i), log=str(log)) for i in range(3)]
    assert _runner(tmp_path).values(J.counted, jobs) == [{"y": float(i * i)} for i in range(3)]
    _runner(tmp_path).values(J.counted, jobs)
    assert _calls(log) == 3  # repeated: all from the cache
    _code_fingerprint(monkeypatch, "f" * 64)  # as if a model file had been edited
    r = _runner(tmp_path)
    r.values(J.counted, jobs)
    assert _calls(log) == 6 and r.stats["cached"] == 0


def _entry(tmp_path, fn, kw):
    return cache_entry_path(tmp_path / "cache", run_key(fn, kw))


@pytest.mark.parametrize("damage", ["edit_value", "empty_object", "truncate", "wrong_key", "not_object", "huge_wall",
                                    "deep_header"])
def test_invalid_entry_is_recomputed_with_a_warning(tmp_path, damage, capsys):
    log = tmp_path / "log"
    kw = dict(x=3.0, log=str(log))
    _runner(tmp_path).values(J.counted, [kw])
    path = _entry(tmp_path, J.counted, kw)
    text = path.read_text()
    head, body = text.split("\n", 1)
    entry = json.loads(head)
    if damage == "edit_value":
        path.write_text(head + "\n" + body.replace("9.0", "10.0"))  # hand-edited, checksum no longer matches
    elif damage == "empty_object":
        path.write_text("{}")
    elif damage == "truncate":
        path.write_text(text[: len(text) // 2])
    elif damage == "wrong_key":
        entry["key"] = "0" * 64
        path.write_text(json.dumps(entry) + "\n" + body)
    elif damage == "huge_wall":  # an integer no float holds
        path.write_text(head.replace(f'"wall_s":{json.dumps(entry["wall_s"])}', '"wall_s":' + "9" * 400) + "\n" + body)
    elif damage == "deep_header":
        path.write_text("[" * 100_000 + "\n" + body)
    else:
        path.write_text("[1, 2]")
    r = _runner(tmp_path)
    assert r.values(J.counted, [kw]) == [{"y": 9.0}]
    assert _calls(log) == 2  # recomputed, not used
    assert len(r.warnings) == 1 and str(path) in r.warnings[0] and "recomputing" in r.warnings[0]
    err = capsys.readouterr().err
    assert err.count("warning:") == 1 and str(path) in err
    fresh, problem = read_cache_entry(path, run_key(J.counted, kw), R.code_fingerprint())
    assert problem is None and fresh["value"] == {"y": 9.0}  # overwritten with a valid entry


def test_entry_records_what_computed_it(tmp_path):
    kw = dict(x=2.0, delay=0.05)
    _runner(tmp_path).values(J.slow_square, [kw])
    head, body = _entry(tmp_path, J.slow_square, kw).read_text().split("\n", 1)
    e = json.loads(head)
    assert e["key"] == run_key(J.slow_square, kw) and e["fingerprint"] == R.code_fingerprint()
    assert e["fn"] == "runner_jobs.slow_square" and len(e["kwargs_sha256"]) == 64 and len(e["value_sha256"]) == 64
    assert json.loads(body)["y"] == 4.0 and e["wall_s"] > 0.04  # the job sleeps 0.05 s (no upper bound: a busy host)


def test_arrays_in_a_value_come_back_from_the_cache_bit_for_bit(tmp_path):
    """A run's numpy arrays are stored as their bytes: the cached value equals the computed one bit for bit and has
    the same types (arrays stay arrays, other dtypes become lists), and the entry is smaller than decimal text."""
    import numpy as np

    kw = dict(n=500, seed=3)
    fresh = _runner(tmp_path).values(J.table, [kw])[0]
    cached_runner = _runner(tmp_path)
    cached = cached_runner.values(J.table, [kw])[0]
    assert cached_runner.stats["cached"] == 1
    want = J.table(**kw)
    for v in (fresh, cached):
        assert v["table"].dtype == np.float64 and v["table"].tobytes() == want["table"].tobytes()
        assert v["counts"].dtype == np.int64 and v["counts"].tolist() == list(range(500))
        assert v["hit"].dtype == bool and (v["hit"] == want["hit"]).all() and v["names"] == ["a", "b"]
    assert _entry(tmp_path, J.table, kw).stat().st_size < len(json.dumps(want["table"].tolist()))


def test_a_value_using_the_array_tag_as_a_key_is_an_error_of_the_run(tmp_path):
    out = _runner(tmp_path).map(J.square_tagged, [{"x": 1.0}])[0]
    assert out.value is None and C.ARRAY_TAG in out.error


def test_worker_reuses_an_entry_written_by_another_sweep(tmp_path):
    """The cache is read again right before a job runs: a run another sweep finished meanwhile is reused."""
    log = tmp_path / "log"
    kw = dict(x=5.0, log=str(log))
    key = run_key(J.counted, kw)
    cache = tmp_path / "cache"
    R.write_cache_entry(cache, key, "runner_jobs.counted", kw, {"y": 25.0}, 12.5, R.code_fingerprint())
    out = run_jobs(J.counted, [(key, kw)], str(cache), R.code_fingerprint(), True)
    assert out[0]["cached"] and out[0]["value"] == {"y": 25.0} and out[0]["wall_s"] == 12.5
    assert _calls(log) == 0


def test_runner_rechecks_the_cache_after_its_first_look(tmp_path, monkeypatch):
    """Between the runner's first look and the run, another sweep writes the entry: it is not recomputed."""
    log = tmp_path / "log"
    jobs = [dict(x=float(i), log=str(log)) for i in range(2)]
    r = _runner(tmp_path)
    real = R.read_cache_entry
    looks = []

    def first_look_misses(path, key, fingerprint=None):
        looks.append(key)
        if looks.count(key) == 1:  # the runner's first look; meanwhile "another sweep" finishes the run
            R.write_cache_entry(r.cache_dir, key, "runner_jobs.counted", {}, {"y": -1.0}, 3.0, fingerprint)
            return None, None
        return real(path, key, fingerprint)

    monkeypatch.setattr(R, "read_cache_entry", first_look_misses)  # the map's look ...
    monkeypatch.setattr(JOBS, "read_cache_entry", first_look_misses)  # ... and the run's (runs.jobs.run_jobs)
    out = r.map(J.counted, jobs)
    assert [o.value for o in out] == [{"y": -1.0}] * 2 and all(o.cached for o in out)
    assert _calls(log) == 0 and r.stats["cached"] == 2 and r.stats["computed"] == 0


def test_stats_keep_the_cold_cost(tmp_path):
    jobs = [dict(x=float(i), delay=0.15) for i in range(4)]
    cold = _runner(tmp_path)
    cold.values(J.slow_square, jobs)
    assert cold.stats["computed"] == 4 and cold.stats["compute_s"] > 0.55  # four runs that sleep 0.15 s each
    warm = _runner(tmp_path)
    warm.values(J.slow_square, jobs)
    s = warm.stats
    assert s["cached"] == 4 and s["compute_s"] == 0.0
    assert s["cached_compute_s"] == pytest.approx(cold.stats["compute_s"], rel=1e-9)
    assert s["cold_compute_s"] == pytest.approx(cold.stats["compute_s"], rel=1e-9)
    assert f"cold cost {cold.stats['compute_s']:.1f} s of compute" in warm.summary_line()


def test_failures_are_recorded_not_cached_and_duplicates_run_once(tmp_path):
    jobs = [dict(x=1.0), dict(x=-1.0), dict(x=1.0)]
    r = _runner(tmp_path)
    out = r.map(J.fail_on_negative, jobs)
    assert [o.error is None for o in out] == [True, False, True] and "x must be >= 0" in out[1].error
    assert out[2].value == out[0].value and r.stats["computed"] == 2 and r.stats["failed"] == 1
    again = _runner(tmp_path).map(J.fail_on_negative, jobs)
    assert [o.cached for o in again] == [True, False, True]


def test_chunked_pool_keeps_order_and_per_run_progress(tmp_path):
    from rich.console import Console

    buf = io.StringIO()
    r = SweepRunner(workers=2, cache_dir=tmp_path / "cache", progress=True,
                    console=Console(file=buf, width=120, force_terminal=False))
    jobs = [dict(x=float(i)) for i in range(60)]
    out = r.map(J.square, jobs, label="tiny")
    assert [o.index for o in out] == list(range(60)) and [o.value["y"] for o in out] == [i * i for i in range(60)]
    assert "60/60" in buf.getvalue() and r.stats["computed"] == 60
    assert all(_entry(tmp_path, J.square, kw).is_file() for kw in jobs)  # workers wrote each entry


@pytest.mark.parametrize("use_cache", [True, False], ids=["cache", "no-cache"])
def test_prefetched_runs_are_taken_by_the_map_not_run_again(tmp_path, use_cache):
    log = tmp_path / "calls.log"
    jobs = [dict(x=float(i), log=str(log), tag=f"p{i}", delay=0.02) for i in range(12)]
    with SweepRunner(workers=2, cache_dir=tmp_path / "cache", progress=False, use_cache=use_cache) as r:
        assert r.prefetch(J.logged, jobs) == 12
        assert r.prefetch(J.logged, jobs[:5]) == 0  # queued or started already
        out = r.map(J.logged, jobs)
        assert [o.value["y"] for o in out] == [float(i * i) for i in range(12)] and not any(o.error for o in out)
        assert r.stats["computed"] == 12 and r.stats["cached"] == 0  # this sweep's runs, not cached ones
        assert sorted(log.read_text().split()) == sorted(f"p{i}" for i in range(12))  # each ran once
        assert r.prefetch(J.logged, jobs) == (0 if use_cache else 12)  # finished runs are in the cache


def test_a_maps_own_runs_go_before_queued_prefetched_ones(tmp_path):
    """Deterministic on a busy machine: the prefetched runs wait at a gate until the map has sent its own runs (had
    the chunks in flight finished before, the feeder would rightly have sent more), and the map sends its runs and
    counts them in flight under the lock the feeder takes (it cannot slip a queued chunk in between)."""
    import threading

    log, gate = tmp_path / "order.log", tmp_path / "gate"
    ahead = [dict(x=float(i), log=str(log), tag=f"ahead{i}", delay=0.1, gate=str(gate)) for i in range(40)]
    own = [dict(x=float(i), log=str(log), tag=f"own{i}") for i in range(4)]
    with SweepRunner(workers=2, cache_dir=tmp_path / "cache", progress=False) as r:
        sent = threading.Event()

        def open_gate():  # once two prefetched chunks and the map's four are in flight (or the map went first)
            _wait_for(lambda: sent.is_set() or len(r._local._live) >= 2 + 4, 60)
            gate.touch()

        opener = threading.Thread(target=open_gate, daemon=True)
        r.prefetch(J.logged, ahead)  # chunks of 5: at most one chunk per worker in flight
        opener.start()
        try:
            assert [o.value["y"] for o in r.map(J.logged, own)] == [0.0, 1.0, 4.0, 9.0]
        finally:
            sent.set()
            opener.join()
        done = log.read_text().split()
        last_own = max(done.index(f"own{i}") for i in range(4))
        assert last_own < 4 + 2 * 5, done  # only the chunks already in flight finished first
        # the rest is still queued or running; a map asking for some of it takes it over
        out = r.map(J.logged, ahead[-3:])
        assert [o.value["y"] for o in out] == [37.0 ** 2, 38.0 ** 2, 39.0 ** 2]
        assert r.stats["computed"] == 7
    # close dropped what was still queued: nothing ran twice, not everything ran
    names = log.read_text().split()
    assert len(names) == len(set(names)) and len(names) < 44


def test_abort_ends_runs_started_ahead_at_once(tmp_path):
    log = tmp_path / "order.log"
    ahead = [dict(x=float(i), log=str(log), tag=f"ahead{i}", delay=0.3) for i in range(40)]
    with SweepRunner(workers=2, cache_dir=tmp_path / "cache", progress=False) as r:
        r.prefetch(J.logged, ahead)
        assert _wait_for(lambda: _calls(log) >= 1, 30), "no prefetched run started"
        r.abort()
        n = _calls(log)
        time.sleep(1.0)
        assert _calls(log) == n < 40  # nothing runs on after the abort
        assert r.map(J.logged, ahead[:2])[1].value == {"y": 1.0}  # a new pool serves the next map


def test_a_crash_among_runs_started_ahead_does_not_fail_other_runs(tmp_path):
    with SweepRunner(workers=2, cache_dir=tmp_path / "cache", progress=False) as r:
        r.prefetch(J.slow_square, [dict(x=3.0, delay=1.0)], chunks=1)
        r.prefetch(J.crash, [dict(x=0.0)])  # breaks the pool, and with it the other worker's run
        assert _wait_for(lambda: getattr(r._executor, "_broken", False), 30), "the pool did not break"
        out = r.map(J.slow_square, [dict(x=3.0, delay=1.0)])  # run again on a new pool, not failed
        assert out[0].error is None and out[0].value["y"] == 9.0


def test_a_worker_that_dies_takes_only_its_own_run_down(tmp_path):
    """A run that kills its worker breaks the pool and every run in flight with it: those run again (a new pool,
    then one at a time), and only the run that dies on its own is recorded as failed, with what to do."""
    jobs = [dict(x=float(i), bad=3.0, delay=0.2) for i in range(6)]
    with SweepRunner(workers=2, cache_dir=tmp_path / "cache", progress=False) as r:
        out = r.map(J.crash_at, jobs)
        assert [o.error is None for o in out] == [True, True, True, False, True, True]
        assert out[3].error.startswith(R.WORKER_DEATH) and "ran alone" in out[3].error
        assert [o.value["y"] for o in out if o.error is None] == [0.0, 1.0, 4.0, 16.0, 25.0]
        assert r.stats["failed"] == 1
        assert r.map(J.slow_square, [dict(x=2.0, delay=0.0)])[0].value["y"] == 4.0  # the pool serves on
    assert len(list((tmp_path / "cache").rglob("*.json"))) == 6  # five runs and the last map's


def test_a_pool_that_breaks_while_runs_are_sent_does_not_end_the_map(tmp_path, monkeypatch):
    """The pool breaks between two submissions (a run started ahead died): the runs not sent are run again,
    not the whole map ended with the error."""
    from concurrent.futures.process import BrokenProcessPool

    with SweepRunner(workers=2, cache_dir=tmp_path / "cache", progress=False) as r:
        pool, _ = r._local.pool()
        real, calls = pool.submit, []

        def breaks_once(*args, **kwargs):
            calls.append(1)
            if len(calls) == 2:
                raise BrokenProcessPool("broke while the runs were sent")
            return real(*args, **kwargs)

        monkeypatch.setattr(pool, "submit", breaks_once)
        out = r.map(J.slow_square, [dict(x=float(i), delay=0.0) for i in range(4)])
        assert [o.value["y"] for o in out] == [0.0, 1.0, 4.0, 9.0] and len(calls) > 2


def test_workers_that_die_whatever_they_run_end_the_retries(tmp_path):
    """Every run kills its worker (as an environment that cannot run them would): after three deaths alone in a
    row the rest fail at once, each with the pool's error, instead of a pool per run."""
    jobs = [dict(x=float(i), bad=float(i)) for i in range(6)]
    with SweepRunner(workers=2, cache_dir=tmp_path / "cache", progress=False) as r:
        out = r.map(J.crash_at, jobs)
        assert all(o.error and o.error.startswith(R.WORKER_DEATH) for o in out)
        assert sum("may not start at all" in o.error for o in out) == 3 and r.stats["failed"] == 6
        assert r.map(J.slow_square, [dict(x=2.0, delay=0.0)])[0].value["y"] == 4.0  # a new pool serves on


def test_warm_up_runs_in_a_worker_uncached_and_holds_back_queued_runs(tmp_path):
    log = tmp_path / "order.log"
    ahead = [dict(x=3.0, log=str(log), tag="ahead")]
    with SweepRunner(workers=2, cache_dir=tmp_path / "cache", progress=False) as r:
        w1 = r.warm_up(J.logged, dict(x=1.0, log=str(log), tag="warm1", delay=1.0))
        w2 = r.warm_up(J.logged, dict(x=2.0, log=str(log), tag="warm2", delay=1.0))
        r.prefetch(J.logged, ahead, chunks=1)  # both workers are warming up: it stays queued ...
        time.sleep(0.3)  # (time for the prefetch thread to act: it would have sent it by now)
        own = [dict(x=4.0, log=str(log), tag="own1"), dict(x=5.0, log=str(log), tag="own2")]  # two: to the pool
        assert [o.value["y"] for o in r.map(J.logged, own)] == [16.0, 25.0]
        assert w1.result(timeout=60) == {"y": 1.0} and w2.result(timeout=60) == {"y": 4.0}
        assert r.map(J.logged, ahead)[0].value == {"y": 9.0}
        assert r.stats["computed"] == 3  # a warm-up is not a run: not counted ...
    done = log.read_text().split()
    # ... the map's own runs went first (had the warm-ups not held workers, the queued run would have been sent to
    # the pool at once and run before them)
    assert max(done.index("own1"), done.index("own2")) < done.index("ahead"), done
    assert len(list((tmp_path / "cache").rglob("*.json"))) == 3  # the runs' entries only


def _wait_for_lines(path, n, timeout=60.0):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if path.exists() and len(path.read_text().split()) >= n:
            return path.read_text().split()
        time.sleep(0.05)
    raise AssertionError(f"{path}: fewer than {n} lines after {timeout} s")


def test_start_workers_starts_every_worker_with_its_prime_and_the_runs_use_them(tmp_path):
    log = tmp_path / "primed.log"
    with SweepRunner(workers=2, cache_dir=tmp_path / "cache", progress=False) as r:
        assert r.start_workers(functools.partial(J.prime_log, str(log))) == 2
        pids = set(_wait_for_lines(log, 2))  # before any run: both processes started and primed, once each
        assert len(pids) == 2 and os.getpid() not in {int(p) for p in pids}
        assert r.start_workers() == 0  # the pool is running
        outs = r.map(J.slow_square, [dict(x=float(i), delay=0.2) for i in range(4)])
        assert [o.value["y"] for o in outs] == [0.0, 1.0, 4.0, 9.0]
        assert {str(o.value["pid"]) for o in outs} <= pids  # the runs went to the started workers
        assert r.stats["computed"] == 4  # a prime is not a run
    assert len(log.read_text().split()) == 2


def test_a_failing_prime_is_ignored_and_one_worker_starts_nothing(tmp_path):
    with SweepRunner(workers=2, cache_dir=tmp_path / "cache", progress=False) as r:
        assert r.start_workers(J.prime_fails) == 2
        assert [o.value["y"] for o in r.map(J.square, [dict(x=2.0), dict(x=3.0)])] == [4.0, 9.0]
    one = _runner(tmp_path)
    assert one.start_workers(J.prime_fails) == 0 and one._executor is None


def test_default_workers_are_the_cores_this_process_may_use(tmp_path):
    n = R.usable_cores()
    assert 1 <= n <= (os.cpu_count() or 1)
    if hasattr(os, "sched_getaffinity"):
        assert n == len(os.sched_getaffinity(0))  # a container pinned to some cores: those, not the host's
    assert SweepRunner(cache_dir=tmp_path, progress=False).workers == n


def test_warm_up_does_nothing_with_one_worker(tmp_path):
    assert _runner(tmp_path).warm_up(J.square, dict(x=1.0)) is None


@pytest.mark.parametrize("use_cache", [True, False])
def test_all_cached_tells_whether_a_map_would_start_workers(tmp_path, use_cache):
    r = _runner(tmp_path, use_cache=use_cache)
    jobs = [dict(x=1.0), dict(x=2.0)]
    assert r.all_cached(J.square, []) and not r.all_cached(J.square, jobs)
    r.map(J.square, jobs[:1])
    assert not r.all_cached(J.square, jobs)
    r.map(J.square, jobs)
    assert r.all_cached(J.square, jobs) == use_cache and r.all_cached(J.square, jobs[:1]) == use_cache


def test_prefetch_does_nothing_with_one_worker(tmp_path):
    r = _runner(tmp_path)
    assert r.prefetch(J.square, [dict(x=1.0)]) == 0 and r.map(J.square, [dict(x=1.0)])[0].value == {"y": 1.0}


@pytest.mark.parametrize("bad", [0, -2, 1.5, "two"])
def test_bad_worker_counts_are_config_errors(bad):
    with pytest.raises(ConfigError, match=r"--workers must be >= 1.*omit it to use all cores"):
        SweepRunner(workers=bad)


@pytest.mark.parametrize("addr", ["", "tcp://", "localhost", "http://host:8786", "host:port", "tcp://h:99999",
                                  "tcp://h:1/path"])
def test_malformed_scheduler_is_a_config_error(addr):
    with pytest.raises(ConfigError, match="--scheduler"):
        SweepRunner(scheduler=addr)


def test_unreachable_scheduler_is_a_quick_config_error(tmp_path, monkeypatch):
    """Quick: the runner's own connect timeout reaches Dask's client on every attempt (Dask's default is 30 s a
    call), read from the calls themselves rather than from a clock."""
    import distributed  # a dependency of berryshaker (dask[distributed])

    asked = []
    real_client = distributed.Client

    def client(address, *args, **kwargs):
        asked.append((address, kwargs.get("timeout")))
        return real_client(address, *args, **kwargs)

    monkeypatch.setattr(distributed, "Client", client)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # closed again: nothing listens there
    r = SweepRunner(scheduler=f"127.0.0.1:{port}", cache_dir=tmp_path, progress=False)
    r.scheduler_timeout_s = 0.5
    with pytest.raises(ConfigError, match=r"no Dask scheduler answered within 0.5 s"):
        r.check_scheduler()
    with pytest.raises(ConfigError, match="omit --scheduler"):
        r.map(J.square, [dict(x=1.0)])
    assert asked == [(f"tcp://127.0.0.1:{port}", "0.5s")] * 2, asked  # check_scheduler, then map


# ---- interruption and a killed parent (real processes) -------------------------------------------------
# Ctrl-C's default action in the script: a process started with SIGINT ignored (an xdist worker, nohup, some CI
# runners) passes that on through exec, and Python then leaves it ignored
_SCRIPT = textwrap.dedent("""
    import signal
    import sys
    signal.signal(signal.SIGINT, signal.default_int_handler)
    sys.path.insert(0, {tests!r})
    import berryshaker.runs.local_pool as L
    import berryshaker.runs.runner as R
    import runner_jobs as J
    L._USE_PDEATHSIG = {pdeathsig!r}
    if __name__ == "__main__":
        r = R.SweepRunner(workers=2, cache_dir={cache!r}, progress=False)
        try:
            r.map(J.{fn}, {jobs!r})
        except KeyboardInterrupt:
            sys.exit(130)
""")


def _start(tmp_path, fn, jobs, pdeathsig=True):
    script = tmp_path / "sweep.py"
    script.write_text(_SCRIPT.format(tests=str(TESTS), cache=str(tmp_path / "cache"), fn=fn, jobs=jobs,
                                     pdeathsig=pdeathsig))
    return subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)


def _wait_for(cond, timeout):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if cond():
            return True
        time.sleep(0.05)
    return False


def _gone(pids, timeout):
    import psutil

    def all_gone():
        for pid in pids:
            try:
                if psutil.Process(pid).status() != psutil.STATUS_ZOMBIE:
                    return False
            except psutil.NoSuchProcess:
                pass
        return True

    return _wait_for(all_gone, timeout)


def test_ctrl_c_stops_promptly_and_keeps_finished_runs(tmp_path, monkeypatch):
    import psutil  # a dependency of dask.distributed, one of berryshaker's
    # 60 s of work on 2 workers, so the signal lands mid-sweep even on a loaded machine; "promptly" is the 10 s
    # hang guard below
    jobs = [dict(x=float(i), delay=0.5) for i in range(240)]
    proc = _start(tmp_path, "slow_square", jobs)
    try:
        cache = tmp_path / "cache"
        assert _wait_for(lambda: len(list(cache.rglob("*.json"))) >= 3, 20), "no run finished"
        children = [c.pid for c in psutil.Process(proc.pid).children(recursive=True)]
        os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C in a terminal does: the whole process group
        _, err = proc.communicate(timeout=10)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    # promptly: it stopped with most of the runs not done (entries < len(jobs) below); communicate(timeout=10)
    # is the hang guard
    assert proc.returncode == 130, (proc.returncode, err)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("interrupted:") and "run the same command again" in lines[0], err
    entries = [read_cache_entry(p, p.stem)[0] for p in cache.rglob("*.json")]
    assert 3 <= len(entries) < len(jobs) and all(entries)  # finished runs are kept, each entry valid
    said = int(lines[0].split()[1])  # "interrupted: N of 240 runs had finished..."
    assert 1 <= said <= len(entries)
    # a hang guard, not a clock: polled, it returns as soon as the workers are gone
    assert _gone(children, 30.0), "worker processes outlived the interrupted sweep"
    # the finished runs are not recomputed when the sweep is run again (the subprocess's code fingerprint:
    # other people may be editing the package while the tests run)
    fps = {e["fingerprint"] for e in entries}
    assert len(fps) == 1
    fp = fps.pop()
    _code_fingerprint(monkeypatch, fp)
    done = [kw for kw in jobs if any(e["value"]["y"] == kw["x"] ** 2 for e in entries)]
    r = SweepRunner(workers=1, cache_dir=cache, progress=False)
    r.map(J.slow_square, done)
    assert r.stats["cached"] == len(done) == len(entries) and r.stats["computed"] == 0


@pytest.mark.parametrize("pdeathsig", [True, False], ids=["death-signal", "polling-thread"])
def test_workers_exit_when_the_parent_is_killed(tmp_path, pdeathsig):
    import psutil  # a dependency of dask.distributed, one of berryshaker's
    started = tmp_path / "started"
    started.mkdir()
    jobs = [dict(x=float(i), folder=str(started), delay=60.0) for i in range(4)]
    proc = _start(tmp_path, "touch_and_sleep", jobs, pdeathsig)
    try:
        assert _wait_for(lambda: len(list(started.iterdir())) >= 2, 20), "workers did not start"
        children = [c.pid for c in psutil.Process(proc.pid).children(recursive=True)]
        assert len(children) >= 2
        os.kill(proc.pid, signal.SIGKILL)  # the parent only: its workers are orphaned
        proc.wait(timeout=5)
        # polled, so it returns as soon as they are gone; 30 s is half of the 60 s each orphan would sleep on
        assert _gone(children, 30.0), "orphaned workers kept running after the parent was killed"
    finally:
        for pid in [proc.pid] + [c for c in locals().get("children", [])]:
            try:
                os.kill(pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass


def test_dask_cluster_runs_are_cached_by_the_client(tmp_path):
    import distributed  # a dependency of berryshaker (dask[distributed])
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None,
                                  protocol="tcp://") as cluster:
        jobs = [dict(x=float(i)) for i in range(6)] + [dict(x=-1.0)]
        r = SweepRunner(scheduler=cluster.scheduler_address, cache_dir=tmp_path / "cache", progress=False)
        out = r.map(J.fail_on_negative, jobs)
        assert [o.value["y"] for o in out[:6]] == [i * i for i in range(6)] and "x must be >= 0" in out[6].error
        assert all(_entry(tmp_path, J.fail_on_negative, kw).is_file() for kw in jobs[:6])
        again = SweepRunner(scheduler=cluster.scheduler_address, cache_dir=tmp_path / "cache", progress=False)
        again.map(J.fail_on_negative, jobs)
        assert again.stats["cached"] == 6 and again.stats["computed"] == 1


def _blas_probe(env: dict) -> dict:
    """In a fresh interpreter with ``env``: the BLAS libraries' threads before and after one_blas_thread()."""
    code = textwrap.dedent("""
        import json
        import numpy, scipy.linalg
        from threadpoolctl import threadpool_info
        from berryshaker.runs.runner import one_blas_thread
        before = one_blas_thread()
        print(json.dumps({"before": before, "after": sorted({i["num_threads"] for i in threadpool_info()}),
                          "n": len(threadpool_info())}))
    """)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _cores() -> int:
    """The CPUs this process may run on (what OpenBLAS sizes its pool by)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def test_pool_workers_run_one_blas_thread(tmp_path):
    """Each worker is a process per core: its BLAS must not fan out over the cores."""
    env = {k: v for k, v in os.environ.items() if k not in R.BLAS_THREAD_VARIABLES}
    probe = _blas_probe(env)
    assert probe["n"] >= 1 and probe["after"] == [1]
    if _cores() > 1:  # the limit is not vacuous: OpenBLAS would have used every core
        assert max(probe["before"].values()) > 1
    if any(v in os.environ for v in R.BLAS_THREAD_VARIABLES):
        pytest.skip("the pool's workers inherit this process's BLAS thread variables")
    out = _runner(tmp_path, workers=2, use_cache=False).map(J.blas_threads, [dict(x=0.0), dict(x=1.0)])
    assert all(o.error is None and o.value["libraries"] >= 1 and o.value["threads"] == [1] for o in out)
    # the initializer's one_blas_thread ran (it records the libraries it found; numpy's and scipy's loaded after the
    # variables were set start with one thread, the limit of a library loaded earlier is the probe's case above)
    assert all(len(o.value["before"]) >= 1 for o in out)


@pytest.mark.parametrize("user", ["OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"])
def test_a_user_set_blas_thread_count_is_kept(user):
    """A BLAS thread count set by the user is kept; an unrelated one (OMP) does not switch the BLAS limit off."""
    env = {k: v for k, v in os.environ.items() if k not in R.BLAS_THREAD_VARIABLES}
    env[user] = "2"
    probe = _blas_probe(env)
    assert _cores() < 2 or 2 in probe["after"]
    env = {k: v for k, v in os.environ.items() if k not in R.BLAS_THREAD_VARIABLES}
    env["OMP_NUM_THREADS"] = "2"
    assert _blas_probe(env)["after"] == [1]
