"""What each candidate cause of the drive's mismatch does to it (docs/design.md, "Why the bench's
force factor and Q differ from the model's"): the shift in ln(A_bench / A_model) and
ln(Q_bench / Q_model) of `predicted_plates.drive_mismatch` each one gives, from closed forms
and the solve itself, never fitted to a printed value. `python -m
squeezebench.plates.drive_candidates` prints the table the docs quote.
"""
from __future__ import annotations

import dataclasses
import math

import pandas as pd

from squeezebench.plates import laminate, plate_modes, predicted_plates

MM = predicted_plates.MM


def reading_shift(velocity_factor: float = 1.0, voltage_factor: float = 1.0) -> tuple[float, float]:
    """(d ln A, d ln Q) of the mismatch when the true velocity pp is `velocity_factor` times the
    printed one and the true drive `voltage_factor` times the printed (a reading of pp as an
    amplitude is a factor 2). The model's v goes as V and its mechanical P as V^2, and the
    mismatch reads ln A = ln(P/P_m) - ln(v/v_m), ln Q = 2 ln(v/v_m) - ln(P/P_m)
    (`drive_mismatch`), so d ln A = -ln(a b) and d ln Q = 2 ln a: a drive read high moves the
    force factor only, a velocity read high both, oppositely."""
    return -math.log(velocity_factor * voltage_factor), 2 * math.log(velocity_factor)


def model_shift(before: dict[str, float], after: dict[str, float]) -> tuple[float, float]:
    """(d ln A, d ln Q) of the mismatch when the model's centre response (`predicted_plates.
    centre_response`) moves from `before` to `after`: the bench's implied A is model-free, so
    ln(A_bench / A) moves by -d ln A; its implied Q goes through w M (v = A V Q / (w M),
    P = A^2 V^2 Q / (2 w M)), so ln(Q_bench / Q) moves by d ln(w M)."""
    def omega_mass(r):
        return r["frequency_hz"] * r["modal_mass_kg"]
    return (-math.log(after["force_factor_n_per_v"] / before["force_factor_n_per_v"]),
            math.log(omega_mass(after) / omega_mass(before)))


def _moved_patches(geometry: plate_modes.PlateGeometry, dx_m: float) -> plate_modes.PlateGeometry:
    return dataclasses.replace(geometry, patches=tuple(dataclasses.replace(p, x_center_m=p.x_center_m + dx_m)
                                                       for p in geometry.patches))


def candidates() -> pd.DataFrame:
    """Per candidate and plate (Table 3's 75 mm, Table 4's 1-column): the shift each gives the
    mismatch, d ln A and d ln Q, and the factors exp(d) they multiply A_bench / A and Q_bench / Q
    by. The readings in closed form (`reading_shift`); the bond (rigid, and ten times more
    compliant), Table 3's column 1 and 2 mm off mid-length and the velocity read 2 mm off the
    centre across the width, each solved (`model_shift`)."""
    n = predicted_plates.STATED_ANTINODES["76 mm plates"]
    plates = {"Table 3 75": predicted_plates.table3_plate("75"), "Table 4 1-column": predicted_plates.table4_plate("1-column")}
    nominal = {name: predicted_plates.centre_response(g, n) for name, g in plates.items()}
    rows = []

    def add(candidate: str, plate: str, shift: tuple[float, float]) -> None:
        rows.append({"candidate": candidate, "plate": plate, "d_ln_force_factor": shift[0], "d_ln_q": shift[1],
                     "force_factor_ratio_times": math.exp(shift[0]), "q_ratio_times": math.exp(shift[1])})

    for plate in plates:
        add("velocity read as amplitude (true pp = 2x printed)", plate, reading_shift(velocity_factor=2.0))
        add("voltage read as amplitude (true pp = 2x printed)", plate, reading_shift(voltage_factor=2.0))
    soft = dataclasses.replace(plate_modes.EPOXY, shear_modulus_pa=plate_modes.EPOXY.shear_modulus_pa / 10)
    for label, bond in (("bond rigid", laminate.RIGID_BOND), ("bond ten times more compliant", soft)):
        for plate, geometry in plates.items():
            add(label, plate, model_shift(nominal[plate], predicted_plates.centre_response(geometry, n, bond)))
    for dx_mm in (1.0, 2.0):
        moved = predicted_plates.centre_response(_moved_patches(plates["Table 3 75"], dx_mm * MM), n)
        add(f"Table 3's column {dx_mm:g} mm off mid-length", "Table 3 75", model_shift(nominal["Table 3 75"], moved))
    for plate, geometry in plates.items():
        modes, k = predicted_plates._solve_working(geometry, n, None)
        centre = modes.deflection_at(k, geometry.length_m / 2, geometry.width_m / 2)
        off = modes.deflection_at(k, geometry.length_m / 2, geometry.width_m / 2 + 2 * MM)
        # the velocity read where the deflection is `off`: A and M referred there, A / phi and 1 / phi^2
        add("velocity read 2 mm off the centre across the width", plate, (math.log(abs(off / centre)),
                                                                           -2 * math.log(abs(off / centre))))
    return pd.DataFrame(rows)


def main() -> None:
    with pd.option_context("display.width", 200, "display.max_columns", 10, "display.float_format", "{:.3g}".format):
        print(candidates().to_string(index=False))


if __name__ == "__main__":
    main()
