"""The simulated instruments obey their manuals, whoever talks to them: power-on state,
long and short forms, refusals with the manual's code, and the state rules that matter
for a measurement (raw PyVISA messages, no driver)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import pyvisa
from hypothesis import given
from hypothesis import strategies as st

from squeezebench import paths
from squeezebench.simbench import effects as fx
from squeezebench.simbench import scpi, traces
from squeezebench.simbench.generator import modulated

_TOKENS = itertools.count()
TERMINATIONS = {"read_termination": "\n", "write_termination": "\n"}


@pytest.fixture
def bench():
    rm = pyvisa.ResourceManager(f"{paths.default_scene()}#raw{next(_TOKENS)}@simbench")
    resources = {role: rm.open_resource(address, **TERMINATIONS) for role, address in
                 (("generator", "GPIB0::10::INSTR"), ("scope", "TCPIP0::192.168.0.20::INSTR"),
                  ("vibrometer", "ASRL1::INSTR"))}
    for resource in resources.values():
        resource.timeout = 200
    yield resources
    rm.close()


def refused(resource, query: str) -> None:
    with pytest.raises(pyvisa.VisaIOError) as caught:
        resource.query(query)
    assert caught.value.error_code == pyvisa.constants.StatusCode.error_timeout


# -- HP 33120A ----------------------------------------------------------------------------------
def test_generator_powers_on_as_its_guide_says(bench):
    g = bench["generator"]
    assert g.query("*IDN?").startswith("HEWLETT-PACKARD,33120A")
    assert [g.query(q) for q in ("FUNC:SHAP?", "FREQ?", "VOLT?", "VOLT:OFFS?", "VOLT:UNIT?", "OUTP:LOAD?")] == \
        ["SIN", "+1.000000000000E+03", "+1.000000E-01", "+0.000000E+00", "VPP", "+5.000000E+01"]
    assert g.query("SYST:ERR?") == '+0,"No error"'


def test_generator_accepts_short_and_long_forms_units_min_max(bench):
    g = bench["generator"]
    g.write("frequency 2.5 KHZ;:FUNCTION:SHAPE SQUARE;:VOLTage:UNIT vrms")
    assert g.query("FREQ?;:FUNC:SHAP?;:VOLT:UNIT?") == "+2.500000000000E+03;SQU;VRMS"
    g.write("FREQ MAX")
    assert float(g.query("FREQuency?")) == 15e6 and float(g.query("FREQ? MIN")) == 100e-6
    g.write("VOLT:UNIT VPP;:OUTP:LOAD INF")
    assert float(g.query("VOLT?")) == pytest.approx(0.2)   # the output stays: 100 mVpp into 50 ohm shows 200
    assert g.query("SYST:ERR?") == '+0,"No error"'


@pytest.mark.parametrize("message, code, text", [
    ("FREQU 1000", -113, "Undefined header"),          # neither the short nor the long form
    ("MATH:DEFI 3", -113, "Undefined header"),
    ("FREQ 20 MHZ", -222, "Data out of range;value clipped to upper limit"),
    ("FREQ 1 VOLT", -131, "Invalid suffix"),
    ("FUNC:SHAP PULSE", -224, "Illegal parameter value"),
    ("OUTP:LOAD 75", -224, "Illegal parameter value"),
    ("FREQ", -109, "Missing parameter"),
])
def test_generator_reports_refusals_in_its_error_queue(bench, message, code, text):
    g = bench["generator"]
    g.write(message)
    assert g.query("SYST:ERR?") == f'{code},"{text}"'
    assert g.query("SYST:ERR?") == '+0,"No error"'


def test_generator_answers_nothing_to_a_query_it_refuses(bench):
    g = bench["generator"]
    refused(g, "FREQUENC?")
    assert g.query("SYST:ERR?") == '-113,"Undefined header"'
    assert g.query("SYST:ERR?") == '-420,"Query UNTERMINATED"'   # the read found nothing



def test_generator_runs_one_modulation_at_a_time(bench):
    g = bench["generator"]
    assert [g.query(f"{m}:STAT?") for m in ("AM", "FM", "FSK", "BM", "SWE")] == ["0"] * 5
    g.write("AM:STAT ON")
    g.write("SWEEP:STATE ON")   # turning one on turns the one before off
    assert [g.query(f"{m}:STAT?") for m in ("AM", "FM", "FSKEY", "BM", "SWE")] == ["0", "0", "0", "0", "1"]
    g.write("SWE:STAT OFF")
    assert g.query("SWE:STAT?") == "0" and g.query("SYST:ERR?") == '+0,"No error"'


def test_a_modulation_left_on_is_not_the_sine_a_point_assumes():
    """Closed forms of generator.modulated: AM at 100 % depth averages half the amplitude
    over its 10 ms period, FM stays within its 100 Hz deviation, a one-cycle burst every
    10 ms drives a 37 kHz plate with 1/370 of its amplitude, a sweep never reaches it."""
    times_s = np.linspace(0.0, 0.1, 2001)[:-1]
    am = [modulated("AM", 37e3, 10.0, t)[1] for t in times_s]
    assert np.mean(am) == pytest.approx(5.0, rel=1e-6) and max(am) <= 10.0
    fm = [modulated("FM", 37e3, 10.0, t)[0] for t in times_s]
    assert min(fm) >= 37e3 - 100.0 and max(fm) <= 37e3 + 100.0 and np.ptp(fm) > 190.0
    assert modulated("BM", 37e3, 10.0, 0.0)[1] == pytest.approx(10.0 / 370.0)
    assert max(modulated("SWE", 37e3, 10.0, t)[0] for t in times_s) <= 1e3

# -- Tektronix TDS 3054B ------------------------------------------------------------------------
def test_scope_powers_on_as_appendix_d_says(bench):
    s = bench["scope"]
    assert s.query("HEADER?") == ":HEADER 1"
    s.write("HEADER OFF")
    assert s.query("*ESR?") == "128" and s.query("ALLEV?") == '401,"Power on"'
    answers = [s.query(q) for q in ("SELECT:CH1?", "SELECT:CH2?", "SELECT:MATH?", "HORIZONTAL:RECORDLENGTH?",
                                    "ACQUIRE:MODE?", "ACQUIRE:NUMAVG?", "TRIGGER:A:EDGE:SOURCE?", "TRIGGER:A:MODE?",
                                    "MATH:DEFINE?", "CH1:SCALE?", "CH3:PROBE?", "CH2:ID?", "CH2:YUNIT?")]
    assert answers == ["1", "0", "0", "10000", "SAMPLE", "16", "CH1", "AUTO", '"CH1+CH2"', "1.0000E-1", "1.0000E-1",
                       '"TCP202"', '"A"']


def test_scope_accepts_any_abbreviation_from_the_capitals_and_compound_messages(bench):
    s = bench["scope"]
    s.write("head off;*CLS;acq:numav 4;MODE AVERAGE;:horizontal:recordl 500;:ch2:scale 0.5;POSITION 1")
    assert s.query("ACQUIRE:NUMAVG?;MODE?;:HOR:RECORDLENGTH?") == "4;AVERAGE;500"
    assert s.query("CH2:SCALE?;POSITION?;:CH1:POSITION?") == "5.0000E-1;1.0000E+0;0.0000E+0"
    assert s.query("*ESR?") == "0"


@pytest.mark.parametrize("message", ['MATH:DEFI "CH1*CH2"', "HOR:RECO 500", "ACQ:NUMAVG 4;NUMAV 8;:FOO 1",
                                     "CH5:SCALE 1"])
def test_scope_reports_an_undefined_header_as_event_113(bench, message):
    s = bench["scope"]
    s.write("HEADER OFF;*CLS")
    s.write(message)
    assert int(s.query("*ESR?")) & 32   # CME
    assert s.query("EVMSG?").startswith('113,"Undefined header; ')


def test_scope_refused_query_returns_nothing_and_queues_why(bench):
    s = bench["scope"]
    s.write("HEADER OFF;*CLS")
    refused(s, "HOR:RECO?")
    assert s.query("*ESR?") == str(32 + 4)
    assert s.query("ALLEV?") == '113,"Undefined header; HOR:RECO?",420,"Query UNTERMINATED"'


def test_a_detected_probe_fixes_the_channels_gain(bench):
    s = bench["scope"]
    s.write("HEADER OFF;*CLS;:CH2:PROBE 0.1")
    assert s.query("*ESR?") == "16" and s.query("EVMSG?") == '242,"Hardware configuration error; :CH2:PROBE 0.1"'
    assert s.query("CH2:PROBE?") == "1.0000E+0"


def setup(s, *, select="ON", trigger="CH1", mode="AUTO", averages=16):
    s.write(f"HEADER OFF;*CLS;:SELECT:CH1 {select};CH2 {select};CH3 {select};:SELECT:MATH {select}")
    s.write(f"TRIGGER:A:EDGE:SOURCE {trigger};:TRIGGER:A:MODE {mode};:HORIZONTAL:RECORDLENGTH 500")
    s.write(f"ACQUIRE:MODE AVERAGE;NUMAVG {averages};STOPAFTER SEQUENCE;:MATH:TYPE DUAL;DEFINE \"CH1*CH2\"")
    s.write("CH1:PROBE 0.01;SCALE 10;:CH2:SCALE 0.01;:CH3:PROBE 1;SCALE 2")   # 37.6 Vpp, 45 mApp, 7.5 Vpp
    s.timeout = 5000


def drive(bench):
    bench["generator"].write("OUTP:LOAD INF;:FREQ 37180;VOLT 1.88")


def measure(s, source: str, kind: str) -> float:
    return float(s.query(f"MEASUREMENT:IMMED:SOURCE {source};TYPE {kind};VALUE?"))


def test_a_channel_that_is_not_displayed_has_no_measurement_nor_record(bench):
    s = bench["scope"]
    drive(bench)
    setup(s, select="OFF")
    s.write("ACQUIRE:STATE RUN")
    assert s.query("*OPC?") == "1"
    assert measure(s, "CH3", "MAXIMUM") == 9.91e37
    assert s.query("*ESR?") == "16" and s.query("ALLEV?").startswith('2225,"Measurement error, No waveform')
    s.write("DATA:SOURCE CH3")
    assert s.query("WFMPRE?").split(";") == ["1", "8", "BIN", "RI", "MSB"]   # transmission fields only
    s.timeout = 200
    refused(s, "CURVE?")
    assert s.query("*ESR?") == str(16 + 4)
    assert s.query("ALLEV?").startswith('2244,"Waveform requested is not turned on')


def test_a_transfer_stopping_beyond_the_record_sends_the_whole_record(bench):
    """p. 2-96: DATa:STOP above the record length transfers up to it (the driver's fetch
    relies on it rather than asking the record length first)."""
    s = bench["scope"]
    drive(bench)
    setup(s)
    s.write("ACQUIRE:STATE RUN")
    s.query("*OPC?")
    s.write("DATA:SOURCE CH1;ENCDG RIBINARY;WIDTH 2;START 1;STOP 10000")
    assert s.query("WFMPRE?").split(";")[5] == "500"   # NR_PT
    assert s.query_binary_values("CURVE?", datatype="h", is_big_endian=True, container=np.array).size == 500


def test_math_exists_only_in_the_mode_it_was_defined_in(bench):
    s = bench["scope"]
    drive(bench)
    setup(s)
    s.write("ACQUIRE:STATE RUN")
    s.query("*OPC?")
    power_w = measure(s, "MATH", "MEAN")
    assert 0 < power_w < 1
    s.write("MATH:TYPE FFT")
    assert measure(s, "MATH", "MEAN") == 9.91e37
    s.write('MATH:TYPE DUAL;DEFINE "CH1+CH2"')
    assert measure(s, "MATH", "MEAN") != pytest.approx(power_w, rel=0.1)


def test_extreme_measurements_are_the_records_extremes_in_every_math_definition_and_gate(bench):
    """The extremes a record's trigger, clipping check and measurements share are its own:
    MAXIMUM, MINIMUM, PK2 of a channel and of MATH as defined now (a redefinition between
    two queries of one record is read anew), over the record and within a cursor gate,
    equal the transferred trace's, and a second acquisition's are its own."""
    s = bench["scope"]
    drive(bench)
    setup(s)

    def transferred(source: str) -> np.ndarray:
        s.write(f"DATA:SOURCE {source};ENCDG RIBINARY;WIDTH 2;START 1;STOP 500")
        preamble = s.query("WFMPRE?").split(";")   # YMULT, YZERO, YOFF: fields 13 to 15
        y_mult, y_zero, y_off = (float(field) for field in preamble[12:15])
        counts = s.query_binary_values("CURVE?", datatype="h", is_big_endian=True, container=np.array)
        return (counts - y_off) * y_mult + y_zero

    # the cursor gate: the record's first half (500 samples over 10 divisions, trigger centred)
    record_s = 10.0 * float(s.query("HORIZONTAL:MAIN:SCALE?"))
    s.write(f"CURSOR:FUNCTION VBARS;VBARS:POSITION1 {-record_s / 2.0!r};POSITION2 {-record_s / 1000.0 * 1.5!r}")
    readings = []
    for _ in range(2):
        s.write("ACQUIRE:STATE RUN")
        s.query("*OPC?")
        for define in ("CH1*CH2", "CH1-CH2"):
            s.write(f'MATH:DEFINE "{define}"')
            for source in ("CH3", "MATH"):
                for gating, gated in (("OFF", slice(None)), ("CURSOR", slice(0, 250))):
                    s.write(f"MEASUREMENT:GATING {gating}")
                    trace = transferred(source)[gated]
                    high, low, pp = (measure(s, source, kind) for kind in ("MAXIMUM", "MINIMUM", "PK2"))
                    # to the transfer's resolution (16-bit counts of the same values)
                    step = (trace.max() - trace.min()) / 2**14
                    assert high == pytest.approx(trace.max(), abs=step) and low == pytest.approx(trace.min(), abs=step)
                    assert pp == pytest.approx(high - low, rel=1e-11)   # replies carry 13 digits
                    readings.append((high, low))
    assert readings[2] != readings[6]   # MATH redefined: CH1*CH2 and CH1-CH2 differ
    assert readings[:8] != readings[8:]   # the second acquisition drew noise of its own


def test_averaging_needs_the_trigger_on_the_driven_signal(bench):
    s = bench["scope"]
    drive(bench)
    setup(s, trigger="CH4")
    s.write("ACQUIRE:STATE RUN")
    s.query("*OPC?")
    untriggered = measure(s, "CH1", "PK2PK")
    setup(s, trigger="CH1")
    s.write("ACQUIRE:STATE RUN")
    s.query("*OPC?")
    triggered = measure(s, "CH1", "PK2PK")
    assert untriggered < 0.6 * triggered   # 16 random phases average the sine away
    setup(s, trigger="CH4", mode="NORMAL")
    s.write("ACQUIRE:STATE RUN")
    s.timeout = 2000
    refused(s, "*OPC?")                    # no trigger ever comes


def test_a_clipped_channel_has_no_measurement(bench):
    s = bench["scope"]
    drive(bench)
    setup(s)
    s.write("CH1:PROBE 0.01;SCALE 0.5;:ACQUIRE:STATE RUN")   # 37.6 Vpp on 4 V of screen
    s.query("*OPC?")
    assert measure(s, "CH1", "MAXIMUM") == 9.91e37
    assert s.query("*ESR?") == "16"
    assert s.query("ALLEV?").startswith('2227,"Positive and Negative Clipping')


@given(st.lists(st.floats(-1.2, 1.2), min_size=1, max_size=40), st.floats(1e-3, 1e3), st.floats(-5.0, 5.0),
       st.floats(-2.0, 2.0), st.sampled_from([0.0, 1e-9, 1e-12, 2e-16]))
def test_clipping_is_read_from_the_extremes_as_from_every_sample(fractions, scale, position_div, offset, nudge_div):
    """`traces.reaches_limits` places the trace's two extremes (`extremes_of`) on the screen: the same
    verdict as placing every sample (a position rises with the value), for samples on, just
    inside and just past the ADC limits' tolerance."""
    edges = [fx.ADC_MAX_DIV - nudge_div, fx.ADC_MIN_DIV + nudge_div]
    divisions = np.array([f * fx.ADC_MAX_DIV for f in fractions] + edges[:len(fractions) % 3])
    trace = (divisions - position_div) * scale + offset * scale
    screen = (trace - offset * scale) / scale + position_div
    every_sample = (bool(np.any(screen >= fx.ADC_MAX_DIV - 1e-9)), bool(np.any(screen <= fx.ADC_MIN_DIV + 1e-9)))
    assert traces.reaches_limits(traces.extremes_of(trace), offset * scale, scale, position_div) == every_sample


def test_reset_restores_appendix_d_but_keeps_the_event_queue(bench):
    s = bench["scope"]
    s.write("HEADER OFF;:SELECT:CH1 OFF;:FOO;*RST")
    assert s.query("SELECT:CH1?") == "1" and s.query("*ESR?") == str(128 + 32)


# -- Polytec OFV-5000 -----------------------------------------------------------------------------
def test_controller_powers_on_with_echo(bench):
    v = bench["vibrometer"]
    assert v.query("GetDevInfo,Controller,0,Name") == "GetDevInfo,Controller,0,Name"   # the echo first
    assert v.read() == "OFV-5000"
    v.write("Set,Interface,0,Echo,Off")
    assert v.read() == "Set,Interface,0,Echo,Off"
    assert v.query("Get,Interface,0,Echo") == "Off"


def test_controller_lists_its_decoders_ranges_in_its_own_spelling(bench):
    v = bench["vibrometer"]
    v.write("Set,Interface,0,Echo,Off")
    v.read()
    assert v.query("Get,VeloDec,0,Name") == "VD-09"
    ranges = v.query("GetDevInfo,VeloDec,0,Range").split(",")
    assert "25mm/s/V" not in ranges and ranges[0] == "5mm/s/V"
    for line in ("Set,VeloDec,0,Range,25mm/s/V", "Set,VeloFilter,0,LowPassRange,100kHz", "Get,VeloDec,3,Range",
                 "get,velodec,0,range", "Set,VeloDec,0,Range"):
        assert v.query(line) == "Error"
    v.write("Set,VeloFilter,0,LowPassRange,100 kHz")
    assert v.query("Get,VeloFilter,0,LowPassRange") == "100 kHz"


def test_another_decoder_lists_other_ranges():
    rm = pyvisa.ResourceManager(f"{paths.default_scene()}#raw{next(_TOKENS)}#decoder=VD-02@simbench")
    v = rm.open_resource("ASRL1::INSTR", **TERMINATIONS)
    v.write("Set,Interface,0,Echo,Off")
    v.read()
    assert v.query("GetDevInfo,VeloDec,0,Range") == "5mm/s/V,25mm/s/V,125mm/s/V,1000mm/s/V"
    rm.close()


def test_parser_rules():
    tree = scpi.HeaderTree(scpi.SCPI)
    tree.add("[SOURce:]FREQuency")
    tree.add("VOLTage[:LEVel]")
    tree.add("VOLTage:OFFSet")
    units = list(scpi.MessageParser(tree).units('sour:freq 1;:VOLT:LEV 2;OFFS 3;:volt:offset 4, 5;FREQ 6;:FREQ "a;b"'))
    assert [(u.path, u.arguments) for u in units[:4]] == [
        ("FREQUENCY", ("1",)), ("VOLTAGE", ("2",)), ("VOLTAGE:OFFSET", ("3",)), ("VOLTAGE:OFFSET", ("4", "5"))]
    assert isinstance(units[4], scpi.ScpiError) and units[4].code == -113   # FREQ is not under VOLTage
    assert (units[5].path, units[5].arguments) == ("FREQUENCY", ('"a;b"',))


def test_scope_replies_in_short_form_with_verbose_off(bench):
    """VERBose OFF (p. 2-308): keywords in replies, header included, in short form."""
    s = bench["scope"]
    s.write("ACQUIRE:MODE AVERAGE;:MEASUREMENT:GATING SCREEN;:VERBOSE OFF")
    assert s.query("ACQUIRE:MODE?") == ":ACQ:MOD AVE"
    s.write("HEADER OFF")
    assert [s.query(q) for q in ("ACQUIRE:MODE?", "MEASUREMENT:GATING?", "CH1:BANDWIDTH?", "VERBOSE?")] == \
        ["AVE", "SCRE", "FUL", "0"]
    s.write("VERBOSE ON")
    assert s.query("ACQUIRE:MODE?") == "AVERAGE"


def _curve_values(s, source: str) -> np.ndarray:
    """CURVE? of `source` in its units, through the preamble's YMULT, YZERO and YOFF."""
    s.write(f"DATA:SOURCE {source};ENCDG RIBINARY;WIDTH 2;START 1;STOP 500")
    fields = s.query("WFMPRE?").split(";")
    y_mult, y_zero, y_off = float(fields[12]), float(fields[13]), float(fields[14])
    raw = s.query_binary_values("CURVE?", datatype="h", is_big_endian=True, container=np.array)
    return y_zero + y_mult * (raw - y_off)


def test_a_channel_offset_moves_the_trace_on_screen_not_the_values(bench):
    """CH<x>:OFFSet (p. 2-67) is subtracted before the ADC and given back as YZEro: the
    record reads the same, the screen (and what clips) moves; the range follows Table 2-30."""
    s = bench["scope"]
    drive(bench)
    setup(s)
    s.write("ACQUIRE:STATE RUN")
    s.query("*OPC?")
    plain = _curve_values(s, "CH1")
    s.write("CH1:OFFSET 10;:ACQUIRE:STATE RUN")   # one division of 10 V/div
    s.query("*OPC?")
    np.testing.assert_allclose(_curve_values(s, "CH1"), plain, atol=10.0 / 25.0 * 2)
    s.write("CH1:OFFSET 40;:ACQUIRE:STATE RUN")   # the sine's troughs below the screen
    s.query("*OPC?")
    assert measure(s, "CH1", "MAXIMUM") == 9.91e37
    assert s.query("*ESR?") == "16" and "Negative Clipping" in s.query("ALLEV?")
    s.write("CH1:OFFSET 5000")   # beyond +-1000 V: 100 V at the 1x input of a 100:1 probe
    assert float(s.query("CH1:OFFSET?")) == 1000.0
    assert s.query("*ESR?") == "16" and s.query("ALLEV?") == '526,"Parameter overrange"'


def test_a_50_ohm_input_halves_a_50_ohm_source_and_silences_a_passive_probe(bench):
    s = bench["scope"]
    drive(bench)
    setup(s)
    s.write("CH3:SCALE 0.05;:ACQUIRE:STATE RUN")
    s.query("*OPC?")
    velocity_v, piezo_v = measure(s, "CH3", "PK2PK"), measure(s, "CH1", "PK2PK")
    s.write("CH3:IMPEDANCE FIFTY;:CH1:IMPEDANCE FIFTY;:ACQUIRE:STATE RUN")
    s.query("*OPC?")
    assert measure(s, "CH3", "PK2PK") == pytest.approx(velocity_v / 2.0, rel=0.02)
    assert measure(s, "CH1", "PK2PK") < 0.01 * piezo_v   # what is left is a few ADC steps


@given(st.text(alphabet="ABDEGIMNORSTUVXaegimnorstuvx :", max_size=12),
       st.sampled_from([scpi.SCPI, scpi.PREFIX]))
def test_a_settings_choice_table_accepts_and_refuses_what_choice_does(text, style):
    """`scpi.Choices` (a setting handler's table, remembering the words it accepted) answers
    every word as `scpi.choice` does, the second time too, and refuses the same ones."""
    options = {"AVErage": "AVERAGE", "SAMple": "SAMPLE", "ENVelope": "ENVELOPE", "MINimum": "MINIMUM"}
    table = scpi.Choices(options, style)
    try:
        expected = scpi.choice(text, options, style)
    except scpi.ScpiError as exc:
        for _ in range(2):
            with pytest.raises(scpi.ScpiError) as refused:
                table(text)
            assert refused.value.code == exc.code
    else:
        assert table(text) == expected == table(text)
