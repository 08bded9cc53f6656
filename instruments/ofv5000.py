"""Polytec OFV-5000 vibrometer controller (with an OFV-505 sensor head).

Not SCPI. The controller speaks ASCII lines over RS-232 (115200 baud, 8N1, LF):
`<Verb>,<Device>,<index>,<Attribute>[,<value>]` with the verbs `GetDevInfo`, `Get` and
`Set` (OFV-5000 user manual, "RS-232 interface commands"; cited below as "OFV RS-232").
A `Set` has no reply and the controller keeps no error queue: it answers `Error` to a
line it refuses, so the driver reads every setting back after writing it and a refusal
shows up in front of the read-back's reply. Echo is on at power-on: the controller
repeats each line it receives, which would interleave with the replies, so the driver
turns it off and reads the echo of that very line if there is one.

Values are the controller's own spelling, which the driver reads from it rather than
assumes: the velocity decoder's ranges (`125mm/s/V`) differ between decoder models and
`GetDevInfo,VeloDec,0,Range` lists those of the installed one; the filter settings are
spelled with a space (`100 kHz`). The decoder turns velocity into a voltage on the
scope's CH3 with the range's scale factor: at `125mm/s/V`, 1 V means 0.125 m/s
(`volts_to_velocity_mps`). The low-pass filter must stay above the plate's 25-60 kHz.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np
from pyvisa import constants

from squeezebench.instruments.base import Instrument, set_serial_line
from squeezebench.instruments.errors import GarbledReply, InstrumentError, InstrumentTimeout
from squeezebench.instruments.properties import checked, control, strict_discrete_set

#: The output low-pass filter for a measurement of the plate (25-60 kHz): 5 and 20 kHz
#: would cut the signal.
MEASUREMENT_FILTER = "100 kHz"
LOW_PASS_FILTERS = ("Off", "5 kHz", "20 kHz", "100 kHz")
#: Tracking filter settings: it bridges signal dropouts by limiting how fast the decoded
#: velocity may change, which a clean 25-60 kHz signal does not need.
TRACKING_FILTERS = ("Off", "Slow", "Fast")
BAUD_RATE = 115200
#: How long to wait for the reply that follows an `Error` line (the controller answers
#: within milliseconds; a refused Get has nothing more to send).
_AFTER_ERROR_S = 0.2
_RANGE = re.compile(r"^\s*([0-9]*\.?[0-9]+)\s*(mm|m|µm|um)/s/V\s*$")
_UNITS_M = {"m": 1.0, "mm": 1e-3, "µm": 1e-6, "um": 1e-6}


def range_mps_per_v(name: str) -> float:
    """A decoder range as the controller spells it (`125mm/s/V`) -> m/s per V."""
    match = _RANGE.match(name)
    if match is None:
        raise ValueError(f"not a velocity range: {name!r}")
    return float(match.group(1)) * _UNITS_M[match.group(2)]


def _flag(reply: str) -> bool:
    if reply.strip() not in ("0", "1"):
        raise ValueError("expected 0 or 1")
    return reply.strip() == "1"


def _percent(reply: str) -> float:
    value = float(reply)
    if not 0.0 <= value <= 100.0:
        raise ValueError("expected 0 to 100")
    return value


def _ranges(reply: str) -> dict[str, float]:
    names = [name.strip() for name in reply.split(",") if name.strip()]
    if not names:
        raise ValueError("no ranges listed")
    return {name: range_mps_per_v(name) for name in names}


class OFV5000(Instrument):
    """The bench's vibrometer controller (`ASRL1::INSTR` on the simulated bench)."""

    MODEL = "OFV-5000"

    echo = control("Get,Interface,0,Echo", "Set,Interface,0,Echo,{}", "Whether the controller repeats each line.",
                   values={"On": "On", "Off": "Off"}, check_set=True, manual="OFV RS-232 Interface Echo")
    decoder = control("Get,VeloDec,0,Name", None, "Model of the installed velocity decoder (index 0).",
                      parse=str.strip, manual="OFV RS-232 VeloDec Name")
    velocity_range = control("Get,VeloDec,0,Range", "Set,VeloDec,0,Range,{}",
                             "Velocity decoder range as the controller spells it, e.g. 125mm/s/V.",
                             validator=lambda vibrometer: strict_discrete_set(vibrometer.ranges_mps_per_v),
                             parse=str.strip, check_set=True, manual="OFV RS-232 VeloDec Range")
    low_pass_filter = control("Get,VeloFilter,0,LowPassRange", "Set,VeloFilter,0,LowPassRange,{}",
                              "Output low-pass filter.", values={name: name for name in LOW_PASS_FILTERS},
                              check_set=True, manual="OFV RS-232 VeloFilter LowPassRange")

    high_pass_filter = control("Get,VeloFilter,0,HighPassRange", "Set,VeloFilter,0,HighPassRange,{}",
                               "Output high-pass filter: Off, or a corner the controller lists.",
                               parse=str.strip, validator=strict_discrete_set(("Off",)), check_set=True,
                               manual="OFV RS-232 VeloFilter HighPassRange")
    tracking_filter = control("Get,TrackingFilter,0,Range", "Set,TrackingFilter,0,Range,{}", "Tracking filter.",
                              values={name: name for name in TRACKING_FILTERS}, check_set=True,
                              manual="OFV RS-232 TrackingFilter Range")

    def __init__(self, resource: Any, role: str = "vibrometer") -> None:
        super().__init__(resource, role)
        set_serial_line(resource, BAUD_RATE, constants.StopBits.one)
        self._last_line = ""
        self.device_clear()
        self._echo_off()
        self.ranges_mps_per_v = self._listed_ranges()

    # -- the line protocol ------------------------------------------------------------------------
    def write(self, command: str) -> None:
        self._last_line = command
        super().write(command)

    def query(self, command: str) -> str:
        """A Get: its reply, after any `Error` the controller sent for the line before
        (a refused Set), which raises InstrumentError once the link is in step again."""
        refused = self._last_line
        self._last_line = command
        reply = super().query(command)
        if reply != "Error":
            return reply
        try:
            with self.timeout(_AFTER_ERROR_S):
                self._read(command)
        except InstrumentTimeout:   # nothing follows: this very line was refused
            raise InstrumentError(self.role, self.resource_name, f"the controller refused {command!r} (Error)") \
                from None
        raise InstrumentError(self.role, self.resource_name, f"the controller refused {refused!r} (Error)")

    def _read(self, operation: str) -> str:
        with self._visa(operation):
            return self.resource.read().strip()

    def _echo_off(self) -> None:
        """`Set,Interface,0,Echo,Off`, then read the echo state back: with echo on, the
        controller first repeats the Set line itself, which is skipped."""
        line = "Set,Interface,0,Echo,Off"   # OFV RS-232 Interface Echo
        self.write(line)
        reply = self.query("Get,Interface,0,Echo")
        if reply == line:
            reply = self._read("Get,Interface,0,Echo")
        if reply != "Off":
            raise GarbledReply(self.role, self.resource_name, "Get,Interface,0,Echo", reply, "expected Off")

    def _listed_ranges(self) -> dict[str, float]:
        command = "GetDevInfo,VeloDec,0,Range"   # OFV RS-232 GetDevInfo: the decoder's legal ranges
        return self.parse_reply(command, self.query(command), _ranges)

    @property
    def identification(self) -> str:
        return self.query("GetDevInfo,Controller,0,Name")   # OFV RS-232 Controller Name

    # -- the decoder's scale ---------------------------------------------------------------------
    @property
    def velocity_range_mps_per_v(self) -> float:
        """Decoder scale factor (m/s per V of output)."""
        name = self.velocity_range
        if name not in self.ranges_mps_per_v:
            raise GarbledReply(self.role, self.resource_name, "Get,VeloDec,0,Range", name,
                               f"not one of the decoder's ranges {', '.join(self.ranges_mps_per_v)}")
        return self.ranges_mps_per_v[name]

    @velocity_range_mps_per_v.setter
    def velocity_range_mps_per_v(self, mps_per_v: float) -> None:
        scale = checked(f"{self.role}.velocity_range_mps_per_v",
                        strict_discrete_set(self.ranges_mps_per_v.values(), "m/s/V"), mps_per_v)
        self.velocity_range = next(name for name, s in self.ranges_mps_per_v.items() if s == scale)

    def volts_to_velocity_mps(self, volts: float | np.ndarray, range_mps_per_v: float | None = None):
        """Decoder output (V) -> velocity (m/s), at `range_mps_per_v` or the present range."""
        scale = self.velocity_range_mps_per_v if range_mps_per_v is None else range_mps_per_v
        return np.asarray(volts, dtype=np.float64) * scale if np.ndim(volts) else float(volts) * scale

    # -- live readings (queried each time: they follow the signal) -------------------------------
    def over_range(self) -> bool:
        """Whether the decoder output exceeds its range (velocity beyond the range's limit)."""
        command = "Get,OverRange,0,Value"   # OFV RS-232 OverRange
        return self.parse_reply(command, self.query(command), _flag)

    def signal_level_percent(self) -> float:
        """Strength of the light returning to the sensor head, 0 to 100 %."""
        command = "Get,SignalLevel,0,Value"   # OFV RS-232 SignalLevel
        return self.parse_reply(command, self.query(command), _percent)

    def settings_snapshot(self) -> dict[str, Any]:
        snapshot = super().settings_snapshot()
        snapshot["velocity_range_mps_per_v"] = self.ranges_mps_per_v.get(snapshot["velocity_range"])
        return snapshot

    # Names the protocols package calls.
    def set_range(self, name: str) -> None:
        self.velocity_range = name

    def prepare_for_measurement(self) -> None:
        """The output filters a measurement of the plate needs, whatever a previous user
        chose: the low-pass above the plate's band, no high-pass, no tracking filter."""
        self.low_pass_filter = MEASUREMENT_FILTER
        self.high_pass_filter = "Off"
        self.tracking_filter = "Off"
