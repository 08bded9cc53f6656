"""The command summaries of the instruments' manuals, as checked-in tables.

`simbench/commands/<model>.tsv` lists every header (the two SCPI instruments), controller
line (OFV-5000) or two-letter command (SMC100) of the manual's command summary with its
forms and arguments: what the simulated instrument accepts, what the command walk of
tests/test_sim_commands.py sends, and what docs/instrument-commands.md counts. Each file
says in its first lines where it comes from. The tables hold headers and argument
syntax only.

Columns, tab-separated: header, forms (space-separated), arguments, reply (the value a
setting kept as state only has at power-on, or the fixed reply of a query-only header;
may be empty), limits (`low high` of a number; may be absent).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

TABLES = Path(__file__).resolve().parent / "commands"
#: The table of each simulated instrument (by role).
TABLE_OF_ROLE = {"generator": "hp33120a", "scope": "tds3000", "vibrometer": "ofv5000", "stage": "smc100"}


@dataclass(frozen=True)
class Entry:
    """One row of a command summary."""

    header: str
    forms: frozenset[str]
    arguments: str
    reply: str
    limits: tuple[float, float] | None

    @property
    def settable(self) -> bool:
        return "set" in self.forms

    @property
    def queryable(self) -> bool:
        return "query" in self.forms


@functools.cache
def table(name: str) -> tuple[Entry, ...]:
    """The rows of `commands/<name>.tsv`, in the file's order."""
    rows = []
    path = TABLES / f"{name}.tsv"
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        if not line.strip() or line.startswith("#"):
            continue
        fields = line.split("\t") + ["", "", ""]
        header, forms, arguments, reply, limits = (f.strip() for f in fields[:5])
        if not header or not forms:
            raise ValueError(f"{path.name}:{number}: a row needs a header and its forms")
        low_high = tuple(float(v) for v in limits.split()) if limits else None
        if low_high is not None and len(low_high) != 2:
            raise ValueError(f"{path.name}:{number}: limits are 'low high', not {limits!r}")
        rows.append(Entry(header, frozenset(forms.split()), arguments, reply, low_high))
    return tuple(rows)
