"""Bursts of stop signals against whole `squeezebench run` processes: the full 200 trials
of issue 48 (prints figures; not a test: about 70 s of one core idle).

The suite runs a seeded sample of the same trials (tests/test_stop_bursts.py,
`SUITE_TRIALS`); this runs them all with the same function, `whole_process_bursts`: one warm
harness forks a child per trial that runs the real entry point, and every trial must end
with exit status 130, no traceback and the interruption said.

Run: python benchmarks/bench_stops.py [--trials 200] [--seed 41]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import reference  # noqa: E402  (benchmarks/, the script's own folder)
from test_stop_bursts import SEED, whole_process_bursts  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=200)
    parser.add_argument("--seed", type=int, default=SEED)
    args = parser.parse_args()
    before = reference.measure()
    load = os.getloadavg()[0]
    start_s = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="squeezebench-stops-") as tmp:
        result = whole_process_bursts(Path(tmp), args.trials, args.seed)
    elapsed_s = time.perf_counter() - start_s
    unit = reference.mean(before, reference.measure())
    exits_130 = result["statuses"].get("130", 0)
    print(f"whole-process stop bursts, seed {args.seed}: {result['trials']} trials, {exits_130} exited 130 "
          f"(statuses {result['statuses']}), {len(result['problems'])} problems; {unit.both(elapsed_s)} (load {load:.2f} before)")
    print(f"before: {before.line()}")
    for problem in result["problems"]:
        print(f"  {problem}")
    return 0 if exits_130 == result["trials"] == args.trials and not result["problems"] else 1


if __name__ == "__main__":
    sys.exit(main())
