"""PyVISA backend of the simulated bench: `ResourceManager("<scene.yaml>@simbench")`.

The library path is the scene file, optionally followed by `#<anything>`: PyVISA keeps
one library object per path, so `instruments.bench.open_bench` appends a unique token
to get a fresh bench each time. `visa_lib.bench` is the `SimulatedBench` (clock, plate
state, mount, closed-form truth).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Tuple

from pyvisa import constants
from pyvisa.util import LibraryPath
from pyvisa_sim import parser
from pyvisa_sim.highlevel import SimVisaLibrary

from squeezebench.simbench.clock import BUS_TIMINGS
from squeezebench.simbench.devices import INSTRUMENTS, SimulatedInstrument
from squeezebench.simbench.scene import load_scene
from squeezebench.simbench.simulation import SimulatedBench
from squeezebench import paths

DEFINITIONS = Path(__file__).resolve().parent / "definitions" / "bench.yaml"

#: Which instrument a pyvisa-sim device of bench.yaml is, from words in its name.
_ROLE_WORDS = {"generator": ("33120", "generator"), "scope": ("tds", "3054", "scope"),
               "vibrometer": ("ofv", "vibrometer", "polytec")}


class SimulatedDevices:
    """The bench's instruments by canonical resource name (what SimVisaLibrary.open looks up)."""

    def __init__(self, instruments: dict[str, SimulatedInstrument]) -> None:
        self._instruments = instruments

    def __getitem__(self, resource_name: str) -> SimulatedInstrument:
        return self._instruments[resource_name]

    def list_resources(self) -> Tuple[str, ...]:
        return tuple(self._instruments)


def scene_path_of(library_path: str) -> Path:
    """`<scene>[#token]` -> the scene file; no path: the default scene."""
    path = str(library_path).split("#", 1)[0]
    return Path(path) if path and path != "unset" else paths.default_scene()


class SceneVisaLibrary(SimVisaLibrary):
    """pyvisa-sim's library with instruments backed by a scene's physics."""

    bench: SimulatedBench

    @staticmethod
    def get_library_paths() -> Tuple[LibraryPath]:
        return (LibraryPath("unset"),)

    def _init(self) -> None:
        self.sessions = {}
        self.bench = SimulatedBench(load_scene(scene_path_of(self.library_path)))
        static = parser.get_devices(str(DEFINITIONS), False)
        instruments = {}
        for resource_name in static.list_resources():
            device = static[resource_name]
            role = _role(device.name)
            bus = BUS_TIMINGS[resource_name.split("::", 1)[0].rstrip("0123456789").lower()]
            instruments[resource_name] = INSTRUMENTS[role](device, self.bench, bus)
            setattr(self.bench, role, instruments[resource_name])
        missing = [role for role in INSTRUMENTS if getattr(self.bench, role) is None]
        if missing:
            raise ValueError(f"{DEFINITIONS}: no device for {', '.join(missing)}")
        self.devices = SimulatedDevices(instruments)
        self.bench.start()

    def read(self, session, count: int) -> Tuple[bytes, constants.StatusCode]:
        try:
            sess = self.sessions[session]
        except KeyError:
            return b"", constants.StatusCode.error_invalid_object
        return sess.device.read(count, _timeout_s(sess))

    def write(self, session, data: bytes) -> Tuple[int, constants.StatusCode]:
        try:
            sess = self.sessions[session]
        except KeyError:
            return 0, constants.StatusCode.error_invalid_object
        sess.device.write(data)
        return len(data), constants.StatusCode.success

    def clear(self, session) -> constants.StatusCode:
        try:
            self.sessions[session].device.clear()
        except KeyError:
            return constants.StatusCode.error_invalid_object
        return constants.StatusCode.success

    def close(self, session: Any) -> constants.StatusCode:
        if self.sessions.get(session) is self:  # the resource manager's own session
            self.bench.close()
        return super().close(session)


def _role(device_name: str) -> str:
    name = device_name.lower()
    for role, words in _ROLE_WORDS.items():
        if any(word in name for word in words):
            return role
    raise ValueError(f"{DEFINITIONS}: cannot tell which instrument device {device_name!r} is "
                     f"(expected a name containing one of {_ROLE_WORDS})")


def _timeout_s(session) -> float:
    """The session's VISA timeout in seconds (infinite stays infinite)."""
    timeout_ms, _ = session.get_attribute(constants.ResourceAttribute.timeout_value)
    return float("inf") if timeout_ms == constants.VI_TMO_INFINITE else timeout_ms / 1000.0
