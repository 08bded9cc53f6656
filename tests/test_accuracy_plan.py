"""The floor a bench's specified errors put under a campaign (quick's measuring steps, simulated)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from squeezebench import paths
from squeezebench.analysis.calibration import gain_weight
from squeezebench.plates.specifications import SPECIFICATIONS
from squeezebench.protocols.accuracy_plan import accuracy_floors
from small_quick import HEADER, MEASURING_RUNS, small_quick

QUICK = paths.campaigns_dir() / "quick.yaml"


@pytest.fixture(scope="module")
def user_small_quick(tmp_path_factory) -> Path:
    """quick's two kinds of measuring step at a few search points, as a user may write
    them: without the deskew calibration run the shipped quick carries, so the plan
    decides whether to buy it (`small_quick` without its calibration). Their floors are
    quick's within 0.1 % of the power; the plans' measurements are simulated once for the
    module (the session's plan cache)."""
    campaign = tmp_path_factory.mktemp("user_small") / "small_quick.yaml"
    campaign.write_text(HEADER + MEASURING_RUNS, encoding="utf-8")
    return campaign


@pytest.fixture(scope="module")
def measured_floors(user_small_quick):
    """`measure_floors` of the campaign, through its plan cache as `make_plan` calls it: the
    floors' tests and the module's plans read one run of it (each ran it again before)."""
    from squeezebench.protocols.accuracy_plan import measure_floors
    from squeezebench.protocols.planning import campaign_cache

    return campaign_cache(user_small_quick).call(measure_floors, user_small_quick)


@pytest.fixture(scope="module")
def floors(user_small_quick, measured_floors):
    return accuracy_floors(user_small_quick, 0.01, measured_floors)


def test_a_one_percent_target_is_below_the_gain_floor(floors):
    # power carries four gains (voltage probe, CH1, CH2 +-2 %, TCP202 +-3 %): p95 ~ 1.96 x 2.7 % whatever the averaging
    voltage_path = math.hypot(SPECIFICATIONS["voltage_probe_attenuation"].std_uncertainty,
                              SPECIFICATIONS["scope_gain"].std_uncertainty)
    gains = math.sqrt(voltage_path**2 + SPECIFICATIONS["scope_gain"].std_uncertainty**2
                      + SPECIFICATIONS["current_probe_gain"].std_uncertainty**2)
    power = [f for f in floors.floors if f.quantity == "power_w"]
    assert all(f.floor_p95_rel >= 1.96 * gains * 0.999 for f in power)
    # the gain check trades the current path's errors for the voltage path's: gV^(1+a) (g2 gp)^(1-a)
    alpha = gain_weight()
    checked = math.hypot((1 + alpha) * voltage_path,
                         (1 - alpha) * math.hypot(SPECIFICATIONS["scope_gain"].std_uncertainty,
                                                  SPECIFICATIONS["current_probe_gain"].std_uncertainty))
    assert checked < gains   # little: the voltage path (probe and CH1) is nearly as uncertain as the current path
    assert all(f.calibrated_floor_p95_rel >= 1.96 * checked * 0.999 for f in power)
    assert {f.calibrated_dominant_term for f in power} <= {"current path gain (gain-checked)",
                                                          "voltage probe attenuation (gain-checked)"}
    assert len(floors.below_floor()) == len(floors.floors)
    text = "\n".join(floors.lines())
    assert "below the reachable floor" in text and "voltage reference" in text


def test_the_deskew_calibration_lifts_the_delay_term_at_its_cost(floors, user_small_quick, measured_floors):
    assert floors.calibration_bench_time_s > 1.0
    assert floors.deskew_std_uncertainty_s < 1e-9
    assert set(floors.own_bench_time_s) == {"detuning", "cutting"}
    for f in floors.floors:
        assert f.calibrated_floor_p95_rel <= f.floor_p95_rel + 1e-12
    # the gains alone leave 5.25 % (p95) on the cut's power, 5.8 % on the detuning's (5.2 % calibrated)
    relaxed = accuracy_floors(user_small_quick, 0.053, measured_floors)
    assert relaxed.below_floor() == []
    for run in relaxed.calibrated_runs():   # the calibration is planned only where it is needed
        assert relaxed.floor(run, calibrated=False) > 0.053 >= relaxed.floor(run, calibrated=True)
    assert relaxed.calibrated_runs()
    assert all(0 < relaxed.noise_allowance(run) < 0.053 for run in relaxed.own_bench_time_s)
    assert relaxed.as_dict()["calibration"]["runs"] == relaxed.calibrated_runs()


# -- the planner with the floor (protocols.planning) -------------------------------------------
@pytest.fixture(scope="module")
def relaxed_plan(user_small_quick):
    """Planned and checked on `user_small_quick`: the check's 8 benches are most of the
    plan's time, and each runs the whole campaign. Its power p95 on those benches (about
    6.8 %) stays near the 8 % target, so an erring check still shows."""
    from squeezebench.protocols.planning import make_plan

    return make_plan(user_small_quick, 0.08, repeats=2, check_benches=8)


def test_a_reachable_target_is_planned_and_checked_on_eight_erring_benches(relaxed_plan):
    plan = relaxed_plan
    assert plan.check_benches == 8 and plan.meets_check
    assert (plan.check["p95_abs_rel_error"] <= 0.08).all()
    assert (plan.check["p95_abs_rel_error"] > 0.005).all()   # the benches' errors, not noise
    assert not plan.calibrate   # every floor is well below 8 %: no calibration bought
    assert set(plan.own_s) == set(plan.settings_by_run)
    table = plan.table()
    assert "own s" in table and "512-avg s" in table and "meets the target" in table
    data = plan.as_dict()
    assert data["own_bench_time_s"] == pytest.approx(sum(plan.own_s.values()))
    assert data["check"]["benches"] == 8 and data["floors"]["below_floor"] == []
    # what the plan read or simulated: the settings' first round (all a target of 8 % needs)
    # on 2 plates and operating points (the detuning's, the one cut's), the floors, the two
    # runs' baseline and plan, the 8 checked benches
    assert data["cache"]["read"] + data["cache"]["simulated"] == 2 + 1 + 2 + 2 + 8


def test_a_target_below_the_floor_is_said_with_its_dominant_term(user_small_quick):
    from squeezebench.protocols.planning import make_plan
    plan = make_plan(user_small_quick, 0.01, repeats=2, check_benches=8)
    assert plan.check is None   # nothing to check: no setting reaches it
    table = plan.table()
    assert "below the reachable floor" in table and "current probe gain" in table
    for name, setting in plan.settings_by_run.items():   # noise kept well below the floor, not chased
        assert plan.error_by_run[name] <= plan.floors.floor(name, calibrated=True) / 3.0 or setting.averages == 512


def test_a_missed_check_calibrates_then_tightens_the_missing_runs(monkeypatch, user_small_quick):
    """The check on erring benches is the arbiter: a miss first buys the calibration, then
    halves the noise the missing run may take, until the check meets the target."""
    import pandas as pd

    from squeezebench.protocols import planning

    verdicts = iter([0.09, 0.09, 0.02])   # the detuning run's p95 in successive checks
    seen = []

    def check(campaign_path, plan, benches, workers=1, scheduler=None, cache=None):
        seen.append((plan.calibrate, dict(plan.noise_scale), plan.settings_by_run["detuning"]))
        return pd.DataFrame([{"run_name": "detuning", "quantity": "power_w", "p95_abs_rel_error": next(verdicts)},
                             {"run_name": "cutting", "quantity": "power_w", "p95_abs_rel_error": 0.02}])

    monkeypatch.setattr(planning, "check_plan", check)
    plan = planning.make_plan(user_small_quick, 0.08, repeats=2, check_benches=8)
    assert [calibrated for calibrated, _, _ in seen] == [False, True, True]
    assert [scale for _, scale, _ in seen] == [{}, {}, {"detuning": 0.5}]
    assert plan.meets_check and plan.noise_scale == {"detuning": 0.5}
    assert plan.floors.calibration_forced_by.startswith("the check on 8 benches")
    assert seen[2][2].averages >= seen[1][2].averages   # less noise allowed: never cheaper
    assert "its noise may take 0.5" in plan.table()
    assert plan.as_dict()["check"]["noise_scale"] == {"detuning": 0.5}


def test_a_plan_that_keeps_missing_is_returned_checked_and_says_so(monkeypatch, user_small_quick):
    import pandas as pd

    from squeezebench.protocols import planning

    calls = []

    def check(campaign_path, plan, benches, workers=1, scheduler=None, cache=None):
        calls.append(plan)
        return pd.DataFrame([{"run_name": "detuning", "quantity": "power_w", "p95_abs_rel_error": 0.5}])

    monkeypatch.setattr(planning, "check_plan", check)
    plan = planning.make_plan(user_small_quick, 0.08, repeats=2, check_benches=8)
    assert len(calls) == planning.MAX_TIGHTENINGS + 1 and calls[-1] is plan   # the last plan is the checked one
    assert not plan.meets_check and plan.missed_runs() == ["detuning"]
    assert f"missed by detuning after {planning.MAX_TIGHTENINGS} tightenings" in plan.table()
    assert plan.as_dict()["check"]["meets_target"] is False


def test_plan_write_below_the_floor_exits_non_zero_and_the_written_plan_carries_the_calibration(
        tmp_path, monkeypatch, capsys):
    """The plan's noise allowance there assumes the calibrated floor: the file a person runs
    must carry the calibration, and a script must not read the exit code as success."""
    from squeezebench import cli
    from squeezebench.protocols import planning
    from squeezebench.protocols.accuracy_plan import CALIBRATION_RUN
    from squeezebench.protocols.campaign import load_campaign

    real = planning.make_plan
    monkeypatch.setattr(planning, "make_plan", lambda path, target, **kw: real(path, target, repeats=2, **kw))
    out = tmp_path / "planned.yaml"
    campaign = small_quick(tmp_path / "campaign")   # quick's three kinds of step, its calibration first
    assert cli.main(["plan", str(campaign), "--target-rel-error", "0.01", "--write", str(out), "--json"]) == 2
    captured = capsys.readouterr()
    assert "below the floor" in captured.err
    data = json.loads(captured.out)
    assert data["reachable"] is False and data["floors"]["calibration"]["planned"] is True
    for run in data["runs"]:   # the per-run figure is the total; the noise part is named as such
        floor = max(f["calibrated_floor_p95_rel"] for f in data["floors"]["floors"] if f["run_name"] == run["run"])
        assert run["p95_rel_error"] == pytest.approx(math.hypot(floor, run["noise_p95_rel_error"]))
        assert run["p95_rel_error"] > 0.01 > run["noise_p95_rel_error"]
    assert [r.name for r in load_campaign(out).runs][0] == CALIBRATION_RUN
    # the campaign carries its calibration already (as the shipped quick does): kept once, its bench time in its own
    assert [r.protocol for r in load_campaign(out).runs].count(CALIBRATION_RUN) == 1
    assert data["own_bench_time_by_run_s"][CALIBRATION_RUN] > 1.0


def test_a_target_below_the_q_and_tan_theta_floors_is_refused_naming_them(tmp_path, monkeypatch, capsys):
    """Q and tan theta' carry the plates' geometry and material tolerances (d31 and c11
    +-5 %, the sheet's thickness): their floors are above 8 % whatever the averaging, so a
    plan at 8 % on a characterisation says so, names them and exits 2 (issue 46: it said
    'reachable')."""
    from squeezebench import cli
    from squeezebench.protocols import planning
    from squeezebench.yamlfiles import dump_yaml, load_strict

    paper = load_strict(paths.paper_campaign().read_text())
    fig5 = next(run for run in paper["runs"] if run["name"] == "fig5_small_plates")
    fig5 = {**fig5, "parameters": {**fig5["parameters"], "plates": fig5["parameters"]["plates"][:1],
                                   "search": {"start_hz": 30000, "stop_hz": 60000, "points": 31}}}
    campaign = tmp_path / "fig5.yaml"
    campaign.write_text(dump_yaml({"name": "fig5", **{k: paper[k] for k in ("acquisition", "safety")},
                                   "runs": [fig5]}))
    real = planning.make_plan
    monkeypatch.setattr(planning, "make_plan", lambda path, target, **kw: real(path, target, repeats=2, **kw))
    assert cli.main(["plan", str(campaign), "--target-rel-error", "0.08", "--json"]) == 2
    captured = capsys.readouterr()
    assert "leave on q, tan_theta;" in captured.err
    data = json.loads(captured.out)
    below = {f["quantity"]: f["calibrated_floor_p95_rel"] for f in data["floors"]["below_floor"]}
    assert {"q", "tan_theta"} <= set(below) and min(below["q"], below["tan_theta"]) > 0.08
    assert data["reachable"] is False
    assert cli.main(["plan", str(campaign), "--target-rel-error", "0.08"]) == 2   # the cache answers
    text = capsys.readouterr().out
    assert "fig5_small_plates        q " in text and "fig5_small_plates        tan_theta" in text
    assert "below the reachable floor" in text


def test_a_folder_named_like_a_shipped_campaign_does_not_hide_it(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "quick").mkdir()
    assert paths.campaign_file("quick") == QUICK
    (tmp_path / "mine.yaml").write_text("runs: []\n")
    assert paths.campaign_file("mine.yaml") == Path("mine.yaml")


def test_a_plan_dearer_than_the_campaigns_own_settings_says_so():
    from squeezebench.protocols import planning

    def plan(own_s: dict) -> str:
        return planning.Plan(0.05, {}, {"detuning": planning.Setting(500, 16), "cutting": planning.Setting(500, 4)},
                             {"detuning": 0.01, "cutting": 0.01}, {"detuning": 2.0, "cutting": 1.0},
                             {"detuning": 8.0, "cutting": 4.0}, own_s=own_s).table()

    assert "dearer than the campaign's own settings: 3.0 s of bench time against 2.0 s (1.50 times)" in \
        plan({"detuning": 1.0, "cutting": 1.0})
    assert "dearer" not in plan({"detuning": 2.0, "cutting": 2.0})


def test_a_floors_run_that_stored_no_point_is_refused_with_the_cause(tmp_path, monkeypatch):
    """`stored_points` finds nothing when no step kept a waveform: one message saying so, not
    a crash in the budgets. The calibration alone is the quickest run to read it from."""
    import yaml

    from squeezebench.errors import UserError
    from squeezebench.protocols import accuracy_plan

    data = yaml.safe_load(QUICK.read_text(encoding="utf-8"))
    data["runs"] = [run for run in data["runs"] if run["protocol"] == "deskew_calibration"]
    campaign = tmp_path / "calibration_only.yaml"
    campaign.write_text(yaml.safe_dump(data), encoding="utf-8")
    assert accuracy_plan.measure_floors(campaign)[0] == []   # a run storing points: read, no floor among them
    monkeypatch.setattr(accuracy_plan, "stored_points", lambda run: (None, None))
    with pytest.raises(UserError, match=r"calibration_only.yaml: its run on the simulated bench stored no "
                                        r"measured point .* cannot be read"):
        accuracy_plan.measure_floors(campaign)


# -- what the budgets' over-coverage costs (analysis.over_coverage, OverCoverageCost) -------------
def world_coverage_study(run_dir: Path, factor: float) -> Path:
    """A world-model coverage study in RUN_DIR whose power U over-covers: normal errors on
    400 benches, U = 1.96 sigma / `factor`, so p95 |error| / U is `factor` (closed form)."""
    import numpy as np
    import pandas as pd

    errors = np.random.default_rng(5).normal(0.0, 0.01, 400)
    u = 1.959964 * 0.01 / factor
    directory = run_dir / "study" / "coverage_world"
    directory.mkdir(parents=True)
    pd.DataFrame({"error_model": "world", "quantity": "power_w", "bench_seed": np.arange(errors.size),
                  "rel_error": errors, "rel_expanded_u": u, "covered": np.abs(errors) <= u}
                 ).to_parquet(directory / "points.parquet")
    return run_dir


def test_a_narrower_power_budget_drops_the_calibration_the_plan_needs(user_small_quick):
    """At 5.3 % the detuning run's power floor (5.8 %) needs the deskew calibration; with power
    budgets half as wide the floors are under 3 %: no calibration, and the plan says what the
    over-coverage costs (the calibration's bench time at least), run by run; a map figure's
    surplus, which no plan prices, is named with why (`over_coverage.UNPRICED`) and changes nothing."""
    from squeezebench.analysis.over_coverage import UNPRICED
    from squeezebench.protocols.planning import CALIBRATION_RUN, make_plan

    plan = make_plan(user_small_quick, 0.053, repeats=2, check_benches=0,
                     shrink_factors={"power_w": 0.5, "map_coefficient_of_variation": 0.8}, shrink_source="a study")
    cost = plan.over_coverage
    assert plan.calibrate and not cost.narrower.calibrate
    assert [f.floor_p95_rel for f in cost.narrower.floors.floors] == pytest.approx(
        [f.floor_p95_rel * (0.5 if f.quantity == "power_w" else 1.0) for f in plan.floors.floors])
    assert cost.saved_s(plan) == pytest.approx(plan.planned_total_s - cost.narrower.planned_total_s)
    assert cost.saved_s(plan) >= plan.planned_s[CALIBRATION_RUN] > 1.0
    for name, setting in plan.settings_by_run.items():   # more of the target left to noise: never dearer
        assert cost.narrower.settings_by_run[name].averages <= setting.averages
    text = plan.table()
    assert "over-coverage on the world model (coverage study in a study)" in text
    assert f"the over-coverage costs {cost.saved_s(plan):.1f} s" in text and f"{CALIBRATION_RUN}: " in text
    assert f"map_coefficient_of_variation 0.80 ({UNPRICED['map_coefficient_of_variation']})" in text
    assert make_plan(user_small_quick, 0.053, repeats=2, check_benches=0, shrink_factors={}).table().endswith(
        "no quantity over-covers; nothing to save")


def test_plan_with_a_world_coverage_study_prices_its_over_coverage(tmp_path, monkeypatch, capsys, user_small_quick):
    from squeezebench import cli
    from squeezebench.protocols import planning

    real = planning.make_plan
    monkeypatch.setattr(planning, "make_plan",
                        lambda path, target, **kw: real(path, target, repeats=2, **{**kw, "check_benches": 0}))
    study = world_coverage_study(tmp_path / "study_run", factor=0.5)
    assert cli.main(["plan", str(user_small_quick), "--target-rel-error", "0.053", "--coverage", str(study), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)["over_coverage"]
    assert data["shrink_factors"]["power_w"] == pytest.approx(0.5, rel=0.1)
    assert data["source"] == str(study) and data["reachable"] is True
    assert data["saved_bench_time_s"] > 1.0   # the calibration, at least
    assert {run["run"] for run in data["runs"]} == {"detuning", "cutting"}
    assert cli.main(["plan", str(user_small_quick), "--target-rel-error", "0.053", "--coverage", str(study)]) == 0
    assert "the over-coverage costs" in capsys.readouterr().out


def test_plan_refuses_a_coverage_folder_without_a_world_study_before_planning(tmp_path, monkeypatch, capsys):
    import pandas as pd

    from squeezebench import cli
    from squeezebench.protocols import planning

    monkeypatch.setattr(planning, "make_plan", lambda *a, **kw: pytest.fail("planned before refusing"))
    assert cli.main(["plan", str(QUICK), "--coverage", str(tmp_path)]) == 2
    assert "no coverage study on the world model" in capsys.readouterr().err
    few = world_coverage_study(tmp_path / "few", factor=0.5)
    points = few / "study" / "coverage_world" / "points.parquet"
    pd.read_parquet(points).head(3).to_parquet(points)   # three benches
    assert cli.main(["plan", str(QUICK), "--coverage", str(few)]) == 2
    assert "has 3 benches; an over-coverage needs at least 10" in capsys.readouterr().err
