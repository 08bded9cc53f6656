"""The materials and the laminate a bonded piezo makes with the plate, as small pure functions.

Named materials (Table 2 aluminium, the NCE 41 datasheet, the epoxy bond) and their
tolerances; a two-layer section's bending stiffness and mass about its shifted neutral axis
(classical laminate theory); the compliant bond's shear lag (Crawley & de Luis 1987); and
the thick-plate correction onto Mindlin's flexural branch (Mindlin 1951). The modal model
(`plates.plate_modes`) builds on them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from squeezebench.plates.specifications import MODEL_TOLERANCES, sheet_thickness_tolerance


EPSILON_0_F_PER_M = 8.8541878128e-12


@dataclass(frozen=True)
class Isotropic:
    """An isotropic elastic material: Young's modulus, Poisson's ratio, density."""

    young_pa: float
    poisson: float
    density_kg_m3: float

    @property
    def plate_modulus_pa(self) -> float:
        """E / (1 - nu^2): the modulus of a layer in cylindrical (plane-strain) bending."""
        return self.young_pa / (1.0 - self.poisson**2)


@dataclass(frozen=True)
class Piezo(Isotropic):
    """A piezoceramic's constants (NCE 41 datasheet values in `NCE41`)."""

    d31_c_per_n: float = -130e-12
    relative_permittivity_t: float = 1350.0
    k31: float = 0.33
    tan_delta: float = 0.004

    @property
    def plate_e31_c_per_m2(self) -> float:
        """d31 / (s11^E (1 - nu_p)): the stress per field of a patch bonded to a plate."""
        return self.d31_c_per_n * self.young_pa / (1.0 - self.poisson)


# The paper's Table 2 (Young's modulus printed 67109 N/m^2, read as 67.109 GPa: the printed
# value would make the resonator stiffless) and the NCE 41 datasheet (Noliac): eps33^T/eps0
# 1350, k31 0.33, tan delta 0.004 at low field; tolerances +-5 % on d31 and k, +-10 % on eps.
ALUMINIUM_TABLE2 = Isotropic(young_pa=67.109e9, poisson=0.34, density_kg_m3=2790.0)


NCE41 = Piezo(young_pa=80e9, poisson=0.33, density_kg_m3=7900.0)


@dataclass(frozen=True)
class Bond:
    """The adhesive layer between a piezo and the resonator: thickness, shear modulus, loss
    factor (of its shear modulus) and density."""

    thickness_m: float
    shear_modulus_pa: float
    loss_factor: float
    density_kg_m3: float


#: A two-part room-temperature-curing structural epoxy (`specifications.BOND_EPOXY`, whose
#: source says where each figure and its tolerance come from): 40 um pressed bondline, shear
#: modulus 1 GPa, loss factor 0.03, density 1050 kg/m^3.
EPOXY = Bond(thickness_m=40e-6, shear_modulus_pa=1.0e9, loss_factor=0.03, density_kg_m3=1050.0)


RIGID_BOND = Bond(thickness_m=0.0, shear_modulus_pa=math.inf, loss_factor=0.0, density_kg_m3=0.0)


#: Relative half-widths of the inputs' spreads (`specifications.MODEL_TOLERANCES` says where
#: each comes from); a plate's thickness has its sheet's, from its nominal thickness
#: (`relative_tolerances`).
RELATIVE_TOLERANCES = {name: spec.half_width for name, spec in MODEL_TOLERANCES.items()}


def relative_tolerances(thickness_m: float) -> dict[str, float]:
    """Every input's relative half-width for a plate of nominal `thickness_m`."""
    return {**RELATIVE_TOLERANCES, "thickness_m": sheet_thickness_tolerance(thickness_m)}


def relative_standard_uncertainty(name: str, half_width: float) -> float:
    """u of an input of relative half-width `half_width`: rectangular (GUM 4.3.7) but for the
    sheet's thickness, triangular (GUM 4.3.9, `specifications.THICKNESS_DISTRIBUTION`)."""
    return half_width / (math.sqrt(6.0) if name == "thickness_m" else math.sqrt(3.0))


def laminate(resonator: Isotropic, h_r: float, piezo: Isotropic, h_p: float, h_b: float = 0.0):
    """Bending stiffness D (N m), mass per area (kg/m^2, the bond's left out: `bonded_section`)
    and the piezo mid-plane's distance from the neutral axis (m) of a resonator of thickness
    h_r with a piezo layer h_p on one face, a bond layer h_b between them carrying no bending
    stress (classical laminate theory; h_p = 0 gives the bare plate, D = E h^3 / 12(1 - nu^2))."""
    q_r, q_p = resonator.plate_modulus_pa, piezo.plate_modulus_pa
    z_r, z_p = h_r / 2, h_r + h_b + h_p / 2
    z_n = (q_r * h_r * z_r + q_p * h_p * z_p) / (q_r * h_r + q_p * h_p)
    d = (q_r * (h_r**3 / 12 + h_r * (z_r - z_n) ** 2)
         + q_p * (h_p**3 / 12 + h_p * (z_p - z_n) ** 2))
    return d, resonator.density_kg_m3 * h_r + piezo.density_kg_m3 * h_p, z_p - z_n


def shear_lag_effectiveness(resonator: Isotropic, h_r: float, piezo: Isotropic, h_p: float, bond: Bond,
                            patch_length_m: float) -> float:
    """The share of a rigid bond's strain a piezo of length `patch_length_m` (along the bending)
    shares with the resonator's surface, averaged over the patch: Crawley & de Luis (1987,
    AIAA J. 25(10), Eqs. 12-15), shear lag in the bond with Gamma^2 = (G_b / t_b)
    (1 / (E_p' t_p) + alpha / (E_r' t_r)), alpha = 6 for bending, and the strain
    1 - cosh(Gamma x) / cosh(Gamma l / 2) along the patch, whose mean is
    eta = 1 - tanh(Gamma l / 2) / (Gamma l / 2) (plate moduli E/(1 - nu^2): a wide patch on a
    plate). A rigid bond (G_b / t_b infinite) gives 1."""
    if bond.thickness_m == 0.0 or math.isinf(bond.shear_modulus_pa):
        return 1.0
    gamma = math.sqrt(bond.shear_modulus_pa / bond.thickness_m
                      * (1.0 / (piezo.plate_modulus_pa * h_p) + 6.0 / (resonator.plate_modulus_pa * h_r)))
    x = gamma * patch_length_m / 2.0
    return 1.0 - math.tanh(x) / x


def bond_energy_ratio(resonator: Isotropic, h_r: float, piezo: Isotropic, h_p: float, bond: Bond,
                      patch_length_m: float) -> float:
    """Shear strain energy stored in the bond over the piezo's own strain energy, for a patch
    on a surface strained uniformly (Crawley & de Luis's shear lag, as `shear_lag_effectiveness`):
    the bond's shear stress is tau = E_p' t_p d(eps_p)/dx with eps_p = eps0 (1 - cosh(Gamma x) /
    cosh(Gamma l / 2)); integrating tau^2 t_b / 2 G_b over the patch against the piezo's
    E_p' t_p / 2 int eps_p^2 gives, with X = Gamma l / 2,
    (1 + 6 E_p' t_p / (E_r' t_r)) / 2 (sinh 2X / 2X - 1) / cosh^2 X over the piezo's share
    (the rigid bond's energy times its strain's mean square, eta here to first order). 0 for a rigid bond."""
    if bond.thickness_m == 0.0 or math.isinf(bond.shear_modulus_pa):
        return 0.0
    stiffness_ratio = piezo.plate_modulus_pa * h_p / (resonator.plate_modulus_pa * h_r)
    gamma = math.sqrt(bond.shear_modulus_pa / bond.thickness_m
                      * (1.0 / (piezo.plate_modulus_pa * h_p) + 6.0 / (resonator.plate_modulus_pa * h_r)))
    x = gamma * patch_length_m / 2.0
    # sinh(2x)/(2x cosh^2 x) = tanh(x)/x and 1/cosh^2 = 1 - tanh^2: no overflow for a stiff bond
    bond_over_rigid = (1.0 + 6.0 * stiffness_ratio) / 2.0 * (math.tanh(x) / x - 1.0 + math.tanh(x) ** 2)
    return bond_over_rigid / shear_lag_effectiveness(resonator, h_r, piezo, h_p, bond, patch_length_m)


def bonded_section(resonator: Isotropic, h_r: float, piezo: Isotropic, h_p: float, bond: Bond,
                   patch_length_m: float) -> tuple[float, float, float, float]:
    """A bonded patch's section: bending stiffness D (N m), mass per area (kg/m^2), the piezo's
    lever arm z_m (m) and its shear-lag effectiveness eta. The patch adds eta of what a rigid
    bond would add to the bare plate's D (the piezo strains eta as much as the surface under
    it, on average), all of its own and the bond's mass."""
    d_bare, mass_bare, _ = laminate(resonator, h_r, piezo, 0.0)
    d_rigid, mass, z_m = laminate(resonator, h_r, piezo, h_p, bond.thickness_m)
    eta = shear_lag_effectiveness(resonator, h_r, piezo, h_p, bond, patch_length_m)
    return (d_bare + eta * (d_rigid - d_bare), mass + bond.density_kg_m3 * bond.thickness_m, z_m, eta)


SHEAR_COEFFICIENT = 5.0 / 6.0


def mindlin_frequency_ratio(kh: float, poisson: float, shear_coefficient: float = SHEAR_COEFFICIENT) -> float:
    """Mindlin's flexural frequency over Kirchhoff's for a straight-crested wave of wavenumber
    k in a plate of thickness h (Mindlin 1951, J. Appl. Mech. 18, Eq. 25; the Timoshenko
    beam's dispersion relation with the plate modulus): with D = E h^3 / 12 (1 - nu^2),
    S = kappa G h and I = h^3 / 12, per unit rho,
    (S k^2 - h w^2)(D k^2 + S - I w^2) = (S k)^2, a quadratic in w^2 whose lower root is the
    flexural branch; Kirchhoff's w^2 = D k^4 / h. Depends on k h, nu and kappa only."""
    h, k = 1.0, kh
    d = 1.0 / (12.0 * (1.0 - poisson**2))
    shear = shear_coefficient / (2.0 * (1.0 + poisson))
    inertia = 1.0 / 12.0
    a = h * inertia
    b = -(shear * k**2 * inertia + h * (d * k**2 + shear))
    c = shear * d * k**4
    lower = 2.0 * c / (-b + math.sqrt(b * b - 4.0 * a * c))   # the smaller root, without cancellation
    return math.sqrt(lower / (d * k**4 / h))


def thick_plate_frequency_hz(kirchhoff_hz: float, resonator: Isotropic, thickness_m: float) -> float:
    """A Kirchhoff frequency moved onto Mindlin's branch at the bare plate's equivalent
    wavenumber k = (w^2 rho h / D)^(1/4) (`mindlin_frequency_ratio`)."""
    if kirchhoff_hz <= 0.0:
        return kirchhoff_hz
    d, mass, _ = laminate(resonator, thickness_m, resonator, 0.0)
    k = ((2 * math.pi * kirchhoff_hz) ** 2 * mass / d) ** 0.25
    return kirchhoff_hz * mindlin_frequency_ratio(k * thickness_m, resonator.poisson)


def kirchhoff_frequency_hz(frequency_hz: float, resonator: Isotropic, thickness_m: float) -> float:
    """The Kirchhoff frequency whose Mindlin correction is `frequency_hz` (`thick_plate_frequency_hz`
    inverted by fixed-point iteration: the ratio moves by a few per cent, each step takes about
    a tenth off the error)."""
    kirchhoff = frequency_hz
    for _ in range(50):
        step = frequency_hz * kirchhoff / thick_plate_frequency_hz(kirchhoff, resonator, thickness_m)
        if abs(step - kirchhoff) <= 1e-12 * kirchhoff:
            break
        kirchhoff = step
    return step
