"""The Tektronix TDS 3054B's settings as its programmer manual spells and bounds them.

The keyword tables (long form -> the reply's spelling), the status bits, the limits and
the small parsers and formats the simulated scope (`simbench.scope`) uses, and that
`simbench.devices` draws a previous user's settings from. "TDS PM" = TDS3000/B/C Series
Programmer Manual 071-0381-03 (page numbers).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Callable

from squeezebench.simbench import scpi, traces
from squeezebench.simbench.scpi import PREFIX, Unit
from squeezebench.simbench.scpi_device import _choices

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
