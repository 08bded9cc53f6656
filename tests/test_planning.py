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


@pytest.fixture(scope="module")
def quick_plates():
    """The quick campaign's plates and operating points, and all twenty settings measured on each."""
    from squeezebench.protocols.campaign import load_campaign
    from squeezebench.protocols.planning import _run_plates, _run_points, measure_settings

    keys = list(dict.fromkeys((scene, state, point, run.acquisition, run.safety)
                              for run in load_campaign(QUICK).runs for scene, state, plate in _run_plates(run)
                              for point in _run_points(run, plate)))
    return {key: measure_settings(*key, repeats=4)[0] for key in keys}


def test_each_run_gets_the_cheapest_setting_meeting_the_target_on_all_its_plates(plan):
    from squeezebench.protocols.planning import bench_time_per_point_s

    for name, studies in plan.studies.items():
        chosen = plan.settings_by_run[name]
        measured_everywhere = set.intersection(*({r.setting for r in s.results} for s in studies))
        for setting in measured_everywhere:
            if all(s.result(setting).p95_rel_error <= TARGET_REL_ERROR for s in studies):
                assert bench_time_per_point_s(studies, chosen) <= bench_time_per_point_s(studies, setting)


def test_measuring_the_averagings_as_far_as_needed_chooses_as_measuring_all_twenty(quick_plates, monkeypatch):
    from squeezebench.protocols.plan_cache import CACHE_VARIABLE, PlanCache
    from squeezebench.protocols.planning import (AVERAGES, AVERAGING_ROUNDS, SETTINGS, PlateStudy, SettingsStudy,
                                                 cheapest_setting)

    assert tuple(n for averagings in AVERAGING_ROUNDS for n in averagings) == AVERAGES
    monkeypatch.setenv(CACHE_VARIABLE, "off")
    cache = PlanCache([QUICK])   # one cache: each round is measured once over all the targets
    keys = list(quick_plates)
    full = [PlateStudy(key[0], key[1], key[2].voltage_vpp, 0.0, quick_plates[key]) for key in keys]
    errors = sorted({r.p95_rel_error for results in quick_plates.values() for r in results})
    fallback = Setting(10000, BASELINE_AVERAGES)
    # every measured error as a target, and just below it: each setting in turn meets or misses
    targets = [1e-9, *errors, *(e * (1 - 1e-9) for e in errors), 1.0]
    for plates in (keys[:1], keys):   # one plate, and a run over all of them
        for target in targets:
            study = SettingsStudy(cache, plates, repeats=4)
            chosen = study.choose({"run": (plates, target, fallback)}, workers=1, scheduler=None)["run"]
            assert chosen == cheapest_setting([full[keys.index(k)] for k in plates], target, fallback)
            for key in plates:   # the rounds measured, and as measuring all twenty on one bench gave
                measured = study.study(key).results
                assert [r.setting for r in measured] == \
                    [s for s in SETTINGS if any(s.averages in AVERAGING_ROUNDS[i] for i in range(study.rounds[key]))]
                alone = {r.setting: r for r in quick_plates[key]}
                assert [r.p95_rel_error for r in measured] == [alone[r.setting].p95_rel_error for r in measured]
                assert [r.bench_time_per_point_s for r in measured] == \
                    pytest.approx([alone[r.setting].bench_time_per_point_s for r in measured], rel=1e-3)
    loose = SettingsStudy(cache, keys, repeats=4)
    loose.choose({"run": (keys, 1.0, fallback)}, workers=1, scheduler=None)
    assert set(loose.rounds.values()) == {1}   # met in sample mode: nothing more averaged is measured
    strict = SettingsStudy(cache, keys, repeats=4)
    assert strict.choose({"run": (keys, 1e-9, fallback)}, workers=1, scheduler=None)["run"] == fallback
    assert set(strict.rounds.values()) == {len(AVERAGING_ROUNDS)}


def test_errors_shrink_with_averaging(quick_plates):
    # Averaging removes noise: 512 averages beat 2 on every plate studied; a point's bench
    # time grows with the averaging at either record length (what the rounds rely on).
    for results in quick_plates.values():
        for record_length in RECORD_LENGTHS:
            by_averages = {r.setting.averages: r for r in results if r.setting.record_length == record_length}
            assert by_averages[512].p95_rel_error < by_averages[2].p95_rel_error
            costs = [by_averages[n].bench_time_per_point_s for n in sorted(by_averages)]
            assert costs == sorted(costs) and len(set(costs)) == len(costs)


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
    from squeezebench.protocols.planning import CALIBRATION_RUN, campaign_cache, simulate_run_bench_time_s
    from squeezebench.protocols.variants import planned_campaign

    settings = {"detuning": {"averages": 8}, "cutting": {"averages": 32, "record_length": 500}}
    together = bench_time_by_run_s(run_campaign(planned_campaign(QUICK, settings, True, tmp_path / QUICK.name),
                                                out_dir=tmp_path / "run", progress=False))
    assert set(together) == {CALIBRATION_RUN, *settings}
    # the floors' run as a plan reads it (this module's plan ran it: its plan cache holds it)
    _, _, calibration_s, _ = campaign_cache(QUICK).call(measure_floors, QUICK)
    assert calibration_s == pytest.approx(together.pop(CALIBRATION_RUN), rel=1e-9)
    for name, seconds in together.items():
        assert simulate_run_bench_time_s(QUICK, name, settings[name]) == pytest.approx(seconds, rel=1e-9)
