"""Where averaging stops paying: total error on benches whose instruments err within spec.

For each of `benches` simulated benches (systematic errors drawn once from its
`bench_seed`, `variants.systematic_effects`) and each averaging count, one point is
measured and reduced as the report reduces it, and scored against the truth at its
setting (the same plate without the errors). Two points: the Table 3 point (gains
dominate) and the Fig. 2c stress point (power factor 0.018: the CH2 delay dominates).
Each configuration is scored twice: as the bench is (`systematics_<point>`) and with the
power corrected by the calibration (deskew and gain check) run on that bench first
(`..._calibrated`), whose
bench time is charged to the trial (one calibration per point: the worst case; a
campaign pays it once). The rows follow the study's trial schema (`analysis.study`), one
bench per `repeat`, so the p95 over benches and the fronts come out as for the other
experiments: averaging lowers the noise until the bench's errors are all that is left.
"""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

import pandas as pd

from squeezebench.analysis.calibration import calibration_from_points
from squeezebench.analysis.study import STUDY_DIR
from squeezebench.instruments.bench import open_bench, sim_bench_config
from squeezebench.protocols import calibration
from squeezebench.protocols.accuracy_study import SimulatedSession, _reduce, _write_atomically, open_simulated
from squeezebench.protocols.acquisition import AcquisitionSettings
from squeezebench.protocols.safety import SafetyLimits
from squeezebench.protocols.variants import scene_with_effects, systematic_effects


@dataclasses.dataclass(frozen=True)
class StudyPoint:
    name: str
    scene: str
    state: str
    voltage_vpp: float
    frequency_hz: float | None   # None: at the resonance


@dataclasses.dataclass(frozen=True)
class SystematicsSettings:
    benches: int = 8
    averages: tuple[int, ...] = (1, 4, 16, 64, 256)
    base: AcquisitionSettings = AcquisitionSettings(averages=16, record_length=10000,
                                                    periods_per_record=20.0, settle_s=0.05)
    points: tuple[StudyPoint, ...] = (
        StudyPoint("table3", "one_column_1mm.yaml", "75x41", 20.0, None),
        StudyPoint("stress", "one_column_1mm.yaml", "76x41", 240.0, 37560.0))
    calibration: calibration.Parameters = calibration.Parameters(frequency_hz=37000.0)
    calibration_acquisition: AcquisitionSettings = AcquisitionSettings(averages=64, record_length=10000,
                                                                       periods_per_record=20.0, settle_s=0.05)


def _deskew(session: SimulatedSession, state: str, settings: SystematicsSettings):
    """Run the calibration on this bench (resistor in the plate's place), then put the plate back."""
    params = settings.calibration
    session.simulated.set_state(calibration.resistor_state(params.load_ohm))
    acquisition = session.acquisition(settings.calibration_acquisition)
    session.drive.set_frequency(params.frequency_hz)
    session.drive.set_piezo_voltage(params.piezo_voltage_vpp)
    columns = {"run_name": "deskew", "calibration_load_ohm": params.load_ohm, "shunt_ohm": session.bench.electronics.shunt_ohm,
               "calibration_load_tolerance_rel": params.load_tolerance_rel}
    rows = [{**_reduce(acquisition.measure()).as_row(), **columns} for _ in range(params.repeats)]
    session.drive.to_minimum()
    session.simulated.set_state(state)
    return calibration_from_points(pd.DataFrame(rows))


def _truth(plain_scene: Path, state: str, frequency_hz: float, generator_vpp: float):
    with open_bench(sim_bench_config(plain_scene)) as bench:
        simulated = bench.resource_manager.visalib.bench
        simulated.set_state(state)
        bench.generator.set_frequency(frequency_hz)
        bench.generator.set_amplitude_vpp(generator_vpp)
        return simulated.truth()


def systematics_trials(settings: SystematicsSettings, work_dir: Path) -> pd.DataFrame:
    """The trial rows of both experiments, all points, all benches."""
    rows: list[dict] = []
    defaults = {"record_length": settings.base.record_length, "periods_per_record": settings.base.periods_per_record,
                "search_points": 0, "search_tolerance_hz": 0.0, "settle_s": settings.base.settle_s,
                "n_voltages": 1, "tracking": False}
    for point in settings.points:
        limits = SafetyLimits(max_piezo_voltage_vpp=max(point.voltage_vpp, SafetyLimits().max_piezo_voltage_vpp))
        plain = scene_with_effects(point.scene, work_dir / "plain", [])
        for seed in range(1, settings.benches + 1):
            erring = scene_with_effects(point.scene, work_dir / f"bench_{seed}", systematic_effects(seed))
            with open_simulated(erring, point.state, settings.base.settle_s, limits) as session:
                start_s = session.now_s()
                deskew = _deskew(session, point.state, settings)
                calibration_s = session.now_s() - start_s
                session.drive.set_piezo_voltage(point.voltage_vpp)
                if point.frequency_hz is None:
                    session.go_to_resonance()
                else:
                    session.drive.set_frequency(point.frequency_hz)
                truth = _truth(plain, point.state, session.drive.frequency_hz, session.drive.generator_amplitude_vpp)
                for averages in settings.averages:
                    acquisition = session.acquisition(dataclasses.replace(settings.base, averages=averages))
                    acquisition.measure(keep_waveforms=False)   # ranging, as a step's earlier points do
                    start_s = session.now_s()
                    reduction = _reduce(acquisition.measure())
                    point_s = session.now_s() - start_s
                    corrected_w = deskew.corrected_power_w(reduction.power_w.value, reduction.reactive_power_var.value,
                                                           reduction.frequency_hz.value)
                    base = {"scene": Path(point.scene).name, "state": point.state,
                            **defaults, "averages": averages, "repeat": seed}
                    velocity = (reduction.velocity_pp_mps.value, truth.velocity_pp_mps)
                    experiment = f"systematics_{point.name}"
                    for experiment, power_w, cost_s in (
                            (experiment, reduction.power_w.value, point_s),
                            (f"{experiment}_calibrated", corrected_w, point_s + calibration_s)):
                        for quantity, (measured, true) in (("power_w", (power_w, truth.power_w)),
                                                           ("velocity_pp_mps", velocity)):
                            rows.append({"experiment": experiment, **base, "bench_time_s": cost_s,
                                         "quantity": quantity, "measured_value": measured, "true_value": true,
                                         "rel_error": measured / true - 1.0})
    return pd.DataFrame(rows)


def run_systematics_study(out_dir: Path, settings: SystematicsSettings = SystematicsSettings()) -> Path:
    """Write OUT_DIR/study/systematics.parquet (both experiments); return its path."""
    path = Path(out_dir) / STUDY_DIR / "systematics.parquet"
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="squeezebench-systematics-") as tmp:
        frame = systematics_trials(settings, Path(tmp))
    _write_atomically(frame, path)
    return path
