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
