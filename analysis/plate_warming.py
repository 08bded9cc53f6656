"""How far a plate's warming had moved its resonance when a search read it: a correction and
its uncertainty from the run's own record of the power the plate dissipated.

A search states the resonance of the plate as mounted, at rest at the room's temperature
(the truth a coverage study scores it against); but a plate driven earlier in the run (Table
4's third configuration is searched on the plate its second just drove at 24 V pp, a minute
later) or by the search's own readings on the peak is warmer, and its resonance lower by
|alpha| f dT (`plates.warming`). Nothing in a search's readings tells that displacement from
the resonance itself; its sign is known, and its size follows from the run's powers and the
heating constants, whose tolerances are stated: a known systematic effect, corrected (GUM
3.2.4) by its estimate with the inputs at their best estimates (GUM 4.1.4), its u from each
input's tolerance read as a rectangle (GUM 4.3.7). It was a bias bound at the warmest end of
every tolerance at once: U then held a plate at its warmest constants, where the specified
benches' plates warm by 20 to 35 % of that, and the searches of benches within specification
were covered 97.6 % of the time (their budgets claim 95.5 % at the bound, 98.9 % at a quarter
of it). The middle of the range the tolerances span at once was tried and left: it sits above
what a plate with each constant anywhere within its tolerance gives, and the corrected
searches read high on the warming steps (+0.3 to +0.5 U on average, 20 benches).

The estimate is the energy balance of `plates.warming`'s lumped body over the run's stored
readings on the plate (every protocol's: sweeps, points, re-centrings), each interval
between two readings of the run dissipating the power the plate took at the later one: a
reading's time is its end (`protocols.acquisition.Point.clock_s`), and the protocol sets the
next reading's frequency or voltage as soon as one ends, then settles and acquires
(`protocols.resonance`, `protocols.safety.DriveController`), so the drive between two
readings is the later one's, as the simulated plate is heated (`simbench.effects.HeatingDrift`
takes the power of the drive set at every advance of its clock). The mean of the interval's
two ends, taken before, lagged a search's own warming by half a reading (3 to 6 % under the
simulated plate's rise at the searches of a plate at rest, five seeded benches; each
reading's own power, 0 to 8 % over on twelve: a step starts from the generator's minimum,
which no reading stores). The power is the
|power| the scope read less the series shunt's loss R_s I_pp^2 / 8
(`dielectric.plate_power_w`; the scope reads the power at the amplifier's output, Sec. 2.1,
and the shunt's loss heats the shunt: 8.6 % of the nine-column plate's power at resonance,
0.4 % of the one-column plate's), R_s the run's scene's (`dielectric.shunt_ohm`; a scene that
names none, the whole power, a bound), the plate at rest before the run's first reading
(which took as long as the next: the rows' clock is the campaign's). The search is corrected
reading by reading (`cold_shift_hz`): each of its readings referred to the plate at rest by
its own rise, the vertex fitted again. Dated instead by the mean time of the readings on the
peak's top, a search whose plate warmed under its golden section was over-corrected: its
crowded readings on the vertex set the mean time and barely move the vertex (the
nine-column plate's search 2.3 times the simulated plate's correction, Table 4's third
configuration 1.4 times, on a seeded bench; +0.13 and +0.2 U on twelve seeded benches). Its
u: |alpha| within +-30 %, the heat capacity (sheet thickness, density, specific heat at their
limits together), the convection, the intervals' powers at the smaller or the larger of their
ends and the shunt's resistance within `dielectric.SHUNT_TOLERANCE_REL`, each carried through
the same fit. A plate cut during
the run (Table 3) heats at each reading's length: its heat capacity and convection go with
its length, its time constant does not, and its temperature carries through the cut
(`_plate_powers`, as the simulator's plate keeps it); the mean of the cut and the uncut
plate's estimates, each over the whole run, was taken before, and on a seeded bench put the
28 mm plate 69 mK warm where it was 29. A plate driven in an earlier run is at rest when
the next starts: each run's readings are timed by its own clock.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from squeezebench.analysis.budgets import Term
from squeezebench.analysis import dielectric
from squeezebench.analysis.resonance_searches import PEAK_FIT_SHARE, peak_of_readings
from squeezebench.plates import warming
from squeezebench.plates.laminate import ALUMINIUM_TABLE2
from squeezebench.plates.specifications import (HEATING_NOMINAL, HEATING_TOLERANCES, MODEL_TOLERANCES,
                                                sheet_thickness_tolerance)

#: The columns a run's readings need for the bound.
HISTORY_COLUMNS = ("run_name", "plate", "bench_time_s", "scope_power_w")
TERM = "plate warming since at rest"
ROOM_TERM = "room drift since the run started"


def warming_estimate_k(history: pd.DataFrame, plate: str, at_s, length_m: float, width_m: float,
                       thickness_m: float, shunt_ohm: float = 0.0,
                       state_lengths_m: dict[str, float] | None = None) -> tuple:
    """The temperature rise of `plate` at `at_s` (a time, or an array of them) with its
    constants at their nominal values and each interval between two of the run's readings at
    the power the plate took at the later one (`_plate_powers`: the stored ones less the loss
    of the `shunt_ohm` shunt they were read through; the inputs' best estimates, GUM 4.1.4:
    the drive between two readings is the later one's, module docstring), and the half-widths
    of the rise's rectangles (GUM 4.3.7, 5.1.3) as each input alone runs over its tolerance:
    the capacity's (sheet thickness, density, specific heat: C and tau together), the
    convection's (tau), the intervals' powers (the larger of their ends against the smaller)
    and the shunt's resistance (`dielectric.SHUNT_TOLERANCE_REL`: more of it leaves the plate
    less). Each half-width is signed, the rise at one end of its input's tolerance less that at
    the other, halved (a search weighs its readings' rises, `search_warming_term`, and the
    weighed halves are what is a half-width); the powers' and the shunt's are never negative.
    A reading in a state of `state_lengths_m` (a plate cut during the run) heats the plate at
    its cut length (`_plate_powers`)."""
    lengths = (length_m, state_lengths_m or {})
    times_s, power_w = _plate_powers(history, plate, shunt_ohm, *lengths)

    def rise(capacity: float = 0.0, convection: float = 0.0, held_w: np.ndarray = power_w):
        return _rise_at_k(times_s, held_w, at_s, _body(length_m, width_m, thickness_m, capacity, convection))

    less_shunt_w, more_shunt_w = (
        _plate_powers(history, plate, shunt_ohm * (1.0 + sign * dielectric.SHUNT_TOLERANCE_REL), *lengths)[1]
        for sign in (-1, 1))
    halves = [0.5 * (rise(capacity=1.0) - rise(capacity=-1.0)), 0.5 * (rise(convection=1.0) - rise(convection=-1.0)),
              0.5 * (rise(held_w=warming.held_powers_w(power_w)) - rise(held_w=warming.held_powers_w(power_w, np.minimum))),
              0.5 * (rise(held_w=less_shunt_w) - rise(held_w=more_shunt_w))]
    return rise(), halves


def _plate_powers(history: pd.DataFrame, plate: str, shunt_ohm: float, length_m: float,
                  state_lengths_m: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """The run's readings' sorted times and the power each dissipated in `plate`
    (`dielectric.plate_power_w`: the scope's less the `shunt_ohm` shunt's loss; 0 on another
    plate; a reading without a power, the plate's largest), as the plate at `length_m` would
    take it: a plate cut to L (its reading's state in `state_lengths_m`) has its heat
    capacity and its convection both in proportion to L (tau unchanged), so
    C(L) dT/dt = P - G(L) T is C(L0) dT/dt = P L0 / L - G(L0) T, its temperature carried
    through the cut (a temperature, not a heat: the piece kept holds it)."""
    rows = history.sort_values("bench_time_s", kind="stable")
    on_plate = (rows["plate"] == plate).to_numpy()
    current_pp_a = rows["scope_current_pp_a"].to_numpy(float) if "scope_current_pp_a" in rows else math.nan
    states = rows["scene_state"] if "scene_state" in rows else pd.Series(None, index=rows.index, dtype=object)
    per_length = length_m / states.map(state_lengths_m).fillna(length_m).to_numpy(float)
    power_w = np.where(on_plate, per_length * dielectric.plate_power_w(rows["scope_power_w"].to_numpy(float),
                                                                       current_pp_a, shunt_ohm), 0.0)
    if on_plate.any():
        power_w = np.where(on_plate & ~np.isfinite(power_w), np.nanmax(np.where(on_plate, power_w, np.nan)), power_w)
    return rows["bench_time_s"].to_numpy(float), power_w


def _body(length_m: float, width_m: float, thickness_m: float, capacity: float, convection: float) -> warming.ThermalPlate:
    """The plate's lumped body with its heat capacity's inputs (sheet thickness, density,
    specific heat) at `capacity` times their tolerances from nominal and its convection at
    `convection` times its own (-1, 0 or 1)."""
    return warming.thermal_plate(
        length_m * 1e3, width_m * 1e3, thickness_m * (1.0 + capacity * sheet_thickness_tolerance(thickness_m)) * 1e3,
        ALUMINIUM_TABLE2.density_kg_m3 * (1.0 + capacity * _tolerance(MODEL_TOLERANCES, "density_kg_m3")),
        HEATING_NOMINAL["specific_heat_j_per_kg_k"] * (1.0 + capacity * _tolerance(HEATING_TOLERANCES, "specific_heat_j_per_kg_k")),
        HEATING_NOMINAL["convection_w_per_m2_k"] * (1.0 + convection * _tolerance(HEATING_TOLERANCES, "convection_w_per_m2_k")))


def _rise_at_k(times_s: np.ndarray, held_w: np.ndarray, at_s, body: warming.ThermalPlate):
    """The body's rise at `at_s` (a time, or an array of them) under the run's powers, each
    held over the interval that closes at its reading, at rest before the run's first reading
    (`run_start_s`) and undriven after its last: an interval holding a time is cut there."""
    grid_s = np.concatenate([[run_start_s(times_s)], times_s])
    held_w = np.concatenate([[0.0], held_w, [0.0]])   # held_w[j]: over (grid_s[j - 1], grid_s[j]]
    query_s = np.atleast_1d(np.asarray(at_s, dtype=float))
    kept = int(np.searchsorted(grid_s, query_s.max(), side="right"))   # the intervals after the last time: none
    times_s = np.concatenate([grid_s[:kept], query_s])
    order = np.argsort(times_s, kind="stable")
    rise_k = np.empty(len(times_s))
    rise_k[order] = warming.temperature_rise_k(
        times_s[order], np.concatenate([held_w[:kept], held_w[np.searchsorted(grid_s, query_s)]])[order], body)
    return float(rise_k[kept]) if np.ndim(at_s) == 0 else rise_k[kept:]


def run_start_s(times_s: np.ndarray) -> float:
    """When a run's plate was last at rest, from its readings' sorted times: the first reading
    took as long as the next (a reading's own time; the rows store no run start, and their
    clock is the campaign's)."""
    return float(times_s[0] - (times_s[1] - times_s[0] if len(times_s) > 1 else 0.0))


def _tolerance(table: dict, key: str) -> float:
    return table[key].half_width


def top_readings_time_s(sweep_time_s: np.ndarray, sweep_velocity: np.ndarray) -> float:
    """When a search read its resonance: the mean time of its readings on the peak's top
    (those at PEAK_FIT_SHARE of the largest or above, the ones its vertex is fitted to)."""
    top = sweep_velocity >= PEAK_FIT_SHARE * np.nanmax(sweep_velocity)
    return float(np.mean(sweep_time_s[top]))


def plate_size_m(scene: dict) -> tuple[float, float, float] | None:
    """The plate's length, width and thickness (m) from its scene copy, as mounted (None if
    it lacks one)."""
    plate = scene.get("plate") if isinstance(scene, dict) else None
    sizes = [plate.get(key) if isinstance(plate, dict) else None for key in ("length_mm", "width_mm", "thickness_mm")]
    if not all(isinstance(size, (int, float)) and size > 0 for size in sizes):
        return None
    return tuple(size * 1e-3 for size in sizes)


def state_lengths_m(scene: dict) -> dict[str, float]:
    """The plate's length (m) in each scene state that states one (`plate_length_mm`: Table
    3's cuts)."""
    declared = scene.get("states") if isinstance(scene, dict) and isinstance(scene.get("states"), dict) else {}
    return {state: 1e-3 * values["plate_length_mm"] for state, values in declared.items()
            if isinstance(values, dict) and isinstance(values.get("plate_length_mm"), (int, float))
            and values["plate_length_mm"] > 0}


def search_room_term(history: pd.DataFrame, frequency_hz: float, at_s: float) -> Term | None:
    """The room's drift since the run started (`run_start_s` of the run's readings, `history`)
    until `at_s`: the plate follows the room, whose temperature moves by up to
    `warming.ROOM_DRIFT_K_PER_S` t of a sign nothing here knows, and the resonance with it by
    f |alpha| of that (`warming.room_drift_bound_hz`): a rectangle about zero (GUM 4.3.7),
    as in the drift's estimate (`resonance_drift`). None where the run holds no dated reading."""
    times_s = np.sort(history["bench_time_s"].to_numpy(float)) if "bench_time_s" in history else np.array([])
    times_s = times_s[np.isfinite(times_s)]
    if not len(times_s) or not math.isfinite(at_s):
        return None
    elapsed_s = at_s - run_start_s(times_s)
    bound_hz = float(warming.room_drift_bound_hz(frequency_hz, elapsed_s))
    return Term(ROOM_TERM, "B", bound_hz / math.sqrt(3.0),
                f"the room's air drifting by up to {3600.0 * warming.ROOM_DRIFT_K_PER_S:g} K/h over the "
                f"{elapsed_s:.0f} s since the run started, the plate following it: the resonance within "
                f"+-{bound_hz:.2f} Hz (f |alpha|, alpha at its limit; sign unknown)", rectangular=True)


def search_warming_term(history: pd.DataFrame, plate: str, scene: dict, frequency_hz: float,
                        reading_s: np.ndarray, setting_hz: np.ndarray,
                        velocity: np.ndarray) -> tuple[float, Term] | None:
    """The correction of a search of `plate` for its plate's warming, and its term (module
    docstring): its readings (their times `reading_s`, settings `setting_hz` and velocities),
    each on the plate as warm as it was when it was read, referred to the plate at rest
    (`cold_shift_hz`). None where the run's readings hold no power, the plate's scene no
    size, or the search no dated reading."""
    reading_s = np.asarray(reading_s, dtype=float)
    if (not set(HISTORY_COLUMNS) <= set(history.columns) or not len(reading_s) or not np.isfinite(reading_s).all()
            or not np.isfinite(history.loc[history["plate"] == plate, "scope_power_w"].to_numpy(float)).any()):
        return None
    size_m = plate_size_m(scene)
    if size_m is None:
        return None
    ohm = dielectric.shunt_ohm(scene) or 0.0   # a scene that names none: the whole stored power, an upper bound
    rises_k, halves_k = warming_estimate_k(history, plate, reading_s, *size_m, ohm, state_lengths_m(scene))
    alpha = abs(HEATING_NOMINAL["frequency_coefficient_per_k"])

    def shift_hz(rise_k: np.ndarray) -> float:
        return cold_shift_hz(setting_hz, velocity, frequency_hz, alpha * np.asarray(setting_hz, dtype=float) * rise_k)

    correction_hz = shift_hz(rises_k)
    alpha_half = _tolerance(HEATING_TOLERANCES, "frequency_coefficient_per_k")
    u_hz = math.hypot(alpha_half * correction_hz, *(shift_hz(half_k) for half_k in halves_k)) / math.sqrt(3.0)
    rise_k = correction_hz / (frequency_hz * alpha)
    return correction_hz, Term(
        TERM, "B", u_hz,
        f"corrected by +{correction_hz:.2f} Hz: the plate {rise_k * 1e3:.1f} mK warmer than at rest where the "
        "search read its resonance (each reading at its own warming, referred to the plate at rest and the "
        "vertex fitted again), from the run's stored powers on it, each held from the reading before, less the "
        f"{ohm:g} ohm shunt's loss (energy balance, plates.warming, the constants nominal); u from the heating "
        f"tolerances (the resonance's {HEATING_NOMINAL['frequency_coefficient_per_k']:.0e}/K +-{alpha_half:.0%}, "
        "heat capacity, convection), the powers between their readings and the shunt's resistance, each a "
        "rectangle", rectangular=False)


def cold_shift_hz(setting_hz, velocity, frequency_hz: float, shift_hz) -> float:
    """How far a search's resonance `frequency_hz` moves when each of its readings (at
    `setting_hz`, reading `velocity`) is referred to the plate at rest: a plate whose resonance
    is lower by `shift_hz` (per reading: f |alpha| T at its own T) reads at f what the plate at
    rest reads at f + shift (the mode's velocity depends on f / f0 alone, `peak_of_readings`).
    A resonance fitted to the readings' top moves as the vertex fitted to the shifted
    readings: each reading moves it by as much as it weighs in the fit, which the mean time of
    the top readings does not tell (a golden section's readings, crowded on the vertex, weigh
    little; the sweep's on the top's sides, read earlier, most: on a seeded bench Table 4's
    third configuration's plate warmed from 62 to 166 mK over its top readings, and dated by
    their mean time its correction read its search 0.2 U high on twelve). A stored best
    reading (no top to fit) moves by its own shift."""
    setting_hz, velocity, shift_hz = (np.asarray(values, dtype=float) for values in (setting_hz, velocity, shift_hz))
    fit = peak_of_readings(setting_hz, velocity)
    if fit is not None and not np.isin(frequency_hz, setting_hz):
        cold = peak_of_readings(setting_hz + shift_hz, velocity)
        if cold is not None:
            return cold.frequency_hz - fit.frequency_hz
    at = np.flatnonzero(setting_hz == frequency_hz)
    return float(shift_hz[at[0] if len(at) else int(np.nanargmax(velocity))])
