"""The paper's plates as the plate model sees them, and what it predicts beside the print.

Geometry from the paper's stated dimensions (data/paper/*.csv); materials the one shared
set of `plates.plate_modes` (Table 2 aluminium, NCE 41); no per-plate parameter. Where the
text does not say where a column sits, the assumption is stated beside it (`LAYOUTS`).
"""
from __future__ import annotations

import dataclasses
import functools
import math
from pathlib import Path

import numpy as np
import pandas as pd

from squeezebench.plates import laminate, plate_modes, specifications
from squeezebench.paper import paper_value

MM = 1e-3

#: Where the edge columns sit the paper does not say ("glued at the edges", Fig. 3; "at the four
#: corners", Sec. 5.2); its rule places them (`half_wave_edge_gap_mm`). How far an edge piezo
#: may sit from where the rule puts it (mm, rectangular half-width): hand bonding to a mark
#: (+-0.5 mm, as Table 3's column) and the rule's own ambiguity, the bare beam's nodal lines
#: against the loaded plate's (0.5 mm on Table 4's plate: its first half-wave's centre 6.3 mm
#: from the edge on the beam, 6.8 mm in the solve).
HALF_WAVE_TOLERANCE_MM = 1.0


@functools.cache   # 7 ms of beam shape a call, and a map plan builds the large plate 25 times
def half_wave_edge_gap_mm(length_mm: float, antinodes: int, piezo_x_mm: float) -> float:
    """The edge gap at which an end piezo `piezo_x_mm` long sits centred on the first half-wave
    from the free edge, between the first two nodal lines of the free-free beam mode of
    `antinodes` interior antinodes on a plate `length_mm` long (`plate_modes.free_free_beam_shape`,
    closed form; the nodes depend on the count and the length only). The paper's design rule,
    not a printed result: each piezo drives one half-wave section between nodal lines, its
    width "close to" lambda/2 (Sec. 2.2; Sec. 3.2's lambda/2 section, Eq. 26 zero at both its
    ends), and the large plate's lambda/2 was designed to its piezos (Sec. 5.2). Table 4's plate:
    3.80 mm (nodes 2.64 and 9.96 mm); the large plate: 4.26 mm (3.04 and 11.47 mm)."""
    beta_l = plate_modes.free_free_beam_roots(antinodes)[-1]
    x_mm = np.linspace(0.0, length_mm / 2, 100_001)
    nodes = plate_modes.sign_changes(x_mm, plate_modes.free_free_beam_shape(beta_l, length_mm, x_mm)[0])
    return float((nodes[0] + nodes[1]) / 2 - piezo_x_mm / 2)


#: The mode each plate is driven in, as the text describes the plate (never a printed
#: result): "All plates worked at the (9, 0) mode" (Sec. 2.1), the large plate's (21, 0)
#: mode (Sec. 5.3.1). A cut plate's mode is not stated as a design: it is the (n, 0) mode
#: its centre column drives nearest the uncut plate's (`_cut_plate_mode`).
STATED_ANTINODES = {"76 mm plates": 9, "large": 21}

#: Column layouts (x of each centred column's centre, mm) and why; the edge columns' place
#: follows from the mode (`half_wave_edge_gap_mm`).
LAYOUTS = {
    "table3": ((38.0,), "assumed: the one column sits mid-length, since the plate was cut "
                        "symmetrically to 28 mm and still driven (Sec. 2.3.1); at the centre's curvature "
                        "maximum its +-0.5 mm bonding tolerance moves nothing to first order (to second, "
                        "the force factor by about 3 %: 13 % at 1 mm, plates.drive_candidates)"),
    "table4": ((), "Fig. 3 caption: piezos glued at the edges; each edge piezo centred on the first half-wave "
                   f"from the edge (the paper's rule, half_wave_edge_gap_mm) +- {HALF_WAVE_TOLERANCE_MM:g} mm"),
    "large": ((), "Sec. 5.2: two piezos at each corner (along the short edges); each centred on the first "
                  f"half-wave from the edge (half_wave_edge_gap_mm) +- {HALF_WAVE_TOLERANCE_MM:g} mm"),
}


#: The paper's plates whose columns sit at the edges (`LAYOUTS` keys): where their sizes are
#: printed and the mode each is driven in.
EDGE_PLATES = {"table4": ("table4", "plate", STATED_ANTINODES["76 mm plates"]),
               "large": ("large_plate", "large_plate", STATED_ANTINODES["large"])}


def rule_edge_gap_mm(layout: str) -> float:
    """The edge gap the half-wave rule (`half_wave_edge_gap_mm`) gives the edge columns of the
    paper's plate `layout` ("table4" or "large", `EDGE_PLATES`): from its printed length and
    piezo width and its stated mode. The one way to the nominal gap: the plates are built at it
    and the placement's tolerance is taken about it."""
    source, item, antinodes = EDGE_PLATES[layout]
    return half_wave_edge_gap_mm(paper_value(source, item, "resonator_length_mm"), antinodes,
                                 paper_value(source, item, "piezo_width_mm"))


def _columns(x_mm: tuple[float, ...], width_mm: float, per: int, powered: int) -> tuple:
    patches = ()
    for i, x in enumerate(x_mm):
        patches += plate_modes.column(x * MM, width_mm * MM, 5 * MM, 9 * MM, 0.5 * MM, per,
                                      powered=i < powered, name=f"column {i + 1}")
    return patches


def table3_plate(label: str) -> plate_modes.PlateGeometry:
    length = paper_value("table3", "plate", "resonator_length_mm")
    width = paper_value("table3", "plate", "resonator_width_mm")
    plate = plate_modes.PlateGeometry(length * MM, width * MM,
                                      paper_value("table3", "plate", "resonator_thickness_mm") * MM,
                                      _columns(LAYOUTS["table3"][0], width, 4, 1))
    return plate.cut_to(float(label) * MM)


def table4_plate(label: str, edge_gap_mm: float | None = None) -> plate_modes.PlateGeometry:
    """Table 4's plate `label`, its edge columns `edge_gap_mm` from the edges (None: the
    half-wave rule's, `rule_edge_gap_mm`)."""
    width = paper_value("table4", "plate", "resonator_width_mm")
    length = paper_value("table4", "plate", "resonator_length_mm")
    piezo_x = paper_value("table4", "plate", "piezo_width_mm")
    if edge_gap_mm is None:
        edge_gap_mm = rule_edge_gap_mm("table4")
    n_columns = int(paper_value("table4", label, "n_columns"))
    xs = (edge_gap_mm + piezo_x / 2, length - edge_gap_mm - piezo_x / 2)
    return plate_modes.PlateGeometry(
        length * MM, width * MM, paper_value("table4", "plate", "resonator_thickness_mm") * MM,
        _columns(xs[:n_columns], width, 4, int(paper_value("table4", label, "n_powered_columns"))))


def large_plate(edge_gap_mm: float | None = None) -> plate_modes.PlateGeometry:
    """The large plate, its corner piezos `edge_gap_mm` from the short edges (None: the
    half-wave rule's, `rule_edge_gap_mm`)."""
    q = lambda name: paper_value("large_plate", "large_plate", name)  # noqa: E731
    width, length, piezo_x = q("resonator_width_mm"), q("resonator_length_mm"), q("piezo_width_mm")
    if edge_gap_mm is None:
        edge_gap_mm = rule_edge_gap_mm("large")
    patches = tuple(plate_modes.Patch(x * MM, y * MM, piezo_x * MM,
                                      q("piezo_length_mm") * MM, q("piezo_thickness_mm") * MM, True, "corner")
                    for x in (edge_gap_mm + piezo_x / 2, length - edge_gap_mm - piezo_x / 2)
                    for y in (7.0, 21.0, width - 21.0, width - 7.0))
    return plate_modes.PlateGeometry(length * MM, width * MM, q("resonator_thickness_mm") * MM, patches)


#: The one damping figure, shared by every aluminium plate on its cushion: the paper's only
#: damping measurement that is not itself a compared result, the Fig. 2c stress case (37.6 V
#: at 37180 Hz and 240 V at 37560 Hz give the same velocity, so |Z(37560)|/R = 240/37.6 ->
#: q_mech = 310; Sec. 2.2). Within the plausible range for aluminium in air (hundreds to ~2000).
#: `plates.damping` predicts each plate's Q from its losses instead (`loss_budget`).
MECHANICAL_Q = 310.0


#: How far one plate's mechanical Q may stray from the build's `MECHANICAL_Q` (rectangular
#: half-width; the design file's default spread, designing.design_file).
MECHANICAL_Q_TOLERANCE = 0.30


def _u(name: str, tolerances: dict[str, float]) -> float:
    return laminate.relative_standard_uncertainty(name, tolerances[name])


def frequency_relative_u(thickness_m: float) -> float:
    """Expanded (k = 2) relative uncertainty of a predicted frequency of a plate of nominal
    `thickness_m` from the sheet's and the alloy family's tolerances (f ~ h sqrt(E / rho);
    `laminate.relative_tolerances`, the thickness triangular). A plate's own terms (bond,
    placement) are added by `_predictions`."""
    t = laminate.relative_tolerances(thickness_m)
    return 2 * math.sqrt(_u("thickness_m", t) ** 2 + (_u("young_pa", t) / 2) ** 2
                         + (_u("density_kg_m3", t) / 2) ** 2)


def response_relative_u(thickness_m: float) -> dict[str, float]:
    """Expanded (k = 2) relative uncertainty of the predicted velocity and power at resonance at
    a given voltage of a plate of nominal `thickness_m`, in closed form from the tolerances
    (`laminate.relative_tolerances`, the thickness triangular, the rest rectangular):
    v = F V q / (w M) and P = F^2 V^2 q / (2 w M), with F proportional to d31 and w M to
    h^2 sqrt(E rho) (f ~ h sqrt(E / rho), M ~ rho h); the force factor's own dependence on the
    resonator (the piezo's lever arm about the neutral axis) is left out, and a plate's own
    terms (bond, placement) are added by `_predictions`."""
    t = laminate.relative_tolerances(thickness_m)
    u = {name: _u(name, t) for name in t}
    u_q = MECHANICAL_Q_TOLERANCE / math.sqrt(3)
    u_omega_mass = math.hypot(2 * u["thickness_m"], u["young_pa"] / 2, u["density_kg_m3"] / 2)
    # the amplitude v / w = F V q / (w^2 M), w^2 M ~ E h^3
    u_omega2_mass = math.hypot(3 * u["thickness_m"], u["young_pa"])
    return {"velocity_pp_mps": 2 * math.hypot(u["d31_c_per_n"], u_q, u_omega_mass),
            "amplitude_pp_m": 2 * math.hypot(u["d31_c_per_n"], u_q, u_omega2_mass),
            "power_w": 2 * math.hypot(2 * u["d31_c_per_n"], u_q, u_omega_mass),
            # at a given velocity P = w M v0^2 / (2 q): the force factor (d31) drops out
            "power_at_velocity_w": 2 * math.hypot(u_q, u_omega_mass),
            # tan theta' inverted through Eqs. 27 and 25 goes as P / (A f) ~ F: q, M and w cancel
            "tan_theta": 2 * u["d31_c_per_n"]}


def bond_effectiveness_range(geometry: plate_modes.PlateGeometry) -> tuple[float, float, float]:
    """The first patch's shear-lag effectiveness eta at the bond's nominal and at the two ends
    of its stated tolerances (thicker and softer: the least; thinner and stiffer: the most)."""
    t = laminate.RELATIVE_TOLERANCES
    p, bond = geometry.patches[0], plate_modes.EPOXY

    def eta(scale_t: float, scale_g: float) -> float:
        moved = dataclasses.replace(bond, thickness_m=bond.thickness_m * scale_t,
                                    shear_modulus_pa=bond.shear_modulus_pa * scale_g)
        return laminate.shear_lag_effectiveness(plate_modes.ALUMINIUM_TABLE2, geometry.thickness_m,
                                                   plate_modes.NCE41, p.thickness_m, moved, p.length_x_m)

    lo_t, lo_g = 1 + t["bond_thickness_m"], 1 - t["bond_shear_modulus_pa"]
    return eta(1, 1), eta(lo_t, lo_g), eta(2 - lo_t, 2 - lo_g)


def response_per_volt(frequency_hz: float, modal_mass_kg: float, force_factor_n_per_v: float,
                      mechanical_q: float | None = None) -> dict[str, float]:
    """A plate at resonance per volt of drive, with the build's one `MECHANICAL_Q` unless
    `mechanical_q` is given (a one-degree-of-freedom resonator referred to the point its modal
    mass and force factor A are referred to): mechanical resistance R = w M / q, velocity pp
    per Vpp |A| / R, amplitude pp per Vpp |A| / (R w), power per Vpp^2 R (|A| / (2 R))^2 / 2
    (the velocity amplitude is half its pp)."""
    omega = 2 * math.pi * frequency_hz
    resistance = omega * modal_mass_kg / (mechanical_q or MECHANICAL_Q)
    velocity_pp = abs(force_factor_n_per_v) / resistance
    return {"frequency_hz": frequency_hz, "velocity_pp_mps_per_vpp": velocity_pp,
            "amplitude_pp_m_per_vpp": velocity_pp / omega,
            "power_w_per_vpp2": 0.5 * resistance * (velocity_pp / 2) ** 2}


def paper_plates():
    """Each paper plate the model predicts: (table, item, label, geometry, edge placement or
    None (for the plates whose columns sit at an edge: the geometry as a function of the gap in
    mm, and the rule's gap it is built at, `rule_edge_gap_mm`), the stated antinodes or None
    for a cut plate)."""
    for label in ("75", "59", "28"):
        yield ("Table 3", label, f"{label} x 41 x 1 mm", table3_plate(label), None,
               STATED_ANTINODES["76 mm plates"] if label == "75" else None)
    for label in ("1-column", "2-columns 1 powered", "2-columns 2 powered"):
        yield ("Table 4", label, label, table4_plate(label),
               (functools.partial(table4_plate, label), rule_edge_gap_mm("table4")), STATED_ANTINODES["76 mm plates"])
    yield ("Sec. 5", "large_plate", "large plate 198 x 138 x 2 mm", large_plate(), (large_plate, rule_edge_gap_mm("large")),
           STATED_ANTINODES["large"])


def _search_hz(geometry: plate_modes.PlateGeometry, antinodes: int) -> float:
    """Where a plate's (n, 0) mode of `antinodes` interior antinodes is sought: the bare plate's
    bending-wave frequency at a half-wavelength of L / (n + 1/2) (a free end's node sits about a
    quarter wave in), from geometry and Table 2 only."""
    return plate_modes.flexural_frequency_hz(plate_modes.ALUMINIUM_TABLE2, geometry.thickness_m,
                                             geometry.length_m / (antinodes + 0.5))


def mode_with_antinodes(modes: plate_modes.PlateModes, antinodes: int, near_hz: float) -> int:
    """The (n, 0) mode with `antinodes` interior antinodes nearest `near_hz` (the family's
    neighbours have other counts, so `near_hz` only breaks a tie)."""
    family = [k for k in range(len(modes.frequencies_hz))
              if modes.uniformity[k] >= 0.6 and modes.interior_antinodes(k) == antinodes]
    if not family:
        raise ValueError(f"no (n, 0) mode with {antinodes} interior antinodes near {near_hz:.0f} Hz")
    return min(family, key=lambda k: abs(modes.frequencies_hz[k] - near_hz))


def _cut_plate_mode(modes: plate_modes.PlateModes, uncut_hz: float) -> int:
    """A cut plate's working mode: among its (n, 0) modes, those its powered column drives (at
    least a tenth of the best force factor: a centre column cannot drive an antisymmetric
    mode), the one nearest the uncut plate's working frequency (the bench's drive stays where
    it was; the same column, the same half-wavelength)."""
    family = np.nonzero(modes.uniformity >= 0.8)[0]
    force = np.abs(modes.force_factor_n_per_v[family][:, modes.powered].sum(axis=1))
    driven = family[force >= 0.1 * force.max()]
    return int(driven[np.argmin(abs(modes.frequencies_hz[driven] - uncut_hz))])


#: The modes a working mode is chosen among: those within this whole band (relative) about
#: where it is sought (`plate_modes.mode_count`), so a stated mode's estimate may miss by 15 %.
SEARCH_BAND_REL = 0.3
#: A stated mode is first sought among this many modes nearest its estimate (ARPACK's work
#: grows with the square of the modes asked for: the large plate's 71-mode band took 5.0
#: CPU-s, 12 modes 0.5 s, 6 modes 0.35 s), the band widened only if they do not show it
#: (`_shows_nearest`). Six show each paper plate's stated mode at once: its estimate is
#: within two of the plate's modes of it.
FIRST_MODES = 6


def _shows_nearest(modes: plate_modes.PlateModes, k: int, near_hz: float) -> bool:
    """Whether mode k is the (n, 0) mode of its count nearest `near_hz` among all the plate's
    modes, not only among those solved: the solve's modes are those nearest its shift, a run
    of the spectrum without a gap (and the thick-plate correction keeps their order), so every
    mode nearer `near_hz` than k is in it if the run reaches past k's distance on both sides."""
    distance = abs(modes.frequencies_hz[k] - near_hz)
    return bool(modes.frequencies_hz.min() < near_hz - distance and modes.frequencies_hz.max() > near_hz + distance)


def _solve_stated(geometry: plate_modes.PlateGeometry, antinodes: int, bond: laminate.Bond = plate_modes.EPOXY):
    """The plate's solution on `bond` and the index of its mode of `antinodes` stated antinodes
    (`mode_with_antinodes` about `_search_hz` among the modes of `SEARCH_BAND_REL`): the same
    mode as that band's solve gives, sought in `FIRST_MODES` modes and twice as many until they
    show it (`_shows_nearest`), the whole band the last resort."""
    near = _search_hz(geometry, antinodes)
    band = plate_modes.mode_count(geometry, plate_modes.ALUMINIUM_TABLE2, plate_modes.NCE41, near, SEARCH_BAND_REL)
    n_modes = min(FIRST_MODES, band)
    while n_modes < band:
        modes = plate_modes.solve_plate(geometry, near_hz=near, n_modes=n_modes, bond=bond)
        try:
            k = mode_with_antinodes(modes, antinodes, near)
        except ValueError:   # none of that count in view yet
            k = None
        if k is not None and _shows_nearest(modes, k, near):
            return modes, k
        n_modes = min(2 * n_modes, band)
    modes = plate_modes.solve_plate(geometry, near_hz=near, n_modes=band, bond=bond)
    return modes, mode_with_antinodes(modes, antinodes, near)


def _solve_working(geometry: plate_modes.PlateGeometry, antinodes: int | None, uncut_hz: float | None):
    """The plate's solution and its working mode's index (`_solve_stated`, or for a cut plate
    `_cut_plate_mode` among the modes of `SEARCH_BAND_REL` about the uncut plate's)."""
    if antinodes is not None:
        return _solve_stated(geometry, antinodes)
    modes = plate_modes.solve_plate(geometry, near_hz=uncut_hz, band_rel=SEARCH_BAND_REL)
    return modes, _cut_plate_mode(modes, uncut_hz)


def centre_response(geometry: plate_modes.PlateGeometry, antinodes: int,
                    bond: laminate.Bond = plate_modes.EPOXY) -> dict[str, float]:
    """`geometry`'s mode with `antinodes` interior antinodes on `bond` (the epoxy every paper
    plate is glued with, unless a candidate cause tries another: `drive_candidates`), referred
    to its centre (`_at_centre`)."""
    return _at_centre(geometry, *_solve_stated(geometry, antinodes, bond))


def _at_centre(geometry, modes, k) -> dict[str, float]:
    """Frequency, modal mass and powered force factor referred to the plate's centre (where the
    paper measured, Sec. 2.3.1)."""
    mass_kg, forces = modes.referred_to(k, geometry.length_m / 2, geometry.width_m / 2)
    return {"frequency_hz": float(modes.frequencies_hz[k]), "modal_mass_kg": mass_kg,
            "force_factor_n_per_v": abs(float(forces[modes.powered].sum()))}


@functools.cache
def _predictions() -> pd.DataFrame:
    """Per plate and per volt, from geometry, the stated modes and the datasheets only: no
    printed result, voltage or frequency is read (tests/test_predicted_plates.py perturbs each)."""
    from squeezebench.plates import damping

    out = []
    uncut_hz = None
    for table, item, plate_label, geometry, placement, antinodes in paper_plates():
        modes, k = _solve_working(geometry, antinodes, uncut_hz)
        if table == "Table 3" and antinodes is not None:
            uncut_hz = float(modes.frequencies_hz[k])
        nominal = _at_centre(geometry, modes, k)
        f = nominal["frequency_hz"]
        # bond: the patches' added stiffness and moment scale with eta (Rayleigh: d ln w^2 = S_p d ln eta)
        eta, eta_lo, eta_hi = bond_effectiveness_range(geometry)
        span = (eta_hi - eta_lo) / eta
        u_bond_f = 0.5 * float(modes.piezo_energy_share[k]) * span / (2 * math.sqrt(3))
        u_bond_force = span / (2 * math.sqrt(3))
        u_place = {"frequency_hz": 0.0, "force_factor_n_per_v": 0.0, "modal_mass_kg": 0.0}
        if placement is not None:   # the edge gap's ends, each solved (the force factor is far from linear in it)
            at_gap, gap = placement
            ends = [centre_response(at_gap(gap + side * HALF_WAVE_TOLERANCE_MM), antinodes) for side in (-1, 1)]
            u_place = {q: abs(ends[1][q] - ends[0][q]) / nominal[q] / (2 * math.sqrt(3)) for q in u_place}
        # a cut plate's length is the cut's (Table 3's plates; the others are stated sheets): a
        # free-free mode of a given count rings at (beta_n / L)^2, so d ln f / d ln L = -2
        cut_mm = specifications.cut_length_tolerance_mm(geometry.length_m / MM) if table == "Table 3" else 0.0
        u_cut_f = 2 * cut_mm * MM / geometry.length_m / math.sqrt(3)
        u_f = math.hypot(frequency_relative_u(geometry.thickness_m) / 2, u_bond_f, u_place["frequency_hz"], u_cut_f)
        base = response_relative_u(geometry.thickness_m)
        u_drive = math.hypot(u_bond_force, u_place["force_factor_n_per_v"], u_place["modal_mass_kg"])
        terms = damping.mode_loss_terms(modes, k, plate_modes.ALUMINIUM_TABLE2, geometry.thickness_m,
                                        plate_modes.EPOXY.loss_factor)
        response = response_per_volt(f, nominal["modal_mass_kg"], nominal["force_factor_n_per_v"])
        out.append({"table": table, "item": item, "plate": plate_label,
                    "resonator_thickness_mm": geometry.thickness_m / MM, "predicted_frequency_hz": f,
                    "predicted_frequency_u_hz": f * 2 * u_f,
                    "kirchhoff_frequency_hz": float(modes.kirchhoff_frequencies_hz[k]),
                    "frequency_u_bond_rel": 2 * u_bond_f, "frequency_u_placement_rel": 2 * u_place["frequency_hz"],
                    "cut_length_tolerance_mm": cut_mm,
                    # the cut's term alone, k for 95 % of its rectangle (0.95 sqrt 3)
                    "frequency_u_cut_length_rel": 0.95 * math.sqrt(3) * u_cut_f,
                    "predicted_antinodes": modes.interior_antinodes(k),
                    "predicted_half_wavelength_mm": modes.half_wavelength_m(k) * 1e3,
                    "modal_mass_g": nominal["modal_mass_kg"] * 1e3,
                    "force_factor_n_per_v": nominal["force_factor_n_per_v"],
                    "clamped_capacitance_f": float(modes.clamped_capacitance_f[modes.powered].sum()),
                    "force_factor_u_placement_rel": 2 * u_place["force_factor_n_per_v"],
                    "bond_effectiveness": eta, "piezo_energy_share": float(modes.piezo_energy_share[k]),
                    "drive_u_rel": 2 * u_drive,
                    "velocity_pp_mps_per_vpp": response["velocity_pp_mps_per_vpp"],
                    "velocity_u_rel": 2 * math.hypot(base["velocity_pp_mps"] / 2, u_drive),
                    "power_w_per_vpp2": response["power_w_per_vpp2"],
                    "power_u_rel": 2 * math.hypot(base["power_w"] / 2, 2 * u_drive),
                    "power_at_velocity_u_rel": 2 * math.hypot(base["power_at_velocity_w"] / 2, u_place["modal_mass_kg"]),
                    "damping_q": damping.mechanical_q(terms),
                    **{f"loss_{name}": value for name, value in terms.items()}})
    return pd.DataFrame(out)


def _printed(table: str, item: str) -> dict:
    """The printed values a prediction is set beside (and the drive voltage it is evaluated at)."""
    if table == "Sec. 5":
        q = lambda name: paper_value("large_plate", "large_plate", name)  # noqa: E731
        return {"printed_frequency_hz": q("frequency_hz"), "printed_antinodes": 21,
                "printed_half_wavelength_mm": q("half_wavelength_mm"), "voltage_vpp": q("voltage_vpp"),
                "printed_velocity_pp_mps": np.nan, "printed_power_w": q("power_w")}
    name = "table3" if table == "Table 3" else "table4"
    q = lambda quantity, row=item: paper_value(name, row, quantity)  # noqa: E731
    return {"printed_frequency_hz": q("frequency_hz"),
            "printed_antinodes": int(q("n_antinodes") if name == "table3" else q("n_antinodes", "plate")),
            "printed_half_wavelength_mm": np.nan, "voltage_vpp": q("voltage_vpp"),
            "printed_velocity_pp_mps": q("velocity_pp_mps"), "printed_power_w": q("power_w")}


def _at_printed_drive() -> pd.DataFrame:
    """Each plate's model at its printed drive voltage, beside the print: frequency, antinodes,
    spacing, velocity and the input power at resonance, with their U (k = 2) from the stated
    tolerances only (sheet, alloy, bond, placement, the build's Q spread). The input power is
    the mechanical power with the one shared `MECHANICAL_Q` plus the powered piezos' dielectric
    loss (`damping.dielectric_power_w`, NCE 41's low-field tan delta): the paper's oscilloscope
    read the electrical power in (Sec. 2.1), and Sec. 2.2 places the dielectric part there."""
    from squeezebench.plates import damping

    rows = []
    for row in _predictions().to_dict("records"):
        printed = _printed(row["table"], row["item"])
        v = printed["voltage_vpp"]
        velocity, mechanical = row["velocity_pp_mps_per_vpp"] * v, row["power_w_per_vpp2"] * v**2
        dielectric = damping.dielectric_power_w(row["predicted_frequency_hz"], row["clamped_capacitance_f"], v,
                                                plate_modes.NCE41.tan_delta)
        rows.append({"table": row["table"], "item": row["item"], "plate": row["plate"],
                     "resonator_thickness_mm": row["resonator_thickness_mm"],
                     "predicted_frequency_hz": row["predicted_frequency_hz"],
                     "predicted_frequency_u_hz": row["predicted_frequency_u_hz"],
                     "printed_frequency_hz": printed["printed_frequency_hz"],
                     "frequency_deviation": row["predicted_frequency_hz"] / printed["printed_frequency_hz"] - 1,
                     "predicted_antinodes": row["predicted_antinodes"],
                     "printed_antinodes": printed["printed_antinodes"],
                     "predicted_half_wavelength_mm": row["predicted_half_wavelength_mm"],
                     "printed_half_wavelength_mm": printed["printed_half_wavelength_mm"],
                     "voltage_vpp": v, "predicted_velocity_pp_mps": velocity,
                     "velocity_u_tolerances_rel": row["velocity_u_rel"],
                     "printed_velocity_pp_mps": printed["printed_velocity_pp_mps"],
                     "predicted_mechanical_power_w": mechanical, "predicted_dielectric_power_w": dielectric,
                     "predicted_power_w": mechanical + dielectric,
                     # the dielectric term's own tolerance (tan delta) is left out: it is under 1 % of the power
                     "power_u_tolerances_rel": row["power_u_rel"] * mechanical / (mechanical + dielectric),
                     "printed_power_w": printed["printed_power_w"]})
    frame = pd.DataFrame(rows)
    velocity = [printed_velocity_pp_mps(row.table, row.item, row.predicted_frequency_hz) for row in frame.itertuples()]
    frame["predicted_power_at_printed_velocity_w"] = (
        frame["predicted_mechanical_power_w"] * (velocity / frame["predicted_velocity_pp_mps"]) ** 2
        + frame["predicted_dielectric_power_w"])
    frame["power_at_velocity_u_tolerances_rel"] = _predictions()["power_at_velocity_u_rel"].to_numpy()
    return frame


#: The build the drive's model-form term is sized on (`drive_model_form`); the others judge it
#: (`drive_cross_check`). Table 3: the build the shared `MECHANICAL_Q` comes from (Fig. 2c).
DRIVE_FIT_ON = "Table 3"
#: The builds, each one plate set of one make: the plates of a build share a sheet, a bond and
#: a bench (Table 3: one 1 mm plate cut down; Table 4: 1.2 mm edge columns; the large plate).
DRIVE_BUILDS = ("Table 3", "Table 4", "Sec. 5")


def printed_velocity_pp_mps(table: str, item: str, frequency_hz: float) -> float:
    """A plate's printed centre velocity pp; for the large plate, which prints none, its stated
    amplitude ("above 1 um", Sec. 5.3.2) read as pp, times w at `frequency_hz`."""
    if table == "Sec. 5":
        return 2 * math.pi * frequency_hz * paper_value("large_plate", "large_plate", "amplitude_m")
    return _printed(table, item)["printed_velocity_pp_mps"]


def drive_mismatch() -> pd.DataFrame:
    """Per paper plate, what its printed velocity and power say of the model's drive: the force
    factor and the Q the bench realised over the model's (its force factor at the nominal
    placement and bond, the shared `MECHANICAL_Q`), as logarithms. At resonance v = A V Q / (w M)
    and P_mech = A^2 V^2 Q / (2 w M), so with the model's v and P_mech: ln(A_bench / A) =
    ln(P_mech,printed / P_mech) - ln(v_printed / v) and ln(Q_bench / Q) = 2 ln(v_printed / v) -
    ln(P_mech,printed / P_mech), the printed mechanical power being the printed input power less
    the predicted dielectric loss. The large plate's velocity is its stated 1 um read as pp
    (`printed_velocity_pp_mps`). The modal mass is the model's (issue 45's review: within 1 %)."""
    frame = _at_printed_drive()
    velocity = np.array([printed_velocity_pp_mps(row.table, row.item, row.predicted_frequency_hz)
                         for row in frame.itertuples()])
    ln_v = np.log(velocity / frame["predicted_velocity_pp_mps"])
    ln_p = np.log((frame["printed_power_w"] - frame["predicted_dielectric_power_w"]) / frame["predicted_mechanical_power_w"])
    return pd.DataFrame({"table": frame["table"], "item": frame["item"],
                         "ln_force_factor_ratio": ln_p - ln_v, "ln_q_ratio": 2 * ln_v - ln_p})


def drive_model_form(fit_on: str = DRIVE_FIT_ON) -> dict[str, float]:
    """The drive's model-form term sized on the plates of the build `fit_on` (`drive_mismatch`):
    the second moments about zero (no bias is corrected: a mean fitted on one build is not
    known to hold on another) of ln(force factor ratio) and ln(Q ratio) and their co-moment.
    A response going as A^a Q^q then carries the relative standard uncertainty
    u = sqrt(a^2 s_AA + q^2 s_QQ + 2 a q s_AQ) in its logarithm: velocity (a, q) = (1, 1), the
    mechanical power (2, 1). Returns those second moments' square roots (u_force_factor_ln,
    u_q_ln, the correlation) and the two responses' u_velocity_ln and u_power_ln."""
    rows = drive_mismatch()
    rows = rows[rows["table"] == fit_on]
    if rows.empty:
        raise ValueError(f"no paper plate in build {fit_on!r}; the builds: {', '.join(DRIVE_BUILDS)}")
    a, q = rows["ln_force_factor_ratio"].to_numpy(), rows["ln_q_ratio"].to_numpy()
    s_aa, s_qq, s_aq = float(np.mean(a * a)), float(np.mean(q * q)), float(np.mean(a * q))
    return {"fit_on": fit_on, "plates": len(rows), "u_force_factor_ln": math.sqrt(s_aa), "u_q_ln": math.sqrt(s_qq),
            "correlation": s_aq / math.sqrt(s_aa * s_qq) if s_aa * s_qq > 0 else 0.0,
            "u_velocity_ln": math.sqrt(s_aa + s_qq + 2 * s_aq),
            "u_power_ln": math.sqrt(4 * s_aa + s_qq + 4 * s_aq)}


def log_term_expanded_rel(u_ln: float, k: float = 2.0) -> float:
    """A term known as a standard uncertainty u of a logarithm, as a symmetric relative expanded
    uncertainty of the value: exp(k u) - 1, which holds a value up to exp(k u) times the
    prediction and, being at least 1 - exp(-k u), down to exp(-k u) times it (GUM Suppl. 1's
    log-normal quantity, its k-interval in ln mapped back, widened to the symmetric one)."""
    return math.expm1(k * u_ln)


def expanded_interval(value, u):
    """The interval a value and its U (k = 2) stand for, numbers or arrays: value - U to
    value + U, or, where U reaches a positive value, the factor interval value / F to value F
    with F = 1 + U / value (the upper end is value + U either way): a positive quantity whose
    relative U is exp(k u) - 1 (`log_term_expanded_rel`, a log-normal one) has that
    k-interval, and value - U would put zero and below inside, which no voltage, power or
    amplitude can be."""
    value, u = np.asarray(value, dtype=float), np.asarray(u, dtype=float)
    past = (u >= value) & (value > 0)
    low = np.where(past, value**2 / np.where(past, value + u, 1.0), value - u)
    return low, value + u


def within_expanded_interval(truth, value, u):
    """Whether `truth` lies in the interval `value` and its U stand for (`expanded_interval`,
    ends included), numbers (a bool) or arrays: every "within U" verdict, so a verdict says
    what the page shows. Not |truth - value| <= U: where U reaches a positive value, a truth
    between value - U and value / F (F = 1 + U / value) is outside the factor interval. A
    verdict on two uncertain numbers passes U = hypot(U_value, U_truth), the U of their
    difference (GUM 5.1.2), whose interval a truth without U reduces to."""
    low, high = expanded_interval(value, u)
    truth = np.asarray(truth, dtype=float)
    inside = (low <= truth) & (truth <= high)
    return bool(inside) if inside.ndim == 0 else inside


def interval_reach(truth, value, u):
    """How far `truth` lies from `value` as a fraction of the shown interval's half on its side
    (`expanded_interval`): at most 1 exactly where `within_expanded_interval` holds, so a
    "largest error over U" beside a count of verdicts never says 0.3 of a miss. |truth - value|
    / U on a value +- U interval; below the value of a factor interval, over value - value / F."""
    low, high = expanded_interval(value, u)
    value, truth = np.asarray(value, dtype=float), np.asarray(truth, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        reach = np.where(truth >= value, (truth - value) / (high - value), (value - truth) / (value - low))
    return float(reach) if reach.ndim == 0 else reach


def drive_term_rel(fit_on: str = DRIVE_FIT_ON) -> dict[str, float]:
    """The drive's model-form term sized on `fit_on` (`drive_model_form`) as relative expanded
    uncertainties (k = 2, `log_term_expanded_rel`) of a response at a given voltage going as
    A Q (velocity, amplitude), as A^2 Q (mechanical power), and of one going as 1 / Q (the power
    at a given velocity)."""
    return dict(_drive_term_rel(fit_on))


@functools.cache   # the model and the print alone, as `_predictions`: a report asks it two dozen times
def _drive_term_rel(fit_on: str) -> dict[str, float]:
    form = drive_model_form(fit_on)
    return {"velocity": log_term_expanded_rel(form["u_velocity_ln"]), "power": log_term_expanded_rel(form["u_power_ln"]),
            "power_at_velocity": log_term_expanded_rel(form["u_q_ln"])}


def predictions(fit_on: str = DRIVE_FIT_ON) -> pd.DataFrame:
    """Predicted beside printed for Tables 3-4 and the large plate: frequency (and its U:
    sheet, alloy, bond and placement), deviation, interior antinodes, nodal-line spacing, and
    velocity and input power (mechanical with the one shared `MECHANICAL_Q`, plus dielectric)
    at resonance at the printed drive voltage, each with U (k = 2): the stated tolerances'
    (placement and bond included) and the drive's model-form term sized on the build `fit_on`
    (`drive_model_form`) in quadrature. And the power the plate takes at its printed velocity
    (the power a lab needs for the amplitude it wants, Eq. 28's reading: w M v0^2 / (2 q) plus
    the dielectric loss at the printed drive), whose U has no force factor in it: the Q spread,
    w M and placement's tolerances and the term's Q part. The model is solved once per process
    from geometry and the stated modes (`_predictions`); printed values set beside it, the drive
    voltage (and for the last, the printed velocity) scales it, and only the `fit_on` build's
    printed velocity and power size the model-form term."""
    frame = _at_printed_drive()
    term = drive_term_rel(fit_on)
    velocity_rel = np.hypot(frame.pop("velocity_u_tolerances_rel"), term["velocity"])
    power_rel = np.hypot(frame.pop("power_u_tolerances_rel"), term["power"])
    frame.insert(frame.columns.get_loc("printed_velocity_pp_mps"), "predicted_velocity_u_pp_mps",
                 frame["predicted_velocity_pp_mps"] * velocity_rel)
    frame.insert(frame.columns.get_loc("printed_power_w"), "predicted_power_u_w", frame["predicted_power_w"] * power_rel)
    at_velocity_rel = np.hypot(frame.pop("power_at_velocity_u_tolerances_rel"), term["power_at_velocity"])
    frame["predicted_power_at_printed_velocity_u_w"] = frame["predicted_power_at_printed_velocity_w"] * at_velocity_rel
    return frame


def drive_cross_check() -> pd.DataFrame:
    """The drive's model-form term sized on each build in turn (`drive_model_form`) and judged on
    every build: per (fitted build, judged build) the term's size, and how many of the judged
    build's printed velocities and powers (at the printed voltage, and at the printed velocity)
    the predictions' U then holds (`within_expanded_interval`), and the largest reach into
    the interval (`interval_reach`: above 1 exactly for a miss)
    (`role` "fitted" where the two builds are one: an in-sample figure, not a test)."""
    rows = []
    for fit_on in DRIVE_BUILDS:
        form = drive_model_form(fit_on)
        frame = predictions(fit_on)
        for judged in DRIVE_BUILDS:
            part = frame[frame["table"] == judged]
            row = {"fitted_on": fit_on, "judged": judged, "role": "fitted" if judged == fit_on else "held out",
                   "u_force_factor_ln": form["u_force_factor_ln"], "u_q_ln": form["u_q_ln"],
                   "power_u_model_form_rel": log_term_expanded_rel(form["u_power_ln"])}
            for name, value, u, printed in (("velocity", "predicted_velocity_pp_mps", "predicted_velocity_u_pp_mps",
                                             "printed_velocity_pp_mps"),
                                            ("power", "predicted_power_w", "predicted_power_u_w", "printed_power_w"),
                                            ("power_at_velocity", "predicted_power_at_printed_velocity_w",
                                             "predicted_power_at_printed_velocity_u_w", "printed_power_w")):
                scored = part[np.isfinite(part[printed])]
                row[f"{name}_covered"] = int(within_expanded_interval(scored[printed], scored[value], scored[u]).sum())
                row[f"{name}_scored"] = len(scored)
                row[f"{name}_max_error_over_u"] = (float(np.max(interval_reach(scored[printed], scored[value], scored[u])))
                                                   if len(scored) else math.nan)
            rows.append(row)
    return pd.DataFrame(rows)


#: The paper's table quantities the model predicts: (value column, U column) of `predictions`.
PREDICTED_QUANTITIES = {
    "n_antinodes": ("predicted_antinodes", None),
    "frequency_hz": ("predicted_frequency_hz", "predicted_frequency_u_hz"),
    "velocity_pp_mps": ("predicted_velocity_pp_mps", "predicted_velocity_u_pp_mps"),
    "power_w": ("predicted_power_w", "predicted_power_u_w"),
}


def tidy(table: str) -> pd.DataFrame:
    """One row per (item, quantity) of the paper's `table` ("Table 3", "Table 4") the model
    predicts: predicted_value and predicted_expanded_uncertainty (k = 2, NaN for a count). Table 4's amplitude is
    the predicted velocity over w, its U the velocity's drive term with its own tolerances."""
    frame = predictions().merge(_predictions()[["item", "drive_u_rel"]], on="item")
    term = drive_term_rel()
    rows = []
    for row in frame[frame["table"] == table].to_dict("records"):
        for quantity, (value, u) in PREDICTED_QUANTITIES.items():
            rows.append({"item": row["item"], "quantity": quantity, "predicted_value": float(row[value]),
                         "predicted_expanded_uncertainty": float(row[u]) if u else math.nan})
        amplitude = row["predicted_velocity_pp_mps"] / (2 * math.pi * row["predicted_frequency_hz"])
        base = response_relative_u(row["resonator_thickness_mm"] * MM)["amplitude_pp_m"]
        rows.append({"item": row["item"], "quantity": "amplitude_pp_m", "predicted_value": amplitude,
                     "predicted_expanded_uncertainty": amplitude * math.hypot(base, row["drive_u_rel"], term["velocity"])})
    return pd.DataFrame(rows, columns=["item", "quantity", "predicted_value", "predicted_expanded_uncertainty"])


def large_plate_response() -> dict[str, float]:
    """The large plate at its predicted working mode, per volt: amplitude pp per Vpp at its
    centre and power per Vpp^2 (both linear in the drive: Eqs. 25 and 27 are, and so is the
    plate), each with its relative U (k = 2, the placement and bond terms and the drive's
    model-form term, `drive_term_rel`, included), and the frequency; what Figs. 8 and 9 and
    Table 5 show beside the measured lines. The power is the input: mechanical plus the
    powered piezos' dielectric loss (as `predictions`)."""
    from squeezebench.plates import damping

    row = _predictions().set_index("item").loc["large_plate"]
    u = response_relative_u(row["resonator_thickness_mm"] * MM)
    term = drive_term_rel()
    omega = 2 * math.pi * row["predicted_frequency_hz"]
    mechanical = float(row["power_w_per_vpp2"])
    dielectric = damping.dielectric_power_w(row["predicted_frequency_hz"], row["clamped_capacitance_f"], 1.0,
                                            plate_modes.NCE41.tan_delta)
    return {"frequency_hz": float(row["predicted_frequency_hz"]),
            "amplitude_pp_m_per_vpp": float(row["velocity_pp_mps_per_vpp"] / omega),
            "amplitude_rel_U": math.hypot(u["amplitude_pp_m"], row["drive_u_rel"], term["velocity"]),
            "power_w_per_vpp2": mechanical + dielectric,
            "power_rel_U": math.hypot(float(row["power_u_rel"]) * mechanical / (mechanical + dielectric), term["power"])}


def loss_budget() -> pd.DataFrame:
    """Per paper plate: the Q its printed power and velocity imply through the model's modal
    mass (`damping.implied_q`; the large plate's "1 um" read as pp), each loss term at its
    nominal (`damping.mode_loss_terms`) and the share of the printed power the powered piezos'
    dielectric loss takes at the printed drive (`damping.dielectric_power_w`): what
    `damping.fit_and_check` fits and judges."""
    from squeezebench.plates import damping

    rows = []
    for row in _predictions().to_dict("records"):
        printed = _printed(row["table"], row["item"])
        f = row["predicted_frequency_hz"]
        velocity_pp = printed_velocity_pp_mps(row["table"], row["item"], f)
        implied = damping.implied_q(f, row["modal_mass_g"] * 1e-3, velocity_pp, printed["printed_power_w"])
        dielectric = damping.dielectric_power_w(f, row["clamped_capacitance_f"], printed["voltage_vpp"],
                                                plate_modes.NCE41.tan_delta)
        rows.append({"table": row["table"], "item": row["item"], "implied_q": implied,
                     "dielectric_share_of_power": dielectric / printed["printed_power_w"],
                     **{name: value for name, value in row.items() if name.startswith("loss_")}})
    return pd.DataFrame(rows)


def implied_force_factor_n_per_v(voltage_vpp: float, velocity_pp_mps: float, power_w: float) -> float:
    """The force factor a printed drive, velocity and power imply at resonance, model-free:
    the drive's force amplitude A V0 times the velocity amplitude v0 over two is the power, so
    A = 2 P / (V0 v0) (V0, v0 half their pp)."""
    return 2.0 * power_w / (voltage_vpp / 2.0 * velocity_pp_mps / 2.0)


def what_would_agree() -> pd.DataFrame:
    """For each paper plate, what the printed power and velocity imply beside what the model
    predicts, and so which input would have to move, and by how much, for the two to agree:
    the force factor (implied / predicted; the edge gap that would give it is the design
    model's inference, `designing.paper_placement`) and the Q (implied / the build's
    `MECHANICAL_Q`)."""
    from squeezebench.plates import damping

    rows = []
    for row in _predictions().to_dict("records"):
        printed = _printed(row["table"], row["item"])
        f, v = row["predicted_frequency_hz"], printed["voltage_vpp"]
        velocity = printed_velocity_pp_mps(row["table"], row["item"], f)
        implied_force = implied_force_factor_n_per_v(v, velocity, printed["printed_power_w"])
        implied_q = damping.implied_q(f, row["modal_mass_g"] * 1e-3, velocity, printed["printed_power_w"])
        rows.append({"table": row["table"], "item": row["item"],
                     "predicted_force_factor_n_per_v": row["force_factor_n_per_v"],
                     "implied_force_factor_n_per_v": implied_force,
                     "force_factor_ratio": implied_force / row["force_factor_n_per_v"],
                     "implied_q": implied_q, "q_ratio": implied_q / MECHANICAL_Q,
                     "physics_q": row["damping_q"]})
    return pd.DataFrame(rows)


def large_plate_mode() -> dict:
    """The large plate's predicted working mode's figures: its frequency, interior antinodes and
    nodal-line spacing (what `large_plate_mode_figure` draws, without drawing it)."""
    modes, k = _solve_working(large_plate(), STATED_ANTINODES["large"], None)
    return {"frequency_hz": float(modes.frequencies_hz[k]), "interior_antinodes": modes.interior_antinodes(k),
            "half_wavelength_mm": modes.half_wavelength_m(k) * 1e3}


def large_plate_mode_figure(path: Path) -> Path:
    """The large plate's predicted working mode, drawn to `path`. Drawn once per process (it
    depends on the model alone): every report of a process writes the same PNG, and a test
    session writes dozens."""
    path.write_bytes(_large_plate_mode_png())
    return path


@functools.cache
def _large_plate_mode_png() -> bytes:
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    modes, k = _solve_working(large_plate(), STATED_ANTINODES["large"], None)
    fig, ax = plt.subplots(figsize=(7, 4.2))
    image = ax.pcolormesh(modes.x_m * 1e3, modes.y_m * 1e3, modes.shapes[k].T, cmap="RdBu_r",
                          vmin=-1, vmax=1, shading="gouraud")
    for patch in modes_patches(large_plate()):
        ax.add_patch(plt.Rectangle(*patch, fill=False, edgecolor="k", linewidth=0.8))
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(f"predicted mode at {modes.frequencies_hz[k]:.0f} Hz "
                 f"({modes.interior_antinodes(k)} interior antinodes)")
    fig.colorbar(image, ax=ax, label="deflection / largest")
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=100, bbox_inches="tight")
    plt.close(fig)
    return png.getvalue()


def modes_patches(geometry: plate_modes.PlateGeometry) -> list[tuple[tuple[float, float], float, float]]:
    """Each patch as matplotlib's ((x0, y0), width, height) in mm."""
    return [((p.bounds[0] * 1e3, p.bounds[2] * 1e3), p.length_x_m * 1e3, p.width_y_m * 1e3)
            for p in geometry.patches]


#: The paper's plates the model knows, by the name a run stores them under (the scene's stem).
GEOMETRIES = {"large_plate": large_plate}


def known_plate_modes(plate: str, near_hz: float) -> plate_modes.PlateModes | None:
    """The model's modes of `plate` near `near_hz` (solved once: `plate_modes.solve_plate`
    keeps them), None for a plate the model does not know: what `working_shape` reads."""
    if plate not in GEOMETRIES:
        return None
    return plate_modes.solve_plate(GEOMETRIES[plate](), near_hz=near_hz)


def working_shape(plate: str, near_hz: float, x_m, y_m) -> tuple[np.ndarray, float] | None:
    """The model's working mode of `plate` (the (n, 0) mode nearest `near_hz`) at the
    points (x, y), scaled +1 at its largest, and that mode's frequency; None for a plate
    the model does not know."""
    modes = known_plate_modes(plate, near_hz)
    if modes is None:
        return None
    k = modes.working_mode(near_hz)
    return modes.shape_at(k, x_m, y_m), float(modes.frequencies_hz[k])


def main() -> None:
    """The paper's plates predicted beside print and what would have to move (`python -m
    squeezebench.plates.predicted_plates`; the placement the print implies:
    `python -m squeezebench.designing.paper_placement`)."""
    with pd.option_context("display.width", 220, "display.max_columns", 30, "display.float_format", "{:.4g}".format):
        for title, frame in (("predicted beside printed", predictions()),
                             ("what would have to move", what_would_agree())):
            print(f"\n{title}\n{frame.to_string(index=False)}")


if __name__ == "__main__":
    main()
