"""The acquisition planner on the quick campaign (simulated bench, seeded, a few seconds)."""

from pathlib import Path

import pytest

from squeezebench.protocols.planning import BASELINE_AVERAGES, RECORD_LENGTHS, Setting, make_plan

QUICK = Path(__file__).resolve().parents[1] / "data" / "campaigns" / "quick.yaml"
TARGET_REL_ERROR = 0.01


@pytest.fixture(scope="module")
def plan():
    # Fewer repeats than the default keep the test fast; the streams are seeded by the scene.
    return make_plan(QUICK, TARGET_REL_ERROR, repeats=4)


def test_planned_settings_meet_the_target_in_at_most_half_the_baseline_time(plan):
    assert set(plan.settings_by_run) == {"detuning", "cutting"}
    assert all(error <= TARGET_REL_ERROR for error in plan.error_by_run.values())
    assert plan.planned_total_s <= 0.5 * plan.baseline_total_s
    assert all(s.averages < BASELINE_AVERAGES for s in plan.settings_by_run.values())


def test_each_run_gets_the_cheapest_setting_meeting_the_target_on_all_its_plates(plan):
    for name, studies in plan.studies.items():
        chosen = plan.settings_by_run[name]
        cost = lambda setting: sum(s.result(setting).bench_time_per_point_s for s in studies)  # noqa: E731
        for result in studies[0].results:
            if all(s.result(result.setting).p95_rel_error <= TARGET_REL_ERROR for s in studies):
                assert cost(chosen) <= cost(result.setting)


def test_errors_shrink_with_averaging(plan):
    # Averaging removes noise: 512 averages beat 2 on every plate studied.
    for studies in plan.studies.values():
        for study in studies:
            for record_length in RECORD_LENGTHS:
                many, few = (study.result(Setting(record_length, n)) for n in (512, 2))
                assert many.p95_rel_error < few.p95_rel_error
                assert many.bench_time_per_point_s > few.bench_time_per_point_s


def test_table_lists_each_run_and_the_total(plan):
    table = plan.table()
    for name in ("detuning", "cutting", "total"):
        assert name in table



def test_the_planned_campaign_is_written_with_the_planned_settings(tmp_path, monkeypatch):
    from squeezebench.protocols import planning
    from squeezebench.protocols.campaign import load_campaign

    # the plan itself is tested above; here only what `--write` does with it
    fake = planning.Plan(TARGET_REL_ERROR, {}, {"detuning": Setting(500, 4), "cutting": Setting(10000, 1)},
                         {"detuning": 0.005, "cutting": 0.004}, {"detuning": 1.0, "cutting": 1.0},
                         {"detuning": 9.0, "cutting": 9.0})
    monkeypatch.setattr(planning, "make_plan", lambda path, target, **parallel: fake)
    out = tmp_path / "planned.yaml"
    text = planning.plan_campaign(QUICK, TARGET_REL_ERROR, write=out)
    assert f"written to {out}" in text
    runs = {run.name: run.acquisition for run in load_campaign(out).runs}
    assert (runs["detuning"].record_length, runs["detuning"].averages) == (500, 4)
    assert (runs["cutting"].record_length, runs["cutting"].averages) == (10000, 1)


def test_a_setting_measures_the_same_whatever_ran_before_it_on_the_bench():
    from squeezebench.protocols.campaign import load_campaign
    from squeezebench.protocols.planning import _run_plates, _run_points, measure_settings

    run = load_campaign(QUICK).runs[0]
    scene, state, plate = _run_plates(run)[0]
    args = (scene, state, _run_points(run, plate)[0], run.acquisition, run.safety)
    settings = [Setting(500, 4), Setting(500, 64), Setting(10000, 1)]
    forward, forward_hz = measure_settings(*args, repeats=2, settings=settings)
    backward, backward_hz = measure_settings(*args, repeats=2, settings=settings[::-1])
    assert forward_hz == backward_hz
    assert [r.p95_rel_error for r in forward] == [r.p95_rel_error for r in backward[::-1]]
    # the scope keeps the averaging count it last had, and says so in a reply one byte
    # longer: bench time may differ by a byte's transfer, nothing more
    assert [r.bench_time_per_point_s for r in forward] == \
        pytest.approx([r.bench_time_per_point_s for r in backward[::-1]], rel=1e-3)
    assert forward[0].p95_rel_error != forward[1].p95_rel_error   # the settings do differ


def test_a_run_timed_alone_takes_its_bench_time_within_the_campaign(tmp_path):
    # The planner times runs apart, on as many workers: each must cost what it does in order,
    # and the calibration what it cost when the floors were measured.
    from squeezebench.protocols.accuracy_plan import measure_floors
    from squeezebench.protocols.bench_errors import bench_time_by_run_s
    from squeezebench.protocols.campaign import run_campaign
    from squeezebench.protocols.planning import CALIBRATION_RUN, simulate_run_bench_time_s
    from squeezebench.protocols.variants import planned_campaign

    settings = {"detuning": {"averages": 8}, "cutting": {"averages": 32, "record_length": 500}}
    together = bench_time_by_run_s(run_campaign(planned_campaign(QUICK, settings, True, tmp_path / QUICK.name),
                                                out_dir=tmp_path / "run", progress=False))
    assert set(together) == {CALIBRATION_RUN, *settings}
    _, _, calibration_s, _ = measure_floors(QUICK)
    assert calibration_s == pytest.approx(together.pop(CALIBRATION_RUN), rel=1e-9)
    for name, seconds in together.items():
        assert simulate_run_bench_time_s(QUICK, name, settings[name]) == pytest.approx(seconds, rel=1e-9)
