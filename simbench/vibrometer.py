"""Simulated Polytec OFV-5000 vibrometer controller: its RS-232 line protocol.

Manual reference: "OFV" = Polytec OFV-5000 user manual, RS-232 interface commands. What
could not be verified against the manual is said where it is modelled.
"""

from __future__ import annotations

import re
from typing import Callable

from squeezebench.simbench import command_tables
from squeezebench.simbench.device_base import SimulatedInstrument

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
