"""The lines a person reads first: a value the run was given never counts as agreement."""

from __future__ import annotations

import pandas as pd

from squeezebench.analysis.headline import headline, verdicts


def _table(rows):
    columns = ["table", "item", "quantity", "paper_value", "relative_difference", "agrees", "origin", "calibrated_on"]
    return pd.DataFrame(rows, columns=columns)


TABLES = {
    "table3": _table([
        ("table3", 75, "n_antinodes", 9.0, 0.0, True, "campaign setting", None),
        ("table3", 75, "frequency_hz", 37160.0, -4e-5, True, "calibration input", "scene: f = 37160"),
        ("table3", 59, "power_w", 0.023, 0.01, True, "measured", None),
        ("table3", 28, "power_w", None, None, None, "measured", None),   # nothing printed: not compared
    ]),
    "table5": _table([
        ("table5", "measured", "q", 1.48, -3e-4, True, "derived", "large.yaml: power_w = 1.3"),
        ("table5", "estimated", "tan_theta", -1.3, 0.96, False, "derived", "small.yaml: tan_theta = -1.25"),
        ("table5", "estimated", "q", 1.51, -0.50, False, "derived", "small.yaml: q = 2.34"),
    ]),
}


def test_inputs_and_what_is_derived_from_them_are_round_trips_when_they_come_back():
    found = verdicts(TABLES).set_index(["table", "item", "quantity"])["verdict"]
    assert found[("Table 3", 75, "n_antinodes")] == "round trip"
    assert found[("Table 3", 75, "frequency_hz")] == "round trip"
    assert found[("Table 3", 59, "power_w")] == "agrees"
    assert found[("Table 5", "measured", "q")] == "round trip"
    assert found[("Table 5", "estimated", "tan_theta")] == "disagrees"   # derived, and it misses
    assert len(found) == 6


def test_a_table_the_run_does_not_hold_counts_nothing():
    """The report writes Tables 3-5 with the printed values and nothing compared (`agrees`
    empty) when the run has no such campaign (a map alone): nothing there agrees."""
    absent = {"table3": _table([("table3", 75, "power_w", 0.027, float("nan"), pd.NA, None, None)])}
    absent["table3"]["agrees"] = absent["table3"]["agrees"].astype("boolean")
    assert verdicts(absent).empty
    assert not any("compared values" in line for line in headline("simulated", 10, 1, absent))


def test_headline_counts_and_names_the_largest_miss():
    deviation = pd.Series([0.002, -0.023, 0.096, 0.034])
    printed = pd.Series([43792.0, 44810.0, 35130.0, 37160.0])
    predicted = pd.DataFrame({"frequency_deviation": deviation, "printed_frequency_hz": printed,
                              "predicted_frequency_hz": printed * (1 + deviation),
                              "predicted_frequency_u_hz": printed * 0.05})   # U 5 %: the 9.6 % miss is beyond it
    lines = headline("simulated", 1111, 8, {**TABLES, "predicted": predicted})
    assert lines[0] == "Dry run on the simulated bench: 1111 stored points from 8 campaign runs."
    assert "of 6 compared values" in lines[1] and "1 agree; 2 disagree" in lines[1]
    assert "Table 5 estimated tan θ′, +96 %" in lines[1] and "3 are round trips" in lines[1]
    assert "2 of 4 printed resonance frequencies within 3 % (worst +9.6 %) and 3 within their U" in lines[2]


def test_a_miss_of_the_opposite_sign_is_said_to_be():
    """Under the physical reading Table 5's Q comes out negative: -1061 % is a sign, said so."""
    flipped = {"table5": _table([("table5", "measured", "q", 1.48, -10.61, False, "derived", None)])}
    assert "(largest: Table 5 measured Q, -1061 %, the sign opposite to print)" in headline("simulated", 9, 1, flipped)[1]
    assert "opposite" not in headline("simulated", 1111, 8, TABLES)[1]


def test_a_run_without_paper_tables_says_only_what_ran():
    assert headline("real", 12, 1, {}) == ["Measured on a real bench: 12 stored points from 1 campaign runs."]


def test_powers_resting_on_an_unmeasured_delay_are_said_first():
    lines = headline("real", 12, 1, {}, needs_deskew=2)
    assert len(lines) == 2 and lines[1].startswith("2 stored powers have a U mostly the current probe's delay bound")
    assert "--write FILE" in lines[1]


def test_values_read_on_predicted_plates_are_said_to_be():
    predicted = {"table4": _table([("table4", "1-column", "power_w", 0.115, -0.69, False, "predicted", None),
                                   ("table4", "1-column", "frequency_hz", 43792, 0.0005, True, "predicted", None)])}
    lines = headline("simulated", 40, 1, predicted)
    assert "1 agree; 1 disagree" in lines[1]
    assert "2 of them read on plates the model predicted (nothing printed in)" in lines[1]
    assert "predicted" not in headline("simulated", 1111, 8, TABLES)[1]
