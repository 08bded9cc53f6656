"""Does every stored power's U hold a lagging current probe without a deskew run? (issue 46;
prints figures, exits 1 on a miss)

The paper campaign (the shipped one, its map runs left out) is run without its deskew
calibration on a bench whose current probe lags the voltage probe by 17 ns, the budget's
CH2 delay then being the specified bound, not a measured delay. Every stored point's power
is scored against the reading ideal instruments give at its recorded generator setting on
the same plates without the lag (`bench_errors`' truth), and |error| is set beside U: per
run the worst |error| / U and the number of powers above U (the promise: none). The
stress point of Fig. 2c (power factor 0.018) is where the lag moves the power most.

Run: python benchmarks/bench_probe_lag.py [--lag-ns 17] [--campaign paper.yaml]
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from squeezebench import paths  # noqa: E402
from squeezebench.analysis.rundata import load_run  # noqa: E402
from squeezebench.analysis.uncertainty import run_uncertainties  # noqa: E402
from squeezebench.protocols.bench_errors import _truths  # noqa: E402  (the coverage study's truth)
from squeezebench.protocols.campaign import run_campaign  # noqa: E402
from squeezebench.protocols.variants import campaign_with_effects, without_calibration  # noqa: E402


def lagged_power_errors(campaign: Path, lag_s: float, work: Path):
    """Every stored point of `campaign` without its deskew run, on a bench whose current
    probe lags by `lag_s`: run, phase, power, its truth and U."""
    plain_campaign = without_calibration(Path(shutil.copy(campaign, work / campaign.name)))
    lagging = campaign_with_effects(plain_campaign, work / "lagging", [{"current_probe_delay": {"delay_s": lag_s}}])
    campaign_with_effects(plain_campaign, work / "plain", [])   # the same plates without the lag
    run_dir = run_campaign(lagging, out_dir=work / "run", progress=False, durable=False)
    points = run_uncertainties(load_run(run_dir)).points
    truths = _truths(points, work / "plain")
    points = points.assign(true_power_w=[truths[index]["power_w"] for index in points.index])
    points["error_over_u"] = (points["power_w"] - points["true_power_w"]).abs() / points["power_w_U"]
    return points


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lag-ns", type=float, default=17.0)
    parser.add_argument("--campaign", default="paper.yaml")
    args = parser.parse_args()
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="squeezebench-lag-") as tmp:
        points = lagged_power_errors(paths.campaign_file(args.campaign), args.lag_ns * 1e-9, Path(tmp))
    print(f"{args.campaign} without its deskew run, current probe lagging {args.lag_ns:g} ns "
          f"({time.perf_counter() - start:.0f} s wall)")
    print(f"{'run':<24} {'powers':>6} {'max |error|/U':>14} {'above U':>8} {'worst |error|':>14} {'its U':>8}")
    for run, group in points.groupby("run_name", sort=False):
        worst = group.loc[group["error_over_u"].idxmax()]
        print(f"{run:<24} {len(group):>6d} {group['error_over_u'].max():>14.3f} "
              f"{int((group['error_over_u'] > 1.0).sum()):>8d} "
              f"{abs(worst['power_w'] / worst['true_power_w'] - 1.0):>14.2%} "
              f"{worst['power_w_U'] / abs(worst['true_power_w']):>8.2%}")
    above = int((points["error_over_u"] > 1.0).sum())
    print(f"{'total':<24} {len(points):>6d} {points['error_over_u'].max():>14.3f} {above:>8d}: "
          f"{'every stored power within its U' if not above else 'powers outside their U'}")
    return 0 if not above else 1


if __name__ == "__main__":
    raise SystemExit(main())
