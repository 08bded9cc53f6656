"""The simulated bench's clock: bench time advances only by modelled durations.

Every instrument operation costs the time it would take on the real bench (bus latency
and transfer, acquisitions, generator settling) and protocol waits (`sleep`) add theirs,
so a dry run reports the bench time a real run would need without waiting for it.
Effects that evolve with time (plate heating) subscribe to the advances.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable


@dataclass(frozen=True)
class BusTiming:
    """Cost of one message on an instrument bus: fixed latency plus bytes / rate."""

    latency_s: float
    bytes_per_s: float

    def message_s(self, n_bytes: int) -> float:
        return self.latency_s + n_bytes / self.bytes_per_s


#: Assumed figures (no datasheet numbers survive for this bench): GPIB handshakes about a
#: millisecond per message and moves roughly 200 kB/s with the TDS3000 GPIB module; the
#: TDS3000B 10BASE-T port is slower per byte than its wire because the scope formats
#: records itself; the OFV-5000 RS-232 link runs at 115200 baud 8N1 (10 bits per byte)
#: and its controller takes a few milliseconds to answer.
BUS_TIMINGS = {
    "gpib": BusTiming(latency_s=1e-3, bytes_per_s=200e3),
    "tcpip": BusTiming(latency_s=1e-3, bytes_per_s=300e3),
    "asrl": BusTiming(latency_s=3e-3, bytes_per_s=115200 / 10),
}


class VirtualClock:
    """Bench time since the bench was opened, kept in whole nanoseconds.

    Integer nanoseconds make a step's duration independent of where the clock stood when
    the step began (float sums are not), so a resumed campaign times its steps exactly as
    an uninterrupted one.
    """

    def __init__(self) -> None:
        self._now_ns = 0
        self._listeners: list[Callable[[float, float], None]] = []

    def now_s(self) -> float:
        return self._now_ns / 1e9

    def advance(self, duration_s: float) -> None:
        """Let `duration_s` of bench time pass; listeners see (start_s, duration_s)."""
        if duration_s < 0:
            raise ValueError(f"the bench clock cannot go back ({duration_s!r} s)")
        duration_ns = round(duration_s * 1e9)
        start_s = self._now_ns / 1e9   # now_s(), inline: every message advances the clock twice
        self._now_ns += duration_ns
        for listener in self._listeners:
            listener(start_s, duration_ns / 1e9)

    def advance_to(self, time_s: float) -> None:
        if time_s > self.now_s():
            self.advance(time_s - self.now_s())

    def sleep(self, seconds: float) -> None:
        """A protocol's settling wait: costs bench time, no wall time."""
        self.advance(max(0.0, float(seconds)))

    def subscribe(self, listener: Callable[[float, float], None]) -> None:
        self._listeners.append(listener)

    def unsubscribe(self, listener: Callable[[float, float], None]) -> None:
        self._listeners.remove(listener)
