"""A campaign's simulated bench with more effects on: the same plates on another bench.

The accuracy study, the planner and the coverage tests need the paper campaign on a
bench whose instruments err within their specifications. This writes copies of the
scenes a campaign names with extra effects appended (e.g. the systematic effects drawn
from one `bench_seed`) and a copy of the campaign pointing at them; nothing shipped is
changed, and the copies are ordinary scene and campaign files a user can run.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from squeezebench import paths
from squeezebench.simbench.effects import SYSTEMATIC_EFFECTS


def systematic_effects(bench_seed: int, draw: bool = True, only: tuple[str, ...] = SYSTEMATIC_EFFECTS) -> list[dict]:
    """Scene `effects:` entries of one bench's systematic errors at specification
    magnitudes (drawn once from `bench_seed` when `draw`; the limits themselves otherwise)."""
    return [{name: {"draw": int(draw), "bench_seed": int(bench_seed)}} for name in only]


def campaign_with_effects(campaign_file: Path, out_dir: Path, effects: list) -> Path:
    """Write `out_dir/<campaign>` whose every scene also lists `effects`; return its path.

    Scenes are found where the campaign runner finds them (`paths.scenes_dir()`, or an
    absolute path); effects a scene already lists keep its own parameters.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    campaign = yaml.safe_load(Path(campaign_file).read_text())
    copies: dict[str, str] = {}

    def copy_scene(value: str) -> str:
        if value not in copies:
            source = Path(value) if Path(value).is_absolute() else paths.scenes_dir() / value
            scene = yaml.safe_load(source.read_text())
            listed = {_effect_name(e) for e in scene.get("effects", [])}
            scene["effects"] = list(scene.get("effects", [])) + [e for e in effects if _effect_name(e) not in listed]
            target = out_dir / source.name
            target.write_text(yaml.safe_dump(scene, sort_keys=False))
            copies[value] = str(target.resolve())
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
    target.write_text(yaml.safe_dump(campaign, sort_keys=False))
    return target


def _effect_name(entry) -> str:
    return entry if isinstance(entry, str) else next(iter(entry))
