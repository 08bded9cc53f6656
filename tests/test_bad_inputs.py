"""The stress test's bad-input set: each is one line naming the file, the field or cause,
exit status 2, from `squeezebench validate` and from `squeezebench run`, and nothing is
created or changed on disk (no run directory). Also: the JSON Schemas in docs/schemas/
are the models' current ones.
"""

from __future__ import annotations

import json

import pytest

from squeezebench import cli, paths, schemas
from squeezebench.instruments.agilent33120a import Agilent33120A
from squeezebench.instruments.errors import OutOfRangeError
from squeezebench.yamlfiles import dump_yaml
from test_protocols_support import FAST_ACQUISITION, ONE_COLUMN_PLATE

SEARCH = {"start_hz": 36000, "stop_hz": 38500, "points": 11, "tolerance_hz": 1.0}
CUT = {"name": "cut", "protocol": "resonator_cutting", "plate": ONE_COLUMN_PLATE,
       "parameters": {"search": SEARCH, "piezo_voltage_vpp": 20,
                      "lengths": [{"plate_length_mm": 75, "state": "75x41", "n_antinodes": 9}]}}
GOOD = {"name": "bad", "bench": {"scene": "one_column_1mm.yaml"}, "acquisition": FAST_ACQUISITION, "runs": [CUT]}
BENCH = ("visa_library: '@py'\nresources: {generator: 'GPIB0::10::INSTR', scope: '%s', "
         "vibrometer: 'ASRL1::INSTR'}\nelectronics: {generator_load: %s}\n")


def campaign_text(**changes) -> str:
    return dump_yaml({**GOOD, **changes})


def with_params(**parameters) -> list:
    return [{**CUT, "parameters": {**CUT["parameters"], **parameters}}]


#: On a real bench a plate needs its name (there is no scene to name it).
NAMED_PLATE = [{**CUT, "plate": {**ONE_COLUMN_PLATE, "name": "plate_1"}}]
#: (file text or bytes, words the one line must hold)
CAMPAIGNS = {
    "non_utf8": (b"name: caf\xe9\nruns: []\n", ["not UTF-8", "0xe9"]),
    "acquisition_list": (campaign_text(acquisition=[1, 2]), ["field 'acquisition'", "must be a mapping", "averages"]),
    "output_dir_number": (campaign_text(output_dir=123), ["field 'output_dir'", "valid string"]),
    "duplicate_key": (campaign_text(safety={"max_piezo_voltage_vpp": 100}).replace(
        "  max_piezo_voltage_vpp: 100\n", "  max_piezo_voltage_vpp: 100\n  max_piezo_voltage_vpp: 240\n"),
        ["max_piezo_voltage_vpp", "given twice"]),
    "inf_limit": (campaign_text().replace("runs:", "safety: {max_piezo_voltage_vpp: .inf}\nruns:"), [".inf", "finite"]),
    "nan_dwell": (campaign_text().replace("runs:", "safety: {ramp_dwell_s: .nan}\nruns:"), [".nan", "finite"]),
    "unbounded_points": (campaign_text(runs=with_params(search={**SEARCH, "points": 10**7})),
                         ["field 'runs[0].parameters.search.points'", "2001"]),
    "tiny_ramp_step": (campaign_text(safety={"ramp_step_vpp": 1e-4}), ["field 'runs[0].safety.ramp_step_vpp'", "0.1 Vpp"]),
    "voltage_above_limit": (campaign_text(runs=with_params(piezo_voltage_vpp=150)),
                            ["field 'runs[0].parameters.piezo_voltage_vpp'", "150 Vpp", "limit", "100 Vpp"]),
    "negative_voltage": (campaign_text(runs=with_params(piezo_voltage_vpp=-5)),
                         ["field 'runs[0].parameters.piezo_voltage_vpp'", "-5", "positive"]),
    "frequency_out_of_range": (campaign_text(runs=with_params(search={**SEARCH, "stop_hz": 2e7})),
                               ["field 'runs[0].parameters.search.stop_hz'", "generator's range"]),
    "unknown_protocol": (campaign_text(runs=[{**CUT, "protocol": "cuting"}]),
                         ["field 'runs[0].protocol'", "'cuting'", "resonator_cutting"]),
    "unknown_scene": (campaign_text(bench={"scene": "nope.yaml"}), ["field 'runs[0].bench.scene'", "one_column_1mm.yaml"]),
    "bad_visa_address": (campaign_text(bench={"file": "lab.yaml"}, runs=NAMED_PLATE), ["lab.yaml", "resources.scope", "VISA resource"]),
    "bench_load_75": (campaign_text(bench={"file": "lab75.yaml"}, runs=NAMED_PLATE), ["lab75.yaml", "generator_load", "50, INF"]),
    "not_a_mapping": ("- a\n- list\n", ["top level", "campaign"]),
    "name_dot": (campaign_text(name="."), ["field 'name'", "'.'", "names files"]),
    "name_dotdot": (campaign_text(name=".."), ["field 'name'", "'..'", "names files"]),
    "name_300_chars": (campaign_text(name="n" * 300), ["field 'name'", "300 characters", "at most 100"]),
    "run_name_dotdot": (campaign_text(runs=[{**CUT, "name": ".."}]), ["field 'runs[0].name'", "'..'"]),
    "plate_name_dotdot": (campaign_text(runs=[{**CUT, "plate": {**ONE_COLUMN_PLATE, "name": ".."}}]),
                          ["runs[0]", "'..'", "names files"]),
    "limit_1e9": (campaign_text(safety={"max_piezo_voltage_vpp": 1e9}),
                  ["field 'runs[0].safety.max_piezo_voltage_vpp'", "amplifier's maximum output"]),
    "ramp_397": (campaign_text(safety={"ramp_step_vpp": 397}), ["field 'runs[0].safety.ramp_step_vpp'", "no ramp"]),
    "no_lengths": (campaign_text(runs=with_params(lengths=[])), ["field 'runs[0]'", "no step"]),
    "periods_1e9": (campaign_text(acquisition={**FAST_ACQUISITION, "periods_per_record": 1e9}),
                    ["periods_per_record", "longest record"]),
    "scene_duplicate_key": (campaign_text(bench={"scene": "twice.yaml"}), ["twice.yaml", "amplifier_gain", "given twice"]),
    "bench_duplicate_key": (campaign_text(bench={"file": "twice_bench.yaml"}, runs=NAMED_PLATE),
                            ["twice_bench.yaml", "generator_load", "given twice"]),
}


@pytest.fixture
def files(tmp_path):
    (tmp_path / "lab.yaml").write_text(BENCH % ("192.168.0.20", "INF"))
    (tmp_path / "lab75.yaml").write_text(BENCH % ("TCPIP0::192.168.0.20::INSTR", "75"))
    (tmp_path / "twice_bench.yaml").write_text((BENCH % ("TCPIP0::192.168.0.20::INSTR", "INF")).replace(
        "electronics: {generator_load: INF}", "electronics:\n  generator_load: INF\n  generator_load: '50'"))
    scene = paths.default_scene().with_name("one_column_1mm.yaml")
    text = scene.read_text()
    (tmp_path / "twice.yaml").write_text(text.replace("amplifier_gain:", "amplifier_gain: 20\n  amplifier_gain:", 1))
    return tmp_path


def write(folder, name, content):
    path = folder / f"{name}.yaml"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    return path


def one_line(capsys) -> str:
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.mark.parametrize("case", sorted(CAMPAIGNS))
def test_validate_and_run_refuse_with_one_line_and_store_nothing(files, capsys, case):
    content, words = CAMPAIGNS[case]
    path = write(files, case, content)
    before = sorted(p.name for p in files.iterdir())
    assert cli.main(["validate", str(path)]) == cli.EXIT_USER_ERROR
    line = one_line(capsys)
    for word in [path.name, *words]:
        assert word in line, (word, line)
    assert cli.main(["run", str(path), "--out", str(files / "run")]) == cli.EXIT_USER_ERROR
    assert path.name in one_line(capsys)
    assert sorted(p.name for p in files.iterdir()) == before   # no run directory, nothing else


def test_validate_reports_each_file_and_json(files, capsys, tmp_path):
    good = write(files, "good", campaign_text())
    bad = write(files, "bad", campaign_text(output_dir=123))
    assert cli.main(["validate", str(good), str(files / "lab75.yaml"), str(bad), "--json"]) == cli.EXIT_USER_ERROR
    document = json.loads(capsys.readouterr().out)
    results = document["files"]
    assert document["command"] == "validate" and document["passed"] is False
    assert [r["ok"] for r in results] == [True, False, False]
    assert results[0]["kind"] == "campaign" and "one_column_1mm.yaml" in results[0]["summary"]
    assert "output_dir" in results[2]["error"]


def test_validate_warns_of_a_doubling_bench(files, capsys):
    bench = files / "doubling.yaml"
    bench.write_text(BENCH % ("TCPIP0::192.168.0.20::INSTR", "50"))
    assert cli.main(["validate", str(bench)]) == 0
    assert "twice its displayed Vpp" in capsys.readouterr().err


def test_unwritable_output_is_one_message(files, capsys):
    path = write(files, "good", campaign_text())
    blocker = files / "a_file"
    blocker.write_text("not a folder\n")
    assert cli.main(["run", str(path), "--out", str(blocker / "run")]) == cli.EXIT_USER_ERROR
    assert "cannot be written" in one_line(capsys)
    assert blocker.read_text() == "not a folder\n"


def test_out_of_range_setting_mid_run_is_one_message(files, capsys, monkeypatch):
    path = write(files, "good", campaign_text())
    calls = {"n": 0}
    original = Agilent33120A.set_frequency

    def refusing(self, frequency_hz):
        calls["n"] += 1
        if calls["n"] == 5:
            raise OutOfRangeError("frequency_hz", 2e7, "100 µHz to 15 MHz")
        return original(self, frequency_hz)

    monkeypatch.setattr(Agilent33120A, "set_frequency", refusing)
    assert cli.main(["run", str(path), "--out", str(files / "run")]) == cli.EXIT_USER_ERROR
    line = one_line(capsys)
    assert "frequency_hz" in line and "run cut" in line


def test_json_schemas_are_current():
    for name, schema in schemas.json_schemas().items():
        stored = (schemas.SCHEMAS_DIR / name).read_text(encoding="utf-8")
        assert stored == schemas.schema_text(schema), f"run 'python -m squeezebench.schemas' to update {name}"


def test_shipped_files_validate(capsys):
    from squeezebench import paths

    files = [*paths.campaigns_dir().glob("*.yaml"), *(paths.data_dir() / "benches").glob("*.yaml")]
    assert cli.main(["validate", *map(str, files)]) == 0
    assert capsys.readouterr().out.count(": valid ") == len(files)


def test_output_made_read_only_mid_run_is_one_message_and_loses_nothing(files, capsys, monkeypatch):
    """The folder refuses writes after the first step is stored (as chmod a-w would, which
    root ignores, so the refusal is injected): one line, exit 2, the stored step intact
    and the run completes on resume."""
    import os

    from squeezebench.protocols.storage import RunStore

    path = write(files, "good", campaign_text(runs=with_params(lengths=[
        {"plate_length_mm": 75, "state": "75x41", "n_antinodes": 9},
        {"plate_length_mm": 59, "state": "59x41", "n_antinodes": 7}])))
    run_dir = files / "run"
    original = os.replace

    def read_only_after_first_step(source, target, *args, **kwargs):
        if (run_dir / "journal.jsonl").exists() and (run_dir / "journal.jsonl").stat().st_size > 0:
            raise PermissionError(13, "Permission denied", str(target))
        return original(source, target, *args, **kwargs)

    monkeypatch.setattr(os, "replace", read_only_after_first_step)
    assert cli.main(["run", str(path), "--out", str(run_dir), "-q"]) == cli.EXIT_USER_ERROR
    line = one_line(capsys)
    assert "cannot be written" in line and "Permission denied" in line and "--resume" in line
    monkeypatch.undo()
    store = RunStore(run_dir)
    assert len(store.journal()) >= 1 and store.verify() == []
    assert not list(files.glob("*.parquet")) and not (files / "measurements").exists()   # nothing outside
    assert cli.main(["run", str(path), "--out", str(run_dir), "--resume", "-q"]) == 0
    assert len(store.journal()) == 2


def test_a_folder_that_cannot_be_written_stops_the_run_before_the_bench_opens(files, capsys, monkeypatch):
    from pathlib import Path

    from pyvisa.resources import MessageBasedResource

    path = write(files, "good", campaign_text())
    original = Path.write_bytes
    sent = []

    def refusing(self, data):
        if self.name == ".squeezebench.probe" and "waveforms" in self.parts:
            raise PermissionError(13, "Permission denied", str(self))
        return original(self, data)

    monkeypatch.setattr(Path, "write_bytes", refusing)
    monkeypatch.setattr(MessageBasedResource, "write", lambda *args, **kwargs: sent.append(args))
    assert cli.main(["run", str(path), "--out", str(files / "run"), "-q"]) == cli.EXIT_USER_ERROR
    line = one_line(capsys)
    assert "waveforms" in line and "cannot be written" in line
    assert sent == []   # not one message to an instrument


def test_check_reads_the_bench_file_through_runs_validator(files, capsys):
    """A scope 'address' that is not a VISA address: one line naming it (was an
    AttributeError from the driver layer)."""
    assert cli.main(["check", "--bench", str(files / "lab.yaml")]) == cli.EXIT_USER_ERROR
    line = one_line(capsys)
    assert "lab.yaml" in line and "resources.scope" in line and "VISA resource" in line
    assert cli.main(["check", "--bench", str(files / "twice_bench.yaml")]) == cli.EXIT_USER_ERROR
    assert "given twice" in one_line(capsys)


def test_plan_refuses_an_infinite_target_and_an_unwritable_output_before_planning(files, capsys, monkeypatch):
    from squeezebench.protocols import planning

    def no_planning(*args, **kwargs):
        raise AssertionError("planned before refusing")

    monkeypatch.setattr(planning, "plan_campaign", no_planning)
    monkeypatch.setattr(planning, "make_plan", no_planning)
    with pytest.raises(SystemExit) as refused:
        cli.main(["plan", "quick.yaml", "--target-rel-error", "inf"])
    assert refused.value.code == cli.EXIT_USER_ERROR and "--target-rel-error" in capsys.readouterr().err
    blocker = files / "a_file"
    blocker.write_text("not a folder\n")
    assert cli.main(["plan", "quick.yaml", "--write", str(blocker / "planned.yaml")]) == cli.EXIT_USER_ERROR
    assert "cannot be written" in one_line(capsys)
    assert blocker.read_text() == "not a folder\n"


def test_validate_and_run_refuse_more_powered_columns_than_the_scene_powers(files, capsys):
    path = write(files, "five", campaign_text(runs=[{**CUT, "plate": {**ONE_COLUMN_PLATE, "n_powered_columns": 5}}]))
    assert cli.main(["validate", str(path)]) == cli.EXIT_USER_ERROR
    refused = one_line(capsys).split(": ", 1)[1]
    assert cli.main(["run", str(path), "--out", str(files / "run")]) == cli.EXIT_USER_ERROR
    line = one_line(capsys)
    assert line.endswith(refused)   # the one validator, the same words
    assert "5 powered columns" in line and "powers 1" in line and "n_powered_columns" in line
    assert not (files / "run").exists()


@pytest.mark.parametrize("content", [b"garbage", b"PAR1" + b"\0" * 64 + b"PAR1"])
def test_an_unreadable_waveform_file_is_named(tmp_path, content):
    from squeezebench.analysis.rundata import RunDataError, load_waveform

    (tmp_path / "w.parquet").write_bytes(content)
    with pytest.raises(RunDataError, match=r"w\.parquet: unreadable waveform file \("):
        load_waveform(tmp_path, "w.parquet")
    with pytest.raises(RunDataError, match="missing"):
        load_waveform(tmp_path, "absent.parquet")
