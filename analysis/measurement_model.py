"""The measurement model of every quantity the report states, listed the way a calibration
certificate lists it: the measurand (what exactly is measured, and where), the model
equation, and every input with its type, distribution, standard uncertainty, source and
whether it is corrected or only budgeted.

The inputs are not restated here: they are the terms of the budgets `analysis.uncertainty`
computes the report's U from (at one stored point of the run), and the tolerances of the
geometry and materials, so the page cannot drift from the numbers. What no budget holds
yet is said as such (NOT_BUDGETED), not left out.
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from squeezebench.analysis import uncertainty
from squeezebench.analysis.budgets import Term
from squeezebench.analysis.calibration import Deskew


@dataclass(frozen=True)
class Measurand:
    definition: str   # what, where, under which conditions
    model: str        # the equation the stored value comes from


#: The report's quantities: each stored point's (`uncertainty.POINT_BUDGETS`) and the derived ones.
MEASURANDS: dict[str, Measurand] = {
    "power_w": Measurand(
        "Real power the amplifier delivers into the series shunt and the powered piezos, at the drive "
        "frequency in steady state. The shunt's loss R_s |I|^2 / 2 is part of it (as it is of the paper's P); "
        "the plate alone dissipates less.",
        "P = mean over whole periods of v(t) i(t), v from CH1 (amplifier output, through the voltage probe), "
        "i from CH2 (TCP202); with a deskew run P = (P' + Q' w tau) k^-alpha (tau: CH2's measured delay, "
        "k: current-to-voltage gain ratio, alpha its weight)"),
    "piezo_voltage_vpp": Measurand(
        "Peak-to-peak voltage at the amplifier output, across shunt and piezos (CH1), at the drive frequency.",
        "V = 2 |V_1| of the sine fitted to the CH1 record at the drive frequency"),
    "velocity_pp_mps": Measurand(
        "Peak-to-peak velocity along the laser beam at the measurement point, at the drive frequency.",
        "v = 2 |U_3| s of the sine fitted to the CH3 record, s the decoder's range (m/s per V)"),
    "frequency_hz": Measurand(
        "Frequency of the drive during the record (at resonance: the resonance the search found).",
        "f from the sine fit of the record; the scope's time base sets its scale"),
    "q": Measurand(
        "Mechanical quality factor Q of the plate's working mode, as the paper's Eq. 27 defines it.",
        "Eq. 27 inverted: Q from the slope of amplitude pp against piezo voltage, the geometry and "
        "the materials (the convention's reading)"),
    "tan_theta": Measurand(
        "Loss factor tan theta' of the plate, as the paper's Eq. 25 defines it.",
        "Eq. 25 inverted: tan theta' from the slope of power against voltage squared, Q, the frequency, the "
        "geometry and the materials; the CH1 gain, in both slopes, cancels"),
    "power_ratio": Measurand(
        "Pt / P0 of Fig. 2: the power once the velocity v0 is regained after detuning, over the power at "
        "resonance at the same v0, on the same plate and bench.",
        "R = mean P_t / mean P_0; the gains cancel, the CH2 delay, the generator's frequency and the "
        "resonance's drift do not "
        "(uncertainty.power_ratio_std_uncertainty)"),
}

#: Inputs known to matter that no budget holds yet: stated, with why, rather than left out.
NOT_BUDGETED = (
    ("velocity_pp_mps", "vibrometer decoder response over frequency",
     "the decoder's +-1 % calibration error is budgeted; how flat its output stays from its calibration "
     "frequency to the plates' 30-50 kHz is not in the project's specifications"),
)


def _distribution(term: Term) -> str:
    return "normal (Type A: the record's fit and scatter)" if term.type == "A" else \
        "rectangular (Type B: a stated limit +-a, u = a/sqrt(3))"


def _correction(term: Term, deskew: Deskew | None) -> str:
    if term.name.startswith("CH2 delay after deskew"):
        return f"corrected: tau = {deskew.delay_s * 1e9:.2f} ns measured by the run's deskew calibration"
    if term.name.startswith("CH2 delay"):
        return "not corrected (no deskew run): budgeted at its limit"
    if term.name.startswith("voltage probe compensation") and deskew is not None and deskew.frequency_hz:
        return (f"partly corrected: the deskew at {deskew.frequency_hz:.0f} Hz took its phase for part of the "
                "delay; the residue at this frequency is budgeted")
    if term.name == "gain check":
        return "corrected: the deskew run's gain ratio k, weighted"
    if term.type == "A":
        return "random: averages down over repeats"
    return "not corrected (sign unknown): budgeted at its limit"


def model_table(point: dict, deskew: Deskew | None) -> pd.DataFrame:
    """One row per (quantity, input): the measurand and model of the quantity, the input's
    type, distribution, relative standard uncertainty, correction and source, from the
    budgets of `point` (a stored, reduced point of the run) and the tolerances of Q and
    tan theta'. The not-budgeted inputs close the table."""
    rows = []
    for quantity in uncertainty.POINT_BUDGETS:
        budget = uncertainty.point_budget(quantity, point, deskew)
        for term in budget.terms:
            rows.append({"quantity": quantity, "input": term.name, "type": term.type,
                         "distribution": _distribution(term),
                         "relative_std_uncertainty": term.std_uncertainty / abs(budget.value),
                         "correction": _correction(term, deskew), "source": term.source})
    for quantity in ("q", "tan_theta"):
        rows.append({"quantity": quantity, "input": "the slopes' budgets (as power_w, piezo_voltage_vpp, "
                     "velocity_pp_mps), shared terms kept correlated", "type": "A and B",
                     "distribution": "as listed for those quantities", "relative_std_uncertainty": float("nan"),
                     "correction": "as listed for those quantities", "source": "analysis.uncertainty.model_budgets"})
        # the sheet's thickness tolerance depends on the plate: its source gives it per thickness
        sheet = {"resonator_thickness_m": uncertainty.Tolerance(
            float("nan"), "one value per plate, from its nominal thickness: " + uncertainty.SHEET_THICKNESS_SOURCE,
            uncertainty.SHEET)}
        for name, tolerance in {**sheet, **uncertainty.TOLERANCES}.items():
            rows.append({"quantity": quantity, "input": name, "type": "B",
                         "distribution": _distribution(Term(name, "B", 0.0, "")),
                         "relative_std_uncertainty": tolerance.half_width_rel / 3**0.5,
                         "correction": "not corrected (sign unknown): budgeted at its limit",
                         "source": tolerance.source})
    rows.append({"quantity": "power_ratio", "input": "noise of each mean; CH2 delay through w Q'/P at both points; "
                 "the generator's frequency and amplitude through each power's share on the resonance, its "
                 "dielectric share and the shunt's loss from the capacitive current (analysis.dielectric); the "
                 "resonance's drift between the readings: its estimate (the plate's warming scaled by the run's "
                 "readings of its resonance), corrected for, and its u, normal; a bias bound where the readings "
                 "alone give it (analysis.resonance_drift)",
                 "type": "A and B", "distribution": "as listed for power_w",
                 "relative_std_uncertainty": float("nan"),
                 "correction": "the deskew's, when the run has one; the resonance's estimated drift (GUM 3.2.4); "
                               "the gains cancel",
                 "source": "analysis.uncertainty.power_ratio_std_uncertainty"})
    for quantity, name, why in NOT_BUDGETED:
        rows.append({"quantity": quantity, "input": name, "type": "not budgeted", "distribution": "",
                     "relative_std_uncertainty": float("nan"), "correction": "none", "source": why})
    order = {quantity: i for i, quantity in enumerate(MEASURANDS)}
    table = pd.DataFrame(rows).sort_values("quantity", key=lambda q: q.map(order), kind="stable").reset_index(drop=True)
    table.insert(1, "measurand", table["quantity"].map(lambda q: MEASURANDS[q].definition if q in MEASURANDS else ""))
    table.insert(2, "model", table["quantity"].map(lambda q: MEASURANDS[q].model if q in MEASURANDS else ""))
    return table
