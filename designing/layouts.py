"""Where the piezos go: a sweep of layouts of one design, power against homogeneity.

The trade-off of the beam-model paper (ref. 001) made into numbers: each layout of the
design's plate (columns, their distance from the ends, piezos per column and how they are
spread across the width, piezo thickness) is solved by the plate model at the design's
working mode and target, and gives the power and voltage the target needs and how even
the touch area's antinodes are. The distance from the ends is searched finest near the
edges, where the mode's curvature, and with it the drive, changes fastest: the front then
says where to bond the piezos, not only how many. Layouts that share a mesh (they differ only in piezo
thickness) form one task, so the mesh and its basis are built once (`plate_modes`).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import pandas as pd

from squeezebench.designing import design as design_model
from squeezebench.designing.design_file import DesignFile, Group

#: The sweep's axes (216 layouts, 72 meshes). Edge gaps are fractions of the working mode's
#: half-wavelength between the plate's ends and the end columns' piezos (0: flush with the
#: edge); a whole half-wave in repeats the flush curvature at the next nodal line, so the gaps
#: stop short of it and are closest where the drive changes fastest.
COLUMNS = ("ends", "ends_and_centre")
EDGE_GAPS_HALF_WAVES = (0.0, 0.125, 0.25, 0.375, 0.5, 0.75)
PIEZOS_PER_COLUMN = (2, 4, 6)
ARRANGEMENTS = ("corners", "centred")
PIEZO_THICKNESSES_MM = (0.3, 0.5, 1.0)

LAYOUT_COLUMNS = ["layout", "columns", "edge_offset_mm", "edge_gap_mm", "piezos_per_column", "arrangement",
                  "piezo_thickness_mm", "n_piezos"]
RESULT_COLUMNS = ["frequency_hz", "interior_antinodes", "coupling_share", "voltage_vpp", "power_w", "piezo_field_v_per_mm",
                  "current_pp_a", "weakest_antinode_ratio", "width_uniformity", "feasible", "why_not"]


@dataclass(frozen=True)
class Layout:
    columns: str
    edge_offset_mm: float   # centre of the end columns from the plate's ends
    piezos_per_column: int
    arrangement: str
    piezo_thickness_mm: float

    @property
    def mesh_key(self) -> tuple:
        """Layouts with the same key differ only in thickness: one mesh serves them all."""
        return (self.columns, self.edge_offset_mm, self.piezos_per_column, self.arrangement)

    def edge_gap_mm(self, piezo_length_x_mm: float) -> float:
        """From the plate's ends to the end columns' piezos."""
        return round(self.edge_offset_mm - piezo_length_x_mm / 2, 3)

    def name(self) -> str:
        return (f"{self.columns} @{self.edge_offset_mm:.1f} mm, {self.piezos_per_column} {self.arrangement}, "
                f"{self.piezo_thickness_mm:g} mm")


def grid(half_wavelength_mm: float, piezo_length_x_mm: float) -> list[Layout]:
    """The sweep's layouts (216): every combination of the axes above."""
    layouts = []
    for columns, gap, count, arrangement, thickness in itertools.product(
            COLUMNS, EDGE_GAPS_HALF_WAVES, PIEZOS_PER_COLUMN, ARRANGEMENTS, PIEZO_THICKNESSES_MM):
        x = piezo_length_x_mm / 2 + gap * half_wavelength_mm
        layouts.append(Layout(columns, round(x, 3), count, arrangement, thickness))
    return layouts


def groups(layout: Layout, design: DesignFile) -> list[Group]:
    """The layout's groups on the design's plate: a column's piezos side by side across the
    middle of the width ("centred"), or half at each end of it as two groups ("corners",
    the paper's large plate: 4 per column, 2 per corner)."""
    length, width = design.resonator.length_mm, design.resonator.width_mm
    w = design.piezo.width_y_mm
    xs = [layout.edge_offset_mm, length - layout.edge_offset_mm]
    if layout.columns == "ends_and_centre":
        xs.insert(1, length / 2)
    n = layout.piezos_per_column
    out = []
    for i, x in enumerate(xs):
        if layout.arrangement == "corners":
            half = n // 2
            out.append(Group(name=f"c{i}_low", x_mm=x, y_mm=[w / 2 + j * w for j in range(half)]))
            out.append(Group(name=f"c{i}_high", x_mm=x, y_mm=[width - w / 2 - j * w for j in range(n - half)]))
        else:
            first = width / 2 - n * w / 2 + w / 2
            out.append(Group(name=f"c{i}", x_mm=x, y_mm=[first + j * w for j in range(n)]))
    return out


def layout_design(layout: Layout, design: DesignFile, antinodes: int) -> DesignFile:
    """The design with this layout's piezos, at the base design's working mode."""
    return DesignFile.model_validate({
        **design.model_dump(), "groups": [g.model_dump() for g in groups(layout, design)],
        "piezo": {**design.piezo.model_dump(), "thickness_mm": layout.piezo_thickness_mm},
        "mode": {"interior_antinodes": antinodes}})


def evaluate(layout: Layout, design: DesignFile, antinodes: int, solve=None) -> dict:
    """One layout's row: what the target needs, the homogeneity, and whether it is feasible
    (amplifier output, the piezo's field limit, powered piezos that do not cancel); a layout
    the model cannot answer for says why instead of numbers."""
    row = {"columns": layout.columns, "edge_offset_mm": layout.edge_offset_mm,
           "edge_gap_mm": layout.edge_gap_mm(design.piezo.length_x_mm),
           "piezos_per_column": layout.piezos_per_column, "arrangement": layout.arrangement,
           "piezo_thickness_mm": layout.piezo_thickness_mm}
    try:
        candidate = layout_design(layout, design, antinodes)
        values = design_model.operating_point(candidate, solve=solve).values
    except (design_model.DesignError, ValueError) as exc:
        return {**row, "n_piezos": np.nan, **{c: np.nan for c in RESULT_COLUMNS},
                "feasible": False, "why_not": str(exc).split(": ", 1)[-1]}
    limits = []
    if values["voltage_vpp"] > design.amplifier.max_output_vpp:
        limits.append(f"needs {values['voltage_vpp']:.0f} Vpp > amplifier {design.amplifier.max_output_vpp:g} Vpp")
    if values["piezo_field_v_per_mm"] > candidate.piezo.max_field_v_per_mm:
        limits.append(f"field {values['piezo_field_v_per_mm']:.0f} V/mm > {candidate.piezo.max_field_v_per_mm:g} V/mm")
    if values["coupling_share"] < design_model.MIN_COUPLING_SHARE:
        limits.append(f"its powered piezos cancel on the working mode (net coupling {values['coupling_share']:.0%})")
    if values["interior_antinodes"] != antinodes:
        limits.append(f"its working mode has {values['interior_antinodes']} antinodes, not the design's {antinodes}")
    return {**row, "n_piezos": candidate.n_powered_piezos,
            **{c: values[c] for c in RESULT_COLUMNS if c in values},
            "feasible": not limits, "why_not": "; ".join(limits)}


def evaluate_mesh_group(task: tuple[tuple[Layout, ...], DesignFile, int]) -> list[dict]:
    """A parallel task: the layouts that share one mesh, solved one after the other."""
    layouts, design, antinodes = task
    return [evaluate(layout, design, antinodes) for layout in layouts]


def tasks(layouts: list[Layout], design: DesignFile, antinodes: int) -> list[tuple]:
    by_mesh: dict[tuple, list[Layout]] = {}
    for layout in layouts:
        by_mesh.setdefault(layout.mesh_key, []).append(layout)
    return [(tuple(group), design, antinodes) for group in by_mesh.values()]


def pareto_front(frame: pd.DataFrame) -> pd.Series:
    """True for the feasible layouts no other feasible layout beats on both power (lower)
    and weakest antinode (higher)."""
    ok = frame["feasible"].astype(bool) & frame["power_w"].notna()
    power, even = frame["power_w"].to_numpy(), frame["weakest_antinode_ratio"].to_numpy()
    front = np.zeros(len(frame), dtype=bool)
    for i in np.nonzero(ok.to_numpy())[0]:
        better = ok.to_numpy() & (power <= power[i]) & (even >= even[i]) & ((power < power[i]) | (even > even[i]))
        front[i] = not better.any()
    return pd.Series(front, index=frame.index)


def finish(rows: list[dict]) -> pd.DataFrame:
    """The sweep's table, in the grid's order, numbered, with its Pareto front marked."""
    frame = pd.DataFrame(rows).sort_values(["columns", "edge_offset_mm", "piezos_per_column", "arrangement",
                                            "piezo_thickness_mm"], kind="stable").reset_index(drop=True)
    frame.insert(0, "layout", np.arange(1, len(frame) + 1))
    frame["pareto"] = pareto_front(frame)
    return frame[LAYOUT_COLUMNS + RESULT_COLUMNS + ["pareto"]]
