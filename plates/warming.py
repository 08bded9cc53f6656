"""A plate's warming under its drive and the fall of its resonance: a lumped thermal model.

A thin aluminium plate conducts heat across its thickness far faster than still air takes
it from its faces (Biot number h t / k ~ 10 W/m^2K x 1 mm / 200 W/mK = 5e-5), so it warms
as one body: C dT/dt = P - G T (Newton's law of cooling), T its rise over the room, P the
power it dissipates, C = rho c L W t its heat capacity and G = h 2 L W the convection from
both faces (Incropera & DeWitt, Fundamentals of Heat and Mass Transfer, Sec. 5.2, the
lumped capacitance method; tau = C / G). Its resonance goes as sqrt(E / rho) times its
geometry, so it moves by f alpha T, alpha the frequency's temperature coefficient.

Nominal values and their tolerances are `specifications.HEATING_NOMINAL` and
`specifications.HEATING_TOLERANCES`: a plate within them has its time constant within
`time_constant_range_s` and its resonance moves by f |alpha| / C per joule it keeps, within
`drift_per_joule_range_hz`, so the drift is f |alpha| / C times the heat E(t) it holds,
E = C T (`held_heat_j`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from squeezebench.plates.specifications import HEATING_NOMINAL, HEATING_TOLERANCES


@dataclass(frozen=True)
class ThermalPlate:
    """A plate as one thermal body: its heat capacity C (J/K) and its conductance G = h A
    (W/K) to the room."""

    heat_capacity_j_per_k: float
    conductance_w_per_k: float

    @property
    def time_constant_s(self) -> float:
        """tau = C / G: how fast the plate settles at its steady rise P / G."""
        return self.heat_capacity_j_per_k / self.conductance_w_per_k


def thermal_plate(length_mm: float, width_mm: float, thickness_mm: float, density_kg_m3: float,
                  specific_heat_j_per_kg_k: float, convection_w_per_m2_k: float) -> ThermalPlate:
    """C = rho c L W t and G = h 2 L W (both faces; the edges' 2 (L + W) t is under 4 % of
    them for a 1 mm plate of a few centimetres, and left out)."""
    face_m2 = length_mm * width_mm * 1e-6
    return ThermalPlate(density_kg_m3 * specific_heat_j_per_kg_k * face_m2 * thickness_mm * 1e-3,
                        convection_w_per_m2_k * 2.0 * face_m2)


def time_constant_range_s(length_mm: float, width_mm: float, thickness_mm: float,
                          density_kg_m3: float) -> tuple[float, float]:
    """The least and the largest tau = C / G within `HEATING_TOLERANCES` (c at its limits, h
    at the opposite ones)."""
    c, h = (HEATING_NOMINAL[key] for key in ("specific_heat_j_per_kg_k", "convection_w_per_m2_k"))
    dc, dh = (HEATING_TOLERANCES[key].half_width for key in ("specific_heat_j_per_kg_k", "convection_w_per_m2_k"))
    return tuple(thermal_plate(length_mm, width_mm, thickness_mm, density_kg_m3, c * (1 + sc * dc),
                               h * (1 - sc * dh)).time_constant_s for sc in (-1.0, 1.0))


def drift_per_joule_range_hz(frequency_hz: float, length_mm: float, width_mm: float, thickness_mm: float,
                             density_kg_m3: float) -> tuple[float, float]:
    """The least and the largest f |alpha| / C (Hz per joule held in the plate) within
    `HEATING_TOLERANCES`: how far the resonance moves per joule the plate has kept."""
    c, alpha = HEATING_NOMINAL["specific_heat_j_per_kg_k"], abs(HEATING_NOMINAL["frequency_coefficient_per_k"])
    dc, da = (HEATING_TOLERANCES[key].half_width for key in ("specific_heat_j_per_kg_k", "frequency_coefficient_per_k"))
    capacity = thermal_plate(length_mm, width_mm, thickness_mm, density_kg_m3, c, 1.0).heat_capacity_j_per_k
    return (frequency_hz * alpha * (1 - da) / (capacity * (1 + dc)),
            frequency_hz * alpha * (1 + da) / (capacity * (1 - dc)))


def held_powers_w(power_w, bound=np.maximum) -> np.ndarray:
    """The power over the interval before each of a run's dated readings, for
    `temperature_rise_k`: the larger of that reading's and the previous one's (the first,
    its own), or with `bound` np.minimum the smaller. A drive that rose (a regain) or fell (a
    detuning at the level's voltage) between two readings stayed between their settings, so
    the larger bounds the heat from above and the smaller from below."""
    power_w = np.asarray(power_w, dtype=float)
    return bound(power_w, np.concatenate([power_w[:1], power_w[:-1]]))


def held_heat_j(times_s, power_w, time_constant_s: float) -> np.ndarray:
    """E = C T, the heat the plate holds at each of `times_s` (`temperature_rise_k` of a plate
    of C = 1 J/K): int P(t') exp(-(t - t') / tau) dt', which needs tau alone."""
    return temperature_rise_k(times_s, power_w, ThermalPlate(1.0, 1.0 / time_constant_s))


def temperature_rise_k(times_s, power_w, plate: ThermalPlate) -> np.ndarray:
    """The plate's rise over the room at each of `times_s` (increasing), cold at the first,
    the power held at `power_w[i]` over (times_s[i - 1], times_s[i]]: the exact step of
    C dT/dt = P - G T, T_i = P_i / G + (T_(i-1) - P_i / G) exp(-(t_i - t_(i-1)) / tau)."""
    times_s, power_w = np.asarray(times_s, dtype=float), np.asarray(power_w, dtype=float)
    decay = np.exp(-np.diff(times_s, prepend=times_s[:1]) / plate.time_constant_s)
    rise_k = np.zeros(len(times_s))
    for i in range(1, len(times_s)):
        steady_k = power_w[i] / plate.conductance_w_per_k
        rise_k[i] = steady_k + (rise_k[i - 1] - steady_k) * decay[i]
    return rise_k


def resonance_drift_bound_hz(frequency_hz: float, rise_k) -> np.ndarray:
    """|delta f| <= f |alpha| T with alpha at its tolerance's limit (`HEATING_TOLERANCES`)."""
    alpha = abs(HEATING_NOMINAL["frequency_coefficient_per_k"]) * (
        1.0 + HEATING_TOLERANCES["frequency_coefficient_per_k"].half_width)
    return frequency_hz * alpha * np.asarray(rise_k, dtype=float)


#: How fast a lab's air may drift (K/s): assumed, an air-conditioned room held within about
#: a kelvin, drifting by at most 1 K over an hour. The plate follows it (lagged by tau), so
#: its resonance may move by f |alpha| ROOM_DRIFT_K_PER_S t over a run's t seconds.
ROOM_DRIFT_K_PER_S = 1.0 / 3600.0


def room_drift_bound_hz(frequency_hz: float, elapsed_s) -> np.ndarray:
    """The room's share of the drift after `elapsed_s` (`ROOM_DRIFT_K_PER_S`)."""
    return resonance_drift_bound_hz(frequency_hz, ROOM_DRIFT_K_PER_S * np.maximum(np.asarray(elapsed_s, float), 0.0))

