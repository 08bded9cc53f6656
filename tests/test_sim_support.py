"""Helpers of the simulated-bench tests (no tests here): scenes in tmp_path and a raw
PyVISA view of the bench that uses exactly the command strings of docs/design.md."""

from __future__ import annotations

import cmath
import itertools
import math
from pathlib import Path

import numpy as np
import pyvisa
import yaml

from squeezebench import paths

_TOKENS = itertools.count()
TERMINATIONS = {"read_termination": "\n", "write_termination": "\n"}
RANGES_MPS_PER_V = {"5mm/s/V": 0.005, "25mm/s/V": 0.025, "125mm/s/V": 0.125, "1000mm/s/V": 1.0}


def scene_file(tmp_path: Path, name: str = "one_column_1mm.yaml", **changes) -> Path:
    """A copy of a shipped scene with top-level sections replaced (e.g. effects=[])."""
    scene = yaml.safe_load((paths.scenes_dir() / name).read_text())
    scene.update(changes)
    path = tmp_path / f"{len(list(tmp_path.iterdir()))}_{name}"
    path.write_text(yaml.safe_dump(scene, sort_keys=False))
    return path


class RawBench:
    """The three simulated instruments through plain PyVISA writes and queries."""

    def __init__(self, scene_path: Path) -> None:
        self.rm = pyvisa.ResourceManager(f"{scene_path}#{next(_TOKENS)}@simbench")
        self.sim = self.rm.visalib.bench
        self.generator = self.rm.open_resource("GPIB0::10::INSTR", **TERMINATIONS)
        self.scope = self.rm.open_resource("TCPIP0::192.168.0.20::INSTR", **TERMINATIONS)
        self.vibrometer = self.rm.open_resource("ASRL1::INSTR", **TERMINATIONS)
        self.scope.timeout = 60_000
        self.range_mps_per_v = 1.0
        self.scope.write("HEAD OFF")

    def close(self) -> None:
        self.rm.close()

    def drive(self, frequency_hz: float, generator_vpp: float, load: str = "INF") -> None:
        self.generator.write("FUNC:SHAP SIN")
        self.generator.write(f"OUTP:LOAD {load}")
        self.generator.write(f"FREQ {frequency_hz!r}")
        self.generator.write(f"VOLT {generator_vpp!r}")

    def set_range(self, name: str) -> None:
        self.vibrometer.write(f"Set,VeloDec,0,Range,{name}")
        self.range_mps_per_v = RANGES_MPS_PER_V[name]

    def configure(self, frequency_hz: float, *, averages: int | None = 16, record_length: int = 500,
                  periods: int = 20, fill_div: float = 6.0, range_name: str | None = None) -> None:
        """Probes, record, averaging; vertical scales fitted to the closed-form truth."""
        truth = self.sim.truth()
        if range_name is None:  # the most sensitive range keeping the output within 8 Vpp
            range_name = next(n for n, r in RANGES_MPS_PER_V.items() if truth.velocity_pp_mps / r <= 8.0)
        self.set_range(range_name)
        electronics = self.sim.scene.electronics
        expected_pp = (truth.output_voltage_pp_v, truth.current_pp_a, truth.velocity_pp_mps / self.range_mps_per_v)
        probes = (1.0 / electronics.voltage_probe_attenuation, electronics.current_probe_a_per_a, 1.0)
        for channel, (pp, probe) in enumerate(zip(expected_pp, probes), start=1):
            self.scope.write(f"CH{channel}:PRO {probe!r}")
            self.scope.write(f"CH{channel}:COUP DC")
            self.scope.write(f"CH{channel}:POS 0")
            self.scope.write(f"CH{channel}:SCA {pp / fill_div!r}")
        self.scope.write(f"HOR:MAI:SCA {periods / frequency_hz / 10.0!r}")
        self.scope.write(f"HOR:RECO {record_length}")
        self.scope.write('MATH:DEFI "CH1*CH2"')
        if averages is None:
            self.scope.write("ACQ:MOD SAM")
        else:
            self.scope.write("ACQ:MOD AVE")
            self.scope.write(f"ACQ:NUMAV {averages}")
        self.scope.write("ACQ:STOPA SEQ")

    def acquire(self) -> None:
        self.scope.write("ACQ:STATE RUN")
        assert self.scope.query("*OPC?") == "1"

    def measure(self, source: str, kind: str) -> float:
        self.scope.write(f"MEASU:IMM:SOU {source}")
        self.scope.write(f"MEASU:IMM:TYP {kind}")
        return float(self.scope.query("MEASU:IMM:VAL?"))

    def fetch(self, source: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        """(time_s, values, raw counts, preamble) of `source` over the whole record."""
        n = int(self.scope.query("HOR:RECO?"))
        for command in (f"DAT:SOU {source}", "DAT:ENC RIB", "DAT:WID 2", "DAT:STAR 1", f"DAT:STOP {n}"):
            self.scope.write(command)
        fields = self.scope.query("WFMP?").split(";")
        preamble = {"n": int(fields[5]), "x_incr": float(fields[8]), "x_zero": float(fields[10]),
                    "y_mult": float(fields[12]), "y_zero": float(fields[13]), "y_off": float(fields[14])}
        raw = np.asarray(self.scope.query_binary_values("CURV?", datatype="h", is_big_endian=True,
                                                        container=np.array), dtype=float)
        time_s = preamble["x_zero"] + np.arange(preamble["n"]) * preamble["x_incr"]
        values = preamble["y_zero"] + preamble["y_mult"] * (raw - preamble["y_off"])
        return time_s, values, raw, preamble


def sampled_truth(truth, time_s: np.ndarray, range_mps_per_v: float) -> dict[str, np.ndarray]:
    """The closed-form steady state on the scope's time grid (trigger: CH1 rising zero)."""
    omega = 2.0 * math.pi * truth.frequency_hz
    reference = truth.output_voltage_phasors_v[0]

    def sine(phasor: complex) -> np.ndarray:
        return abs(phasor) * np.sin(omega * time_s + cmath.phase(phasor / reference))

    voltage, current = sine(reference), sine(truth.current_phasor)
    return {"CH1": voltage, "CH2": current, "CH3": sine(truth.velocity_phasor) / range_mps_per_v,
            "MATH": voltage * current}
