"""One measured point, the way Section 2.1 measures it.

CH1 is the piezo voltage (through the voltage probe), CH2 the current (TCP202), CH3 the
vibrometer output; MATH = CH1 * CH2 is the instantaneous power, and its MEAN over the
record "after careful DC cancellation and noise reduction through averaging" is the
supplied power. The scope averages N acquisitions and the horizontal scale is chosen so
the record holds the requested number of periods.

Vertical scales follow the signal: each channel is set so the expected peak-to-peak
fills about `fill_divisions` of the 8 on screen, or less where the trace sits off the
screen's centre (a current probe's DC offset): its extent from the centre, twice the larger
of its maximum and minus its minimum, then fills EXTENT_FILL_DIVISIONS. Sized by its
peak-to-peak alone, such a trace clips, then is too faint at the coarser scale, at every
point. The expectation is the last point of the same step scaled by the drive voltage
(velocity and current are proportional to the piezo voltage near a resonance); a step
starts with no expectation and a coarse range. A clipped channel (ClippedTraceError, or
a trace at the screen edge) is re-ranged coarser and acquired again; a trace using less
than `min_fill_divisions` is re-ranged finer once, because ADC steps of a barely visible
trace would dominate the power. The vibrometer's decoder range is chosen the same way
from the expected velocity. A search's reading is re-ranged once more where its velocity
trace fills the screen off what it asks for (SEARCH_FILL_TOLERANCE): a peak-to-peak errs by a
fixed share of a division, so readings compared at different fills would err differently.
"""

from __future__ import annotations

import json
import logging
import math
from dataclasses import dataclass, field
from typing import Any

import pandas as pd

from squeezebench.instruments.errors import ClippedTraceError
from squeezebench.instruments.tds3054b import HORIZONTAL_SCALES_S_PER_DIV, RECORD_LENGTHS
from squeezebench.protocols.safety import DriveController, MeasuredVoltageError
from squeezebench.errors import UserError

log = logging.getLogger(__name__)

SCREEN_DIVISIONS = 8.0
HORIZONTAL_DIVISIONS = 10.0
PIEZO_CHANNEL, CURRENT_CHANNEL, VELOCITY_CHANNEL = 1, 2, 3

#: A clipped trace is re-acquired with this much more range (its true size is unknown).
CLIP_GROWTH = 4.0
#: Divisions a trace's extent from the screen's centre may fill (the 2 % edge and noise left).
EXTENT_FILL_DIVISIONS = 7.0


#: Largest share by which a search's reading may fall short of the crest for want of a
#: sample near it (`crest_shortfall_rel`). The readings a search compares are fitted for the
#: resonance (`analysis.resonance_searches.peak_of_readings`), where one reading 0.25 % low
#: moved a Q 40 plate's vertex 2.6 Hz: at 2e-4 a reading moves it 0.2 Hz at most, under a
#: quarter of the generator's 20 ppm (0.9 Hz at 44 kHz), the largest term of its budget.
SEARCH_CREST_SHORTFALL = 2e-4
#: The widest step between the 1-2-4 time bases: a record asked for P periods holds up to
#: this many times P (`Acquisition._set_horizontal` takes the next time base up).
TIME_BASE_STEP = max(b / a for a, b in zip(HORIZONTAL_SCALES_S_PER_DIV, HORIZONTAL_SCALES_S_PER_DIV[1:]))
#: How far a search's velocity trace may fill the screen off the scale the reading itself
#: asks for (`Acquisition._scale_for`) before it is re-ranged and read again. A peak-to-peak
#: errs by a fixed share of a division, whatever the signal: the noise lifts both extremes
#: (about 0.014 division at the scope's 0.01 division rms and 16 averages), and the
#: undithered ADC step rounds each one. Read at 2 divisions instead of 6, a reading errs
#: three times as much (+0.7 % against +0.23 %): the coarse reading just below a peak, read
#: after a clip at a quarter of the scale, put the fitted resonance 1 Hz low on small plate
#: 3 and 0.66 Hz low on Table 4's second configuration, search after search. Within +-10 %
#: of the same fill, the readings a search compares err by the same share to within a tenth
#: of it (+-0.02 % of a reading at 16 averages, under the 0.05 % their noise scatters them),
#: and a common share the fit absorbs (a factor leaves the vertex of 1/v^2 where it is,
#: `analysis.resonance_searches.peak_of_readings`). At +-5 % the searches land no closer
#: and read a fifth more often.
SEARCH_FILL_TOLERANCE = 0.10


def crest_shortfall_rel(samples_per_period: float) -> float:
    """Largest relative amount by which the highest sample of a sine sampled at least
    `samples_per_period` times a period falls short of its crest (its peak-to-peak likewise).

    Sample k sits at the phase k f dt of a period (mod 1), wherever the trigger falls between
    samples, and consecutive samples are f dt = 1 / samples_per_period apart: no gap between
    the phases the record visits is wider, and a crest in the middle of a gap g is read at
    cos(pi g) of itself. Over many periods the phases usually fill the gaps, but not where
    f dt is near a fraction p/q of small q: the samples then visit q phases only, however many
    periods the record holds (44118 Hz at 2 us: f dt = 3/34, 34 phases, up to 0.42 % low)."""
    return 1.0 - math.cos(math.pi / samples_per_period)


def search_record_length(settings: "AcquisitionSettings") -> int:
    """Points per record of a search's readings (`Acquisition.measure_at`): the campaign's
    record length, or the shortest longer one, whose crest shortfall cannot exceed
    SEARCH_CREST_SHORTFALL at any frequency (the longest where none is that fine). The time
    base leaves N / (TIME_BASE_STEP P) samples per period at least (`crest_shortfall_rel`):
    4.9 % for 500 points of 20 periods, 1.2e-4 for 10000. One length for the whole search: a
    reading's noise lifts its extremes more the more samples it holds (about 0.1 % between
    500 and 10000 at 16 averages), which a search switching records between its readings
    would read as a distortion of the peak. Keeping the campaign's 500 points and asking for
    fewer periods cannot bound it: the crest bound's 157 samples a period leave room for 3.18
    periods at most, the scope's FREQ needs two rising crossings in its whole-period gate (two
    periods), and the 1-2-4 time base steps by up to 2.5 (44118 Hz: 1.76 or 4.41 periods)."""
    longer = [n for n in RECORD_LENGTHS if n >= settings.record_length]
    fine = [n for n in longer
            if crest_shortfall_rel(n / (TIME_BASE_STEP * settings.periods_per_record)) <= SEARCH_CREST_SHORTFALL]
    return min(fine) if fine else max(longer)


class RangingError(UserError):
    """A channel stays clipped at its coarsest scale: the signal is beyond the bench."""


@dataclass(frozen=True)
class AcquisitionSettings:
    """Campaign `acquisition:` section."""

    averages: int = 16               # 1: sample mode; else ACQUIRE:NUMAVG, a power of two 2..512
    record_length: int = 500         # HORIZONTAL:RECORDLENGTH, 500 or 10000 points
    periods_per_record: float = 20.0  # periods of the drive the record holds
    settle_s: float = 0.5            # bench time after each generator change (ring-up)
    fill_divisions: float = 6.0      # expected pp on screen, of 8 divisions
    min_fill_divisions: float = 2.0  # below this a channel is re-ranged finer
    max_ranging_attempts: int = 8    # acquisitions per point before giving up
    vibrometer_max_output_pp_v: float = 8.0   # keep the decoder output within this pp

    def __post_init__(self) -> None:
        if self.averages < 1 or self.averages > 512 or self.averages & (self.averages - 1):
            raise ValueError(f"averages must be 1 (sample mode) or a power of two in 2..512, "
                             f"got {self.averages!r}")
        if self.record_length not in RECORD_LENGTHS:
            raise ValueError(f"record_length must be 500 or 10000, got {self.record_length!r}")
        if not self.periods_per_record > 0 or self.settle_s < 0:
            raise ValueError("periods_per_record must be positive and settle_s not negative")
        if not 0 < self.min_fill_divisions < self.fill_divisions < SCREEN_DIVISIONS:
            raise ValueError("need 0 < min_fill_divisions < fill_divisions < 8")


@dataclass
class Point:
    """What one measured point gives: drive, scope measurements, maybe waveforms."""

    generator_frequency_hz: float
    generator_amplitude_vpp: float
    amplifier_gain: float
    piezo_voltage_setpoint_vpp: float
    averages: int
    record_length: int
    scope_power_w: float          # MATH MEAN
    scope_velocity_pp_v: float    # CH3 MAXIMUM - MINIMUM
    scope_piezo_voltage_pp_v: float   # CH1 (piezo volts: the probe gain is set)
    scope_current_pp_a: float     # CH2
    scope_frequency_hz: float     # CH1 FREQ
    vibrometer_scale_mps_per_v: float
    clock_s: float                # bench clock at the end of the point
    waveforms: pd.DataFrame | None = None
    waveform_metadata: dict[str, Any] = field(default_factory=dict)

    @property
    def velocity_pp_mps(self) -> float:
        return self.scope_velocity_pp_v * self.vibrometer_scale_mps_per_v


class Acquisition:
    """Configures the scope and vibrometer for, and acquires, measured points."""

    def __init__(self, bench, drive: DriveController, settings: AcquisitionSettings):
        self.bench = bench
        self.drive = drive
        self.settings = settings
        # The installed decoder's ranges, as the controller lists them (they differ between models).
        self._vibrometer_ranges = dict(bench.vibrometer.ranges_mps_per_v)
        self._vibrometer_scale = max(self._vibrometer_ranges.values())
        self._record_length: int | None = None   # as last set on the scope
        self.reset_ranges()

    def reset_ranges(self) -> None:
        """Forget expectations: a step starts from the same state however it is reached."""
        # Per-volt expectations from the last point: current pp and extent (A), velocity pp (m/s).
        self._current_pp_a_per_vpp: float | None = None
        self._current_extent_a_per_vpp: float | None = None
        self._velocity_pp_mps_per_vpp: float | None = None
        self._horizontal_scale_s: float | None = None   # asked for
        self._horizontal_set_s: float | None = None     # the 1-2-4 value set

    def configure(self) -> None:
        """Fixed settings of the scope and the vibrometer: displayed channels, probes,
        coupling, trigger, averaging, MATH, record length, output filter; everything a
        measurement relies on, whatever state the instruments were left in.

        Called once when a run opens its bench, before any step: a resumed step finds the
        scope exactly as an uninterrupted one does.
        """
        scope, electronics = self.bench.scope, self.bench.electronics
        scope.configure_channel(PIEZO_CHANNEL, probe_gain=1.0 / electronics.voltage_probe_attenuation)
        scope.configure_channel(CURRENT_CHANNEL, probe_gain=electronics.current_probe_a_per_a)
        scope.configure_channel(VELOCITY_CHANNEL, probe_gain=1.0)
        # The piezo voltage is the drive itself, centred on 0 V: every waveform of an
        # average starts at the same phase of it.
        scope.trigger_on(PIEZO_CHANNEL, level=0.0)
        scope.center_record_on_trigger()
        scope.set_math_product()
        self.bench.vibrometer.prepare_for_measurement()
        scope.set_record_length(self.settings.record_length)
        self._record_length = self.settings.record_length
        scope.set_averaging(self.settings.averages)
        # The finest/coarsest scale depends on the probe gain just set; ranging stays inside it.
        self._scale_limits = {channel: scope.channel(channel).scale_range_per_div()
                              for channel in (PIEZO_CHANNEL, CURRENT_CHANNEL, VELOCITY_CHANNEL)}

    # -- measuring ------------------------------------------------------------------------
    def measure_at(self, frequency_hz: float) -> Point:
        """Set the drive frequency and measure without keeping waveforms: a search's reading,
        on the record that reads its crest closely enough (`search_record_length`)."""
        self.drive.set_frequency(frequency_hz)
        return self.measure(keep_waveforms=False, record_length=search_record_length(self.settings),
                            velocity_fill_tolerance=SEARCH_FILL_TOLERANCE)

    def measure(self, keep_waveforms: bool = True, record_length: int | None = None,
                velocity_fill_tolerance: float | None = None) -> Point:
        """Acquire one point at the present drive, re-ranging until nothing clips, on a record
        of `record_length` points (default: the campaign's); with `velocity_fill_tolerance`,
        until the velocity trace fills the screen as its own reading asks to within that share
        (once: re-ranged on what it read, it does)."""
        settings, scope = self.settings, self.bench.scope
        piezo_vpp = self.drive.piezo_voltage_vpp
        record_length = record_length or settings.record_length
        if record_length != self._record_length:
            scope.set_record_length(record_length)
            self._record_length = record_length
        self._set_horizontal(self.drive.frequency_hz)
        pp, extents, waveforms = self._acquire_in_range(piezo_vpp, keep_waveforms, velocity_fill_tolerance)
        point = Point(
            generator_frequency_hz=self.drive.frequency_hz,
            generator_amplitude_vpp=self.drive.generator_amplitude_vpp,
            amplifier_gain=self.drive.amplifier_gain,
            piezo_voltage_setpoint_vpp=piezo_vpp,
            averages=settings.averages,
            record_length=record_length,
            scope_power_w=scope.measure("MATH", "MEAN"),
            scope_velocity_pp_v=pp[VELOCITY_CHANNEL],
            scope_piezo_voltage_pp_v=pp[PIEZO_CHANNEL],
            scope_current_pp_a=pp[CURRENT_CHANNEL],
            scope_frequency_hz=scope.measure(PIEZO_CHANNEL, "FREQ"),
            vibrometer_scale_mps_per_v=self._vibrometer_scale,
            clock_s=self.bench.clock.now_s(),
        )
        if waveforms is not None:
            point.waveforms, point.waveform_metadata = waveforms
            point.waveform_metadata.update(
                vibrometer_scale_mps_per_v=self._vibrometer_scale,
                generator={"frequency_hz": point.generator_frequency_hz,
                           "amplitude_vpp": point.generator_amplitude_vpp,
                           "amplifier_gain": point.amplifier_gain})
        self._current_pp_a_per_vpp = point.scope_current_pp_a / piezo_vpp
        self._current_extent_a_per_vpp = extents[CURRENT_CHANNEL] / piezo_vpp
        self._velocity_pp_mps_per_vpp = point.velocity_pp_mps / piezo_vpp
        return point

    def _acquire_in_range(self, piezo_vpp: float, keep_waveforms: bool, velocity_fill_tolerance: float | None):
        """Acquire until no channel clips or is too faint (nor, with `velocity_fill_tolerance`,
        the velocity off its fill); return pp and extent per channel, and the waveforms."""
        settings, scope = self.settings, self.bench.scope
        self._vibrometer_scale = self._set_vibrometer_range(
            self._expected(self._velocity_pp_mps_per_vpp, piezo_vpp))
        scales = self._initial_scales(piezo_vpp)
        refined: set[int] = set()
        for _ in range(settings.max_ranging_attempts):
            for channel, scale in scales.items():
                finest, coarsest = self._scale_limits[channel]
                scales[channel] = min(max(scale, finest), coarsest)
            scope.set_vertical_scales(scales)
            scope.acquire()
            if self.bench.vibrometer.over_range():
                self._range(scales, VELOCITY_CHANNEL, CLIP_GROWTH * SCREEN_DIVISIONS * scales[VELOCITY_CHANNEL])
                continue
            # Maximum and minimum, not PK2: a spike clips one side only, within the PK2 limit.
            # The scope gives no value of a clipped channel (None); all six in one message.
            extremes = iter(scope.measure_many([(channel, kind) for channel in scales
                                                for kind in ("MAXIMUM", "MINIMUM")]))
            peaks, rerange = {}, {}   # rerange: {channel: (expected pp, expected extent, why)}
            for channel, scale in scales.items():
                high, low = next(extremes), next(extremes)
                if high is None or low is None:
                    rerange[channel] = (CLIP_GROWTH * SCREEN_DIVISIONS * scale, 0.0, "clipped")
                else:
                    peaks[channel] = (high, low)
            pp = {channel: high - low for channel, (high, low) in peaks.items()}
            extents = {channel: 2.0 * max(high, -low) for channel, (high, low) in peaks.items()}
            # Clipped or not, never above the limit (a clipped CH1 spans at least the screen).
            try:
                self.drive.check_measured(pp.get(PIEZO_CHANNEL, SCREEN_DIVISIONS * scales[PIEZO_CHANNEL]),
                                          clipped=PIEZO_CHANNEL not in pp)
            except MeasuredVoltageError as stop:   # the scope's view of that acquisition, as evidence
                stop.evidence.update({"channel_pp": {f"CH{c}": v for c, v in pp.items()},
                                      "channel_scale_per_div": {f"CH{c}": v for c, v in scales.items()},
                                      "clipped_channels": [f"CH{c}" for c in rerange]})
                raise
            for channel, scale in scales.items():
                if channel in rerange:
                    continue
                # Channels sit at position 0: an extent this large reaches the ADC limit
                # (an offset trace with nothing moving is caught by its extent too).
                edge = 0.98 * SCREEN_DIVISIONS * scale
                if extents[channel] >= edge:
                    rerange[channel] = (CLIP_GROWTH * extents[channel], 0.0, "clipped")
                elif channel not in refined and pp[channel] < settings.min_fill_divisions * scale:
                    refined.add(channel)
                    rerange[channel] = (pp[channel], extents[channel], "too faint")
                elif (channel == VELOCITY_CHANNEL and velocity_fill_tolerance is not None and channel not in refined
                      and abs(scale / self._scale_for(pp[channel], extents[channel]) - 1.0) > velocity_fill_tolerance):
                    refined.add(channel)
                    rerange[channel] = (pp[channel], extents[channel], "off its search fill")
            if not rerange:
                try:
                    return pp, extents, (self._fetch_waveforms() if keep_waveforms else None)
                except ClippedTraceError as exc:   # a spike the PK2 of an average missed
                    rerange[exc.channel] = (CLIP_GROWTH * pp[exc.channel], 0.0, "clipped trace")
            for channel, (expected_pp, expected_extent, why) in rerange.items():
                log.info("CH%d %s at %.4g per division: re-ranging", channel, why, scales[channel])
                self._range(scales, channel, expected_pp, expected_extent)
        raise RangingError(f"could not range the scope within {settings.max_ranging_attempts} "
                           f"acquisitions at {piezo_vpp:.4g} Vpp, {self.drive.frequency_hz:.1f} Hz")

    # -- ranging --------------------------------------------------------------------------
    @staticmethod
    def _expected(per_vpp: float | None, piezo_vpp: float) -> float | None:
        return None if per_vpp is None else per_vpp * piezo_vpp

    def _initial_scales(self, piezo_vpp: float) -> dict[int, float]:
        current_pp_a = self._expected(self._current_pp_a_per_vpp, piezo_vpp)
        current_extent_a = self._expected(self._current_extent_a_per_vpp, piezo_vpp) or 0.0
        velocity_pp_mps = self._expected(self._velocity_pp_mps_per_vpp, piezo_vpp)
        return {
            PIEZO_CHANNEL: self._scale_for(piezo_vpp),
            # Unknown current: start coarse (1 A pp is watts on these plates), refine after.
            CURRENT_CHANNEL: self._scale_for(current_pp_a or 1.0, current_extent_a),
            # Unknown velocity: the decoder is at its coarsest, its output at most the limit.
            VELOCITY_CHANNEL: self._scale_for(velocity_pp_mps / self._vibrometer_scale if velocity_pp_mps
                                              else self.settings.vibrometer_max_output_pp_v),
        }

    def _scale_for(self, expected_pp: float, expected_extent: float = 0.0) -> float:
        """Volts (or amperes) per division for a trace of `expected_pp` and extent from the
        centre: the pp fills `fill_divisions`, the extent at most EXTENT_FILL_DIVISIONS."""
        return max(expected_pp / self.settings.fill_divisions, expected_extent / EXTENT_FILL_DIVISIONS)

    def _range(self, scales: dict[int, float], channel: int, expected_pp: float,
               expected_extent: float = 0.0) -> None:
        """Set `channel` for a trace of `expected_pp` and extent from the centre (channel
        units; see the module's docstring); CH3 via the decoder."""
        expected_pp = max(expected_pp, 1e-9)   # a flat trace: range on the finest scales
        if channel == VELOCITY_CHANNEL:
            old_scale = self._vibrometer_scale
            self._vibrometer_scale = self._set_vibrometer_range(expected_pp * old_scale)
            expected_pp, expected_extent = (v * old_scale / self._vibrometer_scale
                                            for v in (expected_pp, expected_extent))
        scales[channel] = self._scale_for(expected_pp, expected_extent)

    def _set_vibrometer_range(self, expected_velocity_pp_mps: float | None) -> float:
        """The most sensitive decoder range keeping the output within its limit."""
        limit_v = self.settings.vibrometer_max_output_pp_v
        ranges = self._vibrometer_ranges
        chosen = max(ranges.values())   # unknown velocity: coarsest
        if expected_velocity_pp_mps is not None:
            fitting = [s for s in ranges.values() if expected_velocity_pp_mps / s <= limit_v]
            chosen = min(fitting) if fitting else chosen
        name = next(n for n, s in ranges.items() if s == chosen)
        self.bench.vibrometer.set_range(name)
        return chosen

    def _set_horizontal(self, frequency_hz: float) -> None:
        """Time base for the requested periods; measurements gated on whole periods."""
        scale_s = self.settings.periods_per_record / frequency_hz / HORIZONTAL_DIVISIONS
        if scale_s != self._horizontal_scale_s:
            self._horizontal_set_s = self.bench.scope.set_horizontal_scale(scale_s)
            self._horizontal_scale_s = scale_s
        self.bench.scope.gate_whole_periods(frequency_hz, self._horizontal_set_s, self._record_length)

    def _fetch_waveforms(self) -> tuple[pd.DataFrame, dict[str, Any]]:
        scope = self.bench.scope
        traces = {name: scope.fetch_waveform(channel) for name, channel in
                  (("piezo_voltage_v", PIEZO_CHANNEL), ("current_a", CURRENT_CHANNEL),
                   ("vibrometer_output_v", VELOCITY_CHANNEL))}
        first = traces["piezo_voltage_v"]
        frame = pd.DataFrame({"time_s": first.time_s, **{n: t.values for n, t in traces.items()}})
        metadata = {"preamble": {n: {"y_increment": t.y_increment, "bits": t.bits,
                                     "averages": t.averages} for n, t in traces.items()}}
        json.dumps(metadata)  # fail here, not at storage, on a non-JSON preamble value
        return frame, metadata
