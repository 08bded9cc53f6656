"""Where averaging stops paying: total error on benches whose instruments err within spec.

The accuracy study's `systematics_*` experiments (`protocols.accuracy_study`). A trial is
one simulated bench: its systematic errors are drawn once from its `bench_seed`
(`variants.systematic_effects`; trial k is bench k + 1 in every experiment, the same
benches `plan` checks and the coverage runs on), its noise from the trial's own seed.
On that bench a point is measured and reduced as the report reduces it and scored
against the truth at its setting: the same plate without the errors, driven at the same
generator frequency and amplitude (what `analysis.uncertainty` calls the point's value).

Points of the paper campaign: the Table 3 point (the gains dominate), the Fig. 2c stress
point (power factor 0.018: the CH2 delay dominates), the characterisation of a Fig. 5
plate (Q and tan theta'), the resonance search (its tolerance against the generator's
frequency error, which no calibration of this bench lifts: that needs a frequency
reference), and the whole campaign at one averaging for all its runs, every stored
point scored and the campaign's bench time the cost (minutes of computing: `reproduce`
leaves it to `study`). Each but the search is also run, in the experiment
`..._calibrated`, after the deskew and gain check (`protocols.calibration`) on the same
bench, whose correction the power takes and whose bench time the trial is charged (per
point: the worst case; a campaign pays it once). A calibrated point or sweep trial corrects
the very reading its plain twin's trial scores (the same bench and noise: the two columns
differ by the calibration alone, and a worker measures the reading once, `_point_reading`,
`_sweep_reading`). As on a real bench, a bench is
calibrated once and every configuration measured on it takes that calibration: it is
measured on a bench of its own with the same drawn errors and its own seed
(`bench_calibration`), kept by the worker that runs all of them
(`accuracy_study.work_units`). Averaging lowers the noise until the bench's errors are
all that is left: the floor.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Iterator

import numpy as np
import pandas as pd

from squeezebench import paths
from squeezebench.yamlfiles import load_strict
from squeezebench.analysis import model
from squeezebench.analysis.calibration import Deskew, calibration_from_points
from squeezebench.analysis.characterisation import characterise_plate
from squeezebench.protocols import calibration
from squeezebench.protocols.acquisition import AcquisitionSettings
from squeezebench.protocols.resonance import SearchSettings, find_resonance
from squeezebench.protocols.safety import SafetyLimits
from squeezebench.protocols.simulated_session import (
    SimulatedSession, characterise_at_resonance, open_simulated, points_at_resonance, reduce_point)
from squeezebench.protocols.variants import (CALIBRATION_PROTOCOL, planned_campaign, scene_with_effects,
                                             systematic_effects)

if TYPE_CHECKING:
    from squeezebench.protocols.accuracy_study import TaskRun


@dataclasses.dataclass(frozen=True)
class SystematicsSettings:
    """What the systematics experiments measure (a field of `StudySettings`)."""

    averages: tuple[int, ...] = (1, 4, 16, 64, 256)
    sweep_averages: tuple[int, ...] = (4, 32, 256)
    sweep_voltages: int = 5
    search_tolerances_hz: tuple[float, ...] = (10.0, 1.0, 0.1)
    search_points: int = 11
    search_averages: int = 16   # the flat top of the peak is found in the noise
    campaign: str = "paper.yaml"   # a shipped campaign (squeezebench.paths.campaigns_dir())
    campaign_averages: tuple[int, ...] = (1, 16, 256)
    # The Fig. 2c stress point: the uncut plate far above its resonance, power factor 0.018.
    stress_state: str = "76x41"
    stress_voltage_vpp: float = 240.0
    stress_frequency_hz: float = 37560.0
    calibration: calibration.Parameters = calibration.Parameters()
    calibration_acquisition: AcquisitionSettings = AcquisitionSettings(averages=64, record_length=10000,
                                                                       periods_per_record=20.0, settle_s=0.05)


def _bench_scene(scene: Path, repeat: int) -> Path:
    """Bench `repeat + 1` of `scene`, its instruments' errors drawn from that seed, written beside it."""
    return scene_with_effects(scene, scene.parent / f"bench_{repeat + 1}", systematic_effects(repeat + 1))


def measure_calibration(session: SimulatedSession, settings: SystematicsSettings) -> Deskew:
    """The deskew and gain check on this bench (the resistor in the plate's place, as
    `protocols.calibration` has the operator do), then the plate back."""
    params = settings.calibration
    plate_state = session.simulated.state_name
    session.simulated.set_state(calibration.resistor_state(params.load_ohm))
    acquisition = session.acquisition(settings.calibration_acquisition)
    session.drive.set_frequency(params.frequency_hz)
    session.drive.set_piezo_voltage(params.piezo_voltage_vpp)
    columns = {"run_name": "deskew", "calibration_load_ohm": params.load_ohm,
               "shunt_ohm": session.bench.electronics.shunt_ohm,
               "calibration_load_tolerance_rel": params.load_tolerance_rel}
    rows = [{**reduce_point(acquisition.measure()).as_row(), **columns} for _ in range(params.repeats)]
    session.drive.to_minimum()
    session.simulated.set_state(plate_state)
    return calibration_from_points(pd.DataFrame(rows))


def bench_calibration(run: "TaskRun", repeat: int, limits: SafetyLimits) -> tuple[Deskew, float]:
    """The deskew calibration of bench `repeat + 1` and its bench time: what every
    configuration of the task's experiment measured on that bench takes."""
    task = run.task
    return _calibration(task.scene_file, task.scene_text, task.state, repeat, limits, run.settings.base.settle_s,
                        run.settings.systematics, task.bench_seed("calibration", repeat))


@functools.lru_cache(maxsize=64)
def _calibration(scene_file: str, scene_text: str, state: str | None, repeat: int, limits: SafetyLimits,
                 settle_s: float, settings: SystematicsSettings, seed: int) -> tuple[Deskew, float]:
    """`measure_calibration` on a fresh bench `repeat + 1` of the scene, its noise from `seed`:
    a function of its arguments only, so kept for the worker's next configuration."""
    with tempfile.TemporaryDirectory(prefix="squeezebench-calibration-") as tmp:
        scene = Path(tmp) / scene_file
        scene.write_text(scene_text, encoding="utf-8")
        with open_simulated(_bench_scene(scene, repeat), state, settle_s, limits) as session:
            session.simulated.reseed(seed)
            start_s = session.now_s()
            return measure_calibration(session, settings), session.now_s() - start_s


@functools.lru_cache(maxsize=64)
def _plain_truth(scene_file: str, scene_text: str, state: str | None, settle_s: float, limits: SafetyLimits,
                 frequency_hz: float, generator_vpp: float):
    """The truth of a fresh bench of the scene without the errors, its generator at this
    setting (the point's value, `analysis.uncertainty`): a function of its arguments only, so
    kept for the worker's next trial (every averaging of every bench asks for the same few
    settings: the reproduction's 60 point readings for 2)."""
    with tempfile.TemporaryDirectory(prefix="squeezebench-truth-") as tmp:
        scene = Path(tmp) / scene_file
        scene.write_text(scene_text, encoding="utf-8")
        with open_simulated(scene, state, settle_s, limits) as plain:
            plain.bench.generator.set_frequency(frequency_hz)
            plain.bench.generator.set_amplitude_vpp(generator_vpp)
            return plain.simulated.truth()


@dataclasses.dataclass(frozen=True)
class Reading:
    """What one trial of a point or a sweep reads on its bench, whatever is done with it
    after (as the bench is, or deskewed): `_point_reading`, `_sweep_reading`."""

    scene_file: str
    scene_text: str
    state: str | None
    settle_s: float
    limits: SafetyLimits
    acquisition: AcquisitionSettings
    repeat: int
    seed: int   # the trial's noise (`accuracy_study.Task.seed`: the plain experiment's)

    @classmethod
    def of(cls, run: "TaskRun", repeat: int, limits: SafetyLimits) -> "Reading":
        task = run.task
        return cls(task.scene_file, task.scene_text, task.state, run.settings.base.settle_s, limits,
                   run.acquisition_settings(), repeat, task.seed(repeat))

    @contextlib.contextmanager
    def bench(self) -> Iterator[SimulatedSession]:
        """Bench `repeat + 1`: the plate, the instruments' errors drawn from that seed, its noise from `seed`."""
        with tempfile.TemporaryDirectory(prefix="squeezebench-reading-") as tmp:
            scene = Path(tmp) / self.scene_file
            scene.write_text(self.scene_text, encoding="utf-8")
            with open_simulated(_bench_scene(scene, self.repeat), self.state, self.settle_s, self.limits) as session:
                session.simulated.reseed(self.seed)
                yield session


# A calibrated experiment reads what its plain twin read, trial for trial (the same bench, the
# same noise: `accuracy_study.Experiment.readings_of`), and a worker runs both: these keep a
# worker's readings for the twin's trials, which then only correct them.
@functools.lru_cache(maxsize=128)
def _point_reading(reading: Reading, point: str, voltage_vpp: float, stress_frequency_hz: float):
    """(reduction, truth, bench time) of one point trial: `point_trials`."""
    with reading.bench() as session:
        session.drive.set_piezo_voltage(voltage_vpp)
        if point == "table3":
            session.go_to_resonance()
        else:
            session.drive.set_frequency(stress_frequency_hz)
        truth = _plain_truth(reading.scene_file, reading.scene_text, reading.state, reading.settle_s, reading.limits,
                             session.drive.frequency_hz, session.drive.generator_amplitude_vpp)
        acquisition = session.acquisition(reading.acquisition)
        acquisition.measure(keep_waveforms=False)   # ranging, as a step's earlier points do
        start_s = session.now_s()
        reduction = reduce_point(acquisition.measure())
        return reduction, truth, session.now_s() - start_s


def point_trials(point: str, calibrated: bool, run: "TaskRun") -> None:
    """Power and velocity at the Table 3 point (`point="table3"`, at resonance) or the
    stress point (`"stress"`, at its fixed frequency), one trial per bench; calibrated, the
    same reading with the bench's deskew correction, its bench time the calibration's more."""
    s, x = run.settings, run.settings.systematics
    voltage_vpp = s.point_voltage_vpp if point == "table3" else x.stress_voltage_vpp
    limits = SafetyLimits(max_piezo_voltage_vpp=max(voltage_vpp, SafetyLimits().max_piezo_voltage_vpp))
    for repeat in range(s.repeats):
        correction, calibration_s = bench_calibration(run, repeat, limits) if calibrated else (None, 0.0)
        reduction, truth, bench_time_s = _point_reading(Reading.of(run, repeat, limits), point, voltage_vpp,
                                                        x.stress_frequency_hz)
        power_w = reduction.power_w.value
        if correction is not None:
            power_w = correction.corrected_power_w(power_w, reduction.reactive_power_var.value,
                                                   reduction.frequency_hz.value)
        run.add(repeat, bench_time_s + calibration_s,
                {"power_w": (power_w, truth.power_w),
                 "velocity_pp_mps": (reduction.velocity_pp_mps.value, truth.velocity_pp_mps)})


@functools.lru_cache(maxsize=32)
def _sweep_reading(reading: Reading, voltages_vpp: tuple[float, ...]) -> tuple[pd.DataFrame, float]:
    """(the points at resonance, bench time) of one sweep trial: `sweep_trials` (read-only)."""
    with reading.bench() as session:
        start_s = session.now_s()
        points = points_at_resonance(session, voltages_vpp, session.acquisition(reading.acquisition))
        return points, session.now_s() - start_s


def sweep_trials(calibrated: bool, run: "TaskRun") -> None:
    """Q and tan theta' of a Fig. 5 plate, characterised at resonance over the sweep's
    voltages, one trial per bench (calibrated: the same points, their power deskewed); the
    truth is the same characterisation of the plate without the errors, from its closed-form points."""
    s = run.settings
    voltages_vpp = np.linspace(*s.sweep_voltage_range_vpp, run.knobs["n_voltages"])
    limits = SafetyLimits()
    with open_simulated(run.scene, run.task.state, s.base.settle_s, limits) as plain:
        geometry = plain.simulated.scene.geometry(plain.simulated.state)
        truth = characterise_at_resonance(plain, s.sweep_scene, voltages_vpp, geometry, measure=None)
    for repeat in range(s.repeats):
        correction, calibration_s = bench_calibration(run, repeat, limits) if calibrated else (None, 0.0)
        points, bench_time_s = _sweep_reading(Reading.of(run, repeat, limits), tuple(voltages_vpp))
        if correction is not None:
            points = points.assign(power_w=correction.corrected_power_w(
                points["power_w"], points["reactive_power_var"], points["frequency_hz"]))
        measured = characterise_plate(s.sweep_scene, points, geometry, model.PAPER_CONVENTION)
        run.add(repeat, bench_time_s + calibration_s,
                {"q": (measured.q.value, truth.q.value),
                 "tan_theta": (measured.tan_theta.value, truth.tan_theta.value)})


def search_trials(run: "TaskRun") -> None:
    """The resonance search over the Table 3 plate's peak, one trial per bench: the
    generator setting it ends on against the plate's resonance. The search reads the
    generator's own setting, so the generator's frequency error is an error of the result."""
    s = run.settings
    offsets_hz = np.random.default_rng(s.seed).uniform(-0.5, 0.5, size=s.repeats) * s.search_half_span_hz
    for repeat in range(s.repeats):
        reading = Reading.of(run, repeat, SafetyLimits())
        with reading.bench() as session:
            session.drive.set_piezo_voltage(s.search_voltage_vpp)
            true_hz = session.simulated.resonance_truth().frequency_hz
            centre_hz = true_hz + offsets_hz[repeat]   # where the peak falls in the range is luck
            search = SearchSettings(centre_hz - s.search_half_span_hz, centre_hz + s.search_half_span_hz,
                                    points=run.knobs["search_points"], tolerance_hz=run.knobs["search_tolerance_hz"])
            acquisition = session.acquisition(reading.acquisition)
            start_s = session.now_s()
            run.add_search(repeat, start_s, find_resonance(acquisition.measure_at, search), search, true_hz,
                           s.systematics.search_tolerances_hz)


@dataclasses.dataclass(frozen=True)
class CampaignSpec:
    """What a `systematics_campaign` task carries in a scene's place: a shipped campaign's
    text (its scenes are found in the shipped scenes, `protocols.campaign`)."""

    name: str

    @property
    def file_name(self) -> str:
        return self.name

    def render(self, scenes_dir: Path, seed: int) -> str:
        return (paths.campaigns_dir() / self.name).read_text(encoding="utf-8")


def campaign_trials(calibrated: bool, run: "TaskRun") -> None:
    """The whole campaign (`run.scene` is its file) with every run at the task's
    averaging, after the deskew calibration when `calibrated`, one trial per bench: every
    stored point's power and velocity against the truth at its setting; the cost is the
    campaign's bench time (the calibration's included)."""
    # Imported here: every study worker imports this module, and only this experiment,
    # which `reproduce` leaves out, needs the coverage study's machinery (0.25 CPU-s of imports).
    from squeezebench.protocols.bench_errors import errors_on_bench

    names = [entry["name"] for entry in load_strict(run.scene.read_text(encoding="utf-8"))["runs"]
             if entry["protocol"] != CALIBRATION_PROTOCOL]   # the calibration keeps its own averaging
    settings = {name: {"averages": run.knobs["averages"]} for name in names}
    for repeat in range(run.settings.repeats):
        with tempfile.TemporaryDirectory(prefix="squeezebench-campaign-") as tmp:
            variant = planned_campaign(run.scene, settings, calibrated, Path(tmp) / run.scene.name)
            errors = errors_on_bench(variant, repeat + 1, Path(tmp) / "bench")
        for _, point in errors.groupby(["run_name", "step_id", "point_index"], sort=False):
            run.add(repeat, errors.attrs["bench_time_s"],
                    {row.quantity: (row.measured_value, row.true_value) for row in point.itertuples()})
