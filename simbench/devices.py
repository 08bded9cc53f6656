"""The simulated instruments: pyvisa-sim devices whose dynamic replies come from physics.

Each wrapper keeps pyvisa-sim's grammar and state (dialogues, properties with their
specs, error queues): a message that is not one of the few dynamic queries goes to the
wrapped `pyvisa_sim.devices.Device` exactly as it would in pyvisa-sim. The wrapper adds:

- whole-reply reads (pyvisa-sim hands out one byte per call, far too slow for 20 kB
  records), and an immediate VISA timeout, with the bench clock advanced by the
  session timeout, when the instrument has nothing to say;
- bench time for every message (bus latency and transfer) and for what the instrument
  does (generator settling, scope acquisitions);
- the dynamic queries: scope `*OPC?`, `BUSY?`, `MEASU:IMM:VAL?`, `WFMP?`, `CURV?`, and
  vibrometer `Get,OverRange,0,Value`, `Get,SignalLevel,0,Value`.
"""

from __future__ import annotations

import copy
import math
import re
from collections import deque
from dataclasses import dataclass
from typing import Callable, ClassVar

import numpy as np
from pyvisa import constants, errors
from pyvisa_sim.component import NoResponse
from pyvisa_sim.devices import Device

from squeezebench.simbench import effects as fx
from squeezebench.simbench import physics, traces
from squeezebench.simbench.clock import BusTiming

#: Bench time the 33120A takes to apply a change (assumed: a new frequency settles in
#: about 10 ms; an amplitude, offset or load change may switch attenuator relays).
GENERATOR_FREQUENCY_SETTLE_S = 0.010
GENERATOR_LEVEL_SETTLE_S = 0.030
#: Time between two averaged acquisitions of the TDS3054B beyond the record itself
#: (assumed: trigger re-arm plus processing and display of each waveform).
SCOPE_REARM_S = 0.010


@dataclass
class Deferred:
    """A reply the instrument gives only once it has finished (e.g. `*OPC?`)."""

    ready_s: float
    payload: bytes


class SimulatedInstrument:
    """A pyvisa-sim device with whole-message reads, bench time and dynamic replies."""

    role: ClassVar[str]

    def __init__(self, device: Device, bench, bus: BusTiming) -> None:
        self.device = device
        self.bench = bench
        self.bus = bus
        self._input = bytearray()
        self._replies: deque = deque()
        self.disconnected = False   # set by the `disconnect` fault, for good
        self._defaults = self._property_values()
        self._dynamic: dict[bytes, Callable[[], bytes | Deferred]] = self.dynamic_queries()

    def dynamic_queries(self) -> dict[bytes, Callable[[], bytes | Deferred]]:
        return {}

    # -- what the VISA library calls ------------------------------------------------------
    def write(self, data: bytes) -> None:
        self.bench.clock.advance(self.bus.message_s(len(data)))
        self._input += data
        eom = self.device._query_eom
        if not self._input.endswith(eom):
            return
        message = bytes(self._input[:-len(eom)])
        self._input.clear()
        for query in message.split(self.device.delimiter) if self.device.delimiter else [message]:
            faults = self._faults(query) if self.bench.effects.bus else ()
            reply = self.handle(query)
            if isinstance(reply, Deferred):
                reply.payload += self.device._response_eom
            elif reply is not None and reply is not NoResponse:
                reply = bytearray(reply + self.device._response_eom)
            else:
                continue
            for fault in faults:
                reply = self._faulty_reply(fault, reply)
                if reply is None:   # lost: later faults have nothing to act on
                    break
            else:
                self._replies.append(reply)

    def is_query(self, message: bytes) -> bool:
        """Whether `message` asks for a reply (IEEE 488.2: it ends with '?')."""
        return message.endswith(b"?")

    # -- faults (the scene's `bus` effects) ----------------------------------------------------
    def _faults(self, query: bytes) -> list:
        """The bus faults hitting this message, after they acted; a disconnect fails it."""
        bench = self.bench
        bench.messages_received += 1
        faults = [f for f in bench.effects.bus if f.hits(self.role, bench.messages_received, self.is_query(query))]
        for fault in faults:
            fault.act(self)
        if self.disconnected:
            raise errors.VisaIOError(constants.VI_ERROR_CONN_LOST)
        return faults

    def _faulty_reply(self, fault, reply: bytearray | Deferred) -> bytearray | Deferred | None:
        eom = self.device._response_eom
        if isinstance(reply, Deferred):
            payload = fault.reply(reply.payload, eom)
            if payload is None:
                return None
            reply.payload = payload
            return reply
        return fault.reply(reply, eom)

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
        self.bench.clock.advance(timeout_s)
        raise errors.VisaIOError(constants.VI_ERROR_TMO)

    def clear(self) -> None:
        """Device clear: drop pending input and replies."""
        self._input.clear()
        self._replies.clear()

    # -- one message --------------------------------------------------------------------------
    def handle(self, query: bytes):
        dynamic = self._dynamic.get(query)
        if dynamic is not None:
            return dynamic()
        reply = self.device._match(query)
        if reply is None:
            return self.device.error_response("command_error")
        if query == b"*RST":
            self._restore(self._defaults)
        self.after_command(query)
        return reply

    def after_command(self, query: bytes) -> None:
        """Hook: react to a command pyvisa-sim accepted."""

    # -- pyvisa-sim state -----------------------------------------------------------------
    def value(self, name: str):
        return self.device._properties[name].get_value()

    def channel_value(self, name: str, channel: int):
        """A per-channel property: pyvisa-sim channels, or flat `ch<n>_<name>` properties."""
        flat = self.device._properties.get(f"ch{channel}_{name}")
        if flat is not None:
            return flat.get_value()
        for component in self.device._channels.values():
            prop = component._properties.get(name)
            if prop is not None:
                return prop._value[_channel_id(prop._value, channel)]
        raise KeyError(f"{self.role}: no per-channel property {name!r} in the definitions")

    def _property_values(self) -> list:
        props = list(self.device._properties.values())
        for component in self.device._channels.values():
            props += component._properties.values()
        return [(p, copy.copy(p._value)) for p in props]

    @staticmethod
    def _restore(values: list) -> None:
        """*RST: every property back to its power-on default."""
        for prop, value in values:
            prop._value = copy.copy(value)


def _channel_id(values: dict, channel: int):
    """pyvisa-sim keys channel values by the id as written in the YAML (str or int)."""
    return channel if channel in values else str(channel)


def _load_ohm(value) -> float:
    """OUTP:LOAD as a resistance: 50, or infinite for INF (the 33120A reports 9.9E+37)."""
    text = str(value).strip().upper()
    if text.startswith("INF") or text == "MAX":
        return math.inf
    ohm = float(text)
    return math.inf if ohm >= 9.9e37 else ohm


_SHAPES = {"SINUSOID": "SIN"}  # long form of the one shape that drives the plate


class Generator(SimulatedInstrument):
    """Agilent 33120A: its settings drive the plate."""

    role = "generator"

    def settings(self) -> physics.GeneratorSettings:
        return physics.GeneratorSettings(
            frequency_hz=float(self.value("frequency")),
            amplitude=float(self.value("amplitude")),
            voltage_unit=str(self.value("voltage_unit")).upper(),
            offset_v=float(self.value("offset")),
            load_ohm=_load_ohm(self.value("load")),
            shape=_SHAPES.get(str(self.value("shape")).upper(), str(self.value("shape")).upper()))

    def handle(self, query: bytes):
        if query.endswith(b"?"):
            return super().handle(query)
        before = self.settings()
        reply = super().handle(query)
        after = self.settings()
        # The 33120A reprograms its synthesiser (or attenuator) on every setting command, even
        # one repeating the present value, so the busy time depends on the command alone: a
        # resumed campaign then spends the same bench time as an uninterrupted one.
        settle_s = 0.0
        if query.startswith(b"FREQ"):
            settle_s = GENERATOR_FREQUENCY_SETTLE_S
        elif query.startswith((b"VOLT", b"OUTP:LOAD", b"FUNC", b"APPL")):
            settle_s = GENERATOR_LEVEL_SETTLE_S
        # the plate sees the new drive from the command on; the generator is busy after
        self.bench.generator_written(drive_changed=after != before)
        self.bench.clock.advance(settle_s)
        return reply


class Vibrometer(SimulatedInstrument):
    """Polytec OFV-5000: the decoder range scales CH3; OverRange and SignalLevel live."""

    role = "vibrometer"
    _RANGE = re.compile(r"^\s*([0-9.]+)\s*(mm|m)/s/V\s*$")

    def is_query(self, message: bytes) -> bool:
        return message.startswith(b"Get")   # its protocol: Get,<item>,<channel>,<field>

    def dynamic_queries(self):
        return {b"Get,OverRange,0,Value": lambda: b"1" if self.bench.vibrometer_over_range() else b"0",
                b"Get,SignalLevel,0,Value":
                    lambda: b"%d" % round(self.bench.scene.measurement_point.signal_level_percent)}

    def range_mps_per_v(self) -> float:
        text = str(self.value("velocity_range"))
        match = self._RANGE.match(text)
        if match is None:
            raise ValueError(f"vibrometer: cannot read the decoder range {text!r}")
        return float(match.group(1)) * (1e-3 if match.group(2) == "mm" else 1.0)


#: DAT:ENC -> (numpy dtype for a 2-byte sample, BN_Fmt, BYT_Or)
_ENCODINGS = {"RIB": (">i2", "RI", "MSB"), "RPB": (">u2", "RP", "MSB"),
              "SRI": ("<i2", "RI", "LSB"), "SRP": ("<u2", "RP", "LSB")}
#: Long forms of the measurement types the simulator computes.
_MEASUREMENTS = {"CMEAN": "CME", "PK2PK": "PK2", "FREQUENCY": "FREQ", "AMPLITUDE": "AMP",
                 "MAXIMUM": "MAX", "MINIMUM": "MINI"}
_UNITS = {"CH1": "V", "CH2": "A", "CH3": "V", "MATH": "VA"}


class Scope(SimulatedInstrument):
    """Tektronix TDS 3054B: acquisitions of the plate's signals, measurements, records."""

    role = "scope"

    def __init__(self, device: Device, bench, bus: BusTiming) -> None:
        super().__init__(device, bench, bus)
        self._record: traces.Record | None = None
        self._ready_s = 0.0
        self._scaled: tuple = (None, None, None, None)

    def dynamic_queries(self):
        return {b"*OPC?": lambda: Deferred(self._ready_s, b"1"),
                b"BUSY?": lambda: b"1" if self.bench.clock.now_s() < self._ready_s else b"0",
                b"MEASU:IMM:VAL?": self._measurement,
                b"WFMP?": self._preamble,
                b"CURV?": self._curve}

    def after_command(self, query: bytes) -> None:
        if query in (b"ACQ:STATE RUN", b"ACQ:STATE ON", b"ACQ:STATE 1"):
            self._start_acquisition()

    def setup(self) -> traces.ScopeSetup:
        averaging = str(self.value("acquire_mode")).upper().startswith("AVE")
        return traces.ScopeSetup(
            channels=tuple(traces.ChannelSetup(
                scale_per_div=float(self.channel_value("scale", ch)),
                position_div=float(self.channel_value("position", ch)),
                coupling=str(self.channel_value("coupling", ch)).upper()[:3],
                probe_gain=float(self.channel_value("probe", ch))) for ch in (1, 2, 3)),
            horizontal_scale_s=float(self.value("horizontal_scale")),
            record_length=int(self.value("record_length")),
            averages=int(self.value("acquire_averages")) if averaging else 1)

    def _start_acquisition(self) -> None:
        setup = self.setup()
        period_s = setup.record_time_s + SCOPE_REARM_S
        self._record = self.bench.acquire(setup, period_s)
        self._ready_s = self.bench.clock.now_s() + setup.averages * period_s

    def record(self) -> traces.Record:
        """The last acquisition; a scope never started shows what it free-runs on."""
        if self._record is None:
            self._start_acquisition()
        return self._record

    # -- dynamic replies ----------------------------------------------------------------------
    def _measurement(self) -> bytes:
        kind = str(self.value("measurement_type")).upper()
        value = traces.measure(self.record(), str(self.value("measurement_source")).upper(),
                               _MEASUREMENTS.get(kind, kind))
        # 9.9E37 is what the scope answers when a measurement has no value
        return b"9.9E37" if not math.isfinite(value) else b"%.12E" % value

    def _selection(self) -> tuple[str, int, int, int, str]:
        source = str(self.value("data_source")).upper()
        n = self.record().setup.record_length
        start = min(max(1, int(self.value("data_start"))), n)
        stop = min(max(start, int(self.value("data_stop"))), n)
        return source, start, stop, int(self.value("data_width")), str(self.value("data_encoding")).upper()[:3]

    def _scaling(self, source: str, width: int) -> tuple[float, float, np.ndarray]:
        """(YMUlt, YOFf, raw counts) of `source` in the last record (WFMP? then CURV?
        ask for the same, so the last answer is kept)."""
        record, (kept, kept_source, kept_width, scaled) = self.record(), self._scaled
        if not (kept is record and kept_source == source and kept_width == width):
            scaled = self._scale(source, width)
            self._scaled = (record, source, width, scaled)
        return scaled

    def _scale(self, source: str, width: int) -> tuple[float, float, np.ndarray]:
        record = self.record()
        if source == "MATH":
            trace = record.trace("MATH")
            peak = float(np.max(np.abs(trace)))
            y_mult, y_off = (peak / 32000.0 if peak > 0 else 1.0), 0.0
            counts = np.round(trace / y_mult)
        else:
            channel = record.setup.channels[int(source[2:]) - 1]
            y_mult = channel.scale_per_div / fx.COUNTS_PER_DIV
            y_off = channel.position_div * fx.COUNTS_PER_DIV
            counts = np.round(record.trace(source) / y_mult + y_off)
        counts = np.clip(counts, -32768, 32767)
        if width == 1:  # the high byte of the left-justified 16-bit sample
            return y_mult * 256.0, y_off / 256.0, np.floor(counts / 256.0)
        return y_mult, y_off, counts

    def _preamble(self) -> bytes:
        source, start, stop, width, encoding = self._selection()
        record = self.record()
        y_mult, y_off, _ = self._scaling(source, width)
        setup = record.setup
        _, fmt, order = _ENCODINGS.get(encoding, ("", "RI", "MSB"))
        mode = f"Average mode ({setup.averages})" if setup.averages > 1 else "Sample mode"
        if source == "MATH":
            wfid = f"Math, {setup.horizontal_scale_s:.1E} s/div, {setup.record_length} points, {mode}"
        else:
            channel = setup.channels[int(source[2:]) - 1]
            wfid = (f"{source[0]}{source[1:].lower()}, {channel.coupling} coupling, "
                    f"{channel.scale_per_div:.1E} {_UNITS[source]}/div, {setup.horizontal_scale_s:.1E} s/div, "
                    f"{setup.record_length} points, {mode}")
        x_zero = setup.first_sample_s + (start - 1) * setup.sample_interval_s
        encoding_field = "ASC" if encoding.startswith("ASC") else "BIN"
        return (f'{width};{8 * width};{encoding_field};{fmt};{order};{stop - start + 1};"{wfid}";Y;'
                f'{setup.sample_interval_s:.12E};0;{x_zero:.12E};"s";{y_mult:.12E};0.0E0;{y_off:.12E};'
                f'"{_UNITS[source]}"').encode()

    def _curve(self) -> bytes:
        source, start, stop, width, encoding = self._selection()
        _, _, counts = self._scaling(source, width)
        counts = counts[start - 1:stop].astype(np.int64)
        if encoding.startswith("ASC"):
            return b",".join(b"%d" % c for c in counts)
        dtype, fmt, order = _ENCODINGS.get(encoding, _ENCODINGS["RIB"])
        if fmt == "RP":  # unsigned binary: offset by half the range
            counts = counts + (128 if width == 1 else 32768)
        dtype = dtype if width == 2 else dtype[0] + dtype[1] + "1"
        data = counts.astype(dtype).tobytes()
        length = b"%d" % len(data)
        return b"#%d%s%s" % (len(length), length, data)


INSTRUMENTS = {cls.role: cls for cls in (Generator, Scope, Vibrometer)}
