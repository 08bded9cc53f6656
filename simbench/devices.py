"""The simulated instruments: models of what the three manuals say, with physics behind.

Each instrument parses what it receives with its manual's grammar (`simbench.scpi` for
the two IEEE 488.2 instruments, the controller's line protocol for the OFV-5000), keeps
its settings in a state that starts as the manual's power-on state, and reports what it
refuses the way its manual says: the 33120A in its SCPI error queue (`SYST:ERR?`), the
TDS 3054B in its Standard Event Status Register and event queue (`*ESR?`, `EVMsg?`,
`ALLEv?`), the OFV-5000 with an `Error` line. A refused query returns nothing: the
reader waits out its VISA timeout, as on the real bus.

The simulator never looks at which driver talks to it. What it adds beyond the manuals:
bench time for every message (bus latency and transfer), for what the instrument does
(generator settling, scope acquisitions), the bus faults a scene names, and the physics
(the generator drives the plate, the scope acquires its signals, the vibrometer's
decoder range scales CH3).

Manual references: "33120A UG" = HP 33120A User's Guide (Chapter 4 remote interface
reference, Chapter 5 error messages), "TDS PM" = TDS3000/B/C Series Programmer Manual
071-0381-03 (page numbers), "OFV" = Polytec OFV-5000 user manual, RS-232 interface
commands. What could not be verified against a manual is said where it is modelled.
"""

from __future__ import annotations

import math
import re
import zlib
from collections import deque
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Callable, ClassVar, Iterator

import numpy as np
from pyvisa import constants, errors

from squeezebench.simbench import effects as fx
from squeezebench.simbench import command_tables, physics, scpi, state_only, traces
from squeezebench.simbench.clock import BusTiming
from squeezebench.simbench.scpi import PREFIX, SCPI, ScpiError, Unit

#: Bench time the 33120A takes to apply a change (assumed: a new frequency settles in
#: about 10 ms; an amplitude, offset or load change may switch attenuator relays).
GENERATOR_FREQUENCY_SETTLE_S = 0.010
GENERATOR_LEVEL_SETTLE_S = 0.030
#: Time between two averaged acquisitions of the TDS3054B beyond the record itself
#: (assumed: trigger re-arm plus processing and display of each waveform).
SCOPE_REARM_S = 0.010
EOM = b"\n"


@dataclass
class Deferred:
    """A reply the instrument gives only once it has finished (e.g. `*OPC?`)."""

    ready_s: float
    payload: bytes


class SimulatedInstrument:
    """Message transport, bench time and faults common to the three instruments."""

    role: ClassVar[str]

    def __init__(self, bench, bus: BusTiming, options: dict[str, str]) -> None:
        self.bench = bench
        self.bus = bus
        self.options = options
        self._input = bytearray()
        self._replies: deque = deque()
        self.disconnected = False   # set by the `disconnect` fault, for good
        self.power_on()

    def power_on(self) -> None:
        """The state the manual gives for power-on."""
        raise NotImplementedError

    def handle(self, message: bytes) -> list:
        """Replies (bytes or Deferred, without terminator) to one received message."""
        raise NotImplementedError

    def inject_error(self) -> None:
        """The `instrument_error` fault: an error the instrument reports on its own."""

    def is_query(self, message: bytes) -> bool:
        return message.rstrip().endswith(b"?")

    # -- what the VISA library calls ------------------------------------------------------
    def write(self, data: bytes) -> None:
        self.bench.clock.advance(self.bus.message_s(len(data)))
        self._input += data
        while EOM in self._input:
            end = self._input.index(EOM)
            message = bytes(self._input[:end]).rstrip(b"\r")
            del self._input[:end + 1]
            self._receive(message)

    def _receive(self, message: bytes) -> None:
        faults = self._faults(message) if self.bench.effects.bus else ()
        for reply in self.handle(message):
            if isinstance(reply, Deferred):
                reply.payload += EOM
            else:
                reply = bytearray(reply + EOM)
            for fault in faults:
                reply = self._faulty_reply(fault, reply)
                if reply is None:   # lost: later faults have nothing to act on
                    break
            else:
                self._replies.append(reply)

    def _faults(self, message: bytes) -> list:
        """The bus faults hitting this message, after they acted; a disconnect fails it."""
        bench = self.bench
        bench.messages_received += 1
        faults = [f for f in bench.effects.bus if f.hits(self.role, bench.messages_received, self.is_query(message))]
        for fault in faults:
            fault.act(self)
        if self.disconnected:
            raise errors.VisaIOError(constants.VI_ERROR_CONN_LOST)
        return faults

    @staticmethod
    def _faulty_reply(fault, reply):
        if isinstance(reply, Deferred):
            payload = fault.reply(reply.payload, EOM)
            if payload is None:
                return None
            reply.payload = payload
            return reply
        return fault.reply(reply, EOM)

    def read(self, count: int, timeout_s: float) -> tuple[bytes, constants.StatusCode]:
        clock = self.bench.clock
        if self.disconnected:
            raise errors.VisaIOError(constants.VI_ERROR_CONN_LOST)
        if not self._replies:
            self._time_out(timeout_s)
        head = self._replies[0]
        if isinstance(head, Deferred):
            if head.ready_s - clock.now_s() > timeout_s:
                self._time_out(timeout_s)
            clock.advance_to(head.ready_s)
            payload = head.payload
            head = self._replies[0] = payload if isinstance(payload, fx.TruncatedPayload) else bytearray(payload)
        chunk = bytes(head[:count])
        del head[:count]
        clock.advance(self.bus.message_s(len(chunk)))
        if head:
            return chunk, constants.StatusCode.success_max_count_read
        self._replies.popleft()
        if isinstance(head, fx.TruncatedPayload):   # no END: the reader asks for the rest, which never comes
            return chunk, constants.StatusCode.success_max_count_read
        return chunk, constants.StatusCode.success

    def _time_out(self, timeout_s: float) -> None:
        """Nothing to read: the session waits its whole timeout (bench time, not wall)."""
        self.read_without_reply()
        self.bench.clock.advance(timeout_s)
        raise errors.VisaIOError(constants.VI_ERROR_TMO)

    def read_without_reply(self) -> None:
        """Hook: the controller tried to read with nothing in the output queue."""

    def clear(self) -> None:
        """Device clear (IEEE 488.1 DCL/SDC): drop pending input and replies."""
        self._input.clear()
        self._replies.clear()


#: The lists `recorded_refusals` is filling.
_REFUSALS: list[list[str]] = []


@contextmanager
def recorded_refusals() -> Iterator[list[str]]:
    """Every command a simulated SCPI instrument (generator, scope) refuses while inside,
    one line each: what a test or benchmark asserts a run never provokes."""
    refused: list[str] = []
    _REFUSALS.append(refused)
    try:
        yield refused
    finally:
        _REFUSALS.remove(refused)


# == IEEE 488.2 instruments ===========================================================================
@dataclass(frozen=True)
class Command:
    """One header of a manual: its spelling, what its set and query forms do, where it is."""

    spec: str
    query: Callable | None
    set: Callable | None
    section: str
    suffixes: tuple[int, ...] = (1, 2, 3, 4)   # the <x> a header allows


class ScpiInstrument(SimulatedInstrument):
    """Dispatch on the canonical header path; errors through `report`.

    COMMANDS are the headers modelled physically; every other header of the manual's
    command summary (`TABLE`, see `command_tables`) is accepted and kept as state only
    (`state_only`), in `stored`."""

    STYLE: ClassVar[str]
    TABLE: ClassVar[str]
    COMMANDS: ClassVar[tuple[Command, ...]]
    _parser: ClassVar[scpi.MessageParser]
    _handlers: ClassVar[dict[tuple[str, bool], Callable]]
    _short_paths: ClassVar[dict[str, str]]
    #: Queries whose replies carry their own headers (HEADer ON), besides the groups.
    OWN_HEADERS: ClassVar[frozenset[str]] = frozenset()
    #: Canonical paths of the headers COMMANDS models; the queries whose replies are headed.
    modelled: ClassVar[frozenset[str]]
    _headed: ClassVar[frozenset[str]]
    stored: dict

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if "COMMANDS" not in cls.__dict__:
            return
        tree = scpi.HeaderTree(cls.STYLE)
        cls._handlers, cls._short_paths = {}, {}
        allowed: dict[str, tuple[int, ...]] = {}
        for command in cls.COMMANDS:
            path = tree.add(command.spec, command.suffixes)
            cls._short_paths[path] = scpi.short_path(command.spec)
            allowed[path] = command.suffixes
            for query, handler in ((True, command.query), (False, command.set)):
                if handler is not None:
                    cls._handlers[path, query] = handler
        cls.modelled = frozenset(allowed)
        cls._add_state_only(tree, allowed)
        cls._parser = scpi.MessageParser(tree)

    @classmethod
    def _add_state_only(cls, tree: scpi.HeaderTree, allowed: dict[str, tuple[int, ...]]) -> None:
        """The summary's headers (and forms) COMMANDS leaves out, as state only; a query-only
        header grouping settings answers them all (`<all settings>`: the whole setup)."""
        groups, settings = [], []
        for entry in command_tables.table(cls.TABLE):
            path = tree.add(entry.header)
            cls._short_paths.setdefault(path, scpi.short_path(entry.header))
            allowed.setdefault(path, (1, 2, 3, 4))
            setting = state_only.Setting(entry, path)
            if entry.settable and entry.queryable and entry.arguments and not (setting.argument.free
                                                                               or path.startswith("*")):
                settings.append(path)
            if entry.settable:
                cls._handlers.setdefault((path, False), setting.set)
            if entry.queryable and (path, True) not in cls._handlers:
                if not entry.settable and entry.reply in ("", "<all settings>"):
                    groups.append((path, entry.reply == "<all settings>"))
                cls._handlers[path, True] = setting.query
        grouped = set()
        for path, whole in groups:
            children = [(child, cls._handlers[child, True], allowed[child]) for child in settings
                        if whole or child.startswith(path + ":")]
            if children:
                cls._handlers[path, True] = state_only.group(children)
                grouped.add(path)
        cls._headed = frozenset(grouped) | cls.OWN_HEADERS

    def handle(self, message: bytes) -> list:
        if self._replies:   # IEEE 488.2 6.3.2.3: a new message discards unread replies
            self._replies.clear()
            self.report(ScpiError(-410, "Query INTERRUPTED"))
        try:
            text = message.decode("ascii")
        except UnicodeDecodeError:
            self.report(ScpiError(-101, "Invalid character"))
            return []
        replies = []
        for unit in self._parser.units(text):
            if isinstance(unit, ScpiError):
                self.refuse(unit)
                continue
            handler = self._handlers.get((unit.path, unit.query))
            try:
                if handler is None:
                    raise scpi.undefined_header()
                reply = handler(self, unit)
            except ScpiError as exc:
                exc.detail = unit.text
                self.refuse(exc)
                continue
            if reply is not None:
                replies.append(reply if unit.path in self._headed else self.with_header(unit, reply))
        return self.combine(replies)

    def refuse(self, error: ScpiError) -> None:
        """A command refused (its text in `error.detail`): reported as the manual says, and
        shown to every `recorded_refusals` open (command, execution, device or query errors:
        codes 100-499 but the power-on event; the 5xx warnings and 2xxx measurement events
        are not refusals of the command)."""
        if 100 <= abs(error.code) < 500 and error.code != 401:
            for refused in _REFUSALS:
                refused.append(f"{self.role}: {error.code} {error.message} ({error.detail})")
        self.report(error)

    @staticmethod
    def combine(replies: list) -> list:
        """Replies to the queries of one message go out as one, `;`-separated."""
        if len(replies) <= 1:
            return replies
        ready_s = max((r.ready_s for r in replies if isinstance(r, Deferred)), default=None)
        payload = b";".join(r.payload if isinstance(r, Deferred) else r for r in replies)
        return [payload if ready_s is None else Deferred(ready_s, payload)]

    def with_header(self, unit: Unit, reply):
        return reply

    def report(self, error: ScpiError) -> None:
        raise NotImplementedError

    def read_without_reply(self) -> None:
        self.report(ScpiError(-420, "Query UNTERMINATED"))


def _setting(key: str, parse: Callable, fmt: Callable[[object], str], *, per_channel: bool = False):
    """(query, set) handlers of a plain setting stored under `key`."""

    def state_key(unit: Unit):
        return (key, unit.suffixes[0]) if per_channel else key

    def query(instrument, unit: Unit) -> bytes:
        scpi.no_arguments(unit.arguments)
        return fmt(instrument.state[state_key(unit)]).encode()

    def set_(instrument, unit: Unit) -> None:
        value = parse(instrument, scpi.only_argument(unit.arguments), unit)
        instrument.state[state_key(unit)] = value
        instrument.changed(key, unit)

    return query, set_


def _choices(options: dict[str, str], style: str) -> Callable:
    return lambda instrument, text, unit: scpi.choice(text, options, style)


# == HP/Agilent 33120A ================================================================================
#: Sine limits (33120A UG, Chapter 4 "Output Configuration Commands" and Chapter 8
#: specifications): frequency; Vpp and |offset| + Vpp/2 per output termination setting.
GEN_FREQUENCY_HZ = (100e-6, 15e6)
GEN_AMPLITUDE_VPP = {50.0: (0.050, 10.0), math.inf: (0.100, 20.0)}
GEN_PEAK_V = {50.0: 5.0, math.inf: 10.0}
GEN_INFINITE = 9.9e37
#: Modulations (UG Ch. 4 "Modulation Commands"): the state key and the header's spelling.
GEN_MODULATIONS = {"AM": "AM", "FM": "FM", "FSK": "FSKey", "BM": "BM", "SWE": "SWEep"}
GEN_ERROR_QUEUE_DEPTH = 20
_GEN_SHAPES = {"SINusoid": "SIN", "SQUare": "SQU", "TRIangle": "TRI", "RAMP": "RAMP", "NOISe": "NOIS",
               "DC": "DC", "USER": "USER"}
_GEN_UNITS = {"VPP": "VPP", "VRMS": "VRMS", "DBM": "DBM"}
_FREQUENCY_SUFFIXES = {"HZ": 1.0, "KHZ": 1e3, "MHZ": 1e6}   # SCPI: MHZ is megahertz for Hz
_VOLT_SUFFIXES = {"V": 1.0, "MV": 1e-3}


def _vpp_from(value: float, unit: str) -> float:
    """An amplitude in the 33120A's VOLT:UNIT (sine) -> Vpp (UG Ch. 4, VOLTage:UNIT)."""
    if unit == "VRMS":
        return value * 2.0 * math.sqrt(2.0)
    if unit == "DBM":
        return math.sqrt(50.0 * 1e-3 * 10.0 ** (value / 10.0)) * 2.0 * math.sqrt(2.0)
    return value


def _vpp_to(vpp: float, unit: str) -> float:
    if unit == "VRMS":
        return vpp / (2.0 * math.sqrt(2.0))
    if unit == "DBM":
        return 10.0 * math.log10((vpp / (2.0 * math.sqrt(2.0))) ** 2 / 50.0 / 1e-3)
    return vpp


class Generator(ScpiInstrument):
    """HP/Agilent 33120A: SCPI, short or long forms, its error queue, its sine limits."""

    role = "generator"
    STYLE = SCPI
    TABLE = "hp33120a"
    IDENTITY = b"HEWLETT-PACKARD,33120A,0,7.0-5.0-1.0"

    def power_on(self) -> None:
        self.errors: deque = deque()
        self.factory_settings()

    def factory_settings(self) -> None:
        """UG Ch. 4 *RST (also the power-on state): sine, 1 kHz, 100 mVpp, 0 V offset,
        50 ohm output termination, amplitudes in Vpp."""
        self.state = {"shape": "SIN", "frequency": 1e3, "amplitude_vpp": 0.1, "offset": 0.0,
                      "load": 50.0, "unit": "VPP", "modulation": None}
        self.stored = {}

    # -- errors (UG Ch. 5: SYSTem:ERRor? reads the oldest, +0,"No error" when empty) -------------
    def report(self, error: ScpiError) -> None:
        if len(self.errors) >= GEN_ERROR_QUEUE_DEPTH:
            self.errors[-1] = (-350, "Too many errors")
            return
        self.errors.append((error.code, error.message))

    def inject_error(self) -> None:
        self.report(ScpiError(-222, "Data out of range"))

    def _error_query(self, unit: Unit) -> bytes:
        scpi.no_arguments(unit.arguments)
        code, message = self.errors.popleft() if self.errors else (0, "No error")
        return b'%+d,"%s"' % (code, message.encode())

    # -- physics --------------------------------------------------------------------------------
    def settings(self) -> physics.GeneratorSettings:
        s = self.state
        frequency_hz, amplitude_vpp = s["frequency"], s["amplitude_vpp"]
        if s["modulation"] is not None:
            frequency_hz, amplitude_vpp = modulated(s["modulation"], frequency_hz, amplitude_vpp,
                                                    self.bench.clock.now_s())
        return physics.GeneratorSettings(frequency_hz=frequency_hz, amplitude=amplitude_vpp,
                                         voltage_unit="VPP", offset_v=s["offset"], load_ohm=s["load"],
                                         shape=s["shape"])

    def changed(self, key: str, unit: Unit) -> None:
        """Every setting command reprograms the synthesiser or the attenuators, even one
        repeating the present value: the busy time depends on the command alone (so a
        resumed campaign spends the bench time an uninterrupted one does)."""
        self.bench.generator_written(drive_changed=self.settings() != self._before)
        self.bench.clock.advance(GENERATOR_FREQUENCY_SETTLE_S if key == "frequency" else GENERATOR_LEVEL_SETTLE_S)

    def handle(self, message: bytes) -> list:
        self._before = self.settings()
        return super().handle(message)

    # -- limits ---------------------------------------------------------------------------------
    def _limited(self, value: float, low: float, high: float) -> float:
        """UG Ch. 5: an out-of-range number is clipped to the limit and reported as -222."""
        if value > high:
            self.report(ScpiError(-222, "Data out of range;value clipped to upper limit"))
            return high
        if value < low:
            self.report(ScpiError(-222, "Data out of range;value clipped to lower limit"))
            return low
        return value

    def _amplitude_limits_vpp(self) -> tuple[float, float]:
        low, high = GEN_AMPLITUDE_VPP[self.state["load"]]
        return low, min(high, 2.0 * (GEN_PEAK_V[self.state["load"]] - abs(self.state["offset"])))

    def _offset_limit_v(self) -> float:
        return GEN_PEAK_V[self.state["load"]] - self.state["amplitude_vpp"] / 2.0

    @staticmethod
    def _min_max(text: str, low: float, high: float, default: float | None = None) -> float | None:
        """MINimum, MAXimum (and DEFault, the *RST value, where the summary allows it)."""
        word = text.strip().upper()
        if word in ("MIN", "MINIMUM"):
            return low
        if word in ("MAX", "MAXIMUM"):
            return high
        if default is not None and word in ("DEF", "DEFAULT"):
            return default
        return None

    def _limit_query(self, unit: Unit, value: float, low: float, high: float, fmt: str) -> bytes:
        if unit.arguments:
            limit = self._min_max(scpi.only_argument(unit.arguments), low, high)
            if limit is None:
                raise scpi.illegal_parameter()
            value = limit
        return (fmt % value).encode()

    def _frequency_value(self, text: str, default: float | None = None) -> float:
        value = self._min_max(text, *GEN_FREQUENCY_HZ, default)
        value = scpi.number(text, _FREQUENCY_SUFFIXES) if value is None else value
        return self._limited(value, *GEN_FREQUENCY_HZ)

    def _amplitude_vpp_value(self, text: str, default_vpp: float | None = None) -> float:
        low, high = self._amplitude_limits_vpp()
        vpp = self._min_max(text, low, high, default_vpp)
        if vpp is None:
            match = re.match(r"^(.*?)\s*(M?)(VPP|VRMS|DBM)$", text.strip().upper())
            if match:   # a unit suffix overrides VOLT:UNIT for this number
                vpp = _vpp_from(scpi.number(match.group(1)) * (1e-3 if match.group(2) else 1.0), match.group(3))
            else:
                vpp = _vpp_from(scpi.number(text, _VOLT_SUFFIXES), self.state["unit"])
        return self._limited(vpp, low, high)

    def _offset_value(self, text: str, default: float | None = None) -> float:
        limit = self._offset_limit_v()
        value = self._min_max(text, -limit, limit, default)
        return self._limited(scpi.number(text, _VOLT_SUFFIXES) if value is None else value, -limit, limit)

    # -- handlers -------------------------------------------------------------------------------
    def _frequency_query(self, unit: Unit) -> bytes:
        return self._limit_query(unit, self.state["frequency"], *GEN_FREQUENCY_HZ, "%+.12E")

    def _frequency_set(self, unit: Unit) -> None:
        self.state["frequency"] = self._frequency_value(scpi.only_argument(unit.arguments))
        self.changed("frequency", unit)

    def _amplitude_query(self, unit: Unit) -> bytes:
        low, high = self._amplitude_limits_vpp()
        unit_name = self.state["unit"]
        return self._limit_query(unit, _vpp_to(self.state["amplitude_vpp"], unit_name),
                                 _vpp_to(low, unit_name), _vpp_to(high, unit_name), "%+.6E")

    def _amplitude_set(self, unit: Unit) -> None:
        self.state["amplitude_vpp"] = self._amplitude_vpp_value(scpi.only_argument(unit.arguments))
        self.changed("amplitude", unit)

    def _offset_query(self, unit: Unit) -> bytes:
        limit = self._offset_limit_v()
        return self._limit_query(unit, self.state["offset"], -limit, limit, "%+.6E")

    def _offset_set(self, unit: Unit) -> None:
        self.state["offset"] = self._offset_value(scpi.only_argument(unit.arguments))
        self.changed("offset", unit)

    def _apply(self, unit: Unit, shape: str) -> None:
        """APPLy:<shape> [<frequency> [,<amplitude> [,<offset>]]] (UG Ch. 4): the shape and its
        numbers in one command; one left out, or DEFault, is its *RST value (1 kHz, 100 mVpp,
        0 V). The amplitude is in VOLT:UNIT; APPLy turns modulation off. For DC only the
        offset acts (the level)."""
        if len(unit.arguments) > 3:
            raise scpi.parameter_not_allowed()
        frequency, amplitude, offset = (*unit.arguments, "DEF", "DEF", "DEF")[:3]
        self.state.update(shape=shape, modulation=None)
        if shape != "DC":
            self.state["frequency"] = self._frequency_value(frequency, 1e3)
            self.state["amplitude_vpp"] = self._amplitude_vpp_value(amplitude, 0.1)
        self.state["offset"] = self._offset_value(offset, 0.0)
        self.changed("apply", unit)

    def _apply_query(self, unit: Unit) -> bytes:
        """APPLy?: shape, frequency, amplitude (VOLT:UNIT) and offset as one quoted string."""
        scpi.no_arguments(unit.arguments)
        s = self.state
        amplitude = _vpp_to(s["amplitude_vpp"], s["unit"])
        return b'"%s %+.12E,%+.6E,%+.6E"' % (s["shape"].encode(), s["frequency"], amplitude, s["offset"])

    def _load_query(self, unit: Unit) -> bytes:
        load = self.state["load"]
        if unit.arguments:   # OUTPut:LOAD? {MINimum|MAXimum}: 50 ohm, INFinity
            load = self._min_max(scpi.only_argument(unit.arguments), 50.0, math.inf)
            if load is None:
                raise scpi.illegal_parameter()
        return b"%+.6E" % (GEN_INFINITE if math.isinf(load) else load)

    def _load_set(self, unit: Unit) -> None:
        """OUTPut:LOAD {50|INFinity|MINimum|MAXimum}: only 50 ohm or INF (UG Ch. 4). The
        output stays the same: what is programmed and displayed is rescaled."""
        text = scpi.only_argument(unit.arguments).upper()
        if text in ("INF", "INFINITY", "MAX", "MAXIMUM"):
            load = math.inf
        elif text in ("MIN", "MINIMUM"):
            load = 50.0
        else:
            value = scpi.number(text, {"OHM": 1.0})
            if value != 50.0:
                raise ScpiError(-224, "Illegal parameter value")
            load = 50.0
        if load != self.state["load"]:
            factor = 2.0 if math.isinf(load) else 0.5
            self.state["amplitude_vpp"] *= factor
            self.state["offset"] *= factor
            self.state["load"] = load
        self.changed("load", unit)

    def _modulation_set(self, unit: Unit, kind: str) -> None:
        """One modulation at a time: turning one on turns the one on before off."""
        on = scpi.boolean(scpi.only_argument(unit.arguments))
        if on:
            self.state["modulation"] = kind
        elif self.state["modulation"] == kind:
            self.state["modulation"] = None
        self.changed("modulation", unit)

    def _reset(self, unit: Unit) -> None:
        scpi.no_arguments(unit.arguments)
        self.factory_settings()
        self.changed("reset", unit)

    def _clear_status(self, unit: Unit) -> None:
        scpi.no_arguments(unit.arguments)
        self.errors.clear()

    COMMANDS = (
        Command("*IDN", lambda g, u: g.IDENTITY, None, "UG Ch. 4 *IDN?"),
        Command("*RST", None, _reset, "UG Ch. 4 *RST"),
        Command("*CLS", None, _clear_status, "UG Ch. 4 *CLS"),
        Command("*OPC", lambda g, u: b"1", lambda g, u: None, "UG Ch. 4 *OPC"),
        Command("SYSTem:ERRor", _error_query, None, "UG Ch. 4 SYSTem:ERRor?; Ch. 5"),
        Command("[SOURce:]FUNCtion:SHAPe", *_setting("shape", _choices(_GEN_SHAPES, SCPI), str),
                "UG Ch. 4 FUNCtion:SHAPe"),
        Command("[SOURce:]FREQuency", _frequency_query, _frequency_set, "UG Ch. 4 FREQuency"),
        Command("[SOURce:]VOLTage", _amplitude_query, _amplitude_set, "UG Ch. 4 VOLTage"),
        Command("[SOURce:]VOLTage:OFFSet", _offset_query, _offset_set, "UG Ch. 4 VOLTage:OFFSet"),
        Command("[SOURce:]VOLTage:UNIT", *_setting("unit", _choices({**_GEN_UNITS, "DEFault": "VPP"}, SCPI), str),
                "UG Ch. 4 VOLTage:UNIT"),
        Command("OUTPut:LOAD", _load_query, _load_set, "UG Ch. 4 OUTPut:LOAD"),
        *(Command(f"[SOURce:]{spelling}:STATe", lambda g, u, kind=kind: _flag(g.state["modulation"] == kind).encode(),
                  lambda g, u, kind=kind: g._modulation_set(u, kind), f"UG Ch. 4 {spelling}:STATe")
          for kind, spelling in GEN_MODULATIONS.items()),
        *(Command(f"APPLy:{spelling}", None, lambda g, u, shape=shape: g._apply(u, shape), f"UG Ch. 4 APPLy:{spelling}")
          for spelling, shape in _GEN_SHAPES.items()),
        Command("APPLy", _apply_query, None, "UG Ch. 4 APPLy?"),
    )

    # -- state-only headers (state_only): replies as the 33120A formats numbers and keywords --
    def clipped(self, value: float, low: float, high: float) -> float:
        return self._limited(value, low, high)

    @staticmethod
    def number_reply(value: float, integer: bool) -> str:
        return "%+d" % value if integer else "%+.6E" % value

    @staticmethod
    def choice_reply(value: str, spelling: str) -> str:
        return scpi.short_form(spelling)


def modulated(kind: str, frequency_hz: float, amplitude_vpp: float, time_s: float) -> tuple[float, float]:
    """(frequency, amplitude pp) a modulation left on makes of the programmed sine at
    `time_s`, with the modulation parameters at their *RST values (UG Ch. 4). Quasi-static:
    an acquisition lasts well under a millisecond, the modulations run at 10-100 Hz. AM:
    100 % depth at 100 Hz, the peak at the programmed amplitude; FM: 100 Hz deviation at
    10 Hz; FSK: hops to 100 Hz at a 10 Hz rate; bursts of one cycle at 100 Hz drive the
    plate (Q of hundreds) with their average only; sweep: 100 Hz to 1 kHz in 1 s."""
    if kind == "AM":
        return frequency_hz, amplitude_vpp * 0.5 * (1.0 + math.sin(2.0 * math.pi * 100.0 * time_s))
    if kind == "FM":
        return frequency_hz + 100.0 * math.sin(2.0 * math.pi * 10.0 * time_s), amplitude_vpp
    if kind == "FSK":
        return (frequency_hz if (time_s * 10.0) % 1.0 < 0.5 else 100.0), amplitude_vpp
    if kind == "BM":
        return frequency_hz, amplitude_vpp * min(1.0, 100.0 / frequency_hz)
    return 100.0 + 900.0 * (time_s % 1.0), amplitude_vpp


# == Tektronix TDS 3054B ==============================================================================
CHANNELS = (1, 2, 3, 4)
#: TDS PM p. 3-13 to 3-18: which SESR bit an event sets.
_PON, _URQ, _CME, _EXE, _DDE, _QYE, _OPC = 128, 64, 32, 16, 8, 4, 1
EVENT_QUEUE_DEPTH = 40   # TDS PM p. 3-9
NO_VALUE = b"9.91E37"    # what the scope answers for a measurement without a value
#: HORizontal:MAIn:SCAle values (1-2-4 sequence; the TDS 3054B's fastest is 1 ns/div).
SCOPE_TIME_BASES_S = tuple(float(f"{m}e{e}") for e in range(-9, 1) for m in (1, 2, 4)) + (10.0,)
_RECORD_LENGTHS = (500, 10000)
_AVERAGES = tuple(2 ** k for k in range(1, 10))
_ACQ_MODES = {"SAMple": "SAMPLE", "PEAKdetect": "PEAKDETECT", "AVErage": "AVERAGE", "ENVelope": "ENVELOPE"}
_STOP_AFTER = {"RUNSTop": "RUNSTOP", "SEQuence": "SEQUENCE"}
_COUPLINGS = {"AC": "AC", "DC": "DC", "GND": "GND"}
_BANDWIDTHS = {"TWEnty": "TWENTY", "ONEFifty": "ONEFIFTY", "FULl": "FULL"}
_IMPEDANCES = {"FIFty": "FIFTY", "MEG": "MEG"}
_TRIGGER_TYPES = {"EDGe": "EDGE", "VIDeo": "VIDEO", "LOGIc": "LOGIC", "PULse": "PULSE"}
_TRIGGER_MODES = {"AUTO": "AUTO", "NORMal": "NORMAL"}
_TRIGGER_SOURCES = {**{f"CH{n}": f"CH{n}" for n in CHANNELS}, "LINE": "LINE", "VERTical": "VERTICAL",
                    "ALTernating": "ALTERNATING"}
_SLOPES = {"RISe": "RISE", "FALL": "FALL"}
_TRIGGER_COUPLINGS = {"DC": "DC", "HFRej": "HFREJ", "LFRej": "LFREJ", "NOISErej": "NOISEREJ", "AC": "LFREJ"}
_MATH_TYPES = {"DUAL": "DUAL", "FFT": "FFT"}   # ADVanced and DPO need the TDS3AAM module
_SOURCES = {**{f"CH{n}": f"CH{n}" for n in CHANNELS}, "MATH": "MATH", "MATH1": "MATH"}
_GATINGS = {"SCREen": "SCREEN", "CURSor": "CURSOR", "OFF": "OFF"}
_CURSORS = {"HBArs": "HBARS", "OFF": "OFF", "WAVEform": "WAVEFORM", "VBArs": "VBARS", "GRATicule": "GRATICULE"}
_MEASUREMENTS = {"AMPlitude": "AMPLITUDE", "AREa": "AREA", "BURst": "BURST", "CARea": "CAREA", "CMEan": "CMEAN",
                 "CRMs": "CRMS", "DELAY": "DELAY", "FALL": "FALL", "FREQuency": "FREQUENCY", "HIGH": "HIGH",
                 "LOW": "LOW", "MAXimum": "MAXIMUM", "MEAN": "MEAN", "MINImum": "MINIMUM", "NDUty": "NDUTY",
                 "NOVershoot": "NOVERSHOOT", "NWIdth": "NWIDTH", "PDUty": "PDUTY", "PERIod": "PERIOD",
                 "PHASE": "PHASE", "PK2pk": "PK2PK", "POVershoot": "POVERSHOOT", "PWIdth": "PWIDTH",
                 "RISe": "RISE", "RMS": "RMS"}
#: The measurements traces.measure computes (long form -> its name there); another type
#: answers no value (NO_VALUE, event 2200): the simulator does not compute it.
_SIMULATED_MEASUREMENTS = {"MEAN": "MEAN", "CMEAN": "CME", "PK2PK": "PK2", "AMPLITUDE": "AMP", "MAXIMUM": "MAX",
                           "MINIMUM": "MINI", "RMS": "RMS", "FREQUENCY": "FREQ", "PERIOD": "PERI", "HIGH": "HIGH",
                           "LOW": "LOW", "CRMS": "CRM"}
_ENCODINGS = {"ASCIi": "ASCII", "RIBinary": "RIBINARY", "RPBinary": "RPBINARY", "SRIbinary": "SRIBINARY",
              "SRPbinary": "SRPBINARY"}
#: DATa:ENCdg -> (BN_Fmt, BYT_Or) of the preamble.
_FORMATS = {"ASCII": ("RP", "MSB"), "RIBINARY": ("RI", "MSB"), "RPBINARY": ("RP", "MSB"),
            "SRIBINARY": ("RI", "LSB"), "SRPBINARY": ("RP", "LSB")}
_UNITS = {"CH1": "V", "CH2": "A", "CH3": "V", "CH4": "V"}
_MATH_DEFINITION = re.compile(r"^\s*(CH[1-4]|REF[1-4])\s*([-+*/])\s*(CH[1-4]|REF[1-4])\s*$", re.IGNORECASE)
_PREAMBLE_FIELDS = ("BYT_NR", "BIT_NR", "ENCDG", "BN_FMT", "BYT_OR", "NR_PT", "WFID", "PT_FMT", "XINCR", "PT_OFF",
                    "XZERO", "XUNIT", "YMULT", "YZERO", "YOFF", "YUNIT")
#: TDS PM Table 2-30 (CH<x>:OFFSet): (input scale it applies below, V/div; offset limit, V) at 1x.
_OFFSET_RANGE_AT_1X = ((10e-3, 0.1), (100e-3, 1.0), (1.0, 10.0), (math.inf, 100.0))
#: Replies with VERBose OFF: every keyword a setting query answers, in its short form.
_SHORT_KEYWORDS = {long.encode(): scpi.short_form(spelling).encode()
                   for table in (_ACQ_MODES, _STOP_AFTER, _COUPLINGS, _BANDWIDTHS, _IMPEDANCES, _TRIGGER_TYPES,
                                 _TRIGGER_MODES, _TRIGGER_SOURCES, _SLOPES, _TRIGGER_COUPLINGS, _MATH_TYPES, _SOURCES,
                                 _GATINGS, _CURSORS, _MEASUREMENTS, _ENCODINGS)
                   for spelling, long in table.items() if spelling.upper() == long}
#: TDS PM p. 2-68 (CH<x>:SCAle): 1 mV to 10 V per division with a 1x probe.
_SCALE_AT_1X = (1e-3, 10.0)


@dataclass(frozen=True)
class _Setup(traces.ScopeSetup):
    """The acquisition settings with where the record starts relative to the trigger
    (HORizontal:DELay and HORizontal:TRIGger:POSition, p. 2-144 to 2-148)."""

    record_start_s: float = 0.0

    @property
    def first_sample_s(self) -> float:
        return self.record_start_s


def _nr3(value: float) -> str:
    return f"{value:.4E}".replace("E+0", "E+").replace("E-0", "E-")


def _quoted(text: str) -> str:
    return '"' + text.replace('"', '""') + '"'


@dataclass(frozen=True)
class Probe:
    """A probe the scope detects through its TekProbe interface: the channel's gain and
    units are then fixed (TDS PM p. 2-68, CH<x>:PRObe; p. 2-65, CH<x>:ID?)."""

    model: str
    gain: float
    unit: str


def _tds_choice(options: dict[str, str]) -> Callable:
    return _choices(options, PREFIX)


def _int(low: int, high: int) -> Callable:
    return lambda scope, text, unit: int(round(scope._forced(scpi.number(text), low, high)))


def _nearest_int(allowed: tuple) -> Callable:
    return lambda scope, text, unit: int(scope._nearest(scpi.number(text), allowed))


def _trigger_level(scope, text: str, unit: Unit) -> float:
    """TRIGger:A:LEVel {ECL|TTL|<NR3>} (TDS PM p. 2-271): the presets are -1.3 V and 1.4 V."""
    preset = {"ECL": -1.3, "TTL": 1.4}.get(text.strip().upper())
    return scpi.number(text) if preset is None else preset


def _flag(value: bool) -> str:
    return "1" if value else "0"


class Scope(ScpiInstrument):
    """Tektronix TDS 3054B: the programmer manual's grammar, status system and state rules,
    acquiring the plate's signals."""

    role = "scope"
    STYLE = PREFIX
    TABLE = "tds3000"
    OWN_HEADERS = frozenset({"WFMPRE", "WAVFRM"})
    IDENTITY = b"TEKTRONIX,TDS 3054B,0,CF:91.1CT FV:v3.41 TDS3GM:v1.00 TDS3FFT:v1.00 TDS3TRG:v1.00"

    def power_on(self) -> None:
        """TDS PM Appendix D (factory initialization), which *RST also applies, plus the
        power-on status: PON set and event 401 waiting (p. 3-1, Table 3-7)."""
        electronics = self.bench.scene.electronics
        # CH2 carries the TCP202 current probe: the scope detects it (TekProbe level II) and
        # fixes its gain. A coded CH1 probe (level I) fixes its gain too, but has no model
        # to name. The other inputs have no coded probe.
        self.probes = {2: Probe("TCP202", electronics.current_probe_a_per_a, "A")}
        if electronics.voltage_probe_coded:
            self.probes[1] = Probe("", 1.0 / electronics.voltage_probe_attenuation, "V")
        self.sesr = _PON
        self.pending: list[tuple[int, str]] = [(401, "Power on")]
        self.available: list[tuple[int, str]] = []
        self.header = True   # not in Appendix D: the power-on defaults of the HEADer and
        self.verbose = True  # VERBose states
        self.factory_settings()

    def factory_settings(self) -> None:
        self.state = {"record_length": 10000, "horizontal_scale": 4e-4, "acquire_mode": "SAMPLE",
                      "num_averages": 16, "stop_after": "RUNSTOP", "trigger_type": "EDGE", "trigger_mode": "AUTO",
                      "trigger_source": "CH1", "trigger_slope": "RISE", "trigger_coupling": "DC",
                      "trigger_level": 0.0, "math_type": "DUAL", "math_define": "CH1+CH2",
                      "measurement_source": "CH1", "measurement_type": "PERIOD", "data_source": "CH1",
                      "data_encoding": "RIBINARY", "data_width": 1, "data_start": 1, "data_stop": 10000,
                      "select_math": False, "delay_state": True, "delay_time": 0.0, "trigger_position": 10,
                      "gating": "OFF", "cursor_function": "OFF", ("vbar", 1): -1.6e-3, ("vbar", 2): 1.6e-3}
        self.stored = {}
        for n in CHANNELS:
            probe = self.probes.get(n)
            self.state.update({("select", n): n == 1, ("scale", n): 0.1, ("position", n): 0.0,
                               ("offset", n): 0.0, ("coupling", n): "DC", ("bandwidth", n): "FULL",
                               ("impedance", n): "MEG", ("probe", n): probe.gain if probe else 0.1,
                               ("yunit", n): probe.unit if probe else "V"})
        self.running = True
        self._record: traces.Record | None = None
        self._ready_s = 0.0
        self._scaled: tuple = (None, None, None, None)
        # A record's clipping per channel setting, and the last gate: every measurement of
        # an acquisition asks for the same (six extremes, a mean and a frequency per point).
        self._clipped: tuple = (None, {})
        self._gated: tuple = (None, None)

    # -- status and events (TDS PM Section 3) ------------------------------------------------
    def report(self, error: ScpiError) -> None:
        code = abs(error.code)
        self.event(code, error.message, error.detail)

    def event(self, code: int, message: str, command: str = "") -> None:
        bit = (_CME if 100 <= code < 200 else _DDE if 300 <= code < 400 and code != 350
               else _QYE if code in (410, 420, 430, 440) else _PON if code == 401 else _EXE)
        self.sesr |= bit
        if command:   # <Message>;<Command>, at most 60 characters, the command right-justified
            message = f"{message}; {command[-max(0, 58 - len(message)):]}"
        if len(self.pending) >= EVENT_QUEUE_DEPTH:
            self.pending[-1] = (350, "Queue overflow")
        else:
            self.pending.append((code, message))

    def inject_error(self) -> None:
        self.event(222, "Data out of range")

    def _esr(self, unit: Unit) -> bytes:
        """*ESR? reads and clears the SESR and makes the events it summarises readable;
        events not read since the last *ESR? are dropped (TDS PM p. 3-9)."""
        scpi.no_arguments(unit.arguments)
        value, self.sesr = self.sesr, 0
        self.available, self.pending = self.pending, []
        return b"%d" % value

    def _no_events(self) -> tuple[int, str]:
        return (1, "No events to report - new events pending *ESR?") if self.pending \
            else (0, "No events to report - queue empty")

    def _evmsg(self, unit: Unit) -> bytes:
        scpi.no_arguments(unit.arguments)
        code, message = self.available.pop(0) if self.available else self._no_events()
        return f"{code},{_quoted(message)}".encode()

    def _allev(self, unit: Unit) -> bytes:
        scpi.no_arguments(unit.arguments)
        events, self.available = self.available or [self._no_events()], []
        return ",".join(f"{code},{_quoted(message)}" for code, message in events).encode()

    def _event_code(self, unit: Unit) -> bytes:
        scpi.no_arguments(unit.arguments)
        return b"%d" % (self.available.pop(0) if self.available else self._no_events())[0]

    def _clear_status(self, unit: Unit) -> None:
        scpi.no_arguments(unit.arguments)
        self.sesr, self.pending, self.available = 0, [], []

    def _reset(self, unit: Unit) -> None:
        scpi.no_arguments(unit.arguments)
        self.factory_settings()

    def with_header(self, unit: Unit, reply):
        """HEADer ON: a query's reply starts with its header. VERBose OFF: keywords, in the
        header and as the value, come in short form (p. 2-308: `AVERAGE` is `AVE`)."""
        if unit.path.startswith("*") or isinstance(reply, Deferred):
            return reply
        if not self.verbose:
            reply = _SHORT_KEYWORDS.get(reply, reply)
        if not self.header:
            return reply
        path = unit.path if self.verbose else self._short_paths[unit.path]
        for x in unit.suffixes:
            path = path.replace("<X>", str(x), 1).replace("<x>", str(x), 1)
        return b":" + path.encode() + b" " + reply

    def _header_set(self, unit: Unit) -> None:
        self.header = scpi.boolean(scpi.only_argument(unit.arguments))

    def _verbose_set(self, unit: Unit) -> None:
        self.verbose = scpi.boolean(scpi.only_argument(unit.arguments))

    # -- settings with rules -----------------------------------------------------------------
    def _forced(self, value: float, low: float, high: float) -> float:
        """TDS PM p. 2-9: most numbers are forced to a valid setting; the scope warns
        with 525/526 (Table 3-8)."""
        if value > high:
            self.event(526, "Parameter overrange")
            return high
        if value < low:
            self.event(525, "Parameter underrange")
            return low
        return value

    @staticmethod
    def _nearest(value: float, allowed: tuple) -> float:
        """A value with a fixed set of settings is rounded to the nearest (e.g.
        HORizontal:MAIn:SCAle, p. 2-145: "rounded to a valid scale setting")."""
        return min(allowed, key=lambda a: abs(math.log(a / value)) if value > 0 else a)

    def _scale_limits(self, channel: int) -> tuple[float, float]:
        gain = self.state["probe", channel]
        return _SCALE_AT_1X[0] / gain, _SCALE_AT_1X[1] / gain

    def _scale_set(self, unit: Unit) -> None:
        channel = unit.suffixes[0]
        value = scpi.number(scpi.only_argument(unit.arguments))
        self.state["scale", channel] = self._forced(value, *self._scale_limits(channel))

    def _probe_set(self, unit: Unit) -> None:
        """A detected probe has one legal gain: another is a hardware configuration
        error (TDS PM p. 2-68). The volts per division at the input stay: the scale in
        user units follows the gain."""
        channel = unit.suffixes[0]
        gain = scpi.number(scpi.only_argument(unit.arguments))
        probe = self.probes.get(channel)
        if probe is not None:
            if not math.isclose(gain, probe.gain, rel_tol=1e-6):
                raise ScpiError(242, "Hardware configuration error")
            return
        if not 1e-4 <= gain <= 1e4 or gain <= 0:
            raise ScpiError(222, "Data out of range")
        self.state["scale", channel] *= self.state["probe", channel] / gain
        self.state["probe", channel] = gain

    def _offset_set(self, unit: Unit) -> None:
        """CH<x>:OFFSet (p. 2-67): the range follows the scale at the probe's input (Table
        2-30, for a 1x probe; in the channel's units with another), forced like any number."""
        channel = unit.suffixes[0]
        limit = self._offset_limit(channel)
        value = scpi.number(scpi.only_argument(unit.arguments))
        self.state["offset", channel] = self._forced(value, -limit, limit)

    def _offset_limit(self, channel: int) -> float:
        """The largest offset (channel units) at the channel's present scale and probe."""
        gain = self.state["probe", channel]
        input_scale = self.state["scale", channel] * gain
        return next(limit for below, limit in _OFFSET_RANGE_AT_1X if input_scale < below) / gain

    def _input_gain(self, channel: int) -> float:
        """What CH<x>:IMPedance leaves of the signal: CH1 comes through the passive voltage
        probe's tip resistor, CH2 and CH3 from 50 Ohm outputs (current probe amplifier,
        vibrometer decoder)."""
        if self.state["impedance", channel] == "MEG":
            return 1.0
        attenuation = self.bench.scene.electronics.voltage_probe_attenuation
        source_ohm = (attenuation - 1.0) * 1e6 if channel == 1 else 50.0
        return traces.input_gain(50.0, source_ohm)

    def _coupling_set(self, unit: Unit) -> None:
        channel = unit.suffixes[0]
        coupling = scpi.choice(scpi.only_argument(unit.arguments), _COUPLINGS, PREFIX)
        if coupling == "AC" and channel in self.probes:   # TDS PM p. 2-66: not with a level II probe
            raise ScpiError(242, "Hardware configuration error")
        self.state["coupling", channel] = coupling

    def _probe_id(self, unit: Unit) -> bytes:
        scpi.no_arguments(unit.arguments)
        probe = self.probes.get(unit.suffixes[0])
        return _quoted(probe.model if probe else "").encode()

    def _yunit_set(self, unit: Unit) -> None:
        channel = unit.suffixes[0]
        text = scpi.quoted_string(scpi.only_argument(unit.arguments)).upper()
        if text not in ("V", "A"):
            raise scpi.illegal_parameter()
        if channel in self.probes and text != self.probes[channel].unit:
            raise ScpiError(242, "Hardware configuration error")
        self.state["yunit", channel] = text

    def _math_define_set(self, unit: Unit) -> None:
        """MATH:DEFINE <QString> (TDS PM p. 2-198): in DUAL mode "<source><op><source>"."""
        definition = scpi.quoted_string(scpi.only_argument(unit.arguments))
        if self.state["math_type"] == "DUAL" and _MATH_DEFINITION.match(definition) is None:
            raise ScpiError(2235, "Math error, Invalid math description")
        self.state["math_define"] = definition.upper().replace(" ", "")

    def _horizontal_set(self, unit: Unit) -> None:
        value = scpi.number(scpi.only_argument(unit.arguments))
        self.state["horizontal_scale"] = self._nearest(self._forced(value, SCOPE_TIME_BASES_S[0],
                                                                    SCOPE_TIME_BASES_S[-1]), SCOPE_TIME_BASES_S)

    def _select_set(self, unit: Unit, key) -> None:
        self.state[key] = scpi.boolean(scpi.only_argument(unit.arguments))

    def _acquire_state_set(self, unit: Unit) -> None:
        text = scpi.only_argument(unit.arguments).upper()
        run = text in ("RUN", "ON") or (text not in ("STOP", "OFF") and scpi.boolean(text))
        self.running = run
        if run:
            self._start_acquisition()

    def _acquire_state_query(self, unit: Unit) -> bytes:
        scpi.no_arguments(unit.arguments)
        if self.state["stop_after"] == "SEQUENCE" and self.bench.clock.now_s() >= self._ready_s:
            self.running = False
        return b"1" if self.running else b"0"

    # -- acquisitions --------------------------------------------------------------------------
    def setup(self) -> traces.ScopeSetup:
        s = self.state
        averaging = s["acquire_mode"] == "AVERAGE"
        record_s = traces.HORIZONTAL_DIVISIONS * s["horizontal_scale"]
        # Delay on: the screen centre is delay_time after the trigger; off: the trigger
        # sits trigger_position % into the record (Appendix D: delay on, 0 s).
        start_s = s["delay_time"] - record_s / 2.0 if s["delay_state"] else -s["trigger_position"] / 100.0 * record_s
        return _Setup(
            channels=tuple(traces.ChannelSetup(scale_per_div=s["scale", ch], position_div=s["position", ch],
                                               coupling=s["coupling", ch], probe_gain=s["probe", ch],
                                               offset=s["offset", ch], input_gain=self._input_gain(ch))
                           for ch in (1, 2, 3)),
            horizontal_scale_s=s["horizontal_scale"], record_length=s["record_length"],
            averages=s["num_averages"] if averaging else 1, record_start_s=start_s)

    def _start_acquisition(self) -> None:
        setup = self.setup()
        period_s = setup.record_time_s + SCOPE_REARM_S
        record = self.bench.acquire(setup, period_s)
        triggered = self._triggered(record)
        if not triggered and self.state["trigger_mode"] == "NORMAL":
            self._record, self._ready_s = record, math.inf   # waits for a trigger that never comes
            return
        self._record = record if triggered else self._untriggered(record)
        self._ready_s = self.bench.clock.now_s() + setup.averages * period_s

    def _triggered(self, record: traces.Record) -> bool:
        """An edge trigger fires when its source crosses the level: a driven channel
        (CH1-CH3 carry the plate's signals, CH4 is idle) whose trace spans the level."""
        s = self.state
        source = s["trigger_source"]
        if s["trigger_type"] != "EDGE" or source not in ("CH1", "CH2", "CH3"):
            return False
        trace = record.trace(source)
        return float(trace.min()) < s["trigger_level"] < float(trace.max())

    def _untriggered(self, record: traces.Record) -> traces.Record:
        """AUTO mode without a trigger: each waveform starts at a random phase of the
        drive, so averaging N of them shrinks the alternating part by |mean(exp(i phi))|
        (about 1/sqrt(N)); a single waveform keeps its amplitude."""
        n = record.setup.averages
        if n == 1:
            return record
        rng = np.random.default_rng([self.bench.scene.seed, round(self.bench.clock.now_s() * 1e9)])
        shrink = abs(np.mean(np.exp(1j * rng.uniform(0.0, 2.0 * math.pi, n))))
        mean = record.values.mean(axis=1, keepdims=True)
        return traces.Record(record.setup, mean + shrink * (record.values - mean), record.frequency_hz)

    def record(self) -> traces.Record:
        """The last acquisition; a scope never started shows what it free-runs on."""
        if self._record is None or (self.running and self.state["stop_after"] == "RUNSTOP"):
            self._start_acquisition()
        return self._record

    def _opc_query(self, unit: Unit):
        scpi.no_arguments(unit.arguments)
        return Deferred(self._ready_s, b"1")

    def _busy(self, unit: Unit) -> bytes:
        scpi.no_arguments(unit.arguments)
        return b"1" if self.bench.clock.now_s() < self._ready_s else b"0"

    # -- what a source shows -------------------------------------------------------------------
    def displayed(self, source: str) -> bool:
        return self.state["select_math"] if source == "MATH" else self.state["select", int(source[2:])]

    def _channel_trace(self, record: traces.Record, source: str) -> np.ndarray:
        channel = int(source[2:])
        return record.trace(source) if channel <= 3 else np.zeros(record.setup.record_length)

    def trace(self, source: str) -> np.ndarray | None:
        """`source` in its units, or None when the scope has no waveform for it: not
        displayed, or MATH in another mode than the DUAL waveform math simulated here."""
        if not self.displayed(source):
            return None
        record = self.record()
        if source != "MATH":
            return self._channel_trace(record, source)
        match = _MATH_DEFINITION.match(self.state["math_define"])
        if self.state["math_type"] != "DUAL" or match is None or "REF" in match.group(0):
            return None
        first, operator, second = (self._channel_trace(record, match.group(1)), match.group(2),
                                   self._channel_trace(record, match.group(3)))
        if operator == "*" and (match.group(1), match.group(3)) == ("CH1", "CH2"):
            return record.trace("MATH")
        with np.errstate(divide="ignore", invalid="ignore"):
            return {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.divide}[operator](first, second)

    def _clipping(self, source: str) -> tuple[int, str] | None:
        """Measurement error 2227-2229 (TDS PM Table 3-5) when a channel the source
        shows reaches the ADC limits."""
        if source == "MATH":
            match = _MATH_DEFINITION.match(self.state["math_define"])
            channels = [int(match.group(i)[2:]) for i in (1, 3)] if match else []
        else:
            channels = [int(source[2:])]
        record = self.record()
        if self._clipped[0] is not record:
            self._clipped = (record, {})
        high = low = False
        for channel in (c for c in channels if c <= 3):
            setting = (channel, self.state["offset", channel], self.state["scale", channel],
                       self.state["position", channel])
            if setting not in self._clipped[1]:
                screen = (record.trace(f"CH{channel}") - setting[1]) / setting[2] + setting[3]
                self._clipped[1][setting] = (bool(np.any(screen >= fx.ADC_MAX_DIV - 1e-9)),
                                             bool(np.any(screen <= fx.ADC_MIN_DIV + 1e-9)))
            channel_high, channel_low = self._clipped[1][setting]
            high, low = high or channel_high, low or channel_low
        if high and low:
            return 2227, "Positive and Negative Clipping"
        if high or low:
            return (2228, "Measurement error, Positive Clipping") if high else \
                (2229, "Measurement error, Negative Clipping")
        return None

    def _measurement(self, unit: Unit) -> bytes:
        """MEASUrement:IMMed:VALue? (TDS PM p. 2-213): 9.91E37 and the reason in the
        event queue when there is no value."""
        scpi.no_arguments(unit.arguments)
        source, kind = self.state["measurement_source"], self.state["measurement_type"]
        trace = self.trace(source)
        if trace is None:
            self.event(2225, "Measurement error, No waveform to measure")
            return NO_VALUE
        clipping = self._clipping(source)
        if clipping is not None:
            self.event(*clipping)
            return NO_VALUE
        if kind not in _SIMULATED_MEASUREMENTS:
            self.event(2200, "Measurement error, Measurement system error")
            return NO_VALUE
        record = self.record()
        gate = self._gate(record.setup)
        if gate is None:
            self.event(2206, "Measurement error, Invalid gate")
            return NO_VALUE
        value = traces.measure(traces.Record(record.setup, trace[None, gate], record.frequency_hz), "CH1",
                               _SIMULATED_MEASUREMENTS[kind])
        if not math.isfinite(value):
            self.event(2202, "Measurement error, No period found")
            return NO_VALUE
        return b"%.12E" % value

    def _gate(self, setup: traces.ScopeSetup) -> slice | None:
        """The samples a measurement uses: the whole record, or with MEASUrement:GATing
        CURSor those between the vertical bar cursors (p. 2-207); None if none are."""
        if self.state["gating"] != "CURSOR":
            return slice(None)
        low, high = sorted((self.state["vbar", 1], self.state["vbar", 2]))
        key = (setup.first_sample_s, setup.sample_interval_s, setup.record_length, low, high)
        if self._gated[0] != key:
            times_s = setup.times_s()
            inside = np.flatnonzero((times_s >= low) & (times_s <= high))
            self._gated = (key, slice(int(inside[0]), int(inside[-1]) + 1) if inside.size else None)
        return self._gated[1]

    def _measurement_units(self, unit: Unit) -> bytes:
        scpi.no_arguments(unit.arguments)
        source = self.state["measurement_source"]
        return _quoted("VA" if source == "MATH" else self.state["yunit", int(source[2:])]).encode()

    # -- waveform transfer (TDS PM p. 2-39 to 2-43, CURVe p. 2-90, WFMPre? p. 2-314) -------------
    def _selection(self) -> tuple[str, int, int, int, str]:
        s = self.state
        n = s["record_length"]
        start = min(max(1, s["data_start"]), n)
        stop = min(max(start, s["data_stop"]), n)
        return s["data_source"], start, stop, s["data_width"], s["data_encoding"]

    def _scaling(self, source: str, width: int) -> tuple[float, float, float, np.ndarray]:
        """(YMUlt, YOFf, YZEro, raw counts) of `source` in the last record (WFMPre? then CURVe?
        ask for the same, so the last answer is kept)."""
        record, (kept, kept_source, kept_width, scaled) = self.record(), self._scaled
        if not (kept is record and kept_source == source and kept_width == width):
            scaled = self._scale(source, width, self.trace(source))
            self._scaled = (record, source, width, scaled)
        return scaled

    def _scale(self, source: str, width: int, trace: np.ndarray) -> tuple[float, float, float, np.ndarray]:
        """(YMUlt, YOFf, YZEro, counts): YZEro carries the channel's offset (p. 2-314)."""
        if source == "MATH":
            peak = float(np.max(np.abs(trace)))
            y_mult, y_off, y_zero = (peak / 32000.0 if peak > 0 else 1.0), 0.0, 0.0
        else:
            channel = int(source[2:])
            y_mult = self.state["scale", channel] / fx.COUNTS_PER_DIV
            y_off = self.state["position", channel] * fx.COUNTS_PER_DIV
            y_zero = self.state["offset", channel]
        counts = np.clip(np.round((trace - y_zero) / y_mult + y_off), -32768, 32767)
        if width == 1:  # the high byte of the left-justified 16-bit sample
            return y_mult * 256.0, y_off / 256.0, y_zero, np.floor(counts / 256.0)
        return y_mult, y_off, y_zero, counts

    def _preamble(self, unit: Unit) -> bytes:
        """WFMPre?: the 16 fields, or only the five transmission fields when the source is
        not displayed (TDS PM p. 2-314)."""
        scpi.no_arguments(unit.arguments)
        source, start, stop, width, encoding = self._selection()
        fmt, order = _FORMATS[encoding]
        fields = [str(width), str(8 * width), "ASC" if encoding == "ASCII" else "BIN", fmt, order]
        if self.trace(source) is not None:
            setup = self.record().setup
            y_mult, y_off, y_zero, _ = self._scaling(source, width)
            mode = f"Average mode ({setup.averages})" if setup.averages > 1 else "Sample mode"
            if source == "MATH":
                unit_name = "VA"
                wfid = f"Math, {setup.horizontal_scale_s:.1E} s/div, {setup.record_length} points, {mode}"
            else:
                channel = int(source[2:])
                unit_name = self.state["yunit", channel]
                wfid = (f"Ch{channel}, {self.state['coupling', channel]} coupling, "
                        f"{self.state['scale', channel]:.1E} {unit_name}/div, {setup.horizontal_scale_s:.1E} s/div, "
                        f"{setup.record_length} points, {mode}")
            x_zero = setup.first_sample_s + (start - 1) * setup.sample_interval_s
            fields += [str(stop - start + 1), _quoted(wfid), "Y", f"{setup.sample_interval_s:.12E}", "0",
                       f"{x_zero:.12E}", '"s"', f"{y_mult:.12E}", f"{y_zero:.12E}", f"{y_off:.12E}", _quoted(unit_name)]
        if self.header:
            return (":WFMPRE:" + ";".join(f"{name} {value}" for name, value in zip(_PREAMBLE_FIELDS, fields))).encode()
        return ";".join(fields).encode()

    def _curve(self, unit: Unit) -> bytes:
        """CURVe?: the record as a block; a source not displayed is refused (Table 2-31)."""
        scpi.no_arguments(unit.arguments)
        source, start, stop, width, encoding = self._selection()
        if self.trace(source) is None:
            raise ScpiError(2244, "Waveform requested is not turned on")
        *_, counts = self._scaling(source, width)
        counts = counts[start - 1:stop].astype(np.int64)
        if encoding == "ASCII":
            return b",".join(b"%d" % c for c in counts)
        fmt, order = _FORMATS[encoding]
        if fmt == "RP":  # unsigned binary: offset by half the range
            counts = counts + (128 if width == 1 else 32768)
        dtype = ("<" if order == "LSB" else ">") + ("u" if fmt == "RP" else "i") + str(width)
        data = counts.astype(dtype).tobytes()
        length = b"%d" % len(data)
        return b"#%d%s%s" % (len(length), length, data)

    def _waveform(self, unit: Unit) -> bytes:
        """WAVFrm? (p. 2-309): WFMPre? and CURVe? in one reply; only the transmission fields
        of the preamble when the source is not displayed."""
        preamble = self._preamble(unit)
        if self.trace(self._selection()[0]) is None:
            return preamble
        curve = Unit("CURVE", True, (), (), unit.text)
        return preamble + b";" + self.with_header(curve, self._curve(curve))

    def _event_count(self, unit: Unit) -> bytes:
        """EVQty? (p. 2-127): the events *ESR? made readable and not read yet."""
        scpi.no_arguments(unit.arguments)
        return b"%d" % len(self.available)

    COMMANDS = (
        Command("*IDN", lambda s, u: s.IDENTITY, None, "p. 2-149 *IDN?"),
        Command("*RST", None, _reset, "p. 2-252 *RST"),
        Command("*CLS", None, _clear_status, "p. 2-71 *CLS"),
        Command("*ESR", _esr, None, "p. 2-116 *ESR?"),
        Command("*OPC", _opc_query, lambda s, u: None, "p. 2-240 *OPC"),
        Command("EVMsg", _evmsg, None, "p. 2-126 EVMsg?"),
        Command("ALLEv", _allev, None, "p. 2-54 ALLEv?"),
        Command("EVENT", _event_code, None, "p. 2-125 EVENT?"),
        Command("BUSY", _busy, None, "p. 2-55 BUSY?"),
        Command("HEADer", lambda s, u: b"1" if s.header else b"0", _header_set, "p. 2-143 HEADer"),
        Command("VERBose", lambda s, u: b"1" if s.verbose else b"0", _verbose_set, "p. 2-308 VERBose"),
        Command("CH<x>:SCAle", _setting("scale", None, _nr3, per_channel=True)[0], _scale_set, "p. 2-69 CH<x>:SCAle"),
        Command("CH<x>:VOLts", _setting("scale", None, _nr3, per_channel=True)[0], _scale_set, "p. 2-70 CH<x>:VOLts"),
        Command("CH<x>:POSition", *_setting("position", lambda s, t, u: s._forced(scpi.number(t), -5.0, 5.0), _nr3,
                                            per_channel=True), "p. 2-68 CH<x>:POSition"),
        Command("CH<x>:COUPling", _setting("coupling", None, str, per_channel=True)[0], _coupling_set,
                "p. 2-64 CH<x>:COUPling"),
        Command("CH<x>:BANdwidth", *_setting("bandwidth", _tds_choice(_BANDWIDTHS), str, per_channel=True),
                "p. 2-63 CH<x>:BANdwidth"),
        Command("CH<x>:IMPedance", *_setting("impedance", _tds_choice(_IMPEDANCES), str, per_channel=True),
                "p. 2-66 CH<x>:IMPedance"),
        Command("CH<x>:OFFSet", _setting("offset", None, _nr3, per_channel=True)[0], _offset_set,
                "p. 2-67 CH<x>:OFFSet"),
        Command("CH<x>:PRObe", _setting("probe", None, _nr3, per_channel=True)[0], _probe_set, "p. 2-68 CH<x>:PRObe"),
        Command("CH<x>:ID", _probe_id, None, "p. 2-65 CH<x>:ID?"),
        Command("CH<x>:YUNit", _setting("yunit", None, _quoted, per_channel=True)[0], _yunit_set,
                "p. 2-70 CH<x>:YUNit"),
        Command("SELect:CH<x>", _setting("select", None, _flag, per_channel=True)[0],
                lambda s, u: s._select_set(u, ("select", u.suffixes[0])), "p. 2-260 SELect:<wfm>"),
        Command("SELect:MATH", _setting("select_math", None, _flag)[0],
                lambda s, u: s._select_set(u, "select_math"), "p. 2-260 SELect:<wfm>"),
        Command("HORizontal:MAIn:SCAle", _setting("horizontal_scale", None, _nr3)[0], _horizontal_set,
                "p. 2-146 HORizontal:MAIn:SCAle"),
        Command("HORizontal:RECORDLength", *_setting("record_length", _nearest_int(_RECORD_LENGTHS), str),
                "p. 2-147 HORizontal:RECORDLength"),
        Command("HORizontal:DELay:STATE", *_setting("delay_state", lambda s, t, u: scpi.boolean(t), _flag),
                "p. 2-144 HORizontal:DELay:STATE"),
        Command("HORizontal:DELay:TIMe", *_setting("delay_time", lambda s, t, u: scpi.number(t), _nr3),
                "p. 2-145 HORizontal:DELay:TIMe"),
        Command("HORizontal:TRIGger:POSition", *_setting("trigger_position", _int(0, 100), str),
                "p. 2-148 HORizontal:TRIGger:POSition"),
        Command("MEASUrement:GATing", *_setting("gating", _tds_choice(_GATINGS), str), "p. 2-207 MEASUrement:GATing"),
        Command("CURSor:FUNCtion", *_setting("cursor_function", _tds_choice(_CURSORS), str), "p. 2-72 CURSor:FUNCtion"),
        Command("CURSor:VBArs:POSITION<x>", *_setting("vbar", lambda s, t, u: scpi.number(t), _nr3, per_channel=True),
                "p. 2-79 CURSor:VBArs:POSITION<x>", suffixes=(1, 2)),
        Command("ACQuire:MODe", *_setting("acquire_mode", _tds_choice(_ACQ_MODES), str), "p. 2-45 ACQuire:MODe"),
        Command("ACQuire:NUMAVg", *_setting("num_averages", _nearest_int(_AVERAGES), str), "p. 2-47 ACQuire:NUMAVg"),
        Command("ACQuire:STOPAfter", *_setting("stop_after", _tds_choice(_STOP_AFTER), str),
                "p. 2-49 ACQuire:STOPAfter"),
        Command("ACQuire:STATE", _acquire_state_query, _acquire_state_set, "p. 2-48 ACQuire:STATE"),
        Command("TRIGger:A:TYPe", *_setting("trigger_type", _tds_choice(_TRIGGER_TYPES), str),
                "p. 2-289 TRIGger:A:TYPe"),
        Command("TRIGger:A:MODe", *_setting("trigger_mode", _tds_choice(_TRIGGER_MODES), str),
                "p. 2-277 TRIGger:A:MODe"),
        Command("TRIGger:A:EDGe:SOUrce", *_setting("trigger_source", _tds_choice(_TRIGGER_SOURCES), str),
                "p. 2-269 TRIGger:A:EDGe:SOUrce"),
        Command("TRIGger:A:EDGe:SLOpe", *_setting("trigger_slope", _tds_choice(_SLOPES), str),
                "p. 2-269 TRIGger:A:EDGe:SLOpe"),
        Command("TRIGger:A:EDGe:COUPling", *_setting("trigger_coupling", _tds_choice(_TRIGGER_COUPLINGS), str),
                "p. 2-268 TRIGger:A:EDGe:COUPling"),
        Command("TRIGger:A:LEVel", *_setting("trigger_level", _trigger_level, _nr3),
                "p. 2-271 TRIGger:A:LEVel"),
        Command("MATH:TYPe", *_setting("math_type", _tds_choice(_MATH_TYPES), str), "p. 2-202 MATH:TYPe"),
        Command("MATH:DEFINE", _setting("math_define", None, _quoted)[0], _math_define_set, "p. 2-198 MATH:DEFINE"),
        Command("MEASUrement:IMMed:SOUrce", *_setting("measurement_source", _tds_choice(_SOURCES), str),
                "p. 2-210 MEASUrement:IMMed:SOUrce"),
        Command("MEASUrement:IMMed:SOURCE1", *_setting("measurement_source", _tds_choice(_SOURCES), str),
                "p. 2-210 MEASUrement:IMMed:SOURCE<x>"),
        Command("MEASUrement:IMMed:TYPe", *_setting("measurement_type", _tds_choice(_MEASUREMENTS), str),
                "p. 2-211 MEASUrement:IMMed:TYPe"),
        Command("MEASUrement:IMMed:VALue", _measurement, None, "p. 2-213 MEASUrement:IMMed:VALue?"),
        Command("MEASUrement:IMMed:UNIts", _measurement_units, None, "p. 2-213 MEASUrement:IMMed:UNIts?"),
        Command("DATa:SOUrce", *_setting("data_source", _tds_choice(_SOURCES), str), "p. 2-94 DATa:SOUrce"),
        Command("DATa:ENCdg", *_setting("data_encoding", _tds_choice(_ENCODINGS), str), "p. 2-93 DATa:ENCdg"),
        Command("DATa:WIDth", *_setting("data_width", _nearest_int((1, 2)), str), "p. 2-97 DATa:WIDth"),
        Command("DATa:STARt", *_setting("data_start", _int(1, 10000), str), "p. 2-95 DATa:STARt"),
        Command("DATa:STOP", *_setting("data_stop", _int(1, 10000), str), "p. 2-96 DATa:STOP"),
        Command("WFMPre", _preamble, None, "p. 2-314 WFMPre?"),
        Command("CURVe", _curve, None, "p. 2-90 CURVe"),
        Command("WAVFrm", _waveform, None, "p. 2-309 WAVFrm?"),
        Command("EVQty", _event_count, None, "p. 2-127 EVQty?"),
    )

    def changed(self, key: str, unit: Unit) -> None:
        """Nothing happens at once: settings act on the next acquisition."""

    # -- state-only headers (state_only): replies as the TDS formats numbers and keywords ----
    def clipped(self, value: float, low: float, high: float) -> float:
        return self._forced(value, low, high)

    @staticmethod
    def number_reply(value: float, integer: bool) -> str:
        return str(int(value)) if integer else _nr3(value)

    def choice_reply(self, value: str, spelling: str) -> str:
        return value if self.verbose else scpi.short_form(spelling)


# == Polytec OFV-5000 =================================================================================
#: Velocity decoders and their ranges as the controller spells them (unverified against
#: Polytec's documentation: the VD-09 and VD-02 range sets are from Polytec data sheets as
#: remembered; the controller lists the installed decoder's with GetDevInfo,VeloDec,0,Range).
DECODERS = {
    "VD-09": ("5mm/s/V", "10mm/s/V", "20mm/s/V", "50mm/s/V", "100mm/s/V", "200mm/s/V", "500mm/s/V", "1000mm/s/V"),
    "VD-02": ("5mm/s/V", "25mm/s/V", "125mm/s/V", "1000mm/s/V"),
}
#: The output filter settings as the controller spells them (high-pass corners unverified).
#: Kept as state: the simulated decoder output does not pass through them.
LOW_PASS_FILTERS = ("Off", "5 kHz", "20 kHz", "100 kHz")
HIGH_PASS_FILTERS = ("Off", "100 Hz")
TRACKING_FILTERS = ("Off", "Slow", "Fast")
_RANGE = re.compile(r"^\s*([0-9.]+)\s*(mm|m)/s/V\s*$")


class Vibrometer(SimulatedInstrument):
    """Polytec OFV-5000 controller: ASCII lines `<Verb>,<Device>,<index>,<Attribute>[,<value>]`,
    echo on at power-on, `Error` for a line it refuses; the decoder range scales CH3."""

    role = "vibrometer"
    #: The lines (Device,index,Attribute) that act: on the protocol (echo) or on the signal
    #: chain (the decoder range scales CH3; over-range and signal level read the bench).
    #: Every other line of the command set (command_tables) is kept as state only.
    MODELLED = frozenset({"Controller,0,Name", "Interface,0,Echo", "VeloDec,0,Name", "VeloDec,0,Range",
                          "OverRange,0,Value", "SignalLevel,0,Value"})

    def power_on(self) -> None:
        self.decoder = self.options.get("decoder", "VD-09")
        if self.decoder not in DECODERS:
            raise ValueError(f"vibrometer: unknown decoder {self.decoder!r} (known: {', '.join(DECODERS)})")
        self.state = {"echo": "On", "range": DECODERS[self.decoder][-1], "low_pass": "100 kHz", "high_pass": "Off",
                      "tracking": "Off"}
        self._lines: dict[tuple[str, str, str, str], Callable[[str | None], bytes | None]] = {
            ("GetDevInfo", "Controller", "0", "Name"): lambda value: b"OFV-5000",
            ("Get", "Interface", "0", "Echo"): lambda value: self.state["echo"].encode(),
            ("Set", "Interface", "0", "Echo"): self._setter("echo", ("On", "Off")),
            ("Get", "VeloDec", "0", "Name"): lambda value: self.decoder.encode(),
            ("GetDevInfo", "VeloDec", "0", "Name"): lambda value: self.decoder.encode(),
            ("GetDevInfo", "VeloDec", "0", "Range"): lambda value: ",".join(DECODERS[self.decoder]).encode(),
            ("Get", "VeloDec", "0", "Range"): lambda value: self.state["range"].encode(),
            ("Set", "VeloDec", "0", "Range"): self._setter("range", DECODERS[self.decoder]),
            ("GetDevInfo", "VeloFilter", "0", "LowPassRange"): lambda value: ",".join(LOW_PASS_FILTERS).encode(),
            ("Get", "VeloFilter", "0", "LowPassRange"): lambda value: self.state["low_pass"].encode(),
            ("Set", "VeloFilter", "0", "LowPassRange"): self._setter("low_pass", LOW_PASS_FILTERS),
            ("GetDevInfo", "VeloFilter", "0", "HighPassRange"): lambda value: ",".join(HIGH_PASS_FILTERS).encode(),
            ("Get", "VeloFilter", "0", "HighPassRange"): lambda value: self.state["high_pass"].encode(),
            ("Set", "VeloFilter", "0", "HighPassRange"): self._setter("high_pass", HIGH_PASS_FILTERS),
            ("Get", "TrackingFilter", "0", "Range"): lambda value: self.state["tracking"].encode(),
            ("Set", "TrackingFilter", "0", "Range"): self._setter("tracking", TRACKING_FILTERS),
            ("Get", "OverRange", "0", "Value"): lambda value: b"1" if self.bench.vibrometer_over_range() else b"0",
            ("Get", "SignalLevel", "0", "Value"):
                lambda value: b"%d" % round(self.bench.scene.measurement_point.signal_level_percent),
        }
        self.stored: dict[str, str] = {}
        for entry in command_tables.table("ofv5000"):
            for verb in entry.forms:
                self._lines.setdefault((verb, *entry.header.split(",")), self._state_only(entry, verb))

    def _setter(self, key: str, allowed: tuple[str, ...]):
        def set_(value: str | None) -> bytes | None:
            if value not in allowed:
                return b"Error"
            self.state[key] = value
            return None
        return set_

    def _state_only(self, entry: command_tables.Entry, verb: str) -> Callable[[str | None], bytes | None]:
        """A line the simulator does not model: Set keeps a value among those the table
        lists (or a number in its low..high), Get reads it back, GetDevInfo lists them."""
        values = entry.arguments.split("|") if entry.arguments else []
        if verb == "GetDevInfo":
            return lambda value: (",".join(values) if values else entry.reply).encode()
        if verb == "Get":
            return lambda value: self.stored.get(entry.header, entry.reply).encode()
        low_high = [float(v) for v in values[0].split("..")] if len(values) == 1 and ".." in values[0] else None

        def set_(value: str | None) -> bytes | None:
            try:
                allowed = low_high[0] <= float(value) <= low_high[1] if low_high else value in values
            except ValueError:
                allowed = False
            if not allowed:
                return b"Error"
            self.stored[entry.header] = value
            return None
        return set_

    def is_query(self, message: bytes) -> bool:
        return message.startswith(b"Get")

    def handle(self, message: bytes) -> list:
        replies = [message] if self.state["echo"] == "On" else []
        text = message.decode("ascii", errors="replace").strip()
        fields = text.split(",")
        key = tuple(fields[:4])
        action = self._lines.get(key) if len(key) == 4 else None
        value = fields[4] if len(fields) == 5 else None
        if action is None or (key[0] == "Set") != (value is not None) or len(fields) > 5:
            replies.append(b"Error")
        else:
            reply = action(value)
            if reply is not None:
                replies.append(reply)
        return replies

    def range_mps_per_v(self) -> float:
        match = _RANGE.match(self.state["range"])
        return float(match.group(1)) * (1e-3 if match.group(2) == "mm" else 1.0)


INSTRUMENTS = {cls.role: cls for cls in (Generator, Scope, Vibrometer)}


# == start states ======================================================================================
def hostile_start(bench) -> None:
    """Instruments as a previous user may leave them: scope math in FFT mode, trigger on
    the idle CH4, every channel off, headers on, envelope single sequence, stale events;
    generator with a square wave, Vrms units, 50 ohm and a stale error; vibrometer echo
    on with the decoder on its most sensitive range and the 5 kHz filter; the stage homed
    but left far from zero, slowed to 5 mm/s, with a refused command's letter pending."""
    scope, generator, vibrometer = bench.scope, bench.generator, bench.vibrometer
    scope.state.update({"math_type": "FFT", "math_define": "FFT(CH1,HANNING,LOGRMS)", "trigger_source": "CH4",
                        "trigger_mode": "NORMAL", "acquire_mode": "ENVELOPE", "stop_after": "SEQUENCE",
                        "data_encoding": "ASCII", "data_width": 1, "record_length": 500, "select_math": False,
                        ("probe", 3): 0.1, ("coupling", 1): "AC"})
    for channel in CHANNELS:
        scope.state["select", channel] = False
    scope.event(113, "Undefined header", "MATH:DEFI \"CH1*CH2\"")
    scope.header = True
    generator.state.update({"shape": "SQU", "unit": "VRMS", "offset": 0.5})
    generator.report(ScpiError(-113, "Undefined header"))
    vibrometer.state.update({"echo": "On", "range": DECODERS[vibrometer.decoder][0], "low_pass": "5 kHz"})
    if bench.stage is not None:
        bench.stage.leave(x_mm=150.0, y_mm=20.0, velocity_mm_per_s=5.0, error="C")


def previous_user_start(bench, seed: int) -> None:
    """Instruments as one previous user, drawn from `seed`, may have left them: every
    setting the simulated instruments have, each drawn among the values its manual allows
    (a coded probe's gain and a level II probe's coupling stay what the hardware allows),
    plus a stale event on the scope and an error on the generator. Nothing is power-cycled."""
    rng = np.random.default_rng([seed, zlib.crc32(b"previous user")])

    def pick(options):
        options = list(options)
        return options[int(rng.integers(len(options)))]

    scope, generator, vibrometer = bench.scope, bench.generator, bench.vibrometer
    s = scope.state
    for n in CHANNELS:
        if n not in scope.probes:
            s["probe", n] = pick((1.0, 0.1, 0.01, 0.001))
        finest, coarsest = scope._scale_limits(n)
        s["scale", n] = pick(v for v in (1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0) if finest <= v <= coarsest)
        limit = scope._offset_limit(n)
        s.update({("select", n): bool(rng.integers(2)), ("position", n): float(rng.uniform(-5.0, 5.0)),
                  ("offset", n): pick((0.0, float(rng.uniform(-limit, limit)))),
                  ("coupling", n): pick(("DC", "GND") if n in scope.probes else _COUPLINGS.values()),
                  ("bandwidth", n): pick(_BANDWIDTHS.values()), ("impedance", n): pick(_IMPEDANCES.values())})
    math_type = pick(_MATH_TYPES.values())
    s.update({"record_length": pick(_RECORD_LENGTHS), "horizontal_scale": pick(SCOPE_TIME_BASES_S[6:24]),
              "acquire_mode": pick(_ACQ_MODES.values()), "num_averages": pick(_AVERAGES),
              "stop_after": pick(_STOP_AFTER.values()), "trigger_type": pick(_TRIGGER_TYPES.values()),
              "trigger_mode": pick(_TRIGGER_MODES.values()), "trigger_source": pick(_TRIGGER_SOURCES.values()),
              "trigger_slope": pick(_SLOPES.values()), "trigger_coupling": pick(_TRIGGER_COUPLINGS.values()),
              "trigger_level": float(rng.uniform(-2.0, 2.0)), "math_type": math_type,
              "math_define": pick(("CH1+CH2", "CH2-CH3", "CH1*CH3")) if math_type == "DUAL"
              else "FFT(CH1,HANNING,LOGRMS)",
              "measurement_source": pick(_SOURCES.values()), "measurement_type": pick(_SIMULATED_MEASUREMENTS),
              "data_source": pick(_SOURCES.values()), "data_encoding": pick(_ENCODINGS.values()),
              "data_width": pick((1, 2)), "data_start": int(rng.integers(1, 500)), "data_stop": int(rng.integers(1, 10001)),
              "select_math": bool(rng.integers(2)), "delay_state": bool(rng.integers(2)),
              "delay_time": float(rng.uniform(-1e-3, 1e-3)), "trigger_position": int(rng.integers(0, 101)),
              "gating": pick(_GATINGS.values()), "cursor_function": pick(_CURSORS.values()),
              ("vbar", 1): float(rng.uniform(-2e-3, 2e-3)), ("vbar", 2): float(rng.uniform(-2e-3, 2e-3))})
    scope.header, scope.verbose = bool(rng.integers(2)), bool(rng.integers(2))
    scope.event(113, "Undefined header", "MATH:DEFI \"CH1*CH2\"")
    load = pick(GEN_PEAK_V)
    low, high = GEN_AMPLITUDE_VPP[load]
    amplitude_vpp = float(rng.uniform(low, high))
    offset_limit = GEN_PEAK_V[load] - amplitude_vpp / 2.0
    generator.state.update({"shape": pick(_GEN_SHAPES.values()), "frequency": float(10 ** rng.uniform(1.0, 6.0)),
                            "unit": pick(_GEN_UNITS.values()), "load": load, "amplitude_vpp": amplitude_vpp,
                            "offset": float(rng.uniform(-offset_limit, offset_limit)),
                            "modulation": pick((None, *GEN_MODULATIONS))})
    generator.report(ScpiError(-113, "Undefined header"))
    vibrometer.state.update({"echo": pick(("On", "Off")), "range": pick(DECODERS[vibrometer.decoder]),
                             "low_pass": pick(LOW_PASS_FILTERS), "high_pass": pick(HIGH_PASS_FILTERS),
                             "tracking": pick(TRACKING_FILTERS)})
    if bench.stage is not None:
        bench.stage.leave(x_mm=float(rng.uniform(0.0, 300.0)), y_mm=float(rng.uniform(0.0, 100.0)),
                          velocity_mm_per_s=float(rng.uniform(1.0, 20.0)), error=pick("@CDH"))


START_STATES: dict[str, Callable] = {"power_on": lambda bench: None, "hostile": hostile_start}
_PREVIOUS_USER = re.compile(r"^previous-(\d+)$")


def start_state(name: str) -> Callable:
    """The start state `name`: one of START_STATES, or `previous-<seed>` (previous_user_start)."""
    if name in START_STATES:
        return START_STATES[name]
    match = _PREVIOUS_USER.match(name)
    if match is None:
        raise ValueError(f"unknown simulated bench start state {name!r} "
                         f"(known: {', '.join(START_STATES)}, previous-<seed>)")
    return lambda bench: previous_user_start(bench, int(match.group(1)))
