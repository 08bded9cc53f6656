"""The driver base: one instrument of the bench over a PyVISA message-based resource.

A driver knows its role on the bench (`generator`, `scope`, `vibrometer`) and the
resource's address so every error names both. All traffic goes through `write`,
`query` and `query_block`, which turn PyVISA's errors into the project's typed errors:
a VISA timeout becomes `InstrumentTimeout` naming the command, any other VISA failure
an `InstrumentError` with VISA's own description.
"""

from __future__ import annotations

import functools
from contextlib import contextmanager
from typing import Any, Iterator

import numpy as np
from pyvisa import constants
from pyvisa.errors import VisaIOError
from pyvisa.resources import SerialInstrument

from squeezebench.instruments.errors import (ConnectionLost, GarbledReply, InstrumentConnectionError, InstrumentError,
                                InstrumentTimeout)
from squeezebench.instruments.properties import controls_of

#: Every instrument of the bench ends its messages with LF, both ways.
TERMINATION = "\n"
#: VISA timeout of ordinary commands; long operations raise it temporarily.
DEFAULT_TIMEOUT_S = 2.0
#: What a VISA operation fails with (`Instrument._failure` types each).
_VISA_FAILURES = (VisaIOError, UnicodeDecodeError, OSError)


class Instrument:
    """Message-based traffic with typed errors; not tied to SCPI (the OFV-5000 is not).

    A driver defines `identification` and `MODEL`, what the identification must contain
    for the instrument to be the one the driver is written for.
    """

    MODEL: str = ""

    def __init__(self, resource: Any, role: str) -> None:
        self.resource = resource
        self.role = role
        self.resource_name = str(getattr(resource, "resource_name", resource))
        resource.read_termination = TERMINATION
        resource.write_termination = TERMINATION
        resource.timeout = DEFAULT_TIMEOUT_S * 1000.0

    # -- what the control descriptors use ---------------------------------------------------
    @property
    def property_prefix(self) -> str:
        return self.role

    @property
    def command_fields(self) -> dict[str, Any]:
        return {}

    # -- traffic -------------------------------------------------------------------------------
    # write and query catch inline what `_visa` translates: they carry nearly every message
    # of a campaign, a study or a plan, and a context manager per message cost more than
    # the simulated instrument's answer to a setting.
    def write(self, command: str) -> None:
        try:
            self.resource.write(command)
        except _VISA_FAILURES as exc:
            raise self._failure(exc, command) from None

    def query(self, command: str) -> str:
        try:
            return self.resource.query(command).strip()
        except _VISA_FAILURES as exc:
            raise self._failure(exc, command) from None

    def query_block(self, command: str) -> np.ndarray:
        """An IEEE 488.2 definite-length block of big-endian signed 16-bit samples.

        PyVISA parses the block header; a malformed block is a GarbledReply.
        """
        with self._visa(command):
            try:
                return self.resource.query_binary_values(command, datatype="h", is_big_endian=True,
                                                         container=np.array)
            except ValueError as exc:  # PyVISA's block parser refusing the data
                raise GarbledReply(self.role, self.resource_name, command, b"<binary block>", str(exc)) from None

    @contextmanager
    def _visa(self, operation: str) -> Iterator[None]:
        try:
            yield
        except _VISA_FAILURES as exc:
            raise self._failure(exc, operation) from None

    def _failure(self, exc: Exception, operation: str) -> InstrumentError:
        """The typed error of a VISA operation's failure."""
        if isinstance(exc, VisaIOError):
            if exc.error_code == constants.StatusCode.error_timeout:
                return InstrumentTimeout(self.role, self.resource_name, operation, self.resource.timeout / 1000.0)
            if exc.error_code == constants.StatusCode.error_connection_lost:
                return ConnectionLost(self.role, self.resource_name, operation)
            return InstrumentError(self.role, self.resource_name,
                                   f"VISA error during {operation!r}: {exc.description}")
        if isinstance(exc, UnicodeDecodeError):   # line noise instead of the instrument's text
            return GarbledReply(self.role, self.resource_name, operation, exc.object, "not ASCII text")
        # socket-based VISA backends (pyvisa-py TCPIP) lose links as an OSError
        return ConnectionLost(self.role, self.resource_name, operation, str(exc))

    def device_clear(self) -> None:
        """IEEE 488.1 device clear (viClear): the instrument drops unread replies and
        half-received input, so a session starts in step whatever the last one left."""
        try:
            self.resource.clear()
        except (NotImplementedError, VisaIOError):   # a link without device clear has nothing to drop
            pass

    @contextmanager
    def timeout(self, timeout_s: float) -> Iterator[None]:
        """Raise the VISA timeout for one long operation, then restore it."""
        previous_ms = self.resource.timeout
        self.resource.timeout = timeout_s * 1000.0
        try:
            yield
        finally:
            self.resource.timeout = previous_ms

    def parse_reply(self, command: str, reply: str, parse=float) -> Any:
        """`parse(reply)`, or GarbledReply naming the command and the reply."""
        try:
            return parse(reply)
        except ValueError as exc:
            raise GarbledReply(self.role, self.resource_name, command, reply, str(exc)) from None

    # -- common to every driver ----------------------------------------------------------------
    @property
    def identification(self) -> str:
        raise NotImplementedError

    def identify(self) -> str:
        """The identification, checked to be a `MODEL` (another instrument at the address
        is a connection error, not something to send commands to)."""
        identification = self.identification
        if not identification:
            raise InstrumentConnectionError(self.role, self.resource_name, "no answer to the identification query")
        if self.MODEL not in identification:
            raise InstrumentConnectionError(self.role, self.resource_name,
                                            f"it answers {identification!r}, which is not a {self.MODEL}")
        return identification

    def settings_snapshot(self) -> dict[str, Any]:
        """Every readable setting, queried now (provenance of a run)."""
        return {name: getattr(self, name) for name in controls_of(type(self))}


def set_serial_line(resource: Any, baud_rate: int, stop_bits: constants.StopBits,
                    flow_control: constants.ControlFlow | None = None) -> None:
    """On a serial resource (RS-232), the line settings its manual gives: 8 data bits, no
    parity, `baud_rate`, `stop_bits` (and `flow_control`); a GPIB or network resource has none."""
    if isinstance(resource, SerialInstrument):
        resource.baud_rate = baud_rate
        resource.data_bits = 8
        resource.parity = constants.Parity.none
        resource.stop_bits = stop_bits
        if flow_control is not None:
            resource.flow_control = flow_control


def concatenated(commands: list[str]) -> str:
    """Program message units in one message (IEEE 488.2 7.6.1; SCPI-1999 Vol. 1 6.2.4; the
    TDS3000 programmer manual's rules, p. 2-4): a unit whose header shares the previous
    one's branch gives only its last mnemonic; one on another branch starts again from the
    root with `:`; a common (`*`) command goes as it is and leaves the branch unchanged.
    The instrument runs them in order; the replies of the queries come back as one
    message, `;`-separated. One bus round trip instead of one per unit."""
    return _concatenated(tuple(commands))


@functools.lru_cache(maxsize=4096)
def _concatenated(commands: tuple[str, ...]) -> str:
    """`concatenated`, kept: a study or a plan sends the same messages thousands of times
    (the same measurements, transfers and acquisitions on every bench; 87 % of the study's
    41,000 are repeats), and joining them again cost more than looking them up."""
    units, branch = [], None
    for command in commands:
        if command.startswith("*"):
            units.append(command)
            continue
        header = command.split(" ", 1)[0]
        own = header.rpartition(":")[0]
        if branch is None:
            units.append(command)
        elif own == branch:
            units.append(command[len(branch) + 1:] if branch else command)
        else:
            units.append(":" + command)
        branch = own
    return ";".join(units)


class SCPIInstrument(Instrument):
    """An IEEE 488.2 instrument: `*IDN?`, `*RST`, `*CLS`."""

    def __init__(self, resource: Any, role: str) -> None:
        super().__init__(resource, role)
        # A reply a previous session left unread would answer our first query, and a
        # half-sent command would swallow it (IEEE 488.2 6.3: Query INTERRUPTED).
        self.device_clear()

    @property
    def identification(self) -> str:
        return self.query("*IDN?")  # IEEE 488.2 10.14

    def read_controls(self, *names: str) -> tuple:
        """This instrument's controls `names` read in one message (`read_together`)."""
        return self.read_together([(self, getattr(type(self), name)) for name in names])

    def read_together(self, reads: list[tuple[Any, Any]]) -> tuple:
        """Controls, each (its owner: this instrument or a part of it such as a scope's
        channel, the control), read in one message (`concatenated`), each parsed as reading
        it alone would be; for controls whose replies hold no `;`."""
        message = concatenated([control.get_command.format(**owner.command_fields) for owner, control in reads])
        reply = self.query(message)
        parts = reply.split(";")
        try:
            if len(parts) != len(reads):
                raise ValueError(f"expected {len(reads)} replies")
            return tuple(control.value_of(part) for (_, control), part in zip(reads, parts))
        except ValueError as exc:
            raise GarbledReply(self.role, self.resource_name, message, reply, str(exc)) from None

    def reset(self) -> None:
        self.write("*RST")  # IEEE 488.2 10.32

    def clear_status(self) -> None:
        """Empty the error/event queue and the status registers."""
        self.write("*CLS")  # IEEE 488.2 10.3
