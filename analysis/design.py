"""What a plate design will need, predicted before it is built (`squeezebench design`).

Route (a), physics: the design's geometry and datasheets through the plate model
(`analysis.plate_modes`): the working (n, 0) mode, its modal mass and the powered piezos'
force factor referred to the plate's centre, and the one fitted figure, the build's
mechanical Q. At resonance the plate is a Butterworth-Van Dyke branch seen from the piezos:

    R = w M / Q                      mechanical resistance at the centre (N s/m)
    v_pp = A V_pp / R                velocity at the centre for a drive V (pp for pp)
    P = R (v_pp/2)^2 / 2 + w C0 tan(delta) (V_pp/2)^2 / 2      mechanical + dielectric
    I = (V_pp/2) |A^2/R + w C0 (tan(delta) + j)|               current amplitude

so the power at a given amplitude depends on mass, frequency and damping only, the
voltage for it on the coupling too. tan(delta) follows the NCE 41 datasheet between its
low-field value and its value at 400 V/mm, linear in the field amplitude.

Each result carries U (k = 2) from the material, geometry, piezo and damping tolerances
(rectangular half-widths of the design file), propagated by the law of propagation of
uncertainty with sensitivities from a solve at each input moved by its standard
uncertainty (GUM 5.1.3, numerically): the budget says which inputs dominate.

Route (b), the paper's method (Sec. 5): Q and tan(theta') measured on characterised small
plates of the same build, Q scaled to the design's piezo by Eq. 29, tan(theta') the mean of
the plates as thick as the resonator, then Eqs. 27 and 25 under the report's reading
(`report.REPORT_CONVENTION`), at the frequency and lambda/2 route (a) predicts.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from uncertainties import ufloat

from squeezebench.analysis import cartography, model, plate_modes, reduced_layouts
from squeezebench.analysis.design_file import DesignFile
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


class DesignError(UserError):
    """A design the model cannot answer for, with the reason and what to change."""


#: The inputs whose tolerances make the uncertainty: (name in `Tolerances`, what it moves,
#: whether moving it needs a new solve of the plate).
INPUTS = (
    ("young_pa", "resonator Young's modulus", True),
    ("density_kg_m3", "resonator density", True),
    ("thickness_m", "resonator thickness", True),
    ("d31_c_per_n", "piezo d31", False),
    ("relative_permittivity_t", "piezo permittivity (C0)", False),
    ("tan_delta", "piezo tan delta", False),
    ("mechanical_q", "mechanical Q of the build", False),
)


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
    (a tolerance moves frequencies, never the mode a design is built for)."""
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
    centre_share: float   # the centre's deflection over the mode's largest
    centre_to_antinode: float   # |centre's deflection| over the nearest antinode's on the centre line
    touch_x_m: np.ndarray = field(repr=False)
    touch_y_m: np.ndarray = field(repr=False)
    touch: np.ndarray = field(repr=False)   # deflection / centre's, on the touch grid


_STRUCTURAL = tuple(name for name, _, solve in INPUTS if solve)


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
    force = abs(float(modes.force_factor_n_per_v[k, modes.powered].sum()) / centre_share)
    if force == 0:
        raise DesignError(f"design {design.name!r}: the powered piezos' forces cancel on the "
                          f"{modes.frequencies_hz[k]:.0f} Hz mode; power groups on one side of a nodal line")
    return ModalPart(modes, k, geometry, mass_kg, force, centre_share, abs(centre_share) / np.abs(around).max(),
                     gx, gy, values.reshape(gx.shape) / centre_share)


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
        force_factor_n_per_v=modal.force_factor_n_per_v * f["d31_c_per_n"],
        mechanical_q=design.damping.mechanical_q * f["mechanical_q"],
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
UNCERTAIN = ("frequency_hz", "half_wavelength_mm", "modal_mass_g", "force_factor_n_per_v", "clamped_capacitance_nf",
             "k_eff", "velocity_pp_mps", "amplitude_pp_m", "voltage_vpp", "piezo_field_v_per_mm",
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


def predict_physics(design: DesignFile) -> PhysicsPrediction:
    """Route (a) with its budget: one solve at nominal, one per structural input moved by its
    standard uncertainty (t / sqrt 3 for a rectangular half-width t); the piezo's and the
    damping's inputs reuse the nominal solve."""
    modal = modal_part(design)
    nominal = operating_point(design, modal=modal)
    antinodes = nominal.values["interior_antinodes"]
    rows, perturbed = [], {}
    for name, label, structural in INPUTS:
        tolerance = design.damping.tolerance_rel if name == "mechanical_q" else design.tolerance(name)
        u_rel = tolerance / math.sqrt(3)
        if u_rel == 0:
            continue
        moved = modal_part(design, {name: 1 + u_rel}, antinodes=antinodes) if structural else modal
        point = operating_point(design, {name: 1 + u_rel}, modal=moved)
        perturbed[name] = point
        for output in UNCERTAIN:
            change = point.values[output] - nominal.values[output]
            rows.append({"output": output, "input": name, "input_label": label, "tolerance_rel": tolerance,
                         "input_u_rel": u_rel, "contribution": change, "contribution_abs": abs(change)})
    budget = pd.DataFrame(rows, columns=["output", "input", "input_label", "tolerance_rel", "input_u_rel",
                                         "contribution", "contribution_abs"])
    expanded = {output: COVERAGE_FACTOR * float(np.sqrt((budget.loc[budget["output"] == output, "contribution"] ** 2)
                                                        .sum()))
                for output in UNCERTAIN}
    return PhysicsPrediction(design, nominal, expanded, budget, perturbed)


# --- route (b): the paper's method from characterised small plates ---------------------------

@dataclass(frozen=True)
class PaperRoute:
    """Route (b)'s answer: Q and tan(theta') carried to the design, and what they give."""

    q: object   # uncertainties' ufloat
    tan_theta: object
    voltage_vpp: object
    power_w: object
    amplitude_pp_m: float
    template: str
    small_plates: tuple[str, ...]
    convention: model.Convention   # the reading the small plates were characterised and carried under
    geometry: model.PlateGeometry

    def power_at(self, voltage_vpp: np.ndarray, frequency_hz: float) -> tuple[np.ndarray, np.ndarray]:
        """Eq. 25 against voltage: nominal and U (k = 2) from Q and tan(theta')."""
        per_v2 = _eq25_per_v2(self.q, self.tan_theta, frequency_hz, self.geometry, self.convention)
        return (per_v2.nominal_value * np.asarray(voltage_vpp) ** 2,
                COVERAGE_FACTOR * per_v2.std_dev * np.asarray(voltage_vpp) ** 2)


def _eq25_per_v2(q, tan_theta, frequency_hz, geometry: model.PlateGeometry, convention: model.Convention):
    """Eq. 25's power per Vpp^2; linear in Q, tan(theta') and f, so ufloats pass through."""
    return q * tan_theta * frequency_hz * model.power_w(1.0, 1.0, 1.0, 1.0, geometry, convention)


def predict_from_small_plates(physics: PhysicsPrediction, plates: dict,
                              convention: model.Convention | None = None) -> PaperRoute:
    """Route (b) from `plates` (name -> `tables.PlateCharacterisation`, the small plates of
    one or more characterisation runs, characterised under `convention`: by default the
    report's reading; a plate as thick as the design is needed)."""
    from squeezebench.analysis.report import REPORT_CONVENTION
    from squeezebench.analysis.tables import LARGE_PLATE, mean_over_plates

    design, values = physics.design, physics.nominal.values
    convention = convention or REPORT_CONVENTION
    thickness_m = design.resonator.thickness_mm * 1e-3
    small = {n: p for n, p in plates.items() if n != LARGE_PLATE}
    same = {n: p for n, p in small.items()
            if math.isclose(p.geometry.resonator_thickness_m, thickness_m, rel_tol=1e-6)}
    if not same:
        found = ", ".join(f"{n} ({p.geometry.resonator_thickness_m * 1e3:g} mm)" for n, p in sorted(small.items()))
        raise DesignError(f"route (b) needs a characterised small plate {design.resonator.thickness_mm:g} mm thick "
                          f"like the design's resonator; the runs hold {found or 'none'}")
    b_design = design.piezo.width_y_mm * 1e-3
    template_name = design.from_small_plates.template_plate
    if template_name is not None:
        if template_name not in same:
            raise DesignError(f"from_small_plates.template_plate {template_name!r} is not among the characterised "
                              f"plates as thick as the design: {', '.join(sorted(same))}")
        template = same[template_name]
        q_small = ufloat(template.q.value, template.q.std_uncertainty)
        b_small = template.geometry.piezo_length_m
    else:
        mean_q = mean_over_plates(list(same.values()), "q")
        q_small = ufloat(mean_q.value, mean_q.std_uncertainty)
        b_small = float(np.mean([p.geometry.piezo_length_m for p in same.values()]))
        template_name = "mean of " + ", ".join(sorted(same))
    tan = mean_over_plates(list(same.values()), "tan_theta")
    q = q_small * model.q_large_from_small(1.0, b_design, b_small, as_printed=convention.eq29_as_printed)
    geometry = model.PlateGeometry(
        resonator_thickness_m=thickness_m, piezo_thickness_m=design.piezo.thickness_mm * 1e-3,
        piezo_length_m=b_design, half_wavelength_m=values["half_wavelength_mm"] * 1e-3,
        n_powered_piezos=design.n_powered_piezos, n_powered_groups=design.n_powered_groups)
    frequency = ufloat(values["frequency_hz"], physics.expanded["frequency_hz"] / COVERAGE_FACTOR)
    amplitude = values["amplitude_pp_m"]   # at the centre, where the paper's amplitudes are read
    tan_theta = ufloat(tan.value, tan.std_uncertainty)
    voltage = amplitude / (q * model.amplitude_pp_m(1.0, 1.0, geometry, convention))
    power = _eq25_per_v2(q, tan_theta, frequency, geometry, convention) * voltage**2
    return PaperRoute(q=q, tan_theta=tan_theta, voltage_vpp=voltage, power_w=power, amplitude_pp_m=amplitude,
                      template=template_name, small_plates=tuple(sorted(same)), convention=convention,
                      geometry=geometry)


# --- closing the loop: the built plate, measured -----------------------------------------------

@dataclass(frozen=True)
class Measured:
    plate: str
    frequency_hz: float
    voltage_vpp: object   # ufloat: the voltage the measured slope needs for the target amplitude
    power_w: object
    origin: str = ""   # provenance of the points: "measured" on a real bench, "simulated" or "predicted" on the simulated one


def measured_point(physics: PhysicsPrediction, built) -> Measured:
    """What a characterisation of the built plate (`tables.PlateCharacterisation`) says the
    design needs: the target's centre amplitude over the measured amplitude slope, and the
    measured power slope at that voltage."""
    amplitude_slope = ufloat(built.amplitude_slope.slope.value, built.amplitude_slope.slope.std_uncertainty)
    power_slope = ufloat(built.power_slope.slope.value, built.power_slope.slope.std_uncertainty)
    voltage = physics.nominal.values["amplitude_pp_m"] / amplitude_slope
    return Measured(built.plate, built.frequency_hz, voltage, power_slope * voltage**2, built.origin)


def comparison(physics: PhysicsPrediction, paper: PaperRoute | None, measured: Measured | None,
               printed: dict[str, float] | None = None) -> pd.DataFrame:
    """One row per quantity and source: value, U (k = 2), and against the reference (the
    measurement when there is one, else the printed value): deviation and whether the
    reference lies within the prediction's U."""
    v, U = physics.nominal.values, physics.expanded
    rows = [("frequency_hz", "physics (a)", v["frequency_hz"], U["frequency_hz"]),
            ("voltage_vpp", "physics (a)", v["voltage_vpp"], U["voltage_vpp"]),
            ("power_w", "physics (a)", v["power_w"], U["power_w"])]
    if paper is not None:
        rows += [("voltage_vpp", "small plates (b)", paper.voltage_vpp.nominal_value,
                  COVERAGE_FACTOR * paper.voltage_vpp.std_dev),
                 ("power_w", "small plates (b)", paper.power_w.nominal_value, COVERAGE_FACTOR * paper.power_w.std_dev)]
    reference = {}
    if measured is not None:
        reference = {"frequency_hz": (measured.frequency_hz, 0.0, f"measured ({measured.plate})"),
                     "voltage_vpp": (measured.voltage_vpp.nominal_value, COVERAGE_FACTOR * measured.voltage_vpp.std_dev,
                                     f"measured ({measured.plate})"),
                     "power_w": (measured.power_w.nominal_value, COVERAGE_FACTOR * measured.power_w.std_dev,
                                 f"measured ({measured.plate})")}
    elif printed:
        reference = {k: (value, 0.0, "printed in the paper") for k, value in printed.items()}
    out = []
    for quantity, source, value, u in rows:
        ref = reference.get(quantity)
        deviation = value / ref[0] - 1 if ref else math.nan
        within = bool(abs(value - ref[0]) <= math.hypot(u, ref[1])) if ref else None
        out.append({"quantity": quantity, "source": source, "value": value, "expanded_uncertainty": u,
                    "reference": ref[2] if ref else "", "reference_value": ref[0] if ref else math.nan,
                    "reference_expanded_uncertainty": ref[1] if ref else math.nan,
                    "deviation": deviation, "within_u": within})
    return pd.DataFrame(out)


@dataclass(frozen=True)
class DesignAnswer:
    """Everything `squeezebench design` found for one design file."""

    physics: PhysicsPrediction
    paper_route: PaperRoute | None = None
    paper_route_problem: str = ""   # why route (b) has no answer, when it has none
    measured: Measured | None = None
    printed: dict[str, float] | None = None   # the paper's values for this plate, when it is one of its plates
    layouts: pd.DataFrame | None = None
    layouts_note: str = ""   # how the layouts were solved (reduced model checked, or in full)
    #: every design this lab checked against its built plate (`designing.HISTORY_FILE`)
    history: pd.DataFrame | None = None

    @property
    def design(self) -> DesignFile:
        return self.physics.design

    def comparison(self) -> pd.DataFrame:
        return comparison(self.physics, self.paper_route, self.measured, self.printed)
