"""Every "within U" verdict is "in the interval shown" (`predicted_plates.within_expanded_interval`):
value - U to value + U, or the factor interval value / F to value F (F = 1 + U / value) where U
reaches a positive value. Each verdict is tested on a truth between value - U and value / F,
which |truth - value| <= U (the rule before) calls within and the page's interval does not."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from uncertainties import ufloat

from squeezebench.plates import predicted_plates
from squeezebench.plates.predicted_plates import expanded_interval, interval_reach, within_expanded_interval

#: U 30 past the value 10: F = 4, the interval 2.5 to 40; 1 lies within 10 +- 30, not within the interval.
VALUE, U, BELOW_FACTOR_END = 10.0, 30.0, 1.0

finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False)
positive = st.floats(min_value=1e-6, max_value=1e6)
uncertainty = st.floats(min_value=0.0, max_value=1e6)


def test_closed_form_cases():
    assert within_expanded_interval(12.0, 10.0, 2.0) and within_expanded_interval(8.0, 10.0, 2.0)   # ends held
    assert not within_expanded_interval(12.5, 10.0, 2.0) and not within_expanded_interval(7.5, 10.0, 2.0)
    # U = value: the factor interval 5 to 20 (F = 2), not 0 to 20
    assert within_expanded_interval(5.0, 10.0, 10.0) and not within_expanded_interval(4.9, 10.0, 10.0)
    assert within_expanded_interval(20.0, 10.0, 10.0) and not within_expanded_interval(20.1, 10.0, 10.0)
    assert not within_expanded_interval(BELOW_FACTOR_END, VALUE, U) and abs(BELOW_FACTOR_END - VALUE) <= U
    assert within_expanded_interval(2.5, VALUE, U) and within_expanded_interval(40.0, VALUE, U)
    # a signed value keeps value +- U: -3 +- 5 holds 1 and -8
    assert within_expanded_interval(1.0, -3.0, 5.0) and within_expanded_interval(-8.0, -3.0, 5.0)
    assert within_expanded_interval(0.0, 0.0, 0.0) and not within_expanded_interval(0.1, 0.0, 0.0)
    assert not within_expanded_interval(math.nan, 1.0, 1.0) and not within_expanded_interval(1.0, math.nan, 1.0)
    assert isinstance(within_expanded_interval(1.0, 1.0, 0.5), bool)
    np.testing.assert_array_equal(within_expanded_interval([1.0, 2.5, 41.0], VALUE, U), [False, True, False])


@settings(max_examples=300, deadline=None)
@given(truth=finite, value=finite, u=uncertainty)
def test_the_verdict_is_the_interval_expanded_interval_returns(truth, value, u):
    low, high = expanded_interval(value, u)
    assert within_expanded_interval(truth, value, u) == bool(low <= truth <= high)


@settings(max_examples=300, deadline=None)
@given(truth=finite, value=finite, u=uncertainty)
def test_below_the_value_or_signed_it_is_value_plus_minus_u(truth, value, u):
    """Where U is below the value (or the value is not positive), the verdict is |truth - value|
    <= U, away from the ends, where rounding may decide either way."""
    assume(u < value or value <= 0)
    assume(abs(abs(truth - value) - u) > 1e-9 * (abs(value) + u + 1.0))
    assert within_expanded_interval(truth, value, u) == (abs(truth - value) <= u)


@settings(max_examples=300, deadline=None)
@given(value=positive, excess=st.floats(min_value=0.0, max_value=1e3), ratio=st.floats(min_value=1e-3, max_value=1e3))
def test_past_the_value_the_interval_is_symmetric_in_the_logarithm(value, excess, ratio):
    """U >= value: value / F to value F, so a truth value r is held exactly when value / r is
    (away from the ends)."""
    u = value * (1.0 + excess)
    factor = 1.0 + u / value
    assume(abs(abs(math.log(ratio)) - math.log(factor)) > 1e-9)
    inside = abs(math.log(ratio)) < math.log(factor)
    assert within_expanded_interval(value * ratio, value, u) == inside == within_expanded_interval(value / ratio, value, u)


def _physics(value: float, u: float):
    point = SimpleNamespace(values={"frequency_hz": 40e3, "voltage_vpp": value, "power_w": 1.0})
    return SimpleNamespace(nominal=point, expanded={"frequency_hz": 1.0, "voltage_vpp": u, "power_w": 0.1})


def test_the_design_comparison_judges_the_factor_interval():
    from squeezebench.designing.answer import comparison

    frame = comparison(_physics(VALUE, U), None, None, {"voltage_vpp": BELOW_FACTOR_END, "power_w": 1.05})
    within = frame.set_index("quantity")["within_u"]
    assert within["voltage_vpp"] is False and within["power_w"] is True
    inside = comparison(_physics(VALUE, U), None, None, {"voltage_vpp": 3.0})
    assert inside.set_index("quantity").at["voltage_vpp", "within_u"] is True


def test_the_design_comparison_with_a_measured_reference_takes_the_combined_u():
    """A measured reference carries its own U: the interval of value and hypot(U, U_ref),
    here hypot(30, 40) = 50, F = 6, 10 / 6 to 60."""
    from squeezebench.designing.answer import Measured, comparison

    def measured(voltage):
        return Measured("strip", 40e3, ufloat(voltage, 20.0), ufloat(1.0, 0.01), "measured")
    within = {v: comparison(_physics(VALUE, U), None, measured(v)).set_index("quantity").at["voltage_vpp", "within_u"]
              for v in (1.5, 1.7, 60.0, 60.5)}
    assert within == {1.5: False, 1.7: True, 60.0: True, 60.5: False}


def test_the_placement_curves_edge_gaps_within_u_are_those_whose_interval_holds_the_voltage():
    from squeezebench.report.design_report import edge_gaps_within_u

    curve = pd.DataFrame({"edge_gap_mm": [1.0, 2.0, 3.0, 4.0], "voltage_vpp": [VALUE, VALUE, 2.0, 50.0],
                          "voltage_expanded_uncertainty": [U, 5.0, 0.5, 1.0]})
    # 1 mm: 1 Vpp within 10 +- 30 but below 10 / 4; 3 mm: 2 +- 0.5 holds 1.5, not 1
    assert edge_gaps_within_u(curve, BELOW_FACTOR_END) == []
    assert edge_gaps_within_u(curve, 3.0) == [1.0]
    assert edge_gaps_within_u(curve, 2.4) == [3.0]
    assert edge_gaps_within_u(curve, 6.0) == [1.0, 2.0]


def test_the_transfer_studys_covered_is_the_factor_interval():
    from squeezebench.designing import transfer

    build = SimpleNamespace(seed=300, thickness_mm=1.5, mechanical_q=400.0, large_length_mm=200.0)

    def row(measured_w):
        return transfer._row(build, "physics (a)", VALUE, U, SimpleNamespace(power_w=ufloat(measured_w, 1e-6)))
    assert row(BELOW_FACTOR_END)["covered"] is False and row(3.0)["covered"] is True


def _plates(predicted: float, u: float, printed: float) -> pd.DataFrame:
    return pd.DataFrame([{
        "table": build, "item": "75", "predicted_frequency_hz": 40e3, "predicted_frequency_u_hz": 1e3,
        "printed_frequency_hz": 40.2e3, "predicted_velocity_pp_mps": 0.2, "predicted_velocity_u_pp_mps": 0.05,
        "printed_velocity_pp_mps": 0.21, "predicted_power_w": predicted, "predicted_power_u_w": u,
        "printed_power_w": printed, "predicted_power_at_printed_velocity_w": 0.03,
        "predicted_power_at_printed_velocity_u_w": 0.01} for build in predicted_plates.DRIVE_BUILDS])


def test_the_studys_design_rows_are_covered_by_the_factor_interval(monkeypatch):
    from squeezebench.analysis import study

    monkeypatch.setattr(predicted_plates, "predictions", lambda: _plates(VALUE, U, BELOW_FACTOR_END))
    rows = study.design_coverage_points().set_index(["run_name", "quantity"])["covered"]
    assert not rows.xs("predicted_power_w", level="quantity").any()
    assert rows.xs("predicted_frequency_hz", level="quantity").all()
    monkeypatch.setattr(predicted_plates, "predictions", lambda: _plates(VALUE, U, 3.0))
    assert study.design_coverage_points().set_index("quantity").loc["predicted_power_w", "covered"].all()


def test_the_headlines_physics_count_is_the_factor_interval():
    from squeezebench.report.headline import _physics_line

    def count(printed_w):
        line = _physics_line(_plates(VALUE, U, printed_w).iloc[:1])
        return line.text.split("; power ")[1].split(" (")[0]
    assert count(BELOW_FACTOR_END) == "0 of 1" and count(3.0) == "1 of 1"


def test_interval_reach_closed_forms():
    assert interval_reach(12.0, 10.0, 2.0) == pytest.approx(1.0) and interval_reach(9.0, 10.0, 2.0) == pytest.approx(0.5)
    assert interval_reach(40.0, VALUE, U) == pytest.approx(1.0) and interval_reach(2.5, VALUE, U) == pytest.approx(1.0)
    assert interval_reach(-8.0, -3.0, 5.0) == pytest.approx(1.0)
    assert list(interval_reach(np.array([11.0, 7.0]), 10.0, 2.0)) == pytest.approx([0.5, 1.5])


@given(truth=finite, value=finite, u=uncertainty)
@settings(max_examples=300)
def test_interval_reach_is_past_one_exactly_outside_the_interval(truth, value, u):
    low, high = expanded_interval(value, u)
    # away from the ends, where the two sides of a rounding error could disagree
    assume(u > 1e-9 and min(abs(truth - low), abs(truth - high)) > 1e-9 * max(1.0, abs(value), u))
    assert (interval_reach(truth, value, u) <= 1.0) == within_expanded_interval(truth, value, u)


def test_the_drive_cross_check_counts_the_factor_interval(monkeypatch):
    form = {"u_force_factor_ln": 0.5, "u_q_ln": 0.3, "u_power_ln": 0.9}
    monkeypatch.setattr(predicted_plates, "drive_model_form", lambda fit_on: form)
    monkeypatch.setattr(predicted_plates, "predictions", lambda fit_on: _plates(VALUE, U, BELOW_FACTOR_END))
    check = predicted_plates.drive_cross_check()
    assert (check["power_covered"] == 0).all() and (check["power_scored"] == 1).all()
    # |error| / U is 0.3, yet the truth is outside: the reach is (10 - 1) / (10 - 2.5) = 1.2, past 1 as a miss is
    assert check["power_max_error_over_u"].to_numpy() == pytest.approx(1.2)
    assert (check["velocity_covered"] == 1).all()
    monkeypatch.setattr(predicted_plates, "predictions", lambda fit_on: _plates(VALUE, U, 3.0))
    assert (predicted_plates.drive_cross_check()["power_covered"] == 1).all()


def test_the_frequency_budget_judges_the_frequency_in_hz_not_two_ratios(monkeypatch):
    """100 +- 60 Hz holds 45 Hz; the rule before compared 100 / 45 - 1 (relative to print) with
    60 / 100 (relative to the model) and said no."""
    from squeezebench.plates import frequency_budget, plate_modes

    geometry = SimpleNamespace(thickness_m=1e-3)
    frame = pd.DataFrame([{"item": "75", "printed_frequency_hz": 45.0, "predicted_frequency_hz": 100.0,
                           "predicted_frequency_u_hz": 60.0, "predicted_antinodes": 3, "kirchhoff_frequency_hz": 101.0}])
    monkeypatch.setattr(predicted_plates, "predictions", lambda: frame)
    monkeypatch.setattr(predicted_plates, "_predictions", lambda: frame)
    monkeypatch.setattr(predicted_plates, "paper_plates", lambda: [("Table 3", "75", "75", geometry, None, 3)])
    monkeypatch.setattr(plate_modes, "solve_plate", lambda *args, **kwargs: SimpleNamespace(frequencies_hz=[102.0]))
    monkeypatch.setattr(predicted_plates, "mode_with_antinodes", lambda modes, antinodes, near_hz: 0)
    assert frequency_budget.frequency_budget().at[0, "within_U"]
    frame.loc[0, "predicted_frequency_u_hz"] = 54.0
    assert not frequency_budget.frequency_budget().at[0, "within_U"]
