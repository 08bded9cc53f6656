"""Shared helpers of the protocol and campaign tests (no tests here).

Scenes are copied into the test's tmp_path with `effects: []` so the simulated bench is
noise-free and a run is exactly repeatable; campaigns are written there too.
"""

from __future__ import annotations

from pathlib import Path


from squeezebench.protocols.campaign import run_campaign
from squeezebench.protocols.storage import read_measurements
from squeezebench import paths
from squeezebench.yamlfiles import dump_yaml, load_strict

#: Small acquisition settings: the tests check logic, not noise.
FAST_ACQUISITION = {"averages": 2, "record_length": 500, "periods_per_record": 10, "settle_s": 0.2}
ONE_COLUMN_PLATE = {"n_powered_columns": 1, "n_powered_piezos": 4}


def noise_free_scene(tmp_path: Path, name: str, effects: list | None = None) -> Path:
    """A copy of a shipped scene without effects (noise, drift...) but `effects`, in tmp_path."""
    scene = load_strict((paths.scenes_dir() / name).read_text())
    scene["effects"] = effects or []
    path = tmp_path / name
    path.write_text(dump_yaml(scene))
    return path


def write_campaign(tmp_path: Path, runs: list[dict], name: str = "test", **top) -> Path:
    campaign = {"name": name, "acquisition": FAST_ACQUISITION, **top, "runs": runs}
    path = tmp_path / f"{name}.yaml"
    path.write_text(dump_yaml(campaign))
    return path


def run_rows(tmp_path: Path, runs: list[dict], **top):
    """Run a campaign of `runs`; return (run_dir, measurement rows)."""
    run_dir = run_campaign(write_campaign(tmp_path, runs, **top), out_dir=tmp_path / "run")
    return run_dir, read_measurements(run_dir)


def results(rows, protocol: str):
    """The recorded (non-sweep) rows of one protocol."""
    rows = rows[rows["protocol"] == protocol]
    if "sweep" in rows:
        rows = rows[rows["sweep"].fillna(False) == False]  # noqa: E712 - nullable column
    return rows.reset_index(drop=True)
