"""What a scene file describes, once read (`simbench.scene.load_scene`): the plate, its
piezos, the mode, the states, the electronics, the measurement point and the effects.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from squeezebench.analysis import model
from squeezebench.errors import UserError
from squeezebench.simbench import physics
from squeezebench.simbench.transport_faults import TransportFault

#: The paper's model is linear in V: a `paper_model` calibration is evaluated here, inside
#: the Fig. 5 sweeps, and gives the same plate at any voltage.
PAPER_MODEL_REFERENCE_VPP = 20.0


class SceneError(UserError):
    """A scene file that cannot be used; the message names file, field and what is allowed."""


@dataclass(frozen=True)
class Plate:
    name: str
    material: physics.ResonatorMaterial
    length_mm: float
    width_mm: float
    thickness_mm: float

    @property
    def mass_kg(self) -> float:
        return self.material.density_kg_m3 * self.length_mm * self.width_mm * self.thickness_mm * 1e-9


@dataclass(frozen=True)
class Piezo:
    length_mm: float  # b_p of Eq. 25: along the nodal lines
    width_mm: float
    thickness_mm: float
    material: physics.PiezoMaterial

    @property
    def area_m2(self) -> float:
        return self.length_mm * self.width_mm * 1e-6

    @property
    def mass_kg(self) -> float:
        return self.material.density_kg_m3 * self.area_m2 * self.thickness_mm * 1e-3


@dataclass(frozen=True)
class Column:
    name: str
    position_mm: float  # centre of the column along the plate length, from one end


@dataclass(frozen=True)
class Actuators:
    piezo: Piezo
    piezos_per_column: int
    columns: tuple[Column, ...]


@dataclass(frozen=True)
class Mode:
    name: str
    half_wavelength_mm: float


@dataclass(frozen=True)
class Calibration:
    """The published (or model) measurement at resonance a state reproduces."""

    voltage_vpp: float
    velocity_pp_mps: float
    power_w: float
    form: str  # "velocity", "amplitude" or "paper_model"
    reading: str = ""  # the paper_model's convention name


@dataclass(frozen=True)
class State:
    """One condition of the plate: a cut, a set of powered columns..."""

    name: str
    description: str
    resonance_frequency_hz: float
    q_mech: float
    powered_columns: tuple[str, ...]
    n_powered_piezos: int
    calibration: Calibration | None  # None: the branch follows from the physics alone
    capacitance_f: float  # clamped capacitance of the powered piezos
    branch: physics.MotionalBranch  # the working mode (calibrated, or from the physics)
    q_mech_origin: str = "given"  # "given" or "modal mass" (derived from the plate)
    plate_length_mm: float | None = None  # the plate's length in this state (a cut); None: uncut
    #: resonance, modal mass and force factor from the plate model (simbench.predicted), not given
    predicted: bool = False

    def load(self) -> physics.PlateLoad:
        """The plate as the amplifier sees it, with every effect off."""
        return physics.PlateLoad(capacitance_f=self.capacitance_f, branches=(self.branch,))


@dataclass(frozen=True)
class Electronics:
    amplifier_gain: float = 20.0
    amplifier_max_output_vpp: float = 300.0
    amplifier_bandwidth_hz: float = 500e3
    amplifier_input_ohm: float = 1e6
    shunt_ohm: float = 2.0
    voltage_probe_attenuation: float = 100.0
    current_probe_a_per_a: float = 1.0
    generator_load: str = "INF"
    #: The CH1 probe carries a coding resistor (TekProbe level I): the scope fixes its gain
    #: at 1/voltage_probe_attenuation and names no model (CH<x>:ID? reads "").
    voltage_probe_coded: bool = False

    def amplifier(self) -> physics.Amplifier:
        """The amplifier with every effect off (limits are the amplifier_limits effect)."""
        return physics.Amplifier(gain=self.amplifier_gain, input_ohm=self.amplifier_input_ohm)


@dataclass(frozen=True)
class MeasurementPoint:
    x_mm: float
    y_mm: float
    signal_level_percent: float = 80.0


@dataclass(frozen=True)
class EffectSpec:
    name: str
    parameters: dict[str, float]


@dataclass(frozen=True)
class Scene:
    path: Path
    plate: Plate
    actuators: Actuators
    mode: Mode
    states: dict[str, State]
    initial_state: str
    electronics: Electronics
    measurement_point: MeasurementPoint
    effects: tuple[EffectSpec, ...]
    seed: int
    provenance: dict[str, str]
    #: Why this scene reproduces a measurement rather than what physics predicts; None: it
    #: describes a plate within `PLAUSIBILITY`.
    replay_reason: str | None = None
    #: Faults of a served bench's transport (`serve-sim`); the in-process bench has none.
    transport_faults: tuple[TransportFault, ...] = ()

    def state(self, name: str) -> State:
        try:
            return self.states[name]
        except KeyError:
            raise SceneError(f"{self.path}: states: no state {name!r}; "
                             f"allowed: {', '.join(self.states)}") from None

    def plate_in(self, state: State) -> Plate:
        """The resonator as `state` has it (a cut state is shorter)."""
        return replace(self.plate, length_mm=state.plate_length_mm or self.plate.length_mm)

    def geometry(self, state: State) -> model.PlateGeometry:
        """The half-wavelength section of the paper's Fig. 4 for `state`."""
        return _geometry(self.plate, self.actuators.piezo, self.mode, state.n_powered_piezos,
                         len(state.powered_columns))


def _geometry(plate: Plate, piezo: Piezo, mode: Mode, n_powered: int, n_groups: int) -> model.PlateGeometry:
    return model.PlateGeometry(
        resonator_thickness_m=plate.thickness_mm * 1e-3, piezo_thickness_m=piezo.thickness_mm * 1e-3,
        piezo_length_m=piezo.length_mm * 1e-3, half_wavelength_m=mode.half_wavelength_mm * 1e-3,
        n_powered_piezos=n_powered, n_powered_groups=n_groups)
