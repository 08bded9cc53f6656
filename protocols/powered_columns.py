"""Section 2.3.2, Table 4: do unpowered piezoceramics dissipate? Compare configurations.

The paper compares a one-column plate at 24 V pp with a two-column plate (76 × 41 ×
1.2 mm) where one column is powered at 24 V pp, then both at 12 V pp: with the same
amplitude the power stays the same (the unpowered column takes none) and doubling the
powered piezos halves the voltage (Eq. 1, A ∝ n_c V). Each configuration is one step:
mount the plate / connect the columns, search the resonance, record the point.
"""

from __future__ import annotations

from dataclasses import dataclass

from squeezebench.protocols import resonance
from squeezebench.protocols.resonance import SearchSettings
from squeezebench.protocols.steps import Plate, Step, StepContext

PROTOCOL = "powered_columns"


@dataclass(frozen=True, kw_only=True)
class Configuration(Plate):
    configuration: str                  # "1-column", "2-columns 1 powered", ...
    piezo_voltage_vpp: float
    search: SearchSettings | None = None  # default: the run's search


@dataclass(frozen=True)
class Parameters:
    search: SearchSettings
    configurations: tuple[Configuration, ...]


def plan(params: Parameters, plate: Plate) -> list[Step]:
    return [Step(f"configuration_{i + 1}", configuration,
                 lambda ctx, configuration=configuration: _measure(ctx, params, configuration))
            for i, configuration in enumerate(params.configurations)]


def _measure(ctx: StepContext, params: Parameters, configuration: Configuration) -> None:
    resonance.record_point_at_resonance(ctx, configuration.search or params.search,
                                        configuration.piezo_voltage_vpp,
                                        configuration=configuration.configuration)
