"""A served instrument on a TCP port of the loopback: a raw SCPI socket, as the TDS 3054B's
Ethernet module (TDS3EM) offers one and VISA opens as `TCPIP::HOST::PORT::SOCKET`.

One client at a time, as the instrument's socket server takes; a client that goes away
(or a `connection_reset` fault) frees the port for the next one.
"""

from __future__ import annotations

import array
import fcntl
import select
import socket
import struct
import termios
import threading

from pyvisa.errors import VisaIOError

from squeezebench.simbench.serve import LOOPBACK, send


_QUICKACK = getattr(socket, "TCP_QUICKACK", 12)


def _unread(connection: socket.socket) -> int:
    """Bytes received and not read yet (tcp(7) SIOCINQ, the same request as FIONREAD)."""
    count = array.array("i", [0])
    try:
        fcntl.ioctl(connection.fileno(), termios.FIONREAD, count)
    except OSError:
        return 0
    return count[0]


class TcpPort:
    """Listens on `host`:`port` (0: a free one) and serves `endpoint` until `close`."""

    def __init__(self, endpoint, host: str = "127.0.0.1", port: int = 0) -> None:
        if host not in LOOPBACK:
            raise ValueError(f"serve-sim listens on the loopback only ({', '.join(LOOPBACK)}), not {host!r}")
        self.endpoint = endpoint
        self._listener = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM)
        self._listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._listener.bind((host, port))
        self._listener.listen(1)
        self._listener.settimeout(0.1)
        self.host, self.port = host, self._listener.getsockname()[1]
        self._closed = threading.Event()
        self._holding, self._connection = False, None
        endpoint.served.register(self)
        self._thread = threading.Thread(target=self._serve, name=f"serve-sim tcp {self.port}", daemon=True)
        self._thread.start()

    @property
    def address(self) -> str:
        return f"TCPIP::{self.host}::{self.port}::SOCKET"

    def close(self) -> None:
        self._closed.set()
        self._thread.join(timeout=5)
        self._listener.close()

    def _serve(self) -> None:
        while not self._closed.is_set():
            try:
                connection, _ = self._listener.accept()
            except (socket.timeout, OSError):
                continue
            with connection:
                self._talk(connection, self.endpoint.generation())

    def pending(self) -> bool:
        """Whether bytes of the client wait here, unread or unanswered."""
        connection = self._connection
        return self._holding or (connection is not None and connection.fileno() >= 0 and _unread(connection) > 0)

    def _talk(self, connection: socket.socket, generation: int) -> None:
        """One client's session; once a fresh bench opens, what this one still sends is dropped."""
        connection.settimeout(0.1)
        connection.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        def stale() -> bool:
            return self._closed.is_set() or self.endpoint.generation() != generation
        self._connection = connection
        while not stale():
            if not select.select([connection], [], [], 0.1)[0]:
                continue
            self._holding = True
            try:
                data = connection.recv(65536)
                # ACK at once: a client writing two messages in a row (Nagle) would otherwise
                # wait out the delayed ACK, some 40 ms a message (Linux tcp(7), TCP_QUICKACK)
                connection.setsockopt(socket.IPPROTO_TCP, _QUICKACK, 1)
                if not data:
                    return
                replies = self.endpoint(data, generation, self)
            except (OSError, VisaIOError):   # gone, or the instrument's own `disconnect` fault
                return
            finally:
                self._holding = False
            for message, reply in replies:
                delivery = self.endpoint.delivery(message, reply)
                try:
                    send(delivery, connection.sendall, stale)
                except OSError:
                    return
                if delivery.cut:   # RST, not FIN: the peer's next read fails at once
                    connection.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
                    return
