"""What simbench.traces keeps between acquisitions (a drive's signals, the fundamental's
rotation) and the shortcuts of the kept average give the numbers computing afresh gives,
bit for bit."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from squeezebench.simbench import effects as fx
from squeezebench.simbench import physics, traces

SETTINGS = fx.DigitizerSettings(sample_lsb_div=fx.ADC_SPAN_DIV / 2**9, average_lsb_div=fx.ADC_SPAN_DIV / 2**14,
                                averaging=True)
CHANNEL = traces.ChannelSetup(scale_per_div=1.0, position_div=0.0, coupling="DC", probe_gain=1.0)
SETUP = traces.ScopeSetup(channels=(CHANNEL,) * 3, horizontal_scale_s=4e-5, record_length=10000, averages=16)


def steady(frequency_hz: float, amplitude_v: float) -> physics.SteadyState:
    """One plate mode driven by a sine of `amplitude_v` (amplitude) at `frequency_hz`."""
    load = physics.PlateLoad(capacitance_f=20e-9, branches=(physics.MotionalBranch(
        frequency_hz=30e3, q_mech=200.0, force_factor_n_per_v=0.05, resistance_ns_per_m=0.4, visibility=0.8),))
    drive = physics.Drive(np.array([1]), np.array([amplitude_v * np.exp(0.3j)]), 0.0)
    return physics.solve_steady_state(load, drive, frequency_hz)


def test_a_drive_shown_again_reuses_its_signals_which_are_a_fresh_synthesis():
    first = traces._steady_signals(steady(30e3, 10.0), SETUP)
    again = traces._steady_signals(steady(30e3, 10.0), SETUP)   # the same drive, solved anew
    assert again is first and not first.flags.writeable
    assert np.array_equal(first, traces.synthesize(steady(30e3, 10.0), SETUP.times_s().copy()))
    other = traces._steady_signals(steady(30.1e3, 10.0), SETUP)
    assert not np.array_equal(other, first)


def test_a_kept_rotation_gives_what_computing_it_afresh_gives():
    """Another amplitude at one frequency keeps the rotation, not the signals; a writable
    time base (not a shared one) is computed afresh every time."""
    times_s = SETUP.times_s()
    traces.synthesize(steady(29.9e3, 5.0), times_s)
    kept = traces.synthesize(steady(29.9e3, 7.0), times_s)
    assert np.array_equal(kept, traces.synthesize(steady(29.9e3, 7.0), times_s.copy()))
    # the amplifier's output scales with the drive: the kept rotation is that frequency's
    assert np.allclose(kept[0], 7.0 / 5.0 * traces.synthesize(steady(29.9e3, 5.0), times_s)[0], rtol=1e-12, atol=0)


def random_state(branches: int, orders: tuple[int, ...], seed: int) -> physics.SteadyState:
    """A steady state of `branches` plate modes and harmonic `orders`, its phasors and gains drawn."""
    rng = np.random.default_rng(seed)

    def phasors(*shape):
        return rng.normal(size=shape) + 1j * rng.normal(size=shape)

    modes = tuple(physics.MotionalBranch(frequency_hz=30e3 + 100 * k, q_mech=200.0, force_factor_n_per_v=rng.normal(),
                                         resistance_ns_per_m=0.4, visibility=rng.uniform(-1, 1))
                  for k in range(branches))
    n_orders = len(orders)
    return physics.SteadyState(frequency_hz=30.05e3, orders=np.array(orders), output_voltage_phasors_v=10 * phasors(n_orders),
                               output_dc_v=0.01, piezo_voltage_phasors_v=phasors(n_orders),
                               capacitive_current_phasors_a=1e-3 * phasors(n_orders),
                               branch_velocity_phasors_mps=0.1 * phasors(branches, n_orders), branches=modes)


def transient_fundamentals(state: physics.SteadyState, n: int) -> np.ndarray:
    rng = np.random.default_rng(n)
    shape = (len(state.branches), n)
    return 0.1 * (rng.normal(size=shape) + 1j * rng.normal(size=shape))


@pytest.mark.parametrize("orders", [(1,), (1, 2, 3)])
@pytest.mark.parametrize("branches", [1, 2, 3])
@pytest.mark.parametrize("transient", [False, True])
def test_a_synthesis_is_the_complex_products_real_part_bit_for_bit(orders, branches, transient):
    """`synthesize` works out a one-order product's real part alone: the numbers taking the
    real part of the complex product gives, for one plate mode or several (their sums in
    the modes' order), in steady state or during a transient."""
    state = random_state(branches, orders, branches * 10 + len(orders))
    modes = state.branches
    times_s = SETUP.times_s().copy()
    fundamentals = transient_fundamentals(state, times_s.size) if transient else None
    omega = 2 * np.pi * state.frequency_hz
    trigger_s = (-0.5 * np.pi - np.angle(state.output_voltage_phasors_v[0])) / omega
    rotation = traces._uniform_rotation(omega, float(trigger_s), times_s)
    harmonics = rotation[None, :] ** np.array(orders)[:, None]
    branch = np.real(state.branch_velocity_phasors_mps @ harmonics)
    if transient:
        branch = branch + np.real(fundamentals * rotation - state.branch_velocity_phasors_mps[:, :1] * rotation)
    forces, visibility = (np.array([getattr(m, name) for m in modes]) for name in ("force_factor_n_per_v", "visibility"))
    expected = np.stack([np.real(state.output_voltage_phasors_v @ harmonics) + state.output_dc_v,
                         np.real(state.capacitive_current_phasors_a @ harmonics) + forces @ branch, visibility @ branch])
    assert np.array_equal(traces.synthesize(state, times_s, fundamentals), expected)


@pytest.mark.parametrize("branches", [1, 3])
@pytest.mark.parametrize("transient", [False, True])
@pytest.mark.parametrize("delays_s", [(0.0, 1e-9, 0.0), (-2e-9, 3e-9, 0.0), (1e-9, 1e-9, 5e-9)])
def test_delayed_channels_are_each_the_row_of_a_whole_synthesis_at_their_times(branches, transient, delays_s):
    """`_delayed_signals` synthesises a delayed channel alone at its own times, the others
    together (and `_steady_signals` keeps that): each row is the one a synthesis of all
    three channels at that channel's times gives, bit for bit."""
    state = random_state(branches, (1, 2), branches)
    times_s = SETUP.times_s()
    delays_s = np.array(delays_s)
    fundamentals = transient_fundamentals(state, times_s.size) if transient else None
    expected = np.stack([traces.synthesize(state, times_s - delay, fundamentals)[ch] if delay else
                         traces.synthesize(state, times_s, fundamentals)[ch] for ch, delay in enumerate(delays_s)])
    assert np.array_equal(traces._delayed_signals(state, times_s, delays_s, fundamentals), expected)
    if not transient:
        kept = traces._steady_signals(state, SETUP, delays_s)
        assert np.array_equal(kept, expected) and traces._steady_signals(state, SETUP, delays_s) is kept


@settings(max_examples=80, deadline=None)
@given(n=st.integers(1, 20_000), frequency_hz=st.floats(100.0, 200e3), periods=st.floats(0.5, 50.0),
       trigger_s=st.floats(-1e-4, 1e-4), start=st.floats(-1.0, 0.0))
def test_a_rotation_by_blocks_is_the_sample_by_sample_one(n, frequency_hz, periods, trigger_s, start):
    """The rotation of an evenly spaced time base, worked out by blocks (`_uniform_rotation`),
    is cos + i sin of each sample's phase to within that phase's own rounding."""
    step_s = periods / frequency_hz / n
    times_s = start * n * step_s + np.arange(n) * step_s
    phase = 2 * np.pi * frequency_hz * (times_s + trigger_s)
    by_blocks = traces._uniform_rotation(2 * np.pi * frequency_hz, trigger_s, times_s)
    assert by_blocks.shape == (n,)
    assert np.max(np.abs(by_blocks - traces._cis(phase))) <= 8 * np.finfo(float).eps * (np.max(np.abs(phase)) + 1.0)


@pytest.mark.parametrize("averages", [2, 4, 8, 16, 32])
def test_a_kept_average_of_whole_average_steps_is_the_rounded_mean(averages):
    """Up to the steps' ratio (32 here) the mean is whole average steps: the shortcut gives
    what rounding it gives, +0.0 for a -0.0 sum, and draws nothing for ties."""
    rng = np.random.default_rng(7)
    total = np.round(rng.normal(0.0, 40.0, 2000))
    total[:3] = (-0.0, 0.0, -1.0)
    ratio = round(SETTINGS.sample_lsb_div / SETTINGS.average_lsb_div)
    expected = np.floor(total * (ratio / averages) + 0.5) * SETTINGS.average_lsb_div
    state = rng.bit_generator.state
    kept = traces._kept_average(total.copy(), averages, SETTINGS, rng)
    assert np.array_equal(kept, expected) and np.array_equal(np.signbit(kept), np.signbit(expected))
    assert rng.bit_generator.state == state
