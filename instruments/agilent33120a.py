"""HP/Agilent 33120A 15 MHz function generator: the sine that drives the amplifier.

The 33120A has no output on/off command (that came with the 33220A): "off" here means
the smallest amplitude the present load setting allows (`output_to_minimum`).

`OUTP:LOAD` only tells the generator what load to expect: it rescales what is
programmed and displayed, not what comes out. Into the amplifier's high-impedance input
the setting must be INF, or the amplitude delivered is twice the one programmed.

Limits of the sine (user's guide): 100 uHz - 15 MHz; 50 mVpp - 10 Vpp into 50 ohm and
100 mVpp - 20 Vpp into high impedance; |offset| + Vpp/2 <= 5 V (50 ohm) or 10 V (high-Z).
They are checked before anything is sent, against the load setting read from the
generator. Amplitudes are peak-to-peak: the driver sets `VOLT:UNIT VPP` on connect.

Commands are the SCPI short forms of the HP 33120A User's Guide (Chapter 4, "Remote
Interface Reference"; errors in Chapter 5); the section is cited beside each.
"""

from __future__ import annotations

import re
from typing import Any

from pyvisa import constants

from squeezebench.instruments.base import SCPIInstrument, set_serial_line
from squeezebench.instruments.errors import InstrumentError
from squeezebench.instruments.properties import Validator, checked, control, strict_range

#: The RS-232 port's factory baud rate (33120A UG, Chapter 3).
BAUD_RATE = 9600
#: Sine frequency limits (Hz).
FREQUENCY_RANGE_HZ = (100e-6, 15e6)
#: Sine amplitude limits (Vpp) and |offset| + Vpp/2 limit (V) per OUTP:LOAD setting.
AMPLITUDE_RANGE_VPP = {"50": (0.050, 10.0), "INF": (0.100, 20.0)}
PEAK_LIMIT_V = {"50": 5.0, "INF": 10.0}
#: The 33120A reports an INF load as 9.9E+37.
_INFINITE_LOAD = 9.9e37
#: SYST:ERR? holds at most 20 errors; more reads than that means the queue never empties.
_ERROR_QUEUE_DEPTH = 20
_ERROR = re.compile(r'^\s*([+-]?\d+)\s*,\s*"(.*)"\s*$')


def _state(reply: str) -> bool:
    """<mod>:STATe? answers 0 or 1."""
    if reply.strip() not in ("0", "1"):
        raise ValueError("expected 0 or 1")
    return reply.strip() == "1"


def _load_setting(reply: str) -> str:
    """OUTP:LOAD? -> "50" or "INF" (the instrument answers +5.000000E+01 or +9.900000E+37)."""
    ohm = float(reply)
    if ohm >= _INFINITE_LOAD:
        return "INF"
    if ohm == 50.0:
        return "50"
    raise ValueError("neither 50 ohm nor high impedance")


def amplitude_range(load: str, offset_v: float) -> Validator:
    low, high = AMPLITUDE_RANGE_VPP[load]
    high = min(high, 2.0 * (PEAK_LIMIT_V[load] - abs(offset_v)))
    return strict_range(low, high, f"Vpp into OUTP:LOAD {load} with a {offset_v:g} V offset")


def offset_range(load: str, amplitude_vpp: float) -> Validator:
    headroom_v = PEAK_LIMIT_V[load] - amplitude_vpp / 2.0
    return strict_range(-headroom_v, headroom_v,
                        f"V: |offset| + Vpp/2 <= {PEAK_LIMIT_V[load]:g} V into OUTP:LOAD {load}")


class Agilent33120A(SCPIInstrument):
    """The bench's generator (`GPIB0::10::INSTR` on the simulated bench)."""

    MODEL = "33120A"

    shape = control("FUNC:SHAP?", "FUNC:SHAP {}", "Output function.",
                    values={"SIN": "SIN", "SQU": "SQU", "TRI": "TRI", "RAMP": "RAMP",
                            "NOIS": "NOIS", "DC": "DC", "USER": "USER"}, manual="UG Ch. 4 FUNCtion:SHAPe")
    frequency_hz = control("FREQ?", "FREQ {:.9g}", "Output frequency (Hz), sine limits.",
                           validator=strict_range(*FREQUENCY_RANGE_HZ, "Hz"), manual="UG Ch. 4 FREQuency")
    voltage_unit = control("VOLT:UNIT?", None, "Unit of VOLT numbers: VPP, set on connect and "
                           "by apply_sine (amplitude_vpp relies on it).",
                           values={"VPP": "VPP", "VRMS": "VRMS", "DBM": "DBM"}, manual="UG Ch. 4 VOLTage:UNIT")
    amplitude_vpp = control("VOLT?", "VOLT {:.9g}", "Sine amplitude, peak-to-peak (V), "
                            "within the limits of the present load setting.",
                            validator=lambda generator: amplitude_range(generator.output_load, generator.offset_v),
                            manual="UG Ch. 4 VOLTage")
    offset_v = control("VOLT:OFFS?", "VOLT:OFFS {:.9g}", "DC offset (V).",
                       validator=lambda generator: offset_range(generator.output_load, generator.amplitude_vpp),
                       manual="UG Ch. 4 VOLTage:OFFSet")
    output_load = control("OUTP:LOAD?", "OUTP:LOAD {}", 'Expected load: "50" (ohm) or "INF" (high impedance).',
                          values={"50": "50", "INF": "INF"}, parse=_load_setting, manual="UG Ch. 4 OUTPut:LOAD")

    def __init__(self, resource: Any, role: str = "generator") -> None:
        # Over RS-232 (33120A UG, Chapter 3 "RS-232 interface configuration"): 9600 baud,
        # 8 data bits, no parity, 2 stop bits, the factory settings. Set before the first byte.
        set_serial_line(resource, BAUD_RATE, constants.StopBits.two)
        super().__init__(resource, role)
        # Safe from the first message: before anything is read, whatever a previous user
        # left is brought to rest. Through the amplifier a 2 V offset is some 40 V DC on the
        # piezos, and an amplitude is multiplied by the gain; MIN is the present load
        # setting's minimum, so this needs no reading first.
        self.write("VOLT:UNIT VPP")  # UG Ch. 4 VOLTage:UNIT (how VOLT numbers are read and written)
        self.write("VOLT MIN")  # UG Ch. 4 VOLTage {<amplitude>|MINimum|MAXimum}
        self.write("VOLT:OFFS 0")  # UG Ch. 4 VOLTage:OFFSet
        # A modulation left on makes the drive something else than the sine every point
        # assumes (AM halves it on average, a burst or a sweep barely reaches the plate).
        self.write("AM:STAT OFF")  # UG Ch. 4 AM:STATe
        self.write("FM:STAT OFF")  # UG Ch. 4 FM:STATe
        self.write("FSK:STAT OFF")  # UG Ch. 4 FSKey:STATe
        self.write("BM:STAT OFF")  # UG Ch. 4 BM:STATe (burst modulation)
        self.write("SWE:STAT OFF")  # UG Ch. 4 SWEep:STATe

    def modulations_on(self) -> list[str]:
        """The modulations reported on (normally none: the connection turns them off)."""
        return [name for name in ("AM", "FM", "FSK", "BM", "SWE")
                if self.parse_reply(f"{name}:STAT?", self.query(f"{name}:STAT?"), _state)]  # UG Ch. 4 <mod>:STATe?

    # -- limits of the present load setting ------------------------------------------------------
    @property
    def min_amplitude_vpp(self) -> float:
        return AMPLITUDE_RANGE_VPP[self.output_load][0]

    @property
    def max_amplitude_vpp(self) -> float:
        return AMPLITUDE_RANGE_VPP[self.output_load][1]

    # -- procedures ------------------------------------------------------------------------------
    def apply_sine(self, frequency_hz: float, amplitude_vpp: float, offset_v: float = 0.0) -> None:
        """Sine of `amplitude_vpp` at `frequency_hz` around `offset_v`, all checked first."""
        load = self.output_load
        frequency_hz = checked(f"{self.role}.frequency_hz", type(self).frequency_hz.validator, frequency_hz)
        amplitude_vpp = checked(f"{self.role}.amplitude_vpp", amplitude_range(load, 0.0), amplitude_vpp)
        offset_v = checked(f"{self.role}.offset_v", offset_range(load, amplitude_vpp), offset_v)
        present_offset_v = self.offset_v
        self.write("FUNC:SHAP SIN")  # UG Ch. 4 FUNCtion:SHAPe
        self.write("VOLT:UNIT VPP")  # UG Ch. 4 VOLTage:UNIT
        self.write(f"FREQ {frequency_hz:.9g}")  # UG Ch. 4 FREQuency
        # The 33120A refuses (and clips) a combination beyond the peak limit, even for a
        # moment: lower the offset before raising the amplitude, raise it after.
        if abs(offset_v) <= abs(present_offset_v):
            self.write(f"VOLT:OFFS {offset_v:.9g}")  # UG Ch. 4 VOLTage:OFFSet
            self.write(f"VOLT {amplitude_vpp:.9g}")  # UG Ch. 4 VOLTage
        else:
            self.write(f"VOLT {amplitude_vpp:.9g}")
            self.write(f"VOLT:OFFS {offset_v:.9g}")

    def output_to_minimum(self) -> None:
        """The nearest the 33120A has to "output off": the minimum amplitude of the load setting."""
        self.amplitude_vpp = self.min_amplitude_vpp

    def sine_at_minimum(self) -> None:
        """A plain sine (no offset) at the minimum amplitude of the load setting, whatever a
        previous session left: the amplitude is lowered first, then the output reshaped."""
        self.output_to_minimum()
        self.apply_sine(self.frequency_hz, self.min_amplitude_vpp)

    # What the protocols' DriveController calls (one command each).
    def set_frequency(self, frequency_hz: float) -> None:
        self.frequency_hz = frequency_hz

    def set_amplitude_vpp(self, amplitude_vpp: float) -> None:
        self.amplitude_vpp = amplitude_vpp

    def read_errors(self) -> list[tuple[int, str]]:
        """Drain SYSTem:ERRor? (UG Ch. 5: oldest first, +0,"No error" when empty)."""
        errors: list[tuple[int, str]] = []
        for _ in range(_ERROR_QUEUE_DEPTH + 1):
            reply = self.query("SYST:ERR?")  # UG Ch. 4 SYSTem:ERRor?
            code, message = self.parse_reply("SYST:ERR?", reply, _error)
            if code == 0:
                return errors
            errors.append((code, message))
        errors.append((0, f"error queue not empty after {_ERROR_QUEUE_DEPTH + 1} reads"))
        return errors

    def check_errors(self) -> None:
        """InstrumentError with the first queued error's own code and message (later ones
        appended to the message)."""
        errors = self.read_errors()
        if errors:
            (code, message), later = errors[0], errors[1:]
            if later:
                message += " (then: " + "; ".join(f"{c},{m!r}" for c, m in later) + ")"
            raise InstrumentError(self.role, self.resource_name, message, code)


def _error(reply: str) -> tuple[int, str]:
    match = _ERROR.match(reply)
    if match is None:
        raise ValueError('expected <code>,"<message>"')
    return int(match.group(1)), match.group(2)
