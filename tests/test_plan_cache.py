"""What a plan measured is kept for the next plan of the same campaign, never read for another."""

from __future__ import annotations

import pytest

from squeezebench import paths
from squeezebench.protocols import plan_cache
from squeezebench.protocols.plan_cache import CACHE_VARIABLE, PlanCache

QUICK = paths.campaigns_dir() / "quick.yaml"
CALLS: list[tuple] = []


def measured(*args):
    """A measurement that leaves a trace of being made."""
    CALLS.append(args)
    return sum(args)


@pytest.fixture
def cache_folder(tmp_path, monkeypatch):
    monkeypatch.setenv(CACHE_VARIABLE, str(tmp_path / "cache"))
    CALLS.clear()
    return tmp_path / "cache"


def test_a_second_plan_reads_what_the_first_measured(tmp_path, cache_folder):
    inputs = tmp_path / "scene.yaml"
    inputs.write_text("seed: 1\n")
    first = PlanCache([inputs])
    assert first.call(measured, 1, 2) == 3 and first.call(measured, 1, 2) == 3   # one plan asks once
    assert CALLS == [(1, 2)] and (first.read, first.measured) == (0, 1)
    second = PlanCache([inputs])
    assert second.call(measured, 1, 2) == 3 and second.call(measured, 2, 2) == 4
    assert CALLS == [(1, 2), (2, 2)] and (second.read, second.measured) == (1, 1)
    assert "1 of 2 read from" in second.words() and str(cache_folder) in second.words()
    assert second.as_dict() == {"location": str(cache_folder / "plan"), "read": 1, "simulated": 1}


def test_a_changed_input_file_is_measured_again(tmp_path, cache_folder):
    inputs = tmp_path / "scene.yaml"
    inputs.write_text("seed: 1\n")
    PlanCache([inputs]).call(measured, 5)
    inputs.write_text("seed: 2\n")
    again = PlanCache([inputs])
    again.call(measured, 5)
    assert CALLS == [(5,), (5,)] and again.read == 0


def test_changed_source_is_a_new_key(tmp_path, cache_folder, monkeypatch):
    inputs = tmp_path / "scene.yaml"
    inputs.write_text("seed: 1\n")
    before = PlanCache([inputs]).fingerprint
    monkeypatch.setattr(plan_cache, "source_fingerprint", lambda: "other code")
    assert PlanCache([inputs]).fingerprint != before


def test_off_measures_everything_and_keeps_nothing(tmp_path, monkeypatch):
    monkeypatch.setenv(CACHE_VARIABLE, "off")
    CALLS.clear()
    inputs = tmp_path / "scene.yaml"
    inputs.write_text("seed: 1\n")
    for _ in range(2):
        cache = PlanCache([inputs])
        cache.call(measured, 1)
    assert CALLS == [(1,), (1,)] and cache.location is None
    assert "all 1 simulated now" in cache.words()


def test_only_a_cache_without_plans_says_everything_is_to_simulate(tmp_path, cache_folder, monkeypatch):
    """`plan` starts its workers early on that word alone: with a plan kept it may read all."""
    inputs = tmp_path / "scene.yaml"
    inputs.write_text("seed: 1\n")
    assert plan_cache.holds_nothing()   # no folder yet
    PlanCache([inputs])
    assert plan_cache.holds_nothing()   # opened, nothing kept
    PlanCache([inputs]).call(measured, 1)
    assert not plan_cache.holds_nothing()
    monkeypatch.setenv(CACHE_VARIABLE, "off")
    assert plan_cache.holds_nothing()


def test_the_default_folder_is_the_users_cache(monkeypatch, tmp_path):
    monkeypatch.delenv(CACHE_VARIABLE)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert plan_cache.cache_dir() == tmp_path / "squeezebench"


def test_a_replanned_campaign_is_the_same_plan_read_not_simulated(cache_folder):
    from squeezebench.protocols.planning import make_plan

    first = make_plan(QUICK, 0.01, repeats=2, check_benches=0)
    second = make_plan(QUICK, 0.02, repeats=2, check_benches=0)
    # the settings' first round on each plate and operating point (3: all 1 % needs here),
    # the floors, the two runs' baseline and plan
    assert first.cache["simulated"] == 3 + 1 + 2 + 2 and first.cache["read"] == 0
    # at another target only the planned campaign's timing can be new
    assert second.cache["simulated"] <= 1 and second.cache["read"] >= first.cache["simulated"] - 1
    assert {run: [s.results for s in studies] for run, studies in first.studies.items()} == \
        {run: [s.results for s in studies] for run, studies in second.studies.items()}
    assert first.floors.floors == second.floors.floors and first.baseline_s == second.baseline_s
    assert "read from" in second.table() and second.as_dict()["cache"] == second.cache


def test_a_run_already_timed_at_its_setting_is_not_run_again(tmp_path, cache_folder):
    """The floors' run is the campaign as written, and the baseline runs at 512 averages: a
    run planned at the setting it is written with, or written at 512 averages, takes its
    bench time from there."""
    from squeezebench.protocols.planning import Setting, make_plan, simulate_run_bench_time_s
    from squeezebench.protocols.variants import with_acquisition

    written = {"detuning": {"record_length": 500, "averages": 1}, "cutting": {"averages": 512}}
    campaign = with_acquisition(QUICK, written, tmp_path / QUICK.name)
    plan = make_plan(campaign, 0.5, repeats=2, check_benches=0)   # sample mode meets 50 %
    assert plan.settings_by_run == {"detuning": Setting(500, 1), "cutting": Setting(500, 1)}
    # the settings' first round on the 3 plates, the floors, detuning's baseline, cutting's plan
    assert plan.cache["simulated"] == 3 + 1 + 1 + 1
    assert plan.planned_s["detuning"] == plan.own_s["detuning"]
    assert plan.baseline_s["cutting"] == plan.own_s["cutting"] != plan.planned_s["cutting"]
    # what a timing of its own would have read
    assert plan.planned_s["detuning"] == pytest.approx(
        simulate_run_bench_time_s(campaign, "detuning", written["detuning"]), rel=1e-9)
