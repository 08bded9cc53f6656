"""Speed of the simulated bench (prints figures; not a test).

1. A plain query (`*IDN?`) through the scene backend against a bare pyvisa-sim query on
   the same instrument definitions (goal: at most 2x slower).
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

from squeezebench.simbench.backend import DEFINITIONS  # noqa: E402
from squeezebench.simbench.effects import EFFECTS  # noqa: E402
from squeezebench import paths  # noqa: E402

TERMINATIONS = {"read_termination": "\n", "write_termination": "\n"}
SCOPE = "TCPIP0::192.168.0.20::INSTR"
F_HZ = 37180.0
_TOKENS = itertools.count()


def best_of(repeat: int, function, *args) -> float:
    """Best wall time of `repeat` calls: the least disturbed by the machine."""
    return min(timeit.repeat(lambda: function(*args), number=1, repeat=repeat))


def idn_queries(resource, count: int = 200) -> None:
    for _ in range(count):
        resource.query("*IDN?")


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
    vibrometer.write("Set,VeloDec,0,Range,125mm/s/V")
    for channel, scale, probe in ((1, 37.6 / 6, 0.01), (2, 0.045 / 6, 1.0), (3, 3.0 / 6, 1.0)):
        scope.write(f"CH{channel}:PRO {probe!r}")
        scope.write(f"CH{channel}:SCA {scale!r}")
    for command in (f"HOR:MAI:SCA {20 / F_HZ / 10!r}", "HOR:RECO 10000", "ACQ:MOD AVE", "ACQ:NUMAV 16",
                    "ACQ:STOPA SEQ", 'MATH:DEFI "CH1*CH2"', "MEASU:IMM:SOU MATH", "MEASU:IMM:TYP MEAN",
                    "DAT:ENC RIB", "DAT:WID 2", "DAT:STAR 1", "DAT:STOP 10000"):
        scope.write(command)
    scope.timeout = 60_000
    return rm, scope


def acquire_and_fetch(scope) -> None:
    scope.write("ACQ:STATE RUN")
    scope.query("*OPC?")
    float(scope.query("MEASU:IMM:VAL?"))
    for channel in ("CH1", "CH2", "CH3"):
        scope.write(f"DAT:SOU {channel}")
        scope.query("WFMP?")
        scope.query_binary_values("CURV?", datatype="h", is_big_endian=True, container=np.array)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    repeat = parser.parse_args().repeat

    bare = pyvisa.ResourceManager(f"{DEFINITIONS}@sim").open_resource(SCOPE, **TERMINATIONS)
    with tempfile.TemporaryDirectory() as tmp:
        ideal_scene = scene_with(Path(tmp), [])
        # every effect of a healthy bench: faults would stop the acquisitions being timed
        every_scene = scene_with(Path(tmp), [name for name, effect in EFFECTS.items() if not effect.fault])
        _, scene_scope = prepared_scope(ideal_scene)
        bare_s = best_of(repeat, idn_queries, bare) / 200
        scene_s = best_of(repeat, idn_queries, scene_scope) / 200
        print(f"*IDN? query: pyvisa-sim {bare_s * 1e6:8.1f} us   scene backend {scene_s * 1e6:8.1f} us   "
              f"ratio {scene_s / bare_s:5.2f} (goal <= 2)")

        _, ideal_scope = prepared_scope(ideal_scene)
        _, every_scope = prepared_scope(every_scene)
        ideal_s = best_of(repeat, acquire_and_fetch, ideal_scope)
        every_s = best_of(repeat, acquire_and_fetch, every_scope)
        print(f"acquire + fetch 3 x 10k points, 16 averages: ideal {ideal_s * 1e3:7.2f} ms   "
              f"all effects {every_s * 1e3:7.2f} ms   ratio {every_s / ideal_s:5.1f} (goal >= 10)")


if __name__ == "__main__":
    main()
