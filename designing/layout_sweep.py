"""A layout sweep's tasks on the reduced model, and its check against the full solve.

`designing.layouts` says what the layouts are and what a layout's row holds; here they are
answered by the reduced model of their plate (`plates.reduced_layouts`), in chunks
(each worker builds the model once), and a sample of them is solved in full as well:
the sweep keeps the reduced answers only if every sampled layout's working mode is within
`reduced_layouts.FREQUENCY_TOLERANCE_REL` in frequency and `FORCE_TOLERANCE_REL` in force
factor of its full solve (both refusing it counts as agreeing); otherwise its caller
solves every layout in full and says so (`squeezebench.designing.workflow`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from squeezebench.designing import design as design_model
from squeezebench.designing import layouts
from squeezebench.plates import reduced_layouts
from squeezebench.designing.design_file import DesignFile

#: The sample solved in full: 8 layouts and one more per 200, drawn with this seed.
SAMPLE_SEED = 51


def sample(count: int) -> list[int]:
    """Which of `count` layouts the check solves in full (the same ones every run)."""
    size = min(count, 8 + count // 200)
    return sorted(int(i) for i in np.random.default_rng(SAMPLE_SEED).choice(count, size, replace=False))


def bare_plate(design: DesignFile, grid: list[layouts.Layout], antinodes: int) -> reduced_layouts.BarePlate:
    """The reduced model's plate for the sweep: meshed on every patch edge of its layouts."""
    return design_model.bare_plate(design).with_edges_of(
        [layouts.layout_design(layout, design, antinodes).geometry() for layout in grid])


def _working_point(layout: layouts.Layout, design: DesignFile, antinodes: int, solve=None) -> dict | None:
    try:
        values = design_model.operating_point(layouts.layout_design(layout, design, antinodes), solve=solve).values
    except (design_model.DesignError, ValueError):
        return None
    return {"frequency_hz": values["frequency_hz"], "force_factor_n_per_v": values["force_factor_n_per_v"]}


@dataclass(frozen=True)
class ReducedChunk:
    """Layouts answered by the reduced model; runs to (rows, how many needed the full solve,
    the working points of those of them in `sampled`)."""

    layouts: tuple[layouts.Layout, ...]
    design: DesignFile
    antinodes: int
    bare: reduced_layouts.BarePlate
    sampled: frozenset = frozenset()

    def run(self) -> tuple[list[dict], int, dict]:
        solve = reduced_layouts.Solver(self.bare)
        rows, points = [], {}
        for layout in self.layouts:
            rows.append(layouts.evaluate(layout, self.design, self.antinodes, solve=solve))
            if layout in self.sampled:   # right after its row, from the modes the solver keeps
                points[layout] = _working_point(layout, self.design, self.antinodes, solve)
        return rows, solve.full_solves, points


@dataclass(frozen=True)
class CheckedLayout:
    """One sampled layout: its full solve's row and working point."""

    layout: layouts.Layout
    design: DesignFile
    antinodes: int

    def run(self) -> dict:
        return {"layout": self.layout, "row": layouts.evaluate(self.layout, self.design, self.antinodes),
                "full": _working_point(self.layout, self.design, self.antinodes)}


def run(task: ReducedChunk | CheckedLayout):
    """The parallel engine's task function (module level, picklable)."""
    return task.run()


def tasks(grid: list[layouts.Layout], design: DesignFile, antinodes: int,
          chunks: int) -> tuple[list[CheckedLayout], list[ReducedChunk]]:
    """The sample's full solves, and the layouts in `chunks` chunks: one a worker, since a
    worker builds the model for its first chunk and loky replaces a worker between tasks
    once it holds 300 MB more than after its first (the large plate's model and its kept
    patches can), so a further chunk could pay the build again (7 s idle). The layouts whose
    end columns are the same rectangles (the same place, piezos per column and arrangement;
    with or without a centre column, every thickness) go to one chunk, one after the other,
    so a worker computes those rectangles' forms once; these groups are dealt to the chunks
    in turn, by piezos per column and arrangement first, so every chunk gets as many
    layouts of each (a layout's work grows with its patches). Dealt by place and columns
    instead, a place's two column sets fell to two workers whenever the places were odd in
    number, and both computed its end columns' forms (456 instead of 328 on the
    324-layout sweep)."""
    bare = bare_plate(design, grid, antinodes)
    sampled = [grid[i] for i in sample(len(grid))]

    def end_columns(layout: layouts.Layout) -> tuple:
        return layout.piezos_per_column, layout.arrangement, layout.edge_offset_mm

    groups: dict[tuple, list[layouts.Layout]] = {}
    for layout in sorted(grid, key=end_columns):
        groups.setdefault(end_columns(layout), []).append(layout)
    runs = list(groups.values())
    dealt = [tuple(layout for run in runs[i::chunks] for layout in run) for i in range(min(chunks, len(runs)))]
    return ([CheckedLayout(layout, design, antinodes) for layout in sampled],
            [ReducedChunk(chunk, design, antinodes, bare, frozenset(sampled) & frozenset(chunk)) for chunk in dealt])


@dataclass(frozen=True)
class Sweep:
    """A sweep by the reduced model: its rows, how many layouts fell back to the full solve
    where the model does not settle, and the sample's check (its rows by the full solve in
    `checked`)."""

    rows: list[dict]
    fallbacks: int
    checked: list[dict]
    check: "Check"


def sweep(grid: list[layouts.Layout], design: DesignFile, antinodes: int, workers: int, scheduler=None,
          description: str = "layouts") -> Sweep:
    """Every layout by the reduced model and the sample by the full solve, on the parallel
    engine in one map: the chunks first (each worker builds the model once), then the
    sample's full solves, which need no model and fill the workers' tails. The sampled
    layouts' reduced answers come from their chunks. A sweep whose check misses has cost its
    reduced solves, a few per cent of solving it in full."""
    from squeezebench.protocols.parallel import map_unordered

    checks, chunks = tasks(grid, design, antinodes, chunks=workers)
    rows, fallbacks, reduced, full = [], 0, {}, []
    for task, result in map_unordered(run, [*chunks, *checks], workers=workers, scheduler=scheduler,
                                      description=description):
        if isinstance(task, ReducedChunk):
            rows.extend(result[0])
            fallbacks += result[1]
            reduced.update(result[2])
        else:
            full.append(result)
    checked = [{**result, "reduced": reduced[result["layout"]]} for result in full]
    return Sweep(rows, fallbacks, checked, check(checked))


@dataclass(frozen=True)
class Check:
    """The sample's deviations of the reduced model from the full solve (one row a layout)."""

    table: pd.DataFrame

    @property
    def passed(self) -> bool:
        return bool(self.table["within"].all())

    def worst(self) -> str:
        answered = self.table.dropna(subset=["frequency_rel", "force_factor_rel"])
        if answered.empty:
            return "no sampled layout answered by both"
        return (f"worst |frequency| {answered['frequency_rel'].abs().max():.3%}, worst |force factor| "
                f"{answered['force_factor_rel'].abs().max():.2%} on {len(self.table)} sampled layouts")


def check(results: list[dict]) -> Check:
    """The sample's `CheckedLayout` results compared (relative deviations, reduced - full)."""
    rows = []
    for result in results:
        full, reduced = result["full"], result["reduced"]
        row = {"layout": result["layout"].name(), "frequency_rel": np.nan, "force_factor_rel": np.nan}
        if full is None or reduced is None:
            row["within"] = full is None and reduced is None
        else:
            row["frequency_rel"] = reduced["frequency_hz"] / full["frequency_hz"] - 1
            row["force_factor_rel"] = reduced["force_factor_n_per_v"] / full["force_factor_n_per_v"] - 1
            row["within"] = bool(abs(row["frequency_rel"]) <= reduced_layouts.FREQUENCY_TOLERANCE_REL
                                 and abs(row["force_factor_rel"]) <= reduced_layouts.FORCE_TOLERANCE_REL)
        rows.append(row)
    return Check(pd.DataFrame(rows, columns=["layout", "frequency_rel", "force_factor_rel", "within"]))
