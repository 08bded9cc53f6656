"""The Python API and its worked notebook (docs/notebook_example.ipynb), executed."""

import json
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

import squeezebench  # noqa: E402
from squeezebench import api  # noqa: E402
from squeezebench.errors import UserError  # noqa: E402

NOTEBOOK = Path(__file__).resolve().parents[1] / "docs" / "notebook_example.ipynb"


@pytest.fixture(scope="module")
def notebook(tmp_path_factory):
    """The notebook's namespace after running its code cells in order in a fresh directory,
    as a kernel would (one namespace; the cells hold no magics)."""
    cells = json.loads(NOTEBOOK.read_text())["cells"]
    namespace: dict = {"__name__": "__main__"}
    where = tmp_path_factory.mktemp("notebook")
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(where)
        for number, cell in enumerate(cells):
            if cell["cell_type"] == "code":
                exec(compile("".join(cell["source"]), f"{NOTEBOOK.name} cell {number}", "exec"), namespace)
    assert sum(cell["cell_type"] == "code" for cell in cells) == 4
    return namespace, where


def test_the_example_finds_the_resonance_inside_its_search(notebook):
    namespace, _ = notebook
    sweep, row = namespace["sweep"], namespace["at_resonance"]
    assert len(sweep) >= 26 and sweep["sweep"].all()
    assert 36000 < row.resonance_frequency_hz < 38500
    assert row.velocity_pp_mps == pytest.approx(sweep["velocity_pp_mps"].max(), rel=0.05)
    assert namespace["plot"].points_seen == len(namespace["points"])


def test_the_example_characterises_velocity_linear_and_power_quadratic(notebook):
    namespace, _ = notebook
    table = namespace["table"]
    assert list(table.piezo_voltage_setpoint_vpp) == [20, 40, 60]
    assert namespace["velocity_per_volt"] > 0
    assert namespace["power_exponent"] == pytest.approx(2.0, abs=0.15)


def test_run_data_as_frames_and_the_report(notebook):
    namespace, where = notebook
    waveforms, settings = namespace["waveforms"], namespace["settings"]
    assert {"run_name", "step_id", "point_index", "time_s", "piezo_voltage_v", "current_a",
            "vibrometer_output_v"} <= set(waveforms.columns)
    assert waveforms.groupby("point_index").size().eq(500).all()   # FAST's record length
    assert settings.loc[0, "acquisition.averages"] == 4   # one row per run, one typed column per setting
    assert settings["acquisition.averages"].dtype == "int64" and settings["run_name"].tolist() == ["characterisation"]
    report = where / "runs/notebook/characterisation/report"
    assert (report / "index.html").is_file() and (report / "scenes.csv").is_file()   # as the CLI's


def test_uncertainties_and_tables_as_frames(notebook):
    namespace, where = notebook
    run = api.load_run(where / "runs/notebook/characterisation")
    budgets = run.uncertainties()
    assert len(budgets) == run.points()["waveform_file"].notna().sum() > 0 and (budgets["power_w_U"] > 0).all()
    assert (budgets["power_w_U"] / budgets["power_w"]).median() < 0.2
    tables = run.tables()
    assert {"fig5", "table3"} <= set(tables)
    assert tables["table3"]["value"].dtype == float   # the run has no Table 3: NaN, not words
    assert set(tables["table3"]["status"]) == {"not measured"}


def test_resume_of_an_api_run_uses_the_same_campaign(notebook):
    _, where = notebook
    namespace, _ = notebook
    again = api.resonance_search(where / "runs/notebook/search", plate=namespace["PLATE"],
                                 search=namespace["SEARCH"], scene="one_column_1mm.yaml",
                                 acquisition=namespace["FAST"], resume=True)
    assert len(again.points()) == len(namespace["points"])


def test_open_bench_talks_to_the_instruments():
    with api.open_bench(scene="one_column_1mm.yaml") as bench:
        assert "33120A" in bench.identify()["generator"]
    with pytest.raises(UserError, match="exactly one of"):
        api.open_bench()


def test_the_package_root_offers_the_api():
    assert squeezebench.resonance_search is api.resonance_search
    assert squeezebench.load_run is api.load_run
    with pytest.raises(AttributeError):
        squeezebench.no_such_name


def test_a_paper_table_in_the_shape_pandas_users_expect(tmp_path):
    """One row per plate, named for what it is; one column per quantity with its unit in the
    name, its U and the printed value beside it; snake_case; a round trip is a status."""
    run = api.run_campaign("quick", tmp_path / "quick")
    wide = api.table3(run, wide=True)
    assert wide.columns[0] == "plate_length_mm" and wide["plate_length_mm"].dtype == float
    for quantity in ("frequency_hz", "power_w", "velocity_pp_mps"):
        assert {quantity, f"{quantity}_expanded_u", f"paper_{quantity}", f"{quantity}_status"} <= set(wide.columns)
        assert wide[quantity].dtype == float
    assert all(column == column.lower() for column in wide.columns)
    tidy = run.table3()
    measured = tidy[tidy["status"] != "not measured"]
    assert len(wide) == tidy["item"].nunique() and len(measured)
    assert set(measured["status"]) <= {"round_trip", "measured"} and measured.loc[
        measured["status"] == "round_trip", "agrees"].isna().all()


def test_each_setting_takes_one_type_and_a_flag_some_runs_lack_stays_a_flag(tmp_path):
    (tmp_path / "settings").mkdir()
    (tmp_path / "settings" / "sweep.json").write_text(json.dumps(
        {"acquisition": {"averages": 16}, "safety": {"interlock": True}, "voltages_vpp": [10.0, 20.0], "mode": "slow"}))
    (tmp_path / "settings" / "map.json").write_text(json.dumps(
        {"acquisition": {"averages": 4}, "voltages_vpp": [5.0], "mode": "fast"}))
    settings = api.load_run(tmp_path).settings()
    assert settings["run_name"].tolist() == ["map", "sweep"]   # in file-name order
    assert settings["acquisition.averages"].dtype == "int64"
    assert settings["safety.interlock"].dtype == "boolean" and settings["safety.interlock"].isna().sum() == 1
    assert settings["voltages_vpp"].tolist() == [[5.0], [10.0, 20.0]]
    assert settings["mode"].tolist() == ["fast", "slow"]
