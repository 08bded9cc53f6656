"""Speed of `squeezebench design` on the paper's large plate (prints figures; not a test).

What it times, in one run: the physics route with its whole budget (one solve at nominal,
one per structural tolerance on the same mesh, the rest reusing them), and the sweep of
300 piezo layouts on the parallel engine with the default workers (the cores this process
may use). Goal (issue 24): the sweep <= 5 min on this 2-core machine. Printed as ratios
of this run, with the load average beside them.

Run: python benchmarks/bench_design.py
"""

from __future__ import annotations

import os
import sys
import time

from squeezebench.analysis import design, layouts
from squeezebench.paths import design_file
from squeezebench.protocols.parallel import map_unordered
from squeezebench.workers import default_workers
from squeezebench.schemas import load_design_file

SWEEP_GOAL_S = 300.0


def main() -> int:
    spec = load_design_file(design_file("large_plate"))
    start = time.perf_counter()
    physics = design.predict_physics(spec)
    physics_s = time.perf_counter() - start
    values = physics.nominal.values
    grid = layouts.grid(values["half_wavelength_mm"], spec.piezo.length_x_mm)
    workers = default_workers()
    start = time.perf_counter()
    rows = [row for _, result in map_unordered(layouts.evaluate_mesh_group,
                                               layouts.tasks(grid, spec, int(values["interior_antinodes"])),
                                               workers=workers) for row in result]
    sweep_s = time.perf_counter() - start
    frame = layouts.finish(rows)
    print(f"load average (1 min) at the end: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores, {workers} workers")
    print(f"physics route with its budget: {physics_s:.1f} s ({len(physics.perturbed)} tolerance points)")
    print(f"layout sweep: {len(frame)} layouts in {sweep_s:.0f} s (goal <= {SWEEP_GOAL_S:.0f} s, ratio "
          f"{sweep_s / SWEEP_GOAL_S:.2f}), {sweep_s * workers / len(frame):.2f} s of one core a layout; "
          f"{int(frame['feasible'].sum())} within the limits, {int(frame['pareto'].sum())} on the Pareto front")
    return 0 if sweep_s <= SWEEP_GOAL_S else 1


if __name__ == "__main__":
    sys.exit(main())
