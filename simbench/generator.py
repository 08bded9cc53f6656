"""Simulated HP/Agilent 33120A function generator: SCPI, its error queue, its sine limits.

Manual references: "33120A UG" = HP 33120A User's Guide (Chapter 4 remote interface
reference, Chapter 5 error messages). What could not be verified against the manual is
said where it is modelled.
"""

from __future__ import annotations

import math
import re
from collections import deque

from squeezebench.simbench import physics, scpi
from squeezebench.simbench.scpi import SCPI, ScpiError, Unit
from squeezebench.simbench.scpi_device import Command, ScpiInstrument, _choices, _flag, _setting

#: Bench time the 33120A takes to apply a change (assumed: a new frequency settles in
#: about 10 ms; an amplitude, offset or load change may switch attenuator relays).
GENERATOR_FREQUENCY_SETTLE_S = 0.010
GENERATOR_LEVEL_SETTLE_S = 0.030
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

    def settings_key(self):
        """What `settings()` depends on, cheaper to build and compare than the settings:
        the programmed drive, or the settings themselves while a modulation moves them with
        bench time (the bench asks at every clock advance whether its steady state still
        holds)."""
        s = self.state
        if s["modulation"] is not None:
            return self.settings()
        return s["frequency"], s["amplitude_vpp"], s["offset"], s["load"], s["shape"]

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
