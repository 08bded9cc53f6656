"""Campaign and bench files, described once as pydantic models.

The models give the error messages (one line: the file, the field as written in the file,
what is wrong and what is allowed) and the JSON Schemas editors use (docs/schemas/;
`python -m squeezebench.schemas` rewrites them, a test checks they are current). The
protocols' own dataclasses (their `Parameters`, `AcquisitionSettings`, `SafetyLimits`,
`Plate`) are the models of their sections: pydantic validates them as they are, so
their checks (`__post_init__`) are the schema's.

Files are read by `yamlfiles.read_yaml` (also used for scenes and bench files), which refuses what PyYAML would silently accept: a key
given twice (the second would win), `.nan` and `.inf`, and text that is not UTF-8.
Scenes are simbench's (`simbench.scene.load_scene` validates them).
"""

from __future__ import annotations

import json
import math
import re
import sys
from pathlib import Path
from typing import Annotated, Any, Iterable, Literal, Optional, Union

import pyvisa.rname
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, ValidationError, create_model, model_validator

from squeezebench import paths
from squeezebench.errors import UserError
from squeezebench.instruments.bench import OPTIONAL_ROLES, ROLES, BenchConfig, BenchElectronics, is_simulated
from squeezebench.instruments.smc100 import AXES as SMC100_AXES
from squeezebench.instruments.errors import BenchFileError
from squeezebench.protocols import (calibration, cartography, characterisation, cutting, detuning, powered_columns,
                                   resonance)
from squeezebench.protocols.acquisition import AcquisitionSettings
from squeezebench.protocols.safety import SafetyLimits
from squeezebench.protocols.steps import Plate
from squeezebench.yamlfiles import FileFormatError, read_yaml  # noqa: F401 - the readers of every file

PROTOCOLS = {module.PROTOCOL: module for module in
             (resonance, detuning, cutting, powered_columns, characterisation, calibration, cartography)}
SCHEMAS_DIR = Path(__file__).resolve().parents[1] / "docs" / "schemas"


# -- the models ---------------------------------------------------------------------------
_NAME_PATTERN = r"^[A-Za-z0-9_.-]+$"


#: A name becomes a file or folder name with a suffix (".partial", ".parquet"): well under
#: the 255 bytes a file-system name may have.
MAX_NAME_LENGTH = 100


def file_name_problem(value: str) -> str | None:
    """Why `value` cannot name a file or folder inside a run directory (None if it can):
    letters, digits, '_', '-' or '.', not '.' or '..' (they name a folder already, the
    second one outside the run), at most MAX_NAME_LENGTH characters."""
    if not re.match(_NAME_PATTERN, value):
        return f"{value!r} must be letters, digits, '_', '-' or '.' (it names files)"
    if value in (".", ".."):
        return f"{value!r} is not a name: it names a folder that exists already (it names files)"
    if len(value) > MAX_NAME_LENGTH:
        return f"{value[:20]!r}... is {len(value)} characters long; at most {MAX_NAME_LENGTH} (it names files)"
    return None


def _file_name(value: str) -> str:
    problem = file_name_problem(value)
    if problem:
        raise ValueError(problem)
    return value


Name = Annotated[str, AfterValidator(_file_name), Field(json_schema_extra={"pattern": _NAME_PATTERN})]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class BenchChoice(_Model):
    """Exactly one: `scene` (the simulated bench, a file in data/scenes/ or a path) or
    `file` (a bench file with real VISA addresses, relative to the campaign file)."""

    scene: Optional[str] = None
    file: Optional[str] = None

    @model_validator(mode="after")
    def _exactly_one(self) -> BenchChoice:
        if (self.scene is None) == (self.file is None):
            raise ValueError("needs exactly one of 'scene' (simulated bench) or 'file' (real bench)")
        return self


class _RunBase(_Model):
    name: Name
    bench: Optional[BenchChoice] = None   # default: the campaign's
    plate: Plate
    acquisition: AcquisitionSettings = AcquisitionSettings()   # merged over the campaign's
    safety: SafetyLimits = SafetyLimits()                      # merged over the campaign's


RUN_MODELS = {protocol: create_model(f"{protocol}_run", __base__=_RunBase, protocol=(Literal[protocol], ...),
                                     parameters=(module.Parameters, ...))
              for protocol, module in PROTOCOLS.items()}
AnyRun = Annotated[Union[tuple(RUN_MODELS.values())], Field(discriminator="protocol")]


class CampaignFile(_Model):
    """A campaign: protocol runs, run step by step (see protocols.campaign)."""

    name: Optional[Name] = None            # default: the file's stem
    output_dir: Optional[str] = None       # default: runs/<name>
    bench: Optional[BenchChoice] = None
    acquisition: AcquisitionSettings = AcquisitionSettings()
    safety: SafetyLimits = SafetyLimits()
    runs: list[AnyRun] = Field(min_length=1)

    @staticmethod
    def prepared(data: Any) -> Any:
        """The file's data with each run given the campaign's bench, acquisition and
        safety under its own, and its plate the bench scene (and its stem as name) by
        default (`validated` calls it before validation)."""
        if not isinstance(data, dict) or not isinstance(data.get("runs"), list):
            return data
        runs = []
        for run in data["runs"]:
            if isinstance(run, dict):
                run = dict(run)
                for key in ("acquisition", "safety"):
                    top, own = data.get(key) or {}, run.get(key) or {}
                    if isinstance(top, dict) and isinstance(own, dict):
                        run[key] = {**top, **own}
                if run.get("bench") is None and data.get("bench") is not None:
                    run["bench"] = data["bench"]
                bench, plate = run.get("bench"), run.get("plate")
                if isinstance(plate, dict) and isinstance(bench, dict) and isinstance(bench.get("scene"), str):
                    # a plate named otherwise keeps the bench scene's geometry
                    run["plate"] = {"name": Path(bench["scene"]).stem, "scene": bench["scene"], **plate}
            runs.append(run)
        return {**data, "runs": runs}


def _visa_address(value: str) -> str:
    try:
        pyvisa.rname.parse_resource_name(value.strip())
    except pyvisa.rname.InvalidResourceName:
        raise ValueError(f"{value!r} is not a VISA resource address (e.g. GPIB0::10::INSTR, "
                         "TCPIP0::192.168.0.20::INSTR, ASRL1::INSTR)") from None
    return value.strip()


VisaAddress = Annotated[str, AfterValidator(_visa_address)]


#: The interfaces each instrument has (its manual): the 33120A GPIB and RS-232; the TDS3054B
#: Ethernet, and GPIB or RS-232 through its communication module; the OFV-5000 controller and
#: the SMC100 RS-232 (a USB adapter is a serial port too). An RS-232 port may also be reached
#: through a serial device server: a TCPIP SOCKET address.
INTERFACES = {"generator": ("GPIB", "ASRL"), "scope": ("TCPIP", "GPIB", "ASRL"),
              "vibrometer": ("ASRL",), "stage": ("ASRL",)}


class Resources(_Model):
    generator: VisaAddress
    scope: VisaAddress
    vibrometer: VisaAddress
    stage: Optional[VisaAddress] = None   # the x-y stage a map (cartography) needs; SMC100 pair

    @model_validator(mode="after")
    def _reachable_and_distinct(self) -> Resources:
        seen: dict[str, str] = {}
        for role, allowed in INTERFACES.items():
            address = getattr(self, role)
            if address is None:
                continue
            parsed = pyvisa.rname.parse_resource_name(address)
            serial_server = "ASRL" in allowed and (parsed.interface_type, parsed.resource_class) == ("TCPIP", "SOCKET")
            if parsed.interface_type not in allowed and not serial_server:
                raise ValueError(f"{role} {address!r} is a {parsed.interface_type} address; the {role} is reached "
                                 f"by {' or '.join(allowed)}{' (or a serial server, TCPIP...::SOCKET)' if 'ASRL' in allowed else ''}")
            key = str(parsed).upper()
            if key in seen:
                raise ValueError(f"{role} and {seen[key]} have the same address, {address!r}: each instrument "
                                 "answers at its own")
            seen[key] = role
        return self


def _travel(value: tuple[float, float]) -> tuple[float, float]:
    if not value[0] < value[1]:
        raise ValueError(f"{list(value)} must be [low, high] mm, low below high")
    return value


class StageTravel(_Model):
    """The x-y stage's travel per axis (mm): the software limits SL and SR set on each SMC100
    controller (SMC100 user's manual), known before the bench opens so that `validate` and
    `run` refuse a map beyond them alike; the run checks every point again against the limits
    the stage reports when it opens."""

    x: Annotated[tuple[float, float], AfterValidator(_travel)]
    y: Annotated[tuple[float, float], AfterValidator(_travel)]


class BenchFile(_Model):
    """A real bench: the VISA library, an address per instrument, the electronics."""

    visa_library: Optional[str] = ""   # "" or null: the system VISA library; "@py": pyvisa-py
    simulator: Optional[VisaAddress] = None   # serve-sim's bench port (a served simulated bench)
    resources: Resources
    stage_travel_mm: Optional[StageTravel] = None   # with resources.stage, and only then
    electronics: BenchElectronics = BenchElectronics()

    @model_validator(mode="after")
    def _stage_described(self) -> BenchFile:
        if (self.resources.stage is None) != (self.stage_travel_mm is None):
            raise ValueError("resources.stage and stage_travel_mm ({x: [low, high], y: [low, high]} mm, the "
                             "controllers' SL and SR) go together: a map is checked against the travel "
                             "before the bench opens")
        return self

    @staticmethod
    def prepared(data: Any) -> Any:
        """`generator_load: 50` is a number in YAML; the setting is the text 50 or INF
        (`validated` calls it before validation)."""
        electronics = data.get("electronics") if isinstance(data, dict) else None
        if isinstance(electronics, dict) and isinstance(electronics.get("generator_load"), (int, str)) \
                and not isinstance(electronics["generator_load"], bool):
            data = {**data, "electronics": {**electronics,
                                            "generator_load": str(electronics["generator_load"]).upper()}}
        return data


def validated(model: type[BaseModel], data: Any) -> Any:
    """`data` (a file's YAML) as `model`, strictly: no coercion, so "16" is not a count,
    true is not 1 and 3.5 is not an integer (a number where a float is asked is fine).
    Validated as JSON: strict mode then still takes a YAML list for a tuple and a mapping
    for a section. A YAML value JSON has no form for (a date) becomes its text, which only
    a text field accepts. A model's `prepared` (defaults one section takes from another)
    runs first, on the data as read: pydantic's JSON mode would not take Python values
    back from a validator."""
    prepare = getattr(model, "prepared", None)
    return model.model_validate_json(json.dumps(prepare(data) if prepare else data, default=str), strict=True)


# -- errors -------------------------------------------------------------------------------
def _field_path(loc: tuple) -> str:
    """runs[0].parameters.search.points, without pydantic's union tags (a protocol's branch
    name, "literal['aluminium_table2']", "IsotropicMaterial"): the file's words only."""
    parts: list[str] = []
    for i, item in enumerate(loc):
        if isinstance(item, int):
            parts.append(f"[{item}]")
        elif i > 0 and isinstance(loc[i - 1], int) and item in RUN_MODELS:
            continue   # the discriminator's branch name
        elif i > 0 and not re.fullmatch(r"[a-z_][a-z0-9_]*", str(item)):
            continue   # a union's branch: the field is the one before it
        else:
            parts.append(f".{item}" if parts else str(item))
    return "".join(parts)


def _allowed(model: type[BaseModel], loc: tuple) -> list[str]:
    """The field names allowed where `loc` points (for 'unknown field' messages)."""
    schema = model.model_json_schema()
    node: dict = schema
    for item in loc[:-1]:
        node = _resolve(schema, node)
        if isinstance(item, int):
            node = node.get("items", {})
        elif item in RUN_MODELS and "oneOf" in node:
            node = next((_resolve(schema, n) for n in node["oneOf"]
                         if _resolve(schema, n).get("properties", {}).get("protocol", {}).get("const") == item), {})
        else:
            node = node.get("properties", {}).get(item, {})
    return sorted(_resolve(schema, node).get("properties", {}))


def _resolve(schema: dict, node: dict) -> dict:
    while True:
        if "$ref" in node:
            node = schema["$defs"][node["$ref"].split("/")[-1]]
        elif "anyOf" in node:
            node = next((n for n in node["anyOf"] if n.get("type") != "null"), {})
        else:
            return node


_UNKNOWN = ("extra_forbidden", "unexpected_keyword_argument")


def problems(error: ValidationError, model: type[BaseModel]) -> list[tuple[str, str]]:
    """Every problem of a file, one (field, message) per field in the file's words: a union
    tries each branch and reports each, but it is one field and one problem; a misspelt key
    is one problem (the right name, which it makes "missing", is offered instead)."""
    errors = error.errors(include_url=False)
    found: dict[str, str] = {}
    guessed: set[str] = set()
    for one in sorted(errors, key=lambda e: e["type"] not in _UNKNOWN):   # unknown keys first
        field, message, guess = _problem(one, model)
        if one["type"] == "missing" and field in guessed:
            continue
        if guess:
            guessed.add(guess)
        found.setdefault(field, message)
    return list(found.items())


def _problem(one: dict, model: type[BaseModel]) -> tuple[str, str, str]:
    """(field, message, the field a misspelt key was probably meant to be) of one error."""
    import difflib

    loc, kind = one["loc"], one["type"]
    field = _field_path(loc) or "top level"
    guess = ""
    if kind in _UNKNOWN:
        allowed = _allowed(model, loc)
        close = difflib.get_close_matches(str(loc[-1]), allowed, n=1)
        message = f"unknown field ({f'did you mean {close[0]!r}? ' if close else ''}allowed: {', '.join(allowed)})"
        if close:
            guess = _field_path((*loc[:-1], close[0]))
    elif kind == "missing":
        message = "is missing"
    elif kind == "value_error":
        message = str(one["ctx"]["error"])
    elif kind == "union_tag_invalid":
        message = f"{one['input'].get('protocol')!r} is not one of: {', '.join(sorted(RUN_MODELS))}" \
            if isinstance(one.get("input"), dict) else one["msg"]
        field = f"{field}.protocol"
    elif kind == "union_tag_not_found":
        message, field = f"is missing (one of: {', '.join(sorted(RUN_MODELS))})", f"{field}.protocol"
    elif kind == "too_short" and loc == ("runs",):
        message = "must be a non-empty list of protocol runs"
    elif kind in ("model_type", "dataclass_type", "dict_type"):
        allowed = _allowed(model, (*loc, "_"))
        message = f"{one['input']!r} must be a mapping" + (f" of {', '.join(allowed)}" if allowed else "")
    elif kind == "string_too_long":   # the text itself would be the whole line
        message = (f"{one['input'][:20]!r}... is {len(one['input'])} characters long; "
                   f"at most {one['ctx']['max_length']} characters")
    elif kind in ("float_type", "int_type") and _is_number(one.get("input")):
        message = f"{one['input']!r} is text, not a number: write it without quotes"
    else:
        message = f"{one['input']!r}: {one['msg'][0].lower()}{one['msg'][1:]}"
    return field, message, guess


def _is_number(text: Any) -> bool:
    """A number quoted in the file ('1.5'), not words ('20 V')."""
    try:
        return isinstance(text, str) and math.isfinite(float(text))
    except ValueError:
        return False


def describe(error: ValidationError, model: type[BaseModel]) -> tuple[str, str]:
    """(field, message) of a validation error's first problem, in the file's words, and how
    many more the file has."""
    found = problems(error, model)
    (field, message), more = found[0], len(found) - 1
    return field, message + (f" ({more} more problem{'s' if more > 1 else ''} after this one)" if more else "")


# -- bench files --------------------------------------------------------------------------
def load_bench_file(path: str | Path) -> BenchConfig:
    """A real bench from its YAML file; BenchFileError names file, field and what is allowed."""
    path = Path(path)
    try:
        data = read_yaml(path)
    except FileFormatError as exc:
        raise BenchFileError(path, "file", str(exc).removeprefix(f"{path}: ")) from None
    try:
        bench = validated(BenchFile, data)
    except ValidationError as exc:
        raise BenchFileError(path, *describe(exc, BenchFile)) from None
    return BenchConfig(visa_library=bench.visa_library or "",
                       resources={role: address for role in (*ROLES, *OPTIONAL_ROLES)
                                  if (address := getattr(bench.resources, role)) is not None},
                       electronics=bench.electronics, source=str(path), simulator=bench.simulator,
                       stage_travel_mm=bench.stage_travel_mm and bench.stage_travel_mm.model_dump())


def stage_travel_mm(config: BenchConfig) -> dict[str, tuple[float, float]] | None:
    """The stage's travel per axis (mm) before the bench opens: the simulated stage's, a real
    one's as its bench file states it (a run reads the stage's own, SMC100 SL/SR, when it
    opens it, and checks the map again); None for a bench without a stage."""
    if not is_simulated(config):
        return config.stage_travel_mm
    from squeezebench.simbench.stage import TRAVEL_MM

    return {axis: TRAVEL_MM[str(address)] for axis, address in SMC100_AXES.items()}


# -- design files -------------------------------------------------------------------------
#: The design-file user guide every design-file error names.
DESIGN_GUIDE = "docs/design-files.md"


def load_design_file(path: str | Path, characterised: Iterable[str] = ()):
    """A plate to design (`designing.design_file.DesignFile`); a problem is one line naming
    the file, the field and what is wrong. `from_small_plates.template_plate` must name a
    plate the paper's route can read (`template_plates`, with the plates `characterised` in
    the runs `design --from` reads)."""
    from squeezebench.designing.design_file import DesignFile   # the plate model's imports: only for a design

    path = Path(path)
    data = read_yaml(path)
    try:
        design = validated(DesignFile, data)
    except ValidationError as exc:   # every problem at once: a design file is written by hand
        found = problems(exc, DesignFile)
        if len(found) == 1:
            raise UserError(f"{path}: {found[0][0]}: {found[0][1]} (every field: {DESIGN_GUIDE})") from None
        raise UserError(f"{path}: {len(found)} problems (every field: {DESIGN_GUIDE}):\n"
                        + "\n".join(f"  {field}: {message}" for field, message in found)) from None
    template, known = design.from_small_plates.template_plate, template_plates(characterised)
    if template is not None and template not in known:
        raise UserError(f"{path}: from_small_plates.template_plate: {template!r} is no plate the paper's route "
                        f"knows; known: {', '.join(known)} (the shipped small plates, and with design --from the "
                        f"runs' characterised plates; every field: {DESIGN_GUIDE})")
    return design


def template_plates(characterised: Iterable[str] = ()) -> list[str]:
    """The plates whose Q the paper's route (Eq. 29) may scale: the shipped scenes' plates
    but the large one it designs (a characterisation names a plate by its scene), and
    `characterised`, the plates of the runs given."""
    from squeezebench.analysis.characterisation import LARGE_PLATE

    return sorted({name for name in paths.shipped_names("scenes") if name != LARGE_PLATE} | set(characterised))


# -- scenes -------------------------------------------------------------------------------
def check_scene(path: Path) -> None:
    """Validate a scene with simbench's own loader (SceneError names file and field)."""
    from squeezebench.simbench.scene import load_scene

    load_scene(path)


def replay_departures(path: Path) -> list[str]:
    """What of each replayed (given or calibrated) state of a scene departs from the plate
    model's prediction beyond its tolerances (`simbench.predicted`), one line per state:
    `validate` says it (a few seconds of solving per plate, so not at every campaign load)."""
    from squeezebench.simbench.predicted import predict
    from squeezebench.simbench.scene import load_scene

    scene = load_scene(path)
    kind = (f"a declared replay ({scene.replay_reason})" if scene.replay_reason
            else "not a replay, and its physics")
    lines = []
    for state in scene.states.values():
        departures = [] if state.predicted else predict(scene, state).departures()
        if departures:
            lines.append(f"{path.name}: state {state.name!r}, {kind}, departs from the plate model: "
                         + "; ".join(departures))
    return lines


# -- checking any file -------------------------------------------------------------------
def check_powered_piezos(campaign) -> None:
    """Before `run`: raise a UserError at the first step whose plate's n_powered_piezos
    differs from what its scene's state powers (n_c scales Q and tan theta'; a real bench
    has no scene: nothing to check; a deskew calibration drives a resistor, no plate)."""
    from squeezebench.simbench.scene import load_scene   # the campaign's scenes: only for run

    for run in campaign.runs:
        if run.protocol == "deskew_calibration":
            continue
        for step in run.steps():
            scene_path = step.plate.scene or run.bench.scene
            if scene_path is None:
                continue
            scene = load_scene(scene_path)
            state = scene.state(step.plate.state or scene.initial_state)
            if state.n_powered_piezos != step.plate.n_powered_piezos:
                raise UserError(
                    f"{campaign.file}: run {run.name!r}, step {step.step_id!r}: plate {step.plate.name!r} says "
                    f"{step.plate.n_powered_piezos} powered piezos, but {scene_path.name} state {state.name!r} "
                    f"powers {len(state.powered_columns)} columns x {scene.actuators.piezos_per_column} = "
                    f"{state.n_powered_piezos} (n_c scales Q and tan theta'): correct n_powered_piezos")
            if len(state.powered_columns) != step.plate.n_powered_columns:   # stored in every row
                raise UserError(
                    f"{campaign.file}: run {run.name!r}, step {step.step_id!r}: plate {step.plate.name!r} says "
                    f"{step.plate.n_powered_columns} powered columns, but {scene_path.name} state {state.name!r} "
                    f"powers {len(state.powered_columns)}: correct n_powered_columns")


def load_checked_campaign(path: Path, bench_file: Path | None = None):
    """The campaign as `run` takes it (`protocols.campaign.load_campaign`), and each plate's
    powered piezos and columns against its scene's state: what `validate` and `run` both
    refuse (a plate of 8000 powered piezos passed `validate` and stopped `run`)."""
    from squeezebench.protocols.campaign import load_campaign

    campaign = load_campaign(path, bench_file=bench_file)
    check_powered_piezos(campaign)
    return campaign


def validate_file(path: Path) -> dict[str, Any]:
    """Check a campaign (with every scene and bench file it uses and every request it
    will make), bench or scene file. Returns {file, kind, summary, warnings}; a problem
    is the UserError of the file it is in."""
    from squeezebench.protocols.safety import chain_warnings

    path = Path(path)
    data = read_yaml(path)
    if isinstance(data, dict) and "runs" in data:
        campaign = load_checked_campaign(path)
        configs = {run.bench.input_file: run.bench.config() for run in campaign.runs}
        scenes = sorted({p.name for run in campaign.runs for p in run.input_files() if p.suffix == ".yaml"})
        n_steps = sum(len(run.steps()) for run in campaign.runs)
        return {"file": str(path), "kind": "campaign",
                "summary": f"{len(campaign.runs)} run{'s' if len(campaign.runs) != 1 else ''}, {n_steps} "
                           f"step{'s' if n_steps != 1 else ''}, inputs {', '.join(scenes)}",
                "warnings": [f"{source}: {w}" for source, config in configs.items()
                             for w in chain_warnings(config.electronics)]}
    if isinstance(data, dict) and ("resources" in data or "visa_library" in data):
        config = load_bench_file(path)
        return {"file": str(path), "kind": "bench", "summary": ", ".join(config.resources.values()),
                "warnings": chain_warnings(config.electronics)}
    if isinstance(data, dict) and "plate" in data:
        return {"file": str(path), "kind": "scene", "summary": "", "warnings": replay_departures(path)}
    if isinstance(data, dict) and "resonator" in data:
        from squeezebench.designing.design import predict_physics   # what `design` refuses, refused here too

        design = load_design_file(path)
        mode = predict_physics(design).nominal.values
        return {"file": str(path), "kind": "design",
                "summary": f"{design.n_powered_piezos} powered piezos in {design.n_powered_groups} groups, "
                           f"working mode {mode['frequency_hz']:.0f} Hz",
                "warnings": []}
    raise UserError(f"{path}: top level: not a campaign (with 'runs'), bench (with 'resources'), "
                    "scene (with 'plate') or design (with 'resonator') file")


# -- JSON Schemas -------------------------------------------------------------------------
def json_schemas() -> dict[str, dict]:
    from squeezebench.designing.design_file import DesignFile

    return {"campaign.schema.json": CampaignFile.model_json_schema(),
            "bench.schema.json": BenchFile.model_json_schema(),
            "design.schema.json": DesignFile.model_json_schema()}


def schema_text(schema: dict) -> str:
    return json.dumps(schema, indent=2, sort_keys=True) + "\n"


def write_json_schemas(folder: Path = SCHEMAS_DIR) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for name, schema in json_schemas().items():
        (folder / name).write_text(schema_text(schema), encoding="utf-8")
        written.append(folder / name)
    return written


if __name__ == "__main__":
    for written_path in write_json_schemas(Path(sys.argv[1]) if len(sys.argv) > 1 else SCHEMAS_DIR):
        print(written_path)
