"""A plate warming under its drive, and its resonance falling with it: one lumped thermal mass.

The plate (aluminium, Table 2's density) dissipates the electrical power its piezos take and
loses heat by free convection from both faces: C dT/dt = P - G T, with C = rho c L W h its heat
capacity and G = h_c 2 L W its conductance to the room (Newton's law of cooling; a
millimetre of aluminium is isothermal across its thickness within a second: its Biot number
h_c h / k is some 1e-4). So T(t) = (1 / C) integral of P(t') exp(-(t - t') / tau) dt' with
tau = C / G, and its resonance moves by FREQUENCY_COEFFICIENT_PER_K per kelvin of it.

One source for the simulated plate's warming (`simbench.effects.HeatingDrift`) and for the
bound the analysis puts on a resonance read on a plate not at rest (`analysis.plate_warming`);
their tolerances are `specifications.HEATING_TOLERANCES`.
"""

from __future__ import annotations

import numpy as np

from squeezebench.plates.laminate import ALUMINIUM_TABLE2

#: Relative change of a plate's resonance per kelvin: its modulus's temperature coefficient
#: over two (f ~ sqrt(E / rho)): aluminium's modulus falls about 4e-4 per kelvin.
FREQUENCY_COEFFICIENT_PER_K = -2e-4
#: Free convection from a few centimetres of plate in still room air (W/m^2K).
CONVECTION_W_PER_M2_K = 10.0
#: Aluminium's specific heat at room temperature (J/kgK).
SPECIFIC_HEAT_J_PER_KG_K = 900.0
#: The plate's density (kg/m^3): Table 2's aluminium.
DENSITY_KG_M3 = ALUMINIUM_TABLE2.density_kg_m3


def heat_capacity_j_per_k(length_m: float, width_m: float, thickness_m: float,
                          density_kg_m3: float = DENSITY_KG_M3,
                          specific_heat_j_per_kg_k: float = SPECIFIC_HEAT_J_PER_KG_K) -> float:
    """C = rho c L W h, the plate alone (its piezos and bond add to it)."""
    return density_kg_m3 * specific_heat_j_per_kg_k * length_m * width_m * thickness_m


def conductance_w_per_k(length_m: float, width_m: float, convection_w_per_m2_k: float = CONVECTION_W_PER_M2_K) -> float:
    """G = h_c 2 L W: convection from both faces (the edges' share, h / L, left out)."""
    return convection_w_per_m2_k * 2.0 * length_m * width_m


def temperature_rise_k(starts_s, ends_s, powers_w, at_s: float, heat_capacity: float, time_constant_s: float) -> float:
    """The rise at `at_s` of a plate at rest before the first interval that dissipated
    `powers_w[i]` over [starts_s[i], ends_s[i]] (intervals not overlapping): each interval's
    share of (1 / C) integral P exp(-(t - t') / tau) dt', P tau / C (exp(-(t - b) / tau) -
    exp(-(t - a) / tau)), over its part before `at_s`. tau infinite: the adiabatic E / C."""
    starts_s, ends_s = np.minimum(np.asarray(starts_s, float), at_s), np.minimum(np.asarray(ends_s, float), at_s)
    powers_w = np.asarray(powers_w, float)
    if np.isinf(time_constant_s):
        return float(np.sum(powers_w * (ends_s - starts_s)) / heat_capacity)
    held = np.exp(-(at_s - ends_s) / time_constant_s) - np.exp(-(at_s - starts_s) / time_constant_s)
    return float(np.sum(powers_w * held) * time_constant_s / heat_capacity)
