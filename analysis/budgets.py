"""A GUM budget of one value: its terms, their combination in quadrature, and the coverage
factor k for 95 % under the budget's own distribution (its rectangular terms convolved with
the normal rest), not k = 2 by default. `analysis.uncertainty` builds the stored values'
budgets from these.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

#: The conventional k (GUM 6.3.3), kept for the coverage a budget would have with it.
COVERAGE_FACTOR = 2.0
#: The coverage probability an expanded uncertainty is meant to reach (GUM 6.2.2).
COVERAGE_PROBABILITY = 0.95
#: |error| at the 95th percentile of a near-normal combined distribution, in standard uncertainties.
P95_FACTOR = 1.96
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
        """k u with k for 95 % under the budget's own distribution (`coverage_factor`)."""
        return self.coverage_factor * self.std_uncertainty

    @property
    def dominant(self) -> Term:
        return max(self.terms, key=lambda t: t.std_uncertainty)

    @property
    def coverage_factor(self) -> float:
        """k such that +-k u holds the value with COVERAGE_PROBABILITY under the budget's own
        distribution (`budget_distribution`): 1.96 for a normal, down to 1.65 (0.95 sqrt(3))
        when one rectangular term is the whole budget (GUM G.2.3 / G.6.5: a dominant
        rectangle's trapezoid; JCGM 101 5.3: k from the distribution, not 2 by default).
        k = 2 over-covered every value whose budget is one specification's limit."""
        return budget_distribution(*self._shape()).factor(COVERAGE_PROBABILITY)

    def coverage_probability(self, k: float = COVERAGE_FACTOR) -> float:
        """The probability that +-k u holds the value under the budget's own distribution:
        its rectangular terms as the specifications state them, the rest normal (GUM G.2:
        a sum of several terms tends to one). k = 2 gives 95 % only near normal; where one
        rectangular term dominates it gives more (1 at most for the rectangle alone once
        k u >= sqrt(3) u)."""
        return budget_distribution(*self._shape()).probability(k)

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
def budget_distribution(rectangles: tuple[float, ...], rest: float) -> Distribution:
    """The distribution of X = sum of R_i + N, R_i uniform on +-rectangles[i], N normal with
    standard deviation `rest` (units of u, sum of variances 1), by numerical convolution on a
    grid of 1 / STEPS_PER_U (JCGM 101 propagates distributions; here the sum of independent
    inputs is a convolution, exact to the grid's step). Symmetric about 0."""
    # Imported here: scipy.signal (with the scipy.stats it loads) is about 0.5 CPU-s to
    # import, which every study and plan worker importing this module paid and none used.
    from scipy.signal import fftconvolve

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
            density = fftconvolve(density, np.full(2 * width + 1, 1.0 / (2 * width + 1)), mode="same")
    density = np.clip(density, 0.0, None)
    density /= density.sum()
    centre = steps
    covered = density[centre] + 2.0 * np.concatenate([[0.0], np.cumsum(density[centre + 1:])])
    return Distribution(x[centre:] + 0.5 / STEPS_PER_U, np.minimum(covered, 1.0))
