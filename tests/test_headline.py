"""The lines a person reads first: a value the run was given is a round trip, never an
agreement; physics is set against print; each printed number the run does not return is
said with its reason."""

from __future__ import annotations

import math

import pandas as pd

from squeezebench.report.headline import Line, headline, opening, verdicts
from squeezebench.analysis.tables import ROUND_TRIP, finish_table


def _table(rows):
    columns = ["table", "item", "quantity", "value", "expanded_uncertainty", "paper_value", "relative_difference",
               "agrees", "origin", "calibrated_on", "status"]
    return finish_table(pd.DataFrame([(*row, "measured") for row in rows], columns=columns))


TABLES = {
    "table3": _table([
        ("table3", 75, "n_antinodes", 9.0, 0.0, 9.0, 0.0, True, "campaign setting", None),
        ("table3", 75, "frequency_hz", 37158.5, 11.0, 37160.0, -4e-5, True, "calibration input", "scene: f = 37160"),
        ("table3", 59, "power_w", 0.02323, 0.0011, 0.023, 0.01, True, "measured", None),
        ("table3", 28, "power_w", math.nan, math.nan, math.nan, math.nan, None, "measured", None),   # not compared
    ]),
    "table5": _table([
        ("table5", "measured", "q", 1.4796, 0.2, 1.48, -3e-4, True, "derived", "large.yaml: power_w = 1.3"),
        ("table5", "estimated", "tan_theta", -0.052, 0.006, -1.3, 0.96, False, "derived", "small.yaml: tan_theta = -1.25"),
        ("table5", "estimated", "q", 0.755, 0.1, 1.51, -0.50, False, "derived", "small.yaml: q = 2.34"),
    ]),
}


def test_a_value_the_run_was_given_that_comes_back_is_a_round_trip_in_the_table_itself():
    """The CSV a pandas user reads: `agrees` empty and status 'round_trip', so summing
    `agrees` never counts a round trip as an agreement."""
    table3 = TABLES["table3"].set_index(["item", "quantity"])
    assert table3.loc[(75, "frequency_hz"), "status"] == ROUND_TRIP and pd.isna(table3.loc[(75, "frequency_hz"), "agrees"])
    assert table3.loc[(75, "n_antinodes"), "status"] == ROUND_TRIP
    assert table3.loc[(59, "power_w"), "status"] == "measured" and table3.loc[(59, "power_w"), "agrees"]
    assert int(TABLES["table3"]["agrees"].sum()) == 1
    missed = TABLES["table5"].set_index(["item", "quantity"]).loc[("estimated", "q")]
    assert missed["status"] == "measured" and not missed["agrees"]   # given inputs, and it misses: a finding


def test_inputs_and_what_is_derived_from_them_are_round_trips_when_they_come_back():
    found = verdicts(TABLES).set_index(["table", "item", "quantity"])["verdict"]
    assert found[("Table 3", 75, "n_antinodes")] == "round trip"
    assert found[("Table 3", 75, "frequency_hz")] == "round trip"
    assert found[("Table 3", 59, "power_w")] == "agrees"
    assert found[("Table 5", "measured", "q")] == "round trip"
    assert found[("Table 5", "estimated", "tan_theta")] == "disagrees"   # derived, and it misses
    assert len(found) == 6


def test_the_chain_is_one_sentence_not_a_count_of_agreements():
    lines = headline("simulated", 1111, 8, TABLES)
    assert lines[0] == "Dry run on the simulated bench: 1111 stored points from 8 campaign runs."
    assert lines[1].startswith("The chain is verified: every printed value this run was given comes back within "
                               "its U (3 round trips")
    assert lines[2] == "1 value this run measured agrees with print within U."
    assert not any("agree" in line for line in lines[3:])


def test_each_printed_number_not_returned_has_a_line_with_the_tables_rounding_and_its_reason():
    reason = Line("Table 5 estimated Q: printed 1.51, this run 0.76 ± 0.10; Eq. 29 says so.", "#audit-x", "miss")
    lines = opening("simulated", 9, 1, TABLES, reasons={("table5", "estimated", "q"): reason})
    misses = [line for line in lines if line.kind == "miss"]
    assert [line.text for line in lines if line.kind == "misses"] == ["2 printed numbers this run does not return:"]
    assert misses[0].text == "Table 5 estimated tan θ′: printed −1.3, this run −0.0520 ± 0.0060 (+96.0 %)."
    assert misses[1] == reason   # the report's reason, linked
    assert headline("simulated", 9, 1, TABLES)[-1].startswith("- Table 5 estimated Q: printed 1.51")


def test_a_miss_of_the_opposite_sign_is_said_to_be_with_the_tables_rounding():
    """Under the physical reading Table 5's Q comes out negative: −1061 %, as the table rounds it."""
    flipped = {"table5": _table([("table5", "measured", "q", -14.2, 2.0, 1.48, -10.607, False, "derived", "")])}
    assert "- Table 5 measured Q: printed 1.48, this run −14.2 ± 2.0 (−1061 %, the opposite sign)." \
        in headline("simulated", 9, 1, flipped)
    assert not any("opposite" in line for line in headline("simulated", 1111, 8, TABLES))


def test_physics_against_print_within_u_or_not():
    deviation = pd.Series([0.002, -0.023, 0.096, 0.034])
    printed = pd.Series([43792.0, 44810.0, 35130.0, 37160.0])
    predicted = pd.DataFrame({"printed_frequency_hz": printed, "predicted_frequency_hz": printed * (1 + deviation),
                              "predicted_frequency_u_hz": printed * 0.05,   # U 5 %: the 9.6 % miss is beyond it
                              "printed_power_w": [0.1, 0.1, 0.1, math.nan],
                              "predicted_power_w": [0.1, 0.05, 0.3, 0.2], "predicted_power_u_w": [0.02] * 4})
    line = next(line for line in opening("simulated", 1, 1, {**TABLES, "predicted": predicted}) if line.kind == "physics")
    assert ("resonance frequency 3 of 4 plates (worst +9.6 %, U up to 5.1 %); power 1 of 3 (worst +200 %, "
            "U up to 40.0 %)") in line.text
    assert line.href == "#predicted"
    # a run that measured none of the paper's plates (a map alone) is not told about them
    assert not any(line.kind == "physics" for line in opening("simulated", 1, 1, {"predicted": predicted}))


def test_a_map_is_read_in_um_pp_against_the_haptics_criterion_with_the_tables_rounding():
    from squeezebench.report.headline import map_lines

    maps = pd.DataFrame([{"run_name": "fig7", "n_touch_points": 350, "mean_velocity_pp_mps": 0.09824,
                          "mean_velocity_pp_mps_U": 0.00254, "mean_amplitude_pp_m": 2.984e-7,
                          "mean_amplitude_pp_m_U": 7.7e-9, "criterion_amplitude_pp_m": 1e-6,
                          "piezo_voltage_vpp": 20.0, "voltage_for_criterion_vpp": 67.02,
                          "coefficient_of_variation": 0.497040, "coefficient_of_variation_U": 1.6e-5,
                          "coefficient_of_variation_grid_correction": -0.01226, "width_uniformity": 0.9412}])
    text = map_lines(maps)[0].text
    assert "0.2984 ± 0.0077 µm pp at 20 V pp, below the 1 µm pp a fingertip needs (about 67 V pp reaches it)" in text
    assert "94.1% uniform" in text
    # the CV is given as corrected for where the grid fell, by how much, and what the points alone read
    assert ("coefficient of variation 49.7040 ± 0.0016 % (corrected by −1.23 points for where the grid fell on the "
            "mode; the points alone 50.93 %)") in text


def test_no_number_is_shown_past_six_figures():
    from squeezebench.report.presentation import with_uncertainty

    assert with_uncertainty(45.275888133030989, 3.3e-14) == "45.2759 (U < 0.0001)"
    assert with_uncertainty(9.21847, 0.00067) == "9.21847 ± 0.00067"
    assert with_uncertainty(-14.218, 2.04) == "−14.2 ± 2.0"
    assert with_uncertainty(44593.0, 2471.0) == "44600 ± 2500"   # two figures on U, left of the units too


def test_a_tables_cell_gives_u_one_figure_where_two_would_put_its_value_past_six():
    """A 37 kHz resonance read to 0.77 Hz: "37160.0 ± 0.8" (GUM 7.2.6 allows one figure on U),
    not seven figures; where two keep the value within six, two."""
    from squeezebench.report.presentation import cell

    def run_text(value: float, u: float, quantity: str = "frequency_hz") -> str:
        row = pd.Series({"quantity": quantity, "status": "measured", "value": value, "expanded_uncertainty": u})
        return cell(row, None).split("<div class='run'>")[1].split("</div>")[0]

    assert run_text(37160.004, 0.77) == "37160.0 ± 0.8"
    assert run_text(37160.004, 1.5) == "37160.0 ± 1.5"
    assert run_text(4716.0, 0.77) == "4716.00 ± 0.77"
    assert run_text(0.0312, 0.0011, "power_w") == "31.2 ± 1.1"   # in mW


def test_a_u_past_its_value_is_shown_as_a_factor_range_never_as_value_plus_minus_u():
    """"56 +- 70 Vpp" would hold zero and negative voltages: a U at least the value is the
    log-normal k-interval value / F to value F, F = 1 + U / value; below it, value +- U."""
    from squeezebench.report.presentation import with_uncertainty, with_uncertainty_or_range

    assert with_uncertainty_or_range(56.0, 70.0, unit="Vpp") == "56 Vpp (×/÷ 2.2: 25 to 130 Vpp)"
    assert with_uncertainty_or_range(45.2, 212.0) == "45 (×/÷ 5.7: 7.9 to 260)"
    assert with_uncertainty_or_range(56.0, 20.0) == with_uncertainty(56.0, 20.0) == "56 ± 20"
    assert with_uncertainty_or_range(-3.0, 5.0) == with_uncertainty(-3.0, 5.0)   # a signed value keeps +- U


def test_the_paper_tables_physics_cell_shows_a_u_past_its_value_as_a_range_in_display_units():
    """Table 3's power cell: the model's 0.15 W with a U of 3.6 W (its drive term) reads as a
    factor range in mW, never "150 ± 3600"; a U below the value keeps its ± form."""
    from squeezebench.report.presentation import _physics

    wide = _physics(pd.Series({"predicted_value": 0.15, "predicted_expanded_uncertainty": 3.6}), "power_w", None)
    assert "150 (×/÷ 25: 6.0 to 3800)" in wide and "±" not in wide
    narrow = _physics(pd.Series({"predicted_value": 0.15, "predicted_expanded_uncertainty": 0.03}), "power_w", None)
    assert "150 ± 30" in narrow


def test_the_figures_physics_band_never_reaches_below_zero_where_u_passes_the_value():
    """Fig. 9's band with U 24 times the power (its drive term): y / F to y F, F = 1 + U / y, as
    the cells write it, not y - U (negative watts); with U below the value, y - U to y + U."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from squeezebench.report.figures import _physics_band

    x = np.array([0.0, 400.0, 1600.0])
    for rel_u, low in ((24.0, 1 / 25), (0.5, 0.5)):
        fig, ax = plt.subplots()
        y = 1e-3 * x
        _physics_band(ax, x, y, rel_u * y, "physics")
        band = ax.collections[0].get_paths()[0].vertices
        plt.close(fig)
        at_end = band[np.isclose(band[:, 0], 1600.0), 1]
        assert band[:, 1].min() >= 0.0
        assert np.allclose(np.unique(np.round(at_end, 12)), [1.6 * low, 1.6 * (1 + rel_u)])


def test_a_run_without_paper_tables_says_only_what_ran_in_the_singular():
    assert headline("real", 1, 1, {}) == ["Measured on a real bench: 1 stored point from 1 campaign run."]


def test_powers_resting_on_an_unmeasured_delay_are_said():
    lines = headline("real", 12, 1, {}, needs_deskew=2)
    assert len(lines) == 2 and lines[1].startswith("2 stored powers have a U mostly the current probe's delay bound")
    assert "--write FILE" in lines[1] and "`" not in lines[1]   # no markdown in a sentence


def test_values_read_on_predicted_plates_are_said_to_be():
    predicted = {"table4": _table([("table4", "1-column", "power_w", 0.036, 0.01, 0.115, -0.69, False, "predicted", None),
                                   ("table4", "1-column", "frequency_hz", 43813, 20, 43792, 0.0005, True, "predicted", None)])}
    lines = headline("simulated", 40, 1, predicted)
    assert "1 value this run measured agrees with print within U, 1 of them on plates the model predicted" in lines[1]
    assert lines[2] == "1 printed number this run does not return:"
