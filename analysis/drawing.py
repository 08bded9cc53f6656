"""The report's figures drawn in other processes while the report computes its next sections.

A figure function (`analysis.figures`, `cartography_report.map_figure`) takes its data and
the PNG's path and reads nothing else, so the report hands it to a worker and goes on: a
third of a report's time is matplotlib, which otherwise leaves every core but one idle.
The page is written only once every figure is (`Drawing.finish`). With one worker figures
are drawn in place, as before; the PNGs are the same bytes either way, so a figure whose
process died (killed, out of memory) is drawn again here rather than lost.
"""

from __future__ import annotations

from concurrent.futures import BrokenExecutor, Future
from pathlib import Path
from typing import Any, Callable

from joblib.externals.loky import ProcessPoolExecutor

#: The drawing processes, kept for the next report of this process (a second report, a test
#: session): (size, executor). Not joblib's reusable executor, which the trials resize.
_EXECUTOR: tuple[int, ProcessPoolExecutor] | None = None


def _executor(size: int, fresh: bool = False) -> ProcessPoolExecutor:
    """The drawing processes; `fresh`: new ones (the old ones broke)."""
    global _EXECUTOR
    if fresh or _EXECUTOR is None or _EXECUTOR[0] != size:
        if _EXECUTOR is not None:
            _EXECUTOR[1].shutdown(wait=False)
        # loky's processes: spawned, not forked, so safe beside the threads of a busy parent
        _EXECUTOR = (size, ProcessPoolExecutor(max_workers=size))
    return _EXECUTOR[1]


class Drawing:
    """Figures drawn on `workers - 1` processes beside this one (none for one worker)."""

    def __init__(self, workers: int) -> None:
        if workers < 1:
            raise ValueError(f"workers must be at least 1, got {workers!r}")
        self._size = workers - 1
        self._executor = _executor(self._size) if workers > 1 else None
        self._pending: list[tuple[Future, tuple]] = []   # (future, the call it runs)
        self._beside: list[Future] = []   # `beside` work, read by the sections themselves

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

    def beside(self, function: Callable[..., Any], *arguments: Any) -> Callable[[], Any]:
        """`function(*arguments)` on a drawing process (here at once, with one worker), for a
        section to read later: returns the call giving its result or raising what it raised
        (computed here if its process died). For work the report would otherwise do on its
        one thread while the drawing processes wait for figures."""
        if self._executor is None:
            done: Future = Future()
            try:
                done.set_result(function(*arguments))
            except Exception as exc:   # raised where the section reads it
                done.set_exception(exc)
            return done.result
        try:
            future = self._executor.submit(function, *arguments)
        except BrokenExecutor:
            self._executor = _executor(self._size, fresh=True)
            future = self._executor.submit(function, *arguments)
        self._beside.append(future)

        def read() -> Any:
            try:
                return future.result()
            except BrokenExecutor:
                return function(*arguments)
        return read

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
        """Drop the figures and the `beside` work not started yet (the report stopped, or
        is written: a section that was not built leaves its work unread)."""
        for future in [f for f, _ in self._pending] + self._beside:
            future.cancel()
        self._pending, self._beside = [], []
