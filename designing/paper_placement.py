"""Where the paper's edge columns sit, inferred from its printed numbers through the design
model: the large plate as a design file, its voltage and power against the end piezos'
distance from the edges (`design.placement_rows`, the one placement curve), and the edge
gap at which each edge plate's model meets the force factor its print implies.

Every gap here is an INFERENCE, labelled so, and never an input of a prediction of the
numbers it is inferred from (the predictions take the half-wave rule's,
`predicted_plates.rule_edge_gap_mm`).
`python -m squeezebench.designing.paper_placement` prints them.
"""
from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
import pandas as pd

from squeezebench.designing import design
from squeezebench.designing.design_file import DesignFile
from squeezebench.paper import paper_value
from squeezebench.plates import laminate, plate_modes, predicted_plates
from squeezebench.plates.predicted_plates import (HALF_WAVE_TOLERANCE_MM, MECHANICAL_Q, MM, STATED_ANTINODES,
                                                  implied_force_factor_n_per_v, large_plate, table4_plate)


#: The edge gaps (mm) the placement curve and the inference sweep: the stated range and on
#: to where the patch reaches the first nodal line of curvature.
EDGE_GAPS_MM = (0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0)


def large_plate_design(edge_gap_mm: float | None = None, amplitude_pp_m: float = 1e-6):
    """The paper's large plate (`predicted_plates.large_plate`) as a design file: the same
    geometry, its end piezos `edge_gap_mm` from the edges (None: the half-wave rule's) +-
    `HALF_WAVE_TOLERANCE_MM`, the
    (21, 0) mode, `amplitude_pp_m` at the centre and the build's `MECHANICAL_Q` with the paper's
    builds' spread; the amplifier is the bench's NF HSA 4052 (300 Vpp)."""
    q = lambda name: paper_value("large_plate", "large_plate", name)  # noqa: E731
    geometry = large_plate(edge_gap_mm)
    ys: dict[float, list[float]] = {}
    for p in geometry.patches:
        ys.setdefault(round(p.x_center_m / MM, 9), []).append(round(p.y_center_m / MM, 9))
    groups = [{"name": f"x{x:g}", "x_mm": x, "y_mm": sorted(y), "x_tolerance_mm": HALF_WAVE_TOLERANCE_MM}
              for x, y in ys.items()]
    return DesignFile.model_validate({
        "name": "large_plate",
        "resonator": {"material": "aluminium_table2", "length_mm": q("resonator_length_mm"),
                      "width_mm": q("resonator_width_mm"), "thickness_mm": q("resonator_thickness_mm")},
        "piezo": {"material": "NCE41", "length_x_mm": q("piezo_width_mm"), "width_y_mm": q("piezo_length_mm"),
                  "thickness_mm": q("piezo_thickness_mm")},
        "groups": groups, "mode": {"interior_antinodes": STATED_ANTINODES["large"]},
        "target": {"amplitude_pp_m": amplitude_pp_m, "at": "centre"},
        "damping": {"mechanical_q": MECHANICAL_Q, "spread": "paper_builds",
                    "origin": "the build's one damping figure (predicted_plates.MECHANICAL_Q), spread as the "
                              "paper's builds realise it (predicted_plates.drive_model_form)"},
        "amplifier": {"max_output_vpp": 300.0}})


def large_plate_placement_curve(amplitude_pp_m: float = 1e-6, gaps_mm=EDGE_GAPS_MM) -> pd.DataFrame:
    """The large plate's placement curve, as `design.placement_rows` solves any design's
    (`large_plate_design`): frequency, modal mass and force factor at the centre, and the
    voltage (pp) and power that give `amplitude_pp_m` there against the patches' distance from
    the edge, with the build's `MECHANICAL_Q` and with the plate's own physics Q
    (`plates.damping`, nominal losses: the voltage goes as 1/Q at a given amplitude, the
    mechanical power as 1/Q and the dielectric as the voltage squared)."""
    curve = design.placement_rows(large_plate_design(None, amplitude_pp_m), STATED_ANTINODES["large"], gaps_mm)
    ratio = curve["mechanical_q"] / curve["physics_q"]
    nominal = predicted_plates.rule_edge_gap_mm("large")
    curve["within_stated_range"] = (curve["edge_gap_mm"] - nominal).abs() <= HALF_WAVE_TOLERANCE_MM + 1e-9
    curve["voltage_vpp_physics_q"] = curve["voltage_vpp"] * ratio
    dielectric = curve["power_w"] - curve["mechanical_power_w"]
    curve["power_w_physics_q"] = curve["mechanical_power_w"] * ratio + dielectric * ratio**2
    return curve


def implied_edge_gap_mm(target: float, curve: pd.DataFrame, column: str = "force_factor_n_per_v") -> float | None:
    """INFERENCE, not an input: the first edge gap at which the model's `column` of `curve`
    (against `edge_gap_mm`) reaches `target`, linear between swept gaps; None if no swept gap
    reaches it. Never used to predict the numbers it is inferred from."""
    found = plate_modes.crossings(curve["edge_gap_mm"], curve[column], target)
    return found[0] if found else None


def large_plate_placement_inference() -> pd.DataFrame:
    """INFERENCE, labelled so: the edge gap the large plate's printed numbers imply on the
    model's placement curve (`large_plate_placement_curve`, 1 um read as pp): the printed 32 Vpp
    (with the build's Q and with the physics Q), the printed 1.3 W (likewise) and the force
    factor the two imply together, model-free (`implied_force_factor_n_per_v`). Each row gives
    the curve's range over the swept gaps, so a printed number no placement reaches says so."""
    curve = large_plate_placement_curve()
    q = lambda name: paper_value("large_plate", "large_plate", name)  # noqa: E731
    f = float(curve["frequency_hz"].iloc[0])
    velocity_pp = 2 * math.pi * f * q("amplitude_m")
    targets = (("voltage_vpp", "printed voltage for 1 um pp, build Q", q("voltage_vpp")),
               ("voltage_vpp_physics_q", "printed voltage for 1 um pp, physics Q", q("voltage_vpp")),
               ("power_w", "printed power at 1 um pp, build Q", q("power_w")),
               ("power_w_physics_q", "printed power at 1 um pp, physics Q", q("power_w")),
               ("force_factor_n_per_v", "force factor implied by 32 Vpp, 1 um pp and 1.3 W",
                implied_force_factor_n_per_v(q("voltage_vpp"), velocity_pp, q("power_w"))))
    rows = []
    for column, what, target in targets:
        gap = implied_edge_gap_mm(target, curve, column)
        rows.append({"printed": what, "target": target, "model_min": float(curve[column].min()),
                     "model_max": float(curve[column].max()),
                     "inferred_edge_gap_mm": np.nan if gap is None else gap,
                     "status": "inference" if gap is not None else
                     f"no gap in {curve['edge_gap_mm'].min():g}-{curve['edge_gap_mm'].max():g} mm reaches it"})
    return pd.DataFrame(rows)

#: Issue 45's independent review (its own Argyris code, the same plate, a rigid bond): the large
#: plate's force factor at the centre (N/V) against the patches' distance from the edges (mm),
#: and its modal mass at the centre, stated for the flush placement only (g). A reference to
#: compare with, never an input of the model.
REVIEW_FORCE_FACTORS_N_PER_V = {0.0: 0.38, 1.5: 0.76, 3.0: 1.03, 4.0: 1.10, 8.5: 0.03}
REVIEW_MODAL_MASS_G = 81.4


#: A piezo thickness (m) at which the patches barely stiffen the plate (5 um of NCE 41 adds about
#: 1 % to a 2 mm plate's bending stiffness, 0.5 mm doubles it) while their lever arm stays about
#: the plate's half-thickness.
UNSTIFFENED_PIEZO_M = 5e-6


def voltage_decomposition(gaps_mm=tuple(REVIEW_FORCE_FACTORS_N_PER_V)) -> pd.DataFrame:
    """The large plate's voltage for 1 um pp at the centre, V_pp = w^2 M x_pp / (Q A)
    (`design.Lumped.voltage_vpp_for`), taken apart at each edge gap beside the review's
    (`REVIEW_FORCE_FACTORS_N_PER_V`): our force factor A and modal mass M (both referred to the
    centre), the Q the design uses (the build's `MECHANICAL_Q`) and the loss physics', and the
    amplitude convention (1 um read as pp, the voltage pp, in both). The review's voltage is
    evaluated at our frequency with its A, its flush M at every gap (the only one it states) and
    Q = `MECHANICAL_Q` (the design's Q when it was run, which with the thin-plate frequency of
    then gives its flush 83 Vpp), so ours over it is exactly the product of the three factor
    columns. Beside them the free-free beam's closed form (`plate_modes.free_free_beam_centre_drive`:
    the bare plate's mode, piezos that do not stiffen it) with a rigid bond, as the review's, and
    the full solve with the piezos made too thin to stiffen the plate (`UNSTIFFENED_PIEZO_M`),
    their moment per volt kept the real ones' (e_eff z_m eta of the 0.5 mm piezo and its bond):
    `stiffening_factor` is what the patches' own stiffness does to M / A, hence to the voltage."""
    curve = design.placement_rows(large_plate_design(), STATED_ANTINODES["large"], list(gaps_mm))
    geometry = large_plate()
    h, width, length = geometry.thickness_m, geometry.width_m, geometry.length_m
    patch = geometry.patches[0]

    def lever_and_effectiveness(piezo_m: float, bond) -> tuple[float, float]:
        """The lever arm z_m and shear-lag effectiveness eta of a patch of that thickness on that bond."""
        _, _, z_m, eta = laminate.bonded_section(plate_modes.ALUMINIUM_TABLE2, h, plate_modes.NCE41, piezo_m, bond,
                                                 patch.length_x_m)
        return z_m, eta

    z_rigid, _ = lever_and_effectiveness(patch.thickness_m, laminate.RIGID_BOND)
    z_real, eta_real = lever_and_effectiveness(patch.thickness_m, plate_modes.EPOXY)
    z_thin, eta_thin = lever_and_effectiveness(UNSTIFFENED_PIEZO_M, plate_modes.EPOXY)
    rows = []
    for row in curve.to_dict("records"):
        gap = row["edge_gap_mm"] * MM
        thin = large_plate(row["edge_gap_mm"])
        thin = dataclasses.replace(thin, patches=tuple(dataclasses.replace(p, thickness_m=UNSTIFFENED_PIEZO_M)
                                                       for p in thin.patches))
        unstiffened = predicted_plates.centre_response(thin, STATED_ANTINODES["large"])
        unstiffened_force = unstiffened["force_factor_n_per_v"] * z_real * eta_real / (z_thin * eta_thin)
        spans = [(gap, gap + patch.length_x_m), (length - gap - patch.length_x_m, length - gap)] * (
            len(geometry.patches) // 2)
        beam_mass, beam_force = plate_modes.free_free_beam_centre_drive(
            plate_modes.ALUMINIUM_TABLE2, h, width, length, STATED_ANTINODES["large"], spans, patch.width_y_m,
            plate_modes.NCE41.plate_e31_c_per_m2 * z_rigid)
        review_force = REVIEW_FORCE_FACTORS_N_PER_V[row["edge_gap_mm"]]
        omega = 2 * math.pi * row["frequency_hz"]
        review_voltage = omega**2 * REVIEW_MODAL_MASS_G * 1e-3 * 1e-6 / (MECHANICAL_Q * review_force)
        rows.append({
            "edge_gap_mm": row["edge_gap_mm"], "frequency_hz": row["frequency_hz"],
            "modal_mass_g": row["modal_mass_g"], "force_factor_n_per_v": row["force_factor_n_per_v"],
            "design_q": row["mechanical_q"], "physics_q": row["physics_q"], "amplitude_reading": "1 um pp, Vpp",
            "voltage_vpp": row["voltage_vpp"],
            "voltage_vpp_physics_q": row["voltage_vpp"] * row["mechanical_q"] / row["physics_q"],
            "review_force_factor_n_per_v": review_force, "review_modal_mass_g": REVIEW_MODAL_MASS_G,
            "review_q": MECHANICAL_Q, "review_voltage_vpp": review_voltage,
            "mass_factor": row["modal_mass_g"] / REVIEW_MODAL_MASS_G,
            "force_factor_factor": review_force / row["force_factor_n_per_v"],
            "q_factor": MECHANICAL_Q / row["mechanical_q"], "convention_factor": 1.0,
            "voltage_ratio": row["voltage_vpp"] / review_voltage,
            "beam_force_factor_rigid_n_per_v": beam_force, "beam_modal_mass_g": beam_mass * 1e3,
            "unstiffened_modal_mass_g": unstiffened["modal_mass_kg"] * 1e3,
            "unstiffened_force_factor_n_per_v": unstiffened_force,
            # the epoxy's shear lag and lever arm against the review's rigid bond: A goes as z_m eta
            "bond_moment_share": z_real * eta_real / z_rigid,
            "stiffening_factor": row["modal_mass_g"] / row["force_factor_n_per_v"]
            / (unstiffened["modal_mass_kg"] * 1e3 / unstiffened_force)})
    return pd.DataFrame(rows)


def implied_edge_gaps() -> pd.DataFrame:
    """`predicted_plates.what_would_agree` with, for each edge plate (Table 4, the large
    plate), the edge gap at which the model's force factor meets the one its print implies
    (`inferred_edge_gap_mm`, NaN where no swept gap reaches it or for Table 3's centred
    columns)."""
    agree = predicted_plates.what_would_agree()
    gaps = []
    for row in agree.to_dict("records"):
        gap = None
        if row["table"] != "Table 3":
            gap = implied_edge_gap_mm(row["implied_force_factor_n_per_v"], edge_curve(row["item"]))
        gaps.append(np.nan if gap is None else gap)
    return agree.assign(inferred_edge_gap_mm=gaps)


@functools.cache
def edge_curve(item: str) -> pd.DataFrame:
    """The powered force factor at the plate's centre against the edge gap, for an edge plate."""
    if item == "large_plate":
        return large_plate_placement_curve()
    rows = []
    for gap in EDGE_GAPS_MM:
        geometry = table4_plate(item, gap)
        at = predicted_plates.centre_response(geometry, STATED_ANTINODES["76 mm plates"])
        rows.append({"edge_gap_mm": gap, "force_factor_n_per_v": at["force_factor_n_per_v"]})
    return pd.DataFrame(rows)


def main() -> None:
    """The large plate's placement curve and the placements the print implies (INFERENCE)."""
    with pd.option_context("display.width", 220, "display.max_columns", 30, "display.float_format", "{:.4g}".format):
        for title, frame in (("what would have to move (INFERENCE for the edge gap)", implied_edge_gaps()),
                             ("large plate against the patches' distance from the edge", large_plate_placement_curve()),
                             ("the large plate's placement the print implies (INFERENCE)",
                              large_plate_placement_inference()),
                             ("the large plate's voltage taken apart beside issue 45's review (V = w^2 M x / (Q A))",
                              voltage_decomposition())):
            print(f"\n{title}\n{frame.to_string(index=False)}")


if __name__ == "__main__":
    main()
