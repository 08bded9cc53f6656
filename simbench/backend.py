"""PyVISA backend of the simulated bench: `ResourceManager("<scene.yaml>@simbench")`.

The library path is the scene file, optionally followed by `#<fragment>` parts: PyVISA
keeps one library object per path, so `instruments.bench.open_bench` appends a unique
token to get a fresh bench each time; a fragment `key=value` is a bench option:
`start=power_on|hostile|previous-<seed>` (the instruments' state when the bench opens,
see `simbench.devices.start_state`) and `decoder=VD-09|VD-02` (the vibrometer's velocity
decoder). `visa_lib.bench` is the `SimulatedBench` (clock, plate state, mount,
closed-form truth).
"""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any, Tuple

from pyvisa import constants, rname
from pyvisa.util import LibraryPath
from pyvisa_sim.highlevel import SimVisaLibrary

from squeezebench import paths
from squeezebench.simbench.clock import BUS_TIMINGS
from squeezebench.simbench.device_base import SimulatedInstrument
from squeezebench.simbench.devices import INSTRUMENTS, start_state
from squeezebench.simbench.scene import load_scene
from squeezebench.simbench.simulation import SimulatedBench
from squeezebench.simbench.stage import Stage

#: The simulated bench's instruments at their addresses (docs/design.md).
RESOURCES = {"GPIB0::10::INSTR": "generator", "TCPIP0::192.168.0.20::INSTR": "scope", "ASRL1::INSTR": "vibrometer",
             "ASRL2::INSTR": "stage"}
#: The instruments by role: the three of devices.py and the x-y stage of stage.py.
DEVICES = {**INSTRUMENTS, "stage": Stage}


class SimulatedDevices:
    """The bench's instruments by canonical resource name (what SimVisaLibrary.open looks up)."""

    def __init__(self, instruments: dict[str, SimulatedInstrument]) -> None:
        self._instruments = instruments

    def __getitem__(self, resource_name: str) -> SimulatedInstrument:
        return self._instruments[resource_name]

    def list_resources(self) -> Tuple[str, ...]:
        return tuple(self._instruments)


def scene_path_of(library_path: str) -> Path:
    """`<scene>[#fragment...]` -> the scene file; no path: the default scene."""
    path = str(library_path).split("#", 1)[0]
    return Path(path) if path and path != "unset" else paths.default_scene()


def options_of(library_path: str) -> dict[str, str]:
    """The `#key=value` fragments of a library path."""
    fragments = str(library_path).split("#")[1:]
    return dict(f.split("=", 1) for f in fragments if "=" in f)


#: What `SceneVisaLibrary.ignore_warning` hands out (reusable: it does nothing).
_NOTHING_TO_IGNORE = contextlib.nullcontext()


class SceneVisaLibrary(SimVisaLibrary):
    """pyvisa-sim's library with instruments backed by a scene's physics."""

    bench: SimulatedBench

    def ignore_warning(self, session, *warnings_constants) -> contextlib.AbstractContextManager:
        """PyVISA consults the warnings a session ignores only where a library hands it a
        VISA return value (`handle_return_value`), which this one, like pyvisa-sim's, never
        does: there is nothing to switch off and on again around every read PyVISA makes
        (its generator-based context manager cost more than the simulated reply)."""
        return _NOTHING_TO_IGNORE

    @staticmethod
    def get_library_paths() -> Tuple[LibraryPath]:
        return (LibraryPath("unset"),)

    def _init(self) -> None:
        self.sessions = {}
        options = options_of(self.library_path)
        start = start_state(options.pop("start", "power_on"))
        self.bench = SimulatedBench(load_scene(scene_path_of(self.library_path)))
        instruments = {}
        for resource_name, role in RESOURCES.items():
            bus = BUS_TIMINGS[resource_name.split("::", 1)[0].rstrip("0123456789").lower()]
            setattr(self.bench, role, DEVICES[role](self.bench, bus, options))
            instruments[rname.to_canonical_name(resource_name)] = getattr(self.bench, role)
        self.devices = SimulatedDevices(instruments)
        start(self.bench)
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


#: The attribute every read asks its session for (an enum member's lookup, kept).
_TIMEOUT_VALUE = constants.ResourceAttribute.timeout_value


def _timeout_s(session) -> float:
    """The session's VISA timeout in seconds (infinite stays infinite)."""
    timeout_ms, _ = session.get_attribute(_TIMEOUT_VALUE)
    return float("inf") if timeout_ms == constants.VI_TMO_INFINITE else timeout_ms / 1000.0
