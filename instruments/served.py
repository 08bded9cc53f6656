"""A bench served by `squeezebench serve-sim`: its bench port, the served bench's clock and operator.

The instruments of a served bench are opened through a real VISA library like any lab's;
what is not an instrument (the bench clock the simulated physics runs on, the operator's
plate changes) is asked of serve-sim's bench port, a raw socket named by the bench file's
`simulator:` address (the line protocol of `simbench.serve.bench_command`). Its messages
cost no bench time: they are not on any instrument's bus.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, Mapping

from pyvisa.errors import VisaIOError

from squeezebench.instruments.errors import InstrumentConnectionError, InstrumentError

ROLE = "bench port"


class ServedSimulator:
    """serve-sim's bench port, opened on a resource manager: a fresh served bench (`OPEN`),
    then its clock (`now_s`, `sleep`) and its operator (`request`, `mount`)."""

    def __init__(self, resource_manager: Any, address: str) -> None:
        self.address = address
        try:
            self.resource = resource_manager.open_resource(address, read_termination="\n", write_termination="\n",
                                                           timeout=10_000)
        except (VisaIOError, ValueError, OSError) as exc:
            raise InstrumentConnectionError(ROLE, address, f"no serve-sim bench port at this address ({exc}); "
                                            "is `squeezebench serve-sim` still running?") from None
        self._ask("OPEN")
        self.computing_allowance_s = float(self._ask("ALLOWANCE?"))

    def allow_computing(self, resource: Any) -> None:
        """Add serve-sim's allowance to every timeout a driver sets on `resource`: a served
        reply takes the simulator's computing in wall time (an averaged acquisition on a
        busy machine, seconds), which the VISA timeout would count and a real instrument's
        does not; the driver reads back the timeout it set."""
        allowance_ms = 1000.0 * self.computing_allowance_s
        if not allowance_ms:
            return
        base = type(resource)
        visa_timeout = base.timeout   # PyVISA's attribute descriptor (ms; None or inf: no limit)

        class Allowed(base):   # the same resource class: a driver's isinstance checks still hold
            @property
            def timeout(self):
                value = visa_timeout.__get__(self, base)
                return value if value is None or value == float("inf") else value - allowance_ms

            @timeout.setter
            def timeout(self, value):
                visa_timeout.__set__(self, value if value is None or value == float("inf") else value + allowance_ms)

        current = resource.timeout
        resource.__class__ = Allowed
        resource.timeout = current

    def _ask(self, line: str) -> str:
        try:
            reply = self.resource.query(line).strip()
        except (VisaIOError, OSError) as exc:
            raise InstrumentConnectionError(ROLE, self.address, f"serve-sim did not answer {line!r} ({exc})") from None
        if reply.startswith("ERR"):
            raise InstrumentError(ROLE, self.address, reply.removeprefix("ERR").strip())
        return reply

    # -- the clock ------------------------------------------------------------------------
    def now_s(self) -> float:
        return int(self._ask("TIME?")) / 1e9

    def sleep(self, seconds: float) -> None:
        self._ask(f"SLEEP {max(0.0, float(seconds))!r}")

    # -- the operator -------------------------------------------------------------------------
    def request(self, instruction: str, state: str | None = None) -> None:
        if state is not None:
            self._ask(f"STATE {state}")

    def mount(self, scene_or_plate: str | Path) -> None:
        self._ask(f"MOUNT {Path(scene_or_plate).resolve()}")

    def already_done(self, instruction: str, state: str | None = None) -> None:
        self.request(instruction, state)


def served_bench_file(addresses: Mapping[str, str], electronics: Any,
                      stage_travel_mm: Mapping[str, tuple[float, float]] | None = None) -> dict[str, Any]:
    """The bench file of a served bench: pyvisa-py, the served addresses, the scene's
    electronics and, with a stage, its travel per axis (mm)."""
    travel = {"stage_travel_mm": {axis: list(limits) for axis, limits in stage_travel_mm.items()}} \
        if "stage" in addresses and stage_travel_mm else {}
    return {"visa_library": "@py", "simulator": addresses["bench"],
            "resources": {role: address for role, address in addresses.items() if role != "bench"},
            **travel, "electronics": dataclasses.asdict(electronics)}
