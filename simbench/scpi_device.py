"""The two IEEE 488.2 instruments' common part: dispatch of a manual's headers, refusals.

A header a manual's command summary lists is either modelled (`COMMANDS` of the
instrument) or accepted and kept as state only (`state_only`); the instrument reports a
refused one the way its manual says (`report`), and `recorded_refusals` shows them to a
test or benchmark.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass
from typing import Callable, ClassVar, Iterator

from squeezebench.simbench import command_tables, scpi, state_only
from squeezebench.simbench.device_base import Deferred, SimulatedInstrument
from squeezebench.simbench.scpi import ScpiError, Unit

#: The lists `recorded_refusals` is filling.
_REFUSALS: list[list[str]] = []


@contextmanager
def recorded_refusals() -> Iterator[list[str]]:
    """Every command a simulated SCPI instrument (generator, scope) refuses while inside,
    one line each: what a test or benchmark asserts a run never provokes."""
    refused: list[str] = []
    _REFUSALS.append(refused)
    try:
        yield refused
    finally:
        _REFUSALS.remove(refused)

@dataclass(frozen=True)
class Command:
    """One header of a manual: its spelling, what its set and query forms do, where it is."""

    spec: str
    query: Callable | None
    set: Callable | None
    section: str
    suffixes: tuple[int, ...] = (1, 2, 3, 4)   # the <x> a header allows


class ScpiInstrument(SimulatedInstrument):
    """Dispatch on the canonical header path; errors through `report`.

    COMMANDS are the headers modelled physically; every other header of the manual's
    command summary (`TABLE`, see `command_tables`) is accepted and kept as state only
    (`state_only`), in `stored`."""

    STYLE: ClassVar[str]
    TABLE: ClassVar[str]
    COMMANDS: ClassVar[tuple[Command, ...]]
    _parser: ClassVar[scpi.MessageParser]
    _handlers: ClassVar[dict[tuple[str, bool], Callable]]
    _short_paths: ClassVar[dict[str, str]]
    #: Queries whose replies carry their own headers (HEADer ON), besides the groups.
    OWN_HEADERS: ClassVar[frozenset[str]] = frozenset()
    #: Canonical paths of the headers COMMANDS models; the queries whose replies are headed.
    modelled: ClassVar[frozenset[str]]
    _headed: ClassVar[frozenset[str]]
    stored: dict

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if "COMMANDS" not in cls.__dict__:
            return
        tree = scpi.HeaderTree(cls.STYLE)
        cls._handlers, cls._short_paths = {}, {}
        allowed: dict[str, tuple[int, ...]] = {}
        for command in cls.COMMANDS:
            path = tree.add(command.spec, command.suffixes)
            cls._short_paths[path] = scpi.short_path(command.spec)
            allowed[path] = command.suffixes
            for query, handler in ((True, command.query), (False, command.set)):
                if handler is not None:
                    cls._handlers[path, query] = handler
        cls.modelled = frozenset(allowed)
        cls._add_state_only(tree, allowed)
        cls._parser = scpi.MessageParser(tree)

    @classmethod
    def _add_state_only(cls, tree: scpi.HeaderTree, allowed: dict[str, tuple[int, ...]]) -> None:
        """The summary's headers (and forms) COMMANDS leaves out, as state only; a query-only
        header grouping settings answers them all (`<all settings>`: the whole setup)."""
        groups, settings = [], []
        for entry in command_tables.table(cls.TABLE):
            path = tree.add(entry.header)
            cls._short_paths.setdefault(path, scpi.short_path(entry.header))
            allowed.setdefault(path, (1, 2, 3, 4))
            setting = state_only.Setting(entry, path)
            if entry.settable and entry.queryable and entry.arguments and not (setting.argument.free
                                                                               or path.startswith("*")):
                settings.append(path)
            if entry.settable:
                cls._handlers.setdefault((path, False), setting.set)
            if entry.queryable and (path, True) not in cls._handlers:
                if not entry.settable and entry.reply in ("", "<all settings>"):
                    groups.append((path, entry.reply == "<all settings>"))
                cls._handlers[path, True] = setting.query
        grouped = set()
        for path, whole in groups:
            children = [(child, cls._handlers[child, True], allowed[child]) for child in settings
                        if whole or child.startswith(path + ":")]
            if children:
                cls._handlers[path, True] = state_only.group(children)
                grouped.add(path)
        cls._headed = frozenset(grouped) | cls.OWN_HEADERS

    def handle(self, message: bytes) -> list:
        if self._replies:   # IEEE 488.2 6.3.2.3: a new message discards unread replies
            self._replies.clear()
            self.report(ScpiError(-410, "Query INTERRUPTED"))
        try:
            text = message.decode("ascii")
        except UnicodeDecodeError:
            self.report(ScpiError(-101, "Invalid character"))
            return []
        replies = []
        for unit in self._parser.units(text):
            if isinstance(unit, ScpiError):
                self.refuse(unit)
                continue
            handler = self._handlers.get((unit.path, unit.query))
            try:
                if handler is None:
                    raise scpi.undefined_header()
                reply = handler(self, unit)
            except ScpiError as exc:
                exc.detail = unit.text
                self.refuse(exc)
                continue
            if reply is not None:
                replies.append(reply if unit.path in self._headed else self.with_header(unit, reply))
        return self.combine(replies)

    def refuse(self, error: ScpiError) -> None:
        """A command refused (its text in `error.detail`): reported as the manual says, and
        shown to every `recorded_refusals` open (command, execution, device or query errors:
        codes 100-499 but the power-on event; the 5xx warnings and 2xxx measurement events
        are not refusals of the command)."""
        if 100 <= abs(error.code) < 500 and error.code != 401:
            for refused in _REFUSALS:
                refused.append(f"{self.role}: {error.code} {error.message} ({error.detail})")
        self.report(error)

    @staticmethod
    def combine(replies: list) -> list:
        """Replies to the queries of one message go out as one, `;`-separated."""
        if len(replies) <= 1:
            return replies
        ready_s = max((r.ready_s for r in replies if isinstance(r, Deferred)), default=None)
        payload = b";".join(r.payload if isinstance(r, Deferred) else r for r in replies)
        return [payload if ready_s is None else Deferred(ready_s, payload)]

    def with_header(self, unit: Unit, reply):
        return reply

    def report(self, error: ScpiError) -> None:
        raise NotImplementedError

    def read_without_reply(self) -> None:
        self.report(ScpiError(-420, "Query UNTERMINATED"))


def _setting(key: str, parse: Callable, fmt: Callable[[object], str], *, per_channel: bool = False):
    """(query, set) handlers of a plain setting stored under `key`."""

    def state_key(unit: Unit):
        return (key, unit.suffixes[0]) if per_channel else key

    def query(instrument, unit: Unit) -> bytes:
        scpi.no_arguments(unit.arguments)
        return fmt(instrument.state[state_key(unit)]).encode()

    def set_(instrument, unit: Unit) -> None:
        value = parse(instrument, scpi.only_argument(unit.arguments), unit)
        instrument.state[state_key(unit)] = value
        instrument.changed(key, unit)

    return query, set_


def _choices(options: dict[str, str], style: str) -> Callable:
    table = scpi.Choices(options, style)
    return lambda instrument, text, unit: table(text)

def _flag(value: bool) -> str:
    return "1" if value else "0"
