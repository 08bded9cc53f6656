"""End to end on the simulated bench: the paper campaign's Table 4 run, then the report."""

from __future__ import annotations

import pandas as pd
import pytest

from squeezebench.report.run_report import write_report
from squeezebench.protocols.campaign import run_campaign
from squeezebench import paths
from squeezebench.yamlfiles import dump_yaml, load_strict

TABLE4_RUN = "table4_powered_columns"


def test_table4_campaign_then_report(tmp_path):
    campaign = load_strict(paths.paper_campaign().read_text())
    campaign["runs"] = [run for run in campaign["runs"] if run["name"] == TABLE4_RUN]
    if not campaign["runs"]:
        pytest.skip(f"the paper campaign has no run named {TABLE4_RUN}")
    campaign["name"] = "e2e"
    campaign_file = tmp_path / "e2e.yaml"
    campaign_file.write_text(dump_yaml(campaign))
    run_dir = run_campaign(campaign_file, out_dir=tmp_path / "run")
    write_report(run_dir)
    table4 = pd.read_csv(run_dir / "report" / "table4.csv")
    assert set(table4["status"]) == {"round_trip"}   # its scenes replay the printed points
    power = table4[table4["quantity"] == "power_w"]
    # the recomputed power agrees with the scope's MATH mean of the same points
    ratio = power["value"].astype(float) / power["scope_value"].astype(float)
    assert ratio.between(0.9, 1.1).all(), power.to_string()
    # a printed resonance is compared with where the search set the generator: the
    # frequency's U holds each search's own (uncertainty_resonances.csv), not only the scope's
    frequency = table4[table4["quantity"] == "frequency_hz"].set_index("item")
    searches = pd.read_csv(run_dir / "report" / "uncertainty_resonances.csv")
    for configuration, search_u_hz in zip(frequency.index, searches["resonance_frequency_hz_U"]):
        assert frequency.loc[configuration, "expanded_uncertainty"] >= search_u_hz
