"""The analytic mode shape a map is simulated from, against the free-free beam's closed
forms, and the map's homogeneity numbers and modal assurance criterion."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from squeezebench.analysis.cartography import homogeneity, modal_assurance, signed_amplitude
from squeezebench.paths import scenes_dir
from squeezebench.simbench.modeshape import beam_mode, free_free_root, mode_shape
from squeezebench.simbench.scene import load_scene


def test_free_free_roots_are_the_textbook_values():
    # Blevins Table 8-1: 4.73004074, 7.85320462, 10.9956078, then (n - 1/2) pi
    assert [round(free_free_root(n), 7) for n in (2, 3, 4)] == [4.7300407, 7.8532046, 10.9956078]
    assert free_free_root(21) == pytest.approx(20.5 * np.pi, abs=1e-12)
    with pytest.raises(ValueError):
        free_free_root(1)


@pytest.mark.parametrize("nodes", [2, 5, 21, 60])
def test_the_beam_mode_has_its_nodes_free_ends_and_symmetry(nodes):
    length_m = 0.2
    x = np.linspace(0.0, length_m, 40001)
    phi = beam_mode(x, length_m, nodes)
    assert phi[0] == pytest.approx(1.0, abs=1e-9)
    assert phi[-1] == pytest.approx((-1.0) ** nodes, abs=1e-9)          # symmetric / antisymmetric
    assert np.count_nonzero(np.diff(np.sign(phi)) != 0) == nodes
    assert np.allclose(phi, (-1.0) ** nodes * phi[::-1], atol=1e-8)
    # free edge: zero bending moment (phi'' = 0) at x = 0, by finite differences
    h = x[1] - x[0]
    assert abs(phi[2] - 2 * phi[1] + phi[0]) / h**2 < 1e-3 * (free_free_root(nodes) / length_m) ** 2


def test_the_large_plates_mode_is_uniform_across_the_width_and_zero_off_the_plate():
    scene = load_scene(scenes_dir() / "large_plate.yaml")
    x = np.array([50.0, 50.0, 50.0, -1.0, 199.0])
    y = np.array([0.0, 69.0, 138.0, 10.0, 10.0])
    shape = mode_shape(scene, x, y)
    assert shape[0] == shape[1] == shape[2] != 0.0
    assert shape[3] == shape[4] == 0.0


def test_homogeneity_numbers_of_a_known_set():
    h = homogeneity(np.array([1.0, 2.0, 3.0, 4.0]), share_of_peak=0.7)
    assert (h.mean, h.minimum, h.maximum, h.n_points) == (2.5, 1.0, 4.0, 4)
    assert h.coefficient_of_variation == pytest.approx(np.std([1, 2, 3, 4]) / 2.5)
    assert h.fraction_above_share == 0.5                      # 3 and 4 are >= 2.8
    with pytest.raises(ValueError, match="share_of_peak"):
        homogeneity(np.ones(3), share_of_peak=1.5)


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
    mode = beam_mode(x, 0.198, 21)
    noisy = mode + np.random.default_rng(0).normal(scale=0.05, size=x.size)
    assert modal_assurance(noisy, mode) > 0.99
    with pytest.raises(ValueError, match="different points"):
        modal_assurance(mode, mode[:-1])


def test_the_papers_uniform_mode_claim_as_a_number_for_the_simulated_large_plate():
    """"The mode shape is uniform across the plate", restated: over the touch area (20 mm
    in from the free ends), the antinodes' amplitudes have a coefficient of variation
    under 1 %, and across the width none (to rounding)."""
    from scipy.signal import find_peaks
    scene = load_scene(scenes_dir() / "large_plate.yaml")
    x = np.arange(20.0, 178.0, 0.05)
    row = np.abs(mode_shape(scene, x, 69.0))
    peaks, _ = find_peaks(row)
    antinodes = homogeneity(row[peaks])
    assert antinodes.n_points >= 15
    assert antinodes.coefficient_of_variation < 0.01
    assert antinodes.mean == pytest.approx(1 / np.sqrt(2), rel=0.01)   # interior sqrt(1 + sigma^2) / 2
    across = mode_shape(scene, np.full(50, x[peaks[3]]), np.linspace(0.0, 138.0, 50))
    assert homogeneity(across).coefficient_of_variation < 1e-12
