"""Systematic errors of the bench's instruments within their specifications (issue 15):
gains, delays, the scope's time base and the generator's frequency, fixed or drawn once per bench.
"""

from __future__ import annotations

import zlib
from dataclasses import replace
from typing import ClassVar

import numpy as np

from squeezebench.plates.specifications import SPECIFICATIONS, WORLD_READING, compensation_phase_rad
from squeezebench.simbench import physics
from squeezebench.simbench.effect_base import AcquisitionContext, Effect

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
    #: The error's typical value and spread as fractions of the limit (`world_draw`): the
    #: world's reading of a limit (`specifications.WORLD_READING`) unless the instrument's
    #: data sheet gives the error a known sign.
    world_bias: ClassVar[float] = 0.0
    world_spread: ClassVar[float] = WORLD_READING.spread

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
        self.values = self.drawn_values() if p["draw"] else {k: p[k] for k in self.errors}

    def drawn_values(self) -> dict[str, float]:
        """Each error parameter drawn once, in turn from `rng()`."""
        rng = self.rng()
        return {k: self.drawn(rng, k) for k in self.errors}

    def drawn(self, rng: np.random.Generator, name: str) -> float:
        """Error parameter `name` drawn from `rng` within its half-width (`drawn_fraction`)."""
        p = self.parameters
        return drawn_fraction(rng, p["draw"], self.world_bias, self.world_spread) * abs(p[name])

    #: True when each plate has its own draw on a bench (its build, its mounting) rather
    #: than one the bench's instruments share across every plate they measure.
    per_plate: ClassVar[bool] = False

    def rng(self) -> np.random.Generator:
        """The draw's stream: the bench's, the same for every plate it measures, or with
        `per_plate` the plate's on that bench (every scene of the plate, its cuts and runs,
        shares it; another plate on the same bench has its own)."""
        return draw_stream(self.parameters["bench_seed"], self.name, self.scene.plate.name if self.per_plate else None)


def draw_stream(bench_seed: float, name: str, owner: str | None = None) -> np.random.Generator:
    """The stream effect `name` draws from on bench `bench_seed` (with `owner`, that plate's
    own, or that stock's, `plate_draws.PlateTolerances`)."""
    key = [int(bench_seed), zlib.crc32(name.encode())]
    if owner is not None:
        key.append(zlib.crc32(owner.encode()))
    return np.random.default_rng(key)


def drawn_fraction(rng: np.random.Generator, draw: float, bias: float = 0.0,
                   spread: float = WORLD_READING.spread) -> float:
    """An error as a fraction of its limit, drawn once: uniformly within it (`draw` 1, as the
    budgets assume) or as the world errs (`draw` 2, `world_draw`)."""
    if int(draw) == 2:
        return world_draw(rng, bias, spread)
    return float(rng.uniform(-1.0, 1.0))


def world_draw(rng: np.random.Generator, bias: float, spread: float) -> float:
    """An error as a fraction of its specified limit, drawn as instruments err rather than
    as a budget assumes (`specifications.WORLD_READING`): normal around `bias` with standard
    deviation `spread` (half the limit puts about 5 % of unbiased instruments beyond it), and
    with probability `out_of_spec_probability` out of specification, `out_of_spec_factor`
    times its limit with a random sign (a probe dropped once, a scope overdue for calibration)."""
    if rng.uniform() < WORLD_READING.out_of_spec_probability:
        return WORLD_READING.out_of_spec_factor * (1.0 if rng.uniform() < 0.5 else -1.0)
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


class ScopeTimebaseError(SystematicEffect, errors={"interval_rel": SPECIFICATIONS["scope_timebase"].half_width}):
    """The TDS3054B's sample clock off its nominal rate: its samples are (1 + interval_rel)
    times the nominal interval apart, so the sample it labels t from the trigger (WFMPre
    XINcr, the cursors) was taken at t (1 + interval_rel). A sine of frequency f,
    cos(2 pi f t (1 + interval_rel)) on the labelled times, reads f (1 + interval_rel):
    a clock running slow (rate 1 / (1 + interval_rel)) reads every frequency high by
    interval_rel, and the record's fit, MEASUrement FREQuency and PERIod alike. Amplitudes
    and powers are the signal's, sampled at other instants of the same steady state.
    Default +-20 ppm: TDS3000B Series User Manual, App. A, sample rate and delay time
    accuracy."""

    name = "scope_timebase_error"
    stages = frozenset({"timebase"})

    def sample_interval_scale(self) -> float:
        """The sample interval over the nominal one."""
        return 1.0 + self.values["interval_rel"]


class GeneratorAmplitudeError(Effect):
    """The 33120A puts out (1 + amplitude_rel) times the amplitude it is set to (and answers
    VOLT? with the setting). Default +2 %: its amplitude accuracy and flatness at the plates'
    frequencies (`specifications.SPECIFICATIONS["generator_amplitude"]`). Fixed, never drawn:
    the point budgets state each reading at the generator's recorded setting and carry no term
    for it, so the studies leave it out; Fig. 2's Pt/P0, where only the dielectric loss keeps
    it, budgets it (`uncertainty.power_ratio_budget`)."""

    name = "generator_amplitude_error"
    defaults = {"amplitude_rel": SPECIFICATIONS["generator_amplitude"].half_width}
    limits = {"amplitude_rel": (-0.5, 0.5)}
    stages = frozenset({"generator"})

    def generator(self, settings: physics.GeneratorSettings) -> physics.GeneratorSettings:
        return replace(settings, amplitude=settings.amplitude * (1.0 + self.parameters["amplitude_rel"]))
