"""The thick-plate correction the plate model applies (laminate.mindlin_frequency_ratio)
against Mindlin's plate-strip dispersion solved independently here (numpy's polynomial roots of
the unexpanded equation), its first-order expansion (frequency_budget.mindlin_factor), and the
solver applying it to every mode."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from squeezebench.plates import frequency_budget, laminate, plate_modes, predicted_plates
from squeezebench.plates.frequency_budget import SHEAR_COEFFICIENT, mindlin_factor


def exact_mindlin_over_kirchhoff(kh: float, poisson: float, kappa: float = SHEAR_COEFFICIENT) -> float:
    """The lower (flexural) root of the Mindlin equations for a straight-crested wave of
    wavenumber k, over the Kirchhoff frequency, with h = 1, E = 1, rho = 1:
    (kappa G h k^2 - rho h w^2)(D k^2 + kappa G h - rho h^3 w^2 / 12) = (kappa G h k)^2."""
    h, k = 1.0, kh
    d = 1.0 / (12.0 * (1.0 - poisson**2))
    shear = kappa * h / (2.0 * (1.0 + poisson))
    # a quadratic in w^2: (shear k^2 - h s)(d k^2 + shear - h s / 12) - (shear k)^2 = 0
    a = h * h / 12.0
    b = -(shear * k**2 * h / 12.0 + h * (d * k**2 + shear))
    c = shear * k**2 * (d * k**2 + shear) - (shear * k) ** 2
    s = min(np.roots([a, b, c]).real)
    return math.sqrt(s / (d * k**4 / h))


@settings(max_examples=40, deadline=None)
@given(kh=st.floats(0.01, 0.5), poisson=st.floats(0.2, 0.4))
def test_the_factor_is_the_first_order_expansion_of_mindlins_dispersion(kh, poisson):
    exact = exact_mindlin_over_kirchhoff(kh, poisson)
    first_order = mindlin_factor(kh, math.pi / 1.0, poisson)   # h = kh, k = pi / (pi / 1) = 1
    assert first_order < 1.0 and exact < 1.0
    # the expansion's error is of the next order, (k h)^4
    assert abs(first_order - exact) <= 0.1 * kh**4 + 1e-12   # about 0.05-0.08 (k h)^4 here


def test_a_thicker_plate_or_a_shorter_wave_departs_more_from_kirchhoff():
    assert mindlin_factor(1e-3, 8e-3, 0.34) == pytest.approx(0.970, abs=0.001)   # the 1 mm paper plates: -3 %
    assert mindlin_factor(2e-3, 9e-3, 0.34) < mindlin_factor(1.2e-3, 8e-3, 0.34) < mindlin_factor(1e-3, 8e-3, 0.34)
    assert 1 - mindlin_factor(2e-3, 8e-3, 0.34) == pytest.approx(4 * (1 - mindlin_factor(1e-3, 8e-3, 0.34)))


@settings(max_examples=40, deadline=None)
@given(kh=st.floats(0.01, 1.5), poisson=st.floats(0.2, 0.45))
def test_the_models_thick_plate_ratio_is_mindlins_dispersion(kh, poisson):
    assert laminate.mindlin_frequency_ratio(kh, poisson) == pytest.approx(
        exact_mindlin_over_kirchhoff(kh, poisson), rel=1e-9)


def test_the_thick_plate_bias_at_the_papers_wavelengths():
    """Kirchhoff is about 3 % high at 1 mm, 4 % at 1.2 mm and 8 % at 2 mm for these half-waves
    (issue 45's independent review: 2.9, 4.0, 7.8 %)."""
    for h_mm, half_mm, bias in ((1.0, 8.0, 0.029), (1.2, 8.0, 0.040), (2.0, 9.2, 0.078)):
        ratio = laminate.mindlin_frequency_ratio(math.pi / half_mm * h_mm, 0.34)
        assert 1 / ratio - 1 == pytest.approx(bias, abs=0.007)


def test_the_solver_moves_every_mode_onto_mindlins_branch():
    plate = plate_modes.PlateGeometry(60e-3, 30e-3, 2e-3)
    modes = plate_modes.solve_plate(plate, near_hz=40e3)
    # the same Kirchhoff problem: a thin solve centred where the thick one looked
    thin = plate_modes.solve_plate(plate, near_hz=plate_modes.kirchhoff_frequency_hz(
        40e3, plate_modes.ALUMINIUM_TABLE2, 2e-3), n_modes=len(modes.frequencies_hz), thick_plate=False)
    assert np.allclose(thin.frequencies_hz, modes.kirchhoff_frequencies_hz)
    for f_k, f in zip(modes.kirchhoff_frequencies_hz, modes.frequencies_hz):
        assert f == pytest.approx(plate_modes.thick_plate_frequency_hz(f_k, plate_modes.ALUMINIUM_TABLE2, 2e-3))
        assert f < f_k


def test_a_thick_plate_solve_looks_for_its_modes_where_their_corrected_frequencies_fall():
    """The search centre is a corrected frequency: the mode found nearest it on a 2 mm plate
    (8 % below Kirchhoff) is the one nearest it after the correction, not 8 % away."""
    plate = plate_modes.PlateGeometry(100e-3, 30e-3, 2e-3)
    near = 50e3
    assert plate_modes.thick_plate_frequency_hz(plate_modes.kirchhoff_frequency_hz(
        near, plate_modes.ALUMINIUM_TABLE2, 2e-3), plate_modes.ALUMINIUM_TABLE2, 2e-3) == pytest.approx(near, rel=1e-9)
    modes = plate_modes.solve_plate(plate, near_hz=near, n_modes=6)
    wide = plate_modes.solve_plate(plate, near_hz=near, band_rel=1.0)
    assert np.min(abs(modes.frequencies_hz - near)) == pytest.approx(np.min(abs(wide.frequencies_hz - near)))


def test_the_bare_plates_length_ratio_is_the_free_free_beams():
    """Table 3's cut plates with their column taken off: the model's f28/f75 is the closed-form
    free-free beam's (beta L roots, thick-plate corrected) to 0.1 %, the two 1 % apart each (the
    plate's free long edges soften both alike). So the +3 % by which the bare ratio already
    misses the print is the plates' lengths, not a term of the piezos or the bond."""
    model, beam = {}, {}
    for label, antinodes in (("75", 9), ("28", 3)):
        geometry = predicted_plates.table3_plate(label)
        model[label] = frequency_budget.bare_plate_frequency_hz(geometry, antinodes)
        beam[label] = frequency_budget.free_free_beam_frequency_hz(plate_modes.ALUMINIUM_TABLE2, geometry.thickness_m,
                                                                   geometry.length_m, antinodes)
        assert model[label] == pytest.approx(beam[label], rel=0.015)
    assert model["28"] / model["75"] == pytest.approx(beam["28"] / beam["75"], rel=0.001)
    assert beam["28"] / beam["75"] / (35130 / 37160) - 1 == pytest.approx(0.031, abs=0.002)


@settings(max_examples=20, deadline=None)
@given(st.floats(0.01, 1.0), st.floats(0.0, 1.0))
def test_the_95_percent_half_width_of_two_rectangles_is_their_trapezoids(a, b):
    """Against a seeded draw of the sum of the two rectangles (400,000 pairs: the 95 % point to
    about half a per cent), and 0.95 a for one rectangle alone."""
    from squeezebench.plates.specifications import rectangles_95_half_width
    rng = np.random.default_rng(7)
    total = rng.uniform(-a, a, 400_000) + rng.uniform(-b, b, 400_000)
    assert rectangles_95_half_width(a, b) == pytest.approx(np.quantile(np.abs(total), 0.95), rel=0.01)
    assert rectangles_95_half_width(a, 0.0) == pytest.approx(0.95 * a)
