"""Every header of each simulated instrument's command summary (simbench/commands/*.tsv),
as a client following the manual may send it: long and short form, with and without its
optional nodes, MINimum/MAXimum/DEFault where the summary allows them. Each is accepted
(no command error) and each query answers. Also: the coverage section of
docs/instrument-commands.md is the one the tables and the simulator give."""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import pytest

from squeezebench.simbench import command_coverage, scpi, state_only
from squeezebench.simbench.command_tables import TABLE_OF_ROLE, Entry, table
from squeezebench.simbench.scpi_device import recorded_refusals
from test_sim_support import RawBench, scene_file

DOC = Path(__file__).resolve().parents[1] / "docs" / "instrument-commands.md"


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    raw = RawBench(scene_file(tmp_path_factory.mktemp("commands")))
    yield raw.sim
    raw.close()


def spellings(header: str) -> set[str]:
    """The header in long and in short form, with every optional node and with none;
    suffixes as 1."""
    if header.startswith("*"):
        return {header.upper(), header.lower()}
    parts = scpi.parse_spec(header, (1,))
    out = set()
    for keep_optional, form in itertools.product((True, False), ("long", "short")):
        out.add(":".join(p.long + "1" if p.suffixes else getattr(p, form)
                         for p in parts if keep_optional or not p.optional))
    return out


def sample(arguments: str) -> str:
    """An argument list the syntax allows, optional ones included: the first alternative,
    1 for a number, "A" for a string, a path or a name."""
    text = arguments.replace("<Comma>", ",").replace("...", "").replace("[", "").replace("]", "")
    text = re.sub(r"<[xn]>", "1", text).replace("<wfm>", "CH1")
    text = re.sub(r"\{([^{}|]*)\|?[^{}]*\}", r"\1", text)
    parts = [part.split("|")[0].strip() for part in text.split(",")]
    parts = [re.sub(r"<[^<>]*(string|path|name)[^<>]*>", '"A"', p, flags=re.IGNORECASE) for p in parts if p]
    return ",".join(re.sub(r"<[^<>]*>", "1", p) for p in parts)


def scpi_messages(entry: Entry) -> list[tuple[str, bool]]:
    """(message, is a query) for each spelling and form of a SCPI summary row."""
    argument = state_only.argument(entry.arguments)
    value = sample(entry.arguments)
    if entry.limits and argument.number and not argument.free:
        value = repr(entry.limits[0])
    messages = []
    for header in sorted(spellings(entry.header)):
        if entry.settable:
            messages.append((f"{header} {value}".strip(), False))
        if entry.queryable:
            messages.append((f"{header}? {value if not entry.settable else ''}".strip(), True))
    for word in ("MIN", "MAX", "DEF"):   # where the summary allows the word
        long = {"MIN": "MINimum", "MAX": "MAXimum", "DEF": "DEFault"}[word]
        if long in entry.arguments and argument.number:
            messages.append((f"{entry.header.replace('[SOURce:]', '')} {word}", False))
            if entry.queryable and word != "DEF":
                messages.append((f"{entry.header.replace('[SOURce:]', '')}? {word}", True))
    return messages


@pytest.mark.parametrize("role", ["generator", "scope"])
def test_every_header_of_the_scpi_summaries_is_accepted_and_every_query_answers(sim, role):
    instrument = getattr(sim, role)
    silent, refused = [], []
    with recorded_refusals() as refusals:
        for entry in table(TABLE_OF_ROLE[role]):
            for message, query in scpi_messages(entry):
                before = len(refusals)
                replies = instrument.handle(message.encode())
                instrument._replies.clear()
                refused += [(message, r) for r in refusals[before:] if re.match(r"\w+: -?1\d\d ", r)]
                if query and not replies:
                    silent.append(message)
    assert not refused, f"command errors: {refused[:10]}"
    assert not silent, f"queries without a reply: {silent[:10]}"


def test_the_state_only_headers_read_back_what_was_set(sim):
    """State only: stored and read back in the manual's reply format, MIN/MAX from the
    limits, per suffix (two TDS channels do not share a setting)."""
    generator, scope = sim.generator, sim.scope
    assert generator.handle(b"BM:NCYC 25;:SOURCE:BM:NCYCLES?") == [b"+2.500000E+01"]
    assert generator.handle(b"BM:NCYC MAX;NCYC?;NCYC? MIN") == [b"+5.000000E+04;+1.000000E+00"]
    assert generator.handle(b"FSK:SOUR EXT;SOUR?;:SWE:SPAC LOG;SPAC?") == [b"EXT;LOG"]
    assert generator.handle(b'DISP:TEXT "HI";TEXT?') == [b'"HI"']
    assert generator.handle(b"SYST:ERR?") == [b'+0,"No error"']
    generator.handle(b"AM:DEPT 500")   # beyond the limit: clipped, as the modelled numbers are
    clipped = b'-222,"Data out of range;value clipped to upper limit"'
    assert generator.handle(b"AM:DEPT?;:SYST:ERR?") == [b"+1.200000E+02;" + clipped]
    generator.handle(b"*RST")
    assert generator.handle(b"BM:NCYC?;:FSK:SOUR?") == [b"+1.000000E+00;INT"]
    scope.handle(b"HEADER OFF;VERBOSE ON;CH1:INVERT ON;:CH2:INVERT OFF;:MASK:POLARITY NEGA")
    assert scope.handle(b"CH1:INVERT?;:CH2:INV?;:MASK:POL?") == [b"1;0;NEGATIVE"]
    assert scope.handle(b"VERBOSE OFF;:MASK:POL?;:VERBOSE ON") == [b"NEGA"]


def test_a_group_query_answers_its_settings_as_the_manual_shows(sim):
    """TDS PM p. 2-45: ACQuire? answers the acquisition settings, each with its header."""
    scope = sim.scope
    scope.handle(b"HEADER ON;:ACQUIRE:MODE AVERAGE;NUMAVG 64")
    reply = scope.handle(b"ACQUIRE?")[0].decode()
    assert ":ACQUIRE:MODE AVERAGE" in reply and ":ACQUIRE:NUMAVG 64" in reply
    scope.handle(b"HEADER OFF;:ACQUIRE:MODE SAMPLE")


@pytest.fixture
def vibrometer(sim):
    vibrometer = sim.vibrometer
    vibrometer.handle(b"Set,Interface,0,Echo,Off")
    return vibrometer


def test_every_line_of_the_ofv5000_command_set_is_accepted_and_every_get_answers(vibrometer):
    failures = []
    for entry in table(TABLE_OF_ROLE["vibrometer"]):
        for verb in sorted(entry.forms, reverse=True):   # Set before GetDevInfo and Get
            line = f"{verb},{entry.header}"
            if verb == "Set":
                value = entry.arguments.split("|")[0].split("..")[0] if entry.arguments else None
                value = vibrometer.handle(f"Get,{entry.header}".encode())[-1].decode() if value is None else value
                line += f",{value}"
            replies = [r for r in vibrometer.handle(line.encode()) if r != line.encode()]   # echo (on or off)
            if b"Error" in replies or (verb != "Set") != bool(replies):
                failures.append((line, replies))
    vibrometer.handle(b"Set,Interface,0,Echo,Off")
    assert not failures
    assert vibrometer.handle(b"Set,SensorHead,0,AutoFocusSpan,Small") == []
    assert vibrometer.handle(b"Get,SensorHead,0,AutoFocusSpan") == [b"Small"]
    assert vibrometer.handle(b"Set,SensorHead,0,AutoFocusSpan,Huge") == [b"Error"]


def test_every_smc100_command_is_accepted_and_every_query_answers(sim):
    """Homed first (a move needs READY); a command is refused only for the controller's
    state (TE letters other than A, unknown, and C, a parameter missing or out of range)."""
    stage = sim.stage
    stage.handle(b"1OR")
    sim.clock.advance(100.0)
    failures = []
    for entry in table(TABLE_OF_ROLE["stage"]):
        code = entry.header
        messages = []
        if entry.queryable:
            messages.append((f"1{code}?", True))
        if "report" in entry.forms:
            messages.append((f"1{code}", True))
        if entry.settable:
            value = ""
            if entry.arguments:
                read = stage.handle(f"1{code}?".encode()) if entry.queryable else []
                value = read[0].decode().strip()[3:] if read else "0"
            messages.append((f"1{code}{value}", code == "PT"))
        for message, answers in messages:
            replies = stage.handle(message.encode())
            error = stage.handle(b"1TE")[0].decode().strip()[3:]
            if error in ("A", "C") or answers != bool(replies):
                failures.append((message, replies, error))
        sim.clock.advance(100.0)
    assert not failures


def test_the_coverage_section_of_the_commands_page_is_current():
    assert command_coverage.markdown() in DOC.read_text(encoding="utf-8"), (
        "docs/instrument-commands.md is stale: python -m squeezebench.simbench.command_coverage "
        "docs/instrument-commands.md")
    assert all(c.accepted == c.headers for c in command_coverage.coverages())


def test_wavfrm_is_the_preamble_then_the_curve_each_with_one_header(sim):
    """TDS PM p. 2-309: WAVFrm? answers as WFMPre?;CURVe? does (the preamble carries its
    own header: HEADer ON puts none in front of it)."""
    scope = sim.scope
    scope.handle(b"HEADER ON;:SELECT:CH1 ON;:DATA:SOURCE CH1;ENCDG ASCII;START 1;STOP 5")
    [separate] = scope.handle(b"WFMPRE?;:CURVE?")
    [together] = scope.handle(b"WAVFRM?")
    assert together == separate and together.startswith(b":WFMPRE:BYT_NR ") and b";:CURVE " in together
    scope.handle(b"HEADER OFF;:DATA:ENCDG RIBINARY;STOP 10000")


def test_apply_sets_the_waveform_at_once_and_apply_query_answers_it(sim):
    """UG Ch. 4 APPLy: shape, frequency, amplitude (in VOLT:UNIT), offset in one command,
    DEFault or left out the *RST value, modulation off; APPLy? as one quoted string."""
    generator = sim.generator
    generator.handle(b"*RST;BM:STAT ON;:APPL:SQU 2 KHZ,1.5,0.1")
    assert generator.handle(b"APPL?") == [b'"SQU +2.000000000000E+03,+1.500000E+00,+1.000000E-01"']
    assert generator.handle(b"BM:STAT?") == [b"0"]
    generator.handle(b"VOLT:UNIT VRMS;:APPL:SIN DEF,1")
    assert generator.handle(b"APPLY?") == [b'"SIN +1.000000000000E+03,+1.000000E+00,+0.000000E+00"']
    assert generator.settings().amplitude == pytest.approx(2.0 * 2.0 ** 0.5)
    assert generator.handle(b"SYST:ERR?") == [b'+0,"No error"']
    generator.handle(b"*RST")
