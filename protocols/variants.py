"""Variants of a campaign file: the same plates on another bench, with other scope
settings, or after a deskew calibration.

The accuracy study, the planner and the coverage study need the paper campaign on a
bench whose instruments err within their specifications, at other settings, calibrated
or not. This writes copies of the scenes a campaign names with extra effects appended
(e.g. the systematic effects drawn from one `bench_seed`) and copies of the campaign;
nothing shipped is changed, and the copies are ordinary scene and campaign files a user
can run.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

from squeezebench import paths
from squeezebench.lru import RecentlyUsed
from squeezebench.yamlfiles import dump_yaml, load_strict

#: Where the deskew calibration drives its resistor: a pure delay is the same at every
#: frequency; near the plates' so the resistor's own L/R matters as it will.
CALIBRATION_FREQUENCY_HZ = 37000.0

#: The systematic effects of `simbench.systematic_effects` (scene vocabulary: names, not imports, as
#: protocols never import the simulator): the instruments' errors within specification.
SYSTEMATIC_EFFECTS = ("scope_gain_error", "voltage_probe_error", "current_probe_gain_error", "vibrometer_scale_error",
                      "channel_skew", "current_probe_delay", "voltage_probe_compensation", "generator_frequency_error",
                      "scope_timebase_error")


#: Protocols whose points are read away from the scene's measurement point (the stage
#: moves the spot): the truth a bench is scored against does not describe them, and their
#: accuracy is a map's own figures (`map_planning`), so point studies leave them out.
MAP_PROTOCOLS = ("cartography",)


def without_maps(campaign_file: Path) -> Path:
    """Rewrite the campaign file without its map runs (a variant the studies run)."""
    return _keep_runs(campaign_file, lambda run: run.get("protocol") not in MAP_PROTOCOLS)


def coarser_maps(campaign_file: Path, factor: float) -> Path:
    """Rewrite the campaign file with each map run's grid step `factor` times its own (the
    same area, fewer points)."""
    data = load_strict(Path(campaign_file).read_text(encoding="utf-8"))
    for run in data["runs"]:
        if run.get("protocol") in MAP_PROTOCOLS:
            run["parameters"]["grid"]["step_mm"] = float(run["parameters"]["grid"]["step_mm"]) * factor
    Path(campaign_file).write_text(dump_yaml(data), encoding="utf-8")
    return Path(campaign_file)


def only_run(campaign_file: Path, name: str) -> Path:
    """Rewrite the campaign file with run `name` alone: each run opens a bench of its own,
    so it takes the same bench time alone as within the campaign (a planner times runs apart,
    on as many workers)."""
    return _keep_runs(campaign_file, lambda run: run["name"] == name)


def _keep_runs(campaign_file: Path, keep: Callable[[dict], bool]) -> Path:
    data = load_strict(Path(campaign_file).read_text(encoding="utf-8"))
    data["runs"] = [run for run in data["runs"] if keep(run)]
    Path(campaign_file).write_text(dump_yaml(data), encoding="utf-8")
    return Path(campaign_file)


#: How a simulated bench's errors are drawn (the `draw` of its systematic effects): within
#: the specified limits as the budgets assume, or as the world may err (`systematic_effects.world_draw`).
ERROR_MODELS = {"specified": 1, "world": 2}


def systematic_effects(bench_seed: int, draw: bool = True, only: tuple[str, ...] = SYSTEMATIC_EFFECTS,
                       error_model: str = "specified") -> list[dict]:
    """Scene `effects:` entries of one bench's systematic errors at specification
    magnitudes (drawn once from `bench_seed` when `draw`, under `error_model`; the limits
    themselves otherwise)."""
    mode = ERROR_MODELS[error_model] if draw else 0
    return [{name: {"draw": mode, "bench_seed": int(bench_seed)}} for name in only]


#: The plate drawn within its geometry's and materials' tolerances (`simbench.plate_draws`):
#: what the budgets of Q and tan theta' claim to cover beside the instruments.
PLATE_DRAW_EFFECT = "plate_tolerances"
#: The plate placed on the stage within the alignment a lab reaches by eye
#: (`simbench.spot_effects.PlatePlacement`): where a map's grid lands on the mode, which the
#: correction of its homogeneity figures (`analysis.cartography.grid_bias`) reads off the points.
PLATE_PLACEMENT_EFFECT = "plate_placement"


def plate_draw_effects(bench_seed: int, error_model: str = "specified") -> list[dict]:
    """Scene `effects:` entries of the plates of bench `bench_seed` as built and mounted:
    each plate's inputs drawn once within their tolerances, and its placement on the stage
    within the alignment, under `error_model` (`ERROR_MODELS`). The placement acts on maps
    alone (a stage that never moves reads the scene's point)."""
    draw = {"draw": ERROR_MODELS[error_model], "bench_seed": int(bench_seed)}
    return [{PLATE_DRAW_EFFECT: dict(draw)}, {PLATE_PLACEMENT_EFFECT: dict(draw)}]


#: The plate warming under its drive as a real one does (`simbench.effects.HeatingDrift`): the
#: resonance drift Fig. 2's budgets claim to cover (`uncertainty.drift_term`).
PLATE_WARMING_EFFECT = "heating_drift"


def plate_warming_effects(bench_seed: int, error_model: str = "specified") -> list[dict]:
    """Scene `effects:` entries of the plates of bench `bench_seed` warming under drive, each
    plate's thermal parameters drawn once within their tolerances
    (`specifications.HEATING_TOLERANCES`) under `error_model` (`ERROR_MODELS`)."""
    return [{PLATE_WARMING_EFFECT: {"draw": ERROR_MODELS[error_model], "bench_seed": int(bench_seed)}}]


def campaign_with_effects(campaign_file: Path, out_dir: Path, effects: list, noise_seed: int | None = None,
                          keep_maps: bool = False) -> Path:
    """Write `out_dir/<campaign>` whose every scene also lists `effects` (and reads its noise
    from `noise_seed`, when given: `scene_with_effects`), without its map runs
    (`MAP_PROTOCOLS`) unless `keep_maps`; return its path.

    Scenes are found where the campaign runner finds them (`paths.scenes_dir()`, or an
    absolute path); effects a scene already lists keep its own parameters.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    campaign = load_strict(Path(campaign_file).read_text())
    copies: dict[str, str] = {}

    def copy_scene(value: str) -> str:
        if value not in copies:
            copies[value] = str(scene_with_effects(value, out_dir, effects, noise_seed).resolve())
        return copies[value]

    def walk(node: Any) -> Any:
        if isinstance(node, dict):
            return {k: copy_scene(v) if k == "scene" and isinstance(v, str) else walk(v) for k, v in node.items()}
        if isinstance(node, list):
            return [walk(v) for v in node]
        return node

    campaign = walk(campaign)
    campaign.pop("output_dir", None)
    target = out_dir / Path(campaign_file).name
    target.write_text(dump_yaml(campaign))
    return target if keep_maps else without_maps(target)


def scene_with_effects(scene: str | Path, out_dir: Path, effects: list, noise_seed: int | None = None) -> Path:
    """A copy of `scene` (a name in `paths.scenes_dir()` or a path) in `out_dir` that also
    lists `effects`; effects it already lists keep its own parameters. With `noise_seed` the
    copy's `seed` (its reading noise's stream) is that: another bench is other readings, not
    the scene's one realisation of them again."""
    source = Path(scene) if Path(scene).is_absolute() else paths.scenes_dir() / scene
    text = source.read_text()
    # repr tells apart what the YAML would (1 and 1.0, a list and a tuple): one key, one text.
    composed = _SCENES_WITH_EFFECTS.get((text, repr(effects), noise_seed),
                                        lambda: _text_with_effects(text, effects, noise_seed))
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    target = Path(out_dir) / source.name
    target.write_text(composed)
    return target


#: Scene texts with a bench's effects, by (scene text, effects, noise seed): a study writes
#: the same bench of the same scene for each configuration it measures there, and parsing
#: and dumping the scene cost more than the rest of opening that bench's files.
_SCENES_WITH_EFFECTS: RecentlyUsed[str] = RecentlyUsed(64)


def _text_with_effects(text: str, effects: list, noise_seed: int | None) -> str:
    data = load_strict(text)
    listed = {_effect_name(e) for e in data.get("effects", [])}
    data["effects"] = list(data.get("effects", [])) + [e for e in effects if _effect_name(e) not in listed]
    if noise_seed is not None:
        data["seed"] = int(noise_seed)
    return dump_yaml(data)


def _effect_name(entry) -> str:
    return entry if isinstance(entry, str) else next(iter(entry))


CALIBRATION_PROTOCOL = "deskew_calibration"


def calibration_run(frequency_hz: float, scene: str) -> dict:
    """The campaign entry of a deskew calibration at the plates' working frequency, with
    its own averaging: its records set the delay for every later point."""
    return {"name": "deskew_calibration", "protocol": CALIBRATION_PROTOCOL, "bench": {"scene": scene},
            "plate": {"n_powered_columns": 1, "n_powered_piezos": 1},
            "acquisition": {"averages": 64, "record_length": 10000},
            "parameters": {"frequency_hz": float(frequency_hz)}}


def carries_calibration(campaign_file: Path) -> bool:
    """Whether the campaign measures its CH2 delay itself (a deskew calibration run)."""
    return _calibrates(load_strict(Path(campaign_file).read_text(encoding="utf-8")))


def _calibrates(data: dict) -> bool:
    return any(run.get("protocol") == CALIBRATION_PROTOCOL for run in data["runs"])


def with_calibration(campaign_file: Path, out: Path, frequency_hz: float = CALIBRATION_FREQUENCY_HZ) -> Path:
    """A copy of the campaign whose first run is a deskew calibration (its own, when it
    carries one: the shipped campaigns do)."""
    data = load_strict(Path(campaign_file).read_text(encoding="utf-8"))
    if not _calibrates(data):
        scene = data.get("bench", {}).get("scene") or data["runs"][0]["bench"]["scene"]
        data["runs"] = [calibration_run(frequency_hz, scene), *data["runs"]]
    Path(out).write_text(dump_yaml(data), encoding="utf-8")
    return Path(out)


def without_calibration(campaign_file: Path) -> Path:
    """Rewrite the campaign file without its deskew calibration: the bench as it is."""
    return _keep_runs(campaign_file, lambda run: run.get("protocol") != CALIBRATION_PROTOCOL)


def with_acquisition(campaign_file: Path, acquisition_by_run: dict[str, dict], out: Path) -> Path:
    """A copy of the campaign file with keys of each run's `acquisition:` overridden."""
    data = load_strict(Path(campaign_file).read_text(encoding="utf-8"))
    for run in data["runs"]:
        run.setdefault("acquisition", {}).update(acquisition_by_run.get(run["name"], {}))   # maps: as written
    Path(out).write_text(dump_yaml(data), encoding="utf-8")
    return Path(out)


def planned_campaign(campaign_file: Path, acquisition_by_run: dict[str, dict], calibrate: bool, out: Path) -> Path:
    """The campaign file with these settings, preceded by the deskew calibration if
    `calibrate`, without any if not (its own as written when it carries one)."""
    variant = with_acquisition(campaign_file, acquisition_by_run, out)
    return with_calibration(variant, out) if calibrate else without_calibration(variant)
