"""Faults of a bad day on the bench (issue 7): a clipped trace, and the instruments'
bus faults (timeouts, garbled or truncated replies, error-queue entries, a disconnect).
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from squeezebench.simbench.effect_base import AcquisitionContext, Effect

class ClippedTrace(Effect):
    """A burst on CH2 (a switching spike, a probe knocked) far beyond the screen in the
    `count` acquisitions from the `at_acquisition`-th one of the bench: the record
    clips, the driver raises ClippedTraceError and the protocol must re-range."""

    name = "clipped_trace"
    defaults = {"at_acquisition": 5.0, "count": 1.0, "height_div": 20.0}
    limits = {"at_acquisition": (1.0, math.inf), "count": (1.0, math.inf), "height_div": (6.0, math.inf)}
    stages = frozenset({"signals"})
    varies_per_acquisition = True
    reads_vertical_scale = True   # its spike is a height in divisions
    fault = True

    def __init__(self, scene, **parameters: float) -> None:
        super().__init__(scene, **parameters)
        self.acquisitions = 0

    def signals(self, signals: np.ndarray, ctx: AcquisitionContext) -> np.ndarray:
        self.acquisitions += 1
        first = self.parameters["at_acquisition"]
        if not first <= self.acquisitions < first + self.parameters["count"]:
            return signals
        signals = signals.copy()
        burst = slice(signals.shape[1] // 2, signals.shape[1] // 2 + max(1, signals.shape[1] // 50))
        height = self.parameters["height_div"] * ctx.scale_per_div[1] / ctx.display_gain[1]
        signals[1, burst] += height
        return signals


class TruncatedPayload(bytearray):
    """The part of a reply that arrived; its end never does."""


class BusFault(Effect):
    """A fault of one instrument or its link, from the `at_message`-th message the bench's
    instruments receive (every command and query of all three, counted from when the
    bench opens), on `instrument` (1 generator, 2 scope, 3 vibrometer; 0 any of them),
    for `count` messages. A reply fault hits the first `count` queries from there.

    A simulated instrument calls `act` before it handles a message the fault hits, and
    passes the reply (with its terminator) through `reply`.
    """

    defaults = {"at_message": 200.0, "instrument": 0.0, "count": 1.0}
    limits = {"at_message": (1.0, math.inf), "instrument": (0.0, 3.0), "count": (1.0, math.inf)}
    stages = frozenset({"bus"})
    fault = True
    ROLES = (None, "generator", "scope", "vibrometer")
    needs_reply: ClassVar[bool] = True

    def __init__(self, scene, **parameters: float) -> None:
        super().__init__(scene, **parameters)
        self.role = self.ROLES[int(self.parameters["instrument"])]
        self.remaining = int(self.parameters["count"])

    def hits(self, role: str, message_number: int, is_query: bool) -> bool:
        """Whether this message is faulted (and one fault fewer remains)."""
        if (self.remaining <= 0 or message_number < self.parameters["at_message"]
                or (self.role is not None and role != self.role) or (self.needs_reply and not is_query)):
            return False
        self.remaining -= 1
        return True

    def act(self, instrument) -> None:
        """What the fault does to the instrument before it handles the message."""

    def reply(self, payload: bytearray, eom: bytes) -> bytearray | None:
        """The reply as it reaches the bus (None: nothing arrives)."""
        return payload


class BusTimeout(BusFault):
    """The instrument never answers the query: the read waits out its VISA timeout."""

    name = "bus_timeout"

    def reply(self, payload: bytearray, eom: bytes) -> None:
        return None


class GarbledReplyFault(BusFault):
    """The reply arrives as line noise (bytes that are not the instrument's text)."""

    name = "garbled_reply"

    def reply(self, payload: bytearray, eom: bytes) -> bytearray:
        return bytearray(b"\xff\xfe\x1b#@!" + eom)


class TruncatedReplyFault(BusFault):
    """Only the first half of the reply arrives, without its end: the read times out."""

    name = "truncated_reply"

    def reply(self, payload: bytearray, eom: bytes) -> TruncatedPayload:
        return TruncatedPayload(payload[:max(1, (len(payload) - len(eom)) // 2)])


class InstrumentErrorEntry(BusFault):
    """The instrument queues an error (SYST:ERR? / *ESR? + EVMSG?) as it handles the
    message, as a real one does for a setting it cannot apply. The vibrometer keeps no
    error queue: on it the fault does nothing."""

    name = "instrument_error"
    needs_reply = False

    def act(self, instrument) -> None:
        instrument.inject_error()


class Disconnect(BusFault):
    """The instrument drops off the bus (cable, power, network) for good: from the
    `at_message`-th message on every write and read to it fails (`count` is unused)."""

    name = "disconnect"
    needs_reply = False

    def hits(self, role: str, message_number: int, is_query: bool) -> bool:
        return (message_number >= self.parameters["at_message"]
                and (self.role is None or role == self.role))

    def act(self, instrument) -> None:
        instrument.disconnected = True

