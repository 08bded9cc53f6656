"""How far a U over-covers and how much narrower it could be (analysis.over_coverage), against
closed forms on synthetic coverage rows; and the floors it would lower (AccuracyFloors.scaled)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from squeezebench.analysis.over_coverage import MIN_BENCHES, shrink_factors, shrink_lines
from squeezebench.analysis.study import coverage_table
from squeezebench.protocols.accuracy_plan import AccuracyFloors, RunFloor

Z95 = stats.norm.ppf(0.975)   # 1.95996: |N(0, sigma)| is below Z95 sigma 95 % of the time


def coverage_rows(rel_errors: np.ndarray, rel_expanded_u: float, quantity: str, error_model: str = "world",
                  benches: int | None = None) -> pd.DataFrame:
    """Coverage rows as `bench_errors.errors_on_bench` stores them: one value per bench, or
    the values shared among `benches` benches, as a bench's stored points share it."""
    seeds = np.arange(len(rel_errors))
    if benches is not None:
        seeds = seeds * benches // len(rel_errors)
    return pd.DataFrame({"error_model": error_model, "quantity": quantity, "bench_seed": seeds,
                         "rel_error": rel_errors, "rel_expanded_u": rel_expanded_u,
                         "covered": np.abs(rel_errors) <= rel_expanded_u})


def test_normal_errors_under_a_rectangle_budget_over_cover_by_sqrt3_over_2():
    """Six specified errors, each budgeted as a rectangle at its limit L_i (u_i = L_i / sqrt 3,
    U = 1.96 u for their near-normal sum), drawn as the world model draws them (normal,
    sigma_i = L_i / 2): the sum's spread is sqrt(3) / 2 of the budget's u, so a U that
    factor as wide covers 95 %. The 20,000 sums (the factor to 2 %) are 100 values on each of
    200 benches: the bench bootstrap resamples benches, 20,000 of them cost it 100 times more."""
    rng = np.random.default_rng(3)
    limits = np.array([0.02, 0.01, 0.015, 0.005, 0.01, 0.03])
    errors = rng.normal(0.0, limits / 2.0, size=(20000, limits.size)).sum(axis=1)
    u = Z95 * math.sqrt(np.sum(limits**2) / 3.0)
    table = coverage_table(coverage_rows(errors, u, "power_w", benches=200))
    assert table.loc[0, "benches"] == 200
    factor = shrink_factors(table)["power_w"]
    assert factor == pytest.approx(math.sqrt(3.0) / 2.0, rel=0.02)
    assert np.mean(np.abs(errors) <= factor * u) == pytest.approx(0.95, abs=0.002)   # still covers 95 %


def test_a_u_that_covers_95_percent_or_less_has_no_surplus():
    """U = 1.96 sigma covers 95 % (its interval holds 95 %); 1.5 sigma under-covers: neither
    is named; rows of the specified model are not the world's, and a handful of benches all
    covered is no surplus."""
    rng = np.random.default_rng(4)
    errors = rng.normal(0.0, 0.01, 4000)
    rows = pd.concat([coverage_rows(errors, Z95 * 0.01, "velocity_pp_mps", benches=200),
                      coverage_rows(errors, 1.5 * 0.01, "q", benches=200),
                      coverage_rows(errors, 3.0 * 0.01, "tan_theta", error_model="specified", benches=200),
                      coverage_rows(errors, 3.0 * 0.01, "power_w", benches=200)], ignore_index=True)
    table = coverage_table(pd.concat([rows, coverage_rows(errors[:MIN_BENCHES - 1], 3.0 * 0.01, "amplitude_pp_m")]))
    factors = shrink_factors(table)
    assert set(factors) == {"power_w"}   # amplitude: all covered, but on too few benches to say
    assert factors["power_w"] == pytest.approx(Z95 / 3.0, rel=0.04)
    [line] = shrink_lines(table)
    assert line.startswith("power_w over-covers") and f"a U {factors['power_w']:.2f} times as wide" in line


@settings(max_examples=25, deadline=None)
@given(scale=st.floats(1e-6, 1e3), seed=st.integers(0, 2**16))
def test_the_factor_is_the_95th_percentile_of_error_over_u_whatever_the_scale(scale, seed):
    """Relative errors and U scaled alike leave the factor alone: it is p95 |error| / U."""
    errors = np.random.default_rng(seed).normal(0.0, 1.0, 400)
    rows = coverage_rows(errors * scale, 4.0 * scale, "power_w")
    factor = shrink_factors(coverage_table(rows))["power_w"]
    assert factor == pytest.approx(np.percentile(np.abs(errors), 95.0) / 4.0, rel=1e-9)


def test_scaled_floors_lower_each_quantity_by_its_factor_and_widen_the_noise_allowance():
    floors = AccuracyFloors(0.15, [RunFloor("fig5", "power_w", 0.06, "gain", 0.05, "gain"),
                                   RunFloor("fig5", "q", 0.141, "d31", 0.141, "d31")],
                            own_bench_time_s={"fig5": 500.0}, calibration_bench_time_s=10.0,
                            deskew_std_uncertainty_s=1e-10)
    narrower = floors.scaled({"q": 0.85})
    assert [f.floor_p95_rel for f in narrower.floors] == pytest.approx([0.06, 0.141 * 0.85])
    assert [f.calibrated_floor_p95_rel for f in narrower.floors] == pytest.approx([0.05, 0.141 * 0.85])
    assert narrower.noise_allowance("fig5") == pytest.approx(math.sqrt(0.15**2 - (0.141 * 0.85) ** 2))
    assert floors.noise_allowance("fig5") == pytest.approx(math.sqrt(0.15**2 - 0.141**2))   # unchanged
    assert AccuracyFloors(0.10, floors.floors, {"fig5": 500.0}, 10.0, 1e-10).below_floor()
    assert not AccuracyFloors(0.13, floors.floors, {"fig5": 500.0}, 10.0, 1e-10).scaled({"q": 0.85}).below_floor()


def test_the_reports_coverage_section_says_how_much_narrower_and_where_the_price_is(tmp_path):
    from squeezebench.report.section import ReportContext
    from squeezebench.report.study import _over_coverage_part

    errors = np.random.default_rng(6).normal(0.0, 0.01, 2000)
    context = ReportContext(run=None, out_dir=tmp_path)
    assert _over_coverage_part(context) == ""   # no coverage study
    context.tables["study_coverage"] = coverage_table(coverage_rows(errors, Z95 * 0.01, "power_w"))
    assert _over_coverage_part(context) == ""   # covers 95 %: nothing to say
    context.tables["study_coverage"] = coverage_table(coverage_rows(errors, 0.04, "tan_theta"))
    factor = shrink_factors(context.tables["study_coverage"])["tan_theta"]
    paragraph = _over_coverage_part(context)
    assert "over-covers on benches erring as the world errs" in paragraph
    assert f"a U {factor:.2f} times as wide would still cover 95 %" in paragraph
    assert "squeezebench plan CAMPAIGN --coverage RUN_DIR" in paragraph


def test_a_map_figures_surplus_is_said_to_cost_no_bench_time_for_the_reason_no_plan_prices_it():
    """A map's CV over-covering as the world errs gets the line any quantity gets, and why its
    surplus saves no bench time (its U is the grid correction's, which no map plan is chosen
    by: `UNPRICED`); a point's power, which a plan's floors price, gets no such words."""
    from squeezebench.analysis.over_coverage import UNPRICED
    from squeezebench.protocols.bench_errors import MAP_QUANTITIES

    assert set(UNPRICED) == set(MAP_QUANTITIES)
    errors = np.random.default_rng(7).normal(0.0, 0.01, 2000)
    # 2.5 sigma: 98.8 % covered, the misses spread over the benches (every bench all covered
    # would leave 40 benches' 91.2-100 %, no surplus shown)
    table = coverage_table(pd.concat([coverage_rows(errors, 0.025, "map_coefficient_of_variation", benches=40),
                                      coverage_rows(errors, 0.025, "power_w", benches=40)], ignore_index=True))
    cv, power = sorted(shrink_lines(table))
    assert cv.startswith("map_coefficient_of_variation over-covers") and cv.endswith(
        f"({UNPRICED['map_coefficient_of_variation']})")
    assert "grid correction's" in cv and "no bench time" in cv
    assert power.startswith("power_w over-covers") and power.endswith("would still cover 95 %")
