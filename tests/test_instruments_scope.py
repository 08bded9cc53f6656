"""TDS 3054B driver, byte for byte against the TDS3000/B/C programmer manual: every
command in full spelling (p. 2-4), replies as the manual shows them with HEADER OFF,
events through *ESR? and ALLEV? (Section 3), independent of the simulator."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import CLEAR, TIMEOUT, expected_protocol
from squeezebench.instruments.errors import (BenchMismatch, ClippedTraceError, GarbledReply, InstrumentError,
                                             InstrumentTimeout, NoValidMeasurement, OutOfRangeError)
from squeezebench.instruments.base import concatenated
from squeezebench.instruments.tds3054b import TDS3054B

CONNECT = [(CLEAR, None), ("HEADER OFF", None), ("VERBOSE ON", None)]


def block(raw) -> bytes:
    data = np.asarray(raw, dtype=">i2").tobytes()
    length = str(len(data)).encode()
    return b"#" + str(len(length)).encode() + length + data


def preamble(points: int, fields: str = "2;16;BIN;RI;MSB") -> str:
    return (f'{fields};{points};"Ch2, DC coupling, 5.0E-2 A/div, 2.0E-5 s/div, {points} points, Average mode";'
            f'Y;2.000000E-06;0;-1.000000E-03;"s";1.562500E-05;5.000000E-01;1.000000E+02;"A"')


def test_connect_turns_headers_off_and_identifies():
    idn = "TEKTRONIX,TDS 3054B,0,CF:91.1CT FV:v3.41 TDS3GM:v1.00 TDS3FFT:v1.00 TDS3TRG:v1.00"
    with expected_protocol(TDS3054B, CONNECT + [("*IDN?", idn)]) as scope:
        assert scope.identify() == idn


def test_a_channel_is_displayed_then_set_up_with_the_probe_first():
    with expected_protocol(TDS3054B, CONNECT + [
            ("SELECT:CH1 ON", None), ("CH1:IMPEDANCE MEG", None), ("CH1:ID?", '""'), ("CH1:PROBE 0.01", None), ("CH1:PROBE?", "1.0E-2"),
            ("CH1:OFFSET 0", None), ("CH1:COUPLING DC", None), ("CH1:POSITION 0", None), ("CH1:BANDWIDTH FULL", None)]) as scope:
        scope.configure_channel(1, probe_gain=0.01)


def test_a_coded_probe_that_keeps_its_own_gain_is_a_bench_mismatch_not_a_later_error():
    """TekProbe level I: no model to name, but the gain set does not take (error 242,
    p. 2-68): the mismatch is said in the bench's words and its event is read off."""
    with expected_protocol(TDS3054B, CONNECT + [
            ("SELECT:CH1 ON", None), ("CH1:IMPEDANCE MEG", None), ("CH1:ID?", '""'), ("CH1:PROBE 0.01", None), ("CH1:PROBE?", "1.0E-1"),
            ("*ESR?", "16"), ("ALLEV?", '242,"Hardware configuration error"')]) as scope:
        with pytest.raises(BenchMismatch, match=r"CH1 has a coded \(TekProbe level I\) probe .* gain 0.1 \(10:1\), "
                                                r"but the bench description says 0.01 \(100:1\)"):
            scope.configure_channel(1, probe_gain=0.01)


def test_a_detected_probe_is_read_not_overwritten():
    with expected_protocol(TDS3054B, CONNECT + [
            ("SELECT:CH2 ON", None), ("CH2:IMPEDANCE MEG", None), ("CH2:ID?", '"TCP202"'), ("CH2:PROBE?", "1.0E0"), ("CH2:OFFSET 0", None),
            ("CH2:COUPLING DC", None),
            ("CH2:POSITION 0", None), ("CH2:BANDWIDTH FULL", None)]) as scope:
        scope.configure_channel(2, probe_gain=1.0)


def test_a_detected_probe_that_disagrees_with_the_bench_is_a_bench_mismatch():
    with expected_protocol(TDS3054B, CONNECT + [("SELECT:CH2 ON", None), ("CH2:IMPEDANCE MEG", None), ("CH2:ID?", '"TCP202"'),
                                                ("CH2:PROBE?", "1.0E0")]) as scope:
        with pytest.raises(BenchMismatch, match=r"CH2 has a TCP202 probe .* gain 1 \(1:1\), but the bench .* says 0.1"):
            scope.configure_channel(2, probe_gain=0.1)


def test_trigger_and_math_are_programmed_in_full():
    with expected_protocol(TDS3054B, CONNECT + [
            ("TRIGGER:A:TYPE EDGE", None), ("TRIGGER:A:EDGE:SOURCE CH1", None), ("TRIGGER:A:EDGE:COUPLING DC", None),
            ("TRIGGER:A:EDGE:SLOPE RISE", None), ("TRIGGER:A:LEVEL 0", None), ("TRIGGER:A:MODE AUTO", None),
            ("MATH:TYPE DUAL", None), ('MATH:DEFINE "CH1*CH2"', None), ("SELECT:MATH ON", None),
            ("HORIZONTAL:DELAY:STATE ON", None), ("HORIZONTAL:DELAY:TIME 0", None)]) as scope:
        scope.trigger_on(1, level=0.0)
        scope.set_math_product()
        scope.center_record_on_trigger()


def test_record_length_uses_the_spelling_every_reading_accepts():
    with expected_protocol(TDS3054B, CONNECT + [("HORIZONTAL:RECORDLENGTH 500", None),
                                                ("HORIZONTAL:RECORDLENGTH?", "500")]) as scope:
        scope.set_record_length(500)
        assert scope.record_length == 500


def test_time_base_is_the_next_1_2_4_value():
    with expected_protocol(TDS3054B, CONNECT + [("HORIZONTAL:MAIN:SCALE 4e-05", None)]) as scope:
        assert scope.set_horizontal_scale(2.69e-5) == 4e-5


def test_measurements_are_gated_on_whole_periods():
    # 4e-4 s record at 37180 Hz holds 14 whole periods; the gate stops half a sample early
    stop_s = -2e-4 + 14 / 37180.0 - 0.5 * 4e-4 / 500
    with expected_protocol(TDS3054B, CONNECT + [
            ("CURSOR:FUNCTION VBARS", None), ("CURSOR:VBARS:POSITION1 -0.0002", None),
            (f"CURSOR:VBARS:POSITION2 {stop_s:.9g}", None), ("MEASUREMENT:GATING CURSOR", None)]) as scope:
        scope.gate_whole_periods(37180.0, 4e-5, 500)


def test_averaging_and_single_sequence_acquisition():
    with expected_protocol(TDS3054B, CONNECT + [
            ("ACQUIRE:MODE AVERAGE", None), ("ACQUIRE:NUMAVG 16", None),
            ("ACQUIRE:STOPAFTER SEQUENCE;STATE RUN;*OPC?", "1")]) as scope:
        scope.set_averaging(16)
        scope.acquire_single(timeout_s=5.0)


def test_an_acquisition_that_never_completes_clears_the_late_reply():
    with expected_protocol(TDS3054B, CONNECT + [("ACQUIRE:STOPAFTER SEQUENCE;STATE RUN;*OPC?", TIMEOUT),
                                                (CLEAR, None)]) as scope:
        with pytest.raises(InstrumentTimeout, match="ACQUIRE:STATE RUN, then \\*OPC\\?"):
            scope.acquire_single(timeout_s=1.0)


def measure_script(source: str, kind: str, reply: str) -> list:
    """Source, type and value in one message (manual p. 2-4, concatenation rule 2)."""
    return [(f"MEASUREMENT:IMMED:SOURCE {source};TYPE {kind};VALUE?", reply)]


def test_a_measurement_in_full_spelling():
    with expected_protocol(TDS3054B, CONNECT + measure_script("MATH", "MEAN", "1.012E-1")) as scope:
        assert scope.measure("MATH", "MEAN") == pytest.approx(0.1012)


def test_a_measurement_without_value_names_the_scopes_reason():
    with expected_protocol(TDS3054B, CONNECT + measure_script("CH3", "FREQUENCY", "9.91E37") + [
            ("*ESR?", "16"), ("ALLEV?", '2225,"Measurement error, No waveform to measure; "')]) as scope:
        with pytest.raises(NoValidMeasurement, match="2225, Measurement error, No waveform to measure"):
            scope.measure(3, "FREQ")


def test_a_measurement_refused_for_clipping_is_a_clipped_trace():
    with expected_protocol(TDS3054B, CONNECT + measure_script("CH2", "MAXIMUM", "9.91E37") + [
            ("*ESR?", "16"), ("ALLEV?", '2228,"Measurement error, Positive Clipping; "')]) as scope:
        with pytest.raises(ClippedTraceError) as caught:
            scope.measure(2, "MAXIMUM")
    assert caught.value.channel == 2 and caught.value.clipped_fraction is None


def test_a_refused_command_is_never_hidden_behind_a_clipping():
    """ALLEV? drains every event: the refused CH3:SCALE is the error, with the clipping beside it."""
    with expected_protocol(TDS3054B, CONNECT + measure_script("CH3", "PK2PK", "9.9E37") + [
            ("*ESR?", "52"),
            ("ALLEV?", '222,"Data out of range; CH3:SCALE 1.33333333",2227,"Positive and Negative Clipping"')]) as scope:
        with pytest.raises(InstrumentError) as caught:
            scope.measure(3, "PK2PK")
    assert not isinstance(caught.value, ClippedTraceError) and caught.value.code == 222
    assert "CH3:SCALE" in str(caught.value) and "Clipping" in str(caught.value)


def test_other_events_drained_with_a_clipping_are_reported_with_it():
    with expected_protocol(TDS3054B, CONNECT + measure_script("CH2", "MAXIMUM", "9.91E37") + [
            ("*ESR?", "16"), ("ALLEV?", '2228,"Positive Clipping",2244,"Source waveform is not active"')]) as scope:
        with pytest.raises(ClippedTraceError) as caught:
            scope.measure(2, "MAXIMUM")
    assert "2244" in str(caught.value)


def test_six_extremes_go_in_one_message_and_a_clipped_one_is_none():
    """One message, six replies; the missing one (CH2's maximum) is asked again alone for
    its reason, a clipping: None there, the other five kept."""
    many = ("MEASUREMENT:IMMED:SOURCE CH1;TYPE MAXIMUM;VALUE?;SOURCE CH1;TYPE MINIMUM;VALUE?;"
            "SOURCE CH2;TYPE MAXIMUM;VALUE?;SOURCE CH2;TYPE MINIMUM;VALUE?;"
            "SOURCE CH3;TYPE MAXIMUM;VALUE?;SOURCE CH3;TYPE MINIMUM;VALUE?")
    with expected_protocol(TDS3054B, CONNECT + [
            (many, "1.5;-1.5;9.91E37;-2.0E-3;0.25;-0.24"),
            ("*ESR?", "16"), ("ALLEV?", '2228,"Measurement error, Positive Clipping; "'),
            *measure_script("CH2", "MAXIMUM", "9.91E37"),
            ("*ESR?", "16"), ("ALLEV?", '2228,"Measurement error, Positive Clipping; "')]) as scope:
        values = scope.measure_many([(c, k) for c in (1, 2, 3) for k in ("MAXIMUM", "MINIMUM")])
    assert values == [1.5, -1.5, None, -2.0e-3, 0.25, -0.24]


def test_a_refusal_among_several_missing_values_is_the_error():
    with expected_protocol(TDS3054B, CONNECT + [
            ("MEASUREMENT:IMMED:SOURCE CH1;TYPE MAXIMUM;VALUE?;SOURCE CH3;TYPE PK2PK;VALUE?", "9.9E37;9.9E37"),
            ("*ESR?", "52"), ("ALLEV?", '222,"Data out of range; CH3:SCALE 1.3",2227,"Clipping"')]) as scope:
        with pytest.raises(InstrumentError, match="MAXIMUM measurement of CH1, PK2PK measurement of CH3") as caught:
            scope.measure_many([(1, "MAXIMUM"), (3, "PK2")])
    assert caught.value.code == 222


def test_fewer_replies_than_measurements_are_garbled():
    with expected_protocol(TDS3054B, CONNECT + [
            ("MEASUREMENT:IMMED:SOURCE CH1;TYPE MAXIMUM;VALUE?;SOURCE CH1;TYPE MINIMUM;VALUE?", "1.5")]) as scope:
        with pytest.raises(GarbledReply, match="expected 2 values"):
            scope.measure_many([(1, "MAXIMUM"), (1, "MINIMUM")])


def test_the_acquisition_timeout_reads_its_three_settings_in_one_message():
    with expected_protocol(TDS3054B, CONNECT + [
            ("ACQUIRE:MODE?;NUMAVG?;:HORIZONTAL:MAIN:SCALE?", "AVERAGE;16;1.0E-4")]) as scope:
        assert scope.acquisition_timeout_s() == pytest.approx(5.0 + 16 * (10 * 1e-4 + 0.1))


FETCH_CH2 = "DATA:SOURCE CH2;ENCDG RIBINARY;WIDTH 2;START 1;STOP 10000;:ACQUIRE:MODE?;NUMAVG?;:WFMPRE?"


def fetch_script(reply_preamble: str, curve: bytes | None, acquisition: str = "AVERAGE;16") -> list:
    """Fetching CH2: the transfer set and the record described in one message, then the curve."""
    return [(FETCH_CH2, f"{acquisition};{reply_preamble}")] + ([("CURVE?", curve)] if curve is not None else [])


def test_fetch_waveform_scales_the_block_with_the_preamble():
    raw = np.array([-200, 0, 100, 300])
    with expected_protocol(TDS3054B, CONNECT + fetch_script(preamble(4), block(raw))) as scope:
        waveform = scope.fetch_waveform(2)
    assert waveform.values == pytest.approx(0.5 + 1.5625e-5 * (raw - 100.0))
    assert waveform.time_s == pytest.approx(-1e-3 + 2e-6 * np.arange(4))
    assert waveform.unit == "A" and waveform.averages == 16 and waveform.clipped_fraction == 0.0


def test_a_sample_mode_record_is_one_waveform_whatever_the_averaging_count():
    with expected_protocol(TDS3054B, CONNECT + fetch_script(preamble(4), block([1, 2, 3, 4]), "SAMPLE;16")) as scope:
        assert scope.fetch_waveform(2).averages == 1


def test_a_fetch_reply_without_its_three_parts_is_garbled():
    with expected_protocol(TDS3054B, CONNECT + [(FETCH_CH2, "AVERAGE;16")]) as scope:
        with pytest.raises(GarbledReply, match="the averaging count and the preamble"):
            scope.fetch_waveform(2)


def test_fetching_a_channel_that_is_not_displayed_says_so():
    with expected_protocol(TDS3054B, CONNECT + fetch_script("2;16;BIN;RI;MSB", None)) as scope:
        with pytest.raises(InstrumentError, match="CH2 is not displayed"):
            scope.fetch_waveform(2)


def test_a_clipped_record_is_refused():
    raw = np.array([0, 32640, 100, 32700])
    with expected_protocol(TDS3054B, CONNECT + fetch_script(preamble(4), block(raw))) as scope:
        with pytest.raises(ClippedTraceError, match="50 %"):
            scope.fetch_waveform(2)


def test_a_block_shorter_than_announced_is_garbled():
    with expected_protocol(TDS3054B, CONNECT + fetch_script(preamble(4), block([1, 2, 3]))) as scope:
        with pytest.raises(GarbledReply, match="announces 4 points"):
            scope.fetch_waveform(2)


def test_events_are_read_after_esr_and_reported_with_the_manuals_codes():
    with expected_protocol(TDS3054B, CONNECT + [
            ("*ESR?", "180"), ("ALLEV?", '401,"Power on; ",113,"Undefined header; MATH:DEFI ""CH1*CH2"""')]) as scope:
        with pytest.raises(InstrumentError) as caught:
            scope.check_errors()
    assert caught.value.code == 113 and caught.value.message.startswith("Undefined header; MATH:DEFI")


def test_no_events_is_no_error():
    with expected_protocol(TDS3054B, CONNECT + [("*ESR?", "0"),
                                                ("ALLEV?", '0,"No events to report - queue empty"')]) as scope:
        scope.check_errors()


def test_detected_probes_are_listed():
    script = CONNECT
    for n, model in ((1, ""), (2, "TCP202"), (3, ""), (4, "")):
        script = script + [(f"CH{n}:ID?", f'"{model}"')]
        if model:
            script = script + [(f"CH{n}:PROBE?", "1.0E0"), (f"CH{n}:YUNIT?", '"A"')]
    with expected_protocol(TDS3054B, script) as scope:
        assert scope.detected_probes() == {2: ("TCP202", 1.0, "A")}


@pytest.mark.parametrize("call", [lambda s: s.set_averaging(3), lambda s: s.set_record_length(1000),
                                  lambda s: s.channel(5), lambda s: s.measure("CH9", "MEAN")])
def test_out_of_range_is_refused_before_anything_is_sent(call):
    with expected_protocol(TDS3054B, CONNECT) as scope:
        with pytest.raises(OutOfRangeError):
            call(scope)


def test_replies_in_short_form_are_read_as_their_long_form():
    """A scope whose VERBose was left OFF answers minimum-length keywords (p. 2-308)
    until the connection's VERBOSE ON lands; either form reads the same."""
    with expected_protocol(TDS3054B, CONNECT + [("ACQUIRE:MODE?", "AVE"), ("MEASUREMENT:GATING?", "SCRE"),
                                                ("CH3:IMPEDANCE?", "FIF"), ("ACQUIRE:STOPAFTER?", "SEQ")]) as scope:
        assert (scope.acquire_mode, scope.measurement_gating) == ("AVERAGE", "SCREEN")
        assert scope.channel(3).impedance == "50Ohm" and scope.stop_after == "SEQUENCE"


def test_units_concatenate_as_the_manual_shows():
    """The TDS3000 manual's own examples (p. 2-4): another branch from the root with `:`, the
    same branch by its last mnemonic, a star command as it is, leaving the branch."""
    assert concatenated(["TRIGGER:MODE NORMAL", "ACQUIRE:NUMAVG 10"]) == "TRIGGER:MODE NORMAL;:ACQUIRE:NUMAVG 10"
    assert concatenated(["ACQUIRE:MODE ENVELOPE", "ACQUIRE:NUMAVG 8"]) == "ACQUIRE:MODE ENVELOPE;NUMAVG 8"
    assert concatenated(["ACQUIRE:MODE ENVELOPE", "*TRG", "ACQUIRE:NUMAVG 8"]) == "ACQUIRE:MODE ENVELOPE;*TRG;NUMAVG 8"
    assert concatenated(["ACQUIRE:MODE NORMAL", "ACQUIRE:NUMAVG?", "ACQUIRE:STATE?"]) == \
        "ACQUIRE:MODE NORMAL;NUMAVG?;STATE?"
    assert concatenated(["FREQ 100", "VOLT 1", "VOLT:OFFS 0"]) == "FREQ 100;VOLT 1;:VOLT:OFFS 0"


def test_measurements_in_one_message_are_those_asked_one_by_one_on_the_simulated_scope():
    from squeezebench import paths
    from squeezebench.protocols.acquisition import AcquisitionSettings
    from squeezebench.protocols.simulated_session import open_simulated

    with open_simulated(paths.default_scene(), None, 0.0) as session:
        session.drive.set_piezo_voltage(10.0)
        session.go_to_resonance()
        session.acquisition(AcquisitionSettings(averages=4, record_length=500)).measure(keep_waveforms=False)
        scope = session.bench.scope
        requests = [(c, k) for c in (1, 2, 3) for k in ("MAXIMUM", "MINIMUM")] + [("MATH", "MEAN"), (1, "FREQ")]
        together = scope.measure_many(requests)
        alone = [scope.measure(source, kind) for source, kind in requests]
    assert together == alone and None not in together


def test_three_scales_go_in_two_messages_after_their_probes():
    with expected_protocol(TDS3054B, CONNECT + [
            ("CH1:PROBE?;:CH2:PROBE?;:CH3:PROBE?", "0.1;1.0;1.0"),
            ("CH1:SCALE 2;:CH2:SCALE 0.005;:CH3:SCALE 0.5", None)]) as scope:
        scope.set_vertical_scales({1: 2.0, 2: 0.005, 3: 0.5})


def test_a_scale_beyond_its_probes_range_is_refused_before_any_is_set():
    """A 10:1 probe's finest scale is 10 mV/div: 5 mV/div on CH1 is refused, and no scale goes out."""
    with expected_protocol(TDS3054B, CONNECT + [("CH2:PROBE?;:CH1:PROBE?", "1.0;0.1")]) as scope:
        with pytest.raises(OutOfRangeError, match="scope.ch1.scale_v_per_div"):
            scope.set_vertical_scales({2: 0.005, 1: 0.005})
