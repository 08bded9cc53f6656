"""Speed of the simulated bench (prints figures; not a test).

1. A plain query (`*IDN?`) and a setting command parsed by the scope's manual grammar,
   through the scene backend, against a bare pyvisa-sim query of a one-dialogue
   definition (goal: at most 2x slower).
2. One acquisition and fetch (3 channels, 10k points, MATH mean) on an ideal scene
   against the same with every effect on (goal: the ideal scene at least 10x cheaper).

Run: python benchmarks/bench_simulator.py [--repeat N]
"""

from __future__ import annotations

import argparse
import itertools
import sys
import tempfile
import timeit
from pathlib import Path

import numpy as np
import pyvisa
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import reference  # noqa: E402  (benchmarks/, the script's own folder)
from squeezebench.simbench.effects import EFFECTS  # noqa: E402
from squeezebench import paths  # noqa: E402

TERMINATIONS = {"read_termination": "\n", "write_termination": "\n"}
SCOPE = "TCPIP0::192.168.0.20::INSTR"
F_HZ = 37180.0
_TOKENS = itertools.count()


def best_of(repeat: int, function, *args) -> float:
    """Best wall time of `repeat` calls: the least disturbed by the machine."""
    return min(timeit.repeat(lambda: function(*args), number=1, repeat=repeat))


#: The bare pyvisa-sim reference: one device answering *IDN? from a static dialogue.
BARE_DEFINITION = {"spec": "1.1", "devices": {"scope": {
    "eom": {"TCPIP INSTR": {"q": "\n", "r": "\n"}},
    "dialogues": [{"q": "*IDN?", "r": "TEKTRONIX,TDS 3054B,0,CF:91.1CT FV:v3.41"}]}},
    "resources": {SCOPE: {"device": "scope"}}}


def open_bare_scope(directory: Path):
    """The bare pyvisa-sim reference resource, its definition written into `directory`."""
    definition = directory / "bare.yaml"
    definition.write_text(yaml.safe_dump(BARE_DEFINITION))
    return pyvisa.ResourceManager(f"{definition}@sim").open_resource(SCOPE, **TERMINATIONS)


def idn_queries(resource, count: int = 200) -> None:
    for _ in range(count):
        resource.query("*IDN?")


def setting_commands(resource, count: int = 200) -> None:
    for _ in range(count):
        resource.write("ACQUIRE:NUMAVG 16")


def scene_with(directory: Path, effects: list) -> Path:
    scene = yaml.safe_load(paths.default_scene().read_text())
    scene["effects"] = effects
    path = directory / f"bench_{len(effects)}.yaml"
    path.write_text(yaml.safe_dump(scene, sort_keys=False))
    return path


def prepared_scope(scene: Path):
    rm = pyvisa.ResourceManager(f"{scene}#bench{next(_TOKENS)}@simbench")
    generator = rm.open_resource("GPIB0::10::INSTR", **TERMINATIONS)
    scope = rm.open_resource(SCOPE, **TERMINATIONS)
    vibrometer = rm.open_resource("ASRL1::INSTR", **TERMINATIONS)
    for command in ("OUTP:LOAD INF", f"FREQ {F_HZ!r}", "VOLT 1.88"):
        generator.write(command)
    vibrometer.write("Set,Interface,0,Echo,Off")
    vibrometer.read()   # the echo of that line
    vibrometer.write("Set,VeloDec,0,Range,100mm/s/V")
    for channel, scale, probe in ((1, 37.6 / 6, 0.01), (2, 0.045 / 6, None), (3, 3.0 / 6, 1.0)):
        scope.write(f"SELECT:CH{channel} ON")
        if probe is not None:   # CH2's current probe is detected: the scope fixes its gain
            scope.write(f"CH{channel}:PROBE {probe!r}")
        scope.write(f"CH{channel}:SCALE {scale!r}")
    for command in ("HEADER OFF", "HORIZONTAL:MAIN:SCALE 4e-5", "HORIZONTAL:RECORDLENGTH 10000",
                    "ACQUIRE:MODE AVERAGE", "ACQUIRE:NUMAVG 16", "ACQUIRE:STOPAFTER SEQUENCE",
                    "TRIGGER:A:EDGE:SOURCE CH1", "TRIGGER:A:LEVEL 0", "SELECT:MATH ON", "MATH:TYPE DUAL",
                    'MATH:DEFINE "CH1*CH2"', "MEASUREMENT:IMMED:SOURCE MATH", "MEASUREMENT:IMMED:TYPE MEAN",
                    "DATA:ENCDG RIBINARY", "DATA:WIDTH 2", "DATA:START 1", "DATA:STOP 10000"):
        scope.write(command)
    scope.timeout = 60_000
    return rm, scope


def acquire_and_fetch(scope) -> None:
    scope.write("ACQUIRE:STATE RUN")
    scope.query("*OPC?")
    float(scope.query("MEASUREMENT:IMMED:VALUE?"))
    for channel in ("CH1", "CH2", "CH3"):
        scope.write(f"DATA:SOURCE {channel}")
        scope.query("WFMPRE?")
        scope.query_binary_values("CURVE?", datatype="h", is_big_endian=True, container=np.array)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    repeat = parser.parse_args().repeat
    unit = reference.measure()
    print(unit.line())

    with tempfile.TemporaryDirectory() as tmp:
        bare = open_bare_scope(Path(tmp))
        ideal_scene = scene_with(Path(tmp), [])
        # every effect of a healthy bench: faults would stop the acquisitions being timed
        every_scene = scene_with(Path(tmp), [name for name, effect in EFFECTS.items() if not effect.fault])
        _, scene_scope = prepared_scope(ideal_scene)
        bare_s = best_of(repeat, idn_queries, bare) / 200
        scene_s = best_of(repeat, idn_queries, scene_scope) / 200
        command_s = best_of(repeat, setting_commands, scene_scope) / 200
        print(f"*IDN? query: pyvisa-sim {bare_s * 1e6:8.1f} us   scene backend {scene_s * 1e6:8.1f} us = "
              f"{unit.units(scene_s) * 1e6:.1f} uref   "
              f"ratio {scene_s / bare_s:5.2f} (goal <= 2)")
        print(f"ACQUIRE:NUMAVG 16 (parsed, dispatched on its header): {command_s * 1e6:8.1f} us   "
              f"ratio to the bare query {command_s / bare_s:5.2f} (goal <= 2)")

        _, ideal_scope = prepared_scope(ideal_scene)
        _, every_scope = prepared_scope(every_scene)
        ideal_s = best_of(repeat, acquire_and_fetch, ideal_scope)
        every_s = best_of(repeat, acquire_and_fetch, every_scope)
        print(f"acquire + fetch 3 x 10k points, 16 averages: ideal {ideal_s * 1e3:7.2f} ms = "
              f"{unit.units(ideal_s) * 1e3:.2f} mref   "
              f"all effects {every_s * 1e3:7.2f} ms   ratio {every_s / ideal_s:5.1f} (goal >= 10)")


if __name__ == "__main__":
    main()
