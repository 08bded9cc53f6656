"""Does a plan keep its promise on benches it never saw? (issue 15; prints figures, not a test)

1. `make_plan` on a campaign (the paper's by default) for a target p95 relative error:
   the plan is checked, and if need be tightened, on simulated benches 1..20 with the
   instruments' errors drawn within specification;
2. the planned campaign is then run on other benches (21..20+N by default) it was never
   checked on, and every stored point is scored against the truth: the p95 |relative
   error| per run and quantity, and the coverage of the reported expanded uncertainties.

Run: python benchmarks/plan_accuracy.py [--target 0.05] [--benches 20] [--workers 2] [--campaign FILE]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import reference  # noqa: E402  (benchmarks/, the script's own folder)
from squeezebench import paths  # noqa: E402
from squeezebench.protocols.bench_errors import errors_on_benches, p95_by_run  # noqa: E402
from squeezebench.protocols.planning import CHECK_BENCHES, make_plan, write_planned_campaign  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--campaign", type=Path, default=paths.paper_campaign())
    parser.add_argument("--target", type=float, default=0.05, help="target p95 relative error (default 0.05)")
    parser.add_argument("--benches", type=int, default=20, help="unseen benches to validate on (default 20)")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    unit = reference.measure()
    print(unit.line())
    start = time.perf_counter()
    plan = make_plan(args.campaign, args.target, workers=args.workers)
    print(plan.table())
    print(f"plan: {unit.both(time.perf_counter() - start, 0)} wall")
    if plan.check is None:
        print("the target is below the reachable floor: nothing to validate")
        return 0
    unseen = range(CHECK_BENCHES + 1, CHECK_BENCHES + args.benches + 1)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="squeezebench-plan-accuracy-") as tmp:
        planned = write_planned_campaign(args.campaign, plan, Path(tmp) / args.campaign.name)
        errors = errors_on_benches(planned, unseen, workers=args.workers)
    p95 = p95_by_run(errors)
    print(f"\nthe planned campaign on {len(unseen)} benches it was not checked on "
          f"({unseen.start}..{unseen.stop - 1}), {unit.both(time.perf_counter() - start, 0)} wall:")
    print(p95.to_string(index=False, float_format=lambda v: f"{v:.2%}"))
    worst = p95.groupby("quantity")["p95_abs_rel_error"].max()
    print("worst run p95 |error|: " + ", ".join(f"{q} {v:.2%}" for q, v in worst.items())
          + f" -> {'meets' if (worst <= args.target).all() else 'misses'} the target {args.target:g}")
    coverage = errors.groupby("quantity")["covered"].mean()
    print("stored points whose expanded uncertainty (k = 2) covers the truth: "
          + ", ".join(f"{q} {v:.1%}" for q, v in coverage.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
