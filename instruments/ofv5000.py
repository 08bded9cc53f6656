"""Polytec OFV-5000 vibrometer controller (with an OFV-505 sensor head).

Not SCPI. The controller speaks ASCII lines over RS-232 (115200 baud, 8N1, LF):
`<Verb>,<Device>,<index>,<Attribute>[,<value>]` with the verbs `GetDevInfo`, `Get` and
`Set`. A `Set` has no reply and the controller keeps no error queue, so the driver reads
every setting back after writing it. While `Echo` is On the controller repeats each line
it receives, which would interleave with the replies: the driver turns it off first.

The velocity decoder (index 0 on our controller; indices differ between units) turns
velocity into a voltage on the scope's CH3 with the range's scale factor: at
`125mm/s/V`, 1 V means 0.125 m/s. That conversion lives here
(`volts_to_velocity_mps`). The low-pass filter must stay above the plate's 25-60 kHz:
never 5 kHz or 20 kHz for a measurement.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pyvisa import constants
from pyvisa.resources import SerialInstrument

from squeezebench.instruments.base import Instrument
from squeezebench.instruments.properties import checked, control, strict_discrete_set

#: Velocity decoder ranges (controller's names) and their scale factors (m/s per V).
VELOCITY_RANGES_MPS_PER_V = {"5mm/s/V": 0.005, "25mm/s/V": 0.025, "125mm/s/V": 0.125, "1000mm/s/V": 1.0}
LOW_PASS_FILTERS = ("5kHz", "20kHz", "100kHz", "Off")
BAUD_RATE = 115200


def _flag(reply: str) -> bool:
    if reply.strip() not in ("0", "1"):
        raise ValueError("expected 0 or 1")
    return reply.strip() == "1"


def _percent(reply: str) -> float:
    value = float(reply)
    if not 0.0 <= value <= 100.0:
        raise ValueError("expected 0 to 100")
    return value


class OFV5000(Instrument):
    """The bench's vibrometer controller (`ASRL1::INSTR` on the simulated bench)."""

    MODEL = "OFV-5000"

    echo = control("Get,Interface,0,Echo", "Set,Interface,0,Echo,{}", "Whether the controller repeats each line.",
                   values={"On": "On", "Off": "Off"}, check_set=True)
    velocity_range = control("Get,VeloDec,0,Range", "Set,VeloDec,0,Range,{}",
                             "Velocity decoder range, e.g. 125mm/s/V.",
                             values={name: name for name in VELOCITY_RANGES_MPS_PER_V}, check_set=True)
    low_pass_filter = control("Get,VeloFilter,0,LowPassRange", "Set,VeloFilter,0,LowPassRange,{}",
                              "Output low-pass filter.", values={name: name for name in LOW_PASS_FILTERS},
                              check_set=True)

    def __init__(self, resource: Any, role: str = "vibrometer") -> None:
        super().__init__(resource, role)
        if isinstance(resource, SerialInstrument):
            resource.baud_rate = BAUD_RATE
            resource.data_bits = 8
            resource.parity = constants.Parity.none
            resource.stop_bits = constants.StopBits.one
        self.echo = "Off"

    @property
    def identification(self) -> str:
        return self.query("GetDevInfo,Controller,0,Name")

    # -- the decoder's scale ---------------------------------------------------------------------
    @property
    def velocity_range_mps_per_v(self) -> float:
        """Decoder scale factor (m/s per V of output)."""
        return VELOCITY_RANGES_MPS_PER_V[self.velocity_range]

    @velocity_range_mps_per_v.setter
    def velocity_range_mps_per_v(self, mps_per_v: float) -> None:
        scale = checked(f"{self.role}.velocity_range_mps_per_v",
                        strict_discrete_set(VELOCITY_RANGES_MPS_PER_V.values(), "m/s/V"), mps_per_v)
        self.velocity_range = next(name for name, s in VELOCITY_RANGES_MPS_PER_V.items() if s == scale)

    def volts_to_velocity_mps(self, volts: float | np.ndarray, range_mps_per_v: float | None = None):
        """Decoder output (V) -> velocity (m/s), at `range_mps_per_v` or the present range."""
        scale = self.velocity_range_mps_per_v if range_mps_per_v is None else range_mps_per_v
        return np.asarray(volts, dtype=np.float64) * scale if np.ndim(volts) else float(volts) * scale

    # -- live readings (queried each time: they follow the signal) -------------------------------
    def over_range(self) -> bool:
        """Whether the decoder output exceeds its range (velocity beyond the range's limit)."""
        return self.parse_reply("Get,OverRange,0,Value", self.query("Get,OverRange,0,Value"), _flag)

    def signal_level_percent(self) -> float:
        """Strength of the light returning to the sensor head, 0 to 100 %."""
        return self.parse_reply("Get,SignalLevel,0,Value", self.query("Get,SignalLevel,0,Value"), _percent)

    def settings_snapshot(self) -> dict[str, Any]:
        snapshot = super().settings_snapshot()
        snapshot["velocity_range_mps_per_v"] = VELOCITY_RANGES_MPS_PER_V[snapshot["velocity_range"]]
        return snapshot

    # Name the protocols package calls.
    def set_range(self, name: str) -> None:
        self.velocity_range = name
