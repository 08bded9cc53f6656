"""Opt-in departures from the ideal bench, each named in a scene's `effects:` list.

An effect is a small object with default parameters (a scene may override any) that
acts at one or more stages of the simulation:

- `amplifier`: reshapes the amplifier model (limits);
- `load`: reshapes the plate as the amplifier sees it (shunt, losses, modes, heat);
- `motion`: reshapes the modal velocities over an acquisition (ring-up after a change);
- `signals`: edits the noise-free sensor outputs (offsets, vibrometer clipping);
- `noise`: adds per-acquisition random noise, as an rms in screen divisions;
- `digitizer`: sets how the scope digitises (quantisation, averaging);
- `generator`: what the generator really puts out for its settings (frequency error);
- `timing`: a channel's delay at the drive frequency (skew, current-probe delay, a voltage
  probe's compensation phase);
- `timebase`: the scope's sample clock off its nominal rate: when the samples it labels at
  its nominal interval were really taken (the scope's time-base error);
- `spot`: where the vibrometer's laser meets the plate when the x-y stage moves it
  (backlash, a plate off the stage's zero or rotated, one bench's placement of it, a tilted
  plate);
- `bus`: faults of the instruments and their link (timeouts, garbled or truncated
  replies, error-queue entries, a disconnect), for testing what a campaign does on a
  bad day.

The kinds live apart: the base (`simbench.effect_base`), the systematic errors
(`simbench.systematic_effects`), the faults (`simbench.fault_effects`) and the laser
spot's (`simbench.spot_effects`); here the bench's physical effects, the digitiser,
the registry `EFFECTS` and the pipeline.

`EffectPipeline` keeps, per stage, only the effects acting there, chosen once when the
scene is loaded: an effect that is off is never called, and the ideal bench runs none.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from squeezebench.plates import damping, warming
from squeezebench.plates.laminate import ALUMINIUM_TABLE2
from squeezebench.plates.specifications import HEATING_NOMINAL, HEATING_TOLERANCES
from squeezebench.simbench import physics
from squeezebench.simbench.scene_model import SceneError
from squeezebench.simbench.effect_base import CHANNELS, VIBROMETER_CHANNEL, AcquisitionContext, Effect
from squeezebench.simbench.fault_effects import (BusTimeout, ClippedTrace, Disconnect, GarbledReplyFault,
                                                 InstrumentErrorEntry, TruncatedReplyFault)
from squeezebench.simbench.spot_effects import PlateOffset, PlatePlacement, PlateTilt, Spot, StageBacklash
from squeezebench.simbench.systematic_effects import (ChannelSkew, CurrentProbeDelay, CurrentProbeGainError,
                                                      GeneratorAmplitudeError, GeneratorFrequencyError, ScopeGainError,
                                                      ScopeTimebaseError, VibrometerScaleError,
                                                      VoltageProbeCompensation, VoltageProbeError, draw_stream,
                                                      drawn_fraction)


class Shunt(Effect):
    """The 2-ohm current shunt in series with the plate (Sec. 2.1). CH1 probes the
    amplifier output, so the power the scope computes includes the shunt's loss."""

    name = "shunt"
    stages = frozenset({"load"})

    def load(self, load: physics.PlateLoad) -> physics.PlateLoad:
        return replace(load, series_ohm=self.scene.electronics.shunt_ohm)


class DielectricLossEffect(Effect):
    """C0 loses tan(delta) growing with the field (Rayleigh hysteresis).

    Default calibrated on the paper's Fig. 2c stress case (Sec. 2.2): on the 1-column
    plate (4 piezos 5 x 9 x 0.5 mm, C0 = 4.30 nF with eps_r 1350) the power at the same
    velocity rose from 100 mW to 120 mW when 240 Vpp at 37560 Hz replaced 37.6 Vpp at
    37180 Hz. The 20 mW are 0.5 V^2 w C0 tan(delta) at 120 V amplitude: tan(delta) =
    0.002735 at 240 V/mm, i.e. 120 V amplitude across 0.5 mm.
    """

    name = "dielectric_loss"
    defaults = damping.DIELECTRIC_LOSS_DEFAULTS
    stages = frozenset({"load"})

    def load(self, load: physics.PlateLoad) -> physics.PlateLoad:
        p = self.parameters
        return replace(load, dielectric=physics.DielectricLoss(
            tan_delta_at_reference=p["tan_delta_at_reference"],
            reference_field_amplitude_v_per_m=p["reference_field_amplitude_v_per_mm"] * 1e3,
            exponent=p["exponent"],
            piezo_thickness_m=self.scene.actuators.piezo.thickness_mm * 1e-3))


class AmplifierLimits(Effect):
    """The amplifier's output swing (clipping) and first-order bandwidth, from the
    scene's `electronics`."""

    name = "amplifier_limits"
    stages = frozenset({"amplifier"})

    def amplifier(self, amplifier: physics.Amplifier) -> physics.Amplifier:
        e = self.scene.electronics
        return replace(amplifier, bandwidth_hz=e.amplifier_bandwidth_hz,
                        max_output_vpp=e.amplifier_max_output_vpp)


class NeighbouringMode(Effect):
    """A second vibration mode near the working one: another motional branch.

    Its frequency, sharpness, drive and loss are ratios to the working mode's, and
    `visibility` is how much of its modal velocity the vibrometer sees at the point.
    """

    name = "neighbouring_mode"
    defaults = {"frequency_ratio": 1.02, "q_mech_ratio": 1.0, "force_factor_ratio": 0.5,
                "resistance_ratio": 1.0, "visibility": 0.3}
    stages = frozenset({"load"})

    def load(self, load: physics.PlateLoad) -> physics.PlateLoad:
        p, main = self.parameters, load.branches[0]
        neighbour = physics.MotionalBranch(
            frequency_hz=main.frequency_hz * p["frequency_ratio"],
            q_mech=main.q_mech * p["q_mech_ratio"],
            force_factor_n_per_v=main.force_factor_n_per_v * p["force_factor_ratio"],
            resistance_ns_per_m=main.resistance_ns_per_m * p["resistance_ratio"],
            visibility=p["visibility"])
        return replace(load, branches=(*load.branches, neighbour))


#: The resonance follows the plate's temperature to a millikelvin (2e-7 of its frequency,
#: under a hundredth of a hertz): the steady state is solved again when the plate has
#: warmed by that much, not at every message that advances the clock.
TEMPERATURE_RESOLUTION_K = 1e-3
#: The stream the room's drift is drawn from: the bench's, not a plate's (`draw_stream`).
ROOM_DRIFT_STREAM = "room_drift"


class HeatingDrift(Effect):
    """The plate warms with the power it dissipates and its resonance falls.

    First-order thermal model dT/dt = (P R_th - dT) / tau_th of `plates.warming`'s lumped
    body at the plate's present length (a cut state's), advanced with the bench clock (power
    piecewise constant between clock advances), about the nominal values `specifications.HEATING_NOMINAL` states (free convection from
    both faces, aluminium's specific heat, Table 2's density, the frequency's temperature
    coefficient).

    The room's air drifts at `room_drift_k_per_s` (K/s, constant over a run) and the plate
    follows it through the same lag: tau dT/dt = P R_th + r t - T, T the plate's temperature
    over the room's when the bench opened (the run's start), whose response to the ramp r t
    is r (t - tau) once settled; a plate mounted during the run has followed the room as well.

    With `draw: 1` (or 2) the parameters of `specifications.HEATING_TOLERANCES` are drawn
    once per plate and `bench_seed`, within their tolerances (or as the world errs,
    `systematic_effects.drawn_fraction`), about the values the scene gives: a coverage
    study's plate warms as one real plate might, not as the nominal one. The room's rate is
    drawn once per bench (every plate on it shares its room) within
    +-`warming.ROOM_DRIFT_K_PER_S`, the limit the drift budgets claim, added to the scene's.
    """

    name = "heating_drift"
    defaults = {**HEATING_NOMINAL, "density_kg_m3": ALUMINIUM_TABLE2.density_kg_m3, "room_drift_k_per_s": 0.0,
                "draw": 0.0, "bench_seed": 0.0}
    limits = {"draw": (0.0, 2.0), "bench_seed": (0.0, 2.0**32 - 1)}
    stages = frozenset({"load"})

    def __init__(self, scene, **parameters: float) -> None:
        super().__init__(scene, **parameters)
        if self.parameters["draw"]:
            rng = draw_stream(self.parameters["bench_seed"], self.name, scene.plate.name)
            self.parameters.update({key: self.parameters[key] * (1.0 + drawn_fraction(rng, self.parameters["draw"])
                                                                 * tolerance.half_width)
                                    for key, tolerance in HEATING_TOLERANCES.items()})
            room = draw_stream(self.parameters["bench_seed"], ROOM_DRIFT_STREAM)
            self.parameters["room_drift_k_per_s"] += drawn_fraction(room, self.parameters["draw"]) * warming.ROOM_DRIFT_K_PER_S
        self._scene = scene
        self._size(scene.plate.length_mm)
        self.temperature_rise_k = 0.0
        self._bench = self._state_name = None

    def _size(self, length_mm: float) -> None:
        """The body of the plate at `length_mm` (a cut state is shorter: less metal and less
        face for the same power, so it warms further; its time constant does not change)."""
        p, plate = self.parameters, self._scene.plate
        body = warming.thermal_plate(length_mm, plate.width_mm, plate.thickness_mm, p["density_kg_m3"],
                                     p["specific_heat_j_per_kg_k"], p["convection_w_per_m2_k"])
        self.length_mm = length_mm
        self.thermal_resistance_k_per_w = 1.0 / body.conductance_w_per_k
        self.time_constant_s = body.time_constant_s

    def load(self, load: physics.PlateLoad) -> physics.PlateLoad:
        factor = 1.0 + self.parameters["frequency_coefficient_per_k"] * self.state_key()
        return load.with_branch_frequencies_scaled(factor)

    def attach(self, bench) -> None:
        self._bench = bench
        # a plate mounted during the run sat in the same room since it began, at rest: it
        # followed the room's ramp as a plate on the bench would, r (t - tau (1 - exp(-t / tau)))
        now_s = bench.clock.now_s()
        self.temperature_rise_k = self.parameters["room_drift_k_per_s"] * (
            now_s - self.time_constant_s * -math.expm1(-now_s / self.time_constant_s))
        bench.clock.subscribe(self._advance)

    def detach(self, bench) -> None:
        bench.clock.unsubscribe(self._advance)

    def state_key(self) -> float:
        """The temperature rise the plate's resonance follows, to TEMPERATURE_RESOLUTION_K."""
        return round(self.temperature_rise_k / TEMPERATURE_RESOLUTION_K) * TEMPERATURE_RESOLUTION_K

    def _advance(self, start_s: float, duration_s: float) -> None:
        if self._bench.state_name != self._state_name:   # a cut: the piece kept holds its temperature
            self._state_name = self._bench.state_name
            self._size(_state_length_mm(self._bench, self.length_mm))
        # Sub-steps of a tenth of tau keep the power (which depends on the temperature
        # through the detuning) nearly constant within each step; the room's ramp is exact
        # in each: T(t + h) = T_p(t + h) + (T(t) - T_p(t)) exp(-h / tau), T_p = P R + r (t - tau).
        steps = max(1, math.ceil(10.0 * duration_s / self.time_constant_s))
        step_s = duration_s / steps
        decay = math.exp(-step_s / self.time_constant_s)
        room_k_per_s = self.parameters["room_drift_k_per_s"]
        for i in range(steps):
            held_k = self._bench.plate_power_w() * self.thermal_resistance_k_per_w
            lagged_s = start_s + i * step_s - self.time_constant_s   # the ramp the plate follows, lagged by tau
            self.temperature_rise_k = (held_k + room_k_per_s * (lagged_s + step_s)
                                       + (self.temperature_rise_k - held_k - room_k_per_s * lagged_s) * decay)


def _state_length_mm(bench, otherwise_mm: float) -> float:
    """The plate's length in the bench's present state (a Table 3 cut), or `otherwise_mm`
    while a calibration resistor, not a state of the scene, stands in for the plate."""
    try:
        return bench.scene.plate_in(bench.state).length_mm
    except SceneError:
        return otherwise_mm


class SettlingTransient(Effect):
    """After a drive change the vibration approaches its new steady state with the
    ring time tau = q_mech / (pi f_r) of each mode; an acquisition started too early
    sees the old amplitude fading into the new one.

    Simplification: each mode's fundamental phasor moves exponentially from its value
    at the change to the new steady state; the beat between the drive and the free
    ring-down frequency is not modelled (it averages out over triggered acquisitions).
    """

    name = "settling_transient"
    stages = frozenset({"motion"})

    def __init__(self, scene, **parameters: float) -> None:
        super().__init__(scene, **parameters)
        self._change_s = 0.0
        self._start = None  # branch fundamentals at the change
        self._target = None  # branch fundamentals of the new steady state
        self._tau_s = None

    def attach(self, bench) -> None:
        self.settle(bench.steady_state())

    def settle(self, steady: physics.SteadyState) -> None:
        """Forget the past: the plate is in steady state (a fresh mount, a new state)."""
        self._start = self._target = steady.branch_velocity_phasors_mps[:, 0]
        self._tau_s = np.array([b.ring_time_constant_s for b in steady.branches])

    def drive_changed(self, now_s: float, steady: physics.SteadyState) -> None:
        self._start = self._fundamentals_at(now_s)
        self._target = steady.branch_velocity_phasors_mps[:, 0]
        self._tau_s = np.array([b.ring_time_constant_s for b in steady.branches])
        self._change_s = now_s

    def _fundamentals_at(self, time_s: float) -> np.ndarray:
        fade = np.exp(-(time_s - self._change_s) / self._tau_s)
        start = _padded(self._start, len(self._target))
        return self._target + (start - self._target) * fade

    def motion(self, fundamentals: np.ndarray, ctx: AcquisitionContext) -> np.ndarray:
        """(n_branches, n_samples) fundamentals, averaged over the acquisitions."""
        start = _padded(self._start, len(self._target))
        since_change_s = ctx.start_s - self._change_s + (ctx.record_times_s - ctx.record_times_s[0])
        # mean over k of exp(-(t + k T)/tau): a geometric series
        per_acquisition = np.exp(-ctx.acquisition_period_s / self._tau_s)
        k = np.arange(ctx.averages)
        mean_fade = np.mean(per_acquisition[:, None] ** k[None, :], axis=1)
        fade = mean_fade[:, None] * np.exp(-since_change_s[None, :] / self._tau_s[:, None])
        return fundamentals + (start - self._target)[:, None] * fade


class DcOffset(Effect):
    """DC offsets at the scope inputs: the voltage probe output (0.5 mV is 50 mV at the
    piezo through 100:1), the TCP202 residual after degauss, the vibrometer output.
    They bias the MATH mean by the product of the CH1 and CH2 offsets."""

    name = "dc_offset"
    defaults = {"ch1_v": 0.0005, "ch2_a": 0.002, "ch3_v": 0.005}
    stages = frozenset({"signals"})

    def signals(self, signals: np.ndarray, ctx: AcquisitionContext) -> np.ndarray:
        p = self.parameters
        return signals + np.array([p["ch1_v"], p["ch2_a"], p["ch3_v"]])[:, None]


class VibrometerRange(Effect):
    """The velocity decoder's output saturates at +-10 V; OverRange then reads 1
    (`SimulatedBench.vibrometer_over_range`)."""

    name = "vibrometer_range"
    defaults = {"output_limit_v": 10.0}
    stages = frozenset({"signals"})

    def signals(self, signals: np.ndarray, ctx: AcquisitionContext) -> np.ndarray:
        limit = self.parameters["output_limit_v"]
        output = signals[VIBROMETER_CHANNEL]
        if np.max(np.abs(output)) > limit:
            signals = signals.copy()
            signals[VIBROMETER_CHANNEL] = np.clip(output, -limit, limit)
        return signals


class ScopeNoise(Effect):
    """Vertical noise of the scope, rms in divisions per channel (the TCP202 adds its
    own, so CH2 is noisier)."""

    name = "scope_noise"
    defaults = {"ch1_div_rms": 0.01, "ch2_div_rms": 0.03, "ch3_div_rms": 0.01}
    stages = frozenset({"noise"})

    def noise_div_rms(self, ctx: AcquisitionContext) -> np.ndarray:
        p = self.parameters
        return np.array([p["ch1_div_rms"], p["ch2_div_rms"], p["ch3_div_rms"]])


class VibrometerNoise(Effect):
    """Velocity noise of the decoder, rms in m/s (assumed: a fraction of a mm/s over
    the decoder bandwidth), seen on CH3 through the range."""

    name = "vibrometer_noise"
    defaults = {"velocity_mps_rms": 2e-4}
    stages = frozenset({"noise"})

    def noise_div_rms(self, ctx: AcquisitionContext) -> np.ndarray:
        output_v = self.parameters["velocity_mps_rms"] / ctx.vibrometer_range_mps_per_v
        ch3_div = output_v * ctx.display_gain[VIBROMETER_CHANNEL] / ctx.scale_per_div[VIBROMETER_CHANNEL]
        return np.array([0.0, 0.0, ch3_div])


class Quantisation(Effect):
    """The TDS3000's ADC: 9 bits per sample; averages kept to 14 bits (read with
    DAT:WID 2, left-justified in 16 bits)."""

    name = "quantisation"
    defaults = {"sample_bits": 9, "average_bits": 14}
    stages = frozenset({"digitizer"})

    def digitizer(self, settings: "DigitizerSettings") -> "DigitizerSettings":
        p = self.parameters
        return replace(settings, sample_lsb_div=ADC_SPAN_DIV / 2 ** p["sample_bits"],
                        average_lsb_div=ADC_SPAN_DIV / 2 ** p["average_bits"])


class Averaging(Effect):
    """ACQ:MOD AVE averages N acquisitions: random noise falls as 1/sqrt(N) and noise
    dithers the quantisation. Off, an averaged acquisition is one sample-mode record.

    The average is drawn without drawing its N records where the statistics allow
    (`simbench.traces.average_of_records` states when): at or above
    `dither_threshold_lsb` sample steps of noise, quantisation errors are independent and
    nearly uniform (bias below exp(-2 pi^2) of a step), so one record has the signal's
    mean and variance sigma^2 + lsb^2/12.
    """

    name = "averaging"
    defaults = {"dither_threshold_lsb": 1.0}
    stages = frozenset({"digitizer"})

    def digitizer(self, settings: "DigitizerSettings") -> "DigitizerSettings":
        return replace(settings, averaging=True,
                        dither_threshold_lsb=self.parameters["dither_threshold_lsb"])



EFFECTS: dict[str, type[Effect]] = {cls.name: cls for cls in (
    Shunt, DielectricLossEffect, AmplifierLimits, NeighbouringMode, HeatingDrift,
    SettlingTransient, DcOffset, VibrometerRange, ScopeNoise, VibrometerNoise,
    Quantisation, Averaging, ClippedTrace, BusTimeout, GarbledReplyFault, TruncatedReplyFault,
    InstrumentErrorEntry, Disconnect, ScopeGainError, VoltageProbeError, CurrentProbeGainError, VibrometerScaleError,
    ChannelSkew, CurrentProbeDelay, VoltageProbeCompensation, GeneratorFrequencyError, GeneratorAmplitudeError,
    ScopeTimebaseError, StageBacklash, PlateOffset, PlatePlacement, PlateTilt)}
# the plate drawn within its tolerances (a module of its own; it registers itself in EFFECTS)
from squeezebench.simbench import plate_draws  # noqa: E402,F401


# -- the digitiser ----------------------------------------------------------------------
#: 16-bit samples span 65536 / 6400 = 10.24 divisions: 25 levels per division at 8 bits.
COUNTS_PER_DIV = 6400.0
ADC_SPAN_DIV = 65536 / COUNTS_PER_DIV
ADC_MIN_DIV = -32768 / COUNTS_PER_DIV
ADC_MAX_DIV = 32767 / COUNTS_PER_DIV


@dataclass(frozen=True)
class DigitizerSettings:
    sample_lsb_div: float | None = None  # None: not quantised
    average_lsb_div: float | None = None
    averaging: bool = False
    dither_threshold_lsb: float = 1.0


# -- the pipeline -----------------------------------------------------------------------
class EffectPipeline:
    """The effects of a scene, sorted by the stage they act at."""

    STAGES = ("generator", "amplifier", "load", "motion", "timing", "timebase", "signals", "noise", "digitizer",
              "spot", "bus")

    def __init__(self, effects: list[Effect]) -> None:
        self.effects = effects
        self.by_stage = {stage: [e for e in effects if stage in e.stages] for stage in self.STAGES}
        self._generator = [e.generator for e in self.by_stage["generator"]]
        self._delays = [e.delays_s for e in self.by_stage["timing"]]
        self._timebase = [e.sample_interval_scale for e in self.by_stage["timebase"]]
        self._amplifier = [e.amplifier for e in self.by_stage["amplifier"]]
        self._load = [e.load for e in self.by_stage["load"]]
        # the load effects with a state of their own (a plate's temperature): asked at every clock advance
        self._load_states = [e.state_key for e in self.by_stage["load"] if type(e).state_key is not Effect.state_key]
        self._motion = [e.motion for e in self.by_stage["motion"]]
        self._signals = [e.signals for e in self.by_stage["signals"]]
        self._noise = [e.noise_div_rms for e in self.by_stage["noise"]]
        # carriage (backlash), then stage frame to plate frame (as set, as mounted), then the tilted surface
        order = {"stage_backlash": 0, "plate_offset": 1, "plate_placement": 2, "plate_tilt": 3}
        self._spot = [e.spot for e in sorted(self.by_stage["spot"], key=lambda e: order[e.name])]
        self.digitizer_settings = DigitizerSettings()
        for effect in self.by_stage["digitizer"]:
            self.digitizer_settings = effect.digitizer(self.digitizer_settings)
        self.is_random = bool(self._noise)
        #: Acquisitions at the same settings may show different screens (a moving plate, an
        #: effect that changes per acquisition): no screen can be reused.
        self.screen_varies = bool(self._motion) or any(e.varies_per_acquisition for e in effects)
        #: Acquisitions at the same settings may differ: no record can be reused.
        self.varies = self.is_random or self.screen_varies
        #: A signal depends on the vertical scales: a re-ranged acquisition synthesises anew.
        self.signals_read_vertical_scale = any(e.reads_vertical_scale for e in self.by_stage["signals"])
        self.bus = self.by_stage["bus"]

    @property
    def names(self) -> list[str]:
        return [e.name for e in self.effects]

    def get(self, name: str) -> Effect | None:
        return next((e for e in self.effects if e.name == name), None)

    def generator(self, settings: physics.GeneratorSettings) -> physics.GeneratorSettings:
        for stage in self._generator:
            settings = stage(settings)
        return settings

    def channel_delays_s(self, frequency_hz: float) -> np.ndarray | None:
        """Delay of each channel at the drive frequency (delays add); None when no effect delays."""
        return sum(stage(frequency_hz) for stage in self._delays) if self._delays else None

    def sampled(self, setup):
        """The scope setup `setup` (`traces.ScopeSetup`) as its samples were really taken: its
        time base scaled by the sample clock's errors (the horizontal scale sets the sample
        interval and the record's start from the trigger); `setup` itself, the same object,
        when no effect acts on the time base."""
        if not self._timebase:
            return setup
        return replace(setup, horizontal_scale_s=setup.horizontal_scale_s * math.prod(s() for s in self._timebase))

    def amplifier(self, amplifier: physics.Amplifier) -> physics.Amplifier:
        for stage in self._amplifier:
            amplifier = stage(amplifier)
        return amplifier

    def load(self, load: physics.PlateLoad) -> physics.PlateLoad:
        for stage in self._load:
            load = stage(load)
        return load

    def load_state(self) -> tuple:
        """The load effects' own states (`Effect.state_key`) the steady state depends on."""
        return tuple([state() for state in self._load_states])

    def motion(self, fundamentals: np.ndarray, ctx: AcquisitionContext) -> np.ndarray:
        for stage in self._motion:
            fundamentals = stage(fundamentals, ctx)
        return fundamentals

    def spot(self, stage_mm: tuple[float, float], directions: tuple[int, int]) -> Spot:
        """Where the laser meets the plate for the stage's encoder position `stage_mm` and
        each axis's last direction of travel (+1, -1, 0 never moved)."""
        spot = Spot(*stage_mm)
        for stage in self._spot:
            spot = stage(spot, directions)
        return spot

    @property
    def has_motion(self) -> bool:
        return bool(self._motion)

    def signals(self, signals: np.ndarray, ctx: AcquisitionContext) -> np.ndarray:
        for stage in self._signals:
            signals = stage(signals, ctx)
        return signals

    def noise_div_rms(self, ctx: AcquisitionContext) -> np.ndarray:
        """Independent noises add in power."""
        variance = np.zeros(len(CHANNELS))
        for stage in self._noise:
            variance += stage(ctx) ** 2
        return np.sqrt(variance)

    def attach(self, bench) -> None:
        for effect in self.effects:
            effect.attach(bench)

    def detach(self, bench) -> None:
        for effect in self.effects:
            effect.detach(bench)


def build_pipeline(scene) -> EffectPipeline:
    """Fresh effect objects (they may hold state, e.g. a temperature) for a scene."""
    return EffectPipeline([EFFECTS[spec.name](scene, **spec.parameters) for spec in scene.effects])


def _padded(values: np.ndarray, length: int) -> np.ndarray:
    """A branch vector extended with zeros (a mode that did not exist was at rest)."""
    return values if len(values) == length else np.concatenate([values, np.zeros(length - len(values))])
