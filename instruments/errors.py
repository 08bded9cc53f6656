"""Typed errors of the instrument layer.

Everything an instrument or the bench can do wrong is a `UserError` (the command line
prints it as one clear message): a bench that does not answer, an instrument reporting
an error, a reply that makes no sense, a clipped trace. `OutOfRangeError` is the
exception: it is a `ValueError` raised by the driver itself, before anything is sent,
when a caller asks for a setting the instrument does not have.
"""

from __future__ import annotations

from squeezebench.errors import UserError


class InstrumentError(UserError):
    """An instrument reported an error, or did something a driver cannot accept.

    `code` and `message` are the instrument's own (e.g. the 33120A's
    `-222,"Data out of range"`); `code` is None when the instrument has no code for it.
    """

    def __init__(self, role: str, resource: str, message: str, code: int | None = None):
        self.role = role
        self.resource = resource
        self.code = code
        self.message = message
        where = f"{role} ({resource})"
        super().__init__(f"{where}: error {code}: {message}" if code is not None else f"{where}: {message}")


class InstrumentTimeout(InstrumentError):
    """No answer within the VISA timeout; `operation` says what was waited for."""

    def __init__(self, role: str, resource: str, operation: str, timeout_s: float):
        self.operation = operation
        self.timeout_s = timeout_s
        super().__init__(role, resource, f"no answer to {operation} within {timeout_s:g} s")


class GarbledReply(InstrumentError):
    """A reply that cannot be what the command asks for."""

    def __init__(self, role: str, resource: str, command: str, reply: str | bytes, why: str = ""):
        self.command = command
        self.reply = reply
        shown = reply if len(reply) <= 200 else reply[:200] + (b"..." if isinstance(reply, bytes) else "...")
        super().__init__(role, resource,
                         f"unexpected reply {shown!r} to {command!r}" + (f" ({why})" if why else ""))


class NoValidMeasurement(InstrumentError):
    """The scope had no value for a measurement (it answers 9.9E37), e.g. a frequency on a
    flat trace or a measurement of a source that is not displayed."""


class ClippedTraceError(InstrumentError):
    """A trace reaches the ADC limits: the vertical scale is too fine.

    `source` is the scope's name (`CH1`, `MATH`), `channel` its number (None for MATH).
    `clipped_fraction` is the fraction of a fetched record's samples at the limits, or
    None when the scope itself refused a measurement for clipping (`reason` is its event).
    """

    def __init__(self, role: str, resource: str, source: str, clipped_fraction: float | None, reason: str = ""):
        self.source = source
        self.channel = int(source[2:]) if source.startswith("CH") else None
        self.clipped_fraction = clipped_fraction
        how = (f"{100 * clipped_fraction:.3g} % of its samples are at the ADC limits" if clipped_fraction is not None
               else f"the scope reports {reason}")
        super().__init__(role, resource, f"{source} trace clipped: {how} (use a coarser vertical scale)")


class BenchMismatch(InstrumentError):
    """The hardware says otherwise than the bench description (e.g. a detected probe's gain)."""


class InstrumentConnectionError(InstrumentError):
    """A role of the bench that does not answer at its address, or answers as another instrument."""

    def __init__(self, role: str, resource: str, reason: str):
        self.reason = reason
        super().__init__(role, resource, f"cannot connect: {reason}")


class ConnectionLost(InstrumentError):
    """An instrument that answered before stopped answering for good (cable, power, network)."""

    def __init__(self, role: str, resource: str, operation: str, detail: str = ""):
        self.operation = operation
        super().__init__(role, resource, f"connection lost during {operation!r}" + (f": {detail}" if detail else ""))


class OutOfRangeError(ValueError):
    """A setting outside what the instrument allows; nothing was sent."""

    def __init__(self, property_name: str, value: object, allowed: str):
        self.property_name = property_name
        self.value = value
        self.allowed = allowed
        super().__init__(f"{property_name}: {value!r} is not allowed (allowed: {allowed}); nothing was sent")


class BenchFileError(UserError):
    """A bench description file that cannot be used, naming the file, field and allowed values."""

    def __init__(self, path: object, field: str, problem: str):
        self.path = path
        self.field = field
        self.problem = problem
        super().__init__(f"{path}: {field}: {problem}")


class OperatorUnavailable(UserError):
    """A step needs the person at the bench, and there is no terminal to ask (standard input
    closed or at its end, as under a scheduler or with `< /dev/null`)."""

    def __init__(self, instruction: str, state: str | None = None):
        self.instruction = instruction
        self.state = state
        super().__init__(f"this step needs the operator ({instruction}) and there is no terminal to confirm it on "
                         "(standard input is closed); the drive was set to its minimum and the steps done so far "
                         "are stored: do it, then run the same command with --resume from a terminal, or "
                         "with --resume --operator-done where there is none")
