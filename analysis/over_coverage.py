"""Where an expanded uncertainty is wider than the errors need: by how much it could shrink.

A budget's k holds 95 % both with each specification a rectangle at its limit and as the
world reads the limit (`budgets.ERROR_MODELS`). Where the rectangles set k (a sum of several
comparable terms), the world's errors (`study.COVERAGE_MODELS["world"]`: normal with half the
limit as their standard deviation) are smaller than that: such a sum spreads by
sqrt(3)/2 = 0.87 of the budget's standard uncertainty (rectangle: limit / sqrt(3), GUM 4.3.7;
world: limit / 2), so its U covers more than the 95 % it states there. The factor
U could be multiplied by and still cover 95 % is the 95th percentile of |error| / U over
the coverage study's values (`study.coverage_table`'s `p95_error_over_u`): that fraction of
values then lies within the narrower U. A quantity over-covers when its whole 95 %
interval (`study.coverage_interval`, benches as trials) lies above 95 %: the surplus is then
more than the few benches' luck. What the surplus costs in bench time is the planner's to say (`squeezebench plan
--coverage RUN_DIR`): a floor that much lower leaves more of the target to the noise.
"""

from __future__ import annotations

import pandas as pd

#: The coverage each expanded uncertainty states.
STATED_COVERAGE = 0.95
#: The error model whose surplus is priced: the world's (the specified one is what the budgets assume).
WORLD = "world"
#: Fewer benches say nothing of a surplus: their p95 |error| / U is one bench's luck, even
#: where many values a bench, as good as independent, narrow their interval.
MIN_BENCHES = 10


#: Quantities whose surplus no plan can price, and why: a map's figures. `squeezebench plan
#: --coverage` prices a surplus by lowering the floors of the points' runs; a map plan
#: (`protocols.map_planning`) chooses its grid and averaging by the points' sampling error and
#: noise, not by these U, so a narrower one changes no plan. The CV's and the area's U is the
#: grid correction's own error and the cells' quadrature (`cartography.grid_correction_term`,
#: `grid_quadrature_term`), which averaging does not shrink (the points' noise is about 1 % of
#: the CV's u and under 10 % of the area's on the paper map's benches); the mean's and the
#: peak's is the velocity scale all points share (`cartography.velocity_scale_terms`).
UNPRICED = {quantity: f"a map figure, its U {what}: narrower, it changes no plan, no bench time saved"
            for quantity, what in (("map_coefficient_of_variation", "the grid correction's, not the noise's"),
                                   ("map_fraction_above_share", "the grid correction's, not the noise's"),
                                   ("map_mean_velocity_pp_mps", "the velocity scale's"),
                                   ("map_max_velocity_pp_mps", "the velocity scale's"))}


def shrink_factors(table: pd.DataFrame, error_model: str = WORLD) -> dict[str, float]:
    """{quantity: factor} for each quantity of `table` (`study.coverage_table`) that
    over-covers under `error_model`: scored on at least `MIN_BENCHES` benches, its
    interval's lower end is above `STATED_COVERAGE`, and the factor (p95
    |error| / U, below 1) is what its U could be multiplied by and still cover 95 %.
    Quantities that do not over-cover are left out."""
    rows = table[(table["error_model"] == error_model) & (table["benches"] >= MIN_BENCHES)
                 & (table["coverage_interval_low"] > STATED_COVERAGE) & (table["p95_error_over_u"] < 1.0)]
    return {str(row.quantity): float(row.p95_error_over_u) for row in rows.itertuples()}


def shrink_lines(table: pd.DataFrame, quantity_words=str, error_model: str = WORLD) -> list[str]:
    """One line per quantity `shrink_factors` finds (what the report's coverage section
    says): how far it over-covers and how much narrower its U could be; for one no plan
    prices (`UNPRICED`), why its surplus costs no bench time."""
    by_quantity = table[table["error_model"] == error_model].set_index("quantity")
    return [f"{quantity_words(quantity)} over-covers on benches erring as the world errs "
            f"({by_quantity.at[quantity, 'covered_fraction']:.1%}, interval from "
            f"{by_quantity.at[quantity, 'coverage_interval_low']:.1%}): a U {factor:.2f} times as wide would still "
            f"cover 95 %" + (f" ({UNPRICED[quantity]})" if quantity in UNPRICED else "")
            for quantity, factor in shrink_factors(table, error_model).items()]
