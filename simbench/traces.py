"""Scope records from the physics: synthesis, digitising and the scope's measurements.

Physical signals per channel: CH1 the amplifier output voltage (V, before the shunt),
CH2 the current (A), CH3 the vibrometer output (V = velocity / decoder range). The
probes scale them to channel units (a mis-set probe factor shows up as a wrong reading,
as on the real scope); the screen holds them as divisions from its centre.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass

import numpy as np

from squeezebench.simbench import effects as fx
from squeezebench.simbench import physics

HORIZONTAL_DIVISIONS = 10


@dataclass(frozen=True)
class ChannelSetup:
    scale_per_div: float
    position_div: float
    coupling: str  # DC | AC | GND
    probe_gain: float  # the scope's CH<n>:PRO setting (output / input)


@dataclass(frozen=True)
class ScopeSetup:
    """The scope settings an acquisition depends on."""

    channels: tuple[ChannelSetup, ChannelSetup, ChannelSetup]
    horizontal_scale_s: float
    record_length: int
    averages: int  # 1 in sample mode

    @property
    def record_time_s(self) -> float:
        return HORIZONTAL_DIVISIONS * self.horizontal_scale_s

    @property
    def sample_interval_s(self) -> float:
        return self.record_time_s / self.record_length

    @property
    def first_sample_s(self) -> float:
        """Trigger at the centre of the record (the scope's default position)."""
        return -self.record_time_s / 2.0

    def times_s(self) -> np.ndarray:
        return self.first_sample_s + np.arange(self.record_length) * self.sample_interval_s


@dataclass
class Record:
    """One acquisition as the scope keeps it: channel values in channel units."""

    setup: ScopeSetup
    values: np.ndarray  # (3, n): CH1, CH2, CH3
    frequency_hz: float

    def trace(self, source: str) -> np.ndarray:
        if source == "MATH":
            return self.values[0] * self.values[1]
        return self.values[int(source[2:]) - 1]


def synthesize(steady: physics.SteadyState, times_s: np.ndarray,
               fundamentals: np.ndarray | None = None) -> np.ndarray:
    """Noise-free physical signals (3, n) at `times_s` from the trigger.

    The scope triggers on the rising zero crossing of CH1's fundamental. `fundamentals`
    (n_branches, n) replaces the modes' steady fundamental phasors during a transient.
    """
    omega = 2.0 * math.pi * steady.frequency_hz
    trigger_s = (-0.5 * math.pi - np.angle(steady.output_voltage_phasors_v[0])) / omega
    rotation = np.exp(1j * omega * (times_s + trigger_s))
    orders = steady.orders
    harmonics = rotation[None, :] if len(orders) == 1 else rotation[None, :] ** orders[:, None]
    voltage = np.real(steady.output_voltage_phasors_v @ harmonics) + steady.output_dc_v
    capacitive = np.real(steady.capacitive_current_phasors_a @ harmonics)
    branch = np.real(steady.branch_velocity_phasors_mps @ harmonics)
    if fundamentals is not None:
        steady_fundamental = steady.branch_velocity_phasors_mps[:, :1] * rotation[None, :]
        branch = branch + np.real(fundamentals * rotation[None, :] - steady_fundamental)
    forces = np.array([b.force_factor_n_per_v for b in steady.branches])
    visibility = np.array([b.visibility for b in steady.branches])
    return np.stack([voltage, capacitive + forces @ branch, visibility @ branch])


def acquisition_seed(scene_seed: int, state: str, generator_key: str, counter: int) -> np.random.SeedSequence:
    """The random stream of one acquisition, from what defines it rather than from how
    many came before: a resumed campaign draws exactly what an uninterrupted one did."""
    return np.random.SeedSequence([scene_seed, zlib.crc32(state.encode()),
                                   zlib.crc32(generator_key.encode()), counter])


def acquire(steady: physics.SteadyState, setup: ScopeSetup, sensor_gains: np.ndarray,
            vibrometer_range_mps_per_v: float, pipeline: fx.EffectPipeline, start_s: float,
            acquisition_period_s: float, rng: np.random.Generator | None) -> Record:
    """One (possibly averaged) acquisition of the three channels through the effects.

    `sensor_gains` turn the physical signals into what reaches the scope inputs (probe
    attenuation, current probe A/A, 1 / decoder range).
    """
    times = setup.times_s()
    probe = np.array([c.probe_gain for c in setup.channels])
    ctx = fx.AcquisitionContext(
        record_times_s=times, start_s=start_s,
        acquisition_period_s=acquisition_period_s, averages=setup.averages,
        scale_per_div=np.array([c.scale_per_div for c in setup.channels]),
        display_gain=1.0 / probe, vibrometer_range_mps_per_v=vibrometer_range_mps_per_v)
    fundamentals = pipeline.motion(steady.branch_velocity_phasors_mps[:, :1], ctx) \
        if pipeline.has_motion else None
    signals = synthesize(steady, times, fundamentals)
    delays_s = pipeline.channel_delays_s()
    if delays_s is not None:   # a delayed channel shows its signal from tau earlier
        for ch in np.flatnonzero(delays_s):
            signals[ch] = synthesize(steady, times - delays_s[ch], fundamentals)[ch]
    signals = signals * sensor_gains[:, None]
    signals = pipeline.signals(signals, ctx)
    channel_values = _couple(signals * ctx.display_gain[:, None], setup, steady.frequency_hz)
    position = np.array([c.position_div for c in setup.channels])
    screen = channel_values / ctx.scale_per_div[:, None] + position[:, None]
    digitizer = pipeline.digitizer_settings
    averages = setup.averages if digitizer.averaging else 1
    screen = fx.digitize(screen, pipeline.noise_div_rms(ctx), averages, digitizer, rng)
    values = (screen - position[:, None]) * ctx.scale_per_div[:, None]
    return Record(setup, values, steady.frequency_hz)


def _couple(values: np.ndarray, setup: ScopeSetup, frequency_hz: float) -> np.ndarray:
    """AC coupling removes each channel's mean (over whole periods); GND shows zero."""
    couplings = [c.coupling for c in setup.channels]
    if all(c == "DC" for c in couplings):
        return values
    values = values.copy()
    window = whole_periods(setup.times_s(), frequency_hz)
    for ch, coupling in enumerate(couplings):
        if coupling == "AC":
            values[ch] -= values[ch, window].mean()
        elif coupling == "GND":
            values[ch] = 0.0
    return values


def whole_periods(times_s: np.ndarray, frequency_hz: float, first_only: bool = False) -> slice:
    """Samples covering the largest whole number of periods from the record start
    (or only the first period)."""
    span_s = times_s[-1] - times_s[0] + (times_s[1] - times_s[0])
    periods = 1 if first_only else max(1, math.floor(span_s * frequency_hz + 1e-9))
    count = int(round(periods / frequency_hz / (times_s[1] - times_s[0])))
    return slice(0, max(1, min(count, len(times_s))))


def measure(record: Record, source: str, kind: str) -> float:
    """The scope's immediate measurement `kind` of `source` on the record."""
    trace = record.trace(source)
    if kind == "MEAN":
        return float(trace.mean())
    if kind == "CME":  # cycle mean: over the first period
        return float(trace[whole_periods(record.setup.times_s(), record.frequency_hz, True)].mean())
    if kind in ("PK2", "AMP"):  # AMP (high - low) equals PK2 on a sine without overshoot
        return float(trace.max() - trace.min())
    if kind == "MAX":
        return float(trace.max())
    if kind == "MINI":
        return float(trace.min())
    if kind == "RMS":
        return float(np.sqrt(np.mean(trace**2)))
    if kind == "FREQ":
        return crossing_frequency_hz(trace, record.setup.times_s())
    raise ValueError(f"measurement type {kind!r} is not simulated")


def crossing_frequency_hz(trace: np.ndarray, times_s: np.ndarray) -> float:
    """Frequency from the rising crossings of the mid level (interpolated), as the
    scope finds periods; NaN when fewer than two crossings."""
    level = 0.5 * (trace.max() + trace.min())
    above = trace >= level
    rising = np.flatnonzero(~above[:-1] & above[1:])
    if len(rising) < 2:
        return math.nan
    fraction = (level - trace[rising]) / (trace[rising + 1] - trace[rising])
    crossing_s = times_s[rising] + fraction * (times_s[1] - times_s[0])
    return float((len(crossing_s) - 1) / (crossing_s[-1] - crossing_s[0]))
