"""The report's figures drawn in other processes while the report computes its next sections.

A figure function (`analysis.figures`, `cartography_report.map_figure`) takes its data and
the PNG's path and reads nothing else, so the report hands it to a worker and goes on: a
third of a report's time is matplotlib, which otherwise leaves every core but one idle.
The page is written only once every figure is (`Drawing.finish`). With one worker figures
are drawn in place, as before; the PNGs are the same bytes either way.
"""

from __future__ import annotations

from concurrent.futures import Future
from pathlib import Path
from typing import Any, Callable

from joblib.externals.loky import ProcessPoolExecutor

#: The drawing processes, kept for the next report of this process (a second report, a test
#: session): (size, executor). Not joblib's reusable executor, which the trials resize.
_EXECUTOR: tuple[int, ProcessPoolExecutor] | None = None


def _executor(size: int) -> ProcessPoolExecutor:
    global _EXECUTOR
    if _EXECUTOR is None or _EXECUTOR[0] != size:
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
        self._executor = _executor(workers - 1) if workers > 1 else None
        self._pending: list[Future] = []

    def __call__(self, function: Callable[..., Any], data: Any, path: Path, *more: Any) -> Path:
        """`function(data, path, *more)`, now or on a worker; returns `path`."""
        if self._executor is None:
            function(data, path, *more)
        else:   # the worker's working directory is not this one's
            self._pending.append(self._executor.submit(function, data, Path(path).resolve(), *more))
        return path

    def finish(self) -> None:
        """Wait for every figure handed out; the first one that failed raises here."""
        pending, self._pending = self._pending, []
        try:
            for future in pending:
                future.result()
        finally:
            for future in pending:
                future.cancel()

    def cancel(self) -> None:
        """Drop the figures not started yet (the report stopped)."""
        for future in self._pending:
            future.cancel()
        self._pending = []
