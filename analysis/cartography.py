"""Reduction of a vibration map (Fig. 7): the numbers a plate designer reads off it.

A map is tidy: one row per grid point with its position and the velocity amplitude and
phase against the drive. The phase turns the amplitude into the real mode's signed value
(a standing wave is in phase or in antiphase with the drive), so nodal lines show as sign
changes; the homogeneity numbers are over the touch area's amplitudes; the modal
assurance criterion compares the measured shape with the predicted one (Allemang,
"The modal assurance criterion - twenty years of use and abuse", Sound and Vibration
37(8), 2003, Eq. 1). The stage's move time is the kinematics both the simulated stage and
the map's bench-time estimate use.

A map whose plate the model knows is compared with the model's working mode at the same
points: the prediction comes from geometry and datasheets (`predicted_plates`), never
from the simulated bench.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import pandas as pd

from squeezebench.analysis.budgets import Budget, Term
from squeezebench.plates.specifications import SPECIFICATIONS


@dataclass(frozen=True)
class Homogeneity:
    """Velocity amplitude over the touch area (the unit of the amplitudes given)."""

    mean: float
    minimum: float
    maximum: float
    coefficient_of_variation: float   # standard deviation / mean, population (ddof 0)
    share_of_peak: float              # the stated share of the peak amplitude
    fraction_above_share: float       # fraction of the points above it (of the area once corrected, `grid_bias`)
    n_points: int


def signed_amplitude(amplitude: np.ndarray, phase_rad: np.ndarray) -> np.ndarray:
    """amplitude x cos(phase against the drive): the real mode's signed value."""
    return np.asarray(amplitude, dtype=float) * np.cos(np.asarray(phase_rad, dtype=float))


def homogeneity(amplitude: np.ndarray, share_of_peak: float = 0.5) -> Homogeneity:
    """Homogeneity numbers of the amplitudes of the touch area's grid points."""
    values = np.abs(np.asarray(amplitude, dtype=float).ravel())
    if values.size == 0:
        raise ValueError("no map points in the touch area")
    if not 0.0 < share_of_peak < 1.0:
        raise ValueError(f"share_of_peak {share_of_peak!r} must be between 0 and 1")
    mean = float(values.mean())
    return Homogeneity(mean=mean, minimum=float(values.min()), maximum=float(values.max()),
                       coefficient_of_variation=float(values.std() / mean) if mean > 0 else float("inf"),
                       share_of_peak=share_of_peak,
                       fraction_above_share=float(np.mean(values >= share_of_peak * values.max())),
                       n_points=int(values.size))


def coefficients_of_variation(amplitudes: np.ndarray) -> np.ndarray:
    """`homogeneity(row).coefficient_of_variation` of every row of `amplitudes` (draws x
    points) at once, equal to the last bit: the same reductions, each along its row (a
    Monte Carlo's draws, one `homogeneity` per row, took most of a map plan's candidates)."""
    values = np.abs(np.asarray(amplitudes, dtype=float))
    mean, std = values.mean(axis=1), values.std(axis=1)
    return np.divide(std, mean, out=np.full(mean.shape, np.inf), where=mean > 0)


#: Spots per axis over a grid point's cell at which the field between the points is read
#: (the midpoint rule over the reconstructed field: 6 and 10 give the same figures).
READING_SAMPLES = 8
#: The readings of the field between the points, each with the points it needs along every
#: axis it reads across: straight lines, and the bending line through four points
#: (`bending_weights`); `cell_readings` takes the smoothest the grid allows.
READING_ORDERS = (("linear", 2), ("bending", 4))
#: Terms of the series of `bending_functions`: at k x = 4 pi (a wave at the Nyquist limit,
#: read 4 steps from a stencil's point) the last is below 1e-9 of the sum.
BENDING_SERIES_TERMS = 12


def cell_offsets(samples: int) -> np.ndarray:
    """Where `samples` evenly spread spots lie across a grid point's cell along one axis, in
    grid steps from the point (the midpoint rule's: -1/2 < offset < 1/2)."""
    return (np.arange(samples) + 0.5) / samples - 0.5


def bending_functions(kh_fourth: float, x_steps: np.ndarray) -> np.ndarray:
    """The Krylov-Duncan functions phi_m(x) = m! sum_n (k h)^(4n) x^(4n+m) / (4n+m)!, m = 0..3,
    of x in grid steps h (last axis m): a basis of the solutions of the bending equation
    along a line, w'''' = k^4 w (Kirchhoff plate, D grad^4 w = rho h omega^2 w, for the
    x-dependence of an (n, 0) mode; an Euler-Bernoulli beam alike), spanned by cos, sin, cosh
    and sinh of k x. In series form they stay well conditioned as k h -> 0, where they are
    1, x, x^2 and x^3: the bending reading is then the cubic through four points."""
    x = np.asarray(x_steps, dtype=float)
    # x^(4n+m) are x^0..x^47 in order: running products times the
    # series' coefficients as one matrix product, not 48 pow calls per spot, which were
    # most of a map's reading between the points.
    coefficients = (kh_fourth ** _SERIES_ORDERS * _SERIES_COEFFICIENTS)[:, :, None] * np.eye(4)   # n, m, function
    factors = np.empty((4 * BENDING_SERIES_TERMS, x.size))   # power, spot: the running product runs along rows
    factors[0], factors[1:] = 1.0, x.ravel()
    powers = np.multiply.accumulate(factors, axis=0)
    return (coefficients.reshape(4 * BENDING_SERIES_TERMS, 4).T @ powers).T.reshape(x.shape + (4,))


# The series' constants, made once: every reading of every map evaluates the series.
_SERIES_ORDERS = np.arange(BENDING_SERIES_TERMS)[:, None]
_SERIES_COEFFICIENTS = np.array([[math.factorial(m) / math.factorial(4 * n + m) for m in range(4)]
                                 for n in range(BENDING_SERIES_TERMS)])


def wavenumber_per_step(grid: np.ndarray, axis: int) -> float:
    """k h (rad) of the standing wave along `axis` of a table of the signed field at grid
    steps h: any A cos(k x) + B sin(k x) sampled at equal steps obeys w[i-1] + w[i+1] =
    2 cos(k h) w[i] (Prony's recurrence), whose cos(k h) the least squares over every line
    give; above 1, the wave is evanescent, cosh(k h), whose k spans the same bending
    solutions. Read from the map alone: the plate's drawn thickness and moduli move k by
    a few per cent, and the map samples the mode it has. 0 for fewer than 3 points."""
    cosine = _recurrence_cosine(np.moveaxis(np.asarray(grid, dtype=float), axis, 0))
    if cosine is None:
        return 0.0
    return float(np.arccos(max(cosine, -1.0))) if cosine <= 1.0 else float(np.arccosh(cosine))


def _recurrence_cosine(lines: np.ndarray) -> float | None:
    """The least-squares cos(k h) of Prony's recurrence over `lines` (the axis read first);
    None for fewer than 3 points or a field of zeros in the middle."""
    middle = lines[1:-1]
    square = float(np.sum(middle**2))
    if square == 0.0:
        return None
    return float(np.sum(middle * (lines[:-2] + lines[2:]))) / (2.0 * square)


def recurrence_misfit(grid: np.ndarray, axis: int, straight: bool) -> float:
    """Share of the field along `axis` that a standing wave (its recurrence's own least-squares
    cosine, `wavenumber_per_step`), or with `straight` a line (cos k h = 1), does not hold:
    the rms of Prony's residual w[i-1] + w[i+1] - 2 cos(k h) w[i] over twice the rms of the
    middle points, 0 for a pure standing wave (or line). A mode's envelope, its edges'
    evanescent parts and the points' noise leave it above 0: what the reading between the
    points misreads. 1 (nothing checked) for an axis of 2 points, which no recurrence tests;
    0 for a single one, which is not read across."""
    lines = np.moveaxis(np.asarray(grid, dtype=float), axis, 0)
    if lines.shape[0] < 3:
        return 1.0 if lines.shape[0] == 2 else 0.0
    cosine = 1.0 if straight else _recurrence_cosine(lines)
    if cosine is None:
        return 0.0
    middle = lines[1:-1]
    residual = lines[:-2] + lines[2:] - 2.0 * cosine * middle
    return math.sqrt(float(np.sum(residual**2)) / float(np.sum(middle**2))) / 2.0


def bending_weights(n: int, kh: float, positions_steps: np.ndarray, width: int) -> np.ndarray:
    """Weights (positions x n points) reading a line of n points at `positions_steps` (grid
    steps from the first point) with the `width` nearest points about each position (past
    the outer points, the edge's own): exact for every solution of the bending equation of
    wavenumber k (`bending_functions`) with 4 points, and for straight lines with 2. A
    cubic spline misreads a standing wave sampled 2.4 times per half-wavelength by a few
    per cent between the points, enough to move a CV's grid error by half."""
    positions = np.asarray(positions_steps, dtype=float)
    weights = np.zeros((positions.size, n))
    if n == 1:
        weights[:, 0] = 1.0
        return weights
    left = np.floor(positions).astype(int)
    start = np.clip(left - (width // 2 - 1), 0, n - width)
    nodes = start[:, None] + np.arange(width)
    kh_fourth = kh**4 if width == 4 else 0.0
    basis = bending_functions(kh_fourth, nodes - left[:, None])[..., :width]        # position, node, function
    wanted = bending_functions(kh_fourth, positions - left)[..., :width, None]       # position, function, 1
    np.put_along_axis(weights, nodes, np.linalg.solve(np.swapaxes(basis, 1, 2), wanted)[..., 0], axis=1)
    return weights


@functools.lru_cache(maxsize=64)
def _line_reader(n: int, kh: float, samples: int, shift: float, width: int) -> np.ndarray:
    """`bending_weights` reading a line of n points at `samples` spots about each
    (`cell_offsets` moved by `shift` steps; one: the point itself), kept: a map's noise draws
    read every draw's grid with the same lines (`summarise_map`), 1,600 solves a summary."""
    spots = cell_offsets(samples) + shift if n > 1 else np.zeros(1)
    weights = bending_weights(n, kh, (np.arange(n)[:, None] + spots).ravel(), width)
    weights.flags.writeable = False
    return weights


@dataclass(frozen=True)
class CellReadings:
    """The signed field of a map's points as a table over their x (rows) and y (columns)
    values (`_point_grid`), read between the points by the bending line of each axis's
    own wavenumber (`wavenumber_per_step`), or by straight lines on grids too small for it
    (`method`, of READING_ORDERS). `values`: |field| over every point's cell, one row per
    point, one column per spot (READING_SAMPLES per wide axis, the x offset the slower),
    the same spot of every cell in one column."""

    grid: np.ndarray
    filled: np.ndarray
    wavenumbers: tuple[float, float]   # k x step per axis, rad
    steps_m: tuple[float, float]       # the grid's step per axis (inf along a single row or column)
    method: str
    # over_cells' readings at each count of spots, unmoved: a summary reads a figure's cells for
    # its correction (`grid_bias`), again for its correction's term and for its quadrature term
    _unmoved: dict[int, np.ndarray] = field(default_factory=dict, init=False, repr=False, compare=False)

    @property
    def values(self) -> np.ndarray:
        return self.over_cells(READING_SAMPLES)

    def _reader(self, axis: int, samples: int, shift: float = 0.0) -> np.ndarray:
        """Weights reading the field along `axis` at `samples` spots (`cell_offsets`, all moved
        by `shift` grid steps; one: the point itself) about every point of the grid."""
        return _line_reader(self.grid.shape[axis], self.wavenumbers[axis], samples, shift,
                            dict(READING_ORDERS)[self.method])

    def _spots(self, readers: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        """|field| at the spots `readers` read (`_reader`) about every point: points x spots,
        the x spot the slower."""
        per_axis = [reader.shape[0] // n for reader, n in zip(readers, self.grid.shape)]
        read = (readers[0] @ self.grid @ readers[1].T).reshape(self.grid.shape[0], per_axis[0],
                                                               self.grid.shape[1], per_axis[1])
        return np.abs(read.transpose(0, 2, 1, 3)[self.filled].reshape(int(self.filled.sum()), -1))

    @functools.cached_property
    def at_points(self) -> np.ndarray:
        """|field| at the points themselves, read as the cells are (one spot a point)."""
        return self._spots(tuple(self._reader(axis, 1) for axis in (0, 1)))

    def over_cells(self, samples: int, shift: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
        """|field| over the cells at `samples` spots per wide axis (`cell_offsets`), the spots'
        lattice moved by `shift` grid steps per axis (`grid_quadrature_term`'s registrations);
        an unmoved lattice's reading is kept (read-only)."""
        if shift != (0.0, 0.0):
            return self._spots(tuple(self._reader(axis, samples, shift[axis]) for axis in (0, 1)))
        if samples not in self._unmoved:
            cells = self._spots(tuple(self._reader(axis, samples) for axis in (0, 1)))
            cells.flags.writeable = False
            self._unmoved[samples] = cells
        return self._unmoved[samples]

    def across(self, axis: int) -> np.ndarray:
        """|field| over the cells read across `axis` alone (READING_SAMPLES spots along it, the
        other axis at the point): what the reading between the points along that axis gives."""
        return self._spots(tuple(self._reader(a, READING_SAMPLES if a == axis else 1) for a in (0, 1)))


def _point_grid(x_m: np.ndarray, y_m: np.ndarray, signed: np.ndarray) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """The points as a table over their x (rows) and y (columns) values, both sorted: its
    axes, the signed field at each cell (the mean of the points there; NaN readings count as
    missing) and which cells a point filled. A missing point takes its column's previous,
    then next, value along x, then its row's along y. In NumPy: a pandas pivot table took
    13 ms, most of a reading's time."""
    x, y = (np.round(np.asarray(axis, dtype=float), 9) for axis in (x_m, y_m))
    v = np.asarray(signed, dtype=float)
    read = ~np.isnan(v)
    (xs, row), (ys, column) = (np.unique(axis[read], return_inverse=True) for axis in (x, y))
    cell = row * ys.size + column
    counts = np.bincount(cell, minlength=xs.size * ys.size).reshape(xs.size, ys.size)
    sums = np.bincount(cell, weights=v[read], minlength=xs.size * ys.size).reshape(xs.size, ys.size)
    filled = counts > 0
    grid = np.divide(sums, counts, out=np.full(sums.shape, np.nan), where=filled)
    for axis in (0, 1):
        grid = _backward_filled(_forward_filled(grid, axis), axis)
    grid.flags.writeable = False   # the readings' cached fields were read off it as it is
    return [xs, ys], grid, filled


def _forward_filled(grid: np.ndarray, axis: int) -> np.ndarray:
    """`grid` with each NaN taking the last value before it along `axis` (pandas' ffill)."""
    index = np.where(np.isnan(grid), 0, np.arange(grid.shape[axis]).reshape([-1 if a == axis else 1 for a in (0, 1)]))
    return np.take_along_axis(grid, np.maximum.accumulate(index, axis=axis), axis=axis)


def _backward_filled(grid: np.ndarray, axis: int) -> np.ndarray:
    """`grid` with each NaN taking the first value after it along `axis` (pandas' bfill)."""
    return np.flip(_forward_filled(np.flip(grid, axis), axis), axis)


def cell_readings(x_m: np.ndarray, y_m: np.ndarray, signed: np.ndarray,
                  wavenumbers: tuple[float, float] | None = None) -> CellReadings | None:
    """The vibration over the grid points' cells, read from the field between the points
    (None for a single point, which has no cell to read across): a plate's mode shape is
    smooth in its signed deflection (its amplitude alone has a kink at each nodal line), so
    the signed map is read between the points and its magnitude taken (`CellReadings`).
    The bending reading (READING_ORDERS) holds a standing wave of any phase exactly from
    just over one point per half-wavelength on (k h < pi), where a cubic does not.
    `wavenumbers`: read with these (k h per axis) instead of the field's own."""
    points = [len(np.unique(np.round(np.asarray(axis, dtype=float), 9))) for axis in (x_m, y_m)]
    if points == [1, 1]:
        return None
    method = [name for name, least in READING_ORDERS if all(n >= least or n == 1 for n in points)][-1]
    axes, grid, filled = _point_grid(x_m, y_m, signed)
    steps_m = tuple(float(np.diff(axis).min()) if len(axis) > 1 else math.inf for axis in axes)
    if wavenumbers is None:
        wavenumbers = tuple(wavenumber_per_step(grid, axis) if method == "bending" else 0.0 for axis in (0, 1))
    return CellReadings(grid, filled, wavenumbers, steps_m, method)


@dataclass(frozen=True)
class GridError:
    """The error of homogeneity figure `attribute` read as a grid's points' (`homogeneity`,
    each point standing for its cell) against the same figure of the vibration over their
    cells, as a function of (points' amplitudes, the cells' amplitudes). The area above the
    share of the peak is the cells' above the share of the points' peak, as a map reads it."""

    attribute: str
    share_of_peak: float
    samples: int | None = None   # spots per axis its cells are read at (None: the figure's own rule, `cell_samples`)

    @property
    def cell_samples(self) -> int:
        """Spots per axis over each cell at which `grid_bias` reads the figure's cells: the CV's
        midpoint rule at READING_SAMPLES, the area's at AREA_SAMPLES (the union of its lattice's
        registrations, `grid_quadrature_term`), unless `samples` says otherwise."""
        if self.samples is not None:
            return self.samples
        return AREA_SAMPLES if self.attribute == "fraction_above_share" else READING_SAMPLES

    def threshold(self, points: np.ndarray) -> float:
        """The share of the points' peak amplitude, above which the area counts a cell's spots."""
        return self.share_of_peak * homogeneity(points, self.share_of_peak).maximum

    def __call__(self, points: np.ndarray, cells: np.ndarray) -> float:
        read = homogeneity(points, self.share_of_peak)
        if self.attribute == "fraction_above_share":
            return read.fraction_above_share - float(np.mean(cells >= self.threshold(points)))
        return getattr(read, self.attribute) - getattr(homogeneity(cells, self.share_of_peak), self.attribute)


def grid_bias(readings: CellReadings | None, error: GridError) -> float:
    """`error` of the grid where it fell: its points against the field read over their own
    cells (at `GridError.cell_samples` spots per axis), the correction the map's figure takes
    (`grid_correction_term` its own error; 0 without readings).

    A grid of 2.3 points per half-wavelength reads |a standing wave| at a mix of antinodes
    and flanks that its registration on the mode sets, and the bending reading holds the
    field between the points exactly for a standing wave: on the paper's 4 mm map of the
    large plate at its own registration the true CV error (the points against the mode
    over their cells, 8 x 8 spots) is -0.0208 and the reading gives -0.0214; the area's
    +0.0555 and +0.0538. A known systematic effect is corrected (GUM 3.2.4, F.2.4.5): the
    map's homogeneity figures are the points' less this bias, the vibration's over the cells
    as the reading gives it. It was carried as a bias bound, which held the error at
    p95 |error| / U 0.75 (CV) and 0.6 (area) on 40 benches: a U of the bias's size for an
    error the reading gets to 3 %."""
    if readings is None:
        return 0.0
    return float(error(readings.at_points.ravel(), readings.over_cells(error.cell_samples).ravel()))


def grid_correction_term(readings: CellReadings | None, error: GridError) -> Term:
    """Type B term of a homogeneity figure corrected by its grid bias (`grid_bias`): the
    correction's own error from the reading's misfit, propagated through it (GUM 5.1.3).

    The bending reading holds the part of the field that obeys the standing wave's recurrence
    along each axis; the rest, a share e_a of the field along axis a (`recurrence_misfit`),
    it may misread between the points along that axis as a whole. Each axis's reading makes
    its own part B_a of the CV's bias (the points against the field read across that axis
    alone, `CellReadings.across`), so the corrected CV is uncertain by e_a |B_a|, the axes in
    quadrature (independent readings). An (n, 0) mode's bias is made along its length: the
    misfit across its width (0.029 on the paper map, its edges' evanescent parts) reads a
    field that hardly varies there (|B_y| under 2 % of |B_x|), and taken with the length's
    (0.025) as one share of the whole bias it made the term 1.5 times what the length's
    reading can misread. On the large plate's mode at the placements a bench draws the
    reading's true residual is 0.5 to 1.3 of the term (4 mm grid) and 1.5 to 2.3 (2 mm, where
    the cells' quadrature term is 5 to 11 times larger). Normal: the misfit is a sum over
    many points, of either sign; the residual's spread over the grids it was checked on is
    no bound (a rectangle at e |B| would not hold the 2 mm grid's).

    The area moves as spots cross the share of the peak, each cell's as its own stencil of
    points reads the field there: a cell's part along axis a is half the change of its spots
    above the share as the departures from its point read across that axis scale by 1 +- e_a,
    and the cells and axes add in quadrature. Their net change (the whole field's departures
    scaled at once) let the crossings of rising and falling flanks cancel, which the
    reading's error does not do: on the paper map's benches it ranged 0.00004 to 0.003 where
    the reading's true area error was up to 0.0015, with no relation of sign; in quadrature the
    cells give 0.0008 to 0.0011."""
    if readings is None:
        return Term("grid (its correction's reading)", "B", 0.0, "a single point: no grid correction", rectangular=False)
    misfits = [recurrence_misfit(readings.grid, axis, readings.method == "linear") for axis in (0, 1)]
    points = readings.at_points
    bias = grid_bias(readings, error)
    if error.attribute == "fraction_above_share":
        threshold = error.threshold(points.ravel())
        parts = []
        for axis, misfit in enumerate(misfits):
            across = readings.across(axis)
            above = [np.sum(points + (1.0 + sign * misfit) * (across - points) >= threshold, axis=1)
                     for sign in (1.0, -1.0)]
            parts.append((above[0] - above[1]) / (2.0 * across.size))
        u = float(np.linalg.norm(parts))
    else:
        u = math.hypot(*(misfit * error(points.ravel(), readings.across(axis).ravel())
                         for axis, misfit in enumerate(misfits)))
    return Term("grid (its correction's reading)", "B", u,
                f"the bias {bias:+.4g} subtracted, read between the points by the {readings.method} reading, whose "
                f"recurrence misfits {misfits[0]:.3g} and {misfits[1]:.3g} of the field along x and y",
                rectangular=False)


#: The order p of the midpoint rule's error over the cells for the CV, a figure of mean
#: squares of a continuous field (kinks at nodal lines included): h^2 (Richardson).
CV_QUADRATURE_ORDER = 2
#: Registrations per axis of the area's lattice of spots within one spot (`grid_quadrature_term`):
#: 5 x 5 lattices of READING_SAMPLES^2 spots a cell, which together are the midpoint rule of
#: 5 READING_SAMPLES spots per axis (AREA_SAMPLES). Odd, so that cell_offsets(5) holds 0: the
#: lattice the figure was read at before the union is one of them. An (n, 0) mode's count,
#: whose contours cross the width as straight lines, can dip within a fraction of a spot: on
#: the paper map's bench 45 that lattice read the area 0.0033 under the union (the truth's
#: own, 0.0047) where four moves (+-1/8 and +-3/8 of a spot) read +-0.0012 of it.
LATTICE_REGISTRATIONS = 5
#: Spots per axis over each cell at which the area above the share of the peak is read
#: (`GridError.cell_samples`): the union of the LATTICE_REGISTRATIONS^2 registrations of the
#: READING_SAMPLES lattice, the finer midpoint rule whose count is their counts' mean. A known
#: error of the coarser count, its dip where the lattice fell on the contours, is corrected
#: rather than budgeted (GUM 3.2.4): on seeds 41-79 of the world's benches (the paper map,
#: each reading against itself over 96 x 96 spots a cell) the 8-spot lattice erred
#: -0.0004 +- 0.0017 and the union -0.00005 +- 0.00024, closer on 38 benches of 39; against
#: the truth (the mode over 32 x 32 spots a cell) -0.0005 +- 0.0022 and -0.0002 +- 0.0009.
AREA_SAMPLES = LATTICE_REGISTRATIONS * READING_SAMPLES

#: Points per axis at which the coverage study samples each mapped point's cell for the
#: continuous area above the share of the peak and coefficient of variation (`protocols.bench_errors`).
#: 3 x 3 were too few for the paper map's 2.3 points per half-wavelength: a cell's mean of
#: cos(2 k x) is sin(k h) / (k h) = 0.718 of its amplitude at k h = 1.36, the 3-spot rule's
#: sin(k h) / (3 sin(k h / 3)) = 0.744, and at the map's own registration the true CV
#: error over 8 x 8 spots is -0.0208, over 3 x 3 -0.0145: the study scored a smaller
#: error than the grid makes (p95 |error| / U 0.56 where 0.73 was due). The map's own rule,
#: READING_SAMPLES (8), was then taken, which scored the reading's own 8 x 8 spots
#: against the same spots of the truth: the error of reading the cells at those spots, which
#: `cartography.grid_quadrature_term` claims to cover, was never drawn (the study tested
#: nothing of it). Four times finer, the truth is the continuum's to what that term is about:
#: on bench 45's map the true area over 8, 16, 32, 64 and 128 spots reads 0.6480, 0.6530, 0.6534,
#: 0.6527 and 0.6528 (the 8-spot lattice's error -0.0048, 32's +0.0007), its CV 0.476339,
#: 0.476389, 0.476329, 0.476336 and 0.476338. Twelve times (96): the area is read over 40
#: spots per axis (AREA_SAMPLES), and a judge must be finer than what it
#: judges; on seeds 41-79 of the world's benches the 32-spot truth erred +0.0001 +- 0.0006
#: against 96 x 96, as much as the 40-spot reading's whole error. A map bench takes some
#: 0.75 CPU-s more (4.9 where it took 4.1).
TRUTH_CELL_SAMPLES = 12 * READING_SAMPLES


#: Registrations per axis of the coarser union the area's union is compared with
#: (`grid_quadrature_term`): 3 x 3 lattices moved by 0 and +-1/3 of a spot, the midpoint rule of
#: 3 READING_SAMPLES spots per axis.
COARSER_REGISTRATIONS = 3


def grid_quadrature_term(readings: CellReadings | None, error: GridError) -> Term:
    """Term of a corrected homogeneity figure for reading the cells at a midpoint rule's
    spots instead of over their whole area, normal (a sum over many cells, of either sign).
    The two figures err differently:

    - the CV integrates a continuous field at READING_SAMPLES spots per axis, so the rule
      errs by c h^2, the same at every registration of its spots: Richardson's estimate from
      the change D of the figure as the spots double, |D| / (1 - 2^-p), p = CV_QUADRATURE_ORDER
      (4/3 |D|), Type B;
    - the area counts the spots above the share of the peak, a step: its error is where the
      lattice of spots falls on the threshold's contour, of either sign and with no order in
      h that one doubling could extrapolate (it read the paper map's term 0.001 to 0.013
      between benches). It is read over the union of the lattice's registrations within one
      spot (AREA_SAMPLES; LATTICE_REGISTRATIONS^2 lattices of READING_SAMPLES spots per axis
      moved by cell_offsets(LATTICE_REGISTRATIONS) of a spot), whose count is the mean of
      theirs. The union's own error is read two ways, each blind where the other sees, in
      quadrature: the registrations' spread s (ddof 1) over the square root of their number,
      s / LATTICE_REGISTRATIONS (GUM 4.2.3), which holds where their counts vary apart
      (contours at angles to the lattice), and the change D from the coarser union
      (COARSER_REGISTRATIONS^2 registrations), which sees contours that cross the cells as
      straight lines along an axis of the lattice (an (n, 0) mode's): a move along them
      changes no count, so the 25 registrations are 5, and the union's error is their
      sawtooth at a fifth of the spot, which the five's spread does not bound. On cosine
      modes against their continuum (`tests/test_cartography_mode.py`, 2 to 4 points per
      half-wavelength) 1.96 times the spread alone held the union's error on 78 % of (n, 0)
      modes and 99-100 % of 2-D ones and plane waves, the change alone on 83-88 %, the two
      in quadrature on 95 % and 100 %. Type B."""
    if readings is None:
        return Term("grid (the cells' quadrature)", "B", 0.0, "a single point: no cells", rectangular=False)
    points = readings.at_points.ravel()
    if error.attribute == "fraction_above_share":
        shifts = cell_offsets(LATTICE_REGISTRATIONS) / READING_SAMPLES
        figures = [error(points, readings.over_cells(READING_SAMPLES, (dx, dy)).ravel()) for dx in shifts for dy in shifts]
        spread = float(np.std(figures, ddof=1)) / LATTICE_REGISTRATIONS
        coarser = COARSER_REGISTRATIONS * READING_SAMPLES
        change = error(points, readings.over_cells(coarser).ravel()) - float(np.mean(figures))
        return Term("grid (the cells' quadrature)", "B", math.hypot(spread, change),
                    f"{AREA_SAMPLES} spots per axis over each cell, the union of {LATTICE_REGISTRATIONS ** 2} "
                    f"registrations of {READING_SAMPLES}: their spread over {LATTICE_REGISTRATIONS} ({spread:.2g}) "
                    f"and the change from {coarser} ({change:+.2g}) in quadrature", rectangular=False)
    change = (error(points, readings.over_cells(READING_SAMPLES).ravel())
              - error(points, readings.over_cells(2 * READING_SAMPLES).ravel()))
    return Term("grid (the cells' quadrature)", "B", abs(change) / (1.0 - 2.0**-CV_QUADRATURE_ORDER),
                f"{READING_SAMPLES} against {2 * READING_SAMPLES} spots per axis over each cell, an error of order "
                f"{CV_QUADRATURE_ORDER} (Richardson)", rectangular=False)


def modal_assurance(measured: np.ndarray, predicted: np.ndarray) -> float:
    """MAC = |m^H p|^2 / ((m^H m)(p^H p)) of two shapes at the same points, real or complex;
    1 for proportional shapes whatever the scale, 0 for orthogonal ones."""
    m = np.asarray(measured).ravel()
    p = np.asarray(predicted).ravel()
    if m.shape != p.shape or m.size == 0:
        raise ValueError(f"shapes at different points: {m.size} measured, {p.size} predicted")
    norm = np.vdot(m, m).real * np.vdot(p, p).real
    if norm == 0:
        raise ValueError("a shape that is zero everywhere has no modal assurance")
    return float(abs(np.vdot(m, p)) ** 2 / norm)


def move_time_s(distance_mm: float, velocity_mm_per_s: float, acceleration_mm_per_s2: float) -> float:
    """Duration of a point-to-point move with a trapezoidal (or, if short, triangular)
    velocity profile: d/v + v/a when the axis reaches v, else 2 sqrt(d/a)."""
    d = abs(distance_mm)
    if d >= velocity_mm_per_s**2 / acceleration_mm_per_s2:
        return d / velocity_mm_per_s + velocity_mm_per_s / acceleration_mm_per_s2
    return 2.0 * math.sqrt(d / acceleration_mm_per_s2)


# -- a stored map ----------------------------------------------------------------------------------
#: The columns of a reduced map (report/map_points.csv), one row per grid point.
MAP_COLUMNS = ["run_name", "plate", "grid_row", "x_m", "y_m", "in_touch_area", "generator_frequency_hz",
               "piezo_voltage_setpoint_vpp", "velocity_pp_mps", "velocity_pp_mps_u", "velocity_phase_rad",
               "velocity_phase_rad_u", "signed_velocity_pp_mps"]
#: The homogeneity figures a map reports over the cells (corrected by `grid_bias`).
GRID_FIGURES = ("coefficient_of_variation", "fraction_above_share")
#: Draws of the points' noise behind the homogeneity figures' uncertainty (seeded).
NOISE_DRAWS = 400


def map_points(run) -> pd.DataFrame:
    """Every mapped point of the run, reduced from its stored record: velocity amplitude
    (sine fit) and its phase against the piezo voltage, and the signed velocity."""
    from squeezebench.analysis import tables

    rows = run.protocol("cartography")
    if rows.empty:
        raise tables.MissingDataError("no map in this run (protocol 'cartography')")
    points = tables.reduced_points(run, rows)
    points["signed_velocity_pp_mps"] = signed_amplitude(points["velocity_pp_mps"], points["velocity_phase_rad"])
    points["in_touch_area"] = points["in_touch_area"].astype(bool)
    return points[MAP_COLUMNS].reset_index(drop=True)


def width_uniformity(x_m: np.ndarray, signed: np.ndarray) -> float:
    """Share of the map's mean square in its width-averaged part, sum over x of the mean
    across y squared (times the points per x) over the sum of squares: 1 for an (n, 0)
    mode whose deflection does not vary across the width (the paper's "uniform across the
    plate"), the measure `plate_modes` uses to call a mode (n, 0)."""
    signed = np.asarray(signed, dtype=float).ravel()
    total = float((signed**2).sum())
    if not total > 0:
        return float("nan")
    # grouped by x in NumPy: a pandas groupby costs milliseconds a call, and a layout sweep calls it per layout
    _, column = np.unique(np.round(np.asarray(x_m, dtype=float).ravel(), 9), return_inverse=True)
    points = np.bincount(column)
    return float(((np.bincount(column, signed) / points) ** 2 * points).sum() / total)


def nodal_lines_m(x_m: np.ndarray, signed: np.ndarray) -> np.ndarray:
    """x of the sign changes of the width-averaged signed map (linear interpolation)."""
    from squeezebench.plates.plate_modes import sign_changes

    profile = pd.Series(np.asarray(signed, dtype=float)).groupby(np.round(np.asarray(x_m, dtype=float), 9)).mean()
    return sign_changes(profile.index.to_numpy(), profile.to_numpy())


def velocity_scale_terms(velocity: float) -> tuple:
    """The Type B terms of a point's velocity budget (CH3 gain and the decoder's scale,
    rectangles) at `velocity`: the factor every velocity of a map shares. One bench, one
    factor: it scales the map's mean and peak, never its shape or homogeneity."""
    from squeezebench.analysis.uncertainty import velocity_budget

    unit = velocity_budget({"velocity_pp_mps": velocity, "velocity_pp_mps_u": 0.0, "frequency_hz": 0.0})
    return tuple(t for t in unit.terms if t.type == "B" and t.std_uncertainty > 0)


def retuning_log_levels(setting_hz: np.ndarray, resonance_q: float, frequency_error_rel: float) -> np.ndarray:
    """ln of the factor a generator frequency error e puts on each point's velocity when a
    map's steps are driven at settings f_i of their own (each step re-tracks the resonance).

    Near the top of v = v0 / sqrt(1 + k^2 (f - f0)^2), k = 2 Q / f0 (the curve
    `resonance_searches.mechanical_q_from_sweep` fits), d ln v / d f = -k^2 (f - f0); the
    error moves every drive by e f_i, so ln(v_i read / v_i at the setting) = -k^2 (f_i - f0) e f_i
    to first order in e. Taken about the map's mean setting: the part every point shares
    scales the map and leaves its shape alone; what is left is a level step between the
    map's steps, as large as k^2 e f times their settings' spread (a few Hz), which the
    homogeneity figures do feel."""
    setting_hz = np.asarray(setting_hz, dtype=float)
    k = 2.0 * resonance_q / float(setting_hz.mean())
    return -(k**2) * (setting_hz - setting_hz.mean()) * frequency_error_rel * setting_hz


def retuning_term(figure: Callable[[np.ndarray], float], amplitude: np.ndarray, setting_hz: np.ndarray,
                  resonance_q: float) -> Term:
    """Type B term of a map figure for the generator's frequency error (a rectangle,
    `plates.specifications`) through the steps' level steps (`retuning_log_levels`): its
    sensitivity by the central difference over +-the specified limit (GUM 5.1.3: a
    sensitivity coefficient may be evaluated numerically), times the error's standard
    uncertainty."""
    spec = SPECIFICATIONS["generator_frequency"]
    moved = [figure(amplitude * np.exp(retuning_log_levels(setting_hz, resonance_q, sign * spec.half_width)))
             for sign in (1.0, -1.0)]
    return Term("generator frequency (steps re-tuned)", "B",
                abs(moved[0] - moved[1]) / (2.0 * spec.half_width) * spec.std_uncertainty, spec.source)


def map_resonance_q(run, run_name: str) -> float | None:
    """Q of the resonance the map's first step searched (its sweep at the reference point,
    `resonance_searches.mechanical_q_from_sweep` about the strongest reading); None when
    the run stored no sweep or the sweep shows no peak."""
    from squeezebench.analysis import tables
    from squeezebench.analysis.resonance_searches import mechanical_q_from_sweep

    try:
        sweeps = tables.resonance_sweeps(run)
    except tables.MissingDataError:
        return None
    sweep = sweeps[sweeps["run_name"] == run_name]
    if sweep.empty:
        return None
    first = sweep[sweep["step_id"] == sweep["step_id"].iloc[0]]
    peak_hz = float(first.loc[first["velocity_pp_mps"].idxmax(), "generator_frequency_hz"])
    return mechanical_q_from_sweep(peak_hz, first)


#: The vibration amplitude a fingertip needs to feel the squeeze-film effect, about 1 µm pp
#: (the paper's Sec. 1; its large plate is designed for it, Sec. 5): what a map is read against.
HAPTICS_AMPLITUDE_PP_M = 1e-6


def amplitude_pp_m(velocity_pp_mps: float, frequency_hz: float) -> float:
    """Displacement pp of a sinusoidal vibration of velocity pp `velocity_pp_mps`: x = v / (2 pi f)."""
    return velocity_pp_mps / (2 * math.pi * frequency_hz)


def summarise_map(points: pd.DataFrame, predicted: np.ndarray | None = None, share_of_peak: float = 0.5,
                  seed: int = 0, resonance_q: float | None = None) -> dict:
    """The numbers a designer reads off one map, each with its expanded uncertainty (k for
    95 % under its budget's distribution, `budgets.Budget`): the points' own noise (their
    fits' standard uncertainties, drawn NOISE_DRAWS times, seeded: normal), for the
    velocities (mean, peak) the scale all points share (`velocity_scale_terms`: rectangles),
    which does not average away, and, given the resonance's `resonance_q` (`map_resonance_q`),
    the generator's frequency error through the level steps between the map's re-tuned
    steps (`retuning_term`). The coefficient of variation and the area above the share of
    the mapped peak are the vibration's over the touch area: the points' figures corrected
    by their error where the grid fell (`grid_bias`, read between the points; the points'
    own figure `*_uncorrected`, the correction added `*_grid_correction`), with the
    correction's own error as terms (`grid_correction_term`, `grid_quadrature_term`); the
    noise and the level steps reach them through the figures over the cells, the field read
    again for each draw (the points' own area moves only when a point crosses the share of
    the peak, and carried no noise nor generator term on most of the paper map's benches;
    the cells' area, whose threshold moves with the peak, does). The mean and the peak are
    the points' own (what the stage put the vibrometer on), no cell's: they take no grid
    correction. With `predicted` (the model's shape at the same points) the modal assurance
    criterion of the signed map against it."""
    touch = points[points["in_touch_area"]]
    amplitude = touch["velocity_pp_mps"].to_numpy()
    x_m, y_m, sign = (touch[column].to_numpy() for column in ("x_m", "y_m", "signed_velocity_pp_mps"))
    h = homogeneity(amplitude, share_of_peak)
    # the points' own amplitudes with the mode's sign: a phase off 0 or pi is no smaller vibration
    readings = cell_readings(x_m, y_m, np.copysign(amplitude, sign))

    def figures(values: np.ndarray) -> dict[str, float]:
        """The figures of amplitudes `values` at the touch points as the summary gives them: the
        points' mean and peak, and the CV and area over the cells, the points' less the grid
        bias of their own field read again (the area's threshold is their own peak's share and
        its spots move with the levels: the points' own area stays put until a point crosses),
        at the map's own wavenumbers: the noise moves them by 4e-4 at most on the paper map
        (the width's; the length's 2e-6), which moves the CV's noise term by 3 % of itself, a
        term 400 times under the CV's U (its 7th digit), where each draw's own wavenumbers
        cost 1,600 line solves a summary. The area's cells at READING_SAMPLES spots, one of the
        lattices whose union the summary reads (AREA_SAMPLES): the draws are for the figure's
        spread, not its level, and the union's count, the mean of its lattices' counts, spreads
        no more than one of them (each alike) does; over the union the draws took 5 CPU-s a
        summary more."""
        read = homogeneity(values, share_of_peak)
        again = cell_readings(x_m, y_m, np.copysign(values, sign), None if readings is None else readings.wavenumbers)
        return {"mean": read.mean, "maximum": read.maximum,
                **{a: getattr(read, a) - grid_bias(again, GridError(a, share_of_peak, READING_SAMPLES))
                   for a in GRID_FIGURES}}

    rng = np.random.default_rng(seed)
    drawn = amplitude + rng.normal(size=(NOISE_DRAWS, amplitude.size)) * touch["velocity_pp_mps_u"].to_numpy()
    spread = [figures(d) for d in drawn]

    def corrected(attribute: str) -> dict:
        """The figure over the cells (the points' less their grid bias), its U, and both parts."""
        error = GridError(attribute, share_of_peak)
        bias = grid_bias(readings, error)
        value = getattr(h, attribute) - bias
        terms = (grid_correction_term(readings, error), grid_quadrature_term(readings, error))
        return {attribute: value, f"{attribute}_U": expanded(attribute, value, own=terms),
                f"{attribute}_uncorrected": getattr(h, attribute), f"{attribute}_grid_correction": -bias}

    def expanded(attribute: str, value: float, scaled: bool = False, own: tuple = ()) -> float:
        noise = Term("points' noise", "A", float(np.std([s[attribute] for s in spread], ddof=1)),
                     f"{NOISE_DRAWS} draws of the points' record-fit noise")
        shared = (*own, *velocity_scale_terms(value)) if scaled else own
        if resonance_q is not None:
            shared = (*shared, retuning_term(lambda v: figures(v)[attribute], amplitude,
                                             touch["generator_frequency_hz"].to_numpy(), resonance_q))
        return Budget(attribute, "1", value, (noise, *shared)).expanded_uncertainty

    lines = nodal_lines_m(points["x_m"].to_numpy(), points["signed_velocity_pp_mps"].to_numpy())
    summary = {
        "n_points": len(points), "n_touch_points": h.n_points,
        "mean_velocity_pp_mps": h.mean, "mean_velocity_pp_mps_U": expanded("mean", h.mean, scaled=True),
        "min_velocity_pp_mps": h.minimum, "max_velocity_pp_mps": h.maximum,
        "max_velocity_pp_mps_U": expanded("maximum", h.maximum, scaled=True),
        **corrected("coefficient_of_variation"),
        "share_of_peak": share_of_peak, **corrected("fraction_above_share"),
        "width_uniformity": width_uniformity(touch["x_m"].to_numpy(), touch["signed_velocity_pp_mps"].to_numpy()),
        "n_nodal_lines": len(lines),
        "nodal_line_spacing_m": float(np.diff(lines).mean()) if len(lines) >= 2 else float("nan"),
        "mac_with_predicted": float("nan"),
    }
    if predicted is not None:
        summary["mac_with_predicted"] = modal_assurance(points["signed_velocity_pp_mps"].to_numpy(), predicted)
    return summary
