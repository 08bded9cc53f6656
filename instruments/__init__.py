"""Drivers for the bench instruments, their typed errors and the bench description.

    from squeezebench.instruments import open_bench, sim_bench_config
    with open_bench(sim_bench_config("data/scenes/one_column_1mm.yaml")) as bench:
        bench.generator.apply_sine(40e3, 1.0)
"""

from squeezebench.instruments.agilent33120a import Agilent33120A
from squeezebench.instruments.bench import (Bench, BenchCheck, BenchConfig, BenchElectronics, check_bench, inspect_bench,
                                            open_bench, sim_bench_config)
from squeezebench.instruments.errors import (BenchFileError, ClippedTraceError, GarbledReply, InstrumentConnectionError,
                                InstrumentError, InstrumentTimeout, NoValidMeasurement, OutOfRangeError)
from squeezebench.instruments.ofv5000 import OFV5000
from squeezebench.instruments.tds3054b import TDS3054B, Waveform


def load_bench_file(path) -> BenchConfig:
    """A real bench from its YAML file, through the one validator `run` and `check` use
    (`squeezebench.schemas.load_bench_file`: the file formats sit above the drivers, so
    it is imported when called)."""
    from squeezebench.schemas import load_bench_file as load
    return load(path)


__all__ = ["Agilent33120A", "TDS3054B", "OFV5000", "Waveform", "Bench", "BenchConfig", "BenchElectronics",
           "check_bench", "inspect_bench", "BenchCheck", "load_bench_file", "open_bench", "sim_bench_config", "BenchFileError",
           "ClippedTraceError", "GarbledReply", "InstrumentConnectionError", "InstrumentError",
           "InstrumentTimeout", "NoValidMeasurement", "OutOfRangeError"]
