"""The acquisition planner on the quick campaign (simulated bench, seeded, a few seconds)."""

from pathlib import Path

import pytest

from protocols.planning import BASELINE_AVERAGES, make_plan

QUICK = Path(__file__).resolve().parents[1] / "data" / "campaigns" / "quick.yaml"
TARGET_REL_ERROR = 0.01


@pytest.fixture(scope="module")
def plan():
    # Fewer repeats than the default keep the test fast; the streams are seeded by the scene.
    return make_plan(QUICK, TARGET_REL_ERROR, repeats=4)


def test_planned_settings_meet_the_target_in_at_most_half_the_baseline_time(plan):
    assert set(plan.averages_by_run) == {"detuning", "cutting"}
    assert all(error <= TARGET_REL_ERROR for error in plan.error_by_run.values())
    assert plan.planned_total_s <= 0.5 * plan.baseline_total_s
    assert all(n < BASELINE_AVERAGES for n in plan.averages_by_run.values())


def test_errors_shrink_with_averaging(plan):
    # Averaging removes noise: 512 averages beat 2 on every plate studied.
    for studies in plan.studies.values():
        for study in studies:
            by_averages = {r.averages: r for r in study.results}
            assert by_averages[512].p95_rel_error < by_averages[2].p95_rel_error
            assert by_averages[512].bench_time_per_point_s > by_averages[2].bench_time_per_point_s


def test_table_lists_each_run_and_the_total(plan):
    table = plan.table()
    for name in ("detuning", "cutting", "total"):
        assert name in table

