"""A served instrument on a pseudo-terminal: the serial line of its manual, which VISA opens
as `ASRL/dev/pts/N::INSTR` (pyvisa-py through pyserial).

The client's end is the pty's slave: the line settings it makes there (baud rate, data
bits, parity, stop bits) are readable by the server through the same terminal, so the
port enforces the instrument's settings: bytes pass between the two ends as a UART set
to the manual's settings sends or reads them (`simbench.line.received`), and a client set
otherwise reads and sends garble, as on the real line. With `real_rate`, every byte takes
its time on the line (`LineSettings.transfer_s`); otherwise the bench clock alone counts it.
A pty has no modem lines: the 33120A's DTR/DSR handshake is not modelled.
"""

from __future__ import annotations

import array
import fcntl
import os
import select
import termios
import threading
import time
import tty

from pyvisa.errors import VisaIOError

from squeezebench.simbench.line import PARITIES, LineSettings, received
from squeezebench.simbench.serve import send

_SPEEDS = {getattr(termios, f"B{rate}"): rate for rate in
           (300, 600, 1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400) if hasattr(termios, f"B{rate}")}
_SIZES = {termios.CS5: 5, termios.CS6: 6, termios.CS7: 7, termios.CS8: 8}


def client_settings(fd: int) -> LineSettings:
    """The line settings a terminal is set to (termios(3): speed, CSIZE, PARENB/PARODD, CSTOPB)."""
    _, _, cflag, _, ispeed, _, _ = termios.tcgetattr(fd)
    parity = PARITIES[0] if not cflag & termios.PARENB else ("O" if cflag & termios.PARODD else "E")
    return LineSettings(_SPEEDS.get(ispeed, 38400), _SIZES[cflag & termios.CSIZE], parity,
                        2 if cflag & termios.CSTOPB else 1)


class PtyPort:
    """A pseudo-terminal serving `endpoint` with the line `settings` until `close`."""

    def __init__(self, endpoint, settings: LineSettings, lock, real_rate: bool = False,
                 generation=lambda: 0) -> None:
        self.endpoint, self.settings, self.real_rate = endpoint, settings, real_rate
        self._lock = lock   # the served bench's
        self._generation = generation   # the bench's opening count: a new one drops what is in flight
        self._master, self._slave = os.openpty()
        os.set_blocking(self._master, False)
        self._holding = False
        endpoint.served.register(self)
        tty.setraw(self._slave)   # no echo nor line editing before a client sets the line up
        self.device = os.ttyname(self._slave)
        self._closed = threading.Event()
        self._thread = threading.Thread(target=self._serve, name=f"serve-sim pty {self.device}", daemon=True)
        self._thread.start()

    @property
    def address(self) -> str:
        return f"ASRL{self.device}::INSTR"

    def pending(self) -> bool:
        """Whether bytes of the client wait here, unread or unanswered."""
        count = array.array("i", [0])
        try:
            fcntl.ioctl(self._master, termios.FIONREAD, count)
        except OSError:
            return self._holding
        return self._holding or count[0] > 0

    def flush(self) -> None:
        """Drop what is in flight both ways (a fresh bench: nothing of the old session
        stays, neither replies the client has not read nor messages the port has not)."""
        termios.tcflush(self._slave, termios.TCIFLUSH)   # replies on their way to the client
        termios.tcflush(self._master, termios.TCIFLUSH)  # messages on their way to the instrument
        self.endpoint.reset()

    def close(self) -> None:
        self._closed.set()
        self._thread.join(timeout=5)
        os.close(self._master)
        os.close(self._slave)

    def _serve(self) -> None:
        while not self._closed.is_set():
            ready, _, _ = select.select([self._master], [], [], 0.1)
            if not ready:
                continue
            # read under the bench's lock: a fresh bench (`flush`, under the same lock) never
            # gets a message of the session before it
            with self._lock:
                self._holding = True
                generation = self._generation()
                try:
                    data = os.read(self._master, 65536)
                except OSError:   # flushed since select, or no client has the line open
                    self._holding = False
                    time.sleep(0.01)
                    continue
            try:
                client = client_settings(self._slave)
                if self.real_rate:
                    time.sleep(client.transfer_s(len(data)))
                replies = self.endpoint(received(data, client, self.settings), generation, self)
            except VisaIOError:   # the instrument's own `disconnect` fault: silent from now on
                continue
            finally:
                self._holding = False
            stale = lambda: self._closed.is_set() or self._generation() != generation   # noqa: E731
            for message, reply in replies:
                delivery = self.endpoint.delivery(message, reply)
                client = client_settings(self._slave)
                for piece in delivery.pieces:
                    piece.data = received(piece.data, self.settings, client)
                send(delivery, lambda part: os.write(self._master, part), stale, self.settings if self.real_rate else None)
                if delivery.cut:   # the line goes dead for the rest of this reply
                    break
