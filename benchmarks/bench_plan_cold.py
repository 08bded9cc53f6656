"""The paper campaign's plan from an empty cache, against another checkout's, in one run (issue 51).

`squeezebench plan paper --target-rel-error 0.08 --json` (default flags; the target is below
the Q and tan theta' floors, so it exits 2 after printing the plan) in a fresh process as a
user starts it, from an empty cache of its own (no plan measured, no plate solved), REPEAT
times. With `--against PYTHON` (the interpreter of another checkout's environment, e.g. the
code before a change) the two checkouts alternate, so the load falls on both alike, and
their plans are compared: the same settings, floors, bench times and map plan must come out
(the JSON equal but for the cache's location and counts and the campaign file's path).

Every time is printed in seconds, CPU seconds (the command's and its workers') and
reference units (`reference.py`, timed before and after in this run), with the 1-minute
load average before it and the CPU seconds other processes took meanwhile
(`bench_scaling.command_output`); the best of each checkout's runs is the least disturbed.

Run: python benchmarks/bench_plan_cold.py [--repeat 3] [--target 0.08] [--against /path/to/.venv/bin/python]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import reference  # noqa: E402
from bench_scaling import command_output  # noqa: E402

#: What differs between two checkouts' plans of the same campaign without being the plan.
NOT_THE_PLAN = ("cache", "campaign")


def cold_plan(python: str, target: float) -> tuple[float, str, dict]:
    """Wall seconds, the CPU and load line, and the plan (JSON) of one plan from an empty cache."""
    with tempfile.TemporaryDirectory(prefix="squeezebench-plan-cold-") as cache:
        # PYTHONSAFEPATH: the checkout the command runs from (this one) is not first on
        # sys.path, or another checkout's Python would take this one's squeezebench/ package
        elapsed_s, figures, out = command_output(["plan", "paper", "--target-rel-error", f"{target:g}", "--json"],
                                                 {"SQUEEZEBENCH_CACHE": cache, "PYTHONSAFEPATH": "1"},
                                                 allowed=(0, 2), python=python)
    plan = json.loads(out)
    return elapsed_s, figures, {key: value for key, value in plan.items() if key not in NOT_THE_PLAN}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--target", type=float, default=0.08)
    parser.add_argument("--against", help="the Python of another checkout's environment: its plan alternates "
                                          "with this one's and must be the same")
    args = parser.parse_args()
    checkouts = {"this checkout": sys.executable, **({f"against ({args.against})": args.against}
                                                     if args.against else {})}
    before = reference.measure()
    runs: dict[str, list[tuple[float, str]]] = {name: [] for name in checkouts}
    plans: dict[str, dict] = {}
    for _ in range(args.repeat):
        for name, python in checkouts.items():
            elapsed_s, figures, plans[name] = cold_plan(python, args.target)
            runs[name].append((elapsed_s, figures))
    after = reference.measure()
    unit = reference.mean(before, after)
    print(f"before: {before.line()}\nafter:  {after.line()}\nunit: their mean, {unit.seconds:.3f} s")
    for name, timed in runs.items():
        print(f"plan paper --target-rel-error {args.target:g}, empty cache, {name}:")
        for elapsed_s, figures in timed:
            print(f"  {unit.both(elapsed_s)} ({figures})")
        print(f"  best of {len(timed)}: {unit.both(min(timed)[0])} (goal: <= 8 ref)")
    if len(plans) == 2:
        same = len({json.dumps(plan, sort_keys=True) for plan in plans.values()}) == 1
        print("the two checkouts' plans are " + ("the same" if same else "DIFFERENT") +
              f" ({', '.join(NOT_THE_PLAN)} aside)")
        return 0 if same else 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
