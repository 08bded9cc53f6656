"""Campaigns: a YAML list of protocol runs, run step by step, crash-safe and resumable.

A campaign file (see data/campaigns/paper.yaml):

    name: paper                        # default: the file's stem
    output_dir: runs/paper             # default: runs/<name>, relative to the working dir
    bench: {scene: one_column_1mm.yaml}   # or {file: lab_bench.yaml}; default for runs
    acquisition: {averages: 16, ...}   # protocols.acquisition.AcquisitionSettings
    safety: {max_piezo_voltage_vpp: 100, ...}   # protocols.safety.SafetyLimits
    runs:
      - name: fig2a_one_column         # letters, digits, '_', '-', '.'; unique
        protocol: detuning             # see PROTOCOLS
        bench: {scene: ...}            # optional, replaces the campaign's
        plate: {n_powered_columns: 1, n_powered_piezos: 4}   # name: default scene stem
        acquisition: {...}             # optional, merged over the campaign's
        safety: {...}                  # optional, merged over the campaign's
        parameters: {...}              # the protocol's Parameters

Scenes are looked up next to the campaign file, then in `squeezebench.paths.scenes_dir()`
(absolute paths are kept);
bench files relative to the campaign file. Every error names the file, the field and
what is allowed, as a CampaignError (a UserError: one message, exit status 2).

Running: each run opens its bench, wraps the generator in a DriveController (generator at
its minimum on any exit) and executes its steps in order. A step's rows, waveforms and
journal line are stored by protocols.storage; `resume=True` skips the steps in the
journal and rebuilds each run's context from their journal lines.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as dt
import logging
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from pydantic import ValidationError
from tqdm import tqdm

from squeezebench import paths, schemas
from squeezebench.instruments.agilent33120a import AMPLITUDE_RANGE_VPP, FREQUENCY_RANGE_HZ
from squeezebench.instruments.bench import ConfirmedOperator, open_bench, sim_bench_config
from squeezebench.instruments.errors import OperatorUnavailable, OutOfRangeError
from squeezebench.instruments.tds3054b import HORIZONTAL_DIVISIONS, HORIZONTAL_SCALES_S_PER_DIV
from squeezebench.protocols.acquisition import Acquisition, AcquisitionSettings
from squeezebench.protocols.drive_record import DriveRecord, bring_to_rest
from squeezebench.protocols.safety import DriveController, MeasuredVoltageError, SafetyLimits, chain_warnings
from squeezebench.protocols.steps import Plate, Step, StepContext
from squeezebench.protocols.storage import RunStore, bench_provenance, sha256_file
from squeezebench.terminal import bar_width
from squeezebench.stops import deferred, generator_state, handled, raise_if_stopped
from squeezebench.errors import UserError
from squeezebench.schemas import PROTOCOLS

log = logging.getLogger(__name__)

#: Loggers whose records go to the run's log.txt.
_LOGGED_PACKAGES = ("squeezebench.protocols", "squeezebench.instruments")


class CampaignError(UserError):
    """A malformed campaign file, or a campaign that does not fit its run directory."""

    def __init__(self, file: Path, field: str | None, message: str):
        where = f"{file}: field '{field}'" if field else f"{file}"
        super().__init__(f"{where}: {message}")


class SettingRefused(UserError):
    """A step asked an instrument for a setting outside its range (nothing was sent)."""


# -- the campaign as loaded --------------------------------------------------------------
@dataclass(frozen=True)
class BenchChoice:
    scene: Path | None = None   # the simulated bench with this scene
    file: Path | None = None    # a bench file with real addresses

    def config(self):
        return sim_bench_config(self.scene) if self.scene else schemas.load_bench_file(self.file)

    @property
    def input_file(self) -> Path:
        return self.scene or self.file


@dataclass(frozen=True)
class Run:
    name: str
    protocol: str
    bench: BenchChoice
    plate: Plate
    acquisition: AcquisitionSettings
    safety: SafetyLimits
    parameters: Any

    def steps(self) -> list[Step]:
        return PROTOCOLS[self.protocol].plan(self.parameters, self.plate)

    def input_files(self) -> list[Path]:
        """The bench's scene or file and every scene a step mounts."""
        return list(dict.fromkeys([self.bench.input_file, *_scenes_in(self.parameters)]))


@dataclass(frozen=True)
class Campaign:
    file: Path
    name: str
    output_dir: Path
    runs: tuple[Run, ...]

    def powers_off_resonance_without_deskew(self) -> list[str]:
        """The detuning runs that read powers off resonance (detuned, regained, stress points,
        power factor far below one) in a campaign without a deskew_calibration run: their
        U carries the current probe's lag as a bias bound, which a deskew run would measure
        and shrink (analysis.uncertainty.needs_deskew counts them once measured)."""
        if any(run.protocol == "deskew_calibration" for run in self.runs):
            return []
        return [run.name for run in self.runs if run.protocol == "detuning" and (
            run.parameters.velocity_ratios or run.parameters.stress_frequency_hz is not None)]


def _scenes_in(value: Any) -> list[Path]:
    if isinstance(value, Path):
        return [value]
    if dataclasses.is_dataclass(value):
        return [p for f in dataclasses.fields(value) for p in _scenes_in(getattr(value, f.name))]
    if isinstance(value, tuple):
        return [p for item in value for p in _scenes_in(item)]
    return []


def mapped_scenes(path: Path) -> list[Path]:
    """The scenes the campaign's maps (protocol 'cartography') scan on the simulated bench."""
    return list(dict.fromkeys(run.bench.scene for run in load_campaign(path).runs
                              if run.protocol == "cartography" and run.bench.scene is not None))


def characterised_scenes(path: Path) -> list[Path]:
    """The scenes of the plates the campaign's characterisation runs measure on the simulated
    bench (a run's report predicts each one's Q and tan theta' from its working mode)."""
    return list(dict.fromkeys(scene for run in load_campaign(path).runs if run.protocol == "characterisation"
                              and run.bench.scene is not None for scene in run.input_files()))


def load_campaign(path: Path, bench_file: Path | None = None) -> Campaign:
    """Read and validate a campaign file, every scene and bench file it uses, and every
    voltage, frequency and count it will request (before any bench opens); every
    problem is one CampaignError (or the scene's or bench file's own error). With
    `bench_file`, every run is on that bench (`run --bench`); its scene stays the plate's."""
    path = Path(path)
    model = _campaign_model(path)
    loader = _Loader(path, bench_file)
    name = model.name or path.stem
    problem = schemas.file_name_problem(name)
    if problem:
        raise CampaignError(path, "name", f"{problem} (the file's stem by default); give the campaign a 'name'")
    runs = tuple(loader.run(item, f"runs[{i}]") for i, item in enumerate(model.runs))
    for i, run in enumerate(runs):   # every name that becomes a file, before any bench opens
        steps = run.steps()
        if not steps:
            raise CampaignError(path, f"runs[{i}]", "has no step to measure (an empty list?); give it "
                                "at least one or remove the run")
        for step in steps:
            problem = schemas.file_name_problem(step.step_id) or (
                schemas.file_name_problem(step.plate.name) if step.plate.name else None)
            if problem:
                raise CampaignError(path, f"runs[{i}]", f"step or plate name {problem}")
    names = [run.name for run in runs]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise CampaignError(path, "runs", f"run names must be unique; repeated: {', '.join(duplicates)}")
    for i, run in enumerate(runs):
        check_requests(path, run, f"runs[{i}]")
    return Campaign(path, name, Path(model.output_dir or f"runs/{name}"), runs)


def _campaign_model(path: Path) -> schemas.CampaignFile:
    """The file as the schema reads it; any problem is one CampaignError."""
    try:
        return schemas.validated(schemas.CampaignFile, schemas.read_yaml(path))
    except schemas.FileFormatError as exc:
        raise CampaignError(path, None, str(exc).removeprefix(f"{path}: ")) from None
    except ValidationError as exc:
        raise CampaignError(path, *schemas.describe(exc, schemas.CampaignFile)) from None


def planned_steps(path: Path) -> list[tuple[str, str]]:
    """(run, step) of every step a campaign file plans, in order, read from the file alone
    (a run directory's copy: its scenes and bench file are not looked for)."""
    return [(item.name, step.step_id) for item in _campaign_model(Path(path)).runs
            for step in PROTOCOLS[item.protocol].plan(item.parameters, item.plate)]


class _Loader:
    """Turns a validated run into a Run: scenes and bench files found and validated."""

    def __init__(self, file: Path, bench_file: Path | None = None):
        self.file = file
        self.scenes: dict[Path, None] = {}
        self.bench_file = bench_file

    def run(self, item: Any, field: str) -> Run:
        if self.bench_file is not None:
            bench = self.given_bench(self.bench_file)
        elif item.bench is None:
            raise CampaignError(self.file, f"{field}.bench", "is missing (and the campaign has no default bench)")
        else:
            bench = self.bench(item.bench, f"{field}.bench")
        return Run(name=item.name, protocol=item.protocol, bench=bench,
                   plate=self.with_scenes(item.plate, f"{field}.plate"),
                   acquisition=item.acquisition, safety=item.safety,
                   parameters=self.with_scenes(item.parameters, f"{field}.parameters"))

    def bench(self, choice: Any, field: str) -> BenchChoice:
        if choice.scene is not None:
            return BenchChoice(scene=self.scene(choice.scene, f"{field}.scene"))
        file = Path(choice.file)
        file = file if file.is_absolute() else self.file.parent / file
        if not file.is_file():
            raise CampaignError(self.file, f"{field}.file", f"{file} does not exist")
        try:
            schemas.load_bench_file(file)
        except UserError as exc:   # the bench file's own error, and where the campaign names it
            raise CampaignError(self.file, f"{field}.file", str(exc)) from None
        return BenchChoice(file=file)

    @staticmethod
    def given_bench(file: Path) -> BenchChoice:
        """`run --bench FILE`: relative to the working directory, as a command line's paths are."""
        if not file.is_file():
            raise CampaignError(file, None, "the bench file given with --bench does not exist")
        schemas.load_bench_file(file)   # its own error names file and field
        return BenchChoice(file=file.resolve())

    def scene(self, value: str, field: str) -> Path:
        """A relative scene path is the user's file next to the campaign first, then a shipped one."""
        scene = Path(value)
        if not scene.is_absolute():
            beside = self.file.parent / scene
            scene = beside.resolve() if beside.is_file() else paths.scenes_dir() / scene
        if not scene.is_file():
            known = sorted(p.name for p in paths.scenes_dir().glob("*.yaml"))
            raise CampaignError(self.file, field, f"no scene {scene}; available in {paths.scenes_dir()}: "
                                f"{', '.join(known)}")
        if scene not in self.scenes:
            try:
                schemas.check_scene(scene)
            except UserError as exc:   # the scene's own error, and where the campaign names it
                raise CampaignError(self.file, field, str(exc)) from None
            self.scenes[scene] = None
        return scene

    def with_scenes(self, value: Any, field: str) -> Any:
        """`value` with every scene path (a plate a step mounts) found and validated."""
        if isinstance(value, Path):
            return self.scene(str(value), field)
        if dataclasses.is_dataclass(value):
            changed = {}
            for f in dataclasses.fields(value):
                old = getattr(value, f.name)
                new = self.with_scenes(old, f"{field}.{f.name}")
                if new is not old and f.init:
                    changed[f.name] = new
            return dataclasses.replace(value, **changed) if changed else value
        if isinstance(value, tuple):
            items = tuple(self.with_scenes(item, f"{field}[{i}]") for i, item in enumerate(value))
            return items if any(a is not b for a, b in zip(items, value)) else value
        return value


#: Upper bounds on counts a campaign may request (beyond them a typo, not a plan).
MAX_COUNTS = {"points": 2001, "max_iterations": 100, "max_ranging_attempts": 32}
#: Lower bounds on steps: below them a ramp or a search never ends in bench time.
MIN_STEP_HZ = 0.01
MIN_RAMP_STEP_VPP = 0.1
#: Frequency fields that are steps or widths, not frequencies the generator is set to.
_FREQUENCY_STEPS = ("tolerance_hz", "tracking_step_hz", "first_detuning_hz")
#: Longest wait a campaign may ask for in one setting (s).
MAX_WAIT_S = 600.0


def check_requests(file: Path, run: Run, field: str) -> None:
    """Every voltage, frequency, count, step and wait the run will request, against the
    run's limits and the instruments' ranges, before any bench opens. Voltages a protocol
    derives while running (a detuning's regain) stay checked by the DriveController."""
    electronics = run.bench.config().electronics
    generator_max_vpp = AMPLITUDE_RANGE_VPP[electronics.generator_load][1]
    limits = [(run.safety.max_piezo_voltage_vpp, f"the run's limit ({field}.safety.max_piezo_voltage_vpp)"),
              (electronics.amplifier_max_output_vpp, "the amplifier's maximum output"),
              (electronics.piezo_vpp_for_generator_vpp(generator_max_vpp),
               f"what the generator's {generator_max_vpp:g} Vpp maximum gives through the amplifier")]
    # Sanity bounds: a limit above what the amplifier can deliver protects nothing (1e9 Vpp
    # was accepted), and a step of half its swing or more is no ramp (397 Vpp was accepted).
    if run.safety.max_piezo_voltage_vpp > electronics.amplifier_max_output_vpp:
        raise CampaignError(file, f"{field}.safety.max_piezo_voltage_vpp",
                            f"{run.safety.max_piezo_voltage_vpp:g} Vpp is above the amplifier's maximum output, "
                            f"{electronics.amplifier_max_output_vpp:g} Vpp: a limit must be one the bench can reach")
    if run.safety.ramp_step_vpp >= electronics.amplifier_max_output_vpp / 2:
        raise CampaignError(file, f"{field}.safety.ramp_step_vpp",
                            f"{run.safety.ramp_step_vpp:g} Vpp is half the amplifier's maximum output "
                            f"({electronics.amplifier_max_output_vpp:g} Vpp) or more: that is no ramp")
    if run.safety.ramp_step_vpp < MIN_RAMP_STEP_VPP:
        raise CampaignError(file, f"{field}.safety.ramp_step_vpp",
                            f"{run.safety.ramp_step_vpp!r} Vpp is below the smallest ramp step, {MIN_RAMP_STEP_VPP} Vpp")
    waits = {"safety.ramp_dwell_s": run.safety.ramp_dwell_s, "acquisition.settle_s": run.acquisition.settle_s}
    counts = {"acquisition.max_ranging_attempts": run.acquisition.max_ranging_attempts}
    for name, value in [*waits.items(), *counts.items()]:
        _check_value(file, f"{field}.{name}", name.split(".")[-1], value, limits)
    for where, name, value in _leaves(run.parameters, f"{field}.parameters"):
        _check_value(file, where, name, value, limits)
    # The record must fit on the scope's slowest time base at the lowest frequency asked.
    frequencies_hz = [value for _, name, value in _leaves(run.parameters, "")
                      if name.endswith("_hz") and name not in _FREQUENCY_STEPS and isinstance(value, (int, float))]
    longest_record_s = HORIZONTAL_SCALES_S_PER_DIV[-1] * HORIZONTAL_DIVISIONS
    lowest_hz = min(frequencies_hz, default=FREQUENCY_RANGE_HZ[0])
    if run.acquisition.periods_per_record / lowest_hz > longest_record_s:
        raise CampaignError(file, f"{field}.acquisition.periods_per_record",
                            f"{run.acquisition.periods_per_record!r} periods at {lowest_hz:g} Hz do not fit in the "
                            f"scope's longest record, {longest_record_s:g} s")
    if run.protocol == "cartography":
        _check_map(file, run, f"{field}.parameters")


def _check_map(file: Path, run: Run, field: str) -> None:
    """A map's bench: a stage, and every point within its travel where the travel is known
    before the bench opens (`schemas.stage_travel_mm`; a real stage's is read when the run
    opens it, and every point checked then, before the first move)."""
    config = run.bench.config()
    if "stage" not in config.resources:
        raise CampaignError(file, field, f"a map needs an x-y stage, and {run.bench.input_file} names none "
                            "(resources.stage)")
    travel = schemas.stage_travel_mm(config)
    if travel is None:
        return
    grid = run.parameters.grid
    reference = run.parameters.reference_point_mm
    for i, (axis, bounds) in enumerate((("x", grid.x_range_mm), ("y", grid.y_range_mm))):
        low, high = travel[axis]
        first, last = grid.bounds_mm(bounds)
        for where, value in (("grid", first), ("grid", last), ("reference_point_mm", reference and reference[i])):
            if value is not None and not low <= value <= high:
                raise CampaignError(file, f"{field}.{where}", f"{axis} = {value:g} mm is beyond the stage's travel, "
                                    f"{low:g} to {high:g} mm")


def _check_value(file: Path, where: str, name: str, value: Any, limits) -> None:
    if value is None or isinstance(value, (bool, str, Path)):
        return
    if name.endswith("_vpp"):   # a piezo voltage
        if not value > 0:
            raise CampaignError(file, where, f"{value!r} Vpp: a piezo voltage must be positive")
        for limit_vpp, what in limits:
            if value > limit_vpp:
                raise CampaignError(file, where, f"{value:g} Vpp is above {what}, {limit_vpp:.4g} Vpp")
    elif name.endswith("_hz") and name in _FREQUENCY_STEPS:
        if not value >= MIN_STEP_HZ:
            raise CampaignError(file, where, f"{value!r} Hz is below the smallest step, {MIN_STEP_HZ} Hz")
    elif name.endswith("_hz"):
        low_hz, high_hz = FREQUENCY_RANGE_HZ
        if not low_hz <= value <= high_hz:
            raise CampaignError(file, where, f"{value!r} Hz is outside the generator's range, "
                                f"{low_hz:g} to {high_hz:g} Hz")
    elif name.endswith("_s") and not 0 <= value <= MAX_WAIT_S:
        raise CampaignError(file, where, f"{value!r} s is outside 0 to {MAX_WAIT_S:g} s")
    elif name in MAX_COUNTS and not 1 <= value <= MAX_COUNTS[name]:
        raise CampaignError(file, where, f"{value!r} is outside 1 to {MAX_COUNTS[name]}")


def _leaves(value: Any, field: str, name: str = ""):
    """(field path, field name, value) of every number in a protocol's parameters."""
    if dataclasses.is_dataclass(value):
        for f in dataclasses.fields(value):
            yield from _leaves(getattr(value, f.name), f"{field}.{f.name}", f.name)
    elif isinstance(value, tuple):
        for i, item in enumerate(value):
            yield from _leaves(item, f"{field}[{i}]", name)
    else:
        yield field, name, value


# -- running -----------------------------------------------------------------------------
def run_campaign(path: Path, resume: bool = False, out_dir: Path | None = None,
                 progress: bool = True, say: Callable[[str], None] | None = None,
                 accept_changed_bench: bool = False,
                 on_point: Callable[[dict[str, Any]], None] | None = None,
                 on_step: Callable[[dict[str, Any]], None] | None = None,
                 operator_done: bool = False, durable: bool = True, bench_file: Path | None = None) -> Path:
    """Run (or with `resume`, continue) a campaign; return its run directory. `progress`
    off hides the progress bar (a campaign run inside another tool, e.g. the planner);
    `accept_changed_bench` lets a resume use a bench file or scene changed since (a bench
    fix), recording both versions;
    `say` shows what the operator must know now (default: the terminal's stderr), and
    everything said also goes to log.txt. SIGTERM and SIGHUP stop it as Ctrl-C does.
    `on_point` and `on_step` watch the run (see Watchers). `operator_done` (with `resume`)
    says the operator's action the run stopped on for want of a terminal has been done.
    `durable` off skips the fsyncs, for a temporary run read and deleted by the tool that
    made it (`storage.RunStore`). `bench_file` puts every run on that bench (`run --bench`)."""
    with handled():
        return _run_campaign(path, resume, out_dir, progress, say, accept_changed_bench,
                             Watchers(on_point, on_step), operator_done, durable, bench_file)


@dataclass(frozen=True)
class Watchers:
    """Who watches a run (a live plot, a notebook): `on_point(row)` gets each measurement
    row as a step records it, before the step is stored (a step that fails is measured
    again on resume, and its points seen again); `on_step(entry)` gets each step's journal
    entry once the step is stored. A watcher that fails is logged and never stops the run:
    watching must not cost a measurement."""

    on_point: Callable[[dict[str, Any]], None] | None = None
    on_step: Callable[[dict[str, Any]], None] | None = None

    def point(self, row: dict[str, Any]) -> None:
        self._call(self.on_point, row)

    def step(self, entry: dict[str, Any]) -> None:
        self._call(self.on_step, entry)

    @staticmethod
    def _call(watcher: Callable[[dict[str, Any]], None] | None, record: dict[str, Any]) -> None:
        if watcher is not None:
            try:
                watcher(record)
            except Exception:
                log.exception("a watcher of the run failed (the run goes on)")


def _run_campaign(path: Path, resume: bool, out_dir: Path | None, progress: bool,
                  say: Callable[[str], None] | None, accept_changed_bench: bool, watchers: Watchers,
                  operator_done: bool = False, durable: bool = True, bench_file: Path | None = None) -> Path:
    campaign = load_campaign(path, bench_file)
    run_dir = Path(out_dir) if out_dir is not None else campaign.output_dir
    store = RunStore(run_dir, durable)
    foreign = store.foreign_entries()
    if foreign:
        raise CampaignError(campaign.file, None, f"{run_dir} is not empty and holds no run "
                            f"(no manifest.json; it has {', '.join(foreign[:3])}"
                            f"{', ...' if len(foreign) > 3 else ''}): a run is only written into a new "
                            "or empty directory; choose another output directory")
    if store.exists() and not resume:
        raise CampaignError(campaign.file, None, f"{run_dir} already holds a run; continue it "
                            "with --resume or choose another output directory")
    with store.writer():
        handler = _attach_log(run_dir / "log.txt")
        tell = _teller(say)
        try:
            if store.exists():
                if store.manifest()["campaign"]["sha256"] != sha256_file(campaign.file):
                    raise CampaignError(campaign.file, None, f"the file changed since {run_dir} was "
                                        "started; a resumed run must use the campaign it started with")
                store.ensure_campaign_copy(campaign.file)
                journal = store.repair(tell)
            else:
                store.create(campaign.file)
                journal = []
            store.check_writable([run.name for run in campaign.runs])
            if durable:   # a temporary run (plan, study: simulated, in workers) is no operator's drive
                for config in {run.bench.input_file: run.bench.config() for run in campaign.runs}.values():
                    bring_to_rest(config, tell)   # after an unclean end: the plate at rest before anything
            for warning in dict.fromkeys(f"{run.bench.input_file}: {w}" for run in campaign.runs
                                         for w in chain_warnings(run.bench.config().electronics)):
                tell(warning)
            log.info("campaign %s (%s) in %s, %s", campaign.name, campaign.file, run_dir,
                     f"resuming after {len(journal)} steps" if journal else "new run")
            _Runner(campaign, store, journal, progress, accept_changed_bench, watchers, operator_done).run()
            log.info("campaign %s complete", campaign.name)
        except BaseException as exc:
            log.error("campaign stopped by %s: %s; %scompleted steps are stored, resume to continue",
                      type(exc).__name__, exc, f"{generator_state()}; " if generator_state() else "")
            raise
        finally:
            _detach_log(handler)
    return run_dir


def _teller(say: Callable[[str], None] | None) -> Callable[[str], None]:
    """`say`, also logged as a warning (log.txt keeps what the terminal was told)."""
    def tell(message: str) -> None:
        log.warning("%s", message)
        if say is None:
            print(message, file=sys.stderr)
        else:
            say(message)
    return tell


class _Runner:
    def __init__(self, campaign: Campaign, store: RunStore, journal: list[dict[str, Any]],
                 progress: bool = True, accept_changed_bench: bool = False, watchers: Watchers = Watchers(),
                 operator_done: bool = False):
        self.campaign = campaign
        self.operator_request = store.operator_request() if operator_done else None
        if operator_done and self.operator_request is None:
            raise CampaignError(campaign.file, "--operator-done",
                                f"{store.run_dir} is not waiting for the operator: nothing to take as done")
        self.accept_changed_bench = accept_changed_bench
        self.inputs: dict[str, dict[str, str]] = {}   # run: {input file name: sha256}
        self.progress = progress
        self.watchers = watchers
        self.store = store
        self.journal = journal
        self.done = {(entry["run"], entry["step"]) for entry in journal}
        self.bench_time_s = journal[-1]["campaign_bench_time_s"] if journal else 0.0
        self.plans = [(run, run.steps()) for run in campaign.runs]
        self.campaign_sha256 = sha256_file(campaign.file)   # each journal line vouches for the copy
        self.done_this_session = 0

    def run(self) -> None:
        total = sum(len(steps) for _, steps in self.plans)
        # Two clocks, each named: the wall time the command has taken and may take, and the
        # bench time (virtual on a simulated bench) the campaign has used and will use.
        with tqdm(total=total, initial=len(self.done), unit="step", desc=self.campaign.name,
                  bar_format="{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} steps "
                             "[wall {elapsed}, ~{remaining} to go]{postfix}",
                  disable=not self.progress, **bar_width()) as self.bar:
            self._show_times()
            for run, steps in self.plans:
                pending = [step for step in steps if (run.name, step.step_id) not in self.done]
                if pending:
                    self._run(run, pending)

    def _run(self, run: Run, pending: list[Step]) -> None:
        context: dict[str, Any] = {}
        for entry in self.journal:
            if entry["run"] == run.name:
                context.update(entry["context"])
        for file in run.input_files():
            self.store.add_input(file, accept_changed=self.accept_changed_bench)
        self.inputs[run.name] = {file.name: sha256_file(file) for file in run.input_files()}
        log.info("run %s (%s): %d steps to do", run.name, run.protocol, len(pending))
        try:
            self._run_on_bench(run, pending, context)
        except OutOfRangeError as exc:   # a driver's refusal is a ValueError, not a bug here
            raise SettingRefused(f"run {run.name}: {exc}; the generator was set to its minimum; "
                                 "completed steps are stored") from None

    def _run_on_bench(self, run: Run, pending: list[Step], context: dict[str, Any]) -> None:
        with contextlib.ExitStack() as stack:
            # A stop while the bench opens waits until the DriveController holds the
            # generator at its minimum; it is honoured on leaving `deferred()`.
            with deferred():
                bench = stack.enter_context(open_bench(run.bench.config()))
                if self.operator_request is not None and self.operator_request["run"] == run.name:
                    bench.operator = ConfirmedOperator(bench.operator, self.operator_request["instruction"],
                                                       self.operator_request["state"])
                identifications = bench.identify()
                self.store.record_instruments(run.name, identifications, bench=bench_provenance(
                    run.bench.scene, run.bench.file, identifications))
                self.store.write_settings(run.name, {
                    "run": run.name, "protocol": run.protocol,
                    "acquisition": dataclasses.asdict(run.acquisition),
                    "safety": dataclasses.asdict(run.safety),
                    "electronics": dataclasses.asdict(bench.electronics),
                    "parameters": dataclasses.asdict(run.parameters),
                    "instruments": bench.settings_snapshot()})
                drive = stack.enter_context(DriveController(bench.generator, bench.electronics, bench.clock,
                                                            run.safety, settle_s=run.acquisition.settle_s,
                                                            on_amplitude=DriveRecord(run.bench.config())
                                                            if self.store.durable else None))
            acquisition = Acquisition(bench, drive, run.acquisition)
            acquisition.configure()
            bench.check_errors()   # a setting the instruments refused would void every step
            mounted = _Mounted(scene=run.bench.scene, state=None)
            for step in pending:
                self._step(run, step, bench, drive, acquisition, context, mounted, identifications)

    def _step(self, run: Run, step: Step, bench, drive: DriveController, acquisition: Acquisition,
              context: dict[str, Any], mounted: _Mounted, identifications: dict[str, str]) -> None:
        raise_if_stopped()
        log.info("run %s: step %s", run.name, step.step_id)
        try:
            mounted.prepare(bench, step.plate)
        except OperatorUnavailable as stop:   # kept, so a resume without a terminal can say it is done
            self.store.write_operator_request({"run": run.name, "step": step.step_id,
                                               "instruction": stop.instruction, "state": stop.state})
            raise
        if isinstance(bench.operator, ConfirmedOperator) and bench.operator.answered and self.operator_request:
            self.store.clear_operator_request()
            self.operator_request = None
        acquisition.reset_ranges()
        ctx = StepContext(run_name=run.name, protocol=run.protocol, step=step, bench=bench,
                          drive=drive, acquisition=acquisition, context=dict(context),
                          bench_time_base_s=self.bench_time_s, clock_start_s=bench.clock.now_s(),
                          on_point=self.watchers.point)
        try:
            step.measure(ctx)
        except MeasuredVoltageError as stop:
            path = self.store.write_evidence(run.name, step.step_id, {
                **stop.evidence, "run": run.name, "step": step.step_id, "protocol": run.protocol,
                "points_of_the_step_before": ctx.rows,
                "stopped_utc": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")})
            where = path.relative_to(self.store.run_dir)
            log.error("run %s: step %s stopped by the safety check; what it measured is kept in %s",
                      run.name, step.step_id, where)
            raise MeasuredVoltageError(f"{stop}; what that acquisition measured is kept in {where}",
                                       stop.evidence) from None
        drive.to_minimum()   # every step ends safe: the operator may touch the plate next
        # An error an instrument queued during the step (a refused setting) makes its
        # points doubtful: the step is not stored, and a resume measures it again.
        bench.check_errors()
        bench_time_s = ctx.bench_time_s()
        # A simulated step names the scene it mounted; a real one the bench file.
        provenance = bench_provenance(mounted.scene if run.bench.scene else None, run.bench.file,
                                      identifications)
        files = self.store.write_step(run.name, step.step_id, ctx.rows, ctx.waveforms, provenance)
        entry = {"run": run.name, "step": step.step_id, "protocol": run.protocol,
                 "rows": len(ctx.rows), "context": ctx.updates, "files": files,
                 "inputs": self.inputs[run.name], "campaign_sha256": self.campaign_sha256,
                 "campaign_bench_time_s": bench_time_s,
                 "completed_utc": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")}
        self.store.append_journal(entry)
        self.journal.append(entry)
        context.update(ctx.updates)
        self.bench_time_s = bench_time_s
        self.done_this_session += 1
        log.info("run %s: step %s done, %d rows, bench time %.1f s", run.name, step.step_id,
                 len(ctx.rows), bench_time_s)
        self.watchers.step(entry)
        self.bar.update(1)
        self._show_times()

    def _show_times(self) -> None:
        done, total = self.bar.n, self.bar.total
        remaining = f"{self.bench_time_s / done * (total - done):.0f} s" if done else "?"
        self.bar.set_postfix_str(f"bench {self.bench_time_s:.0f} s, ~{remaining} to go")


@dataclass
class _Mounted:
    """What is on the bench now, so a step asks the operator only for a change."""

    scene: Path | None
    state: str | None

    def prepare(self, bench, plate: Plate) -> None:
        if plate.scene is not None and plate.scene != self.scene:
            bench.operator.mount(plate.scene)
            self.scene, self.state = plate.scene, None
        if plate.state is not None and plate.state != self.state:
            bench.operator.request(plate.instruction or f"Prepare plate {plate.name} as '{plate.state}'",
                                   state=plate.state)
            self.state = plate.state


class _RunLog(logging.FileHandler):
    """log.txt; a line it cannot write (the folder made read-only) is not a traceback on
    the terminal: the storage error that follows says what happened, once."""

    def handleError(self, record: logging.LogRecord) -> None:
        pass


def _attach_log(path: Path) -> logging.Handler:
    handler = _RunLog(path, encoding="utf-8")
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    for name in _LOGGED_PACKAGES:
        logger = logging.getLogger(name)
        logger.addHandler(handler)
        if logger.level == logging.NOTSET or logger.level > logging.INFO:
            logger.setLevel(logging.INFO)
    return handler


def _detach_log(handler: logging.Handler) -> None:
    for name in _LOGGED_PACKAGES:
        logging.getLogger(name).removeHandler(handler)
    handler.close()
