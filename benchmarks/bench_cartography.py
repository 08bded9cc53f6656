"""Speed of a whole simulated map of the large plate at a 2 mm step (prints figures; not a test).

What it times: the shipped `cartography` campaign (1,323 points over the central 96 x 52 mm
of the large plate, the paper's Fig. 7 scale) run end to end on the simulated bench
through the campaign runner: safe open, resonance search at the centre, the stage homed
and stepped in serpentine order, a scope acquisition kept with its waveforms at every
point, re-centring on the resonance every two rows, storage and journal. Then the same
map's bench time against the estimate the protocol makes before running, and the time
`report` takes to reduce the stored records (phase, homogeneity, figure).

Goal: the map <= 60 s of wall time on this class of machine. Printed as a ratio of one run.

Run: python benchmarks/bench_cartography.py
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import reference  # noqa: E402  (benchmarks/, the script's own folder)
from squeezebench.report.run_report import write_report
from squeezebench.paths import campaigns_dir
from squeezebench.protocols.campaign import load_campaign, run_campaign
from squeezebench.protocols.cartography import map_bench_time_s
from squeezebench.protocols.storage import read_measurements

GOAL_S = 60.0


def main() -> int:
    unit = reference.measure()
    campaign_file = campaigns_dir() / "cartography.yaml"
    run = load_campaign(campaign_file).runs[0]
    grid = run.parameters.grid
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        run_dir = run_campaign(campaign_file, out_dir=Path(folder) / "map", progress=False, say=lambda m: None)
        wall_s = time.perf_counter() - start
        rows = read_measurements(run_dir)
        mapped = rows[rows["protocol"] == "cartography"]
        bench_s = float(rows["bench_time_s"].max())   # campaign bench time, cumulative
        start = time.perf_counter()
        write_report(run_dir)
        report_s = time.perf_counter() - start
    moves_s = map_bench_time_s(grid.points_mm(), (0.0, 0.0), 20.0, 80.0, settle_s=0.0, acquisition_s=0.0)
    print(unit.line())
    print(f"load average (1 min) at the end: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    print(f"{len(mapped)} points at {grid.step_mm:g} mm: {unit.both(wall_s)} wall for the whole map "
          f"(goal <= {GOAL_S:.0f} s, ratio {wall_s / GOAL_S:.2f}), {1e3 * wall_s / len(mapped):.1f} ms a point")
    print(f"bench time {bench_s / 60:.1f} min, of which the stage's moves {moves_s / 60:.1f} min "
          f"(the rest: acquisitions, settling, the resonance re-checks)")
    print(f"report on the stored map: {unit.both(report_s)}")
    return 0 if wall_s <= GOAL_S else 1


if __name__ == "__main__":
    sys.exit(main())
