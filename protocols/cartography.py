"""Cartography (paper Sec. 5.2, Fig. 7): the grid a map visits and what it costs.

The stage holds the plate under the vibrometer's spot; the map visits a regular grid over
the plate (step, a margin kept from the edges, optionally a sub-area) in serpentine order,
so consecutive points are one step apart and the stage never flies back across the plate.
Positions are in the plate's frame, mm from the corner, x along its length (the stage's
unit, see `instruments/smc100.py`). The bench time of a map is known before it runs: per
point the stage move (both axes at once, each a trapezoidal profile), the settling wait
and the acquisition.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from squeezebench.analysis.cartography import move_time_s


@dataclass(frozen=True)
class Grid:
    """A regular grid over [x0, x1] x [y0, y1] in mm, `margin_mm` inside those bounds."""

    x_range_mm: tuple[float, float]
    y_range_mm: tuple[float, float]
    step_mm: float
    margin_mm: float = 0.0
    serpentine: bool = True

    def __post_init__(self) -> None:
        if self.step_mm <= 0:
            raise ValueError(f"grid step_mm {self.step_mm!r} must be positive")
        for name, (low, high) in (("x", self.x_range_mm), ("y", self.y_range_mm)):
            if high - low < 2 * self.margin_mm:
                raise ValueError(f"grid: the {name} range {low:g}-{high:g} mm leaves nothing inside a "
                                 f"{self.margin_mm:g} mm margin")

    def axis_mm(self, bounds: tuple[float, float]) -> np.ndarray:
        low, high = bounds[0] + self.margin_mm, bounds[1] - self.margin_mm
        n = int(np.floor((high - low) / self.step_mm + 1e-9)) + 1
        return low + self.step_mm * np.arange(n)

    def points_mm(self) -> np.ndarray:
        """(n, 2) array of (x, y) in visiting order: rows along x, every other row reversed."""
        xs, ys = self.axis_mm(self.x_range_mm), self.axis_mm(self.y_range_mm)
        rows = [xs[::-1] if self.serpentine and i % 2 else xs for i in range(len(ys))]
        return np.array([(x, y) for row, y in zip(rows, ys) for x in row])


def map_bench_time_s(points_mm: np.ndarray, start_mm: tuple[float, float], velocity_mm_per_s: float,
                     acceleration_mm_per_s2: float, settle_s: float, acquisition_s: float) -> float:
    """Bench time of a map: for each point the slower axis's move from the previous point
    (the axes move together), then the settling wait and the acquisition."""
    path = np.vstack([np.asarray(start_mm, dtype=float), np.asarray(points_mm, dtype=float)])
    steps = np.abs(np.diff(path, axis=0))
    moves = [max(move_time_s(dx, velocity_mm_per_s, acceleration_mm_per_s2),
                 move_time_s(dy, velocity_mm_per_s, acceleration_mm_per_s2)) for dx, dy in steps]
    return float(np.sum(moves) + len(steps) * (settle_s + acquisition_s))
