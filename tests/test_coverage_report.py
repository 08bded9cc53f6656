"""What a coverage study found, in words (`study.coverage_verdict`: the report's coverage part
and `study` print it first), then the report's row per quantity with its coverage under each
error model (`report.study`), from the coverage table alone."""

from __future__ import annotations

import numpy as np
import pandas as pd

from squeezebench.analysis.study import coverage_table, coverage_verdict
from squeezebench.report.section import words_of
from squeezebench.report.study import _coverage_grid


def _points(quantity: str, model: str, covered_per_bench: list[int], values: int = 10,
            beyond: tuple[int, ...] = ()) -> pd.DataFrame:
    """Coverage rows: bench b has `covered_per_bench[b]` of its `values` values covered."""
    rows = []
    for bench, covered in enumerate(covered_per_bench, start=1):
        errors = np.r_[np.zeros(covered), np.full(values - covered, 2.0)]   # U is 1: 2 misses
        rows += [{"error_model": model, "quantity": quantity, "bench_seed": bench, "rel_error": e,
                  "rel_expanded_u": 1.0, "covered": e <= 1.0, "beyond_specification": bench in beyond}
                 for e in errors]
    return pd.DataFrame(rows)


def test_the_verdict_names_the_quantities_whose_interval_lies_above_or_below_95_percent():
    """40 benches of 10 values: every value covered (91.2-100 %: holds 95 %), misses spread one
    to each of 8 benches (98 %, interval above 95 %), and 40 values missed on 8 whole benches
    (80 %: below); the world's all covered; the words say which is which."""
    table = coverage_table(pd.concat([
        _points("power_w", "specified", [10] * 40),
        _points("resonance_frequency_hz", "specified", [9] * 8 + [10] * 32),
        _points("velocity_pp_mps", "specified", [0] * 8 + [10] * 32),
        _points("power_w", "world", [10] * 40, beyond=(3, 7)),
    ], ignore_index=True))
    assert table.set_index("quantity").loc["resonance_frequency_hz", "coverage_interval_low"].max() > 0.95
    verdict = coverage_verdict(table, words_of)
    assert verdict.startswith("Within specification (40 benches): the 95 % interval of 1 of 3 quantities holds 95 %")
    assert "; resonance frequency covers more (U wider than the errors need)" in verdict
    assert "; velocity covers less (U too narrow)" in verdict
    assert "As the world errs (40 benches): the 95 % interval of 1 of 1 quantities holds 95 %." in verdict

    grid = _coverage_grid(table).set_index("quantity")
    assert list(grid.columns) == ["within specification, 40 benches", "as the world errs, 40 benches",
                                  "world, instruments within specification, 38 benches"]
    assert grid.at["power", "within specification, 40 benches"] == "100.0 % (91.2-100.0 %)"
    assert grid.at["velocity", "within specification, 40 benches"].startswith("80.0 % (")
    assert grid.at["velocity", "as the world errs, 40 benches"] == ""   # not scored so
    assert grid.at["power", "world, instruments within specification, 38 benches"] == "100.0 %"
