"""The plate's working mode as a 2-D shape the simulated stage is scanned over.

The shape is the finite-element modal model's (`plates.plate_modes`, Kirchhoff plate
with its bonded piezos): the scene's plate in its present state (a cut plate is solved
again) as `simbench.predicted` describes it to the model, and of its modes the (n, 0)
mode nearest the state's resonance frequency, the one the scene says it is driven in.
The solution is cached by geometry and materials, so a map solves its plate once.

A spot is read from the working mode tabulated once per plate on a 0.5 mm grid and
interpolated cubically (the elements' own evaluation costs ~50 ms a point, most of a
1,300-point map; the table costs ~1 s once, kept in the disk cache beside its solve, so
`reproduce` tabulates it on the process that solved the plate, whose elements are built,
not on the campaign's). The table departs from the elements by below
1e-4 of the peak over 99.8 % of the large plate (20,000 random points), up to 2e-4 within
2 mm of a free edge, where the mode's evanescent edge field and the patches' curvature jump
bend faster than a cubic follows; a 1 mm grid left 2.4 % of the plate above 1e-4 (measured
with the 2 mm edge gap; tests/test_cartography_mode.py holds 60 random points to 1e-4).

Scale: 1 at the scene's measurement point (where its states' velocities are given, as
`simbench.predicted` refers the modal mass and force there too), 0 off the plate: a spot
anywhere reads the scene's velocity times the mode's share there, with its sign. A cut
plate keeps its centre, so the measurement point moves by half the cut in its frame.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any, Callable

import numpy as np

from scipy.interpolate import NdBSpline, RegularGridInterpolator

from squeezebench.plates import plate_modes
from squeezebench.simbench import predicted
from squeezebench.simbench.scene_model import SceneError


def working_mode(scene, state) -> tuple[plate_modes.PlateModes, int]:
    """The model's modes of the state's plate and the index of its working mode."""
    resonator, piezo = predicted.materials(scene)
    modes = plate_modes.solve_plate(predicted.geometry(scene, state), resonator, piezo,
                                    near_hz=state.resonance_frequency_hz)
    return modes, modes.working_mode(state.resonance_frequency_hz)


def solve_ahead(scene_paths: list) -> None:
    """Solve the working mode of each scene's initial state now and tabulate it (both kept in
    the disk cache), for a campaign whose maps read them later on another process
    (`reproduce`: its drawing process, while the campaign's first runs measure)."""
    from squeezebench.simbench.scene import load_scene

    for path in scene_paths:
        scene = load_scene(path)
        _table(*working_mode(scene, scene.state(scene.initial_state)))


TABLE_STEP_M = 0.5e-3
_TABLES: dict[tuple[int, int], tuple[plate_modes.PlateModes, RegularGridInterpolator]] = {}


def _table(modes: plate_modes.PlateModes, k: int) -> RegularGridInterpolator:
    """Mode k on the grid, 0 off the plate; kept with its (cached, never freed) solution."""
    key = (id(modes), k)
    if key not in _TABLES:
        x_m = np.linspace(0.0, modes.x_m[-1], int(np.ceil(modes.x_m[-1] / TABLE_STEP_M)) + 1)
        y_m = np.linspace(0.0, modes.y_m[-1], int(np.ceil(modes.y_m[-1] / TABLE_STEP_M)) + 1)

        def tabulated() -> dict[str, np.ndarray]:
            values = modes.shape_at(k, *np.meshgrid(x_m, y_m, indexing="ij"))
            with plate_modes.single_threaded():   # as the solve: the same bits wherever, no spinning thread
                spline = RegularGridInterpolator((x_m, y_m), values, method="cubic")._spline
            return {"values": values, "coefficients": spline.c, "knots_x": spline.t[0], "knots_y": spline.t[1]}

        # a solve the disk cache does not hold (it is off): nor its table
        table = tabulated() if modes.stored_key is None else \
            plate_modes.stored_solves().get(_table_key(modes.stored_key, k), tabulated)
        spline = NdBSpline((table["knots_x"], table["knots_y"]), table["coefficients"], 3)
        _TABLES[key] = modes, _SolvedCubic((x_m, y_m), table["values"], spline)
    return _TABLES[key][1]


class _SolvedCubic(RegularGridInterpolator):
    """The cubic interpolator of a table whose spline coefficients are already solved (an
    iterative solve over the whole grid, most of the table's cost): kept in the disk cache
    with it, and read like any cubic `RegularGridInterpolator` (0 off the grid)."""

    def __init__(self, points, values, spline: NdBSpline) -> None:
        self._solved = spline
        super().__init__(points, values, method="cubic", bounds_error=False, fill_value=0.0)

    def _construct_spline(self, method, solver=None, **solver_args) -> NdBSpline:
        return self._solved


def _table_key(stored_key: str, k: int) -> str:
    """The disk cache's key of mode k's table of the solve kept under `stored_key` (whose
    key covers the plate model's code): the grid's step and this module's code decide the rest."""
    source = hashlib.sha256(Path(__file__).read_bytes()).hexdigest()
    return hashlib.sha256(f"{stored_key}\0mode table\0{k}\0{TABLE_STEP_M!r}\0{source}".encode()).hexdigest()


#: Below this share of the mode's largest deflection the scene's measurement point is too
#: near a nodal line to refer a map to: the scene's velocities would be mostly noise there.
MIN_REFERENCE_SHARE = 0.1


def mode_shape(scene, state, x_mm, y_mm) -> np.ndarray:
    """The working mode's deflection at (x, y) in mm from the plate's corner (x along its
    length) over its deflection at the scene's measurement point; 0 off the plate."""
    return shape_of(scene, state)(x_mm, y_mm)


def shape_of(scene, state) -> Callable[[Any, Any], np.ndarray]:
    """`mode_shape` of the state's plate as a function of (x_mm, y_mm): its solve is found,
    and its reference read, once. The stage keeps it while the state stays (a read of the
    solve by its key hashes the whole plate, most of a spot's cost where a study reads the
    cells of a map's points, some 20,000 spots)."""
    table = _table(*working_mode(scene, state))
    offset_mm = (scene.plate.length_mm - (state.plate_length_mm or scene.plate.length_mm)) / 2
    point = scene.measurement_point
    reference = float(table([(point.x_mm - offset_mm) * 1e-3, point.y_mm * 1e-3])[0])
    if abs(reference) < MIN_REFERENCE_SHARE:
        raise SceneError(f"{scene.path}: measurement_point ({point.x_mm}, {point.y_mm}) mm is at "
                         f"{abs(reference):.0%} of the working mode's largest deflection in state "
                         f"{state.name!r}, near a nodal line: move it to an antinode to map this plate")

    def shape(x_mm, y_mm) -> np.ndarray:
        x_m, y_m = np.broadcast_arrays(np.asarray(x_mm, dtype=float) * 1e-3, np.asarray(y_mm, dtype=float) * 1e-3)
        return table(np.stack([x_m.ravel(), y_m.ravel()], axis=-1)).reshape(x_m.shape) / reference
    return shape
