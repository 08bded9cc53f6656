"""A budget's coverage factor (`analysis.budgets`): the smallest k holding 95 % under every
error model it claims to cover, its stated limits as the specifications state them
(rectangles) and as the world reads them (`specifications.WORLD_READING`), each checked
against a seeded Monte Carlo of that model drawn here, not through the convolution."""

from __future__ import annotations

import gc
import math
import tracemalloc

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from squeezebench.analysis.budgets import (COVERAGE_PROBABILITY, ERROR_MODELS, P95_FACTOR, SPECIFIED, WORLD,
                                           WORLD_DROPPED_MAX, Budget, Term, WorldMixture, _box_convolved,
                                           _distinct_rows)
from squeezebench.plates.specifications import WORLD_READING

DRAWS = 400_000


def limit_draws(rng: np.random.Generator, a: float, error_model: str) -> np.ndarray:
    """DRAWS errors of a limit +-a under `error_model`: uniform within it, or as the world errs
    (normal with standard deviation spread a, and with probability p at +-factor a)."""
    if error_model == SPECIFIED:
        return rng.uniform(-a, a, DRAWS)
    beyond = rng.uniform(size=DRAWS) < WORLD_READING.out_of_spec_probability
    signs = np.where(rng.uniform(size=DRAWS) < 0.5, -1.0, 1.0)
    return np.where(beyond, signs * WORLD_READING.out_of_spec_factor * a, rng.normal(0.0, WORLD_READING.spread * a, DRAWS))


def covered(budget: Budget, error_model: str, seed: int = 11) -> float:
    """Monte Carlo share of |sum of the budget's errors| <= its U under `error_model`:
    rectangular terms as limits +-sqrt(3) u, the rest normal."""
    rng = np.random.default_rng(seed)
    errors = sum((limit_draws(rng, math.sqrt(3.0) * t.std_uncertainty, error_model) if t.is_rectangular
                  else rng.normal(0.0, t.std_uncertainty, DRAWS)) for t in budget.terms)
    return float(np.mean(np.abs(errors) <= budget.expanded_uncertainty))


def test_one_limit_covers_the_worlds_errors_too():
    """A value that is one specification's limit (the generator's 20 ppm on a resonance
    frequency): the rectangle's own k, 0.95 sqrt(3) = 1.65, covers 93.3 % of the world's errors
    (normal, spread a / 2, 1 % at 1.5 a); k now holds 95 % of those: 0.99 P(|Z| <= 2 k u / a) = 0.95,
    k = sqrt(3) z / 2 with z the normal's 1 - 0.05 / 0.99 / 2 point (2.051), 1.776."""
    one_limit = Budget("x", "1", 1.0, (Term("generator frequency", "B", 0.01, "a limit"),))
    assert covered(one_limit, WORLD) == pytest.approx(0.95, abs=0.002)
    assert one_limit.coverage_factor == pytest.approx(math.sqrt(3.0) * 2.0510 / 2.0, abs=2e-3)
    assert covered(one_limit, SPECIFIED) == 1.0   # k u beyond the rectangle's edge
    assert one_limit.coverage_probability(0.95 * math.sqrt(3.0), WORLD) == pytest.approx(0.933, abs=1e-3)


def test_a_normal_budget_keeps_the_normals_k():
    """Noise and a standard deviation are normal in both models: k = 1.96; a bias bound
    alone is held by U = its bound, 1.96 u as it is stored."""
    for term in (Term("noise", "A", 0.01, "fit"), Term("grid", "B", 0.01, "a standard deviation", rectangular=False),
                 Term("delay", "B", 0.01, "a bias bound", bias=True)):
        assert Budget("x", "1", 1.0, (term,)).coverage_factor == pytest.approx(1.959964, abs=1e-3)


def normal_with_bias_u(rest_u: float, bound: float) -> float:
    """The smallest U with P(|N + B| <= U) = 95 % for N normal (standard deviation `rest_u`)
    and a bias B at its bound: Phi((U - B) / u) - Phi((-U - B) / u) = 0.95 (the least
    coverage over |b| <= B is at |b| = B, the normal being symmetric and unimodal)."""
    from scipy.optimize import brentq
    from scipy.stats import norm

    return brentq(lambda u: norm.cdf((u - bound) / rest_u) - norm.cdf((-u - bound) / rest_u) - 0.95,
                  0.0, bound + 10.0 * rest_u, xtol=1e-12)


@pytest.mark.parametrize("bound_u", [0.0, 0.1, 0.5, 1.0, 1.96, 4.0, 20.0])
def test_a_bias_bound_beside_a_normal_covers_exactly_95_percent_at_its_bound(bound_u):
    """One normal (u = 1) and one bias bound B (the resonance's drift): U is the closed
    form's (`normal_with_bias_u`); on a grid of biases over +-B the normal's exact coverage
    of +-U is never below 95 % and is 95 % at +-B; between the quadrature's U
    (sqrt(B^2 + 1.96^2), which holds a bias at B with less) and the linear sum 1.96 + B
    (GUM F.2.4.5), B + 1.645 once B >> u."""
    from scipy.stats import norm

    budget = Budget("x", "1", 1.0, (Term("noise", "A", 1.0, "fit"),
                                    Term("drift", "A", bound_u / P95_FACTOR, "a bias bound", bias=True)))
    expanded = budget.expanded_uncertainty
    # the budget's shape is rounded up to 1e-3 u_c (`Budget._shape`): U a hair wide, never short
    assert 0.0 <= expanded - normal_with_bias_u(1.0, bound_u) <= 4e-3 * budget.std_uncertainty
    biases = np.linspace(-bound_u, bound_u, 101)
    held = norm.cdf(expanded - biases) - norm.cdf(-expanded - biases)
    assert held.min() >= 0.95 - 1e-4
    # 95 % at +-B but for the shape's rounding up (1e-3 u_c of U, some 1e-3 of coverage at B = 20 u)
    assert 0.95 - 1e-4 <= held[0] == held[-1] <= 0.95 + 1.5e-3
    assert math.hypot(bound_u, P95_FACTOR) <= expanded <= bound_u + P95_FACTOR + 4e-3 * budget.std_uncertainty
    for error_model in ERROR_MODELS:   # no limit: both models read the budget alike
        assert 0.95 - 1e-4 <= budget.coverage_probability(budget.coverage_factor, error_model) <= 0.95 + 1.5e-3


def biased_coverage(limit: float, rest_u: float, bias: float, expanded: float, error_model: str) -> float:
    """P(|L + N + b| <= U), L a limit +-`limit` as `error_model` reads it, N normal: the
    normal's cdf integrated over L (Gauss-Legendre on the rectangle; the world's normal
    within the limit and its two points beyond it in closed form)."""
    from scipy.stats import norm

    def held(centre, sigma):
        return norm.cdf((expanded - bias - centre) / sigma) - norm.cdf((-expanded - bias - centre) / sigma)

    if error_model == SPECIFIED:
        nodes, weights = np.polynomial.legendre.leggauss(400)
        return float(np.dot(weights, held(limit * nodes, max(rest_u, 1e-12))) / 2.0)
    p, factor = WORLD_READING.out_of_spec_probability, WORLD_READING.out_of_spec_factor
    within = math.hypot(rest_u, WORLD_READING.spread * limit)
    return float((1 - p) * held(0.0, within) + 0.5 * p * (held(factor * limit, max(rest_u, 1e-12))
                                                           + held(-factor * limit, max(rest_u, 1e-12))))


@settings(max_examples=40, deadline=None)
@given(st.floats(0.0, 5.0), st.floats(0.05, 3.0), st.floats(0.0, 3.0), st.floats(-1.0, 1.0))
def test_u_holds_95_percent_at_any_bias_within_its_bound(bound_u, normal_u, limit_u, where):
    """Whatever the bias bound B, the normal's u and a limit's (a gain's), and wherever
    the bias lies within +-B, +-U holds at least 95 % under both error models (exact
    coverage by quadrature, not through the budget's grid), and U is never above the
    linear sum of the rest's 95 % U and B (GUM F.2.4.5)."""
    budget = Budget("x", "1", 1.0, (Term("gain", "B", limit_u, "a limit"), Term("noise", "A", normal_u, "fit"),
                                    Term("drift", "A", bound_u / P95_FACTOR, "a bias bound", bias=True)))
    expanded = budget.expanded_uncertainty
    for error_model in ERROR_MODELS:
        assert biased_coverage(math.sqrt(3.0) * limit_u, normal_u, where * bound_u, expanded, error_model) >= 0.9495
    rest = Budget("x", "1", 1.0, (Term("gain", "B", limit_u, "a limit"), Term("noise", "A", normal_u, "fit")))
    assert expanded <= rest.expanded_uncertainty + bound_u + 4e-3 * budget.std_uncertainty


@settings(max_examples=20, deadline=None)
@given(st.floats(0.0, 3.0), st.floats(0.0, 3.0), st.floats(0.0, 3.0))
def test_k_is_the_smallest_factor_holding_95_percent_under_every_error_model(first_u, second_u, normal_u):
    """Two limits (CH3's gain and the decoder's scale) and a normal, whatever their sizes:
    +-U holds at least 95 % of a Monte Carlo of each model, and just 95 % of the one that
    sets k (the smallest such k), within the Monte Carlo's and the grid's error."""
    if first_u + second_u + normal_u < 1e-3:
        return
    budget = Budget("x", "1", 1.0, (Term("spec", "B", first_u, "a limit"), Term("other", "B", second_u, "a limit"),
                                    Term("noise", "A", normal_u, "fit")))
    shares = [covered(budget, model) for model in ERROR_MODELS]
    assert min(shares) == pytest.approx(0.95, abs=0.003)
    assert all(share >= 0.947 for share in shares)


@settings(max_examples=15, deadline=None)
@given(st.floats(0.0, 3.0), st.floats(0.05, 3.0), st.floats(1.0, 3.0))
def test_the_worlds_coverage_of_plus_minus_k_u_is_the_convolutions(rectangular_u, normal_u, k):
    """Budget.coverage_probability under the world model against a Monte Carlo of it."""
    budget = Budget("x", "1", 1.0, (Term("spec", "B", rectangular_u, "a limit"), Term("noise", "A", normal_u, "fit")))
    rng = np.random.default_rng(7)
    errors = limit_draws(rng, math.sqrt(3.0) * rectangular_u, WORLD) + rng.normal(0.0, normal_u, DRAWS)
    expected = float(np.mean(np.abs(errors) <= k * budget.std_uncertainty))
    assert budget.coverage_probability(k, WORLD) == pytest.approx(expected, abs=0.005)


#: Steps per u of the grid the world's closed form is checked against: twice the
#: budgets' 2000 (read between steps, it tests the closed form far finer than that).
FINE_STEPS_PER_U = 4000


def world_on_fine_grid(rectangles: tuple[float, ...], rest: float) -> tuple[np.ndarray, np.ndarray]:
    """(x, P(|X| <= x)) of the world's X for a budget's shape, by convolving on a grid of
    1 / FINE_STEPS_PER_U: the rest's normal, then each limit's (1 - p) normal (spread a) and
    p / 2 point masses at +-factor a (moved to the nearest step)."""
    from scipy.signal import fftconvolve

    h = 1.0 / FINE_STEPS_PER_U
    half = WORLD_READING.out_of_spec_factor * sum(rectangles) + 8.0 * math.sqrt(
        rest**2 + sum((WORLD_READING.spread * a) ** 2 for a in rectangles))
    steps = int(math.ceil(half / h))
    x = np.arange(-steps, steps + 1) * h
    density = np.exp(-0.5 * (x / rest) ** 2) if rest > 0 else (x == 0).astype(float)
    density /= density.sum()
    p = WORLD_READING.out_of_spec_probability
    for a in rectangles:
        within = np.exp(-0.5 * (x / (WORLD_READING.spread * a)) ** 2)
        shift = int(round(WORLD_READING.out_of_spec_factor * a / h))
        beyond = np.roll(density, shift) + np.roll(density, -shift)   # no wrap: the grid's ends hold ~0
        density = (1.0 - p) * fftconvolve(density, within / within.sum(), mode="same") + 0.5 * p * beyond
    centre = steps
    # P(|X| <= x) at the cell edges x_j + h / 2: the centre's cell and twice the cells beyond.
    held = density[centre] + 2.0 * np.concatenate([[0.0], np.cumsum(density[centre + 1:])])
    return x[centre:] + 0.5 * h, held / held[-1]


#: |k closed form - k fine grid| and |coverage closed form - fine grid's| allowed: the fine grid
#: moves a point mass by up to half its step (1.25e-4 u), which shifts k by at most p times that,
#: and the mixture leaves out WORLD_DROPPED_MAX; 200 random shapes differ by 5e-8 and 1e-8 at
#: most. The budgets' own 2000-step grid, which the closed form replaced, was 5e-4 off in k.
CLOSED_FORM_K_TOLERANCE, CLOSED_FORM_COVERAGE_TOLERANCE = 2e-5, 2e-6


@settings(max_examples=20, deadline=None)
@given(st.lists(st.floats(0.001, 3.0), min_size=0, max_size=6), st.floats(0.0, 2.0), st.floats(0.5, 3.5))
def test_the_worlds_closed_form_is_the_fine_grids_convolution(limits_u, normal_u, k):
    """The world's mixture of normals (`WorldMixture`) against a convolution on a grid
    twice as fine as the budgets' grid: the 95 % factor and the coverage of any +-k u within
    CLOSED_FORM_K_TOLERANCE and CLOSED_FORM_COVERAGE_TOLERANCE, over random budget shapes
    (up to 6 limits, with or without a normal rest)."""
    if sum(limits_u) + normal_u < 1e-2:
        return
    budget = Budget("x", "1", 1.0, (*(Term(f"limit {i}", "B", u, "a limit") for i, u in enumerate(limits_u)),
                                    Term("noise", "A", normal_u, "fit")))
    shape = budget._shape()[:2]   # no bias bound: the rectangles and the rest
    mixture = WorldMixture.of(*shape)
    assert 0.0 <= mixture.dropped <= WORLD_DROPPED_MAX
    assert mixture.weights.sum() + mixture.dropped == pytest.approx(1.0, abs=1e-12)
    x, held = world_on_fine_grid(*shape)
    grid_k = float(np.interp(COVERAGE_PROBABILITY, held, x))
    assert mixture.factor(COVERAGE_PROBABILITY) == pytest.approx(grid_k, abs=CLOSED_FORM_K_TOLERANCE)
    assert budget.coverage_probability(k, WORLD) == pytest.approx(float(np.interp(k, x, held)),
                                                                 abs=CLOSED_FORM_COVERAGE_TOLERANCE)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=60), st.integers(0, 40))
def test_a_specified_rectangle_is_the_grids_moving_mean(values, width):
    """The specified grid's rectangle (`_box_convolved`) is the centred convolution with 2 w + 1
    equal weights, zero beyond the grid's ends, whatever the width against the grid."""
    density = np.array(values)
    expected = np.convolve(density, np.full(2 * width + 1, 1.0 / (2 * width + 1)))[width:width + len(density)]
    assert np.allclose(_box_convolved(density, width), expected, rtol=0.0, atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.sampled_from([0.0, 0.5, 1.25, 3.0]), st.sampled_from([0.0, 0.25, 1.0])), min_size=1,
                max_size=40))
def test_the_mixtures_distinct_components_are_numpys_unique_rows(rows):
    """`_distinct_rows` gives np.unique's rows, in its order, and its inverse (ties and repeats
    drawn on purpose): the world factor's mixture must not move by a bit for being faster."""
    rows = np.array(rows, dtype=float)
    distinct, which = _distinct_rows(rows)
    expected, expected_which = np.unique(rows, axis=0, return_inverse=True)
    assert np.array_equal(distinct, expected) and np.array_equal(which, expected_which.ravel())


def test_an_unknown_error_model_is_refused():
    with pytest.raises(ValueError, match="unknown error model"):
        Budget("x", "1", 1.0, (Term("spec", "B", 0.01, "a limit"),)).coverage_probability(2.0, "lab")


@settings(max_examples=30, deadline=None)
@example(limits_u=[0.259765625], normal_u=2.59375)   # the largest k a random search found
@given(st.lists(st.floats(0.0, 3.0), min_size=1, max_size=4), st.floats(0.0, 3.0))
def test_the_planners_floor_bounds_every_u_the_budget_states(limits_u, normal_u):
    """The planner's floors are `Budget.p95_bound` (`uncertainty.systematic_floor`): P95_FACTOR
    u, as no k of limits and normals, under either model, exceeds the normal's by more than
    0.2 % (a small rectangle read as the world does, 1.96225 at u 0.26 against a normal's 2.59);
    with a bias bound (the CH2 delay without deskew) U, which does. A floor is never below
    the U the report prints by more than that."""
    if sum(limits_u) + normal_u < 1e-3:
        return
    terms = (*(Term(f"limit {i}", "B", u, "a limit") for i, u in enumerate(limits_u)), Term("noise", "A", normal_u, "fit"))
    budget = Budget("x", "1", 1.0, terms)
    assert budget.coverage_factor <= P95_FACTOR * 1.002
    assert budget.p95_bound == P95_FACTOR * budget.std_uncertainty
    biased = Budget("x", "1", 1.0, (*terms, Term("delay", "B", normal_u + limits_u[0], "a bias bound", bias=True)))
    assert biased.p95_bound == max(P95_FACTOR * biased.std_uncertainty, biased.expanded_uncertainty)


def test_the_distributions_kept_stay_bounded_over_many_benches_shapes():
    """A coverage study's worker meets new budget shapes on every bench (its drawn errors
    set the terms): the distributions it keeps for them stay within tens of MB, where an
    entry-count bound let them grow by some 20 MB a bench until loky retired the worker as
    leaking (300 MB over its size). 600 shapes of 0.1 MB each: 60 MB kept without a bound
    by bytes."""
    def budget(limit_u: float) -> Budget:
        return Budget("x", "1", 1.0, (Term("spec", "B", limit_u, "a limit"), Term("noise", "A", 1.0, "fit")))

    budget(0.1).coverage_probability(2.0)   # what a first call sets up once is no growth
    gc.collect()
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        for i in range(600):
            assert 0.95 < budget(0.2 + 0.001 * i).coverage_probability(2.0) < 1.0
        gc.collect()
        kept_mb = (tracemalloc.get_traced_memory()[0] - before) / 2**20
    finally:
        tracemalloc.stop()
    assert kept_mb < 40.0
