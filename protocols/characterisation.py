"""Sections 4-5, Figs. 5, 8 and 9: amplitude and power against voltage at resonance.

For each plate (the six small plates of Fig. 5, the large plate of Figs. 8-9) the paper
"adjusted the waveform generator to activate the plate at the desired resonance
frequency" and "applied several voltages", reading amplitude (vibrometer) and power
(scope). Analysis fits amplitude against V (Eq. 27 gives Q) and power against V² (Eq. 25
gives Q·tanθ'). The resonance may move with drive level (heating, nonlinearity), so it
is re-centred before each voltage unless `track_resonance` is off. One plate is one step.

Tracking reads only the velocity, which is clean with little averaging: with
`tracking_averages` set, the search runs at that averaging and only the recorded points
use the run's. On a heating plate this matters (the accuracy study's `heating`
experiment): a slow search lags the drift it is meant to follow.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from squeezebench.protocols import resonance
from squeezebench.protocols.acquisition import Acquisition, AcquisitionSettings
from squeezebench.protocols.resonance import SearchSettings, track_resonance
from squeezebench.protocols.steps import Plate, Step, StepContext

PROTOCOL = "characterisation"


@dataclass(frozen=True, kw_only=True)
class CharacterisedPlate(Plate):
    search: SearchSettings | None = None  # default: the run's search


@dataclass(frozen=True)
class Parameters:
    search: SearchSettings
    voltages_vpp: tuple[float, ...]
    plates: tuple[CharacterisedPlate, ...] = ()   # default: the run's own plate
    track_resonance: bool = True
    tracking_averages: int | None = None   # default: the run's averaging

    def __post_init__(self) -> None:
        if not self.voltages_vpp or any(not v > 0 for v in self.voltages_vpp):
            raise ValueError("voltages_vpp must be a non-empty list of positive voltages")
        if self.tracking_averages is not None:
            AcquisitionSettings(averages=self.tracking_averages)   # the same rule as the run's


def plan(params: Parameters, plate: Plate) -> list[Step]:
    plates = params.plates or (CharacterisedPlate(name=plate.name, n_powered_columns=plate.n_powered_columns,
                                                  n_powered_piezos=plate.n_powered_piezos, scene=plate.scene),)
    return [Step(f"plate_{p.name}", p, lambda ctx, p=p: _sweep_voltage(ctx, params, p.search or params.search))
            for p in plates]


def _sweep_voltage(ctx: StepContext, params: Parameters, search: SearchSettings) -> None:
    frequency_hz = resonance.record_search(ctx, search)
    tracker = ctx.acquisition
    if params.tracking_averages is not None:
        tracker = Acquisition(ctx.bench, ctx.drive, replace(ctx.acquisition.settings,
                                                            averages=params.tracking_averages))
    for voltage_vpp in sorted(params.voltages_vpp):   # upwards: the drive only ever ramps up
        ctx.drive.set_piezo_voltage(voltage_vpp)
        if params.track_resonance:
            if tracker is not ctx.acquisition:
                tracker.configure()
            frequency_hz = track_resonance(tracker.measure_at, frequency_hz, search).frequency_hz
            if tracker is not ctx.acquisition:
                ctx.acquisition.configure()
        ctx.drive.set_frequency(frequency_hz)
        ctx.record(ctx.acquisition.measure(keep_waveforms=True), resonance_frequency_hz=frequency_hz)
