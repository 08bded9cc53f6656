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
- `spot`: where the vibrometer's laser meets the plate when the x-y stage moves it
  (backlash, a plate off the stage's zero or rotated, a tilted plate);
- `bus`: faults of the instruments and their link (timeouts, garbled or truncated
  replies, error-queue entries, a disconnect), for testing what a campaign does on a
  bad day.

`EffectPipeline` keeps, per stage, only the effects acting there, chosen once when the
scene is loaded: an effect that is off is never called, and the ideal bench runs none.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from squeezebench.plates.specifications import SPECIFICATIONS, compensation_phase_rad
from squeezebench.simbench import physics

#: Screen channels: CH1 piezo voltage (V), CH2 current (A), CH3 vibrometer output (V).
CHANNELS = ("CH1", "CH2", "CH3")
VIBROMETER_CHANNEL = 2  # index of CH3 in CHANNELS


@dataclass
class AcquisitionContext:
    """What the stages need to know about one acquisition."""

    record_times_s: np.ndarray  # sample times from the trigger (s)
    start_s: float  # bench time when the first averaged acquisition starts
    acquisition_period_s: float  # from one averaged acquisition to the next
    averages: int  # 1 in sample mode
    scale_per_div: np.ndarray  # channel units per division, per channel
    display_gain: np.ndarray  # channel units per physical unit (probe settings)
    vibrometer_range_mps_per_v: float


class Effect:
    """Base of all effects: a name, default parameters and the stages it acts at."""

    name: ClassVar[str]
    defaults: ClassVar[dict[str, float]] = {}
    #: Allowed (low, high) of a parameter, checked when the scene is read.
    limits: ClassVar[dict[str, tuple[float, float]]] = {}
    stages: ClassVar[frozenset[str]] = frozenset()
    #: True when two acquisitions at the same settings differ (the record cannot be reused).
    varies_per_acquisition: ClassVar[bool] = False
    #: A fault (issue 7) rather than a property of a healthy bench.
    fault: ClassVar[bool] = False

    def __init__(self, scene, **parameters: float) -> None:
        self.scene = scene
        self.parameters = {**self.defaults, **parameters}

    def attach(self, bench) -> None:
        """Called once when a simulated bench starts using this effect."""

    def detach(self, bench) -> None:
        """Called when the bench swaps the scene (mount) or closes."""

    def state_key(self):
        """What of the effect's own state the steady state depends on (None: nothing)."""
        return None


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
    defaults = {"tan_delta_at_reference": 0.002735, "reference_field_amplitude_v_per_mm": 240.0,
                "exponent": 1.0}
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


class HeatingDrift(Effect):
    """The plate warms with the power it dissipates and its resonance falls.

    First-order thermal model dT/dt = (P R_th - dT) / tau_th, advanced with the bench
    clock (power piecewise constant between clock advances). Assumed: free convection
    from both faces, h = 10 W/m2K (the plate lies on a cushion); aluminium specific heat
    900 J/kgK and Table 2's density 2790 kg/m3; frequency coefficient -2e-4 per kelvin
    (the Young's modulus of aluminium falls about 4e-4/K, f scales with its square root).
    """

    name = "heating_drift"
    defaults = {"frequency_coefficient_per_k": -2e-4, "convection_w_per_m2_k": 10.0,
                "specific_heat_j_per_kg_k": 900.0, "density_kg_m3": 2790.0}
    stages = frozenset({"load"})

    def __init__(self, scene, **parameters: float) -> None:
        super().__init__(scene, **parameters)
        p, plate = self.parameters, scene.plate
        area_m2 = 2.0 * plate.length_mm * plate.width_mm * 1e-6
        mass_kg = p["density_kg_m3"] * plate.length_mm * plate.width_mm * plate.thickness_mm * 1e-9
        self.thermal_resistance_k_per_w = 1.0 / (p["convection_w_per_m2_k"] * area_m2)
        self.time_constant_s = self.thermal_resistance_k_per_w * mass_kg * p["specific_heat_j_per_kg_k"]
        self.temperature_rise_k = 0.0
        self._plate_power_w = None

    def load(self, load: physics.PlateLoad) -> physics.PlateLoad:
        factor = 1.0 + self.parameters["frequency_coefficient_per_k"] * self.state_key()
        return load.with_branch_frequencies_scaled(factor)

    def attach(self, bench) -> None:
        self._plate_power_w = bench.plate_power_w
        bench.clock.subscribe(self._advance)

    def detach(self, bench) -> None:
        bench.clock.unsubscribe(self._advance)

    def state_key(self) -> float:
        """The temperature rise the plate's resonance follows, to TEMPERATURE_RESOLUTION_K."""
        return round(self.temperature_rise_k / TEMPERATURE_RESOLUTION_K) * TEMPERATURE_RESOLUTION_K

    def _advance(self, start_s: float, duration_s: float) -> None:
        # Sub-steps of a tenth of tau keep the power (which depends on the temperature
        # through the detuning) nearly constant within each step.
        steps = max(1, math.ceil(10.0 * duration_s / self.time_constant_s))
        decay = math.exp(-duration_s / steps / self.time_constant_s)
        for _ in range(steps):
            final_k = self._plate_power_w() * self.thermal_resistance_k_per_w
            self.temperature_rise_k = final_k + (self.temperature_rise_k - final_k) * decay


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


# -- systematic errors (issue 15) ----------------------------------------------------------
class SystematicEffect(Effect):
    """An error of the bench's instruments within their specification: the same on every
    acquisition, unknown to whoever measures, and removable only by calibration.

    Each error parameter defaults to the instrument's specified limit
    (`plates.specifications`). With `draw: 1` the parameter is a half-width instead: the
    error is drawn once, uniformly in +-|value|, from `bench_seed`, as a real bench has one
    unknown set of errors within its specifications. Scenes naming the same `bench_seed`
    share the draw (the same instruments measure every plate); the accuracy study varies
    it to simulate many benches.

    `draw: 2` draws as the world may err rather than as the budgets assume (`world_draw`):
    normal, not rectangular; a delay with the sign and size a probe's data sheet would give
    it (`world_bias`); and now and then an error beyond its specification. A coverage
    study on such benches tests the budgets against errors they did not assume.
    """

    errors: ClassVar[tuple[str, ...]] = ()
    #: The error's typical value and spread as fractions of the limit (`world_draw`).
    world_bias: ClassVar[float] = 0.0
    world_spread: ClassVar[float] = 0.5

    def __init_subclass__(cls, errors: dict[str, float] | None = None, **kwargs) -> None:
        """`errors`: the error parameters and their default (specified) magnitudes."""
        super().__init_subclass__(**kwargs)
        if errors is not None:
            cls.errors = tuple(errors)
            cls.defaults = {**errors, "draw": 0.0, "bench_seed": 0.0}
            cls.limits = {"draw": (0.0, 2.0), "bench_seed": (0.0, 2.0**32 - 1)}

    def __init__(self, scene, **parameters: float) -> None:
        super().__init__(scene, **parameters)
        p = self.parameters
        if p["draw"]:
            rng = np.random.default_rng([int(p["bench_seed"]), zlib.crc32(self.name.encode())])
            if int(p["draw"]) == 2:
                self.values = {k: world_draw(rng, self.world_bias, self.world_spread) * abs(p[k])
                               for k in self.errors}
            else:
                self.values = {k: float(rng.uniform(-1.0, 1.0)) * abs(p[k]) for k in self.errors}
        else:
            self.values = {k: p[k] for k in self.errors}


#: How often an error of a `draw: 2` bench is beyond its specification, and how far (one
#: bench in 13 has one: eight errors per bench).
OUT_OF_SPEC_PROBABILITY = 0.01
OUT_OF_SPEC_FACTOR = 1.5


def world_draw(rng: np.random.Generator, bias: float, spread: float) -> float:
    """An error as a fraction of its specified limit, drawn as instruments err rather than
    as a budget assumes: normal around `bias` with standard deviation `spread` (half the
    limit puts about 5 % of unbiased instruments beyond it), and with probability
    OUT_OF_SPEC_PROBABILITY out of specification, OUT_OF_SPEC_FACTOR times its limit with
    a random sign (a probe dropped once, a scope overdue for calibration)."""
    if rng.uniform() < OUT_OF_SPEC_PROBABILITY:
        return OUT_OF_SPEC_FACTOR * (1.0 if rng.uniform() < 0.5 else -1.0)
    return float(rng.normal(bias, spread))


class _ChannelGains(SystematicEffect):
    """A systematic effect that scales the channels as the scope sees them (`gains()`:
    one factor per channel)."""

    stages = frozenset({"signals"})

    def signals(self, signals: np.ndarray, ctx: AcquisitionContext) -> np.ndarray:
        return signals * self.gains()[:, None]


class ScopeGainError(_ChannelGains, errors=dict.fromkeys(("ch1_rel", "ch2_rel", "ch3_rel"),
                                                        SPECIFICATIONS["scope_gain"].half_width)):
    """Vertical gain error of each scope channel: CH<n> reads (1 + ch<n>_rel) times its
    input. Default +-2 %: TDS3000B User Manual, App. A, DC gain accuracy."""

    name = "scope_gain_error"

    def gains(self) -> np.ndarray:
        v = self.values
        return 1.0 + np.array([v["ch1_rel"], v["ch2_rel"], v["ch3_rel"]])


class VoltageProbeError(_ChannelGains,
                        errors={"attenuation_rel": SPECIFICATIONS["voltage_probe_attenuation"].half_width}):
    """The voltage probe divides by its nominal attenuation / (1 + attenuation_rel): CH1
    sees (1 + attenuation_rel) times the amplifier output over the nominal ratio. Default
    +-2 %, assumed (`plates.specifications` says why); it adds to the scope's gain error."""

    name = "voltage_probe_error"

    def gains(self) -> np.ndarray:
        return np.array([1.0 + self.values["attenuation_rel"], 1.0, 1.0])


class CurrentProbeGainError(_ChannelGains,
                            errors={"gain_rel": SPECIFICATIONS["current_probe_gain"].half_width}):
    """The TCP202 puts out (1 + gain_rel) times the current. Default +-3 %: TCP202
    instruction manual (070-9542), Specifications, DC accuracy."""

    name = "current_probe_gain_error"

    def gains(self) -> np.ndarray:
        return np.array([1.0, 1.0 + self.values["gain_rel"], 1.0])


class VibrometerScaleError(_ChannelGains,
                           errors={"scale_rel": SPECIFICATIONS["vibrometer_scale"].half_width}):
    """The OFV-5000 decoder puts out (1 + scale_rel) times velocity / range. Default
    +-1 %: Polytec velocity decoder specifications, calibration error of the analog
    output."""

    name = "vibrometer_scale_error"

    def gains(self) -> np.ndarray:
        return np.array([1.0, 1.0, 1.0 + self.values["scale_rel"]])


class _ChannelDelay(SystematicEffect):
    """A systematic effect that delays CH2 against CH1 (the scope triggers on CH1)."""

    stages = frozenset({"timing"})
    delay_parameter: ClassVar[str]

    def delays_s(self, frequency_hz: float) -> np.ndarray:
        """Each channel's delay at the drive frequency (a pure delay: the same at every one)."""
        return np.array([0.0, self.values[self.delay_parameter], 0.0])


class ChannelSkew(_ChannelDelay, errors={"ch2_delay_s": SPECIFICATIONS["scope_skew"].half_width}):
    """The scope's own delay of CH2 against CH1: CH2 shows i(t - ch2_delay_s). Mean
    power becomes 0.5 Re(V conj(I) exp(j w tau)) = P cos(w tau) - Q_r sin(w tau), with
    Q_r = 0.5 Im(V conj I) (negative for the capacitive plate: a delay raises the power;
    phasor algebra). Default 1 ns, assumed: no TDS3000B figure was found (Tektronix
    verifies +-50 to +-100 ps on its TDS 500B/600B/700A); `plates.specifications`
    says why 1 ns."""

    name = "channel_skew"
    delay_parameter = "ch2_delay_s"


class CurrentProbeDelay(_ChannelDelay,
                        errors={"delay_s": SPECIFICATIONS["current_probe_delay"].half_width}):
    """The TCP202's signal delay left uncorrected against the voltage probe: CH2 shows
    i(t - delay_s); same closed form as `channel_skew`. Default 10 ns, assumed: a current
    probe's propagation delay exceeds a voltage probe's by ~8 ns in Tektronix's own
    deskew example (TCP0030 against TDP1000), and +-10 ns is what CH<x>:DESKew can
    correct (programmer manual). At
    the Fig. 2c stress point (power factor 0.018) 10 ns moves the power by ~16 mW."""

    name = "current_probe_delay"
    delay_parameter = "delay_s"
    world_bias, world_spread = 0.8, 0.15   # ~8 +- 1.5 ns behind the voltage probe (Tektronix's deskew example)


class VoltageProbeCompensation(_ChannelDelay,
                               errors={"mismatch_rel": SPECIFICATIONS["voltage_probe_compensation"].half_width}):
    """The voltage probe's divider compensated off by mismatch_rel (its high-frequency gain
    over its low-frequency gain, minus one): CH1 leads by `compensation_phase_rad`, about
    mismatch_rel * f_pole / f at the plates' frequencies, a phase that falls with frequency
    where a delay's grows. Shown as CH1 advanced by phase / w at the drive frequency. Its gain
    part is the attenuation error at the working frequency (`voltage_probe_error`). Default
    +-1 %, assumed (`plates.specifications` says why)."""

    name = "voltage_probe_compensation"

    def delays_s(self, frequency_hz: float) -> np.ndarray:
        phase = compensation_phase_rad(self.values["mismatch_rel"], frequency_hz)
        return np.array([-phase / (2.0 * np.pi * frequency_hz), 0.0, 0.0])


class GeneratorFrequencyError(SystematicEffect,
                              errors={"frequency_rel": SPECIFICATIONS["generator_frequency"].half_width}):
    """The 33120A puts out (1 + frequency_rel) times the frequency it is set to (and
    answers FREQ? with the setting). Default +-20 ppm: 33120A User's Guide,
    Specifications, frequency accuracy (1 year)."""

    name = "generator_frequency_error"
    stages = frozenset({"generator"})

    def generator(self, settings: physics.GeneratorSettings) -> physics.GeneratorSettings:
        return replace(settings, frequency_hz=settings.frequency_hz * (1.0 + self.values["frequency_rel"]))


# -- faults (issue 7) ------------------------------------------------------------------------
class ClippedTrace(Effect):
    """A burst on CH2 (a switching spike, a probe knocked) far beyond the screen in the
    `count` acquisitions from the `at_acquisition`-th one of the bench: the record
    clips, the driver raises ClippedTraceError and the protocol must re-range."""

    name = "clipped_trace"
    defaults = {"at_acquisition": 5.0, "count": 1.0, "height_div": 20.0}
    limits = {"at_acquisition": (1.0, math.inf), "count": (1.0, math.inf), "height_div": (6.0, math.inf)}
    stages = frozenset({"signals"})
    varies_per_acquisition = True
    fault = True

    def __init__(self, scene, **parameters: float) -> None:
        super().__init__(scene, **parameters)
        self.acquisitions = 0

    def signals(self, signals: np.ndarray, ctx: AcquisitionContext) -> np.ndarray:
        self.acquisitions += 1
        first = self.parameters["at_acquisition"]
        if not first <= self.acquisitions < first + self.parameters["count"]:
            return signals
        signals = signals.copy()
        burst = slice(signals.shape[1] // 2, signals.shape[1] // 2 + max(1, signals.shape[1] // 50))
        height = self.parameters["height_div"] * ctx.scale_per_div[1] / ctx.display_gain[1]
        signals[1, burst] += height
        return signals


class TruncatedPayload(bytearray):
    """The part of a reply that arrived; its end never does."""


class BusFault(Effect):
    """A fault of one instrument or its link, from the `at_message`-th message the bench's
    instruments receive (every command and query of all three, counted from when the
    bench opens), on `instrument` (1 generator, 2 scope, 3 vibrometer; 0 any of them),
    for `count` messages. A reply fault hits the first `count` queries from there.

    A simulated instrument calls `act` before it handles a message the fault hits, and
    passes the reply (with its terminator) through `reply`.
    """

    defaults = {"at_message": 200.0, "instrument": 0.0, "count": 1.0}
    limits = {"at_message": (1.0, math.inf), "instrument": (0.0, 3.0), "count": (1.0, math.inf)}
    stages = frozenset({"bus"})
    fault = True
    ROLES = (None, "generator", "scope", "vibrometer")
    needs_reply: ClassVar[bool] = True

    def __init__(self, scene, **parameters: float) -> None:
        super().__init__(scene, **parameters)
        self.role = self.ROLES[int(self.parameters["instrument"])]
        self.remaining = int(self.parameters["count"])

    def hits(self, role: str, message_number: int, is_query: bool) -> bool:
        """Whether this message is faulted (and one fault fewer remains)."""
        if (self.remaining <= 0 or message_number < self.parameters["at_message"]
                or (self.role is not None and role != self.role) or (self.needs_reply and not is_query)):
            return False
        self.remaining -= 1
        return True

    def act(self, instrument) -> None:
        """What the fault does to the instrument before it handles the message."""

    def reply(self, payload: bytearray, eom: bytes) -> bytearray | None:
        """The reply as it reaches the bus (None: nothing arrives)."""
        return payload


class BusTimeout(BusFault):
    """The instrument never answers the query: the read waits out its VISA timeout."""

    name = "bus_timeout"

    def reply(self, payload: bytearray, eom: bytes) -> None:
        return None


class GarbledReplyFault(BusFault):
    """The reply arrives as line noise (bytes that are not the instrument's text)."""

    name = "garbled_reply"

    def reply(self, payload: bytearray, eom: bytes) -> bytearray:
        return bytearray(b"\xff\xfe\x1b#@!" + eom)


class TruncatedReplyFault(BusFault):
    """Only the first half of the reply arrives, without its end: the read times out."""

    name = "truncated_reply"

    def reply(self, payload: bytearray, eom: bytes) -> TruncatedPayload:
        return TruncatedPayload(payload[:max(1, (len(payload) - len(eom)) // 2)])


class InstrumentErrorEntry(BusFault):
    """The instrument queues an error (SYST:ERR? / *ESR? + EVMSG?) as it handles the
    message, as a real one does for a setting it cannot apply. The vibrometer keeps no
    error queue: on it the fault does nothing."""

    name = "instrument_error"
    needs_reply = False

    def act(self, instrument) -> None:
        instrument.inject_error()


class Disconnect(BusFault):
    """The instrument drops off the bus (cable, power, network) for good: from the
    `at_message`-th message on every write and read to it fails (`count` is unused)."""

    name = "disconnect"
    needs_reply = False

    def hits(self, role: str, message_number: int, is_query: bool) -> bool:
        return (message_number >= self.parameters["at_message"]
                and (self.role is None or role == self.role))

    def act(self, instrument) -> None:
        instrument.disconnected = True


# -- the laser spot on a plate the stage moves ---------------------------------------------------
@dataclass(frozen=True)
class Spot:
    """Where the laser meets the plate, mm from the plate's corner in its own frame, and
    the share of the plate's normal velocity that lies along the beam."""

    x_mm: float
    y_mm: float
    beam_share: float = 1.0


class StageBacklash(Effect):
    """Lost motion in each axis's drive: the carriage lags the motor by half the backlash
    behind its last direction of travel, so a point approached from the other side sits
    one backlash away. The SMC100's `TP` reads the motor's encoder, so the driver never
    sees it (SMC100 UM TP). Default 20 um per axis, assumed: a typical lead-screw stage
    without backlash compensation (`BA` not set)."""

    name = "stage_backlash"
    defaults = {"x_mm": 0.02, "y_mm": 0.02}
    limits = {"x_mm": (0.0, 1.0), "y_mm": (0.0, 1.0)}
    stages = frozenset({"spot"})

    def spot(self, spot: Spot, directions: tuple[int, int]) -> Spot:
        p = self.parameters
        return replace(spot, x_mm=spot.x_mm - 0.5 * p["x_mm"] * directions[0],
                       y_mm=spot.y_mm - 0.5 * p["y_mm"] * directions[1])


class PlateOffset(Effect):
    """The plate not where the map thinks: its corner at (x_mm, y_mm) in the stage's frame
    and its edges turned by rotation_deg (counter-clockwise). A grid laid out for the
    plate then drifts across it, and its last points may miss the plate (velocity 0:
    the laser lands on the mount)."""

    name = "plate_offset"
    defaults = {"x_mm": 1.0, "y_mm": 1.0, "rotation_deg": 0.5}
    limits = {"x_mm": (-50.0, 50.0), "y_mm": (-50.0, 50.0), "rotation_deg": (-10.0, 10.0)}
    stages = frozenset({"spot"})

    def spot(self, spot: Spot, directions: tuple[int, int]) -> Spot:
        p = self.parameters
        angle = math.radians(p["rotation_deg"])
        dx, dy = spot.x_mm - p["x_mm"], spot.y_mm - p["y_mm"]
        return replace(spot, x_mm=math.cos(angle) * dx + math.sin(angle) * dy,
                       y_mm=-math.sin(angle) * dx + math.cos(angle) * dy)


class PlateTilt(Effect):
    """A plate not level under a vertical beam: tilted by tilt_x_deg along its length and
    tilt_y_deg across. A horizontal step of the stage covers 1/cos(tilt) of the plate's
    surface, so the spot drifts ahead of the grid as the map goes on, and the beam sees
    the normal velocity times cos(tilt_x) cos(tilt_y). Default 1 degree along, assumed:
    a plate resting on foam (the paper's mounting is not described)."""

    name = "plate_tilt"
    defaults = {"tilt_x_deg": 1.0, "tilt_y_deg": 0.0}
    limits = {"tilt_x_deg": (-20.0, 20.0), "tilt_y_deg": (-20.0, 20.0)}
    stages = frozenset({"spot"})

    def spot(self, spot: Spot, directions: tuple[int, int]) -> Spot:
        cx, cy = math.cos(math.radians(self.parameters["tilt_x_deg"])), math.cos(math.radians(self.parameters["tilt_y_deg"]))
        return Spot(spot.x_mm / cx, spot.y_mm / cy, spot.beam_share * cx * cy)


EFFECTS: dict[str, type[Effect]] = {cls.name: cls for cls in (
    Shunt, DielectricLossEffect, AmplifierLimits, NeighbouringMode, HeatingDrift,
    SettlingTransient, DcOffset, VibrometerRange, ScopeNoise, VibrometerNoise,
    Quantisation, Averaging, ClippedTrace, BusTimeout, GarbledReplyFault, TruncatedReplyFault,
    InstrumentErrorEntry, Disconnect, ScopeGainError, VoltageProbeError, CurrentProbeGainError, VibrometerScaleError,
    ChannelSkew, CurrentProbeDelay, VoltageProbeCompensation, GeneratorFrequencyError, StageBacklash, PlateOffset, PlateTilt)}


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

    STAGES = ("generator", "amplifier", "load", "motion", "timing", "signals", "noise", "digitizer", "spot", "bus")

    def __init__(self, effects: list[Effect]) -> None:
        self.effects = effects
        self.by_stage = {stage: [e for e in effects if stage in e.stages] for stage in self.STAGES}
        self._generator = [e.generator for e in self.by_stage["generator"]]
        self._delays = [e.delays_s for e in self.by_stage["timing"]]
        self._amplifier = [e.amplifier for e in self.by_stage["amplifier"]]
        self._load = [e.load for e in self.by_stage["load"]]
        self._motion = [e.motion for e in self.by_stage["motion"]]
        self._signals = [e.signals for e in self.by_stage["signals"]]
        self._noise = [e.noise_div_rms for e in self.by_stage["noise"]]
        # carriage (backlash), then stage frame to plate frame, then the tilted surface
        order = {"stage_backlash": 0, "plate_offset": 1, "plate_tilt": 2}
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

    def amplifier(self, amplifier: physics.Amplifier) -> physics.Amplifier:
        for stage in self._amplifier:
            amplifier = stage(amplifier)
        return amplifier

    def load(self, load: physics.PlateLoad) -> physics.PlateLoad:
        for stage in self._load:
            load = stage(load)
        return load

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
