"""The report's figures drawn in other processes while the report computes its next sections.

A figure function (`report.figures`, `cartography_report.map_figure`) takes its data and
the PNG's path and reads nothing else, so the report hands it to a worker and goes on: a
third of a report's time is matplotlib, which otherwise leaves every core but one idle.
The page is written only once every figure is (`Drawing.finish`). With one worker figures
are drawn in place, as before; the PNGs are the same bytes either way, so a figure whose
process died (killed, out of memory) is drawn again here rather than lost. `beside` hands
the same processes work a later report reads (`run_report.solve_ahead`), so that they
start once and are busy while this process runs something else.
"""

from __future__ import annotations

import contextlib
from concurrent.futures import BrokenExecutor, Future
from pathlib import Path
from typing import Any, Callable

from joblib.externals.loky import ProcessPoolExecutor

from squeezebench.disk_cache import cache_dir
from squeezebench.protocols.parallel import start_resource_trackers, worker_context

#: The drawing processes, kept for the next report of this process (a second report, a test
#: session): (size, executor). Not joblib's reusable executor, which the trials resize.
_EXECUTOR: tuple[int, ProcessPoolExecutor] | None = None


def _executor(size: int, fresh: bool = False) -> ProcessPoolExecutor:
    """The drawing processes; `fresh`: new ones (the old ones broke)."""
    global _EXECUTOR
    if fresh or _EXECUTOR is None or _EXECUTOR[0] != size:
        if _EXECUTOR is not None:
            _EXECUTOR[1].shutdown(wait=False)
        # loky's processes: spawned, or forked from `parallel.preload`'s server, never from this
        # busy parent, so safe beside its threads
        start_resource_trackers()
        _EXECUTOR = (size, ProcessPoolExecutor(max_workers=size, context=worker_context()))
    return _EXECUTOR[1]


def beside(workers: int, function: Callable[[], Any]) -> Future | None:
    """`function()` now on the drawing processes of a `Drawing(workers)` to come, for what it
    leaves in the disk cache (a solve) that this process reads later. None with one worker
    (there is none beside this process) or with the disk cache off (nothing it did would
    reach this process)."""
    if workers < 2 or cache_dir() is None:
        return None
    try:
        return _executor(workers - 1).submit(function)
    except BrokenExecutor:   # a process of an earlier report died
        return _executor(workers - 1, fresh=True).submit(function)


def stop_beside(work: Future | None) -> None:
    """Drop `beside` work this process no longer waits for (it stops): one not started is
    cancelled, a running one is ended with the drawing processes (the interpreter would
    wait for it at exit); a later report gets new ones."""
    global _EXECUTOR
    if work is not None and not work.cancel() and not work.done() and _EXECUTOR is not None:
        _EXECUTOR[1].shutdown(wait=False, kill_workers=True)
        _EXECUTOR = None


class Drawing:
    """Figures drawn on `workers - 1` processes beside this one (none for one worker)."""

    def __init__(self, workers: int) -> None:
        if workers < 1:
            raise ValueError(f"workers must be at least 1, got {workers!r}")
        self._size = workers - 1
        self._executor = _executor(self._size) if workers > 1 else None
        self._pending: list[tuple[Future, tuple]] = []   # (future, the call it runs)
        self._ahead: list[Future] = []

    def __call__(self, function: Callable[..., Any], data: Any, path: Path, *more: Any) -> Path:
        """`function(data, path, *more)`, now or on a worker; returns `path`."""
        if self._executor is None:
            function(data, path, *more)
            return path
        call = (function, data, Path(path).resolve(), *more)   # the worker's working directory is not ours
        try:
            future = self._executor.submit(*call)
        except BrokenExecutor:   # a process of an earlier report died
            self._executor = _executor(self._size, fresh=True)
            future = self._executor.submit(*call)
        self._pending.append((future, call))
        return path

    def ahead(self, function: Callable[..., Any], *arguments: Any) -> None:
        """`function(*arguments)` on a drawing process for what it leaves behind (a solve
        in the disk cache) that this process reads later, after `wait_ahead`; nothing with
        one worker or the disk cache off (this process computes it where it needs it)."""
        if self._executor is None or cache_dir() is None:
            return
        try:
            self._ahead.append(self._executor.submit(function, *arguments))
        except BrokenExecutor:   # a process of an earlier report died: this process does it
            pass

    def wait_ahead(self) -> None:
        """Wait for the `ahead` work; one that failed is left to this process to meet."""
        ahead, self._ahead = self._ahead, []
        for future in ahead:
            with contextlib.suppress(Exception):
                future.result()

    def finish(self) -> None:
        """Wait for every figure handed out; one that failed raises here. This process has
        nothing else left to do, so it draws the figures no worker has started, the last
        handed out first (the least likely started). A figure whose process died is drawn
        here instead, and the next report gets new processes."""
        pending, self._pending = self._pending, []
        broken = False
        try:
            for future, (function, *arguments) in reversed(pending):
                if future.cancel():
                    function(*arguments)
            for future, (function, *arguments) in pending:
                if future.cancelled():   # drawn above
                    continue
                try:
                    future.result()
                except BrokenExecutor:
                    broken = True
                    function(*arguments)
        finally:
            for future, _ in pending:
                future.cancel()
            if broken:
                _executor(self._size, fresh=True)

    def cancel(self) -> None:
        """Drop the figures and the `ahead` work not started yet (the report stopped)."""
        for future in [future for future, _ in self._pending] + self._ahead:
            future.cancel()
        self._pending, self._ahead = [], []
