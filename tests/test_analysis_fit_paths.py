"""The fast reduction paths (one shared basis from exact rotations, Gauss-Newton on the
frequency) against the plain computations they replace: np.linalg.lstsq on np.sin /
np.cos, and scipy's bounded search of the residual."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import optimize

from squeezebench.analysis import waveforms


def plain_fit(tau, y, frequency_hz):
    phase = 2 * np.pi * frequency_hz * tau
    design = np.column_stack([np.sin(phase), np.cos(phase), np.ones_like(phase)])
    coefficients = np.linalg.lstsq(design, y, rcond=None)[0]
    return coefficients, y - design @ coefficients


def record(n, periods, phase, noise, float32_time, seed):
    frequency_hz = 37180.0
    dt = periods / frequency_hz / n
    t = (np.arange(n) - n / 2) * dt
    if float32_time:
        t = t.astype(np.float32).astype(np.float64)
    y = 3.0 * np.sin(2 * np.pi * frequency_hz * t + phase) + 0.2 + noise * np.random.default_rng(seed).normal(size=n)
    return t, y, frequency_hz


@settings(max_examples=40, deadline=None)
@given(st.sampled_from([500, 2001, 10000]), st.floats(1.2, 60.0), st.floats(0.0, 6.3), st.floats(1e-4, 0.3),
       st.booleans(), st.integers(0, 2**32 - 1))
def test_fast_paths_equal_the_plain_computations(n, periods, phase, noise, float32_time, seed):
    t, y, frequency_hz = record(n, periods, phase, noise, float32_time, seed)
    tau = t - 0.5 * (t[0] + t[-1])
    fit = waveforms.fit_sine(t, y, frequency_hz * 1.0003)
    coefficients, residual = plain_fit(tau, y - y.mean(), frequency_hz * 1.0003)
    np.testing.assert_allclose([fit.sin_coefficient, fit.cos_coefficient], coefficients[:2], rtol=1e-9, atol=1e-12)
    assert math.isclose(fit.residual_rms, math.sqrt(residual @ residual / n), rel_tol=1e-8)

    found_hz = waveforms.estimate_frequency_hz(t, y)
    bin_hz = 1.0 / (n * waveforms.sample_interval_s(t))

    def rss(f):
        residual = plain_fit(tau, y - y.mean(), f)[1]
        return float(residual @ residual)

    best = optimize.minimize_scalar(lambda x: rss(found_hz + x * bin_hz), bounds=(-0.5, 0.5), method="bounded",
                                    options={"xatol": 1e-9})
    assert abs(best.x) < 1e-6   # no better frequency nearby: the residual's minimum
