"""Where the plate model's resonance misses come from: each paper plate's frequency taken
apart, printed beside what the model gives (`python -m squeezebench.plates.frequency_budget`).

The model corrects two model-form terms a thin laminate lacks (`plates.plate_modes`): the
thick-plate (Mindlin) shear and rotary inertia, -3 to -8 % here, and the epoxy bond's shear
lag, which takes part of the patches' stiffening away. The budget shows each step from the
thin plate with a rigid bond (the model before issue 45) to the model, every plate's U
(k = 2: sheet thickness, alloy family, bond, placement) and the same-sheet ratios, in which the
sheet's thickness and the alloy cancel (`same_sheet_ratios`).
"""
from __future__ import annotations

import math

import pandas as pd

from squeezebench.plates import laminate, plate_modes, predicted_plates

SHEAR_COEFFICIENT = laminate.SHEAR_COEFFICIENT


def mindlin_factor(thickness_m: float, half_wavelength_m: float, poisson: float,
                   shear_coefficient: float = SHEAR_COEFFICIENT) -> float:
    """First-order thick-plate factor on a Kirchhoff flexural frequency (Mindlin's shear
    deformation and rotary inertia): 1 - (k h)^2 / 24 (1 + 2 / (kappa (1 - nu))), k = pi / (lambda/2):
    the expansion of `laminate.mindlin_frequency_ratio`, which the model applies."""
    kh = math.pi / half_wavelength_m * thickness_m
    return 1.0 - kh**2 / 24.0 * (1.0 + 2.0 / (shear_coefficient * (1.0 - poisson)))


def frequency_budget() -> pd.DataFrame:
    """One row per paper plate: printed frequency, the model's with its U, and the thin plate
    with a rigid bond and with the epoxy bond (Kirchhoff), each with its deviation from print."""
    predictions = predicted_plates.predictions().set_index("item")
    model = predicted_plates._predictions().set_index("item")
    rows = []
    for table, item, _, geometry, _, antinodes in predicted_plates.paper_plates():
        printed_hz = float(predictions.loc[item, "printed_frequency_hz"])
        model_hz = float(predictions.loc[item, "predicted_frequency_hz"])
        # centred where the model's own (Kirchhoff) solve looked: the same mesh, the same family
        thin_hz = float(model.loc[item, "kirchhoff_frequency_hz"])
        rigid = plate_modes.solve_plate(geometry, near_hz=thin_hz, band_rel=0.3, bond=laminate.RIGID_BOND,
                                        thick_plate=False)
        k = predicted_plates.mode_with_antinodes(rigid, int(predictions.loc[item, "predicted_antinodes"]), thin_hz)
        values = {"thin_rigid_bond": float(rigid.frequencies_hz[k]),
                  "thin_epoxy_bond": float(model.loc[item, "kirchhoff_frequency_hz"]), "model": model_hz}
        row = {"table": table, "item": item, "thickness_mm": geometry.thickness_m * 1e3,
               "printed_frequency_hz": printed_hz,
               "model_frequency_U_rel": float(predictions.loc[item, "predicted_frequency_u_hz"]) / model_hz}
        for name, value in values.items():
            row[f"{name}_frequency_hz"] = value
            row[f"{name}_deviation"] = value / printed_hz - 1.0
        row["within_U"] = abs(row["model_deviation"]) <= row["model_frequency_U_rel"]
        rows.append(row)
    return pd.DataFrame(rows)


def same_sheet_ratios() -> pd.DataFrame:
    """f59/f75 and f28/f75 (Table 3: one sheet, cut), model and print: thickness and alloy
    cancel, what is left is the model's form (thick plate, bond, the plate's shape). With it,
    the bond effectiveness eta that would close the gap, to first order (Rayleigh: the patches'
    stiffening holds a share S_p of each mode's energy, so d ln f = S_p / 2 d ln eta and the
    ratio moves by (S_p,item - S_p,75) / 2 d ln eta): what would have to move, not a fit."""
    frame = predicted_plates.predictions().set_index("item")
    model_rows = predicted_plates._predictions().set_index("item")
    rows = []
    for item in ("59", "28"):
        model = frame.loc[item, "predicted_frequency_hz"] / frame.loc["75", "predicted_frequency_hz"]
        printed = frame.loc[item, "printed_frequency_hz"] / frame.loc["75", "printed_frequency_hz"]
        lever = (model_rows.loc[item, "piezo_energy_share"] - model_rows.loc["75", "piezo_energy_share"]) / 2
        eta = model_rows.loc[item, "bond_effectiveness"]
        rows.append({"ratio": f"f{item}/f75", "model": model, "printed": printed, "deviation": model / printed - 1,
                     "bond_effectiveness": eta,
                     "bond_effectiveness_to_agree": eta * math.exp(math.log(printed / model) / lever)})
    return pd.DataFrame(rows)


def main() -> None:
    frame = frequency_budget()
    columns = ["table", "item", "thickness_mm", "printed_frequency_hz", "model_frequency_U_rel"] + [
        c for c in frame.columns if c.endswith("_deviation")] + ["within_U"]
    with pd.option_context("display.width", 200, "display.float_format", "{:.4g}".format):
        print(frame[columns].to_string(index=False))
        print(same_sheet_ratios().to_string(index=False))
    print(f"within U (k = 2): {int(frame['within_U'].sum())} of {len(frame)}")


if __name__ == "__main__":
    main()
