"""One validator, the same bounds: what `validate` accepts the command that runs the file
accepts, and what it refuses is refused by that command with the same message, quickly
(a map of 50 million points was planned point by point and hung both)."""

from __future__ import annotations

import time

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from squeezebench import cli, paths, schemas
from squeezebench.errors import UserError
from squeezebench.instruments.bench import open_bench, sim_bench_config
from squeezebench.protocols.cartography import Grid


def _campaign(tmp_path, grid: dict, name: str = "map") -> str:
    data = yaml.safe_load(paths.campaign_file("cartography.yaml").read_text())
    data["runs"][0]["parameters"]["grid"] = grid
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


def _cause(capsys) -> str:
    """The one message a refusal printed, without the command's name."""
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err.split(": ", 1)[1]


def _both_refuse(tmp_path, capsys, file: str, *words: str) -> str:
    started = time.process_time()
    assert cli.main(["validate", file]) == cli.EXIT_USER_ERROR
    assert time.process_time() - started < 2.0
    refused = _cause(capsys)
    assert cli.main(["run", file, "--out", str(tmp_path / "run"), "-q"]) == cli.EXIT_USER_ERROR
    assert _cause(capsys) == refused   # the same validator, the same words
    assert all(word in refused for word in words), refused
    assert not (tmp_path / "run").exists()
    return refused


@pytest.mark.parametrize("step_mm, words", [(1e-6, ("4.99e+15 points", "10000")), (0.01, ("4.99e+07 points",)),
                                            (500, ("one point",))])
def test_unbounded_and_one_point_maps_are_refused_at_once_by_validate_and_run(tmp_path, capsys, step_mm, words):
    file = _campaign(tmp_path, {"x_range_mm": [51, 147], "y_range_mm": [43, 95], "step_mm": step_mm})
    _both_refuse(tmp_path, capsys, file, "step_mm", *words)


def test_a_map_at_negative_positions_is_refused_by_both(tmp_path, capsys):
    file = _campaign(tmp_path, {"x_range_mm": [-10, 40], "y_range_mm": [43, 95], "step_mm": 10})
    _both_refuse(tmp_path, capsys, file, "-10 mm", "none is negative")


def test_a_map_beyond_the_stages_travel_is_refused_by_both(tmp_path, capsys):
    file = _campaign(tmp_path, {"x_range_mm": [250, 350], "y_range_mm": [43, 95], "step_mm": 10})
    _both_refuse(tmp_path, capsys, file, "x = 350 mm", "stage's travel, 0 to 300 mm")


#: A real bench's stage and its travel (SMC100 SL/SR), as a bench file states them.
STAGE = {"stage": "ASRL2::INSTR"}
TRAVEL = {"x": [0, 150], "y": [0, 100]}


def _bench_file(tmp_path, travel=None, **resources) -> str:
    data = yaml.safe_load((paths.benches_dir() / "lab_example.yaml").read_text())
    data["resources"].update(resources)
    if travel is not None:
        data["stage_travel_mm"] = travel
    path = tmp_path / "bench.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


@pytest.mark.parametrize("resources, words", [
    ({"stage": "ASRL1::INSTR"}, ("stage and vibrometer have the same address",)),
    ({"stage": "GPIB0::12::INSTR"}, ("is a GPIB address", "reached by ASRL")),
    ({"vibrometer": "TCPIP0::192.168.0.30::INSTR"}, ("is a TCPIP address",)),
])
def test_addresses_distinct_and_reachable_by_their_interface_in_validate_check_and_run(tmp_path, capsys,
                                                                                       resources, words):
    bench = _bench_file(tmp_path, **resources)
    assert cli.main(["validate", bench]) == cli.EXIT_USER_ERROR
    refused = _cause(capsys)
    assert all(word in refused for word in words), refused
    assert cli.main(["check", "--bench", bench]) == cli.EXIT_USER_ERROR
    assert _cause(capsys) == refused


def test_a_serial_instrument_behind_a_serial_server_is_reachable(tmp_path, capsys):
    assert cli.main(["validate", _bench_file(tmp_path, TRAVEL, stage="TCPIP0::192.168.0.40::4001::SOCKET")]) == 0


def _real_map(tmp_path, bench: str, grid: dict) -> str:
    data = yaml.safe_load(paths.campaign_file("cartography.yaml").read_text())
    data["bench"] = {"file": bench}
    data["runs"][0]["plate"]["name"] = "large_plate"   # no scene names it on a real bench
    data["runs"][0]["parameters"]["grid"] = grid
    path = tmp_path / "real_map.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


@pytest.mark.parametrize("resources, travel, grid, words", [
    (STAGE, TRAVEL, {"x_range_mm": [51, 147], "y_range_mm": [43, 95], "step_mm": 4}, None),
    (STAGE, TRAVEL, {"x_range_mm": [100, 160], "y_range_mm": [43, 95], "step_mm": 4},
     ("x = 160 mm", "stage's travel, 0 to 150 mm")),
    (STAGE, {"x": [-50, 150], "y": [0, 100]}, {"x_range_mm": [-20, 40], "y_range_mm": [43, 95], "step_mm": 4},
     ("-20 mm", "none is negative")),
    ({}, None, {"x_range_mm": [51, 147], "y_range_mm": [43, 95], "step_mm": 4}, ("a map needs an x-y stage",)),
    ({"stage": "ASRL1::INSTR"}, TRAVEL, {"x_range_mm": [51, 147], "y_range_mm": [43, 95], "step_mm": 4},
     ("stage and vibrometer have the same address",)),
    (STAGE, None, {"x_range_mm": [51, 147], "y_range_mm": [43, 95], "step_mm": 4},
     ("resources.stage and stage_travel_mm", "go together")),
    (STAGE, {"x": [150, 0], "y": [0, 100]}, {"x_range_mm": [51, 147], "y_range_mm": [43, 95], "step_mm": 4},
     ("stage_travel_mm.x", "low below high")),
])
def test_a_real_benchs_map_is_held_to_its_stage_by_validate_and_run_alike(tmp_path, capsys, resources, travel,
                                                                          grid, words):
    """On a real bench the travel is the bench file's (the controllers' SL/SR): a map beyond
    it, at negative positions, without a stage, with a stage at another's address or of
    unstated travel is refused by `validate` and by `run` in the same words, before the
    bench opens; a map within it passes `validate`."""
    campaign = _real_map(tmp_path, _bench_file(tmp_path, travel, **resources), grid)
    if words is None:
        assert cli.main(["validate", campaign, "-q"]) == 0
    else:
        _both_refuse(tmp_path, capsys, campaign, *words)


def test_a_stated_travel_beyond_the_controllers_limits_stops_the_map_and_fails_check():
    """`validate` trusts the bench file's travel; the stage, opened, says its own (SL/SR):
    more stated than the controllers allow is a BenchMismatch for a run and for `check`."""
    import dataclasses

    from squeezebench.instruments.bench import inspect_bench
    from squeezebench.instruments.errors import BenchMismatch

    config = dataclasses.replace(sim_bench_config(paths.scenes_dir() / "large_plate.yaml"),
                                 stage_travel_mm={"x": (0.0, 400.0), "y": (0.0, 200.0)})
    with open_bench(config) as bench:
        with pytest.raises(BenchMismatch, match="states the x travel 0 to 400 mm.*are 0 to 300 mm"):
            bench.stage
    found = inspect_bench(config, out=lambda line: None)
    assert not found.passed and any("stage_travel_mm" in problem for problem in found.disagreements)
    assert inspect_bench(dataclasses.replace(config, stage_travel_mm={"x": (0.0, 300.0), "y": (10.0, 150.0)}),
                         out=lambda line: None).passed   # a narrower travel stated is kept to, not refused


def test_the_stage_travel_stated_for_a_served_bench_is_the_simulated_stages():
    from squeezebench.instruments.served import served_bench_file
    from squeezebench.simbench.stage import TRAVEL_MM

    config = sim_bench_config(paths.scenes_dir() / "large_plate.yaml")
    written = served_bench_file({"bench": "TCPIP0::127.0.0.1::5000::SOCKET", **config.resources},
                                config.electronics, schemas.stage_travel_mm(config))
    assert written["stage_travel_mm"] == {"x": list(TRAVEL_MM["1"]), "y": list(TRAVEL_MM["2"])}


def _design(tmp_path, base=None, **changes) -> str:
    """The shipped large plate's design file (or the file `base`) with `changes`."""
    data = yaml.safe_load((base or paths.designs_dir() / "large_plate.yaml").read_text())
    data.update(changes)
    path = tmp_path / "design.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


@pytest.mark.parametrize("changes, words", [
    ({"groups": [{"name": "A", "x_mm": 3, "y_mm": [7, 21]}, {"name": "B", "x_mm": 3, "y_mm": [7, 21]}]},
     ("groups 'A' and 'B'", "overlap")),
    ({"name": "x" * 300}, ("at most 100 characters",)),
    ({"from_small_plates": {"template_plate": "small_plate_9"}},
     ("from_small_plates.template_plate", "'small_plate_9'", "known: ", "small_plate_4")),
    ({"from_small_plates": {"template_plate": "p" * 300}}, ("from_small_plates.template_plate", "300 characters")),
    ({"groups": [{"name": "g" * 300, "x_mm": 5, "y_mm": [7, 21]}]}, ("groups[0].name", "at most 100 characters")),
    ({"piezo": {"length_x_mm": 10, "width_y_mm": 14, "thickness_mm": 0.5}, "resonator": {"length_mm": 198,
      "width_mm": 2, "thickness_mm": 2}}, ("overhangs the plate", "0 to 2 mm")),
])
def test_design_files_refused_alike_by_validate_and_design(tmp_path, capsys, changes, words):
    design = _design(tmp_path, **changes)
    assert cli.main(["validate", design]) == cli.EXIT_USER_ERROR
    refused = _cause(capsys)
    assert all(word in refused for word in words), refused
    assert cli.main(["design", design, "--no-layouts", "--out", str(tmp_path / "out")]) == cli.EXIT_USER_ERROR
    assert _cause(capsys) == refused


def test_a_template_plate_the_runs_characterised_is_known(tmp_path):
    """`design --from` adds the runs' plates to the shipped ones: a plate of one's own."""
    design = _design(tmp_path, from_small_plates={"template_plate": "my_small_plate"})
    assert "my_small_plate" not in schemas.template_plates() and "large_plate" not in schemas.template_plates()
    with pytest.raises(UserError, match="'my_small_plate' is no plate"):
        schemas.load_design_file(design)
    assert schemas.load_design_file(design, characterised=["my_small_plate"]).from_small_plates.template_plate \
        == "my_small_plate"


def _scene(tmp_path, name: str = "scene", **changes) -> str:
    """one_column_1mm's scene with `changes` merged into its sections."""
    data = yaml.safe_load((paths.scenes_dir() / "one_column_1mm.yaml").read_text())
    for section, values in changes.items():
        data[section] = {**data[section], **values}
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


@pytest.mark.parametrize("changes, words", [
    ({"plate": {"width_mm": 2}}, ("actuators:", "column 'A'", "overhangs the plate", "0 to 2 mm")),
    ({"actuators": {"piezo": {"length_mm": 10, "width_mm": 5, "thickness_mm": 0.5, "material": "NCE 41"},
                    "piezos_per_column": 5}}, ("actuators:", "column 'A'", "10 mm", "overhangs", "0 to 41 mm")),
    ({"actuators": {"columns": [{"name": "A", "position_mm": 2.5}, {"name": "B", "position_mm": 75}]}},
     ("actuators:", "column 'B'", "overhangs the plate", "0 to 76")),
    ({"actuators": {"columns": [{"name": "A", "position_mm": 2.5}, {"name": "B", "position_mm": 5}]}},
     ("actuators:", "columns 'A' and 'B'", "overlap")),
    ({"measurement_point": {"x_mm": 38, "y_mm": 20500}}, ("measurement_point.y_mm", "off the plate", "41 mm")),
])
def test_piezos_or_the_spot_off_the_plate_are_refused_by_validate_and_run(tmp_path, capsys, changes, words):
    """The scene alone and a campaign on it: `validate` and `run` refuse with one line naming
    the scene and the field, before anything is measured."""
    scene = _scene(tmp_path, **changes)
    assert cli.main(["validate", scene]) == cli.EXIT_USER_ERROR
    refused = _cause(capsys)
    assert all(word in refused for word in (scene, *words)), refused
    data = yaml.safe_load(paths.campaign_file("quick.yaml").read_text())
    data["bench"] = {"scene": scene}
    campaign = tmp_path / "on_it.yaml"
    campaign.write_text(yaml.safe_dump(data))
    assert _both_refuse(tmp_path, capsys, str(campaign), "runs[0].bench.scene").endswith(refused)


@pytest.fixture(scope="module")
def simulated_stage():
    """The simulated bench's stage as a run's map meets it (travel read from the stage)."""
    bench = open_bench(sim_bench_config(paths.scenes_dir() / "large_plate.yaml"))
    try:
        yield bench.stage
    finally:
        bench.close()


_MM = st.floats(-50, 400, allow_nan=False).map(lambda v: round(v, 1))


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(x=st.tuples(_MM, _MM).map(sorted), y=st.tuples(_MM, _MM).map(sorted),
       step_mm=st.sampled_from([1e-6, 0.05, 0.5, 2.0, 7.5, 40.0, 600.0]), margin_mm=st.sampled_from([0.0, 2.0]))
def test_any_map_validate_accepts_the_run_accepts_point_by_point(tmp_path, capsys, simulated_stage, x, y,
                                                                 step_mm, margin_mm):
    """Accepted: every point passes the check the run makes before its first move (the
    stage's travel as the stage reports it). Refused: `run` refuses it, in the same words."""
    grid = {"x_range_mm": list(x), "y_range_mm": list(y), "step_mm": step_mm, "margin_mm": margin_mm}
    file = _campaign(tmp_path, grid)
    if cli.main(["validate", file, "-q"]) == 0:
        points = Grid((x[0], x[1]), (y[0], y[1]), step_mm, margin_mm).points_mm()
        assert 1 < len(points) <= 10_000
        for x_mm, y_mm in np.vstack([points, [Grid((x[0], x[1]), (y[0], y[1]), step_mm, margin_mm).centre_point_mm()]]):
            simulated_stage.check_reachable(x_mm, y_mm)
    else:
        refused = _cause(capsys)
        assert cli.main(["run", file, "--out", str(tmp_path / "never"), "-q"]) == cli.EXIT_USER_ERROR
        assert _cause(capsys) == refused


def _two_groups(tmp_path, dx_mm: float, dy_mm: float) -> tuple[str, bool]:
    """The design template (120 x 60 x 1.5 mm, the guide's plate: a third of the large
    plate's elements to solve where `validate` accepts) with group B placed (dx, dy) from
    group A at the plate's centre, and whether their piezos share area (|dx| < length and
    |dy| < width)."""
    template = paths.design_template()
    data = yaml.safe_load(template.read_text())
    length_mm, width_mm = data["piezo"]["length_x_mm"], data["piezo"]["width_y_mm"]
    x_mm, y_mm = data["resonator"]["length_mm"] / 2, data["resonator"]["width_mm"] / 2
    design = _design(tmp_path, base=template, groups=[{"name": "A", "x_mm": x_mm, "y_mm": [y_mm]},
                                                      {"name": "B", "x_mm": x_mm + dx_mm, "y_mm": [y_mm + dy_mm]}])
    return design, abs(dx_mm) < length_mm and abs(dy_mm) < width_mm


@settings(max_examples=25, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(dx_mm=st.floats(-12, 12).map(lambda v: round(v, 1)), dy_mm=st.floats(-16, 16).map(lambda v: round(v, 1)))
def test_two_groups_are_refused_exactly_when_their_piezos_overlap(tmp_path, dx_mm, dy_mm):
    """Refused by the design files' validator (the one `validate` and `design` both call),
    exactly when the two rectangles share area. Through the validator, not the command: an
    accepted file would go on to the plate's physics and its budget (about four
    solves of the plate per example); the command's own answers are the next test's."""
    design, overlap = _two_groups(tmp_path, dx_mm, dy_mm)
    if overlap:
        with pytest.raises(UserError, match="groups 'A' and 'B'"):
            schemas.load_design_file(design)
    else:
        schemas.load_design_file(design)


@pytest.mark.parametrize("dx_mm, dy_mm", [(5.9, 0.0), (6.0, 0.0), (0.0, 13.9)])
def test_validate_refuses_overlapping_groups_and_accepts_touching_ones(tmp_path, capsys, dx_mm, dy_mm):
    """`validate` at the rule's edges: 0.1 mm of overlap refused naming both groups, piezos
    that only touch accepted (the plate's physics solved for them)."""
    design, overlap = _two_groups(tmp_path, dx_mm, dy_mm)
    assert cli.main(["validate", design, "-q"]) == (cli.EXIT_USER_ERROR if overlap else 0)
    if overlap:
        assert "groups 'A' and 'B'" in _cause(capsys)
