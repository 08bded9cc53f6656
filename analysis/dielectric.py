"""The parts of a stored power that do not follow the resonance: the piezos' dielectric loss,
and the series shunt's loss from their capacitive current.

The scope reads the electrical power in (Sec. 2.1): the motional branch's, which follows the
resonance's Lorentzian (P ~ v^2 at one voltage), plus the clamped capacitance's loss
P_d = w C0 V0^2 tan(delta) / 2 (`plates.damping.dielectric_power_w`), whose tan(delta) grows
with the field as tan_ref (E / E_ref)^n (`damping.field_tan_delta`): P_d goes as f V0^(2 + n)
and not with the resonance. Fig. 2's Pt is read on the resonance's slope at a higher voltage
than P0, so its dielectric share is larger, and a generator's frequency or amplitude error
moves it otherwise than P0 (`uncertainty.power_ratio_budget`). Both factors from stored data:

- C0 from the run's own reading at resonance (same run and velocity level): there the
  motional branch is a real admittance, so the reactive power is the capacitance's alone,
  |Q_r0| = w0 C0 V0^2 / 2 (the plate as built, whatever its permittivity);
- tan(delta)'s law from the scene copy the run stored (inputs/): its `dielectric_loss`
  effect, values over `damping.DIELECTRIC_LOSS_DEFAULTS` as the simulator takes them, and
  the piezos' thickness; a scene without that effect describes loss-free piezos (share 0).
  A bench without a scene (a real one) has the law its campaign states for the plate
  (`protocols.steps.PiezoLoss`, stored with every row: `STATED_COLUMNS`).

A point with neither, or whose run and level hold no reading at resonance, has no estimate
(NaN): its budgets take the whole power as following the resonance, which gives the larger
generator-frequency term (`NOT_DESCRIBED` says so in the term's source).

The power is read through the series shunt R_s (Sec. 2.1: CH1 at the amplifier's output), so
it holds R_s |I|^2 / 2 with I = I_m + I_C, the motional current and the capacitive one,
I_C = j w C0 V0. Its parts: R_s |I_m|^2 / 2 goes as v^2, with the resonance;
R_s (w C0 V0)^2 / 2 as f^2 V^2 (`shunt_capacitive_power_w`), not with it; and the cross term
R_s Re(I_m I_C*) = -2 R_s w C0 x P_m (`shunt_cross_power_w`), x = 2 Q (f - f0) / f0 signed
(x^2 = 1 / r^2 - 1 at a point's velocity ratio r), as f x P_m; its slope dS_x / dx = -2 R_s w
C0 P_m (`shunt_cross_slope_w`) is the same at every x, the peak's too, where S_x is 0: a drift
or the generator's frequency error that moves P0 off the peak moves S_x there as on the slope
(`uncertainty.resonance_power_per_hz`, `uncertainty.generator_sensitivities`). C0 is the
level's (above); R_s the scene copy's where it names the `shunt` effect (0 where it does not:
the simulated plate then has none), a bench file's `electronics.shunt_ohm`; a point without
both has no estimate and its whole shunt loss counts as following the resonance (1.4 % of
Fig. 2a's Pt at r = 0.5, 75 Vpp).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from squeezebench.analysis import provenance
from squeezebench.plates import damping

#: The scene effect that describes the piezos' dielectric loss (simbench's name for it).
DIELECTRIC_LOSS_EFFECT = "dielectric_loss"
#: The scene effect that puts the series shunt in the simulated bench.
SHUNT_EFFECT = "shunt"
#: What a budget says of a point without an estimate.
NOT_DESCRIBED = ("no stored description of the piezos' dielectric loss (no scene copy with the run, or no "
                 "reading at resonance): the whole power is taken to follow the resonance, the larger "
                 "(conservative) generator-frequency term")


def loss_law(scene: dict) -> dict[str, float] | None:
    """The field law of a stored scene's piezos: tan_delta_at_reference, reference field
    (V/m), exponent and piezo thickness (m); tan 0 when the scene names no dielectric loss.
    None when the scene gives no piezo thickness (not a scene this law can read)."""
    piezo = ((scene.get("actuators") or {}).get("piezo") or {}) if isinstance(scene, dict) else {}
    thickness_mm = piezo.get("thickness_mm") if isinstance(piezo, dict) else None
    if not isinstance(thickness_mm, (int, float)) or not thickness_mm > 0:
        return None
    law = {**damping.DIELECTRIC_LOSS_DEFAULTS, "tan_delta_at_reference": 0.0}
    for effect in scene.get("effects") or []:
        if effect == DIELECTRIC_LOSS_EFFECT:
            law = dict(damping.DIELECTRIC_LOSS_DEFAULTS)
        elif isinstance(effect, dict) and DIELECTRIC_LOSS_EFFECT in effect:
            law = {**damping.DIELECTRIC_LOSS_DEFAULTS, **(effect[DIELECTRIC_LOSS_EFFECT] or {})}
    return {"tan_delta_at_reference": float(law["tan_delta_at_reference"]),
            "reference_field_amplitude_v_per_m": float(law["reference_field_amplitude_v_per_mm"]) * 1e3,
            "exponent": float(law["exponent"]), "piezo_thickness_m": float(thickness_mm) * 1e-3}


#: The row columns of a law the campaign states (`protocols.steps.PiezoLoss.as_row`), in
#: the order of `damping.field_tan_delta`'s: thickness (mm), tan_ref, E_ref (V/mm), exponent.
STATED_COLUMNS = ("piezo_thickness_mm", "piezo_tan_delta_at_reference", "piezo_loss_reference_field_v_per_mm",
                  "piezo_loss_exponent")


def stated_law(row: dict) -> dict[str, float] | None:
    """The law a campaign stated for the row's plate (None: it stated none)."""
    values = [row.get(column) for column in STATED_COLUMNS]
    if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in values):
        return None
    thickness_mm, tan_delta, field_v_per_mm, exponent = map(float, values)
    return {"tan_delta_at_reference": tan_delta, "reference_field_amplitude_v_per_m": field_v_per_mm * 1e3,
            "exponent": exponent, "piezo_thickness_m": thickness_mm * 1e-3}


def clamped_capacitance_f(reactive_power_var: float, frequency_hz: float, voltage_vpp: float) -> float:
    """C0 from a reading at resonance, where the reactive power is the capacitance's alone:
    |Q_r| = w C0 V0^2 / 2, V0 = V_pp / 2."""
    return abs(reactive_power_var) / (math.pi * frequency_hz * (voltage_vpp / 2.0) ** 2)


def dielectric_power_w(law: dict[str, float], capacitance_f: float, frequency_hz: float,
                       voltage_vpp: float) -> float:
    """The piezos' dielectric loss at one drive, tan(delta) at its own field."""
    tan_delta = damping.field_tan_delta(voltage_vpp / 2.0, law["piezo_thickness_m"], law["tan_delta_at_reference"],
                                        law["reference_field_amplitude_v_per_m"], law["exponent"])
    return damping.dielectric_power_w(frequency_hz, capacitance_f, voltage_vpp, tan_delta)


def shunt_ohm(stored: dict) -> float | None:
    """The series shunt a run's powers were read through, from its stored scene or bench file
    (module docstring); None where the copy does not say."""
    electronics = stored.get("electronics") if isinstance(stored, dict) else None
    value = electronics.get("shunt_ohm") if isinstance(electronics, dict) else None
    if not isinstance(value, (int, float)) or not value >= 0:
        return None
    if "actuators" in stored:   # a scene: the simulator has the shunt only where it is named
        named = [e if isinstance(e, str) else next(iter(e), None) for e in stored.get("effects") or []]
        return float(value) if SHUNT_EFFECT in named else 0.0
    return float(value)


#: The shunt's resistance about its stated value (a rectangle's half-width, relative).
SHUNT_TOLERANCE_REL = 0.01   # assumed: the 2 ohm shunt within 1 %


def plate_power_w(stored_power_w, current_pp_a, shunt_ohm: float) -> np.ndarray:
    """The power the plate itself dissipates, the one that warms it (`plates.warming`): the
    stored power, read through the series shunt at the amplifier's output (Sec. 2.1), less the
    shunt's loss R_s I_rms^2, I_rms = I_pp / (2 sqrt 2) for the sinusoidal current CH2 reads:

        P_plate = |P| - R_s I_pp^2 / 8   (never below 0)

    It keeps the piezos' dielectric loss: they are bonded to the plate and warm with it. A
    reading without a stored current keeps its whole power, which bounds the plate's from
    above (the shunt takes under 10 % of it at resonance: `simbench.scene_bounds`)."""
    current_pp_a = np.asarray(current_pp_a, dtype=float)
    shunt_w = np.where(np.isfinite(current_pp_a), shunt_ohm * current_pp_a**2 / 8.0, 0.0)
    return np.maximum(np.abs(np.asarray(stored_power_w, dtype=float)) - shunt_w, 0.0)


def shunt_capacitive_power_w(shunt_ohm: float, capacitance_f: float, frequency_hz: float, voltage_vpp: float) -> float:
    """R_s |I_C|^2 / 2, I_C = w C0 V0 (V0 = V_pp / 2): the shunt's loss from the capacitive current."""
    return 0.5 * shunt_ohm * (2.0 * math.pi * frequency_hz * capacitance_f * voltage_vpp / 2.0) ** 2


def shunt_cross_power_w(shunt_ohm: float, capacitance_f: float, frequency_hz: float, detuning_x: float,
                        resonant_power_w: float) -> float:
    """R_s Re(I_m I_C*) = -2 R_s w C0 x P_m, P_m the motional power: Y_m = G / (1 + j x) puts
    Re(Y_m (-j w C0)) = -w C0 x G / (1 + x^2) = -2 w C0 x P_m / V0^2. `resonant_power_w`: the
    part of the power that goes as v^2 (P_m and the shunt's R_s |I_m|^2 / 2, 1 + R_s G of it)."""
    return -2.0 * shunt_ohm * 2.0 * math.pi * frequency_hz * capacitance_f * detuning_x * resonant_power_w


def with_dielectric_power(points: pd.DataFrame, scenes: dict[str, dict]) -> pd.DataFrame:
    """`points` with `dielectric_power_w` (NaN without an estimate, module docstring) and
    `dielectric_voltage_exponent` (2 + n: d ln P_d / d ln V) for every point of a detuning run
    whose run and level hold a reading at resonance and whose law is known: its scene copy in
    `scenes`, else the one its campaign stated; and the shunt's parts, `shunt_capacitive_power_w`,
    `shunt_cross_power_w` and `shunt_cross_slope_w` (dS_x / dx), where the stored copy gives the
    shunt (NaN where not)."""
    out = points.copy()
    for column in ("dielectric_power_w", "dielectric_voltage_exponent", *SHUNT_COLUMNS):
        out[column] = math.nan
    needed = {"detuning_phase", "velocity_level_pp_mps", "reactive_power_var", "piezo_voltage_vpp", "frequency_hz"}
    if out.empty or not needed <= set(out.columns):
        return out
    scene_files = provenance.scene_files(out)
    at_resonance = out[(out["detuning_phase"] == "resonance") & out["reactive_power_var"].notna()]
    levels = at_resonance.groupby(["run_name", "velocity_level_pp_mps"])
    capacitance = {key: clamped_capacitance_f(float(group["reactive_power_var"].mean()),
                                              float(group["frequency_hz"].mean()),
                                              float(group["piezo_voltage_vpp"].mean()))
                   for key, group in levels}
    resonance_hz = levels["frequency_hz"].mean().to_dict()
    shunt_parts = np.full((len(out), len(SHUNT_COLUMNS)), math.nan)   # set as whole columns: a .loc per row cost more than its sums
    for position, (index, row) in enumerate(zip(out.index, out.to_dict("records"))):
        stored = scenes.get(scene_files[index], {})
        law = loss_law(stored) or stated_law(row)
        key = (row["run_name"], row["velocity_level_pp_mps"])
        c0 = capacitance.get(key)
        if c0 is None or not np.isfinite(row["piezo_voltage_vpp"]):
            continue
        frequency_hz, voltage_vpp = float(row["frequency_hz"]), float(row["piezo_voltage_vpp"])
        loss_w = math.nan
        if law is not None:
            loss_w = dielectric_power_w(law, c0, frequency_hz, voltage_vpp)
            out.at[index, "dielectric_power_w"] = loss_w
            out.at[index, "dielectric_voltage_exponent"] = 2.0 + law["exponent"]
        ohm = shunt_ohm(stored)
        if ohm is not None:
            shunt_parts[position] = _shunt_parts(ohm, c0, row, resonance_hz[key], loss_w)
    out[list(SHUNT_COLUMNS)] = shunt_parts
    return out


#: The shunt's parts `with_dielectric_power` adds.
SHUNT_COLUMNS = ("shunt_capacitive_power_w", "shunt_cross_power_w", "shunt_cross_slope_w")


def _shunt_parts(ohm: float, c0: float, row: dict, resonance_hz: float, loss_w: float) -> list[float]:
    """A point's shunt loss from the capacitive current, its cross term and its slope in x,
    dS_x / dx = -2 R_s w C0 P_m; x from the point's velocity ratio (0 at resonance, where S_x = 0
    but its slope is not: a drift that moves P0 off the peak moves it by the slope, as it moves
    Pt), the resonant part of its power what the rest leaves."""
    frequency_hz, voltage_vpp = float(row["frequency_hz"]), float(row["piezo_voltage_vpp"])
    capacitive_w = shunt_capacitive_power_w(ohm, c0, frequency_hz, voltage_vpp)
    per_x = shunt_cross_power_w(ohm, c0, frequency_hz, 1.0, 1.0)   # S_x = per_x x P_m
    ratio, offset_hz = row.get("target_velocity_ratio"), frequency_hz - resonance_hz
    if row["detuning_phase"] == "resonance" or not isinstance(ratio, (int, float)) or not 0 < ratio < 1 \
            or offset_hz == 0:
        resonant_w = float(row["power_w"]) - np.nan_to_num(loss_w) - capacitive_w
        return [capacitive_w, 0.0, per_x * resonant_w]
    x = math.copysign(math.sqrt(1.0 / ratio**2 - 1.0), offset_hz)
    resonant_w = (float(row["power_w"]) - np.nan_to_num(loss_w) - capacitive_w) / (1.0 + per_x * x)
    return [capacitive_w, per_x * x * resonant_w, per_x * resonant_w]
