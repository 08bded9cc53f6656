"""Independent tasks on local cores (joblib's loky processes) or a Dask cluster.

One code path for both: joblib runs the tasks, on its loky backend for `workers` local
processes, or on its dask backend when a `scheduler` is given (a scheduler address such
as ``tcp://head:8786``, or a cluster object, e.g. a dask-jobqueue ``SLURMCluster``).
Results come back as the tasks finish, whatever the order, and feed a progress bar on a
terminal. A task must be a module-level function of picklable arguments whose result
does not depend on which worker runs it or on what ran before (the study and the
planner seed every trial from what defines it).
"""

from __future__ import annotations

import contextlib
from typing import Any, Callable, Iterable, Iterator, TypeVar

import joblib
from tqdm import tqdm

from squeezebench.errors import UserError

T = TypeVar("T")
CONNECT_TIMEOUT_S = 10.0
def _indexed(function: Callable[[T], Any], index: int, item: T) -> tuple[int, Any]:
    return index, function(item)


@contextlib.contextmanager
def _backend(workers: int, scheduler: Any) -> Iterator[int]:
    """joblib's configuration for the run; yields the n_jobs to ask for."""
    if scheduler is None:
        if workers < 1:
            raise ValueError(f"workers must be at least 1, got {workers!r}")
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
                  scheduler: Any = None, description: str = "") -> Iterator[tuple[T, Any]]:
    """(item, function(item)) for every item, in the order the tasks finish.

    `workers` local processes (1: in this process, in order), or the Dask cluster at
    `scheduler`. The progress bar shows only when stderr is a terminal.
    """
    items = list(items)
    if not items:
        return
    with _backend(workers, scheduler) as n_jobs, \
            tqdm(total=len(items), desc=description, unit="task", disable=None, leave=False) as bar:
        run = joblib.Parallel(n_jobs=min(n_jobs, len(items)), return_as="generator_unordered")
        for index, result in run(joblib.delayed(_indexed)(function, i, item) for i, item in enumerate(items)):
            bar.update()
            yield items[index], result
