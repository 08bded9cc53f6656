"""Does a plan's bench time come true? (issue 46; prints figures, not a test)

For each campaign (quick at a 6 % target, the paper's at 8 % by default): `make_plan`
without its check on erring benches (the check changes no bench time unless it tightens),
then the planned campaign as `plan --write` writes it is run once on the simulated bench
(its map runs left out, as the point planner leaves them), and each run's bench time from
its journal is set beside the plan's estimate: per run, in total, and the ratio
measured / planned (the plan promises 0.95 to 1.05). A target below a floor still gives a
plan (noise kept under the floor): its time is compared all the same.

Run: python benchmarks/bench_plan_time.py [--workers 2] [--campaign quick.yaml:0.06 ...]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from squeezebench import paths  # noqa: E402
from squeezebench.protocols.bench_errors import bench_time_by_run_s  # noqa: E402
from squeezebench.protocols.campaign import run_campaign  # noqa: E402
from squeezebench.protocols.planning import make_plan, write_planned_campaign  # noqa: E402
from squeezebench.protocols.variants import without_maps  # noqa: E402

DEFAULT = ("quick.yaml:0.06", "paper.yaml:0.08")
PROMISE = (0.95, 1.05)


def measured_bench_time_s(campaign: Path, target: float, workers: int) -> tuple[dict, dict, float]:
    """(planned s per run, measured s per run, own s in total) of the campaign's plan at `target`."""
    plan = make_plan(campaign, target, workers=workers, check_benches=0)
    with tempfile.TemporaryDirectory(prefix="squeezebench-plan-time-") as tmp:
        planned = without_maps(write_planned_campaign(campaign, plan, Path(tmp) / campaign.name))
        run_dir = run_campaign(planned, out_dir=Path(tmp) / "run", progress=False, durable=False)
        return dict(plan.planned_s), bench_time_by_run_s(run_dir), plan.own_total_s


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--campaign", nargs="*", default=list(DEFAULT), metavar="FILE:TARGET")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    within = True
    for entry in args.campaign:
        name, target = entry.rsplit(":", 1)
        start = time.perf_counter()
        planned, measured, own_s = measured_bench_time_s(paths.campaign_file(name), float(target), args.workers)
        print(f"\n{name} at {float(target):g} ({time.perf_counter() - start:.0f} s wall)")
        print(f"{'run':<24} {'planned s':>10} {'measured s':>11} {'ratio':>6}")
        for run in measured:
            ratio = measured[run] / planned[run] if planned.get(run) else float("nan")
            print(f"{run:<24} {planned.get(run, float('nan')):>10.1f} {measured[run]:>11.1f} {ratio:>6.3f}")
        total_planned, total_measured = sum(planned.values()), sum(measured.values())
        ratio = total_measured / total_planned
        within &= PROMISE[0] <= ratio <= PROMISE[1]
        print(f"{'total':<24} {total_planned:>10.1f} {total_measured:>11.1f} {ratio:>6.3f} "
              f"({'within' if PROMISE[0] <= ratio <= PROMISE[1] else 'outside'} {PROMISE[0]}-{PROMISE[1]}); "
              f"the campaign's own settings: {own_s:.1f} s, the plan {total_planned / own_s:.2f} times that")
    return 0 if within else 1


if __name__ == "__main__":
    raise SystemExit(main())
