"""What accuracy costs in bench time, measured on the simulated bench (ground truth known).

Each experiment varies the settings that cost bench time and scores every measurement
against the scene's closed-form truth (`SimulatedBench.resonance_truth`), with the cost
read from the virtual bench clock. Measurements are reduced exactly as the report reduces
stored waveforms (`analysis.waveforms.reduce_record`; Q and tan(theta') by
`analysis.tables.characterise_plate`), so an error here is an error in the report.

Experiments (the scene, state and voltage of each are in `StudySettings`):
- `averages`: sample mode and scope averaging 2..512 at resonance -> power, velocity, amplitude;
- `record`: periods per record x record length (500 / 10000 points) -> the same;
- `search`: coarse sweep points x golden-section tolerance -> resonance frequency;
- `settle`: wait after a voltage step (ring-up, `settling_transient` on) -> power, velocity;
- `sweep`: voltages in a characterisation sweep x averaging -> Q, tan(theta');
- `heating`: a series of points at a high voltage with `heating_drift` on, at the
  frequency found cold or re-centred before each point (tracking), per averaging.

Every configuration is repeated (`repeats`) on one seeded bench: the repeats draw
successive noise streams, so the trials give error distributions, not single points.
The trials go to RUN_DIR/study/<experiment>.parquet, one row per (trial, quantity), each
experiment written atomically when it completes; the scenes as run (effects added) are
copied to RUN_DIR/study/inputs/. `analysis.study` turns them into Pareto fronts.
"""

from __future__ import annotations

import contextlib
import itertools
import dataclasses
import json
import os
from pathlib import Path
from typing import Callable, Iterator

import numpy as np
import pandas as pd
import yaml

import squeezebench
from squeezebench.analysis import model
from squeezebench.analysis.study import STUDY_DIR
from squeezebench.analysis.tables import characterise_plate
from squeezebench.analysis.waveforms import PointReduction, reduce_record
from squeezebench.instruments.bench import open_bench, sim_bench_config
from squeezebench.protocols.acquisition import Acquisition, AcquisitionSettings, Point
from squeezebench.protocols.resonance import SearchSettings, find_resonance, track_resonance
from squeezebench.protocols.safety import DriveController, SafetyLimits
from squeezebench import paths



@dataclasses.dataclass(frozen=True)
class StudySettings:
    repeats: int = 8
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

    def __post_init__(self) -> None:
        if self.repeats < 2:
            raise ValueError(f"repeats must be at least 2 (a distribution), got {self.repeats!r}")


class Trials:
    """Rows of one experiment: each trial's full settings, its cost and its errors."""

    def __init__(self, experiment: str, base: dict) -> None:
        self.experiment = experiment
        self.base = base
        self.rows: list[dict] = []

    def add(self, knobs: dict, repeat: int, bench_time_s: float, values: dict[str, tuple[float, float]]) -> None:
        """`values` maps a quantity name (with its unit) to (measured, true)."""
        for quantity, (measured, true) in values.items():
            self.rows.append({"experiment": self.experiment, **self.base, **knobs, "repeat": repeat,
                              "bench_time_s": bench_time_s, "quantity": quantity,
                              "measured_value": measured, "true_value": true,
                              "rel_error": measured / true - 1.0})

    def frame(self) -> pd.DataFrame:
        return pd.DataFrame(self.rows)


@dataclasses.dataclass
class SimulatedSession:
    """An open simulated bench with its drive: the tools that need the scene's truth."""

    bench: object
    simulated: object
    drive: DriveController

    def now_s(self) -> float:
        return self.bench.clock.now_s()

    def acquisition(self, settings: AcquisitionSettings) -> Acquisition:
        acquisition = Acquisition(self.bench, self.drive, settings)
        acquisition.configure()
        return acquisition

    def go_to_resonance(self) -> None:
        self.drive.set_frequency(self.simulated.resonance_truth().frequency_hz)


@contextlib.contextmanager
def open_simulated(scene: Path, state: str | None, settle_s: float,
                   limits: SafetyLimits = SafetyLimits()) -> Iterator[SimulatedSession]:
    """The simulated bench of `scene` in `state`, driven within `limits`."""
    with open_bench(sim_bench_config(scene)) as bench:
        simulated = bench.resource_manager.visalib.bench
        if state is not None:
            simulated.set_state(state)
        with DriveController(bench.generator, bench.electronics, bench.clock, limits,
                             settle_s=settle_s) as drive:
            yield SimulatedSession(bench, simulated, drive)


def _reduce(point: Point) -> PointReduction:
    """The report's reduction of the point's waveforms."""
    preamble = point.waveform_metadata["preamble"]
    return reduce_record(point.waveforms, point.vibrometer_scale_mps_per_v,
                         y_increments={name: p["y_increment"] for name, p in preamble.items()},
                         averages=point.averages, frequency_hint_hz=point.generator_frequency_hz)


def _point_values(reduction: PointReduction, truth) -> dict[str, tuple[float, float]]:
    return {"power_w": (reduction.power_w.value, truth.power_w),
            "velocity_pp_mps": (reduction.velocity_pp_mps.value, truth.velocity_pp_mps),
            "amplitude_pp_m": (reduction.amplitude_pp_m.value, truth.amplitude_pp_m)}


class AccuracyStudy:
    """Runs the experiments of one study into a run directory's study/ folder."""

    def __init__(self, settings: StudySettings, scenes_dir: Path, out_dir: Path,
                 progress: Callable[[str], None] = lambda message: None) -> None:
        self.settings = settings
        self.scenes_dir = Path(scenes_dir)
        self.out_dir = Path(out_dir) / STUDY_DIR
        self.progress = progress
        base = settings.base
        self.defaults = {"averages": base.averages, "record_length": base.record_length,
                         "periods_per_record": base.periods_per_record, "search_points": 0,
                         "search_tolerance_hz": 0.0, "settle_s": base.settle_s, "n_voltages": 1,
                         "tracking": False}

    # -- scenes -------------------------------------------------------------------------------
    def _scene(self, name: str, extra_effects: tuple[str, ...] = (),
               q_mech: tuple[str, float] | None = None) -> Path:
        """The scene as run, copied into study/inputs/ (with the effects the study adds,
        and `q_mech` = (state, value) overriding one state's mechanical Q) and seeded by
        the study, so the trials can be redone from the run directory."""
        data = yaml.safe_load((self.scenes_dir / name).read_text(encoding="utf-8"))
        present = {e if isinstance(e, str) else next(iter(e)) for e in data.get("effects", [])}
        data["effects"] = [*data.get("effects", []), *(e for e in extra_effects if e not in present)]
        data["seed"] = self.settings.seed
        stem = Path(name).stem + "".join(f"+{e}" for e in extra_effects)
        if q_mech is not None:
            # A sharper resonance of the same plate (same modal mass, R_mech / (q/q_old))
            # reaching the same velocity at the same voltage needs a weaker coupling and
            # takes q_old/q of the power: scaling the calibrated power keeps the plate
            # physical (the scene refuses a modal mass q/q_old times the plate's).
            state = data["states"][q_mech[0]]
            state["calibration"]["power_w"] *= state["q_mech"] / q_mech[1]
            state["q_mech"] = q_mech[1]
            stem += f"+q{q_mech[1]:g}"
        path = self.out_dir / "inputs" / f"{stem}.yaml"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
        return path

    def _trials(self, experiment: str, scene: Path, state: str | None) -> Trials:
        return Trials(experiment, {"scene": scene.name, "state": state or ""})

    # -- experiments ----------------------------------------------------------------------------
    def averages(self) -> Trials:
        base = self.settings.base
        return self._at_the_point("averages", [dataclasses.replace(base, averages=n) for n in self.settings.averages])

    def record(self) -> Trials:
        s = self.settings
        return self._at_the_point("record", [
            dataclasses.replace(s.base, record_length=length, periods_per_record=periods)
            for length in s.record_lengths for periods in s.periods_per_record])

    def _at_the_point(self, experiment: str, variants: list[AcquisitionSettings]) -> Trials:
        """Repeated points at the Table 3 point, once per acquisition settings variant."""
        s = self.settings
        scene = self._scene(s.point_scene)
        trials = self._trials(experiment, scene, s.point_state)
        with open_simulated(scene, s.point_state, s.base.settle_s) as bench:
            bench.drive.set_piezo_voltage(s.point_voltage_vpp)
            bench.go_to_resonance()
            for settings in variants:
                self._repeat_points(bench, trials, settings)
        return trials

    def _repeat_points(self, bench: SimulatedSession, trials: Trials, settings: AcquisitionSettings) -> None:
        """`repeats` points at the present drive; ranging first, as a step's earlier points do."""
        acquisition = bench.acquisition(settings)
        acquisition.measure(keep_waveforms=False)
        truth = bench.simulated.resonance_truth()
        knobs = {"averages": settings.averages, "record_length": settings.record_length,
                 "periods_per_record": settings.periods_per_record}
        for repeat in range(self.settings.repeats):
            start_s = bench.now_s()
            point = acquisition.measure()
            trials.add({**self.defaults, **knobs}, repeat, bench.now_s() - start_s,
                       _point_values(_reduce(point), truth))

    def search(self) -> Trials:
        s = self.settings
        scene = self._scene(s.point_scene)
        trials = self._trials("search", scene, s.point_state)
        with open_simulated(scene, s.point_state, s.base.settle_s) as bench:
            bench.drive.set_piezo_voltage(s.search_voltage_vpp)
            true_hz = bench.simulated.resonance_truth().frequency_hz
            # Where the resonance falls in the range is luck: a seeded random offset per
            # trial, else a grid point could sit exactly on it.
            offsets_hz = np.random.default_rng(s.seed).uniform(-0.5, 0.5, size=s.repeats) * s.search_half_span_hz
            for n_averages, points, tolerance_hz in itertools.product(
                    s.search_averages, s.search_points, s.search_tolerances_hz):
                # A search reads only the velocity's peak-to-peak: the short record does.
                settings = dataclasses.replace(s.base, averages=n_averages, record_length=500)
                acquisition = bench.acquisition(settings)
                for repeat, offset_hz in enumerate(offsets_hz):
                    bench.simulated.reseed(s.seed + repeat)
                    search = SearchSettings(true_hz + offset_hz - s.search_half_span_hz,
                                            true_hz + offset_hz + s.search_half_span_hz,
                                            points=points, tolerance_hz=tolerance_hz)
                    acquisition.reset_ranges()   # each search starts as a step does
                    start_s = bench.now_s()
                    found = find_resonance(acquisition.measure_at, search)
                    knobs = {"averages": n_averages, "record_length": settings.record_length,
                             "search_points": points, "search_tolerance_hz": tolerance_hz}
                    trials.add({**self.defaults, **knobs}, repeat, bench.now_s() - start_s,
                               {"resonance_frequency_hz": (found.frequency_hz, true_hz)})
        return trials

    def settle(self) -> Trials:
        s = self.settings
        scene = self._scene(s.point_scene, ("settling_transient",), q_mech=(s.point_state, s.settle_q_mech))
        trials = self._trials("settle", scene, s.point_state)
        with open_simulated(scene, s.point_state, s.base.settle_s) as bench:
            bench.drive.set_piezo_voltage(s.settle_from_vpp)
            bench.go_to_resonance()
            acquisition = bench.acquisition(s.base)
            for settle_s in s.settle_s:
                for repeat in range(s.repeats):
                    bench.simulated.reseed(s.seed + repeat)
                    # Back to the lower level and fully rung down: each trial sees the same step.
                    bench.drive.settle_s = 1.0
                    bench.drive.set_piezo_voltage(s.settle_from_vpp)
                    acquisition.measure(keep_waveforms=False)
                    bench.drive.settle_s = settle_s
                    start_s = bench.now_s()
                    bench.drive.set_piezo_voltage(s.point_voltage_vpp)
                    point = acquisition.measure()
                    values = _point_values(_reduce(point), bench.simulated.resonance_truth())
                    del values["amplitude_pp_m"]   # velocity's error over a frequency known to 1e-6
                    trials.add({**self.defaults, "settle_s": settle_s}, repeat, bench.now_s() - start_s, values)
        return trials

    def sweep(self) -> Trials:
        s = self.settings
        scene = self._scene(s.sweep_scene)
        trials = self._trials("sweep", scene, None)
        with open_simulated(scene, None, s.base.settle_s) as bench:
            state = bench.simulated.state
            geometry = bench.simulated.scene.geometry(state)
            for n_voltages in s.sweep_voltage_counts:
                voltages_vpp = np.linspace(*s.sweep_voltage_range_vpp, n_voltages)
                truth = self._characterise(bench, voltages_vpp, geometry, measure=None)
                for n_averages in s.sweep_averages:
                    acquisition = bench.acquisition(dataclasses.replace(s.base, averages=n_averages))
                    for repeat in range(s.repeats):
                        bench.simulated.reseed(s.seed + repeat)
                        bench.drive.set_piezo_voltage(float(voltages_vpp[0]))
                        acquisition.reset_ranges()
                        start_s = bench.now_s()
                        measured = self._characterise(bench, voltages_vpp, geometry, measure=acquisition)
                        knobs = {"averages": n_averages, "n_voltages": n_voltages}
                        trials.add({**self.defaults, **knobs}, repeat, bench.now_s() - start_s,
                                   {"q": (measured.q.value, truth.q.value),
                                    "tan_theta": (measured.tan_theta.value, truth.tan_theta.value)})
        return trials

    def _characterise(self, bench: SimulatedSession, voltages_vpp, geometry, measure: Acquisition | None):
        """Q and tan(theta') from points at resonance (measured, or the closed-form truth
        at the same voltages when `measure` is None), by the report's own reduction."""
        rows = []
        for voltage_vpp in voltages_vpp:
            bench.drive.set_piezo_voltage(float(voltage_vpp))
            bench.go_to_resonance()
            if measure is None:
                truth = bench.simulated.resonance_truth()
                rows.append({"piezo_voltage_vpp": truth.output_voltage_pp_v, "amplitude_pp_m": truth.amplitude_pp_m,
                             "amplitude_pp_m_u": 0.0, "power_w": truth.power_w, "power_w_u": 0.0,
                             "frequency_hz": truth.frequency_hz})
            else:
                rows.append(_reduce(measure.measure()).as_row())   # the columns the report's points carry
        return characterise_plate(self.settings.sweep_scene, pd.DataFrame(rows), geometry, model.PAPER_CONVENTION)

    def heating(self) -> Trials:
        s = self.settings
        scene = self._scene(s.heating_scene, ("heating_drift",))
        trials = self._trials("heating", scene, s.heating_state)
        tracking = SearchSettings(1.0, 2.0, tracking_step_hz=s.tracking_step_hz,
                                  tolerance_hz=s.tracking_tolerance_hz)
        for track in (False, True):
            for n_averages in s.heating_averages:
                # A fresh, cold plate per configuration: the resonance is found cold.
                with open_simulated(scene, s.heating_state, s.base.settle_s) as bench:
                    tracker = bench.acquisition(dataclasses.replace(s.base, averages=s.tracking_averages))
                    acquisition = bench.acquisition(dataclasses.replace(s.base, averages=n_averages))
                    bench.drive.set_piezo_voltage(s.heating_voltage_vpp)
                    bench.go_to_resonance()
                    frequency_hz = bench.drive.frequency_hz
                    acquisition.measure(keep_waveforms=False)
                    for index in range(s.heating_points):
                        start_s = bench.now_s()
                        if track:
                            tracker.configure()
                            frequency_hz = track_resonance(tracker.measure_at, frequency_hz,
                                                           tracking).frequency_hz
                            bench.drive.set_frequency(frequency_hz)
                            acquisition.configure()
                        truth = bench.simulated.resonance_truth()
                        point = acquisition.measure()
                        knobs = {"averages": n_averages, "tracking": track}
                        trials.add({**self.defaults, **knobs}, index, bench.now_s() - start_s,
                                   {"power_w": (_reduce(point).power_w.value, truth.power_w)})
        return trials

    # -- running ----------------------------------------------------------------------------------
    EXPERIMENTS = ("averages", "record", "search", "settle", "sweep", "heating")

    def run(self, experiments: tuple[str, ...] = EXPERIMENTS, resume: bool = False) -> Path:
        """Run the experiments; with `resume`, keep those already stored under the same settings."""
        unknown = set(experiments) - set(self.EXPERIMENTS)
        if unknown:
            raise ValueError(f"unknown experiments {sorted(unknown)}; allowed: {', '.join(self.EXPERIMENTS)}")
        self.out_dir.mkdir(parents=True, exist_ok=True)
        manifest_path = self.out_dir / "manifest.json"
        manifest = {"software_version": squeezebench.__version__,
                    "settings": json.loads(json.dumps(dataclasses.asdict(self.settings), default=str))}
        stored = json.loads(manifest_path.read_text(encoding="utf-8")) if manifest_path.exists() else None
        keep = resume and stored is not None and stored.get("settings") == manifest["settings"]
        if not keep:
            for old in self.out_dir.glob("*.parquet"):   # trials of other settings would mix in
                old.unlink()
        manifest_path.write_text(json.dumps(manifest, indent=2), encoding="utf-8")
        for name in experiments:
            path = self.out_dir / f"{name}.parquet"
            if keep and path.exists():
                self.progress(f"accuracy study: {name} already stored")
                continue
            self.progress(f"accuracy study: {name}")
            _write_atomically(getattr(self, name)().frame(), path)
        return self.out_dir


def _write_atomically(frame: pd.DataFrame, path: Path) -> None:
    temporary = path.with_name(f".{path.name}.tmp")
    frame.to_parquet(temporary, index=False)
    os.replace(temporary, path)


def run_study(out_dir: Path, settings: StudySettings = StudySettings(),
              experiments: tuple[str, ...] = AccuracyStudy.EXPERIMENTS, resume: bool = False,
              progress: Callable[[str], None] = print) -> Path:
    """The study on the shipped scenes into OUT_DIR/study/."""
    return AccuracyStudy(settings, paths.scenes_dir(), out_dir, progress).run(experiments, resume)
