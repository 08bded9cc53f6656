"""The paper's plates as the plate model sees them, and what it predicts beside the print.

Geometry from the paper's stated dimensions (data/paper/*.csv); materials the one shared
set of `analysis.plate_modes` (Table 2 aluminium, NCE 41); no per-plate parameter. Where the
text does not say where a column sits, the assumption is stated beside it (`LAYOUTS`).
"""
from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pandas as pd

from squeezebench.analysis import plate_modes
from squeezebench.analysis.paper import paper_value

MM = 1e-3

#: Column layouts (x of each column's centre, mm) and why.
LAYOUTS = {
    "table3": ((38.0,), "assumed: the one column sits mid-length, since the plate was cut "
                        "symmetrically to 28 mm and still driven (Sec. 2.3.1)"),
    "table4": ((2.5, 73.5), "Fig. 3 caption: piezos glued at the edges"),
    "large": ((3.0, 195.0), "Sec. 5.2: two piezos at each corner (along the short edges)"),
}


#: The one damping figure, shared by every aluminium plate on its cushion: the paper's only
#: damping measurement that is not itself a compared result, the Fig. 2c stress case (37.6 V
#: at 37180 Hz and 240 V at 37560 Hz give the same velocity, so |Z(37560)|/R = 240/37.6 ->
#: q_mech = 310; Sec. 2.2). Within the plausible range for aluminium in air (hundreds to ~2000).
MECHANICAL_Q = 310.0


def _columns(x_mm: tuple[float, ...], width_mm: float, per: int, powered: int) -> tuple:
    patches = ()
    for i, x in enumerate(x_mm):
        patches += plate_modes.column(x * MM, width_mm * MM, 5 * MM, 9 * MM, 0.5 * MM, per,
                                      powered=i < powered, name=f"column {i + 1}")
    return patches


def table3_plate(label: str) -> plate_modes.PlateGeometry:
    length = paper_value("table3", "plate", "resonator_length_mm")
    width = paper_value("table3", "plate", "resonator_width_mm")
    plate = plate_modes.PlateGeometry(length * MM, width * MM,
                                      paper_value("table3", "plate", "resonator_thickness_mm") * MM,
                                      _columns(LAYOUTS["table3"][0], width, 4, 1))
    return plate.cut_to(float(label) * MM)


def table4_plate(label: str) -> plate_modes.PlateGeometry:
    width = paper_value("table4", "plate", "resonator_width_mm")
    n_columns = int(paper_value("table4", label, "n_columns"))
    return plate_modes.PlateGeometry(
        paper_value("table4", "plate", "resonator_length_mm") * MM, width * MM,
        paper_value("table4", "plate", "resonator_thickness_mm") * MM,
        _columns(LAYOUTS["table4"][0][:n_columns], width, 4,
                 int(paper_value("table4", label, "n_powered_columns"))))


def large_plate() -> plate_modes.PlateGeometry:
    q = lambda name: paper_value("large_plate", "large_plate", name)  # noqa: E731
    width = q("resonator_width_mm")
    patches = tuple(plate_modes.Patch(x * MM, y * MM, q("piezo_width_mm") * MM,
                                      q("piezo_length_mm") * MM, q("piezo_thickness_mm") * MM, True, "corner")
                    for x in LAYOUTS["large"][0]
                    for y in (7.0, 21.0, width - 21.0, width - 7.0))
    return plate_modes.PlateGeometry(q("resonator_length_mm") * MM, width * MM,
                                     q("resonator_thickness_mm") * MM, patches)


#: How far one plate's mechanical Q may stray from the build's `MECHANICAL_Q` (rectangular
#: half-width; the design file's default spread, analysis.design_file).
MECHANICAL_Q_TOLERANCE = 0.30


def frequency_relative_u(thickness_m: float) -> float:
    """Expanded (k = 2) relative uncertainty of a predicted frequency of a plate of nominal
    `thickness_m` from the material and sheet tolerances (f ~ h sqrt(E / rho); each tolerance
    a rectangular half-width, `plate_modes.relative_tolerances`)."""
    t = plate_modes.relative_tolerances(thickness_m)
    return 2 * math.sqrt(t["thickness_m"] ** 2 + (t["young_pa"] / 2) ** 2
                         + (t["density_kg_m3"] / 2) ** 2) / math.sqrt(3)


def response_relative_u(thickness_m: float) -> dict[str, float]:
    """Expanded (k = 2) relative uncertainty of the predicted velocity and power at resonance at
    a given voltage of a plate of nominal `thickness_m`, in closed form from the tolerances
    (rectangular half-widths, `plate_modes.relative_tolerances`):
    v = F V q / (w M) and P = F^2 V^2 q / (2 w M), with F proportional to d31 and w M to
    h^2 sqrt(E rho) (f ~ h sqrt(E / rho), M ~ rho h); the force factor's own dependence on the
    resonator (the piezo's lever arm about the neutral axis) is left out."""
    t = plate_modes.relative_tolerances(thickness_m)
    u = {name: half / math.sqrt(3) for name, half in t.items()}
    u_q = MECHANICAL_Q_TOLERANCE / math.sqrt(3)
    u_omega_mass = math.hypot(2 * u["thickness_m"], u["young_pa"] / 2, u["density_kg_m3"] / 2)
    # the amplitude v / w = F V q / (w^2 M), w^2 M ~ E h^3
    u_omega2_mass = math.hypot(3 * u["thickness_m"], u["young_pa"])
    return {"velocity_pp_mps": 2 * math.hypot(u["d31_c_per_n"], u_q, u_omega_mass),
            "amplitude_pp_m": 2 * math.hypot(u["d31_c_per_n"], u_q, u_omega2_mass),
            "power_w": 2 * math.hypot(2 * u["d31_c_per_n"], u_q, u_omega_mass),
            # tan theta' inverted through Eqs. 27 and 25 goes as P / (A f) ~ F: q, M and w cancel
            "tan_theta": 2 * u["d31_c_per_n"]}


def response_per_volt(frequency_hz: float, modal_mass_kg: float, force_factor_n_per_v: float) -> dict[str, float]:
    """A plate at resonance per volt of drive, with the build's one `MECHANICAL_Q` (a
    one-degree-of-freedom resonator referred to the point its modal mass and force factor A
    are referred to): mechanical resistance R = w M / q, velocity pp per Vpp |A| / R,
    amplitude pp per Vpp |A| / (R w), power per Vpp^2 R (|A| / (2 R))^2 / 2 (the velocity
    amplitude is half its pp)."""
    omega = 2 * math.pi * frequency_hz
    resistance = omega * modal_mass_kg / MECHANICAL_Q
    velocity_pp = abs(force_factor_n_per_v) / resistance
    return {"frequency_hz": frequency_hz, "velocity_pp_mps_per_vpp": velocity_pp,
            "amplitude_pp_m_per_vpp": velocity_pp / omega,
            "power_w_per_vpp2": 0.5 * resistance * (velocity_pp / 2) ** 2}


def paper_plates():
    """Each paper plate the model predicts: (table, item, label, geometry, printed frequency,
    printed antinodes, printed lambda/2 in mm or None, printed voltage, velocity and power)."""
    for label in ("75", "59", "28"):
        yield ("Table 3", label, f"{label} x 41 x 1 mm", table3_plate(label),
               paper_value("table3", label, "frequency_hz"), paper_value("table3", label, "n_antinodes"), None,
               *(paper_value("table3", label, q) for q in ("voltage_vpp", "velocity_pp_mps", "power_w")))
    for label in ("1-column", "2-columns 1 powered", "2-columns 2 powered"):
        yield ("Table 4", label, label, table4_plate(label), paper_value("table4", label, "frequency_hz"),
               paper_value("table4", "plate", "n_antinodes"), None,
               *(paper_value("table4", label, q) for q in ("voltage_vpp", "velocity_pp_mps", "power_w")))
    q = lambda name: paper_value("large_plate", "large_plate", name)  # noqa: E731
    yield ("Sec. 5", "large_plate", "large plate 198 x 138 x 2 mm", large_plate(), q("frequency_hz"), 21.0,
           q("half_wavelength_mm"), q("voltage_vpp"), np.nan, q("power_w"))


@functools.cache
def _predictions() -> pd.DataFrame:
    out = []
    for (table, item, plate_label, geometry, printed_hz, printed_antinodes, printed_half_mm,
         voltage_vpp, printed_velocity, printed_power) in paper_plates():
        u_rel = frequency_relative_u(geometry.thickness_m)
        u_response = response_relative_u(geometry.thickness_m)
        modes = plate_modes.solve_plate(geometry, near_hz=printed_hz)
        k = modes.working_mode(printed_hz)
        f = float(modes.frequencies_hz[k])
        # at resonance, at the plate centre (where the paper measured, Sec. 2.3.1):
        # R = w M / q, v = A V / R (pp for pp), P = R v0^2 / 2 with v0 the velocity amplitude
        mass_kg, forces = modes.referred_to(k, geometry.length_m / 2, geometry.width_m / 2)
        response = response_per_volt(f, mass_kg, float(forces[modes.powered].sum()))
        velocity_pp = response["velocity_pp_mps_per_vpp"] * voltage_vpp
        half_mm = modes.half_wavelength_m(k) * 1e3
        power = response["power_w_per_vpp2"] * voltage_vpp**2
        out.append({"table": table, "item": item, "plate": plate_label,
                    "resonator_thickness_mm": geometry.thickness_m / MM, "predicted_frequency_hz": f,
                    "predicted_frequency_u_hz": f * u_rel, "printed_frequency_hz": printed_hz,
                    "frequency_deviation": f / printed_hz - 1,
                    "predicted_antinodes": modes.interior_antinodes(k),
                    "printed_antinodes": int(printed_antinodes),
                    "predicted_half_wavelength_mm": half_mm,
                    "printed_half_wavelength_mm": printed_half_mm if printed_half_mm else np.nan,
                    "voltage_vpp": voltage_vpp, "predicted_velocity_pp_mps": velocity_pp,
                    "predicted_velocity_u_pp_mps": velocity_pp * u_response["velocity_pp_mps"],
                    "printed_velocity_pp_mps": printed_velocity,
                    "predicted_power_w": power, "predicted_power_u_w": power * u_response["power_w"],
                    "printed_power_w": printed_power})
    return pd.DataFrame(out)


def predictions() -> pd.DataFrame:
    """Predicted beside printed for Tables 3-4 and the large plate: frequency (and its U),
    deviation, interior antinodes, nodal-line spacing, and velocity and power at resonance at
    the printed voltage with the one shared `MECHANICAL_Q` (each with U, k = 2). The printed
    frequency only centres the (n, 0) mode search (the family's neighbours lie >= 2/n away).
    Solved once per process: geometry and materials are the module's own."""
    return _predictions().copy()


#: The paper's table quantities the model predicts: (value column, U column) of `predictions`.
PREDICTED_QUANTITIES = {
    "n_antinodes": ("predicted_antinodes", None),
    "frequency_hz": ("predicted_frequency_hz", "predicted_frequency_u_hz"),
    "velocity_pp_mps": ("predicted_velocity_pp_mps", "predicted_velocity_u_pp_mps"),
    "power_w": ("predicted_power_w", "predicted_power_u_w"),
}


def tidy(table: str) -> pd.DataFrame:
    """One row per (item, quantity) of the paper's `table` ("Table 3", "Table 4") the model
    predicts: predicted_value and predicted_expanded_uncertainty (k = 2, NaN for a count). Table 4's amplitude is
    the predicted velocity over w."""
    frame = _predictions()
    rows = []
    for row in frame[frame["table"] == table].to_dict("records"):
        for quantity, (value, u) in PREDICTED_QUANTITIES.items():
            rows.append({"item": row["item"], "quantity": quantity, "predicted_value": float(row[value]),
                         "predicted_expanded_uncertainty": float(row[u]) if u else math.nan})
        amplitude = row["predicted_velocity_pp_mps"] / (2 * math.pi * row["predicted_frequency_hz"])
        rows.append({"item": row["item"], "quantity": "amplitude_pp_m", "predicted_value": amplitude,
                     "predicted_expanded_uncertainty": amplitude * response_relative_u(
                         row["resonator_thickness_mm"] * MM)["amplitude_pp_m"]})
    return pd.DataFrame(rows, columns=["item", "quantity", "predicted_value", "predicted_expanded_uncertainty"])


def large_plate_response() -> dict[str, float]:
    """The large plate at its predicted working mode, per volt: amplitude pp per Vpp at its
    centre and power per Vpp^2 (both linear in the drive: Eqs. 25 and 27 are, and so is the
    plate), each with its relative U (k = 2), and the frequency; what Figs. 8 and 9 and
    Table 5 show beside the measured lines."""
    row = _predictions().set_index("item").loc["large_plate"]
    u = response_relative_u(row["resonator_thickness_mm"] * MM)
    omega = 2 * math.pi * row["predicted_frequency_hz"]
    return {"frequency_hz": float(row["predicted_frequency_hz"]),
            "amplitude_pp_m_per_vpp": float(row["predicted_velocity_pp_mps"] / omega / row["voltage_vpp"]),
            "amplitude_rel_U": u["amplitude_pp_m"],
            "power_w_per_vpp2": float(row["predicted_power_w"] / row["voltage_vpp"] ** 2),
            "power_rel_U": u["power_w"]}


def large_plate_mode_figure(path: Path) -> dict:
    """The large plate's predicted working mode, drawn to `path`; returns its figures."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    printed_hz = paper_value("large_plate", "large_plate", "frequency_hz")
    modes = plate_modes.solve_plate(large_plate(), near_hz=printed_hz)
    k = modes.working_mode(printed_hz)
    fig, ax = plt.subplots(figsize=(7, 4.2))
    image = ax.pcolormesh(modes.x_m * 1e3, modes.y_m * 1e3, modes.shapes[k].T, cmap="RdBu_r",
                          vmin=-1, vmax=1, shading="gouraud")
    for patch in modes_patches(large_plate()):
        ax.add_patch(plt.Rectangle(*patch, fill=False, edgecolor="k", linewidth=0.8))
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(f"predicted mode at {modes.frequencies_hz[k]:.0f} Hz "
                 f"({modes.interior_antinodes(k)} interior antinodes)")
    fig.colorbar(image, ax=ax, label="deflection / largest")
    fig.savefig(path, dpi=100, bbox_inches="tight")
    plt.close(fig)
    return {"frequency_hz": float(modes.frequencies_hz[k]),
            "interior_antinodes": modes.interior_antinodes(k),
            "half_wavelength_mm": modes.half_wavelength_m(k) * 1e3}


def modes_patches(geometry: plate_modes.PlateGeometry) -> list[tuple[tuple[float, float], float, float]]:
    """Each patch as matplotlib's ((x0, y0), width, height) in mm."""
    return [((p.bounds[0] * 1e3, p.bounds[2] * 1e3), p.length_x_m * 1e3, p.width_y_m * 1e3)
            for p in geometry.patches]


#: The paper's plates the model knows, by the name a run stores them under (the scene's stem).
GEOMETRIES = {"large_plate": large_plate}


def working_shape(plate: str, near_hz: float, x_m, y_m) -> tuple[np.ndarray, float] | None:
    """The model's working mode of `plate` (the (n, 0) mode nearest `near_hz`) at the
    points (x, y), scaled +1 at its largest, and that mode's frequency; None for a plate
    the model does not know."""
    if plate not in GEOMETRIES:
        return None
    modes = plate_modes.solve_plate(GEOMETRIES[plate](), near_hz=near_hz)
    k = modes.working_mode(near_hz)
    return modes.shape_at(k, x_m, y_m), float(modes.frequencies_hz[k])
