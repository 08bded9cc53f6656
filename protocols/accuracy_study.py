"""What accuracy costs in bench time, measured on the simulated bench (ground truth known).

Each experiment varies the settings that cost bench time and scores every measurement
against the scene's closed-form truth (`SimulatedBench.resonance_truth`), with the cost
read from the virtual bench clock. Measurements are reduced exactly as the report reduces
stored waveforms (`analysis.waveforms.reduce_record`; Q and tan(theta') by
`analysis.characterisation.characterise_plate`), so an error here is an error in the report.

Experiments (the scene, state and voltage of each are in `StudySettings`):
- `averages`: sample mode and scope averaging 2..512 at resonance -> power, velocity, amplitude;
- `record`: periods per record x record length (500 / 10000 points) -> the same;
- `search`: coarse sweep points x golden-section tolerance -> resonance frequency (one
  search per trial, to the finest tolerance; the coarser ones stop on its way);
- `settle`: wait after a voltage step (ring-up, `settling_transient` on) -> power, velocity;
- `sweep`: voltages in a characterisation sweep x averaging -> Q, tan(theta');
- `heating`: a series of points at a high voltage with `heating_drift` on, at the
  frequency found cold or re-centred before each point (tracking), per averaging;
- `systematics_table3`, `systematics_stress`, `systematics_sweep`, each also `..._calibrated`:
  points of the paper campaign on benches whose instruments err within specification, one
  bench per repeat, per averaging (`protocols.systematics_study`) -> total error and the
  floor no averaging lowers, as the bench is and after the deskew calibration;
  `systematics_search`: the resonance search's tolerance on such benches;
  `systematics_campaign` (also `..._calibrated`): the whole paper campaign per averaging,
  every stored point scored, its bench time the cost (minutes: `reproduce` leaves it out).

Every configuration is repeated (`repeats`): the trials give error distributions, not
single points. A task is one configuration of one experiment on its own fresh simulated
bench; each trial draws its noise from its own seed (study seed, experiment,
configuration, repeat) and starts from the same bench state, so the trials are the same
whatever the order, the partition or the number of workers (`protocols.parallel`: local
processes or a Dask cluster). Each task's trials go to its own file; an experiment's
trials are then stored as RUN_DIR/study/<experiment>.parquet, one row per (trial,
quantity); the scenes as run (effects added) are in RUN_DIR/study/inputs/.
`analysis.study` turns them into Pareto fronts.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import functools
import itertools
import json
import shutil
import tempfile
import threading
import zlib
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np
import pandas as pd

import squeezebench
from squeezebench.analysis.study import STUDY_DIR
from squeezebench.analysis.waveforms import PointReduction
from squeezebench.protocols import systematics_study
from squeezebench.protocols.acquisition import AcquisitionSettings
from squeezebench.protocols.parallel import map_unordered
from squeezebench.protocols.resonance import (Resonance, SearchSettings, find_resonance, stopped_at,
                                              track_resonance)
from squeezebench.protocols.storage import write_atomic, write_frame_atomic
from squeezebench.protocols.simulated_session import (
    SimulatedSession, characterise_at_resonance, open_simulated, reduce_point)
from squeezebench import paths
from squeezebench.yamlfiles import dump_yaml, load_strict


@dataclasses.dataclass(frozen=True)
class StudySettings:
    #: 6: every one of reproduce's 173 figures (p95 errors) stayed within 2 Monte Carlo u of
    #: the same study's with 8 (largest |z| 1.7), for 16 % less of the study's CPU time
    repeats: int = 6
    seed: int = 1
    base: AcquisitionSettings = AcquisitionSettings(averages=16, record_length=10000,
                                                    periods_per_record=20.0, settle_s=0.05)
    # The Table 3 point: one-column plate, 75 mm, 20 Vpp.
    point_scene: str = "one_column_1mm.yaml"
    point_state: str = "75x41"
    point_voltage_vpp: float = 20.0
    averages: tuple[int, ...] = (1, 2, 4, 8, 16, 32, 64, 128, 256, 512)   # 1: sample mode
    periods_per_record: tuple[float, ...] = (2.0, 5.0, 10.0, 20.0, 50.0)
    record_lengths: tuple[int, ...] = (500, 10000)
    search_points: tuple[int, ...] = (11, 41, 81)
    search_tolerances_hz: tuple[float, ...] = (10.0, 0.5)
    search_averages: tuple[int, ...] = (4, 16, 64)   # the flat top of the peak is found in the noise
    search_half_span_hz: float = 300.0   # the search brackets the resonance by this much
    search_voltage_vpp: float = 10.0
    settle_s: tuple[float, ...] = (0.0, 0.01, 0.02, 0.05, 0.1, 0.2)
    settle_from_vpp: float = 10.0        # the step: settle_from_vpp -> point_voltage_vpp
    # The Table 3 plate rings up in 2 ms, within the generator's own 30 ms level change,
    # so settling is studied on the same point made sharp: a ring time of ~40 ms.
    settle_q_mech: float = 5000.0
    # Characterisation of a small plate (Fig. 5): n voltages evenly over the range.
    sweep_scene: str = "small_plate_1.yaml"
    sweep_voltage_counts: tuple[int, ...] = (3, 5, 9)   # a line fit needs 3
    sweep_voltage_range_vpp: tuple[float, float] = (10.0, 40.0)
    sweep_averages: tuple[int, ...] = (4, 32, 256)
    # Heating: the uncut plate held at a high drive.
    heating_scene: str = "one_column_1mm.yaml"
    heating_state: str = "76x41"
    heating_voltage_vpp: float = 75.0
    heating_averages: tuple[int, ...] = (2, 8, 32, 128, 512)
    heating_points: int = 8
    tracking_step_hz: float = 5.0
    tracking_tolerance_hz: float = 0.5
    tracking_averages: int = 8   # velocity is clean: tracking need not wait for the power's averaging
    # Total error on benches whose instruments err within spec (one bench per repeat).
    systematics: systematics_study.SystematicsSettings = systematics_study.SystematicsSettings()

    def __post_init__(self) -> None:
        if self.repeats < 2:
            raise ValueError(f"repeats must be at least 2 (a distribution), got {self.repeats!r}")


def _point_values(reduction: PointReduction, truth) -> dict[str, tuple[float, float]]:
    return {"power_w": (reduction.power_w.value, truth.power_w),
            "velocity_pp_mps": (reduction.velocity_pp_mps.value, truth.velocity_pp_mps),
            "amplitude_pp_m": (reduction.amplitude_pp_m.value, truth.amplitude_pp_m)}



def _settings_values(settings: AcquisitionSettings) -> dict:
    return {"averages": settings.averages, "record_length": settings.record_length,
            "periods_per_record": settings.periods_per_record, "settle_s": settings.settle_s}


# -- the experiments ------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class SceneSpec:
    """A shipped scene as the study runs it: with the effects the study adds, and
    `q_mech` = (state, value) overriding one state's mechanical Q."""

    name: str
    extra_effects: tuple[str, ...] = ()
    q_mech: tuple[str, float] | None = None

    @property
    def file_name(self) -> str:
        stem = Path(self.name).stem + "".join(f"+{e}" for e in self.extra_effects)
        if self.q_mech is not None:
            stem += f"+q{self.q_mech[1]:g}"
        return f"{stem}.yaml"

    def render(self, scenes_dir: Path, seed: int) -> str:
        """The scene file's text, seeded by the study (each trial reseeds it on top)."""
        data = load_strict((Path(scenes_dir) / self.name).read_text(encoding="utf-8"))
        present = {e if isinstance(e, str) else next(iter(e)) for e in data.get("effects", [])}
        data["effects"] = [*data.get("effects", []), *(e for e in self.extra_effects if e not in present)]
        data["seed"] = seed
        if self.q_mech is not None:
            # A sharper resonance of the same plate (same modal mass, R_mech / (q/q_old))
            # reaching the same velocity at the same voltage needs a weaker coupling and
            # takes q_old/q of the power: scaling the calibrated power keeps the plate
            # physical (the scene refuses a modal mass q/q_old times the plate's).
            state = data["states"][self.q_mech[0]]
            state["calibration"]["power_w"] *= state["q_mech"] / self.q_mech[1]
            state["q_mech"] = self.q_mech[1]
        return dump_yaml(data)


@dataclasses.dataclass(frozen=True)
class Experiment:
    """What an experiment varies and how one configuration's trials run.

    `configurations` lists the knob values of each configuration (columns of
    `analysis.study.KNOBS`; the others keep `StudySettings.base`'s); `run` measures every
    trial of one configuration into a `TaskRun`, and may store rows of other knob values
    its trials also answer (a search's coarser tolerances, `TaskRun.add_search`). Adding
    an experiment is one function pair and one entry in `EXPERIMENTS`.
    """

    scene: Callable[[StudySettings], SceneSpec]   # or a systematics_study.CampaignSpec
    state: Callable[[StudySettings], str | None]
    configurations: Callable[[StudySettings], list[dict]]
    run: Callable[["TaskRun"], None]
    #: Its configurations share each bench's calibration (`systematics_study.bench_calibration`,
    #: kept by the worker): one worker runs them all, so no bench is calibrated twice.
    shares_calibrations: bool = False
    #: The experiment whose trials' readings its trials take, configuration for configuration and
    #: repeat for repeat (`Task.seed`): a calibrated experiment corrects what its plain twin read,
    #: and the worker that runs both reads once (`work_units`).
    readings_of: str | None = None


def _at_the_point(run: "TaskRun") -> None:
    """Repeated points at the Table 3 point, ranged first as a step's earlier points do."""
    s = run.settings
    settings = run.acquisition_settings()
    with run.bench() as bench:
        bench.drive.set_piezo_voltage(s.point_voltage_vpp)
        bench.go_to_resonance()
        ranged = bench.acquisition(settings)
        ranged.measure(keep_waveforms=False)
        truth = bench.simulated.resonance_truth()
        for repeat in run.trials(bench):
            acquisition = copy.copy(ranged)   # every trial starts from the ranged expectations
            start_s = bench.now_s()
            point = acquisition.measure()
            run.add(repeat, bench.now_s() - start_s, _point_values(reduce_point(point), truth))


def _search(run: "TaskRun") -> None:
    s = run.settings
    with run.bench() as bench:
        bench.drive.set_piezo_voltage(s.search_voltage_vpp)
        true_hz = bench.simulated.resonance_truth().frequency_hz
        # Where the resonance falls in the range is luck: a seeded random offset per
        # repeat (the same for every configuration), else a grid point could sit on it.
        offsets_hz = np.random.default_rng(s.seed).uniform(-0.5, 0.5, size=s.repeats) * s.search_half_span_hz
        acquisition = bench.acquisition(run.acquisition_settings())
        for repeat in run.trials(bench):
            search = SearchSettings(true_hz + offsets_hz[repeat] - s.search_half_span_hz,
                                    true_hz + offsets_hz[repeat] + s.search_half_span_hz,
                                    points=run.knobs["search_points"], tolerance_hz=run.knobs["search_tolerance_hz"])
            acquisition.reset_ranges()   # each search starts as a step does
            start_s = bench.now_s()
            run.add_search(repeat, start_s, find_resonance(acquisition.measure_at, search), search, true_hz,
                           s.search_tolerances_hz)


def _settle(run: "TaskRun") -> None:
    s = run.settings
    with run.bench() as bench:
        bench.drive.set_piezo_voltage(s.settle_from_vpp)
        bench.go_to_resonance()
        ranged = bench.acquisition(s.base)
        ranged.measure(keep_waveforms=False)
        for repeat in run.trials(bench):
            acquisition = copy.copy(ranged)
            # Back to the lower level and fully rung down: each trial sees the same step.
            bench.drive.settle_s = 1.0
            bench.drive.set_piezo_voltage(s.settle_from_vpp)
            acquisition.measure(keep_waveforms=False)
            bench.drive.settle_s = run.knobs["settle_s"]
            start_s = bench.now_s()
            bench.drive.set_piezo_voltage(s.point_voltage_vpp)
            point = acquisition.measure()
            values = _point_values(reduce_point(point), bench.simulated.resonance_truth())
            del values["amplitude_pp_m"]   # velocity's error over a frequency known to 1e-6
            run.add(repeat, bench.now_s() - start_s, values)


def _sweep(run: "TaskRun") -> None:
    s = run.settings
    with run.bench() as bench:
        geometry = bench.simulated.scene.geometry(bench.simulated.state)
        voltages_vpp = np.linspace(*s.sweep_voltage_range_vpp, run.knobs["n_voltages"])
        truth = characterise_at_resonance(bench, s.sweep_scene, voltages_vpp, geometry, measure=None)
        acquisition = bench.acquisition(run.acquisition_settings())
        for repeat in run.trials(bench):
            bench.drive.set_piezo_voltage(float(voltages_vpp[0]))
            acquisition.reset_ranges()
            start_s = bench.now_s()
            measured = characterise_at_resonance(bench, s.sweep_scene, voltages_vpp, geometry, measure=acquisition)
            run.add(repeat, bench.now_s() - start_s,
                    {"q": (measured.q.value, truth.q.value),
                     "tan_theta": (measured.tan_theta.value, truth.tan_theta.value)})


def _heating(run: "TaskRun") -> None:
    """A series of points on a fresh, cold plate (the resonance is found cold): the
    repeat is the point's place in the series."""
    s = run.settings
    tracking = SearchSettings(1.0, 2.0, tracking_step_hz=s.tracking_step_hz, tolerance_hz=s.tracking_tolerance_hz)
    with run.bench() as bench:
        tracker = bench.acquisition(dataclasses.replace(s.base, averages=s.tracking_averages))
        acquisition = bench.acquisition(run.acquisition_settings())
        bench.drive.set_piezo_voltage(s.heating_voltage_vpp)
        bench.go_to_resonance()
        frequency_hz = bench.drive.frequency_hz
        acquisition.measure(keep_waveforms=False)
        for index in run.trials(bench, s.heating_points):
            start_s = bench.now_s()
            if run.knobs["tracking"]:
                tracker.configure()
                frequency_hz = track_resonance(tracker.measure_at, frequency_hz, tracking).frequency_hz
                bench.drive.set_frequency(frequency_hz)
                acquisition.configure()
            truth = bench.simulated.resonance_truth()
            point = acquisition.measure()
            run.add(index, bench.now_s() - start_s, {"power_w": (reduce_point(point).power_w.value, truth.power_w)})


#: The experiments, in the order they are listed and stored.
EXPERIMENTS: dict[str, Experiment] = {
    "averages": Experiment(lambda s: SceneSpec(s.point_scene), lambda s: s.point_state,
                           lambda s: [{"averages": n} for n in s.averages], _at_the_point),
    "record": Experiment(lambda s: SceneSpec(s.point_scene), lambda s: s.point_state,
                         lambda s: [{"record_length": length, "periods_per_record": periods}
                                    for length in s.record_lengths for periods in s.periods_per_record],
                         _at_the_point),
    # A search's readings take the record that reads their crest (`acquisition.search_record_length`:
    # 10,000 points from these 500 of 20 periods), as the campaign's do. One task
    # searches to the finest tolerance; the coarser ones are read from its points.
    "search": Experiment(lambda s: SceneSpec(s.point_scene), lambda s: s.point_state,
                         lambda s: [{"averages": n, "record_length": 500, "search_points": points,
                                     "search_tolerance_hz": min(s.search_tolerances_hz)}
                                    for n, points in itertools.product(s.search_averages, s.search_points)],
                         _search),
    "settle": Experiment(lambda s: SceneSpec(s.point_scene, ("settling_transient",),
                                             q_mech=(s.point_state, s.settle_q_mech)),
                         lambda s: s.point_state, lambda s: [{"settle_s": t} for t in s.settle_s], _settle),
    "sweep": Experiment(lambda s: SceneSpec(s.sweep_scene), lambda s: None,
                        lambda s: [{"n_voltages": n, "averages": a}
                                   for n in s.sweep_voltage_counts for a in s.sweep_averages], _sweep),
    "heating": Experiment(lambda s: SceneSpec(s.heating_scene, ("heating_drift",)), lambda s: s.heating_state,
                          lambda s: [{"tracking": track, "averages": n}
                                     for track in (False, True) for n in s.heating_averages], _heating),
    **{f"systematics_{point}{'_calibrated' if calibrated else ''}": Experiment(
        lambda s: SceneSpec(s.point_scene),
        (lambda s: s.point_state) if point == "table3" else (lambda s: s.systematics.stress_state),
        lambda s: [{"averages": n} for n in s.systematics.averages],
        functools.partial(systematics_study.point_trials, point, calibrated), shares_calibrations=calibrated,
        readings_of=f"systematics_{point}" if calibrated else None)
       for point in ("table3", "stress") for calibrated in (False, True)},
    "systematics_search": Experiment(
        lambda s: SceneSpec(s.point_scene), lambda s: s.point_state,
        lambda s: [{"averages": s.systematics.search_averages, "record_length": 500,
                    "search_points": s.systematics.search_points,
                    "search_tolerance_hz": min(s.systematics.search_tolerances_hz)}],
        systematics_study.search_trials),
    **{f"systematics_campaign{'_calibrated' if calibrated else ''}": Experiment(
        lambda s: systematics_study.CampaignSpec(s.systematics.campaign), lambda s: None,
        lambda s: [{"averages": n} for n in s.systematics.campaign_averages],
        functools.partial(systematics_study.campaign_trials, calibrated))
       for calibrated in (False, True)},
    **{f"systematics_sweep{'_calibrated' if calibrated else ''}": Experiment(
        lambda s: SceneSpec(s.sweep_scene), lambda s: None,
        lambda s: [{"n_voltages": s.systematics.sweep_voltages, "averages": n} for n in s.systematics.sweep_averages],
        functools.partial(systematics_study.sweep_trials, calibrated), shares_calibrations=calibrated,
        readings_of="systematics_sweep" if calibrated else None)
       for calibrated in (False, True)},
}


# -- tasks: one configuration of one experiment ---------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Task:
    """Everything one configuration's trials need, picklable for a worker: the scene as
    text (a worker needs no shared file system), the knobs, and the seeds."""

    settings: StudySettings
    experiment: str
    knobs: tuple[tuple[str, Any], ...]
    scene_file: str
    scene_text: str
    state: str | None

    @property
    def key(self) -> str:
        return json.dumps(dict(self.knobs), sort_keys=True)

    @property
    def file_name(self) -> str:
        """The task's own trial file under study/trials/<experiment>/."""
        return "_".join(f"{knob}={value}" for knob, value in self.knobs) + ".parquet"

    def seed(self, trial: int | str) -> int:
        """The noise of one trial (or of the configuration's setup): from what defines it,
        never from what ran before, so any order, partition or worker count draws the same;
        the same configuration's of the experiment whose readings it takes (`Experiment.readings_of`)."""
        return self._seed(EXPERIMENTS[self.experiment].readings_of or self.experiment, self.key, trial)

    def bench_seed(self, what: str, repeat: int) -> int:
        """The noise of `what` every configuration of the experiment shares on bench
        `repeat` (its calibration): from the experiment and the bench, not the configuration."""
        return self._seed(self.experiment, what, repeat)

    def _seed(self, *parts: Any) -> int:
        entropy = [self.settings.seed, *(zlib.crc32(str(part).encode()) for part in parts)]
        return int(np.random.SeedSequence(entropy).generate_state(1)[0])


class TaskRun:
    """One task's bench, trials and rows (one row per trial and quantity)."""

    def __init__(self, task: Task, scene: Path) -> None:
        self.task = task
        self.settings = task.settings
        self.scene = scene
        self.knobs = {**_settings_values(self.settings.base), "search_points": 0, "search_tolerance_hz": 0.0,
                      "n_voltages": 1, "tracking": False, **dict(task.knobs)}
        self.rows: list[dict] = []

    def acquisition_settings(self) -> AcquisitionSettings:
        return dataclasses.replace(self.settings.base, **{k: v for k, v in self.knobs.items()
                                                          if k in _settings_values(self.settings.base)})

    @contextlib.contextmanager
    def bench(self) -> Iterator[SimulatedSession]:
        """A fresh simulated bench of the task's scene, its noise seeded by the task."""
        with open_simulated(self.scene, self.task.state, self.settings.base.settle_s) as session:
            session.simulated.reseed(self.task.seed("setup"))
            yield session

    def trials(self, session: SimulatedSession, count: int | None = None) -> Iterator[int]:
        """Trial indices; each trial's noise restarts from its own seed."""
        for repeat in range(self.settings.repeats if count is None else count):
            session.simulated.reseed(self.task.seed(repeat))
            yield repeat

    def add(self, repeat: int, bench_time_s: float, values: dict[str, tuple[float, float]], **knobs) -> None:
        """`values` maps a quantity name (with its unit) to (measured, true); `knobs`
        override the task's for rows read from a finer configuration's trial."""
        for quantity, (measured, true) in values.items():
            self.rows.append({"experiment": self.task.experiment, "scene": self.task.scene_file,
                              "state": self.task.state or "", **self.knobs, **knobs, "repeat": repeat,
                              "bench_time_s": bench_time_s, "quantity": quantity, "measured_value": measured,
                              "true_value": true, "rel_error": measured / true - 1.0})


    def add_search(self, repeat: int, start_s: float, found: Resonance, search: SearchSettings, true_hz: float,
                   tolerances_hz: tuple[float, ...]) -> None:
        """A search's rows at each of `tolerances_hz` (`found` went to the finest of them),
        its bench time up to its last point (`protocols.resonance.stopped_at`)."""
        for tolerance_hz in sorted(tolerances_hz, reverse=True):
            result = stopped_at(found, search, tolerance_hz)
            self.add(repeat, result.points[-1].clock_s - start_s,
                     {"resonance_frequency_hz": (result.frequency_hz, true_hz)}, search_tolerance_hz=tolerance_hz)


def work_units(tasks: list[Task]) -> list[tuple[Task, ...]]:
    """What one worker runs at a time: the configurations of an experiment that shares its
    benches' calibrations together (on two workers, calibrating every bench in both cost
    the study 16 calibrations of 40), after those of the experiment whose readings it takes
    (`Experiment.readings_of`: read once, then corrected), each other task alone; the shared
    ones first, being the longest, so the last units to finish are short."""
    read = {experiment.readings_of for experiment in EXPERIMENTS.values()}
    shared: dict[str, list[Task]] = {}
    alone = []
    for task in tasks:
        experiment = EXPERIMENTS[task.experiment]
        if experiment.shares_calibrations or task.experiment in read:
            shared.setdefault(experiment.readings_of or task.experiment, []).append(task)
        else:
            alone.append((task,))
    # the readings' own experiment first in its unit (a stable sort: configuration order kept)
    return [tuple(sorted(unit, key=lambda task: EXPERIMENTS[task.experiment].readings_of is not None))
            for unit in shared.values()] + alone


def run_tasks(unit: tuple[Task, ...]) -> list[pd.DataFrame]:
    """The trials of a unit's tasks, in order, on one worker."""
    return [run_task(task) for task in unit]


def run_task(task: Task) -> pd.DataFrame:
    """The trials of one task (in a worker: the scene goes to a private temporary file)."""
    with tempfile.TemporaryDirectory(prefix="squeezebench-study-") as tmp:
        scene = Path(tmp) / task.scene_file
        scene.write_text(task.scene_text, encoding="utf-8")
        run = TaskRun(task, scene)
        EXPERIMENTS[task.experiment].run(run)
        return pd.DataFrame(run.rows)


# -- running ----------------------------------------------------------------------------------------
class AccuracyStudy:
    """Runs the experiments of one study into a run directory's study/ folder.

    Each task (one configuration of one experiment) writes its own file,
    study/trials/<experiment>/<knobs>.parquet, atomically when it completes; an
    experiment's file study/<experiment>.parquet is assembled from its tasks' files in
    configuration order once they are all stored. A resumed study runs only the missing tasks.
    """

    EXPERIMENTS = tuple(EXPERIMENTS)

    def __init__(self, settings: StudySettings, scenes_dir: Path, out_dir: Path,
                 progress: Callable[[str], None] = lambda message: None,
                 workers: int = 1, scheduler: Any = None, stop: threading.Event | None = None,
                 bar: bool = True) -> None:
        self.settings = settings
        self.stop = stop
        self.bar = bar
        self.scenes_dir = Path(scenes_dir)
        self.out_dir = Path(out_dir) / STUDY_DIR
        self.trials_dir = self.out_dir / "trials"
        self.progress = progress
        self.workers = workers
        self.scheduler = scheduler

    def tasks(self, experiments: tuple[str, ...]) -> list[Task]:
        s = self.settings
        tasks = []
        for name in experiments:
            experiment = EXPERIMENTS[name]
            scene = experiment.scene(s)
            text = scene.render(self.scenes_dir, s.seed)
            tasks += [Task(s, name, tuple(knobs.items()), scene.file_name, text, experiment.state(s))
                      for knobs in experiment.configurations(s)]
        return tasks

    def run(self, experiments: tuple[str, ...] = EXPERIMENTS, resume: bool = False) -> Path:
        """Run the experiments; with `resume`, keep what is already stored under the same settings."""
        unknown = set(experiments) - set(EXPERIMENTS)
        if unknown:
            raise ValueError(f"unknown experiments {sorted(unknown)}; allowed: {', '.join(EXPERIMENTS)}")
        self.out_dir.mkdir(parents=True, exist_ok=True)
        manifest_path = self.out_dir / "manifest.json"
        manifest = {"software_version": squeezebench.__version__,
                    "settings": json.loads(json.dumps(dataclasses.asdict(self.settings), default=str))}
        stored = json.loads(manifest_path.read_text(encoding="utf-8")) if manifest_path.exists() else None
        keep = resume and stored is not None and stored.get("settings") == manifest["settings"]
        if not keep:   # trials of other settings would mix in
            for old in self.out_dir.glob("*.parquet"):
                old.unlink()
            shutil.rmtree(self.trials_dir, ignore_errors=True)
        write_atomic(manifest_path, json.dumps(manifest, indent=2).encode("utf-8"))
        tasks = self.tasks(experiments)
        for task in {task.scene_file: task for task in tasks}.values():   # the scenes as run
            write_atomic(self.out_dir / "inputs" / task.scene_file, task.scene_text.encode("utf-8"))
        stored_experiments = {name for name in experiments if (self.out_dir / f"{name}.parquet").exists()}
        for name in sorted(stored_experiments, key=experiments.index):
            self.progress(f"accuracy study: {name} already stored")
        pending = [task for task in tasks if task.experiment not in stored_experiments
                   and not self._task_path(task).exists()]
        if pending:
            where = f"the Dask cluster at {self.scheduler}" if self.scheduler is not None else \
                f"{self.workers} worker{'s' if self.workers > 1 else ''}"
            self.progress(f"accuracy study: {len(pending)} tasks of {len(tasks)} on {where}")
        for unit, frames in map_unordered(run_tasks, work_units(pending), self.workers, self.scheduler,
                                          "accuracy study", bar=self.bar):
            for task, frame in zip(unit, frames):
                write_frame_atomic(self._task_path(task), frame)
            if self.stop is not None and self.stop.is_set():   # the tasks stored are kept for a resume
                return self.out_dir
        for name in experiments:
            if name not in stored_experiments:
                self._assemble(name, [task for task in tasks if task.experiment == name])
        return self.out_dir

    def _task_path(self, task: Task) -> Path:
        return self.trials_dir / task.experiment / task.file_name

    def _assemble(self, name: str, tasks: list[Task]) -> None:
        """The experiment's file from its tasks' files, in configuration order."""
        frame = pd.concat([pd.read_parquet(self._task_path(task)) for task in tasks], ignore_index=True)
        write_frame_atomic(self.out_dir / f"{name}.parquet", frame)
        shutil.rmtree(self.trials_dir / name)
        self.progress(f"accuracy study: {name} stored")


def run_study(out_dir: Path, settings: StudySettings = StudySettings(),
              experiments: tuple[str, ...] = AccuracyStudy.EXPERIMENTS, resume: bool = False,
              progress: Callable[[str], None] = print, workers: int = 1, scheduler: Any = None,
              stop: threading.Event | None = None, bar: bool = True) -> Path:
    """The study on the shipped scenes into OUT_DIR/study/, on `workers` local processes
    or the Dask cluster at `scheduler` (the trials are the same either way); once `stop` is
    set it ends after the tasks it is storing, unassembled (`resume` continues it); `bar`
    off hides its progress bar (it runs beside another)."""
    return AccuracyStudy(settings, paths.scenes_dir(), out_dir, progress, workers, scheduler, stop,
                         bar).run(experiments, resume)
