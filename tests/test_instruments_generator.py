"""Agilent 33120A driver, byte for byte against the HP 33120A User's Guide (Chapter 4
command reference, Chapter 5 error messages): the exact messages sent and the replies
the instrument gives, independent of the simulator."""

from __future__ import annotations

import pytest

from conftest import CLEAR, TIMEOUT, expected_protocol
from squeezebench.instruments.agilent33120a import Agilent33120A
from squeezebench.instruments.errors import GarbledReply, InstrumentError, InstrumentTimeout, OutOfRangeError

CONNECT = [(CLEAR, None), ("VOLT:UNIT VPP", None), ("VOLT MIN", None), ("VOLT:OFFS 0", None),   # at rest first
           ("AM:STAT OFF", None), ("FM:STAT OFF", None), ("FSK:STAT OFF", None), ("BM:STAT OFF", None),
           ("SWE:STAT OFF", None)]
IDN = "HEWLETT-PACKARD,33120A,0,7.0-5.0-1.0"
LOAD_INF = ("OUTP:LOAD?", "+9.900000E+37")
LOAD_50 = ("OUTP:LOAD?", "+5.000000E+01")


def test_connect_and_identify():
    with expected_protocol(Agilent33120A, CONNECT + [("*IDN?", IDN)]) as generator:
        assert generator.identify() == IDN


def test_frequency_round_trip():
    with expected_protocol(Agilent33120A, CONNECT + [("FREQ 37180.25", None),
                                                     ("FREQ?", "+3.718025000000E+04")]) as generator:
        generator.frequency_hz = 37180.25
        assert generator.frequency_hz == 37180.25


@pytest.mark.parametrize("load, reply", [("50", "+5.000000E+01"), ("INF", "+9.900000E+37")])
def test_output_load_as_the_instrument_answers_it(load, reply):
    with expected_protocol(Agilent33120A, CONNECT + [(f"OUTP:LOAD {load}", None), ("OUTP:LOAD?", reply)]) as g:
        g.output_load = load
        assert g.output_load == load


def test_amplitude_is_checked_against_the_load_and_offset_it_reads():
    # into high impedance 20 Vpp is allowed with no offset; with 4 V of offset only 12 Vpp
    with expected_protocol(Agilent33120A, CONNECT + [LOAD_INF, ("VOLT:OFFS?", "+0.000000E+00"), ("VOLT 20", None),
                                                     LOAD_INF, ("VOLT:OFFS?", "+4.000000E+00")]) as generator:
        generator.amplitude_vpp = 20.0
        with pytest.raises(OutOfRangeError, match=r"generator.amplitude_vpp: 13.*0.1 to 12 Vpp"):
            generator.amplitude_vpp = 13.0


def test_apply_sine_sends_the_documented_commands():
    with expected_protocol(Agilent33120A, CONNECT + [
            LOAD_INF, ("VOLT:OFFS?", "+0.000000E+00"),
            ("FUNC:SHAP SIN", None), ("VOLT:UNIT VPP", None), ("FREQ 37180", None),
            ("VOLT:OFFS 0", None), ("VOLT 1.88", None)]) as generator:
        generator.apply_sine(37180.0, 1.88)


def test_apply_sine_raises_the_amplitude_before_a_larger_offset():
    with expected_protocol(Agilent33120A, CONNECT + [
            LOAD_50, ("VOLT:OFFS?", "+0.000000E+00"),
            ("FUNC:SHAP SIN", None), ("VOLT:UNIT VPP", None), ("FREQ 1000", None),
            ("VOLT 2", None), ("VOLT:OFFS 1", None)]) as generator:
        generator.apply_sine(1000.0, 2.0, offset_v=1.0)


@pytest.mark.parametrize("call, allowed", [
    (lambda g: setattr(g, "frequency_hz", 20e6), "0.0001 to 1.5e+07 Hz"),
    (lambda g: g.apply_sine(1000.0, 25.0), "0.1 to 20 Vpp"),
])
def test_out_of_range_is_refused_before_anything_is_sent(call, allowed):
    script = CONNECT + ([LOAD_INF] if "Vpp" in allowed else [])
    with expected_protocol(Agilent33120A, script) as generator:
        with pytest.raises(OutOfRangeError, match=allowed.replace("+", r"\+")):
            call(generator)


def test_output_to_minimum_is_the_loads_minimum():
    with expected_protocol(Agilent33120A, CONNECT + [LOAD_50, LOAD_50, ("VOLT:OFFS?", "+0.000000E+00"),
                                                     ("VOLT 0.05", None)]) as generator:
        generator.output_to_minimum()


def test_error_queue_is_drained_with_the_manuals_codes():
    with expected_protocol(Agilent33120A, CONNECT + [
            ("SYST:ERR?", '-113,"Undefined header"'), ("SYST:ERR?", '-222,"Data out of range;value clipped to '
                                                                     'upper limit"'),
            ("SYST:ERR?", '+0,"No error"')]) as generator:
        with pytest.raises(InstrumentError) as caught:
            generator.check_errors()
    assert caught.value.code == -113 and "Undefined header" in caught.value.message
    assert "-222" in caught.value.message


def test_empty_error_queue_is_no_error():
    with expected_protocol(Agilent33120A, CONNECT + [("SYST:ERR?", '+0,"No error"')]) as generator:
        assert generator.read_errors() == []


def test_garbled_reply_names_command_and_reply():
    with expected_protocol(Agilent33120A, CONNECT + [("FREQ?", "+3.7#@!")]) as generator:
        with pytest.raises(GarbledReply, match=r"FREQ\?"):
            generator.frequency_hz


def test_a_refused_query_is_a_timeout_naming_it():
    with expected_protocol(Agilent33120A, CONNECT + [("FREQ?", TIMEOUT)]) as generator:
        with pytest.raises(InstrumentTimeout, match=r"FREQ\?"):
            generator.frequency_hz
