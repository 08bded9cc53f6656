"""TDS 3054B driver against plain pyvisa-sim (simbench/definitions/tds3054b.yaml).

Records are built here as real IEEE 488.2 blocks of big-endian int16 and served by the
simulated device in place of its static CURV? answer, so PyVISA's own block reader and
parser run on them (the VISA session still reads them through pyvisa-sim).
"""

from __future__ import annotations

import numpy as np
import pytest
from pyvisa_sim.component import NoResponse

from squeezebench.instruments.errors import (ClippedTraceError, GarbledReply, InstrumentError, InstrumentTimeout,
                                NoValidMeasurement, OutOfRangeError)
from squeezebench.instruments.tds3054b import HORIZONTAL_SCALES_S_PER_DIV, TDS3054B, Waveform

ADDRESS = "TCPIP0::192.168.0.20::INSTR"


@pytest.fixture
def resource(rm):
    return rm.open_resource(ADDRESS)


@pytest.fixture
def device(rm, resource):
    """The pyvisa-sim device behind the resource, to change what it answers."""
    return rm.visalib.sessions[resource.session].device


@pytest.fixture
def scope(resource, sent):
    return TDS3054B(resource)


def answer(device, monkeypatch, replies: dict[bytes, bytes | object]) -> None:
    """Make the simulated scope answer `replies` (bytes, or NoResponse) to those queries."""
    match = device._match
    monkeypatch.setattr(device, "_match", lambda query: replies[query] if query in replies else match(query))


def block(raw: np.ndarray) -> bytes:
    data = np.asarray(raw, dtype=">i2").tobytes()
    length = str(len(data)).encode()
    return b"#" + str(len(length)).encode() + length + data


def preamble(points: int, *, x_increment=2e-6, point_offset=0, x_zero=-1e-3, y_mult=4e-3 / 256, y_zero=0.5,
             y_off=100.0, unit="V", fields: str = "2;16;BIN;RI;MSB") -> bytes:
    return (f'{fields};{points};"Ch2, DC coupling, 5.0E-2 A/div, 2.0E-5 s/div, {points} points, Average mode";'
            f'Y;{x_increment:.6E};{point_offset};{x_zero:.6E};"s";{y_mult:.6E};{y_zero:.6E};{y_off:.6E};'
            f'"{unit}"').encode()


def test_identification_and_header_off(scope, sent):
    assert "TDS 3054" in scope.identify()
    assert sent[0] == "HEAD OFF"


@pytest.mark.parametrize("number", [1, 2, 3, 4])
def test_channel_settings_round_trip(scope, sent, number):
    ch = scope.channel(number)
    ch.probe_gain = 0.01
    assert sent[-1] == f"CH{number}:PRO 0.01"
    ch.scale_v_per_div = 2.5
    assert sent[-1] == f"CH{number}:SCA 2.5"
    ch.position_div = -1.5
    assert sent[-1] == f"CH{number}:POS -1.5"
    ch.coupling = "AC"
    assert sent[-1] == f"CH{number}:COUP AC"
    ch.bandwidth = "20MHz"
    assert sent[-1] == f"CH{number}:BAN TWE"
    assert ch.settings_snapshot() == {"probe_gain": 0.01, "scale_v_per_div": 2.5, "position_div": -1.5,
                                      "coupling": "AC", "bandwidth": "20MHz"}


def test_long_form_replies_are_understood(scope, monkeypatch):
    # A real scope answers the long forms of what was set (SAMPLE for SAM).
    for reply, expected in [("SAMPLE", "SAMPLE"), ("AVERAGE", "AVERAGE"), ("AVE", "AVERAGE")]:
        monkeypatch.setattr(scope, "query", lambda command: reply)
        assert scope.acquire_mode == expected
    monkeypatch.setattr(scope, "query", lambda command: "ONEFIFTY")
    assert scope.channel(1).bandwidth == "150MHz"


def test_vertical_scale_range_follows_the_probe(scope, sent):
    ch = scope.channel(1)
    ch.probe_gain = 0.01                       # 100:1: 0.1 V/div to 1 kV/div at the tip
    ch.scale_v_per_div = 500.0
    del sent[:]
    with pytest.raises(OutOfRangeError) as info:
        ch.scale_v_per_div = 0.05
    assert "scope.ch1.scale_v_per_div" in str(info.value) and "0.1 to 1000" in str(info.value)
    assert [m for m in sent if not m.endswith("?")] == []


@pytest.mark.parametrize("name, value, allowed", [
    ("horizontal_scale_s_per_div", 3e-6, "1e-09, 2e-09, 4e-09"),
    ("record_length", 1000, "500, 10000"),
    ("num_averages", 3, "2, 4, 8"),
    ("num_averages", 1024, "256, 512"),
    ("acquire_mode", "HIRES", "SAMPLE, AVERAGE"),
    ("data_stop", 10001, "1 to 10000"),
])
def test_out_of_range_refused_before_sending(scope, sent, name, value, allowed):
    del sent[:]
    with pytest.raises(OutOfRangeError) as info:
        setattr(scope, name, value)
    assert f"scope.{name}" in str(info.value) and allowed in str(info.value)
    assert sent == []


def test_channel_position_and_number_refused(scope, sent):
    del sent[:]
    with pytest.raises(OutOfRangeError, match=r"scope.ch3.position_div.*-5 to 5 div"):
        scope.channel(3).position_div = 5.5
    with pytest.raises(OutOfRangeError, match=r"scope.channel.*1, 2, 3, 4"):
        scope.channel(5)
    assert sent == []


def test_acquisition_settings_round_trip(scope, sent):
    scope.horizontal_scale_s_per_div = 4e-6
    assert sent[-1] == "HOR:MAI:SCA 4e-06"
    assert scope.horizontal_scale_s_per_div == 4e-6
    scope.record_length = 500
    assert sent[-1] == "HOR:RECO 500" and scope.record_length == 500
    scope.set_averaging(64)
    assert sent[-2:] == ["ACQ:MOD AVE", "ACQ:NUMAV 64"]
    assert (scope.acquire_mode, scope.num_averages) == ("AVERAGE", 64)
    scope.acquire_mode = "SAMPLE"
    assert sent[-1] == "ACQ:MOD SAM" and scope.acquire_mode == "SAMPLE"
    scope.set_averaging(64)
    scope.set_averaging(1)   # one waveform: sample mode, NUMAV untouched
    assert sent[-1] == "ACQ:MOD SAM" and scope.acquire_mode == "SAMPLE"


def test_horizontal_scale_rounds_up_to_the_1_2_4_sequence(scope):
    assert scope.set_horizontal_scale(2.6e-6) == 4e-6      # 20 periods of 76.9 kHz
    assert scope.horizontal_scale_s_per_div == 4e-6
    assert scope.set_horizontal_scale(1e-5) == 1e-5
    assert HORIZONTAL_SCALES_S_PER_DIV[:4] == (1e-9, 2e-9, 4e-9, 1e-8)
    with pytest.raises(OutOfRangeError, match="horizontal_scale_s_per_div"):
        scope.set_horizontal_scale(20.0)


def test_math_product(scope, sent):
    scope.define_math_product("CH1", "CH2")
    assert sent[-1] == 'MATH:DEFI "CH1*CH2"'
    assert scope.math_definition == "CH1*CH2"


def test_acquire_single(scope, sent, resource):
    before_ms = resource.timeout
    del sent[:]
    scope.acquire_single(timeout_s=30.0)
    assert sent == ["ACQ:STOPA SEQ", "ACQ:STATE RUN", "*OPC?"]
    assert resource.timeout == before_ms


def test_acquisition_that_never_completes(scope, device, resource, monkeypatch):
    answer(device, monkeypatch, {b"*OPC?": NoResponse})
    before_ms = resource.timeout
    with pytest.raises(InstrumentTimeout) as info:
        scope.acquire_single(timeout_s=0.05)
    assert "acquisition" in info.value.operation and info.value.timeout_s == 0.05
    assert resource.timeout == before_ms


def test_measure(scope, sent):
    del sent[:]
    assert scope.measure(2, "PK2PK") == 0.25
    assert sent == ["MEASU:IMM:SOU CH2", "MEASU:IMM:TYP PK2", "MEASU:IMM:VAL?"]
    del sent[:]
    scope.measure("MATH", "MEAN")
    scope.measure(1, "FREQ")                              # short forms are accepted too
    assert [m for m in sent if m.startswith("MEASU:IMM:TYP")] == ["MEASU:IMM:TYP MEAN", "MEASU:IMM:TYP FREQ"]
    del sent[:]
    with pytest.raises(OutOfRangeError, match="measurement_type"):
        scope.measure(1, "WOBBLE")
    with pytest.raises(OutOfRangeError, match="scope.source"):
        scope.measure(5, "MEAN")
    assert sent == []


@pytest.mark.parametrize("reply", [b"9.91E37", b"9.9E37"])
def test_measurement_without_value(scope, device, monkeypatch, reply):
    answer(device, monkeypatch, {b"MEASU:IMM:VAL?": reply})
    with pytest.raises(NoValidMeasurement, match=r"no valid FREQUENCY measurement of CH3"):
        scope.measure(3, "FREQUENCY")


def test_fetch_waveform_decodes_and_scales_the_block(scope, device, sent, monkeypatch):
    scope.record_length = 500
    scope.set_averaging(16)
    raw = (np.arange(500) * 37 % 20001 - 10000).astype(np.int16)
    raw[7] = 0x0A0A        # an LF byte inside the data must not end the read
    answer(device, monkeypatch, {b"WFMP?": preamble(500, point_offset=3), b"CURV?": block(raw)})
    del sent[:]
    waveform = scope.fetch_waveform(2)
    assert [m for m in sent if m.startswith("DAT")] == ["DAT:SOU CH2", "DAT:ENC RIB", "DAT:WID 2",
                                                         "DAT:STAR 1", "DAT:STOP 500"]
    assert isinstance(waveform, Waveform)
    assert waveform.values.dtype == np.float64 and waveform.values.shape == (500,)
    np.testing.assert_allclose(waveform.time_s, -1e-3 + 2e-6 * (np.arange(500) - 3), rtol=0, atol=1e-15)
    np.testing.assert_allclose(waveform.values, 0.5 + (4e-3 / 256) * (raw.astype(float) - 100.0), rtol=1e-12)
    assert waveform.values[7] == pytest.approx(0.5 + (4e-3 / 256) * (2570 - 100))
    assert (waveform.unit, waveform.source, waveform.bits, waveform.averages) == ("V", "CH2", 16, 16)
    assert (waveform.x_increment_s, waveform.y_multiplier, waveform.y_offset_counts, waveform.y_zero) == \
        (2e-6, 4e-3 / 256, 100.0, 0.5)
    assert waveform.y_increment == waveform.y_multiplier
    assert waveform.clipped_fraction == 0.0


def test_clipped_trace(scope, device, monkeypatch):
    scope.record_length = 500
    raw = np.zeros(500, dtype=np.int16)
    raw[[10, 20, 30, 40]] = [32767, -32768, 32640, 32639]   # the last one is inside the ADC range
    answer(device, monkeypatch, {b"WFMP?": preamble(500), b"CURV?": block(raw)})
    with pytest.raises(ClippedTraceError) as info:
        scope.fetch_waveform("ch3")
    assert info.value.channel == 3 and info.value.source == "CH3"
    assert info.value.clipped_fraction == 3 / 500
    assert "CH3" in str(info.value) and "0.6 %" in str(info.value)
    waveform = scope.fetch_waveform(3, allow_clipped=True)
    assert waveform.clipped_fraction == 3 / 500


def test_block_not_matching_its_preamble(scope, device, monkeypatch):
    scope.record_length = 500
    answer(device, monkeypatch, {b"WFMP?": preamble(500), b"CURV?": block(np.zeros(499))})
    with pytest.raises(GarbledReply, match="announces 500 points"):
        scope.fetch_waveform(1)


def test_malformed_block_header(scope, device, monkeypatch):
    answer(device, monkeypatch, {b"WFMP?": preamble(2), b"CURV?": b"#9garbage"})
    with pytest.raises(GarbledReply, match="CURV"):
        scope.fetch_waveform(1)


def test_unexpected_transfer_format(scope, device, monkeypatch):
    answer(device, monkeypatch, {b"WFMP?": preamble(2, fields="1;8;BIN;RP;MSB")})
    with pytest.raises(GarbledReply, match="2-byte signed big-endian"):
        scope.fetch_waveform(1)


def test_source_not_displayed(scope, device, monkeypatch):
    answer(device, monkeypatch, {b"WFMP?": b"2;16;BIN;RI;MSB"})
    with pytest.raises(InstrumentError, match="CH4 is not displayed"):
        scope.fetch_waveform(4)


def test_fetch_through_the_static_simulator(scope):
    # The static definitions answer a finished acquisition and a 2-point record.
    scope.acquire_single(timeout_s=1.0)
    waveform = scope.fetch_waveform(1)
    np.testing.assert_allclose(waveform.values, [16448 * 1.5625e-5] * 2)


def test_error_events_carry_the_scopes_message(scope):
    scope.check_errors()                       # *ESR? 0: nothing to report
    scope.write("CH1:POS 7")                   # bypassing the driver's check
    with pytest.raises(InstrumentError) as info:
        scope.check_errors()
    assert info.value.code == 222 and info.value.message == "Data out of range"
    scope.check_errors()                       # *ESR? was cleared by reading it


def test_settings_snapshot(scope):
    scope.configure_channel(1, probe_gain=0.01)
    snapshot = scope.settings_snapshot()
    assert {"horizontal_scale_s_per_div", "record_length", "acquire_mode", "num_averages", "stop_after",
            "math_definition", "measurement_source", "measurement_type", "data_source"} <= set(snapshot)
    assert snapshot["ch1"] == {"probe_gain": 0.01, "scale_v_per_div": 0.1, "position_div": 0.0,
                               "coupling": "DC", "bandwidth": "FULL"}
    assert set(snapshot) >= {"ch1", "ch2", "ch3", "ch4"}
