"""A GUM budget of one value: its terms, their combination in quadrature, and the coverage
factor k for 95 % under every error model the budget claims to cover, from the budget's own
terms: its rectangular terms (stated limits) as the specifications state them, convolved with
the normal rest, and as the world reads a limit (`plates.specifications.WORLD_READING`: normal
with half the limit as its spread, now and then beyond it). Not k = 2 by default.
`analysis.uncertainty` builds the stored values' budgets from these.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from squeezebench.lru import RecentlyUsed
from squeezebench.plates.specifications import WORLD_READING

#: The conventional k (GUM 6.3.3), kept for the coverage a budget would have with it.
COVERAGE_FACTOR = 2.0
#: The coverage probability an expanded uncertainty is meant to reach (GUM 6.2.2).
COVERAGE_PROBABILITY = 0.95
#: |error| at the 95th percentile of a near-normal combined distribution, in standard uncertainties.
P95_FACTOR = 1.96
#: The error models a U claims to cover: its stated limits as rectangles (GUM 4.3.7, what the
#: specifications state) and as the world reads them (`WORLD_READING`). k holds 95 % under both.
SPECIFIED, WORLD = "specified", "world"
ERROR_MODELS = (SPECIFIED, WORLD)
BUDGET_COLUMNS = ["quantity", "unit", "value", "term", "type", "std_uncertainty", "relative",
                  "share", "source"]


@dataclass(frozen=True)
class Term:
    name: str
    type: str  # "A" (statistics of this record) or "B" (specification, tolerance, setting)
    std_uncertainty: float  # in the unit of the budget's value
    source: str
    #: A stated limit read as a rectangle (GUM 4.3.7): a Type B term unless it says otherwise
    #: (a bias bound whose k-fold is the bound is no rectangle about zero).
    rectangular: bool | None = None

    @property
    def is_rectangular(self) -> bool:
        return self.type == "B" if self.rectangular is None else self.rectangular


@dataclass(frozen=True)
class Budget:
    """The terms of one value; combined in quadrature (independent inputs)."""

    quantity: str
    unit: str
    value: float
    terms: tuple[Term, ...]

    @property
    def std_uncertainty(self) -> float:
        return math.sqrt(sum(t.std_uncertainty**2 for t in self.terms))

    @property
    def expanded_uncertainty(self) -> float:
        """k u with k for 95 % under every error model the budget claims (`coverage_factor`)."""
        return self.coverage_factor * self.std_uncertainty

    @property
    def dominant(self) -> Term:
        return max(self.terms, key=lambda t: t.std_uncertainty)

    @property
    def coverage_factor(self) -> float:
        """The smallest k such that +-k u holds the value with COVERAGE_PROBABILITY under every
        error model in ERROR_MODELS (`shape_coverage_factor`). Under the specified rectangles
        alone k runs from 1.96 for a normal down to 1.65 (0.95 sqrt(3)) when one rectangle is
        the whole budget (GUM G.2.3 / G.6.5; JCGM 101 5.3: k from the distribution, not 2 by
        default); but a limit read as the world reads it (normal, half the limit as spread, one
        in 100 at 1.5 times it) leaves that 1.65 covering 93.3 %, so such a budget takes the
        world's 1.78, and a budget of normal terms keeps 1.96."""
        return shape_coverage_factor(self._shape())

    def coverage_probability(self, k: float = COVERAGE_FACTOR, error_model: str = SPECIFIED) -> float:
        """The probability that +-k u holds the value under the budget's distribution in
        `error_model` (`budget_distribution`): its rectangular terms as the specifications
        state them or as the world reads their limits, the rest normal (GUM G.2: a sum of
        several terms tends to one). k = 2 gives 95 % only near normal; where one rectangular
        term dominates it gives more under the specifications (1 at most for the rectangle
        alone once k u >= sqrt(3) u)."""
        return budget_distribution(*self._shape(), error_model).probability(k)

    def _shape(self) -> tuple[tuple[float, ...], float]:
        """The rectangles' half-widths and the rest's standard deviation, in units of u
        (rounded: budgets of one shape share one distribution)."""
        u = self.std_uncertainty
        if u == 0.0:
            return (), 1.0
        rectangles = [math.sqrt(3.0) * t.std_uncertainty / u for t in self.terms if t.is_rectangular]
        rest = math.sqrt(max(1.0 - sum(a * a / 3.0 for a in rectangles), 0.0))
        return tuple(sorted(round(a, 3) for a in rectangles if a >= 1e-3)), round(rest, 3)

    def as_frame(self) -> pd.DataFrame:
        """One row per term, largest first, with its share of the combined variance."""
        total = self.std_uncertainty**2 or 1.0
        rows = [{"quantity": self.quantity, "unit": self.unit, "value": self.value, "term": t.name,
                 "type": t.type, "std_uncertainty": t.std_uncertainty,
                 "relative": t.std_uncertainty / abs(self.value) if self.value else math.nan,
                 "share": t.std_uncertainty**2 / total, "source": t.source}
                for t in sorted(self.terms, key=lambda t: -t.std_uncertainty)]
        return pd.DataFrame(rows, columns=BUDGET_COLUMNS)


@dataclass(frozen=True)
class Distribution:
    """P(|X| <= x) on a grid of x >= 0, X in units of its standard deviation."""

    x: np.ndarray
    covered: np.ndarray

    def probability(self, k: float) -> float:
        return float(np.interp(k, self.x, self.covered))

    def factor(self, probability: float) -> float:
        """The smallest k with P(|X| <= k) >= probability."""
        return float(self.x[min(int(np.searchsorted(self.covered, probability)), len(self.x) - 1)])


#: Grid steps per unit of the standard deviation on which a budget's distribution is convolved.
STEPS_PER_U = 2000


@functools.lru_cache(maxsize=4096)
def shape_coverage_factor(shape: tuple[tuple[float, ...], float]) -> float:
    """The smallest k giving COVERAGE_PROBABILITY under every one of ERROR_MODELS for a
    budget of `shape` (`Budget._shape`): the largest of their 95 % factors. Only the factor
    is kept of the world's distribution: its grid reaches 3.5 times the rectangles' sum, and
    a study worker meets thousands of shapes (the specified one stays cached for
    `Budget.coverage_probability`)."""
    return max((budget_distribution if model == SPECIFIED else convolved_distribution)(*shape, model)
               .factor(COVERAGE_PROBABILITY) for model in ERROR_MODELS)


#: Distributions built lately, by shape and error model: budgets of one shape share one. By
#: bytes: a distribution's grid holds 0.1-0.3 MB, and the shapes of a coverage study's bench
#: are its own (its drawn errors and plates set the terms), so an entry-count bound of
#: 4096 let a study worker grow by some 20 MB a bench towards 0.5-1 GB, past the 300 MB over
#: its size at which loky retires a worker as leaking ("A worker stopped while some jobs
#: were given to the executor"). 32 MB keeps a bench's few hundred shapes' recent ones.
_DISTRIBUTIONS: RecentlyUsed[Distribution] = RecentlyUsed(
    4096, max_bytes=32 * 2**20, weigh=lambda distribution: distribution.x.nbytes + distribution.covered.nbytes)


def budget_distribution(rectangles: tuple[float, ...], rest: float, error_model: str = SPECIFIED) -> Distribution:
    """`convolved_distribution`, cached (`_DISTRIBUTIONS`)."""
    return _DISTRIBUTIONS.get((rectangles, rest, error_model),
                              lambda: convolved_distribution(rectangles, rest, error_model))


def convolved_distribution(rectangles: tuple[float, ...], rest: float, error_model: str = SPECIFIED) -> Distribution:
    """The distribution of X = sum of R_i + N, N normal with standard deviation `rest`, R_i
    the i-th stated limit +-rectangles[i] (units of u; the specified variances sum to 1) as
    `error_model` reads it: SPECIFIED uniform on +-a (GUM 4.3.7); WORLD as instruments err
    (`WORLD_READING`): normal with standard deviation spread a, but with probability
    out_of_spec_probability at +-out_of_spec_factor a (`world_convolved`). By numerical
    convolution on a grid of 1 / STEPS_PER_U (JCGM 101 propagates distributions; the sum of
    independent inputs is a convolution, exact to the grid's step). Symmetric about 0."""
    if error_model not in ERROR_MODELS:
        raise ValueError(f"unknown error model {error_model!r}: one of {', '.join(ERROR_MODELS)}")
    reach = (1.0 if error_model == SPECIFIED
             else max(7.0 * WORLD_READING.spread, WORLD_READING.out_of_spec_factor))
    half = reach * sum(rectangles) + 7.0 * rest + 1e-9
    steps = int(math.ceil(half * STEPS_PER_U))
    x = np.arange(-steps, steps + 1) / STEPS_PER_U
    if rest > 0:
        density = np.exp(-0.5 * (x / rest) ** 2)
    else:
        density = (x == 0).astype(float)
    density /= density.sum()
    for a in rectangles:
        if error_model == SPECIFIED:
            width = int(round(a * STEPS_PER_U))
            if width:
                density = _convolved(density, np.full(2 * width + 1, 1.0 / (2 * width + 1)))
        else:
            density = world_convolved(density, a)
    density = np.clip(density, 0.0, None)
    density /= density.sum()
    centre = steps
    covered = density[centre] + 2.0 * np.concatenate([[0.0], np.cumsum(density[centre + 1:])])
    return Distribution(x[centre:] + 0.5 / STEPS_PER_U, np.minimum(covered, 1.0))


def _convolved(density: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """`density` convolved with a centred `kernel`, on the same grid."""
    # Imported here: scipy.signal (with the scipy.stats it loads) is about 0.5 CPU-s to
    # import, which every study and plan worker importing this module paid and none used.
    from scipy.signal import fftconvolve

    return fftconvolve(density, kernel, mode="same")


def world_convolved(density: np.ndarray, a: float) -> np.ndarray:
    """`density` (on the grid of 1 / STEPS_PER_U, room enough at its ends) convolved with a
    limit +-a as the world reads it (`WORLD_READING`): (1 - p) N(0, (spread a)^2) + p/2 at
    each of +-factor a."""
    sigma = WORLD_READING.spread * a
    reach = int(math.ceil(7.0 * sigma * STEPS_PER_U))
    if reach:
        kernel = np.exp(-0.5 * (np.arange(-reach, reach + 1) / (sigma * STEPS_PER_U)) ** 2)
        within = _convolved(density, kernel / kernel.sum())
    else:
        within = density
    shift = int(round(WORLD_READING.out_of_spec_factor * a * STEPS_PER_U))
    beyond = np.zeros_like(density)
    if shift:
        beyond[shift:] += density[:-shift]
        beyond[:-shift] += density[shift:]
    else:
        beyond = 2.0 * density
    p = WORLD_READING.out_of_spec_probability
    return (1.0 - p) * within + 0.5 * p * beyond
