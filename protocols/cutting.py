"""Section 2.3.1, Table 3: does the resonator itself dissipate? Cut it and compare.

The paper: the one-column plate is cut "symmetrically" from 75 mm to 59 mm and finally
28 mm; at each length the same 20 V pp is applied at resonance and "the power and
vibration velocity at the center of the plate" are measured. Each length is one step:
the operator cuts (on the simulated bench the scene switches state), the resonance is
searched again (a shorter resonator resonates elsewhere: 35130 Hz at 28 mm), then the
point at 20 V pp is recorded.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from squeezebench.protocols import resonance
from squeezebench.protocols.resonance import SearchSettings
from squeezebench.protocols.steps import Plate, Step, StepContext

PROTOCOL = "resonator_cutting"


@dataclass(frozen=True)
class Length:
    plate_length_mm: float
    state: str                          # the scene state of the cut plate, e.g. "59x41"
    n_antinodes: int
    search: SearchSettings | None = None  # default: the run's search


@dataclass(frozen=True)
class Parameters:
    search: SearchSettings
    lengths: tuple[Length, ...]
    piezo_voltage_vpp: float = 20.0     # Table 3: 20 V pp at every length


def plan(params: Parameters, plate: Plate) -> list[Step]:
    steps = []
    for length in params.lengths:
        cut = replace(plate, state=length.state,
                      instruction=f"Cut the resonator symmetrically to {length.plate_length_mm:g} mm")
        steps.append(Step(f"length_{length.plate_length_mm:g}mm".replace(".", "p"), cut,
                          lambda ctx, length=length: _measure_length(ctx, params, length)))
    return steps


def _measure_length(ctx: StepContext, params: Parameters, length: Length) -> None:
    resonance.record_point_at_resonance(ctx, length.search or params.search, params.piezo_voltage_vpp,
                                        plate_length_mm=length.plate_length_mm,
                                        n_antinodes=length.n_antinodes)
