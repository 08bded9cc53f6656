"""Waveform reduction: closed forms without noise, honest uncertainties with noise,
properties (V^2 scaling, time-shift invariance), hard inputs, clear errors."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from squeezebench.analysis import waveforms as wf


def sines(n=4000, periods=23.4, f=43_792.0, v_amp=12.0, i_amp=0.05, phi=1.0, dc_v=0.0, dc_i=0.0,
          vib_amp=0.8, t0=1e-4, dtype=np.float64):
    dt = periods / f / n
    t = t0 + np.arange(n) * dt
    w = 2 * np.pi * f * t
    return (t.astype(dtype), (v_amp * np.sin(w) + dc_v).astype(dtype),
            (i_amp * np.sin(w - phi) + dc_i).astype(dtype), (vib_amp * np.sin(w + 0.3)).astype(dtype))


def test_noise_free_reduction_equals_closed_form():
    t, v, i, vib = sines()
    r = wf.reduce_point(t, v, i, vib, 0.125)
    truth_power = 0.5 * 12.0 * 0.05 * math.cos(1.0)
    assert r.frequency_hz.value == pytest.approx(43_792.0, rel=1e-9)
    assert r.power_fit_w.value == pytest.approx(truth_power, rel=1e-9)
    assert r.power_w.value == pytest.approx(truth_power, rel=1e-9)
    assert r.piezo_voltage_vpp.value == pytest.approx(24.0, rel=1e-9)
    assert r.velocity_pp_mps.value == pytest.approx(2 * 0.8 * 0.125, rel=1e-9)
    assert r.amplitude_pp_m.value == pytest.approx(2 * 0.8 * 0.125 / (2 * np.pi * 43_792.0), rel=1e-9)
    assert r.n_periods == 23


@pytest.mark.parametrize("phi", [1.5, 1.56, 1.569])
def test_integer_period_power_is_corrected_for_its_window(phi):
    # 37.3 samples per period: the window's sum misses the product's mean by a remainder of
    # its twice-frequency part, a growing share of the power as the power factor falls
    # (2e-3 of it at phi = 1.569). The reduction subtracts it rather than budgeting it.
    f = 43_792.0
    dt = 1 / (f * 37.3)
    t = np.arange(10_000) * dt
    v, i = 10.0 * np.sin(2 * np.pi * f * t), 0.1 * np.sin(2 * np.pi * f * t - phi)
    truth = 0.5 * 10.0 * 0.1 * math.cos(phi)
    r = wf.reduce_point(t, v, i, 0.2 * np.sin(2 * np.pi * f * t), 0.125)
    assert abs(wf.integer_period_mean_power_w(v, i, dt, f) / truth - 1) > 5e-5   # the window's bias is there
    assert r.power_w.value == pytest.approx(truth, rel=1e-9)
    assert r.power_w.std_uncertainty < 1e-9 * truth


def test_integer_period_mean_is_exact_for_whole_periods_in_whole_samples():
    # 40 samples per period exactly: the window is a whole number of samples, no bias.
    f = 50_000.0
    dt = 1 / (f * 40)
    t = np.arange(4010) * dt
    v = 3.0 * np.sin(2 * np.pi * f * t) + 100.0
    i = 2.0 * np.sin(2 * np.pi * f * t - 1.5) - 7.0
    assert wf.integer_period_mean_power_w(v, i, dt, f) == pytest.approx(3.0 * math.cos(1.5), rel=1e-9)


@pytest.mark.parametrize("case", ["pf_0.001", "non_integer", "big_dc", "few_samples", "float32"])
def test_hard_cases_within_stated_uncertainty(case):
    kwargs = {"pf_0.001": dict(phi=math.acos(1e-3)), "non_integer": dict(periods=7.77),
              "big_dc": dict(dc_v=500.0, dc_i=20.0), "few_samples": dict(n=200, periods=41.3),
              "float32": dict(dtype=np.float32)}[case]
    t, v, i, vib = sines(**kwargs)
    rng = np.random.default_rng(3)
    v = v + rng.normal(0, 0.01, v.size).astype(v.dtype)
    i = i + rng.normal(0, 1e-4, i.size).astype(i.dtype)
    r = wf.reduce_point(t, v, i, vib, 0.125, y_increments={"piezo_voltage_v": 1e-3})
    truth = 0.5 * 12.0 * 0.05 * math.cos(kwargs.get("phi", 1.0))
    for estimate in (r.power_w, r.power_fit_w):
        assert abs(estimate.value - truth) <= 4 * estimate.std_uncertainty + 1e-6 * abs(truth), (case, estimate)


def _coverage(trials: int, noise_v: float, noise_i: float, noise_vib: float):
    rng = np.random.default_rng(12345)
    truth_power = 0.5 * 12.0 * 0.05 * math.cos(1.3)
    hits = {"power_w": 0, "power_fit_w": 0, "velocity_pp_mps": 0, "frequency_hz": 0}
    for _ in range(trials):
        periods = rng.uniform(15, 30)
        t, v, i, vib = sines(n=2000, periods=periods, phi=1.3, t0=rng.uniform(0, 1e-3))
        r = wf.reduce_point(t, v + rng.normal(0, noise_v, v.size), i + rng.normal(0, noise_i, i.size),
                            vib + rng.normal(0, noise_vib, vib.size), 0.125)
        truths = {"power_w": truth_power, "power_fit_w": truth_power, "velocity_pp_mps": 0.2,
                  "frequency_hz": 43_792.0}
        for key, truth in truths.items():
            estimate = getattr(r, key)
            hits[key] += abs(estimate.value - truth) <= 2 * estimate.std_uncertainty
    return {k: v / trials for k, v in hits.items()}


def test_stated_uncertainties_cover_the_truth():
    # k = 2 should cover ~95 %; with 200 trials accept 90-100 % (binomial scatter ~1.5 %).
    coverage = _coverage(200, noise_v=0.2, noise_i=2e-3, noise_vib=0.02)
    for key, fraction in coverage.items():
        assert fraction >= 0.90, coverage


@settings(max_examples=40, deadline=None, derandomize=True)
@given(scale=st.floats(0.01, 100.0), shift=st.integers(0, 3999))
def test_power_scales_with_voltage_squared(scale, shift):
    """Voltage and current both scale with V on a linear plate: power scales with V^2."""
    t, v, i, _ = sines()
    dt = t[1] - t[0]
    base = wf.integer_period_mean_power_w(v, i, dt, 43_792.0)
    scaled = wf.integer_period_mean_power_w(scale * v, scale * i, dt, 43_792.0)
    assert scaled == pytest.approx(scale**2 * base, rel=1e-9)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(start=st.floats(0.0, 1.0))
def test_integer_period_mean_is_time_shift_invariant(start):
    """Whatever the phase at the first sample, a whole number of periods gives the same mean
    (up to the window's sub-sample discretisation, small at 100+ samples per period)."""
    f, n = 43_792.0, 6000
    dt = 1 / (f * 171.3)
    t = (start / f) + np.arange(n) * dt
    v = 5.0 * np.sin(2 * np.pi * f * t) + 2.0
    i = 0.1 * np.sin(2 * np.pi * f * t - 0.7) + 0.5
    assert wf.integer_period_mean_power_w(v, i, dt, f) == pytest.approx(0.25 * math.cos(0.7), rel=2e-3)


def test_fitted_pp_is_not_noise_biased_but_raw_is():
    rng = np.random.default_rng(7)
    t, v, i, vib = sines()
    r = wf.reduce_point(t, v, i, vib + rng.normal(0, 0.2, vib.size), 0.125)
    assert r.velocity_pp_mps.value == pytest.approx(0.2, rel=0.02)
    assert r.velocity_raw_pp_mps > 0.25  # max - min picks up the noise peaks


@pytest.mark.parametrize("bad, message", [
    (np.array([]), "non-empty"),
    (np.array([1.0, np.nan, 2.0]), "NaN"),
])
def test_empty_or_nan_input_is_a_value_error(bad, message):
    with pytest.raises(ValueError, match=message):
        wf.as_samples("current_a", bad)


def test_nan_anywhere_rejected_by_the_fast_path():
    t, v, i, _ = sines()
    i[-1] = np.nan  # after the integer-period window
    with pytest.raises(ValueError, match="NaN"):
        wf.integer_period_mean_power_w(v, i, t[1] - t[0], 43_792.0)
    with pytest.raises(ValueError, match="NaN"):
        wf.reduce_point(t, v, i, v, 0.125)


def test_record_shorter_than_a_period_is_refused():
    t, v, i, _ = sines(n=100, periods=0.5)
    with pytest.raises(ValueError, match="shorter than one period"):
        wf.integer_period_mean_power_w(v, i, t[1] - t[0], 43_792.0)


def test_channel_without_oscillation_still_reduces():
    """A plate that does not move: velocity ~0 with its uncertainty, no exception."""
    t, v, i, _ = sines()
    rng = np.random.default_rng(11)
    r = wf.reduce_point(t, v, i, rng.normal(0, 1e-3, t.size), 0.125)
    assert r.velocity_pp_mps.value < 5 * r.velocity_pp_mps.std_uncertainty + 1e-4
