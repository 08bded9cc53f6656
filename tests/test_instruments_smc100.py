"""SMC100 x-y stage driver, message for message against Newport's command grammar
(`<address><AA>[value|?]`, replies `<address><AA><value>`, the `TS` state word and the
`TE` error letter); independent of the simulator."""

from __future__ import annotations

import re

import pytest

from conftest import expected_protocol
from squeezebench.instruments.errors import GarbledReply, InstrumentError, OutOfRangeError
from squeezebench.instruments.smc100 import SMC100Stage, describe_errors, parse_state

#: Opening reads both axes' software limits: x 0..300 mm, y 0..200 mm.
OPEN = [("1SL?", "1SL0"), ("1SR?", "1SR300"), ("2SL?", "2SL0"), ("2SR?", "2SR200")]


def stage(script):
    return expected_protocol(SMC100Stage, OPEN + script, poll_interval_s=0.0)


def test_opening_reads_the_travel_of_each_axis():
    with stage([]) as smc:
        assert smc.travel_mm == {"x": (0.0, 300.0), "y": (0.0, 200.0)}


def test_identification_asks_both_controllers():
    with stage([("1VE", "1VE SMC_CC - Controller-driver version 2.0.0"),
                ("2VE", "2VE SMC_CC - Controller-driver version 2.0.0")]) as smc:
        assert "SMC" in smc.identify()


def test_homing_runs_OR_only_on_a_not_referenced_axis_and_waits_for_ready():
    script = [("1TS", "1TS00000A"), ("1OR", None), ("1TE", "1TE@"),
              ("1TS", "1TS00001E"), ("1TS", "1TS000032"),
              ("2TS", "2TS000033")]   # y already READY keeps its reference
    with stage(script) as smc:
        smc.home()


def test_a_move_waits_for_both_axes_and_returns_the_encoder_positions():
    script = [("1PA12.5", None), ("1TE", "1TE@"), ("2PA40", None), ("2TE", "2TE@"),
              ("1TS", "1TS000028"), ("1TS", "1TS000033"), ("2TS", "2TS000033"),
              ("1TP", "1TP12.50012"), ("2TP", "2TP39.99987")]
    with stage(script) as smc:
        assert smc.move_to_mm(12.5, 40.0) == (12.50012, 39.99987)


def test_a_point_beyond_travel_is_refused_before_anything_is_sent():
    with stage([]) as smc:
        with pytest.raises(OutOfRangeError, match=r"x = 12\.000 mm, y = 250\.000 mm.*y within the travel 0 to 200"):
            smc.move_to_mm(12.0, 250.0)


def test_a_following_error_is_reported_in_the_manuals_words():
    script = [("1PA10", None), ("1TE", "1TE@"), ("2PA10", None), ("2TE", "2TE@"),
              ("1TS", "1TS000028"), ("1TS", "1TS002028")]
    with stage(script) as smc:
        with pytest.raises(InstrumentError, match="x axis after '1PA10': following error"):
            smc.move_to_mm(10.0, 10.0)


def test_a_refused_move_names_the_te_letter():
    script = [("1PA10", None), ("1TE", "1TEH")]
    with stage(script) as smc:
        with pytest.raises(InstrumentError, match="refused '1PA10': H, command not allowed in NOT REFERENCED"):
            smc.move_to_mm(10.0, 10.0)


def test_a_disabled_axis_is_not_waited_for():
    with stage([("1TS", "1TS00000A"), ("1OR", None), ("1TE", "1TE@"), ("1TS", "1TS00003C")]) as smc:
        with pytest.raises(InstrumentError, match="controller state 3C, not READY"):
            smc.home()


def test_stop_is_sent_to_both_controllers():
    with stage([("1ST", None), ("2ST", None)]) as smc:
        smc.stop()


def test_parking_stops_then_moves_to_the_negative_limits_only_when_homed():
    homed = [("1ST", None), ("2ST", None), ("1TS", "1TS000033"), ("2TS", "2TS000033"),
             ("1PA0", None), ("1TE", "1TE@"), ("2PA0", None), ("2TE", "2TE@"),
             ("1TS", "1TS000033"), ("2TS", "2TS000033"), ("1TP", "1TP0"), ("2TP", "2TP0")]
    with stage(homed) as smc:
        smc.park()
    with stage([("1ST", None), ("2ST", None), ("1TS", "1TS00000A")]) as smc:
        smc.park()


def test_velocity_and_acceleration_are_read_and_set_with_the_te_check():
    script = [("1VA?", "1VA5"), ("2AC?", "2AC20"), ("1VA10", None), ("1TE", "1TE@")]
    with stage(script) as smc:
        assert smc.velocity_mm_per_s("x") == 5.0
        assert smc.acceleration_mm_per_s2("y") == 20.0
        smc.set_velocity_mm_per_s("x", 10.0)
        with pytest.raises(OutOfRangeError):
            smc.set_velocity_mm_per_s("x", 0.0)


def test_a_reply_from_the_wrong_controller_is_garbled():
    with stage([("1TP", "2TP5.0")]) as smc:
        with pytest.raises(GarbledReply, match="start with 1TP"):
            smc.position_mm("x")


def test_state_word_and_error_bits():
    assert parse_state("002033") == (0x0020, "33")
    assert describe_errors(0x0022) == ["positive end of run", "following error"]
    with pytest.raises(ValueError):
        parse_state("33")


#: Every driver action once, in the order a map uses them.
SESSION = OPEN + [("1VE", "1VE SMC_PP - Controller-driver version 3.0.0"),
                  ("2VE", "2VE SMC_PP - Controller-driver version 3.0.0"),
                  ("1TS", "1TS00000A"), ("1OR", None), ("1TE", "1TE@"), ("1TS", "1TS000032"),
                  ("2TS", "2TS00000A"), ("2OR", None), ("2TE", "2TE@"), ("2TS", "2TS000032"),
                  ("1VA?", "1VA5"), ("2AC?", "2AC20"), ("2VA2.5", None), ("2TE", "2TE@"),
                  ("1PA1.5", None), ("1TE", "1TE@"), ("2PA2", None), ("2TE", "2TE@"),
                  ("1TS", "1TS000033"), ("2TS", "2TS000033"), ("1TP", "1TP1.5"), ("2TP", "2TP2"),
                  ("1ST", None), ("2ST", None)]


def test_every_message_of_a_session_is_in_the_command_table():
    from test_instrument_commands import DOC, _pattern
    text = DOC.read_text(encoding="utf-8").split("## Newport SMC100", 1)[1].split("\n## ", 1)[0]
    forms = [re.compile(_pattern(m.group(1).replace("\\|", "|")))
             for m in re.finditer(r"^\| `(.+?)` \| SMC100 UM \w+ \|", text, flags=re.M)]
    assert len(forms) >= 12
    with expected_protocol(SMC100Stage, SESSION, poll_interval_s=0.0) as smc:
        smc.identify()
        smc.home()
        smc.velocity_mm_per_s("x"), smc.acceleration_mm_per_s2("y")
        smc.set_velocity_mm_per_s("y", 2.5)
        smc.move_to_mm(1.5, 2.0)
        smc.stop()
    undocumented = sorted({m for m, _ in SESSION if not any(f.match(m) for f in forms)})
    assert not undocumented, f"stage messages not in {DOC.name}: {undocumented}"
    assert not any(f.match("1PR5") for f in forms)   # a command the driver does not send is not listed
