"""The 2-D mode shape a map is simulated from (the finite-element modal model's working
mode, referred to the scene's measurement point), and the map's homogeneity numbers and
modal assurance criterion."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import pandas as pd

from squeezebench.analysis.budgets import Budget, Term
from squeezebench.analysis.cartography import (AREA_SAMPLES, LATTICE_REGISTRATIONS, READING_SAMPLES, cell_offsets,
                                               cell_readings, coefficients_of_variation, GridError, grid_bias,
                                               grid_correction_term, grid_quadrature_term, homogeneity, modal_assurance,
                                               recurrence_misfit, retuning_log_levels, retuning_term, signed_amplitude,
                                               summarise_map)
from squeezebench.paths import scenes_dir
from squeezebench.plates.specifications import SPECIFICATIONS
from squeezebench.simbench.modeshape import mode_shape, working_mode
from squeezebench.simbench.scene import load_scene
from squeezebench.simbench.scene_model import MeasurementPoint, SceneError


@pytest.fixture(scope="module")
def large():
    scene = load_scene(scenes_dir() / "large_plate.yaml")
    return scene, scene.state("large")


def test_the_shape_is_one_at_the_scenes_measurement_point_and_zero_off_the_plate(large):
    scene, state = large
    point = scene.measurement_point
    assert mode_shape(scene, state, point.x_mm, point.y_mm) == pytest.approx(1.0, abs=1e-12)
    off = mode_shape(scene, state, np.array([-1.0, 199.0, 50.0, 50.0]), np.array([10.0, 10.0, -0.5, 138.5]))
    assert np.all(off == 0.0)


def test_the_tabulated_shape_is_the_elements_own(large):
    scene, state = large
    modes, k = working_mode(scene, state)
    rng = np.random.default_rng(3)
    x_mm, y_mm = rng.uniform(0, scene.plate.length_mm, 60), rng.uniform(0, scene.plate.width_mm, 60)
    point = scene.measurement_point
    exact = modes.shape_at(k, x_mm * 1e-3, y_mm * 1e-3) / modes.shape_at(k, point.x_mm * 1e-3, point.y_mm * 1e-3)
    assert np.allclose(mode_shape(scene, state, x_mm, y_mm), exact, atol=1e-4)


def test_a_row_along_the_length_crosses_the_models_nodal_lines(large):
    """Sign changes along the centre line are the modal model's own nodal lines: the count
    agrees, and the place within a quarter of λ/2 (the model places a line where the
    width-averaged deflection changes sign, and the lines bow slightly across the width)."""
    scene, state = large
    modes, k = working_mode(scene, state)
    x_mm = np.arange(0.125, scene.plate.length_mm, 0.25)
    row = mode_shape(scene, state, x_mm, scene.plate.width_mm / 2)
    crossings = np.nonzero(np.diff(np.sign(row)) != 0)[0]
    lines_mm = modes.nodal_lines_m(k) * 1e3
    assert len(crossings) == len(lines_mm) == modes.interior_antinodes(k) + 1
    assert np.allclose(x_mm[crossings] + 0.125, lines_mm, atol=modes.half_wavelength_m(k) * 1e3 / 4)


def test_across_the_width_an_antinode_keeps_its_sign(large):
    """The working mode is an (n, 0) mode: no nodal line along the length, so across the
    width at an antinode the deflection never changes sign (its size may vary)."""
    scene, state = large
    x_mm = np.arange(0.5, scene.plate.length_mm, 0.5)
    row = mode_shape(scene, state, x_mm, scene.plate.width_mm / 2)
    for i in np.nonzero((np.abs(row[1:-1]) >= np.abs(row[:-2])) & (np.abs(row[1:-1]) > np.abs(row[2:])))[0][::4]:
        across = mode_shape(scene, state, np.full(41, x_mm[i + 1]), np.linspace(0.0, scene.plate.width_mm, 41))
        assert np.all(np.sign(across) == np.sign(row[i + 1]))


def test_a_measurement_point_on_a_nodal_line_is_refused_with_the_point_named(large):
    scene, state = large
    modes, k = working_mode(scene, state)
    node_mm = float(modes.nodal_lines_m(k)[5] * 1e3)
    on_node = replace(scene, measurement_point=MeasurementPoint(node_mm, scene.plate.width_mm / 2))
    with pytest.raises(SceneError, match="nodal line"):
        mode_shape(on_node, state, 10.0, 10.0)


def test_homogeneity_numbers_of_a_known_set():
    h = homogeneity(np.array([1.0, 2.0, 3.0, 4.0]), share_of_peak=0.7)
    assert (h.mean, h.minimum, h.maximum, h.n_points) == (2.5, 1.0, 4.0, 4)
    assert h.coefficient_of_variation == pytest.approx(np.std([1, 2, 3, 4]) / 2.5)
    assert h.fraction_above_share == 0.5                      # 3 and 4 are >= 2.8
    with pytest.raises(ValueError, match="share_of_peak"):
        homogeneity(np.ones(3), share_of_peak=1.5)


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 3000), st.integers(1, 12), st.floats(1e-3, 1.0), st.integers(0, 2**32 - 1))
def test_coefficients_of_variation_are_homogeneity_s_to_the_last_bit(points, draws, spread, seed):
    """The Monte Carlo of a map plan takes every draw's CV at once; the plan must not move."""
    rng = np.random.default_rng(seed)
    amplitudes = rng.uniform(0.0, 1.0, points) * (1.0 + spread * rng.standard_normal((draws, points)))
    amplitudes[0] = 0.0 if draws > 1 else amplitudes[0]   # a row without vibration: CV infinite, as homogeneity's
    expected = [homogeneity(row).coefficient_of_variation for row in amplitudes]
    assert coefficients_of_variation(amplitudes).tolist() == expected


def test_signed_amplitude_turns_antiphase_into_a_sign():
    assert np.allclose(signed_amplitude([2.0, 2.0], [0.0, np.pi]), [2.0, -2.0])


@settings(max_examples=50, deadline=None)
@given(st.floats(-1e3, 1e3).filter(lambda s: abs(s) > 1e-6), st.integers(3, 40))
def test_mac_is_one_for_any_scaling_and_symmetric(scale, n):
    rng = np.random.default_rng(n)
    shape = rng.normal(size=n)
    assert modal_assurance(scale * shape, shape) == pytest.approx(1.0)
    other = rng.normal(size=n)
    assert modal_assurance(shape, other) == pytest.approx(modal_assurance(other, shape))
    assert 0.0 <= modal_assurance(shape, other) <= 1.0 + 1e-12


def test_mac_of_orthogonal_shapes_and_of_a_noisy_map():
    x = np.linspace(0.0, 0.198, 100)
    assert modal_assurance(np.sin(2 * np.pi * x / 0.198), np.cos(2 * np.pi * x / 0.198)) == pytest.approx(0, abs=1e-12)
    mode = np.cos(21 * np.pi * x / 0.198)
    noisy = mode + np.random.default_rng(0).normal(scale=0.05, size=x.size)
    # closed form for small noise: MAC ~ 1 / (1 + sigma^2 / mean(mode^2)) = 1 / (1 + 0.005)
    assert modal_assurance(noisy, mode) == pytest.approx(1 / 1.005, abs=0.004)
    with pytest.raises(ValueError, match="different points"):
        modal_assurance(mode, mode[:-1])


def test_a_generator_error_steps_the_levels_of_re_tuned_steps_as_the_lorentzian_does():
    # each step re-tracks the peak through a generator off by e: its settings sit near f0 / (1 + e),
    # a few Hz apart; the plate answers at f (1 + e), ideal instruments at f
    f0_hz, q, e = 52_400.0, 304.0, 2e-5
    settings_hz = f0_hz / (1 + e) + np.array([-2.5, 0.0, 2.5, 1.0])
    k = 2 * q / f0_hz

    def velocity(f_hz):
        return 1.0 / np.sqrt(1 + k**2 * (f_hz - f0_hz) ** 2)

    exact = np.log(velocity(settings_hz * (1 + e)) / velocity(settings_hz))
    modelled = retuning_log_levels(settings_hz, q, e)
    # the part every point shares scales the map; the steps' differences are what is modelled
    assert np.allclose(modelled - modelled.mean(), exact - exact.mean(), rtol=0, atol=1e-3 * np.ptp(exact))
    assert np.ptp(exact) > 1e-4   # a level step the points' noise (about 1.5e-4 / sqrt(26) a step) would show


def test_the_retuning_term_of_two_points_is_the_closed_form_sensitivity_times_the_specification():
    # CV of two values a > b is (a - b) / (a + b); levels g_i = exp(lambda_i e) give
    # dCV/de = 2 a b (lambda_1 - lambda_2) / (a + b)^2
    a, b, q = 0.2, 0.1, 304.0
    settings_hz = np.array([52_399.0, 52_403.0])
    lam = retuning_log_levels(settings_hz, q, 1.0)
    term = retuning_term(lambda v: homogeneity(v).coefficient_of_variation, np.array([a, b]), settings_hz, q)
    expected = abs(2 * a * b * (lam[0] - lam[1]) / (a + b) ** 2) * SPECIFICATIONS["generator_frequency"].std_uncertainty
    assert term.std_uncertainty == pytest.approx(expected, rel=1e-6)
    assert term.type == "B" and term.is_rectangular
    # one setting for every point: the error scales the map and leaves its homogeneity
    flat = retuning_term(lambda v: homogeneity(v).coefficient_of_variation, np.array([a, b]), np.full(2, 52_400.0), q)
    assert flat.std_uncertainty == pytest.approx(0.0, abs=1e-15)


@settings(max_examples=40, deadline=None)
@given(st.integers(2, 12), st.integers(2, 9), st.floats(0.0, 1.0), st.integers(0, 2**32 - 1))
def test_width_uniformity_is_the_width_averaged_share_of_the_mean_square(columns, rows, mix, seed):
    """A map w(x, y) = f(x) + mix g(x) h(y), h of zero mean across the width: the
    width-averaged part is f, so the share is sum f^2 / (sum f^2 + mix^2 sum (g h)^2),
    1 for a deflection that does not vary across the width, in any order of the points."""
    from squeezebench.analysis.cartography import width_uniformity

    rng = np.random.default_rng(seed)
    f, g, h = rng.normal(size=columns), rng.normal(size=columns), rng.normal(size=rows)
    h -= h.mean()
    x = np.repeat(np.linspace(0.0, 0.1, columns), rows)
    w = np.repeat(f, rows) + mix * np.outer(g, h).ravel()
    expected = rows * (f**2).sum() / (w**2).sum()
    order = rng.permutation(x.size)
    assert width_uniformity(x[order], w[order]) == pytest.approx(expected, rel=1e-9)
    assert width_uniformity(x, np.repeat(f, rows)) == pytest.approx(1.0, rel=1e-12)


def _sampled_mode(rng, kind: str, points_per_half_wave: float, n_x: int = 13, n_y: int = 7,
                  refine: tuple[int, int] = (24, 24)):
    """A cosine mode shape cos(k x + a) ((n, 0): contours across the grid's rows),
    cos(k x + a) cos(0.7 k y + b) (2-D) or a plane wave at a random angle, signed, sampled
    on a unit grid; and the continuous shape's magnitude over the same cells, on a grid
    `refine` times finer along x and y."""
    k = math.pi * points_per_half_wave ** -1.0
    a, b, angle = rng.uniform(0, 2 * math.pi), rng.uniform(0, 2 * math.pi), rng.uniform(0, math.pi)
    shapes = {"n0": lambda x, y: np.cos(k * x + a) + 0.0 * y,
              "2d": lambda x, y: np.cos(k * x + a) * np.cos(0.7 * k * y + b),
              "plane": lambda x, y: np.cos(k * (x * math.cos(angle) + y * math.sin(angle)) + a)}
    shape = shapes[kind]
    x, y = np.meshgrid(np.arange(n_x, dtype=float), np.arange(n_y, dtype=float))
    fine_x, fine_y = np.meshgrid((np.arange(n_x)[:, None] + cell_offsets(refine[0])).ravel(),
                                 (np.arange(n_y)[:, None] + cell_offsets(refine[1])).ravel())
    return x.ravel(), y.ravel(), shape(x, y).ravel(), np.abs(shape(fine_x, fine_y)).ravel()


FIGURES = ("coefficient_of_variation", "fraction_above_share")
#: The synthetic maps' grid step.
STEP_M = 2e-3


def _corrected(readings, points: np.ndarray, cells: np.ndarray, figure: str) -> tuple[float, float, float]:
    """The points' error against `cells` (half the points' peak for the area), the error
    left once corrected by the grid bias, and the corrected figure's grid U (k = 1.96 times
    the correction's and the quadrature's terms in quadrature: both normal)."""
    error = GridError(figure, 0.5)
    u = math.hypot(grid_correction_term(readings, error).std_uncertainty,
                   grid_quadrature_term(readings, error).std_uncertainty)
    uncorrected = error(points, cells)
    return uncorrected, uncorrected - grid_bias(readings, error), 1.96 * u


def _sin2_mean_offset_error(n: int, k: float, x0: float) -> float:
    """Closed form: mean of cos^2(k x) over the grid x0 + i, i = 0..n-1 (unit step), minus its
    mean over that grid's cells [x0 - 1/2, x0 + n - 1/2]. The sampled mean is 1/2 +
    cos(2 k x0 + (n - 1) k) sin(n k) / (2 n sin k) (a geometric sum of exp(2 j k x_i)); the
    continuous one 1/2 + (sin 2 k b - sin 2 k a) / (4 k (b - a))."""
    a, b = x0 - 0.5, x0 + n - 0.5
    sampled = 0.5 + math.cos(2 * k * x0 + (n - 1) * k) * math.sin(n * k) / (2 * n * math.sin(k))
    return sampled - (0.5 + (math.sin(2 * k * b) - math.sin(2 * k * a)) / (4 * k * n))


class _MeanSquare(GridError):
    """The mean of the field's square over the points against its mean over their cells."""

    def __call__(self, points: np.ndarray, cells: np.ndarray) -> float:
        return float(np.mean(points**2) - np.mean(cells**2))


@settings(max_examples=40, deadline=None)
@given(st.floats(2.0, 8.0), st.integers(12, 24), st.floats(0.0, 10.0), st.floats(0.0, 2 * math.pi))
def test_the_grid_bias_of_a_standing_waves_sampled_mean_square_is_the_closed_form(points_per_half_wave, n, x0, phase):
    """A standing wave cos(k x + phase) on a 2 mm grid of n columns (6 rows), the figure the
    mean of the field's square over the points against its mean over their cells: read off
    the bending reconstruction, which holds a standing wave exactly (its recurrence leaves
    no misfit), the grid's bias is the closed form's (`_sin2_mean_offset_error`) to 1 % of
    the aliasing's amplitude (the midpoint rule's, 8 spots a cell, against the integral),
    from 2 points per half-wavelength on."""
    k = math.pi / points_per_half_wave
    amplitude = abs(math.sin(n * k) / (2 * n * math.sin(k)))
    assume(amplitude > 0.02)   # a grid of nearly whole half-waves has no aliasing error to find
    x, y = np.meshgrid(x0 + np.arange(n, dtype=float), np.arange(6.0))
    readings = cell_readings(STEP_M * x.ravel(), STEP_M * y.ravel(), np.cos(k * x + phase).ravel())
    assert readings.method == "bending"
    assert grid_bias(readings, _MeanSquare("mean_square", 0.5)) == pytest.approx(_sin2_mean_offset_error(n, k, x0 + phase / k),
                                                             abs=0.01 * amplitude)
    assert max(recurrence_misfit(readings.grid, axis, False) for axis in (0, 1)) < 1e-9


@settings(max_examples=60, deadline=None)
@given(st.floats(0.1, 3.0), st.floats(0.0, 2 * math.pi), st.floats(1e-3, 1e3), st.integers(3, 30), st.integers(1, 5))
def test_a_standing_wave_or_a_line_leaves_no_recurrence_misfit_and_a_parabola_the_closed_forms(kh, phase, scale, n,
                                                                                            rows):
    """Prony's recurrence w[i-1] + w[i+1] = 2 cos(k h) w[i] holds every A cos(k x + phase)
    at equal steps, so a standing wave of any wavenumber, phase and scale leaves no misfit,
    and a straight line none against cos = 1. A parabola w = i^2 against a straight line
    leaves the second difference, 2 at every middle point: misfit sqrt(4 (n - 2) / sum of
    i^2 over them) / 2, the same for any scale. An axis of 2 points is unchecked (1), of
    one not read (0)."""
    i = np.arange(n, dtype=float)
    wave = scale * np.cos(kh * i + phase)
    assume(np.sum(wave[1:-1] ** 2) > 1e-6 * scale**2 * n)
    assert recurrence_misfit(np.tile(wave, (rows, 1)).T, 0, False) < 1e-7
    assert recurrence_misfit(np.tile(wave, (rows, 1)), 1, False) < 1e-7
    assert recurrence_misfit(np.tile(1.0 + scale * i, (rows, 1)).T, 0, True) < 1e-12
    parabola = np.tile(scale * i**2, (rows, 1)).T
    assert recurrence_misfit(parabola, 0, True) == pytest.approx(math.sqrt(4 * (n - 2) / np.sum(i[1:-1] ** 4)) / 2,
                                                                 rel=1e-9)
    assert recurrence_misfit(np.ones((2, rows)), 0, True) == 1.0 and recurrence_misfit(np.ones((1, rows)), 0, True) == 0.0


@pytest.mark.parametrize("kind", ["n0", "2d", "plane"])
def test_the_corrected_figures_of_a_cosine_mode_are_its_continuous_ones(kind):
    """The points' figure against the same figure of the continuous mode shape over their
    cells (24 x 24 spots; the (n, 0) mode, constant across y, 480 along x and one across),
    grids of 2 to 4 points per half-wavelength at random phases (300 of each, seeded):
    corrected by the grid bias the reading gives, the error left is a small part of the
    points' (the midpoint rule's; the reading holds a cosine exactly), and the grid's U,
    from the correction's and the quadrature's terms, holds it 90 % of the time or more, to
    the reference's own resolution (the area's error jumps as whole columns of spots cross
    half the peak). The (n, 0) mode's reference is finer along x than the area's union of
    lattices (AREA_SAMPLES): its contours cross the cells as straight lines, the count's
    error is a column of spots per contour, and 24 would score the reference's error."""
    refine = (480, 1) if kind == "n0" else (24, 24)
    rng = np.random.default_rng(46)
    found = {figure: [] for figure in FIGURES}
    for _ in range(300):
        x, y, sampled, fine = _sampled_mode(rng, kind, rng.uniform(2.0, 4.0), refine=refine)
        readings = cell_readings(STEP_M * x, STEP_M * y, sampled)
        for figure in FIGURES:
            found[figure].append(_corrected(readings, np.abs(sampled), fine, figure))
    # the reference's own resolution: a column of its spots (a (n, 0) mode's cross half the peak a column at a time)
    resolution = {"coefficient_of_variation": 0.0, "fraction_above_share": 1.0 / (refine[0] * 13)}
    for figure, most in zip(FIGURES, (0.05, 0.1)):
        uncorrected, left, expanded = np.abs(np.array(found[figure])).T
        assert np.median(uncorrected) > 0.004   # the grid's error is real: a correction of 0 would leave it
        assert np.median(left) < most * np.median(uncorrected)
        assert np.mean(left <= expanded + resolution[figure]) >= 0.9


#: Spots (along x, across y) of each cell at which the large plate's mode is the area's
#: reference: along the length, which its (21, 0) mode's contours cross, finer than the area's
#: union of lattices (AREA_SAMPLES, 40), and on none of its spots; across the width, along which
#: they run nearly straight, 4 (4 and 32 give the same area to 5e-5 on the 2 and 4 mm grids).
AREA_REFERENCE_SPOTS = (96, 4)


def _large_plate_map(large, step_mm: float, dx_mm: float, dy_mm: float = 0.0) -> list[tuple[float, float, float]]:
    """The paper's map area (51-147 x 43-95 mm) of the large plate's working mode on a grid
    of `step_mm` shifted by (dx, dy): per figure, the points' error against the mode over
    their cells (the CV's over 8 x 8 spots each, the area's over AREA_REFERENCE_SPOTS), the
    error left once corrected, and the grid's U (`_corrected`)."""
    scene, state = large
    x, y = np.meshgrid(np.arange(51.0, 147.1, step_mm) + dx_mm, np.arange(43.0, 95.1, step_mm) + dy_mm)
    signed = mode_shape(scene, state, x, y).ravel()
    readings = cell_readings(1e-3 * x.ravel(), 1e-3 * y.ravel(), signed)

    def over_cells(along_x: int, across_y: int) -> np.ndarray:
        a, b = np.meshgrid(cell_offsets(along_x) * step_mm, cell_offsets(across_y) * step_mm, indexing="ij")
        return np.abs(mode_shape(scene, state, x.ravel()[:, None] + a.ravel(), y.ravel()[:, None] + b.ravel())).ravel()

    return [_corrected(readings, np.abs(signed), over_cells(*spots), figure)
            for figure, spots in zip(FIGURES, ((8, 8), AREA_REFERENCE_SPOTS))]


#: The placements a bench draws (+-1 mm per axis, `specifications.SPECIFICATIONS["plate_placement"]`),
#: 8 x 2 midpoint spots: where the grid may fall on the mode.
PLACEMENTS_MM = [(dx, dy) for dx in cell_offsets(8) * 2.0 for dy in cell_offsets(2) * 2.0]


@pytest.mark.parametrize("step_mm", [4.0, 2.0])
def test_on_the_large_plates_mode_the_corrected_figures_are_held_by_the_grids_u(large, step_mm):
    """The paper campaign's 4 mm map (2.4 points per half-wavelength) and the cartography
    campaign's 2 mm one (4.7) registered at the placements a bench draws: the correction
    leaves under 5 % of the CV's grid error (the reading's 3 %) and under a quarter of the
    area's, and the grid's U of the corrected figures holds every one, at a fraction of the
    error the points' figures make (the bias bound's U was larger than that error)."""
    found = np.array([_large_plate_map(large, step_mm, dx, dy) for dx, dy in PLACEMENTS_MM])   # placement, figure, 3
    uncorrected, left, expanded = np.abs(found[..., 0]), np.abs(found[..., 1]), found[..., 2]
    assert np.all(np.sqrt(np.mean(left**2, axis=0)) < [0.05, 0.25] * np.sqrt(np.mean(uncorrected**2, axis=0)))
    assert np.all(left <= expanded)
    assert np.all(np.median(expanded, axis=0) < 0.5 * np.median(uncorrected, axis=0))


def test_the_paper_maps_own_symmetric_registration_is_corrected(large):
    """The paper's 4 mm grid as laid out (x = 51 + 4 n, 25 columns symmetric about the
    plate's centre, 99 mm) meets the (21, 0) mode symmetrically, so the columns cross half
    the points' peak in pairs: the points' area is off by +0.055 and their CV by -0.021, the
    largest over the placement. Corrected, both are left within the grid's U and at under
    a twentieth of that."""
    (cv, cv_left, cv_u), (area, area_left, area_u) = _large_plate_map(large, 4.0, 0.0)
    assert abs(area) > 0.05 and abs(cv) > 0.02
    assert abs(cv_left) < 0.05 * abs(cv) and abs(area_left) < 0.05 * abs(area)
    assert abs(cv_left) <= cv_u and abs(area_left) <= area_u


def test_the_correction_term_is_the_misfit_times_the_cvs_bias_and_a_cosines_has_none():
    """The CV's correction term is e |B| (`grid_correction_term`): 0 for a standing wave,
    which the reading holds; on a standing wave under a linear envelope (1 + x / 40) the
    recurrence misfits, and the term is that misfit times the bias the reading subtracts."""
    x, y = np.meshgrid(np.arange(25.0), np.arange(6.0))
    k = math.pi / 2.3
    error = GridError("coefficient_of_variation", 0.5)
    pure = cell_readings(STEP_M * x.ravel(), STEP_M * y.ravel(), np.cos(k * x + 0.3).ravel())
    assert grid_correction_term(pure, error).std_uncertainty < 1e-9 * abs(grid_bias(pure, error))
    envelope = cell_readings(STEP_M * x.ravel(), STEP_M * y.ravel(), ((1.0 + x / 40.0) * np.cos(k * x + 0.3)).ravel())
    misfit = recurrence_misfit(envelope.grid, 0, False)
    assert misfit > 0.005
    assert grid_correction_term(envelope, error).std_uncertainty == pytest.approx(
        misfit * abs(grid_bias(envelope, error)), rel=1e-9)
    assert not grid_correction_term(pure, error).is_rectangular   # normal, k = 1.96


def test_each_axis_misfit_is_propagated_through_the_bias_its_own_reading_makes():
    """A standing wave along x (a pure one: no misfit there) under an envelope across the
    width, sqrt(1 + y), which the recurrence across y misfits: the CV's bias is mostly made
    by reading between the points along x, where nothing is misread, so the term is the y
    misfit times the small bias reading across y makes (the field read across that axis
    alone), not the y misfit times the whole bias."""
    x, y = np.meshgrid(np.arange(25.0), np.arange(6.0))
    signed = (np.cos(math.pi / 2.3 * x + 0.3) * np.sqrt(1.0 + y)).ravel()
    readings = cell_readings(STEP_M * x.ravel(), STEP_M * y.ravel(), signed)
    error = GridError("coefficient_of_variation", 0.5)
    misfit_x, misfit_y = (recurrence_misfit(readings.grid, axis, False) for axis in (0, 1))
    assert misfit_x < 1e-9 < 0.005 < misfit_y
    across_y = error(readings.at_points.ravel(), readings.across(1).ravel())
    term = grid_correction_term(readings, error).std_uncertainty
    assert term == pytest.approx(misfit_y * abs(across_y), rel=1e-6)
    assert term < 0.25 * misfit_y * abs(grid_bias(readings, error))


@settings(max_examples=30, deadline=None)
@given(st.integers(-12, 10), st.booleans(), st.floats(2.0, 4.0), st.floats(0.0, 2 * math.pi), st.floats(0.0, 0.2))
def test_the_correction_and_its_terms_do_not_depend_on_the_fields_scale_or_sign(power, flip, points_per_half_wave,
                                                                               phase, slope):
    """The CV and the area are ratios of the field to itself: on a standing wave under an
    envelope (1 + slope x / 10, which the recurrence misfits), scaled by any factor and of
    either sign, the grid bias and both terms of the corrected figures are the same (to the
    last bit for a power of 2, which scales every reading exactly: a spot at the share of
    the peak stays on its side)."""
    x, y = np.meshgrid(np.arange(20.0), np.arange(5.0))
    signed = ((1.0 + slope * x / 10.0) * np.cos(math.pi / points_per_half_wave * x + phase)).ravel()
    base = cell_readings(STEP_M * x.ravel(), STEP_M * y.ravel(), signed)
    moved = cell_readings(STEP_M * x.ravel(), STEP_M * y.ravel(), (-1.0 if flip else 1.0) * 2.0**power * signed)
    for figure in FIGURES:
        error = GridError(figure, 0.5)
        for found in (grid_bias, lambda r, e: grid_correction_term(r, e).std_uncertainty,
                      lambda r, e: grid_quadrature_term(r, e).std_uncertainty):
            assert found(moved, error) == found(base, error)


def test_the_cell_readings_of_a_linear_field_are_the_continuous_uniform_distribution():
    """v = 1 + x at x = 0..4 (any rows, any order, any sign convention of the field): over
    the cells [-0.5, 4.5] the field is uniform on [0.5, 5.5], mean 3 and standard deviation
    5 / sqrt(12): CV = 5 / (3 sqrt 12), which the bending reading gives, so the corrected CV
    is it; a line is no misfit (no correction term) and the midpoint rule is exact for its
    mean and to 1 / (4 N^2) of its variance (the quadrature term is that small). Half the
    points' peak (5), 2.5, is reached over (5.5 - 2.5) / 5 of the area."""
    x, y = np.meshgrid(np.arange(5.0), np.arange(4.0))
    order = np.random.default_rng(1).permutation(20)
    x, y, v = x.ravel()[order], y.ravel()[order], (1.0 + x).ravel()[order]
    readings = cell_readings(STEP_M * x, STEP_M * y, v)
    assert readings.method == "bending" and readings.values.shape == (20, 64)
    closed = 5.0 / (3.0 * math.sqrt(12.0))
    error = GridError("coefficient_of_variation", 0.5)
    assert homogeneity(v).coefficient_of_variation - grid_bias(readings, error) == pytest.approx(closed, rel=2e-3)
    assert grid_correction_term(readings, error).std_uncertainty < 1e-12
    assert grid_quadrature_term(readings, error).std_uncertainty < 2e-3 * closed
    above = np.mean(readings.values >= 0.5 * 5.0)
    assert above == pytest.approx(3.0 / 5.0, abs=1.0 / 40)   # to a spot of 1/8 cell
    assert np.array_equal(cell_readings(STEP_M * x, STEP_M * y, -v).values, readings.values)
    flat = cell_readings(STEP_M * x, STEP_M * y, np.full(20, 0.3))
    assert grid_bias(flat, error) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("share", [0.37, 0.43, 0.61])
def test_the_area_is_the_union_of_the_lattices_registrations_and_its_term_the_closed_forms(share):
    """v = 1 + x at x = 0..5 (3 rows), read exactly: the area above `share` of the peak (6)
    is the spots right of t = 6 share - 1, counted in closed form for each registration of
    the lattice (its spots at i + cell_offsets(8) + d, d over cell_offsets(5) / 8, the y
    moves changing nothing). The corrected area is their mean, the count over the union's
    AREA_SAMPLES spots a cell, within half a column of them (1 / 480) of the continuum's
    (5.5 - t) / 6; its term is their spread over 5 and the change from the coarser union's
    count (3 x 3 registrations, 24 spots a cell) in quadrature."""
    x, y = np.meshgrid(np.arange(6.0), np.arange(3.0))
    readings = cell_readings(STEP_M * x.ravel(), STEP_M * y.ravel(), (1.0 + x).ravel())
    t = 6.0 * share - 1.0

    def count(samples: int, move: float = 0.0) -> float:
        return float(np.mean((np.arange(6.0)[:, None] + cell_offsets(samples)).ravel() + move >= t))

    moves = cell_offsets(LATTICE_REGISTRATIONS) / READING_SAMPLES
    counts = [count(READING_SAMPLES, d) for d in moves for _ in moves]
    union = float(np.mean(counts))
    assert union == pytest.approx(count(AREA_SAMPLES), abs=1e-12)
    assert abs(union - (5.5 - t) / 6.0) <= 0.5 / (AREA_SAMPLES * 6)
    error = GridError("fraction_above_share", share)
    assert homogeneity(1.0 + x, share).fraction_above_share - grid_bias(readings, error) == pytest.approx(union, abs=1e-12)
    term = grid_quadrature_term(readings, error)
    assert term.std_uncertainty == pytest.approx(
        math.hypot(np.std(counts, ddof=1) / LATTICE_REGISTRATIONS, count(3 * READING_SAMPLES) - union), rel=1e-9)
    assert 0.0 < term.std_uncertainty <= 0.5 / (READING_SAMPLES * 6)


def test_an_n0_modes_area_is_read_over_the_union_closer_than_on_its_own_lattice():
    """(n, 0) cosine modes cos(k x + a), 2 to 4 points per half-wavelength at random phases
    (100, seeded), against the continuum (480 spots a cell along x, the contours straight
    across y): their contours cross every cell's spots as straight lines, so the count of
    the figure's own lattice of 8 spots a cell dips or rises by whole columns of spots at a
    time (up to 0.031 here); the corrected area, the count over the union of its 25
    registrations (40 spots per axis), errs under 0.3 of the own lattice's error (rms: a
    fifth of the spot, a fifth of the error)."""
    rng = np.random.default_rng(46)
    own, union = [], []
    for _ in range(100):
        x, y, sampled, fine = _sampled_mode(rng, "n0", rng.uniform(2.0, 4.0), refine=(480, 1))
        readings = cell_readings(STEP_M * x, STEP_M * y, sampled)
        error = GridError("fraction_above_share", 0.5)
        continuum = float(np.mean(fine >= error.threshold(np.abs(sampled))))
        own.append(float(np.mean(readings.values >= error.threshold(np.abs(sampled)))) - continuum)
        union.append(homogeneity(sampled).fraction_above_share - grid_bias(readings, error) - continuum)
    assert np.sqrt(np.mean(np.square(union))) < 0.3 * np.sqrt(np.mean(np.square(own)))


def test_the_noise_of_the_peak_moves_the_corrected_area_as_its_threshold_does():
    """A line scan v = 1 + x at x = 0..7 whose peak alone is noisy (sigma 0.4): no point
    crosses half of the peak, so the points' own area stays put, but the threshold over the
    cells, half the peak, moves by sigma / 2 across a field rising 1 a step, and the
    corrected area, the cells' right of it over 8 steps, by sigma / 16: the area's U is that
    times its k, to the spots' steps of 1/64 (the threshold, at x = 3, lies between two
    spots at every registration of their lattice: no quadrature term)."""
    x = np.arange(8.0)
    value = 1.0 + x
    sigma = 0.4
    points = pd.DataFrame({"x_m": STEP_M * x, "y_m": 0.0, "in_touch_area": True, "velocity_pp_mps": value,
                           "velocity_pp_mps_u": np.where(x == 7.0, sigma, 0.0), "signed_velocity_pp_mps": value,
                           "generator_frequency_hz": 50e3})
    readings = cell_readings(STEP_M * x, np.zeros(8), value)
    assert grid_quadrature_term(readings, GridError("fraction_above_share", 0.5)).std_uncertainty == 0.0
    k = Budget("area", "1", 1.0, (Term("noise", "A", 1.0, "normal"),)).coverage_factor
    assert summarise_map(points)["fraction_above_share_U"] / k == pytest.approx(sigma / 16.0, rel=0.05)


def test_the_bending_reading_of_a_cosine_over_whole_half_waves_is_the_closed_form_cv():
    """|cos(pi x / 4)| over whole half-waves (4 points each, 5 half-waves): its CV over the
    continuum is sqrt(1/2 - 4/pi^2) / (2/pi) = 0.4834; the points a quarter-cell off the
    antinodes read 0.467 by themselves, the corrected CV (the bending reading of the signed
    field between them) is within 1 % of the closed form: it reads across the nodal lines,
    where the amplitude alone kinks; and the grid's U holds what is left."""
    closed = math.sqrt(0.5 - 4.0 / math.pi**2) / (2.0 / math.pi)
    x, y = np.meshgrid(np.arange(20.0), np.arange(5.0))
    signed = np.cos(math.pi * (x + 0.25) / 4.0).ravel()
    readings = cell_readings(STEP_M * x.ravel(), STEP_M * y.ravel(), signed)
    points = homogeneity(signed).coefficient_of_variation
    assert abs(points - closed) > 0.015
    _, _, expanded = _corrected(readings, np.abs(signed), np.full(5, closed), "coefficient_of_variation")
    corrected = points - grid_bias(readings, GridError("coefficient_of_variation", 0.5))
    assert corrected == pytest.approx(closed, rel=0.01)
    assert abs(corrected - closed) <= max(expanded, 0.002 * closed)


def test_a_line_scan_is_read_along_its_one_axis_and_a_point_not_at_all():
    x = np.arange(6.0)
    bending = cell_readings(x, np.zeros(6), 1.0 + x)
    assert bending.method == "bending" and bending.values.shape == (6, 8)
    assert homogeneity(bending.values.ravel()).coefficient_of_variation == pytest.approx(6.0 / (3.5 * math.sqrt(12.0)),
                                                                                       rel=2e-3)
    assert cell_readings(np.zeros(1), np.zeros(1), np.ones(1)) is None
    assert grid_bias(None, GridError("coefficient_of_variation", 0.5)) == 0.0
    for term in (grid_correction_term, grid_quadrature_term):
        assert term(None, GridError("coefficient_of_variation", 0.5)).std_uncertainty == 0.0
    assert cell_readings(np.arange(3.0), np.zeros(3), np.ones(3)).method == "linear"


def test_the_paper_campaigns_map_plate_solved_ahead_is_read_by_the_bench(tmp_path, monkeypatch, large):
    """`reproduce` solves the working mode its map scans on another process before the
    campaign reaches the map (`commands._solve_campaign_plates`): the bench's stage then reads it from
    the disk cache, solving nothing, and gets the same mode; so does the report's prediction
    of each plate the campaign characterises."""
    from squeezebench import paths
    from squeezebench.commands import _solve_campaign_plates
    from squeezebench.disk_cache import CACHE_VARIABLE
    from squeezebench.plates import plate_modes
    from squeezebench.protocols.campaign import mapped_scenes

    scene, state = large
    assert mapped_scenes(paths.paper_campaign()) == [scenes_dir() / "large_plate.yaml"]
    monkeypatch.setenv(CACHE_VARIABLE, str(tmp_path))
    plate_modes._CACHE.clear()
    _solve_campaign_plates(paths.paper_campaign())
    solved, k = working_mode(scene, state)
    plate_modes._CACHE.clear()   # another process: only the disk cache is shared
    monkeypatch.setattr(plate_modes, "_eigenpairs", lambda *a, **kw: pytest.fail("solved again"))
    read, k_read = working_mode(scene, state)
    assert k_read == k and np.array_equal(read.shapes, solved.shapes)
    # the characterised plates too, which the report predicts at its end (`report.simulated_plates`)
    from squeezebench.protocols.campaign import characterised_scenes
    from squeezebench.simbench import predicted

    assert len(characterised_scenes(paths.paper_campaign())) == 7
    for path in characterised_scenes(paths.paper_campaign()):
        small = load_scene(path)
        assert predicted.predict(small, small.state(small.initial_state)).frequency_hz > 0


def test_the_table_kept_on_disk_is_read_back_bit_for_bit_without_evaluating_the_elements(large, tmp_path, monkeypatch):
    """`reproduce` tabulates the map's working mode (and solves its spline) on the process
    that solved the plate; the campaign's process reads both instead, and interpolates to
    the last bit as a cubic `RegularGridInterpolator` of the elements' values does."""
    from scipy.interpolate import RegularGridInterpolator

    from squeezebench.plates import plate_modes
    from squeezebench.simbench import modeshape

    scene, state = large
    monkeypatch.setenv("SQUEEZEBENCH_CACHE", str(tmp_path))
    monkeypatch.setattr(modeshape, "_TABLES", {})
    modes, k = working_mode(scene, state)
    if modes.stored_key is None:   # solved before this test's cache: the same solve, kept here now
        modes = replace(modes, stored_key="0" * 64)
    built = modeshape._table(modes, k)
    assert len(list((tmp_path / "plates").glob("*.npz"))) == 1
    x_m, y_m = built.grid
    plain = RegularGridInterpolator((x_m, y_m), modes.shape_at(k, *np.meshgrid(x_m, y_m, indexing="ij")),
                                    method="cubic", bounds_error=False, fill_value=0.0)

    monkeypatch.setattr(modeshape, "_TABLES", {})
    monkeypatch.setattr(plate_modes.PlateModes, "shape_at", lambda *_: pytest.fail("the elements evaluated again"))
    read = modeshape._table(modes, k)
    rng = np.random.default_rng(5)
    points = np.column_stack([rng.uniform(-0.01, x_m[-1] + 0.01, 500), rng.uniform(-0.01, y_m[-1] + 0.01, 500)])
    assert np.array_equal(read(points), plain(points)) and np.array_equal(built(points), plain(points))
    assert modeshape._table_key(modes.stored_key, k + 1) != modeshape._table_key(modes.stored_key, k)
