"""Simulated Newport SMC100 x-y stage: two controllers (x at address 1, y at 2) on one
serial line, answering the grammar and keeping the state of the SMC100 user's manual
(cited as in `instruments/smc100.py`: "SMC100 UM" and the command's two letters).

State per axis: NOT REFERENCED at power-on (`TS` ...0A), HOMING (1E) during `OR`, MOVING
(28) during `PA`, READY from HOMING (32) or from MOVING (33). A move takes the bench time
of a trapezoidal velocity profile at the axis's `VA` and `AC`, on the simulated clock; `TS`
reads MOVING until that time has passed. A command the controller refuses is silent and
leaves its letter for `TE` (SMC100 UM TE): H for a move NOT REFERENCED, M while MOVING, C
for a parameter missing or beyond the software limits `SL`/`SR`. The other commands of the
manual's set (`commands/smc100.tsv`: servo gains, jogging, the TTL port ...) are kept per
axis as state only.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from squeezebench.analysis.cartography import move_time_s
from squeezebench.simbench import command_tables
from squeezebench.simbench.device_base import SimulatedInstrument
from squeezebench.simbench.modeshape import shape_of

#: Assumed figures of a typical SMC100 stage (no datasheet survives for this bench).
TRAVEL_MM = {"1": (0.0, 300.0), "2": (0.0, 200.0)}
VELOCITY_MM_PER_S = 20.0
ACCELERATION_MM_PER_S2 = 80.0
REVISION = "SMC_CC - Controller-driver version 2.0.0"
#: Parameters read with `?` (PA?: the target of the last move); the other queries (TS, TP, VE) take no argument.
_PARAMETERS = ("SL", "SR", "VA", "AC", "PA")
_LINE = re.compile(r"^(\d{1,2})([A-Z]{2})(.*)$")
#: The manual's command set (command_tables); the commands below it are modelled, the
#: others kept per axis as state only (a KP gain tunes no servo here).
COMMANDS = {entry.header: entry for entry in command_tables.table("smc100")}
MODELLED = frozenset({"AC", "OR", "PA", "PR", "PT", "SL", "SR", "ST", "TE", "TH", "TP", "TS", "VA", "VE"})
#: Commands that answer without `?`: the reports, and PT (the time a move would take).
_ANSWERING = frozenset(code for code, entry in COMMANDS.items() if "report" in entry.forms) | {"PT"}


#: The replies of the queries the stage models, from an axis (a map polls TS some 80,000 times).
_QUERIES = {"TS": lambda axis: f"{0:04X}{axis.state}", "TP": lambda axis: f"{axis.position_mm:.6g}",
            "TH": lambda axis: f"{axis.target_mm if axis.state in ('1E', '28') else axis.position_mm:.6g}",
            "VE": lambda axis: f" {REVISION}", "SL": lambda axis: f"{axis.low_mm:g}",
            "SR": lambda axis: f"{axis.high_mm:g}", "VA": lambda axis: f"{axis.velocity_mm_per_s:g}",
            "AC": lambda axis: f"{axis.acceleration_mm_per_s2:g}", "PA": lambda axis: f"{axis.target_mm:.6g}"}


@dataclass
class Axis:
    low_mm: float
    high_mm: float
    position_mm: float = 0.0
    state: str = "0A"
    start_mm: float = 0.0
    target_mm: float = 0.0
    start_s: float = 0.0
    end_s: float = 0.0
    direction: int = 0   # of the last move: +1, -1 (0: never moved); backlash acts against it
    velocity_mm_per_s: float = VELOCITY_MM_PER_S
    acceleration_mm_per_s2: float = ACCELERATION_MM_PER_S2
    error: str = "@"
    stored: dict[str, str] = field(default_factory=dict)   # state-only parameters


class Stage(SimulatedInstrument):
    """SMC100 pair; `point_mm()` is where the stage holds the plate under the laser spot."""

    role = "stage"

    def power_on(self) -> None:
        self.axes = {address: Axis(*travel) for address, travel in TRAVEL_MM.items()}
        self.used = False   # a bench whose stage never moved measures where the scene says
        self._gain_key: tuple | None = None
        self._gain = 1.0
        self._shape_key: tuple | None = None   # (scene, state name) of `_shape`, the working mode's shape_of
        self._shape = None

    def leave(self, x_mm: float, y_mm: float, velocity_mm_per_s: float, error: str) -> None:
        """As a previous session may leave the pair (no power cycle): both axes READY at
        (x, y), x slowed, a refused command's letter unread. The plate is still mounted with
        its measurement point under the spot (`used` stays False)."""
        for axis, position in zip(self.axes.values(), (x_mm, y_mm)):
            axis.state, axis.position_mm = "32", position
        self.axes["1"].velocity_mm_per_s, self.axes["1"].error = velocity_mm_per_s, error

    def spot_gain(self) -> float:
        """Velocity along the beam under the laser spot / the scene's velocity, which is the
        working mode's at the scene's measurement point (`modeshape`); 0 off the plate. The
        stage frame is the plate's frame (its corner at the stage's zero) unless the scene
        names spot effects (`effects.EffectPipeline.spot`: backlash, offset, tilt). A stage
        that never moved costs nothing: 1, the scene's own measurement point."""
        if not self.used:
            return 1.0
        key = (self.point_mm(), tuple(axis.direction for axis in self.axes.values()), self.bench.state_name)
        if key != self._gain_key:   # a point is acquired many times (ranging, averaging)
            self._gain_key = key
            spot = self.bench.effects.spot(*key[:2])
            self._gain = spot.beam_share * float(self._mode_shape()(spot.x_mm, spot.y_mm))
        return self._gain

    def spot_gains(self, x_mm: np.ndarray, y_mm: np.ndarray) -> np.ndarray:
        """`spot_gain` at stage positions (x_mm, y_mm), arrays, each approached as the stage
        last moved (its axes' directions): the coverage study's truth over a map's cells reads
        some 350,000 spots a map (`bench_errors._map_homogeneities`), which a move each would
        take minutes to read. The spot effects and the mode's table take arrays as they come."""
        spot = self.bench.effects.spot((np.asarray(x_mm, dtype=float), np.asarray(y_mm, dtype=float)),
                                       tuple(axis.direction for axis in self.axes.values()))
        return spot.beam_share * self._mode_shape()(spot.x_mm, spot.y_mm)

    def _mode_shape(self):
        """The working mode's `shape_of` for the bench's scene and state, found again only when
        either changes (a cut, another plate mounted, a reseeded scene)."""
        scene = self.bench.scene
        if self._shape_key is None or self._shape_key[0] is not scene or self._shape_key[1] != self.bench.state_name:
            self._shape_key, self._shape = (scene, self.bench.state_name), shape_of(scene, self.bench.state)
        return self._shape

    def is_query(self, message: bytes) -> bool:
        match = _LINE.match(message.decode("ascii", errors="replace").strip())
        return match is not None and (match.group(3) == "?" or match.group(2) in _ANSWERING)

    def point_mm(self) -> tuple[float, float]:
        self._settle_all()
        return self.axes["1"].position_mm, self.axes["2"].position_mm

    def _settle_all(self) -> None:
        for axis in self.axes.values():
            self._settle(axis)

    def _settle(self, axis: Axis) -> None:
        """A move whose bench time has passed has ended: READY at the target."""
        if axis.state in ("1E", "28") and self.bench.clock.now_s() >= axis.end_s:
            axis.position_mm = axis.target_mm
            axis.state = "32" if axis.state == "1E" else "33"

    def handle(self, message: bytes) -> list:
        match = _LINE.match(message.decode("ascii", errors="replace").strip())
        if match is None or match.group(1) not in self.axes:
            return []   # another address or line noise: no controller answers
        address, command, argument = match.groups()
        axis = self.axes[address]
        self._settle(axis)
        reply = self._command(axis, command, argument)
        return [] if reply is None else [f"{address}{command}{reply}".encode() + b"\r"]

    def _command(self, axis: Axis, command: str, argument: str) -> str | None:
        if command == "TE":
            letter, axis.error = axis.error, "@"
            return letter
        if command in _QUERIES and argument in ("", "?") and (argument == "?") == (command in _PARAMETERS):
            return _QUERIES[command](axis)
        if command == "OR" and argument == "":
            self._home(axis)
        elif command == "PA":
            self._move(axis, argument)
        elif command == "PR":
            self._move(axis, argument, relative=True)
        elif command == "PT" and argument not in ("", "?"):
            displacement = _number(argument)
            if displacement is None:
                axis.error = "C"
                return None
            return f"{move_time_s(displacement, axis.velocity_mm_per_s, axis.acceleration_mm_per_s2):.6g}"
        elif command in ("VA", "AC") and argument not in ("", "?"):
            self._rate(axis, command, argument)
        elif command in ("SL", "SR") and argument not in ("", "?"):
            self._software_limit(axis, command, argument)
        elif command == "ST" and argument == "":
            self._stop(axis)
        else:
            return self._state_only(axis, command, argument)
        return None

    @staticmethod
    def _state_only(axis: Axis, command: str, argument: str) -> str | None:
        """A command of the manual's set that moves nothing here: stored per axis and read
        back (STATE ONLY); a number beyond the table's limits is refused with C."""
        entry = COMMANDS.get(command)
        if entry is None:
            axis.error = "A"   # SMC100 UM TE: unknown message code
        elif argument == "?" and entry.queryable:
            return axis.stored.get(command, entry.reply)
        elif argument == "" and "report" in entry.forms:
            return entry.reply
        elif entry.settable and argument != "?" and bool(argument) == bool(entry.arguments):
            value = _number(argument) if entry.limits else argument
            if value is None or (entry.limits and not entry.limits[0] <= value <= entry.limits[1]):
                axis.error = "C"
            elif argument:
                axis.stored[command] = f"{value:g}" if entry.limits else argument
        else:
            axis.error = "C"   # a parameter missing, or one the command does not take
        return None

    def _home(self, axis: Axis) -> None:
        if axis.state not in ("0A", "0B", "0C", "0D", "0E", "0F", "10"):
            axis.error = "K" if axis.state.startswith("3") else "D"
            return
        self._start(axis, "1E", axis.low_mm)

    def _move(self, axis: Axis, argument: str, relative: bool = False) -> None:
        target = _number(argument)
        if target is None:
            axis.error = "C"
            return
        if relative:
            target += axis.position_mm
        if axis.state not in ("32", "33", "34", "35"):
            axis.error = {"28": "M", "1E": "L"}.get(axis.state, "H")
        elif not axis.low_mm <= target <= axis.high_mm:
            axis.error = "C"
        else:
            self._start(axis, "28", target)

    def _start(self, axis: Axis, state: str, target_mm: float) -> None:
        now = self.bench.clock.now_s()
        self.used = True
        axis.state, axis.start_mm, axis.target_mm, axis.start_s = state, axis.position_mm, target_mm, now
        if target_mm != axis.position_mm:
            axis.direction = 1 if target_mm > axis.position_mm else -1
        axis.end_s = now + move_time_s(target_mm - axis.position_mm, axis.velocity_mm_per_s,
                                       axis.acceleration_mm_per_s2)

    @staticmethod
    def _rate(axis: Axis, command: str, argument: str) -> None:
        """VA (velocity) or AC (acceleration): positive; they shape the next move's profile."""
        value = _number(argument)
        if value is None or value <= 0:
            axis.error = "C"
        elif command == "VA":
            axis.velocity_mm_per_s = value
        else:
            axis.acceleration_mm_per_s2 = value

    @staticmethod
    def _software_limit(axis: Axis, command: str, argument: str) -> None:
        """SL/SR: the travel PA and PR may use; each stays on its side of the position."""
        value = _number(argument)
        if value is None or (value > axis.position_mm if command == "SL" else value < axis.position_mm):
            axis.error = "C"
        elif command == "SL":
            axis.low_mm = value
        else:
            axis.high_mm = value

    def _stop(self, axis: Axis) -> None:
        if axis.state in ("1E", "28"):
            span = max(axis.end_s - axis.start_s, 1e-12)
            done = min(1.0, (self.bench.clock.now_s() - axis.start_s) / span)
            axis.position_mm = axis.start_mm + done * (axis.target_mm - axis.start_mm)
            axis.state = "0E" if axis.state == "1E" else "33"   # a stopped homing leaves it NOT REFERENCED


def _number(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        return None
    return value if value == value and abs(value) != float("inf") else None
