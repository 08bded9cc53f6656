"""The part of a stored power that does not follow the resonance: the piezos' dielectric loss.

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
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from squeezebench.analysis import provenance
from squeezebench.plates import damping

#: The scene effect that describes the piezos' dielectric loss (simbench's name for it).
DIELECTRIC_LOSS_EFFECT = "dielectric_loss"
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


def with_dielectric_power(points: pd.DataFrame, scenes: dict[str, dict]) -> pd.DataFrame:
    """`points` with `dielectric_power_w` (NaN without an estimate, module docstring) and
    `dielectric_voltage_exponent` (2 + n: d ln P_d / d ln V) for every point of a detuning run
    whose run and level hold a reading at resonance and whose law is known: its scene copy in
    `scenes`, else the one its campaign stated."""
    out = points.copy()
    out["dielectric_power_w"] = math.nan
    out["dielectric_voltage_exponent"] = math.nan
    needed = {"detuning_phase", "velocity_level_pp_mps", "reactive_power_var", "piezo_voltage_vpp", "frequency_hz"}
    if out.empty or not needed <= set(out.columns):
        return out
    scene_files = provenance.scene_files(out)
    at_resonance = out[(out["detuning_phase"] == "resonance") & out["reactive_power_var"].notna()]
    capacitance = {key: clamped_capacitance_f(float(group["reactive_power_var"].mean()),
                                              float(group["frequency_hz"].mean()),
                                              float(group["piezo_voltage_vpp"].mean()))
                   for key, group in at_resonance.groupby(["run_name", "velocity_level_pp_mps"])}
    for index, row in out.iterrows():
        law = loss_law(scenes.get(scene_files[index], {})) or stated_law(row.to_dict())
        c0 = capacitance.get((row["run_name"], row["velocity_level_pp_mps"]))
        if law is None or c0 is None or not np.isfinite(row["piezo_voltage_vpp"]):
            continue
        out.at[index, "dielectric_power_w"] = dielectric_power_w(law, c0, float(row["frequency_hz"]),
                                                                 float(row["piezo_voltage_vpp"]))
        out.at[index, "dielectric_voltage_exponent"] = 2.0 + law["exponent"]
    return out
