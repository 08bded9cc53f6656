"""The lean averaged acquisition (simbench.traces.average_of_records) against drawing
every record: the reduced power and velocity have the same mean and spread over seeds,
with quantisation, noise (above and below a step) and the clip in play."""

import math
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from squeezebench.analysis.waveforms import fit_sine, integer_period_mean_power_w
from squeezebench.simbench import effects as fx
from squeezebench.simbench import traces

SETTINGS = fx.DigitizerSettings(sample_lsb_div=fx.ADC_SPAN_DIV / 2**9, average_lsb_div=fx.ADC_SPAN_DIV / 2**14,
                                averaging=True)
STEP_DIV = SETTINGS.sample_lsb_div
FREQUENCY_HZ = 1000.0
DT_S = 1e-5


def screen(n_samples: int, voltage_amplitude_div: float) -> np.ndarray:
    """CH1 voltage, CH2 current (leading by 60 degrees, with an offset), CH3 velocity (small:
    a few steps, where quantisation's bias shows), in divisions."""
    phase = 2 * math.pi * FREQUENCY_HZ * DT_S * np.arange(n_samples)
    return np.stack([voltage_amplitude_div * np.sin(phase), 2.5 * np.sin(phase + math.pi / 3) + 0.3,
                     3.3 * STEP_DIV * np.sin(phase + 0.4)])


# Noise: CH1 half a step (below the dithering threshold), CH2 1.5 steps (dithered), CH3 a
# quarter step (quantisation biases the average; averaging cannot remove it).
NOISE_DIV = np.array([0.5, 1.5, 0.25]) * STEP_DIV


def every_record(signals: np.ndarray, averages: int, rng: np.random.Generator) -> np.ndarray:
    return traces._clip(np.stack([
        traces._kept_average(traces._sum_of_records(s, sigma, averages, STEP_DIV, rng), averages, SETTINGS, rng)
        for s, sigma in zip(signals, NOISE_DIV)]))


def lean(signals: np.ndarray, averages: int, rng: np.random.Generator) -> np.ndarray:
    return traces.digitize(signals, NOISE_DIV, averages, SETTINGS, rng)


def unquantised(signals: np.ndarray, averages: int, rng: np.random.Generator) -> np.ndarray:
    """What ignoring the sample quantisation would draw: the control the test must reject."""
    return signals + (NOISE_DIV / math.sqrt(averages))[:, None] * rng.standard_normal(signals.shape)


def reduced(records: np.ndarray) -> tuple[float, float]:
    """Power (the paper's integer-period mean of v i) and velocity peak-to-peak (sine fit)."""
    time_s = DT_S * np.arange(records.shape[1])
    power = integer_period_mean_power_w(records[0], records[1], DT_S, FREQUENCY_HZ)
    velocity = fit_sine(time_s, records[2], FREQUENCY_HZ, frequency_is_estimated_here=False).pp.value
    return power, velocity


def over_seeds(draw, signals, averages, seeds):
    return np.array([reduced(draw(signals, averages, np.random.default_rng(seed))) for seed in seeds])


def same_distribution(a: np.ndarray, b: np.ndarray) -> bool:
    """Means within 4.5 standard errors and spreads within the F-test's 99.9 % band, per column."""
    se = np.sqrt(a.var(axis=0, ddof=1) / len(a) + b.var(axis=0, ddof=1) / len(b))
    means_agree = np.abs(a.mean(axis=0) - b.mean(axis=0)) <= 4.5 * se
    ratio = a.std(axis=0, ddof=1) / b.std(axis=0, ddof=1)
    band = math.exp(3.3 * math.sqrt(2.0 / (len(a) - 1)))   # log of an sd ratio ~ N(0, 1/(2(n-1))) x 2
    spreads_agree = (ratio > 1 / band) & (ratio < band)
    return bool(means_agree.all() and spreads_agree.all())


@pytest.mark.parametrize("averages, n_samples, n_seeds, amplitude_div", [
    (16, 2000, 150, 3.5),      # a few records: the sums' lattice decides record by record
    (64, 2000, 150, 5.11),     # the voltage's peaks within noise of the clip
    (512, 1000, 60, 3.5),
])
def test_lean_average_matches_drawing_every_record(averages, n_samples, n_seeds, amplitude_div):
    signals = screen(n_samples, amplitude_div)
    drawn = over_seeds(every_record, signals, averages, range(n_seeds))
    leaned = over_seeds(lean, signals, averages, range(1000, 1000 + n_seeds))
    assert same_distribution(leaned, drawn)
    # the comparison can fail: ignoring the quantisation misses the velocity's bias
    assert not same_distribution(over_seeds(unquantised, signals, averages, range(2000, 2000 + n_seeds)), drawn)


def test_moments_of_a_quantised_record_are_exact():
    rng = np.random.default_rng(5)
    steps = np.array([0.0, 0.3, 0.5, 255.8, 300.0])   # on a level, between, on a threshold, at / past the clip
    mean, variance = traces._level_moments(steps, 0.4, -256, 256)
    draws = np.clip(np.round(steps[:, None] + 0.4 * rng.standard_normal((steps.size, 400_000))), -256, 256)
    np.testing.assert_allclose(mean, draws.mean(axis=1), atol=5e-3)
    np.testing.assert_allclose(variance, draws.var(axis=1), atol=5e-3)
    assert variance[-1] == 0.0 and mean[-1] == 256.0   # held at the clip


@settings(max_examples=60, deadline=None)
@given(sigma_steps=st.floats(0.05, 1.2), averages=st.integers(1, 80), seed=st.integers(0, 2**32 - 1))
def test_sums_said_to_be_drawn_record_by_record_have_no_direct_sample(sigma_steps, averages, seed):
    """Where `_some_sum_is_direct` says no sample's sum is direct, `sum_of_records` skips
    their moments: working them out must find no direct sample, on any signal clear of the clip."""
    signal = np.random.default_rng(seed).uniform(-3.0, 3.0, 4000)
    said_direct = traces._some_sum_is_direct(sigma_steps, averages)
    with mock.patch.object(traces, "_some_sum_is_direct", lambda *_: True):   # the moments, always
        full = traces.sum_of_records(signal, sigma_steps * STEP_DIV, averages, fx.DigitizerSettings(
            sample_lsb_div=STEP_DIV, average_lsb_div=SETTINGS.average_lsb_div, averaging=True,
            dither_threshold_lsb=math.inf))   # keeps the per-sample moments in play at every noise
    if not said_direct:
        assert not full.direct.any()


@pytest.mark.parametrize("averages", [4, 8])
def test_records_drawn_record_by_record_are_drawn_as_before(monkeypatch, averages):
    """Half a step of noise, 4 or 8 averages (the search's): no sum is direct, so its moments
    are skipped, and the records are exactly those the full computation draws."""
    signals = screen(2000, 3.5)
    noise_div = np.full(3, 0.5 * STEP_DIV)
    assert not traces._some_sum_is_direct(0.5, averages)
    lean = traces.digitize(signals, noise_div, averages, SETTINGS, np.random.default_rng(3))
    monkeypatch.setattr(traces, "_some_sum_is_direct", lambda sigma_steps, n: True)
    full = traces.digitize(signals, noise_div, averages, SETTINGS, np.random.default_rng(3))
    np.testing.assert_array_equal(lean, full)


def test_an_effect_that_is_off_costs_nothing_and_no_noise_is_exact():
    signals = screen(500, 3.5)
    quiet = traces.digitize(signals, np.zeros(3), 512, SETTINGS, rng=None)   # no random draw at all
    expected = traces._clip(traces._quantise(traces._quantise(traces._clip(signals), STEP_DIV),
                                             SETTINGS.average_lsb_div))
    np.testing.assert_array_equal(quiet, expected)


@pytest.mark.parametrize("averages", [1, 4, 512])
def test_records_of_a_kept_screen_are_those_of_fresh_ones_draw_for_draw(averages):
    """A bench keeps a screen's sums of records for its next acquisitions at the same
    settings: the records are then exactly what computing everything again gives."""
    signals = screen(2000, 5.11)   # near the clip, some samples drawn record by record
    kept: dict = {}
    for seed in range(3):
        again = traces.digitize(signals, NOISE_DIV, averages, SETTINGS, np.random.default_rng(seed), kept)
        fresh = traces.digitize(signals, NOISE_DIV, averages, SETTINGS, np.random.default_rng(seed))
        np.testing.assert_array_equal(again, fresh)
    assert len(kept) == (3 if averages > 1 else 0)


def test_a_bench_reuses_a_screen_only_while_its_settings_and_drive_stay():
    from squeezebench import paths
    from squeezebench.instruments.bench import open_bench, sim_bench_config

    with open_bench(sim_bench_config(paths.default_scene())) as bench:
        simulated = bench.resource_manager.visalib.bench
        bench.generator.set_frequency(37000.0)
        bench.scope.acquire()
        first = simulated._screen_cache[1]
        bench.scope.acquire()
        assert simulated._screen_cache[1] is first
        bench.generator.set_frequency(37100.0)
        bench.scope.acquire()
        assert simulated._screen_cache[1] is not first


@pytest.mark.parametrize("effects", [["scope_noise", "quantisation", "averaging", "dc_offset", "vibrometer_noise"],
                                     ["scope_noise", "quantisation", "averaging", "clipped_trace"]])
def test_a_re_ranged_channel_draws_the_record_a_fresh_screen_draws(tmp_path, monkeypatch, effects):
    """A channel re-ranged at the same drive keeps the last screen's signals and the other
    channels' rows and sums (`traces.placed_anew`): every record is, bit for bit, what
    computing the screen afresh draws; an effect whose signals read the scale (a clipped
    trace's spike is a height in divisions) has its screen computed afresh."""
    from squeezebench import paths
    from squeezebench.protocols.acquisition import AcquisitionSettings
    from squeezebench.protocols.simulated_session import open_simulated
    from squeezebench.yamlfiles import dump_yaml, load_strict

    scene = load_strict(paths.default_scene().read_text(encoding="utf-8"))
    (tmp_path / "scene.yaml").write_text(dump_yaml({**scene, "effects": effects}), encoding="utf-8")

    def records(placed_anew):
        monkeypatch.setattr(traces, "placed_anew", placed_anew)
        kept, reused = [], []
        with open_simulated(tmp_path / "scene.yaml", None, 0.5) as session:
            session.acquisition(AcquisitionSettings(averages=16))   # configures the scope
            session.drive.set_piezo_voltage(10.0)
            session.drive.set_frequency(37000.0)
            scope = session.bench.scope
            for scale_v_per_div in (2.0, 1.0, 1.0, 0.5):
                scope.set_vertical_scales({1: 2.0, 2: 0.5, 3: scale_v_per_div})
                scope.acquire()
                kept.append(np.stack([scope.fetch_waveform(ch).values for ch in (1, 2, 3)]))
                reused.append(session.simulated._screen_cache[1].channel_values)
        return kept, reused

    placed, placed_channels = records(traces.placed_anew)
    fresh, fresh_channels = records(lambda *args, **kwargs: None)
    for a, b in zip(placed, fresh):
        np.testing.assert_array_equal(a, b)
    assert (placed_channels[3] is placed_channels[0]) == ("clipped_trace" not in effects)
    assert fresh_channels[3] is not fresh_channels[0]


def test_another_vibrometer_range_keeps_the_other_channels_sums(tmp_path, monkeypatch):
    """A search re-ranges the vibrometer at the same drive: the screen is computed afresh,
    but CH1 and CH2 show what they showed, so their sums of records are the last screen's
    (`Screen.keep_sums_of`), and every record is, bit for bit, what fresh sums draw."""
    from squeezebench import paths
    from squeezebench.protocols.acquisition import AcquisitionSettings
    from squeezebench.protocols.simulated_session import open_simulated

    def records(keep_sums_of):
        monkeypatch.setattr(traces.Screen, "keep_sums_of", keep_sums_of)
        kept, screens = [], []
        with open_simulated(paths.default_scene(), None, 0.5) as session:
            session.acquisition(AcquisitionSettings(averages=16))   # configures the scope
            session.drive.set_piezo_voltage(10.0)
            session.drive.set_frequency(37000.0)
            vibrometer, scope = session.bench.vibrometer, session.bench.scope
            for name in list(vibrometer.ranges_mps_per_v)[:3]:
                vibrometer.set_range(name)
                scope.acquire()
                kept.append(np.stack([scope.fetch_waveform(ch, allow_clipped=True).values for ch in (1, 2, 3)]))
                screens.append(session.simulated._screen_cache[1])
        return kept, screens

    shared, shared_screens = records(traces.Screen.keep_sums_of)
    fresh, fresh_screens = records(lambda self, earlier: None)
    for a, b in zip(shared, fresh):
        np.testing.assert_array_equal(a, b)
    first, last = shared_screens[0], shared_screens[-1]
    assert last is not first and all(last.sums[ch] is first.sums[ch] for ch in (0, 1)) and last.sums[2] is not first.sums[2]
    assert all(fresh_screens[-1].sums[ch] is not fresh_screens[0].sums[ch] for ch in range(3))
