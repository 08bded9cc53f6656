"""Tektronix TDS 3054B oscilloscope (TDS3000B series): acquisitions, measurements, records.

Every command is spelled in full, as the TDS3000/B/C programmer manual (071-0381-03,
"Abbreviating Commands", p. 2-4) advises: abbreviations differ between its own summary
tables and command entries (`HORizontal:RECOrdlength` vs `HORizontal:RECORDLength`), the
full spelling is accepted by every reading. Page numbers beside each command are the
manual's. The driver sends `HEADER OFF` on connect so replies carry no headers.

On our bench CH1 is the piezo voltage (through a 100:1 probe, gain 0.01), CH2 the TCP202
current probe (detected by the scope through its TekProbe interface, which fixes the
channel's gain and units), CH3 the vibrometer output, MATH = CH1*CH2 (dual waveform
math) the instantaneous power. A measurement or a transfer needs its source displayed
(`SELECT:<wfm> ON`); averaging needs the edge trigger on a driven channel.

Records are fetched as signed big-endian 16-bit binary (`DATA:ENCDG RIBINARY`,
`DATA:WIDTH 2`): an IEEE 488.2 definite-length block parsed by PyVISA, scaled with the
`WFMPRE?` preamble: t = XZEro + XINcr * (n - PT_Off), y = YZEro + YMUlt * (raw - YOFf).
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from squeezebench.instruments.base import SCPIInstrument, concatenated
from squeezebench.instruments.errors import (BenchMismatch, ClippedTraceError, GarbledReply, InstrumentError,
                                             InstrumentTimeout, NoValidMeasurement, OutOfRangeError)
from squeezebench.instruments.properties import (checked, control, strict_boolean, strict_discrete_set,
                                                 strict_integer_range, strict_range, token_for_reply, unquote)

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
#: 9.9E37 is the scope's "no value" (9.91E37 on some firmware); the event queue says why.
NO_VALUE = 9.9e37
#: Event codes (p. 3-15, Table 3-5) of a measurement refused for clipping.
CLIPPING_EVENTS = (2227, 2228, 2229)
#: Events that report no error: none to report (0, 1), power on (401), operation complete (402).
_NOT_ERRORS = (0, 1, 401, 402)
#: ADC limits of 16-bit samples. Sample mode digitises 9 bits, left-justified (the low 7
#: bits are zero), so its top code is 255 * 128 = 32640; averaged records carry more bits
#: but cannot exceed the codes they average. At or beyond these a sample was clipped.
CLIP_LOW_COUNTS, CLIP_HIGH_COUNTS = -32768, 32640
#: Acquisition time allowed for trigger re-arm and processing of each averaged waveform
#: beyond the record itself (an allowance, not a specification), and a fixed margin.
_REARM_ALLOWANCE_S = 0.1
_ACQUISITION_MARGIN_S = 5.0

#: Measurement kinds (MEASUrement:IMMed:TYPe, p. 2-211), long form sent -> its short form.
MEASUREMENTS = {"AMPLITUDE": "AMP", "AREA": "ARE", "BURST": "BUR", "CAREA": "CAR", "CMEAN": "CME",
                "CRMS": "CRM", "DELAY": "DELAY", "FALL": "FALL", "FREQUENCY": "FREQ", "HIGH": "HIGH",
                "LOW": "LOW", "MAXIMUM": "MAX", "MEAN": "MEAN", "MINIMUM": "MINI", "NDUTY": "NDU",
                "NOVERSHOOT": "NOV", "NWIDTH": "NWI", "PDUTY": "PDU", "PERIOD": "PERI", "PHASE": "PHASE",
                "PK2PK": "PK2", "POVERSHOOT": "POV", "PWIDTH": "PWI", "RISE": "RIS", "RMS": "RMS"}
_FULL = {name: name for name in MEASUREMENTS}


def scale_range_per_div(probe_gain: float) -> tuple[float, float]:
    """(finest, coarsest) vertical scale with a probe of this gain, in channel units/div."""
    return SCALE_RANGE_AT_1X[0] / probe_gain, SCALE_RANGE_AT_1X[1] / probe_gain


def source_name(source: int | str) -> str:
    """1 -> "CH1"; "ch2" -> "CH2"; "MATH" stays."""
    name = f"CH{source}" if isinstance(source, int) and not isinstance(source, bool) else str(source).upper()
    if name not in SOURCES:
        raise OutOfRangeError("scope.source", source, "1-4, CH1-CH4, MATH")
    return name


def _running(reply: str) -> bool:
    """ACQUIRE:STATE? and BUSY? answer 0 or 1 (accept the set forms too)."""
    text = reply.strip().upper()
    if text in ("1", "ON", "RUN"):
        return True
    if text in ("0", "OFF", "STOP"):
        return False
    raise ValueError("expected 0 or 1")


def _on(reply: str) -> bool:
    """SELECT:<wfm>? answers 0 or 1."""
    return _running(reply)


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
    """The WFMPRE? fields the driver uses (HEADER OFF form)."""

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
    """WFMPRE? -> Preamble; ValueError if it is not the 16 fields of a displayed waveform."""
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

    probe_gain = control("CH{ch}:PROBE?", "CH{ch}:PROBE {:.9g}",
                         "Probe gain, output/input (a 100:1 probe is 0.01); fixed by a detected probe.",
                         validator=strict_range(*PROBE_GAIN_RANGE), manual="p. 2-68 CH<x>:PRObe")
    scale_v_per_div = control("CH{ch}:SCALE?", "CH{ch}:SCALE {:.9g}",
                              "Vertical scale in the channel's units (V, or A for a current probe) per division.",
                              validator=lambda ch: strict_range(*ch.scale_range_per_div(),
                                                                "units/div at the present probe gain"),
                              manual="p. 2-69 CH<x>:SCAle")
    position_div = control("CH{ch}:POSITION?", "CH{ch}:POSITION {:.9g}", "Vertical position (divisions from centre).",
                           validator=strict_range(-5.0, 5.0, "div"), manual="p. 2-68 CH<x>:POSition")
    offset = control("CH{ch}:OFFSET?", "CH{ch}:OFFSET {:.9g}",
                     "Offset subtracted from the input before the ADC, in the channel's units.",
                     manual="p. 2-67 CH<x>:OFFSet")
    impedance = control("CH{ch}:IMPEDANCE?", "CH{ch}:IMPEDANCE {}", "Input impedance: 1 MOhm, or 50 Ohm.",
                        values={"1MOhm": "MEG", "50Ohm": "FIFTY"}, manual="p. 2-66 CH<x>:IMPedance")
    coupling = control("CH{ch}:COUPLING?", "CH{ch}:COUPLING {}", "Input coupling.",
                       values={"DC": "DC", "AC": "AC", "GND": "GND"}, manual="p. 2-64 CH<x>:COUPling")
    bandwidth = control("CH{ch}:BANDWIDTH?", "CH{ch}:BANDWIDTH {}", "Bandwidth limit.",
                        values={"FULL": "FULL", "20MHz": "TWENTY", "150MHz": "ONEFIFTY"},
                        manual="p. 2-63 CH<x>:BANdwidth")
    displayed = control("SELECT:CH{ch}?", "SELECT:CH{ch} {}", "Whether the channel is displayed (measurable).",
                        values={True: "ON", False: "OFF"}, validator=strict_boolean(), parse=_on,
                        manual="p. 2-260 SELect:<wfm>")
    probe_model = control("CH{ch}:ID?", None, "Model of a probe detected through TekProbe level II, or ''.",
                          parse=unquote, manual="p. 2-65 CH<x>:ID?")
    unit = control("CH{ch}:YUNIT?", None, 'Units of the channel: "V", or "A" for a current probe.', parse=unquote,
                   manual="p. 2-70 CH<x>:YUNit")

    def scale_range_per_div(self) -> tuple[float, float]:
        """(finest, coarsest) vertical scale at the present probe gain, in channel units/div."""
        return scale_range_per_div(self.probe_gain)

    def settings_snapshot(self) -> dict[str, Any]:
        return {name: getattr(self, name) for name in ("probe_gain", "scale_v_per_div", "position_div", "offset",
                                                       "impedance", "coupling", "bandwidth", "displayed",
                                                       "probe_model", "unit")}

    def use_probe(self, probe_gain: float) -> None:
        """The bench's probe on this channel: set its gain, unless the scope detected a probe
        (then its gain is the hardware's, and a bench file saying otherwise is wrong). A
        coded probe without a model (TekProbe level I: `ID?` reads "") is found the way
        the manual offers: it refuses any gain but its one legal value (error 242, Hardware
        Configuration, p. 2-68 CH<x>:PRObe), so the gain read back is still its own. That
        queued event is this mismatch, said here in the bench's words, not left for later."""
        model = self.probe_model
        if not model:
            self.probe_gain = probe_gain
            detected = self.probe_gain
            if math.isclose(detected, probe_gain, rel_tol=1e-6):
                return
            self.scope.read_events()
            model = "coded (TekProbe level I)"
        else:
            detected = self.probe_gain
        if not math.isclose(detected, probe_gain, rel_tol=1e-6):
            raise BenchMismatch(self.role, self.resource_name,
                                f"CH{self.number} has a {model} probe the scope detected with gain {detected:g} "
                                f"({1 / detected:g}:1), but the bench description says {probe_gain:g} "
                                f"({1 / probe_gain:g}:1)")


class TDS3054B(SCPIInstrument):
    """The bench's oscilloscope (`TCPIP0::192.168.0.20::INSTR` on the simulated bench)."""

    MODEL = "TDS 3054"

    horizontal_scale_s_per_div = control("HORIZONTAL:MAIN:SCALE?", "HORIZONTAL:MAIN:SCALE {:.9g}",
                                         "Time base (s/div), 1-2-4 sequence; see set_horizontal_scale.",
                                         validator=strict_discrete_set(HORIZONTAL_SCALES_S_PER_DIV, "s/div"),
                                         manual="p. 2-146 HORizontal:MAIn:SCAle")
    record_length = control("HORIZONTAL:RECORDLENGTH?", "HORIZONTAL:RECORDLENGTH {:d}", "Points per record.",
                            validator=strict_discrete_set(RECORD_LENGTHS), parse=int,
                            manual="p. 2-147 HORizontal:RECORDLength")
    delay_on = control("HORIZONTAL:DELAY:STATE?", "HORIZONTAL:DELAY:STATE {}",
                       "Delay mode: the screen centre is delay_time_s after the trigger.",
                       values={True: "ON", False: "OFF"}, validator=strict_boolean(), parse=_on,
                       manual="p. 2-144 HORizontal:DELay:STATE")
    delay_time_s = control("HORIZONTAL:DELAY:TIME?", "HORIZONTAL:DELAY:TIME {:.9g}", "Delay time (s).",
                           manual="p. 2-145 HORizontal:DELay:TIMe")
    measurement_gating = control("MEASUREMENT:GATING?", "MEASUREMENT:GATING {}",
                                 "Which part of the record measurements use.",
                                 values={"OFF": "OFF", "SCREEN": "SCREEN", "CURSOR": "CURSOR"},
                                 manual="p. 2-207 MEASUrement:GATing")
    cursor_function = control("CURSOR:FUNCTION?", "CURSOR:FUNCTION {}", "Cursor type (VBARS gate measurements).",
                              values={"OFF": "OFF", "VBARS": "VBARS", "HBARS": "HBARS", "WAVEFORM": "WAVEFORM",
                                      "GRATICULE": "GRATICULE"},
                              manual="p. 2-72 CURSor:FUNCtion")
    cursor1_s = control("CURSOR:VBARS:POSITION1?", "CURSOR:VBARS:POSITION1 {:.9g}",
                        "First vertical bar cursor, s from the trigger.", manual="p. 2-79 CURSor:VBArs:POSITION<x>")
    cursor2_s = control("CURSOR:VBARS:POSITION2?", "CURSOR:VBARS:POSITION2 {:.9g}",
                        "Second vertical bar cursor, s from the trigger.", manual="p. 2-79 CURSor:VBArs:POSITION<x>")
    acquire_mode = control("ACQUIRE:MODE?", "ACQUIRE:MODE {}", "Acquisition mode.",
                           values={"SAMPLE": "SAMPLE", "AVERAGE": "AVERAGE", "PEAKDETECT": "PEAKDETECT",
                                   "ENVELOPE": "ENVELOPE"}, manual="p. 2-45 ACQuire:MODe")
    num_averages = control("ACQUIRE:NUMAVG?", "ACQUIRE:NUMAVG {:d}", "Waveforms averaged in AVERAGE mode.",
                           validator=strict_discrete_set(AVERAGE_COUNTS), parse=int, manual="p. 2-47 ACQuire:NUMAVg")
    stop_after = control("ACQUIRE:STOPAFTER?", "ACQUIRE:STOPAFTER {}",
                         "SEQUENCE: stop after one (averaged) acquisition.",
                         values={"SEQUENCE": "SEQUENCE", "RUNSTOP": "RUNSTOP"}, manual="p. 2-49 ACQuire:STOPAfter")
    acquisition_running = control("ACQUIRE:STATE?", None, "Whether the scope is acquiring.", parse=_running,
                                  manual="p. 2-48 ACQuire:STATE")
    trigger_type = control("TRIGGER:A:TYPE?", "TRIGGER:A:TYPE {}", "A trigger type (the bench uses EDGE).",
                           values={"EDGE": "EDGE", "VIDEO": "VIDEO", "COMMUNICATION": "COMMUNICATION",
                                   "LOGIC": "LOGIC", "PULSE": "PULSE"},
                           manual="p. 2-289 TRIGger:A:TYPe")
    trigger_mode = control("TRIGGER:A:MODE?", "TRIGGER:A:MODE {}", "AUTO, or NORMAL (waits for a trigger).",
                           values={"AUTO": "AUTO", "NORMAL": "NORMAL"}, manual="p. 2-277 TRIGger:A:MODe")
    trigger_source = control("TRIGGER:A:EDGE:SOURCE?", "TRIGGER:A:EDGE:SOURCE {}", "Edge trigger source.",
                             values={name: name for name in (*(s for s in SOURCES if s != "MATH"), "EXT10", "EXT",
                                                             "VERTICAL", "LINE", "ALTERNATING")},
                             manual="p. 2-269 TRIGger:A:EDGe:SOUrce")
    trigger_slope = control("TRIGGER:A:EDGE:SLOPE?", "TRIGGER:A:EDGE:SLOPE {}", "Edge trigger slope.",
                            values={"RISE": "RISE", "FALL": "FALL"}, manual="p. 2-269 TRIGger:A:EDGe:SLOpe")
    trigger_coupling = control("TRIGGER:A:EDGE:COUPLING?", "TRIGGER:A:EDGE:COUPLING {}", "Edge trigger coupling.",
                               values={"DC": "DC", "HFREJ": "HFREJ", "LFREJ": "LFREJ", "NOISEREJ": "NOISEREJ"},
                               manual="p. 2-268 TRIGger:A:EDGe:COUPling")
    trigger_level = control("TRIGGER:A:LEVEL?", "TRIGGER:A:LEVEL {:.9g}", "A trigger level, in the source's units.",
                            manual="p. 2-271 TRIGger:A:LEVel")
    math_type = control("MATH:TYPE?", "MATH:TYPE {}", "Math mode: DUAL (waveform math) or FFT.",
                        values={"DUAL": "DUAL", "FFT": "FFT", "ADVANCED": "ADVANCED", "DPO": "DPO"},
                        manual="p. 2-202 MATH:TYPe")
    math_definition = control("MATH:DEFINE?", 'MATH:DEFINE "{}"', "The MATH waveform's expression, e.g. CH1*CH2.",
                              parse=unquote, manual="p. 2-198 MATH:DEFINE")
    math_displayed = control("SELECT:MATH?", "SELECT:MATH {}", "Whether MATH is displayed (measurable).",
                             values={True: "ON", False: "OFF"}, validator=strict_boolean(), parse=_on,
                             manual="p. 2-260 SELect:<wfm>")
    measurement_source = control("MEASUREMENT:IMMED:SOURCE?", "MEASUREMENT:IMMED:SOURCE {}",
                                 "Source of the immediate measurement.", values={name: name for name in SOURCES},
                                 manual="p. 2-210 MEASUrement:IMMed:SOUrce")
    measurement_type = control("MEASUREMENT:IMMED:TYPE?", "MEASUREMENT:IMMED:TYPE {}",
                               "Kind of the immediate measurement.", values=_FULL,
                               parse=lambda reply: token_for_reply(MEASUREMENTS, reply),
                               manual="p. 2-211 MEASUrement:IMMed:TYPe")
    data_source = control("DATA:SOURCE?", "DATA:SOURCE {}", "Waveform CURVE? transfers.",
                          values={name: name for name in SOURCES}, manual="p. 2-94 DATa:SOUrce")
    data_encoding = control("DATA:ENCDG?", "DATA:ENCDG {}", "Transfer encoding (the driver uses RIBINARY).",
                            values={"RIBINARY": "RIBINARY", "RPBINARY": "RPBINARY", "SRIBINARY": "SRIBINARY",
                                    "SRPBINARY": "SRPBINARY", "ASCII": "ASCII"}, manual="p. 2-93 DATa:ENCdg")
    data_width = control("DATA:WIDTH?", "DATA:WIDTH {:d}", "Bytes per transferred point.",
                         validator=strict_discrete_set((1, 2)), parse=int, manual="p. 2-97 DATa:WIDth")
    data_start = control("DATA:START?", "DATA:START {:d}", "First transferred point (1-based).",
                         validator=strict_integer_range(1, max(RECORD_LENGTHS)), parse=int, manual="p. 2-95 DATa:STARt")
    data_stop = control("DATA:STOP?", "DATA:STOP {:d}", "Last transferred point.",
                        validator=strict_integer_range(1, max(RECORD_LENGTHS)), parse=int, manual="p. 2-96 DATa:STOP")

    def __init__(self, resource: Any, role: str = "scope") -> None:
        super().__init__(resource, role)
        self.write("HEADER OFF")  # p. 2-143 HEADer: replies without command headers
        self.write("VERBOSE ON")  # p. 2-308 VERBose: keywords in replies in their long form
        self._channels = {n: Channel(self, n) for n in CHANNELS}
        self._immediate_messages: dict[tuple[tuple[str, str], ...], str] = {}

    def channel(self, number: int) -> Channel:
        if number not in self._channels:
            raise OutOfRangeError(f"{self.role}.channel", number, "1, 2, 3, 4")
        return self._channels[number]

    # -- set-up ----------------------------------------------------------------------------------
    def configure_channel(self, channel: int, *, probe_gain: float, coupling: str = "DC",
                          position_div: float = 0.0, bandwidth: str = "FULL") -> None:
        """Display the channel (a measurement needs it) and set it up. Probe first: it sets
        the range the vertical scale is checked against; a detected probe is only checked.
        The input is the 1 MOhm the probes are made for, with no offset: a previous user's
        50 Ohm or offset would scale or shift every reading without an error."""
        ch = self.channel(channel)
        ch.displayed = True
        ch.impedance = "1MOhm"
        ch.use_probe(probe_gain)
        ch.offset = 0.0
        ch.coupling = coupling
        ch.position_div = position_div
        ch.bandwidth = bandwidth

    def trigger_on(self, channel: int, level: float = 0.0, slope: str = "RISE") -> None:
        """Edge trigger on a driven channel at `level` (its units). An average of waveforms
        that are not triggered on the signal averages it away."""
        source = source_name(channel)
        self.trigger_type = "EDGE"
        self.trigger_source = source
        self.trigger_coupling = "DC"
        self.trigger_slope = slope
        self.trigger_level = level
        self.trigger_mode = "AUTO"

    def center_record_on_trigger(self) -> None:
        """Delay mode on at 0 s: the record is centred on the trigger (what
        gate_whole_periods relies on; Appendix D has it so, a previous user may not)."""
        self.delay_on = True
        self.delay_time_s = 0.0

    def gate_whole_periods(self, frequency_hz: float, scale_s_per_div: float, record_length: int) -> None:
        """Measurements over the largest whole number of periods of `frequency_hz` in the
        record: the time base is a 1-2-4 value, so the record itself rarely holds whole
        periods, and a mean over a part-period of the power's ripple is biased. The gate
        ends half a sample early so its last sample is not the next period's first."""
        record_s = HORIZONTAL_DIVISIONS * scale_s_per_div
        start_s = -record_s / 2.0
        periods = math.floor(record_s * frequency_hz + 1e-9)
        if periods < 1:
            raise OutOfRangeError(f"{self.role}.gate_whole_periods", frequency_hz,
                                  f"at least one period in a {record_s:g} s record")
        self.cursor_function = "VBARS"
        self.cursor1_s = start_s
        self.cursor2_s = start_s + periods / frequency_hz - 0.5 * record_s / record_length
        self.measurement_gating = "CURSOR"

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
        """MATH = first * second as dual waveform math, displayed (CH1*CH2: the
        instantaneous power on our bench). The definition's syntax depends on the math
        type (p. 2-198), so the type is set first."""
        self.math_type = "DUAL"
        self.math_definition = f"{source_name(first)}*{source_name(second)}"
        self.math_displayed = True

    # -- acquisition -----------------------------------------------------------------------------
    def acquire_single(self, timeout_s: float) -> None:
        """One single-sequence acquisition (all NUMAVG waveforms in AVERAGE mode), waited for
        with `*OPC?`, which answers only once it is complete (p. 3-10); the three in one
        message (p. 2-4)."""
        message = concatenated([TDS3054B.stop_after.set_message(self, "SEQUENCE"),
                                "ACQUIRE:STATE RUN",  # p. 2-48 ACQuire:STATE
                                "*OPC?"])  # p. 2-240 *OPC
        with self.timeout(timeout_s):
            try:
                reply = self.query(message)
            except InstrumentTimeout:
                # The late "1" would otherwise be read as the answer to the next query.
                self.device_clear()
                raise InstrumentTimeout(self.role, self.resource_name,
                                        "the acquisition (ACQUIRE:STATE RUN, then *OPC?)", timeout_s) from None
        if reply != "1":
            raise GarbledReply(self.role, self.resource_name, "*OPC?", reply, "expected 1")

    def acquisition_timeout_s(self) -> float:
        """How long a single sequence may take with the present settings, generously."""
        mode, averages, scale_s = self.read_controls("acquire_mode", "num_averages", "horizontal_scale_s_per_div")
        averages = averages if mode == "AVERAGE" else 1
        record_s = HORIZONTAL_DIVISIONS * scale_s
        return _ACQUISITION_MARGIN_S + averages * (record_s + _REARM_ALLOWANCE_S)

    def busy(self) -> bool:
        return self.parse_reply("BUSY?", self.query("BUSY?"), _running)  # p. 2-55 BUSY?

    # -- measurements ----------------------------------------------------------------------------
    def measure(self, source: int | str, kind: str) -> float:
        """One immediate measurement of the last acquisition: `kind` is a MEASUrement:IMMed:TYPe
        long form (MEAN, CMEAN, PK2PK, FREQUENCY, RMS, AMPLITUDE, ...) or its short form.

        Without a value the scope answers 9.9E37 and queues the reason: clipping raises
        ClippedTraceError, anything else NoValidMeasurement with the scope's own message."""
        value = self._immediate([(source, kind)])[0]
        if isinstance(value, ClippedTraceError):
            raise value
        return value

    def measure_many(self, requests: list[tuple[int | str, str]]) -> list[float | None]:
        """Immediate measurements of the last acquisition, in order, all in one message:
        None where the source's trace is clipped (a caller re-ranges that channel and keeps
        the others); any other missing value raises as `measure` does."""
        return [None if isinstance(value, ClippedTraceError) else value for value in self._immediate(requests)]

    def _immediate(self, requests: list[tuple[int | str, str]]) -> list[float | ClippedTraceError]:
        """Each request's SOURCE, TYPE and VALUE? (p. 2-210 to 2-213) concatenated into one
        message (p. 2-4), its replies `;`-separated (p. 2-5). The reason for a missing value
        is in the event queue, which does not say which measurement it belongs to: with
        several missing, the queue is read and each is asked again alone."""
        if not requests:
            return []
        message = self._immediate_message(tuple((source_name(source), self._measurement_kind(kind))
                                                for source, kind in requests))
        reply = self.query(message)
        values: list[float | ClippedTraceError] = [self.parse_reply(message, part) for part in reply.split(";")]
        if len(values) != len(requests):
            raise GarbledReply(self.role, self.resource_name, message, reply, f"expected {len(requests)} values")
        missing = [i for i, value in enumerate(values) if abs(value) >= NO_VALUE]
        if not missing:
            return values
        events = [event for event in self.read_events() if event[0] not in _NOT_ERRORS]
        what = ", ".join(f"{self._measurement_kind(kind)} measurement of {source_name(source)}"
                         for source, kind in (requests[i] for i in missing))
        why = "; ".join(f"{code}, {text}" for code, text in events) or \
            "no signal it can measure, or the source is not displayed"
        # Reading the queue to explain the missing value drains every other event with it:
        # a refused command (command, execution or device error: Tables 3-4 to 3-6, codes 1xx-3xx) is
        # reported whatever came with it, never hidden behind a clipping the runner re-ranges.
        refused = next((code for code, _ in events if 100 <= code < 400), None)
        if refused is not None:
            raise InstrumentError(self.role, self.resource_name, f"no {what}; the scope reports {why}", refused)
        if len(requests) > 1:
            for i in missing:
                values[i] = self._immediate([requests[i]])[0]
            return values
        name = source_name(requests[0][0])
        clipping = [text for code, text in events if code in CLIPPING_EVENTS]
        if clipping:
            others = "; ".join(f"{code}, {text}" for code, text in events if code not in CLIPPING_EVENTS)
            return [ClippedTraceError(self.role, self.resource_name, name, None,
                                      clipping[0] + (f" (also: {others})" if others else ""))]
        raise NoValidMeasurement(self.role, self.resource_name,
                                 f"no valid {what} (the scope answered {reply}: {why})")

    def _immediate_message(self, requests: tuple[tuple[str, str], ...]) -> str:
        """The message of `_immediate` for (source name, long measurement kind) requests, kept:
        a campaign asks the same few lists of measurements thousands of times."""
        message = self._immediate_messages.get(requests)
        if message is None:
            commands = []
            for source, kind in requests:
                commands += [TDS3054B.measurement_source.set_message(self, source),
                             TDS3054B.measurement_type.set_message(self, kind),
                             "MEASUREMENT:IMMED:VALUE?"]  # p. 2-213
            message = self._immediate_messages[requests] = concatenated(commands)
        return message

    def _measurement_kind(self, kind: str) -> str:
        """A MEASUrement:IMMed:TYPe long form, from the long or the short form."""
        kind_key = kind.upper()
        if kind_key in MEASUREMENTS:
            return kind_key
        try:
            return token_for_reply(MEASUREMENTS, kind_key)
        except ValueError:
            raise OutOfRangeError(f"{self.role}.measurement_type", kind, ", ".join(MEASUREMENTS)) from None

    def fetch_waveform(self, source: int | str, *, allow_clipped: bool = False) -> Waveform:
        """The whole record of `source` from the last acquisition, scaled to its units.

        Two bus round trips: one message sets the transfer and reads the acquisition mode,
        the averaging count and the preamble (p. 2-4), then CURVE?. DATa:STOP at the largest
        record length transfers the whole record whatever its length (p. 2-96), so the
        record length need not be asked first. A record with samples at the ADC limits
        raises ClippedTraceError unless `allow_clipped`; the Waveform says which fraction
        was clipped either way.
        """
        name = source_name(source)
        scope = type(self)
        message = concatenated([scope.data_source.set_message(self, name),
                                scope.data_encoding.set_message(self, "RIBINARY"),
                                scope.data_width.set_message(self, 2),
                                scope.data_start.set_message(self, 1),
                                scope.data_stop.set_message(self, max(RECORD_LENGTHS)),
                                scope.acquire_mode.get_command, scope.num_averages.get_command,
                                "WFMPRE?"])  # p. 2-314
        reply = self.query(message)
        parts = reply.split(";", 2)
        if len(parts) != 3:
            raise GarbledReply(self.role, self.resource_name, message, reply,
                               "expected the acquisition mode, the averaging count and the preamble")
        mode, averages = (self.parse_reply(message, part, control.value_of)
                          for part, control in zip(parts, (scope.acquire_mode, scope.num_averages)))
        if len(parts[2].split(";")) == 5:
            raise InstrumentError(self.role, self.resource_name,
                                  f"{name} is not displayed: the scope has no record of it")
        preamble = self.parse_reply(message, parts[2], parse_preamble)
        if (preamble.bytes_per_point, preamble.encoding, preamble.binary_format, preamble.byte_order) != \
                (2, "BIN", "RI", "MSB"):
            raise GarbledReply(self.role, self.resource_name, "WFMPRE?", parts[2],
                               "expected 2-byte signed big-endian binary (DATA:ENCDG RIBINARY, DATA:WIDTH 2)")
        raw = self.query_block("CURVE?")  # p. 2-90
        if raw.size != preamble.points:
            raise GarbledReply(self.role, self.resource_name, "CURVE?", f"<block of {raw.size} points>",
                               f"the preamble announces {preamble.points} points")
        clipped = (raw <= CLIP_LOW_COUNTS) | (raw >= CLIP_HIGH_COUNTS)
        clipped_fraction = float(np.count_nonzero(clipped)) / raw.size if raw.size else 0.0
        if clipped_fraction > 0 and not allow_clipped:
            raise ClippedTraceError(self.role, self.resource_name, name, clipped_fraction)
        n = np.arange(raw.size, dtype=np.float64)
        return Waveform(
            time_s=preamble.x_zero_s + preamble.x_increment_s * (n - preamble.point_offset),
            values=preamble.y_zero + preamble.y_multiplier * (raw.astype(np.float64) - preamble.y_offset_counts),
            unit=preamble.y_unit, x_increment_s=preamble.x_increment_s, y_multiplier=preamble.y_multiplier,
            y_offset_counts=preamble.y_offset_counts, y_zero=preamble.y_zero, bits=preamble.bits,
            source=name, clipped_fraction=clipped_fraction, averages=averages if mode == "AVERAGE" else 1)

    # -- status (Section 3: *ESR? makes the events it summarises readable) -----------------------
    def read_events(self) -> list[tuple[int, str]]:
        """*ESR? (read and cleared), then every event it made readable (ALLEV?), in order;
        the queue is empty afterwards."""
        self.parse_reply("*ESR?", self.query("*ESR?"), int)  # p. 2-116
        return self.parse_reply("ALLEV?", self.query("ALLEV?"), _events)  # p. 2-54

    def check_errors(self) -> None:
        """InstrumentError with the first error event's code and message (later ones appended)."""
        errors = [event for event in self.read_events() if event[0] not in _NOT_ERRORS]
        if errors:
            (code, message), later = errors[0], errors[1:]
            if later:
                message += " (then: " + "; ".join(f"{c},{m!r}" for c, m in later) + ")"
            raise InstrumentError(self.role, self.resource_name, message, code)

    def detected_probes(self) -> dict[int, tuple[str, float, str]]:
        """{channel: (probe model, gain, unit)} for each probe the scope detected."""
        probes = {}
        for number, ch in self._channels.items():
            model = ch.probe_model
            if model:
                probes[number] = (model, ch.probe_gain, ch.unit)
        return probes

    def settings_snapshot(self) -> dict[str, Any]:
        snapshot = super().settings_snapshot()
        snapshot.update({f"ch{n}": ch.settings_snapshot() for n, ch in self._channels.items()})
        return snapshot

    # Names the protocols package calls.
    def set_vertical_scales(self, scales_per_div: dict[int, float]) -> None:
        """Several channels' vertical scales in two messages, not two per channel (p. 2-4):
        their probe gains read together (a scale's range depends on its probe), then the
        scales set together. A scale outside its channel's range is refused (OutOfRangeError)
        before any is sent."""
        channels = [self.channel(number) for number in scales_per_div]
        gains = self.read_together([(ch, Channel.probe_gain) for ch in channels])
        commands = []
        for ch, gain, scale in zip(channels, gains, scales_per_div.values()):
            allowed = strict_range(*scale_range_per_div(gain), "units/div at the present probe gain")
            value = checked(f"{ch.property_prefix}.scale_v_per_div", allowed, scale)
            commands.append(Channel.scale_v_per_div.message_for(ch, value))   # p. 2-69 CH<x>:SCAle
        self.write(concatenated(commands))

    def set_record_length(self, points: int) -> None:
        self.record_length = points

    def set_math_product(self) -> None:
        self.define_math_product("CH1", "CH2")

    def acquire(self) -> None:
        """acquire_single with a timeout estimated from the present settings."""
        self.acquire_single(self.acquisition_timeout_s())


def _events(reply: str) -> list[tuple[int, str]]:
    """ALLEV? -> [(code, message)]: <code>,<QString>[,<code>,<QString>...] (p. 2-54)."""
    fields = next(csv.reader([reply], delimiter=",", quotechar='"', skipinitialspace=True))
    if len(fields) % 2:
        raise ValueError("expected code,\"message\" pairs")
    return [(int(fields[i]), fields[i + 1]) for i in range(0, len(fields), 2)]
