"""What the simulated instruments share: message transport, bench time and bus faults.

Each instrument parses what it receives with its manual's grammar (`simbench.scpi` for
the two IEEE 488.2 instruments, through `simbench.scpi_device`; the controller's line
protocol for the OFV-5000, `simbench.vibrometer`), keeps its settings in a state that
starts as the manual's power-on state, and reports what it refuses the way its manual
says: the 33120A in its SCPI error queue (`SYST:ERR?`), the TDS 3054B in its Standard
Event Status Register and event queue (`*ESR?`, `EVMsg?`, `ALLEv?`), the OFV-5000 with an
`Error` line. A refused query returns nothing: the reader waits out its VISA timeout, as
on the real bus.

The simulator never looks at which driver talks to it. What it adds beyond the manuals:
bench time for every message (bus latency and transfer), for what the instrument does
(generator settling, scope acquisitions), the bus faults a scene names, and the physics
(the generator drives the plate, the scope acquires its signals, the vibrometer's
decoder range scales CH3).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import ClassVar

from pyvisa import constants, errors

from squeezebench.simbench.clock import BusTiming
from squeezebench.simbench.fault_effects import TruncatedPayload

EOM = b"\n"


@dataclass
class Deferred:
    """A reply the instrument gives only once it has finished (e.g. `*OPC?`)."""

    ready_s: float
    payload: bytes


class SimulatedInstrument:
    """Message transport, bench time and faults common to the three instruments."""

    role: ClassVar[str]

    def __init__(self, bench, bus: BusTiming, options: dict[str, str]) -> None:
        self.bench = bench
        self.bus = bus
        self.options = options
        self._input = bytearray()
        self._replies: deque = deque()
        self.disconnected = False   # set by the `disconnect` fault, for good
        self.power_on()

    def power_on(self) -> None:
        """The state the manual gives for power-on."""
        raise NotImplementedError

    def handle(self, message: bytes) -> list:
        """Replies (bytes or Deferred, without terminator) to one received message."""
        raise NotImplementedError

    def inject_error(self) -> None:
        """The `instrument_error` fault: an error the instrument reports on its own."""

    def is_query(self, message: bytes) -> bool:
        return message.rstrip().endswith(b"?")

    # -- what the VISA library calls ------------------------------------------------------
    def write(self, data: bytes) -> None:
        self.bench.clock.advance(self.bus.message_s(len(data)))
        if not self._input and data.find(EOM) == len(data) - 1 >= 0:   # one whole message, the usual case
            self._receive(bytes(data[:-1]).rstrip(b"\r"))
            return
        self._input += data
        while EOM in self._input:
            end = self._input.index(EOM)
            message = bytes(self._input[:end]).rstrip(b"\r")
            del self._input[:end + 1]
            self._receive(message)

    def _receive(self, message: bytes) -> None:
        faults = self._faults(message) if self.bench.effects.bus else ()
        for reply in self.handle(message):
            if isinstance(reply, Deferred):
                reply.payload += EOM
            else:
                reply = bytearray(reply + EOM)
            for fault in faults:
                reply = self._faulty_reply(fault, reply)
                if reply is None:   # lost: later faults have nothing to act on
                    break
            else:
                self._replies.append(reply)

    def _faults(self, message: bytes) -> list:
        """The bus faults hitting this message, after they acted; a disconnect fails it."""
        bench = self.bench
        bench.messages_received += 1
        faults = [f for f in bench.effects.bus if f.hits(self.role, bench.messages_received, self.is_query(message))]
        for fault in faults:
            fault.act(self)
        if self.disconnected:
            raise errors.VisaIOError(constants.VI_ERROR_CONN_LOST)
        return faults

    @staticmethod
    def _faulty_reply(fault, reply):
        if isinstance(reply, Deferred):
            payload = fault.reply(reply.payload, EOM)
            if payload is None:
                return None
            reply.payload = payload
            return reply
        return fault.reply(reply, EOM)

    def read(self, count: int, timeout_s: float) -> tuple[bytes, constants.StatusCode]:
        clock = self.bench.clock
        if self.disconnected:
            raise errors.VisaIOError(constants.VI_ERROR_CONN_LOST)
        if not self._replies:
            self._time_out(timeout_s)
        head = self._replies[0]
        if isinstance(head, Deferred):
            if head.ready_s - clock.now_s() > timeout_s:
                self._time_out(timeout_s)
            clock.advance_to(head.ready_s)
            payload = head.payload
            head = self._replies[0] = payload if isinstance(payload, TruncatedPayload) else bytearray(payload)
        chunk = bytes(head[:count])
        del head[:count]
        clock.advance(self.bus.message_s(len(chunk)))
        if head:
            return chunk, constants.StatusCode.success_max_count_read
        self._replies.popleft()
        if isinstance(head, TruncatedPayload):   # no END: the reader asks for the rest, which never comes
            return chunk, constants.StatusCode.success_max_count_read
        return chunk, constants.StatusCode.success

    def _time_out(self, timeout_s: float) -> None:
        """Nothing to read: the session waits its whole timeout (bench time, not wall)."""
        self.read_without_reply()
        self.bench.clock.advance(timeout_s)
        raise errors.VisaIOError(constants.VI_ERROR_TMO)

    def read_without_reply(self) -> None:
        """Hook: the controller tried to read with nothing in the output queue."""

    def clear(self) -> None:
        """Device clear (IEEE 488.1 DCL/SDC): drop pending input and replies."""
        self._input.clear()
        self._replies.clear()
