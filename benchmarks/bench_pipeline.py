"""Speed of the pipeline (prints figures; not a test).

1. `reproduce`: the paper campaign on the simulated bench into a temporary directory,
   the accuracy study, then the report (report.run_report.write_report), in wall seconds.
2. Waveform reduction: analysis.waveforms.integer_period_mean_power_w on 10k samples
   against a bare numpy dot product of the same two arrays (goal: at most 3x slower;
   the reduction is three dot products, so it should stay within a small factor).

Run: python benchmarks/bench_pipeline.py [--repeat N] [--skip-reproduce]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import timeit
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import reference  # noqa: E402  (benchmarks/, the script's own folder)
from squeezebench.report.run_report import write_report  # noqa: E402
from squeezebench.analysis.waveforms import integer_period_mean_power_w  # noqa: E402
from squeezebench.protocols.accuracy_study import run_study  # noqa: E402
from squeezebench.protocols.campaign import run_campaign  # noqa: E402

PAPER = ROOT / "data" / "campaigns" / "paper.yaml"
N_SAMPLES = 10_000
FREQUENCY_HZ = 37180.0
PERIODS_PER_RECORD = 20.0
REDUCTION_GOAL_RATIO = 3.0


def best_of(repeat: int, function, *args) -> float:
    """Best wall time of `repeat` calls: the least disturbed by the machine."""
    return min(timeit.repeat(lambda: function(*args), number=1, repeat=repeat))


def reproduce_wall_s() -> dict[str, float]:
    """Wall seconds of each phase of `squeezebench reproduce`: campaign, study, report."""
    phases = {}
    with tempfile.TemporaryDirectory(prefix="squeezebench-bench-") as tmp:
        start_s = time.perf_counter()
        run_dir = run_campaign(PAPER, out_dir=Path(tmp) / "paper", progress=False)
        phases["campaign"] = time.perf_counter() - start_s
        start_s = time.perf_counter()
        run_study(run_dir, progress=lambda message: None)
        phases["accuracy study"] = time.perf_counter() - start_s
        start_s = time.perf_counter()
        write_report(run_dir)
        phases["report"] = time.perf_counter() - start_s
    return phases


def reduction_ratio(repeat: int) -> tuple[float, float]:
    """Per-call wall seconds of the reduction and of a bare dot product, same samples."""
    rng = np.random.default_rng(0)
    dt_s = PERIODS_PER_RECORD / FREQUENCY_HZ / N_SAMPLES
    t_s = np.arange(N_SAMPLES) * dt_s
    voltage_v = 20.0 * np.sin(2 * np.pi * FREQUENCY_HZ * t_s) + 0.01 * rng.standard_normal(N_SAMPLES) + 0.05
    current_a = 0.01 * np.sin(2 * np.pi * FREQUENCY_HZ * t_s - 1.2) + 1e-5 * rng.standard_normal(N_SAMPLES)
    calls = 1000   # per timing: one call is a few microseconds, below the timer's resolution

    def reduce_many():
        for _ in range(calls):
            integer_period_mean_power_w(voltage_v, current_a, dt_s, FREQUENCY_HZ)

    def dot_many():
        for _ in range(calls):
            np.dot(voltage_v, current_a)

    reduce_many()   # warm the window cache, as in a run where every record has the same layout
    return best_of(repeat, reduce_many) / calls, best_of(repeat, dot_many) / calls


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=5, help="timings per figure, best kept (default 5)")
    parser.add_argument("--skip-reproduce", action="store_true", help="only the waveform reduction")
    args = parser.parse_args(argv)
    unit = reference.measure()
    print(unit.line())
    if not args.skip_reproduce:
        phases = reproduce_wall_s()
        print("reproduce: " + " + ".join(f"{name} {unit.both(seconds)}" for name, seconds in phases.items())
              + f" = {unit.both(sum(phases.values()))} wall (goal: under 120 s)")
    reduce_s, dot_s = reduction_ratio(args.repeat)
    ratio = reduce_s / dot_s
    verdict = "ok" if ratio <= REDUCTION_GOAL_RATIO else "SLOWER than goal"
    print(f"waveform reduction ({N_SAMPLES} samples): {reduce_s * 1e6:.1f} us = {unit.units(reduce_s) * 1e6:.1f} uref "
          f"vs bare dot "
          f"{dot_s * 1e6:.1f} us -> {ratio:.2f}x (goal <= {REDUCTION_GOAL_RATIO:g}x, {verdict})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
