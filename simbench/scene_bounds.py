"""What makes a scene's state a plate that can exist (`BOUNDS`) and one physics predicts
(`PLAUSIBILITY`): the figures at resonance checked against them (`StateFigures`), which
`simbench.scene.load_scene` applies to every state and docs/scenes.md tabulates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from squeezebench.simbench import physics
from squeezebench.simbench.scene_mechanics import assembly_mass_kg, force_factor_n_per_v
from squeezebench.simbench.scene_model import PAPER_MODEL_REFERENCE_VPP, Scene, State

#: What a plate that can exist obeys (checked on every state at load).
MAX_SHUNT_SHARE = 0.10  # Sec. 2.1: the 2 ohm shunt took at most 10 % of the power
MAX_POWER_FACTOR = 0.99  # a piezo load is capacitive: C0 always draws reactive current
BOUNDS = {
    "effective_coupling": "effective coupling <= the piezo material's k31",
    "power_factor": f"power factor at resonance < {MAX_POWER_FACTOR:g}",
    "modal_mass_ratio": "modal mass <= the mass of the plate with its piezos (not for a predicted state: the "
                        "model's own mass, at a point that may move less than the peak)",
    "shunt_share": f"shunt share of the power at resonance <= {MAX_SHUNT_SHARE:.0%} (Sec. 2.1)",
    "positive": "C0, R_mech, force factor and modal mass > 0",
}
#: What a plate physics predicts obeys (checked on every state of a scene that is not a replay).
PLAUSIBILITY = {
    "q_mech_range": "q_mech within the resonator material's range for a free plate in air "
                    "(physics.ResonatorMaterial.q_mech_range)",
    "plate_model": "a calibrated state's resonance, force factor and modal mass within the plate model's "
                   "tolerances (simbench.predicted)",
}


@dataclass(frozen=True)
class StateFigures:
    """What makes a state physically possible or not, at resonance."""

    scene: str
    state: str
    origin: str  # "physical", or the calibration's form (and reading)
    capacitance_nf: float
    effective_coupling: float
    material_k31: float
    power_factor: float
    modal_mass_g: float
    plate_mass_g: float
    shunt_share: float
    shunt_share_detuned: float  # at the Fig. 2 50 % detuning, voltage doubled to regain v0
    loss_w_per_um2: float  # plate power / (amplitude pp in um)^2
    force_factor_vs_datasheet: float  # calibrated n_c psi over the pin-force value
    q_mech: float
    q_mech_range: tuple[float, float]  # the resonator material's

    @property
    def modal_mass_ratio(self) -> float:
        return self.modal_mass_g / self.plate_mass_g

    def violations(self) -> list[str]:
        """Each bound of BOUNDS this state breaks, with the values."""
        broken = []
        if not all(v > 0 and math.isfinite(v) for v in (self.capacitance_nf, self.modal_mass_g,
                                                          self.force_factor_vs_datasheet, self.q_mech)):
            broken.append(f"{BOUNDS['positive']}: C0 {self.capacitance_nf:.4g} nF, modal mass "
                          f"{self.modal_mass_g:.4g} g, q_mech {self.q_mech:.4g}")
        if self.effective_coupling > self.material_k31:
            broken.append(f"{BOUNDS['effective_coupling']}: k_eff {self.effective_coupling:.3f} > "
                          f"k31 {self.material_k31:.3f}")
        if self.power_factor >= MAX_POWER_FACTOR:
            broken.append(f"{BOUNDS['power_factor']}: power factor {self.power_factor:.4f}")
        # a predicted mass is the plate model's own, referred to the measurement point: above
        # the plate's mass where the point moves less than the mode's peak, which is physics
        if self.modal_mass_ratio > 1.0 and self.origin != "predicted":
            broken.append(f"{BOUNDS['modal_mass_ratio']}: modal mass {self.modal_mass_g:.4g} g > "
                          f"{self.plate_mass_g:.4g} g ({self.modal_mass_ratio:.3g} x)")
        if self.shunt_share > MAX_SHUNT_SHARE:
            broken.append(f"{BOUNDS['shunt_share']}: the shunt takes {self.shunt_share:.1%}")
        return broken

    def implausibilities(self) -> list[str]:
        """The q_mech bound of PLAUSIBILITY, if this state breaks it (the plate model's bound
        needs a solve: `_refuse_implausible` asks `simbench.predicted`)."""
        low, high = self.q_mech_range
        if low <= self.q_mech <= high:
            return []
        return [f"{PLAUSIBILITY['q_mech_range']}: q_mech {self.q_mech:.4g} outside {low:g} to {high:g}"]

    def as_row(self) -> dict:
        return {"scene": self.scene, "state": self.state, "origin": self.origin,
                "c0_nf": self.capacitance_nf, "effective_coupling": self.effective_coupling,
                "material_k31": self.material_k31, "power_factor": self.power_factor,
                "modal_mass_g": self.modal_mass_g, "plate_mass_g": self.plate_mass_g,
                "modal_mass_ratio": self.modal_mass_ratio, "shunt_share": self.shunt_share,
                "shunt_share_detuned": self.shunt_share_detuned,
                "loss_w_per_um2": self.loss_w_per_um2,
                "force_factor_vs_datasheet": self.force_factor_vs_datasheet, "q_mech": self.q_mech}


def state_figures(scene: "Scene", state: State) -> StateFigures:
    """C0, coupling, power factor, modal mass, shunt share and loss of `state` at
    resonance, on the scene's bench (its shunt in series, whether or not the `shunt`
    effect is on: the paper's bench had it), at the calibration voltage (20 Vpp if none)."""
    voltage_vpp = state.calibration.voltage_vpp if state.calibration else PAPER_MODEL_REFERENCE_VPP
    load = physics.PlateLoad(capacitance_f=state.capacitance_f, branches=(state.branch,),
                             series_ohm=scene.electronics.shunt_ohm)

    def at(frequency_hz: float, amplitude_v: float) -> physics.SteadyState:
        drive = physics.Drive(np.array([1]), np.array([amplitude_v + 0j]), 0.0)
        return physics.solve_steady_state(load, drive, frequency_hz)

    def shunt_share(steady: physics.SteadyState) -> float:
        shunt_w = 0.5 * scene.electronics.shunt_ohm * abs(steady.current_phasor) ** 2
        return shunt_w / steady.power_w if steady.power_w > 0 else math.inf

    steady = at(state.branch.frequency_hz, voltage_vpp / 2.0)
    current = abs(steady.current_phasor)
    apparent = 0.5 * voltage_vpp / 2.0 * current
    # Fig. 2: above resonance where |Z_mech| = 2 R_mech (q (r - 1/r) = sqrt(3)) the velocity
    # halves, and twice the voltage regains it
    x = math.sqrt(3.0) / state.q_mech
    detuned = at(state.branch.frequency_hz * (x + math.sqrt(x * x + 4.0)) / 2.0, voltage_vpp)
    amplitude_um = steady.amplitude_pp_m * 1e6
    plate = scene.plate_in(state)
    physical_psi = force_factor_n_per_v(plate, scene.actuators, scene.mode, state.powered_columns)
    origin = "predicted" if state.predicted else "physical" if state.calibration is None else (
        state.calibration.form + (f" ({state.calibration.reading})" if state.calibration.reading else ""))
    return StateFigures(
        scene=scene.path.stem, state=state.name, origin=origin, capacitance_nf=state.capacitance_f * 1e9,
        effective_coupling=physics.effective_coupling(state.branch, state.capacitance_f),
        material_k31=scene.actuators.piezo.material.k31,
        power_factor=steady.power_w / apparent if apparent > 0 else 0.0,
        modal_mass_g=physics.modal_mass_kg(state.branch) * 1e3,
        plate_mass_g=assembly_mass_kg(plate, scene.actuators) * 1e3,
        shunt_share=shunt_share(steady), shunt_share_detuned=shunt_share(detuned),
        loss_w_per_um2=steady.plate_power_w / amplitude_um**2 if amplitude_um > 0 else math.inf,
        force_factor_vs_datasheet=state.branch.force_factor_n_per_v / physical_psi if physical_psi > 0 else math.inf,
        q_mech=state.q_mech, q_mech_range=scene.plate.material.q_mech_range)


def scene_figures(scene: "Scene") -> list[StateFigures]:
    return [state_figures(scene, state) for state in scene.states.values()]
