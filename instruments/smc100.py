"""Newport SMC100 (CC or PP) motion controllers as the x-y stage under the vibrometer.

Chosen over a Zaber ASCII or an ESP301 controller because its command manual is public
and its grammar is the smallest that still reports everything a map needs: two-letter
ASCII commands, one axis per controller, and both controllers on one serial resource
(RS-232 to the first, RS-485 between them), addressed 1 (x) and 2 (y). The state word of
`TS` carries the positioner's error bits (following error, end of run) and the
controller's state (NOT REFERENCED, HOMING, MOVING, READY) in the manual's own terms,
so "the move finished" and "why it failed" are read, never guessed from timing.

Cited below as "SMC100 UM" (Newport SMC100CC & SMC100PP Single-Axis Motion Controller/
Driver User's Manual, chapter "Controller Command Set", command entries by their two
letters; the state table of chapter "Controller States"; the error letters of `TE`).
Not available here in full text: the grammar is the one public drivers quote
(`xxAAnn`, CR LF, replies `xxAA<value>`); the bit and letter tables below are from
those drivers and the manual as remembered, **unverified** in detail.

Line protocol (SMC100 UM "Communication protocol"): `<address><AA>[<value>|?]` ended by
CR LF at 57600 baud, 8N1, XON/XOFF. A set or an action has no reply; a query (`TP`,
`TS`, `TE`, and a parameter with `?`) answers `<address><AA><value>`. A command the
controller refuses is silent: its reason is the letter `TE` returns, so the driver asks
`TE` after each action.

Positions are in millimetres on the wire (the stage's unit), so every name here carries
`_mm`; the protocol converts to the project's SI metres where it stores them.
"""

from __future__ import annotations

import time
from typing import Any, Callable

from pyvisa import constants

from squeezebench.instruments.base import Instrument, set_serial_line
from squeezebench.instruments.errors import InstrumentError, OutOfRangeError

BAUD_RATE = 57600
#: SMC100 UM "Communication protocol": every command ends with CR LF, so does every reply.
LINE_END = "\r\n"
#: The stage's axes and the RS-485 address of the controller driving each.
AXES = {"x": 1, "y": 2}

#: SMC100 UM TS: the two last hex digits of the state word.
NOT_REFERENCED = {"0A", "0B", "0C", "0D", "0E", "0F", "10"}
HOMING = {"1E", "1F"}
MOVING = {"28"}
READY = {"32", "33", "34", "35"}
DISABLE = {"3C", "3D", "3E"}

#: SMC100 UM TS: the first four hex digits, the positioner error bits.
POSITIONER_ERRORS = {
    0x0001: "negative end of run",
    0x0002: "positive end of run",
    0x0004: "peak current limit",
    0x0008: "RMS current limit",
    0x0010: "short circuit detection",
    0x0020: "following error",
    0x0040: "homing time out",
    0x0080: "wrong ESP stage",
    0x0100: "DC voltage too low",
    0x0200: "80 W output power exceeded",
}

#: SMC100 UM TE: the letter of the last command error; `@` is none.
COMMAND_ERRORS = {
    "A": "unknown message code or floating point controller address",
    "B": "controller address not correct",
    "C": "parameter missing or out of range",
    "D": "command not allowed",
    "E": "home sequence already started",
    "G": "displacement out of limits",
    "H": "command not allowed in NOT REFERENCED state",
    "I": "command not allowed in CONFIGURATION state",
    "J": "command not allowed in DISABLE state",
    "K": "command not allowed in READY state",
    "L": "command not allowed in HOMING state",
    "M": "command not allowed in MOVING state",
    "N": "current position out of software limit",
    "S": "communication time out",
    "V": "error during command execution",
}


def parse_state(word: str) -> tuple[int, str]:
    """`TS` value `EEEESS` -> (positioner error bits, controller state code)."""
    if len(word) != 6:
        raise ValueError("expected 6 hex digits EEEESS")
    return int(word[:4], 16), word[4:].upper()


def describe_errors(bits: int) -> list[str]:
    """Positioner error bits in the manual's words."""
    return [text for bit, text in POSITIONER_ERRORS.items() if bits & bit]


class SMC100Stage(Instrument):
    """Two SMC100 controllers (x at address 1, y at 2) on one serial resource."""

    #: SMC100 UM VE: the revision reads `SMC_CC - ...` or `SMC_PP - ...`.
    MODEL = "SMC_"

    def __init__(self, resource: Any, role: str = "stage", poll_interval_s: float = 0.05,
                 motion_timeout_s: float = 60.0, sleep: Callable[[float], None] = time.sleep) -> None:
        super().__init__(resource, role)
        resource.read_termination = LINE_END
        resource.write_termination = LINE_END
        set_serial_line(resource, BAUD_RATE, constants.StopBits.one, constants.ControlFlow.xon_xoff)
        self.poll_interval_s = poll_interval_s
        self.motion_timeout_s = motion_timeout_s
        self.sleep = sleep   # the bench's own wait: bench time on the simulated bench
        self.travel_mm = {axis: self._travel_mm(axis) for axis in AXES}

    # -- the line protocol ------------------------------------------------------------------------
    def ask(self, axis: str, command: str, suffix: str = "") -> str:
        """`<address><command><suffix>` -> the value after the echoed `<address><command>`."""
        message = f"{AXES[axis]}{command}{suffix}"
        reply = self.query(message)
        head = f"{AXES[axis]}{command}"

        def value(text: str) -> str:
            if not text.startswith(head):
                raise ValueError(f"expected the reply to start with {head}")
            return text[len(head):].strip()
        return self.parse_reply(message, reply, value)

    def _number(self, axis: str, command: str, suffix: str = "") -> float:
        message = f"{AXES[axis]}{command}{suffix}"
        return self.parse_reply(message, self.ask(axis, command, suffix), float)

    def clear_status(self) -> list[str]:
        """Read `TE` on both axes (SMC100 UM TE: reading the error code clears it), so a
        letter a previous user left is not taken for this session's; returns those letters
        in the manual's words."""
        stale = []
        for axis in AXES:
            letter = self.ask(axis, "TE")
            if letter != "@":
                stale.append(f"{axis}: {letter}, {COMMAND_ERRORS.get(letter, 'error code not in the manual')}")
        return stale

    def check_command_error(self, axis: str, after: str) -> None:
        """`TE` (SMC100 UM TE): the letter of the last command's error, raised in the
        manual's words; `@` means the command `after` was accepted."""
        letter = self.ask(axis, "TE")
        if letter != "@":
            text = COMMAND_ERRORS.get(letter, "error code not in the manual's TE table")
            raise InstrumentError(self.role, self.resource_name,
                                  f"{axis} axis refused {after!r}: {letter}, {text}")

    def state(self, axis: str) -> tuple[int, str]:
        """`TS` (SMC100 UM TS): (positioner error bits, controller state)."""
        message = f"{AXES[axis]}TS"
        return self.parse_reply(message, self.ask(axis, "TS"), parse_state)

    # -- identification and parameters ----------------------------------------------------------
    @property
    def identification(self) -> str:
        return self.ask("x", "VE")   # SMC100 UM VE: controller revision, e.g. "SMC_CC - ..."

    def identify(self) -> str:
        """Both controllers answer `VE` as SMC100s."""
        found = super().identify()
        other = self.ask("y", "VE")   # SMC100 UM VE
        if self.MODEL not in other:
            raise InstrumentError(self.role, self.resource_name,
                                  f"the y axis (address {AXES['y']}) answers {other!r}, not an SMC100")
        return found

    def _travel_mm(self, axis: str) -> tuple[float, float]:
        return (self._number(axis, "SL", "?"),    # SMC100 UM SL: negative software limit
                self._number(axis, "SR", "?"))    # SMC100 UM SR: positive software limit

    def velocity_mm_per_s(self, axis: str) -> float:
        return self._number(axis, "VA", "?")   # SMC100 UM VA: move velocity

    def set_velocity_mm_per_s(self, axis: str, velocity_mm_per_s: float) -> None:
        if velocity_mm_per_s <= 0:
            raise OutOfRangeError(f"{self.role}.velocity_mm_per_s", velocity_mm_per_s, "> 0")
        self.write(f"{AXES[axis]}VA{velocity_mm_per_s:.6g}")   # SMC100 UM VA
        self.check_command_error(axis, f"{AXES[axis]}VA{velocity_mm_per_s:.6g}")

    def acceleration_mm_per_s2(self, axis: str) -> float:
        return self._number(axis, "AC", "?")   # SMC100 UM AC: acceleration

    def position_mm(self, axis: str) -> float:
        return self._number(axis, "TP")   # SMC100 UM TP: current (encoder) position

    def axis_settings(self, axis: str) -> dict[str, Any]:
        """What `check` reads of an axis (nothing moves): controller state in the manual's
        words, position, travel, speed, and any positioner error (SMC100 UM TS, TP, SL, SR,
        VA, AC)."""
        bits, state = self.state(axis)
        named = ("NOT REFERENCED" if state in NOT_REFERENCED else "HOMING" if state in HOMING
                 else "MOVING" if state in MOVING else "READY" if state in READY
                 else "DISABLE" if state in DISABLE else f"state {state}")
        low, high = self.travel_mm[axis]
        return {"address": AXES[axis], "state": named, "position_mm": self.position_mm(axis),
                "travel_low_mm": low, "travel_high_mm": high, "velocity_mm_per_s": self.velocity_mm_per_s(axis),
                "acceleration_mm_per_s2": self.acceleration_mm_per_s2(axis), "positioner_errors": describe_errors(bits)}

    @staticmethod
    def describe_axis(axis: str, settings: dict[str, Any]) -> str:
        """An axis's `axis_settings` as the line `check` shows."""
        errors = settings["positioner_errors"]
        return (f"{axis} (address {settings['address']}): {settings['state']}, position "
                f"{settings['position_mm']:.3f} mm, travel {settings['travel_low_mm']:g} to "
                f"{settings['travel_high_mm']:g} mm, velocity {settings['velocity_mm_per_s']:g} mm/s, "
                f"acceleration {settings['acceleration_mm_per_s2']:g} mm/s2"
                + (f"; positioner errors: {', '.join(errors)}" if errors else ""))

    # -- motion -----------------------------------------------------------------------------------
    def homed(self) -> bool:
        return all(self.state(axis)[1] in READY for axis in AXES)

    def home(self) -> None:
        """`OR` (SMC100 UM OR: execute home search) on each axis NOT REFERENCED, then wait
        for READY; an axis already READY keeps its reference."""
        for axis, address in AXES.items():
            if self.state(axis)[1] in NOT_REFERENCED:
                self.write(f"{address}OR")
                self.check_command_error(axis, f"{address}OR")
                self._wait_ready(axis, f"{address}OR")

    def check_reachable(self, x_mm: float, y_mm: float) -> None:
        """OutOfRangeError naming the point if it is outside either axis's software limits
        (SMC100 UM SL/SR); nothing is sent."""
        for axis, value in (("x", x_mm), ("y", y_mm)):
            low, high = self.travel_mm[axis]
            if not low <= value <= high:
                raise OutOfRangeError(f"{self.role} point (x = {x_mm:.3f} mm, y = {y_mm:.3f} mm)", float(value),
                                      f"{axis} within the travel {low:g} to {high:g} mm")

    def move_to_mm(self, x_mm: float, y_mm: float) -> tuple[float, float]:
        """`PA` (SMC100 UM PA: move absolute) on both axes, wait until both are READY,
        and return the encoder positions (`TP`). A point beyond travel is refused before
        anything is sent; a following error or end of run raises in the manual's words."""
        self.check_reachable(x_mm, y_mm)
        for axis, value in (("x", x_mm), ("y", y_mm)):
            message = f"{AXES[axis]}PA{value:.6g}"
            self.write(message)
            self.check_command_error(axis, message)
        for axis, value in (("x", x_mm), ("y", y_mm)):
            self._wait_ready(axis, f"{AXES[axis]}PA{value:.6g}")
        return self.position_mm("x"), self.position_mm("y")

    def stop(self) -> None:
        """`ST` (SMC100 UM ST: stop motion) on both axes; safe in any state."""
        for address in AXES.values():
            self.write(f"{address}ST")

    def park(self) -> None:
        """Stop any motion (`ST`), then, if both axes are homed, move to the park corner
        (both negative software limits), out of the laser's way; an axis not homed stays
        where it stopped, since `PA` is refused NOT REFERENCED (SMC100 UM TE, H)."""
        self.stop()
        if self.homed():
            self.move_to_mm(self.travel_mm["x"][0], self.travel_mm["y"][0])

    def _wait_ready(self, axis: str, after: str) -> None:
        deadline = time.monotonic() + self.motion_timeout_s
        while True:
            bits, state = self.state(axis)
            if bits:
                raise InstrumentError(self.role, self.resource_name,
                                      f"{axis} axis after {after!r}: " + ", ".join(describe_errors(bits)))
            if state in READY:
                return
            if state not in MOVING | HOMING:
                raise InstrumentError(self.role, self.resource_name,
                                      f"{axis} axis after {after!r}: controller state {state}, not READY")
            if time.monotonic() > deadline:
                raise InstrumentError(self.role, self.resource_name,
                                      f"{axis} axis still moving {self.motion_timeout_s:g} s after {after!r}")
            self.sleep(self.poll_interval_s)
