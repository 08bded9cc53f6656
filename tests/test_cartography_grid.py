"""The map's grid (step, margin, serpentine order) and its bench time before it runs."""

from __future__ import annotations

import numpy as np
import pytest

from squeezebench.protocols.cartography import Grid, map_bench_time_s
from squeezebench.analysis.cartography import move_time_s


def test_a_serpentine_grid_visits_every_point_once_one_step_apart():
    grid = Grid((0.0, 198.0), (0.0, 138.0), step_mm=2.0, margin_mm=5.0)
    points = grid.points_mm()
    assert points[:, 0].min() == 5.0 and points[:, 0].max() == 193.0
    assert points[:, 1].min() == 5.0 and points[:, 1].max() == 133.0
    assert len(points) == 95 * 65 == len({tuple(p) for p in points})
    assert np.allclose(np.abs(np.diff(points, axis=0)).sum(axis=1), 2.0)   # never a fly-back


def test_a_raster_grid_flies_back_at_each_row():
    points = Grid((0.0, 10.0), (0.0, 4.0), step_mm=2.0, serpentine=False).points_mm()
    assert points[6].tolist() == [0.0, 2.0] and points[5].tolist() == [10.0, 0.0]


def test_bad_grids_are_refused_with_the_cause():
    with pytest.raises(ValueError, match="step_mm"):
        Grid((0.0, 10.0), (0.0, 10.0), step_mm=0.0)
    with pytest.raises(ValueError, match="the y range 0-10 mm leaves nothing inside a 6 mm margin"):
        Grid((0.0, 20.0), (0.0, 10.0), step_mm=1.0, margin_mm=6.0)


def test_the_bench_time_is_moves_plus_settle_plus_acquisition_per_point():
    points = Grid((0.0, 4.0), (0.0, 2.0), step_mm=2.0).points_mm()   # 3 x 2 points
    step_s = move_time_s(2.0, 20.0, 80.0)
    expected = 5 * step_s + 6 * (0.1 + 0.3)       # the first point is at the start: no move
    assert map_bench_time_s(points, (0.0, 0.0), 20.0, 80.0, 0.1, 0.3) == pytest.approx(expected)
