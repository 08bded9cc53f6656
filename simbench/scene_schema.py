"""The scene file as a pydantic model: its JSON Schema (for editors) and its reference page.

`simbench.scene.load_scene` reads and checks scenes (its messages name file, field and the
allowed values, and it refuses plates that cannot exist); this model describes the same
file for tools: `docs/scene.schema.json` is its JSON Schema, `docs/scene-format.md` lists
every field with its unit, default and allowed values, and `docs/scenes.md` tabulates the
shipped scenes' electromechanical figures. The test suite checks that every shipped scene
validates here and that the three pages are current; rewrite them with

    python -m squeezebench.simbench.scene_schema docs/
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated, Any, Literal, Union

from pydantic import BaseModel, ConfigDict, Field

from squeezebench.simbench import physics
from squeezebench.simbench.effects import EFFECTS
from squeezebench.simbench.transport_faults import FAULTS, ROLES
from squeezebench.simbench.scene import CONVENTIONS, GENERATOR_LOADS, load_scene, scenes_table
from squeezebench.simbench.scene_bounds import BOUNDS, PLAUSIBILITY
from squeezebench.simbench.scene_model import PAPER_MODEL_REFERENCE_VPP, Electronics
from squeezebench.simbench.predicted import (FORCE_FACTOR_TOLERANCE, FREQUENCY_TOLERANCE, MODAL_MASS_TOLERANCE,
                                             predictions_table)

PiezoMaterialName = Literal[tuple(physics.PIEZO_MATERIALS)]  # type: ignore[valid-type]
ResonatorMaterialName = Literal[tuple(physics.RESONATOR_MATERIALS)]  # type: ignore[valid-type]
ReadingName = Literal[tuple(CONVENTIONS)]  # type: ignore[valid-type]
EffectName = Literal[tuple(EFFECTS)]  # type: ignore[valid-type]
_DEFAULT_ELECTRONICS = Electronics()


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class PlateModel(_Strict):
    """The resonator: a free rectangular plate."""

    name: str = Field(description="the plate's name (the campaign's plate name may differ)")
    material: ResonatorMaterialName = Field(description="resonator material; its constants are the "
                                                        "datasheet's (simbench.physics.RESONATOR_MATERIALS)")
    length_mm: float = Field(gt=0, description="along the mode's wave (the (n,0) mode's x)")
    width_mm: float = Field(gt=0, description="along the nodal lines")
    thickness_mm: float = Field(gt=0, description="h_i of the paper's Fig. 4")


class PiezoModel(_Strict):
    """One piezo patch; every patch of the plate is alike."""

    length_mm: float = Field(gt=0, description="b_p: the side along the nodal lines")
    width_mm: float = Field(gt=0, description="the side along the plate's length")
    thickness_mm: float = Field(gt=0, description="h_p; poled and electroded through the thickness")
    material: PiezoMaterialName = Field(description="piezoceramic; eps33^T, d31, k31, s11^E, tan delta, "
                                                    "Qm and density come from its datasheet")


class ColumnModel(_Strict):
    name: str = Field(description="how states name it in powered_columns")
    position_mm: float = Field(ge=0, description="centre of the column along the plate length, from one end")


class ActuatorsModel(_Strict):
    piezo: PiezoModel
    piezos_per_column: int = Field(ge=1, description="patches side by side along the nodal lines")
    columns: list[ColumnModel] = Field(min_length=1, description="names unique")


class ModeModel(_Strict):
    name: str = Field(description="e.g. '(9,0)'")
    half_wavelength_mm: float = Field(gt=0, description="lambda/2 of the working mode")


class MeasuredCalibration(_Strict):
    """A measurement at resonance the state reproduces (as the scope reads it)."""

    voltage_vpp: float = Field(gt=0, description="amplifier output, peak-to-peak")
    power_w: float = Field(gt=0, description="mean of CH1 x CH2 (includes the shunt when it is on)")
    velocity_pp_mps: float | None = Field(default=None, gt=0, description="vibrometer velocity, peak-to-peak; "
                                                                          "exactly one of this and amplitude_pp_m")
    amplitude_pp_m: float | None = Field(default=None, gt=0, description="displacement, peak-to-peak")


class PaperModelParameters(_Strict):
    q: float = Field(gt=0, description="the paper's dynamic amplification factor Q (Eq. 27)")
    tan_theta: float = Field(description="the paper's loss tangent tan theta' (Eq. 25); negative where "
                                         "a < 0 (printed E_i)")
    convention: ReadingName = Field(description="the reading of Eqs. 25/27 (analysis.model; 'inferred' is "
                                                "the one analysis.readings finds consistent)")


class PaperModelCalibration(_Strict):
    """The measurement Eqs. 25 and 27 give for Q and tan theta' (evaluated at
    PAPER_MODEL_REFERENCE_VPP; the model is linear, so any voltage gives the same plate)."""

    paper_model: PaperModelParameters


class StateModel(_Strict):
    """One condition of the plate (a cut, a set of powered columns)."""

    description: str = ""
    resonance_frequency_hz: Union[Annotated[float, Field(gt=0)], Literal["predicted"]] = Field(
        description="Hz; or 'predicted': the plate model's working mode (no calibration, q_mech required)")
    q_mech: float | None = Field(default=None, gt=0, description="mechanical quality factor (sharpness of "
                                 "the resonance); required without calibration; with one, left out: "
                                 "w_r M / R_mech from the plate's modal mass")
    powered_columns: list[str] = Field(min_length=1, description="names from actuators.columns")
    plate_length_mm: float | None = Field(default=None, gt=0, description="the plate's length in this state "
                                          "(a cut, Table 3); default plate.length_mm; sets the modal mass")
    n_powered_piezos: int | None = Field(default=None, ge=1, description="optional; if given it must equal "
                                         "len(powered_columns) x piezos_per_column")
    calibration: Union[MeasuredCalibration, PaperModelCalibration, None] = Field(
        default=None, description="left out: the branch follows from the physics (datasheet, modal mass, q_mech)")


class ElectronicsModel(_Strict):
    amplifier_gain: float = Field(default=_DEFAULT_ELECTRONICS.amplifier_gain, gt=0)
    amplifier_max_output_vpp: float = Field(default=_DEFAULT_ELECTRONICS.amplifier_max_output_vpp, gt=0,
                                            description="used by the amplifier_limits effect")
    amplifier_bandwidth_hz: float = Field(default=_DEFAULT_ELECTRONICS.amplifier_bandwidth_hz, gt=0)
    amplifier_input_ohm: float = Field(default=_DEFAULT_ELECTRONICS.amplifier_input_ohm, gt=0)
    shunt_ohm: float = Field(default=_DEFAULT_ELECTRONICS.shunt_ohm, ge=0,
                             description="series shunt; the shunt share bound uses it whatever the effects")
    voltage_probe_attenuation: float = Field(default=_DEFAULT_ELECTRONICS.voltage_probe_attenuation, gt=0)
    current_probe_a_per_a: float = Field(default=_DEFAULT_ELECTRONICS.current_probe_a_per_a, gt=0)
    generator_load: Literal[GENERATOR_LOADS] = Field(default=_DEFAULT_ELECTRONICS.generator_load)  # type: ignore[valid-type]
    voltage_probe_coded: bool = Field(default=_DEFAULT_ELECTRONICS.voltage_probe_coded,
                                      description="the CH1 probe is coded (TekProbe level I): the scope fixes its gain")


class MeasurementPointModel(_Strict):
    x_mm: float = Field(ge=0)
    y_mm: float = Field(ge=0)
    signal_level_percent: float = Field(default=80.0, ge=0, le=100)
    description: str = ""


EffectEntry = Union[EffectName, dict[EffectName, Union[dict[str, float], None]]]


class ReplayModel(_Strict):
    """The scene reproduces a measurement rather than what the plate model predicts."""

    reason: str = Field(min_length=1, description="why: e.g. calibrated on a published point the model "
                                                  "does not explain; shown by validate, docs/scenes.md, the report")


class TransportFaultModel(_Strict):
    """A fault of a served bench's transport: on one instrument's `occurrence`-th reply to a
    message containing `query`, once per serve-sim (`chunked_reply`: on every reply)."""

    fault: Literal[tuple(FAULTS)]  # type: ignore[valid-type]
    instrument: Literal[ROLES]  # type: ignore[valid-type]
    query: str = Field(default="", description="text the message must contain (any message when empty)")
    occurrence: int = Field(default=1, ge=1)
    max_chunk_bytes: float | None = Field(default=None, gt=0, description="chunked_reply: largest piece (7)")
    max_pause_s: float | None = Field(default=None, gt=0, description="chunked_reply: longest pause (0.002)")
    seed: float | None = Field(default=None, ge=0, description="chunked_reply: the pieces' random seed (0)")
    bytes_per_s: float | None = Field(default=None, gt=0, description="slow_trickle: the reply's rate (50)")


class SceneFile(_Strict):
    """A scene: one plate on the simulated bench, its states, electronics and effects."""

    description: str = ""
    plate: PlateModel
    actuators: ActuatorsModel
    mode: ModeModel
    states: dict[str, StateModel] = Field(min_length=1)
    initial_state: str = Field(description="one of the states")
    electronics: ElectronicsModel = ElectronicsModel()
    measurement_point: MeasurementPointModel = MeasurementPointModel(x_mm=0, y_mm=0)
    effects: list[EffectEntry] = Field(default_factory=list, description="effect names, or {name: {parameter: "
                                       "number}}; see simbench.effects")
    seed: int = Field(default=0, ge=0)
    replay: ReplayModel | None = Field(default=None, description="declared when the scene's calibration departs "
                                       "from the plate model beyond its tolerances, or q_mech from the material's "
                                       "range; otherwise such a scene is refused")
    provenance: dict[str, str] = Field(default_factory=dict, description="dotted field path (or section) -> "
                                       "where the number comes from")
    transport_faults: list[TransportFaultModel] = Field(
        default_factory=list, description="faults of the transport when the scene is served (`serve-sim`); "
                                          "see simbench.transport_faults")


def json_schema() -> dict[str, Any]:
    return SceneFile.model_json_schema()


# --- the reference pages --------------------------------------------------------------------

def _unit(name: str) -> str:
    for suffix, unit in (("_mm", "mm"), ("_hz", "Hz"), ("_vpp", "V peak-to-peak"), ("_w", "W"),
                         ("_pp_mps", "m/s peak-to-peak"), ("_pp_m", "m peak-to-peak"), ("_ohm", "ohm"),
                         ("_percent", "%"), ("_a_per_a", "A/A")):
        if name.endswith(suffix):
            return unit
    return ""


def _inner_models(annotation) -> list[type[BaseModel]]:
    """Models inside list[...] / dict[str, ...] annotations."""
    args = getattr(annotation, "__args__", ())
    return [a for a in args[-1:] if isinstance(a, type) and issubclass(a, BaseModel)]


def _rows(model: type[BaseModel], prefix: str) -> list[tuple[str, str, str, str, str]]:
    rows = []
    for name, field in model.model_fields.items():
        path = f"{prefix}.{name}" if prefix else name
        annotation = field.annotation
        nested = [a for a in getattr(annotation, "__args__", (annotation,))
                  if isinstance(a, type) and issubclass(a, BaseModel)]
        default = "required" if field.is_required() else (
            "see below" if nested else repr(field.get_default(call_default_factory=True)))
        allowed = ""
        args = getattr(annotation, "__args__", ())
        if getattr(annotation, "__origin__", None) is Literal:
            allowed = ", ".join(map(str, args))
        bounds = ", ".join(f"{k} {v}" for m in field.metadata for k, v in (
            ("> ", getattr(m, "gt", None)), (">= ", getattr(m, "ge", None)), ("<= ", getattr(m, "le", None)))
            if v is not None) if field.metadata else ""
        rows.append((path, _unit(name), default,
                     allowed or bounds.replace("> ", ">").replace(">= ", ">=").replace("<= ", "<="),
                     field.description or ""))
        child = {"states": "states.<name>", "columns": "actuators.columns[i]"}.get(name, path)
        for sub in nested + [a for a in _inner_models(annotation) if a not in nested]:
            rows += _rows(sub, child)
    return rows


def format_markdown() -> str:
    lines = ["# Scene file format", "",
             "Generated from `simbench/scene_schema.py` (`python -m squeezebench.simbench.scene_schema docs/`); "
             "the JSON Schema for editors is `scene.schema.json` beside this page. A scene is YAML; "
             "`squeezebench.simbench.scene.load_scene` reads it. Units are in the field names "
             "(pp = peak-to-peak).", "",
             "| field | unit | default | allowed | meaning |", "|---|---|---|---|---|"]
    lines += [f"| `{p}` | {u} | {d} | {a} | {m} |" for p, u, d, a, m in _rows(SceneFile, "")]
    lines += ["", "`states.<name>` stands for each state; a calibration is either the measured form "
              "(`voltage_vpp`, `power_w` and one of `velocity_pp_mps`, `amplitude_pp_m`) or "
              f"`{{paper_model: {{q, tan_theta, convention}}}}` (evaluated at {PAPER_MODEL_REFERENCE_VPP:g} Vpp).",
              "", "## Materials", "", "| material | constants | source |", "|---|---|---|"]
    for m in physics.PIEZO_MATERIALS.values():
        tolerances = ", ".join(f"{k} +-{v:.0%}" for k, v in m.tolerances.items())
        lines.append(f"| {m.name} (piezo) | eps33^T/eps0 {m.relative_permittivity_free:g}, d31 "
                     f"{m.d31_c_per_n * 1e12:g} pC/N, k31 {m.k31:g}, s11^E {m.s11e_m2_per_n * 1e12:g}e-12 m2/N, "
                     f"tan delta {m.tan_delta:g} ({m.tan_delta_high_field:g} at {m.high_field_v_per_m / 1e3:g} V/mm), "
                     f"Qm {m.mechanical_q:g}, density {m.density_kg_m3:g} kg/m3; tolerances: {tolerances} "
                     f"| {m.source} |")
    for m in physics.RESONATOR_MATERIALS.values():
        lines.append(f"| {m.name} (resonator) | E {m.young_pa / 1e9:g} GPa, nu {m.poisson:g}, density "
                     f"{m.density_kg_m3:g} kg/m3 | {m.source} |")
    lines += ["", "## How a state's motional branch is built", "",
              "- C0 = n eps33^T (1 - k31^2) eps0 A / h_p over the powered piezos (clamped by the plate).",
              "- Mode shape phi(x) = cos(pi x / (lambda/2)), unit at the free ends; modal mass M = half the "
              "plate's mass (of the state's `plate_length_mm` if cut) plus each bonded patch's mass times the "
              "mean of phi^2 over it.",
              "- Force factor n_c psi = sum over powered patches of |e31| b_p z_m |phi'(x_end) - phi'(x_start)|, "
              "e31 = d31 / s11^E, z_m the patch's mid-plane distance from the composite neutral axis "
              "(pin-force model; each column wired in phase with the mode).",
              "- Without calibration: R_mech = w_r M / q_mech. With one: R_mech and n_c psi reproduce it at "
              "resonance (through the shunt and dielectric loss when those effects are on) and, without "
              "q_mech, q_mech = w_r M / R_mech.",
              "- `simbench.physics.motional_elements` gives the branch's R/L/C seen from the terminals; "
              "`simbench.scene.scenes_table` the figures of `docs/scenes.md`.",
              "", "Example of a plate written only from physical parameters: `data/examples/own_plate.yaml` "
              "(with `data/examples/own_plate_campaign.yaml`).",
              "", "## A plate that can exist", "",
              "A scene is refused at load if a piezo overhangs the plate or lies on another, in its column or "
              "another, where the plate model places them (a column's piezos side by side centred on the width; "
              "columns at one position at the width's two ends), or if `measurement_point` is off the plate.",
              "", "Every state is refused at load if it breaks one of:", ""]
    lines += [f"- {text}" for text in BOUNDS.values()]
    lines += ["", "## Effects", "", "| effect | parameters (defaults) |", "|---|---|"]
    lines += [f"| `{name}` | {', '.join(f'{k} = {v:g}' for k, v in effect.defaults.items()) or 'none'} |"
              for name, effect in EFFECTS.items()]
    return "\n".join(lines) + "\n"


def scenes_markdown(scene_paths: list[Path]) -> str:
    """docs/scenes.md: every shipped scene and state, its figures at resonance."""
    table = scenes_table(scene_paths)
    columns = {"scene": "scene", "state": "state", "origin": "origin", "c0_nf": "C0 (nF, clamped)",
               "effective_coupling": "k_eff", "power_factor": "power factor",
               "modal_mass_ratio": "modal mass / plate mass", "shunt_share": "shunt share",
               "shunt_share_detuned": "shunt share at 50 % detuning",
               "loss_w_per_um2": "loss (W per um pp^2)", "force_factor_vs_datasheet": "n_c psi / datasheet",
               "q_mech": "q_mech"}
    lines = ["# The shipped scenes at resonance", "",
             "Generated by `python -m squeezebench.simbench.scene_schema docs/` from "
             "`simbench.scene.scenes_table` (the report calls it too). C0 from eps33^T (1 - k31^2); "
             "k_eff = sqrt(C_m / (C0 + C_m)); power factor and shunt share on the scene's bench (its "
             "shunt in series) at the calibration voltage (20 Vpp without one), and at the Fig. 2 50 % detuning with the voltage doubled to regain the velocity (not bounded: the paper's plates were not all measured there); modal mass = q_mech R_mech / "
             "w_r against the plate with its piezos; loss = plate power / (amplitude pp in um)^2; "
             "n_c psi / datasheet = the calibrated force factor over the pin-force value from the "
             "datasheet. Bounds: " + "; ".join(BOUNDS.values()) + ".", "",
             "| " + " | ".join(columns.values()) + " |", "|" + "---|" * len(columns)]
    for row in table.to_dict("records"):
        lines.append("| " + " | ".join(f"{row[c]:.3g}" if isinstance(row[c], float) else str(row[c])
                                       for c in columns) + " |")
    return "\n".join(lines + _predicted_beside_replay(scene_paths)) + "\n"


def _predicted_beside_replay(scene_paths: list[Path]) -> list[str]:
    """The plate model's prediction for every state beside what the scene replays."""
    table = predictions_table([load_scene(p) for p in scene_paths])
    columns = {"scene": "scene", "state": "state", "predicted_frequency_hz": "predicted f (Hz)",
               "replay_frequency_hz": "replay f (Hz)", "frequency_departure": "replay / predicted - 1",
               "interior_antinodes": "antinodes (predicted)", "half_wavelength_mm": "lambda/2 (mm, predicted)",
               "k_eff": "k_eff (predicted)", "predicted_force_factor_n_per_v": "force factor (N/V, predicted)",
               "replay_force_factor_n_per_v": "force factor (N/V, replay)",
               "predicted_modal_mass_g": "modal mass (g, predicted)", "replay_modal_mass_g": "modal mass (g, replay)",
               "departures": "replay departs"}
    lines = ["", "## Predicted beside replay", "",
             "Predicted: `simbench.predicted` puts each state's geometry and materials (never its "
             "resonance, calibration or q_mech) through the plate model `plates.plate_modes` "
             "(free plate on Argyris elements with Mindlin's thick-plate correction, piezos as laminate "
             "patches on an epoxy bond); the working "
             "(n, 0) mode is searched near the replayed resonance. Force factor (powered piezos, "
             "plate constant d31/(s11(1-nu))) and modal mass are referred to the scene's "
             "measurement point. Replay: the scene's calibrated branch. Flagged when the "
             f"resonance departs by more than {FREQUENCY_TOLERANCE:.0%} or the force factor by "
             f"more than {FORCE_FACTOR_TOLERANCE:.0%}, the modal mass by more than {MODAL_MASS_TOLERANCE:.0%}, "
             "or when a cut removes every piezo. A scene that is not a declared replay is refused at load where "
             "it breaks these: " + "; ".join(PLAUSIBILITY.values()) + ".", "",
             "| " + " | ".join(columns.values()) + " |", "|" + "---|" * len(columns)]
    def cell(column: str, value: Any) -> str:
        if not isinstance(value, float):
            return str(value)
        if column == "frequency_departure":
            return f"{value:+.1%}"
        return f"{value:.0f}" if column.endswith("frequency_hz") else f"{value:.3g}"

    for row in table.to_dict("records"):
        lines.append("| " + " | ".join(cell(c, row[c]) for c in columns) + " |")
    lines += ["", "Why each scene is a replay (its `replay.reason`):", ""]
    lines += [f"- `{scene.path.stem}`: {scene.replay_reason or 'not a replay: within the bounds above'}"
              for scene in map(load_scene, scene_paths)]
    return lines


def write_docs(docs_dir: Path, scene_paths: list[Path]) -> list[Path]:
    docs_dir.mkdir(parents=True, exist_ok=True)
    pages = {"scene.schema.json": json.dumps(json_schema(), indent=2) + "\n",
             "scene-format.md": format_markdown(), "scenes.md": scenes_markdown(scene_paths)}
    for name, text in pages.items():
        (docs_dir / name).write_text(text, encoding="utf-8")
    return [docs_dir / name for name in pages]


if __name__ == "__main__":
    from squeezebench import paths

    for written in write_docs(Path(sys.argv[1] if len(sys.argv) > 1 else "docs"),
                              sorted(paths.scenes_dir().glob("*.yaml"))):
        print(written)
