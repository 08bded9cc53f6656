"""A simulated bench opened for a study or a plan: the drive, the acquisition, and the
report's own reduction of what it measures.

The accuracy study, the systematics experiments and the planner all score measurements
against the scene's closed-form truth, so they need the simulator behind the bench (its
truth, its state, its noise seed) beside the drivers; this is the one place that opens
such a bench. Campaigns never use it: they see only the drivers.
"""

from __future__ import annotations

import contextlib
import dataclasses
from pathlib import Path
from typing import Iterator

import pandas as pd

from squeezebench.analysis import model
from squeezebench.analysis.characterisation import PlateCharacterisation, characterise_plate
from squeezebench.analysis.waveforms import PointReduction, reduce_record
from squeezebench.instruments.bench import open_bench, sim_bench_config
from squeezebench.protocols.acquisition import Acquisition, AcquisitionSettings, Point
from squeezebench.protocols.safety import DriveController, SafetyLimits


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


def reduce_point(point: Point) -> PointReduction:
    """The report's reduction of the point's waveforms."""
    preamble = point.waveform_metadata["preamble"]
    return reduce_record(point.waveforms, point.vibrometer_scale_mps_per_v,
                         y_increments={name: p["y_increment"] for name, p in preamble.items()},
                         averages=point.averages, frequency_hint_hz=point.generator_frequency_hz)


def points_at_resonance(session: SimulatedSession, voltages_vpp, measure: Acquisition | None) -> pd.DataFrame:
    """Points at resonance at each voltage, with the columns the report's points carry:
    measured and reduced by the report's own reduction, or the closed-form truth at the
    same voltages when `measure` is None."""
    rows = []
    for voltage_vpp in voltages_vpp:
        session.drive.set_piezo_voltage(float(voltage_vpp))
        session.go_to_resonance()
        if measure is None:
            truth = session.simulated.resonance_truth()
            rows.append({"piezo_voltage_vpp": truth.output_voltage_pp_v, "amplitude_pp_m": truth.amplitude_pp_m,
                         "amplitude_pp_m_u": 0.0, "power_w": truth.power_w, "power_w_u": 0.0,
                         "frequency_hz": truth.frequency_hz})
        else:
            rows.append(reduce_point(measure.measure()).as_row())
    return pd.DataFrame(rows)


def characterise_at_resonance(session: SimulatedSession, plate_name: str, voltages_vpp, geometry,
                              measure: Acquisition | None) -> PlateCharacterisation:
    """Q and tan(theta') from `points_at_resonance`, by the report's own reduction."""
    return characterise_plate(plate_name, points_at_resonance(session, voltages_vpp, measure), geometry,
                              model.PAPER_CONVENTION)
