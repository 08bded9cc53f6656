"""The bench over a real VISA stack (serve-sim + pyvisa-py) against the simulation backend
(prints figures; not a test).

1. Per-message overhead: one query answered by the same simulated instrument through the
   simulation backend (`@simbench`, in-process) and through pyvisa-py over serve-sim's
   loopback TCP socket (the scope) and pseudo-terminal (the vibrometer).
2. One 10,000-point waveform (the scope's `CURVE?`, 16-bit samples: a 20,008-byte block)
   over a serial line at the 33120A's rate (9600 baud 8N2) and at the OFV-5000's (115200
   baud 8N1) with `--line-rate real`: the wall time the transfer takes against the line's
   n x frame bits / baud.

3. With `--paper`: the paper campaign on the in-process bench and over pyvisa-py against
   serve-sim, both wall times, and whether every step file's rows are equal (bench
   provenance apart). Too slow for the test suite (about a minute on 2 cores), so here.

Run: python benchmarks/bench_realio.py [--count N] [--skip-slow-line] [--paper]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import uuid
from pathlib import Path

import pandas as pd
import pyvisa
import yaml
from pyvisa import constants

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from squeezebench import paths  # noqa: E402
from squeezebench.instruments.bench import sim_bench_config  # noqa: E402
from squeezebench.instruments.served import served_bench_file  # noqa: E402
from squeezebench.protocols.campaign import run_campaign  # noqa: E402
from squeezebench.schemas import stage_travel_mm  # noqa: E402
from squeezebench.simbench.line import MANUAL_SETTINGS, LineSettings  # noqa: E402
from squeezebench.simbench.serve import InstrumentEndpoint, ServedBench  # noqa: E402
from squeezebench.simbench.serve_pty import PtyPort  # noqa: E402
from squeezebench.simbench.serve_sim import ServedSim  # noqa: E402

SCENE = paths.input_file("one_column_1mm")
TERMINATIONS = {"read_termination": "\n", "write_termination": "\n"}
QUERIES = {"scope": "*IDN?", "vibrometer": "GetDevInfo,VeloDec,0,Name"}
SIM_ADDRESSES = {"scope": "TCPIP0::192.168.0.20::INSTR", "vibrometer": "ASRL1::INSTR"}
POINTS = 10_000
STOP_BITS = {1: constants.StopBits.one, 2: constants.StopBits.two}


def per_message_s(resource, query: str, count: int) -> float:
    resource.query(query)
    start = time.perf_counter()
    for _ in range(count):
        resource.query(query)
    return (time.perf_counter() - start) / count


def overheads(count: int) -> None:
    sim_manager = pyvisa.ResourceManager(f"{SCENE}#{uuid.uuid4().hex}@simbench")
    sim = {role: per_message_s(sim_manager.open_resource(address, **TERMINATIONS), QUERIES[role], count)
           for role, address in SIM_ADDRESSES.items()}
    sim_manager.close()
    with ServedSim(SCENE) as served:
        manager = pyvisa.ResourceManager("@py")
        scope = manager.open_resource(served.addresses["scope"], **TERMINATIONS)
        vibrometer = manager.open_resource(served.addresses["vibrometer"], **TERMINATIONS)
        vibrometer.baud_rate = MANUAL_SETTINGS["vibrometer"].baud
        real = {"scope": per_message_s(scope, QUERIES["scope"], count),
                "vibrometer": per_message_s(vibrometer, QUERIES["vibrometer"], count)}
        manager.close()
    print(f"per-message wall time, one query and its reply, mean of {count}:")
    for role, transport in (("scope", "TCP socket"), ("vibrometer", "pty")):
        print(f"  {role:10s} @simbench {sim[role] * 1e6:7.0f} us | @py over {transport:10s} "
              f"{real[role] * 1e6:7.0f} us | overhead {(real[role] - sim[role]) * 1e6:+7.0f} us")


def waveform_over_line(settings: LineSettings, name: str) -> None:
    """The scope's 10,000-point record served on a pty at `settings`, at the line's real rate."""
    served = ServedBench(SCENE)
    port = PtyPort(InstrumentEndpoint(served, "scope"), settings, served.lock, real_rate=True,
                   generation=lambda: served.generation)
    manager = pyvisa.ResourceManager("@py")
    try:
        scope = manager.open_resource(port.address, **TERMINATIONS)
        scope.baud_rate, scope.stop_bits = settings.baud, STOP_BITS[settings.stop_bits]
        scope.timeout = 120_000
        scope.write(f"HEADER OFF;:HORIZONTAL:RECORDLENGTH {POINTS};:DATA:SOURCE CH1;ENCDG RIBINARY;WIDTH 2;"
                    f"START 1;STOP {POINTS}")
        scope.query("*OPC?")
        clock = served.bench.clock
        bench_before = clock.now_s()
        start = time.perf_counter()
        samples = scope.query_binary_values("CURVE?", datatype="h", is_big_endian=True)
        wall_s = time.perf_counter() - start
        n_bytes = len(f"#5{2 * POINTS}") + 2 * POINTS + 1
        print(f"  {name:28s} {settings!s:20s} {len(samples)} points, {n_bytes} bytes: wall {wall_s:6.2f} s | "
              f"line n x {settings.frame_bits} bits / baud {settings.transfer_s(n_bytes):6.2f} s | "
              f"simulated bench clock {clock.now_s() - bench_before:6.3f} s")
    finally:
        manager.close()
        port.close()
        served.close()


def paper_over_pyvisa_py() -> None:
    """The paper campaign in-process and served, rows compared step file by step file."""
    provenance = ["bench", "bench_input", "bench_input_sha256"]
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        in_process = run_campaign(paths.campaign_file("paper"), out_dir=Path(folder) / "sim", progress=False)
        sim_s = time.perf_counter() - start
        with ServedSim(SCENE, computing_allowance_s=30) as served:
            bench = Path(folder) / "served.yaml"
            config = sim_bench_config(SCENE)
            bench.write_text(yaml.safe_dump(served_bench_file(served.addresses, config.electronics,
                                                               stage_travel_mm(config))))
            start = time.perf_counter()
            over_py = run_campaign(paths.campaign_file("paper"), out_dir=Path(folder) / "py", progress=False,
                                   bench_file=bench)
            py_s = time.perf_counter() - start
        files = sorted(in_process.glob("measurements/*/*.parquet"))
        differ = [f.relative_to(in_process) for f in files
                  if not pd.read_parquet(f).drop(columns=provenance).equals(
                      pd.read_parquet(over_py / f.relative_to(in_process)).drop(columns=provenance))]
    print(f"paper campaign: @simbench {sim_s:.1f} s, @py over serve-sim {py_s:.1f} s; {len(files)} step files, "
          f"{len(differ)} with other rows" + (f": {', '.join(map(str, differ))}" if differ else " (all equal)"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=300, help="queries per transport (default 300)")
    parser.add_argument("--skip-slow-line", action="store_true", help="leave out the 9600-baud line (~23 s)")
    parser.add_argument("--paper", action="store_true", help="also the paper campaign both ways (about a minute)")
    args = parser.parse_args()
    overheads(args.count)
    print(f"one {POINTS}-point waveform (CURVE?, 16-bit) over a serial line, --line-rate real:")
    if not args.skip_slow_line:
        waveform_over_line(MANUAL_SETTINGS["generator"], "33120A's RS-232")
    waveform_over_line(MANUAL_SETTINGS["vibrometer"], "OFV-5000's RS-232")
    if args.paper:
        paper_over_pyvisa_py()


if __name__ == "__main__":
    main()
