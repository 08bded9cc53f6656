"""A GUM budget of one value: its terms, their combination in quadrature, and the coverage
factor k for 95 % under every error model the budget claims to cover, from the budget's own
terms: its rectangular terms (stated limits) as the specifications state them, convolved with
the normal rest on a grid, and as the world reads a limit (`plates.specifications.WORLD_READING`:
normal with half the limit as its spread, now and then beyond it), a mixture of normals in
closed form. Not k = 2 by default. A bias bound (an error of unknown size within +-B that no
average removes: the resonance's drift, an uncorrected delay) is no spread about zero: U holds
95 % whatever the bias within its bound, so it adds to the rest's U nearly linearly rather
than in quadrature (GUM F.2.4.5).
`analysis.uncertainty` builds the stored values' budgets from these.
"""

from __future__ import annotations

import functools
import itertools
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
    #: (a standard deviation is normal).
    rectangular: bool | None = None
    #: A bias bound: the error is one value within +-`bound` (P95_FACTOR u), of a sign or size
    #: nothing here knows, the same on every reading (a one-sided drift, an uncorrected delay):
    #: U must hold the value at any bias within it, not on average over a spread about zero.
    bias: bool = False

    @property
    def is_rectangular(self) -> bool:
        return not self.bias and (self.type == "B" if self.rectangular is None else self.rectangular)

    @property
    def bound(self) -> float:
        """A bias bound's half-width (the standard uncertainty it is stored as is bound / P95_FACTOR)."""
        return P95_FACTOR * self.std_uncertainty if self.bias else 0.0


@dataclass(frozen=True)
class Budget:
    """The terms of one value; combined in quadrature (independent inputs)."""

    quantity: str
    unit: str
    value: float
    terms: tuple[Term, ...]
    #: What `value` was corrected by for a known systematic effect (GUM 3.2.4), already in it:
    #: another reading of the same quantity, uncorrected, adds it to stand for what this does.
    correction: float = 0.0

    @property
    def std_uncertainty(self) -> float:
        return math.sqrt(sum(t.std_uncertainty**2 for t in self.terms))

    @property
    def expanded_uncertainty(self) -> float:
        """k u with k for 95 % under every error model the budget claims (`coverage_factor`)."""
        return self.coverage_factor * self.std_uncertainty

    @property
    def p95_bound(self) -> float:
        """The |error| the budget allows 95 % of the time, for a floor (`uncertainty.systematic_floor`):
        the normal's P95_FACTOR u, which a k of rectangles and normals exceeds by 0.2 % at most
        (the world's tail beyond a small rectangle's limit, and the k search's rounding up: a
        floor's share of U, not worth a k search per stored point); with a bias bound its U,
        which is wider (a bias at its bound is no spread about zero)."""
        if not any(t.bias for t in self.terms):
            return P95_FACTOR * self.std_uncertainty
        return max(P95_FACTOR * self.std_uncertainty, self.expanded_uncertainty)

    @property
    def dominant(self) -> Term:
        return max(self.terms, key=lambda t: t.std_uncertainty)

    @property
    def coverage_factor(self) -> float:
        """The smallest k such that +-k u holds the value with COVERAGE_PROBABILITY under every
        error model in ERROR_MODELS, at every bias within the budget's bias bounds
        (`shape_coverage_factor`). Under the specified rectangles
        alone k runs from 1.96 for a normal down to 1.65 (0.95 sqrt(3)) when one rectangle is
        the whole budget (GUM G.2.3 / G.6.5; JCGM 101 5.3: k from the distribution, not 2 by
        default); but a limit read as the world reads it (normal, half the limit as spread, one
        in 100 at 1.5 times it) leaves that 1.65 covering 93.3 %, so such a budget takes the
        world's 1.78, and a budget of normal terms keeps 1.96. A bias bound B with a normal rest
        of u_r takes U with Phi((U - B) / u_r) - Phi((-U - B) / u_r) = 0.95: B + 1.645 u_r once
        B >> u_r, where a quadrature of B / 1.96 would give U = sqrt(B^2 + (1.96 u_r)^2) and
        hold a bias at its bound 1 time in 2."""
        return shape_coverage_factor(*self._shape())

    def coverage_probability(self, k: float = COVERAGE_FACTOR, error_model: str = SPECIFIED) -> float:
        """The probability that +-k u holds the value under the budget's distribution in
        `error_model`: its rectangular terms as the specifications state them
        (`budget_distribution`) or as the world reads their limits (`WorldMixture`), the rest normal (GUM G.2: a sum of
        several terms tends to one). k = 2 gives 95 % only near normal; where one rectangular
        term dominates it gives more under the specifications (1 at most for the rectangle
        alone once k u >= sqrt(3) u). With bias bounds, the least such probability over every
        bias within them (`worst_bias_probability`): what the U promises whatever the bias."""
        rectangles, rest, bias = self._shape()
        if error_model == WORLD:
            return worst_bias_probability(WorldMixture.of(rectangles, rest).biased_probability, k, bias)
        if error_model == SPECIFIED:
            return worst_bias_probability(budget_distribution(rectangles, rest).biased_probability, k, bias)
        raise ValueError(f"unknown error model {error_model!r}: one of {', '.join(ERROR_MODELS)}")

    def _shape(self) -> tuple[tuple[float, ...], float, float]:
        """The rectangles' half-widths, the rest's standard deviation and the bias bounds'
        sum (bounds of unknown signs add: their worst case is all at one side), in units of u
        (rounded: budgets of one shape share one distribution; the rest and the bias up, as
        a U a hair wide is no fault and one a hair short of a large bias is)."""
        u = self.std_uncertainty
        if u == 0.0:
            return (), 1.0, 0.0
        rectangles = [math.sqrt(3.0) * t.std_uncertainty / u for t in self.terms if t.is_rectangular]
        bias_variance = sum((t.std_uncertainty / u) ** 2 for t in self.terms if t.bias)
        rest = math.sqrt(max(1.0 - sum(a * a / 3.0 for a in rectangles) - bias_variance, 0.0))
        bias = sum(t.bound for t in self.terms) / u
        return tuple(sorted(round(a, 3) for a in rectangles if a >= 1e-3)), _rounded_up(rest), _rounded_up(bias)

    def as_frame(self) -> pd.DataFrame:
        """One row per term, largest first, with its share of the combined variance."""
        total = self.std_uncertainty**2 or 1.0
        rows = [{"quantity": self.quantity, "unit": self.unit, "value": self.value, "term": t.name,
                 "type": t.type, "std_uncertainty": t.std_uncertainty,
                 "relative": t.std_uncertainty / abs(self.value) if self.value else math.nan,
                 "share": t.std_uncertainty**2 / total, "source": t.source}
                for t in sorted(self.terms, key=lambda t: -t.std_uncertainty)]
        return pd.DataFrame(rows, columns=BUDGET_COLUMNS)


def _rounded_up(x: float) -> float:
    """x to the next 1e-3 above it (a shape's rounding; not past x itself when x is on one)."""
    return math.ceil(x * 1e3 - 1e-6) / 1e3


@dataclass(frozen=True)
class Distribution:
    """P(|X| <= x) on a grid of x >= 0, X in units of its standard deviation."""

    x: np.ndarray
    covered: np.ndarray

    def probability(self, k: float) -> float:
        return float(np.interp(k, self.x, self.covered))

    def biased_probability(self, k, bias: float):
        """P(|X + bias| <= k) for X symmetric about 0: F(k - b) - F(-k - b) with
        F(x) = (1 + sign(x) P(|X| <= |x|)) / 2; `k` or `bias` a number or an array."""
        k = np.asarray(k, dtype=float)
        return 0.5 * (np.sign(k - bias) * np.interp(np.abs(k - bias), self.x, self.covered)
                      + np.interp(k + bias, self.x, self.covered))

    def factor(self, probability: float, bias: float = 0.0) -> float:
        """The smallest k with P(|X + b| <= k) >= probability for every |b| <= `bias` (X's
        density is symmetric and unimodal, a convolution of such: the least coverage is at
        |b| = bias, Anderson's theorem), on the grid; increasing in k."""
        held = self.biased_probability(self.x + bias, bias) if bias else self.covered
        return float(self.x[min(int(np.searchsorted(held, probability)), len(self.x) - 1)] + bias)


#: Grid steps per unit of the standard deviation on which a budget's specified distribution is convolved.
STEPS_PER_U = 2000


@functools.lru_cache(maxsize=4096)
def shape_coverage_factor(rectangles: tuple[float, ...], rest: float, bias: float = 0.0) -> float:
    """The smallest k giving COVERAGE_PROBABILITY under every one of ERROR_MODELS, at any bias
    within +-`bias`, for a budget of this shape (`Budget._shape`): the largest of their 95 %
    factors, the specified one from its convolved grid (kept for
    `Budget.coverage_probability`), the world's in closed form (`world_coverage_factor`)."""
    return max(budget_distribution(rectangles, rest).factor(COVERAGE_PROBABILITY, bias),
               world_coverage_factor(rectangles, rest, COVERAGE_PROBABILITY, bias))


#: Biases at which the least coverage over +-B is sought where X's distribution may not be
#: unimodal (the world's mixture: its beyond-the-limit components): 0, B / 16, ..., B.
BIAS_STEPS = 16


def worst_bias_probability(biased_probability, k: float, bias: float) -> float:
    """The least P(|X + b| <= k) over |b| <= `bias` (symmetric X: b >= 0 suffice), on
    BIAS_STEPS + 1 biases, B among them: where X is symmetric and unimodal the least is at B."""
    biases = np.linspace(0.0, bias, BIAS_STEPS + 1) if bias else np.zeros(1)
    return float(np.min(biased_probability(k, biases)))   # every bias at once: a k search asks this a dozen times


#: The largest share of the world's error distribution a `WorldMixture` may leave out: its
#: coverage is then the whole's to within this and never above it, so its k is never below
#: the whole's, and above it by at most this over |X|'s density at k (of order 0.1 at 95 %:
#: some 1e-7, where the specified grid's step is 5e-4).
WORLD_DROPPED_MAX = 1e-8


@dataclass(frozen=True)
class WorldMixture:
    """The world's distribution of X = sum of R_i + N (`WORLD_READING`; units of u): each
    limit +-a_i is normal with standard deviation spread a_i with probability 1 - p, else at
    +-factor a_i (p / 2 each), N normal with standard deviation `rest`; so X is a mixture of
    normals, one for each choice of the limits beyond their bounds and their signs, with the
    mean the sum of their +-factor a_i and the variance rest^2 plus the others' (spread a_i)^2.
    3^n of them for n limits: those with more than `beyond_max` limits beyond are left out,
    weighing `dropped` (the binomial tail P(B(n, p) > beyond_max) <= WORLD_DROPPED_MAX)."""

    weights: np.ndarray
    means: np.ndarray
    sigmas: np.ndarray
    dropped: float

    @classmethod
    def of(cls, rectangles: tuple[float, ...], rest: float) -> WorldMixture:
        p, factor = WORLD_READING.out_of_spec_probability, WORLD_READING.out_of_spec_factor
        n = len(rectangles)
        beyond_max, dropped = n, 0.0
        while beyond_max > 0:
            tail = sum(math.comb(n, m) * p**m * (1.0 - p) ** (n - m) for m in range(beyond_max, n + 1))
            if tail > WORLD_DROPPED_MAX:
                break
            beyond_max, dropped = beyond_max - 1, tail
        limits = np.asarray(rectangles, dtype=float)
        weights, means, sigmas = [], [], []
        for m in range(beyond_max + 1):
            beyond = limits[np.array(list(itertools.combinations(range(n), m)), dtype=int).reshape(math.comb(n, m), m)]
            signs = np.array(list(itertools.product((-1.0, 1.0), repeat=m))).reshape(2**m, m)
            variance = rest**2 + WORLD_READING.spread**2 * (np.sum(limits**2) - np.sum(beyond**2, axis=1))
            means.append((factor * beyond @ signs.T).ravel())
            sigmas.append(np.repeat(np.sqrt(np.maximum(variance, 0.0)), len(signs)))
            weights.append(np.full(len(means[-1]), (1.0 - p) ** (n - m) * (0.5 * p) ** m))
        # P(|X| <= k) is the same for a component and its mirror, and equal limits make equal
        # components: one of each (|mean|, sigma), with their weights summed, holds the same.
        distinct, which = _distinct_rows(np.round(np.column_stack([np.abs(np.concatenate(means)),
                                                                   np.concatenate(sigmas)]), 12))
        return cls(np.bincount(which, weights=np.concatenate(weights)), distinct[:, 0], distinct[:, 1], dropped)

    def probability(self, k: float) -> float:
        """P(|X| <= k) of the components kept: at most `dropped` below the whole's."""
        return self.biased_probability(k, 0.0)

    def biased_probability(self, k: float, bias):
        """P(|X + bias| <= k) of the components kept, `bias` a number or an array (one
        probability each). Each distinct component stands for itself and its mirror (-mean),
        which hold the same share of +-k about 0 but not about -bias: both halves are summed."""
        # Imported here: scipy.special is some 0.4 CPU-s to import, which every study and plan
        # worker importing this module would pay, most never asking for a k.
        from scipy.special import ndtr

        def held(means: np.ndarray) -> np.ndarray:
            with np.errstate(divide="ignore", invalid="ignore"):
                return np.where(self.sigmas > 0.0,
                                ndtr((k - means) / self.sigmas) - ndtr((-k - means) / self.sigmas),
                                np.abs(means) <= k)   # all limits beyond and no rest: a point

        shift = np.asarray(bias, dtype=float)[..., None]   # bias, component
        held_by_bias = (held(self.means + shift) if not np.any(shift) else
                        0.5 * (held(self.means + shift) + held(-self.means + shift)))
        out = held_by_bias @ self.weights
        return float(out) if out.ndim == 0 else out

    def factor(self, probability: float, bias: float = 0.0) -> float:
        """The smallest k with P(|X + b| <= k) >= probability for every |b| <= `bias`, to 1e-10
        (Brent's method on the kept components, whose coverage never exceeds the whole's: so
        no smaller than the whole's k, and above it by at most `dropped` over the density there)."""
        from scipy.optimize import brentq

        reach = float(np.max(np.abs(self.means) + 8.0 * self.sigmas)) + bias
        return float(brentq(lambda k: worst_bias_probability(self.biased_probability, k, bias) - probability,
                            0.0, reach, xtol=1e-10))


def _distinct_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """np.unique(rows, axis=0, return_inverse=True) of a two-column array, the same rows in the
    same order and the same inverse: by a stable lexsort of the columns, where np.unique sorts a
    structured view of the rows, five times slower (most of a report's `WorldMixture.of`)."""
    order = np.lexsort((rows[:, 1], rows[:, 0]))
    ordered = rows[order]
    first = np.empty(len(rows), dtype=bool)
    first[:1] = True
    first[1:] = (ordered[1:] != ordered[:-1]).any(axis=1)
    which = np.empty(len(rows), dtype=np.intp)
    which[order] = np.cumsum(first) - 1
    return ordered[first], which


def world_coverage_factor(rectangles: tuple[float, ...], rest: float, probability: float, bias: float = 0.0) -> float:
    """The world's 95 % factor of a budget's shape (`WorldMixture`), at any bias within +-`bias`."""
    return WorldMixture.of(rectangles, rest).factor(probability, bias)


#: Specified distributions built lately, by shape: budgets of one shape share one (its k, then
#: `Budget.coverage_probability` of that k, in `uncertainty.with_expanded_uncertainties`). By
#: bytes: a distribution's grid holds 0.1-0.3 MB, and the shapes of a coverage study's bench
#: are its own (its drawn errors and plates set the terms), so an entry-count bound of
#: 4096 let a study worker grow by some 20 MB a bench towards 0.5-1 GB, past the 300 MB over
#: its size at which loky retires a worker as leaking ("A worker stopped while some jobs
#: were given to the executor"). 32 MB keeps a bench's few hundred shapes' recent ones.
_DISTRIBUTIONS: RecentlyUsed[Distribution] = RecentlyUsed(
    4096, max_bytes=32 * 2**20, weigh=lambda distribution: distribution.x.nbytes + distribution.covered.nbytes)


def budget_distribution(rectangles: tuple[float, ...], rest: float) -> Distribution:
    """`convolved_distribution`, cached (`_DISTRIBUTIONS`)."""
    return _DISTRIBUTIONS.get((rectangles, rest), lambda: convolved_distribution(rectangles, rest))


def convolved_distribution(rectangles: tuple[float, ...], rest: float) -> Distribution:
    """The distribution of X = sum of R_i + N, N normal with standard deviation `rest`, R_i
    uniform on +-rectangles[i] (GUM 4.3.7: the stated limits as the specifications state
    them; units of u, the variances summing to 1). By numerical convolution on a grid of
    1 / STEPS_PER_U (JCGM 101 propagates distributions; the sum of independent inputs is a
    convolution, exact to the grid's step). Symmetric about 0."""
    half = sum(rectangles) + 7.0 * rest + 1e-9
    steps = int(math.ceil(half * STEPS_PER_U))
    x = np.arange(-steps, steps + 1) / STEPS_PER_U
    if rest > 0:
        density = np.exp(-0.5 * (x / rest) ** 2)
    else:
        density = (x == 0).astype(float)
    density /= density.sum()
    for a in rectangles:
        width = int(round(a * STEPS_PER_U))
        if width:
            density = _box_convolved(density, width)
    density = np.clip(density, 0.0, None)
    density /= density.sum()
    centre = steps
    covered = density[centre] + 2.0 * np.concatenate([[0.0], np.cumsum(density[centre + 1:])])
    return Distribution(x[centre:] + 0.5 / STEPS_PER_U, np.minimum(covered, 1.0))


def _box_convolved(density: np.ndarray, width: int) -> np.ndarray:
    """`density` convolved with a centred box of 2 width + 1 equal weights summing to 1, on
    the same grid: a moving mean by cumulative sums, O(n) where an FFT is O(n log n), and
    the same values to rounding (2e-14 on the coverage of the paper report's shapes)."""
    summed = np.cumsum(np.concatenate([np.zeros(width + 1), density, np.zeros(width)]))
    return (summed[2 * width + 1:] - summed[:len(density)]) / (2 * width + 1)
