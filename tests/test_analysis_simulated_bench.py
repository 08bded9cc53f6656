"""Tables 3 and 4 recomputed from dry runs of the shipped paper campaign.

Noise-free scenes give the printed values within 0.1 %; the shipped scenes (noise,
quantisation, offsets, shunt, dielectric loss) within 1 %, and each stored point's stated
uncertainty covers the scene's closed-form truth at that point's drive. The printed
amplitudes are left out of the 0.1 % check: Table 4 prints 1.08 um where its own 0.30 m/s
at 43792 Hz gives 1.09 um (the audit shows it); they are checked within 1 %.
"""

from __future__ import annotations

import math

import pandas as pd
import pytest

from squeezebench.analysis import tables
from squeezebench.analysis.rundata import load_run
from squeezebench.analysis.tables import reduced_points
from squeezebench.protocols.campaign import run_campaign
from squeezebench.simbench import physics
from squeezebench.simbench.effects import build_pipeline
from squeezebench.simbench.scene import load_scene
from squeezebench import paths
from squeezebench.yamlfiles import dump_yaml, load_strict

RUNS = ("table3_cutting", "table4_powered_columns")
CALIBRATED = ("frequency_hz", "voltage_vpp", "power_w", "velocity_pp_mps")
# |value - truth| <= k standard uncertainties for each of the 24 (point, quantity) pairs, one
# noise draw. At k = 3 one pair falls outside by chance in about 6 % of draws (Bonferroni:
# 24 x 0.27 %); k = 3.5 keeps the family-wise rate near 1 %. Measured: with scene seeds 1-4
# the normalised power deviations scatter as N(0, 1) (max |z| 2.3, 2.0, 2.0, 2.8 before the
# manual-grammar scope; 3.1, 1.3, 2.3, 1.2 after it, whose decoder ranges change how many
# acquisitions a point takes and so which noise it draws; with the old decoder's ranges the
# new scope reproduces the old deviations exactly).
COVERAGE_K = 3.5
#: Without the scene's noise the scope's ADC rounds every averaged acquisition alike, so its
#: step leaves a fixed error the averaging cannot remove; the records' Type A u assumes the
#: noise dithers it, as on the realistic bench. Both power estimators (window and sine fit)
#: read configuration 3's 0.1 W 4.9e-6 low alike: the record's, a few parts per million.
UNDITHERED_REL = 1e-5


def _with_scenes(node, scenes: dict[str, str]):
    """The campaign with every `scene:` replaced by the path in `scenes`."""
    if isinstance(node, dict):
        return {k: (scenes[v] if k == "scene" else _with_scenes(v, scenes)) for k, v in node.items()}
    if isinstance(node, list):
        return [_with_scenes(v, scenes) for v in node]
    return node


@pytest.fixture(scope="module")
def noise_free(tmp_path_factory):
    """Tables 3 and 4's runs of the paper campaign on its scenes without their effects."""
    tmp_path = tmp_path_factory.mktemp("noise_free")
    campaign = load_strict(paths.paper_campaign().read_text())
    campaign["runs"] = [run for run in campaign["runs"] if run["name"] in RUNS]
    scenes = {}
    for name in ("one_column_1mm.yaml", "one_column_1p2mm.yaml", "two_column_1p2mm.yaml"):
        scene = load_strict((paths.scenes_dir() / name).read_text())
        scene["effects"] = []
        scenes[name] = str(tmp_path / name)
        (tmp_path / name).write_text(dump_yaml(scene))
    campaign = _with_scenes(campaign, scenes)
    campaign_file = tmp_path / "tables.yaml"
    campaign_file.write_text(dump_yaml(campaign))
    run_dir = run_campaign(campaign_file, out_dir=tmp_path / "run")
    # the tables as the report computes them (`finish_table`: its CSVs' rows), without the
    # rest of a report (some 5 CPU-s): `realistic` reads the CSVs the paper report wrote
    run = load_run(run_dir)
    return run_dir, _tables([tables.finish_table(table(run)) for table in (tables.table3, tables.table4)])


def _tables(frames: list[pd.DataFrame]) -> pd.DataFrame:
    """Tables 3 and 4 as one frame, the antinode counts (no unit, no budget) left out."""
    table = pd.concat(frames, ignore_index=True)
    return table[table["quantity"] != "n_antinodes"]


@pytest.fixture(scope="module")
def realistic(paper_run, paper_report):
    """The shipped scenes as they are: the session's paper run (`paper_run`), whose Tables 3
    and 4 runs these are, and its report, not a second run of them."""
    run_dir, _ = paper_run
    return run_dir, _tables([pd.read_csv(run_dir / "report" / f"table{n}.csv") for n in (3, 4)])


def test_noise_free_tables_3_and_4_within_0p1_percent(noise_free):
    _, table = noise_free
    assert set(table["status"]) == {"round_trip"}   # the scenes replay the printed points: every value comes back
    calibrated = table[table["quantity"].isin(CALIBRATED)]
    worst = calibrated.loc[calibrated["relative_difference"].abs().idxmax()]
    assert abs(worst["relative_difference"]) < 1e-3, worst.to_dict()
    assert (table["relative_difference"].abs() < 0.01).all()   # amplitudes: the printed rounding


def test_realistic_tables_3_and_4_within_1_percent(realistic):
    _, table = realistic
    assert set(table["status"]) == {"round_trip"}   # the scenes replay the printed points: every value comes back
    worst = table.loc[table["relative_difference"].abs().idxmax()]
    assert abs(worst["relative_difference"]) < 0.01, worst.to_dict()


@pytest.mark.parametrize("bench", ["noise_free", "realistic"])
def test_stated_uncertainties_cover_the_scenes_truth(bench, request):
    run_dir, _ = request.getfixturevalue(bench)
    run = load_run(run_dir)
    points = reduced_points(run, run.measurements[run.measurements["waveform_file"].notna()
                                                  & run.measurements["run_name"].isin(RUNS)])
    checked = 0
    for point in points.itertuples(index=False):
        scene = load_scene(run_dir / "inputs" / f"{point.plate}.yaml")
        state = scene.state(point.scene_state if isinstance(point.scene_state, str) else scene.initial_state)
        truth = physics.steady_state(state, scene.electronics, point.generator_frequency_hz,
                                     point.generator_amplitude_vpp, build_pipeline(scene))
        for measured, u, true in ((point.power_w, point.power_w_u, truth.power_w),
                                  (point.velocity_pp_mps, point.velocity_pp_mps_u, truth.velocity_pp_mps)):
            assert math.isfinite(u) and u > 0
            assert abs(measured - true) <= COVERAGE_K * u + UNDITHERED_REL * abs(true) * (bench == "noise_free"), (
                point.step_id, measured, true, u)
        checked += 1
    assert checked >= 6
