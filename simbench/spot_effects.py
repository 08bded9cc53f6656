"""Where the vibrometer's laser meets the plate when the x-y stage moves it: the stage's
backlash, a plate off the stage's zero or rotated (as set, or as mounted on one bench), a
tilted plate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from squeezebench.plates.specifications import SPECIFICATIONS
from squeezebench.simbench.effect_base import Effect
from squeezebench.simbench.systematic_effects import SystematicEffect

@dataclass(frozen=True)
class Spot:
    """Where the laser meets the plate, mm from the plate's corner in its own frame, and
    the share of the plate's normal velocity that lies along the beam."""

    x_mm: float
    y_mm: float
    beam_share: float = 1.0


class StageBacklash(Effect):
    """Lost motion in each axis's drive: the carriage lags the motor by half the backlash
    behind its last direction of travel, so a point approached from the other side sits
    one backlash away. The SMC100's `TP` reads the motor's encoder, so the driver never
    sees it (SMC100 UM TP). Default 20 um per axis, assumed: a typical lead-screw stage
    without backlash compensation (`BA` not set)."""

    name = "stage_backlash"
    defaults = {"x_mm": 0.02, "y_mm": 0.02}
    limits = {"x_mm": (0.0, 1.0), "y_mm": (0.0, 1.0)}
    stages = frozenset({"spot"})

    def spot(self, spot: Spot, directions: tuple[int, int]) -> Spot:
        p = self.parameters
        return replace(spot, x_mm=spot.x_mm - 0.5 * p["x_mm"] * directions[0],
                       y_mm=spot.y_mm - 0.5 * p["y_mm"] * directions[1])


class PlateOffset(Effect):
    """The plate not where the map thinks: its corner at (x_mm, y_mm) in the stage's frame
    and its edges turned by rotation_deg (counter-clockwise). A grid laid out for the
    plate then drifts across it, and its last points may miss the plate (velocity 0:
    the laser lands on the mount)."""

    name = "plate_offset"
    defaults = {"x_mm": 1.0, "y_mm": 1.0, "rotation_deg": 0.5}
    limits = {"x_mm": (-50.0, 50.0), "y_mm": (-50.0, 50.0), "rotation_deg": (-10.0, 10.0)}
    stages = frozenset({"spot"})

    def spot(self, spot: Spot, directions: tuple[int, int]) -> Spot:
        p = self.parameters
        angle = math.radians(p["rotation_deg"])
        dx, dy = spot.x_mm - p["x_mm"], spot.y_mm - p["y_mm"]
        return replace(spot, x_mm=math.cos(angle) * dx + math.sin(angle) * dy,
                       y_mm=-math.sin(angle) * dx + math.cos(angle) * dy)


class PlatePlacement(SystematicEffect, errors=dict.fromkeys(("x_mm", "y_mm"),
                                                           SPECIFICATIONS["plate_placement"].half_width)):
    """Where one bench's mounting put the plate under the stage's frame: its corner at
    (x_mm, y_mm), within the alignment a lab reaches by eye (+-1 mm per axis,
    `specifications.SPECIFICATIONS["plate_placement"]`). What varies from bench to bench in
    a map is where its grid lands on the mode: with `draw: 1` each plate's offset is drawn
    once per bench, uniformly within the limits, with `draw: 2` as the world errs
    (`systematic_effects.world_draw`); `draw: 0` puts the corner at the limits. Off unless
    a scene names it: a stage that never moves (no map) reads the scene's point anyway."""

    name = "plate_placement"
    stages = frozenset({"spot"})
    per_plate = True   # each plate is mounted on its own

    def spot(self, spot: Spot, directions: tuple[int, int]) -> Spot:
        return replace(spot, x_mm=spot.x_mm - self.values["x_mm"], y_mm=spot.y_mm - self.values["y_mm"])


class PlateTilt(Effect):
    """A plate not level under a vertical beam: tilted by tilt_x_deg along its length and
    tilt_y_deg across. A horizontal step of the stage covers 1/cos(tilt) of the plate's
    surface, so the spot drifts ahead of the grid as the map goes on, and the beam sees
    the normal velocity times cos(tilt_x) cos(tilt_y). Default 1 degree along, assumed:
    a plate resting on foam (the paper's mounting is not described)."""

    name = "plate_tilt"
    defaults = {"tilt_x_deg": 1.0, "tilt_y_deg": 0.0}
    limits = {"tilt_x_deg": (-20.0, 20.0), "tilt_y_deg": (-20.0, 20.0)}
    stages = frozenset({"spot"})

    def spot(self, spot: Spot, directions: tuple[int, int]) -> Spot:
        cx, cy = math.cos(math.radians(self.parameters["tilt_x_deg"])), math.cos(math.radians(self.parameters["tilt_y_deg"]))
        return Spot(spot.x_mm / cx, spot.y_mm / cy, spot.beam_share * cx * cy)

