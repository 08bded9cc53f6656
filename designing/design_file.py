"""A plate to design, as a user draws it: the model of `squeezebench design PLATE.yaml`.

Resonator (material, dimensions), piezos (type, size, where each group sits and whether it
is powered), the working mode sought, the target (amplitude or velocity, peak-to-peak, at
the centre or over the touch area), the damping figure of the build, the amplifier's limits
and the tolerances the uncertainty comes from. Lengths in mm as a drawing gives them; every
other quantity in SI with its unit in its name. `squeezebench.schemas.load_design_file`
reads and validates a file with one-line messages (file, field, what is allowed).
"""
from __future__ import annotations

import re

from typing import Literal, Optional, Union

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from squeezebench.plates import laminate, plate_modes
from squeezebench.plates.specifications import sheet_thickness_tolerance

#: Materials a design may name instead of giving constants. aluminium_table2 is the paper's
#: Table 2 aluminium; al_6061_t6 the ASM datasheet of 6061-T6 (68.9 GPa, 0.33, 2700 kg/m^3).
RESONATOR_MATERIALS = {"aluminium_table2": plate_modes.ALUMINIUM_TABLE2,
                       "al_6061_t6": plate_modes.Isotropic(young_pa=68.9e9, poisson=0.33, density_kg_m3=2700.0)}
PIEZO_MATERIALS = {"NCE41": plate_modes.NCE41}
#: The names people write for them (compared without case, spaces, hyphens or underscores).
MATERIAL_ALIASES = {"aluminium": "aluminium_table2", "aluminum": "aluminium_table2", "al": "aluminium_table2",
                    "aluminiumtable2": "aluminium_table2", "al6061t6": "al_6061_t6", "6061t6": "al_6061_t6",
                    "aa6061t6": "al_6061_t6", "aluminium6061t6": "al_6061_t6", "nce41": "NCE41"}


#: How the guide and the messages name each material.
MATERIAL_WORDS = {"aluminium_table2": "aluminium (the paper's Table 2)", "al_6061_t6": "Al 6061-T6",
                  "NCE41": "NCE 41"}


def material_name(value, known: dict) -> object:
    """A material as written ("Al 6061-T6", "NCE 41") as its name in `known`; constants (a
    mapping) as they are; an unknown name is a ValueError naming what is accepted."""
    if not isinstance(value, str):
        return value
    name = MATERIAL_ALIASES.get(re.sub(r"[\s_-]", "", value.lower()), value)
    if name in known:
        return name
    constants = ", or give young_pa, poisson and density_kg_m3" if known is RESONATOR_MATERIALS else ""
    raise ValueError(f"unknown material {value!r}: name {' or '.join(MATERIAL_WORDS[k] for k in known)} (any "
                     f"case, spaces or hyphens){constants}")


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class IsotropicMaterial(_Model):
    young_pa: float = Field(gt=0)
    poisson: float = Field(gt=-1, lt=0.5)
    density_kg_m3: float = Field(gt=0)


class Resonator(_Model):
    material: Union[Literal["aluminium_table2", "al_6061_t6"], IsotropicMaterial] = "aluminium_table2"
    length_mm: float = Field(gt=0, le=2000)
    width_mm: float = Field(gt=0, le=2000)
    thickness_mm: float = Field(gt=0, le=50)

    _material = field_validator("material", mode="before")(lambda value: material_name(value, RESONATOR_MATERIALS))


class PiezoSpec(_Model):
    material: Literal["NCE41"] = "NCE41"
    _material = field_validator("material", mode="before")(lambda value: material_name(value, PIEZO_MATERIALS))
    length_x_mm: float = Field(gt=0, description="across the nodal lines (along the plate's length)")
    width_y_mm: float = Field(gt=0, description="along the nodal lines: the paper's b_p")
    thickness_mm: float = Field(gt=0, le=10)
    #: The field amplitude the design must stay under. Default: the highest field at which the
    #: NCE 41 datasheet states a loss (tan delta 0.020 at 400 V/mm); above it nothing is known.
    max_field_v_per_mm: float = Field(400.0, gt=0)
    #: tan delta at low field and at `max_field_v_per_mm` (NCE 41 datasheet): the dielectric
    #: loss is interpolated linearly in the field between them.
    tan_delta_low_field: float = Field(0.004, ge=0, lt=1)
    tan_delta_at_max_field: float = Field(0.020, ge=0, lt=1)


class Group(_Model):
    """Piezos bonded side by side across the width at one place along the length."""

    name: str = Field(min_length=1, max_length=100)   # a name in messages and tables, bounded as the design's
    x_mm: float = Field(ge=0, description="centre of the group's piezos along the length")
    y_mm: list[float] = Field(min_length=1, description="centre of each piezo across the width")
    powered: bool = True
    #: Half-width (rectangular) of where the bond puts the group along the length; default
    #: the design's bonding tolerance (`Tolerances.placement_mm`).
    x_tolerance_mm: Optional[float] = Field(None, ge=0, le=20)


class Mode(_Model):
    """The working (n, 0) mode: by its count of antinodes between the nodal lines (what a
    designer draws: lambda/2 = length / count), or the one nearest a frequency."""

    interior_antinodes: Optional[int] = Field(None, ge=1, le=200)
    near_hz: Optional[float] = Field(None, gt=1e3, lt=1e6)

    @model_validator(mode="after")
    def _one_way(self) -> "Mode":
        if (self.interior_antinodes is None) == (self.near_hz is None):
            raise ValueError("give exactly one of interior_antinodes or near_hz")
        return self


class Target(_Model):
    amplitude_pp_m: Optional[float] = Field(None, gt=0, lt=1e-3)
    velocity_pp_mps: Optional[float] = Field(None, gt=0, lt=100)
    at: Literal["centre", "touch_area"] = "centre"

    @model_validator(mode="after")
    def _one_quantity(self) -> "Target":
        if (self.amplitude_pp_m is None) == (self.velocity_pp_mps is None):
            raise ValueError("give exactly one of amplitude_pp_m or velocity_pp_mps")
        return self


class Damping(_Model):
    """The plate's mechanical loss: the build's stated Q (one figure shared by every plate of
    it), or Q from the physics of its losses (`plates.damping`: aluminium, ceramic Qm, bond,
    radiation into air, weighted by the mode's strain energy), when `source` is physics; then
    `tolerance_rel` is the spread of what the loss model leaves out and `mechanical_q` unused.
    A stated Q spreads by `tolerance_rel` (rectangular), or, with `spread: paper_builds` for a Q
    taken from a build of the paper, by what the paper's builds show of their realised Q
    (log-normal, sized on one build and judged on the others:
    `plates.predicted_plates.drive_model_form`; the force factor they realise over the
    model's is a term of every design's budget); then `tolerance_rel` is unused."""

    source: Literal["stated", "physics"] = "stated"
    mechanical_q: Optional[float] = Field(None, gt=1, lt=1e5)
    tolerance_rel: float = Field(0.3, ge=0, lt=1, description="half-width of a rectangular spread")
    spread: Literal["rectangular", "paper_builds"] = "rectangular"
    origin: str = Field(min_length=1)

    @model_validator(mode="after")
    def _stated_q_given(self) -> "Damping":
        if self.source == "stated" and self.mechanical_q is None:
            raise ValueError("give mechanical_q, or source: physics for Q from the plate's losses")
        if self.source == "physics" and self.spread == "paper_builds":
            raise ValueError("spread: paper_builds is the spread of a Q stated from the paper's builds; "
                             "with source: physics give tolerance_rel for the losses outside the model")
        return self


class Amplifier(_Model):
    max_output_vpp: float = Field(gt=0)
    max_current_app: Optional[float] = Field(None, gt=0)
    max_power_w: Optional[float] = Field(None, gt=0)


class TouchArea(_Model):
    x_mm: tuple[float, float]
    y_mm: tuple[float, float]


class Tolerances(_Model):
    """Half-widths of rectangular spreads, relative (datasheet and stock tolerances)."""

    young_pa: float = Field(laminate.RELATIVE_TOLERANCES["young_pa"], ge=0, lt=1)
    density_kg_m3: float = Field(laminate.RELATIVE_TOLERANCES["density_kg_m3"], ge=0, lt=1)
    thickness_m: Optional[float] = Field(None, ge=0, lt=1, description="default: the rolled sheet's "
                                         "(EN 485-4, specifications.sheet_thickness_tolerance)")
    d31_c_per_n: float = Field(laminate.RELATIVE_TOLERANCES["d31_c_per_n"], ge=0, lt=1)
    relative_permittivity_t: float = Field(laminate.RELATIVE_TOLERANCES["relative_permittivity_t"], ge=0, lt=1)
    tan_delta: float = Field(0.3, ge=0, lt=1)
    #: Bonding tolerance along the length (mm, rectangular half-width, absolute): where a hand
    #: with a paper template puts a piezo, for a group that states none.
    placement_mm: float = Field(0.5, ge=0, le=20)


class FromSmallPlates(_Model):
    """Route (b), the paper's method: which characterised small plate's Q Eq. 29 scales."""

    template_plate: Optional[str] = Field(None, min_length=1, max_length=100, pattern=r"^[A-Za-z0-9_.-]+$",
                                          description="a plate's name, as a run names it; default: the mean "
                                                      "over the small plates as thick as the resonator")
    origin: str = ""


class DesignFile(_Model):
    name: str = Field(min_length=1, max_length=100, pattern=r"^[A-Za-z0-9_.-]+$")   # a folder's name, as schemas.MAX_NAME_LENGTH
    description: str = ""
    resonator: Resonator
    piezo: PiezoSpec
    groups: list[Group] = Field(min_length=1)
    mode: Mode
    target: Target
    damping: Damping
    amplifier: Amplifier
    touch_area: Optional[TouchArea] = None
    tolerances: Tolerances = Tolerances()
    from_small_plates: FromSmallPlates = FromSmallPlates()
    #: One of the paper's plates (a name in data/paper/large_plate.csv) whose printed
    #: frequency, voltage and power the prediction is set beside.
    paper_plate: Optional[Literal["large_plate"]] = None
    #: Where each value comes from, by field (shown in the design report beside the assumptions).
    provenance: dict[str, str] = {}

    @model_validator(mode="after")
    def _fits_on_plate(self) -> "DesignFile":
        r = self.resonator
        if not any(g.powered for g in self.groups):
            raise ValueError("no group is powered: set powered: true on at least one")
        names = [g.name for g in self.groups]
        if len(set(names)) != len(names):
            raise ValueError(f"group names must differ: {names}")
        problem = self.geometry().layout_problem("group")   # within a group and across groups
        if problem:
            raise ValueError(problem)
        if self.touch_area is not None:
            (x0, x1), (y0, y1) = self.touch_area.x_mm, self.touch_area.y_mm
            if not (0 <= x0 < x1 <= r.length_mm and 0 <= y0 < y1 <= r.width_mm):
                raise ValueError(f"touch_area {self.touch_area.x_mm} x {self.touch_area.y_mm} mm must lie on the "
                                 f"plate (0 to {r.length_mm:g} x 0 to {r.width_mm:g} mm), lower bound first")
        return self

    @model_validator(mode="after")
    def _thickness_tolerance_known(self) -> "DesignFile":
        self.tolerance("thickness_m")   # unstated, the sheet's: the standard gives it only for some thicknesses
        return self

    # -- what the plate model reads ----------------------------------------------------
    def tolerance(self, name: str) -> float:
        """Input `name`'s relative half-width (`Tolerances`); the resonator's thickness, unless
        stated, its sheet's."""
        stated = getattr(self.tolerances, name)
        if stated is None:
            return sheet_thickness_tolerance(self.resonator.thickness_mm * 1e-3)
        return stated

    @property
    def placement_tolerance_mm(self) -> float:
        """The widest of the groups' placement tolerances: the budget moves every group
        together (one template or jig places them all), by this much."""
        return max(g.x_tolerance_mm if g.x_tolerance_mm is not None else self.tolerances.placement_mm
                   for g in self.groups)

    def edge_gap_mm(self, group: Group) -> float:
        """Distance from the group's piezos to the nearer end of the plate (0: flush)."""
        return min(group.x_mm, self.resonator.length_mm - group.x_mm) - self.piezo.length_x_mm / 2

    def is_end_group(self, group: Group) -> bool:
        """A group in an outer quarter of the length: what a placement along the length moves."""
        return min(group.x_mm, self.resonator.length_mm - group.x_mm) < self.resonator.length_mm / 4

    def with_end_groups_at(self, edge_gap_mm: float) -> "DesignFile":
        """The design with every end group `edge_gap_mm` from its end of the plate (each at
        its own end; groups nearer the middle stay)."""
        length, half_piezo = self.resonator.length_mm, self.piezo.length_x_mm / 2
        return self._end_groups_moved(lambda x: edge_gap_mm + half_piezo if x < length / 2
                                      else length - edge_gap_mm - half_piezo)

    def moved_inward(self, shift_mm: float) -> "DesignFile":
        """The design with every end group `shift_mm` nearer the middle of the length."""
        length = self.resonator.length_mm
        return self._end_groups_moved(lambda x: x + shift_mm if x < length / 2 else x - shift_mm)

    def _end_groups_moved(self, new_x_mm) -> "DesignFile":
        moved = [g.model_copy(update={"x_mm": new_x_mm(g.x_mm)}) if self.is_end_group(g) else g for g in self.groups]
        return DesignFile.model_validate({**self.model_dump(), "groups": [g.model_dump() for g in moved]})

    @property
    def resonator_material(self) -> plate_modes.Isotropic:
        m = self.resonator.material
        return RESONATOR_MATERIALS[m] if isinstance(m, str) else plate_modes.Isotropic(
            m.young_pa, m.poisson, m.density_kg_m3)

    @property
    def piezo_material(self) -> plate_modes.Piezo:
        return PIEZO_MATERIALS[self.piezo.material]

    def geometry(self, thickness_factor: float = 1.0) -> plate_modes.PlateGeometry:
        """The plate model's geometry (SI), the resonator's thickness scaled by `thickness_factor`."""
        mm, p = 1e-3, self.piezo
        patches = tuple(plate_modes.Patch(g.x_mm * mm, y * mm, p.length_x_mm * mm, p.width_y_mm * mm,
                                          p.thickness_mm * mm, g.powered, g.name)
                        for g in self.groups for y in g.y_mm)
        return plate_modes.PlateGeometry(self.resonator.length_mm * mm, self.resonator.width_mm * mm,
                                         self.resonator.thickness_mm * mm * thickness_factor, patches)

    @property
    def touch_area_mm(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """The touch area; by default the plate less a tenth of its length and width at each edge."""
        if self.touch_area is not None:
            return tuple(self.touch_area.x_mm), tuple(self.touch_area.y_mm)
        r = self.resonator
        return (r.length_mm / 10, r.length_mm * 0.9), (r.width_mm / 10, r.width_mm * 0.9)

    @property
    def search_hz(self) -> float:
        """Where the mode solver looks: `mode.near_hz`, or for a count of antinodes the bare
        plate's free-free beam estimate, bending waves of half-wavelength L / (n + 1/2) (beta L =
        (n + 1/2) pi, n antinodes between n + 1 nodal lines) in the model's thick plate
        (`plate_modes.flexural_frequency_hz`); the bonded piezos move it a few per cent, well
        inside the solver's band."""
        if self.mode.near_hz is not None:
            return self.mode.near_hz
        m, h, length = self.resonator_material, self.resonator.thickness_mm * 1e-3, self.resonator.length_mm * 1e-3
        return plate_modes.flexural_frequency_hz(m, h, length / (self.mode.interior_antinodes + 0.5))

    @property
    def n_powered_piezos(self) -> int:
        return sum(len(g.y_mm) for g in self.groups if g.powered)

    @property
    def n_powered_groups(self) -> int:
        return sum(1 for g in self.groups if g.powered)
