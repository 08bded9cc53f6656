"""How many local processes a command uses when told nothing (`--workers` unset)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from squeezebench import cli
from squeezebench.errors import UserError
from squeezebench.workers import WORKERS_VARIABLE, default_workers


def test_default_is_the_cores_this_process_may_use(monkeypatch):
    monkeypatch.delenv(WORKERS_VARIABLE, raising=False)
    assert default_workers() == len(os.sched_getaffinity(0))


def test_the_affinity_mask_not_the_machine_decides(monkeypatch):
    monkeypatch.delenv(WORKERS_VARIABLE, raising=False)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0})
    assert default_workers() == 1


def test_the_variable_overrides_the_cores(monkeypatch):
    monkeypatch.setenv(WORKERS_VARIABLE, "3")
    assert default_workers() == 3


@pytest.mark.parametrize("text", ["0", "-2", "two", "1.5"])
def test_a_bad_variable_is_one_message(monkeypatch, text):
    monkeypatch.setenv(WORKERS_VARIABLE, text)
    with pytest.raises(UserError, match=WORKERS_VARIABLE):
        default_workers()


def test_commands_that_run_trials_take_the_default(monkeypatch):
    monkeypatch.setenv(WORKERS_VARIABLE, "3")
    seen = {}
    parser = cli.build_parser()
    args = parser.parse_args(["study", "--out", "somewhere"])
    assert args.workers is None   # unset until main resolves it, so the variable is read at run time
    monkeypatch.setattr(args, "func", lambda a: seen.setdefault("workers", a.workers) and 0, raising=False)
    monkeypatch.setattr(cli, "build_parser", lambda: type("P", (), {"parse_args": lambda self, argv: args})())
    assert cli.main(["study"]) == 0
    assert seen["workers"] == 3


def test_a_bad_variable_exits_2(monkeypatch, capsys):
    monkeypatch.setenv(WORKERS_VARIABLE, "none")
    assert cli.main(["plan", "quick", "--target-rel-error", "0.05"]) == 2
    assert WORKERS_VARIABLE in capsys.readouterr().err


def test_ci_runs_exactly_the_readmes_test_command():
    """A newcomer's command is the one CI proves: chromium, the venv, the suite on every core."""
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    readme = (root / "README.md").read_text()
    command = next(line for line in readme.splitlines() if "pip install -e '.[test]'" in line)
    assert "apt-get install -y chromium" in command and "pytest -n auto" in command
    assert command in (root / ".ci" / "run").read_text().splitlines()



#: Run with the BLAS free to take every core (the suite's conftest sets one thread for its own
#: processes): a task in this process, and the process outside any task.
_BLAS_THREADS = """
import numpy
from threadpoolctl import threadpool_info
from squeezebench.protocols.parallel import map_unordered
def threads(_):
    return max(pool["num_threads"] for pool in threadpool_info())
inside = [t for _, t in map_unordered(threads, range(3), workers=1, bar=False)]
print(threads(None), max(inside))
"""


def test_a_task_runs_its_blas_on_one_thread_whatever_runs_it():
    """A task's sums add in one order wherever it runs: loky's workers get cpu_count // N
    BLAS threads, this process (--workers 1) every core, and `plan paper`'s map read otherwise
    in the 16th digit at --workers 1 and 2 before each task was held to one thread."""
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    done = subprocess.run([sys.executable, "-c", _BLAS_THREADS], env=env, capture_output=True, text=True,
                          timeout=120, check=True)
    outside, inside = map(int, done.stdout.split())
    assert inside == 1
    assert outside > 1 or len(os.sched_getaffinity(0)) == 1   # else this test shows nothing


def _fails_on_two(item: int) -> int:
    if item == 2:
        raise ValueError("task 2 fails")
    return item


def test_every_task_hands_its_freed_heap_back(monkeypatch):
    """loky retires a worker whose resident size grew 300 MB past its first task's as leaking;
    freed heap that glibc keeps counts in that size, so a task, failed ones too, ends by
    trimming it (`parallel._return_freed_memory`), once a TRIM_INTERVAL_S at most."""
    import platform

    from squeezebench.protocols import parallel

    if platform.libc_ver()[0] == "glibc":
        assert parallel._malloc_trim() is not None   # the machines the project runs on
    trims = []
    monkeypatch.setattr(parallel, "_malloc_trim", lambda: trims.append)
    monkeypatch.setattr(parallel, "TRIM_INTERVAL_S", 0.0)
    assert dict(parallel.map_unordered(_fails_on_two, [0, 1], workers=1, bar=False)) == {0: 0, 1: 1}
    assert trims == [0, 0]
    with pytest.raises(ValueError, match="task 2 fails"):
        list(parallel.map_unordered(_fails_on_two, [2], workers=1, bar=False))
    assert trims == [0, 0, 0]
    # within the interval since the last trim, short tasks do not trim again: a trim costs milliseconds
    monkeypatch.setattr(parallel, "TRIM_INTERVAL_S", 3600.0)
    assert len(dict(parallel.map_unordered(_fails_on_two, [0, 1, 3], workers=1, bar=False))) == 3
    assert trims == [0, 0, 0]


def _imported_parent_and_variable(module: str) -> tuple[bool, int, str | None]:
    return module in sys.modules, os.getppid(), os.environ.get("SQUEEZEBENCH_TEST_VARIABLE")


#: colorsys: a module nothing the workers run imports of itself.
_PRELOADED = """
import os, sys
sys.path.insert(0, {tests!r})
from squeezebench.protocols import parallel
from test_parallel_defaults import _imported_parent_and_variable as task
parallel.preload("colorsys")
before = [r for _, r in parallel.map_unordered(task, ["colorsys"] * 4, workers=2, bar=False)]
os.environ["SQUEEZEBENCH_TEST_VARIABLE"] = "set since"
after = [r for _, r in parallel.map_unordered(task, ["colorsys"] * 4, workers=2, bar=False)]
print(all(imported for imported, _, _ in before), all(parent != os.getpid() for _, parent, _ in before),
      {{variable for _, _, variable in before}}, {{variable for _, _, variable in after}})
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the forkserver is what Linux runs")
def test_preloaded_workers_are_forked_from_a_server_that_imported_their_modules():
    """`parallel.preload`: the workers start with what the server imported (one import for
    all of them), as its children, not this process's (loky's spawned workers are); and a
    task runs in its caller's environment of the moment, not the server's."""
    env = {k: v for k, v in os.environ.items() if k != "SQUEEZEBENCH_TEST_VARIABLE"}
    done = subprocess.run([sys.executable, "-c", _PRELOADED.format(tests=os.path.dirname(__file__))],
                          env=env, capture_output=True, text=True, timeout=120, check=True)
    assert done.stdout.split("\n")[0] == "True True {None} {'set since'}"


_HANG_UP = """
import os, signal, time
from multiprocessing import resource_tracker
from joblib.externals.loky.backend import resource_tracker as loky_tracker
from squeezebench.protocols import parallel
list(parallel.map_unordered(abs, [-1, -2, -3], workers=2, bar=False))
trackers = [resource_tracker._resource_tracker._pid, loky_tracker._resource_tracker._pid]
for pid in trackers:
    os.kill(pid, signal.SIGHUP)
time.sleep(0.5)
print([os.waitpid(pid, os.WNOHANG)[0] == 0 for pid in trackers],
      signal.SIGHUP in signal.pthread_sigmask(signal.SIG_BLOCK, []))
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="a hang-up is a POSIX signal")
def test_the_workers_resource_trackers_outlive_a_hang_up_and_this_process_still_takes_it():
    """`parallel.start_resource_trackers`: a SIGHUP to the whole process group (a closed
    terminal, `kill -HUP -PGID`) used to kill the trackers, and the ones started in their place
    printed a KeyError traceback per name under the run's stop message; they now outlive it,
    and the process that started them still gets its hang-ups (its mask is as it was)."""
    done = subprocess.run([sys.executable, "-c", _HANG_UP], capture_output=True, text=True, timeout=120, check=True)
    assert done.stdout.split("\n")[0] == "[True, True] False"
