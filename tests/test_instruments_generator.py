"""Agilent 33120A driver against plain pyvisa-sim (simbench/definitions/agilent33120a.yaml)."""

from __future__ import annotations

import math

import pytest

from squeezebench.instruments.agilent33120a import Agilent33120A
from squeezebench.instruments.errors import GarbledReply, InstrumentError, InstrumentTimeout, OutOfRangeError
from squeezebench.errors import UserError

ADDRESS = "GPIB0::10::INSTR"


@pytest.fixture
def resource(rm):
    return rm.open_resource(ADDRESS)


@pytest.fixture
def generator(resource, sent):
    return Agilent33120A(resource)


def settings(messages: list[str]) -> list[str]:
    """The messages that change a setting (not queries)."""
    return [m for m in messages if not m.endswith("?")]


def test_identification_and_connect(generator, sent):
    assert "33120A" in generator.identify()
    assert sent[0] == "VOLT:UNIT VPP"   # amplitudes are peak-to-peak from the start
    assert generator.voltage_unit == "VPP"


@pytest.mark.parametrize("frequency_hz", [100e-6, 1.0, 37180.25, 15e6])
def test_frequency_round_trip(generator, sent, frequency_hz):
    generator.frequency_hz = frequency_hz
    assert sent[-1] == f"FREQ {frequency_hz:.9g}"
    assert generator.frequency_hz == pytest.approx(frequency_hz, rel=1e-9)


@pytest.mark.parametrize("load, amplitudes", [("50", (0.05, 3.3, 10.0)), ("INF", (0.1, 12.5, 20.0))])
def test_load_and_amplitude_round_trip(generator, sent, load, amplitudes):
    generator.output_load = load
    assert sent[-1] == f"OUTP:LOAD {load}"
    assert generator.output_load == load
    for amplitude_vpp in amplitudes:
        generator.amplitude_vpp = amplitude_vpp
        assert sent[-1] == f"VOLT {amplitude_vpp:.9g}"
        assert generator.amplitude_vpp == pytest.approx(amplitude_vpp, rel=1e-6)


def test_offset_and_shape_round_trip(generator, sent):
    generator.output_load = "INF"
    generator.amplitude_vpp = 4.0
    generator.offset_v = -7.5
    assert sent[-1] == "VOLT:OFFS -7.5"
    assert generator.offset_v == -7.5
    generator.shape = "SQU"
    assert sent[-1] == "FUNC:SHAP SQU"
    assert generator.shape == "SQU"


def test_load_reply_of_the_instrument_is_understood(generator, monkeypatch):
    # The 33120A answers 9.9E+37 for INF (pyvisa-sim answers +INF): both are high impedance.
    monkeypatch.setattr(generator, "query", lambda command: "+9.900000E+37")
    assert generator.output_load == "INF"
    monkeypatch.setattr(generator, "query", lambda command: "+5.000000E+01")
    assert generator.output_load == "50"


def test_apply_sine_sends_the_documented_commands(generator, sent):
    generator.output_load = "INF"
    del sent[:]
    generator.apply_sine(40000.5, 2.5, 1.0)
    assert settings(sent) == ["FUNC:SHAP SIN", "VOLT:UNIT VPP", "FREQ 40000.5", "VOLT 2.5", "VOLT:OFFS 1"]
    assert (generator.shape, generator.frequency_hz, generator.amplitude_vpp, generator.offset_v) == \
        ("SIN", 40000.5, 2.5, 1.0)
    # Lowering the offset goes first, so the 33120A never sees a combination beyond its limit.
    del sent[:]
    generator.apply_sine(40000.5, 19.0, 0.0)
    assert settings(sent)[-2:] == ["VOLT:OFFS 0", "VOLT 19"]


@pytest.mark.parametrize("name, value, allowed", [
    ("frequency_hz", 20e6, "0.0001 to 1.5e+07 Hz"),
    ("frequency_hz", 50e-6, "0.0001 to 1.5e+07 Hz"),
    ("frequency_hz", math.nan, "0.0001 to 1.5e+07 Hz"),
    ("amplitude_vpp", 12.0, "0.05 to 10 Vpp into OUTP:LOAD 50"),
    ("amplitude_vpp", 0.01, "0.05 to 10 Vpp into OUTP:LOAD 50"),
    ("output_load", "1000", "50, INF"),
    ("shape", "SINE", "SIN, SQU"),
])
def test_out_of_range_refused_before_sending(generator, sent, name, value, allowed):
    del sent[:]
    with pytest.raises(OutOfRangeError) as info:
        setattr(generator, name, value)
    assert f"generator.{name}" in str(info.value)
    assert allowed in str(info.value)
    assert settings(sent) == []


def test_amplitude_limits_follow_the_load_and_offset(generator, sent):
    generator.output_load = "INF"
    generator.amplitude_vpp = 15.0            # fine into high impedance
    generator.output_load = "50"
    assert generator.min_amplitude_vpp == 0.05 and generator.max_amplitude_vpp == 10.0
    generator.output_load = "INF"
    generator.amplitude_vpp = 10.0
    generator.offset_v = 4.0
    del sent[:]
    with pytest.raises(OutOfRangeError, match=r"offset_v.*-5 to 5 V"):
        generator.offset_v = 5.5              # 5.5 + 10/2 > 10 V
    with pytest.raises(OutOfRangeError, match=r"amplitude_vpp.*0.1 to 12 Vpp"):
        generator.amplitude_vpp = 14.0        # 4 + 14/2 > 10 V
    assert settings(sent) == []


def test_apply_sine_checks_everything_before_sending(generator, sent):
    generator.output_load = "50"
    del sent[:]
    with pytest.raises(OutOfRangeError, match="generator.amplitude_vpp"):
        generator.apply_sine(40e3, 15.0)
    with pytest.raises(OutOfRangeError, match="generator.offset_v"):
        generator.apply_sine(40e3, 8.0, 1.5)   # 1.5 + 4 > 5 V into 50 ohm
    with pytest.raises(OutOfRangeError, match="generator.frequency_hz"):
        generator.apply_sine(16e6, 1.0)
    assert settings(sent) == []


@pytest.mark.parametrize("load, minimum_vpp", [("50", 0.05), ("INF", 0.1)])
def test_output_to_minimum(generator, sent, load, minimum_vpp):
    generator.output_load = load
    generator.amplitude_vpp = 5.0
    generator.output_to_minimum()
    assert sent[-1] == f"VOLT {minimum_vpp:g}"
    assert generator.amplitude_vpp == minimum_vpp


def test_error_queue_reports_the_instruments_own_message(generator):
    generator.check_errors()                  # empty queue: +0,"No error"
    generator.write("FREQ 2e7")               # bypassing the driver's check
    with pytest.raises(InstrumentError) as info:
        generator.check_errors()
    assert info.value.code == -222
    assert info.value.message == "Data out of range"
    assert isinstance(info.value, UserError)
    generator.check_errors()                  # drained


def test_several_errors_are_all_reported(generator):
    generator.write("VOLT 99")
    generator.write("VOLT:OFFS 99")
    with pytest.raises(InstrumentError, match=r"Data out of range \(then: -222,'Data out of range'\)"):
        generator.check_errors()


def test_garbled_reply_names_command_and_reply(generator, monkeypatch):
    monkeypatch.setattr(generator.resource, "query", lambda command: "ERROR")
    with pytest.raises(GarbledReply) as info:
        generator.frequency_hz
    assert info.value.command == "FREQ?" and info.value.reply == "ERROR"
    assert "'FREQ?'" in str(info.value) and "'ERROR'" in str(info.value)


def test_visa_timeout_becomes_instrument_timeout(generator):
    generator.resource.timeout = 50           # ms; an unknown query gets no answer
    with pytest.raises(InstrumentTimeout) as info:
        generator.query("APPL?")
    assert info.value.operation == "APPL?"
    assert "generator" in str(info.value) and ADDRESS in str(info.value)


def test_settings_snapshot(generator):
    generator.output_load = "INF"
    generator.apply_sine(37180.0, 1.5)
    assert generator.settings_snapshot() == {"shape": "SIN", "frequency_hz": 37180.0, "voltage_unit": "VPP",
                                             "amplitude_vpp": 1.5, "offset_v": 0.0, "output_load": "INF"}


def test_sine_at_minimum_lowers_first_then_reshapes(generator, sent):
    generator.output_load = "INF"
    generator.shape = "SQU"
    generator.amplitude_vpp = 5.0
    generator.offset_v = 1.0
    del sent[:]
    generator.sine_at_minimum()
    changes = settings(sent)
    assert changes[0] == "VOLT 0.1"   # the amplitude comes down before anything else changes
    assert (generator.shape, generator.offset_v, generator.amplitude_vpp) == ("SIN", 0.0, 0.1)
