"""The report's figures drawn on another process: the same PNG bytes as drawn in place, the
path handed back at once, and a figure that fails stops the report at `finish`."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from squeezebench.report import figures
from squeezebench.report.drawing import Drawing


def _power() -> pd.DataFrame:
    voltages = np.array([8.0, 16.0, 24.0, 32.0])
    return pd.DataFrame({"piezo_voltage_vpp": voltages, "power_measured_w": 1.2e-3 * voltages**2,
                         "power_estimated_w": np.nan, "power_predicted_w": 1.0e-3 * voltages**2,
                         "power_predicted_U_w": 2e-4 * voltages**2})


def test_a_figure_drawn_on_a_worker_is_the_one_drawn_in_place(tmp_path, monkeypatch):
    Drawing(2)   # the worker starts in this directory...
    monkeypatch.chdir(tmp_path)   # ...and the report is asked for from another, by a relative path
    here, there = Path("here.png"), Path("there.png")
    assert Drawing(1)(figures.fig9_power, _power(), here) == here and here.stat().st_size > 10_000
    drawing = Drawing(2)
    assert drawing(figures.fig9_power, _power(), there) == there   # handed back before it is drawn
    drawing.finish()
    assert there.read_bytes() == here.read_bytes()


def test_a_figure_that_fails_raises_at_finish(tmp_path):
    drawing = Drawing(2)
    drawing(figures.fig9_power, pd.DataFrame({"piezo_voltage_vpp": [1.0]}), tmp_path / "broken.png")
    with pytest.raises(KeyError, match="power_measured_w"):
        drawing.finish()
    drawing.finish()   # what failed is not raised twice
    with pytest.raises(ValueError, match="at least 1"):
        Drawing(0)


def test_a_figure_whose_process_died_is_drawn_here_and_the_next_report_gets_new_processes(tmp_path):
    """A drawing process killed mid-figure (out of memory, a stray signal) loses nothing:
    `finish` draws that figure in this process, and later figures go to fresh processes."""
    parent = os.getpid()

    def dies_on_a_worker(data, path):
        if os.getpid() != parent:
            os._exit(1)
        figures.fig9_power(data, path)

    drawing = Drawing(2)
    drawing(dies_on_a_worker, _power(), tmp_path / "killed.png")
    drawing.finish()
    assert (tmp_path / "killed.png").stat().st_size > 10_000
    again = Drawing(2)
    again(figures.fig9_power, _power(), tmp_path / "after.png")
    again.finish()
    assert (tmp_path / "after.png").read_bytes() == (tmp_path / "killed.png").read_bytes()


def _drawn_by(data, path):
    import time

    time.sleep(0.1)
    Path(path).write_text(str(os.getpid()))


def test_figures_no_worker_has_started_are_drawn_here_at_finish(tmp_path):
    # the report has nothing left to do but wait: it draws what the worker has not begun
    drawing = Drawing(2)
    paths = [tmp_path / f"figure{i}.png" for i in range(6)]
    for path in paths:
        drawing(_drawn_by, None, path)
    drawing.finish()
    drawers = [int(path.read_text()) for path in paths]   # each drawn once, by someone
    assert drawers[-1] == os.getpid()   # the last handed out cannot have been started


def _pid() -> int:
    return os.getpid()


def _sleeps() -> None:
    import time

    time.sleep(60)


def test_work_beside_runs_on_the_drawing_process_a_later_report_uses(tmp_path):
    from squeezebench.report.drawing import beside

    assert beside(1, _pid) is None   # one worker: nothing beside this process
    work = beside(2, _pid)
    assert work.result(timeout=60) != os.getpid()
    drawing = Drawing(2)
    drawing(_drawn_by, None, tmp_path / "figure.png")   # drawn by the same process, not a new one
    drawing.finish()
    assert int((tmp_path / "figure.png").read_text()) in (work.result(), os.getpid())


def test_work_beside_stopped_while_running_ends_at_once_and_the_next_report_gets_new_processes(tmp_path):
    import time

    from squeezebench.report.drawing import beside, stop_beside

    work = beside(2, _sleeps)
    while not work.running():   # started: it cannot be cancelled, only ended with its process
        time.sleep(0.01)
    start_s = time.perf_counter()
    stop_beside(work)
    assert time.perf_counter() - start_s < 5
    stop_beside(None)   # nothing handed out: nothing to stop
    drawing = Drawing(2)
    drawing(figures.fig9_power, _power(), tmp_path / "after.png")
    drawing.finish()
    assert (tmp_path / "after.png").stat().st_size > 10_000


def test_plates_are_solved_ahead_only_where_a_report_can_read_them(monkeypatch):
    from squeezebench.disk_cache import CACHE_VARIABLE
    from squeezebench.report.run_report import solve_ahead

    assert solve_ahead(1) is None   # no drawing process
    monkeypatch.setenv(CACHE_VARIABLE, "off")
    assert solve_ahead(2) is None   # kept nowhere: the report would solve them again


def _leaves_pid(path):
    import time

    time.sleep(0.2)
    Path(path).write_text(str(os.getpid()))


def test_work_handed_ahead_runs_on_a_drawing_process_and_is_waited_for(tmp_path):
    """`ahead` work (a report's plate solve, left in the disk cache) runs on a drawing
    process; `wait_ahead` returns once it is done; with one worker nothing is handed out
    (the report computes it where it needs it)."""
    drawing = Drawing(2)
    drawing.ahead(_leaves_pid, tmp_path / "ahead.txt")
    drawing.wait_ahead()
    assert int((tmp_path / "ahead.txt").read_text()) != os.getpid()
    alone = Drawing(1)
    alone.ahead(_leaves_pid, tmp_path / "alone.txt")
    alone.wait_ahead()
    assert not (tmp_path / "alone.txt").exists()


def test_work_ahead_that_fails_is_left_to_the_report(tmp_path):
    drawing = Drawing(2)
    drawing.ahead(_leaves_pid, tmp_path / "missing" / "ahead.txt")   # its folder does not exist
    drawing.wait_ahead()   # nothing raised: the section that needs it meets the error itself
