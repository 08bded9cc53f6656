"""The simulated bench behind the instruments: scene, state, effects, clock, physics.

The three simulated instruments (`simbench.devices.INSTRUMENTS`) read their settings from their
pyvisa-sim state and ask this object for the physics: the generator's settings drive
the plate, the scope's acquisitions see it, the vibrometer's range scales CH3.
"""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np

from squeezebench.simbench import effects as fx
from squeezebench.simbench import physics, traces
from squeezebench.simbench.clock import VirtualClock
from squeezebench.simbench.scene import load_scene
from squeezebench.simbench.scene_model import Scene


#: The state an operator is asked for when the calibration resistor replaces the plate
#: (`protocols.calibration`): `calibration_resistor_<ohms>ohm`.
_RESISTOR_STATE = re.compile(r"^calibration_resistor_([0-9.]+)ohm$")


def calibration_resistor_ohm(state_name: str) -> float | None:
    match = _RESISTOR_STATE.match(state_name)
    return float(match.group(1)) if match else None


class SimulatedBench:
    """One bench: what `visa_lib.bench` is for tests, studies and the operator."""

    def __init__(self, scene: Scene) -> None:
        self.clock = VirtualClock()
        self.generator = self.scope = self.vibrometer = self.stage = None  # bound by the backend
        self._closed = False
        self._install(scene)

    # -- the plate ------------------------------------------------------------------------
    @property
    def scene(self) -> Scene:
        return self._scene

    @property
    def state(self):
        return self._scene.state(self.state_name)

    def set_state(self, name: str) -> None:
        """Switch the plate to another state of its scene (a cut, other powered columns)."""
        if calibration_resistor_ohm(name) is None:
            self._scene.state(name)  # a SceneError naming the allowed states
        self.state_name = name
        for effect in self.effects.by_stage["motion"]:  # the operator took minutes
            effect.settle(self.steady_state())

    def reseed(self, seed: int) -> None:
        """Another noise realisation of the same bench, its streams restarting here (the
        accuracy study's trials: each draws from its own seed, whatever ran before)."""
        self._scene = replace(self._scene, seed=int(seed))
        self.acquisitions_since_generator_write = 0

    def mount(self, scene_path: str | Path) -> None:
        """Put another plate on the bench (the instruments keep their settings)."""
        self.effects.detach(self)
        self._install(load_scene(scene_path))
        self.effects.attach(self)

    def _install(self, scene: Scene) -> None:
        self._scene = scene
        self.state_name = scene.initial_state
        self.effects = fx.build_pipeline(scene)
        self._steady_cache: tuple = (None, None)
        self._screen_cache: tuple = (None, None)
        self._record_cache: tuple = (None, None)
        self.acquisitions_since_generator_write = 0
        self.messages_received = 0   # by the three instruments: what bus faults count

    def start(self) -> None:
        """Called by the backend once the instruments are bound."""
        self.effects.attach(self)

    # -- physics ----------------------------------------------------------------------------
    def steady_state(self) -> physics.SteadyState:
        """Steady state at the present generator settings (cached until they change)."""
        key = (self.state_name, self.generator.settings_key(), self.effects.load_state())
        if self._steady_cache[0] != key:
            self._steady_cache = (key, self._solve(self.effects.generator(self.generator.settings()),
                                                   self.effects.load(self.plate_load())))
        return self._steady_cache[1]

    def _solve(self, generator: physics.GeneratorSettings, load: physics.PlateLoad) -> physics.SteadyState:
        amplifier = self.effects.amplifier(self._scene.electronics.amplifier())
        return physics.solve_steady_state(load, physics.amplifier_output(generator, amplifier),
                                          generator.frequency_hz)

    def truth(self) -> physics.SteadyState:
        """The closed-form steady state for the present settings (tests, accuracy study)."""
        return self.steady_state()

    def resonance_truth(self) -> physics.SteadyState:
        """The closed-form steady state at the present voltage, driven at the main mode's
        resonance as it is now (heating may have moved it): what "at resonance" means
        when the accuracy study scores a measurement. The drive is not changed."""
        load = self.effects.load(self.plate_load())
        generator = replace(self.generator.settings(), frequency_hz=load.branches[0].frequency_hz)
        return self._solve(generator, load)

    def plate_load(self) -> physics.PlateLoad:
        """What the amplifier drives with every effect off: the plate in its state, or the
        calibration resistor in its place."""
        resistor_ohm = calibration_resistor_ohm(self.state_name)
        return self.state.load() if resistor_ohm is None else physics.resistor_load(resistor_ohm)

    def plate_power_w(self) -> float:
        return self.steady_state().plate_power_w

    def sensor_gains(self) -> np.ndarray:
        """Physical signal -> scope input: voltage probe, current probe, decoder range."""
        e = self._scene.electronics
        return np.array([1.0 / e.voltage_probe_attenuation, e.current_probe_a_per_a,
                         self.stage.spot_gain() / self.vibrometer.range_mps_per_v()])

    def vibrometer_over_range(self) -> bool:
        """Live OverRange flag: the decoder output peak beyond its limit."""
        effect = self.effects.get("vibrometer_range")
        if effect is None:
            return False
        steady = self.steady_state()
        peak_v = 0.5 * steady.velocity_pp_mps / self.vibrometer.range_mps_per_v()
        return peak_v > effect.parameters["output_limit_v"]

    # -- events from the instruments ---------------------------------------------------------
    def generator_written(self, drive_changed: bool) -> None:
        """A command reached the generator: the random streams restart from it (so a
        resumed step, which re-sends its commands, draws what the first attempt drew);
        a changed drive also starts a transient."""
        self.acquisitions_since_generator_write = 0
        if drive_changed:
            for effect in self.effects.by_stage["motion"]:
                effect.drive_changed(self.clock.now_s(), self.steady_state())

    def acquire(self, setup: traces.ScopeSetup, acquisition_period_s: float) -> traces.Record:
        """One acquisition starting now; its random stream is set by what defines it.

        Unless a moving plate or an effect changes it from one acquisition to the next, the
        screen before the noise depends only on the settings, so the last one is reused
        while they stay the same (repeated points draw only their noise); without noise the
        record itself is (the ideal bench costs almost nothing).
        """
        steady, gains = self.steady_state(), self.sensor_gains()
        key = (self._steady_cache[0], setup, tuple(gains))
        last_key, last = self._screen_cache
        if self.effects.screen_varies or last_key != key:
            range_mps_per_v, now_s = self.vibrometer.range_mps_per_v(), self.clock.now_s()
            # a channel re-ranged at the same drive: the last screen's signals, placed anew
            shown = None if self.effects.screen_varies or last_key is None or last_key[::2] != key[::2] \
                else traces.placed_anew(last, setup, self.effects, range_mps_per_v, now_s, acquisition_period_s)
            if shown is None:
                shown = traces.screen(steady, setup, gains, range_mps_per_v, self.effects, now_s, acquisition_period_s)
                if last is not None:   # another vibrometer range leaves CH1 and CH2 as they were
                    shown.keep_sums_of(last)
            self._screen_cache = (key, shown)
        shown = self._screen_cache[1]
        if not self.effects.varies:
            if self._record_cache[0] != key:
                self._record_cache = (key, traces.record_of(shown, self.effects.digitizer_settings, None))
            return self._record_cache[1]
        rng = None
        if self.effects.is_random:
            seed = traces.acquisition_seed(self._scene.seed, self.state_name,
                                           repr(self.generator.settings()),
                                           self.acquisitions_since_generator_write,
                                           repr(self.stage.point_mm()) if self.stage.used else None)
            rng = traces.acquisition_rng(seed)
        self.acquisitions_since_generator_write += 1
        return traces.record_of(shown, self.effects.digitizer_settings, rng)

    def close(self) -> None:
        """Stop the effects' clock subscriptions (once: PyVISA may close twice)."""
        if not self._closed:
            self.effects.detach(self)
            self._closed = True

