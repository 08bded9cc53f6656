"""Everything `squeezebench design` found for one design file (`DesignAnswer`): both routes,
the verdict, and the built plate's measurement compared with them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pandas as pd
from uncertainties import ufloat

from squeezebench.designing.design_file import DesignFile
from squeezebench.designing.design import COVERAGE_FACTOR, PhysicsPrediction
from squeezebench.designing.paper_route import PaperRoute
from squeezebench.designing.verdict import Verdict, judge
from squeezebench.plates import predicted_plates


@dataclass(frozen=True)
class Measured:
    plate: str
    frequency_hz: float
    voltage_vpp: object   # ufloat: the voltage the measured slope needs for the target amplitude
    power_w: object
    origin: str = ""   # provenance of the points: "measured" on a real bench, "simulated" or "predicted" on the simulated one


def measured_point(physics: PhysicsPrediction, built) -> Measured:
    """What a characterisation of the built plate (`characterisation.PlateCharacterisation`) says the
    design needs: the target's centre amplitude over the measured amplitude slope, and the
    measured power slope at that voltage."""
    amplitude_slope = ufloat(built.amplitude_slope.slope.value, built.amplitude_slope.slope.std_uncertainty)
    power_slope = ufloat(built.power_slope.slope.value, built.power_slope.slope.std_uncertainty)
    voltage = physics.nominal.values["amplitude_pp_m"] / amplitude_slope
    return Measured(built.plate, built.frequency_hz, voltage, power_slope * voltage**2, built.origin)


def comparison(physics: PhysicsPrediction, paper: PaperRoute | None, measured: Measured | None,
               printed: dict[str, float] | None = None) -> pd.DataFrame:
    """One row per quantity and source: value, U (k = 2), and against the reference (the
    measurement when there is one, else the printed value): deviation and whether the
    reference lies within U: in the interval the value and the combined U, hypot(U, the
    reference's U), stand for (`predicted_plates.within_expanded_interval`)."""
    v, U = physics.nominal.values, physics.expanded
    rows = [("frequency_hz", "physics (a)", v["frequency_hz"], U["frequency_hz"]),
            ("voltage_vpp", "physics (a)", v["voltage_vpp"], U["voltage_vpp"]),
            ("power_w", "physics (a)", v["power_w"], U["power_w"])]
    if paper is not None:
        rows += [("voltage_vpp", "small plates (b)", paper.voltage_vpp.nominal_value,
                  COVERAGE_FACTOR * paper.voltage_vpp.std_dev),
                 ("power_w", "small plates (b)", paper.power_w.nominal_value, COVERAGE_FACTOR * paper.power_w.std_dev)]
    reference = {}
    if measured is not None:
        reference = {"frequency_hz": (measured.frequency_hz, 0.0, f"measured ({measured.plate})"),
                     "voltage_vpp": (measured.voltage_vpp.nominal_value, COVERAGE_FACTOR * measured.voltage_vpp.std_dev,
                                     f"measured ({measured.plate})"),
                     "power_w": (measured.power_w.nominal_value, COVERAGE_FACTOR * measured.power_w.std_dev,
                                 f"measured ({measured.plate})")}
    elif printed:
        reference = {k: (value, 0.0, "printed in the paper") for k, value in printed.items()}
    out = []
    for quantity, source, value, u in rows:
        ref = reference.get(quantity)
        deviation = value / ref[0] - 1 if ref else math.nan
        within = predicted_plates.within_expanded_interval(ref[0], value, math.hypot(u, ref[1])) if ref else None
        out.append({"quantity": quantity, "source": source, "value": value, "expanded_uncertainty": u,
                    "reference": ref[2] if ref else "", "reference_value": ref[0] if ref else math.nan,
                    "reference_expanded_uncertainty": ref[1] if ref else math.nan,
                    "deviation": deviation, "within_u": within})
    return pd.DataFrame(out)


@dataclass(frozen=True)
class DesignAnswer:
    """Everything `squeezebench design` found for one design file."""

    physics: PhysicsPrediction
    paper_route: PaperRoute | None = None
    paper_route_problem: str = ""   # why route (b) has no answer, when it has none
    measured: Measured | None = None
    printed: dict[str, float] | None = None   # the paper's values for this plate, when it is one of its plates
    layouts: pd.DataFrame | None = None
    layouts_note: str = ""   # how the layouts were solved (reduced model checked, or in full)
    #: every design this lab checked against its built plate (`designing.workflow.HISTORY_FILE`)
    history: pd.DataFrame | None = None
    #: judged by `designing.run_design` (with the placement curve and the neighbouring modes)
    verdict: Verdict | None = None
    #: the design with its end groups at each distance from the edges (`placement_curve`)
    placement: pd.DataFrame | None = None
    #: the layout sweep's least-power layout on its Pareto front, with its own budget
    best_layout: PhysicsPrediction | None = None

    @property
    def design(self) -> DesignFile:
        return self.physics.design

    def comparison(self) -> pd.DataFrame:
        return comparison(self.physics, self.paper_route, self.measured, self.printed)

    def judged(self) -> Verdict:
        """The verdict given, or the one the physics alone gives (no changes from the
        placement curve or the neighbouring modes)."""
        return self.verdict or judge(self.physics, self.placement)
