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

import dataclasses
import datetime as dt
import logging
import re
import sys
import types
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import yaml
from tqdm import tqdm

from squeezebench.instruments.bench import load_bench_file, open_bench, sim_bench_config
from squeezebench.protocols import calibration, characterisation, cutting, detuning, powered_columns, resonance
from squeezebench.protocols.acquisition import Acquisition, AcquisitionSettings
from squeezebench.protocols.safety import (DriveController, SafetyLimits, chain_warnings,
                                              stop_signals_interrupt)
from squeezebench.protocols.steps import Plate, Step, StepContext
from squeezebench.protocols.storage import RunStore, sha256_file
from squeezebench import paths
from squeezebench.errors import UserError

log = logging.getLogger(__name__)

PROTOCOLS = {module.PROTOCOL: module for module in
             (resonance, detuning, cutting, powered_columns, characterisation, calibration)}
_NAME = re.compile(r"^[A-Za-z0-9_.-]+$")
#: Loggers whose records go to the run's log.txt.
_LOGGED_PACKAGES = ("squeezebench.protocols", "squeezebench.instruments")


class CampaignError(UserError):
    """A malformed campaign file, or a campaign that does not fit its run directory."""

    def __init__(self, file: Path, field: str | None, message: str):
        where = f"{file}: field '{field}'" if field else f"{file}"
        super().__init__(f"{where}: {message}")


# -- the campaign as loaded --------------------------------------------------------------
@dataclass(frozen=True)
class BenchChoice:
    scene: Path | None = None   # the simulated bench with this scene
    file: Path | None = None    # a bench file with real addresses

    def config(self):
        return sim_bench_config(self.scene) if self.scene else load_bench_file(self.file)

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


def _scenes_in(value: Any) -> list[Path]:
    if isinstance(value, Path):
        return [value]
    if dataclasses.is_dataclass(value):
        return [p for f in dataclasses.fields(value) for p in _scenes_in(getattr(value, f.name))]
    if isinstance(value, tuple):
        return [p for item in value for p in _scenes_in(item)]
    return []


def load_campaign(path: Path) -> Campaign:
    """Read and validate a campaign file; every problem is a CampaignError."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise CampaignError(path, None, f"cannot read: {exc.strerror}") from exc
    except yaml.YAMLError as exc:
        raise CampaignError(path, None, f"not valid YAML: {exc}") from exc
    reader = _Reader(path)
    top = reader.mapping(data, None, required={"runs"},
                         allowed={"name", "output_dir", "bench", "acquisition", "safety", "runs"})
    name = reader.name(top.get("name", path.stem), "name")
    output_dir = Path(top.get("output_dir", f"runs/{name}"))
    if not isinstance(top["runs"], list) or not top["runs"]:
        raise CampaignError(path, "runs", "must be a non-empty list of protocol runs")
    runs = tuple(reader.run(item, f"runs[{i}]", top) for i, item in enumerate(top["runs"]))
    names = [run.name for run in runs]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise CampaignError(path, "runs", f"run names must be unique; repeated: {', '.join(duplicates)}")
    return Campaign(path, name, output_dir, runs)


class _Reader:
    """Turns YAML values into the protocols' dataclasses, naming the field on error."""

    def __init__(self, file: Path):
        self.file = file

    def error(self, field: str | None, message: str) -> CampaignError:
        return CampaignError(self.file, field, message)

    def mapping(self, value: Any, field: str | None, required: set[str], allowed: set[str]) -> dict:
        if not isinstance(value, dict):
            raise self.error(field, f"must be a mapping with keys {', '.join(sorted(allowed))}")
        for key in value:
            if key not in allowed:
                raise self.error(_join(field, key), f"unknown; allowed: {', '.join(sorted(allowed))}")
        for key in sorted(required - set(value)):
            raise self.error(_join(field, key), "is missing")
        return value

    def name(self, value: Any, field: str) -> str:
        if not isinstance(value, str) or not _NAME.match(value):
            raise self.error(field, f"{value!r} must be letters, digits, '_', '-' or '.' (it names files)")
        return value

    def run(self, item: Any, field: str, top: dict) -> Run:
        run = self.mapping(item, field, required={"name", "protocol", "plate"},
                           allowed={"name", "protocol", "bench", "plate", "acquisition", "safety",
                                    "parameters"})
        name = self.name(run["name"], f"{field}.name")
        protocol = run["protocol"]
        if protocol not in PROTOCOLS:
            raise self.error(f"{field}.protocol", f"{protocol!r} is not one of: {', '.join(sorted(PROTOCOLS))}")
        if "bench" not in run and "bench" not in top:
            raise self.error(f"{field}.bench", "is missing (and the campaign has no default bench)")
        bench = self.bench(run.get("bench", top.get("bench")), f"{field}.bench")
        plate_data = dict(run["plate"]) if isinstance(run["plate"], dict) else run["plate"]
        if isinstance(plate_data, dict) and "name" not in plate_data and bench.scene is not None:
            plate_data["name"] = bench.scene.stem
        if isinstance(plate_data, dict) and "scene" not in plate_data and bench.scene is not None:
            plate_data["scene"] = str(bench.scene)   # a plate named otherwise keeps its geometry
        merged = lambda key: {**(top.get(key) or {}), **(run.get(key) or {})}  # noqa: E731
        return Run(
            name=name, protocol=protocol, bench=bench,
            plate=self.build(Plate, plate_data, f"{field}.plate"),
            acquisition=self.build(AcquisitionSettings, merged("acquisition"), f"{field}.acquisition"),
            safety=self.build(SafetyLimits, merged("safety"), f"{field}.safety"),
            parameters=self.build(PROTOCOLS[protocol].Parameters, run.get("parameters") or {},
                                  f"{field}.parameters"),
        )

    def bench(self, value: Any, field: str) -> BenchChoice:
        bench = self.mapping(value, field, required=set(), allowed={"scene", "file"})
        if len(bench) != 1:
            raise self.error(field, "needs exactly one of 'scene' (simulated bench) or 'file' (real bench)")
        if "scene" in bench:
            return BenchChoice(scene=self.scene(bench["scene"], f"{field}.scene"))
        file = Path(str(bench["file"]))
        file = file if file.is_absolute() else self.file.parent / file
        if not file.is_file():
            raise self.error(f"{field}.file", f"{file} does not exist")
        return BenchChoice(file=file)

    def scene(self, value: Any, field: str) -> Path:
        """A relative scene path is the user's file next to the campaign first, then a shipped one."""
        scene = Path(str(value))
        if not scene.is_absolute():
            beside = self.file.parent / scene
            scene = beside.resolve() if beside.is_file() else paths.scenes_dir() / scene
        if not scene.is_file():
            known = sorted(p.name for p in paths.scenes_dir().glob("*.yaml"))
            raise self.error(field, f"no scene {scene}; available in {paths.scenes_dir()}: {', '.join(known)}")
        return scene

    def build(self, cls: type, value: Any, field: str):
        """A dataclass from a mapping: unknown, missing and mistyped fields are errors."""
        hints = typing.get_type_hints(cls)
        fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
        required = {name for name, f in fields.items()
                    if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING}
        data = self.mapping(value, field, required=required, allowed=set(fields))
        kwargs = {key: self.convert(hints[key], item, _join(field, key)) for key, item in data.items()}
        try:
            return cls(**kwargs)
        except (ValueError, TypeError) as exc:
            raise self.error(field, str(exc)) from exc

    def convert(self, hint: Any, value: Any, field: str) -> Any:
        origin, args = typing.get_origin(hint), typing.get_args(hint)
        if origin in (typing.Union, types.UnionType):
            if value is None and type(None) in args:
                return None
            (hint,) = [a for a in args if a is not type(None)]
            return self.convert(hint, value, field)
        if dataclasses.is_dataclass(hint):
            return self.build(hint, value, field)
        if origin is tuple:
            if not isinstance(value, list):
                raise self.error(field, "must be a list")
            return tuple(self.convert(args[0], item, f"{field}[{i}]") for i, item in enumerate(value))
        if hint is Path:   # the only paths in parameters are scenes a step mounts
            return self.scene(value, field)
        if hint is float and isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)
        if isinstance(value, hint) and not (hint is int and isinstance(value, bool)):
            return value
        raise self.error(field, f"{value!r} is not a {hint.__name__}")


def _join(field: str | None, key: str) -> str:
    return f"{field}.{key}" if field else key


# -- running -----------------------------------------------------------------------------
def run_campaign(path: Path, resume: bool = False, out_dir: Path | None = None,
                 progress: bool = True, say: Callable[[str], None] | None = None,
                 on_point: Callable[[dict[str, Any]], None] | None = None,
                 on_step: Callable[[dict[str, Any]], None] | None = None) -> Path:
    """Run (or with `resume`, continue) a campaign; return its run directory. `progress`
    off hides the progress bar (a campaign run inside another tool, e.g. the planner);
    `say` shows what the operator must know now (default: the terminal's stderr), and
    everything said also goes to log.txt. SIGTERM and SIGHUP stop it as Ctrl-C does.
    `on_point` and `on_step` watch the run (see Watchers)."""
    with stop_signals_interrupt():
        return _run_campaign(path, resume, out_dir, progress, say, Watchers(on_point, on_step))


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
                  say: Callable[[str], None] | None, watchers: Watchers) -> Path:
    campaign = load_campaign(path)
    run_dir = Path(out_dir) if out_dir is not None else campaign.output_dir
    store = RunStore(run_dir)
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
            for warning in dict.fromkeys(f"{run.bench.input_file}: {w}" for run in campaign.runs
                                         for w in chain_warnings(run.bench.config().electronics)):
                tell(warning)
            log.info("campaign %s (%s) in %s, %s", campaign.name, campaign.file, run_dir,
                     f"resuming after {len(journal)} steps" if journal else "new run")
            _Runner(campaign, store, journal, progress, watchers).run()
            log.info("campaign %s complete", campaign.name)
        except BaseException as exc:
            log.error("campaign stopped by %s: %s; completed steps are stored, resume to continue",
                      type(exc).__name__, exc)
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
                 progress: bool = True, watchers: Watchers = Watchers()):
        self.campaign = campaign
        self.progress = progress
        self.watchers = watchers
        self.store = store
        self.journal = journal
        self.done = {(entry["run"], entry["step"]) for entry in journal}
        self.bench_time_s = journal[-1]["campaign_bench_time_s"] if journal else 0.0
        self.plans = [(run, run.steps()) for run in campaign.runs]
        self.done_this_session = 0

    def run(self) -> None:
        total = sum(len(steps) for _, steps in self.plans)
        with tqdm(total=total, initial=len(self.done), unit="step", desc=self.campaign.name,
                  dynamic_ncols=True, disable=not self.progress) as self.bar:
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
            self.store.add_input(file)
        log.info("run %s (%s): %d steps to do", run.name, run.protocol, len(pending))
        with open_bench(run.bench.config()) as bench:
            self.store.record_instruments(run.name, bench.identify())
            self.store.write_settings(run.name, {
                "run": run.name, "protocol": run.protocol,
                "acquisition": dataclasses.asdict(run.acquisition),
                "safety": dataclasses.asdict(run.safety),
                "electronics": dataclasses.asdict(bench.electronics),
                "parameters": dataclasses.asdict(run.parameters),
                "instruments": bench.settings_snapshot()})
            drive = DriveController(bench.generator, bench.electronics, bench.clock, run.safety,
                                    settle_s=run.acquisition.settle_s)
            acquisition = Acquisition(bench, drive, run.acquisition)
            acquisition.configure()
            bench.check_errors()   # a setting the instruments refused would void every step
            mounted = _Mounted(scene=run.bench.scene, state=None)
            with drive:
                for step in pending:
                    self._step(run, step, bench, drive, acquisition, context, mounted)

    def _step(self, run: Run, step: Step, bench, drive: DriveController, acquisition: Acquisition,
              context: dict[str, Any], mounted: _Mounted) -> None:
        log.info("run %s: step %s", run.name, step.step_id)
        mounted.prepare(bench, step.plate)
        acquisition.reset_ranges()
        ctx = StepContext(run_name=run.name, protocol=run.protocol, step=step, bench=bench,
                          drive=drive, acquisition=acquisition, context=dict(context),
                          bench_time_base_s=self.bench_time_s, clock_start_s=bench.clock.now_s(),
                          on_point=self.watchers.point)
        step.measure(ctx)
        drive.to_minimum()   # every step ends safe: the operator may touch the plate next
        # An error an instrument queued during the step (a refused setting) makes its
        # points doubtful: the step is not stored, and a resume measures it again.
        bench.check_errors()
        bench_time_s = ctx.bench_time_s()
        files = self.store.write_step(run.name, step.step_id, ctx.rows, ctx.waveforms)
        entry = {"run": run.name, "step": step.step_id, "protocol": run.protocol,
                 "rows": len(ctx.rows), "context": ctx.updates, "files": files,
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
        remaining = f"{self.bench_time_s / done * (total - done):.0f}s" if done else "?"
        self.bar.set_postfix_str(f"bench time {self.bench_time_s:.0f}s, ~{remaining} to go")


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


def _attach_log(path: Path) -> logging.Handler:
    handler = logging.FileHandler(path, encoding="utf-8")
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
