"""serve-sim put together: one served bench, its bench port, the scope's socket and the
serial instruments' pseudo-terminals (`simbench.serve`, `serve_tcp`, `serve_pty`)."""

from __future__ import annotations

from pathlib import Path
from typing import Callable

from squeezebench.simbench.line import MANUAL_SETTINGS
from squeezebench.simbench.serve import (LINE_RATES, NETWORK_ROLES, SERIAL_ROLES, BenchEndpoint, InstrumentEndpoint,
                                         ServedBench)
from squeezebench.simbench.serve_pty import PtyPort
from squeezebench.simbench.serve_tcp import TcpPort


class ServedSim:
    """The served bench of `scene` on loopback ports until `close` (a context manager).
    `line_rate="real"` makes every byte on a serial line take its time on the line;
    `computing_allowance_s` is added to the clients' VISA timeouts (`instruments.served`)."""

    def __init__(self, scene: str | Path, line_rate: str = "model", host: str = "127.0.0.1",
                 on_event: Callable[[str], None] = lambda text: None, computing_allowance_s: float = 0.0) -> None:
        if line_rate not in LINE_RATES:
            raise ValueError(f"line_rate must be one of {', '.join(LINE_RATES)}, got {line_rate!r}")
        self.served = ServedBench(scene, on_event, computing_allowance_s)
        self.ports: dict = {}
        try:
            self.ports["bench"] = TcpPort(BenchEndpoint(self.served), host)
            for role in NETWORK_ROLES:
                self.ports[role] = TcpPort(InstrumentEndpoint(self.served, role), host)
            for role in SERIAL_ROLES:
                self.ports[role] = PtyPort(InstrumentEndpoint(self.served, role), MANUAL_SETTINGS[role], self.served.lock,
                                           real_rate=line_rate == "real", generation=lambda: self.served.generation)
                self.served.on_open.append(self.ports[role].flush)
        except BaseException:
            self.close()
            raise

    @property
    def addresses(self) -> dict[str, str]:
        """The VISA address of each port: `bench` (the bench port) and every role."""
        return {name: port.address for name, port in self.ports.items()}

    def close(self) -> None:
        for port in self.ports.values():
            port.close()
        self.ports = {}
        self.served.close()

    def __enter__(self) -> ServedSim:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()
