"""The paper's model: proportionalities, the Eq. 25/27/28 chain, inversions, conventions."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from squeezebench.analysis import model

CONVENTIONS = [model.PAPER_CONVENTION, model.PHYSICAL_CONVENTION,
               replace(model.PAPER_CONVENTION, voltage="amplitude", amplitude="amplitude"),
               replace(model.PHYSICAL_CONVENTION, neutral_plane="resonator_middle")]

geometries = st.builds(
    model.PlateGeometry,
    resonator_thickness_m=st.sampled_from([1e-3, 1.2e-3, 2e-3]),
    piezo_thickness_m=st.just(0.5e-3),
    piezo_length_m=st.floats(5e-3, 15e-3),
    half_wavelength_m=st.floats(5e-3, 15e-3),
    n_powered_piezos=st.integers(1, 16))


@settings(max_examples=60, deadline=None, derandomize=True)
@given(geometry=geometries, q=st.floats(0.5, 5.0), voltage=st.floats(1.0, 100.0), k=st.integers(1, 4),
       convention=st.sampled_from(CONVENTIONS))
def test_amplitude_proportional_to_nc_times_v(geometry, q, voltage, k, convention):
    """Eq. 1 / Eq. 27: A is proportional to n_c V."""
    base = model.amplitude_pp_m(q, voltage, geometry, convention)
    more = replace(geometry, n_powered_piezos=geometry.n_powered_piezos * k)
    assert model.amplitude_pp_m(q, voltage / k, more, convention) == pytest.approx(base, rel=1e-12)
    assert model.amplitude_pp_m(q, 2 * voltage, geometry, convention) == pytest.approx(2 * base, rel=1e-12)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(geometry=geometries, q=st.floats(0.5, 5.0), tan=st.floats(-2.0, -0.01), voltage=st.floats(1.0, 100.0),
       frequency=st.floats(2e4, 8e4), convention=st.sampled_from(CONVENTIONS))
def test_eq28_is_eq25_of_eq27_with_pi(geometry, q, tan, voltage, frequency, convention):
    amplitude = model.amplitude_pp_m(q, voltage, geometry, convention)
    direct = model.power_w(q, tan, voltage, frequency, geometry, convention)
    chained = model.power_from_amplitude_w(amplitude, q, tan, frequency, geometry,
                                           replace(convention, eq28_with_pi=True))
    as_printed = model.power_from_amplitude_w(amplitude, q, tan, frequency, geometry,
                                              replace(convention, eq28_with_pi=False))
    assert chained == pytest.approx(direct, rel=1e-10)
    assert direct / as_printed == pytest.approx(math.pi, rel=1e-10)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(geometry=geometries, q=st.floats(0.5, 5.0), tan=st.floats(-2.0, -0.01), voltage=st.floats(1.0, 100.0),
       convention=st.sampled_from(CONVENTIONS))
def test_inversions_round_trip(geometry, q, tan, voltage, convention):
    amplitude = model.amplitude_pp_m(q, voltage, geometry, convention)
    assert model.q_from_amplitude(amplitude, voltage, geometry, convention) == pytest.approx(q, rel=1e-10)
    power = model.power_w(q, tan, voltage, 5e4, geometry, convention)
    assert model.tan_theta_from_power(power, voltage, q, 5e4, geometry, convention) == pytest.approx(tan, rel=1e-10)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(geometry=geometries, q=st.floats(0.5, 5.0), tan=st.floats(-2.0, -0.01), voltage=st.floats(1.0, 100.0))
def test_power_at_constant_amplitude_is_independent_of_nc(geometry, q, tan, voltage):
    """Sec. 3.3's conclusion: at a given amplitude, the number of piezos drops out."""
    convention = model.PAPER_CONVENTION
    doubled = replace(geometry, n_powered_piezos=2 * geometry.n_powered_piezos)
    p1 = model.power_w(q, tan, voltage, 5e4, geometry, convention)
    p2 = model.power_w(q, tan, voltage / 2, 5e4, doubled, convention)
    assert p2 == pytest.approx(p1, rel=1e-12)


def test_bending_neutral_plane_with_printed_modulus_sits_in_the_piezo():
    """With E_i = 67109 Pa the resonator has no stiffness: the stiffness centroid is the
    piezo mid-plane, where Eq. 12's numerator 1 - 2 f0 nearly vanishes."""
    geometry = model.PlateGeometry(2e-3, 0.5e-3, 14e-3, 9e-3, 8)
    convention = replace(model.PAPER_CONVENTION, neutral_plane="bending_neutral")
    assert model.neutral_plane_m(geometry, convention) == pytest.approx(0.25e-3, rel=1e-4)
    physical = replace(model.PHYSICAL_CONVENTION, neutral_plane="bending_neutral")
    assert 0.5e-3 < model.neutral_plane_m(geometry, physical) < 2.5e-3


@settings(max_examples=80, deadline=None, derandomize=True)
@given(geometry=geometries, groups=st.integers(1, 4), q=st.floats(0.5, 5.0), tan=st.floats(-2.0, -0.01),
       voltage=st.floats(1.0, 100.0), frequency=st.floats(2e4, 8e4),
       reading=st.builds(lambda values: values, st.fixed_dictionaries({
           "voltage": st.sampled_from(["pp", "amplitude", "rms"]),
           "amplitude": st.sampled_from(["pp", "amplitude"]),
           "n_c": st.sampled_from(["piezos", "groups"]),
           "eq25_with_pi": st.booleans(), "c11_reduced": st.booleans(),
           "eq25_coefficient": st.sampled_from([0.75, 0.375])})))
def test_every_reading_inverts_its_own_eqs_25_and_27(geometry, groups, q, tan, voltage, frequency, reading):
    """Whatever the reading, Q and tan theta' come back from the amplitude and power it gives."""
    geometry = replace(geometry, n_powered_groups=min(groups, geometry.n_powered_piezos))
    convention = replace(model.PAPER_CONVENTION, name="any", **reading)
    amplitude = model.amplitude_pp_m(q, voltage, geometry, convention)
    power = model.power_w(q, tan, voltage, frequency, geometry, convention)
    q_back = model.q_from_amplitude(amplitude, voltage, geometry, convention)
    assert q_back == pytest.approx(q, rel=1e-9)
    assert model.tan_theta_from_power(power, voltage, q_back, frequency, geometry, convention) == pytest.approx(
        tan, rel=1e-9)


def test_the_reading_axes_scale_eq25_as_stated():
    geometry = model.PlateGeometry(2e-3, 0.5e-3, 14e-3, 9e-3, 8, 4)
    base = model.power_w(1.48, -1.24, 32.0, 52400.0, geometry, model.PAPER_CONVENTION)

    def ratio(**change):
        return model.power_w(1.48, -1.24, 32.0, 52400.0, geometry, replace(model.PAPER_CONVENTION, **change)) / base

    assert ratio(eq25_with_pi=False) == pytest.approx(1 / math.pi, rel=1e-12)
    assert ratio(eq25_coefficient=0.375) == pytest.approx(0.5, rel=1e-12)
    assert ratio(n_c="groups") == pytest.approx(0.25, rel=1e-12)
    assert ratio(voltage="rms") == pytest.approx(1 / 8, rel=1e-12)
    assert ratio(c11_reduced=False) == pytest.approx(1 - 0.33**2, rel=1e-12)
