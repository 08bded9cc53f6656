"""Limits on what reaches the piezo, through the whole chain: generator load setting, its
50 ohm output into the amplifier's input impedance, the gain; and the measured CH1 check.

The stress test's case: `generator_load: 50` into a high-impedance amplifier input put
190 Vpp on a plate limited to 100 Vpp. The simulated bench models the 33120A's source
(simbench.physics: open-circuit voltage doubled for LOAD 50, divided by the amplifier
input), so the generator commands can be checked against the physics, not the driver.
"""

from __future__ import annotations

import json
import re

import pytest
from pyvisa.resources import MessageBasedResource

from squeezebench.instruments.bench import BenchElectronics
from squeezebench.protocols.campaign import run_campaign
from squeezebench.protocols.safety import MeasuredVoltageError, chain_warnings
from squeezebench.protocols.storage import read_measurements
from squeezebench.simbench import physics
from squeezebench.yamlfiles import dump_yaml, load_strict
from test_faults import _AMPLITUDE_WRITE, BusTap, _is_minimum
from test_protocols_support import ONE_COLUMN_PLATE, noise_free_scene, write_campaign

LIMIT_VPP = 100.0


def fifty_ohm_campaign(tmp_path, voltages_vpp):
    scene = noise_free_scene(tmp_path, "one_column_1mm.yaml")
    data = load_strict(scene.read_text())
    data.setdefault("electronics", {}).update(generator_load="50", amplifier_input_ohm=1e6)
    scene.write_text(dump_yaml(data))
    search = {"start_hz": 36000, "stop_hz": 38500, "points": 11, "tolerance_hz": 2.0}
    return write_campaign(tmp_path, [
        {"name": "sweep", "protocol": "characterisation", "plate": ONE_COLUMN_PLATE,
         "parameters": {"search": search, "voltages_vpp": voltages_vpp, "track_resonance": False}}],
        bench={"scene": str(scene)}, safety={"max_piezo_voltage_vpp": LIMIT_VPP})


def plate_vpp_per_generator_vpp() -> float:
    """The simulator's physics of the chain (not the controller's): LOAD 50 into 1 MOhm."""
    amplifier = physics.Amplifier(gain=20.0, input_ohm=1e6)
    return (physics.generator_emf_vpp(1.0, 50.0)
            * physics.divider_vpp(1.0, physics.GENERATOR_SOURCE_OHM, amplifier.input_ohm) * amplifier.gain)


def test_fifty_ohm_setting_never_puts_more_than_the_limit_on_the_plate(tmp_path, monkeypatch):
    campaign = fifty_ohm_campaign(tmp_path, [40, 80, LIMIT_VPP])
    tap = BusTap(monkeypatch)
    said = []
    run_dir = run_campaign(campaign, out_dir=tmp_path / "run", say=said.append)
    rows = read_measurements(run_dir)
    sent_vpp = rows["generator_amplitude_vpp"]
    factor = plate_vpp_per_generator_vpp()
    assert factor == pytest.approx(40.0, rel=1e-4)   # twice the nominal gain
    # every amplitude the generator held at a point, through the physics, is within the limit
    assert (sent_vpp * factor).max() <= LIMIT_VPP * (1 + 1e-9)
    # and what CH1 measured agrees: the plate got the setpoint, not twice it
    points = rows[rows["piezo_voltage_setpoint_vpp"] == LIMIT_VPP]
    assert len(points) == 1
    assert points["scope_piezo_voltage_pp_v"].iloc[0] == pytest.approx(LIMIT_VPP, rel=0.02)
    assert rows["scope_piezo_voltage_pp_v"].max() <= LIMIT_VPP * 1.02
    assert any("twice its displayed Vpp" in message for message in said)
    assert _is_minimum(tap.last_amplitude_vpp)


def amplitudes_sent(monkeypatch) -> list[float]:
    """Every generator amplitude (Vpp) written from now on, in order."""
    sent = []
    original = MessageBasedResource.write

    def write(resource, message, *args, **kwargs):
        match = _AMPLITUDE_WRITE.match(message)
        if match:
            sent.append(float(match.group(1)))
        return original(resource, message, *args, **kwargs)

    monkeypatch.setattr(MessageBasedResource, "write", write)
    return sent


def test_every_generator_command_through_the_physics_stays_within_the_limit(tmp_path, monkeypatch):
    campaign = fifty_ohm_campaign(tmp_path, [30, LIMIT_VPP])
    sent = amplitudes_sent(monkeypatch)
    run_campaign(campaign, out_dir=tmp_path / "run", say=lambda message: None)
    assert sent and max(sent) * plate_vpp_per_generator_vpp() <= LIMIT_VPP * (1 + 1e-9)


@pytest.mark.parametrize("load, input_ohm, warned", [("50", 1e6, True), ("50", 50.0, False), ("INF", 1e6, False)])
def test_a_doubling_configuration_is_warned_at_load(load, input_ohm, warned):
    electronics = BenchElectronics(generator_load=load, amplifier_input_ohm=input_ohm)
    assert bool(chain_warnings(electronics)) is warned
    expected = 20.0 * (2.0 if load == "50" else 1.0) * input_ohm / (input_ohm + 50.0)
    assert electronics.piezo_vpp_per_generator_vpp == pytest.approx(expected, rel=1e-12)


def test_a_misdescribed_gain_stops_at_the_first_point_even_under_the_limit(tmp_path, monkeypatch):
    """Bench file x20 believed, the chain giving twice that (the controller trusts the nominal
    gain): the resonance search's first acquisition, at 10 Vpp and far under the 100 Vpp limit,
    already measures more than the chain was told to produce. The run stops there, naming both
    voltages, with the generator at its minimum; before, it went on storing twice the setpoint."""
    campaign = fifty_ohm_campaign(tmp_path, [20, 40, 54])
    monkeypatch.setattr(BenchElectronics, "piezo_vpp_per_generator_vpp", property(lambda e: e.amplifier_gain))
    tap = BusTap(monkeypatch)
    with pytest.raises(MeasuredVoltageError, match="where the chain was told to produce 10 Vpp") as stop:
        run_campaign(campaign, out_dir=tmp_path / "run", say=lambda message: None)
    measured_vpp = float(re.search(r"measured (?:at least )?([0-9.]+) Vpp on CH1", str(stop.value)).group(1))
    assert measured_vpp > 10 * 1.2   # a first, possibly clipped, acquisition already tells
    assert measured_vpp < LIMIT_VPP  # no limit was reached: only the comparison with the setpoint stops it
    assert _is_minimum(tap.last_amplitude_vpp)
    assert "told to produce" in (tmp_path / "run" / "log.txt").read_text()
    # the acquisition that stopped it is kept, beside the data and never among it
    (evidence_file,) = (tmp_path / "run" / "evidence").rglob("*.json")
    assert str(evidence_file.relative_to(tmp_path / "run")) in str(stop.value)
    evidence = json.loads(evidence_file.read_text())
    assert evidence["measured_piezo_vpp"] == pytest.approx(measured_vpp, rel=1e-3)
    assert evidence["commanded_piezo_vpp"] == pytest.approx(10.0) and evidence["measured_to_commanded"] > 1.2
    assert set(evidence["channel_scale_per_div"]) >= {"CH1", "CH2", "CH3"}
    assert read_measurements(tmp_path / "run").empty or \
        (read_measurements(tmp_path / "run")["scope_piezo_voltage_pp_v"] <= 10 * 1.2).all()


def test_a_coded_probe_other_than_the_bench_file_is_refused_by_check_and_before_the_first_drive(tmp_path, monkeypatch):
    """CH1 carries a coded 10:1 probe (TekProbe level I: the scope fixes its gain and names
    no model); the bench file says 100:1. `check` fails naming both, and a run stops at open,
    before any amplitude above the generator's minimum is sent; before, `check` passed and
    the run died on error 242 of its first CH1:PROBE."""
    from dataclasses import replace

    from squeezebench.instruments.bench import check_bench, sim_bench_config
    from squeezebench.instruments.errors import BenchMismatch
    from squeezebench.protocols import campaign as campaign_module

    scene = noise_free_scene(tmp_path, "one_column_1mm.yaml")
    data = load_strict(scene.read_text())
    data.setdefault("electronics", {}).update({"voltage_probe_attenuation": 10.0, "voltage_probe_coded": True})
    scene.write_text(dump_yaml(data))

    def misdescribed(path):
        config = sim_bench_config(path)
        return replace(config, electronics=replace(config.electronics, voltage_probe_attenuation=100.0))

    lines = []
    assert check_bench(sim_bench_config(scene), out=lines.append) == 0
    assert check_bench(misdescribed(scene), out=lines.append) == 2
    assert any("CH1 has a coded" in line and "10:1" in line and "100:1" in line for line in lines)
    monkeypatch.setattr(campaign_module, "sim_bench_config", misdescribed)
    sent = amplitudes_sent(monkeypatch)
    campaign = write_campaign(tmp_path, [{"name": "search", "protocol": "resonance_search", "plate": ONE_COLUMN_PLATE,
                                          "parameters": {"search": {"start_hz": 36000, "stop_hz": 38500, "points": 5}}}],
                              bench={"scene": str(scene)})
    with pytest.raises(BenchMismatch, match="CH1 has a coded"):
        run_campaign(campaign, out_dir=tmp_path / "run", say=lambda message: None)
    assert sent and all(_is_minimum(v) for v in sent)
    assert read_measurements(tmp_path / "run").empty
