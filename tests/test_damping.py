"""Q from the physics of the losses (plates.damping): closed forms, the modal strain energy
weighting, and the fit on one build judged on the others."""
import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from squeezebench.plates import damping, plate_modes, predicted_plates

AL = plate_modes.ALUMINIUM_TABLE2


def test_coincidence_of_aluminium_sheets():
    """f_c h is about 12 Hz m for aluminium (c0^2 / (2 pi) sqrt(12 rho (1 - nu^2) / E))."""
    assert damping.coincidence_frequency_hz(AL, 1e-3) == pytest.approx(12.2e3, rel=0.03)
    assert damping.coincidence_frequency_hz(AL, 2e-3) == pytest.approx(damping.coincidence_frequency_hz(AL, 1e-3) / 2)


@given(f=st.floats(30e3, 80e3), h=st.floats(1e-3, 3e-3))
@settings(max_examples=30, deadline=None, derandomize=True)
def test_radiation_loss_is_the_radiated_over_the_kinetic_power(f, h):
    """Two faces radiating rho0 c0 sigma <v^2> each, over w rho h <v^2>: falls as 1 / (f h)
    well above coincidence, and sigma tends to 1 there."""
    eta = damping.radiation_loss_factor(f, AL, h)
    sigma = damping.radiation_efficiency(f, damping.coincidence_frequency_hz(AL, h))
    assert eta == pytest.approx(2 * 1.204 * 343.2 * sigma / (2 * math.pi * f * 2790.0 * h))
    assert sigma > 1.0
    assert damping.radiation_efficiency(100 * f, damping.coincidence_frequency_hz(AL, h)) == pytest.approx(1, abs=0.01)


def test_radiation_below_coincidence_is_refused():
    with pytest.raises(ValueError, match="below the coincidence"):
        damping.radiation_loss_factor(5e3, AL, 1e-3)


def test_the_papers_1_mm_plate_radiates_a_q_of_several_hundred():
    """About 37 kHz, 1 mm: eta_rad ~ 1.5e-3 (Q ~ 650 from radiation alone)."""
    assert 1 / damping.radiation_loss_factor(37e3, AL, 1e-3) == pytest.approx(650, rel=0.1)


def test_loss_terms_weight_each_mechanism_by_its_strain_energy():
    bare = damping.loss_terms(0.0, 0.0, 40e3, AL, 1e-3, bond_loss_factor=0.05)
    assert bare["piezo"] == bare["bond"] == 0 and bare["aluminium"] == damping.ALUMINIUM_LOSS_FACTOR
    loaded = damping.loss_terms(0.2, 0.5, 40e3, AL, 1e-3, bond_loss_factor=0.05)
    total = 1 + 0.5 * 0.2
    assert loaded["piezo"] == pytest.approx(0.2 / damping.NCE41_MECHANICAL_Q / total)
    assert loaded["bond"] == pytest.approx(0.05 * 0.1 / total)
    assert damping.mechanical_q(loaded) == pytest.approx(1 / sum(loaded.values()))


@given(share=st.floats(0.0, 0.5), eta=st.floats(1e-4, 0.1))
@settings(max_examples=30, deadline=None, derandomize=True)
def test_two_parts_of_equal_loss_give_that_loss(share, eta):
    """Strain-energy weighting: aluminium and ceramic both at eta (Qm = 1/eta), no bond, no
    face losses, give Q = 1/eta whatever the ceramic's share."""
    terms = damping.loss_terms(share, 0.0, 40e3, AL, 1e-3, bond_loss_factor=0.0, piezo_mechanical_q=1 / eta,
                               aluminium_loss_factor=eta, cushion_resistance_pa_s_per_m=0.0)
    assert terms["aluminium"] + terms["piezo"] == pytest.approx(eta)


@given(f=st.floats(30e3, 80e3), h=st.floats(1e-3, 3e-3), resistance=st.floats(100.0, 1e4))
@settings(max_examples=30, deadline=None, derandomize=True)
def test_a_face_resistance_on_a_bare_plate_loses_r_over_w_rho_h(f, h, resistance):
    terms = damping.loss_terms(0.0, 0.0, f, AL, h, bond_loss_factor=0.0, cushion_resistance_pa_s_per_m=resistance)
    assert terms["cushion"] == pytest.approx(resistance / (2 * math.pi * f * 2790.0 * h))


def test_the_two_faced_radiation_q_is_rho_h_w_over_2_rho0_c0_sigma():
    f, h = 52e3, 2e-3
    sigma = damping.radiation_efficiency(f, damping.coincidence_frequency_hz(AL, h))
    assert 1 / damping.radiation_loss_factor(f, AL, h) == pytest.approx(
        2790.0 * h * 2 * math.pi * f / (2 * 1.204 * 343.2 * sigma))
    assert damping.radiation_loss_factor(f, AL, h, faces=1) == pytest.approx(damping.radiation_loss_factor(f, AL, h) / 2)


def test_a_lossless_layer_presents_rho_c_and_loss_raises_it():
    """Re sqrt(rho E (1 + j eta)) = rho c at eta = 0 and rises as sqrt((1 + sqrt(1 + eta^2)) / 2)."""
    assert damping.plane_wave_resistance_pa_s_per_m(30.0, 3e5, 0.0) == pytest.approx(30.0 * math.sqrt(3e5 / 30.0))
    lossy = damping.plane_wave_resistance_pa_s_per_m(30.0, 3e5, 0.5)
    assert lossy == pytest.approx(3000.0 * math.sqrt((1 + math.sqrt(1.25)) / 2))
    assert 1000 < damping.CUSHION_RESISTANCE_PA_S_PER_M < 6300


def test_the_face_integral_of_a_bare_plate_mode_is_one_over_rho_h():
    """Mass normalisation: int rho h phi^2 dA = 1 on a plate without patches."""
    geometry = plate_modes.PlateGeometry(0.04, 0.02, 1e-3)
    modes = plate_modes.solve_plate(geometry, near_hz=40e3)
    k = modes.working_mode(40e3, min_uniformity=0.0)
    assert damping.face_integral_m2_per_kg(modes, k) == pytest.approx(1 / (2790.0 * 1e-3), rel=0.02)


def test_the_solves_face_integral_is_what_the_refined_shape_grid_converges_to():
    """A patched plate's exact int phi^2 dA (the mode's quadratic form with the unit mass
    matrix) is the limit of the shape integrated on ever finer grids (a reduced model's way):
    the trapezoid's error falls as the grid step squared, a quarter per halving."""
    modes = plate_modes.solve_plate(predicted_plates.table3_plate("28"), near_hz=37e3, band_rel=0.3)
    k = modes.working_mode(37e3)
    exact = damping.face_integral_m2_per_kg(modes, k)
    shape_only = dataclasses.replace(modes, face_integral_m2_per_kg=None)
    errors = [damping.face_integral_m2_per_kg(shape_only, k, refine) / exact - 1 for refine in (4, 8)]
    assert 0 < errors[1] < errors[0] < 1e-2
    assert errors[1] / errors[0] == pytest.approx(0.25, abs=0.01)


@given(f=st.floats(20e3, 60e3), c=st.floats(1e-10, 1e-8), v=st.floats(1.0, 300.0), tan=st.floats(1e-3, 0.05))
@settings(max_examples=30, deadline=None, derandomize=True)
def test_dielectric_power_is_the_parallel_loss_resistances(f, c, v, tan):
    resistance = 1 / (2 * math.pi * f * c * tan)
    assert damping.dielectric_power_w(f, c, v, tan) == pytest.approx((v / 2) ** 2 / (2 * resistance))


def test_the_implied_q_inverts_the_one_mode_response():
    """P = R v0^2 / 2 and Q = w M / R, so a Q, a mass and a velocity give back their power."""
    q, mass, f, v_pp = 250.0, 8e-3, 40e3, 0.3
    power = 0.5 * (2 * math.pi * f * mass / q) * (v_pp / 2) ** 2
    assert damping.implied_q(f, mass, v_pp, power) == pytest.approx(q)


@given(p=st.floats(1.0, 1e4))
@settings(max_examples=20, deadline=None, derandomize=True)
def test_the_fit_recovers_the_parameter_that_made_the_qs(p):
    fixed, per_unit = np.array([1e-3, 2e-3, 1.5e-3]), np.array([2e-7, 5e-7, 3e-7])
    assert damping.fit_linear_loss(fixed, per_unit, 1 / (fixed + p * per_unit)) == pytest.approx(p)


def test_the_fit_stops_at_zero_when_the_rest_already_loses_too_much():
    fixed = np.array([2e-3, 3e-3])
    assert damping.fit_linear_loss(fixed, np.array([1e-7, 1e-7]), 1 / (0.5 * fixed)) == 0.0


def test_fit_and_check_fits_on_one_build_and_holds_the_others_out():
    frame = damping.fit_and_check("Table 4")
    assert set(frame.loc[frame["table"] == "Table 4", "role"]) == {"fitted"}
    assert set(frame.loc[frame["table"] != "Table 4", "role"]) == {"held out"}
    resistance = frame["fitted_cushion_resistance_pa_s_per_m"]
    assert resistance.nunique() == 1 and resistance.iloc[0] > 0
    other = damping.fit_and_check("Sec. 5")
    assert other["fitted_cushion_resistance_pa_s_per_m"].iloc[0] != resistance.iloc[0]
    # the held-out rows' Q is the fitted loss, not their own implied Q
    held = frame[frame["role"] == "held out"]
    assert (held["q_fitted"] != held["implied_q"]).all()
    # what the fit cannot change: Q without the cushion rises with the plate's size
    large = frame.set_index("item").loc["large_plate"]
    assert large["q_without_cushion"] > frame.set_index("item").loc["75", "q_without_cushion"]


def test_the_fit_never_reads_the_rows_it_judges(monkeypatch):
    """Moving a held-out plate's implied Q moves its ratio, not the fitted resistance."""
    from squeezebench.plates import predicted_plates

    budget = predicted_plates.loss_budget()
    moved = budget.assign(implied_q=np.where(budget["table"] == "Sec. 5", budget["implied_q"] * 3, budget["implied_q"]))
    monkeypatch.setattr(predicted_plates, "loss_budget", lambda: moved.copy())
    base = damping.fit_and_check("Table 4")
    monkeypatch.setattr(predicted_plates, "loss_budget", lambda: budget.copy())
    plain = damping.fit_and_check("Table 4")
    assert base["fitted_cushion_resistance_pa_s_per_m"].iloc[0] == plain["fitted_cushion_resistance_pa_s_per_m"].iloc[0]
    large = lambda f: f.set_index("item").loc["large_plate", "q_fitted_over_implied"]  # noqa: E731
    assert large(base) == pytest.approx(large(plain) / 3)


def test_cross_check_fits_each_build_once():
    frame = damping.cross_check()
    assert len(frame) == len(damping.BUILDS) ** 2
    assert (frame.groupby("fitted_on")["role"].apply(lambda r: (r == "fitted").sum()) == 1).all()
    assert (frame["fitted_cushion_resistance_pa_s_per_m"] >= 0).all()


def test_the_terms_table_sums_the_mechanisms_it_shows():
    frame = damping.terms_table()
    parts = frame[["loss_aluminium", "loss_piezo", "loss_bond", "loss_radiation", "loss_cushion_fitted"]]
    assert frame["loss_total"].to_numpy() == pytest.approx(parts.sum(axis=1).to_numpy())
    fit = damping.fit_and_check().set_index("item")
    assert (1 / frame.set_index("item")["loss_total"]).to_numpy() == pytest.approx(fit["q_fitted"].to_numpy())
