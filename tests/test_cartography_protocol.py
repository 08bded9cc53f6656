"""The cartography protocol on the simulated bench: a small map of the large plate through
the campaign runner, against the mode the simulator was given; killed and resumed; a
point beyond travel refused before anything moves; the bench left safe."""

from __future__ import annotations

import random

import numpy as np
import pytest
from pyvisa.resources import MessageBasedResource

from squeezebench import schemas
from squeezebench.analysis.cartography import map_points, modal_assurance, summarise_map
from squeezebench.analysis.rundata import load_run
from squeezebench.paths import scenes_dir
from squeezebench.protocols.campaign import SettingRefused, run_campaign
from squeezebench.protocols.storage import read_measurements
from squeezebench.simbench.modeshape import mode_shape
from squeezebench.simbench.scene import load_scene
from test_campaign_resume import RAISED_AS, InjectedFault, WriteCounter, assert_same_rows
from test_protocols_support import write_campaign

LARGE_PLATE = {"n_powered_columns": 4, "n_powered_piezos": 8}


def map_campaign(tmp_path, grid=None):
    """The shipped large plate, with its noise and offsets, mapped coarsely: 11 x 3 points
    over about six half-wavelengths, two rows a step."""
    parameters = {"search": {"start_hz": 51500, "stop_hz": 53500, "points": 11, "tolerance_hz": 2.0},
                  "piezo_voltage_vpp": 20,
                  "grid": grid or {"x_range_mm": [70, 130], "y_range_mm": [49, 89], "step_mm": 6},
                  "rows_per_step": 2, "settle_s": 0.01}
    return write_campaign(tmp_path, [{"name": "map", "protocol": "cartography", "plate": LARGE_PLATE,
                                      "parameters": parameters}],
                          bench={"scene": str(scenes_dir() / "large_plate.yaml")})


def recording(monkeypatch) -> list[tuple[str, str]]:
    """Every message written from now on, as (resource name, message)."""
    sent = []
    original = MessageBasedResource.write

    def write(resource, message, *args, **kwargs):
        sent.append((resource.resource_name, message))
        return original(resource, message, *args, **kwargs)

    monkeypatch.setattr(MessageBasedResource, "write", write)
    return sent


@pytest.fixture(scope="module")
def mapped(tmp_path_factory):
    tmp_path = tmp_path_factory.mktemp("map")
    campaign = map_campaign(tmp_path)
    with pytest.MonkeyPatch.context() as monkeypatch:
        sent = recording(monkeypatch)
        run_dir = run_campaign(campaign, out_dir=tmp_path / "run", progress=False, say=lambda m: None)
    return campaign, run_dir, sent


def test_the_map_shows_the_mode_the_plate_was_given(mapped):
    _, run_dir, _ = mapped
    points = map_points(load_run(run_dir))
    assert len(points) == 11 * 7
    scene = load_scene(scenes_dir() / "large_plate.yaml")
    given = mode_shape(scene, scene.state("large"), points["x_m"] * 1e3, points["y_m"] * 1e3)
    assert modal_assurance(points["signed_velocity_pp_mps"].to_numpy(), given) >= 0.95
    # the sign (phase against the drive) follows the mode's: nodal lines where physics puts them
    assert np.mean(np.sign(points["signed_velocity_pp_mps"]) == np.sign(given)) >= 0.95
    summary = summarise_map(points, given)
    assert summary["n_nodal_lines"] >= 5
    assert 0 < summary["coefficient_of_variation_U"] < summary["coefficient_of_variation"]


def test_a_finished_map_leaves_the_drive_at_minimum_then_the_spot_on_the_centre(mapped):
    """Fig. 8 is measured at the centre of the mapped plate: the map's last move returns
    there (the grid point nearest its centre, 100, 67 mm), after the drive is at its minimum."""
    _, _, sent = mapped
    stage = [(i, message) for i, (resource, message) in enumerate(sent) if resource.startswith("ASRL2")]
    last_x = [i for i, message in stage if message.startswith("1PA")][-1]
    assert sent[last_x][1] == "1PA100" and [m for _, m in stage if m.startswith("2PA")][-1] == "2PA67"
    amplitudes = [(i, message) for i, (resource, message) in enumerate(sent)
                  if resource.startswith("GPIB") and message.startswith("VOLT ")]
    minimum = amplitudes[-1][1]                     # the runner's own last word is the minimum
    before = [message for i, message in amplitudes if i < last_x]
    assert before[-1] == minimum
    assert any(message != minimum for message in before)   # it did drive the plate


def test_a_stopped_map_brings_the_drive_down_then_parks(tmp_path, monkeypatch):
    campaign = map_campaign(tmp_path)
    sent = []
    original = MessageBasedResource.write

    def write(resource, message, *args, **kwargs):
        sent.append((resource.resource_name, message))
        if message.startswith("1PA") and ("stop", "") not in sent \
                and sum(m.startswith("1PA") for _, m in sent) == 12:   # Ctrl-C once, mid-map
            sent.append(("stop", ""))
            raise KeyboardInterrupt
        return original(resource, message, *args, **kwargs)

    monkeypatch.setattr(MessageBasedResource, "write", write)
    with pytest.raises(KeyboardInterrupt):
        run_campaign(campaign, out_dir=tmp_path / "run", progress=False, say=lambda m: None)
    after = sent[sent.index(("stop", "")) + 1:]
    generator = [i for i, (resource, message) in enumerate(after) if resource.startswith("GPIB") and message.startswith("VOLT ")]
    parks = [i for i, (resource, message) in enumerate(after) if message in ("1PA0", "2PA0")]
    assert generator and parks and generator[0] < parks[0]


def test_a_point_beyond_travel_is_refused_before_the_stage_moves(tmp_path, monkeypatch):
    campaign = map_campaign(tmp_path, grid={"x_range_mm": [250, 320], "y_range_mm": [49, 60], "step_mm": 10})
    # As on a real bench, whose stage's travel is known only once the run reads it (the
    # simulated stage's is checked as the campaign loads: test_file_bounds).
    monkeypatch.setattr(schemas, "stage_travel_mm", lambda config: None)
    sent = recording(monkeypatch)
    with pytest.raises(SettingRefused, match=r"stage point \(x = 310\.000 mm, y = 49\.000 mm\): 310\.0 is not allowed"):
        run_campaign(campaign, out_dir=tmp_path / "run", progress=False, say=lambda m: None)
    assert not any("PA" in message for resource, message in sent if resource.startswith("ASRL2"))


def test_a_map_killed_anywhere_and_resumed_stores_the_rows_of_an_uninterrupted_one(mapped, tmp_path, monkeypatch):
    campaign, run_dir, sent = mapped
    expected = read_measurements(run_dir)
    rng = random.Random(7)
    for trial in range(3):
        out = tmp_path / f"trial{trial}"
        fault = rng.choice([InjectedFault, KeyboardInterrupt, ConnectionResetError])
        with monkeypatch.context() as patch:
            WriteCounter(patch, fail_at=rng.randrange(len(sent) // 4, len(sent)), fault=fault)
            with pytest.raises(RAISED_AS.get(fault, fault)):
                run_campaign(campaign, out_dir=out, progress=False, say=lambda m: None)
        run_campaign(campaign, resume=True, out_dir=out, progress=False, say=lambda m: None)
        assert_same_rows(read_measurements(out), expected)


@pytest.fixture(scope="module")
def section(mapped, tmp_path_factory):
    """(context, body) of the map's report section as a report without drawing processes
    writes it, from this session's own solve of the plate: what the section's test reads,
    and what a section reading a solve another process left in the disk cache must say."""
    from squeezebench.report.cartography_report import cartography_section
    from squeezebench.report.section import ReportContext

    _, run_dir, _ = mapped
    context = ReportContext(run=load_run(run_dir), out_dir=tmp_path_factory.mktemp("section"))
    return context, cartography_section(context).body_html


def test_the_maps_report_section_draws_it_and_describes_every_column(section):
    from squeezebench.analysis import columns

    context, body = section
    run = context.run
    summary, points = context.tables["map_summary"], context.tables["map_points"]
    assert (context.out_dir / "map_map.png").stat().st_size > 10_000
    assert "modal assurance criterion is 1.00" in body or "modal assurance criterion is 0.99" in body
    assert summary.loc[0, "mean_velocity_pp_mps_U"] > 2 * summary.loc[0, "mean_velocity_pp_mps"] * 0.01
    described = columns.dictionary([run.measurements, summary, points])
    assert not (described["meaning"] == "not described").any(), described[described["meaning"] == "not described"]


def test_the_maps_plate_solved_ahead_on_a_drawing_process_is_read_not_solved_again(mapped, section, tmp_path,
                                                                                    monkeypatch):
    """`solve_ahead` hands the mapped plate's solve to a drawing process, which leaves it in
    the disk cache; the section then reads it (this process never solves an eigenproblem)
    and says what it says from this session's own solve of the plate (the map's run solved
    it: solving it again here would only repeat that)."""
    from squeezebench.disk_cache import CACHE_VARIABLE
    from squeezebench.plates import plate_modes
    from squeezebench.report import drawing
    from squeezebench.report.cartography_report import cartography_section, solve_ahead
    from squeezebench.report.section import ReportContext

    _, run_dir, _ = mapped
    _, solved_here = section
    monkeypatch.setenv(CACHE_VARIABLE, str(tmp_path / "cache"))
    drawing._executor(1, fresh=True)   # drawing processes that see this cache
    plate_modes._CACHE.clear()
    monkeypatch.setattr(plate_modes, "_eigenpairs", lambda *a, **k: pytest.fail("solved again in this process"))
    context = ReportContext(run=load_run(run_dir), out_dir=tmp_path, draw=drawing.Drawing(2))
    solve_ahead(context)
    assert cartography_section(context).body_html == solved_here
    context.draw.finish()
    monkeypatch.undo()
    drawing._executor(1, fresh=True)   # later reports' processes see their own cache again


def test_a_stored_maps_plate_solved_during_the_campaign_is_the_solve_the_report_reads(mapped, section, tmp_path,
                                                                                     monkeypatch):
    """`reproduce` solves a map run's plate from its stored rows once the run ends
    (`solve_stored_map`, on the drawing process); the report's map section then reads that
    solve (no eigenproblem solved again) and says the same as from its own. What is tested
    is where the solve goes: its eigenpairs are the ones this session's solve of the plate
    stored (the same key), not a second 8 CPU-s eigenproblem of the same plate."""
    from squeezebench.disk_cache import CACHE_VARIABLE
    from squeezebench.plates import plate_modes
    from squeezebench.plates.predicted_plates import known_plate_modes
    from squeezebench.report.cartography_report import cartography_section, solve_stored_map
    from squeezebench.report.section import ReportContext

    _, run_dir, _ = mapped
    run = load_run(run_dir)
    context, solved_here = section
    summary = context.tables["map_summary"].iloc[0]
    kept = plate_modes.stored_solves().read(known_plate_modes(summary["plate"],
                                                              summary["drive_frequency_hz"]).stored_key)
    solve, solves = plate_modes._eigenpairs, []
    monkeypatch.setattr(plate_modes, "_eigenpairs",
                        lambda *a, **k: solves.append(a) or (solve(*a, **k) if kept is None else kept))
    monkeypatch.setenv(CACHE_VARIABLE, str(tmp_path / "cache"))
    plate_modes._CACHE.clear()
    solve_stored_map(run_dir, run.protocol("cartography")["run_name"].iloc[0])
    assert len(solves) == 1   # solved here, once, into the new cache
    assert len(list((tmp_path / "cache" / "plates").glob("*.npz"))) == 1
    plate_modes._CACHE.clear()
    monkeypatch.setattr(plate_modes, "_eigenpairs", lambda *a, **k: pytest.fail("solved again"))
    assert cartography_section(ReportContext(run=load_run(run_dir), out_dir=tmp_path)).body_html == solved_here


def test_reproduce_hands_a_map_runs_solve_out_once_its_last_step_is_stored(tmp_path, monkeypatch):
    """The paper campaign's map run is handed out when the next run's first step is stored,
    once, and after the campaign when it was the last run."""
    from squeezebench.commands import _StoredMapsAhead
    from squeezebench.report import drawing

    handed = []
    monkeypatch.setattr(drawing, "beside", lambda workers, work: handed.append(work.args) or None)
    maps = _StoredMapsAhead(tmp_path, 2)
    for run in ("fig5_small_plates", "fig7_large_plate_map", "fig7_large_plate_map"):
        maps.step({"run": run})
    assert handed == []
    maps.step({"run": "fig8_9_large_plate"})
    maps.step({"run": "fig8_9_large_plate"})
    assert handed == [(tmp_path, "fig7_large_plate_map")]
    last = _StoredMapsAhead(tmp_path, 2)
    last.step({"run": "fig7_large_plate_map"})
    last.step({})
    assert handed[1:] == [(tmp_path, "fig7_large_plate_map")] and last.handed == [None]
