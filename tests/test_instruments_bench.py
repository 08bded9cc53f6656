"""Bench description, opening and checking (on the simulated bench, from its power-on
state and from a hostile one)."""

from __future__ import annotations

from pathlib import Path

import pytest

from squeezebench.instruments.agilent33120a import Agilent33120A
from squeezebench.schemas import load_bench_file   # the one validator of bench files (`run` and `check`)
from squeezebench.instruments.bench import (SIM_RESOURCES, Bench, BenchConfig, BenchElectronics, SimulatedOperator,
                                            TerminalOperator, WallClock, check_bench, open_bench,
                                            sim_bench_config)
from squeezebench.instruments.errors import BenchFileError, InstrumentConnectionError, OperatorUnavailable
from squeezebench.instruments.ofv5000 import OFV5000
from squeezebench.instruments.tds3054b import TDS3054B
from squeezebench.errors import UserError
from squeezebench.yamlfiles import dump_yaml

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "data" / "scenes" / "one_column_1mm.yaml"


@pytest.fixture(params=["power_on", "hostile"])
def sim_library(request) -> str:
    """The simulated bench, its instruments starting as the manuals power them on or as a
    previous user may have left them (simbench.devices.hostile_start)."""
    return f"{SCENE}#start={request.param}@simbench"


def write_yaml(tmp_path: Path, data, name: str = "bench.yaml") -> Path:
    path = tmp_path / name
    path.write_text(data if isinstance(data, str) else dump_yaml(data))
    return path


GOOD_BENCH = {"visa_library": "@py", "resources": dict(SIM_RESOURCES), "stage_travel_mm": {"x": [0, 300], "y": [0, 200]},
              "electronics": {"amplifier_gain": 20, "amplifier_max_output_vpp": 240, "generator_load": "INF"}}


# -- electronics ----------------------------------------------------------------------------------
def test_electronics_conversions():
    electronics = BenchElectronics(amplifier_gain=20.0, generator_load="50", amplifier_input_ohm=50.0)
    assert electronics.piezo_vpp_for_generator_vpp(2.5) == 50.0   # a matched 50 ohm input
    assert electronics.generator_vpp_for_piezo_vpp(100.0) == 5.0
    assert electronics.voltage_probe_gain == 0.01


@pytest.mark.parametrize("changes", [{"amplifier_gain": 0}, {"shunt_ohm": -2.0}, {"generator_load": "75"},
                                     {"current_probe_a_per_a": True}])
def test_electronics_refuses_nonsense(changes):
    with pytest.raises(ValueError):
        BenchElectronics(**changes)


# -- bench files ----------------------------------------------------------------------------------
def test_load_bench_file(tmp_path):
    config = load_bench_file(write_yaml(tmp_path, GOOD_BENCH))
    assert config.visa_library == "@py"
    assert config.resources == SIM_RESOURCES
    assert config.electronics == BenchElectronics(amplifier_max_output_vpp=240.0)
    assert config.source == str(tmp_path / "bench.yaml")
    assert config.stage_travel_mm == {"x": (0, 300), "y": (0, 200)}


@pytest.mark.parametrize("content, field, allowed", [
    ("resources: [unclosed", "file", "not valid YAML at line "),
    ("- just\n- a list\n", "top level", "electronics, resources, simulator, stage_travel_mm, visa_library"),
    ({**GOOD_BENCH, "amplifier": 20}, "amplifier", "electronics, resources, simulator, stage_travel_mm, visa_library"),
    ({**GOOD_BENCH, "visa_library": 3}, "visa_library", "should be a valid string"),
    ({**GOOD_BENCH, "resources": {"generator": "GPIB0::10::INSTR", "scope": "TCPIP0::1.2.3.4::INSTR"}},
     "resources.vibrometer", "is missing"),
    ({**GOOD_BENCH, "resources": {**SIM_RESOURCES, "scope": "192.168.0.20"}}, "resources.scope",
     "e.g. GPIB0::10::INSTR"),
    ({**GOOD_BENCH, "resources": {**SIM_RESOURCES, "amplifier": "GPIB0::5::INSTR"}},
     "resources.amplifier", "generator, scope, stage, vibrometer"),
    ({**GOOD_BENCH, "electronics": {"amplifier_gain": "twenty"}}, "electronics.amplifier_gain",
     "should be a valid number"),
    ({**GOOD_BENCH, "electronics": {"amplifier_gain": "20"}}, "electronics.amplifier_gain",
     "'20' is text, not a number: write it without quotes"),
    ({**GOOD_BENCH, "electronics": {"shunt_ohm": True}}, "electronics.shunt_ohm", "should be a valid number"),
    ({**GOOD_BENCH, "electronics": {"generator_load": 75}}, "electronics", "50, INF"),
    ({**GOOD_BENCH, "electronics": {"gain": 20}}, "electronics.gain", "amplifier_gain, amplifier_input_ohm"),
])
def test_bench_file_errors_name_file_field_and_allowed_values(tmp_path, content, field, allowed):
    path = write_yaml(tmp_path, content)
    with pytest.raises(BenchFileError) as info:
        load_bench_file(path)
    message = str(info.value)
    assert message.startswith(str(path)) and f": {field}:" in message and allowed in message
    assert isinstance(info.value, UserError)


def test_missing_bench_file(tmp_path):
    with pytest.raises(BenchFileError, match=r"nowhere.yaml: file: cannot be read"):
        load_bench_file(tmp_path / "nowhere.yaml")


def test_sim_bench_config_reads_the_scene_electronics(tmp_path):
    scene = write_yaml(tmp_path, {"plate": {"name": "p"}, "electronics": {
        "amplifier_gain": 10, "shunt_ohm": 1.5, "amplifier_input_ohm": 10000,
        "amplifier_bandwidth_hz": 4e5}}, "scene.yaml")
    config = sim_bench_config(scene)
    assert config.visa_library == f"{scene}@simbench"
    assert config.resources == SIM_RESOURCES
    # keys it names are read (the input impedance: the safety chain counts it), the others
    # keep their defaults, simbench's own are ignored
    assert config.electronics == BenchElectronics(amplifier_gain=10.0, shunt_ohm=1.5, amplifier_input_ohm=10000.0)


def test_sim_bench_config_errors(tmp_path):
    scene = write_yaml(tmp_path, {"electronics": {"voltage_probe_attenuation": -100}}, "scene.yaml")
    with pytest.raises(BenchFileError, match=r"scene.yaml: electronics.voltage_probe_attenuation: .*positive"):
        sim_bench_config(scene)
    with pytest.raises(BenchFileError, match="file: cannot be read"):
        sim_bench_config(tmp_path / "missing.yaml")


# -- opening --------------------------------------------------------------------------------------
def test_open_bench(sim_library):
    config = BenchConfig(sim_library, dict(SIM_RESOURCES))
    with open_bench(config) as bench:
        assert isinstance(bench, Bench)
        assert (type(bench.generator), type(bench.scope), type(bench.vibrometer)) == \
            (Agilent33120A, TDS3054B, OFV5000)
        assert isinstance(bench.operator, SimulatedOperator)
        assert bench.electronics is config.electronics
        assert bench.generator.output_load == "INF"      # what the amplifier input needs
        bench.check_errors()                             # stale status was cleared
        identifications = bench.identify()
        assert "33120A" in identifications["generator"] and "TDS 3054" in identifications["scope"]
        assert identifications["vibrometer"] == "OFV-5000"
        assert bench.vibrometer.echo == "Off"
        snapshot = bench.settings_snapshot()
        assert snapshot["generator"]["output_load"] == "INF" and snapshot["scope"]["ch2"]["probe_model"] == "TCP202"
        resource = bench.generator.resource
    with pytest.raises(Exception):   # closed with the bench
        resource.query("*IDN?")


def test_open_bench_names_the_role_that_does_not_answer(sim_library):
    config = BenchConfig(sim_library, {**SIM_RESOURCES, "scope": "TCPIP0::192.168.0.99::INSTR"})
    with pytest.raises(InstrumentConnectionError) as info:
        open_bench(config)
    assert info.value.role == "scope" and info.value.resource == "TCPIP0::192.168.0.99::INSTR"
    assert "scope (TCPIP0::192.168.0.99::INSTR)" in str(info.value)
    assert isinstance(info.value, UserError)


def test_open_bench_refuses_another_instrument_at_an_address(sim_library, monkeypatch):
    config = BenchConfig(sim_library, {**SIM_RESOURCES, "generator": SIM_RESOURCES["scope"]})
    with pytest.raises(InstrumentConnectionError,
                       match=r"generator \(TCPIP0::192.168.0.20::INSTR\).*'TEKTRONIX,TDS 3054B.*not a 33120A"):
        open_bench(config)
    config = BenchConfig(sim_library, {**SIM_RESOURCES, "generator": SIM_RESOURCES["vibrometer"]})
    with pytest.raises(InstrumentConnectionError, match=r"generator \(ASRL1::INSTR\).*not a 33120A"):
        open_bench(config)   # the OFV-5000 does not speak SCPI (it echoes, then answers Error)


def test_unloadable_visa_library(tmp_path):
    with pytest.raises(InstrumentConnectionError, match="cannot load the VISA library"):
        open_bench(BenchConfig("@no_such_backend", dict(SIM_RESOURCES)))


# -- checking -------------------------------------------------------------------------------------
def test_check_bench(sim_library):
    lines: list[str] = []
    assert check_bench(BenchConfig(sim_library, dict(SIM_RESOURCES)), out=lines.append) == 0
    text = "\n".join(lines)
    assert "generator at GPIB0::10::INSTR: HEWLETT-PACKARD,33120A" in text
    assert "scope at TCPIP0::192.168.0.20::INSTR: TEKTRONIX,TDS 3054B" in text
    assert "vibrometer at ASRL1::INSTR: OFV-5000" in text
    assert "ch2: detected probe TCP202, gain 1, unit A" in text
    assert "decoder = 'VD-09'" in text and "decoder ranges: 5mm/s/V, 10mm/s/V" in text
    assert "401,'Power on'" in text    # read and cleared
    assert text.endswith("bench check passed")


def test_check_bench_reads_and_clears_stale_errors():
    lines: list[str] = []
    assert check_bench(BenchConfig(f"{SCENE}#start=hostile@simbench", dict(SIM_RESOURCES)), out=lines.append) == 0
    text = "\n".join(lines)
    assert "cleared 1 queued event(s): -113,'Undefined header'" in text
    assert "113,'Undefined header; MATH:DEFI \"CH1*CH2\"'" in text
    # the 50 ohm setting the previous user left is named against the bench file's INF
    assert "output_load '50' differs from the bench description's generator_load 'INF'" in text


def test_check_bench_exits_2_when_the_bench_file_disagrees_with_a_detected_probe():
    lines: list[str] = []
    config = BenchConfig(f"{SCENE}@simbench", dict(SIM_RESOURCES), BenchElectronics(current_probe_a_per_a=0.1))
    assert check_bench(config, out=lines.append) == 2
    text = "\n".join(lines)
    assert ("scope CH2 has a TCP202 probe the scope detected with gain 1 (1:1), but the bench description "
            "says 0.1 (10:1) (electronics.current_probe_a_per_a)") in text
    assert text.endswith("bench check FAILED: the bench description disagrees with the hardware")


def test_check_bench_with_a_missing_address(sim_library):
    lines: list[str] = []
    config = BenchConfig(sim_library, {**SIM_RESOURCES, "vibrometer": "ASRL7::INSTR"})
    assert check_bench(config, out=lines.append) == 2
    text = "\n".join(lines)
    assert "vibrometer at ASRL7::INSTR did not answer as expected" in text
    assert "generator at GPIB0::10::INSTR: HEWLETT-PACKARD,33120A" in text   # the others are still shown
    assert text.endswith("bench check FAILED: vibrometer did not answer")


# -- operators ------------------------------------------------------------------------------------
def test_terminal_operator_prompts_and_waits():
    shown, prompts = [], []
    operator = TerminalOperator(out=shown.append, wait=prompts.append)
    operator.request("Cut the plate to 59 mm", state="59x41")
    operator.mount("data/scenes/small_plate_2.yaml")
    assert shown == ["Cut the plate to 59 mm (plate state: 59x41)", "Mount plate small_plate_2 on the bench."]
    assert len(prompts) == 2


def test_terminal_operator_without_a_terminal_is_one_clear_stop():
    """Standard input closed (a scheduler, `< /dev/null`): the cut prompt's EOFError becomes a
    UserError (exit 2) that says what to do and how to resume."""
    def closed(prompt):
        raise EOFError

    operator = TerminalOperator(out=lambda text: None, wait=closed)
    with pytest.raises(OperatorUnavailable, match="Cut the plate to 59 mm.*--resume"):
        operator.request("Cut the plate to 59 mm", state="59x41")


def test_wall_clock():
    clock = WallClock()
    start = clock.now_s()
    clock.sleep(0.01)
    assert clock.now_s() - start >= 0.01


# -- the simulated bench ----------------------------------------------------------------------------
def test_open_bench_on_simbench_uses_its_clock_and_operator():
    pytest.importorskip("squeezebench.simbench.backend")
    config = sim_bench_config(SCENE)
    with open_bench(config) as first, open_bench(config) as second:
        simulated = first.resource_manager.visalib.bench
        assert first.clock is simulated.clock and isinstance(first.operator, SimulatedOperator)
        start_s = first.clock.now_s()
        first.clock.sleep(3600.0)                          # bench time, not wall time
        assert first.clock.now_s() - start_s == pytest.approx(3600.0)
        assert second.clock.now_s() < 3600.0              # each bench is its own
        first.operator.request("Cut the plate to 59 mm", state="59x41")
        assert simulated.state_name == "59x41"
        first.generator.frequency_hz = 37000.0
        assert second.generator.frequency_hz != 37000.0
