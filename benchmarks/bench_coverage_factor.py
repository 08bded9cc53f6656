"""What the coverage factors of a report cost (issue 51; prints figures, not a test)

Runs `squeezebench report RUN_DIR` in this process once, noting every budget shape whose k
it asks for (`analysis.budgets.shape_coverage_factor`), then computes all those k again
from nothing (caches emptied) and prints the CPU seconds that took, in seconds and in
reference units (`benchmarks/reference.py`, timed in the same run), with the load.

Run: python benchmarks/bench_coverage_factor.py RUN_DIR   (a paper run: `squeezebench run paper --out RUN_DIR`)
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from squeezebench import cli  # noqa: E402
from squeezebench.analysis import budgets  # noqa: E402

import reference  # noqa: E402


def report_shapes(run_dir: Path) -> tuple[list, int]:
    """The distinct shapes whose k `report` asks for, in order, and how many times it asks."""
    shapes, asked, factor = {}, [0], budgets.shape_coverage_factor

    def noted(*shape):
        asked[0] += 1
        shapes.setdefault(shape, None)
        return factor(*shape)

    budgets.shape_coverage_factor = noted
    try:
        if cli.main(["report", str(run_dir), "-q"]) != 0:
            raise SystemExit(f"report {run_dir} failed")
    finally:
        budgets.shape_coverage_factor = factor
    return list(shapes), asked[0]


def every_factor_cpu_s(shapes: list) -> float:
    """CPU seconds of every shape's k from nothing (no distribution, no factor cached)."""
    budgets.shape_coverage_factor.cache_clear()
    budgets._DISTRIBUTIONS.clear()
    start = time.process_time()
    for shape in shapes:
        budgets.shape_coverage_factor(*shape)
    return time.process_time() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_dir", type=Path)
    args = parser.parse_args()
    shapes, asked = report_shapes(args.run_dir)
    before = reference.measure()
    cpu_s = every_factor_cpu_s(shapes)
    unit = reference.mean(before, reference.measure())
    print(unit.line())
    print(f"report asked for k {asked} times, {len(shapes)} distinct shapes "
          f"(at most {max(len(rectangles) for rectangles, *_ in shapes)} limits in one)")
    print(f"every k of the report from nothing: {unit.both(cpu_s, 2)} CPU "
          f"({1e3 * cpu_s / len(shapes):.2f} ms a shape; load {os.getloadavg()[0]:.2f})")


if __name__ == "__main__":
    main()
