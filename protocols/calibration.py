"""Deskew and current-gain check: a known resistor through the plate's own channels.

The operator replaces the plate by a calibration resistor (the shunt, probes and cables
stay as for the plate) and the bench drives it at the plates' working frequency. Through
a resistor voltage and current are in phase and i = v / (R + R_shunt), so the stored
records give what the plate measurements cannot: the delay of CH2 (TCP202 and scope
skew) against CH1, and the ratio of the current path's gain to the voltage path's.
`analysis.calibration` turns the records into the correction the budgets apply; the
step's bench time counts like any other step's.

On the simulated bench the operator's state `calibration_resistor_<ohms>ohm` connects
such a resistor (`simbench.simulation`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from squeezebench.protocols.steps import Plate, Step, StepContext

PROTOCOL = "deskew_calibration"


@dataclass(frozen=True)
class Parameters:
    load_ohm: float = 100.0            # the calibration resistor (a precision, low-inductance part)
    load_tolerance_rel: float = 0.001  # its stated tolerance
    frequency_hz: float = 37000.0      # the plates' working frequency: the delay acts as w tau
    piezo_voltage_vpp: float = 10.0    # 0.125 W in 100 ohm
    repeats: int = 4                   # stored records (Type A of the correction)

    def __post_init__(self) -> None:
        if not (self.load_ohm > 0 and 0 <= self.load_tolerance_rel < 0.1 and self.frequency_hz > 0
                and self.piezo_voltage_vpp > 0 and self.repeats >= 1):
            raise ValueError("need load_ohm > 0, 0 <= load_tolerance_rel < 0.1, frequency_hz > 0, "
                             "piezo_voltage_vpp > 0 and repeats >= 1")


def resistor_state(load_ohm: float) -> str:
    return f"calibration_resistor_{load_ohm:g}ohm"


def plan(params: Parameters, plate: Plate) -> list[Step]:
    load = replace(plate, name="calibration_resistor", state=resistor_state(params.load_ohm),
                   instruction=f"Disconnect the plate and connect the {params.load_ohm:g} ohm calibration "
                               "resistor in its place (keep the shunt, probes and cables as they are)")
    return [Step("deskew", load, lambda ctx: _measure(ctx, params))]


def _measure(ctx: StepContext, params: Parameters) -> None:
    ctx.drive.set_frequency(params.frequency_hz)
    ctx.drive.set_piezo_voltage(params.piezo_voltage_vpp)
    for repeat in range(params.repeats):
        ctx.record(ctx.acquisition.measure(keep_waveforms=True), repeat=repeat,
                   calibration_load_ohm=params.load_ohm, calibration_load_tolerance_rel=params.load_tolerance_rel,
                   shunt_ohm=ctx.bench.electronics.shunt_ohm)
