"""The DriveController never lets more than the limit reach the piezos."""

from dataclasses import dataclass

import pytest
from hypothesis import given, settings, strategies as st

from squeezebench.protocols.safety import DriveController, SafetyLimitError, SafetyLimits


class RecordingGenerator:
    min_amplitude_vpp = 0.1

    def __init__(self):
        self.amplitudes_vpp = []
        self.frequencies_hz = []
        self.reset_to_minimum = False

    def set_amplitude_vpp(self, vpp):
        self.amplitudes_vpp.append(vpp)

    def set_frequency(self, hz):
        self.frequencies_hz.append(hz)

    def sine_at_minimum(self):
        self.reset_to_minimum = True


class Clock:
    def __init__(self):
        self.t = 0.0

    def now_s(self):
        return self.t

    def sleep(self, s):
        self.t += s


@dataclass(frozen=True)
class Electronics:
    """An ideal chain: the piezo gets exactly the gain times the generator's Vpp."""

    amplifier_gain: float = 20.0
    amplifier_max_output_vpp: float = 300.0

    @property
    def piezo_vpp_per_generator_vpp(self) -> float:
        return self.amplifier_gain


def drive(limit_vpp=100.0, ramp_step_vpp=10.0, max_output_vpp=300.0):
    generator = RecordingGenerator()
    controller = DriveController(generator, Electronics(amplifier_max_output_vpp=max_output_vpp), Clock(),
                                 SafetyLimits(max_piezo_voltage_vpp=limit_vpp, ramp_step_vpp=ramp_step_vpp))
    return controller, generator


def test_refusal_names_the_limit_and_sends_nothing():
    controller, generator = drive(limit_vpp=100.0)
    assert generator.reset_to_minimum   # whatever a previous session left
    with pytest.raises(SafetyLimitError, match="run's piezo voltage limit of 100 Vpp"):
        controller.set_piezo_voltage(120.0)
    assert generator.amplitudes_vpp == []
    controller, generator = drive(limit_vpp=400.0, max_output_vpp=150.0)
    with pytest.raises(SafetyLimitError, match="amplifier's maximum output of 150 Vpp"):
        controller.set_piezo_voltage(240.0)
    assert generator.amplitudes_vpp == []


def test_raised_limit_allows_the_stress_point():
    controller, generator = drive(limit_vpp=240.0)
    controller.set_piezo_voltage(240.0)
    assert generator.amplitudes_vpp[-1] == pytest.approx(12.0)
    assert max(generator.amplitudes_vpp) <= 12.0


def test_ramps_in_steps_and_ends_at_minimum_on_error():
    controller, generator = drive(ramp_step_vpp=10.0)
    with pytest.raises(KeyboardInterrupt):
        with controller:
            controller.set_piezo_voltage(80.0)
            raise KeyboardInterrupt
    ramp = [20.0 * a for a in generator.amplitudes_vpp[:-1]]
    assert len(ramp) == 8 and all(b - a <= 10.0 + 1e-9 for a, b in zip([2.0] + ramp, ramp))
    assert generator.amplitudes_vpp[-1] == RecordingGenerator.min_amplitude_vpp


@settings(max_examples=200, deadline=None)
@given(limit_vpp=st.floats(5.0, 300.0), ramp_step_vpp=st.floats(0.5, 50.0),
       requests_vpp=st.lists(st.floats(0.0, 400.0), min_size=1, max_size=8))
def test_no_amplitude_sent_exceeds_the_limit(limit_vpp, ramp_step_vpp, requests_vpp):
    controller, generator = drive(limit_vpp, ramp_step_vpp, max_output_vpp=250.0)
    with controller:
        for request_vpp in requests_vpp:
            try:
                controller.set_piezo_voltage(request_vpp)
            except SafetyLimitError:
                assert request_vpp > min(limit_vpp, 250.0)
    previous_vpp = 20.0 * RecordingGenerator.min_amplitude_vpp
    for amplitude_vpp in generator.amplitudes_vpp:
        piezo_vpp = 20.0 * amplitude_vpp
        assert piezo_vpp <= min(limit_vpp, 250.0) + 1e-9
        assert abs(piezo_vpp - previous_vpp) <= ramp_step_vpp + 1e-9
        previous_vpp = piezo_vpp
