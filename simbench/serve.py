"""`squeezebench serve-sim`: the simulated bench's instruments on this machine's real transports.

The scope (Ethernet on the real bench, TDS3EM) answers on a TCP port as a raw SCPI socket
(`TCPIP::127.0.0.1::PORT::SOCKET`); the generator, the vibrometer and the stage (RS-232
in their manuals; the 33120A's GPIB cannot be served) each on a pseudo-terminal
(`ASRL/dev/pts/N::INSTR`) with their manual's line settings (`simbench.line`). A real
VISA library (pyvisa-py, `@py`) talks to them as to the instruments.

The physics and the bench clock are the simulated bench's: every message costs the bench
time of the bus the in-process bench models, however fast the loopback is, so a run over
the served bench has the rows of the same run in-process. A reply is read from the
simulated instrument in the in-process session's pieces (PyVISA's 20 kB chunk) as soon as
it is ready, and the virtual clock lets a deferred reply (`*OPC?`) be ready at once. Not
modelled: a query the instrument refuses makes the client wait its VISA timeout in wall
time, which the served bench clock does not count (in-process it does). What
the bench does outside the instruments (its clock, the operator's plate changes) goes
through one more TCP port, the bench port (`bench_command`'s line protocol), which
`instruments.served` opens a served bench with. The transports are `serve_tcp` and
`serve_pty`; `serve_sim` puts them together. Every port binds to loopback only.
"""

from __future__ import annotations

import dataclasses
import math
import random
import threading
import time
import uuid
from pathlib import Path
from typing import Callable, Iterator

import pyvisa
from pyvisa import constants

from squeezebench.simbench import line
from squeezebench.simbench.scene import load_scene
from squeezebench.simbench.scene_model import SceneError
from squeezebench.simbench.transport_faults import TransportFault
from squeezebench.yamlfiles import read_yaml

#: Where serve-sim may listen: this machine only.
LOOPBACK = ("127.0.0.1", "::1")
#: PyVISA's default read chunk (`Resource.chunk_size`): the in-process session's reads.
VISA_CHUNK_BYTES = 20 * 1024
#: Which transport serves each role.
NETWORK_ROLES = ("scope",)
SERIAL_ROLES = ("generator", "vibrometer", "stage")
LINE_RATES = ("model", "real")


@dataclasses.dataclass
class Piece:
    """Bytes to send, then how long to pause before the next piece."""

    data: bytes
    pause_s: float = 0.0


@dataclasses.dataclass
class Delivery:
    """How one reply leaves: its pieces, and whether the link is cut after them."""

    pieces: list[Piece]
    cut: bool = False


class ServedBench:
    """The simulated bench behind the served ports: one lock, a fresh bench on `open`."""

    def __init__(self, scene_path: str | Path, on_event: Callable[[str], None] = lambda text: None,
                 computing_allowance_s: float = 0.0) -> None:
        self.scene_path = Path(scene_path).resolve()
        scene = load_scene(self.scene_path)
        # once per serve-sim: the faults' counters are this server's, not the scene cache's
        self.faults = tuple(dataclasses.replace(f) for f in scene.transport_faults)
        self.lock = threading.RLock()
        self.generation = 0   # how many times the bench was opened; a delivery of an older one stops
        self._resource_manager: pyvisa.ResourceManager | None = None
        self.on_event = on_event   # told when a transport fault fires (serve-sim's log)
        self.computing_allowance_s = computing_allowance_s   # added to the clients' VISA timeouts
        self.on_open: list[Callable[[], None]] = []   # told when a fresh bench opens (the ptys drop old bytes)
        self._ports: list = []
        self._settling: set = set()
        self.open()

    def register(self, port) -> None:
        """A port (with `pending()`: it holds bytes it has not answered) for `settle` to wait on."""
        self._ports.append(port)

    def settle(self, port, limit_s: float = 5.0) -> None:
        """Wait until every port but `port` has handled what it received. The client is
        one program: what it waits on (a query, a bench command) is the last thing it sent,
        and what it wrote elsewhere before (a new frequency) must reach the bench first, as
        in-process, or bench time and the physics would depend on thread scheduling. Nothing
        pending twice 0.1 ms apart: a pty's bytes reach its master through a kernel worker.
        `limit_s` only bounds a wait on a second client, which breaks the order anyway."""
        end, quiet = time.monotonic() + limit_s, 0
        self._settling.add(port)   # a port waiting here holds nothing the others must wait for
        try:
            while quiet < 2 and time.monotonic() < end:
                busy = any(other.pending() for other in self._ports if other is not port and other not in self._settling)
                quiet = 0 if busy else quiet + 1
                time.sleep(1e-4)
        finally:
            self._settling.discard(port)

    def open(self) -> None:
        """A fresh simulated bench from the scene, as each in-process `open_bench` builds."""
        with self.lock:
            self.close()
            self._resource_manager = pyvisa.ResourceManager(f"{self.scene_path}#{uuid.uuid4().hex}@simbench")
            self.bench = self._resource_manager.visalib.bench
            self.mounted = self.scene_path
            self.generation += 1
            for listener in self.on_open:
                listener()

    def close(self) -> None:
        with self.lock:
            if self._resource_manager is not None:
                self._resource_manager.close()
                self._resource_manager = None

    def mount(self, scene_path: str) -> None:
        """The operator puts a plate on: the plate already mounted stays (and keeps its
        state); a scene that differs from it only by its transport faults is that plate."""
        path = Path(scene_path).resolve()
        with self.lock:
            if path != self.mounted and _plate_of(path) != _plate_of(self.mounted):
                self.bench.mount(path)
            self.mounted = path

    # -- one instrument ----------------------------------------------------------------------
    def exchange(self, role: str, data: bytes) -> list[bytes]:
        """`data` written to the instrument; the replies it then has, each whole."""
        with self.lock:
            device = getattr(self.bench, role)
            device.write(data)   # a `disconnect` bus fault raises VisaIOError: the port closes
            return list(_drain(device))

    def delivery(self, role: str, message: bytes, reply: bytes) -> Delivery:
        """How `reply` (to `message`) leaves, after the transport faults that hit it."""
        for fault in self.faults:
            if fault.hits(role, message):
                if fault.fault != "chunked_reply":
                    self.on_event(f"transport fault {fault.describe()}: fired")
                return _faulty(fault, reply)
        return Delivery([Piece(reply)])


def _plate_of(scene_path: Path) -> dict:
    """A scene file's content but its transport faults."""
    data = read_yaml(scene_path)
    return {key: value for key, value in data.items() if key != "transport_faults"} if isinstance(data, dict) else data


def _drain(device) -> Iterator[bytes]:
    """Each reply the instrument has queued, read as the in-process VISA session reads it
    (chunks of `VISA_CHUNK_BYTES`, each costing its bus time). The queue is the simulated
    instrument's own (`SimulatedInstrument._replies`): reading with nothing queued would
    cost a timeout the client has not waited."""
    while device._replies:
        reply = bytearray()
        while True:
            chunk, status = device.read(VISA_CHUNK_BYTES, math.inf)
            reply += chunk
            if status != constants.StatusCode.success_max_count_read or not device._replies:
                break
        yield bytes(reply)


def _faulty(fault: TransportFault, reply: bytes) -> Delivery:
    """How `reply` leaves under `fault` (`simbench.transport_faults` says what each does)."""
    if fault.fault == "chunked_reply":
        rng = random.Random(int(fault.parameter("seed")) * 1_000_003 + fault.seen)
        pieces, start = [], 0
        while start < len(reply):
            size = rng.randint(1, int(fault.parameter("max_chunk_bytes")))
            pieces.append(Piece(reply[start:start + size], rng.uniform(0.0, fault.parameter("max_pause_s"))))
            start += size
        return Delivery(pieces)
    if fault.fault == "slow_trickle":
        return Delivery([Piece(reply[i:i + 1], 1.0 / fault.parameter("bytes_per_s")) for i in range(len(reply))])
    if fault.fault == "missing_termination":
        return Delivery([Piece(reply.rstrip(b"\n"))])
    if fault.fault == "connection_reset":
        return Delivery([Piece(reply[:len(reply) // 2])], cut=True)
    # framing_error: a burst on the line during the reply, read as by a receiver set to one
    # stop bit more than was sent; it is over before the terminating LF
    sent = line.LineSettings(9600, 8, "N", 1)
    burst = line.received(reply[:-1], sent, dataclasses.replace(sent, stop_bits=2))
    return Delivery([Piece(burst + reply[-1:])])


class InstrumentEndpoint:
    """What a port of one instrument does with the bytes it receives: the instrument's
    replies, each with the message it answers (what a transport fault matches)."""

    def __init__(self, served: ServedBench, role: str) -> None:
        self.served, self.role = served, role
        self._partial = bytearray()

    def generation(self) -> int:
        return self.served.generation

    def __call__(self, data: bytes, generation: int | None = None, port=None) -> list[tuple[bytes, bytes]]:
        """Each whole message in `data` written on its own, as the client's VISA session
        wrote it (a stream may bring several at once): each costs its own bus time. A query
        waits for what the client wrote elsewhere before it (`ServedBench.settle`). Data
        of a session older than the bench (`generation`) is dropped."""
        self._partial += data
        replies = []
        while b"\n" in self._partial:
            end = self._partial.index(b"\n") + 1
            message = bytes(self._partial[:end])
            del self._partial[:end]
            if getattr(self.served.bench, self.role).is_query(message.rstrip(b"\r\n")):
                self.served.settle(port)
            with self.served.lock:
                if generation is not None and generation != self.served.generation:
                    return []
                replies += [(message, reply) for reply in self.served.exchange(self.role, message)]
        return replies

    def reset(self) -> None:
        """Forget a half-received message (a fresh bench)."""
        self._partial.clear()

    def delivery(self, message: bytes, reply: bytes) -> Delivery:
        return self.served.delivery(self.role, message, reply)


class BenchEndpoint:
    """The bench port's side of `bench_command`: whole lines in, one reply line each."""

    def __init__(self, served: ServedBench) -> None:
        self.served = served
        self._partial = bytearray()

    def reset(self) -> None:
        self._partial.clear()

    def generation(self) -> int:
        return -1   # the bench port serves every session, the fresh bench's too

    def __call__(self, data: bytes, generation: int | None = None, port=None) -> list[tuple[bytes, bytes]]:
        self._partial += data
        replies = []
        while b"\n" in self._partial:
            end = self._partial.index(b"\n")
            message = bytes(self._partial[:end]).rstrip(b"\r")
            del self._partial[:end + 1]
            self.served.settle(port)   # every bench command is waited on: the client's last message
            replies.append((message, bench_command(self.served, message) + b"\n"))
        return replies

    @staticmethod
    def delivery(message: bytes, reply: bytes) -> Delivery:
        return Delivery([Piece(reply)])


def send(delivery: Delivery, write: Callable[[bytes], object], stale: Callable[[], bool],
         line_settings: line.LineSettings | None = None) -> None:
    """Write a delivery's pieces; given `line_settings` (a serial line at its real rate),
    each in parts of about 10 ms, each part taking its time on the line. Stops as soon as
    `stale()` (the client has gone, or a fresh bench opened): a pause waits in short steps
    so a trickle never holds up the next session."""
    for piece in delivery.pieces:
        data = piece.data
        step = max(1, line_settings.baud // (line_settings.frame_bits * 100)) if line_settings else max(1, len(data))
        for start in range(0, len(data), step):
            if stale():
                return
            part = data[start:start + step]
            write(part)
            if line_settings and not _wait(line_settings.transfer_s(len(part)), stale):
                return
        if piece.pause_s and not _wait(piece.pause_s, stale):
            return


def _wait(duration_s: float, stale: Callable[[], bool]) -> bool:
    """Sleep `duration_s` in steps of at most 10 ms; False as soon as `stale()`."""
    end = time.monotonic() + duration_s
    while (left := end - time.monotonic()) > 0:
        if stale():
            return False
        time.sleep(min(left, 0.01))
    return True


# -- the bench port ---------------------------------------------------------------------------
def bench_command(served: ServedBench, message: bytes) -> bytes:
    """One line of the bench port's protocol, answered with one line:
    `OPEN` (a fresh bench) -> `OK`; `ALLOWANCE?` -> seconds a client adds to its VISA
    timeouts for the simulator's computing; `TIME?` -> the bench clock in integer nanoseconds;
    `SLEEP <s>` -> `OK` once the bench time has passed; `STATE <name>`, `MOUNT <path>` (the
    operator's plate changes) -> `OK` or `ERR <why>`; `*IDN?` -> who answers."""
    text = message.decode("ascii", "replace").strip()
    verb, _, argument = text.partition(" ")
    try:
        with served.lock:
            if verb == "*IDN?":
                return b"squeezebench,serve-sim bench port,0,1"
            if verb == "ALLOWANCE?":
                return repr(float(served.computing_allowance_s)).encode()
            if verb == "OPEN":
                served.open()
            elif verb == "TIME?":
                return str(round(served.bench.clock.now_s() * 1e9)).encode()
            elif verb == "SLEEP":
                served.bench.clock.sleep(float(argument))
            elif verb == "STATE":
                served.bench.set_state(argument)
            elif verb == "MOUNT":
                served.mount(argument)
            else:
                return f"ERR unknown bench port command {verb!r}".encode()
        return b"OK"
    except (SceneError, ValueError, OSError) as exc:
        return f"ERR {exc}".encode()
