"""A plate's mechanical Q from the physics of its losses, so that Q follows its geometry.

Each mechanism's loss factor weighted by its share of the working mode's strain energy
(the modal strain energy method: 1/Q = sum_i eta_i U_i / U), plus sound radiated into air:

- the aluminium's internal loss over the energy outside the piezos (`ALUMINIUM_LOSS_FACTOR`);
- the ceramic's mechanical loss 1/Qm (NCE 41 datasheet) over the energy the patches add
  (`plate_modes.PlateModes.piezo_energy_share`);
- the epoxy bond's shear loss over the shear energy it stores (`plate_modes.bond_energy_ratio`,
  Crawley & de Luis's shear lag);
- radiation from both faces of a plate above its coincidence frequency (`radiation_loss_factor`).

What is not modelled (the cushion the plates lie on, the leads) is not hidden in a tolerance:
the bond's loss factor, the least known figure, is the one `fit_and_check` fits, on ONE build
(Table 3), and the others (Table 4, the large plate) are judged with it, the table showing
both. The predictions (`plates.predicted_plates`) use the datasheet-class nominal, never the fit.
"""
from __future__ import annotations

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


def radiation_loss_factor(frequency_hz: float, material: plate_modes.Isotropic, thickness_m: float,
                          faces: int = 2) -> float:
    """Loss factor of a bending plate radiating into air from `faces` faces:
    eta_rad = faces rho0 c0 sigma / (w rho h) (radiated power rho0 c0 sigma <v^2> S per face
    over w times the kinetic energy rho h <v^2> S; Cremer, Heckl & Petersson, Sec. 7.7)."""
    sigma = radiation_efficiency(frequency_hz, coincidence_frequency_hz(material, thickness_m))
    omega = 2 * math.pi * frequency_hz
    return faces * AIR_DENSITY_KG_M3 * AIR_SOUND_SPEED_M_S * sigma / (
        omega * material.density_kg_m3 * thickness_m)


def loss_terms(piezo_energy_share: float, bond_energy_ratio: float, frequency_hz: float,
               material: plate_modes.Isotropic, thickness_m: float, bond_loss_factor: float,
               piezo_mechanical_q: float = NCE41_MECHANICAL_Q,
               aluminium_loss_factor: float = ALUMINIUM_LOSS_FACTOR) -> dict[str, float]:
    """Each mechanism's contribution to 1/Q of a mode (modal strain energy method): the shares
    of the aluminium (1 - S_p), the piezos (S_p) and the bond (r_b S_p), normalised by their
    sum, times each loss factor; and the radiation loss factor."""
    bond_share = bond_energy_ratio * piezo_energy_share
    total = 1.0 + bond_share
    return {"aluminium": aluminium_loss_factor * (1.0 - piezo_energy_share) / total,
            "piezo": piezo_energy_share / piezo_mechanical_q / total,
            "bond": bond_loss_factor * bond_share / total,
            "radiation": radiation_loss_factor(frequency_hz, material, thickness_m)}


def mechanical_q(terms: dict[str, float]) -> float:
    """Q = 1 / sum of the loss terms."""
    return 1.0 / sum(terms.values())


def mode_loss_terms(modes: plate_modes.PlateModes, k: int, material: plate_modes.Isotropic, thickness_m: float,
                    bond_loss_factor: float) -> dict[str, float]:
    """`loss_terms` of mode k of a solved plate (its patches' bond energy ratio averaged)."""
    ratio = float(np.mean(modes.bond_energy_ratio)) if len(modes.bond_energy_ratio) else 0.0
    return loss_terms(float(modes.piezo_energy_share[k]), ratio, float(modes.frequencies_hz[k]), material,
                      thickness_m, bond_loss_factor)


def implied_q(frequency_hz: float, modal_mass_kg: float, velocity_pp_mps: float, power_w: float) -> float:
    """The Q a printed power and velocity imply for a mode of modal mass M (referred to where the
    velocity was measured): P = R v0^2 / 2 with v0 = v_pp / 2, Q = w M / R."""
    resistance = 2.0 * power_w / (velocity_pp_mps / 2.0) ** 2
    return 2 * math.pi * frequency_hz * modal_mass_kg / resistance


def fit_bond_loss_factor(rows: pd.DataFrame) -> float:
    """The bond loss factor that best gives `rows`' implied Q (least squares in 1/Q, which is
    linear in it: 1/Q = a + b eta_b); rows carry `loss_without_bond` (a) and `bond_loss_per_eta` (b)."""
    a, b = rows["loss_without_bond"].to_numpy(), rows["bond_loss_per_eta"].to_numpy()
    target = 1.0 / rows["implied_q"].to_numpy()
    return float(np.sum(b * (target - a)) / np.sum(b * b))


def fit_and_check(fit_on: str = "Table 3") -> pd.DataFrame:
    """The bond loss factor fitted on the plates of `fit_on` (their printed power and velocity
    give each an implied Q through the model's modal mass) and every paper plate's Q predicted
    with it beside its implied Q: a `role` column says which rows were fitted and which are
    held out. Also the Q with the datasheet-class nominal (`plate_modes.EPOXY.loss_factor`)."""
    from squeezebench.plates import predicted_plates

    frame = predicted_plates.loss_budget()
    fitted = fit_bond_loss_factor(frame[frame["table"] == fit_on])
    frame["fitted_bond_loss_factor"] = fitted
    frame["q_fitted"] = 1.0 / (frame["loss_without_bond"] + fitted * frame["bond_loss_per_eta"])
    frame["q_fitted_over_implied"] = frame["q_fitted"] / frame["implied_q"]
    frame["role"] = np.where(frame["table"] == fit_on, "fitted", "held out")
    return frame[["table", "item", "role", "implied_q", "q_nominal", "q_fitted", "q_fitted_over_implied",
                  "fitted_bond_loss_factor", "radiation_share", "bond_share_nominal"]]


def main() -> None:
    with pd.option_context("display.width", 200, "display.float_format", "{:.4g}".format):
        print(fit_and_check().to_string(index=False))


if __name__ == "__main__":
    main()
