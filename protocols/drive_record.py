"""What a generator was left at by a process that died before bringing it down.

A killed process (SIGKILL, the PC's power cut, a crash of the interpreter) cannot set its
generator to the minimum: the 33120A keeps its last amplitude and the plate stays driven
until someone acts. So the DriveController writes each amplitude above the minimum to a
small record per generator (in `paths.state_dir()`) before sending it, and removes the
record once the generator is at its minimum again. A record whose process is gone is an
unclean end: the next `check` or `run` on that bench says so, with the amplitude it was
left at, and brings the generator to its minimum before anything else;
`squeezebench safe --bench FILE` does only that, for an operator who wants the plate at
rest now.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import os
from pathlib import Path
from typing import Any, Callable

from squeezebench import paths
from squeezebench.instruments.bench import BenchConfig, generator_only, is_simulated
from squeezebench.protocols.storage import write_json_atomic


def record_file(config: BenchConfig) -> Path:
    """The record of the bench's generator: one file per VISA library and address (every
    simulated bench shares one: its generator is simulated anew by each process)."""
    where = "simulated" if is_simulated(config) else f"{config.visa_library}|{config.resources['generator']}"
    return paths.state_dir() / f"drive-{hashlib.sha256(where.encode()).hexdigest()[:16]}.json"


class DriveRecord:
    """The DriveController's `on_amplitude`: called with the generator amplitude (Vpp) and
    the piezo voltage (Vpp) before an amplitude above the minimum is sent, and with None
    once the minimum has been sent."""

    def __init__(self, config: BenchConfig):
        self.path = record_file(config)
        self.fields = {"generator": config.resources["generator"], "bench": config.source or "simulated"}

    def __call__(self, generator_amplitude_vpp: float | None, piezo_vpp: float | None) -> None:
        if generator_amplitude_vpp is None:
            self.path.unlink(missing_ok=True)
            return
        write_json_atomic(self.path, {**self.fields, "generator_amplitude_vpp": generator_amplitude_vpp,
                                      "piezo_vpp": piezo_vpp, "pid": os.getpid(),
                                      "recorded_utc": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")},
                          durable=False)   # a kill, not a power cut, is what it is for: no fsync per ramp step


def left_driven(config: BenchConfig) -> dict[str, Any] | None:
    """The record of an unclean end on this bench's generator (None if there is none, or if
    the process that wrote it is still running: it is driving the generator now)."""
    path = record_file(config)
    try:
        record = json.loads(path.read_text())
        pid = int(record["pid"])
    except FileNotFoundError:
        return None
    except (ValueError, KeyError, TypeError):   # a damaged record: what it says is unknown, so at rest to be safe
        return {"generator": config.resources["generator"], "generator_amplitude_vpp": None, "pid": None}
    if pid != os.getpid() and _alive(pid):
        return None
    return record


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:   # another user's process
        return True
    return True


def unclean_end_message(record: dict[str, Any]) -> str:
    amplitude = record.get("generator_amplitude_vpp")
    left = (f"left driven at {amplitude:g} Vpp (generator amplitude, peak-to-peak; {record['piezo_vpp']:g} Vpp on "
            f"the piezos), its last recorded amplitude" if amplitude is not None else "maybe left driven (its record "
            "is damaged)")
    return (f"UNCLEAN END: the generator at {record['generator']} was {left}, by process {record.get('pid')} which "
            f"ended without bringing it down ({record.get('recorded_utc', 'time unknown')}); setting it to its "
            "minimum first")


def bring_to_rest(config: BenchConfig, say: Callable[[str], None], always: bool = False) -> dict[str, Any] | None:
    """After an unclean end (or `always`): say it, set the generator to its minimum, forget
    the record; return the record found (None if none)."""
    record = left_driven(config)
    if record is None and not always:
        return None
    if record is not None:
        say(unclean_end_message(record))
    with generator_only(config) as generator:
        generator.sine_at_minimum()
        minimum_vpp = generator.min_amplitude_vpp
    record_file(config).unlink(missing_ok=True)
    say(f"generator at {config.resources['generator']} set to its minimum amplitude, {minimum_vpp:g} Vpp")
    return record
