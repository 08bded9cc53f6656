"""Where the plate model's resonance misses come from: each paper plate's frequency taken
apart, printed beside what the model gives (`python -m squeezebench.analysis.frequency_budget`).

Issue 22 asks for every Table 3-4 resonance within 3 % from one shared parameter set. The
model (Kirchhoff plate, perfectly bonded laminate, Table 2's aluminium) misses the Table 3
plates by +3 to +10 % while Table 4's are within 2.3 %. This module puts numbers on the
candidate causes, each from physics, none fitted:

- the bare plate (no piezo): how much of the miss the resonator alone carries;
- the piezos as mass only (no stiffness): the bound a compliant bond layer tends to, since
  a bond can take the piezo's stiffening away but not its mass;
- the thick-plate correction a Kirchhoff plate lacks (shear and rotary inertia, Mindlin):
  to first order in (k h)^2, f_Mindlin / f_Kirchhoff = 1 - (k h)^2 / 24 (1 + 2 / (kappa (1 - nu)))
  with k = pi / (lambda/2) and kappa = 5/6 (Timoshenko's beam correction with the plate
  modulus E/(1 - nu^2) for E), about -3 % for the 1 mm plates and -9 % for the 2 mm one.

Whatever moves Table 3 onto print moves Table 4 off it: the two builds disagree with each
other under any one parameter set, which the report's numbers, not a fit, show. The 3 %
asked is also below what nominal geometry can promise: a rolled sheet's thickness is
+-0.05 mm at 1 and 1.2 mm (EN 485-4, `specifications.sheet_thickness_tolerance`), +-4-5 % of
a frequency proportional to it, so the model's U (k = 2) is 5-6 %; the last line counts the
plates within it.
"""
from __future__ import annotations

import dataclasses
import math

import pandas as pd

from squeezebench.analysis import plate_modes, predicted_plates

SHEAR_COEFFICIENT = 5.0 / 6.0


def mindlin_factor(thickness_m: float, half_wavelength_m: float, poisson: float,
                   shear_coefficient: float = SHEAR_COEFFICIENT) -> float:
    """First-order thick-plate factor on a Kirchhoff flexural frequency (Mindlin's shear
    deformation and rotary inertia): 1 - (k h)^2 / 24 (1 + 2 / (kappa (1 - nu))), k = pi / (lambda/2)."""
    kh = math.pi / half_wavelength_m * thickness_m
    return 1.0 - kh**2 / 24.0 * (1.0 + 2.0 / (shear_coefficient * (1.0 - poisson)))


def _working_frequency_hz(geometry: plate_modes.PlateGeometry, piezo: plate_modes.Piezo, near_hz: float,
                          antinodes: int) -> float:
    """The (n, 0) mode with the model's count of interior antinodes, searched over a band wide
    enough for the variants' shifts (a mass-loaded plate falls by more than the default band),
    among modes mostly uniform across the width (stiffless edge masses bend the nodal lines:
    0.75 where the model's mode has 0.95)."""
    modes = plate_modes.solve_plate(geometry, piezo=piezo, near_hz=near_hz, band_rel=0.5)
    family = [k for k in range(len(modes.frequencies_hz))
              if modes.uniformity[k] >= 0.6 and modes.interior_antinodes(k) == antinodes]
    if not family:
        raise ValueError(f"no (n, 0) mode with {antinodes} interior antinodes near {near_hz:.0f} Hz")
    return float(modes.frequencies_hz[min(family, key=lambda k: abs(modes.frequencies_hz[k] - near_hz))])


def frequency_budget() -> pd.DataFrame:
    """One row per paper plate: printed frequency, the model's (as the report shows it), the
    bare plate's, the piezos as mass only, and the model's with the thick-plate factor, each
    with its deviation from print."""
    predictions = predicted_plates.predictions().set_index("item")
    mass_only_piezo = dataclasses.replace(plate_modes.NCE41, young_pa=plate_modes.NCE41.young_pa * 1e-6)
    rows = []
    for table, item, _, geometry, printed_hz, *_ in predicted_plates.paper_plates():
        model_hz = float(predictions.loc[item, "predicted_frequency_hz"])
        half_m = float(predictions.loc[item, "predicted_half_wavelength_mm"]) * 1e-3
        antinodes = int(predictions.loc[item, "predicted_antinodes"])
        values = {
            "model": model_hz,
            "bare_plate": _working_frequency_hz(dataclasses.replace(geometry, patches=()), plate_modes.NCE41,
                                                model_hz, antinodes),
            "piezo_mass_only": _working_frequency_hz(geometry, mass_only_piezo, model_hz, antinodes),
            "model_thick_plate": model_hz * mindlin_factor(geometry.thickness_m, half_m,
                                                           plate_modes.ALUMINIUM_TABLE2.poisson),
        }
        row = {"table": table, "item": item, "thickness_mm": geometry.thickness_m * 1e3,
               "printed_frequency_hz": printed_hz,
               "model_frequency_U_rel": float(predictions.loc[item, "predicted_frequency_u_hz"]) / model_hz}
        for name, value in values.items():
            row[f"{name}_frequency_hz"] = value
            row[f"{name}_deviation"] = value / printed_hz - 1.0
        rows.append(row)
    return pd.DataFrame(rows)


def main() -> None:
    frame = frequency_budget()
    columns = ["table", "item", "thickness_mm", "printed_frequency_hz", "model_frequency_U_rel"] + [
        c for c in frame.columns if c.endswith("_deviation")]
    with pd.option_context("display.width", 200, "display.float_format", "{:.4g}".format):
        print(frame[columns].to_string(index=False))
    within = {name[:-len("_deviation")]: int((frame.loc[frame["table"] != "Sec. 5", name].abs() <= 0.03).sum())
              for name in columns if name.endswith("_deviation")}
    print("Table 3-4 frequencies within 3 % of print (of 6): "
          + ", ".join(f"{name} {count}" for name, count in within.items()))
    tables = frame[frame["table"] != "Sec. 5"]
    print(f"the model's within its U (k = 2, {tables['model_frequency_U_rel'].min():.1%}-"
          f"{tables['model_frequency_U_rel'].max():.1%}): "
          f"{int((tables['model_deviation'].abs() <= tables['model_frequency_U_rel']).sum())} of {len(tables)}")


if __name__ == "__main__":
    main()
