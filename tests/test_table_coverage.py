"""The values Tables 3-5 print with a U are scored by the coverage study: each against the
same combination of its points' truths as the table makes of their readings."""

from __future__ import annotations

import pandas as pd
import pytest

from squeezebench.protocols import bench_errors
from squeezebench.protocols.bench_errors import QUANTITIES, TABLE_QUANTITIES, errors_on_bench

from small_quick import HEADER, small_quick

#: One cut length measured by two runs: Table 3's 75 mm row is the mean of two points, each
#: with a search of its own.
TWICE_CUT = HEADER + "".join(f"""
  - name: cutting_{name}
    protocol: resonator_cutting
    plate: {{n_powered_columns: 1, n_powered_piezos: 4}}
    parameters:
      piezo_voltage_vpp: 20
      search: {{start_hz: 36000, stop_hz: 38500, points: 4, tolerance_hz: 50}}
      lengths:
        - {{plate_length_mm: 75, state: 75x41, n_antinodes: 9}}
""" for name in ("first", "second"))


@pytest.fixture(scope="module")
def ideal_bench(tmp_path_factory):
    """The campaign on a bench without systematic errors (its noise only), the plates as
    designed: Table 3's row of two points scored beside the points themselves."""
    folder = tmp_path_factory.mktemp("twice_cut")
    campaign = folder / "twice_cut.yaml"
    campaign.write_text(TWICE_CUT)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(bench_errors, "systematic_effects", lambda *args, **kwargs: [])
        return errors_on_bench(campaign, 1, folder / "bench", quantities=(*QUANTITIES, *TABLE_QUANTITIES))


def test_a_table_row_is_scored_against_the_mean_of_its_points_truths(ideal_bench):
    rows = ideal_bench[ideal_bench["quantity"].isin(TABLE_QUANTITIES)].set_index("quantity")
    # one item (75 mm), each quantity Table 3 prints with a U once (the number of antinodes is a setting)
    assert sorted(rows.index) == ["table_frequency_hz", "table_power_w", "table_velocity_pp_mps", "table_voltage_vpp"]
    for quantity in ("power_w", "velocity_pp_mps"):
        # each run's point at the cut (its search's own point before it is scored too)
        points = ideal_bench[(ideal_bench["quantity"] == quantity)
                             & (ideal_bench["point_index"] == rows.loc[f"table_{quantity}", "point_index"])]
        assert len(points) == 2 and set(points["run_name"]) == {"cutting_first", "cutting_second"}
        assert rows.loc[f"table_{quantity}", "true_value"] == pytest.approx(points["true_value"].mean(), rel=1e-12)
        assert rows.loc[f"table_{quantity}", "measured_value"] == pytest.approx(points["measured_value"].mean(),
                                                                                rel=1e-12)
    # the generator at the voltage's setting drives the ideal piezos with it (the output's 20 Vpp)
    assert rows.loc["table_voltage_vpp", "true_value"] == pytest.approx(20.0, rel=0.02)
    # the plate at rest: its resonance where the scene puts the 75 mm cut, found to a fraction of a hertz
    assert rows.loc["table_frequency_hz", "true_value"] == pytest.approx(37160.0, abs=1.0)


def test_an_ideal_bench_leaves_a_table_row_its_noise_alone(ideal_bench):
    """Without systematic errors what a row misses by is its points' noise (4 averages,
    two points) and the search's fit: a small part of U, which holds the instruments'
    specifications too."""
    rows = ideal_bench[ideal_bench["quantity"].isin(TABLE_QUANTITIES)]
    assert rows["covered"].all()
    assert (rows["rel_error"].abs() < 0.2 * rows["rel_expanded_u"]).all()
    frequency = rows[rows["quantity"] == "table_frequency_hz"].iloc[0]
    assert abs(frequency["measured_value"] - frequency["true_value"]) < 0.2


def test_a_resumed_study_runs_again_a_bench_stored_before_the_tables_were_scored(tmp_path, monkeypatch):
    """`--resume` keeps a bench of the same campaign scored for the same quantities; one
    stored before the tables' values were scored (no `scored` column) is run again, so
    every bench of the table has their rows."""
    from squeezebench.protocols.bench_errors import run_coverage_study

    ran = []

    def scored_bench(campaign_file, seed, error_model="specified", quantities=(), draw_plates=False):
        ran.append(seed)
        return pd.DataFrame({"quantity": ["table_power_w"], "covered": [True], "bench_seed": [seed]}), 1.0

    monkeypatch.setattr(bench_errors, "_errors_on_fresh_bench", scored_bench)
    campaign = small_quick(tmp_path / "campaign")
    path = run_coverage_study(tmp_path, 2, campaign)
    older = path.parent / "bench_1.parquet"
    pd.read_parquet(older).drop(columns="scored").to_parquet(older)
    ran.clear()
    run_coverage_study(tmp_path, 2, campaign, resume=True)
    assert ran == [1]
    assert set(pd.read_parquet(older)["scored"]) == {",".join(bench_errors.COVERAGE_QUANTITIES)}


def test_the_generators_error_moves_the_searchs_setting_not_the_drive_the_scope_reads(tmp_path, monkeypatch):
    """A generator 20 ppm off (its limit, alone): the search's setting is off the cold plate
    by those 20 ppm, which its budget holds; the table's frequency is the scope's fit of the
    drive, which sits on the resonance whatever the setting reads, so its U takes the
    search's budget without that term (`tables._placement`) and still holds it."""
    from squeezebench.analysis import tables
    from squeezebench.analysis.rundata import load_run
    from squeezebench.protocols.variants import systematic_effects

    campaign = tmp_path / "twice_cut.yaml"
    campaign.write_text(TWICE_CUT)
    monkeypatch.setattr(bench_errors, "systematic_effects", lambda *args, **kwargs: systematic_effects(
        1, draw=False, only=("generator_frequency_error",)))
    frame = errors_on_bench(campaign, 1, tmp_path / "bench", quantities=("resonance_frequency_hz", *TABLE_QUANTITIES))
    searches = frame[frame["quantity"] == "resonance_frequency_hz"]
    assert searches["rel_error"].to_numpy() == pytest.approx(-20e-6, abs=2e-6)
    table = frame[frame["quantity"] == "table_frequency_hz"].iloc[0]
    # the records' fit (0.18 Hz each, 10 periods) where the setting is 0.74 Hz off
    assert abs(table["measured_value"] - table["true_value"]) < 0.5 and table["covered"]
    for _, budget in tables._search_budgets(load_run(tmp_path / "bench" / "run")).items():
        kept = {term.name for term in tables._placement(budget).terms}
        assert kept == {term.name for term in budget.terms} - {"generator frequency"}
        assert "generator frequency" in {term.name for term in budget.terms}
