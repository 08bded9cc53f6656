"""Where the shipped data lives (scenes, campaigns, the paper's printed values)."""

import os
from pathlib import Path


def data_dir() -> Path:
    """The project's `data/` folder; `SQUEEZEBENCH_DATA` overrides it."""
    override = os.environ.get("SQUEEZEBENCH_DATA")
    if override:
        return Path(override)
    return Path(__file__).resolve().parents[1] / "data"


def scenes_dir() -> Path:
    return data_dir() / "scenes"


def campaigns_dir() -> Path:
    return data_dir() / "campaigns"


def paper_values_dir() -> Path:
    return data_dir() / "paper"


def default_scene() -> Path:
    """The scene `--bench sim` uses when none is named: the Table 3 one-column plate."""
    return scenes_dir() / "one_column_1mm.yaml"


def paper_campaign() -> Path:
    return campaigns_dir() / "paper.yaml"
