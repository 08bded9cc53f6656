"""The paper's analytical power model (Section 3), as small pure functions.

Every function takes peak-to-peak voltages and returns peak-to-peak amplitudes; the
`Convention` says how the paper's V and A are read inside the printed equations, which
material constants are used, where the neutral plane is, and whether the print slips of
Eqs. 28 and 29 are kept. Nothing here guesses a convention: a caller names one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal

from squeezebench.errors import UserError


class ModelGeometryError(UserError, ValueError):
    """A geometry for which a printed equation has no finite value."""


@dataclass(frozen=True)
class Materials:
    """Table 2: the aluminium resonator and the NCE 41 piezoceramic."""

    resonator_young_pa: float
    resonator_poisson: float
    resonator_density_kg_m3: float
    piezo_c11_pa: float
    piezo_poisson: float
    piezo_d31_c_per_n: float
    piezo_density_kg_m3: float


#: Table 2 as the extraction prints it: E_i = 67109 N/m² taken literally (so α ≈ 0).
#: c11 and d31 lost their exponents in print ("8010^9", "-13010^-12"); read as 80e9 and -130e-12.
MATERIALS_AS_PRINTED = Materials(
    resonator_young_pa=67109.0,
    resonator_poisson=0.34,
    resonator_density_kg_m3=2790.0,
    piezo_c11_pa=80e9,
    piezo_poisson=0.33,
    piezo_d31_c_per_n=-130e-12,
    piezo_density_kg_m3=7900.0,
)

#: Table 2 as physically meant: aluminium E_i = 67 GPa.
MATERIALS_PHYSICAL = replace(MATERIALS_AS_PRINTED, resonator_young_pa=67e9)


@dataclass(frozen=True)
class Convention:
    """How the printed equations are read; recorded next to every derived number.

    Each field is one choice the paper leaves open or prints damaged; `analysis.readings`
    searches over them and says which published numbers each combination reproduces.
    """

    name: str
    materials: Materials
    voltage: Literal["pp", "amplitude", "rms"] = "pp"  # what V means inside Eqs. 25/27
    amplitude: Literal["pp", "amplitude"] = "pp"  # what A of Eq. 27 is
    neutral_plane: Literal["stack_middle", "resonator_middle", "bending_neutral",
                           "interface"] = "stack_middle"
    eq28_with_pi: bool = True  # substituting Eq. 27 into Eq. 25 yields a factor pi
    eq29_as_printed: bool = False  # printed ratio b_large/b_small is inverted w.r.t. the text
    #: what n_c of Eqs. 25/27 counts: every powered piezo (the text's definition) or the
    #: powered groups (columns of the small plates, corner pairs of the large plate)
    n_c: Literal["piezos", "groups"] = "piezos"
    eq25_with_pi: bool = True  # Eq. 25 as printed carries pi f; the same pi Eq. 28 lacks
    c11_reduced: bool = True  # c'11 = c11/(1 - nu_p^2) (Eq. 8) or c11 itself in Eq. 25
    #: Eq. 25's 3/4 follows Eq. 14; the factor-2 slip of Eqs. 20/21/24 would make it 3/8
    eq25_coefficient: float = 0.75

    def voltage_in_equation(self, voltage_vpp: float) -> float:
        if self.voltage == "rms":
            return voltage_vpp / (2.0 * math.sqrt(2.0))
        return voltage_vpp if self.voltage == "pp" else voltage_vpp / 2.0

    def n_c_in_equation(self, geometry: "PlateGeometry") -> int:
        """n_c of Eqs. 25/27 for `geometry` under this reading."""
        if self.n_c == "piezos":
            return geometry.n_powered_piezos
        if geometry.n_powered_groups is None:
            raise ModelGeometryError(
                f"reading {self.name!r} counts powered groups in n_c, but the geometry does not say "
                "how many groups are powered (PlateGeometry.n_powered_groups)")
        return geometry.n_powered_groups

    def amplitude_pp_from_equation(self, amplitude: float) -> float:
        return amplitude if self.amplitude == "pp" else 2.0 * amplitude

    def amplitude_in_equation(self, amplitude_pp_m: float) -> float:
        return amplitude_pp_m if self.amplitude == "pp" else amplitude_pp_m / 2.0


#: The text's own definitions: printed E_i, peak-to-peak V and A, n_c every powered
#: piezo, neutral plane at the middle of the two-layer stack, Eq. 25 with its pi, Eq. 28
#: with the pi the substitution gives and Eq. 29 with the ratio the text describes (Q
#: falls as the piezo gets longer). It reproduces Q = 1.48 at about 1 um, but not the
#: printed tan(theta') (see `analysis.readings`).
PAPER_CONVENTION = Convention(name="paper", materials=MATERIALS_AS_PRINTED)

#: Every equation exactly as printed (Eq. 28 without pi, Eq. 29 with b_large/b_small).
AS_PRINTED_CONVENTION = Convention(
    name="as_printed", materials=MATERIALS_AS_PRINTED, eq28_with_pi=False, eq29_as_printed=True
)

#: Physical material constants, otherwise the paper's reading.
PHYSICAL_CONVENTION = Convention(name="physical", materials=MATERIALS_PHYSICAL)

#: The convention every derived number of the report and of a design from characterised
#: plates uses (the audit shows the others): the physical reading, Table 2's E_i as 67 GPa
#: (printed 67109 Pa, a resonator without stiffness) with the text's own definitions (V and A
#: peak-to-peak, n_c every powered piezo). The paper's Q and tan theta' need other readings;
#: the report's readings section shows them.
REPORT_CONVENTION = PHYSICAL_CONVENTION

#: The one family of readings that `analysis.readings.search_readings` finds reproducing
#: Table 5's measured Q and tan(theta'), the ~1 um / 1.3 W point and Table 4's 1.2 mm
#: mean at once: printed E_i, V peak-to-peak, Eq. 27's A zero-to-peak (the published
#: amplitudes are peak-to-peak), n_c counting powered groups, z0 at the stack middle and
#: Eq. 25 without its pi. It contradicts the text twice (n_c is defined as the number of
#: piezos; Eq. 25 is printed with pi): a hypothesis about what the authors computed.
INFERRED_CONVENTION = Convention(name="inferred", materials=MATERIALS_AS_PRINTED, voltage="pp",
                                 amplitude="amplitude", n_c="groups", eq25_with_pi=False,
                                 eq28_with_pi=False)


@dataclass(frozen=True)
class PlateGeometry:
    """The half-wavelength section of Fig. 4 and the actuators driving it."""

    resonator_thickness_m: float  # h_i
    piezo_thickness_m: float  # h_p
    piezo_length_m: float  # b_p, the piezo length along the nodal lines
    half_wavelength_m: float  # lambda / 2
    n_powered_piezos: int  # n_c as the text defines it
    n_powered_groups: int | None = None  # powered columns / corner groups (a reading of n_c)

    def __post_init__(self) -> None:
        for field_name in ("resonator_thickness_m", "piezo_thickness_m", "piezo_length_m",
                           "half_wavelength_m"):
            value = getattr(self, field_name)
            if not (math.isfinite(value) and value > 0):
                raise ModelGeometryError(f"PlateGeometry.{field_name} must be > 0, got {value!r}")
        if self.n_powered_piezos < 1:
            raise ModelGeometryError(
                f"PlateGeometry.n_powered_piezos must be >= 1, got {self.n_powered_piezos!r}")
        if self.n_powered_groups is not None and not 1 <= self.n_powered_groups <= self.n_powered_piezos:
            raise ModelGeometryError(f"PlateGeometry.n_powered_groups must be 1..n_powered_piezos, "
                                     f"got {self.n_powered_groups!r}")

    @property
    def wavelength_m(self) -> float:
        return 2.0 * self.half_wavelength_m


def reduced_modulus_pa(young_pa: float, poisson: float) -> float:
    """G' = G / (1 - nu^2) (Eq. 6) and c'11 = c11 / (1 - nu_p^2) (Eq. 8): plane strain in y."""
    return young_pa / (1.0 - poisson**2)


def neutral_plane_m(geometry: PlateGeometry, convention: Convention) -> float:
    """z0 measured from the free face of the piezo layer (z = 0), Fig. 4.

    The paper puts it at "the middle plane"; which middle is a convention:
    `stack_middle` (h_p + h_i)/2, `resonator_middle` h_p + h_i/2, or `bending_neutral`,
    the stiffness-weighted centroid of the two layers (composite beam theory), which
    depends on the materials: with E_i as printed it falls on the piezo mid-plane.
    """
    h_p, h_i = geometry.piezo_thickness_m, geometry.resonator_thickness_m
    if convention.neutral_plane == "stack_middle":
        return (h_p + h_i) / 2.0
    if convention.neutral_plane == "resonator_middle":
        return h_p + h_i / 2.0
    if convention.neutral_plane == "interface":
        return h_p
    m = convention.materials
    stiffness_piezo = reduced_modulus_pa(m.piezo_c11_pa, m.piezo_poisson) * h_p
    stiffness_resonator = reduced_modulus_pa(m.resonator_young_pa, m.resonator_poisson) * h_i
    return ((stiffness_piezo * h_p / 2.0 + stiffness_resonator * (h_p + h_i / 2.0))
            / (stiffness_piezo + stiffness_resonator))


def inverse_a(f0: float, alpha: float, beta: float) -> float:
    """1/a of Eq. 12, with f0 = z0/h_p, alpha = G'/c'11, beta = h_i/h_p (Eq. 13).

    Raises ModelGeometryError where the denominator vanishes (1/a has no finite value):
    the check is relative to the size of the terms, so cancellation is caught too.
    """
    numerator = 1.0 - 2.0 * f0
    bracket = 3 * beta + 3 * beta**2 + beta**3 - 6 * f0 - 3 * beta * f0 + 3 * beta * f0**2
    denominator = 1.0 - 3.0 * f0 + 3.0 * f0**2 - alpha * bracket
    scale = 1.0 + 3.0 * abs(f0) + 3.0 * f0**2 + abs(alpha) * (
        3 * beta + 3 * beta**2 + beta**3 + 6 * abs(f0) + 3 * beta * abs(f0) + 3 * beta * f0**2)
    if abs(denominator) <= 1e-12 * scale:
        raise ModelGeometryError(
            f"Eq. 12 denominator vanishes for f0={f0:.6g}, alpha={alpha:.6g}, beta={beta:.6g}: "
            "the bending factor a is zero and Eqs. 25/27 diverge for this geometry")
    return numerator / denominator


def a_factor(geometry: PlateGeometry, convention: Convention) -> float:
    """The bending factor a of Eqs. 11-13 for this geometry and reading of Table 2."""
    m = convention.materials
    alpha = (reduced_modulus_pa(m.resonator_young_pa, m.resonator_poisson)
             / reduced_modulus_pa(m.piezo_c11_pa, m.piezo_poisson))
    beta = geometry.resonator_thickness_m / geometry.piezo_thickness_m
    f0 = neutral_plane_m(geometry, convention) / geometry.piezo_thickness_m
    inv = inverse_a(f0, alpha, beta)
    if abs(inv) <= 1e-12 * (1.0 + 2.0 * abs(f0)):
        raise ModelGeometryError(
            f"Eq. 12 numerator 1 - 2 f0 vanishes (f0={f0:.6g}, z0 at the piezo mid-plane): "
            "the piezo produces no bending moment and a is infinite")
    return 1.0 / inv


def _amplitude_per_q(voltage_vpp: float, geometry: PlateGeometry, convention: Convention) -> float:
    """Eq. 27 divided by Q, in the convention's amplitude meaning."""
    m = convention.materials
    v = convention.voltage_in_equation(voltage_vpp)
    a = a_factor(geometry, convention)
    return (convention.n_c_in_equation(geometry) * 3.0 / 64.0 * m.piezo_d31_c_per_n * v
            * geometry.wavelength_m**2 / (geometry.piezo_thickness_m**2 * a))


def amplitude_pp_m(q: float, voltage_vpp: float, geometry: PlateGeometry,
                   convention: Convention) -> float:
    """Eq. 27: A = Q n_c (3/64) d31 V lambda^2 / (h_p^2 a), returned peak-to-peak."""
    return convention.amplitude_pp_from_equation(q * _amplitude_per_q(voltage_vpp, geometry, convention))


def q_from_amplitude(amplitude_pp: float, voltage_vpp: float, geometry: PlateGeometry,
                     convention: Convention) -> float:
    """Eq. 27 solved for the dynamic amplification factor Q."""
    _require_positive(voltage_vpp=voltage_vpp)
    return convention.amplitude_in_equation(amplitude_pp) / _amplitude_per_q(voltage_vpp, geometry, convention)


def _power_per_q_tan(voltage_vpp: float, frequency_hz: float, geometry: PlateGeometry,
                     convention: Convention) -> float:
    """Eq. 25 divided by Q tan(theta')."""
    m = convention.materials
    v = convention.voltage_in_equation(voltage_vpp)
    h_p = geometry.piezo_thickness_m
    z0 = neutral_plane_m(geometry, convention)
    a = a_factor(geometry, convention)
    c11 = _piezo_c11_pa(convention)
    pi = math.pi if convention.eq25_with_pi else 1.0
    return (v**2 * convention.n_c_in_equation(geometry)**2
            * convention.eq25_coefficient * geometry.piezo_length_m * geometry.wavelength_m
            * pi * frequency_hz * m.piezo_d31_c_per_n**2 * c11
            * (2.0 * z0 - h_p) / (h_p**2 * a))


def _piezo_c11_pa(convention: Convention) -> float:
    m = convention.materials
    return reduced_modulus_pa(m.piezo_c11_pa, m.piezo_poisson) if convention.c11_reduced else m.piezo_c11_pa


def power_w(q: float, tan_theta: float, voltage_vpp: float, frequency_hz: float,
            geometry: PlateGeometry, convention: Convention) -> float:
    """Eq. 25: P = V^2 n_c^2 Q tan(theta') (3 b_p lambda / 4) pi f d31^2 c'11 (2 z0 - h_p)/(h_p^2 a)."""
    return q * tan_theta * _power_per_q_tan(voltage_vpp, frequency_hz, geometry, convention)


def tan_theta_from_power(power: float, voltage_vpp: float, q: float, frequency_hz: float,
                         geometry: PlateGeometry, convention: Convention) -> float:
    """Eq. 25 solved for tan(theta'): (Q tan theta' from the power) / Q, as the paper does."""
    _require_positive(voltage_vpp=voltage_vpp, frequency_hz=frequency_hz)
    if q == 0 or not math.isfinite(q):
        raise ModelGeometryError(f"tan(theta') needs a finite non-zero Q, got {q!r}")
    return power / (q * _power_per_q_tan(voltage_vpp, frequency_hz, geometry, convention))


def power_from_amplitude_w(amplitude_pp: float, q: float, tan_theta: float, frequency_hz: float,
                           geometry: PlateGeometry, convention: Convention) -> float:
    """Eq. 28: P = (A^2/Q) tan(theta') f b_p c'11 (2 z0 - h_p) 1024 h_p^2 a / (3 lambda^3).

    Eq. 27 substituted into Eq. 25 carries a factor pi that the print lacks;
    `convention.eq28_with_pi` decides. Note n_c has dropped out.
    """
    amp = convention.amplitude_in_equation(amplitude_pp)
    h_p = geometry.piezo_thickness_m
    z0 = neutral_plane_m(geometry, convention)
    a = a_factor(geometry, convention)
    c11 = _piezo_c11_pa(convention)
    printed = (amp**2 / q * tan_theta * frequency_hz * geometry.piezo_length_m * c11
               * (2.0 * z0 - h_p) * 1024.0 * h_p**2 * a / (3.0 * geometry.wavelength_m**3))
    return printed * math.pi if convention.eq28_with_pi else printed


def q_large_from_small(q_small: float, b_large_m: float, b_small_m: float, as_printed: bool) -> float:
    """Eq. 29: Q_large = Q_small b_large / b_small as printed; the text (Q falls as the piezo
    gets longer) and Table 5 need the inverse ratio b_small / b_large."""
    _require_positive(b_large_m=b_large_m, b_small_m=b_small_m)
    ratio = b_large_m / b_small_m if as_printed else b_small_m / b_large_m
    return q_small * ratio


def _require_positive(**values: float) -> None:
    for name, value in values.items():
        if not (math.isfinite(value) and value > 0):
            raise ModelGeometryError(f"{name} must be a finite positive number, got {value!r}")
