"""Faults of the transport between a served instrument and the VISA library (`serve-sim`).

A scene names them under `transport_faults`; only a served bench has a transport, so the
in-process simulated bench ignores them. Each acts on the replies of one instrument, the
`occurrence`-th reply to a message containing `query` (any message when not given), and
once per `serve-sim`: a cable pulled and put back, a line hit once. `chunked_reply` is the
exception: it is the way a network stack may deliver any reply, so it acts on every one.

- `chunked_reply`: every reply leaves in random pieces of 1..`max_chunk_bytes` bytes with
  a pause of up to `max_pause_s` between them (a reader must join them);
- `slow_trickle`: the reply trickles at `bytes_per_s`, for longer than the reader's VISA
  timeout when it is slow enough (a VISA read waits its timeout for each piece up to a
  termination character, which a binary block may hold anywhere);
- `missing_termination`: the reply loses its final LF;
- `connection_reset`: half of the reply goes, then the connection is reset (TCP RST) or,
  on a serial line, the port stops answering until the client opens it again;
- `framing_error`: the reply reaches the reader as a receiver at the wrong stop bits and
  parity reads it (`simbench.line.received`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

ROLES = ("generator", "scope", "vibrometer", "stage")
#: Each fault's parameters and their defaults.
FAULTS: dict[str, dict[str, float]] = {
    "chunked_reply": {"max_chunk_bytes": 7, "max_pause_s": 0.002, "seed": 0},
    "slow_trickle": {"bytes_per_s": 50.0},
    "missing_termination": {},
    "connection_reset": {},
    "framing_error": {},
}


@dataclass
class TransportFault:
    fault: str
    instrument: str
    query: str = ""
    occurrence: int = 1
    parameters: dict[str, float] = field(default_factory=dict)
    seen: int = 0       # replies that matched so far (this serve-sim)
    fired: bool = False

    def hits(self, role: str, message: bytes) -> bool:
        """Whether this fault acts on the reply to `message` from `role` (counts it)."""
        if role != self.instrument or (self.fired and self.fault != "chunked_reply"):
            return False
        if self.query and self.query.upper().encode() not in message.upper():
            return False
        self.seen += 1
        if self.fault == "chunked_reply":
            return self.seen >= self.occurrence
        self.fired = self.seen == self.occurrence
        return self.fired

    def parameter(self, name: str) -> float:
        return self.parameters.get(name, FAULTS[self.fault][name])

    def describe(self) -> str:
        what = f"the reply to {self.query!r}" if self.query else "a reply"
        return f"{self.fault} on the {self.instrument}, {what} #{self.occurrence}"


def parse(data: Any, error: Callable[[str, str], Exception]) -> tuple[TransportFault, ...]:
    """The `transport_faults` list of a scene; `error(field, problem)` builds the scene's error."""
    if not isinstance(data, list):
        raise error("transport_faults", f"must be a list of {{fault: NAME, instrument: ROLE, ...}}; "
                                        f"faults: {', '.join(FAULTS)}")
    faults = []
    for i, entry in enumerate(data):
        where = f"transport_faults[{i}]"
        if not isinstance(entry, dict) or "fault" not in entry or "instrument" not in entry:
            raise error(where, "must be a mapping with fault and instrument (and query, occurrence, parameters)")
        name, role = entry["fault"], entry["instrument"]
        if name not in FAULTS:
            raise error(f"{where}.fault", f"got {name!r}; allowed: {', '.join(FAULTS)}")
        if role not in ROLES:
            raise error(f"{where}.instrument", f"got {role!r}; allowed: {', '.join(ROLES)}")
        allowed = ("fault", "instrument", "query", "occurrence", *FAULTS[name])
        unknown = [key for key in entry if key not in allowed]
        if unknown:
            raise error(f"{where}.{unknown[0]}", f"unknown field; allowed: {', '.join(allowed)}")
        occurrence = entry.get("occurrence", 1)
        if isinstance(occurrence, bool) or not isinstance(occurrence, int) or occurrence < 1:
            raise error(f"{where}.occurrence", f"must be an integer >= 1, got {occurrence!r}")
        parameters = {}
        for key in FAULTS[name]:
            if key in entry:
                value = entry[key]
                if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                        or value <= 0 and key != "seed" or value < 0:
                    raise error(f"{where}.{key}", f"must be a positive number, got {value!r}")
                parameters[key] = float(value)
        faults.append(TransportFault(name, role, str(entry.get("query", "")), occurrence, parameters))
    return tuple(faults)
