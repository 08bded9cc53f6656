"""End to end on the simulated bench: the paper campaign, then its report, read at Table 4
(the session's paper run and report, `paper_run` and `paper_report`, which the other
readers of that run share: a second run of its Table 4 and a second report would only
repeat them)."""

from __future__ import annotations

import pandas as pd

TABLE4_RUN = "table4_powered_columns"


def test_table4_campaign_then_report(paper_run, paper_report):
    run_dir, _ = paper_run
    table4 = pd.read_csv(run_dir / "report" / "table4.csv")
    assert set(table4["status"]) == {"round_trip"}   # its scenes replay the printed points
    power = table4[table4["quantity"] == "power_w"]
    # the recomputed power agrees with the scope's MATH mean of the same points
    ratio = power["value"].astype(float) / power["scope_value"].astype(float)
    assert ratio.between(0.9, 1.1).all(), power.to_string()
    # a printed resonance is compared with where the search set the generator: the
    # frequency's U holds each search's own, less the generator's error (the scope's fit reads
    # the drive, which sits on the resonance whatever the setting: `tables._placement`), and
    # the scope's reading beside it
    from squeezebench.analysis import tables
    from squeezebench.analysis.rundata import load_run

    frequency = table4[table4["quantity"] == "frequency_hz"].set_index("item")
    searches = pd.read_csv(run_dir / "report" / "uncertainty_resonances.csv")
    budgets = tables._search_budgets(load_run(run_dir))
    placements = [tables._placement(budgets[(TABLE4_RUN, step)]).expanded_uncertainty
                  for step in searches.loc[searches["run_name"] == TABLE4_RUN, "step_id"]]
    assert len(placements) == len(frequency) == 3   # one search per configuration
    for configuration, search_u_hz in zip(frequency.index, placements):
        assert frequency.loc[configuration, "expanded_uncertainty"] > search_u_hz
