"""Simulated Tektronix TDS 3054B oscilloscope: the programmer manual's grammar, status
system and state rules, acquiring the plate's signals.

Manual reference: "TDS PM" = TDS3000/B/C Series Programmer Manual 071-0381-03 (page
numbers); the settings' spellings and limits are `simbench.scope_settings`. What could
not be verified against the manual is said where it is modelled.
"""

from __future__ import annotations

import math

import numpy as np

from squeezebench.simbench import effects as fx
from squeezebench.simbench import scpi, traces
from squeezebench.simbench.device_base import Deferred
from squeezebench.simbench.scope_settings import (_ACQ_MODES, _AVERAGES, _BANDWIDTHS, _COUPLINGS, _CURSORS, _CME,
                                                  _DDE, _ENCODINGS, _EXE, _FORMATS, _GATINGS, _IMPEDANCES,
                                                  _MATH_DEFINITION, _MATH_TYPES, _MEASUREMENTS, _OFFSET_RANGE_AT_1X,
                                                  _PON, _PREAMBLE_FIELDS, _QYE, _RECORD_LENGTHS, _SCALE_AT_1X,
                                                  _SHORT_KEYWORDS, _SIMULATED_MEASUREMENTS, _SLOPES, _SOURCES,
                                                  _STOP_AFTER, _TRIGGER_COUPLINGS, _TRIGGER_MODES, _TRIGGER_SOURCES,
                                                  _TRIGGER_TYPES, CHANNELS, EVENT_QUEUE_DEPTH, NO_VALUE,
                                                  SCOPE_TIME_BASES_S, Probe, _int, _nearest_int, _nr3, _quoted,
                                                  _Setup, _tds_choice, _trigger_level)
from squeezebench.simbench.scpi import PREFIX, ScpiError, Unit
from squeezebench.simbench.scpi_device import Command, ScpiInstrument, _flag, _setting

#: Time between two averaged acquisitions of the TDS3054B beyond the record itself
#: (assumed: trigger re-arm plus processing and display of each waveform).
SCOPE_REARM_S = 0.010


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
        self._extremes_kept: tuple = (None, {})   # (record, {(source, gate): (lowest, highest)}): `_extremes`
        self._gated: tuple = (None, None, None, None)   # (setup, cursors, time base and cursors, gate): `_gate`

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
        lowest, highest = self._extremes(record, source)
        return lowest < s["trigger_level"] < highest

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
                self._clipped[1][setting] = traces.reaches_limits(self._extremes(record, f"CH{channel}"),
                                                                  *setting[1:])
            channel_high, channel_low = self._clipped[1][setting]
            high, low = high or channel_high, low or channel_low
        if high and low:
            return 2227, "Positive and Negative Clipping"
        if high or low:
            return (2228, "Measurement error, Positive Clipping") if high else \
                (2229, "Measurement error, Negative Clipping")
        return None

    def _extremes(self, record: traces.Record, source: str, trace: np.ndarray | None = None,
                  gate: slice = slice(None)) -> tuple[float, float]:
        """(lowest, highest) of `source` (CH1-CH3, or MATH as now defined, with its `trace`)
        in `record`, within `gate`: its trigger, its clipping check and its extreme and
        frequency measurements each read them, so they are worked out once per record."""
        if self._extremes_kept[0] is not record:
            self._extremes_kept = (record, {})
        key = (source, self.state["math_define"], self.state["math_type"]) if source == "MATH" else source
        key = (key, gate.start, gate.stop)
        kept = self._extremes_kept[1]
        if key not in kept:
            kept[key] = traces.extremes_of((record.trace(source) if trace is None else trace)[gate])
        return kept[key]

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
        kind = _SIMULATED_MEASUREMENTS[kind]
        extremes = self._extremes(record, source, trace, gate) if kind in traces.EXTREME_KINDS else None
        value = traces.measure(trace[gate], record.setup, record.frequency_hz, kind, extremes)
        if not math.isfinite(value):
            self.event(2202, "Measurement error, No period found")
            return NO_VALUE
        return b"%.12E" % value

    def _gate(self, setup: traces.ScopeSetup) -> slice | None:
        """The samples a measurement uses: the whole record, or with MEASUrement:GATing
        CURSor those between the vertical bar cursors (p. 2-207); None if none are. Kept
        for the time base and cursors it was found for, and for the setup object asked
        with: every measurement of a record asks with the same (the cursors compared as
        numbers, which is all the gate compares them by)."""
        if self.state["gating"] != "CURSOR":
            return slice(None)
        cursors = (self.state["vbar", 1], self.state["vbar", 2])
        kept_setup, kept_cursors, kept_key, gate = self._gated
        if kept_setup is setup and kept_cursors == cursors:
            return gate
        low, high = sorted(cursors)
        key = (setup.first_sample_s, setup.sample_interval_s, setup.record_length, low, high)
        if kept_key != key:
            times_s = setup.times_s()
            inside = np.flatnonzero((times_s >= low) & (times_s <= high))
            gate = slice(int(inside[0]), int(inside[-1]) + 1) if inside.size else None
        self._gated = (setup, cursors, key, gate)
        return gate

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
