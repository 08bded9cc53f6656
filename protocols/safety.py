"""The only path from a protocol to the generator: limits, ramps and a safe exit.

Every change of the generator's amplitude or frequency goes through `DriveController`.
The piezo voltage is what the limits are about, and it is the amplifier's output, computed
through the whole chain (`BenchElectronics.piezo_vpp_per_generator_vpp`: the generator's
load setting, its 50 ohm output into the amplifier's input impedance, the gain): with
OUTP:LOAD 50 into a high-impedance input the 33120A puts twice its displayed Vpp on the
amplifier. Every acquisition also compares the piezo voltage measured on CH1 with the
limit (`check_measured`) and drops the drive above it: a bench file that misdescribes
the chain stops at the first point, not after a sweep. The controller refuses,
before anything is sent, a piezo voltage above the campaign limit (the paper: "we do not
apply voltage above 100 V") or above what the amplifier can deliver; it ramps large
changes in steps (a sudden 100 V step on a capacitive load is a current spike through
the shunt and the piezos); and, used as a context manager, it leaves the generator at its
minimum output whatever happens inside: an exception, Ctrl-C (SIGTERM and SIGHUP are
turned into the same KeyboardInterrupt by `squeezebench.stops`) or a normal end. While
it brings the generator down, stop signals are only recorded (`stops.protect`) and the
run stops once the generator is at its minimum; the amplitude it was last commanded is
recorded for the final message, and if the generator cannot be reached, the terminal is
told in capitals that its output state is unknown and what to do by hand.
"""

from __future__ import annotations

import logging
import math
import sys
from dataclasses import dataclass

from squeezebench.errors import UserError
from squeezebench.instruments.bench import GENERATOR_SOURCE_OHM
from squeezebench.stops import protect, raise_if_stopped, record_generator

log = logging.getLogger(__name__)

#: The paper, Section 2.2: "in our application, we do not apply voltage above 100 V".
PAPER_MAX_PIEZO_VOLTAGE_VPP = 100.0
#: gain * (v / gain) may exceed v by an ulp: a limit is met "exactly" within this factor.
_ROUNDING = 1.0 + 1e-12


def output_state_unknown(reason: str) -> str:
    """What the operator must read when the generator may still be driving the plate."""
    return ("GENERATOR OUTPUT STATE UNKNOWN: the generator could not be set to its minimum "
            f"({reason}). THE PLATE MAY STILL BE DRIVEN. By hand: switch the amplifier off or set "
            "the 33120A's amplitude to its minimum on the front panel, before touching the plate.")


class SafetyLimitError(UserError):
    """A requested piezo voltage above a limit; nothing was sent to the generator."""

    def __init__(self, limit_name: str, limit_vpp: float, requested_vpp: float):
        self.limit_name = limit_name
        self.limit_vpp = limit_vpp
        self.requested_vpp = requested_vpp
        super().__init__(
            f"refused a piezo voltage of {requested_vpp:.4g} Vpp: above the {limit_name} "
            f"of {limit_vpp:.4g} Vpp (raise it explicitly in the run's 'safety' section "
            "only if the plate is meant to take it)")


@dataclass(frozen=True)
class SafetyLimits:
    """The limits of one protocol run (campaign `safety:` section)."""

    max_piezo_voltage_vpp: float = PAPER_MAX_PIEZO_VOLTAGE_VPP
    ramp_step_vpp: float = 10.0   # largest piezo-voltage change sent in one command
    ramp_dwell_s: float = 0.01    # bench time between two ramp commands
    #: A measured CH1 peak-to-peak may exceed the limit by this fraction before the run stops:
    #: the scope's vertical gain accuracy, the probe's and the peak-to-peak of the noise.
    measured_tolerance: float = 0.1
    #: The measured CH1 peak-to-peak may differ from the voltage the chain was told to produce
    #: by this fraction before the run stops: the probe's attenuation and the scope's vertical
    #: gain (a few % together), the amplifier's gain tolerance and its droop into a capacitive
    #: load. A misdescribed gain or load setting is a factor of 2, far outside it.
    commanded_tolerance: float = 0.2

    def __post_init__(self) -> None:
        for name in ("max_piezo_voltage_vpp", "ramp_step_vpp"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)!r}")
        if self.ramp_dwell_s < 0:
            raise ValueError(f"ramp_dwell_s must not be negative, got {self.ramp_dwell_s!r}")
        for name in ("measured_tolerance", "commanded_tolerance"):
            if not 0 <= getattr(self, name) <= 0.5:
                raise ValueError(f"{name} must be within 0..0.5, got {getattr(self, name)!r}")


class MeasuredVoltageError(UserError):
    """The piezo voltage measured on CH1 is above the limit, or not what the chain was told
    to produce; the drive was dropped. `evidence` holds what that acquisition showed (the
    campaign keeps it in the run directory: it is why the run stopped, not a measurement)."""

    def __init__(self, message: str, evidence: dict | None = None):
        super().__init__(message)
        self.evidence = dict(evidence or {})


def chain_warnings(electronics) -> list[str]:
    """What in a bench description puts more on the piezos than the generator displays."""
    if electronics.generator_load == "50" and electronics.amplifier_input_ohm > 10 * GENERATOR_SOURCE_OHM:
        return [f"generator_load 50 into an amplifier input of {electronics.amplifier_input_ohm:g} ohm: "
                f"the 33120A puts about twice its displayed Vpp on the amplifier (x"
                f"{electronics.piezo_vpp_per_generator_vpp / electronics.amplifier_gain:.3g}); the limits "
                "count it, but set generator_load: INF unless the amplifier input really is 50 ohm"]
    return []


def _likely_cause(ratio: float) -> str:
    """What a measured-to-commanded ratio points to, for the operator's first look."""
    if 1.8 <= ratio <= 2.2 or 0.45 <= ratio <= 0.55:
        return ("a factor of 2: the amplifier gain in the bench file, or the generator load setting "
                "(50 ohm against a high-impedance amplifier input doubles the output)")
    if 8 <= ratio <= 12 or 0.08 <= ratio <= 0.12:
        return "a factor of 10: the voltage probe's attenuation (10:1 against 100:1)"
    return "check the amplifier gain, the generator load setting and the voltage probe's attenuation"


class DriveController:
    """Sets the piezo drive (frequency, piezo voltage pp) within the run's limits.

    `generator` is an `instruments.Agilent33120A`, `electronics` the bench's
    `BenchElectronics`, `clock` the bench clock (its `sleep` lets a ramp step and a
    settling wait pass on the bench's time, virtual on a dry run).
    """

    def __init__(self, generator, electronics, clock, limits: SafetyLimits,
                 settle_s: float = 0.0, on_amplitude=None):
        self._generator = generator
        # Told (generator Vpp, piezo Vpp) before an amplitude above the minimum is sent, and
        # (None, None) once the minimum is: protocols.drive_record survives a killed process.
        self._on_amplitude = on_amplitude
        self._clock = clock
        self.limits = limits
        self.amplifier_gain = float(electronics.amplifier_gain)   # nominal, as recorded in rows
        self.chain_gain = float(electronics.piezo_vpp_per_generator_vpp)
        self.amplifier_max_output_vpp = float(electronics.amplifier_max_output_vpp)
        self.settle_s = settle_s
        self.minimum_generator_amplitude_vpp = float(generator.min_amplitude_vpp)
        # The generator cannot go below its minimum: that much always reaches the piezos.
        self.check(self.chain_gain * self.minimum_generator_amplitude_vpp)
        # The generator may hold anything from a previous session (a square wave, an
        # offset): every drive starts from a plain sine at its minimum.
        generator.sine_at_minimum()
        self.generator_amplitude_vpp = self.minimum_generator_amplitude_vpp
        self._setpoint_vpp: float | None = None
        self.frequency_hz = math.nan

    # -- limits ---------------------------------------------------------------------------
    @property
    def max_piezo_voltage_vpp(self) -> float:
        """The highest piezo voltage this controller will set (the tighter limit)."""
        return min(self.limits.max_piezo_voltage_vpp, self.amplifier_max_output_vpp)

    def check(self, piezo_voltage_vpp: float) -> None:
        """Raise SafetyLimitError if `piezo_voltage_vpp` is above a limit."""
        if not math.isfinite(piezo_voltage_vpp) or piezo_voltage_vpp < 0:
            raise UserError(f"refused a piezo voltage of {piezo_voltage_vpp!r} Vpp: a voltage "
                            "must be a finite number of at least 0 Vpp")
        if piezo_voltage_vpp > self.amplifier_max_output_vpp * _ROUNDING:
            raise SafetyLimitError("amplifier's maximum output", self.amplifier_max_output_vpp,
                                   piezo_voltage_vpp)
        if piezo_voltage_vpp > self.limits.max_piezo_voltage_vpp * _ROUNDING:
            raise SafetyLimitError("run's piezo voltage limit", self.limits.max_piezo_voltage_vpp,
                                   piezo_voltage_vpp)

    # -- drive ----------------------------------------------------------------------------
    @property
    def piezo_voltage_vpp(self) -> float:
        """The piezo voltage set: the one asked for once a ramp has reached it (the 1 µVpp
        quantisation of the generator's amplitude is not a different setpoint)."""
        return self._setpoint_vpp if self._setpoint_vpp is not None else \
            self.chain_gain * self.generator_amplitude_vpp

    def set_piezo_voltage(self, piezo_voltage_vpp: float) -> None:
        """Ramp to `piezo_voltage_vpp` (checked first), then wait the settling time."""
        if piezo_voltage_vpp > 0:   # going down to the minimum is never refused
            raise_if_stopped()
        self.check(piezo_voltage_vpp)
        target_vpp = max(piezo_voltage_vpp / self.chain_gain,
                         self.minimum_generator_amplitude_vpp)
        start_vpp = self.generator_amplitude_vpp
        # less one quantum: each sent amplitude is rounded to 1 µVpp (see _send_amplitude)
        step_vpp = self.limits.ramp_step_vpp / self.chain_gain - 1e-6
        n_steps = max(1, math.ceil(abs(target_vpp - start_vpp) / step_vpp))
        for i in range(1, n_steps + 1):
            amplitude_vpp = target_vpp if i == n_steps else start_vpp + (target_vpp - start_vpp) * i / n_steps
            self._send_amplitude(amplitude_vpp)
            if i < n_steps:
                self._clock.sleep(self.limits.ramp_dwell_s)
        if target_vpp > self.minimum_generator_amplitude_vpp:
            self._setpoint_vpp = float(piezo_voltage_vpp)
        self._clock.sleep(self.settle_s)

    def check_measured(self, measured_piezo_vpp: float, clipped: bool = False) -> None:
        """Drop the drive and raise MeasuredVoltageError if CH1 measured more than the limit
        (plus the measurement tolerance), or other than the voltage the chain was told to
        produce (beyond `commanded_tolerance`): the bench is not what its description says.
        A `clipped` CH1 gives only a lower bound, so only "too high" can be told from it."""
        allowed_vpp = self.max_piezo_voltage_vpp * (1.0 + self.limits.measured_tolerance)
        setpoint_vpp = self.piezo_voltage_vpp
        ratio = measured_piezo_vpp / setpoint_vpp
        band = 1.0 + self.limits.commanded_tolerance
        if measured_piezo_vpp <= allowed_vpp and ratio <= band and (clipped or ratio >= 1.0 / band):
            return
        evidence = {"measured_piezo_vpp": measured_piezo_vpp, "ch1_clipped": clipped,
                    "commanded_piezo_vpp": setpoint_vpp, "measured_to_commanded": ratio,
                    "max_piezo_voltage_vpp": self.max_piezo_voltage_vpp,
                    "commanded_tolerance": self.limits.commanded_tolerance,
                    "generator_frequency_hz": self.frequency_hz, "bench_clock_s": self._clock.now_s()}
        self.to_minimum(ramp=False)
        if measured_piezo_vpp <= allowed_vpp:
            raise MeasuredVoltageError(
                f"measured {'at least ' if clipped else ''}{measured_piezo_vpp:.4g} Vpp on CH1 where the chain "
                f"was told to produce {setpoint_vpp:.4g} Vpp ({ratio:.3g} times, beyond the "
                f"{self.limits.commanded_tolerance:.0%} tolerance); the generator was set to its minimum. "
                "The bench is not what its description says: " + _likely_cause(ratio), evidence)
        raise MeasuredVoltageError(
            f"measured a piezo voltage of {measured_piezo_vpp:.4g} Vpp on CH1 at a setpoint of "
            f"{setpoint_vpp:.4g} Vpp: above the limit of {self.max_piezo_voltage_vpp:.4g} Vpp "
            f"(+{self.limits.measured_tolerance:.0%} measurement tolerance); the generator was set to its "
            "minimum. The bench is not what its description says: check the amplifier gain, its input "
            "impedance and the generator load setting in the bench file", evidence)

    def set_frequency(self, frequency_hz: float) -> None:
        """Set the drive frequency, then wait the settling time (the plate rings up)."""
        raise_if_stopped()
        self._generator.set_frequency(frequency_hz)
        self.frequency_hz = float(frequency_hz)
        self._clock.sleep(self.settle_s)

    def to_minimum(self, ramp: bool = True) -> None:
        """Bring the generator to its minimum output (ramped unless `ramp` is False)."""
        if ramp:
            self.set_piezo_voltage(0.0)
        else:
            self._send_amplitude(self.minimum_generator_amplitude_vpp)

    def _send_amplitude(self, generator_amplitude_vpp: float) -> None:
        # The one place that writes an amplitude: the last check is made on what is sent,
        # quantised to 1 µVpp so the decimal text on the bus is exactly the checked number
        # (a 9-digit rendering of a binary float can round up past the limit).
        sent_vpp = round(generator_amplitude_vpp, 6)
        if self.chain_gain * sent_vpp > self.max_piezo_voltage_vpp:
            sent_vpp -= 1e-6
        self.check(self.chain_gain * sent_vpp)
        self._setpoint_vpp = None   # until a ramp reaches its target, what is sent is what is set
        at_minimum = sent_vpp <= self.minimum_generator_amplitude_vpp
        if self._on_amplitude is not None and not at_minimum:
            self._on_amplitude(sent_vpp, self.chain_gain * sent_vpp)
        self._generator.set_amplitude_vpp(sent_vpp)
        self.generator_amplitude_vpp = sent_vpp
        if self._on_amplitude is not None and at_minimum:
            self._on_amplitude(None, None)

    # -- safe exit ------------------------------------------------------------------------
    def __enter__(self) -> DriveController:
        return self

    @protect
    def __exit__(self, exc_type, exc, tb) -> None:
        # On an error or Ctrl-C drop at once (the bench may be in any state); on a normal
        # end ramp down like any other change, and drop at once if the ramp fails. A stop
        # signal in here is recorded, never raised (see squeezebench.stops): the bring-down
        # always runs to its end.
        try:
            if exc_type is None:
                try:
                    self.to_minimum(ramp=True)
                except Exception:
                    log.exception("ramping the generator down failed; dropping it at once")
                    self.to_minimum(ramp=False)
            else:
                self.to_minimum(ramp=False)
        except Exception as failure:
            message = output_state_unknown(f"{type(failure).__name__}: {failure}")
            record_generator(message)
            log.critical(message)
            print(message, file=sys.stderr, flush=True)
            if exc_type is None:
                raise
            return
        record_generator(f"the generator's last commanded amplitude is {self.generator_amplitude_vpp:g} Vpp, "
                         "its minimum")
        if exc_type is None:
            raise_if_stopped()   # a stop that came during the ramp down
