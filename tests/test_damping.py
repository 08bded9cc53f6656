"""Q from the physics of the losses (plates.damping): closed forms, the modal strain energy
weighting, and the fit on one build judged on the others."""
import math

import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from squeezebench.plates import damping, plate_modes

AL = plate_modes.ALUMINIUM_TABLE2


def test_coincidence_of_aluminium_sheets():
    """f_c h is about 12 Hz m for aluminium (c0^2 / (2 pi) sqrt(12 rho (1 - nu^2) / E))."""
    assert damping.coincidence_frequency_hz(AL, 1e-3) == pytest.approx(12.2e3, rel=0.03)
    assert damping.coincidence_frequency_hz(AL, 2e-3) == pytest.approx(damping.coincidence_frequency_hz(AL, 1e-3) / 2)


@given(f=st.floats(30e3, 80e3), h=st.floats(1e-3, 3e-3))
@settings(max_examples=30, deadline=None)
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


def test_the_implied_q_inverts_the_one_mode_response():
    """P = R v0^2 / 2 and Q = w M / R, so a Q, a mass and a velocity give back their power."""
    q, mass, f, v_pp = 250.0, 8e-3, 40e3, 0.3
    power = 0.5 * (2 * math.pi * f * mass / q) * (v_pp / 2) ** 2
    assert damping.implied_q(f, mass, v_pp, power) == pytest.approx(q)


@given(eta=st.floats(0.001, 0.2))
@settings(max_examples=20, deadline=None)
def test_the_bond_fit_recovers_the_loss_factor_that_made_the_qs(eta):
    rows = pd.DataFrame({"loss_without_bond": [1e-3, 2e-3, 1.5e-3], "bond_loss_per_eta": [0.02, 0.05, 0.03]})
    rows["implied_q"] = 1 / (rows["loss_without_bond"] + eta * rows["bond_loss_per_eta"])
    assert damping.fit_bond_loss_factor(rows) == pytest.approx(eta)


def test_fit_and_check_fits_on_one_build_and_holds_the_others_out():
    frame = damping.fit_and_check("Table 3")
    assert set(frame.loc[frame["table"] == "Table 3", "role"]) == {"fitted"}
    assert set(frame.loc[frame["table"] != "Table 3", "role"]) == {"held out"}
    assert frame["fitted_bond_loss_factor"].nunique() == 1 and 0 < frame["fitted_bond_loss_factor"].iloc[0] < 1
    other = damping.fit_and_check("Table 4")
    assert other["fitted_bond_loss_factor"].iloc[0] != frame["fitted_bond_loss_factor"].iloc[0]
    # what the fit cannot change: Q rises with the plate's size (radiation and piezo shares fall)
    large = frame.set_index("item").loc["large_plate"]
    assert large["q_nominal"] > frame.set_index("item").loc["75", "q_nominal"]
