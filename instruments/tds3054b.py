"""Tektronix TDS 3054B oscilloscope (TDS3000B series): acquisitions, measurements, records.

Commands are the short forms of the TDS3000/B/C programmer manual. The driver sends
`HEAD OFF` on connect so replies carry no command headers. On our bench CH1 is the piezo
voltage (through a 100:1 probe, `CH1:PRO 0.01`), CH2 the current probe, CH3 the
vibrometer output, MATH = CH1*CH2 the instantaneous power.

Records are fetched as signed big-endian 16-bit binary (`DAT:ENC RIB`, `DAT:WID 2`): an
IEEE 488.2 definite-length block parsed by PyVISA, scaled with the `WFMP?` preamble:
t = XZEro + XINcr * (n - PT_Off), y = YZEro + YMUlt * (raw - YOFf).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from typing import Any

import numpy as np

from squeezebench.instruments.base import SCPIInstrument
from squeezebench.instruments.errors import (ClippedTraceError, GarbledReply, InstrumentError, InstrumentTimeout,
                                NoValidMeasurement, OutOfRangeError)
from squeezebench.instruments.properties import (checked, control, strict_discrete_set, strict_integer_range, strict_range,
                                    token_for_reply, unquote)

CHANNELS = (1, 2, 3, 4)
SOURCES = ("CH1", "CH2", "CH3", "CH4", "MATH")
#: HOR:MAI:SCA values: 1 ns to 10 s per division in a 1-2-4 sequence (the TDS 3054B's
#: fastest is 1 ns/div); decimal literals so the values compare exactly.
HORIZONTAL_SCALES_S_PER_DIV = tuple(float(f"{m}e{e}") for e in range(-9, 1) for m in (1, 2, 4)) + (10.0,)
HORIZONTAL_DIVISIONS = 10
#: ACQ:NUMAV: 2 to 512, powers of two.
AVERAGE_COUNTS = tuple(2 ** k for k in range(1, 10))
RECORD_LENGTHS = (500, 10000)
#: CH<x>:SCA spans 1 mV to 10 V per division at the probe tip of a 1x probe; the probe
#: gain (output/input) scales it into the channel's units.
SCALE_RANGE_AT_1X = (1e-3, 10.0)
#: The manual gives no range for CH<x>:PRO; this covers 1000:1 voltage probes to 10 V/A
#: current probes.
PROBE_GAIN_RANGE = (1e-3, 10.0)
#: 9.9E37 is the scope's "no value" (9.91E37 on some firmware).
NO_VALUE = 9.9e37
#: ADC limits of 16-bit samples. Sample mode digitises 9 bits, left-justified (the low 7
#: bits are zero), so its top code is 255 * 128 = 32640; averaged records carry more bits
#: but cannot exceed the codes they average. At or beyond these a sample was clipped.
CLIP_LOW_COUNTS, CLIP_HIGH_COUNTS = -32768, 32640
#: SESR bits that report an error: CME (5), EXE (4), DDE (3), QYE (2).
_ESR_ERROR_BITS = 0b0011_1100
#: Acquisition time allowed for trigger re-arm and processing of each averaged waveform
#: beyond the record itself (an allowance, not a specification), and a fixed margin.
_REARM_ALLOWANCE_S = 0.1
_ACQUISITION_MARGIN_S = 5.0

#: Measurement kinds (MEASUrement:IMMed:TYPe), long form -> short form sent.
MEASUREMENTS = {"AMPLITUDE": "AMP", "AREA": "ARE", "BURST": "BUR", "CAREA": "CAR", "CMEAN": "CME",
                "CRMS": "CRM", "DELAY": "DELAY", "FALL": "FALL", "FREQUENCY": "FREQ", "HIGH": "HIGH",
                "LOW": "LOW", "MAXIMUM": "MAX", "MEAN": "MEAN", "MINIMUM": "MINI", "NDUTY": "NDU",
                "NOVERSHOOT": "NOV", "NWIDTH": "NWI", "PDUTY": "PDU", "PERIOD": "PERI", "PHASE": "PHASE",
                "PK2PK": "PK2", "POVERSHOOT": "POV", "PWIDTH": "PWI", "RISE": "RIS", "RMS": "RMS"}


def source_name(source: int | str) -> str:
    """1 -> "CH1"; "ch2" -> "CH2"; "MATH" stays."""
    name = f"CH{source}" if isinstance(source, int) and not isinstance(source, bool) else str(source).upper()
    if name not in SOURCES:
        raise OutOfRangeError("scope.source", source, "1-4, CH1-CH4, MATH")
    return name


def _running(reply: str) -> bool:
    """ACQ:STATE? answers 0 or 1 (accept the set forms too)."""
    text = reply.strip().upper()
    if text in ("1", "ON", "RUN"):
        return True
    if text in ("0", "OFF", "STOP"):
        return False
    raise ValueError("expected 0 or 1")


@dataclass(frozen=True)
class Waveform:
    """One fetched record, scaled to the channel's units (V, A, or V*A for MATH)."""

    time_s: np.ndarray
    values: np.ndarray
    unit: str
    x_increment_s: float
    y_multiplier: float      # YMUlt: channel units per count
    y_offset_counts: float   # YOFf
    y_zero: float            # YZEro
    bits: int                # BIT_Nr of the transfer
    source: str
    clipped_fraction: float  # samples at the ADC limits / all samples
    averages: int            # waveforms averaged into the record (1 in sample mode)

    @property
    def y_increment(self) -> float:
        """Units per count (YMUlt), the name run files use."""
        return self.y_multiplier


@dataclass(frozen=True)
class Preamble:
    """The WFMP? fields the driver uses (HEAD OFF form)."""

    bytes_per_point: int
    bits: int
    encoding: str
    binary_format: str
    byte_order: str
    points: int
    waveform_id: str
    x_increment_s: float
    point_offset: int
    x_zero_s: float
    x_unit: str
    y_multiplier: float
    y_zero: float
    y_offset_counts: float
    y_unit: str


def parse_preamble(reply: str) -> Preamble:
    """WFMP? -> Preamble; ValueError if it is not the 16 fields of a displayed waveform."""
    fields = next(csv.reader([reply], delimiter=";", quotechar='"'))
    if len(fields) != 16:
        raise ValueError(f"{len(fields)} fields instead of 16")
    return Preamble(bytes_per_point=int(fields[0]), bits=int(fields[1]), encoding=fields[2].strip().upper(),
                    binary_format=fields[3].strip().upper(), byte_order=fields[4].strip().upper(),
                    points=int(fields[5]), waveform_id=fields[6], x_increment_s=float(fields[8]),
                    point_offset=int(float(fields[9])), x_zero_s=float(fields[10]), x_unit=unquote(fields[11]),
                    y_multiplier=float(fields[12]), y_zero=float(fields[13]), y_offset_counts=float(fields[14]),
                    y_unit=unquote(fields[15]))


class Channel:
    """One input channel: `scope.channel(n)`."""

    def __init__(self, scope: TDS3054B, number: int) -> None:
        self.scope = scope
        self.number = number

    # What the control descriptors need: the scope's traffic, and the channel number.
    @property
    def role(self) -> str:
        return self.scope.role

    @property
    def resource_name(self) -> str:
        return self.scope.resource_name

    @property
    def property_prefix(self) -> str:
        return f"{self.scope.role}.ch{self.number}"

    @property
    def command_fields(self) -> dict[str, Any]:
        return {"ch": self.number}

    def write(self, command: str) -> None:
        self.scope.write(command)

    def query(self, command: str) -> str:
        return self.scope.query(command)

    probe_gain = control("CH{ch}:PRO?", "CH{ch}:PRO {:.9g}",
                         "Probe gain, output/input (a 100:1 probe is 0.01).",
                         validator=strict_range(*PROBE_GAIN_RANGE))
    scale_v_per_div = control("CH{ch}:SCA?", "CH{ch}:SCA {:.9g}",
                              "Vertical scale in the channel's units (V, or A for a current probe) per division.",
                              validator=lambda ch: strict_range(*ch.scale_range_per_div(),
                                                                "units/div at the present probe gain"))
    position_div = control("CH{ch}:POS?", "CH{ch}:POS {:.9g}", "Vertical position (divisions from centre).",
                           validator=strict_range(-5.0, 5.0, "div"))
    coupling = control("CH{ch}:COUP?", "CH{ch}:COUP {}", "Input coupling.",
                       values={"DC": "DC", "AC": "AC", "GND": "GND"})
    bandwidth = control("CH{ch}:BAN?", "CH{ch}:BAN {}", "Bandwidth limit.",
                        values={"FULL": "FUL", "20MHz": "TWE", "150MHz": "ONEF"})

    def scale_range_per_div(self) -> tuple[float, float]:
        """(finest, coarsest) vertical scale at the present probe gain, in channel units/div."""
        gain = self.probe_gain
        return SCALE_RANGE_AT_1X[0] / gain, SCALE_RANGE_AT_1X[1] / gain

    def settings_snapshot(self) -> dict[str, Any]:
        return {"probe_gain": self.probe_gain, "scale_v_per_div": self.scale_v_per_div,
                "position_div": self.position_div, "coupling": self.coupling, "bandwidth": self.bandwidth}


class TDS3054B(SCPIInstrument):
    """The bench's oscilloscope (`TCPIP0::192.168.0.20::INSTR` on the simulated bench)."""

    MODEL = "TDS 3054"

    horizontal_scale_s_per_div = control("HOR:MAI:SCA?", "HOR:MAI:SCA {:.9g}",
                                         "Time base (s/div), 1-2-4 sequence; see set_horizontal_scale.",
                                         validator=strict_discrete_set(HORIZONTAL_SCALES_S_PER_DIV, "s/div"))
    record_length = control("HOR:RECO?", "HOR:RECO {:d}", "Points per record.",
                            validator=strict_discrete_set(RECORD_LENGTHS), parse=int)
    acquire_mode = control("ACQ:MOD?", "ACQ:MOD {}", "Acquisition mode.",
                           values={"SAMPLE": "SAM", "AVERAGE": "AVE", "PEAKDETECT": "PEAK", "ENVELOPE": "ENV"})
    num_averages = control("ACQ:NUMAV?", "ACQ:NUMAV {:d}", "Waveforms averaged in AVERAGE mode.",
                           validator=strict_discrete_set(AVERAGE_COUNTS), parse=int)
    stop_after = control("ACQ:STOPA?", "ACQ:STOPA {}", "SEQUENCE: stop after one (averaged) acquisition.",
                         values={"SEQUENCE": "SEQ", "RUNSTOP": "RUNST"})
    acquisition_running = control("ACQ:STATE?", None, "Whether the scope is acquiring.", parse=_running)
    math_definition = control("MATH:DEFI?", 'MATH:DEFI "{}"', "The MATH waveform's expression, e.g. CH1*CH2.",
                              parse=unquote)
    measurement_source = control("MEASU:IMM:SOU?", "MEASU:IMM:SOU {}", "Source of the immediate measurement.",
                                 values={name: name for name in SOURCES})
    measurement_type = control("MEASU:IMM:TYP?", "MEASU:IMM:TYP {}", "Kind of the immediate measurement.",
                               values=MEASUREMENTS)
    data_source = control("DAT:SOU?", "DAT:SOU {}", "Waveform CURV? transfers.",
                          values={name: name for name in SOURCES})
    data_encoding = control("DAT:ENC?", "DAT:ENC {}", "Transfer encoding (the driver uses RIBINARY).",
                            values={"RIBINARY": "RIB", "RPBINARY": "RPB", "SRIBINARY": "SRI",
                                    "SRPBINARY": "SRP", "ASCII": "ASCI"})
    data_width = control("DAT:WID?", "DAT:WID {:d}", "Bytes per transferred point.",
                         validator=strict_discrete_set((1, 2)), parse=int)
    data_start = control("DAT:STAR?", "DAT:STAR {:d}", "First transferred point (1-based).",
                         validator=strict_integer_range(1, max(RECORD_LENGTHS)), parse=int)
    data_stop = control("DAT:STOP?", "DAT:STOP {:d}", "Last transferred point.",
                        validator=strict_integer_range(1, max(RECORD_LENGTHS)), parse=int)

    def __init__(self, resource: Any, role: str = "scope") -> None:
        super().__init__(resource, role)
        self.write("HEAD OFF")  # replies without command headers
        self._channels = {n: Channel(self, n) for n in CHANNELS}

    def channel(self, number: int) -> Channel:
        if number not in self._channels:
            raise OutOfRangeError(f"{self.role}.channel", number, "1, 2, 3, 4")
        return self._channels[number]

    # -- set-up ----------------------------------------------------------------------------------
    def configure_channel(self, channel: int, *, probe_gain: float, coupling: str = "DC",
                          position_div: float = 0.0, bandwidth: str = "FULL") -> None:
        """Probe first: it sets the range the vertical scale is checked against."""
        ch = self.channel(channel)
        ch.probe_gain = probe_gain
        ch.coupling = coupling
        ch.position_div = position_div
        ch.bandwidth = bandwidth

    def set_horizontal_scale(self, s_per_div: float) -> float:
        """The smallest 1-2-4 time base of at least `s_per_div` (the record then holds at
        least the time asked for); returns the value set."""
        scale = next((s for s in HORIZONTAL_SCALES_S_PER_DIV if s >= s_per_div * (1 - 1e-9)), None)
        if scale is None:
            raise OutOfRangeError(f"{self.role}.horizontal_scale_s_per_div", s_per_div,
                                  f"up to {HORIZONTAL_SCALES_S_PER_DIV[-1]:g} s/div")
        self.horizontal_scale_s_per_div = scale
        return scale

    def set_averaging(self, averages: int) -> None:
        """AVERAGE mode over `averages` waveforms (checked before anything is sent); 1 is
        SAMPLE mode, one waveform per acquisition."""
        if averages == 1:
            self.acquire_mode = "SAMPLE"
            return
        averages = checked(f"{self.role}.num_averages", type(self).num_averages.validator, averages)
        self.acquire_mode = "AVERAGE"
        self.num_averages = averages

    def define_math_product(self, first: str = "CH1", second: str = "CH2") -> None:
        """MATH = first * second (CH1*CH2: the instantaneous power on our bench)."""
        self.math_definition = f"{source_name(first)}*{source_name(second)}"

    # -- acquisition -----------------------------------------------------------------------------
    def acquire_single(self, timeout_s: float) -> None:
        """One single-sequence acquisition (all NUMAVg waveforms in AVERAGE mode), waited for
        with `*OPC?`, which answers only once it is complete."""
        self.stop_after = "SEQUENCE"
        self.write("ACQ:STATE RUN")
        with self.timeout(timeout_s):
            try:
                reply = self.query("*OPC?")
            except InstrumentTimeout:
                # The late "1" would otherwise be read as the answer to the next query.
                self._device_clear()
                raise InstrumentTimeout(self.role, self.resource_name,
                                        "the acquisition (ACQ:STATE RUN, then *OPC?)", timeout_s) from None
        if reply != "1":
            raise GarbledReply(self.role, self.resource_name, "*OPC?", reply, "expected 1")

    def acquisition_timeout_s(self) -> float:
        """How long a single sequence may take with the present settings, generously."""
        averages = self.num_averages if self.acquire_mode == "AVERAGE" else 1
        record_s = HORIZONTAL_DIVISIONS * self.horizontal_scale_s_per_div
        return _ACQUISITION_MARGIN_S + averages * (record_s + _REARM_ALLOWANCE_S)

    def busy(self) -> bool:
        return self.parse_reply("BUSY?", self.query("BUSY?"), _running)

    def _device_clear(self) -> None:
        try:
            self.resource.clear()
        except NotImplementedError:  # a VISA library without device clear has nothing pending
            pass

    # -- measurements ----------------------------------------------------------------------------
    def measure(self, source: int | str, kind: str) -> float:
        """One immediate measurement of the last acquisition: `kind` is a MEASUrement:IMMed:TYPe
        long form (MEAN, CMEAN, PK2PK, FREQUENCY, RMS, AMPLITUDE, ...) or its short form."""
        name = source_name(source)
        kind_key = kind.upper()
        if kind_key not in MEASUREMENTS:
            try:
                kind_key = token_for_reply(MEASUREMENTS, kind_key)
            except ValueError:
                raise OutOfRangeError(f"{self.role}.measurement_type", kind, ", ".join(MEASUREMENTS)) from None
        self.measurement_source = name
        self.measurement_type = kind_key
        reply = self.query("MEASU:IMM:VAL?")
        value = self.parse_reply("MEASU:IMM:VAL?", reply)
        if not abs(value) < NO_VALUE:
            raise NoValidMeasurement(self.role, self.resource_name,
                                     f"no valid {kind_key} measurement of {name} (the scope answered {reply}: "
                                     "no signal it can measure, or the source is not displayed)")
        return value

    def fetch_waveform(self, source: int | str, *, allow_clipped: bool = False) -> Waveform:
        """The whole record of `source` from the last acquisition, scaled to its units.

        A record with samples at the ADC limits raises ClippedTraceError unless
        `allow_clipped`; the Waveform says which fraction was clipped either way.
        """
        name = source_name(source)
        points = self.record_length
        self.data_source = name
        self.data_encoding = "RIBINARY"
        self.data_width = 2
        self.data_start = 1
        self.data_stop = points
        reply = self.query("WFMP?")
        if len(reply.split(";")) == 5:
            raise InstrumentError(self.role, self.resource_name,
                                  f"{name} is not displayed: the scope has no record of it")
        preamble = self.parse_reply("WFMP?", reply, parse_preamble)
        if (preamble.bytes_per_point, preamble.encoding, preamble.binary_format, preamble.byte_order) != \
                (2, "BIN", "RI", "MSB"):
            raise GarbledReply(self.role, self.resource_name, "WFMP?", reply,
                               "expected 2-byte signed big-endian binary (DAT:ENC RIB, DAT:WID 2)")
        raw = self.query_block("CURV?")
        if raw.size != preamble.points:
            raise GarbledReply(self.role, self.resource_name, "CURV?", f"<block of {raw.size} points>",
                               f"the preamble announces {preamble.points} points")
        clipped = (raw <= CLIP_LOW_COUNTS) | (raw >= CLIP_HIGH_COUNTS)
        clipped_fraction = float(np.count_nonzero(clipped)) / raw.size if raw.size else 0.0
        if clipped_fraction > 0 and not allow_clipped:
            raise ClippedTraceError(self.role, self.resource_name, name, clipped_fraction)
        n = np.arange(raw.size, dtype=np.float64)
        averages = self.num_averages if self.acquire_mode == "AVERAGE" else 1
        return Waveform(
            time_s=preamble.x_zero_s + preamble.x_increment_s * (n - preamble.point_offset),
            values=preamble.y_zero + preamble.y_multiplier * (raw.astype(np.float64) - preamble.y_offset_counts),
            unit=preamble.y_unit, x_increment_s=preamble.x_increment_s, y_multiplier=preamble.y_multiplier,
            y_offset_counts=preamble.y_offset_counts, y_zero=preamble.y_zero, bits=preamble.bits,
            source=name, clipped_fraction=clipped_fraction, averages=averages)

    # -- status ----------------------------------------------------------------------------------
    def check_errors(self) -> None:
        """*ESR? (read and cleared), then the event queue: InstrumentError with the first
        event's code and message when an error bit is set."""
        esr = self.parse_reply("*ESR?", self.query("*ESR?"), int)
        if not esr & _ESR_ERROR_BITS:
            return
        events: list[tuple[int, str]] = []
        for _ in range(32):  # the queue is finite; stop on a scope that never empties it
            code, message = self.parse_reply("EVMSG?", self.query("EVMSG?"), _event)
            if code in (0, 1):  # "no events to report"
                break
            events.append((code, message))
        if not events:
            raise InstrumentError(self.role, self.resource_name,
                                  f"*ESR? reports an error ({esr}) but the event queue is empty")
        (code, message), later = events[0], events[1:]
        if later:
            message += " (then: " + "; ".join(f"{c},{m!r}" for c, m in later) + ")"
        raise InstrumentError(self.role, self.resource_name, message, code)

    def settings_snapshot(self) -> dict[str, Any]:
        snapshot = super().settings_snapshot()
        snapshot.update({f"ch{n}": ch.settings_snapshot() for n, ch in self._channels.items()})
        return snapshot

    # Names the protocols package calls.
    def set_vertical_scale(self, channel: int, scale_per_div: float) -> None:
        self.channel(channel).scale_v_per_div = scale_per_div

    def set_record_length(self, points: int) -> None:
        self.record_length = points

    def set_math_product(self) -> None:
        self.define_math_product("CH1", "CH2")

    def acquire(self) -> None:
        """acquire_single with a timeout estimated from the present settings."""
        self.acquire_single(self.acquisition_timeout_s())


def _event(reply: str) -> tuple[int, str]:
    code, _, message = reply.partition(",")
    return int(code), unquote(message)

