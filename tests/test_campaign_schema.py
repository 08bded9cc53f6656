"""A malformed campaign is one CampaignError naming the file, the field and what is allowed."""

import pytest

from squeezebench.protocols.campaign import CampaignError, load_campaign
from squeezebench.errors import UserError
from squeezebench.yamlfiles import dump_yaml, load_strict

GOOD_RUN = {"name": "cut", "protocol": "resonator_cutting", "bench": {"scene": "one_column_1mm.yaml"},
            "plate": {"n_powered_columns": 1, "n_powered_piezos": 4},
            "parameters": {"search": {"start_hz": 36000, "stop_hz": 38500},
                           "lengths": [{"plate_length_mm": 75, "state": "75x41", "n_antinodes": 9}]}}


def campaign_file(tmp_path, **changes):
    data = {"name": "c", "runs": [GOOD_RUN]}
    data.update(changes)
    path = tmp_path / "c.yaml"
    path.write_text(dump_yaml(data))
    return path


def edited_run(**changes):
    run = load_strict(dump_yaml(GOOD_RUN))
    run.update(changes)
    return run


def test_the_good_campaign_loads(tmp_path):
    campaign = load_campaign(campaign_file(tmp_path))
    (run,) = campaign.runs
    assert run.plate.name == "one_column_1mm" and run.safety.max_piezo_voltage_vpp == 100
    assert [step.step_id for step in run.steps()] == ["length_75mm"]
    assert [p.name for p in run.input_files()] == ["one_column_1mm.yaml"]


@pytest.mark.parametrize("changes, field, allowed", [
    ({"runs": [edited_run(protocol="cuting")]}, "runs[0].protocol", "resonator_cutting"),
    ({"runs": [edited_run(bench={"scene": "nope.yaml"})]}, "runs[0].bench.scene", "one_column_1mm.yaml"),
    ({"runs": [edited_run(bench={"scene": "a.yaml", "file": "b.yaml"})]}, "runs[0].bench", "exactly one of"),
    ({"runs": [edited_run(safety={"max_piezo_voltage": 240})]}, "runs[0].safety.max_piezo_voltage",
     "max_piezo_voltage_vpp"),
    ({"runs": [edited_run(acquisition={"averages": 3})]}, "runs[0].acquisition", "power of two"),
    ({"runs": [edited_run(parameters={"search": {"start_hz": 36000, "stop_hz": 38500}})]},
     "runs[0].parameters.lengths", "missing"),
    ({"runs": [edited_run(parameters={**GOOD_RUN["parameters"], "piezo_voltage_vpp": "20 V"})]},
     "runs[0].parameters.piezo_voltage_vpp", "should be a valid number"),
    ({"runs": [edited_run(name="a b")]}, "runs[0].name", "letters, digits"),
    ({"runs": [GOOD_RUN, GOOD_RUN]}, "runs", "repeated: cut"),
    ({"runs": []}, "runs", "non-empty list"),
    ({"output": "x"}, "output", "output_dir"),
])
def test_errors_name_file_field_and_allowed_values(tmp_path, changes, field, allowed):
    path = campaign_file(tmp_path, **changes)
    with pytest.raises(CampaignError) as error:
        load_campaign(path)
    message = str(error.value)
    assert str(path) in message and f"field '{field}'" in message and allowed in message
    assert isinstance(error.value, UserError)


def test_not_yaml_and_missing_file(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("runs: [unclosed")
    with pytest.raises(CampaignError, match="not valid YAML"):
        load_campaign(bad)
    with pytest.raises(CampaignError, match="cannot be read"):
        load_campaign(tmp_path / "absent.yaml")


def test_shipped_campaigns_load():
    from squeezebench import paths

    for name in ("paper.yaml", "quick.yaml"):
        campaign = load_campaign(paths.campaigns_dir() / name)
        assert all(run.steps() for run in campaign.runs)


@pytest.mark.parametrize("changes, field, wrong", [
    ({"runs": [edited_run(acquisition={"averages": "16"})]}, "runs[0].acquisition.averages", "'16'"),
    ({"runs": [edited_run(acquisition={"averages": 16.0})]}, "runs[0].acquisition.averages", "16.0"),
    ({"runs": [edited_run(acquisition={"max_ranging_attempts": True})]},
     "runs[0].acquisition.max_ranging_attempts", "True"),
    ({"runs": [edited_run(parameters={**GOOD_RUN["parameters"], "search": {"start_hz": "36000",
                                                                          "stop_hz": 38500}})]},
     "runs[0].parameters.search.start_hz", "'36000'"),
    ({"runs": [edited_run(safety={"max_piezo_voltage_vpp": True})]}, "runs[0].safety.max_piezo_voltage_vpp", "True"),
])
def test_no_value_is_coerced_into_another_type(tmp_path, changes, field, wrong):
    """A string is not a number, a boolean not a count, 16.0 not an integer: each is
    refused where it stands, not turned into what the field wanted."""
    path = campaign_file(tmp_path, **changes)
    with pytest.raises(CampaignError) as error:
        load_campaign(path)
    assert f"field '{field}': {wrong}" in str(error.value)


def test_a_number_where_a_decimal_is_asked_and_a_list_for_a_sequence_are_fine(tmp_path):
    run = edited_run(parameters={**GOOD_RUN["parameters"], "search": {"start_hz": 36000, "stop_hz": 38500.5}})
    (loaded,) = load_campaign(campaign_file(tmp_path, runs=[run])).runs
    assert loaded.parameters.search.start_hz == 36000.0 and isinstance(loaded.parameters.lengths, tuple)
