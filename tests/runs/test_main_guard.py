"""A script that starts runs (#58: docs/python_api.md's ``api.sweep`` example saved to a file crashed in every
worker, then gave a table without its columns): the example runs as a script with and without the
``if __name__ == "__main__":`` idiom, and workers that die importing the script fail at once with one message.

Each script runs in a fresh interpreter (the start method of the runner's pool is ``forkserver``, or
``spawn`` where that is all there is).
"""

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import berryshaker  # noqa: F401  (points NUMBA_CACHE_DIR at the compiled kernels: the scripts share them)

ROOT = Path(__file__).resolve().parents[2]


def _run(tmp_path, text, name="script.py", args=()):
    script = tmp_path / name
    script.write_text(text)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), str(ROOT)]),
               BERRYSHAKER_CACHE=str(tmp_path / f"cache-{script.stem}"), MPLBACKEND="Agg")
    env.pop("BERRYSHAKER_START_METHOD", None)
    return subprocess.run([sys.executable, str(script), *args], capture_output=True, text=True, env=env,
                          cwd=tmp_path, timeout=180)


def _docs_sweep_example() -> str:
    """The block of docs/python_api.md that calls ``api.sweep``."""
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "python_api.md").read_text(), re.S)
    (block,) = [b for b in blocks if "api.sweep(" in b]
    return block


def test_the_docs_sweep_example_runs_as_a_script_with_and_without_the_main_idiom(tmp_path):
    """As printed (under the idiom) the runs go to worker processes; with the idiom taken away (the file of the
    issue) they run in the script's own process, with a warning that names the line; both give the columns."""
    block = _docs_sweep_example()
    assert 'if __name__ == "__main__":' in block
    check = '\n    print("rows", len(table), bool(table["collision_force_C_peak [N]"].gt(0).all()))\n'
    guarded = _run(tmp_path, block + check)
    assert guarded.returncode == 0, guarded.stderr[-3000:]
    assert "rows 3 True" in guarded.stdout and "warning" not in guarded.stderr

    head, body = block.split('if __name__ == "__main__":')
    body = textwrap.dedent(body.split("\n", 1)[1])
    plain = _run(tmp_path, head + body + textwrap.dedent(check), name="as_saved.py")
    assert plain.returncode == 0, plain.stderr[-3000:]
    assert "rows 3 True" in plain.stdout
    line = next(i for i, t in enumerate((head + body).splitlines(), 1) if "api.sweep(" in t)
    assert f'as_saved.py:{line} starts runs outside `if __name__ == "__main__":`' in plain.stderr
    assert "bootstrapping" not in plain.stderr and "Traceback" not in plain.stderr


def test_workers_that_die_importing_the_script_stop_the_map_at_once(tmp_path):
    """The first check made to miss (it cannot read a script made on the fly, say): every worker meets the
    script's runs while importing it and leaves with one line; the map raises WorkerStartError naming the idiom
    instead of retrying every run alone."""
    text = textwrap.dedent(f"""
        import berryshaker.runs.runner as R
        R.unguarded_main_line = lambda start_method: None
        from tests import runner_jobs as J
        with R.SweepRunner(workers=2, cache_dir={str(tmp_path / 'runs')!r}, progress=False) as r:
            r.map(J.slow_square, [dict(x=float(i), delay=0.0) for i in range(4)])
        """)
    out = _run(tmp_path, text)
    assert out.returncode == 1
    last = out.stderr.strip().splitlines()[-1]
    assert last.startswith("berryshaker.runs.main_guard.WorkerStartError: the worker processes ended before")
    assert "4 run(s) could not run" in last and 'if __name__ == "__main__":' in last and "workers=1" in last
    assert "a worker process imported the main script" in out.stderr
    assert "run again" not in out.stderr and "bootstrapping" not in out.stderr


GUARD_PROBE = "from berryshaker.runs.main_guard import unguarded_main_line as u\n"


@pytest.mark.parametrize(("text", "unsafe_line"), [
    (GUARD_PROBE + "print(u('forkserver'))\n", 2),
    (GUARD_PROBE + "def work():\n    return u('spawn')\n\nprint(work())\n", 5),
    (GUARD_PROBE + "if __name__ == '__main__':\n    print(u('forkserver'))\n", None),
    (GUARD_PROBE + "def work():\n    return u('spawn')\n\nif '__main__' == __name__:\n    print(work())\n", None),
    (GUARD_PROBE + "print(u('fork'))\n", None),  # fork copies the process: nothing is imported again
], ids=["top-level", "function-called-at-top-level", "guarded", "guarded-reversed", "fork"])
def test_an_unguarded_call_is_found_by_its_line(tmp_path, text, unsafe_line):
    out = _run(tmp_path, text)
    assert out.returncode == 0, out.stderr
    expected = "None" if unsafe_line is None else f"({str(tmp_path / 'script.py')!r}, {unsafe_line})"
    assert out.stdout.strip() == expected


def test_python_c_and_the_test_runner_are_safe():
    """No main file to import again (``python -c``), or a guarded entry point (pytest's): None."""
    from berryshaker.runs.main_guard import unguarded_main_line

    code = "from berryshaker.runs.main_guard import unguarded_main_line as u; print(u('spawn'))"
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=60)
    assert out.stdout.strip() == "None"
    assert unguarded_main_line("forkserver") is None
