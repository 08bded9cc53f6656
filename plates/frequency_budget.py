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

from squeezebench.plates import laminate, plate_modes, predicted_plates, specifications

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
        row["within_U"] = predicted_plates.within_expanded_interval(
            printed_hz, model_hz, float(predictions.loc[item, "predicted_frequency_u_hz"]))
        rows.append(row)
    return pd.DataFrame(rows)


def free_free_beam_frequency_hz(material: plate_modes.Isotropic, thickness_m: float, length_m: float,
                                antinodes: int) -> float:
    """Closed form: the free-free beam's elastic mode with `antinodes` antinodes between its
    antinodes + 1 nodes, w = (beta_n / L)^2 sqrt(D / rho h) / 2 pi with cos(beta L) cosh(beta L) = 1
    (plate modulus: a wide strip bends cylindrically), moved onto Mindlin's branch
    (`plate_modes.thick_plate_frequency_hz`)."""
    beta_l = plate_modes.free_free_beam_roots(antinodes)[-1]
    d, mass, _ = plate_modes.laminate(material, thickness_m, material, 0.0)
    thin = (beta_l / length_m) ** 2 * math.sqrt(d / mass) / (2 * math.pi)
    return plate_modes.thick_plate_frequency_hz(thin, material, thickness_m)


def beam_frequency_hz(geometry: plate_modes.PlateGeometry, antinodes: int, thick: bool) -> float:
    """The plate with its piezos as a free-free beam (`plate_modes.beam_frequencies_hz`), its
    elastic mode with `antinodes` antinodes (the count-th root from 100 Hz up): Euler-Bernoulli
    moved onto Mindlin's branch at the bare plate's (as the solver corrects), or with `thick`
    Timoshenko's with each section's own shear stiffness and rotary inertia, the laminate's
    under a patch."""
    top = 2.0 * predicted_plates._search_hz(geometry, antinodes)
    roots = plate_modes.beam_frequencies_hz(geometry, f_min_hz=100.0, f_max_hz=top, thick=thick)
    found = float(roots[antinodes - 1])
    return found if thick else plate_modes.thick_plate_frequency_hz(found, plate_modes.ALUMINIUM_TABLE2,
                                                                     geometry.thickness_m)


def bare_plate_frequency_hz(geometry: plate_modes.PlateGeometry, antinodes: int) -> float:
    """The model's (n, 0) mode of `antinodes` antinodes of the plate with its piezos taken off."""
    bare = plate_modes.PlateGeometry(geometry.length_m, geometry.width_m, geometry.thickness_m)
    near = predicted_plates._search_hz(bare, antinodes)
    modes = plate_modes.solve_plate(bare, near_hz=near, band_rel=0.3)
    return float(modes.frequencies_hz[predicted_plates.mode_with_antinodes(modes, antinodes, near)])


def same_sheet_ratios() -> pd.DataFrame:
    """f59/f75 and f28/f75 (Table 3: one sheet, cut), model and print: thickness and alloy
    cancel, what is left is the model's form (thick plate, bond, the plate's shape). Beside it,
    the same ratio of the bare plates (no piezo: the model's, and the free-free beam's closed
    form), whose deviation no term of the patches can take away; the plates with their piezos
    as beams, thick-plate corrected as the solver does (at the bare plate's) and Timoshenko's
    with the laminate's own shear (bond included) and rotary inertia, whose difference is
    what correcting the laminate, not the bare plate, would move; and the bond effectiveness
    eta that would close the gap, to first order (Rayleigh: the patches' stiffening holds a
    share S_p of each mode's energy, so d ln f = S_p / 2 d ln eta and the ratio moves by
    (S_p,item - S_p,75) / 2 d ln eta): what would have to move, not a fit. The two plates'
    cut lengths (`specifications.cut_length_tolerance_mm`, each rectangular, independent) put a
    term in the ratio's U, k for 95 % of their trapezoid (`rectangles_95_half_width`), and
    `cut_length_to_agree_mm` is the plate's cut length at which the model's ratio would meet
    print with the 75 mm plate held (f ~ L^-2): an inference, never an input of a prediction."""
    frame = predicted_plates.predictions().set_index("item")
    model_rows = predicted_plates._predictions().set_index("item")
    plates = {item: (geometry, int(frame.loc[item, "predicted_antinodes"]))
              for table, item, _, geometry, _, _ in predicted_plates.paper_plates() if table == "Table 3"}

    def bare(item: str) -> tuple[float, float, float, float]:
        geometry, antinodes = plates[item]
        return (bare_plate_frequency_hz(geometry, antinodes),
                free_free_beam_frequency_hz(plate_modes.ALUMINIUM_TABLE2, geometry.thickness_m, geometry.length_m,
                                            antinodes),
                beam_frequency_hz(geometry, antinodes, thick=False), beam_frequency_hz(geometry, antinodes, thick=True))

    rows = []
    bare_75, beam_75, thin_75, thick_75 = bare("75")   # the denominator of both ratios, computed once
    for item in ("59", "28"):
        model = frame.loc[item, "predicted_frequency_hz"] / frame.loc["75", "predicted_frequency_hz"]
        printed = frame.loc[item, "printed_frequency_hz"] / frame.loc["75", "printed_frequency_hz"]
        bare_item, beam_item, thin_item, thick_item = bare(item)
        lever = (model_rows.loc[item, "piezo_energy_share"] - model_rows.loc["75", "piezo_energy_share"]) / 2
        eta = model_rows.loc[item, "bond_effectiveness"]
        rows.append({"ratio": f"f{item}/f75", "model": model, "printed": printed, "deviation": model / printed - 1,
                     "bare_plate_deviation": bare_item / bare_75 / printed - 1,
                     "free_free_beam_deviation": beam_item / beam_75 / printed - 1,
                     "beam_with_piezos_deviation": thin_item / thin_75 / printed - 1,
                     "thick_laminate_beam_deviation": thick_item / thick_75 / printed - 1,
                     "cut_length_u_rel": specifications.rectangles_95_half_width(
                         *(2 * model_rows.loc[i, "cut_length_tolerance_mm"] * 1e-3 / plates[i][0].length_m
                           for i in (item, "75"))),
                     "cut_length_to_agree_mm": plates[item][0].length_m * 1e3 * math.sqrt(model / printed),
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
