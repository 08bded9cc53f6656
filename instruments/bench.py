"""The bench: its description (file or scene), opening it, checking it.

This is the one place that knows whether the bench is simulated. `open_bench` builds a
PyVISA ResourceManager over the library the configuration names:

- `"<scene.yaml>@simbench"`: simbench's simulated bench; the clock and the operator come
  from it (a request for a plate state switches the scene, no prompt);
- anything else (`""`, `"@py"`, a VISA library path): the real bench, with wall time and
  an operator prompted on the terminal; or, when the bench file names serve-sim's bench
  port (`simulator:`), the served simulated bench with its clock and plate changes
  (`instruments.served`).

The drivers never know which: they only see a PyVISA resource.

The amplifier (gain 20) and the current probe have no remote interface: `BenchElectronics`
holds what they do, and every conversion between generator and piezo voltage goes
through it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping

import pyvisa
import yaml
from pyvisa.errors import VisaIOError

from squeezebench.instruments.agilent33120a import Agilent33120A
from squeezebench.instruments.base import Instrument
from squeezebench.instruments.errors import (BenchFileError, BenchMismatch, InstrumentConnectionError, InstrumentError, InstrumentTimeout,
                                             OperatorUnavailable)
from squeezebench.instruments.ofv5000 import OFV5000
from squeezebench.instruments.served import ServedSimulator
from squeezebench.instruments.smc100 import SMC100Stage
from squeezebench.instruments.tds3054b import CHANNELS, TDS3054B
from squeezebench.yamlfiles import load_strict

ROLES = ("generator", "scope", "vibrometer")
#: Instruments only some protocols need (the x-y stage of a map): opened on first use.
OPTIONAL_ROLES = ("stage",)
DRIVERS: dict[str, type[Instrument]] = {"generator": Agilent33120A, "scope": TDS3054B, "vibrometer": OFV5000,
                                        "stage": SMC100Stage}
#: Addresses of the simulated bench (simbench.backend.RESOURCES).
SIM_RESOURCES = {"generator": "GPIB0::10::INSTR", "scope": "TCPIP0::192.168.0.20::INSTR",
                 "vibrometer": "ASRL1::INSTR", "stage": "ASRL2::INSTR"}
SIMBENCH = "@simbench"
GENERATOR_LOADS = ("50", "INF")
#: The 33120A's output impedance (User's Guide, specifications: 50 ohm, fixed).
GENERATOR_SOURCE_OHM = 50.0


@dataclass(frozen=True)
class BenchElectronics:
    """What is between and around the remote-controlled instruments."""

    amplifier_gain: float = 20.0               # NF HSA 4052 as used in the paper
    amplifier_max_output_vpp: float = 300.0    # +-150 V swing (bench value, not the paper's)
    shunt_ohm: float = 2.0
    voltage_probe_attenuation: float = 100.0   # 100:1 probe on CH1
    current_probe_a_per_a: float = 1.0         # TCP202 on CH2, read in amperes
    generator_load: str = "INF"                # the amplifier input is high impedance
    amplifier_input_ohm: float = 1e6           # assumed high-impedance input (not in the paper)

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name == "generator_load":
                if value not in GENERATOR_LOADS:
                    raise ValueError(f"generator_load must be one of {', '.join(GENERATOR_LOADS)}, got {value!r}")
            elif isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value < float("inf"):
                raise ValueError(f"{f.name} must be a positive number, got {value!r}")

    @property
    def voltage_probe_gain(self) -> float:
        """CH1's probe gain (output/input) for the voltage probe."""
        return 1.0 / self.voltage_probe_attenuation

    @property
    def piezo_vpp_per_generator_vpp(self) -> float:
        """Piezo Vpp per displayed generator Vpp, through the whole chain. The 33120A
        scales its source so the displayed Vpp appears across the load it is told about
        (OUTP:LOAD) through its 50 ohm output: its open-circuit voltage is the displayed
        value times 1 + 50/load setting (x2 with LOAD 50, x1 with INF). The amplifier's
        input impedance and the 50 ohm divide that; the amplifier multiplies by its gain."""
        load_setting_ohm = float(self.generator_load) if self.generator_load != "INF" else float("inf")
        open_circuit = 1.0 + GENERATOR_SOURCE_OHM / load_setting_ohm
        divider = self.amplifier_input_ohm / (self.amplifier_input_ohm + GENERATOR_SOURCE_OHM)
        return self.amplifier_gain * open_circuit * divider

    def piezo_vpp_for_generator_vpp(self, generator_vpp: float) -> float:
        return self.piezo_vpp_per_generator_vpp * generator_vpp

    def generator_vpp_for_piezo_vpp(self, piezo_vpp: float) -> float:
        return piezo_vpp / self.piezo_vpp_per_generator_vpp


@dataclass(frozen=True)
class BenchConfig:
    """Which VISA library, which address for each role, which electronics."""

    visa_library: str
    resources: Mapping[str, str]
    electronics: BenchElectronics = field(default_factory=BenchElectronics)
    source: str | None = None   # the file it was read from, for messages
    simulator: str | None = None   # serve-sim's bench port: a served bench's clock and operator
    stage_travel_mm: Mapping[str, tuple[float, float]] | None = None   # per axis, as the bench file states it


# -- bench files ------------------------------------------------------------------------------------
_ELECTRONICS_FIELDS = tuple(f.name for f in dataclasses.fields(BenchElectronics))


def _read_yaml(path: Path) -> Any:
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise BenchFileError(path, "file", f"cannot be read ({exc.strerror or exc})") from None
    try:
        return load_strict(text)   # the campaigns' loader: a key given twice is refused
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        raise BenchFileError(path, "YAML", f"not valid YAML{where}: {getattr(exc, 'problem', exc)}") from None


def _electronics(path: Path, section: Any, field_prefix: str) -> BenchElectronics:
    """BenchElectronics from a scene's `electronics:` mapping; keys it does not know are
    the simulator's (simbench validates the scene)."""
    if section is None:
        return BenchElectronics()
    if not isinstance(section, dict):
        raise BenchFileError(path, field_prefix, f"must be a mapping of {', '.join(_ELECTRONICS_FIELDS)}")
    values = {}
    for key, value in section.items():
        if key not in _ELECTRONICS_FIELDS:
            continue
        if key == "generator_load":
            value = str(value).upper()
            if value not in GENERATOR_LOADS:
                raise BenchFileError(path, f"{field_prefix}.{key}",
                                     f"{section[key]!r} is not allowed (allowed: {', '.join(GENERATOR_LOADS)})")
        elif isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value < float("inf"):
            raise BenchFileError(path, f"{field_prefix}.{key}",
                                 f"{value!r} is not allowed (allowed: a positive number)")
        values[key] = float(value) if key != "generator_load" else value
    return BenchElectronics(**values)


def sim_bench_config(scene_path: str | Path, start: str | None = None) -> BenchConfig:
    """The simulated bench of a scene: its `electronics:` section, the default addresses;
    `start` names the instruments' state when it opens (`simbench.devices.start_state`,
    power-on by default)."""
    path = Path(scene_path)
    scene = _read_yaml(path)
    if not isinstance(scene, dict):
        raise BenchFileError(path, "top level", "must be a mapping (a scene file)")
    fragment = f"#start={start}" if start else ""
    return BenchConfig(visa_library=f"{path}{fragment}{SIMBENCH}", resources=dict(SIM_RESOURCES),
                       electronics=_electronics(path, scene.get("electronics"), "electronics"),
                       source=str(path))


# -- clock and operator -----------------------------------------------------------------------------
class WallClock:
    """Bench time is wall time (seconds since the bench was opened)."""

    def __init__(self) -> None:
        self._start = time.monotonic()

    def now_s(self) -> float:
        return time.monotonic() - self._start

    def sleep(self, seconds: float) -> None:
        time.sleep(max(0.0, float(seconds)))


class TerminalOperator:
    """A person at the bench: prints what to do and waits for Enter."""

    def __init__(self, out: Callable[[str], None] = print, wait: Callable[[str], Any] = input) -> None:
        self._out = out
        self._wait = wait

    def request(self, instruction: str, state: str | None = None) -> None:
        self._out(instruction if state is None else f"{instruction} (plate state: {state})")
        try:
            self._wait("Press Enter when done. ")
        except EOFError:   # nobody can press Enter: stop cleanly, resumable, instead of a traceback
            raise OperatorUnavailable(instruction, state) from None

    def mount(self, scene_or_plate: str | Path) -> None:
        self.request(f"Mount plate {Path(str(scene_or_plate)).stem} on the bench.")

    def already_done(self, instruction: str, state: str | None = None) -> None:
        """The person did it before the run resumed (`run --resume --operator-done`)."""
        self._out(f"{instruction}: done before this resume (--operator-done)")


class SimulatedOperator:
    """The simulated bench does what is asked at once: switch the plate state, mount a scene."""

    def __init__(self, simulated_bench: Any) -> None:
        self._bench = simulated_bench

    def request(self, instruction: str, state: str | None = None) -> None:
        if state is not None:
            self._bench.set_state(state)

    def mount(self, scene_or_plate: str | Path) -> None:
        self._bench.mount(scene_or_plate)

    def already_done(self, instruction: str, state: str | None = None) -> None:
        self.request(instruction, state)


class ConfirmedOperator:
    """The bench's operator, with the one request a run stopped on (no terminal to confirm
    it) answered beforehand: asked again for exactly that, it is taken as done, once; any
    other request goes to the operator as always."""

    def __init__(self, operator: Any, instruction: str, state: str | None) -> None:
        self._operator, self._pending = operator, (instruction, state)

    def request(self, instruction: str, state: str | None = None) -> None:
        if (instruction, state) == self._pending:
            self._pending = None
            self._operator.already_done(instruction, state)
        else:
            self._operator.request(instruction, state)

    def mount(self, scene_or_plate: str | Path) -> None:
        self._operator.mount(scene_or_plate)

    @property
    def answered(self) -> bool:
        return self._pending is None


# -- opening ---------------------------------------------------------------------------------------
class Bench:
    """The opened bench; close it (or use it as a context manager) to release the instruments."""

    def __init__(self, config: BenchConfig, resource_manager: pyvisa.ResourceManager,
                 drivers: dict[str, Instrument], clock: Any, operator: Any) -> None:
        self.config = config
        self.electronics = config.electronics
        self.generator: Agilent33120A = drivers["generator"]
        self.scope: TDS3054B = drivers["scope"]
        self.vibrometer: OFV5000 = drivers["vibrometer"]
        self.drivers = drivers
        self.clock = clock
        self.operator = operator
        self.resource_manager = resource_manager

    def identify(self) -> dict[str, str]:
        return {role: driver.identification for role, driver in self.drivers.items()}

    @property
    def stage(self) -> SMC100Stage:
        """The x-y stage, opened when a protocol first asks for it: a bench without one
        runs every protocol but a map. Its waits are the bench's (bench time when simulated)."""
        if "stage" not in self.drivers:
            address = self.config.resources.get("stage")
            if address is None:
                raise InstrumentConnectionError("stage", "(none)", "this protocol needs an x-y stage; add "
                                                f"resources.stage to the bench file (e.g. {SIM_RESOURCES['stage']})")
            driver = _open_role(self.resource_manager, "stage", address,
                                self.clock if isinstance(self.clock, ServedSimulator) else None)
            driver.clear_status()
            driver.sleep = self.clock.sleep
            self.drivers["stage"] = driver   # closed with the bench, whatever follows
            problem = stated_travel_problem(self.config.stage_travel_mm, driver)
            if problem:
                raise BenchMismatch("stage", address, problem)
        return self.drivers["stage"]

    def check_errors(self) -> None:
        """Drain the generator's and the scope's error queues (the vibrometer keeps none):
        InstrumentError with the instrument's own code and message for the first error."""
        for driver in (self.generator, self.scope):
            driver.check_errors()

    def settings_snapshot(self) -> dict[str, dict[str, Any]]:
        return {role: driver.settings_snapshot() for role, driver in self.drivers.items()}

    def close(self) -> None:
        self.resource_manager.close()

    def __enter__(self) -> Bench:
        return self

    def __exit__(self, *exc_info: Any) -> None:
        self.close()


def _library_path(visa_library: str) -> str:
    """A simulated bench gets a unique path: PyVISA keeps one library per path, and each
    bench must start from its scene, not from another bench's state."""
    if visa_library.endswith(SIMBENCH):
        return f"{visa_library[:-len(SIMBENCH)]}#{uuid.uuid4().hex}{SIMBENCH}"
    return visa_library


def _resource_manager(library: str) -> pyvisa.ResourceManager:
    """`""` is the system VISA library (`@ivi`: NI-VISA, Keysight), never PyVISA's fallback
    to pyvisa-py when there is none: a bench file says `"@py"` to use pyvisa-py."""
    try:
        return pyvisa.ResourceManager(library or "@ivi")
    except (OSError, ValueError, VisaIOError) as exc:
        reason = " ".join(str(exc).split()).rstrip(":")   # PyVISA's own may end in an empty detail
        hint = "" if library else ' (NI-VISA or Keysight IO Libraries; visa_library: "@py" uses pyvisa-py)'
        raise InstrumentConnectionError("bench", library or "(system VISA library)",
                                        f"cannot load the VISA library: {reason}{hint}") from None


def _open_role(resource_manager: pyvisa.ResourceManager, role: str, address: str,
               served: ServedSimulator | None = None) -> Instrument:
    """The role's driver, connected and identified, or InstrumentConnectionError. A served
    instrument's timeouts get serve-sim's allowance for the simulator's own computing."""
    try:
        resource = resource_manager.open_resource(address)
        if served is not None:
            served.allow_computing(resource)
    except (VisaIOError, ValueError) as exc:
        reason = exc.description if isinstance(exc, VisaIOError) else str(exc)
        raise InstrumentConnectionError(role, address, f"no instrument at this address ({reason})") from None
    try:
        driver = DRIVERS[role](resource, role)
        driver.identify()
        return driver
    except InstrumentConnectionError as exc:
        resource.close()
        raise InstrumentConnectionError(role, address, exc.reason) from None
    except InstrumentTimeout as exc:
        resource.close()
        raise InstrumentConnectionError(role, address, f"no answer to {exc.operation}") from None
    except InstrumentError as exc:
        resource.close()
        raise InstrumentConnectionError(role, address, exc.message) from None


@contextlib.contextmanager
def generator_only(config: BenchConfig) -> Iterator[Agilent33120A]:
    """The generator of `config` alone, its load setting the bench's (nothing else is
    opened or touched: for bringing it to rest, `protocols.drive_record`)."""
    resource_manager = _resource_manager(_library_path(config.visa_library))
    try:
        generator = _open_role(resource_manager, "generator", config.resources["generator"])
        generator.output_load = config.electronics.generator_load
        yield generator
    finally:
        resource_manager.close()


def is_simulated(config: BenchConfig) -> bool:
    return config.visa_library.endswith(SIMBENCH)


def open_bench(config: BenchConfig) -> Bench:
    """Open every instrument of `config`; InstrumentConnectionError names the first role
    that does not answer (nothing stays open then)."""
    library = _library_path(config.visa_library)
    resource_manager = _resource_manager(library)
    try:
        # a served bench starts afresh before its instruments open, as a simulated one does
        served = ServedSimulator(resource_manager, config.simulator) if config.simulator else None
        drivers = {role: _open_role(resource_manager, role, config.resources[role], served) for role in ROLES}
        for role in ("generator", "scope"):   # status a previous session left is not this run's
            drivers[role].clear_status()
        # The load setting belongs to what the generator drives (the amplifier input), not
        # to a protocol: with the wrong one every programmed amplitude is off by two.
        drivers["generator"].output_load = config.electronics.generator_load
        if is_simulated(config):
            simulated = resource_manager.visalib.bench
            clock, operator = simulated.clock, SimulatedOperator(simulated)
        elif served is not None:
            clock = operator = served
        else:
            clock, operator = WallClock(), TerminalOperator()
    except BaseException:
        resource_manager.close()
        raise
    return Bench(config, resource_manager, drivers, clock, operator)


# -- checking ---------------------------------------------------------------------------------------
#: What `check_bench` shows of each instrument.
MAIN_SETTINGS = {
    "generator": ("shape", "frequency_hz", "amplitude_vpp", "offset_v", "output_load"),
    "scope": ("horizontal_scale_s_per_div", "record_length", "acquire_mode", "num_averages", "trigger_source",
              "math_type", "math_definition"),
    "vibrometer": ("decoder", "velocity_range", "low_pass_filter", "high_pass_filter", "tracking_filter"),
    "stage": (),
}


def _stale_errors(driver: Instrument) -> list[tuple[int, str]]:
    """Read and clear what the instrument has queued (the vibrometer keeps no queue)."""
    if isinstance(driver, Agilent33120A):
        return driver.read_errors()
    if isinstance(driver, TDS3054B):
        return [event for event in driver.read_events() if event[0] not in (0, 1)]
    if isinstance(driver, SMC100Stage):
        return [("TE", letter) for letter in driver.clear_status()]
    return []


def _report_lines(role: str, driver: Instrument, config: BenchConfig) -> tuple[list[str], list[str], dict[str, Any]]:
    """(lines to show, disagreements between the bench description and the hardware, the
    settings read as typed values, names with their units as everywhere in squeezebench)."""
    electronics = config.electronics
    stale = _stale_errors(driver)
    lines = [f"    cleared {len(stale)} queued event(s): " + "; ".join(f"{c},{m!r}" for c, m in stale)] if stale \
        else ["    no queued errors"]
    settings: dict[str, Any] = {name: getattr(driver, name) for name in MAIN_SETTINGS[role]}
    lines += [f"    {name} = {value!r}" for name, value in settings.items()]
    problems = []
    if isinstance(driver, TDS3054B):
        expected = {1: electronics.voltage_probe_gain, 2: electronics.current_probe_a_per_a}
        for number in CHANNELS:
            ch = driver.channel(number)
            settings[f"ch{number}"] = {"displayed": ch.displayed, "probe_gain": ch.probe_gain,
                                       "scale_v_per_div": ch.scale_v_per_div, "coupling": ch.coupling,
                                       "impedance": ch.impedance, "offset": ch.offset}
            lines.append(f"    ch{number}: " + ", ".join(f"{name} = {value!r}"
                                                          for name, value in settings[f"ch{number}"].items()))
        for number, (model, gain, unit) in driver.detected_probes().items():
            lines.append(f"    ch{number}: detected probe {model}, gain {gain:g}, unit {unit}")
        # Each probe the bench file names, offered to the scope as a run's open does: a
        # detected or coded probe with another gain is refused there, so here too.
        for number, gain in expected.items():
            try:
                driver.channel(number).use_probe(gain)
            except BenchMismatch as exc:
                problems.append(f"scope {exc.message} (electronics."
                                f"{'voltage_probe_attenuation' if number == 1 else 'current_probe_a_per_a'})")
    if isinstance(driver, Agilent33120A) and (load := driver.output_load) != electronics.generator_load:
        # A setting, not hardware: a previous user's, which every run's open replaces.
        lines.append(f"    output_load {load!r} differs from the bench description's generator_load "
                     f"{electronics.generator_load!r}: a run sets {electronics.generator_load!r} when it opens")
    if isinstance(driver, Agilent33120A):
        # The connection turned every modulation off; one still on is a generator that
        # does not do what it is told, and a run would drive the plate with it.
        settings["modulations_on"] = driver.modulations_on()
        lines.append(f"    modulations on: {', '.join(settings['modulations_on']) or 'none'}")
        if settings["modulations_on"]:
            problems.append(f"generator modulation {', '.join(settings['modulations_on'])} still on after "
                            f"the connection turned it off")
    if isinstance(driver, OFV5000):
        settings["velocity_range_mps_per_v"] = driver.velocity_range_mps_per_v
        settings["decoder_ranges_mps_per_v"] = dict(driver.ranges_mps_per_v)
        lines.append("    decoder ranges: " + ", ".join(driver.ranges_mps_per_v))
    if isinstance(driver, SMC100Stage):
        for axis in ("x", "y"):   # read once, shown and returned
            settings[axis] = driver.axis_settings(axis)
            lines.append(f"    {driver.describe_axis(axis, settings[axis])}")
        travel = stated_travel_problem(config.stage_travel_mm, driver)
        if travel:
            problems.append(f"stage {travel}")
    return lines, problems, settings


@dataclass
class InstrumentCheck:
    """What `inspect_bench` found of one instrument."""

    role: str
    address: str
    answered: bool
    identification: str = ""
    details: list[str] = field(default_factory=list)   # queued errors, settings, probes, ranges
    settings: dict[str, Any] = field(default_factory=dict)   # typed, units in the names
    error: str = ""                                     # why it did not answer


@dataclass
class BenchCheck:
    """What `inspect_bench` found of the whole bench (`check --json` prints `as_dict`)."""

    visa_library: str
    instruments: list[InstrumentCheck] = field(default_factory=list)
    electronics: dict[str, Any] = field(default_factory=dict)
    disagreements: list[str] = field(default_factory=list)   # bench description vs hardware
    visa_error: str = ""                                      # the VISA library did not load

    @property
    def passed(self) -> bool:
        return not self.visa_error and not self.disagreements and all(i.answered for i in self.instruments)

    def as_dict(self) -> dict[str, Any]:
        return {**dataclasses.asdict(self), "passed": self.passed}


def stated_travel_problem(stated: Mapping[str, tuple[float, float]] | None, stage: SMC100Stage) -> str | None:
    """Where the bench file states more travel than the controllers' limits (SMC100 UM
    SL/SR; None if it does not): `validate` passed a map against the file's figure."""
    for axis, (low, high) in (stated or {}).items():
        reported = stage.travel_mm[axis]
        if low < reported[0] or high > reported[1]:
            return (f"the bench file states the {axis} travel {low:g} to {high:g} mm, the controller's limits "
                    f"(SL, SR) are {reported[0]:g} to {reported[1]:g} mm: correct stage_travel_mm")
    return None


def inspect_bench(config: BenchConfig, out: Callable[[str], None] = print) -> BenchCheck:
    """Open every instrument (the stage too when the bench names one); say its role,
    address, identification, the errors it had queued (read and cleared), main settings,
    detected probes, the vibrometer decoder with its ranges and the stage's axes (state,
    position, travel; nothing moves), line by line through `out`; return all of it as a `BenchCheck`, which
    names each role that did not answer and each disagreement between the bench
    description and the hardware."""
    result = BenchCheck(config.visa_library or "(system default)")
    out(f"VISA library: {result.visa_library}")
    library = _library_path(config.visa_library)
    try:
        resource_manager = _resource_manager(library)
    except InstrumentConnectionError as exc:
        result.visa_error = str(exc)
        out(result.visa_error)
        return result
    try:
        for role in (*ROLES, *(r for r in OPTIONAL_ROLES if config.resources.get(r))):
            address = config.resources[role]
            try:
                driver = _open_role(resource_manager, role, address)
                lines, disagreements, settings = _report_lines(role, driver, config)
            except InstrumentError as exc:
                result.instruments.append(InstrumentCheck(role, address, False, error=exc.message))
                out(f"{role} at {address} did not answer as expected: {exc.message}")
                continue
            result.instruments.append(InstrumentCheck(role, address, True, driver.identification,
                                                      [line.strip() for line in lines], settings))
            out(f"{role} at {address}: {driver.identification}")
            for line in lines:
                out(line)
            result.disagreements += disagreements
    finally:
        resource_manager.close()
    e = config.electronics
    result.electronics = dataclasses.asdict(e)
    out(f"electronics (not remote-controlled): amplifier gain {e.amplifier_gain:g} "
        f"(max {e.amplifier_max_output_vpp:g} Vpp out), voltage probe {e.voltage_probe_attenuation:g}:1, "
        f"current probe {e.current_probe_a_per_a:g} A/A, shunt {e.shunt_ohm:g} ohm, "
        f"generator load setting {e.generator_load}")
    for problem in result.disagreements:
        out(f"bench description disagrees with the hardware: {problem}")
    failed = [i.role for i in result.instruments if not i.answered]
    if not result.passed:
        causes = ([f"{', '.join(failed)} did not answer"] if failed else []) + \
            (["the bench description disagrees with the hardware"] if result.disagreements else [])
        out(f"bench check FAILED: {'; '.join(causes)}")
    else:
        out("bench check passed")
    return result


def check_bench(config: BenchConfig, out: Callable[[str], None] = print) -> int:
    """`inspect_bench`'s verdict as an exit code: 0, or 2 when anything failed."""
    return 0 if inspect_bench(config, out).passed else 2
