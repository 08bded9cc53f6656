"""The paper's plates as the model predicts them (plates.predicted_plates): every printed
resonance within its U (k = 2) built from stated tolerances only, antinode counts exact, the
same-sheet ratios, the modes chosen by physics, and no printed result, voltage or frequency
read by a prediction."""
import math

import hypothesis
import hypothesis.strategies as st
import numpy as np
import pandas as pd
import pytest

from squeezebench.plates import frequency_budget, laminate, predicted_plates
from squeezebench.paths import paper_values_dir

#: The paper's stated geometry and build: what a prediction is made from (everything else in
#: data/paper/ is a result, a drive or a reading, and must move no predicted value).
INPUTS = {"resonator_length_mm", "resonator_width_mm", "resonator_thickness_mm", "piezo_width_mm",
          "piezo_length_mm", "piezo_thickness_mm", "n_columns", "n_powered_columns", "piezos_per_column",
          "n_piezos", "n_corner_groups", "n_sensor_piezos"}


@pytest.fixture(scope="module")
def frame():
    return predicted_plates.predictions()


@pytest.fixture(scope="module")
def ratios():
    """The same-sheet ratios, computed once for the tests that read them (each computation
    scans eight beams' transfer matrices: some 20 s)."""
    return frequency_budget.same_sheet_ratios().set_index("ratio")


def test_every_printed_resonance_is_within_its_u_and_u_stays_below_6_percent_but_for_a_cut(frame):
    """U (k = 2) holds every printed resonance; without the cut plates' length term it stays
    <= 6 %. With it (ISO 2768-1 class c, +-0.5 mm on 28 mm: +-3.4 % in frequency at 95 %) the
    28 mm plate's U is 6.5 %: a cut short plate cannot be predicted to 6 % from its nominal length."""
    u_rel = frame["predicted_frequency_u_hz"] / frame["predicted_frequency_hz"]
    assert (frame["frequency_deviation"].abs() <= u_rel).all(), frame[["item", "frequency_deviation"]]
    model = predicted_plates._predictions().set_index("item").loc[frame["item"]]
    cut_k2 = 2 * model["frequency_u_cut_length_rel"].to_numpy() / (0.95 * np.sqrt(3))
    assert (np.sqrt(u_rel.to_numpy() ** 2 - cut_k2**2) <= 0.06).all()
    assert (model.loc[["75", "59", "28"], "cut_length_tolerance_mm"] == [0.8, 0.8, 0.5]).all()
    assert (model.drop(index=["75", "59", "28"])["cut_length_tolerance_mm"] == 0).all()


def test_antinode_counts_are_exact_and_the_large_plates_spacing_is_its_design(frame):
    assert (frame["predicted_antinodes"] == frame["printed_antinodes"]).all()
    large = frame[frame["table"] == "Sec. 5"].iloc[0]
    assert large["predicted_half_wavelength_mm"] == pytest.approx(large["printed_half_wavelength_mm"], rel=0.05)


def test_the_thick_plate_correction_takes_the_large_plate_from_plus_6_percent_to_within_its_u():
    row = predicted_plates._predictions().set_index("item").loc["large_plate"]
    printed = 52400.0
    assert 0.04 < row["kirchhoff_frequency_hz"] / printed - 1 < 0.08   # a thin plate: +5.8 %
    assert abs(row["predicted_frequency_hz"] / printed - 1) < 0.03


def test_f59_over_f75_is_within_2_percent_of_print(ratios):
    assert abs(ratios.loc["f59/f75", "deviation"]) <= 0.02
    # the ratio's printed value is the print's, not the model's
    assert ratios.loc["f59/f75", "printed"] == pytest.approx(37180 / 37160)


def test_the_f28_over_f75_miss_is_mostly_the_bare_plates_and_the_laminates_shear_a_tenth_of_it(ratios):
    f28 = ratios.loc["f28/f75"]
    # the bare plates already miss by +3 %: the model and the closed-form beam alike
    assert f28["bare_plate_deviation"] == pytest.approx(f28["free_free_beam_deviation"], abs=0.002)
    assert 0.025 < f28["bare_plate_deviation"] < 0.035
    # the beam with the column, corrected at the bare plate's as the solver does, tracks the model
    assert f28["beam_with_piezos_deviation"] == pytest.approx(f28["deviation"], abs=0.006)
    # Timoshenko with the laminate's own shear (bond included) and rotary inertia: -0.3 to -0.8 %
    assert -0.008 < f28["thick_laminate_beam_deviation"] - f28["beam_with_piezos_deviation"] < -0.003


@pytest.mark.xfail(strict=True, reason="f28/f75 is +5.1 % off print: +3.0 % of it is the bare plates' length "
                                       "ratio (the model's and the free-free beam's closed form agree to 0.1 %, "
                                       "frequency_budget.same_sheet_ratios), the laminate's own shear and rotary "
                                       "inertia take 0.5 % off, and the column's +2.1 % would need eta near 0.24, a "
                                       "bond far softer than an epoxy's: no modelled piezo or bond term reaches it. "
                                       "The two cuts' lengths (ISO 2768-1 class c, +-0.5 mm on 28, +-0.8 mm on 75) "
                                       "hold +-4.5 % of the ratio at 95 %; the print would need the 28 mm plate cut "
                                       "28.7 mm long (an inference, not an input)")
def test_f28_over_f75_is_within_2_percent_of_print(ratios):
    assert abs(ratios.loc["f28/f75", "deviation"]) <= 0.02


def test_the_cut_lengths_are_a_named_term_of_the_same_sheet_ratios(ratios):
    """Each ratio's cut-length term is the trapezoid of its two cuts (f ~ L^-2), and the cut
    length that would make the model's ratio meet print is stated beside it, +0.7 mm on 28 mm:
    beyond the +-0.5 mm assumed."""
    from squeezebench.plates import specifications
    f28 = ratios.loc["f28/f75"]
    assert f28["cut_length_u_rel"] == pytest.approx(specifications.rectangles_95_half_width(2 * 0.5 / 28, 2 * 0.8 / 75))
    assert f28["cut_length_to_agree_mm"] == pytest.approx(28 * np.sqrt(1 + f28["deviation"]))
    assert 0.5 < f28["cut_length_to_agree_mm"] - 28 < 1.0
    assert abs(f28["deviation"]) > f28["cut_length_u_rel"]


def _rows():
    for path in sorted(paper_values_dir().glob("*.csv")):
        table = pd.read_csv(path, dtype={"item": str, "value": str}, keep_default_na=False)
        for row in table.itertuples():
            if row.quantity not in INPUTS:
                yield path.stem, row.item, row.quantity


def test_changing_any_printed_value_changes_no_predicted_value(monkeypatch):
    """Every printed value (frequencies, antinode counts, powers, velocities, voltages, Q, tan
    theta', ...) moved at once, each by its own factor (so no two moves cancel in a ratio),
    times 1.37 and more, then divided by as much: the per-volt predictions stay bit-identical
    (the plate solves are cached by geometry, so a prediction that read a printed value would
    differ). Two evaluations, not one per printed value: each costs some 0.4 s."""
    reference = predicted_plates._predictions().copy()
    original = predicted_plates.paper_value
    rows = list(_rows())
    assert len(rows) > 60
    read = set()
    try:
        for sign in (1, -1):
            factors = {row: (1.37 + 0.001 * i) ** sign for i, row in enumerate(rows)}

            def moved(*key, factors=factors):
                read.add(key)
                return original(*key) * factors.get(key, 1.0)

            monkeypatch.setattr(predicted_plates, "paper_value", moved)
            predicted_plates._predictions.cache_clear()
            pd.testing.assert_frame_equal(predicted_plates._predictions(), reference, check_exact=True,
                                          obj=f"every printed value moved {'up' if sign > 0 else 'down'}")
        assert read   # the moved values reach the predictions' code: it asks for its inputs through paper_value
    finally:
        predicted_plates._predictions.cache_clear()


def test_the_59_mm_plate_keeps_its_mode_when_its_printed_frequency_moves(monkeypatch):
    """Issue 45's case: with the printed 37180 Hz changed to 31000 Hz the old search jumped to a
    6-antinode mode at 28.4 kHz; the mode is now chosen by physics, not by the printed value."""
    original = predicted_plates.paper_value
    monkeypatch.setattr(predicted_plates, "paper_value", lambda name, item, quantity: 31000.0 if (
        name, item, quantity) == ("table3", "59", "frequency_hz") else original(name, item, quantity))
    predicted_plates._predictions.cache_clear()
    try:
        row = predicted_plates.predictions().set_index("item").loc["59"]
        assert row["predicted_antinodes"] == 7 and row["printed_frequency_hz"] == 31000.0
        assert 36e3 < row["predicted_frequency_hz"] < 39e3
    finally:
        predicted_plates._predictions.cache_clear()


def test_a_stated_mode_sought_in_fewer_modes_is_the_one_the_whole_band_gives(monkeypatch):
    """Started from 2 modes, the search widens (2, 4, 8) until its modes reach past the chosen
    one's distance from the estimate on both sides, and stops short of the whole band of 12
    with the mode that band's solve chooses: the same eigenpair, solved to ARPACK's tolerance."""
    from squeezebench.plates import plate_modes

    geometry = predicted_plates.table4_plate("2-columns 1 powered")
    near = predicted_plates._search_hz(geometry, 9)
    whole = plate_modes.solve_plate(geometry, near_hz=near, band_rel=predicted_plates.SEARCH_BAND_REL)
    k = predicted_plates.mode_with_antinodes(whole, 9, near)
    asked = []
    solve = plate_modes.solve_plate
    monkeypatch.setattr(plate_modes, "solve_plate", lambda g, **options: asked.append(options["n_modes"]) or solve(
        g, **options))
    monkeypatch.setattr(predicted_plates, "FIRST_MODES", 2)
    modes, j = predicted_plates._solve_stated(geometry, 9)
    assert asked == [2, 4, 8] and len(whole.frequencies_hz) == 12
    assert modes.frequencies_hz[j] == pytest.approx(whole.frequencies_hz[k], rel=1e-9)
    assert modes.referred_to(j, 0.038, 0.0205)[0] == pytest.approx(whole.referred_to(k, 0.038, 0.0205)[0], rel=1e-6)
    assert predicted_plates._shows_nearest(modes, j, near) and not predicted_plates._shows_nearest(
        modes, int(np.argmax(modes.frequencies_hz)), near)


def test_the_drive_voltage_only_scales_the_responses(frame):
    per_volt = predicted_plates._predictions().set_index("item")
    for row in frame.itertuples():
        assert row.predicted_velocity_pp_mps == pytest.approx(
            per_volt.loc[row.item, "velocity_pp_mps_per_vpp"] * row.voltage_vpp)
        assert row.predicted_mechanical_power_w == pytest.approx(
            per_volt.loc[row.item, "power_w_per_vpp2"] * row.voltage_vpp**2)


def test_placement_is_in_the_edge_plates_u_and_not_in_the_centred_ones():
    """The edge piezos sit on the first half-wave's curvature maximum (`half_wave_edge_gap_mm`), so
    +-1 mm moves their force factor by a few per cent, not the tens of per cent of 2 +- 2 mm."""
    per_volt = predicted_plates._predictions().set_index("item")
    assert (per_volt.loc[["75", "59", "28"], "force_factor_u_placement_rel"] == 0).all()
    assert (per_volt.loc[["1-column", "large_plate"], "force_factor_u_placement_rel"].between(0.03, 0.15)).all()
    assert (per_volt["velocity_u_rel"] > per_volt["force_factor_u_placement_rel"]).all()


def test_what_would_agree_inverts_the_printed_power_and_velocity():
    """The implied force factor and Q, put back through the model's one-mode response at the
    printed drive, give the printed velocity and power: the gap each input would have to close."""
    agree = predicted_plates.what_would_agree().set_index("item")
    model = predicted_plates._predictions().set_index("item")
    frame = predicted_plates.predictions().set_index("item")
    for item in ("75", "1-column", "2-columns 2 powered"):
        response = predicted_plates.response_per_volt(
            model.loc[item, "predicted_frequency_hz"], model.loc[item, "modal_mass_g"] * 1e-3,
            agree.loc[item, "implied_force_factor_n_per_v"], agree.loc[item, "implied_q"])
        v = frame.loc[item, "voltage_vpp"]
        assert response["velocity_pp_mps_per_vpp"] * v == pytest.approx(frame.loc[item, "printed_velocity_pp_mps"])
        assert response["power_w_per_vpp2"] * v**2 == pytest.approx(frame.loc[item, "printed_power_w"])


def test_the_large_plates_placement_curve_is_the_design_models_own():
    """One placement curve: the report's inference reads `design.placement_rows` on the
    paper's large plate as a design file, the same patches as the predictions' plate."""
    from squeezebench.designing import design, paper_placement

    spec = paper_placement.large_plate_design()
    ours = sorted((p.bounds, p.powered) for p in spec.geometry().patches)
    theirs = sorted((p.bounds, p.powered) for p in predicted_plates.large_plate().patches)
    assert np.allclose([b for b, _ in ours], [b for b, _ in theirs]) and [p for _, p in ours] == [p for _, p in theirs]
    gap = predicted_plates.rule_edge_gap_mm("large")
    curve = paper_placement.large_plate_placement_curve(gaps_mm=(gap,)).iloc[0]
    moved = spec.with_end_groups_at(gap)
    point = design.operating_point(moved, modal=design.modal_part(moved, antinodes=21)).values
    assert curve["voltage_vpp"] == pytest.approx(point["voltage_vpp"])
    assert curve["force_factor_n_per_v"] == pytest.approx(point["force_factor_n_per_v"])
    # the physics Q's voltage for the same amplitude goes as 1 / Q
    assert curve["voltage_vpp_physics_q"] * curve["physics_q"] == pytest.approx(curve["voltage_vpp"] * 310.0)


def test_an_inferred_edge_gap_is_where_the_curve_meets_the_implied_force_factor():
    from squeezebench.designing.paper_placement import implied_edge_gap_mm

    curve = pd.DataFrame({"edge_gap_mm": [0.0, 1.0, 2.0], "force_factor_n_per_v": [0.1, 0.3, 0.7]})
    assert implied_edge_gap_mm(0.5, curve) == pytest.approx(1.5)
    assert implied_edge_gap_mm(0.9, curve) is None


def test_the_responses_u_is_the_propagation_of_its_tolerances_with_a_triangular_sheet():
    """The frequency's closed-form U against a Monte Carlo of f ~ h sqrt(E / rho), the sheet's
    thickness triangular within EN 485-4's limit, the alloy's E and rho rectangular."""
    rng = np.random.default_rng(5)
    t = laminate.relative_tolerances(1e-3)
    h = 1 + rng.triangular(-t["thickness_m"], 0, t["thickness_m"], 400_000)
    e = 1 + rng.uniform(-t["young_pa"], t["young_pa"], 400_000)
    rho = 1 + rng.uniform(-t["density_kg_m3"], t["density_kg_m3"], 400_000)
    assert 2 * np.std(h * np.sqrt(e / rho)) == pytest.approx(predicted_plates.frequency_relative_u(1e-3), rel=0.02)


def test_the_large_plates_voltage_is_its_factors_beside_the_review():
    """At 4 mm from the edges (issue 45's review: 1.10 N/V, 81.4 g): our voltage over the
    review's is exactly mass x force factor x Q x convention; the patches' own stiffness and the
    epoxy's shear lag each raise M / A (no factor of the model is the review's bare beam)."""
    from squeezebench.designing.paper_placement import voltage_decomposition
    row = voltage_decomposition((4.0,)).iloc[0]
    product = row["mass_factor"] * row["force_factor_factor"] * row["q_factor"] * row["convention_factor"]
    assert row["voltage_ratio"] == pytest.approx(product, rel=1e-12)
    assert row["design_q"] == predicted_plates.MECHANICAL_Q and row["convention_factor"] == 1.0
    assert row["stiffening_factor"] > 1.1 and row["bond_moment_share"] < 0.8
    # the review's 4 mm force factor is the bare-mode beam's with a rigid bond, to a few per cent
    assert row["review_force_factor_n_per_v"] == pytest.approx(row["beam_force_factor_rigid_n_per_v"], rel=0.05)


def test_the_predicted_power_is_the_mechanical_plus_the_piezos_dielectric_loss(frame):
    """The printed power is the electrical input (Sec. 2.1), so the prediction adds the powered
    piezos' dielectric loss w C V0^2 tan(delta) / 2 (V0 = Vpp / 2) to the mechanical power."""
    per_volt = predicted_plates._predictions().set_index("item")
    for row in frame.itertuples():
        c = per_volt.loc[row.item, "clamped_capacitance_f"]
        dielectric = 2 * math.pi * row.predicted_frequency_hz * c * (row.voltage_vpp / 2) ** 2 * 0.004 / 2
        assert row.predicted_dielectric_power_w == pytest.approx(dielectric)
        assert row.predicted_power_w == pytest.approx(row.predicted_mechanical_power_w + dielectric)
        assert dielectric < 0.01 * row.printed_power_w   # Sec. 2.2: negligible at these voltages


def test_the_drive_mismatch_moves_the_models_force_factor_and_q_onto_the_printed_velocity_and_power(frame):
    """Scaling the model's force factor by exp(ln_force_factor_ratio) and its Q by
    exp(ln_q_ratio) in v = A V Q / (w M), P = A^2 V^2 Q / (2 w M) gives the printed velocity and
    the printed power less the dielectric loss."""
    mismatch = predicted_plates.drive_mismatch().set_index("item")
    model = predicted_plates._predictions().set_index("item")
    for row in frame.itertuples():
        a, q = (math.exp(mismatch.loc[row.item, name]) for name in ("ln_force_factor_ratio", "ln_q_ratio"))
        response = predicted_plates.response_per_volt(row.predicted_frequency_hz, model.loc[row.item, "modal_mass_g"] * 1e-3,
                                                      model.loc[row.item, "force_factor_n_per_v"] * a,
                                                      predicted_plates.MECHANICAL_Q * q)
        velocity = predicted_plates.printed_velocity_pp_mps(row.table, row.item, row.predicted_frequency_hz)
        assert response["velocity_pp_mps_per_vpp"] * row.voltage_vpp == pytest.approx(velocity)
        assert response["power_w_per_vpp2"] * row.voltage_vpp**2 == pytest.approx(
            row.printed_power_w - row.predicted_dielectric_power_w)


def test_the_drive_term_is_the_second_moments_of_its_build_and_propagates_as_a_power_law(monkeypatch):
    """Sized on a build whose plates miss by (a, q) = (ln 2, 0) and (-ln 2, ln 3): the force
    factor's u is ln 2, Q's sqrt(ln^2 3 / 2), and a response A^i Q^j carries
    sqrt(mean((i a + j q)^2)) in its logarithm; another build's rows do not enter."""
    l2, l3 = math.log(2), math.log(3)
    monkeypatch.setattr(predicted_plates, "drive_mismatch", lambda: pd.DataFrame(
        {"table": ["X", "X", "Y"], "item": ["1", "2", "3"], "ln_force_factor_ratio": [l2, -l2, 50.0],
         "ln_q_ratio": [0.0, l3, -50.0]}))
    form = predicted_plates.drive_model_form("X")
    assert form["plates"] == 2
    assert form["u_force_factor_ln"] == pytest.approx(l2)
    assert form["u_q_ln"] == pytest.approx(math.sqrt(l3**2 / 2))
    assert form["u_velocity_ln"] == pytest.approx(math.sqrt((l2**2 + (l3 - l2) ** 2) / 2))
    assert form["u_power_ln"] == pytest.approx(math.sqrt(((2 * l2) ** 2 + (l3 - 2 * l2) ** 2) / 2))
    with pytest.raises(ValueError, match="no paper plate in build 'Z'"):
        predicted_plates.drive_model_form("Z")


@hypothesis.given(u=st.floats(0.0, 3.0), position=st.floats(-1.0, 1.0))
def test_a_log_terms_symmetric_u_holds_every_value_within_its_k_interval_in_ln(u, position):
    """exp(k u) - 1 as a relative U holds any value exp(t k u) times the prediction, |t| <= 1."""
    rel = predicted_plates.log_term_expanded_rel(u)
    assert rel == pytest.approx(math.exp(2 * u) - 1)
    assert abs(math.exp(position * 2 * u) - 1) <= rel * (1 + 1e-12) + 1e-15


def test_the_drive_term_fitted_on_table_3_is_judged_on_the_other_builds():
    """Principle 1: the term sized on Table 3 is judged on Table 4 and the large plate (held
    out), and every build is tried as the fit in turn; the held-out powers are inside U only
    where the term is wide (a build whose force factor and Q misses cancel in its power, Table
    4, sizes a term the large plate falls outside)."""
    check = predicted_plates.drive_cross_check()
    assert set(check["role"]) == {"fitted", "held out"}
    assert len(check) == len(predicted_plates.DRIVE_BUILDS) ** 2
    table3 = check[(check["fitted_on"] == "Table 3") & (check["role"] == "held out")]
    assert (table3["power_covered"] == table3["power_scored"]).all()
    assert (table3["velocity_covered"] == table3["velocity_scored"]).all()
    table4 = check[(check["fitted_on"] == "Table 4") & (check["judged"] == "Sec. 5")].iloc[0]
    assert table4["power_covered"] == 0 and table4["power_max_error_over_u"] > 1.5


def test_the_u_of_a_held_out_build_does_not_read_its_own_printed_values(monkeypatch):
    """Table 4's and the large plate's printed velocities and powers moved: with the term sized on
    Table 3, no predicted value or U moves (only their own printed columns do, and the power at
    the printed velocity, which that velocity sets as the printed voltage sets the others)."""
    reference = predicted_plates.predictions()
    original = predicted_plates.paper_value

    def moved(name, item, quantity):
        value = original(name, item, quantity)
        held_out = name in ("table4", "large_plate") and quantity in ("power_w", "velocity_pp_mps", "amplitude_m")
        return value * 3.1 if held_out else value

    monkeypatch.setattr(predicted_plates, "paper_value", moved)
    frame = predicted_plates.predictions()
    predicted = [c for c in frame.columns if c.startswith("predicted_") and "at_printed_velocity" not in c]
    pd.testing.assert_frame_equal(frame[predicted], reference[predicted])
    assert not frame["printed_power_w"].equals(reference["printed_power_w"])


def test_the_power_at_the_printed_velocity_is_the_modal_resistances_and_carries_no_force_factor(frame):
    """P = (w M / q) v0^2 / 2 + the dielectric loss (v0 = v_pp / 2; the large plate's 1 um read as
    pp), and its U has no d31 or drive term in it: the Q spread, w M and placement, and the
    drive term's Q part."""
    model = predicted_plates._predictions().set_index("item")
    form = predicted_plates.drive_model_form()
    for row in frame.itertuples():
        v0 = predicted_plates.printed_velocity_pp_mps(row.table, row.item, row.predicted_frequency_hz) / 2
        resistance = 2 * math.pi * row.predicted_frequency_hz * model.loc[row.item, "modal_mass_g"] * 1e-3 / 310.0
        assert row.predicted_power_at_printed_velocity_w == pytest.approx(
            resistance * v0**2 / 2 + row.predicted_dielectric_power_w)
        rel = row.predicted_power_at_printed_velocity_u_w / row.predicted_power_at_printed_velocity_w
        assert rel == pytest.approx(math.hypot(model.loc[row.item, "power_at_velocity_u_rel"],
                                               math.expm1(2 * form["u_q_ln"])))
    large = frame.set_index("item").loc["large_plate"]
    assert large.predicted_power_at_printed_velocity_w == pytest.approx(
        2 * math.pi * large.predicted_frequency_hz * model.loc["large_plate", "modal_mass_g"] * 1e-3 / 310.0
        * (math.pi * large.predicted_frequency_hz * 1e-6) ** 2 / 2 + large.predicted_dielectric_power_w)


def test_the_half_wave_rule_puts_the_edge_piezo_where_the_solve_drives_the_mode_best():
    """The edge gap comes from the free-free beam's nodes (closed form), not from any print: on
    Table 4's plate the solve's own first half-wave (the loaded plate's nodal lines) is centred
    within 0.6 mm of the rule's patch centre (the ambiguity its +-1 mm holds), and the solve's
    force factor there is within 5 % of its best over the gaps 0-8 mm, so the +-1 mm moves it
    by a few per cent where 2 +- 2 mm moved it by tens."""
    from squeezebench.designing import paper_placement

    gap = predicted_plates.rule_edge_gap_mm("table4")
    assert gap == predicted_plates.half_wave_edge_gap_mm(76.0, 9, 5.0) == pytest.approx(3.804, abs=1e-3)
    geometry = predicted_plates.table4_plate("1-column")
    assert geometry.patches[0].bounds[0] / predicted_plates.MM == pytest.approx(gap)   # built at the rule's gap
    modes, k = predicted_plates._solve_working(geometry, 9, None)
    lines_mm = modes.nodal_lines_m(k) / predicted_plates.MM
    assert (lines_mm[0] + lines_mm[1]) / 2 == pytest.approx(gap + 2.5, abs=0.6)
    curve = paper_placement.edge_curve("1-column")
    at_rule = predicted_plates.centre_response(geometry, 9)["force_factor_n_per_v"]
    assert at_rule >= 0.95 * curve["force_factor_n_per_v"].max()


@pytest.mark.parametrize("velocity_factor, voltage_factor", [(2.0, 1.0), (1.0, 2.0), (0.5, 2.0)])
def test_a_reading_moves_the_mismatch_as_its_closed_form_says(monkeypatch, velocity_factor, voltage_factor):
    """The docs' reading rows: the mismatch recomputed with the printed velocity and drive scaled
    moves by `drive_candidates.reading_shift` (exactly for the velocity; the drive's dielectric
    share, under 1 % of the printed power, bends it slightly)."""
    from squeezebench.plates import drive_candidates

    before = predicted_plates.drive_mismatch()
    printed, velocity = predicted_plates._printed, predicted_plates.printed_velocity_pp_mps
    monkeypatch.setattr(predicted_plates, "_printed",
                        lambda table, item: printed(table, item) | {"voltage_vpp": printed(table, item)["voltage_vpp"]
                                                                    * voltage_factor})
    monkeypatch.setattr(predicted_plates, "printed_velocity_pp_mps",
                        lambda table, item, f: velocity(table, item, f) * velocity_factor)
    after = predicted_plates.drive_mismatch()
    d_a, d_q = drive_candidates.reading_shift(velocity_factor, voltage_factor)
    moved_a = after["ln_force_factor_ratio"] - before["ln_force_factor_ratio"]
    moved_q = after["ln_q_ratio"] - before["ln_q_ratio"]
    assert np.allclose(moved_a, d_a, atol=0.03) and np.allclose(moved_q, d_q, atol=0.03)
    if voltage_factor == 1.0:
        assert np.allclose(moved_a, d_a, atol=1e-12) and np.allclose(moved_q, d_q, atol=1e-12)


def test_the_candidates_the_docs_quote_a_shared_bond_moves_both_builds_alike_and_the_spot_barely():
    """docs/design.md's solved rows: a rigid or a ten times more compliant bond moves Table 3's and
    Table 4's force-factor mismatch by the same factor within 5 %, so no shared bond parts them;
    reading the velocity 2 mm off the centre moves it under 5 %."""
    from squeezebench.plates import drive_candidates

    frame = drive_candidates.candidates()
    for bond in ("bond rigid", "bond ten times more compliant"):
        shifts = frame.loc[frame["candidate"] == bond, "d_ln_force_factor"].to_numpy()
        assert len(shifts) == 2 and abs(shifts[0] - shifts[1]) < 0.05
    spot = frame[frame["candidate"].str.startswith("velocity read 2 mm")]
    assert (abs(spot["force_factor_ratio_times"] - 1) < 0.05).all()
    readings = frame[frame["candidate"].str.contains("read as amplitude")]
    assert np.allclose(readings["force_factor_ratio_times"], 0.5)
