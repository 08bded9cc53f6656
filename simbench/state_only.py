"""Headers a SCPI instrument's manual lists that the simulator does not model physically.

They are accepted, their arguments checked against the argument syntax of the command
summary (`command_tables`), stored and read back: STATE ONLY. Nothing they set reaches
the physics (a 33120A burst count does not shape the drive; a TDS3000 mask test never
runs). A query-only header answers the fixed reply of its table row; one that groups
settings (`ACQuire?`, `CH<x>?`) answers them concatenated, as the manuals' examples show
(TDS PM p. 2-45 `ACQuire?`); one without either answers 0, a number being the commonest
reply (a simplification: the real replies of such headers are readings the simulator
does not make).
"""

from __future__ import annotations

import itertools
import re
from dataclasses import dataclass
from typing import Callable

from squeezebench.simbench import scpi
from squeezebench.simbench.command_tables import Entry
from squeezebench.simbench.scpi import ScpiError, Unit

#: Placeholders (lower case, without <>) that stand for an integer or a decimal number.
_INTEGERS = ("nr1", "setup number", "enable value")
_NUMBERS = ("nr3", "# cycles", "frequency", "amplitude", "offset", "percent", "depth in percent",
            "peak deviation in hz", "start phase", "rate in hz", "seconds", "value")
_STRINGS = ("qstring", "quoted string")
#: SCPI-1999 Vol. 1 7.2.1: the words a decimal numeric datum may be replaced by.
_NUMERIC_WORDS = {"MINIMUM", "MAXIMUM", "DEFAULT", "INFINITY"}
_SCPI_INFINITY = 9.9e37
#: SELect:CONTROl <wfm>: what a waveform may be (TDS PM "Constructed Mnemonics").
_WAVEFORMS = "CH<x> | MATH | REF<x>"
_SUFFIX = re.compile(r"<[xn]>")
_FREQUENCY_SUFFIXES = {"HZ": 1.0, "KHZ": 1e3, "MHZ": 1e6}


@dataclass(frozen=True)
class Argument:
    """What a header's argument syntax allows, as far as a state-only setting needs."""

    choices: tuple[tuple[str, str], ...]   # (manual spelling, canonical value: long form, upper case)
    number: bool = False
    integer: bool = False
    string: bool = False
    free: bool = False      # several arguments, blocks, file paths, names: kept as sent
    optional: bool = False

    @property
    def boolean(self) -> bool:
        return {"ON", "OFF"} <= {value for _, value in self.choices}


def argument(syntax: str) -> Argument:
    """`{ SAMple | AVErage | <NR1> }`, `<QString>`, `[<arb name>]` ... -> Argument."""
    text = syntax.strip().replace("<wfm>", "{ " + _WAVEFORMS + " }")
    optional = text.startswith("[") and text.endswith("]")
    if optional:
        text = text[1:-1].strip()
    if "," in text or "..." in text:
        return Argument((), free=True, optional=optional)
    choices, number, integer, string, free = [], False, False, False, False
    for token in filter(None, (t.strip(" {}") for t in text.split("|"))):
        if _SUFFIX.search(token) and not token.startswith("<"):   # CH<x>, CURSOR<n>X: one choice per suffix
            choices += [(_SUFFIX.sub(str(x), token),) * 2 for x in (1, 2, 3, 4)]
        elif token.startswith("<"):
            name = token.strip("<> ").lower()
            integer = integer or name in _INTEGERS
            number = number or name in _INTEGERS or name in _NUMBERS
            string = string or name in _STRINGS
            free = free or not (name in _INTEGERS or name in _NUMBERS or name in _STRINGS)
        else:
            choices.append((token, token.upper()))
    return Argument(tuple((spelling, value.upper()) for spelling, value in choices), number, integer, string, free,
                    optional)


class Setting:
    """The set and query handlers of one state-only header of `entry`."""

    def __init__(self, entry: Entry, path: str) -> None:
        self.entry = entry
        self.path = path
        self.argument = argument(entry.arguments)
        # a frequency or rate takes the Hz suffixes (SCPI-1999 Vol. 1 7.2.2)
        self.frequency = re.search(r"<[^<>]*(frequency|rate)[^<>]*>", entry.arguments, re.IGNORECASE) is not None

    def key(self, unit: Unit) -> tuple:
        return (self.path, unit.suffixes)

    # -- set ---------------------------------------------------------------------------------
    def set(self, instrument, unit: Unit) -> None:
        arg = self.argument
        if not self.entry.arguments:
            scpi.no_arguments(unit.arguments)   # an action: nothing to keep
            return
        if arg.free:
            if not unit.arguments and not arg.optional:
                raise scpi.missing_parameter()
            instrument.stored[self.key(unit)] = ("raw", ",".join(unit.arguments))
            return
        instrument.stored[self.key(unit)] = self.value(instrument, scpi.only_argument(unit.arguments))

    def value(self, instrument, text: str):
        """The setting `text` asks for: a canonical choice, a bool, a number or a string."""
        arg = self.argument
        if arg.boolean:
            return scpi.boolean(text)
        if arg.choices:
            try:
                word = scpi.choice(text, dict(arg.choices), instrument.STYLE)
            except ScpiError:
                if not (arg.number or arg.string):
                    raise
            else:
                if not (arg.number and word in _NUMERIC_WORDS):
                    return word
                return self.numeric_word(instrument, word)
        if arg.string:
            return ("string", scpi.quoted_string(text))
        if arg.number:
            value = scpi.number(text, _FREQUENCY_SUFFIXES if self.frequency else None)
            if self.entry.limits is not None:
                value = instrument.clipped(value, *self.entry.limits)
            return round(value) if arg.integer else value
        raise scpi.illegal_parameter()

    def numeric_word(self, instrument, word: str) -> float:
        if word == "INFINITY":
            return _SCPI_INFINITY
        if word == "DEFAULT":
            return float(self.default(instrument))   # a number's *RST value
        if self.entry.limits is None:
            raise scpi.illegal_parameter()
        return self.entry.limits[0] if word == "MINIMUM" else self.entry.limits[1]

    # -- query -------------------------------------------------------------------------------
    def query(self, instrument, unit: Unit) -> bytes:
        if unit.arguments and self.entry.settable:
            if not (self.argument.number and self.entry.limits):
                raise scpi.parameter_not_allowed()
            word = scpi.choice(scpi.only_argument(unit.arguments), {"MINimum": "MINIMUM", "MAXimum": "MAXIMUM"},
                               instrument.STYLE)
            return self.reply(instrument, self.numeric_word(instrument, word))
        # A query-only header's arguments select what it reads (MEASUrement:MEAS<x>:DATa? <NR3>,<NR1>).
        stored = instrument.stored.get(self.key(unit))
        return self.default(instrument) if stored is None else self.reply(instrument, stored)

    def default(self, instrument) -> bytes:
        """The reply before any setting: the table's, else off, the first choice, zero
        (within the limits), an empty string; 0 for a query-only header."""
        arg = self.argument
        if self.entry.reply:
            return self.entry.reply.encode()
        if not self.entry.settable:
            return b"0"
        if arg.free:
            return b""
        if arg.boolean:
            return b"0"
        if arg.choices and not arg.number:
            return self.reply(instrument, arg.choices[0][1])
        if arg.number:
            low, high = self.entry.limits or (0.0, 0.0)
            return self.reply(instrument, min(max(0.0, low), high))
        return b'""'

    def reply(self, instrument, value) -> bytes:
        if isinstance(value, bool):
            return b"1" if value else b"0"
        if isinstance(value, tuple):   # ("string", text) or ("raw", arguments as sent)
            kind, text = value
            return ('"' + text.replace('"', '""') + '"').encode() if kind == "string" else text.encode()
        if isinstance(value, str):
            spelling = next(s for s, v in self.argument.choices if v == value)
            return instrument.choice_reply(value, spelling).encode()
        return instrument.number_reply(value, self.argument.integer).encode()


def group(children: list[tuple[str, Callable, tuple[int, ...]]]) -> Callable:
    """The query handler of a header that groups settings: each child's reply, with its
    header when the instrument sends headers, `;`-separated. `children`: (path, query
    handler, the suffixes its <x> allows); a child's first <x> is the group's own when the
    group has one (CH<x>?), else every allowed one."""

    def query(instrument, unit: Unit) -> bytes:
        scpi.no_arguments(unit.arguments)
        replies = []
        for path, handler, allowed in children:
            count = path.count("<x>")
            own = unit.suffixes[:count]
            for rest in itertools.product(allowed, repeat=count - len(own)):
                child = Unit(path, True, (), own + rest, unit.text)
                replies.append(instrument.with_header(child, handler(instrument, child)))
        return b";".join(replies)

    return query
