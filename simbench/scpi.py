"""IEEE 488.2 / SCPI program messages as the simulated instruments parse them.

A header tree is built once per instrument model from the manual's header spellings
(`HORizontal:RECORDLength`, `[SOURce:]FREQuency`, `CH<x>:PRObe`): upper case is the
short form. Parsing a message unit walks the tree one dict lookup per mnemonic and
dispatches on the canonical header path, so a command costs the same whatever the size
of the command set.

Rules (IEEE 488.2 section 7, SCPI-1999 Vol. 1 section 6; TDS3000 programmer manual
"Command Syntax", pp. 2-1 to 2-7):
- headers in any case; `SCPI` abbreviation accepts exactly the short or the long form,
  `PREFIX` (the TDS3000: "the minimum acceptable abbreviations in capitals") any
  prefix of the long form at least as long as the short form;
- optional nodes in brackets may be left out;
- `;` separates message units; a unit starting with `:` starts again from the root,
  otherwise it continues from the branch of the previous unit's header; a common
  command (`*IDN?`) leaves that branch unchanged;
- arguments follow white space and are separated by commas (quoted strings may hold
  either).
"""

from __future__ import annotations

import functools
import itertools
import math
import re
from dataclasses import dataclass, field
from typing import Iterator

SCPI, PREFIX = "scpi", "prefix"


class ScpiError(Exception):
    """A refused message unit: `code` and `message` as in the SCPI standard error list
    (negative codes); an instrument that reports positive codes (the TDS3000) reports the
    absolute value. Instrument-specific errors carry their own positive code."""

    def __init__(self, code: int, message: str, detail: str = "") -> None:
        super().__init__(f"{code},{message}")
        self.code = code
        self.message = message
        self.detail = detail


# The standard errors the simulated instruments raise (SCPI-1999 Vol. 2 section 21.8;
# the same numbers without sign in the TDS3000 manual, Tables 3-4 and 3-5).
def syntax_error() -> ScpiError:
    return ScpiError(-102, "Syntax error")


def undefined_header() -> ScpiError:
    return ScpiError(-113, "Undefined header")


def missing_parameter() -> ScpiError:
    return ScpiError(-109, "Missing parameter")


def parameter_not_allowed() -> ScpiError:
    return ScpiError(-108, "Parameter not allowed")


def illegal_parameter() -> ScpiError:
    return ScpiError(-224, "Illegal parameter value")


@dataclass
class Node:
    """One mnemonic of the tree; `path` is set where a header ends."""

    children: dict[str, tuple["Node", int | None]] = field(default_factory=dict)
    path: str | None = None


@dataclass(frozen=True)
class Mnemonic:
    long: str            # upper case, e.g. RECORDLENGTH, or CH for CH<x>
    short: str           # the capitals of the manual's spelling, e.g. RECORDL
    optional: bool
    suffixes: tuple[int, ...] = ()   # CH<x>: the allowed x

    def spellings(self, style: str) -> Iterator[tuple[str, int | None]]:
        if self.suffixes:
            for x in self.suffixes:
                yield f"{self.long}{x}", x
            return
        if style == SCPI:
            yield self.short, None
            yield self.long, None
        else:
            for length in range(len(self.short), len(self.long) + 1):
                yield self.long[:length], None


_MNEMONIC = re.compile(r"^(\[)?([A-Za-z_0-9*]+?)(<x>)?(\])?$")


def parse_spec(spec: str, suffixes: tuple[int, ...]) -> list[Mnemonic]:
    """`[SOURce:]FREQuency` -> mnemonics; the capitals are the short form."""
    parts = []
    for raw in re.findall(r"\[[^\]]+\]|[^:\[\]]+", re.sub(r"\[:?([^\]:]+):?\]", r"[\1]", spec)):
        match = _MNEMONIC.match(raw)
        if match is None:
            raise ValueError(f"cannot read header spelling {spec!r} at {raw!r}")
        optional, word, suffix = bool(match.group(1)), match.group(2), bool(match.group(3))
        parts.append(Mnemonic(word.upper(), short_form(word), optional, suffixes if suffix else ()))
    return parts


def short_form(word: str) -> str:
    """The short form of a manual's spelling: its capitals (and digits), `SAMple` -> SAM."""
    return "".join(c for c in word if not c.islower()).upper()


def short_path(spec: str) -> str:
    """The header in short form, as a reply carries it with verbose off: `ACQuire:MODe` ->
    ACQ:MOD (optional mnemonics left out, `<x>` kept for the suffix)."""
    return ":".join(p.short + ("<x>" if p.suffixes else "") for p in parse_spec(spec, (1,)) if not p.optional)


def canonical_path(parts: list[Mnemonic]) -> str:
    return ":".join(p.long + ("<x>" if p.suffixes else "") for p in parts if not p.optional)


class HeaderTree:
    """The headers an instrument defines."""

    def __init__(self, style: str) -> None:
        self.style = style
        self.root = Node()
        self.common: dict[str, str] = {}

    def add(self, spec: str, suffixes: tuple[int, ...] = (1, 2, 3, 4)) -> str:
        """Register a header spelling; returns its canonical path."""
        if spec.startswith("*"):
            self.common[spec.upper()] = spec.upper()
            return spec.upper()
        parts = parse_spec(spec, suffixes)
        path = canonical_path(parts)
        optional = [i for i, p in enumerate(parts) if p.optional]
        for kept in itertools.product((True, False), repeat=len(optional)):
            dropped = {i for i, keep in zip(optional, kept) if not keep}
            node = self.root
            for i, part in enumerate(parts):
                if i in dropped:
                    continue
                spellings = list(part.spellings(self.style))
                # A mnemonic the manual spells with other capitals elsewhere (TDS PM:
                # `SOUrce` and `SOURCE1`) shares its node: every spelling leads there.
                child = next((node.children[s][0] for s, _ in spellings if s in node.children), None) or Node()
                for spelling, x in spellings:
                    node.children.setdefault(spelling, (child, x))
                node = child
            if node.path is not None and node.path != path:
                raise ValueError(f"{spec!r} collides with {node.path!r}")
            node.path = path
        return path

    def resolve(self, branch: Node, branch_suffixes: tuple[int, ...],
                mnemonics: list[str]) -> tuple[str, tuple[int, ...], Node, tuple[int, ...]]:
        """(canonical path, suffixes, branch for the next unit and its suffixes), or
        ScpiError -113. A branch keeps the suffixes of its nodes (CH2:PROBE 1;SCALE 2)."""
        node, suffixes = branch, list(branch_suffixes)
        parent, parent_suffixes = branch, branch_suffixes
        for mnemonic in mnemonics:
            entry = node.children.get(mnemonic)
            if entry is None:
                raise undefined_header()
            parent, parent_suffixes = node, tuple(suffixes)
            node, x = entry
            if x is not None:
                suffixes.append(x)
        if node.path is None:
            raise undefined_header()
        return node.path, tuple(suffixes), parent, parent_suffixes


@dataclass(frozen=True)
class Unit:
    """One message unit, parsed."""

    path: str
    query: bool
    arguments: tuple[str, ...]
    suffixes: tuple[int, ...]
    text: str


def split_outside_quotes(text: str, separator: str) -> list[str]:
    if '"' not in text and "'" not in text:
        return text.split(separator)
    parts, start, quote = [], 0, ""
    for i, char in enumerate(text):
        if quote:
            if char == quote:
                quote = ""
        elif char in "\"'":
            quote = char
        elif char == separator:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return parts


class MessageParser:
    """Program messages -> units, keeping the branch between units of one message."""

    #: Messages parsed without error, remembered: a campaign sends the same few hundred
    #: settings and queries tens of thousands of times (a sweep's new numbers are not kept
    #: past this many).
    REMEMBERED = 4096

    def __init__(self, tree: HeaderTree) -> None:
        self.tree = tree
        self._parsed: dict[str, tuple[Unit, ...]] = {}

    def units(self, message: str) -> tuple[Unit | ScpiError, ...]:
        """Each unit of `message`, or the ScpiError refusing it (later units still run)."""
        parsed = self._parsed.get(message)
        if parsed is None:
            parsed = tuple(self._parse(message))
            if not any(isinstance(unit, ScpiError) for unit in parsed):   # an error is the caller's to annotate
                if len(self._parsed) >= self.REMEMBERED:
                    self._parsed.clear()
                self._parsed[message] = parsed
        return parsed

    def _parse(self, message: str) -> Iterator[Unit | ScpiError]:
        branch, branch_suffixes = self.tree.root, ()
        for raw in split_outside_quotes(message, ";"):
            text = raw.strip()
            if not text:
                continue
            header, _, rest = text.partition(" ")
            if "\t" in header:
                header, _, more = header.partition("\t")
                rest = more + " " + rest
            query = header.endswith("?")
            name = header[:-1] if query else header
            arguments = tuple(a.strip() for a in split_outside_quotes(rest, ",")) if rest.strip() else ()
            try:
                if name.startswith("*"):
                    path = self.tree.common.get(name.upper())
                    if path is None:
                        raise undefined_header()
                    yield Unit(path, query, arguments, (), text)
                    continue
                start, start_suffixes = (self.tree.root, ()) if name.startswith(":") else (branch, branch_suffixes)
                mnemonics = name.lstrip(":").upper().split(":") if name.lstrip(":") else []
                if not mnemonics or "" in mnemonics:
                    raise syntax_error()
                path, suffixes, branch, branch_suffixes = self.tree.resolve(start, start_suffixes, mnemonics)
                yield Unit(path, query, arguments, suffixes, text)
            except ScpiError as exc:
                exc.detail = text
                yield exc


# -- arguments ----------------------------------------------------------------------------------
_NUMBER = re.compile(r"^\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*([A-Za-z%/]*)\s*$")


def only_argument(arguments: tuple[str, ...]) -> str:
    if not arguments or arguments[0] == "":
        raise missing_parameter()
    if len(arguments) > 1:
        raise parameter_not_allowed()
    return arguments[0]


def no_arguments(arguments: tuple[str, ...]) -> None:
    if arguments:
        raise parameter_not_allowed()


def number(text: str, units: dict[str, float] | None = None) -> float:
    """A decimal numeric program datum with an optional suffix from `units` (suffix ->
    multiplier, upper case); -121/-131/-138 as IEEE 488.2 section 7.7.2-7.7.3 says."""
    match = _NUMBER.match(text)
    if match is None:
        starts_as_number = text.strip()[:1].isdigit() or text.strip()[:1] in ("+", "-", ".")
        raise ScpiError(-121, "Invalid character in number") if starts_as_number else ScpiError(-104, "Data type error")
    value = float(match.group(1))
    suffix = match.group(2).upper()
    if suffix:
        if not units:
            raise ScpiError(-138, "Suffix not allowed")
        if suffix not in units:
            raise ScpiError(-131, "Invalid suffix")
        value *= units[suffix]
    if not math.isfinite(value):
        raise ScpiError(-123, "Exponent too large")
    return value


@functools.lru_cache(maxsize=256)
def _spellings(options: tuple[tuple[str, str], ...]) -> tuple[tuple[str, str, str], ...]:
    """(long form, short form, value) of each option, worked out once per option table."""
    return tuple((spelling.upper(), short_form(spelling), value) for spelling, value in options)


def choice(text: str, options: dict[str, str], style: str) -> str:
    """A character program datum among `options` (manual spelling -> canonical value)."""
    return _match(text.strip().upper(), _spellings(tuple(options.items())), style)


def _match(word: str, spellings: tuple[tuple[str, str, str], ...], style: str) -> str:
    for long, short, value in spellings:
        if word in (short, long) or (style == PREFIX and long.startswith(word) and len(word) >= len(short)):
            return value
    raise illegal_parameter()


class Choices:
    """`choice` among fixed `options`, spelled out once: a setting's handler meets the same
    few words tens of thousands of times in a campaign or a study, so each word accepted is
    remembered with its value (at most every prefix of the long forms)."""

    def __init__(self, options: dict[str, str], style: str) -> None:
        self._spellings = _spellings(tuple(options.items()))
        self._style = style
        self._values: dict[str, str] = {}

    def __call__(self, text: str) -> str:
        value = self._values.get(text)
        if value is None:
            value = self._values[text] = _match(text.strip().upper(), self._spellings, self._style)
        return value


def boolean(text: str) -> bool:
    """ON | OFF | <NR1> (non-zero is on)."""
    word = text.strip().upper()
    if word == "ON":
        return True
    if word == "OFF":
        return False
    try:
        return round(float(word)) != 0
    except ValueError:
        raise illegal_parameter() from None


def quoted_string(text: str) -> str:
    """A string program datum (either quote; a doubled quote stands for one)."""
    text = text.strip()
    if len(text) < 2 or text[0] not in "\"'" or text[-1] != text[0]:
        raise ScpiError(-151, "Invalid string data")
    quote = text[0]
    return text[1:-1].replace(quote * 2, quote)

