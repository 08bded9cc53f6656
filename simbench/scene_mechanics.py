"""The plate's electromechanics from a scene's physical parameters: the modal mass of
the (n, 0) mode, the mass of the assembly and the piezos' pin-force factor (`physics`).
"""

from __future__ import annotations

from squeezebench.simbench import physics
from squeezebench.simbench.scene_model import Actuators, Column, Mode, Piezo, Plate

def _patch_extent_m(column: Column, piezo: Piezo) -> tuple[float, float]:
    """Where a column's patches start and end along the plate (the piezo width lies along it)."""
    return ((column.position_mm - piezo.width_mm / 2.0) * 1e-3, (column.position_mm + piezo.width_mm / 2.0) * 1e-3)


def modal_mass_kg(plate: Plate, actuators: Actuators, mode: Mode) -> float:
    """Mass of the (n, 0) mode with unit displacement at the antinodes: half the plate's
    mass (the mean of cos^2) plus every bonded piezo weighted by the mode's mean square
    over its patch (powered or not, a bonded patch moves with the plate)."""
    half = mode.half_wavelength_mm * 1e-3
    piezos = sum(actuators.piezos_per_column * actuators.piezo.mass_kg
                 * physics.mean_square_mode(*_patch_extent_m(c, actuators.piezo), half) for c in actuators.columns)
    return plate.mass_kg / 2.0 + piezos


def assembly_mass_kg(plate: Plate, actuators: Actuators) -> float:
    return plate.mass_kg + len(actuators.columns) * actuators.piezos_per_column * actuators.piezo.mass_kg


def force_factor_n_per_v(plate: Plate, actuators: Actuators, mode: Mode, powered: tuple[str, ...]) -> float:
    """n_c psi from the datasheet: every powered patch's pin force on the mode, each column
    wired in phase with the mode's curvature under it (Eq. 1: A grows with n_c V)."""
    piezo = actuators.piezo
    piezo_young = 1.0 / piezo.material.s11e_m2_per_n
    neutral = physics.neutral_axis_from_piezo_face_m(piezo.thickness_mm * 1e-3, piezo_young,
                                                     plate.thickness_mm * 1e-3, plate.material.young_pa)
    lever = neutral - piezo.thickness_mm * 1e-3 / 2.0
    return sum(actuators.piezos_per_column * physics.piezo_force_factor_n_per_v(
        piezo.material, piezo.length_mm * 1e-3, lever, *_patch_extent_m(c, piezo), mode.half_wavelength_mm * 1e-3)
        for c in actuators.columns if c.name in powered)
