"""Scope records from the physics: synthesis, digitising and the scope's measurements.

Physical signals per channel: CH1 the amplifier output voltage (V, before the shunt),
CH2 the current (A), CH3 the vibrometer output (V = velocity / decoder range). The
probes scale them to channel units (a mis-set probe factor shows up as a wrong reading,
as on the real scope); the screen holds them as divisions from its centre.
"""

from __future__ import annotations

import functools
import math
import zlib
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.special import ndtr

from squeezebench.lru import RecentlyUsed
from squeezebench.simbench import effects as fx
from squeezebench.simbench import physics
from squeezebench.simbench.effect_base import AcquisitionContext

HORIZONTAL_DIVISIONS = 10


@dataclass(frozen=True)
class ChannelSetup:
    scale_per_div: float
    position_div: float
    coupling: str  # DC | AC | GND
    probe_gain: float  # the scope's CH<n>:PRO setting (output / input)
    offset: float = 0.0      # CH<n>:OFFSet, in the channel's units: subtracted before the ADC
    input_gain: float = 1.0  # what the input impedance leaves of the signal (1 at 1 MOhm)


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
        """The sample times (read-only: one array serves every acquisition and measurement
        of the same time base)."""
        return _sample_times_s(self.first_sample_s, self.sample_interval_s, self.record_length)


@functools.lru_cache(maxsize=32)
def _sample_times_s(first_sample_s: float, sample_interval_s: float, record_length: int) -> np.ndarray:
    times = first_sample_s + np.arange(record_length) * sample_interval_s
    times.flags.writeable = False
    return times


@dataclass
class Record:
    """One acquisition as the scope keeps it: channel values in channel units."""

    setup: ScopeSetup
    values: np.ndarray  # (3, n): CH1, CH2, CH3
    frequency_hz: float  # the drive's, as the record shows it on its own time base
    #: CH1 * CH2, worked out once: the scope measures it several times per record.
    _math: np.ndarray | None = field(default=None, init=False, repr=False, compare=False)

    def trace(self, source: str) -> np.ndarray:
        if source == "MATH":
            if self._math is None:
                self._math = self.values[0] * self.values[1]
            return self._math
        return self.values[int(source[2:]) - 1]


def synthesize(steady: physics.SteadyState, times_s: np.ndarray,
               fundamentals: np.ndarray | None = None, channels: tuple[int, ...] = (0, 1, 2)) -> np.ndarray:
    """Noise-free physical signals of `channels` (rows in that order; by default all three:
    (3, n)) at `times_s` from the trigger. A channel's row is the same whichever others are
    asked for (a delayed channel is synthesised alone, at its own times).

    The scope triggers on the rising zero crossing of CH1's fundamental. `fundamentals`
    (n_branches, n) replaces the modes' steady fundamental phasors during a transient.
    """
    omega = 2.0 * math.pi * steady.frequency_hz
    trigger_s = (-0.5 * math.pi - np.angle(steady.output_voltage_phasors_v[0])) / omega
    rotation = _rotation(omega, float(trigger_s), times_s)
    orders = steady.orders
    harmonics = rotation[None, :] if len(orders) == 1 else rotation[None, :] ** orders[:, None]
    signals = np.empty((len(channels), times_s.size))
    if any(channels):   # CH2 and CH3 carry the plate's motion
        branch = _real_part(steady.branch_velocity_phasors_mps, harmonics)
        if fundamentals is not None:
            steady_fundamental = steady.branch_velocity_phasors_mps[:, :1] * rotation[None, :]
            branch = branch + np.real(fundamentals * rotation[None, :] - steady_fundamental)
    for row, channel in enumerate(channels):
        if channel == 0:
            np.add(_real_part(steady.output_voltage_phasors_v, harmonics), steady.output_dc_v, out=signals[row])
        elif channel == 1:
            forces = np.array([b.force_factor_n_per_v for b in steady.branches])
            np.add(_real_part(steady.capacitive_current_phasors_a, harmonics), _weighted(forces, branch),
                   out=signals[row])
        else:
            signals[row] = _weighted(np.array([b.visibility for b in steady.branches]), branch)
    return signals


def _real_part(phasors: np.ndarray, harmonics: np.ndarray) -> np.ndarray:
    """Re(phasors @ harmonics). With one order and one row (a channel's phasor, or the one
    branch) it is Re(X) Re(h) - Im(X) Im(h), worked out alone: the numbers the complex
    product gives (one product per sample, no sum), at half its cost (a screen's synthesis
    ran three). Several branches keep the complex product's real part, a strided view: on
    it the sums over the branches (`_weighted`) run numpy's own loop, in the branches'
    order, where a contiguous array would go to BLAS, which sums in another order."""
    if harmonics.shape[0] != 1 or phasors.ndim == 2 and phasors.shape[0] != 1:
        return np.real(phasors @ harmonics)
    phasor = complex(phasors.flat[0])
    real = phasor.real * harmonics.real
    real -= phasor.imag * harmonics.imag
    return real if phasors.ndim == 2 else real[0]


def _weighted(weights: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """weights @ rows: with one row, its product by the weight (the same numbers, but that
    a zero product keeps its sign where the matrix product's sum from 0 gave +0; the matrix
    product of one term costs twice as much)."""
    return weights[0] * rows[0] if len(weights) == 1 else weights @ rows


#: The steady signals of the last few drives and time bases (3 x 10,000 samples: 240 kB
#: each): a screen synthesised anew at a drive already shown (another vibrometer range, a
#: channel's input impedance, a search's return to its best frequency) reuses them (901 of
#: the cold paper plan's 6,386 screens; a larger cache finds few more).
_SYNTHESIZED: RecentlyUsed[np.ndarray] = RecentlyUsed(16)


def _steady_signals(steady: physics.SteadyState, setup: ScopeSetup, delays_s: np.ndarray | None = None) -> np.ndarray:
    """`_delayed_signals(steady, setup.times_s(), delays_s)`, read-only, kept by what it
    depends on: the steady state's phasors and its branches' gains, the time base and the
    channels' delays."""
    velocity = steady.branch_velocity_phasors_mps
    key = (steady.frequency_hz, steady.orders.tobytes(), steady.output_voltage_phasors_v.tobytes(),
           steady.output_dc_v, steady.capacitive_current_phasors_a.tobytes(), velocity.shape, velocity.tobytes(),
           tuple((b.force_factor_n_per_v, b.visibility) for b in steady.branches),
           setup.first_sample_s, setup.sample_interval_s, setup.record_length,
           None if delays_s is None else delays_s.tobytes())

    def build() -> np.ndarray:
        signals = _delayed_signals(steady, setup.times_s(), delays_s)
        signals.flags.writeable = False
        return signals

    return _SYNTHESIZED.get(key, build)


def _delayed_signals(steady: physics.SteadyState, times_s: np.ndarray, delays_s: np.ndarray | None,
                     fundamentals: np.ndarray | None = None) -> np.ndarray:
    """The three channels' signals (3, n), each at `times_s` less its delay (`delays_s`,
    None: no channel is delayed): a delayed channel shows its signal from tau earlier. Each
    row is synthesised once, at the times it is shown at."""
    delayed = () if delays_s is None else tuple(int(ch) for ch in np.flatnonzero(delays_s))
    if not delayed:
        return synthesize(steady, times_s, fundamentals)
    signals = np.empty((3, times_s.size))
    undelayed = tuple(ch for ch in range(3) if ch not in delayed)
    if undelayed:
        signals[list(undelayed)] = synthesize(steady, times_s, fundamentals, undelayed)
    for ch in delayed:
        signals[ch] = synthesize(steady, times_s - delays_s[ch], fundamentals, (ch,))[0]
    return signals


#: The fundamental's rotation of the last drive frequencies (and trigger phases) on a shared
#: time base, at most 32 MB (200 of 10,000 samples): a voltage sweep or a map at one frequency
#: changes the phasors only, and a plan's runs of one campaign return to its frequencies
#: (the cold paper plan computes 3,206 rotations for 5,485 syntheses so, 5,360 keeping 8).
_ROTATIONS: RecentlyUsed[tuple[np.ndarray, np.ndarray]] = RecentlyUsed(256, max_bytes=32 << 20,
                                                                     weigh=lambda kept: kept[1].nbytes)


def _rotation(omega: float, trigger_s: float, times_s: np.ndarray) -> np.ndarray:
    """exp(i omega (t + trigger_s)) at `times_s`; kept when `times_s` is a shared, read-only
    time base (`ScopeSetup.times_s`). The entry holds that array, so its id names it."""
    def build() -> tuple[np.ndarray, np.ndarray]:
        rotation = _uniform_rotation(omega, trigger_s, times_s)
        rotation.flags.writeable = False
        return times_s, rotation

    if times_s.flags.writeable:
        return build()[1]
    return _ROTATIONS.get((omega, trigger_s, id(times_s)), build)[1]


def _cis(phase: np.ndarray) -> np.ndarray:
    """cos + i sin of a real phase: what np.exp(1j * phase) works out (its real part is 0:
    e^0 = 1 scales nothing), at half the cost."""
    rotation = np.empty(phase.shape, complex)
    np.cos(phase, out=rotation.real)
    np.sin(phase, out=rotation.imag)
    return rotation


def _uniform_rotation(omega: float, trigger_s: float, times_s: np.ndarray) -> np.ndarray:
    """exp(i omega (t + trigger_s)) at `times_s`, evenly spaced (a record's time base, or it
    shifted by a channel's delay): in blocks of about sqrt(n) samples, each block's first
    phase from its own time and the phase steps within a block from the spacing, so a
    record of n samples costs 2 sqrt(n) sines and cosines and n complex products instead
    of n of each (a record's rotation was the largest single cost of a new drive). It
    departs from the sample-by-sample cos + i sin by ~1e-14: the phase's own rounding."""
    n = times_s.size
    block = max(1, math.isqrt(max(n - 1, 0)) + 1)
    if n < 2 * block:   # too short to gain
        return _cis(omega * (times_s + trigger_s))
    step_s = (times_s[-1] - times_s[0]) / (n - 1)
    firsts = _cis(omega * (times_s[::block] + trigger_s))
    within = _cis(omega * step_s * np.arange(block))
    return (firsts[:, None] * within[None, :]).ravel()[:n]


def acquisition_seed(scene_seed: int, state: str, generator_key: str, counter: int,
                     spot_key: str | None = None) -> np.random.SeedSequence:
    """The random stream of one acquisition, from what defines it rather than from how
    many came before: a resumed campaign draws exactly what an uninterrupted one did.

    `spot_key` names where the stage holds the spot once it has moved: without it, each
    step of a map (its drive written afresh, the counter back at 0) driven at the setting
    of an earlier step drew that step's noise again point for point, so points one step
    apart in the visiting order (the same x) shared their noise, which a real bench's
    points never do, and which a map's figures, propagated with independent points, do
    not cover. A bench whose stage never moved keeps the stream it always had.

    Keys below 2^32 are handed over as the uint32 words SeedSequence makes of them (one
    each), which it takes as they are instead of converting the keys one by one: the same
    stream, SeedSequence made in under half the time (4 against 11 us a seed on a loaded
    machine; an acquisition's seeding as a whole 0.110 -> 0.084 ms)."""
    keys = [scene_seed, zlib.crc32(state.encode()), zlib.crc32(generator_key.encode()), counter]
    if spot_key is not None:
        keys.append(zlib.crc32(spot_key.encode()))
    return np.random.SeedSequence(np.array(keys, np.uint32) if 0 <= min(keys) and max(keys) <= _UINT32_MAX else keys)


_UINT32_MAX = 2**32 - 1


def acquisition_rng(seed: np.random.SeedSequence) -> np.random.Generator:
    """The generator an acquisition draws its noise from (`acquisition_seed`). SFC64 rather
    than numpy's default PCG64: a normal costs about a fifth less CPU with it, and drawing
    normals is most of what an averaged acquisition costs; it passes the same statistical
    test batteries (numpy.random's notes on its bit generators)."""
    return np.random.Generator(np.random.SFC64(seed))


@dataclass
class Screen:
    """An acquisition before the digitiser draws its noise: the noise-free signals on the
    screen (divisions from the centre, per channel), each channel's noise (divisions rms)
    and what turns divisions back into channel units. Without a moving plate or an effect
    that changes from one acquisition to the next, every acquisition at the same settings
    shows the same screen, so a bench keeps it, with the sums of records `digitize` derives
    from it (`sums`, per channel, filled as they are needed)."""

    setup: ScopeSetup
    frequency_hz: float
    signal_div: np.ndarray      # (3, n)
    noise_div_rms: np.ndarray   # (3,)
    sums: dict = field(default_factory=dict)
    #: The signals in channel units before they are placed on the screen (3, n).
    channel_values: np.ndarray | None = field(default=None, repr=False)
    #: `_screen_placement(setup)`, worked out once with the screen: every record of it asks.
    placement: tuple[np.ndarray, np.ndarray, np.ndarray] | None = field(default=None, repr=False)

    def keep_sums_of(self, earlier: "Screen") -> None:
        """Take `earlier`'s sums of records for each channel showing exactly what it showed
        (its row and noise, the same number of averages): what `sum_of_records` depends on,
        besides the digitiser's settings, which a bench keeps until a new plate is mounted.
        Rows are compared as `np.array_equal` does; most differ from their first sample on
        (another drive), which is looked at first."""
        if earlier.setup.averages != self.setup.averages:
            return
        for ch, sums in earlier.sums.items():
            row, earlier_row = self.signal_div[ch], earlier.signal_div[ch]
            if (ch not in self.sums and self.noise_div_rms[ch] == earlier.noise_div_rms[ch]
                    and row.shape == earlier_row.shape and row[0] == earlier_row[0]
                    and bool((row == earlier_row).all())):
                self.sums[ch] = sums

    def values(self, divisions: np.ndarray) -> np.ndarray:
        """Channel values of screen positions (3, n), in place of `divisions`."""
        position, scale, offset = self.placement
        divisions -= position
        divisions *= scale
        divisions += offset
        return divisions


def _screen_placement(setup: ScopeSetup) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each channel's position (divisions), scale (units per division) and offset (units),
    as columns: a value v sits at (v - offset) / scale + position divisions."""
    return tuple(np.array([getattr(c, name) for c in setup.channels])[:, None]
                 for name in ("position_div", "scale_per_div", "offset"))


def _context(setup: ScopeSetup, vibrometer_range_mps_per_v: float, start_s: float,
             acquisition_period_s: float) -> AcquisitionContext:
    return AcquisitionContext(
        record_times_s=setup.times_s(), start_s=start_s,
        acquisition_period_s=acquisition_period_s, averages=setup.averages,
        scale_per_div=np.array([c.scale_per_div for c in setup.channels]),
        display_gain=1.0 / np.array([c.probe_gain for c in setup.channels]),
        vibrometer_range_mps_per_v=vibrometer_range_mps_per_v)


def screen(steady: physics.SteadyState, setup: ScopeSetup, sensor_gains: np.ndarray,
           vibrometer_range_mps_per_v: float, pipeline: fx.EffectPipeline, start_s: float,
           acquisition_period_s: float) -> Screen:
    """What one (possibly averaged) acquisition of the three channels shows through the
    effects before the digitiser. `sensor_gains` turn the physical signals into what
    reaches the scope inputs (probe attenuation, current probe A/A, 1 / decoder range).
    The signals are synthesised at the instants the samples were really taken (`sampled`:
    the scope's time base as it errs) and shown at the times the scope labels them with."""
    sampled = pipeline.sampled(setup)
    ctx = _context(sampled, vibrometer_range_mps_per_v, start_s, acquisition_period_s)
    times = ctx.record_times_s
    fundamentals = pipeline.motion(steady.branch_velocity_phasors_mps[:, :1], ctx) \
        if pipeline.has_motion else None
    delays_s = pipeline.channel_delays_s(steady.frequency_hz)
    signals = _delayed_signals(steady, times, delays_s, fundamentals) if fundamentals is not None \
        else _steady_signals(steady, sampled, delays_s)
    signals = signals * (sensor_gains * np.array([c.input_gain for c in setup.channels]))[:, None]
    signals = pipeline.signals(signals, ctx)   # a new array (the effects keep none), so in place below
    signals *= ctx.display_gain[:, None]
    channel_values = _couple(signals, sampled, steady.frequency_hz)
    position, scale, offset = placement = _screen_placement(setup)
    signal_div = channel_values - offset
    signal_div /= scale
    signal_div += position
    shown_hz = steady.frequency_hz * (sampled.horizontal_scale_s / setup.horizontal_scale_s)   # on the labelled times
    return Screen(setup, shown_hz, signal_div, pipeline.noise_div_rms(ctx), channel_values=channel_values,
                  placement=placement)


def _unplaced(setup: ScopeSetup) -> ScopeSetup:
    """`setup` without where its channels sit on the screen (scale, position, offset)."""
    return replace(setup, channels=tuple(replace(c, scale_per_div=1.0, position_div=0.0, offset=0.0)
                                         for c in setup.channels))


def placed_anew(shown: Screen, setup: ScopeSetup, pipeline: fx.EffectPipeline,
                vibrometer_range_mps_per_v: float, start_s: float, acquisition_period_s: float) -> Screen | None:
    """`shown`'s signals on the screen of `setup`, when `setup` differs from `shown.setup` in
    where the channels sit only (CH<x>:SCAle, POSition, OFFSet: a channel re-ranged) and the
    signals do not depend on that (`EffectPipeline.signals_read_vertical_scale`); None
    otherwise. The signals are not synthesised again, and a channel whose place and noise
    are unchanged keeps its row and its sums of records: the numbers `screen` would compute
    afresh, element by element, so the digitiser draws the same record."""
    if (shown.channel_values is None or pipeline.signals_read_vertical_scale
            or _unplaced(setup) != _unplaced(shown.setup)):
        return None
    noise_div_rms = pipeline.noise_div_rms(_context(setup, vibrometer_range_mps_per_v, start_s, acquisition_period_s))
    position, scale, offset = placement = _screen_placement(setup)
    old_position, old_scale, old_offset = shown.placement
    signal_div, sums = shown.signal_div.copy(), {}
    for ch in range(len(setup.channels)):
        if (position[ch, 0], scale[ch, 0], offset[ch, 0], noise_div_rms[ch]) == \
                (old_position[ch, 0], old_scale[ch, 0], old_offset[ch, 0], shown.noise_div_rms[ch]):
            if ch in shown.sums:
                sums[ch] = shown.sums[ch]
        else:
            signal_div[ch] = (shown.channel_values[ch] - offset[ch]) / scale[ch] + position[ch]
    return Screen(setup, shown.frequency_hz, signal_div, noise_div_rms, sums, shown.channel_values, placement)


def record_of(shown: Screen, settings: fx.DigitizerSettings, rng: np.random.Generator | None) -> Record:
    """The record the scope keeps of `shown`: digitised, in channel units."""
    averages = shown.setup.averages if settings.averaging else 1
    divisions = digitize(shown.signal_div, shown.noise_div_rms, averages, settings, rng, shown.sums)
    return Record(shown.setup, shown.values(divisions), shown.frequency_hz)


def input_gain(impedance_ohm: float, source_ohm: float) -> float:
    """What an input of `impedance_ohm` keeps of a signal from a source of `source_ohm`,
    relative to the 1 MOhm input the probes and gains are specified for: a 10:1 passive
    probe (9 MOhm tip) into 50 Ohm keeps almost nothing, a 50 Ohm output keeps half."""
    def divider(load_ohm: float) -> float:
        return load_ohm / (load_ohm + source_ohm)
    return divider(impedance_ohm) / divider(1e6)


# -- the digitiser ----------------------------------------------------------------------
#: Noise tails beyond this many standard deviations (probability < 1e-15) are neglected.
NOISE_REACH_SIGMA = 8.0
#: The sum of N records is drawn as a normal where it spreads over at least this many
#: sample steps (standard deviation); below, its lattice shows and the records are drawn.
MIN_SPREAD_LSB = 2.0


def digitize(screen_div: np.ndarray, noise_div_rms: np.ndarray, averages: int,
             settings: fx.DigitizerSettings, rng: np.random.Generator | None,
             sums: dict | None = None) -> np.ndarray:
    """Screen positions (divisions) of the record the scope keeps, per channel: clipped
    at the ADC limits and quantised, in sample mode or as an average of `averages`.
    `sums` keeps each channel's `SumOfRecords` for the next record of the same screen."""
    out = np.empty(screen_div.shape)   # C order: a row is one channel's record
    averaged = settings.averaging and averages > 1
    sums = {} if sums is None else sums
    for ch, (signal, sigma) in enumerate(zip(screen_div, noise_div_rms)):
        if averaged:
            if sigma > 0 and ch not in sums:
                sums[ch] = sum_of_records(signal, sigma, averages, settings)
            average_of_records(signal, sigma, averages, settings, rng, sums.get(ch), out=out[ch])
        elif sigma > 0:   # in the record's own row, the same operations (the same bits)
            noisy = rng.standard_normal(out=out[ch])
            noisy *= sigma
            noisy += signal
            _clip(noisy, out=noisy)
            if settings.sample_lsb_div is not None:
                noisy /= settings.sample_lsb_div
                np.round(noisy, out=noisy)
                noisy *= settings.sample_lsb_div
        else:
            out[ch] = _quantise(_clip(signal), settings.sample_lsb_div)
    return _clip(out, out=out)


@dataclass(frozen=True)
class SumOfRecords:
    """How `average_of_records` draws the sum of N records, per sample: `centre` + `spread`
    Z (Z standard normal; rounded to whole sample steps when quantised) where `direct`,
    the records one by one elsewhere. It depends on the signal, the noise and N only, so
    the records of one screen share it."""

    centre: np.ndarray | None   # None (and `spread` too) where no sample is direct
    spread: np.ndarray | float | None
    direct: np.ndarray   # bool per sample
    quantised: bool

    @functools.cached_property
    def drawn(self) -> np.ndarray:
        """The samples whose records are drawn one by one (indices): every record of the
        screen asks."""
        return np.flatnonzero(~self.direct)


def sum_of_records(signal: np.ndarray, sigma: float, averages: int,
                   settings: fx.DigitizerSettings) -> SumOfRecords:
    """The distribution `average_of_records` draws the sum of `averages` records of
    `signal` + N(0, sigma^2) from (sigma > 0); see there. Computed in place where the
    arrays allow, the same operations in the same order (the same bits): a screen's
    first record, its sums not yet kept, spends much of its time here."""
    lsb = settings.sample_lsb_div
    reach = NOISE_REACH_SIGMA * sigma
    low, high = fx.ADC_MIN_DIV + reach, fx.ADC_MAX_DIV - reach
    # A usual record stays clear of the clip everywhere, which its two extremes tell.
    all_far = bool(signal.min() >= low and signal.max() <= high)
    if lsb is None:
        far = np.ones(signal.shape, bool) if all_far else (signal >= low) & (signal <= high)
        return SumOfRecords(averages * signal, sigma * math.sqrt(averages), far, quantised=False)
    steps = signal / lsb   # one record's mean and variance, in sample steps
    if sigma >= settings.dither_threshold_lsb * lsb and all_far:
        # Dithered: every sample has the same variance, so the sum has one spread.
        variance = (sigma / lsb) ** 2 + 1.0 / 12.0
        summed_variance = averages * variance
        direct = np.full(steps.shape, summed_variance >= MIN_SPREAD_LSB**2 or variance == 0.0)
        steps *= averages
        return SumOfRecords(steps, math.sqrt(max(summed_variance - 1.0 / 12.0, 0.0)), direct, quantised=True)
    moments = _step_moments(sigma / lsb)
    if all_far and not _some_sum_is_direct(sigma / lsb, averages):
        # Every record is drawn (few averages of noise within a step or so: 4 or 8 of the
        # search's): the per-sample moments below would only tell so, at a third of the cost
        # of drawing the records.
        return SumOfRecords(None, None, np.zeros(steps.shape, bool), quantised=True)
    # Linear interpolation on the uniform phase grid, by index (np.interp searches).
    weight = np.floor(steps)
    np.subtract(steps, weight, out=weight)
    weight *= STEP_PHASES   # the position on the grid, less its index below
    index = weight.astype(np.intp)
    np.minimum(index, STEP_PHASES - 1, out=index)
    weight -= index
    rest = 1.0 - weight
    # The tabulated (mean offset, variance) pairs at the index and the one after (the table
    # shifted by one), each gathered as a pair: two gathers where each moment's own took
    # four, the same numbers. take: the same gather as [index], faster.
    below, above = moments.take(index, axis=0), moments[1:].take(index, axis=0)
    mean = np.multiply(below[:, 0], rest)
    mean += steps
    upper = np.multiply(above[:, 0], weight)
    mean += upper
    variance = np.multiply(below[:, 1], rest)
    np.multiply(above[:, 1], weight, out=upper)
    variance += upper
    if not all_far:
        near = ~((signal >= low) & (signal <= high))
        lowest, highest = round(fx.ADC_MIN_DIV / lsb), round(fx.ADC_MAX_DIV / lsb)   # the clip's levels
        mean[near], variance[near] = _level_moments(steps[near], sigma / lsb, lowest, highest)
    # The sum of N records is a whole number of steps: a normal rounded to that
    # lattice, narrowed by the rounding's 1/12 (Sheppard's correction).
    summed_variance = averages * variance
    direct = summed_variance >= MIN_SPREAD_LSB**2
    direct |= variance == 0.0
    spread = np.subtract(summed_variance, 1.0 / 12.0, out=summed_variance)
    np.maximum(spread, 0.0, out=spread)
    np.sqrt(spread, out=spread)
    mean *= averages
    return SumOfRecords(mean, spread, direct, quantised=True)


def average_of_records(signal: np.ndarray, sigma: float, averages: int, settings: fx.DigitizerSettings,
                       rng: np.random.Generator | None, sums: SumOfRecords | None = None,
                       out: np.ndarray | None = None) -> np.ndarray:
    """The mean of `averages` records, each `signal` + N(0, sigma^2) clipped at the ADC
    limits and quantised to the sample step, without drawing them where statistics allow
    (`sums`: `sum_of_records` of these arguments, computed here if not given).

    The records are independent, so their sum has N times the per-sample mean m and
    variance v of one record. It is drawn directly (one draw per sample, whatever N):
    - without quantisation, exactly, where the signal stays NOISE_REACH_SIGMA from the clip
      (the mean of Gaussians is Gaussian);
    - with quantisation, where the sum spreads over MIN_SPREAD_LSB sample steps or more
      (N v >= (2 lsb)^2, where the central limit theorem holds for the lattice: the sum is
      a normal rounded to whole steps, with Sheppard's correction) or cannot vary (v = 0:
      e.g. held at the clip). m and v are exact: from the probability of each quantisation level
      (the Gaussian's mass between the decision thresholds, the clip's levels taking the
      tails beyond), so the bias averaging cannot remove (noise well below a step) and
      clipping are kept. Away from the clip they depend only on the signal's place within
      a step: tabulated once per noise level (`_step_moments`). At or above
      `dither_threshold_lsb` steps of noise, m = signal and v = sigma^2 + lsb^2/12
      (dithered quantisation, error below exp(-2 pi^2) of a step).
    Elsewhere (few averages, noise far below a step, near the clip unquantised) the N
    records of those samples are drawn and quantised one by one. The scope keeps the
    mean rounded to its average step (`_kept_average`), in `out` if given (C order).
    """
    lsb = settings.sample_lsb_div
    if sigma == 0:   # every record is the same
        return _into(out, _quantise(_quantise(_clip(signal), lsb), settings.average_lsb_div))
    sums = sums or sum_of_records(signal, sigma, averages, settings)
    if sums.drawn.size == signal.size:   # no sample's sum is drawn directly (few averages, weak noise)
        total = _into(out, _sum_of_records(signal, sigma, averages, lsb, rng))
    else:
        # In place (the same operations, so the same bits): one array instead of three.
        total = rng.standard_normal(signal.size, out=out)
        total *= sums.spread
        total += sums.centre
        if sums.quantised:
            np.round(total, out=total)
        if sums.drawn.size:
            total[sums.drawn] = _sum_of_records(signal[sums.drawn], sigma, averages, lsb, rng)
    return _into(out, _kept_average(total, averages, settings, rng))


def _into(out: np.ndarray | None, values: np.ndarray) -> np.ndarray:
    """`values`, in `out` if given."""
    if out is None or values is out:
        return values
    out[...] = values
    return out


def _kept_average(total: np.ndarray, averages: int, settings: fx.DigitizerSettings,
                  rng: np.random.Generator) -> np.ndarray:
    """The average the scope keeps from the sum of N records (in sample steps when
    quantised), rounded to the average step. The sum is whole steps and both steps are
    powers of two of the ADC span, so the mean in average steps is exact and often lands
    half-way: a tie goes either way with equal chance, keeping the kept average an
    unbiased reading of the sum (ties to even, or up, would tie the rounding's error to
    the signal, a bias in the power of a weak power factor). In place of `total` where
    the kept average needs no rounding."""
    lsb, average_lsb = settings.sample_lsb_div, settings.average_lsb_div
    if lsb is None:
        return _quantise(total / averages, average_lsb)
    if average_lsb is None:
        total *= lsb / averages
        return total
    steps_per_sample_step = round(lsb / average_lsb)
    mean = total
    if steps_per_sample_step % averages == 0:
        # N no more than the steps' ratio (16 averages of 8-bit samples in 13 bits): the
        # mean is whole average steps, there is nothing to round and no tie. Adding 0
        # turns the -0.0 of a rounded-down sum into the +0.0 the rounding gives. Both counts
        # are powers of two (bit depths, NUMAVG), so is their ratio: scaling by it is exact,
        # and one product by it times the average step gives the numbers that the mean in
        # average steps, then its product by the step, gave (one pass over the record).
        mean *= steps_per_sample_step // averages * average_lsb
        mean += 0.0
        return mean
    mean *= steps_per_sample_step / averages   # in average steps, exact
    kept = mean + 0.5
    np.floor(kept, out=kept)
    # In place of the mean, no longer needed: the distance to the kept step, 0.5 at a tie.
    ties = np.flatnonzero(np.subtract(kept, mean, out=mean) == 0.5)
    if ties.size:
        kept[ties] -= rng.integers(0, 2, size=ties.size)
    kept *= average_lsb
    return kept


#: Phases within a step at which `_step_moments` tabulates: linear interpolation between
#: them errs by less than 1e-6 of a step for noise down to a tenth of a step.
STEP_PHASES = 4096


@functools.lru_cache(maxsize=64)
def _step_moments(sigma_steps: float) -> np.ndarray:
    """Away from the clip, one quantised record's mean minus the signal, and its variance
    (in steps), at STEP_PHASES + 1 evenly spaced phases of the signal within a step
    (0..1): both have period one step. Rows are phases, the two columns the moments
    (read-only: shared by every screen of this noise)."""
    grid = np.linspace(0.0, 1.0, STEP_PHASES + 1)
    mean, variance = _level_moments(grid, sigma_steps)
    moments = np.stack([mean - grid, variance], axis=1)
    moments.flags.writeable = False
    return moments


@functools.lru_cache(maxsize=256)
def _some_sum_is_direct(sigma_steps: float, averages: int) -> bool:
    """Whether the sum of `averages` records of a sample away from the clip can be drawn
    directly (`sum_of_records`: N v >= MIN_SPREAD_LSB^2, or v = 0) at some phase within a
    step. A sample's v is interpolated between two of `_step_moments`' tabulated values,
    with weights summing to one: it is no more than their largest (the margin covers the
    rounding) and no less than half their smallest, which must not be 0."""
    step_variance = _step_moments(sigma_steps)[:, 1]
    return bool(averages * float(step_variance.max()) * (1.0 + 1e-9) >= MIN_SPREAD_LSB**2
                or float(step_variance.min()) <= 1e-300)


def _level_moments(steps: np.ndarray, sigma_steps: float, lowest: int | None = None,
                   highest: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Per-sample mean and variance (in steps) of round(clip(steps + sigma_steps Z)),
    the clip holding the levels within [lowest, highest]; summed over the levels within
    NOISE_REACH_SIGMA (the window's ends take the tails)."""
    first = np.floor(steps - NOISE_REACH_SIGMA * sigma_steps)
    width = int(math.ceil(2.0 * NOISE_REACH_SIGMA * sigma_steps)) + 2
    z_first = (first + 0.5 - steps) / sigma_steps   # first level's upper threshold, in sigmas
    # Levels as offsets from the window's first (clipped) level: small numbers, and all
    # zero past the clip, so a sample held there has exactly no variance.
    base = first if lowest is None else np.clip(first, lowest, highest)
    below = np.zeros_like(steps)
    mean_offset = np.zeros_like(steps)
    second = np.zeros_like(steps)
    for j in range(width):
        upper = ndtr(z_first + j / sigma_steps) if j < width - 1 else 1.0
        probability = upper - below
        below = upper
        offset = j if lowest is None else np.clip(first + j, lowest, highest) - base
        mean_offset += probability * offset
        second += probability * offset * offset
    return base + mean_offset, np.maximum(second - mean_offset**2, 0.0)


def _sum_of_records(signal: np.ndarray, sigma: float, averages: int, lsb: float | None,
                    rng: np.random.Generator) -> np.ndarray:
    """The sum of `averages` clipped records drawn one by one (in blocks to bound memory),
    in whole sample steps when quantised (in divisions otherwise)."""
    total = np.zeros_like(signal)
    block = max(1, 2_000_000 // max(1, signal.size))
    for first in range(0, averages, block):
        count = min(block, averages - first)
        # In place, the same operations in the same order (the same bits): the draws'
        # block is the only array of its size (records dominate a direct draw's cost).
        records = rng.standard_normal((count, signal.size))
        records *= sigma
        records += signal
        _clip(records, out=records)
        if lsb is not None:
            records /= lsb
            np.round(records, out=records)
        total += records.sum(axis=0)
    return total


def _clip(divisions: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    return np.clip(divisions, fx.ADC_MIN_DIV, fx.ADC_MAX_DIV, out=out)


def _quantise(divisions: np.ndarray, lsb_div: float | None) -> np.ndarray:
    return divisions if lsb_div is None else np.round(divisions / lsb_div) * lsb_div


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


def reaches_limits(extremes: tuple[float, float], offset: float, scale_per_div: float,
                   position_div: float) -> tuple[bool, bool]:
    """Whether a trace (channel units) of these `extremes` (lowest, highest) shown at this
    vertical setting reaches the ADC's top, and its bottom (within 1e-9 division): the
    clipping of TDS PM Table 3-5. A screen position rises with the value (the scale is
    positive, and rounding keeps that order), so the extremes' positions are the positions'
    extremes: two values are placed, not the record (as floats: the operations an array of
    two would do, without its cost at every measurement)."""
    lowest, highest = extremes
    highest = (highest - offset) / scale_per_div + position_div
    lowest = (lowest - offset) / scale_per_div + position_div
    return bool(highest >= fx.ADC_MAX_DIV - 1e-9), bool(lowest <= fx.ADC_MIN_DIV + 1e-9)


def extremes_of(trace: np.ndarray) -> tuple[float, float]:
    """(lowest, highest) sample of `trace`."""
    return float(trace.min()), float(trace.max())


def whole_periods(times_s: np.ndarray, frequency_hz: float, first_only: bool = False) -> slice:
    """Samples covering the largest whole number of periods from the record start
    (or only the first period)."""
    span_s = times_s[-1] - times_s[0] + (times_s[1] - times_s[0])
    periods = 1 if first_only else max(1, math.floor(span_s * frequency_hz + 1e-9))
    count = int(round(periods / frequency_hz / (times_s[1] - times_s[0])))
    return slice(0, max(1, min(count, len(times_s))))


#: The measurements `measure` reads from the trace's extremes alone (FREQ and PERI: their
#: mid level).
EXTREME_KINDS = frozenset({"PK2", "AMP", "MAX", "MINI", "HIGH", "LOW", "FREQ", "PERI"})


def measure(trace: np.ndarray, setup: ScopeSetup, frequency_hz: float, kind: str,
            extremes: tuple[float, float] | None = None) -> float:
    """The scope's immediate measurement `kind` of `trace`, samples of a record of `setup`
    (from its first) showing a drive of `frequency_hz`; `extremes`: the trace's (lowest,
    highest) if already known (`extremes_of`)."""
    if kind in EXTREME_KINDS:
        lowest, highest = extremes or extremes_of(trace)
        if kind in ("PK2", "AMP"):  # AMP (high - low) equals PK2 on a sine without overshoot
            return highest - lowest
        if kind in ("MAX", "HIGH"):  # the min-max method: HIGH and LOW are the extremes
            return highest
        if kind in ("MINI", "LOW"):
            return lowest
        crossing_hz = crossing_frequency_hz(trace, setup.times_s(), 0.5 * (highest + lowest))
        return crossing_hz if kind == "FREQ" else 1.0 / crossing_hz
    if kind == "MEAN":
        return float(trace.mean())
    if kind == "CME":  # cycle mean: over the first period
        return float(trace[whole_periods(setup.times_s(), frequency_hz, True)].mean())
    if kind == "RMS":
        return float(np.sqrt(np.mean(trace**2)))
    if kind == "CRM":  # cycle RMS: over the first period
        return float(np.sqrt(np.mean(trace[whole_periods(setup.times_s(), frequency_hz, True)] ** 2)))
    raise ValueError(f"measurement type {kind!r} is not simulated")


def crossing_frequency_hz(trace: np.ndarray, times_s: np.ndarray, level: float | None = None) -> float:
    """Frequency from the rising crossings of the mid `level` (interpolated; by default
    worked out from the trace), as the scope finds periods; NaN when fewer than two crossings."""
    if level is None:
        lowest, highest = extremes_of(trace)
        level = 0.5 * (highest + lowest)
    above = trace >= level
    rising = np.flatnonzero(~above[:-1] & above[1:])
    if len(rising) < 2:
        return math.nan
    fraction = (level - trace[rising]) / (trace[rising + 1] - trace[rising])
    crossing_s = times_s[rising] + fraction * (times_s[1] - times_s[0])
    return float((len(crossing_s) - 1) / (crossing_s[-1] - crossing_s[0]))
