"""Polytec OFV-5000 driver against plain pyvisa-sim (simbench/definitions/ofv5000.yaml)."""

from __future__ import annotations


import numpy as np
import pytest
import pyvisa

from squeezebench.instruments.errors import GarbledReply, InstrumentError, OutOfRangeError
from squeezebench.instruments.ofv5000 import OFV5000, VELOCITY_RANGES_MPS_PER_V

ADDRESS = "ASRL1::INSTR"


@pytest.fixture
def resource(rm):
    return rm.open_resource(ADDRESS)


@pytest.fixture
def vibrometer(resource, sent):
    return OFV5000(resource)


def test_connect_turns_echo_off_and_sets_the_serial_line(vibrometer, sent, resource):
    assert sent[0] == "Set,Interface,0,Echo,Off"
    assert vibrometer.echo == "Off"
    assert (resource.baud_rate, resource.data_bits) == (115200, 8)
    assert resource.parity == pyvisa.constants.Parity.none
    assert resource.stop_bits == pyvisa.constants.StopBits.one


def test_identification(vibrometer, sent):
    assert vibrometer.identify() == "OFV-5000"
    assert sent[-1] == "GetDevInfo,Controller,0,Name"


@pytest.mark.parametrize("name, mps_per_v", sorted(VELOCITY_RANGES_MPS_PER_V.items()))
def test_velocity_range_round_trip(vibrometer, sent, name, mps_per_v):
    vibrometer.velocity_range = name
    assert f"Set,VeloDec,0,Range,{name}" in sent
    assert vibrometer.velocity_range == name
    assert vibrometer.velocity_range_mps_per_v == mps_per_v


@pytest.mark.parametrize("mps_per_v, name", [(0.005, "5mm/s/V"), (0.025, "25mm/s/V"), (0.125, "125mm/s/V"),
                                             (1.0, "1000mm/s/V")])
def test_velocity_range_by_scale_factor(vibrometer, sent, mps_per_v, name):
    vibrometer.velocity_range_mps_per_v = mps_per_v
    assert f"Set,VeloDec,0,Range,{name}" in sent
    assert vibrometer.velocity_range_mps_per_v == mps_per_v


@pytest.mark.parametrize("name, value, allowed", [
    ("velocity_range_mps_per_v", 0.05, "0.005, 0.025, 0.125, 1 m/s/V"),
    ("velocity_range", "50mm/s/V", "5mm/s/V, 25mm/s/V, 125mm/s/V, 1000mm/s/V"),
    ("low_pass_filter", "50kHz", "5kHz, 20kHz, 100kHz, Off"),
])
def test_out_of_range_refused_before_sending(vibrometer, sent, name, value, allowed):
    del sent[:]
    with pytest.raises(OutOfRangeError) as info:
        setattr(vibrometer, name, value)
    assert f"vibrometer.{name}" in str(info.value) and allowed in str(info.value)
    assert sent == []


@pytest.mark.parametrize("name", ["5kHz", "20kHz", "100kHz", "Off"])
def test_low_pass_filter_round_trip(vibrometer, sent, name):
    vibrometer.low_pass_filter = name
    assert f"Set,VeloFilter,0,LowPassRange,{name}" in sent
    assert vibrometer.low_pass_filter == name


def test_a_setting_the_controller_ignored_is_an_error(vibrometer, resource, monkeypatch):
    # No acknowledgement and no error queue: the read-back is the only evidence.
    vibrometer.velocity_range = "125mm/s/V"
    write = resource.write
    monkeypatch.setattr(resource, "write", lambda m: None if m.startswith("Set,") else write(m))
    with pytest.raises(InstrumentError, match=r"velocity_range reads '125mm/s/V' after setting it to '5mm/s/V'"):
        vibrometer.velocity_range = "5mm/s/V"


def test_live_readings(vibrometer, monkeypatch):
    assert vibrometer.over_range() is False
    assert vibrometer.signal_level_percent() == 80.0
    monkeypatch.setattr(vibrometer, "query", lambda command: "1")
    assert vibrometer.over_range() is True
    monkeypatch.setattr(vibrometer, "query", lambda command: "Over")
    with pytest.raises(GarbledReply, match="Get,OverRange,0,Value"):
        vibrometer.over_range()
    monkeypatch.setattr(vibrometer, "query", lambda command: "140")
    with pytest.raises(GarbledReply, match="0 to 100"):
        vibrometer.signal_level_percent()


def test_volts_to_velocity(vibrometer):
    vibrometer.velocity_range = "125mm/s/V"
    assert vibrometer.volts_to_velocity_mps(2.0) == pytest.approx(0.25)
    np.testing.assert_allclose(vibrometer.volts_to_velocity_mps(np.array([-1.0, 0.5])), [-0.125, 0.0625])
    assert vibrometer.volts_to_velocity_mps(2.0, range_mps_per_v=0.005) == pytest.approx(0.01)


def test_settings_snapshot(vibrometer):
    vibrometer.velocity_range = "25mm/s/V"
    assert vibrometer.settings_snapshot() == {"echo": "Off", "velocity_range": "25mm/s/V",
                                              "low_pass_filter": "100kHz", "velocity_range_mps_per_v": 0.025}
