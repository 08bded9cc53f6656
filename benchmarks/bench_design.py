"""Speed of `squeezebench design` on the paper's large plate (prints figures; not a test).

What it times, in one run, on the parallel engine with the default workers:

1. the physics route with its whole budget (one solve at nominal, one per structural
   tolerance on the same mesh);
2. 324 layouts (the sweep's axes, `layouts.grid`, at 9 gaps between the end columns and
   the ends over the sweep's range of gaps: the goal's 300 in whole placements) by the
   reduced model (`plates.reduced_layouts`: each worker builds the model once, then
   every layout) with its check against the full solve on the sample, in one map as
   `design` runs them (`designing.layout_sweep.sweep`), the worst deviation found, and the
   full solve of whole mesh families (every thickness of a placement), extrapolated to
   the 324;
3. 3,024 layouts with the placement as a variable (84 gaps) by the reduced model
   with its check, the same way (`--skip-3000` skips it);
4. the full solve's mesh convergence at the design's layout: its working mode's frequency
   and force factor at 1.5 (the model's), 2.25 and 3 elements per flexural half-wave
   (`--skip-mesh` skips it).

Goals (issue 51, set for a 300-layout sweep): the sweep <= 20 reference units, 3,000 <= 200.
Every time is printed in seconds and in reference units (`benchmarks/reference.py`), the
reference measured first in this run, each part as it ends with the load average beside;
the reference measured again at the end says how the load moved meanwhile.

Run: python benchmarks/bench_design.py [--families N] [--skip-3000] [--skip-mesh]
"""

from __future__ import annotations

import argparse
import itertools
import os
import sys
import time

import numpy as np

import reference  # the script's own folder (benchmarks/)
from squeezebench.designing import design, layout_sweep, layouts
from squeezebench.disk_cache import CACHE_VARIABLE
from squeezebench.plates import plate_modes
from squeezebench.paths import design_file
from squeezebench.protocols.parallel import map_unordered
from squeezebench.schemas import load_design_file
from squeezebench.workers import default_workers

GOAL_SWEEP_REF = 20.0
GOAL_3000_REF = 200.0
#: gaps x the sweep's 36 other combinations: 324 and 3,024 layouts
SMALL_PLACEMENTS, LARGE_PLACEMENTS = 9, 84
MESH_ELEMENTS_PER_HALF_WAVE = (1.5, 2.25, 3.0)


def placement_grid(half_wavelength_mm: float, piezo_length_x_mm: float, placements: int) -> list[layouts.Layout]:
    """The sweep's axes with `placements` gaps of the end columns from the ends, evenly over
    the sweep's range of gaps, instead of its 6 (36 layouts a gap)."""
    return [layouts.Layout(columns, round(piezo_length_x_mm / 2 + gap * half_wavelength_mm, 3), count,
                           arrangement, thickness)
            for columns, gap, count, arrangement, thickness in itertools.product(
                layouts.COLUMNS, np.linspace(0.0, max(layouts.EDGE_GAPS_HALF_WAVES), placements),
                layouts.PIEZOS_PER_COLUMN, layouts.ARRANGEMENTS, layouts.PIEZO_THICKNESSES_MM)]


def mesh_convergence(spec) -> list[tuple[float, float, float, int]]:
    """(elements per half-wave, working frequency Hz, its force factor N/V, its interior
    antinodes) of the design's own layout solved in full on ever finer meshes."""
    geometry = spec.geometry()
    rows = []
    for density in MESH_ELEMENTS_PER_HALF_WAVE:
        modes = plate_modes.solve_plate(geometry, spec.resonator_material, spec.piezo_material, spec.search_hz,
                                        elements_per_half_wave=density, band_rel=design.SEARCH_BAND_REL)
        k = modes.working_mode(spec.search_hz)
        rows.append((density, float(modes.frequencies_hz[k]), modes.coupling(k)["force_factor_n_per_v"],
                     modes.interior_antinodes(k)))
    return rows


def timed(function, *args):
    start = time.perf_counter()
    result = function(*args)
    return time.perf_counter() - start, result


def load() -> str:
    return f"load average (1 min) {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores"


def report_reduced(grid, placements: int, goal_ref: float, spec, antinodes: int, workers: int, unit):
    """Time `grid` (`placements` gaps) by the reduced model with its check on the sample, as
    `design` runs it (`layout_sweep.sweep`: one map), print it, and return (seconds, check)."""
    total_s, done = timed(layout_sweep.sweep, grid, spec, antinodes, workers)
    assert len(done.rows) == len(grid)
    limits = layout_sweep.reduced_layouts
    print(f"{len(grid)} layouts ({placements} placements), reduced model with its check on {len(done.checked)} "
          f"sampled layouts (each worker's model built once included; {done.fallbacks} fell back to the full "
          f"solve): {unit.both(total_s)} (goal <= {goal_ref:.0f} ref: "
          f"{'met' if unit.units(total_s) <= goal_ref else 'MISSED'}); {load()}\n"
          f"  check against the full solve: {done.check.worst()}; limits {limits.FREQUENCY_TOLERANCE_REL:.1%} and "
          f"{limits.FORCE_TOLERANCE_REL:.0%}: "
          f"{'passed' if done.check.passed else 'MISSED, so `design` solves this sweep in full'}", flush=True)
    return total_s, done.check


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--families", type=int, default=4, help="mesh families (one layout per piezo thickness each) solved in full")
    parser.add_argument("--skip-3000", action="store_true")
    parser.add_argument("--skip-mesh", action="store_true")
    args = parser.parse_args()
    # every solve timed is solved, not read from an earlier run's disk cache (workers inherit it)
    os.environ[CACHE_VARIABLE] = "off"
    # each part printed as it ends (a loaded machine's run is long), in units of the
    # reference measured first; the one measured last shows how the load moved meanwhile
    unit = reference.measure()
    spec = load_design_file(design_file("large_plate"))
    workers = default_workers()
    print(f"reference: {unit.line()}; {load()}, {workers} workers", flush=True)
    physics_s, physics = timed(design.predict_physics, spec)
    print(f"physics route with its budget: {unit.both(physics_s)} ({len(physics.perturbed)} tolerance points)",
          flush=True)
    values = physics.nominal.values
    antinodes = int(values["interior_antinodes"])
    grid = placement_grid(values["half_wavelength_mm"], spec.piezo.length_x_mm, SMALL_PLACEMENTS)
    total_s, check = report_reduced(grid, SMALL_PLACEMENTS, GOAL_SWEEP_REF, spec, antinodes, workers, unit)
    print(check.table.to_string(index=False, float_format=lambda v: f"{v:+.4%}"), flush=True)
    families = layouts.tasks(grid, spec, antinodes)
    chosen = [families[int(i)] for i in np.linspace(0, len(families) - 1, args.families).round()]
    full_s, _ = timed(lambda: list(map_unordered(layouts.evaluate_mesh_group, chosen, workers=workers)))
    solved = sum(len(task[0]) for task in chosen)
    full_sweep_s = full_s * len(grid) / solved
    print(f"{len(grid)} layouts, full solve: {unit.both(full_sweep_s)}, extrapolated from {solved} layouts "
          f"({len(chosen)} mesh families) solved in {unit.both(full_s)}; reduced model "
          f"{full_sweep_s / total_s:.1f}x faster with its check; {load()}", flush=True)
    if not args.skip_3000:
        big = placement_grid(values["half_wavelength_mm"], spec.piezo.length_x_mm, LARGE_PLACEMENTS)
        report_reduced(big, LARGE_PLACEMENTS, GOAL_3000_REF, spec, antinodes, workers, unit)
    if not args.skip_mesh:
        mesh_s, mesh = timed(mesh_convergence, spec)
        finest = mesh[-1]
        print(f"full solve's mesh convergence at the design's layout ({unit.both(mesh_s)}), against "
              f"{finest[0]:g} elements per half-wave: " + "; ".join(
                  f"{density:g}: frequency {frequency / finest[1] - 1:+.3%}, force factor {force / finest[2] - 1:+.2%}"
                  for density, frequency, force, _ in mesh[:-1])
              + f" (antinodes {', '.join(str(row[3]) for row in mesh)})", flush=True)
    after = reference.measure()
    print(f"reference at the end: {after.line()} ({after.seconds / unit.seconds:.2f}x the first); {load()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
