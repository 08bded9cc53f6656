"""Independent tasks on local cores (joblib's loky processes) or a Dask cluster.

One code path for both: joblib runs the tasks, on its loky backend for `workers` local
processes, or on its dask backend when a `scheduler` is given (a scheduler address such
as ``tcp://head:8786``, or a cluster object, e.g. a dask-jobqueue ``SLURMCluster``).
Results come back as the tasks finish, whatever the order, and feed a progress bar on a
terminal. A task must be a module-level function of picklable arguments whose result
does not depend on which worker runs it or on what ran before (the study and the
planner seed every trial from what defines it). Every task runs its numerical libraries'
thread pools (OpenBLAS, OpenMP) at one thread, in this process as on a worker: a sum split
over threads adds in another order, and loky gives its workers cpu_count // N threads each,
so a plate mode solved in a task read otherwise in the 16th digit with N (`plan paper`'s map
at `--workers 1` against 2), which `--workers` promises it does not.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import functools
import importlib
import math
import multiprocessing
import multiprocessing.context
import os
import signal
import threading
import time
import warnings
from typing import Any, Callable, Iterable, Iterator, TypeVar

import joblib
from joblib.externals.loky.backend import context as loky_context
from threadpoolctl import threadpool_limits
from tqdm import tqdm

from squeezebench.errors import UserError
from squeezebench.terminal import bar_width

T = TypeVar("T")
CONNECT_TIMEOUT_S = 10.0
# A map its caller stops (a study stopped with its campaign) drops its unused and running
# tasks on purpose: joblib's warning about them would be a second message after the stop's.
warnings.filterwarnings("ignore", message=r"\d+ tasks (have been successfully executed|which were still being)",
                        category=UserWarning, module="joblib")


def _indexed(function: Callable[[T], Any], index: int, item: T,
             environment: dict[str, str] | None = None) -> tuple[int, Any]:
    """`function(item)` at one BLAS thread, in `environment` (the caller's: a worker forked
    from `preload`'s server otherwise has the server's, and loky reuses its workers)."""
    if environment is not None and environment != os.environ:
        os.environ.clear()
        os.environ.update(environment)
    try:
        with threadpool_limits(limits=1):   # the same sums in the same order wherever it runs (module docstring)
            return index, function(item)
    finally:
        _return_freed_memory()


@functools.cache
def _malloc_trim() -> Callable[[int], int] | None:
    """glibc's malloc_trim, or None where the C library has none (macOS, musl)."""
    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").malloc_trim
    except (OSError, AttributeError):
        return None


#: Seconds at least between two trims in one process: a trim costs 1-20 ms and the pages it
#: returns are faulted in again, and the study's trials (tasks of tens of ms) spent 8 % more CPU
#: trimming after each (20.5 -> 22.2 CPU-s, two interleaved pairs on one worker), 5 % trimming
#: once a second (16.4 -> 17.2). A worker's freed heap grows by some 5 MB a coverage bench (12 CPU-s), so a
#: trim every 10 s keeps it far under loky's 300 MB.
TRIM_INTERVAL_S = 10.0
_last_trim_s = -math.inf


def _return_freed_memory() -> None:
    """Hand the heap the tasks freed back to the system, at most once a TRIM_INTERVAL_S. glibc
    keeps freed blocks for reuse, so a worker's resident size only grows with the arrays its
    tasks made and dropped, and loky retires a worker whose resident size grew 300 MB past its
    size after its first task as leaking ("A worker stopped while some jobs were given to the
    executor"), to start another from nothing: a coverage study warned so about twice in 40
    benches. One process running benches one after another held 376, 415, 417, 420, 421 MB
    after each (kept caches and freed heap), trimmed 344, 354, 354, 356, 356 MB."""
    global _last_trim_s
    trim = _malloc_trim()
    if trim is None or time.monotonic() - _last_trim_s < TRIM_INTERVAL_S:
        return
    trim(0)
    _last_trim_s = time.monotonic()


def start_resource_trackers() -> None:
    """Start multiprocessing's and loky's resource trackers (if not running) deaf to SIGHUP,
    before the first local worker needs them. Python starts them with SIGINT and SIGTERM
    blocked, so a stop sent to the whole process group leaves them be, but not SIGHUP: a hang
    up killed them, the next worker call started new ones that knew none of the names the
    first had registered, and each name unregistered printed a KeyError traceback under the
    run's own stop message. The blocked mask is inherited by the trackers alone (it is
    restored here at once); they still end when this process closes their pipe."""
    from multiprocessing import resource_tracker   # here: only a run with local workers needs them
    from joblib.externals.loky.backend import resource_tracker as loky_tracker
    if not hasattr(signal, "pthread_sigmask"):
        return
    blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGHUP})
    try:
        resource_tracker.ensure_running()
        loky_tracker.ensure_running()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, blocked)


@contextlib.contextmanager
def _backend(workers: int, scheduler: Any) -> Iterator[int]:
    """joblib's configuration for the run; yields the n_jobs to ask for."""
    if scheduler is None:
        if workers < 1:
            raise ValueError(f"workers must be at least 1, got {workers!r}")
        if workers > 1:
            start_resource_trackers()
        # loky: fresh processes that survive between calls (no fork of a busy parent).
        with joblib.parallel_config(backend="loky" if workers > 1 else "sequential"):
            yield workers
        return
    try:
        from distributed import Client   # only a cluster run needs it
    except ImportError:
        raise UserError("a Dask scheduler needs the 'distributed' package: "
                        "pip install 'squeezebench[cluster]'") from None
    try:
        client = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
    except OSError as exc:
        raise UserError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
    with client, joblib.parallel_config(backend="dask"):
        yield max(1, sum(client.nthreads().values()))


def map_unordered(function: Callable[[T], Any], items: Iterable[T], workers: int = 1,
                  scheduler: Any = None, description: str = "", bar: bool = True) -> Iterator[tuple[T, Any]]:
    """(item, function(item)) for every item, in the order the tasks finish.

    `workers` local processes (1: in this process, in order), or the Dask cluster at
    `scheduler`. The progress bar shows only when stderr is a terminal, and `bar`
    (not beside another one: see `Beside`). A `warm` still starting the workers is waited
    for first: two joblib calls at once on one loky executor die together when either aborts.
    """
    items = list(items)
    if not items:
        return
    _wait_for_warming()
    with _backend(workers, scheduler) as n_jobs, \
            tqdm(total=len(items), desc=description, unit="task", disable=None if bar else True,
                 leave=False, **bar_width()) as progress:
        environment = dict(os.environ) if scheduler is None and n_jobs > 1 and worker_context() is not None else None
        run = joblib.Parallel(n_jobs=min(n_jobs, len(items)), return_as="generator_unordered")
        for index, result in run(joblib.delayed(_indexed)(function, i, item, environment)
                                 for i, item in enumerate(items)):
            progress.update()
            yield items[index], result


class Beside:
    """`function(stop)` on a thread of this process while the caller does its own work
    here: its tasks go to the workers meanwhile (the accuracy study beside the campaign).
    `start` (any arguments, so a run's watcher can call it) starts it once; `finish` starts
    it if it has not and waits, re-raising what it raised; `cancel` sets `stop`, which it
    must check between tasks, and waits for it."""

    def __init__(self, function: Callable[[threading.Event], Any]) -> None:
        self.stop = threading.Event()
        self._function = function
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None

    def start(self, *_: Any) -> None:
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="beside", daemon=True)
            self._thread.start()

    def _run(self) -> None:
        try:
            self._function(self.stop)
        except BaseException as exc:   # handed to the caller by finish()
            self._error = exc

    def finish(self) -> None:
        self.start()
        self._thread.join()
        if self._error is not None:
            raise self._error

    def cancel(self) -> None:
        """Stop it (what it stored is kept) and wait; what it raised meanwhile is dropped:
        the caller is raising its own reason."""
        self.stop.set()
        if self._thread is not None:
            self._thread.join()


_warming: list[threading.Thread] = []   # the `warm` threads not yet waited for
_preloaded: list[str] = []   # the modules `preload` named, in order


class _ForkedProcess(multiprocessing.context.ForkServerProcess):
    """A drawing process (`report.drawing`) forked from `preload`'s server that runs in the
    environment of the process starting it (with loky's `env` over it, if any), as a spawned
    one does, where the server's children would keep the server's: a drawing process started
    afresh sees the plate cache set since (`SQUEEZEBENCH_CACHE`). joblib's workers cannot be
    given it (it hands loky no context): their tasks bring the caller's environment instead."""

    def __init__(self, *args: Any, env: dict[str, str] | None = None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._environment = {**os.environ, **(env or {})}

    def run(self) -> None:
        os.environ.clear()
        os.environ.update(self._environment)
        super().run()


class _ForkedContext(multiprocessing.context.ForkServerContext):
    Process = _ForkedProcess


_forked: list[_ForkedContext] = []   # `preload`'s context, once it has been called


def preload(*modules: str) -> None:
    """This process's local workers (the trials' and the report's drawing processes,
    `worker_context`) start as forks of one server process that imported `modules` once
    (multiprocessing's forkserver, through loky), instead of each spawned to import NumPy,
    pandas, SciPy and the package again: about 1 CPU-s a worker, and `reproduce` starts
    three, `plan` and `study` two (one server's import for all). Call it before the first
    worker starts: a server already running keeps what it imported, and the workers import
    the rest themselves. The server is a fresh interpreter that forks nothing but itself, so
    its workers are as safe beside this process's threads as spawned ones; a task's numerical
    libraries run at one thread either way (`_indexed`). Where there is no forkserver
    (Windows) the workers are spawned as before."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return
    _preloaded.extend(module for module in modules if module not in _preloaded)
    multiprocessing.set_forkserver_preload(list(_preloaded))
    if not _forked:
        _forked.append(_ForkedContext())
        # joblib hands loky no context of ours: its workers are the server's plain children,
        # and each task brings its caller's environment instead (`map_unordered`, `_indexed`)
        loky_context.set_start_method("forkserver", force=True)


def worker_context() -> multiprocessing.context.BaseContext | None:
    """The multiprocessing context local workers start in: `preload`'s, else None (loky's own,
    which spawns each)."""
    return _forked[0] if _forked else None


def _import(module: str) -> None:
    """Import `module` in a worker. A failure is the map's to meet and report: raised here,
    it would make joblib abort the warming's batch, and loky's manager thread then dies now
    and again on a work item the abort removed (KeyError in add_call_item_to_queue, about
    1 in 40 failed warmings here), a traceback on stderr that is not the user's business."""
    with contextlib.suppress(Exception):
        importlib.import_module(module)   # nothing returned: a module is no result to send back


def warm(workers: int, module: str) -> None:
    """Start the `workers` local processes a later `map_unordered` uses, forked from a server
    that imported `module` (what their tasks need, `preload`), on a thread: the server starts
    and imports (most of a second) while this process reads its inputs and imports its own,
    instead of after. The map waits for it before it starts, so the two never share the
    executor at once."""
    if workers < 2:
        return
    preload(module)

    def spawn_and_import() -> None:
        try:
            with _backend(workers, None) as n_jobs:
                # twice as many imports as workers: each worker takes one before any ends
                joblib.Parallel(n_jobs=n_jobs)(joblib.delayed(_import)(module) for _ in range(2 * n_jobs))
        except Exception:   # a process failed: the map meets it again and says so
            pass

    thread = threading.Thread(target=spawn_and_import, name="warm", daemon=True)
    _warming.append(thread)
    thread.start()


def _wait_for_warming() -> None:
    while _warming:
        _warming.pop().join()
