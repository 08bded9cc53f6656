"""What `run --plot` costs (prints figures; not a test).

Runs the shipped `quick` campaign through the CLI twice in this process, alternating,
without and with `--plot` (matplotlib's Agg backend: no display, as on a lab's headless
runner or in CI), and prints the wall-time ratio of the medians. Goal: at most 1.5.
Off-screen the plot is drawn once, into RUN_DIR/live_plot.png; on a screen it is
repainted at most every `liveplot.REDRAW_INTERVAL_S`.

Run: python benchmarks/bench_liveplot.py [--repeat N]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

os.environ["MPLBACKEND"] = "Agg"

import reference  # noqa: E402  (benchmarks/, the script's own folder)
from squeezebench import cli  # noqa: E402

GOAL_RATIO = 1.5


def timed_run(out: Path, plot: bool) -> float:
    start = time.perf_counter()
    code = cli.main(["run", "quick", "--out", str(out), "-q", *(["--plot"] if plot else [])])
    if code != 0:
        raise SystemExit(f"run quick{' --plot' if plot else ''} failed with exit status {code}")
    return time.perf_counter() - start


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    unit = reference.measure()
    plain, plotted = [], []
    with tempfile.TemporaryDirectory() as folder:
        timed_run(Path(folder) / "warm", plot=True)   # imports and caches, for neither side
        for i in range(args.repeat):
            plain.append(timed_run(Path(folder) / f"plain{i}", plot=False))
            plotted.append(timed_run(Path(folder) / f"plot{i}", plot=True))
    ratio = statistics.median(plotted) / statistics.median(plain)
    print(f"load average (1 min) at the end: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    print(unit.line())
    print(f"run quick: {unit.both(statistics.median(plain), 2)}, "
          f"with --plot {unit.both(statistics.median(plotted), 2)} "
          f"(medians of {args.repeat}); ratio {ratio:.2f} (goal <= {GOAL_RATIO})")
    return 0 if ratio <= GOAL_RATIO else 1


if __name__ == "__main__":
    sys.exit(main())
