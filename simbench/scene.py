"""Scene files: one plate on the simulated bench, its states, electronics and effects.

A scene is YAML (see `data/scenes/`). Top-level sections:

```
plate:        {name, material, length_mm, width_mm, thickness_mm}
actuators:    {piezo: {length_mm, width_mm, thickness_mm, material},
               piezos_per_column, columns: [{name, position_mm}, ...]}
mode:         {name, half_wavelength_mm}
states:       {<name>: {description, resonance_frequency_hz, q_mech, powered_columns,
               n_powered_piezos, calibration}}
initial_state: <a state name>
electronics:  {amplifier_gain, amplifier_max_output_vpp, amplifier_bandwidth_hz,
               amplifier_input_ohm, shunt_ohm, voltage_probe_attenuation,
               current_probe_a_per_a, generator_load, voltage_probe_coded}
measurement_point: {x_mm, y_mm, signal_level_percent}
effects:      [<name> | {<name>: {<parameter>: <number>}}, ...]
seed:         <int>
provenance:   {<dotted field, or a section>: <where the number comes from>}
```

Materials are named, never typed in: `plate.material` from `physics.RESONATOR_MATERIALS`,
`actuators.piezo.material` from `physics.PIEZO_MATERIALS` (datasheet constants with their
tolerances). C0 is the clamped capacitance of the powered piezos (eps33^T (1 - k31^2)).

A state may be predicted: `resonance_frequency_hz: predicted` (no calibration, a `q_mech`)
takes the resonance, modal mass and force factor at the measurement point from the plate
model (`simbench.predicted`, the finite-element plate with its piezos), near the free
plate's flexural frequency for `mode.half_wavelength_mm`; nothing measured is read.
Otherwise a state is physical by default: without `calibration`, its motional branch follows from
the plate, the piezos and the mode (modal mass, pin-force coupling of each powered patch,
`physics`) and its mechanical quality factor `q_mech`. With a `calibration`, the branch
reproduces a measurement at resonance, in one of three forms: `{voltage_vpp,
velocity_pp_mps, power_w}`, `{voltage_vpp, amplitude_pp_m, power_w}` or `{paper_model:
{q, tan_theta, convention}}`, the last computed with the paper's Eqs. 25 and 27
(`analysis.model`) under a named reading; `q_mech` may then be omitted and follows from
the plate's modal mass. A calibration is read as the scope reads it: amplifier-output Vpp
(CH1), CH1 x CH2 mean power and vibrometer velocity pp, so with the `shunt` or
`dielectric_loss` effect on, the state's motional branch is calibrated through them.

Whatever its origin, every state must describe a plate that can exist (`scene_bounds.BOUNDS`): a scene
whose calibration asks for more is refused at load, naming the bound and the values.
Beyond that, a scene must describe the plate physics predicts (`scene_bounds.PLAUSIBILITY`): q_mech in
its material's range and, for a calibrated state, the resonance, force factor and modal
mass of the plate model within their tolerances. A scene that reproduces a measurement the
model does not explain says so, `replay: {reason: ...}`; it is then loaded, and `validate`,
docs/scenes.md and the report show how far it departs and why.

The `Scene` it returns and its parts are `simbench.scene_model`.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import pandas as pd
import yaml

from squeezebench.analysis import model
from squeezebench.simbench import physics, transport_faults
from squeezebench.simbench.effects import EFFECTS
from squeezebench.simbench.scene_bounds import PLAUSIBILITY, StateFigures, scene_figures
from squeezebench.simbench.scene_mechanics import force_factor_n_per_v, modal_mass_kg
from squeezebench.simbench.scene_model import (PAPER_MODEL_REFERENCE_VPP, Actuators, Calibration, Column, EffectSpec,
                                               Electronics, MeasurementPoint, Mode, Piezo, Plate, Scene, SceneError,
                                               State, _geometry)
from squeezebench.lru import RecentlyUsed
from squeezebench.yamlfiles import load_strict, yaml_problem

#: A state's `resonance_frequency_hz` when the plate model gives it (and the branch).
PREDICTED = "predicted"
#: Readings of the paper's model a `paper_model` calibration may name.
CONVENTIONS = {c.name: c for c in (model.PAPER_CONVENTION, model.AS_PRINTED_CONVENTION,
                                   model.PHYSICAL_CONVENTION, model.INFERRED_CONVENTION)}
GENERATOR_LOADS = ("INF", "50")
#: Effects that were part of the bench the calibration values were measured on: when a
#: scene turns them on, its states are calibrated through them, so that the scope still
#: reads the published voltage, power and velocity (the shunt's and C0's losses are in
#: the published power). Other load effects (a neighbouring mode, heating) stay
#: departures from the published plate.
CALIBRATED_EFFECTS = ("shunt", "dielectric_loss")

def scenes_table(paths: list[Path]) -> pd.DataFrame:
    """One row per (scene, state) of `paths`: the figures of `StateFigures.as_row`."""
    return pd.DataFrame([f.as_row() for path in paths for f in scene_figures(load_scene(path))])


_MISSING = object()


class _Reader:
    """Typed access to the raw YAML with errors naming file, field and what is allowed."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def error(self, field: str, problem: str) -> SceneError:
        return SceneError(f"{self.path}: {field}: {problem}")

    def mapping(self, value: Any, field: str, required: tuple[str, ...],
                optional: tuple[str, ...] = ()) -> dict:
        if not isinstance(value, dict):
            raise self.error(field, f"must be a mapping with {', '.join(required + optional)}, "
                                    f"got {type(value).__name__}")
        unknown = [k for k in value if k not in required + optional]
        if unknown:
            raise self.error(f"{field}.{unknown[0]}", "unknown field; allowed: "
                             + ", ".join(required + optional))
        missing = [k for k in required if k not in value]
        if missing:
            raise self.error(f"{field}.{missing[0]}", "is missing")
        return value

    def number(self, data: dict, key: str, field: str, *, minimum: float = 0.0,
               strict: bool = True, default: Any = _MISSING) -> float:
        value = data.get(key, default)
        name = f"{field}.{key}" if field else key
        if value is _MISSING:
            raise self.error(name, "is missing")
        bound = f"> {minimum:g}" if strict else f">= {minimum:g}"
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                or (value <= minimum if strict else value < minimum):
            raise self.error(name, f"must be a number {bound}, got {value!r}")
        return float(value)

    def integer(self, data: dict, key: str, field: str, minimum: int = 1) -> int:
        value = data.get(key, _MISSING)
        if value is _MISSING:
            raise self.error(f"{field}.{key}", "is missing")
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise self.error(f"{field}.{key}", f"must be an integer >= {minimum}, got {value!r}")
        return value

    def text(self, data: dict, key: str, field: str, default: Any = _MISSING,
             allowed: tuple[str, ...] | None = None) -> str:
        value = data.get(key, default)
        if value is _MISSING:
            raise self.error(f"{field}.{key}", "is missing")
        value = str(value)
        if allowed is not None and value not in allowed:
            raise self.error(f"{field}.{key}", f"got {value!r}; allowed: {', '.join(allowed)}")
        return value


#: Scenes built in this process, by (file name, text): a study or a plan opens a bench per
#: trial (a study's task writes its scene into a folder of its own), and checking a scene
#: may solve its plate. A scene depends on its folder only through `path`, set on the copy
#: returned.
_BUILT: RecentlyUsed[Scene] = RecentlyUsed(32)


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file; calibrate every state's motional branch."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise SceneError(f"{path}: cannot read the scene file ({exc.strerror})") from exc
    # a refused scene raises, naming this path, and is not kept
    return replace(_BUILT.get((path.name, text), lambda: _scene(path, text)), path=path)


def _scene(path: Path, text: str) -> Scene:
    reader = _Reader(path)
    try:
        raw = load_strict(text)   # a key given twice is refused
    except yaml.YAMLError as exc:
        raise SceneError(f"{path}: {yaml_problem(exc)}") from None
    top = reader.mapping(raw, "scene", required=("plate", "actuators", "mode", "states", "initial_state"),
                         optional=("electronics", "measurement_point", "effects", "seed", "provenance",
                                   "description", "replay", "transport_faults"))
    plate = _plate(reader, top["plate"])
    actuators = _actuators(reader, top["actuators"])
    _refuse_misplaced_piezos(reader, plate, actuators)
    mode_data = reader.mapping(top["mode"], "mode", required=("name", "half_wavelength_mm"))
    mode = Mode(str(mode_data["name"]), reader.number(mode_data, "half_wavelength_mm", "mode"))
    states = _states(reader, top["states"], plate, actuators, mode)
    initial = reader.text(top, "initial_state", "", allowed=tuple(states))
    scene = Scene(
        path=path, plate=plate, actuators=actuators, mode=mode, states=states, initial_state=initial,
        electronics=_electronics(reader, top.get("electronics", {})),
        measurement_point=_measurement_point(reader, top.get("measurement_point", {"x_mm": 0, "y_mm": 0}), plate),
        effects=_effects(reader, top.get("effects", [])),
        seed=reader.integer(top, "seed", "", minimum=0) if "seed" in top else 0,
        provenance=_provenance(reader, top.get("provenance", {}), raw),
        replay_reason=_replay_reason(reader, top["replay"]) if "replay" in top else None,
        transport_faults=transport_faults.parse(top.get("transport_faults", []), reader.error),
    )
    scene = _calibrated_through_effects(reader, _predicted_states(reader, scene))
    figures = scene_figures(scene)
    for found in figures:
        broken = found.violations()
        if broken:
            raise reader.error(f"states.{found.state}", "describes a plate that cannot exist: "
                               + "; ".join(broken))
    if scene.replay_reason is None:
        _refuse_implausible(reader, scene, figures)
    return scene


def _refuse_misplaced_piezos(reader: _Reader, plate: Plate, actuators: Actuators) -> None:
    """Every piezo on the plate and none on another, where the plate model places them (a
    10 mm piezo on a 2 mm plate was simulated, its force factor from a patch off the metal)."""
    from squeezebench.simbench.predicted import layout   # it reads scenes

    problem = layout(plate, actuators).layout_problem("column")
    if problem:
        raise reader.error("actuators", problem)


def _replay_reason(reader: _Reader, data: Any) -> str:
    reason = reader.text(reader.mapping(data, "replay", required=("reason",)), "reason", "replay").strip()
    if not reason:
        raise reader.error("replay.reason", "must say why the scene reproduces a measurement rather than "
                                            "what the plate model predicts")
    return reason


def _refuse_implausible(reader: _Reader, scene: Scene, figures: list[StateFigures]) -> None:
    """Refuse a scene that is not a declared replay and breaks `PLAUSIBILITY`: its q_mech
    against the material's range, and each calibrated state against the plate model
    (a solve per plate, so only for calibrated states of scenes that do not declare a replay)."""
    for found in figures:
        state = scene.states[found.state]
        broken = found.implausibilities()
        if state.calibration is not None:
            from squeezebench.simbench.predicted import predict   # it reads scenes

            try:
                departures = predict(scene, state).departures()
            except ValueError as exc:
                raise reader.error(f"states.{state.name}", f"the plate model finds no working mode to compare "
                                                           f"the calibration with: {exc}") from None
            if departures:
                broken.append(f"{PLAUSIBILITY['plate_model']}: " + ", ".join(departures))
        if broken:
            raise reader.error(f"states.{state.name}", "describes a plate physics does not predict: "
                               + "; ".join(broken) + ". A scene that reproduces a measurement the model does "
                               "not explain says so: `replay: {reason: ...}`")


def flexural_frequency_hz(plate: Plate, mode: Mode) -> float:
    """The bare plate's frequency for bending waves of half-wavelength mode.half_wavelength_mm
    (`plate_modes.flexural_frequency_hz`): where a predicted state's mode is sought."""
    from squeezebench.plates import plate_modes   # its solver's imports: only for a predicted state

    m = plate.material
    return plate_modes.flexural_frequency_hz(plate_modes.Isotropic(m.young_pa, m.poisson, m.density_kg_m3),
                                             plate.thickness_mm * 1e-3, mode.half_wavelength_mm * 1e-3)


def _predicted_states(reader: _Reader, scene: Scene) -> Scene:
    """Each predicted state's branch from the plate model: the (n, 0) mode nearest the
    flexural estimate, its modal mass and the powered piezos' force factor referred to the
    measurement point, and the state's q_mech (the build's loss figure)."""
    if not any(state.predicted for state in scene.states.values()):
        return scene
    from squeezebench.simbench.predicted import predict   # it reads scenes: imported when one is predicted

    states = dict(scene.states)
    for name, state in scene.states.items():
        if not state.predicted:
            continue
        try:
            found = predict(scene, state)
        except ValueError as exc:
            raise reader.error(f"states.{name}", f"the plate model finds no working mode: {exc}") from None
        if found.n_piezos_left == 0 or found.force_factor_n_per_v == 0:
            raise reader.error(f"states.{name}", "the plate model finds no powered piezo driving the working mode")
        branch = physics.branch_from_physics(found.frequency_hz, state.q_mech, found.modal_mass_g * 1e-3,
                                             found.force_factor_n_per_v)
        states[name] = replace(state, resonance_frequency_hz=found.frequency_hz, branch=branch)
    return replace(scene, states=states)


def _calibrated_through_effects(reader: _Reader, scene: Scene) -> Scene:
    """`scene` with each state's branch calibrated through the CALIBRATED_EFFECTS it
    turns on (when none is on, `_states` calibrated the plate alone), and q_mech set from
    the modal mass where the scene leaves it out.

    The effects' own load stages give the shunt and the lossy C0, so the calibration
    uses the scene's parameter overrides exactly as the simulation does. They read the
    scene's electronics and actuators, never its states, so the scene can be built first.
    """
    stages = [EFFECTS[spec.name](scene, **spec.parameters).load
              for spec in scene.effects if spec.name in CALIBRATED_EFFECTS]
    states = {}
    for name, state in scene.states.items():
        if state.calibration is None or not stages:
            states[name] = _with_q_from_modal_mass(scene, state)
            continue
        surroundings = physics.PlateLoad(capacitance_f=state.capacitance_f, branches=())
        for stage in stages:
            surroundings = stage(surroundings)
        c = state.calibration
        try:
            branch = physics.calibrate_branch_as_measured(
                surroundings, state.resonance_frequency_hz, state.q_mech, c.voltage_vpp, c.velocity_pp_mps,
                c.power_w)
        except physics.CalibrationError as exc:
            on = ", ".join(s.name for s in scene.effects if s.name in CALIBRATED_EFFECTS)
            raise reader.error(f"states.{name}.calibration", f"cannot be reproduced with {on} on: {exc}") from exc
        states[name] = _with_q_from_modal_mass(scene, replace(state, branch=branch))
    return replace(scene, states=states)


def _with_q_from_modal_mass(scene: Scene, state: State) -> State:
    """A calibrated state without a stated q_mech: q_mech = w_r M / R_mech with M the
    plate's modal mass (the calibration fixes R_mech, the plate its mass)."""
    if state.q_mech_origin == "given":
        return state
    mass = modal_mass_kg(scene.plate_in(state), scene.actuators, scene.mode)
    q_mech = 2.0 * math.pi * state.resonance_frequency_hz * mass / state.branch.resistance_ns_per_m
    return replace(state, q_mech=q_mech, branch=replace(state.branch, q_mech=q_mech))


def _plate(reader: _Reader, data: Any) -> Plate:
    data = reader.mapping(data, "plate", required=("name", "material", "length_mm", "width_mm",
                                                   "thickness_mm"))
    material = physics.RESONATOR_MATERIALS[reader.text(data, "material", "plate",
                                                       allowed=tuple(physics.RESONATOR_MATERIALS))]
    return Plate(str(data["name"]), material,
                 *(reader.number(data, k, "plate") for k in ("length_mm", "width_mm", "thickness_mm")))


def _actuators(reader: _Reader, data: Any) -> Actuators:
    data = reader.mapping(data, "actuators", required=("piezo", "piezos_per_column", "columns"))
    piezo_data = reader.mapping(data["piezo"], "actuators.piezo",
                                required=("length_mm", "width_mm", "thickness_mm", "material"))
    piezo = Piezo(*(reader.number(piezo_data, k, "actuators.piezo")
                    for k in ("length_mm", "width_mm", "thickness_mm")),
                  material=physics.PIEZO_MATERIALS[reader.text(piezo_data, "material", "actuators.piezo",
                                                               allowed=tuple(physics.PIEZO_MATERIALS))])
    columns_data = data["columns"]
    if not isinstance(columns_data, list) or not columns_data:
        raise reader.error("actuators.columns", "must be a non-empty list of {name, position_mm}")
    columns = []
    for i, column in enumerate(columns_data):
        field = f"actuators.columns[{i}]"
        column = reader.mapping(column, field, required=("name", "position_mm"))
        columns.append(Column(str(column["name"]),
                              reader.number(column, "position_mm", field, strict=False)))
    names = [c.name for c in columns]
    if len(set(names)) != len(names):
        raise reader.error("actuators.columns", f"column names must be unique, got {names}")
    return Actuators(piezo, reader.integer(data, "piezos_per_column", "actuators"), tuple(columns))


def _states(reader: _Reader, data: Any, plate: Plate, actuators: Actuators, mode: Mode) -> dict[str, State]:
    if not isinstance(data, dict) or not data:
        raise reader.error("states", "must be a non-empty mapping of state name to state")
    column_names = tuple(c.name for c in actuators.columns)
    states = {}
    for name, state in data.items():
        name, field = str(name), f"states.{name}"
        state = reader.mapping(state, field, required=("resonance_frequency_hz", "powered_columns"),
                               optional=("description", "q_mech", "n_powered_piezos", "calibration",
                                         "plate_length_mm"))
        powered = state["powered_columns"]
        if not isinstance(powered, list) or not powered:
            raise reader.error(f"{field}.powered_columns",
                               f"must be a non-empty list; allowed: {', '.join(column_names)}")
        for column in powered:
            if str(column) not in column_names:
                raise reader.error(f"{field}.powered_columns",
                                   f"got {column!r}; allowed: {', '.join(column_names)}")
        n_powered = len(powered) * actuators.piezos_per_column
        if "n_powered_piezos" in state and reader.integer(state, "n_powered_piezos", field) != n_powered:
            raise reader.error(f"{field}.n_powered_piezos",
                               f"got {state['n_powered_piezos']}; allowed: {n_powered} ({len(powered)} powered "
                               f"columns x {actuators.piezos_per_column} piezos; it may be left out)")
        if "calibration" not in state and "q_mech" not in state:
            raise reader.error(f"{field}.q_mech", "is missing (a state without a calibration needs its "
                                                  "mechanical quality factor)")
        predicted = state["resonance_frequency_hz"] == PREDICTED
        if predicted and "calibration" in state:
            raise reader.error(f"{field}.resonance_frequency_hz", "is 'predicted', but the state has a calibration: "
                                                                  "a state is predicted or calibrated, not both")
        # a predicted state's resonance comes from the plate model once the scene is built
        # (_predicted_states); until then, the free plate's flexural estimate for mode.half_wavelength_mm
        frequency_hz = (flexural_frequency_hz(plate, mode) if predicted
                        else reader.number(state, "resonance_frequency_hz", field))
        length_mm = reader.number(state, "plate_length_mm", field) if "plate_length_mm" in state else None
        if length_mm is not None and length_mm > plate.length_mm:
            raise reader.error(f"{field}.plate_length_mm", f"got {length_mm:g}; allowed: up to plate.length_mm "
                                                           f"({plate.length_mm:g}): a state can only cut the plate")
        powered_names = tuple(str(c) for c in powered)
        geometry = _geometry(plate, actuators.piezo, mode, n_powered, len(powered))
        capacitance_f = physics.piezo_capacitance_f(
            n_powered, actuators.piezo.area_m2, actuators.piezo.thickness_mm * 1e-3,
            physics.clamped_relative_permittivity(actuators.piezo.material))
        if "calibration" in state:
            calibration = _calibration(reader, state["calibration"], f"{field}.calibration", frequency_hz,
                                       geometry)
            given = "q_mech" in state
            # without a stated q_mech, any positive value calibrates R and psi; the plate's
            # modal mass sets it once the effects are known (_with_q_from_modal_mass)
            q_mech = reader.number(state, "q_mech", field) if given else 1.0
            branch = physics.calibrate_branch(frequency_hz, q_mech, calibration.voltage_vpp,
                                              calibration.velocity_pp_mps, calibration.power_w)
        else:
            calibration, given = None, True
            q_mech = reader.number(state, "q_mech", field)
            branch = physics.branch_from_physics(
                frequency_hz, q_mech, modal_mass_kg(replace(plate, length_mm=length_mm or plate.length_mm),
                                                    actuators, mode),
                force_factor_n_per_v(plate, actuators, mode, powered_names))
        states[name] = State(
            name=name, description=str(state.get("description", "")), resonance_frequency_hz=frequency_hz,
            q_mech=q_mech, powered_columns=powered_names, n_powered_piezos=n_powered,
            calibration=calibration, capacitance_f=capacitance_f, branch=branch,
            q_mech_origin="given" if given else "modal mass", plate_length_mm=length_mm,
            predicted=predicted)
    return states


_CALIBRATION_FORMS = ("{voltage_vpp, velocity_pp_mps, power_w}", "{voltage_vpp, amplitude_pp_m, power_w}",
                      "{paper_model: {q, tan_theta, convention}}")


def _calibration(reader: _Reader, data: Any, field: str, frequency_hz: float,
                 geometry: model.PlateGeometry) -> Calibration:
    if not isinstance(data, dict):
        raise reader.error(field, "must be one of " + " or ".join(_CALIBRATION_FORMS))
    if "paper_model" in data:
        reader.mapping(data, field, required=("paper_model",))
        sub = f"{field}.paper_model"
        pm = reader.mapping(data["paper_model"], sub, required=("q", "tan_theta", "convention"))
        convention = CONVENTIONS[reader.text(pm, "convention", sub, allowed=tuple(CONVENTIONS))]
        voltage_vpp = PAPER_MODEL_REFERENCE_VPP
        q = reader.number(pm, "q", sub)
        tan_theta = pm["tan_theta"]
        if isinstance(tan_theta, bool) or not isinstance(tan_theta, (int, float)) or not math.isfinite(tan_theta):
            raise reader.error(f"{sub}.tan_theta", f"must be a number, got {tan_theta!r}")
        try:
            amplitude = model.amplitude_pp_m(q, voltage_vpp, geometry, convention)
            power = model.power_w(q, float(tan_theta), voltage_vpp, frequency_hz, geometry, convention)
        except model.ModelGeometryError as exc:
            raise reader.error(sub, f"the paper's model has no value for this geometry ({exc})") from exc
        if not (amplitude > 0 and power > 0):
            raise reader.error(sub, f"gives amplitude {amplitude:.3g} m and power {power:.3g} W under "
                                    f"convention {convention.name!r}; both must be positive "
                                    "(check the sign of tan_theta for this convention)")
        return Calibration(voltage_vpp, physics.velocity_pp_from_amplitude_pp(amplitude, frequency_hz),
                           power, "paper_model", reading=convention.name)
    if "amplitude_pp_m" in data:
        reader.mapping(data, field, required=("voltage_vpp", "amplitude_pp_m", "power_w"))
        velocity = physics.velocity_pp_from_amplitude_pp(reader.number(data, "amplitude_pp_m", field),
                                                         frequency_hz)
        form = "amplitude"
    elif "velocity_pp_mps" in data:
        reader.mapping(data, field, required=("voltage_vpp", "velocity_pp_mps", "power_w"))
        velocity = reader.number(data, "velocity_pp_mps", field)
        form = "velocity"
    else:
        raise reader.error(field, "must be one of " + " or ".join(_CALIBRATION_FORMS))
    return Calibration(reader.number(data, "voltage_vpp", field), velocity,
                       reader.number(data, "power_w", field), form)


def _electronics(reader: _Reader, data: Any) -> Electronics:
    defaults = Electronics()
    numbers = ("amplifier_gain", "amplifier_max_output_vpp", "amplifier_bandwidth_hz", "amplifier_input_ohm",
               "shunt_ohm", "voltage_probe_attenuation", "current_probe_a_per_a")
    data = reader.mapping(data, "electronics", required=(),
                          optional=numbers + ("generator_load", "voltage_probe_coded"))
    values = {k: reader.number(data, k, "electronics", default=getattr(defaults, k), strict=k != "shunt_ohm")
              for k in numbers}
    load = reader.text(data, "generator_load", "electronics", default=defaults.generator_load,
                       allowed=GENERATOR_LOADS)
    coded = data.get("voltage_probe_coded", defaults.voltage_probe_coded)
    if not isinstance(coded, bool):
        raise reader.error("electronics.voltage_probe_coded", f"must be true or false, got {coded!r}")
    return Electronics(**values, generator_load=load, voltage_probe_coded=coded)


def _measurement_point(reader: _Reader, data: Any, plate: Plate) -> MeasurementPoint:
    data = reader.mapping(data, "measurement_point", required=("x_mm", "y_mm"),
                          optional=("signal_level_percent", "description"))
    level = reader.number(data, "signal_level_percent", "measurement_point", default=80.0, strict=False)
    if level > 100:
        raise reader.error("measurement_point.signal_level_percent", f"must be 0..100, got {level!r}")
    point = MeasurementPoint(reader.number(data, "x_mm", "measurement_point", strict=False),
                             reader.number(data, "y_mm", "measurement_point", strict=False), level)
    # the beam must land on the metal (a point 20 m off a 41 mm plate was a plate-model traceback)
    for axis, value, size in (("x_mm", point.x_mm, plate.length_mm), ("y_mm", point.y_mm, plate.width_mm)):
        if value > size:
            raise reader.error(f"measurement_point.{axis}", f"{value:g} mm is off the plate: at most "
                                                           f"{'plate.length_mm' if axis == 'x_mm' else 'plate.width_mm'}"
                                                           f" ({size:g} mm)")
    return point


def _effects(reader: _Reader, data: Any) -> tuple[EffectSpec, ...]:
    allowed = ", ".join(EFFECTS)
    if not isinstance(data, list):
        raise reader.error("effects", f"must be a list of effect names or {{name: {{parameters}}}}; "
                                      f"allowed names: {allowed}")
    specs = []
    for i, entry in enumerate(data):
        field = f"effects[{i}]"
        if isinstance(entry, dict) and len(entry) == 1:
            name, parameters = next(iter(entry.items()))
            parameters = {} if parameters is None else parameters
        elif isinstance(entry, str):
            name, parameters = entry, {}
        else:
            raise reader.error(field, f"must be a name or {{name: {{parameters}}}}; allowed names: {allowed}")
        if name not in EFFECTS:
            raise reader.error(field, f"unknown effect {name!r}; allowed: {allowed}")
        defaults = EFFECTS[name].defaults
        if not isinstance(parameters, dict):
            raise reader.error(f"{field}.{name}", "parameters must be a mapping")
        for key, value in parameters.items():
            if key not in defaults:
                raise reader.error(f"{field}.{name}.{key}", "unknown parameter; allowed: "
                                   + (", ".join(defaults) or "none (this effect has no parameters)"))
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise reader.error(f"{field}.{name}.{key}", f"must be a number, got {value!r}")
            low, high = EFFECTS[name].limits.get(key, (-math.inf, math.inf))
            if not low <= value <= high:
                raise reader.error(f"{field}.{name}.{key}", f"must be in {low:g}..{high:g}, got {value!r}")
        if name in (s.name for s in specs):
            raise reader.error(field, f"effect {name!r} is listed twice")
        specs.append(EffectSpec(name, {k: float(v) for k, v in parameters.items()}))
    return tuple(specs)


def _provenance(reader: _Reader, data: Any, raw: dict) -> dict[str, str]:
    """Where each number comes from; a key is a dotted field path or a whole section."""
    if not isinstance(data, dict):
        raise reader.error("provenance", "must be a mapping of field path to text")
    known = set(field_paths(raw))
    for key in data:
        if str(key) not in known:
            raise reader.error(f"provenance.{key}", "names no field of this scene; use a dotted path "
                                                    "such as 'states.<name>.q_mech' or a section name")
    return {str(k): str(v) for k, v in data.items()}


def field_paths(value: Any, prefix: str = "") -> list[str]:
    """Every dotted path in a raw scene (sections and leaves; list items as name[i])."""
    paths = [prefix] if prefix else []
    if isinstance(value, dict):
        for key, item in value.items():
            if prefix == "" and key == "provenance":
                continue
            paths += field_paths(item, f"{prefix}.{key}" if prefix else str(key))
    elif isinstance(value, list):
        for i, item in enumerate(value):
            paths += field_paths(item, f"{prefix}[{i}]")
    return paths


def numeric_field_paths(raw: dict) -> list[str]:
    """Paths of every number in a raw scene: each needs a provenance entry."""
    def numbers(value: Any, prefix: str) -> list[str]:
        if isinstance(value, dict):
            return [p for k, v in value.items() if not (prefix == "" and k in ("provenance", "seed"))
                    for p in numbers(v, f"{prefix}.{k}" if prefix else str(k))]
        if isinstance(value, list):
            return [p for i, v in enumerate(value) for p in numbers(v, f"{prefix}[{i}]")]
        return [prefix] if isinstance(value, (int, float)) and not isinstance(value, bool) else []
    return numbers(raw, "")


def covered_by_provenance(path: str, provenance: dict[str, str]) -> bool:
    """A number is covered by its own entry or by one for an enclosing section."""
    while path:
        if path in provenance:
            return True
        cut = max(path.rfind("."), path.rfind("["))
        path = path[:cut] if cut > 0 else ""
    return False
