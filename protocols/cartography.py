"""Cartography (paper Sec. 5.2, Fig. 7): a vibration map of the plate on an x-y stage.

The stage holds the plate under the vibrometer's spot; the map visits a regular grid over
the plate (step, a margin kept from the edges, optionally a sub-area) in serpentine order,
so consecutive points are one step apart and the stage never flies back across the plate.
Positions are in the plate's frame, mm from the corner, x along its length (the stage's
unit, see `instruments/smc100.py`); rows store them in metres. The bench time of a map is
known before it runs: per point the stage move (both axes at once, each a trapezoidal
profile), the settling wait and the acquisition.

At every point the drive stays at one frequency and voltage and the point keeps its
waveforms: the velocity's phase against the piezo voltage (analysis, from the stored
records) turns amplitudes into the mode's signed shape, so nodal lines show as sign
changes. A step maps `rows_per_step` rows of the grid and is the unit of resume; each step
first returns to the reference point and re-centres on the resonance (the plate heats
under a long map), so a resumed map measures what an uninterrupted one would. On any
stop the drive goes to its minimum first, then the stage parks; a finished map leaves
the drive at its minimum and the spot on the reference point (the paper measures Fig. 8
at the centre of the plate it mapped).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from squeezebench.analysis.cartography import move_time_s
from squeezebench.protocols import resonance
from squeezebench.protocols.resonance import SearchSettings, track_resonance
from squeezebench.protocols.steps import Plate, Step, StepContext

PROTOCOL = "cartography"
log = logging.getLogger(__name__)


#: The most points a map may have. The shipped maps have 325 (4 mm step) and 1323 (2 mm);
#: a 1 mm step over the same area has 5141. Beyond this, a typo in `step_mm` (0.01 mm made
#: 50 million points, and planning them alone hung), not a plan.
MAX_MAP_POINTS = 10_000


def axis_count(bounds: tuple[float, float], step_mm: float, margin_mm: float = 0.0) -> float:
    """Positions along one axis of [low, high] at `step_mm`, `margin_mm` inside (a float:
    counted before anything is made, however many)."""
    return float(np.floor((bounds[1] - bounds[0] - 2 * margin_mm) / step_mm + 1e-9)) + 1


def axis_mm(bounds: tuple[float, float], step_mm: float, margin_mm: float = 0.0) -> np.ndarray:
    """Those positions. Unbounded: a model sampled on a fine grid (the map planner's
    continuum) is no map the stage visits, so MAX_MAP_POINTS is `Grid`'s, not theirs."""
    return bounds[0] + margin_mm + step_mm * np.arange(int(axis_count(bounds, step_mm, margin_mm)))


@dataclass(frozen=True)
class Grid:
    """A regular grid over [x0, x1] x [y0, y1] in mm, `margin_mm` inside those bounds."""

    # Checked before any point is made: at most MAX_MAP_POINTS, more than one, none negative
    # (positions are mm from the plate's corner). The docstring above is the schema's text.

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
            if low + self.margin_mm < 0:
                raise ValueError(f"grid: the {name} range starts at {low + self.margin_mm:g} mm (margin included); "
                                 "positions are mm from the plate's corner, none is negative")
        n_points = self.axis_count(self.x_range_mm) * self.axis_count(self.y_range_mm)
        if n_points > MAX_MAP_POINTS:
            raise ValueError(f"grid: step_mm {self.step_mm:g} makes {n_points:.3g} points, more than the "
                             f"{MAX_MAP_POINTS} a map may have; take a longer step or a smaller area")
        if n_points == 1:
            raise ValueError(f"grid: step_mm {self.step_mm:g} is longer than both ranges: the map would be one "
                             "point; take a step shorter than the ranges")

    def bounds_mm(self, bounds: tuple[float, float]) -> tuple[float, float]:
        """The first and last position along one axis (the margin inside `bounds`)."""
        low = bounds[0] + self.margin_mm
        return low, low + self.step_mm * (self.axis_count(bounds) - 1)

    def axis_count(self, bounds: tuple[float, float]) -> float:
        """Points along one axis (a float: counted before anything is made, however many)."""
        return axis_count(bounds, self.step_mm, self.margin_mm)

    def axis_mm(self, bounds: tuple[float, float]) -> np.ndarray:
        return axis_mm(bounds, self.step_mm, self.margin_mm)

    def rows_mm(self) -> list[np.ndarray]:
        """Each row (one y) as an (n, 2) array of (x, y) in visiting order, every other row
        reversed when serpentine."""
        xs, ys = self.axis_mm(self.x_range_mm), self.axis_mm(self.y_range_mm)
        return [np.column_stack([xs[::-1] if self.serpentine and i % 2 else xs, np.full(len(xs), y)])
                for i, y in enumerate(ys)]

    def points_mm(self) -> np.ndarray:
        """(n, 2) array of (x, y) in visiting order: rows along x, every other row reversed."""
        return np.vstack(self.rows_mm())

    def centre_point_mm(self) -> tuple[float, float]:
        """The grid point nearest the grid's centre."""
        points = self.points_mm()
        centre = points.mean(axis=0)
        return tuple(float(v) for v in points[np.argmin(np.hypot(*(points - centre).T))])


@dataclass(frozen=True)
class Parameters:
    """Campaign `parameters:` of a map. `touch_area_mm` ([x0, x1], [y0, y1]) marks the rows
    whose points the homogeneity figures use (default: every point); `reference_point_mm`
    is where the resonance is found and re-checked (default: the grid point nearest the
    centre: the area a finger explores most)."""

    search: SearchSettings
    piezo_voltage_vpp: float
    grid: Grid
    rows_per_step: int = 2
    settle_s: float = 0.02
    stage_velocity_mm_per_s: float = 20.0
    reference_point_mm: tuple[float, float] | None = None
    touch_area_mm: tuple[tuple[float, float], tuple[float, float]] | None = None

    def __post_init__(self) -> None:
        if not self.piezo_voltage_vpp > 0:
            raise ValueError(f"piezo_voltage_vpp must be positive, got {self.piezo_voltage_vpp!r}")
        if self.rows_per_step < 1:
            raise ValueError(f"rows_per_step must be at least 1, got {self.rows_per_step!r}")
        if not self.settle_s >= 0:
            raise ValueError(f"settle_s must not be negative, got {self.settle_s!r}")
        if not self.stage_velocity_mm_per_s > 0:
            raise ValueError(f"stage_velocity_mm_per_s must be positive, got {self.stage_velocity_mm_per_s!r}")

    @property
    def reference_mm(self) -> tuple[float, float]:
        return self.reference_point_mm or self.grid.centre_point_mm()

    def in_touch_area(self, x_mm: float, y_mm: float) -> bool:
        if self.touch_area_mm is None:
            return True
        (x0, x1), (y0, y1) = self.touch_area_mm
        return x0 <= x_mm <= x1 and y0 <= y_mm <= y1


def plan(params: Parameters, plate: Plate) -> list[Step]:
    rows = params.grid.rows_mm()
    n = params.rows_per_step
    chunks = [(first, rows[first:first + n]) for first in range(0, len(rows), n)]
    last = chunks[-1][0]
    return [Step(f"rows_{first:03d}", plate,
                 lambda ctx, first=first, chunk=chunk: _map_rows(ctx, params, first, chunk, last=first == last))
            for first, chunk in chunks]


def _map_rows(ctx: StepContext, params: Parameters, first_row: int, rows: list[np.ndarray], last: bool) -> None:
    stage = ctx.bench.stage
    try:
        # Every point of the whole map, before the first move: a map that cannot finish
        # is refused with the point named, not discovered half-way.
        for x_mm, y_mm in (params.reference_mm, *params.grid.points_mm()):
            stage.check_reachable(x_mm, y_mm)
        _known_stage_state(ctx, stage, params.stage_velocity_mm_per_s)
        stage.move_to_mm(*params.reference_mm)
        frequency_hz = _resonance_hz(ctx, params)
        ctx.drive.set_piezo_voltage(params.piezo_voltage_vpp)
        ctx.drive.set_frequency(frequency_hz)
        for row_offset, row in enumerate(rows):
            for x_mm, y_mm in row:
                _record_point(ctx, params, stage, first_row + row_offset, x_mm, y_mm, frequency_hz)
        if last:   # the drive first; then the spot back on the centre, where Fig. 8 is measured
            ctx.drive.to_minimum()
            stage.move_to_mm(*params.reference_mm)
    except BaseException:
        _bring_down(ctx, stage)
        raise


def _bring_down(ctx: StepContext, stage) -> None:
    """After any stop or failure: the piezos first, then the stage out of the laser's way.
    Each is tried whatever the other did; a failure is logged, never put in place of the
    cause that brought the map down."""
    for what, action in (("drive to minimum", ctx.drive.to_minimum), ("stage park", stage.park)):
        try:
            action()
        except Exception as exc:   # the cause being raised matters more
            log.warning("cartography: %s failed while stopping: %s", what, exc)


def _known_stage_state(ctx: StepContext, stage, velocity_mm_per_s: float) -> None:
    """Homed, at the map's speed and parked, whatever the stage did before (the previous
    step's last point, a power-on after a crash, a previous user's speed). The time this
    takes depends on that history, so the step's bench time starts once the stage is
    parked: a resumed map then stores the bench times an uninterrupted one would."""
    stage.home()
    for axis in ("x", "y"):
        stage.set_velocity_mm_per_s(axis, velocity_mm_per_s)
    stage.park()
    ctx.clock_start_s = ctx.bench.clock.now_s()


def _resonance_hz(ctx: StepContext, params: Parameters) -> float:
    """The first step searches at the reference point; later ones re-centre on the last
    resonance found there (the plate heats under a long map)."""
    known = ctx.context.get("cartography_resonance_hz")
    if known is None:
        frequency_hz = resonance.record_search(ctx, params.search)
    else:
        ctx.drive.set_piezo_voltage(params.search.piezo_voltage_vpp)
        found = track_resonance(ctx.acquisition.measure_at, known, params.search)
        for point in found.points:
            ctx.record(point, protocol=resonance.PROTOCOL, sweep=True, resonance_frequency_hz=found.frequency_hz)
        frequency_hz = found.frequency_hz
    ctx.updates["cartography_resonance_hz"] = frequency_hz
    return frequency_hz


def _record_point(ctx: StepContext, params: Parameters, stage, row: int, x_mm: float, y_mm: float,
                  frequency_hz: float) -> None:
    x_read_mm, y_read_mm = stage.move_to_mm(x_mm, y_mm)
    ctx.bench.clock.sleep(params.settle_s)
    ctx.record(ctx.acquisition.measure(keep_waveforms=True), resonance_frequency_hz=frequency_hz,
               grid_row=row, x_m=x_mm * 1e-3, y_m=y_mm * 1e-3,
               stage_x_m=x_read_mm * 1e-3, stage_y_m=y_read_mm * 1e-3,
               in_touch_area=params.in_touch_area(x_mm, y_mm))


def map_bench_time_s(points_mm: np.ndarray, start_mm: tuple[float, float], velocity_mm_per_s: float,
                     acceleration_mm_per_s2: float, settle_s: float, acquisition_s: float) -> float:
    """Bench time of a map: for each point the slower axis's move from the previous point
    (the axes move together), then the settling wait and the acquisition."""
    return map_time_s(map_moves_s(points_mm, start_mm, velocity_mm_per_s, acceleration_mm_per_s2), len(points_mm),
                      settle_s, acquisition_s)


def map_moves_s(points_mm: np.ndarray, start_mm: tuple[float, float], velocity_mm_per_s: float,
                acceleration_mm_per_s2: float) -> float:
    """The stage's part of a map's bench time: for each point the slower axis's move from the
    previous one. It depends on the grid alone: a plan pricing several averagings of one
    grid computes it once (`map_time_s` adds the rest)."""
    path = np.vstack([np.asarray(start_mm, dtype=float), np.asarray(points_mm, dtype=float)])
    steps = np.abs(np.diff(path, axis=0))
    return float(np.sum([max(move_time_s(dx, velocity_mm_per_s, acceleration_mm_per_s2),
                              move_time_s(dy, velocity_mm_per_s, acceleration_mm_per_s2)) for dx, dy in steps]))


def map_time_s(moves_s: float, n_points: int, settle_s: float, acquisition_s: float) -> float:
    """Bench time of a map of `n_points` whose moves take `moves_s` (`map_moves_s`): at each
    point the settling wait and the acquisition after the move."""
    return float(moves_s + n_points * (settle_s + acquisition_s))
