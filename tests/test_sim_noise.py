"""The digitiser's noise as the bench draws it (`traces.acquisition_rng` from
`traces.acquisition_seed`): zero mean, the scene's variance (sigma^2, sigma^2 / N averaged,
the exact moments of quantised records), white within a record, independent between
channels and between acquisitions, and the same draw from the same seed.

Bounds: a sample mean within 4.5 standard errors, a sample variance within 4.5 of its
standard deviations (2 sigma^4 / (n - 1) for a normal), a correlation within 4.5 / sqrt(n)."""

import math
import zlib

import numpy as np
import pytest

from squeezebench.simbench import effects as fx
from squeezebench.simbench import traces

N_SAMPLES = 40_000
BOUND = 4.5
NOISE_DIV = np.array([0.01, 0.03, 0.02])   # the shipped scenes' scope noise is 0.01 to 0.03 div rms
UNQUANTISED = fx.DigitizerSettings()
AVERAGED = fx.DigitizerSettings(averaging=True)
QUANTISED = fx.DigitizerSettings(sample_lsb_div=fx.ADC_SPAN_DIV / 2**9, average_lsb_div=fx.ADC_SPAN_DIV / 2**14,
                                 averaging=True)


def rng(counter: int, spot: str | None = None) -> np.random.Generator:
    return traces.acquisition_rng(traces.acquisition_seed(7, "mounted", "37180 Hz 1.88 Vpp", counter, spot))


def signals() -> np.ndarray:
    """Three channels' signals (divisions) well inside the ADC's span."""
    phase = np.linspace(0.0, 40.0 * math.pi, N_SAMPLES)
    return np.stack([3.0 * np.sin(phase), 2.0 * np.cos(phase) + 0.5, 1.5 * np.sin(phase + 0.4)])


def noise_of(averages: int, settings: fx.DigitizerSettings, counter: int, spot: str | None = None) -> np.ndarray:
    screen = signals()
    return traces.digitize(screen, NOISE_DIV, averages, settings, rng(counter, spot)) - screen


def correlation(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.corrcoef(a, b)[0, 1])


def assert_normal_moments(noise: np.ndarray, sigma: float) -> None:
    n = noise.size
    assert abs(noise.mean()) <= BOUND * sigma / math.sqrt(n)
    assert abs(noise.var(ddof=1) - sigma**2) <= BOUND * sigma**2 * math.sqrt(2.0 / (n - 1))


def assert_white(noise: np.ndarray) -> None:
    for lag in (1, 2, 3, 10):
        assert abs(correlation(noise[:-lag], noise[lag:])) <= BOUND / math.sqrt(noise.size)


@pytest.mark.parametrize("averages, settings", [(1, UNQUANTISED), (16, AVERAGED), (512, AVERAGED)])
def test_noise_has_the_scenes_variance_and_is_white_and_independent_between_channels(averages, settings):
    noise = noise_of(averages, settings, counter=0)
    for channel, sigma in enumerate(NOISE_DIV):
        assert_normal_moments(noise[channel], sigma / math.sqrt(averages))
        assert_white(noise[channel])
    for first, second in ((0, 1), (0, 2), (1, 2)):
        assert abs(correlation(noise[first], noise[second])) <= BOUND / math.sqrt(N_SAMPLES)


@pytest.mark.parametrize("averages, settings", [(1, UNQUANTISED), (16, AVERAGED), (4, QUANTISED)])
def test_acquisitions_draw_independent_noise_and_a_seed_draws_the_same(averages, settings):
    first = noise_of(averages, settings, counter=0)
    for other in (noise_of(averages, settings, counter=1), noise_of(averages, settings, counter=0, spot="(1.0, 2.0)")):
        for channel in range(3):
            assert abs(correlation(first[channel], other[channel])) <= BOUND / math.sqrt(N_SAMPLES)
    np.testing.assert_array_equal(noise_of(averages, settings, counter=0), first)


@pytest.mark.parametrize("scene_seed", [0, 7, 2**32 - 1, 2**32, 2**64 + 3])
@pytest.mark.parametrize("spot", [None, "(1.0, 2.0)"])
def test_a_seed_is_the_stream_of_its_keys_whichever_way_they_reach_seedsequence(scene_seed, spot):
    """`acquisition_seed` hands keys below 2^32 over as uint32 words: the stream is the one
    SeedSequence makes of the keys as a list of ints (as the benches drew before), big keys
    included (handed over as ints)."""
    keys = [scene_seed, zlib.crc32(b"mounted"), zlib.crc32(b"37180 Hz 1.88 Vpp"), 3]
    if spot is not None:
        keys.append(zlib.crc32(spot.encode()))
    seed = traces.acquisition_seed(scene_seed, "mounted", "37180 Hz 1.88 Vpp", 3, spot)
    np.testing.assert_array_equal(seed.generate_state(4, np.uint64),
                                  np.random.SeedSequence(keys).generate_state(4, np.uint64))


@pytest.mark.parametrize("averages", [1, 4])
@pytest.mark.parametrize("phase_steps", [0.0, 0.3, 0.5])
def test_quantised_records_drawn_one_by_one_have_the_exact_moments(averages, phase_steps):
    """Noise of half a step (below the dithering threshold) and few averages: every sample's
    records are drawn and quantised one by one. The kept value of a signal held at a phase
    of a step has the exact mean and variance of one quantised record (`_level_moments`),
    the variance divided by N, and successive samples are independent."""
    step_div = QUANTISED.sample_lsb_div
    settings = QUANTISED if averages > 1 else fx.DigitizerSettings(sample_lsb_div=step_div)
    level_steps = 40.0 + phase_steps
    screen = np.full((3, N_SAMPLES), level_steps * step_div)
    sigma_steps = 0.5
    kept_steps = traces.digitize(screen, np.full(3, sigma_steps * step_div), averages, settings, rng(3)) / step_div
    mean, variance = traces._level_moments(np.array([level_steps]), sigma_steps)
    for channel in range(3):
        values = kept_steps[channel]
        assert abs(values.mean() - mean[0]) <= BOUND * math.sqrt(variance[0] / averages / N_SAMPLES)
        # the variance of a few-level variable: its own fourth moment sets the bound
        spread = values.var(ddof=1)
        fourth = np.mean((values - values.mean()) ** 4)
        assert abs(spread - variance[0] / averages) <= BOUND * math.sqrt((fourth - spread**2) / N_SAMPLES)
        assert_white(values)
