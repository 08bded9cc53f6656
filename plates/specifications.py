"""The bench's published accuracy specifications: the Type B inputs of every budget.

One place for these numbers: the uncertainty budgets (`analysis.uncertainty`) read them
as rectangular distributions (GUM 4.3.7: a stated limit +-a without more knowledge gives
u = a / sqrt(3)), and the simulated bench's systematic effects (`simbench.effects`) take
them as their default magnitudes, so a simulated bench errs exactly as far as the
manuals allow. Where a manual gives no figure the value is marked "assumed" and says why.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Specification:
    """A limit +-half_width in `unit` ("1" is relative), with where it comes from."""

    half_width: float
    unit: str
    source: str

    @property
    def std_uncertainty(self) -> float:
        """Rectangular distribution over +-half_width (GUM 4.3.7)."""
        return self.half_width / math.sqrt(3.0)


SPECIFICATIONS: dict[str, Specification] = {
    "scope_gain": Specification(
        0.02, "1", "TDS3000B Series User Manual, App. A (Specifications): DC gain accuracy +-2 % "
                   "per channel, sample or average mode"),
    "scope_skew": Specification(
        1e-9, "s", "assumed: no delay-between-channels figure of the TDS3000B was found; Tektronix "
                   "verifies +-50 to +-100 ps on its TDS 500B/600B/700A (performance verification, delay "
                   "between channels); 1 ns bounds an entry-level scope, a tenth of the +-10 ns "
                   "CH<x>:DESKew range (programmer manual)"),
    "voltage_probe_attenuation": Specification(
        0.02, "1", "assumed: the paper names no voltage probe (a 100:1 high-voltage probe is assumed); a "
                   "passive divider probe's attenuation is specified to a few per cent, and the scope's "
                   "gain accuracy does not include it (Tektronix's scope specifications ask for the "
                   "probe's accuracy to be added); +-2 %"),
    "voltage_probe_compensation": Specification(
        0.01, "1", "assumed: a divider probe adjusted by eye on the scope's 1 kHz probe-compensation square "
                   "wave keeps a flat top to about a trace width, +-1 % of the step; above the divider's pole "
                   "(VOLTAGE_PROBE_POLE_HZ) a mismatch d leads CH1 by the phase d f_pole / f, and its gain part is "
                   "the attenuation term's"),
    "current_probe_gain": Specification(
        0.03, "1", "TCP202 instruction manual (070-9542), Specifications: DC accuracy +-3 %"),
    "current_probe_delay": Specification(
        10e-9, "s", "assumed: no propagation-delay figure of the TCP202 was found; Tektronix's deskew note for "
                    "power measurements gives nominal delays of 6.5 ns (TDP1000 voltage probe) and 14.5 ns "
                    "(TCP0030 current probe), 8 ns apart; +-10 ns is also the most CH<x>:DESKew can "
                    "correct (programmer manual); the TCP202's 50 MHz bandwidth (its specifications) acts below "
                    "100 kHz as a constant delay, 1/(2 pi 50 MHz) = 3.2 ns, so its phase over frequency is "
                    "part of this delay"),
    "current_probe_lag": Specification(
        20e-9, "s", "assumed: a limit of known sign, not a zero-mean spread: a current probe's signal path "
                    "(transformer, amplifier, cable) lags a passive voltage probe's; Tektronix's deskew note for "
                    "power measurements has its current probe 8 ns behind its voltage probe; 20 ns bounds twice "
                    "that, the TCP202's 3.2 ns bandwidth delay and a longer cable. Without a deskew run this "
                    "bound (and the scope's skew) is what the CH2 delay may be"),
    "vibrometer_scale": Specification(
        0.01, "1", "Polytec velocity decoder specifications: calibration error of the analog "
                   "output +-1 % (sinusoidal vibration, 70 % of full scale)"),
    "scope_timebase": Specification(
        20e-6, "1", "TDS3000B Series User Manual, App. A: sample rate and delay time accuracy +-20 ppm "
                    "(the frequency a record's fit measures; simulated as the scope_timebase_error effect)"),
    "plate_placement": Specification(
        1.0, "mm", "assumed: the paper does not say how its map's grid was registered on the plate; a plate "
                   "laid on its mount by hand and the grid's origin set by jogging the laser spot onto the "
                   "plate's corner by eye lands within about +-1 mm per axis (the visible spot and the edge's "
                   "burr are each a few tenths of a millimetre); the stage's own repeatability (micrometres, "
                   "an SMC100-class stage) is far below it. Per axis, the plate's rotation left out"),
    "generator_frequency": Specification(
        20e-6, "1", "HP/Agilent 33120A User's Guide, Specifications: frequency accuracy 10 ppm "
                    "(90 days), 20 ppm (1 year); the one-year figure"),
    "generator_amplitude": Specification(
        0.02, "1", "HP/Agilent 33120A User's Guide, Specifications: amplitude accuracy +-1 % of the setting "
                   "(+-1 mVpp) at 1 kHz, and sine flatness +-1 % below 100 kHz relative to 1 kHz; the two added "
                   "at the plates' 30-50 kHz. Only a loss not going as V^2 (the piezos' dielectric loss) "
                   "keeps it in Fig. 2's Pt/P0"),
}


@dataclass(frozen=True)
class WorldReading:
    """What a stated limit +-a means on a real bench, against the rectangle the budgets take
    for it (GUM 4.3.7): instruments and parts err normally about their nominal value, a
    limit being an acceptance bound a few standard deviations out rather than an edge of
    equally likely values, and now and then one errs beyond its limit (a probe dropped once,
    a scope overdue for calibration, a sheet from another mill). Fractions of the limit.
    One source for the simulated world's benches (`simbench.systematic_effects.world_draw`)
    and for the budgets' coverage factor under that world (`analysis.budgets`)."""

    #: Standard deviation of an error within specification: half the limit, so about one
    #: unbiased instrument in 20 is beyond it.
    spread: float = 0.5
    #: How often an error is beyond its limit (each of a bench's errors on its own: with ten
    #: instrument errors about one bench in ten has one) ...
    out_of_spec_probability: float = 0.01
    #: ... and how far: this many times its limit, either sign.
    out_of_spec_factor: float = 1.5


WORLD_READING = WorldReading()


#: Pole of the voltage probe's compensated divider, R_tip C_tip: tens of megohms with a few
#: picofarads (a 100:1 high-voltage probe's tip) make about 0.1 ms. Assumed, as the probe is.
#: Well below the plates' 30-50 kHz, where a compensation mismatch d is a phase lead
#: d f_pole / f: its delay-equivalent falls as 1/f^2, so a deskew at one frequency leaves a
#: residue at another (`uncertainty.compensation_phase_per_mismatch`).
VOLTAGE_PROBE_POLE_HZ = 1.5e3


def compensation_phase_rad(mismatch_rel: float, frequency_hz: float) -> float:
    """CH1's phase lead (rad, a number or an array like `frequency_hz`) through a divider probe whose compensation is off by
    `mismatch_rel` (HF over LF gain minus one): H(f) = (1 + j f / f_z) / (1 + j f / f_p) with
    f_z = f_p / (1 + d), f_p = VOLTAGE_PROBE_POLE_HZ (a compensated RC divider's transfer)."""
    x = np.asarray(frequency_hz, dtype=float) / VOLTAGE_PROBE_POLE_HZ
    phase = np.arctan(x * (1.0 + mismatch_rel)) - np.arctan(x)
    return float(phase) if phase.ndim == 0 else phase


#: The plate model's inputs (`plates.plate_modes.RELATIVE_TOLERANCES`): relative half-widths
#: of rectangular spreads about the nominal values (Table 2's aluminium, NCE 41, the epoxy bond).
MODEL_TOLERANCES: dict[str, Specification] = {
    "young_pa": Specification(
        0.03, "1", "alloy family: the paper names no alloy, only Table 2's constants; ordinary wrought "
                   "aluminium alloys' typical moduli run from 68.9 GPa (1xxx, 3003, 6061) to 73.1 GPa (2024) "
                   "(ASM Handbook Vol. 2, properties of wrought aluminium alloys; Aluminum Association, "
                   "Aluminum Standards and Data), +-3 % about their middle"),
    "density_kg_m3": Specification(
        0.03, "1", "alloy family: typical densities from 2660 kg/m^3 (5083) to 2810 kg/m^3 (7075) (same "
                   "sources), +-3 %; with the modulus's, sqrt(E / rho) spreads by 3-4 % across the family"),
    "d31_c_per_n": Specification(0.05, "1", "NCE 41 datasheet (Noliac): +-5 % on d31 and k"),
    "relative_permittivity_t": Specification(0.10, "1", "NCE 41 datasheet (Noliac): +-10 % on the permittivity"),
    "bond_thickness_m": Specification(
        0.5, "1", "assumed: the paper says only that the piezos are glued; a pressed epoxy bondline under a "
                  "small ceramic is 20-60 um (the Araldite 2011 datasheet's 0.05-0.10 mm is the layer for "
                  "the greatest lap shear strength of a structural joint, thicker than a pressed one): 40 um "
                  "+-50 %"),
    "bond_shear_modulus_pa": Specification(
        0.5, "1", "assumed: cured room-temperature epoxies (Araldite 2011 class) have tensile moduli of "
                  "about 2-3 GPa and Poisson's ratios of 0.35-0.4, so a shear modulus of about 1 GPa; "
                  "+-50 % for the cure and temperature the paper does not state"),
    "bond_loss_factor": Specification(
        0.67, "1", "assumed: a glassy epoxy well below its glass transition has a shear loss factor of "
                   "0.01-0.05 (0.03 +-67 %); fitted on one build in `plates.damping.fit_and_check`"),
}

#: The plate's warming under drive (`plates.warming`, `simbench.effects.HeatingDrift`): nominal
#: values, the assumptions HEATING_TOLERANCES widens: free convection from both faces at
#: 10 W/m^2K (the plate lies on a cushion), aluminium's specific heat 900 J/kgK (its density
#: is Table 2's, `laminate.ALUMINIUM_TABLE2`), and a frequency coefficient of -2e-4 per kelvin
#: (the Young's modulus of aluminium falls about 4e-4/K, f goes with its square root).
HEATING_NOMINAL: dict[str, float] = {"frequency_coefficient_per_k": -2e-4, "convection_w_per_m2_k": 10.0,
                                     "specific_heat_j_per_kg_k": 900.0}

#: The plate's warming under drive (`simbench.effects.HeatingDrift`: its resonance falls as it
#: warms, Fig. 2's resonance drift): relative half-widths about the effect's nominal parameters,
#: drawn per plate on a coverage study's bench (a real plate's alloy, surface and mounting are
#: each lab's own). Keyed by the effect's parameter names.
HEATING_TOLERANCES: dict[str, Specification] = {
    "frequency_coefficient_per_k": Specification(
        0.3, "1", "assumed: a plate's resonance goes as sqrt(E / rho) times its geometry, so its "
                  "temperature coefficient is half its modulus's plus half the expansion's (aluminium's "
                  "23e-6/K: +1e-5/K, which the nominal -2e-4/K leaves out); wrought aluminium alloys' "
                  "moduli fall by some 3-5e-4 per kelvin near room temperature (their moduli fall by "
                  "several GPa of about 70 between room temperature and 150 C, the faster in the "
                  "softer alloys), so -1.5 to -2.5e-4/K: +-30 % about -2e-4/K"),
    "convection_w_per_m2_k": Specification(
        0.5, "1", "assumed: free convection from a plate of a few centimetres in still room air is "
                  "5-15 W/m^2K (its laminar correlations: h ~ 1.3 (dT / L)^0.25 W/m^2K, a few kelvin over "
                  "a few centimetres), radiation from bare or lightly oxidised aluminium (emissivity "
                  "0.05-0.2) adds under 1.2 W/m^2K, and the cushion the plate lies on shields part of "
                  "its lower face: +-50 % about the nominal 10 W/m^2K. It sets the plate's heating rate "
                  "per watt (1 / h A) and, with its thermal mass, its time constant rho c h_plate / 2 h"),
    "specific_heat_j_per_kg_k": Specification(
        0.05, "1", "alloy family: wrought aluminium alloys' specific heats at room temperature run from "
                   "about 860 to 960 J/kgK (ASM Handbook Vol. 2, as the modulus's and density's "
                   "tolerances: 2024 875, 6061 896, 7075 960): +-5 % about 900 J/kgK, the plate's "
                   "thermal mass with its density's tolerance"),
}

#: ISO 2768-1 (1989), Table 1, tolerance class c (coarse): permissible deviation (+-mm) of a
#: linear size without an individual tolerance, by nominal size (over, up to and including; mm).
#: Assumed for a plate cut to length in a lab (the paper's 59 and 28 mm plates were cut from
#: the 75 mm one, Sec. 2.3.1, with no tolerance stated): a saw or shear cut deburred by hand, the
#: class a drawing without tolerances gives to sheet-metal work; rectangular (nothing known
#: beyond the limit, GUM 4.3.7).
CUT_LENGTH_TOLERANCE_MM = ((0.5, 3.0, 0.2), (3.0, 6.0, 0.3), (6.0, 30.0, 0.5), (30.0, 120.0, 0.8),
                           (120.0, 400.0, 1.2), (400.0, 1000.0, 2.0))


def cut_length_tolerance_mm(length_mm: float) -> float:
    """Half-width (mm) of a cut length `length_mm` (`CUT_LENGTH_TOLERANCE_MM`)."""
    for low, high, half_width in CUT_LENGTH_TOLERANCE_MM:
        if low < length_mm <= high:
            return half_width
    raise ValueError(f"no ISO 2768-1 class c tolerance for a length of {length_mm:g} mm")


def rectangles_95_half_width(a: float, b: float) -> float:
    """The half-width holding 95 % of the sum of two independent rectangular spreads +-a and
    +-b: their trapezoid (GUM G.2.3), plateau +-|a - b|, ramps out to +-(a + b); the tail beyond
    x on a ramp is (a + b - x)^2 / (8 a b), on the plateau (a - x) / (2 a) (a >= b). One
    rectangle alone (b = 0) gives 0.95 a, i.e. k = 0.95 sqrt(3) = 1.65."""
    a, b = max(a, b), min(a, b)
    # both ramps hold b / a of the whole: the 95 % point is on them once that is 5 % or more
    return a + b - math.sqrt(8 * a * b * 0.025) if b >= 0.05 * a else 0.95 * a


#: How the sheet's thickness spreads within the standard's limits: triangular (GUM 4.3.9:
#: values near the limits less likely than near the middle), u = a / sqrt(6). A mill rolls to the
#: nominal gauge and the standard's limit is its acceptance bound, not the spread of its
#: production; the rectangular a / sqrt(3) (GUM 4.3.7) would treat a sheet at the limit as as
#: likely as one at the gauge.
THICKNESS_DISTRIBUTION = "triangular"

#: EN 485-4 (1993), Table 1: thickness tolerance (+-mm) of cold-rolled aluminium sheet up to
#: 1000 mm wide, alloy group II, by nominal thickness (over, up to and including; mm). Group II
#: (the wider) because Table 2's 2790 kg/m^3 is a 2xxx alloy's density, all in that group;
#: from 3.5 mm the standard has one value for both groups.
SHEET_THICKNESS_TOLERANCE_MM = ((0.2, 0.5, 0.03), (0.5, 0.8, 0.04), (0.8, 1.2, 0.05), (1.2, 1.5, 0.07),
                                (1.5, 1.8, 0.08), (1.8, 2.0, 0.09), (2.0, 2.5, 0.10), (2.5, 3.0, 0.11),
                                (3.0, 3.5, 0.12), (3.5, 4.0, 0.15), (4.0, 5.0, 0.18), (5.0, 6.0, 0.20))


def sheet_thickness_tolerance(thickness_m: float) -> float:
    """Relative half-width of a rolled sheet's thickness about its nominal `thickness_m`
    (`SHEET_THICKNESS_TOLERANCE_MM`): a plate's thickness is what a lab buys, not measures,
    and f ~ h makes it the largest term of a predicted frequency's budget (4-5 % at 1 mm)."""
    mm = thickness_m * 1e3
    for over, up_to, tolerance_mm in SHEET_THICKNESS_TOLERANCE_MM:
        if over < mm <= up_to + 1e-9:
            return tolerance_mm / mm
    raise ValueError(f"no sheet thickness tolerance for {mm:g} mm (EN 485-4 Table 1 covers "
                     f"{SHEET_THICKNESS_TOLERANCE_MM[0][0]:g}-{SHEET_THICKNESS_TOLERANCE_MM[-1][1]:g} mm): "
                     "state the plate's thickness tolerance")
