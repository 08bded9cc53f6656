"""A plate absent from the paper, written only from physical parameters, goes through
`squeezebench run` and `squeezebench report` and shows its Q and tan theta'."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import pandas as pd

from squeezebench import cli
from squeezebench.yamlfiles import dump_yaml, load_strict

EXAMPLES = Path(__file__).resolve().parents[1] / "data" / "examples"


def _campaign(tmp_path: Path, **plate) -> Path:
    """The example campaign and its scene copied side by side (the scene path is relative)."""
    shutil.copy(EXAMPLES / "own_plate.yaml", tmp_path / "own_plate.yaml")
    campaign = load_strict((EXAMPLES / "own_plate_campaign.yaml").read_text())
    campaign["output_dir"] = str(tmp_path / "run")
    campaign["runs"][0]["plate"].update(plate)
    path = tmp_path / "campaign.yaml"
    path.write_text(dump_yaml(campaign))
    return path


def test_own_plate_runs_and_reports_its_q_and_tan_theta(tmp_path):
    assert "own_plate.yaml" not in {p.name for p in (EXAMPLES.parents[0] / "scenes").glob("*.yaml")}
    assert cli.main(["run", str(_campaign(tmp_path))]) == 0
    assert cli.main(["report", str(tmp_path / "run")]) == 0
    report = tmp_path / "run" / "report"
    plates = pd.read_csv(report / "plates_by_reading.csv").set_index(["plate", "reading"])
    # named "my_plate" in the campaign, not after the scene file: the geometry still follows
    assert set(plates.index) == {("my_plate", "physical"), ("my_plate", "paper"), ("my_plate", "inferred")}
    for reading in ("paper", "inferred"):
        q, tan = plates.loc[("my_plate", reading), ["q", "tan_theta"]]
        assert math.isfinite(q) and q > 0 and math.isfinite(tan) and tan < 0
    html = (report / "index.html").read_text()
    assert "my_plate" in html and f"{plates.loc[('my_plate', 'inferred'), 'q']:.4g}" in html
    # the report says the plate could exist, with the figures it was checked on
    scenes = pd.read_csv(report / "scenes.csv")
    assert list(scenes["scene"]) == ["own_plate"] and list(scenes["origin"]) == ["physical"]
    assert "Simulated plates: could they exist?" in html


def test_a_campaign_miscounting_the_powered_piezos_is_refused_before_it_runs(tmp_path, capsys):
    assert cli.main(["run", str(_campaign(tmp_path, n_powered_piezos=12))]) == cli.EXIT_USER_ERROR
    assert "plate 'my_plate' says 12 powered piezos, but own_plate.yaml state 'both' powers 2 columns x 3 = 6" \
        in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


def test_a_run_miscounting_the_powered_piezos_is_refused_by_the_analysis(tmp_path):
    from squeezebench.protocols.campaign import run_campaign

    run_campaign(_campaign(tmp_path, n_powered_piezos=12), progress=False)   # past the command line's check
    assert cli.main(["report", str(tmp_path / "run")]) == 0
    html = (tmp_path / "run" / "report" / "index.html").read_text()
    assert "the campaign says 12 powered piezos" in html and "powers 2 columns x 3 = 6" in html
    assert not (tmp_path / "run" / "report" / "plates_by_reading.csv").exists()
