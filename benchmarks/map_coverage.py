"""The coverage study of a map's figures alone: the paper campaign's map run on benches 1..N
(issue 46; prints figures, not a test).

`squeezebench study --coverage-benches N` runs the whole paper campaign on every bench; a
map's figures (coefficient of variation, area above half the peak, mean and peak velocity)
depend on the map run alone, which opens a bench of its own (the same scene, seed and
drawn errors as within the campaign), so the campaign cut to that run scores the same
values in a fraction of the time (5-7 CPU-s a bench; the truth over each cell's 96 x 96
spots is read at once, `simbench.stage.Stage.spot_gains`). Each bench places the plate
within its alignment (`variants.plate_draw_effects`: `plate_placement`), so the grid lands
at another place on the mode on every bench, which the grid's correction reads off the points.

Run: python benchmarks/map_coverage.py OUT [--benches 40] [--first-seed 1] [--errors specified world] [--workers 1]
(rows go to OUT/study/<coverage dir>/bench_<k>.parquet as the full study's do; --resume keeps them)
"""

from __future__ import annotations

import argparse
import shutil
import sys
import time
from pathlib import Path

import pandas as pd

from squeezebench import paths
from squeezebench.analysis.study import coverage_lines, coverage_table
from squeezebench.protocols.bench_errors import MAP_QUANTITIES, run_coverage_study
from squeezebench.protocols.variants import ERROR_MODELS, only_run

#: The paper campaign's map run (Fig. 7).
MAP_RUN = "fig7_large_plate_map"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--benches", type=int, default=40)
    parser.add_argument("--first-seed", type=int, default=1,
                        help="the benches' first seed: develop on another block (41..80) than the one reported (1..40)")
    parser.add_argument("--errors", nargs="+", choices=list(ERROR_MODELS), default=list(ERROR_MODELS))
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--resume", action="store_true", help="keep the benches already stored")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    campaign = args.out / "paper_map.yaml"
    shutil.copy(paths.paper_campaign(), campaign)
    only_run(campaign, MAP_RUN)
    scored = []
    for error_model in args.errors:
        started, cpu = time.time(), time.process_time()
        stored = run_coverage_study(args.out, args.benches, campaign_file=campaign, resume=args.resume,
                                    workers=args.workers, error_model=error_model,
                                    first_seed=args.first_seed)
        print(f"{error_model}: {args.benches} benches in {time.time() - started:.0f} s "
              f"({time.process_time() - cpu:.0f} CPU-s in this process)", flush=True)
        points = pd.read_parquet(stored)
        scored.append(points[points["quantity"].isin(MAP_QUANTITIES)].assign(error_model=error_model))
    for line in coverage_lines(coverage_table(pd.concat(scored, ignore_index=True))):
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
