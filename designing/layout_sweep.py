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

import itertools
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
    """Layouts answered by the reduced model; runs to (rows, how many needed the full solve)."""

    layouts: tuple[layouts.Layout, ...]
    design: DesignFile
    antinodes: int
    bare: reduced_layouts.BarePlate

    def run(self) -> tuple[list[dict], int]:
        solve = reduced_layouts.Solver(self.bare)
        return [layouts.evaluate(layout, self.design, self.antinodes, solve=solve)
                for layout in self.layouts], solve.full_solves


@dataclass(frozen=True)
class CheckedLayout:
    """One sampled layout: its full solve's row, and both models' working points."""

    layout: layouts.Layout
    design: DesignFile
    antinodes: int
    bare: reduced_layouts.BarePlate

    def run(self) -> dict:
        row = layouts.evaluate(self.layout, self.design, self.antinodes)
        return {"layout": self.layout, "row": row,
                "full": _working_point(self.layout, self.design, self.antinodes),
                "reduced": _working_point(self.layout, self.design, self.antinodes,
                                          reduced_layouts.Solver(self.bare))}


def run(task: ReducedChunk | CheckedLayout):
    """The parallel engine's task function (module level, picklable)."""
    return task.run()


def tasks(grid: list[layouts.Layout], design: DesignFile, antinodes: int,
          chunks: int) -> tuple[list[CheckedLayout], list[ReducedChunk]]:
    """The sample's checks (each a full solve and a reduced one), and the layouts in `chunks`
    chunks: one a worker, since a worker builds the model for its first chunk and loky
    replaces a worker between tasks once it holds 300 MB more than after its first (the
    large plate's model and its kept patches can), so a further chunk could pay the build
    again (7 s idle). The grid's runs of layouts with the same columns at the same place
    (whose patches share rectangles, so a worker computes them once) are dealt to the
    chunks in turn: cut in order, one chunk would hold every layout with a centre column,
    half as many patches again, and finish last."""
    bare = bare_plate(design, grid, antinodes)
    runs = [list(run) for _, run in itertools.groupby(grid, key=lambda layout: (layout.columns,
                                                                               layout.edge_offset_mm))]
    dealt = [tuple(layout for run in runs[i::chunks] for layout in run) for i in range(min(chunks, len(runs)))]
    return ([CheckedLayout(grid[i], design, antinodes, bare) for i in sample(len(grid))],
            [ReducedChunk(chunk, design, antinodes, bare) for chunk in dealt])


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
