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

from squeezebench import cli, paths
from squeezebench.errors import UserError
from squeezebench.instruments.bench import open_bench, sim_bench_config
from squeezebench.protocols.cartography import Grid
from squeezebench.schemas import load_design_file


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


def _bench_file(tmp_path, **resources) -> str:
    data = yaml.safe_load((paths.benches_dir() / "lab_example.yaml").read_text())
    data["resources"].update(resources)
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
    assert cli.main(["validate", _bench_file(tmp_path, stage="TCPIP0::192.168.0.40::4001::SOCKET")]) == 0


def _design(tmp_path, **changes) -> str:
    data = yaml.safe_load((paths.designs_dir() / "large_plate.yaml").read_text())
    data.update(changes)
    path = tmp_path / "design.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


@pytest.mark.parametrize("changes, words", [
    ({"groups": [{"name": "A", "x_mm": 3, "y_mm": [7, 21]}, {"name": "B", "x_mm": 3, "y_mm": [7, 21]}]},
     ("groups 'A' and 'B'", "overlap")),
    ({"name": "x" * 300}, ("at most 100 characters",)),
])
def test_design_files_refused_alike_by_validate_and_design(tmp_path, capsys, changes, words):
    design = _design(tmp_path, **changes)
    assert cli.main(["validate", design]) == cli.EXIT_USER_ERROR
    refused = _cause(capsys)
    assert all(word in refused for word in words), refused
    assert cli.main(["design", design, "--no-layouts", "--out", str(tmp_path / "out")]) == cli.EXIT_USER_ERROR
    assert _cause(capsys) == refused


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
    """A design with group B placed (dx, dy) from group A, and whether their piezos share
    area (|dx| < length and |dy| < width)."""
    data = yaml.safe_load((paths.designs_dir() / "large_plate.yaml").read_text())
    length_mm, width_mm = data["piezo"]["length_x_mm"], data["piezo"]["width_y_mm"]
    x_mm, y_mm = 60.0, 60.0
    design = _design(tmp_path, groups=[{"name": "A", "x_mm": x_mm, "y_mm": [y_mm]},
                                       {"name": "B", "x_mm": x_mm + dx_mm, "y_mm": [y_mm + dy_mm]}])
    return design, abs(dx_mm) < length_mm and abs(dy_mm) < width_mm


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(dx_mm=st.floats(-12, 12).map(lambda v: round(v, 1)), dy_mm=st.floats(-16, 16).map(lambda v: round(v, 1)))
def test_two_groups_are_refused_exactly_when_their_piezos_overlap(tmp_path, dx_mm, dy_mm):
    """Refused by the design files' validator (the one `validate` and `design` both call),
    exactly when the two rectangles share area. Through the validator, not the command: an
    accepted file would go on to the large plate's physics and its budget (about five
    solves of the large plate per example); the command's own answers are the next test's."""
    design, overlap = _two_groups(tmp_path, dx_mm, dy_mm)
    if overlap:
        with pytest.raises(UserError, match="groups 'A' and 'B'"):
            load_design_file(design)
    else:
        load_design_file(design)


@pytest.mark.parametrize("dx_mm, dy_mm", [(5.9, 0.0), (6.0, 0.0), (0.0, 13.9)])
def test_validate_refuses_overlapping_groups_and_accepts_touching_ones(tmp_path, capsys, dx_mm, dy_mm):
    """`validate` at the rule's edges: 0.1 mm of overlap refused naming both groups, piezos
    that only touch accepted (the large plate's physics solved for them)."""
    design, overlap = _two_groups(tmp_path, dx_mm, dy_mm)
    assert cli.main(["validate", design, "-q"]) == (cli.EXIT_USER_ERROR if overlap else 0)
    if overlap:
        assert "groups 'A' and 'B'" in _cause(capsys)
