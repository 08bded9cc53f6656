"""The simulated instruments by role, and the states a bench may start them in.

The generator (`simbench.generator`), the scope (`simbench.scope`) and the vibrometer
controller (`simbench.vibrometer`) model what their manuals say, with physics behind;
the x-y stage is `simbench.stage`.
"""

from __future__ import annotations

import re
import zlib
from typing import Callable

import numpy as np

from squeezebench.simbench.generator import (_GEN_SHAPES, _GEN_UNITS, GEN_AMPLITUDE_VPP, GEN_MODULATIONS,
                                             GEN_PEAK_V, Generator)
from squeezebench.simbench.scope import Scope
from squeezebench.simbench.scope_settings import (_ACQ_MODES, _AVERAGES, _BANDWIDTHS, _COUPLINGS, _CURSORS,
                                                  _ENCODINGS, _GATINGS, _IMPEDANCES, _MATH_TYPES, _RECORD_LENGTHS,
                                                  _SIMULATED_MEASUREMENTS, _SLOPES, _SOURCES, _STOP_AFTER,
                                                  _TRIGGER_COUPLINGS, _TRIGGER_MODES, _TRIGGER_SOURCES,
                                                  _TRIGGER_TYPES, CHANNELS, SCOPE_TIME_BASES_S)
from squeezebench.simbench.scpi import ScpiError
from squeezebench.simbench.vibrometer import (DECODERS, HIGH_PASS_FILTERS, LOW_PASS_FILTERS, TRACKING_FILTERS,
                                              Vibrometer)

INSTRUMENTS = {cls.role: cls for cls in (Generator, Scope, Vibrometer)}


# == start states ======================================================================================
def hostile_start(bench) -> None:
    """Instruments as a previous user may leave them: scope math in FFT mode, trigger on
    the idle CH4, every channel off, headers on, envelope single sequence, stale events;
    generator with a square wave, Vrms units, 50 ohm and a stale error; vibrometer echo
    on with the decoder on its most sensitive range and the 5 kHz filter; the stage homed
    but left far from zero, slowed to 5 mm/s, with a refused command's letter pending."""
    scope, generator, vibrometer = bench.scope, bench.generator, bench.vibrometer
    scope.state.update({"math_type": "FFT", "math_define": "FFT(CH1,HANNING,LOGRMS)", "trigger_source": "CH4",
                        "trigger_mode": "NORMAL", "acquire_mode": "ENVELOPE", "stop_after": "SEQUENCE",
                        "data_encoding": "ASCII", "data_width": 1, "record_length": 500, "select_math": False,
                        ("probe", 3): 0.1, ("coupling", 1): "AC"})
    for channel in CHANNELS:
        scope.state["select", channel] = False
    scope.event(113, "Undefined header", "MATH:DEFI \"CH1*CH2\"")
    scope.header = True
    generator.state.update({"shape": "SQU", "unit": "VRMS", "offset": 0.5})
    generator.report(ScpiError(-113, "Undefined header"))
    vibrometer.state.update({"echo": "On", "range": DECODERS[vibrometer.decoder][0], "low_pass": "5 kHz"})
    if bench.stage is not None:
        bench.stage.leave(x_mm=150.0, y_mm=20.0, velocity_mm_per_s=5.0, error="C")


def previous_user_start(bench, seed: int) -> None:
    """Instruments as one previous user, drawn from `seed`, may have left them: every
    setting the simulated instruments have, each drawn among the values its manual allows
    (a coded probe's gain and a level II probe's coupling stay what the hardware allows),
    plus a stale event on the scope and an error on the generator. Nothing is power-cycled."""
    rng = np.random.default_rng([seed, zlib.crc32(b"previous user")])

    def pick(options):
        options = list(options)
        return options[int(rng.integers(len(options)))]

    scope, generator, vibrometer = bench.scope, bench.generator, bench.vibrometer
    s = scope.state
    for n in CHANNELS:
        if n not in scope.probes:
            s["probe", n] = pick((1.0, 0.1, 0.01, 0.001))
        finest, coarsest = scope._scale_limits(n)
        s["scale", n] = pick(v for v in (1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0) if finest <= v <= coarsest)
        limit = scope._offset_limit(n)
        s.update({("select", n): bool(rng.integers(2)), ("position", n): float(rng.uniform(-5.0, 5.0)),
                  ("offset", n): pick((0.0, float(rng.uniform(-limit, limit)))),
                  ("coupling", n): pick(("DC", "GND") if n in scope.probes else _COUPLINGS.values()),
                  ("bandwidth", n): pick(_BANDWIDTHS.values()), ("impedance", n): pick(_IMPEDANCES.values())})
    math_type = pick(_MATH_TYPES.values())
    s.update({"record_length": pick(_RECORD_LENGTHS), "horizontal_scale": pick(SCOPE_TIME_BASES_S[6:24]),
              "acquire_mode": pick(_ACQ_MODES.values()), "num_averages": pick(_AVERAGES),
              "stop_after": pick(_STOP_AFTER.values()), "trigger_type": pick(_TRIGGER_TYPES.values()),
              "trigger_mode": pick(_TRIGGER_MODES.values()), "trigger_source": pick(_TRIGGER_SOURCES.values()),
              "trigger_slope": pick(_SLOPES.values()), "trigger_coupling": pick(_TRIGGER_COUPLINGS.values()),
              "trigger_level": float(rng.uniform(-2.0, 2.0)), "math_type": math_type,
              "math_define": pick(("CH1+CH2", "CH2-CH3", "CH1*CH3")) if math_type == "DUAL"
              else "FFT(CH1,HANNING,LOGRMS)",
              "measurement_source": pick(_SOURCES.values()), "measurement_type": pick(_SIMULATED_MEASUREMENTS),
              "data_source": pick(_SOURCES.values()), "data_encoding": pick(_ENCODINGS.values()),
              "data_width": pick((1, 2)), "data_start": int(rng.integers(1, 500)), "data_stop": int(rng.integers(1, 10001)),
              "select_math": bool(rng.integers(2)), "delay_state": bool(rng.integers(2)),
              "delay_time": float(rng.uniform(-1e-3, 1e-3)), "trigger_position": int(rng.integers(0, 101)),
              "gating": pick(_GATINGS.values()), "cursor_function": pick(_CURSORS.values()),
              ("vbar", 1): float(rng.uniform(-2e-3, 2e-3)), ("vbar", 2): float(rng.uniform(-2e-3, 2e-3))})
    scope.header, scope.verbose = bool(rng.integers(2)), bool(rng.integers(2))
    scope.event(113, "Undefined header", "MATH:DEFI \"CH1*CH2\"")
    load = pick(GEN_PEAK_V)
    low, high = GEN_AMPLITUDE_VPP[load]
    amplitude_vpp = float(rng.uniform(low, high))
    offset_limit = GEN_PEAK_V[load] - amplitude_vpp / 2.0
    generator.state.update({"shape": pick(_GEN_SHAPES.values()), "frequency": float(10 ** rng.uniform(1.0, 6.0)),
                            "unit": pick(_GEN_UNITS.values()), "load": load, "amplitude_vpp": amplitude_vpp,
                            "offset": float(rng.uniform(-offset_limit, offset_limit)),
                            "modulation": pick((None, *GEN_MODULATIONS))})
    generator.report(ScpiError(-113, "Undefined header"))
    vibrometer.state.update({"echo": pick(("On", "Off")), "range": pick(DECODERS[vibrometer.decoder]),
                             "low_pass": pick(LOW_PASS_FILTERS), "high_pass": pick(HIGH_PASS_FILTERS),
                             "tracking": pick(TRACKING_FILTERS)})
    if bench.stage is not None:
        bench.stage.leave(x_mm=float(rng.uniform(0.0, 300.0)), y_mm=float(rng.uniform(0.0, 100.0)),
                          velocity_mm_per_s=float(rng.uniform(1.0, 20.0)), error=pick("@CDH"))


START_STATES: dict[str, Callable] = {"power_on": lambda bench: None, "hostile": hostile_start}
_PREVIOUS_USER = re.compile(r"^previous-(\d+)$")


def start_state(name: str) -> Callable:
    """The start state `name`: one of START_STATES, or `previous-<seed>` (previous_user_start)."""
    if name in START_STATES:
        return START_STATES[name]
    match = _PREVIOUS_USER.match(name)
    if match is None:
        raise ValueError(f"unknown simulated bench start state {name!r} "
                         f"(known: {', '.join(START_STATES)}, previous-<seed>)")
    return lambda bench: previous_user_start(bench, int(match.group(1)))
