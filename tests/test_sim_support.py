"""Helpers of the simulated-bench tests (no tests here): scenes in tmp_path and a raw
PyVISA view of the bench that sends commands as the manuals spell them
(docs/instrument-commands.md), independent of the drivers."""

from __future__ import annotations

import cmath
import itertools
import math
from pathlib import Path

import numpy as np
import pyvisa

from squeezebench import paths
from squeezebench.yamlfiles import dump_yaml, load_strict

_TOKENS = itertools.count()
TERMINATIONS = {"read_termination": "\n", "write_termination": "\n"}


def scene_file(tmp_path: Path, name: str = "one_column_1mm.yaml", **changes) -> Path:
    """A copy of a shipped scene with top-level sections replaced (e.g. effects=[])."""
    scene = load_strict((paths.scenes_dir() / name).read_text())
    scene.update(changes)
    path = tmp_path / f"{len(list(tmp_path.iterdir()))}_{name}"
    path.write_text(dump_yaml(scene))
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
        self.scope.write("HEADER OFF")
        # The controller echoes lines at power-on: turn it off and read that line's echo.
        self.vibrometer.write("Set,Interface,0,Echo,Off")
        assert self.vibrometer.read() == "Set,Interface,0,Echo,Off"
        names = self.vibrometer.query("GetDevInfo,VeloDec,0,Range").split(",")
        self.ranges_mps_per_v = {name: float(name.split("mm")[0]) * 1e-3 for name in names}
        self.range_mps_per_v = self.ranges_mps_per_v[self.vibrometer.query("Get,VeloDec,0,Range")]

    def close(self) -> None:
        self.rm.close()

    def drive(self, frequency_hz: float, generator_vpp: float, load: str = "INF") -> None:
        self.generator.write("FUNC:SHAP SIN")
        self.generator.write(f"OUTP:LOAD {load}")
        self.generator.write(f"FREQ {frequency_hz!r}")
        self.generator.write(f"VOLT {generator_vpp!r}")

    def set_range(self, name: str) -> None:
        self.vibrometer.write(f"Set,VeloDec,0,Range,{name}")
        self.range_mps_per_v = self.ranges_mps_per_v[name]

    def configure(self, frequency_hz: float, *, averages: int | None = 16, record_length: int = 500,
                  periods: int = 20, fill_div: float = 6.0, range_name: str | None = None) -> None:
        """Probes, record, averaging; vertical scales fitted to the closed-form truth."""
        truth = self.sim.truth()
        if range_name is None:  # the most sensitive range keeping the output within 8 Vpp
            range_name = next(n for n, r in self.ranges_mps_per_v.items() if truth.velocity_pp_mps / r <= 8.0)
        self.set_range(range_name)
        electronics = self.sim.scene.electronics
        expected_pp = (truth.output_voltage_pp_v, truth.current_pp_a, truth.velocity_pp_mps / self.range_mps_per_v)
        probes = (1.0 / electronics.voltage_probe_attenuation, electronics.current_probe_a_per_a, 1.0)
        for channel, (pp, probe) in enumerate(zip(expected_pp, probes), start=1):
            self.scope.write(f"SELECT:CH{channel} ON")
            if channel != 2:   # CH2's TCP202 is detected: the scope fixes its gain
                self.scope.write(f"CH{channel}:PROBE {probe!r}")
            self.scope.write(f"CH{channel}:COUPLING DC")
            self.scope.write(f"CH{channel}:POSITION 0")
            self.scope.write(f"CH{channel}:SCALE {pp / fill_div!r}")
        self.scope.write(f"HORIZONTAL:MAIN:SCALE {periods / frequency_hz / 10.0!r}")
        self.scope.write(f"HORIZONTAL:RECORDLENGTH {record_length}")
        self.gate_whole_periods(frequency_hz)
        self.scope.write('SELECT:MATH ON;:MATH:TYPE DUAL;DEFINE "CH1*CH2"')
        self.scope.write("TRIGGER:A:TYPE EDGE;EDGE:SOURCE CH1;SLOPE RISE;:TRIGGER:A:LEVEL 0")
        if averages is None:
            self.scope.write("ACQUIRE:MODE SAMPLE")
        else:
            self.scope.write("ACQUIRE:MODE AVERAGE")
            self.scope.write(f"ACQUIRE:NUMAVG {averages}")
        self.scope.write("ACQUIRE:STOPAFTER SEQUENCE")

    def gate_whole_periods(self, frequency_hz: float) -> None:
        """Measurements over the largest whole number of periods the record holds: the
        scope rounds its time base to 1-2-4, so the record itself rarely does."""
        record_s = 10.0 * float(self.scope.query("HORIZONTAL:MAIN:SCALE?"))
        dt_s = record_s / int(self.scope.query("HORIZONTAL:RECORDLENGTH?"))
        self.scope.write("HORIZONTAL:DELAY:STATE ON;TIME 0")   # the record is centred on the trigger
        start_s = -record_s / 2.0
        stop_s = start_s + math.floor(record_s * frequency_hz + 1e-9) / frequency_hz - dt_s / 2.0
        self.scope.write(f"CURSOR:FUNCTION VBARS;VBARS:POSITION1 {start_s!r};POSITION2 {stop_s!r}")
        self.scope.write("MEASUREMENT:GATING CURSOR")

    def acquire(self) -> None:
        self.scope.write("ACQUIRE:STATE RUN")
        assert self.scope.query("*OPC?") == "1"

    def measure(self, source: str, kind: str) -> float:
        self.scope.write(f"MEASUREMENT:IMMED:SOURCE {source}")
        self.scope.write(f"MEASUREMENT:IMMED:TYPE {kind}")
        return float(self.scope.query("MEASUREMENT:IMMED:VALUE?"))

    def fetch(self, source: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        """(time_s, values, raw counts, preamble) of `source` over the whole record."""
        n = int(self.scope.query("HORIZONTAL:RECORDLENGTH?"))
        for command in (f"DATA:SOURCE {source}", "DATA:ENCDG RIBINARY", "DATA:WIDTH 2", "DATA:START 1",
                        f"DATA:STOP {n}"):
            self.scope.write(command)
        fields = self.scope.query("WFMPRE?").split(";")
        preamble = {"n": int(fields[5]), "x_incr": float(fields[8]), "x_zero": float(fields[10]),
                    "y_mult": float(fields[12]), "y_zero": float(fields[13]), "y_off": float(fields[14])}
        raw = np.asarray(self.scope.query_binary_values("CURVE?", datatype="h", is_big_endian=True,
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
