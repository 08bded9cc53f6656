"""Planning a map: the grid step and averaging for a target on the touch area's
coefficient of variation, checked against a map run at the planned settings."""

from __future__ import annotations

import json

import numpy as np
import pytest

from squeezebench import cli
from squeezebench.analysis.cartography import homogeneity, map_points
from squeezebench.analysis.rundata import load_run
from squeezebench.protocols.campaign import run_campaign
from squeezebench.protocols.map_planning import AVERAGES, map_runs, plan_map, write_planned_maps
from squeezebench.protocols.planning import campaign_cache
from squeezebench.yamlfiles import dump_yaml, load_strict
from test_cartography_protocol import map_campaign

TARGET = 0.08   # a 4 mm grid meets it over this area, a 2 mm one with room: the plan must choose


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    tmp_path = tmp_path_factory.mktemp("plan")
    campaign = map_campaign(tmp_path, grid={"x_range_mm": [60, 140], "y_range_mm": [45, 93], "step_mm": 2})
    # through the campaign's plan cache, as `plan` plans it: the CLI's test reads these candidates
    return campaign, plan_map(map_runs(campaign)[0], TARGET, cache=campaign_cache(campaign))


def test_the_plan_is_the_cheapest_candidate_meeting_the_target(planned):
    _, plan = planned
    chosen = plan.chosen
    assert chosen is not None and chosen.error_rel <= TARGET
    meeting = [c for c in plan.candidates if c.error_rel <= TARGET]
    assert chosen.bench_time_s == min(c.bench_time_s for c in meeting)
    assert len(plan.candidates) == 6 * len(AVERAGES)
    assert chosen.bench_time_s < plan.as_written.bench_time_s   # a 2 mm grid is more than this target needs


def test_more_averages_cost_more_and_lower_the_noise(planned):
    _, plan = planned
    for step in {c.step_mm for c in plan.candidates}:
        row = sorted((c for c in plan.candidates if c.step_mm == step), key=lambda c: c.averages)
        assert all(a.bench_time_s < b.bench_time_s for a, b in zip(row, row[1:]))
        assert row[-1].noise_expanded_rel < row[0].noise_expanded_rel
        assert len({c.sampling_error_rel for c in row}) == 1   # the grid, not the averaging, samples


def test_each_candidates_bench_time_is_its_whole_map_priced_alone(planned):
    """A plan prices a grid's moves once for all its averagings: to the last bit what
    pricing each candidate's map whole (`map_bench_time_s`) gives."""
    import dataclasses

    from squeezebench.protocols.cartography import map_bench_time_s
    from squeezebench.protocols.map_planning import _point_noise

    campaign, plan = planned
    run = map_runs(campaign)[0]
    _, acquisition_s, _, acceleration_mm_per_s2 = _point_noise(run)
    for c in plan.candidates:
        points = dataclasses.replace(run.parameters.grid, step_mm=c.step_mm).points_mm()
        assert c.bench_time_s == map_bench_time_s(points, (0.0, 0.0), run.parameters.stage_velocity_mm_per_s,
                                                  acceleration_mm_per_s2, run.parameters.settle_s,
                                                  acquisition_s[c.averages])


def test_a_map_run_as_planned_measures_the_homogeneity_within_the_target(planned, tmp_path):
    """The claim checked where it matters: the planned grid, run on the simulated bench
    with its noise, gives a coefficient of variation within the target of the continuum's."""
    campaign, plan = planned
    out = tmp_path / "planned.yaml"
    out.write_text(campaign.read_text())
    write_planned_maps(campaign, [plan], out)
    points = map_points(load_run(run_campaign(out, out_dir=tmp_path / "run", progress=False, say=lambda m: None)))
    assert len(points) == plan.chosen.n_points
    measured = homogeneity(points["velocity_pp_mps"].to_numpy()).coefficient_of_variation
    assert abs(measured / plan.continuum_cv - 1.0) <= TARGET


def test_plan_cli_answers_for_a_map_and_exits_2_when_no_grid_meets_the_target(planned, capsys, monkeypatch):
    from squeezebench import paths
    from squeezebench.commands import _maps_only
    from squeezebench.protocols import parallel, plan_cache

    campaign, _ = planned
    warmed = []
    monkeypatch.setattr(plan_cache, "holds_nothing", lambda: True)   # as from an empty cache
    monkeypatch.setattr(parallel, "warm", lambda *args: warmed.append(args))
    assert cli.main(["plan", str(campaign), "--target-rel-error", "0.0001", "--json"]) == 2
    answer = json.loads(capsys.readouterr().out)
    assert answer["maps"][0]["chosen"] is None and answer["maps"][0]["as_written"]["step_mm"] == 2
    assert np.isfinite(answer["maps"][0]["continuum_coefficient_of_variation"])
    # a map is planned in this process: no worker is started to import the point planner for nothing
    assert warmed == [] and _maps_only(campaign)
    assert not _maps_only(paths.campaign_file("paper"))   # its maps beside points: the workers are warmed


def test_a_plate_without_a_model_is_refused_with_the_reason(tmp_path):
    from squeezebench.errors import UserError

    campaign = map_campaign(tmp_path)
    data = load_strict(campaign.read_text())
    data["runs"][0]["plate"]["name"] = "my_plate"
    campaign.write_text(dump_yaml(data))
    with pytest.raises(UserError, match="no plate model for 'my_plate'.*cannot be planned"):
        plan_map(map_runs(campaign)[0], 0.05)
