"""Declarative instrument settings, in the manner of PyMeasure's `Instrument.control`.

A driver states each setting once, with the exact command strings it sends:

    frequency_hz = control("FREQ?", "FREQ {:.9g}", "Output frequency (Hz).",
                           validator=strict_range(100e-6, 15e6, "Hz"))

Reading the attribute sends the query and parses the reply; assigning checks the value
against the validator first and raises `OutOfRangeError` (naming the property and what is
allowed) before anything is sent. A validator may depend on the instrument's present
state (the 33120A's amplitude limits depend on its output load): pass a function of the
instrument that returns the validator.

Command strings may contain named fields filled from the owner's `command_fields`
(e.g. `"CH{ch}:SCA?"` on a scope channel). `values` maps Python values to the
instrument's tokens; on reading, a reply matches a token or its SCPI long form (the
TDS answers `SAMPLE` to what was set as `SAM`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Iterable

from squeezebench.instruments.errors import GarbledReply, InstrumentError, OutOfRangeError


@dataclass(frozen=True)
class Validator:
    """Checks a value and returns it in canonical form, or raises ValueError.

    `allowed` says what is allowed, for the OutOfRangeError message.
    """

    check: Callable[[Any], Any]
    allowed: str

    def __call__(self, value: Any) -> Any:
        return self.check(value)


def _number(value: Any) -> float:
    if isinstance(value, bool):
        raise ValueError("a boolean is not a number")
    number = float(value)
    if not math.isfinite(number):
        raise ValueError("not a finite number")
    return number


def strict_range(low: float, high: float, unit: str = "") -> Validator:
    """A number in [low, high]."""

    def check(value: Any) -> float:
        number = _number(value)
        if not low <= number <= high:
            raise ValueError("out of range")
        return number

    return Validator(check, f"{low:g} to {high:g}{' ' + unit if unit else ''}")


def strict_integer_range(low: int, high: int, unit: str = "") -> Validator:
    """An integer in [low, high] (16.0 is accepted as 16)."""

    def check(value: Any) -> int:
        number = _number(value)
        if number != int(number) or not low <= number <= high:
            raise ValueError("out of range")
        return int(number)

    return Validator(check, f"integers {low} to {high}{' ' + unit if unit else ''}")


def strict_discrete_set(values: Iterable[Any], unit: str = "") -> Validator:
    """One of `values` (numbers compare by value: 16.0 is accepted as 16)."""
    allowed = tuple(values)

    def check(value: Any) -> Any:
        for candidate in allowed:
            if value == candidate and type(value) is not bool:
                return candidate
        raise ValueError("not one of the allowed values")

    shown = ", ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in allowed)
    return Validator(check, f"{shown}{' ' + unit if unit else ''}")


def strict_boolean() -> Validator:
    """True or False (a switch such as a displayed waveform)."""

    def check(value: Any) -> bool:
        if not isinstance(value, bool):
            raise ValueError("not a boolean")
        return value

    return Validator(check, "True, False")


def unquote(text: str) -> str:
    """A quoted string reply without its quotes."""
    text = text.strip()
    if len(text) >= 2 and text[0] == text[-1] and text[0] in "\"'":
        return text[1:-1]
    return text


def token_for_reply(values: dict[Any, str], reply: str) -> Any:
    """The key of `values` whose token the reply is (the token, its SCPI long form, or the
    key itself); of tokens that are prefixes of one another the longest wins. A reply in
    short form (an instrument answering with minimum-length keywords, `AVE` for AVERAGE)
    is the one token it begins."""
    text = unquote(reply).upper()
    best, best_length = None, -1
    for key, token in values.items():
        token_upper = str(token).upper()
        if text == str(key).upper():
            return key
        if text.startswith(token_upper) and len(token_upper) > best_length:
            best, best_length = key, len(token_upper)
    if best is None and text:
        begun = [key for key, token in values.items() if str(token).upper().startswith(text)]
        best = begun[0] if len(begun) == 1 else None
    if best is None:
        raise ValueError(f"not one of {', '.join(map(str, values.values()))}")
    return best


class control:  # noqa: N801 - named like PyMeasure's Instrument.control, used like `property`
    """A setting read with `get_command` and written with `set_command`.

    `set_command` is formatted with the (validated, mapped) value as its one positional
    field. `parse` turns a reply into a value (default: float, or the `values` map).
    `check_set` reads the setting back after writing it, for instruments that neither
    acknowledge commands nor keep an error queue (the OFV-5000). `manual` cites where
    the manual defines the command (docs/instrument-commands.md lists them all).
    """

    def __init__(self, get_command: str | None, set_command: str | None, doc: str, *,
                 validator: Validator | Callable[[Any], Validator] | None = None,
                 values: dict[Any, str] | None = None,
                 parse: Callable[[str], Any] | None = None,
                 check_set: bool = False, manual: str = "") -> None:
        self.get_command = get_command
        self.manual = manual
        self.set_command = set_command
        self.__doc__ = doc
        self.values = values
        if validator is None and values is not None:
            validator = strict_discrete_set(values)
        self.validator = validator
        self.parse = parse
        self.check_set = check_set
        self.name = "?"

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    # -- reading ----------------------------------------------------------------------------
    def __get__(self, obj: Any, owner: type | None = None) -> Any:
        if obj is None:
            return self
        if self.get_command is None:
            raise AttributeError(f"{self.name} is write-only")
        command = self.get_command.format(**obj.command_fields)
        reply = obj.query(command)
        try:
            return self.value_of(reply)
        except ValueError as exc:
            raise GarbledReply(obj.role, obj.resource_name, command, reply, str(exc)) from None

    def value_of(self, reply: str) -> Any:
        if self.parse is not None:
            return self.parse(reply)
        if self.values is not None:
            return token_for_reply(self.values, reply)
        return float(reply)

    # -- writing ----------------------------------------------------------------------------
    def __set__(self, obj: Any, value: Any) -> None:
        if self.set_command is None:
            raise AttributeError(f"{self.name} is read-only")
        checked = self.checked(obj, value)
        obj.write(self.message_for(obj, checked))
        if self.check_set:
            now = self.__get__(obj)
            if now != checked:
                raise InstrumentError(obj.role, obj.resource_name,
                                      f"{self.name} reads {now!r} after setting it to {checked!r}")

    def set_message(self, obj: Any, value: Any) -> str:
        """The set command for `value`, validated as a set is (OutOfRangeError names the
        property), for a message concatenated with others: nothing is sent here."""
        if self.set_command is None:
            raise AttributeError(f"{self.name} is read-only")
        return self.message_for(obj, self.checked(obj, value))

    def message_for(self, obj: Any, checked: Any) -> str:
        """The set command for a value its caller has already validated (`checked`)."""
        token = self.values[checked] if self.values is not None else checked
        return self.set_command.format(token, **obj.command_fields)

    def checked(self, obj: Any, value: Any) -> Any:
        """`value` in canonical form, or OutOfRangeError naming the property (nothing sent)."""
        validator = self.validator
        if validator is None:
            return value
        if not isinstance(validator, Validator):
            validator = validator(obj)  # depends on the instrument's present state
        return checked(f"{obj.property_prefix}.{self.name}", validator, value)


def checked(property_name: str, validator: Validator, value: Any) -> Any:
    """`validator(value)`, or OutOfRangeError naming the property and what is allowed."""
    try:
        return validator(value)
    except (ValueError, TypeError):
        raise OutOfRangeError(property_name, value, validator.allowed) from None


def controls_of(cls: type) -> list[str]:
    """Names of the readable controls of a class (base classes first), for snapshots."""
    names: list[str] = []
    for klass in reversed(cls.__mro__):
        for name, attribute in vars(klass).items():
            if isinstance(attribute, control) and attribute.get_command is not None and name not in names:
                names.append(name)
    return names
