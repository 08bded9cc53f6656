"""A plate's mechanical Q from the physics of its losses, so that Q follows its geometry.

Each mechanism's loss factor weighted by its share of the working mode's strain energy
(the modal strain energy method: 1/Q = sum_i eta_i U_i / U), plus the losses through the faces:

- the aluminium's internal loss over the energy outside the piezos (`ALUMINIUM_LOSS_FACTOR`);
- the ceramic's mechanical loss 1/Qm (NCE 41 datasheet) over the energy the patches add
  (`plate_modes.PlateModes.piezo_energy_share`);
- the epoxy bond's shear loss over the shear energy it stores (`plate_modes.bond_energy_ratio`,
  Crawley & de Luis's shear lag);
- radiation from both faces of a plate above its coincidence frequency (`radiation_loss_factor`);
- the cushion the paper's plates lie on (Sec. 2.1), a foam whose frame takes a plane wave from the
  face resting on it (`cushion_resistance_pa_s_per_m`).

Each face term is a resistance per unit area R times the mode's face integral of the
mass-normalised deflection squared over w (`surface_loss_factor`), R / (w rho h) for a bare plate.
The cushion's R is the least known figure (the foam, and how much of the face touches it, are
not stated): `fit_and_check` fits it, on ONE build (Table 4), and judges the others (Table 3, the
large plate) with it, the table showing both; `cross_check` repeats the fit on each build. The
predictions (`plates.predicted_plates`) use the closed-form nominal, never the fit.

The whole face in contact is the hypothesis the builds agree on: fitted on Table 4 it is
about 5900 Pa s/m and the large plate, held out, lands within 15 % of its implied Q. Contact
through the patches alone (the piezos protrude 0.5 mm under the plate) would need 120-560 kPa s/m,
a factor 2.5-4.6 apart between Table 4 and the large plate: no one cushion does both.
"""
from __future__ import annotations

import cmath
import math

import numpy as np
import pandas as pd

from squeezebench.plates import plate_modes

#: Air at 20 degC, 101.325 kPa: density (kg/m^3) and speed of sound (m/s).
AIR_DENSITY_KG_M3 = 1.204
AIR_SOUND_SPEED_M_S = 343.2
#: Aluminium alloys' internal loss factor, of order 1e-4 (Cremer, Heckl & Petersson,
#: Structure-Borne Sound, 3rd ed., Table 2.1 of material loss factors: aluminium ~1e-4).
ALUMINIUM_LOSS_FACTOR = 1e-4
#: NCE 41's mechanical quality factor Qm 1400 (Noliac, Piezo ceramics data sheet ver. 1203).
NCE41_MECHANICAL_Q = 1400.0

#: The cushion (Sec. 2.1: a flat cushion, its material not stated), assumed an open-cell flexible
#: polyurethane foam: density 30 kg/m^3 (cushion foams 20-40), storage modulus 0.3 MPa at these
#: frequencies (0.03 MPa static for an open-cell foam of relative density 0.025 by Gibson & Ashby's
#: E*/E_s ~ (rho*/rho_s)^2, Cellular Solids Eq. 5.6, stiffening up to about 1 MPa towards its glass
#: transition at ultrasonic rates) and loss factor 0.2 (0.1-0.5).
CUSHION_DENSITY_KG_M3 = 30.0
CUSHION_MODULUS_PA = 0.3e6
CUSHION_LOSS_FACTOR = 0.2
#: The builds the cushion's resistance is fitted on and judged against (`fit_and_check`).
BUILDS = ("Table 3", "Table 4", "Sec. 5")
FIT_ON = "Table 4"
#: What `fit_and_check`'s table shows, for its caption.
TABLE_WORDS = (
    "Q from the aluminium's, the ceramic's (Qm) and the bond's losses weighted by their strain energy, "
    "radiation into air from both faces, and the cushion under one face (a foam's plane-wave resistance, "
    "the whole face in contact: closed-form nominal about 3000 Pa s/m, 800-6300 over the foams' range); "
    "implied Q from the printed power and velocity through the model's modal mass at the centre. The "
    f"cushion's resistance is the one figure fitted, on {FIT_ON}. The needed columns: what would have to "
    "move, alone, for a row's Q to meet its implied Q (empty: no value of that input alone does); the "
    "centre's share of the mode that asks, beside the one the printed force factor asks. Fitted resistance")


def coincidence_frequency_hz(material: plate_modes.Isotropic, thickness_m: float) -> float:
    """Where the plate's bending wave speed equals the speed of sound:
    f_c = c0^2 / (2 pi) sqrt(rho h / D) (Cremer, Heckl & Petersson, Eq. 7.29); about 12 kHz for
    1 mm of aluminium, 6 kHz for 2 mm."""
    d, mass, _ = plate_modes.laminate(material, thickness_m, material, 0.0)
    return AIR_SOUND_SPEED_M_S**2 / (2 * math.pi) * math.sqrt(mass / d)


def radiation_efficiency(frequency_hz: float, coincidence_hz: float) -> float:
    """A plate's radiation efficiency above coincidence, sigma = (1 - f_c / f)^(-1/2) (the
    infinite plate's, which a finite plate's tends to well above f_c: Maidanik 1962, J. Acoust.
    Soc. Am. 34, Eq. 4; Leppington, Broadbent & Heron 1982)."""
    if frequency_hz <= coincidence_hz:
        raise ValueError(f"{frequency_hz:.0f} Hz is below the coincidence frequency {coincidence_hz:.0f} Hz: "
                         "the above-coincidence radiation formula does not apply")
    return 1.0 / math.sqrt(1.0 - coincidence_hz / frequency_hz)


def surface_loss_factor(resistance_pa_s_per_m: float, face_integral_m2_per_kg: float, frequency_hz: float) -> float:
    """Loss factor of a mode whose face pushes on a medium of resistance R per unit area:
    the power R w^2 q^2 / 2 int phi^2 dA over w times the energy w^2 q^2 / 2 of a mass-normalised
    mode, eta = R int phi^2 dA / w; a bare plate's int phi^2 dA is 1 / (rho h)."""
    return resistance_pa_s_per_m * face_integral_m2_per_kg / (2 * math.pi * frequency_hz)


def radiation_loss_factor(frequency_hz: float, material: plate_modes.Isotropic, thickness_m: float,
                          faces: int = 2, face_integral_m2_per_kg: float | None = None) -> float:
    """Loss factor of a bending plate radiating into air from `faces` faces, each a resistance
    rho0 c0 sigma per unit area (`surface_loss_factor`): for a bare plate
    eta_rad = faces rho0 c0 sigma / (w rho h), i.e. Q_rad = rho h w / (2 rho0 c0 sigma) from both
    faces (Cremer, Heckl & Petersson, Sec. 7.7). `face_integral_m2_per_kg` is the mode's
    (`face_integral_m2_per_kg`), the bare plate's 1 / (rho h) by default."""
    sigma = radiation_efficiency(frequency_hz, coincidence_frequency_hz(material, thickness_m))
    face = face_integral_m2_per_kg or 1.0 / (material.density_kg_m3 * thickness_m)
    return surface_loss_factor(faces * AIR_DENSITY_KG_M3 * AIR_SOUND_SPEED_M_S * sigma, face, frequency_hz)


def plane_wave_resistance_pa_s_per_m(density_kg_m3: float, modulus_pa: float, loss_factor: float) -> float:
    """The resistance per unit area of a thick lossy layer a face pushes normally,
    Re sqrt(rho E (1 + j eta)) (its characteristic impedance). It holds where the layer's wave,
    sqrt(E / rho) / f (about 2 mm in a cushion foam at 40 kHz), is far shorter than the plate's
    bending wave (18 mm), so each part of the face launches a plane wave, and the layer is thick
    enough to absorb it (no wave returns)."""
    return cmath.sqrt(density_kg_m3 * modulus_pa * (1 + 1j * loss_factor)).real


#: The cushion's nominal resistance per unit area (about 3000 Pa s/m, seven times air's rho0 c0),
#: the whole face in contact; 0.03-1 MPa and 20-40 kg/m^3 span about 800-6300 Pa s/m.
CUSHION_RESISTANCE_PA_S_PER_M = plane_wave_resistance_pa_s_per_m(CUSHION_DENSITY_KG_M3, CUSHION_MODULUS_PA,
                                                                 CUSHION_LOSS_FACTOR)


def face_integral_m2_per_kg(modes: plate_modes.PlateModes, k: int, refine: int = 8) -> float:
    """int phi^2 dA over the plate of mode k mass-normalised (int m phi^2 dA = 1; a bare plate's
    is 1 / (rho h)). A full solve has it exactly, as the quadratic form of the mode with the
    mass matrix of 1 kg/m^2 on its own elements (`plate_modes.PlateModes.face_integral_m2_per_kg`).
    A plate solved otherwise (a reduced model's) has only its shape: scaled to its peak,
    evaluated on the shape grid refined `refine` times (the grid itself, about 1.5 lines per
    half-wave, overstates it by 5-9 %), squared and integrated, over the mass referred to
    that peak."""
    if modes.face_integral_m2_per_kg is not None:
        return float(modes.face_integral_m2_per_kg[k])
    x, y = (np.interp(np.arange((len(g) - 1) * refine + 1) / refine, np.arange(len(g)), g)
            for g in (modes.x_m, modes.y_m))
    shape = modes.shape_at(k, *np.meshgrid(x, y, indexing="ij"))
    return float(np.trapezoid(np.trapezoid(shape**2, y, axis=1), x) / modes.modal_mass_kg[k])


def dielectric_power_w(frequency_hz: float, capacitance_f: float, voltage_pp: float, tan_delta: float) -> float:
    """Power lost in a capacitor of loss tangent tan(delta) driven at V0 = V_pp / 2:
    P = w C V0^2 tan(delta) / 2, the power in its parallel loss resistance 1 / (w C tan(delta))."""
    return 2 * math.pi * frequency_hz * capacitance_f * (voltage_pp / 2) ** 2 * tan_delta / 2


#: The piezos' loss tangent growing with the field, tan = tan_ref (E / E_ref)^exponent, as the
#: simulated bench's `dielectric_loss` effect takes it when a scene names it without values:
#: fitted on the paper's Fig. 2c stress case (Sec. 2.2; the effect's docstring has the
#: arithmetic). One source for the simulator and for the budgets that read a stored scene.
DIELECTRIC_LOSS_DEFAULTS = {"tan_delta_at_reference": 0.002735, "reference_field_amplitude_v_per_mm": 240.0,
                            "exponent": 1.0}


def field_tan_delta(voltage_amplitude_v, piezo_thickness_m: float, tan_delta_at_reference: float,
                    reference_field_amplitude_v_per_m: float, exponent: float):
    """tan(delta) of a piezo at field amplitude E = V0 / t: tan_ref (E / E_ref)^exponent. A loss
    tangent linear in the field (exponent 1) is the Rayleigh law of ferroelectric hysteresis (loss
    per cycle growing as E^3); exponent 0 is a constant tan(delta). With it the dielectric power
    `dielectric_power_w` goes as f V0^(2 + exponent)."""
    field_v_per_m = voltage_amplitude_v / piezo_thickness_m
    return tan_delta_at_reference * (field_v_per_m / reference_field_amplitude_v_per_m) ** exponent


def loss_terms(piezo_energy_share: float, bond_energy_ratio: float, frequency_hz: float,
               material: plate_modes.Isotropic, thickness_m: float, bond_loss_factor: float,
               piezo_mechanical_q: float = NCE41_MECHANICAL_Q,
               aluminium_loss_factor: float = ALUMINIUM_LOSS_FACTOR,
               face_integral: float | None = None,
               cushion_resistance_pa_s_per_m: float = CUSHION_RESISTANCE_PA_S_PER_M) -> dict[str, float]:
    """Each mechanism's contribution to 1/Q of a mode (modal strain energy method): the shares
    of the aluminium (1 - S_p), the piezos (S_p) and the bond (r_b S_p), normalised by their
    sum, times each loss factor; radiation from both faces and the cushion under one, over the
    mode's `face_integral` (m^2/kg; the bare plate's 1 / (rho h) if None)."""
    bond_share = bond_energy_ratio * piezo_energy_share
    total = 1.0 + bond_share
    face = face_integral or 1.0 / (material.density_kg_m3 * thickness_m)
    return {"aluminium": aluminium_loss_factor * (1.0 - piezo_energy_share) / total,
            "piezo": piezo_energy_share / piezo_mechanical_q / total,
            "bond": bond_loss_factor * bond_share / total,
            "radiation": radiation_loss_factor(frequency_hz, material, thickness_m, face_integral_m2_per_kg=face),
            "cushion": surface_loss_factor(cushion_resistance_pa_s_per_m, face, frequency_hz)}


def mechanical_q(terms: dict[str, float]) -> float:
    """Q = 1 / sum of the loss terms."""
    return 1.0 / sum(terms.values())


def mode_loss_terms(modes: plate_modes.PlateModes, k: int, material: plate_modes.Isotropic, thickness_m: float,
                    bond_loss_factor: float) -> dict[str, float]:
    """`loss_terms` of mode k of a solved plate (its patches' bond energy ratio averaged, its own
    face integral), the cushion at its nominal."""
    ratio = float(np.mean(modes.bond_energy_ratio)) if len(modes.bond_energy_ratio) else 0.0
    return loss_terms(float(modes.piezo_energy_share[k]), ratio, float(modes.frequencies_hz[k]), material,
                      thickness_m, bond_loss_factor, face_integral=face_integral_m2_per_kg(modes, k))


def implied_q(frequency_hz: float, modal_mass_kg: float, velocity_pp_mps: float, power_w: float) -> float:
    """The Q a printed power and velocity imply for a mode of modal mass M (referred to where the
    velocity was measured): P = R v0^2 / 2 with v0 = v_pp / 2, Q = w M / R."""
    resistance = 2.0 * power_w / (velocity_pp_mps / 2.0) ** 2
    return 2 * math.pi * frequency_hz * modal_mass_kg / resistance


def fit_linear_loss(fixed_loss: np.ndarray, loss_per_unit: np.ndarray, target_q: np.ndarray) -> float:
    """The parameter p >= 0 that best gives `target_q` when 1/Q = a + b p (least squares in 1/Q,
    where it is linear): a the loss of the other mechanisms, b the loss per unit of p. A loss
    cannot be negative, so where the other mechanisms alone already lose more than the targets
    the fit stops at 0 (one parameter: the bounded least squares is the clipped one)."""
    a, b = np.asarray(fixed_loss, float), np.asarray(loss_per_unit, float)
    return max(0.0, float(np.sum(b * (1.0 / np.asarray(target_q, float) - a)) / np.sum(b * b)))


def _budget() -> pd.DataFrame:
    """Per paper plate (`predicted_plates.loss_budget`): its implied Q, its loss without the
    cushion and the cushion's loss per unit resistance, and the force factor the print implies
    over the model's (`predicted_plates.what_would_agree`)."""
    from squeezebench.plates import predicted_plates

    frame = predicted_plates.loss_budget()
    agree = predicted_plates.what_would_agree()
    frame["force_factor_ratio"] = agree["force_factor_ratio"].to_numpy()
    frame["cushion_per_resistance"] = frame["loss_cushion"] / CUSHION_RESISTANCE_PA_S_PER_M
    frame["loss_without_cushion"] = frame[[f"loss_{name}" for name in ("aluminium", "piezo", "bond",
                                                                        "radiation")]].sum(axis=1)
    return frame


def fit_and_check(fit_on: str = FIT_ON) -> pd.DataFrame:
    """The cushion's resistance fitted on the plates of `fit_on` (their printed power and velocity
    give each an implied Q through the model's modal mass; every other loss at its nominal) and
    every paper plate's Q predicted with it beside its implied Q, a `role` column saying which
    rows were fitted and which are held out. For each row, what would have to move, alone, for
    its Q to meet the implied one: the centre-referred modal mass (the implied Q is proportional
    to it; `centre_amplitude_factor_needed` the centre's share of the mode instead, beside the one
    the printed force factor asks, `centre_amplitude_factor_from_force`), the bond's loss factor,
    the ceramic's Qm or the cushion's resistance (NaN: no value of it alone reaches)."""
    frame = _budget()
    rows = frame[frame["table"] == fit_on]
    fitted = fit_linear_loss(rows["loss_without_cushion"], rows["cushion_per_resistance"], rows["implied_q"])
    loss = frame["loss_without_cushion"] + fitted * frame["cushion_per_resistance"]
    gap = 1.0 / frame["implied_q"] - loss
    nominal = plate_modes.EPOXY.loss_factor
    needed = {"bond_loss_factor_needed": nominal + gap / (frame["loss_bond"] / nominal),
              "ceramic_qm_needed": 1.0 / (1.0 / NCE41_MECHANICAL_Q + gap / (frame["loss_piezo"] * NCE41_MECHANICAL_Q)),
              "cushion_resistance_needed_pa_s_per_m": fitted + gap / frame["cushion_per_resistance"]}
    out = pd.DataFrame({
        "table": frame["table"], "item": frame["item"],
        "role": np.where(frame["table"] == fit_on, "fitted", "held out"),
        "implied_q": frame["implied_q"], "q_without_cushion": 1.0 / frame["loss_without_cushion"],
        "q_nominal": 1.0 / (frame["loss_without_cushion"] + frame["loss_cushion"]),
        "q_fitted": 1.0 / loss, "q_fitted_over_implied": 1.0 / loss / frame["implied_q"],
        "fitted_cushion_resistance_pa_s_per_m": fitted,
        "cushion_share": fitted * frame["cushion_per_resistance"] / loss,
        "radiation_share": frame["loss_radiation"] / loss,
        "dielectric_share_of_power": frame["dielectric_share_of_power"],
        "centre_amplitude_factor_needed": np.sqrt(frame["implied_q"] * loss),
        "centre_amplitude_factor_from_force": 1.0 / frame["force_factor_ratio"],
        **{name: value.where(value > 0) for name, value in needed.items()}})
    return out.reset_index(drop=True)


def terms_table(fit_on: str = FIT_ON) -> pd.DataFrame:
    """Per paper plate, each mechanism's loss factor (1/Q share; the cushion's at the resistance
    fitted on `fit_on`) and the loss its implied Q asks: their orders of magnitude side by side."""
    frame = _budget()
    fitted = fit_and_check(fit_on)["fitted_cushion_resistance_pa_s_per_m"].iloc[0]
    out = frame[["table", "item"]].copy()
    for name in ("aluminium", "piezo", "bond", "radiation"):
        out[f"loss_{name}"] = frame[f"loss_{name}"]
    out["loss_cushion_fitted"] = fitted * frame["cushion_per_resistance"]
    out["loss_total"] = out.filter(like="loss_").sum(axis=1)
    out["loss_implied"] = 1.0 / frame["implied_q"]
    return out


def cross_check() -> pd.DataFrame:
    """`fit_and_check` fitted on each build in turn, tidy: per fitted build and judged build, the
    resistance the fit gives and the median over the judged build's plates of Q predicted over
    implied."""
    rows = []
    for build in BUILDS:
        frame = fit_and_check(build)
        for judged in BUILDS:
            rows.append({"fitted_on": build, "judged": judged, "role": "fitted" if judged == build else "held out",
                         "fitted_cushion_resistance_pa_s_per_m": frame["fitted_cushion_resistance_pa_s_per_m"].iloc[0],
                         "median_q_over_implied": frame.loc[frame["table"] == judged, "q_fitted_over_implied"].median()})
    return pd.DataFrame(rows)


def main() -> None:
    with pd.option_context("display.width", 250, "display.max_columns", 30, "display.float_format", "{:.4g}".format):
        print(terms_table().to_string(index=False))
        print(fit_and_check().to_string(index=False))
        print(cross_check().to_string(index=False))


if __name__ == "__main__":
    main()
