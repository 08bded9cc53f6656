"""What a plate design will need, predicted before it is built (`squeezebench design`).

Route (a), physics: the design's geometry and datasheets through the plate model
(`plates.plate_modes`): the working (n, 0) mode, its modal mass and the powered piezos'
force factor referred to the plate's centre, and the one fitted figure, the build's
mechanical Q. At resonance the plate is a Butterworth-Van Dyke branch seen from the piezos:

    R = w M / Q                      mechanical resistance at the centre (N s/m)
    v_pp = A V_pp / R                velocity at the centre for a drive V (pp for pp)
    P = R (v_pp/2)^2 / 2 + w C0 tan(delta) (V_pp/2)^2 / 2      mechanical + dielectric
    I = (V_pp/2) |A^2/R + w C0 (tan(delta) + j)|               current amplitude

so the power at a given amplitude depends on mass, frequency and damping only, the
voltage for it on the coupling too. tan(delta) follows the NCE 41 datasheet between its
low-field value and its value at 400 V/mm, linear in the field amplitude.

Each result carries U (k = 2) from the material, geometry, placement, piezo and damping
tolerances (rectangular half-widths of the design file), propagated by the law of
propagation of uncertainty with sensitivities from a solve at each input moved by its
standard uncertainty (GUM 5.1.3, numerically): the budget says which inputs dominate.

Where the piezos sit along the length decides the drive: near a free edge the mode's
curvature, which the piezos couple to, falls to zero. `placement_curve` solves the design
with its end groups at a range of distances from the edges, so a designer reads what moving
them does; `designing.verdict.judge` turns the answer into a verdict (feasible, marginal,
infeasible) against the amplifier, the ceramic's field limit and the coupling, naming the
nearest change that makes an infeasible design feasible.

Route (b), the paper's method (Sec. 5), is `designing.paper_route`: Q and tan(theta')
measured on characterised small plates of the same build, Q scaled to the design's piezo by
Eq. 29, tan(theta') the mean of the plates as thick as the resonator, then Eqs. 27 and 25
under the report's reading (`analysis.model.REPORT_CONVENTION`), at the frequency and
lambda/2 route (a) predicts. `designing.answer.DesignAnswer` holds both with the verdict.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np
import pandas as pd

from squeezebench.analysis import cartography
from squeezebench.plates import laminate, damping, plate_modes, predicted_plates, reduced_layouts, specifications
from squeezebench.designing.design_file import DesignFile
from squeezebench.errors import UserError


COVERAGE_FACTOR = 2.0


#: Whole width of the band of modes solved about a design's estimated frequency.
SEARCH_BAND_REL = 0.10


#: Touch-area grid for the homogeneity figures: points per half-wavelength along x.
TOUCH_POINTS_PER_HALF_WAVE = 8


#: A centre deflection below this share of the nearest antinode's (along the centre line,
#: within half a wavelength) is too close to a nodal line for a target "at the centre": the
#: prediction would hang on the node's exact place.
MIN_CENTRE_SHARE = 0.5


#: The powered piezos' net coupling to a mode (|sum of their force factors| over the sum of
#: their magnitudes) below which they cancel on it: the drive then hangs on the few per cent
#: by which the placement breaks the cancellation, and the voltage on nothing a lab controls.
MIN_COUPLING_SHARE = 0.1


#: Below this net coupling the powered piezos partly cancel: an answer, but a marginal one.
PARTIAL_COUPLING_SHARE = 0.5


class DesignError(UserError):
    """A design the model cannot answer for, with the reason and what to change."""


#: The inputs whose tolerances make the uncertainty: (name in `Tolerances`, what it moves,
#: whether moving it needs a new solve of the plate).
INPUTS = (
    ("young_pa", "resonator Young's modulus", True),
    ("density_kg_m3", "resonator density", True),
    ("thickness_m", "resonator thickness", True),
    ("placement_mm", "placement of the end piezos along the length", True),
    ("d31_c_per_n", "piezo d31", False),
    ("relative_permittivity_t", "piezo permittivity (C0)", False),
    ("tan_delta", "piezo tan delta", False),
    ("bond_loss_factor", "bond's loss factor (Q from physics)", False),
    ("mechanical_q", "mechanical Q of the build", False),
    # the force factor the paper's builds realise beyond the model's (`predicted_plates.drive_model_form`):
    # every design's voltage rests on the model's force factor, as their predictions did
    ("build_force_factor", "force factor of the build", False),
)


#: The label of the Q input when Q comes from the loss physics: what the model leaves out.
UNMODELLED_LOSS_LABEL = "mechanical Q: losses outside the loss model"
#: The label of the Q input when a stated Q spreads as the paper's builds' realised Q does.
PAPER_BUILDS_Q_LABEL = "mechanical Q of the build: the paper's builds' spread (log-normal; u of ln Q)"
#: The label of the force factor's model-form input (with spread: paper_builds).
PAPER_BUILDS_FORCE_LABEL = ("force factor of the build: what the paper's builds realise over the model's (log-normal; "
                            "u of ln A; measure the build's force factor to remove it)")


@dataclass(frozen=True)
class Lumped:
    """The plate at its working mode seen from the powered piezos, referred to the centre."""

    frequency_hz: float
    modal_mass_kg: float
    force_factor_n_per_v: float
    mechanical_q: float
    clamped_capacitance_f: float
    piezo_thickness_m: float
    tan_delta_low_field: float
    tan_delta_at_max_field: float
    max_field_v_per_m: float

    @property
    def omega(self) -> float:
        return 2 * math.pi * self.frequency_hz

    @property
    def resistance_ns_per_m(self) -> float:
        return self.omega * self.modal_mass_kg / self.mechanical_q

    def voltage_vpp_for(self, velocity_pp_mps: float) -> float:
        return velocity_pp_mps * self.resistance_ns_per_m / self.force_factor_n_per_v

    def velocity_pp_mps(self, voltage_vpp):
        return self.force_factor_n_per_v * np.asarray(voltage_vpp) / self.resistance_ns_per_m

    def field_v_per_m(self, voltage_vpp):
        return np.asarray(voltage_vpp) / 2 / self.piezo_thickness_m

    def tan_delta(self, voltage_vpp):
        """NCE 41 datasheet: linear in the field amplitude between its two stated points."""
        share = self.field_v_per_m(voltage_vpp) / self.max_field_v_per_m
        return self.tan_delta_low_field + (self.tan_delta_at_max_field - self.tan_delta_low_field) * share

    def mechanical_power_w(self, voltage_vpp):
        return 0.5 * self.resistance_ns_per_m * (self.velocity_pp_mps(voltage_vpp) / 2) ** 2

    def dielectric_power_w(self, voltage_vpp):
        v0 = np.asarray(voltage_vpp) / 2
        return 0.5 * self.omega * self.clamped_capacitance_f * self.tan_delta(voltage_vpp) * v0**2

    def current_pp_a(self, voltage_vpp):
        conductance = (self.force_factor_n_per_v**2 / self.resistance_ns_per_m
                       + self.omega * self.clamped_capacitance_f * self.tan_delta(voltage_vpp))
        susceptance = self.omega * self.clamped_capacitance_f
        return np.asarray(voltage_vpp) * np.hypot(conductance, susceptance)

    @property
    def k_eff(self) -> float:
        stiffness = self.modal_mass_kg * self.omega**2
        a2 = self.force_factor_n_per_v**2
        return math.sqrt(a2 / (stiffness * self.clamped_capacitance_f + a2))


@dataclass(frozen=True)
class OperatingPoint:
    """One solve's answer: the numbers of `values` and what the figures draw."""

    values: dict
    lumped: Lumped
    modes: plate_modes.PlateModes = field(repr=False)
    mode_index: int
    geometry: plate_modes.PlateGeometry = field(repr=False)


def _select_mode(modes: plate_modes.PlateModes, near_hz: float, antinodes: int | None) -> int:
    """The (n, 0) mode nearest `near_hz`; with `antinodes`, the one with that count if any
    (a tolerance moves frequencies, never the mode a design is built for). A mode is chosen
    by its count or by the frequency a designer asks for, never by a printed value."""
    k = modes.working_mode(near_hz)
    if antinodes is None or modes.interior_antinodes(k) == antinodes:
        return k
    same = [i for i in np.nonzero(modes.uniformity >= 0.8)[0] if modes.interior_antinodes(int(i)) == antinodes]
    return int(min(same, key=lambda i: abs(modes.frequencies_hz[i] - near_hz))) if same else k


def _touch_grid(design: DesignFile, half_wave_m: float) -> tuple[np.ndarray, np.ndarray]:
    (x0, x1), (y0, y1) = design.touch_area_mm
    step = half_wave_m * 1e3 / TOUCH_POINTS_PER_HALF_WAVE
    x = np.linspace(x0, x1, max(3, int(np.ceil((x1 - x0) / step)) + 1)) * 1e-3
    y = np.linspace(y0, y1, max(3, int(np.ceil((y1 - y0) / (2 * step))) + 1)) * 1e-3
    return np.meshgrid(x, y, indexing="ij")


def antinode_ratio(x_m: np.ndarray, profile: np.ndarray) -> float:
    """Weakest over strongest antinode of a profile along the length: the peak |value|
    between each pair of sign changes (whole half-waves only); 1 is a perfectly even plate."""
    crossings = np.nonzero(np.sign(profile[:-1]) * np.sign(profile[1:]) < 0)[0]
    peaks = [float(np.abs(profile[a + 1:b + 1]).max()) for a, b in zip(crossings[:-1], crossings[1:])]
    if len(peaks) < 2:
        return float("nan")
    return min(peaks) / max(peaks)


@dataclass(frozen=True)
class ModalPart:
    """What one solve of the plate gives a design: its working mode referred to the centre,
    and the mode's deflection over the touch area relative to the centre's."""

    modes: plate_modes.PlateModes = field(repr=False)
    mode_index: int
    geometry: plate_modes.PlateGeometry = field(repr=False)
    modal_mass_kg: float
    force_factor_n_per_v: float   # powered piezos, signed sum's magnitude, at nominal d31
    coupling_share: float   # |sum of the powered piezos' force factors| / sum of their magnitudes
    centre_share: float   # the centre's deflection over the mode's largest
    centre_to_antinode: float   # |centre's deflection| over the nearest antinode's on the centre line
    touch_x_m: np.ndarray = field(repr=False)
    touch_y_m: np.ndarray = field(repr=False)
    touch: np.ndarray = field(repr=False)   # deflection / centre's, on the touch grid
    loss_terms: dict = field(default_factory=dict)   # `damping.mode_loss_terms` at the nominal bond loss


#: The inputs `modal_part` scales by a factor (placement moves the groups instead).
_STRUCTURAL = tuple(name for name, _, solve in INPUTS if solve and name != "placement_mm")


def coupling_share(force_factors: np.ndarray) -> float:
    """|sum A_i| / sum |A_i| over the powered piezos' force factors on one mode: 1 when they
    all push the same way, 0 when they cancel."""
    total = float(np.abs(force_factors).sum())
    return abs(float(force_factors.sum())) / total if total > 0 else 0.0


def _mesh_half_wave_m(design: DesignFile) -> float:
    """One mesh for the design and its tolerance solves (sized on the nominal bare plate)."""
    return plate_modes.flexural_half_wavelength_m(design.resonator_material, design.resonator.thickness_mm * 1e-3,
                                                  design.search_hz)


def bare_plate(design: DesignFile) -> reduced_layouts.BarePlate:
    """What the design's layouts share, as `modal_part` solves them: the reduced model's key."""
    r = design.resonator
    return reduced_layouts.BarePlate(r.length_mm * 1e-3, r.width_mm * 1e-3, r.thickness_mm * 1e-3,
                                     design.resonator_material, design.piezo_material, design.search_hz,
                                     SEARCH_BAND_REL, mesh_half_wave_m=_mesh_half_wave_m(design))


def modal_part(design: DesignFile, factors: dict[str, float] | None = None,
               antinodes: int | None = None, solve=None) -> ModalPart:
    """Solve the design's plate with its structural inputs scaled by `factors`, by `solve`
    (`plate_modes.solve_plate` unless given: a layout sweep's reduced model)."""
    f = {name: 1.0 for name in _STRUCTURAL} | {k: v for k, v in (factors or {}).items() if k in _STRUCTURAL}
    resonator = design.resonator_material
    resonator = replace(resonator, young_pa=resonator.young_pa * f["young_pa"],
                        density_kg_m3=resonator.density_kg_m3 * f["density_kg_m3"])
    geometry = design.geometry(thickness_factor=f["thickness_m"])
    try:
        mesh_half_wave = _mesh_half_wave_m(design)
        # a design names its mode by antinode count, so +-5 % about the estimate is enough to
        # find it (the estimate is within about 1 % of the solved plate for the paper's plates)
        modes = (solve or plate_modes.solve_plate)(geometry, resonator, design.piezo_material,
                                                   near_hz=design.search_hz, mesh_half_wave_m=mesh_half_wave,
                                                   band_rel=SEARCH_BAND_REL)
        k = _select_mode(modes, design.search_hz, antinodes if antinodes is not None else design.mode.interior_antinodes)
    except ValueError:
        raise DesignError(f"design {design.name!r}: no mode near {design.search_hz:.0f} Hz keeps its nodal lines "
                          "straight across the width (the piezos mix the working mode with its neighbours)") from None
    xc, yc = geometry.length_m / 2, geometry.width_m / 2
    # the sampling follows the design's nominal length scale, not each solve's: plates that
    # share a mesh then share the evaluation of its elements at these points (plate_modes)
    half_wave = mesh_half_wave
    gx, gy = _touch_grid(design, half_wave)
    line = xc + np.linspace(-half_wave, half_wave, 41)   # 20 points each side: the centre is the middle one
    # one evaluation of the elements for the touch grid and the centre line (each call builds a probe)
    values = modes.shape_at(k, np.append(gx.ravel(), line), np.append(gy.ravel(), np.full(line.size, yc)))
    around = values[gx.size:]
    centre_share = float(around[20])
    values = values[:gx.size]
    if centre_share == 0:
        raise DesignError(f"design {design.name!r}: the plate's centre is on a nodal line of the "
                          f"{modes.frequencies_hz[k]:.0f} Hz mode")
    # referred to the centre from the mode's peak (where `modes` refers them): M / s^2, A / s
    mass_kg = float(modes.modal_mass_kg[k]) / centre_share**2
    powered_forces = modes.force_factor_n_per_v[k, modes.powered]
    force = abs(float(powered_forces.sum()) / centre_share)
    if force == 0:
        raise DesignError(f"design {design.name!r}: the powered piezos' forces cancel on the "
                          f"{modes.frequencies_hz[k]:.0f} Hz mode; power groups on one side of a nodal line")
    terms = damping.mode_loss_terms(modes, k, resonator, geometry.thickness_m, plate_modes.EPOXY.loss_factor)
    return ModalPart(modes, k, geometry, mass_kg, force, coupling_share(powered_forces), centre_share,
                     abs(centre_share) / np.abs(around).max(),
                     gx, gy, values.reshape(gx.shape) / centre_share, terms)


def physics_q(terms: dict, bond_factor: float = 1.0) -> float:
    """Q from the loss terms with the bond's loss factor scaled by `bond_factor`."""
    return damping.mechanical_q(terms | {"bond": terms["bond"] * bond_factor})


def operating_point(design: DesignFile, factors: dict[str, float] | None = None,
                    modal: ModalPart | None = None, solve=None) -> OperatingPoint:
    """The design's working point with each input scaled by `factors` (1 if absent); `modal`
    is the solve to use when only non-structural inputs move, `solve` the plate's solver."""
    f = {name: 1.0 for name, _, _ in INPUTS} | (factors or {})
    modal = modal or modal_part(design, f, solve=solve)
    modes, k = modal.modes, modal.mode_index
    frequency = float(modes.frequencies_hz[k])
    if design.target.at == "centre" and modal.centre_to_antinode < MIN_CENTRE_SHARE:
        raise DesignError(
            f"design {design.name!r}: the plate's centre sits near a nodal line of the {frequency:.0f} Hz mode "
            f"({modal.centre_to_antinode:.0%} of the nearest antinode's deflection): set target.at to touch_area")
    lumped = Lumped(
        frequency_hz=frequency, modal_mass_kg=modal.modal_mass_kg,
        force_factor_n_per_v=modal.force_factor_n_per_v * f["d31_c_per_n"] * f["build_force_factor"],
        mechanical_q=(physics_q(modal.loss_terms, f["bond_loss_factor"]) if design.damping.source == "physics"
                      else design.damping.mechanical_q) * f["mechanical_q"],
        clamped_capacitance_f=float(modes.clamped_capacitance_f[modes.powered].sum()) * f["relative_permittivity_t"],
        piezo_thickness_m=design.piezo.thickness_mm * 1e-3,
        tan_delta_low_field=design.piezo.tan_delta_low_field * f["tan_delta"],
        tan_delta_at_max_field=design.piezo.tan_delta_at_max_field * f["tan_delta"],
        max_field_v_per_m=design.piezo.max_field_v_per_mm * 1e3)
    touch = modal.touch
    touch_mean = float(np.abs(touch).mean())
    target_velocity = (design.target.velocity_pp_mps if design.target.velocity_pp_mps is not None
                       else design.target.amplitude_pp_m * lumped.omega)
    centre_velocity = target_velocity / touch_mean if design.target.at == "touch_area" else target_velocity
    voltage = lumped.voltage_vpp_for(centre_velocity)
    mechanical, dielectric = float(lumped.mechanical_power_w(voltage)), float(lumped.dielectric_power_w(voltage))
    current = float(lumped.current_pp_a(voltage))
    values = {
        "frequency_hz": frequency,
        "interior_antinodes": modes.interior_antinodes(k),
        "half_wavelength_mm": modes.half_wavelength_m(k) * 1e3,
        "modal_mass_g": modal.modal_mass_kg * 1e3,
        "plate_mass_g": modes.plate_mass_kg * 1e3,
        "force_factor_n_per_v": lumped.force_factor_n_per_v,
        "coupling_share": modal.coupling_share,
        "mechanical_q": lumped.mechanical_q,
        "physics_q": physics_q(modal.loss_terms),
        "clamped_capacitance_nf": lumped.clamped_capacitance_f * 1e9,
        "k_eff": lumped.k_eff,
        "velocity_pp_mps": centre_velocity,
        "amplitude_pp_m": centre_velocity / lumped.omega,
        "touch_mean_amplitude_pp_m": centre_velocity * touch_mean / lumped.omega,
        "voltage_vpp": voltage,
        "piezo_field_v_per_mm": float(lumped.field_v_per_m(voltage)) / 1e3,
        "tan_delta": float(lumped.tan_delta(voltage)),
        "mechanical_power_w": mechanical,
        "dielectric_power_w": dielectric,
        "power_w": mechanical + dielectric,
        "current_pp_a": current,
        "apparent_power_va": voltage * current / 8,   # (V/2)(I/2)/2: amplitudes
        "power_factor": (mechanical + dielectric) / (voltage * current / 8),
        "weakest_antinode_ratio": antinode_ratio(modal.touch_x_m[:, 0], touch.mean(axis=1)),
        "width_uniformity": cartography.width_uniformity(modal.touch_x_m.ravel(), touch.ravel()),
        "touch_coefficient_of_variation": cartography.homogeneity(touch).coefficient_of_variation,
    }
    return OperatingPoint(values, lumped, modes, k, modal.geometry)


#: The outputs an uncertainty is given for (the counts and the plate's mass are exact).
UNCERTAIN = ("frequency_hz", "half_wavelength_mm", "mechanical_q", "modal_mass_g", "force_factor_n_per_v",
             "clamped_capacitance_nf", "k_eff", "velocity_pp_mps", "amplitude_pp_m", "voltage_vpp", "piezo_field_v_per_mm",
             "mechanical_power_w", "dielectric_power_w", "power_w", "current_pp_a", "apparent_power_va",
             "weakest_antinode_ratio", "width_uniformity")


@dataclass(frozen=True)
class PhysicsPrediction:
    """Route (a): the nominal point, each output's U (k = 2) and the budget behind it."""

    design: DesignFile
    nominal: OperatingPoint
    expanded: dict[str, float]
    budget: pd.DataFrame   # one row per (output, input): the input's standard-uncertainty contribution
    perturbed: dict[str, OperatingPoint] = field(repr=False)

    def dominant(self, output: str) -> str:
        rows = self.budget[self.budget["output"] == output]
        return str(rows.loc[rows["contribution_abs"].idxmax(), "input_label"])

    def band(self, voltage_vpp: np.ndarray, quantity: str) -> tuple[np.ndarray, np.ndarray]:
        """`quantity` ('power_w' or 'velocity_pp_mps') against voltage, nominal and U (k = 2)."""
        def curve(point: OperatingPoint) -> np.ndarray:
            lumped = point.lumped
            if quantity == "power_w":
                return lumped.mechanical_power_w(voltage_vpp) + lumped.dielectric_power_w(voltage_vpp)
            return lumped.velocity_pp_mps(voltage_vpp)
        nominal = curve(self.nominal)
        spread = np.sqrt(sum((curve(p) - nominal) ** 2 for p in self.perturbed.values()))
        return nominal, COVERAGE_FACTOR * spread


def predict_physics(design: DesignFile, modal: ModalPart | None = None) -> PhysicsPrediction:
    """Route (a) with its budget: one solve at nominal (`modal`, when already solved), one per
    structural input moved by its standard uncertainty (t / sqrt 3 for a rectangular
    half-width t, t / sqrt 6 for the sheet's triangular thickness,
    `laminate.relative_standard_uncertainty`; the end groups moved inward together by the
    placement's); the piezo's and the damping's inputs reuse the nominal solve."""
    modal = modal or modal_part(design)
    nominal = operating_point(design, modal=modal)
    antinodes = nominal.values["interior_antinodes"]
    moves_placement = any(design.is_end_group(g) for g in design.groups)
    rows, perturbed = [], {}
    for name, label, structural in INPUTS:
        if name == "placement_mm":
            tolerance_mm = design.placement_tolerance_mm if moves_placement else 0.0
            tolerance, u_rel, u_mm = math.nan, math.nan, tolerance_mm / math.sqrt(3)
            if u_mm == 0:
                continue
            point = _placement_step(design, tolerance_mm, antinodes, nominal)
        elif name == "build_force_factor" or (name == "mechanical_q" and design.damping.spread == "paper_builds"):
            # the model-form term's two parts as two rows: the force factor's on every design (no
            # physics explains the builds' departure from the model's, docs/design.md), the Q's
            # where the Q is the builds'; their correlation (negative on Table 3) is left out,
            # which widens the voltage's U (it goes as 1 / (A Q))
            form = predicted_plates.drive_model_form()
            u_rel = form["u_q_ln"] if name == "mechanical_q" else form["u_force_factor_ln"]
            tolerance_mm, u_mm = math.nan, math.nan
            tolerance = predicted_plates.log_term_expanded_rel(u_rel)
            label = PAPER_BUILDS_Q_LABEL if name == "mechanical_q" else PAPER_BUILDS_FORCE_LABEL
            point = _log_normal_step(design, name, u_rel, modal, nominal)
        else:
            tolerance = _tolerance(design, name)
            tolerance_mm, u_mm = math.nan, math.nan
            if name == "mechanical_q" and design.damping.source == "physics":
                label = UNMODELLED_LOSS_LABEL
            u_rel = laminate.relative_standard_uncertainty(name, tolerance)   # the sheet's triangular
            if u_rel == 0:
                continue
            moved = modal_part(design, {name: 1 + u_rel}, antinodes=antinodes) if structural else modal
            point = operating_point(design, {name: 1 + u_rel}, modal=moved)
        perturbed[name] = point
        for output in UNCERTAIN:
            change = point.values[output] - nominal.values[output]
            rows.append({"output": output, "input": name, "input_label": label, "tolerance_rel": tolerance,
                         "input_u_rel": u_rel, "tolerance_mm": tolerance_mm, "input_u_mm": u_mm,
                         "contribution": change, "contribution_abs": abs(change)})
    budget = pd.DataFrame(rows, columns=["output", "input", "input_label", "tolerance_rel", "input_u_rel",
                                         "tolerance_mm", "input_u_mm", "contribution", "contribution_abs"])
    expanded = {output: COVERAGE_FACTOR * float(np.sqrt((budget.loc[budget["output"] == output, "contribution"] ** 2)
                                                        .sum()))
                for output in UNCERTAIN}
    return PhysicsPrediction(design, nominal, expanded, budget, perturbed)


def _tolerance(design: DesignFile, name: str) -> float:
    """A non-placement input's relative half-width: Q's from the damping, the bond's loss
    factor's from the model's specifications when Q comes from physics (else it moves nothing)."""
    if name == "mechanical_q":
        return design.damping.tolerance_rel
    if name == "bond_loss_factor":
        return specifications.MODEL_TOLERANCES["bond_loss_factor"].half_width if design.damping.source == "physics" else 0.0
    return design.tolerance(name)


def _log_normal_step(design: DesignFile, name: str, u_ln: float, modal: ModalPart,
                     nominal: OperatingPoint) -> OperatingPoint:
    """The working point with the input `name` (Q or the build's force factor) moved by one
    standard uncertainty `u_ln` of its logarithm, as `predicted_plates.log_term_expanded_rel`
    sizes a log-normal term: solved at exp(+k u) and exp(-k u) times it, each output's change
    taken from the side it moves more (the k-interval in ln mapped back, widened to the
    symmetric one) over k; the branch moved 1/k of the way to the upper value, on which a
    response at a given voltage (going as Q, or A) moves more."""
    up, down = (operating_point(design, {name: math.exp(sign * COVERAGE_FACTOR * u_ln)}, modal=modal)
                for sign in (1, -1))

    def moved(key: str) -> float:
        rise, fall = up.values[key] - nominal.values[key], down.values[key] - nominal.values[key]
        return nominal.values[key] + (rise if abs(rise) >= abs(fall) else fall) / COVERAGE_FACTOR
    values = {k: (moved(k) if k in UNCERTAIN else x) for k, x in up.values.items()}
    return replace(up, values=values, lumped=_scaled_lumped(nominal.lumped, up.lumped, 1 / COVERAGE_FACTOR))


def _placement_step(design: DesignFile, tolerance_mm: float, antinodes: int,
                    nominal: OperatingPoint) -> OperatingPoint:
    """The working point with the end groups moved inward by one standard uncertainty of
    the placement, u = t / sqrt 3, as a line through the solve at the whole half-width t
    (and 2 t if that fails): a step of a few tenths of a millimetre can land where two modes
    of the plate mix and none keeps straight nodal lines, which says nothing of the slope."""
    for step_mm in (tolerance_mm, 2 * tolerance_mm):
        moved = design.moved_inward(step_mm)
        try:
            point = operating_point(moved, modal=modal_part(moved, antinodes=antinodes))
        except DesignError:
            continue
        scale = 1 / math.sqrt(3) * tolerance_mm / step_mm
        values = {k: (nominal.values[k] + (x - nominal.values[k]) * scale if k in UNCERTAIN else x)
                  for k, x in point.values.items()}
        return replace(point, values=values, lumped=_scaled_lumped(nominal.lumped, point.lumped, scale))
    raise DesignError(f"design {design.name!r}: with the end piezos moved by the placement tolerance "
                      f"({tolerance_mm:g} or {2 * tolerance_mm:g} mm) no mode keeps its nodal lines straight across "
                      "the width: the placement decides the mode; state a tighter placement tolerance")


def _scaled_lumped(nominal: Lumped, moved: Lumped, scale: float) -> Lumped:
    """`nominal` moved toward `moved` by `scale` of the way, field by field (linear sensitivities)."""
    return Lumped(**{k: getattr(nominal, k) + (getattr(moved, k) - getattr(nominal, k)) * scale
                     for k in nominal.__dataclass_fields__})


#: Points of the placement curve between flush with the edges and half a wavelength in.
PLACEMENT_POINTS = 10
PLACEMENT_COLUMNS = ["edge_gap_mm", "frequency_hz", "interior_antinodes", "modal_mass_g", "force_factor_n_per_v",
                     "coupling_share", "mechanical_q", "physics_q", "voltage_vpp", "voltage_expanded_uncertainty",
                     "mechanical_power_w", "power_w", "piezo_field_v_per_mm", "why_not"]


def placement_range_mm(design: DesignFile, half_wavelength_mm: float) -> tuple[float, float]:
    """Where the end groups may go: from flush with the edges to half a wavelength in (past
    it the same curvature repeats with the next nodal line), within the outer quarters."""
    return 0.0, min(half_wavelength_mm, design.resonator.length_mm / 4 - design.piezo.length_x_mm / 2)


def placement_curve(physics: PhysicsPrediction, gaps_mm: np.ndarray | None = None,
                    mapper: Callable | None = None) -> pd.DataFrame:
    """The design solved with its end groups at each distance from the edges in `gaps_mm`
    (default `PLACEMENT_POINTS` over `placement_range_mm`), on the design's working mode:
    one row per distance, in order. The voltage's U there is the drawn design's relative U
    of every input but the placement (the placement is the axis). `mapper(function, items)`
    yields (item, result) pairs in any order (the parallel engine's map); default: here, in
    order."""
    design, values = physics.design, physics.nominal.values
    if gaps_mm is None:
        gaps_mm = np.linspace(*placement_range_mm(design, values["half_wavelength_mm"]), PLACEMENT_POINTS)
    rows = physics.budget[(physics.budget["output"] == "voltage_vpp") & (physics.budget["input"] != "placement_mm")]
    u_rel_others = COVERAGE_FACTOR * float(np.sqrt((rows["contribution"] ** 2).sum())) / values["voltage_vpp"]
    return placement_rows(design, values["interior_antinodes"], gaps_mm, u_rel_others, mapper)


def placement_rows(design: DesignFile, antinodes: int, gaps_mm, u_rel_others: float = 0.0,
                   mapper: Callable | None = None) -> pd.DataFrame:
    """`design` solved with its end groups at each distance from the edges in `gaps_mm` on
    its `antinodes` mode, one row per distance in order, the voltage's U the relative
    `u_rel_others` of it (`placement_curve`; the report's placement inference for the paper's
    large plate, `paper_placement.large_plate_placement_curve`, reads the same rows)."""
    tasks = [(design, antinodes, float(gap), u_rel_others) for gap in np.asarray(gaps_mm)]
    mapper = mapper or (lambda function, items: ((item, function(item)) for item in items))
    out = sorted((row for _, row in mapper(placement_point, tasks)), key=lambda row: row["edge_gap_mm"])
    return pd.DataFrame(out, columns=PLACEMENT_COLUMNS)


def placement_point(task: tuple[DesignFile, int, float, float]) -> dict:
    """One row of `placement_curve` (a parallel task): the design with its end groups
    `gap` mm from the edges on its `antinodes` mode; a distance the model cannot answer for
    says why instead."""
    design, antinodes, gap, u_rel_others = task
    row = {"edge_gap_mm": gap}
    try:
        moved = design.with_end_groups_at(gap)
        point = operating_point(moved, modal=modal_part(moved, antinodes=antinodes)).values
    except (DesignError, ValueError) as exc:
        return row | {"why_not": str(exc).split(": ", 1)[-1]}
    why = "" if point["interior_antinodes"] == antinodes else f"the mode found has {point['interior_antinodes']} antinodes"
    return (row | {k: point[k] for k in PLACEMENT_COLUMNS if k in point}
            | {"voltage_expanded_uncertainty": u_rel_others * point["voltage_vpp"], "why_not": why})


def mean_edge_gap_mm(design: DesignFile) -> float | None:
    """The end groups' mean distance from their edges (None without end groups)."""
    gaps = [design.edge_gap_mm(g) for g in design.groups if design.is_end_group(g)]
    return float(np.mean(gaps)) if gaps else None
