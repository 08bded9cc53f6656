"""Modal model of a resonator plate with bonded piezo patches, from geometry and datasheets.

Pure physics (no instrument, no run data): the simulator builds predicted scenes from it and
the report prints what it predicts beside the paper's values (docs/design.md, "The plate
model"). The materials, the laminate, the bond's shear lag and the thick-plate correction
are `plates.laminate`'s.

The plate is a Kirchhoff plate (scikit-fem's Argyris triangle, C1-conforming quintic, its
basis built in one pass by `plates.argyris`: 1.5
elements per flexural half-wave give the frequency to 0.1 %), free on all edges as the
paper's plates lay on a cushion (Sec. 2.1). Where a piezo is bonded the section is a
two-layer laminate: bending stiffness about the shifted neutral axis and mass per area of
both layers (classical laminate theory, each layer's plate modulus E/(1-nu^2)). The eigenproblem
K phi = w^2 M phi is solved by SciPy's ARPACK in shift-invert mode near the drive.

Two model-form terms Kirchhoff's laminate lacks are corrected, not absorbed in a tolerance:
- thick plate: each mode's frequency is moved onto Mindlin's flexural branch (shear and
  rotary inertia, `mindlin_frequency_ratio`) at the mode's equivalent wavenumber
  k^4 = w_K^2 rho h / D of the bare plate (exact for a simply supported plate, Mindlin 1951;
  a free plate's (n, 0) modes are sines away from the edges): -3 % at 1 mm, -4 % at
  1.2 mm, -8 % at 2 mm for these half-wavelengths;
- compliant bond: the epoxy layer between piezo and plate transfers strain by shear over a
  length 1/Gamma (Crawley & de Luis 1987's shear lag, `shear_lag_effectiveness`), so a
  patch stiffens the plate, and drives it, by the fraction eta of a rigid bond's; the
  layer also moves the piezo away from the neutral axis by its thickness and adds its mass.

Electromechanical coupling of a piezo (thin patch, field through its thickness, both faces
electroded): the piezo's in-plane stress per volt is e_eff / h_p with the plate constant
e_eff = d31 / (s11^E (1 - nu_p)) (biaxial clamping by a plate; the beam constant d31/s11^E
holds only for a narrow strip). Its bending moment per volt is e_eff z_m, z_m the distance
of the piezo mid-plane from the laminate's neutral axis, and by virtual work the modal force
per volt of a mass-normalised mode phi is

    Theta = e_eff z_m \\int_patch (phi_xx + phi_yy) dA          (N/V per unit modal mass^0.5)

Clamped capacitance C0 = eps33^T (1 - k31^2) A / h_p; k_eff^2 = Theta^2 / (w^2 C0) for the
powered set. All SI units.
"""

from __future__ import annotations

import copy
import functools
import hashlib
import json
import math
from dataclasses import dataclass, field, fields, is_dataclass, replace
from typing import Callable

import numpy as np
from scipy.sparse.linalg import eigsh

from squeezebench.disk_cache import ArrayStore, cache_dir, source_fingerprint
from squeezebench.lru import RecentlyUsed
from squeezebench.plates.laminate import (ALUMINIUM_TABLE2, EPOXY, EPSILON_0_F_PER_M, NCE41, Bond, Isotropic, Piezo,
                                          bond_energy_ratio, bonded_section, kirchhoff_frequency_hz, laminate,
                                          thick_plate_frequency_hz)


@dataclass(frozen=True)
class Patch:
    """One bonded piezo: centre and sides (x along the plate's length), and whether powered."""

    x_center_m: float
    y_center_m: float
    length_x_m: float
    width_y_m: float
    thickness_m: float
    powered: bool = True
    name: str = ""

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        return (self.x_center_m - self.length_x_m / 2, self.x_center_m + self.length_x_m / 2,
                self.y_center_m - self.width_y_m / 2, self.y_center_m + self.width_y_m / 2)


@dataclass(frozen=True)
class PlateGeometry:
    """A rectangular resonator [0, length] x [0, width], free edges, with its piezo patches."""

    length_m: float
    width_m: float
    thickness_m: float
    patches: tuple[Patch, ...] = ()

    def cut_to(self, length_m: float) -> "PlateGeometry":
        """The plate cut symmetrically to `length_m`: patches keep their place on the metal,
        and a patch cut through is removed (a cut is a new geometry, solved again)."""
        offset = (self.length_m - length_m) / 2
        kept = tuple(
            Patch(p.x_center_m - offset, p.y_center_m, p.length_x_m, p.width_y_m, p.thickness_m,
                  p.powered, p.name)
            for p in self.patches
            if p.bounds[0] >= offset - 1e-12 and p.bounds[1] <= offset + length_m + 1e-12)
        return PlateGeometry(length_m, self.width_m, self.thickness_m, kept)

    def layout_problem(self, kind: str) -> str | None:
        """Why the patches cannot be bonded as placed (None if they can): one overhangs the
        plate, or two share area, within one `kind` (a design's group, a scene's column) or
        across two. The model would solve either without complaint: a patch off the metal
        or two patches in one spot are no plate."""
        def mm(value_m: float) -> str:
            return f"{value_m * 1e3:.6g}"

        for p in self.patches:
            x0, x1, y0, y1 = p.bounds
            if x0 < -1e-12 or x1 > self.length_m + 1e-12 or y0 < -1e-12 or y1 > self.width_m + 1e-12:
                return (f"{kind} {p.name!r}: a piezo {mm(p.length_x_m)} x {mm(p.width_y_m)} mm centred at "
                        f"({mm(p.x_center_m)}, {mm(p.y_center_m)}) mm overhangs the plate "
                        f"(0 to {mm(self.length_m)} x 0 to {mm(self.width_m)} mm)")
        for i, a in enumerate(self.patches):
            for b in self.patches[i + 1:]:
                if (abs(a.x_center_m - b.x_center_m) < (a.length_x_m + b.length_x_m) / 2 - 1e-12
                        and abs(a.y_center_m - b.y_center_m) < (a.width_y_m + b.width_y_m) / 2 - 1e-12):
                    who = f"{kind} {a.name!r}" if a.name == b.name else f"{kind}s {a.name!r} and {b.name!r}"
                    return (f"{who}: piezos {mm(a.length_x_m)} x {mm(a.width_y_m)} mm centred at "
                            f"({mm(a.x_center_m)}, {mm(a.y_center_m)}) and ({mm(b.x_center_m)}, "
                            f"{mm(b.y_center_m)}) mm overlap")
        return None


def column(x_center_m: float, plate_width_m: float, piezo_length_x_m: float,
           piezo_width_y_m: float, piezo_thickness_m: float, count: int,
           powered: bool = True, name: str = "") -> tuple[Patch, ...]:
    """`count` piezos side by side along y, centred on the plate's width (a paper column)."""
    first = plate_width_m / 2 - count * piezo_width_y_m / 2 + piezo_width_y_m / 2
    return tuple(Patch(x_center_m, first + i * piezo_width_y_m, piezo_length_x_m,
                       piezo_width_y_m, piezo_thickness_m, powered, name) for i in range(count))


@dataclass
class PlateModes:
    """The modes of one plate near a drive frequency (mass-normalised, M = identity).

    `shapes[k]` is mode k's deflection on the grid `x_m` x `y_m` (shape (nx, ny)), scaled so
    that its largest |w| is 1; `modal_mass_kg[k]` is the mass referred to that point of
    largest deflection, `modal_stiffness_n_per_m` = w^2 M likewise. `force_factor_n_per_v[k, i]`
    is piezo i's modal force per volt referred to the same point (sign kept: piezos at
    opposite-sign curvature pull against each other)."""

    frequencies_hz: np.ndarray
    x_m: np.ndarray
    y_m: np.ndarray
    shapes: np.ndarray
    modal_mass_kg: np.ndarray
    force_factor_n_per_v: np.ndarray
    clamped_capacitance_f: np.ndarray
    powered: np.ndarray
    plate_mass_kg: float
    uniformity: np.ndarray = field(repr=False)
    #: the same modes' thin-plate (Kirchhoff) frequencies, before the thick-plate correction
    kirchhoff_frequencies_hz: np.ndarray = field(repr=False, default=None)
    #: each patch's shear-lag effectiveness eta (`shear_lag_effectiveness`)
    bond_effectiveness: np.ndarray = field(repr=False, default=None)
    #: per mode, the share of its strain energy the patches add over the bare plate (the
    #: piezo layers' share, for `plates.damping`), and per patch the bond's energy over that
    piezo_energy_share: np.ndarray = field(repr=False, default=None)
    bond_energy_ratio: np.ndarray = field(repr=False, default=None)
    #: per mode, int phi^2 dA over the plate of the mass-normalised mode (m^2/kg; the face
    #: losses' weight, `plates.damping`), None for a plate solved otherwise (a reduced model's)
    face_integral_m2_per_kg: np.ndarray | None = field(repr=False, default=None)
    _probe: object = field(repr=False, default=None)  # points (2, N), mode k -> mass-normalised deflections (N)
    _modal_force: np.ndarray = field(repr=False, default=None)  # Theta (modes, patches), mass-normalised
    _peak: np.ndarray = field(repr=False, default=None)  # mass-normalised deflection at each mode's peak
    #: the solve's key in the disk cache (`stored_solves`); None for a plate solved otherwise
    stored_key: str | None = field(repr=False, default=None)
    #: about what keeping it in memory costs (its arrays, its eigenvectors and its probe's basis)
    held_bytes: int = field(repr=False, default=0)

    def shape_at(self, k: int, x_m, y_m) -> np.ndarray:
        """Mode k's deflection at the points (x, y), scaled as `shapes` (+1 at its largest),
        from the elements (not interpolated on the grid); 0 off the plate."""
        x_m, y_m = np.broadcast_arrays(np.asarray(x_m, dtype=float), np.asarray(y_m, dtype=float))
        on = (x_m >= 0) & (x_m <= self.x_m[-1]) & (y_m >= 0) & (y_m <= self.y_m[-1])
        values = np.zeros(x_m.shape)
        if on.any():
            values[on] = self._probe(np.vstack([x_m[on], y_m[on]]), k) / self._peak[k]
        return values

    def deflection_at(self, k: int, x_m: float, y_m: float) -> float:
        """Mode k's mass-normalised deflection (1/sqrt(kg)) at (x, y), from the elements."""
        return float(self._probe(np.array([[x_m], [y_m]]), k)[0])

    def referred_to(self, k: int, x_m: float, y_m: float) -> tuple[float, np.ndarray]:
        """Modal mass (kg) and per-piezo force factors (N/V) of mode k referred to the point
        (x, y): M = 1 / phi(p)^2, A_i = Theta_i / phi(p), so M x'' + K x = sum A_i V_i there."""
        phi = self.deflection_at(k, x_m, y_m)
        return 1.0 / phi**2, self._modal_force[k] / phi

    @property
    def modal_stiffness_n_per_m(self) -> np.ndarray:
        return self.modal_mass_kg * (2 * np.pi * self.frequencies_hz) ** 2

    def interior_antinodes(self, k: int) -> int:
        """Antinodes between the nodal lines across the length (the paper's 'nb of antinodes':
        a free-free (n, 0) mode with n nodal lines has n - 1 between them)."""
        return len(self.nodal_lines_m(k)) - 1

    def nodal_lines_m(self, k: int) -> np.ndarray:
        """x positions where the width-averaged deflection of mode k changes sign."""
        return sign_changes(self.x_m, self.shapes[k].mean(axis=1))

    def half_wavelength_m(self, k: int) -> float:
        """Mean spacing of the interior nodal lines (the first and last sit near free edges,
        where the spacing is shorter, so they are left out when there are enough lines)."""
        lines = self.nodal_lines_m(k)
        inner = lines[1:-1] if len(lines) >= 5 else lines
        return float(np.diff(inner).mean())

    def working_mode(self, near_hz: float, min_uniformity: float = 0.8) -> int:
        """Index of the (n, 0) mode (deflection nearly uniform across the width, nodal lines
        parallel to it) closest to `near_hz`; the paper drives every plate in such a mode."""
        candidates = np.nonzero(self.uniformity >= min_uniformity)[0]
        if candidates.size == 0:
            raise ValueError(f"no (n, 0) mode among {len(self.frequencies_hz)} modes near "
                             f"{near_hz:.0f} Hz; widen the band")
        return int(candidates[np.argmin(abs(self.frequencies_hz[candidates] - near_hz))])

    def coupling(self, k: int) -> dict:
        """The powered piezos' lumped electromechanics for mode k, referred to the point of
        largest deflection: force factor (N/V), clamped C0 (F), k_eff and the BVD motional
        branch per unit mechanical loss (L_m = M / A^2, C_m = A^2 / K; R_m = w M / (q A^2))."""
        on = self.powered
        a = float(self.force_factor_n_per_v[k, on].sum())
        c0 = float(self.clamped_capacitance_f[on].sum())
        m, kk = float(self.modal_mass_kg[k]), float(self.modal_stiffness_n_per_m[k])
        return {"force_factor_n_per_v": a, "clamped_capacitance_f": c0,
                "k_eff": float(np.sqrt(a**2 / (kk * c0 + a**2))) if c0 else 0.0,
                "motional_inductance_h": m / a**2 if a else np.inf,
                "motional_capacitance_f": a**2 / kk}


def _grid(length: float, extra: list[float], target: float) -> np.ndarray:
    """Grid lines 0..length about `target` apart that include every patch edge in `extra`."""
    knots = np.unique(np.clip([0.0, length, *extra], 0.0, length))
    points = [np.linspace(a, b, max(1, int(np.ceil((b - a) / target))) + 1)[:-1]
              for a, b in zip(knots[:-1], knots[1:]) if b - a > 1e-9]
    return np.append(np.concatenate(points), length)


def _key(geometry: PlateGeometry, resonator: Isotropic, piezo: Piezo, near_hz: float,
         n_modes: int, elements_per_half_wave: float, mesh_half_wave_m: float | None, bond: Bond,
         thick_plate: bool) -> str:
    text = json.dumps([_plain(geometry), _plain(resonator), _plain(piezo), near_hz, n_modes,
                       elements_per_half_wave, mesh_half_wave_m, _plain(bond), thick_plate],
                      sort_keys=True, default=float)
    return hashlib.sha256(text.encode()).hexdigest()


def _plain(value):
    """`value` as `dataclasses.asdict` hands it to JSON (a dataclass as the dict of its fields,
    a tuple as a list), without asdict's deep copy of every field: the simulated stage reads
    the solved plate at every spot it moves to, and asdict made most of a read's 1 ms."""
    if is_dataclass(value):
        return {f.name: _plain(getattr(value, f.name)) for f in fields(value)}
    if isinstance(value, (tuple, list)):
        return [_plain(item) for item in value]
    return value


#: Solved plates: a campaign's few plates stay, a layout sweep's hundreds (each solved
#: once) do not pile up in a worker's memory. 32: the test suite's design and prediction
#: modules solved 17 of their 86 plates twice with 16, 8 with 32. And at most 96 MB as
#: `held_bytes` counts them (the large plate about 11 MB, a 76 mm one about 1 MB): 32 large
#: plates held 1.5 GB, and a worker of loky's (the parallel engine's) that grows 300 MB
#: past its size after its first task is retired as leaking, with "A worker stopped while
#: some jobs were given to the executor" when tasks wait, and started again from nothing.
_CACHE: RecentlyUsed[PlateModes] = RecentlyUsed(32, max_bytes=96 * 2**20, weigh=lambda modes: modes.held_bytes)

#: The disk cache of solves (`stored_solves`) stays under this size: a stored solve is
#: mostly its eigenvectors, about 0.2 MB for a 76 mm plate and 5 MB for the large one.
STORED_SOLVES_BYTES_LIMIT = 256 * 2**20


def stored_solves() -> ArrayStore:
    """Solves kept on disk for the next process (`disk_cache`: `plates/` of its folder; none
    with $SQUEEZEBENCH_CACHE=off): `reproduce`, its study's workers, a design sweep's workers
    and the test suite's workers each solve the paper's plates otherwise (seconds each)."""
    folder = cache_dir()
    return ArrayStore(None if folder is None else folder / "plates", STORED_SOLVES_BYTES_LIMIT)


@functools.cache
def solver_fingerprint() -> str:
    """What decides a solve besides its inputs: the plate model's source and the versions
    of the libraries that solve it (a stored solve of other code is never read)."""
    import scipy
    import skfem

    return f"{source_fingerprint(('squeezebench.plates',))} numpy {np.__version__} scipy {scipy.__version__} " \
           f"scikit-fem {skfem.__version__}"


def solve_plate(geometry: PlateGeometry, resonator: Isotropic = ALUMINIUM_TABLE2,
                piezo: Piezo = NCE41, near_hz: float = 40e3, n_modes: int | None = None,
                elements_per_half_wave: float = 1.5, mesh_half_wave_m: float | None = None,
                band_rel: float = 0.16, bond: Bond = EPOXY, thick_plate: bool = True) -> PlateModes:
    """The `n_modes` modes nearest `near_hz` of `geometry` (cached by geometry, materials and
    mesh: a campaign solves each plate once; kept on disk for other processes,
    `stored_solves`). The mesh size follows the bare plate's flexural
    half-wavelength at `near_hz`, pi / (w^2 rho h / D)^(1/4). By default the modes cover
    about +-8 % of `near_hz` (a plate's modal density is S/2 sqrt(rho h / D) per hertz), so
    the (n, 0) neighbours, about 2/n apart in frequency, are in view (`band_rel` is that
    band's whole width, relative). `mesh_half_wave_m`
    fixes that mesh size instead: solves of one plate whose materials move by their
    tolerances then share one mesh, so their differences are physics, not remeshing.
    `bond` is the adhesive under every patch (`RIGID_BOND`: the classical laminate);
    `thick_plate` False leaves the frequencies Kirchhoff's. Plates that differ only in which
    patches are powered, or in their names, share one solve (`mechanical`)."""
    if n_modes is None:
        n_modes = mode_count(geometry, resonator, piezo, near_hz, band_rel)

    def key(plate: PlateGeometry) -> str:
        return _key(plate, resonator, piezo, near_hz, n_modes, elements_per_half_wave, mesh_half_wave_m, bond,
                    thick_plate)

    plate = mechanical(geometry)

    def solved() -> PlateModes:
        plate_key = key(plate)   # one key a read: the stored solve's is made only to solve
        return _CACHE.get(plate_key, lambda: _solve(
            plate, resonator, piezo, near_hz, n_modes, elements_per_half_wave, mesh_half_wave_m, bond, thick_plate,
            hashlib.sha256(f"{solver_fingerprint()}\0{plate_key}".encode()).hexdigest()))

    if plate == geometry:
        return solved()
    powered = np.array([p.powered for p in geometry.patches], dtype=bool)
    return _CACHE.get(key(geometry), lambda: replace(solved(), powered=powered))


def mechanical(geometry: PlateGeometry) -> PlateGeometry:
    """`geometry` as its eigenproblem sees it: every patch powered and unnamed (a patch
    stiffens, weighs and couples alike whether a drive is wired to it; `PlateModes.powered`
    only says which patches' forces a drive sums)."""
    return replace(geometry, patches=tuple(replace(p, powered=True, name="") for p in geometry.patches))


def _thin_half_wavelength_m(material: Isotropic, thickness_m: float, kirchhoff_hz: float) -> float:
    """Half-wavelength pi/k of bending waves in a thin (Kirchhoff) plate, k^4 = w^2 rho h / D."""
    d, mass, _ = laminate(material, thickness_m, material, 0.0)
    return float(np.pi / ((2 * np.pi * kirchhoff_hz) ** 2 * mass / d) ** 0.25)


def mode_count(geometry: PlateGeometry, resonator: Isotropic, piezo: Piezo, near_hz: float,
               band_rel: float) -> int:
    """How many modes cover the band `band_rel` (whole width, relative) about `near_hz`: a
    plate's modal density is S/2 sqrt(rho h / D) per hertz; at least 12."""
    d, mass, _ = laminate(resonator, geometry.thickness_m, piezo, 0.0)
    density_per_hz = geometry.length_m * geometry.width_m / 2 * np.sqrt(mass / d)
    return max(12, int(np.ceil(band_rel * near_hz * density_per_hz)))


def mesh_lines(geometry: PlateGeometry, resonator: Isotropic, kirchhoff_hz: float, elements_per_half_wave: float,
               mesh_half_wave_m: float | None = None, x_edges=None, y_edges=None) -> tuple[np.ndarray, ...]:
    """The mesh lines x, y of a solve (about `elements_per_half_wave` elements per flexural
    half-wave at the eigenproblem's frequency `kirchhoff_hz`, a line on every patch edge, or
    on `x_edges` and `y_edges` when given) and its shape grid gx, gy."""
    half_wave = mesh_half_wave_m or _thin_half_wavelength_m(resonator, geometry.thickness_m, kirchhoff_hz)
    target = half_wave / elements_per_half_wave
    x = _grid(geometry.length_m, [b for p in geometry.patches for b in p.bounds[:2]] if x_edges is None
              else list(x_edges), target)
    y = _grid(geometry.width_m, [b for p in geometry.patches for b in p.bounds[2:]] if y_edges is None
              else list(y_edges), target)
    # Shapes on a grid fine enough to place nodal lines (4 points per half-wave: zero crossings interpolate to ~1 % of it).
    gx = np.linspace(0, geometry.length_m, int(np.ceil(4 * geometry.length_m / half_wave)) + 1)
    gy = np.linspace(0, geometry.width_m, int(np.ceil(4 * geometry.width_m / half_wave)) + 1)
    return x, y, gx, gy


def clamped_capacitance_f(piezo: Piezo, patch: Patch) -> float:
    """C0 = eps33^T (1 - k31^2) A / h_p of one piezo (thin patch, electroded faces)."""
    return (EPSILON_0_F_PER_M * piezo.relative_permittivity_t * (1 - piezo.k31**2)
            * patch.length_x_m * patch.width_y_m / patch.thickness_m)


def flexural_half_wavelength_m(material: Isotropic, thickness_m: float, frequency_hz: float) -> float:
    """Half-wavelength of bending waves at `frequency_hz` in the model's plate: Kirchhoff's
    k^4 = w_K^2 rho h / D at the Kirchhoff frequency whose thick-plate correction is
    `frequency_hz` (`kirchhoff_frequency_hz`)."""
    return _thin_half_wavelength_m(material, thickness_m, kirchhoff_frequency_hz(frequency_hz, material, thickness_m))


#: One point per element (the reference triangle's centroid): the quadrature of the basis
#: probing is read from, which evaluates no function anywhere else.
_CENTROID = (np.array([[1.0 / 3.0], [1.0 / 3.0]]), np.array([0.5]))


@functools.lru_cache(maxsize=2)   # a basis of a large plate holds tens of MB: the current mesh and one more
def _discretisation(x: tuple[float, ...], y: tuple[float, ...], gx: tuple[float, ...], gy: tuple[float, ...]):
    """Mesh, Argyris basis (a function: built on its first call) and the probe of the shape
    grid (gx x gy) for mesh lines x, y: most of a solve's time, and the same for plates that
    differ only in materials or thicknesses (a layout sweep's thickness variants, a
    tolerance's nearby solve).

    Only an assembly needs the basis's functions and derivatives at the quadrature points
    (about four fifths of this discretisation's time): a solve read from the disk cache
    (`stored_solves`) probes, which reads the mesh's mapping, dofs and inverse Vandermonde
    matrices alone, the same whatever the quadrature; so they come from a basis on one point
    per element, and the assembly's is built when a solve asks for it."""
    from skfem import Basis, MeshTri

    from .argyris import Argyris

    mesh = MeshTri.init_tensor(np.array(x), np.array(y))
    # What probing reads of the basis, without its functions' derivatives at the quadrature
    # points (the large plate: 33 MB of its 46): every plate solved on this mesh keeps its
    # probe, and the probe this, long after the basis has left this cache.
    probing = ProbingBasis(Basis(mesh, Argyris(), quadrature=_CENTROID))
    find = tensor_finder(mesh, probing.mapping, np.array(x), np.array(y))
    points = np.array(np.meshgrid(np.array(gx), np.array(gy), indexing="ij")).reshape(2, -1)
    probes: dict[bytes, object] = {}

    @functools.cache
    def basis():
        """The assembly's basis (its element a copy of probing's: the Vandermonde matrices
        already inverted)."""
        return Basis(mesh, copy.copy(probing.elem), intorder=8)

    def probe(p: np.ndarray):
        """The basis evaluated at points p (2, N), kept: a sweep asks for the same touch grid
        on every plate that shares this mesh."""
        key = np.ascontiguousarray(p, dtype=float).tobytes()
        if key not in probes:
            if len(probes) > 32:
                probes.clear()
            probes[key] = _probes(probing, p, find)
        return probes[key]

    probe.held_bytes = probing.nbytes
    return mesh, basis, _probes(probing, points, find), probe


class ProbingBasis:
    """What `argyris.probes` reads of a basis (mesh, mapping, dofs, the element's inverse
    Vandermonde matrices), without the basis functions it evaluated for assembly."""

    def __init__(self, basis) -> None:
        self.mesh, self.mapping, self.element_dofs = basis.mesh, basis.mapping, basis.element_dofs
        self.Nbfun, self.N = basis.Nbfun, basis.N
        self.elem = copy.copy(basis.elem)
        self.elem._kept = (None, None, None)   # the copy keeps no evaluated functions

    @property
    def nbytes(self) -> int:
        mapping = [value for value in vars(self.mapping).values() if isinstance(value, np.ndarray)]
        return sum(a.nbytes for a in [self.elem.V, self.element_dofs, self.mesh.p, self.mesh.t, *mapping])


def tensor_finder(mesh, mapping, x: np.ndarray, y: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """The element each of points (2, N) lies in, on `MeshTri.init_tensor(x, y)`: its
    rectangle by bisection of the mesh lines, then whichever of the rectangle's two
    triangles holds it (the larger least barycentric coordinate, so a point on their
    diagonal or just off the plate by roundoff gets one). skfem's `element_finder` tests
    each point against the elements of five nearest centres of every point asked at once,
    a cost that grows as the square of the points."""
    centres = mesh.p[:, mesh.t].mean(axis=1)
    rectangles = (np.searchsorted(x, centres[0]) - 1) * (len(y) - 1) + np.searchsorted(y, centres[1]) - 1
    pairs = np.argsort(rectangles, kind="stable").reshape(-1, 2)   # row r: rectangle r's two triangles
    assert np.array_equal(np.sort(rectangles), np.repeat(np.arange(len(pairs)), 2)), "not a tensor mesh"

    def find(points: np.ndarray) -> np.ndarray:
        i = np.clip(np.searchsorted(x, points[0], side="right") - 1, 0, len(x) - 2)
        j = np.clip(np.searchsorted(y, points[1], side="right") - 1, 0, len(y) - 2)
        candidates = pairs[i * (len(y) - 1) + j]
        least = []
        for side in (0, 1):
            u, v = mapping.invF(points[:, :, np.newaxis], tind=candidates[:, side])[:, :, 0]
            least.append(np.minimum(np.minimum(u, v), 1 - u - v))
        return np.where(least[0] >= least[1], candidates[:, 0], candidates[:, 1])
    return find


def _probes(basis, points: np.ndarray, find: Callable[[np.ndarray], np.ndarray], chunk: int = 1024):
    """`basis.probes(points)` (`argyris.probes`, its elements by `find`) a chunk at a time:
    the Argyris basis's evaluation holds each point's 21 x 21 coefficients (the large
    plate's 1 mm shape table, 27,700 points: 1.4 GB at once with skfem's own probes, 0.1 GB
    in chunks of 1024)."""
    from scipy.sparse import vstack

    from .argyris import probes

    return vstack([probes(basis, points[:, i:i + chunk], find(points[:, i:i + chunk]))
                   for i in range(0, points.shape[1], chunk)]).tocsr()


def flexural_frequency_hz(material: Isotropic, thickness_m: float, half_wavelength_m: float) -> float:
    """The frequency of bending waves of half-wavelength `half_wavelength_m` in the model's
    plate, the inverse of `flexural_half_wavelength_m`: Kirchhoff's w = (pi / (lambda/2))^2
    sqrt(D / rho h) moved onto Mindlin's branch (`thick_plate_frequency_hz`)."""
    d, mass, _ = laminate(material, thickness_m, material, 0.0)
    thin = float((np.pi / half_wavelength_m) ** 2 * np.sqrt(d / mass) / (2 * np.pi))
    return thick_plate_frequency_hz(thin, material, thickness_m)


def stiffness_and_mass(basis, rigidity_per_element: np.ndarray, mass_per_element: np.ndarray,
                       poisson: float) -> tuple:
    """The Kirchhoff plate's stiffness and mass matrices (CSR) on `basis` (a scalar skfem
    basis with Hessians): the bilinear forms D [(1 - nu) w,ab v,ab + nu w,aa v,bb] and
    rho h w v, D and rho h constant on each element. The same quadrature as skfem's `asm`,
    each element's 21 x 21 block as one batched matrix product instead of a loop over the
    pairs of basis functions (four times faster on the large plate; equal to roundoff).
    An element of zero rigidity gets a zero stiffness block without its products: a solve's
    second assembly, of the patches' added rigidity alone, is zero off the patches (the large
    plate's took 0.05-0.07 CPU-s, 0.023 so; its matrices the same to the bit)."""
    from scipy.sparse import coo_matrix

    fields = [functions[0] for functions in basis.basis]
    n = len(fields)
    dx = basis.dx   # quadrature weight x Jacobian, (elements, points)
    elements, points = dx.shape
    rigid = np.flatnonzero(rigidity_per_element)
    hessians = np.stack([f.hess[:, :, rigid] for f in fields]).reshape(n, 4, len(rigid), points).transpose(2, 0, 1, 3)
    traces = hessians[:, :, 0, :] + hessians[:, :, 3, :]   # (rigid elements, n, points)
    hessians = hessians.reshape(len(rigid), n, 4 * points)
    weight = rigidity_per_element[rigid, None] * dx[rigid]
    full = np.matmul(hessians * np.tile(weight, 4)[:, None, :], hessians.transpose(0, 2, 1))
    laplacians = np.matmul(traces * weight[:, None, :], traces.transpose(0, 2, 1))
    stiffness = np.zeros((elements, n, n))
    stiffness[rigid] = (1 - poisson) * full + poisson * laplacians
    values = np.stack([f.get(0) for f in fields]).transpose(1, 0, 2)   # (elements, n, points)
    mass = np.matmul(values * (mass_per_element[:, None] * dx)[:, None, :], values.transpose(0, 2, 1))
    dofs = basis.element_dofs.T   # block (e, j, i) couples dof i (row) with dof j (column)
    rows = np.broadcast_to(dofs[:, None, :], (elements, n, n)).ravel()
    columns = np.broadcast_to(dofs[:, :, None], (elements, n, n)).ravel()
    shape = (basis.N, basis.N)
    return (coo_matrix((stiffness.ravel(), (rows, columns)), shape=shape).tocsr(),
            coo_matrix((mass.ravel(), (rows, columns)), shape=shape).tocsr())


def _solve(geometry, resonator, piezo, near_hz, n_modes, elements_per_half_wave, mesh_half_wave_m: float | None,
           bond: Bond, thick_plate: bool, stored_key: str) -> PlateModes:
    """The modes of `geometry` on its mesh: the eigenpairs and patch integrals
    (`_eigenpairs`, nearly all a solve's time) read from the disk cache under `stored_key`
    when a process solved them before (`stored_solves`), the rest made from them here."""
    # the eigenproblem is Kirchhoff's: look for its modes where their corrected frequencies fall near the drive
    near_hz = eigenproblem_hz(near_hz, resonator, geometry.thickness_m, thick_plate)
    x, y, gx, gy = mesh_lines(geometry, resonator, near_hz, elements_per_half_wave, mesh_half_wave_m)
    mesh, basis, grid_probe, probe = _discretisation(*(tuple(a.tolist()) for a in (x, y, gx, gy)))
    sections = patch_sections(geometry, resonator, piezo, bond)

    def solved() -> dict[str, np.ndarray]:
        # One BLAS thread (`single_threaded`): the same bits in whichever process solves, and
        # no second thread spinning on a core the campaign and the study keep busy.
        with single_threaded():
            return _eigenpairs(geometry, resonator, piezo, near_hz, n_modes, sections, mesh, basis())

    found = stored_solves().get(stored_key, solved)
    return replace(modes_from_vectors(geometry, resonator, piezo, bond, thick_plate, sections, found["eigenvalues"],
                                      found["vectors"], gx, gy, grid_probe, probe, found["patch_laplacians"],
                                      found["added_energy"], found["face_integrals"]), stored_key=stored_key)


def single_threaded():
    """The numerical libraries' thread pools (OpenBLAS, OpenMP) at one thread, for a block
    (threadpoolctl). ARPACK's and the B-spline solver's vector sums split over two threads
    add in another order, so a solve read otherwise in the 16th digit depending on the
    process that made it (`protocols.parallel` runs its tasks at one thread, the report's
    drawing process ran at two); and a plate's products are too small to gain from a second
    thread: at two, OpenBLAS's waiting thread spun, and the cold `reproduce`'s solves and
    tables took 14.2 CPU-s against 6.1 at one (eigsh 7.9 against 2.8, the tables' spline fit
    2.2 against 0.1), on a machine whose two cores the campaign and the study kept busy."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1)


def _eigenpairs(geometry, resonator, piezo, kirchhoff_hz, n_modes, sections, mesh, basis) -> dict[str, np.ndarray]:
    """The mass-normalised Kirchhoff eigenpairs nearest `kirchhoff_hz` of the plate with its
    patches' `sections` (eigenvalues ascending, vectors (dofs, modes)), each mode's integral
    of phi_xx + phi_yy over each patch, the patches' added rigidity's energy in it and its face
    integral int phi^2 dA (m^2/kg, `PlateModes.face_integral_m2_per_kg`)."""
    from skfem import LinearForm
    from skfem.helpers import dd, trace

    centres = mesh.p[:, mesh.t].mean(axis=1)
    d_bare, mass_bare, _ = laminate(resonator, geometry.thickness_m, piezo, 0.0)
    d_e = np.full(mesh.nelements, d_bare)
    m_e = np.full(mesh.nelements, mass_bare)
    inside = []
    for p, section in zip(geometry.patches, sections):
        x0, x1, y0, y1 = p.bounds
        mask = ((centres[0] > x0) & (centres[0] < x1) & (centres[1] > y0) & (centres[1] < y1))
        d_e[mask], m_e[mask] = section[:2]
        inside.append(mask)

    @LinearForm
    def laplacian(v, w):
        return trace(dd(v))

    k_mat, m_mat = stiffness_and_mass(basis, d_e, m_e, resonator.poisson)
    sigma = (2 * np.pi * kirchhoff_hz) ** 2
    n = min(n_modes, k_mat.shape[0] - 2)
    # a fixed start vector: ARPACK's random one would flip mode signs from run to run
    eigenvalues, vectors = eigsh(k_mat, k=n, M=m_mat, sigma=sigma, which="LM", tol=1e-9,
                                 v0=np.ones(k_mat.shape[0]))
    order = np.argsort(eigenvalues)
    eigenvalues, vectors = eigenvalues[order], vectors[:, order]

    # per element, then summed over each patch's elements: one assembly for every patch
    per_element_laplacian = laplacian.elemental(basis)
    laplacians = np.zeros((n, len(inside)))
    for i, mask in enumerate(inside):
        b = replace(per_element_laplacian, data=per_element_laplacian.data
                                * np.tile(mask, basis.Nbfun)).todefault()
        laplacians[:, i] = b @ vectors
    added = np.where(np.any(inside, axis=0), d_e - d_bare, 0.0) if inside else np.zeros(mesh.nelements)
    # the patches' added rigidity alone (its energy in each mass-normalised mode), and the same
    # assembly's mass form at 1 kg/m^2: int phi^2 dA of each mode, exact on the elements
    k_added, unit_mass = stiffness_and_mass(basis, added, np.ones(mesh.nelements), resonator.poisson)
    return {"eigenvalues": eigenvalues, "vectors": vectors, "patch_laplacians": laplacians,
            "added_energy": np.einsum("ij,ij->j", vectors, k_added @ vectors),
            "face_integrals": np.einsum("ij,ij->j", vectors, unit_mass @ vectors)}


def eigenproblem_hz(near_hz: float, resonator: Isotropic, thickness_m: float, thick_plate: bool) -> float:
    """Where the (Kirchhoff) eigenproblem's modes lie whose frequencies, corrected when
    `thick_plate`, fall near the drive `near_hz`."""
    return kirchhoff_frequency_hz(near_hz, resonator, thickness_m) if thick_plate else near_hz


def patch_sections(geometry: PlateGeometry, resonator: Isotropic, piezo: Piezo,
                   bond: Bond) -> list[tuple[float, float, float, float]]:
    """Each patch's `bonded_section` (D, mass per area, lever arm, eta) on this plate."""
    return [bonded_section(resonator, geometry.thickness_m, piezo, p.thickness_m, bond, p.length_x_m)
            for p in geometry.patches]


def modes_from_vectors(geometry: PlateGeometry, resonator: Isotropic, piezo: Piezo, bond: Bond, thick_plate: bool,
                       sections: list, eigenvalues: np.ndarray, vectors: np.ndarray, gx: np.ndarray,
                       gy: np.ndarray, grid_probe, probe, patch_laplacians: np.ndarray,
                       added_energy: np.ndarray, face_integrals: np.ndarray | None = None) -> PlateModes:
    """The `PlateModes` of mass-normalised Kirchhoff eigenpairs (eigenvalues w_K^2 ascending,
    vectors (dofs, modes)) on a basis whose `grid_probe` evaluates them on the shape grid
    gx x gy and `probe(points)` anywhere; `sections` are the patches' `patch_sections`,
    `patch_laplacians[k, i]` is \\int_patch_i (phi_xx + phi_yy) dA of mode k and
    `added_energy[k]` phi_k^T K_added phi_k, the patches' added rigidity's share of
    w_K^2; `face_integrals[k]` int phi_k^2 dA where the solve has it (None: `plates.damping`
    integrates the shape instead). Shared by the full solve and reduced models of it
    (`plates.reduced_layouts`)."""
    n = len(eigenvalues)
    shapes = (grid_probe @ vectors).T.reshape(n, len(gx), len(gy))
    flat = shapes.reshape(n, -1)
    peak = flat[np.arange(n), np.abs(flat).argmax(axis=1)]  # signed: the peak reads +1
    scaled = shapes / peak[:, None, None]
    column_mean = scaled.mean(axis=2, keepdims=True)
    uniformity = (np.broadcast_to(column_mean, scaled.shape) ** 2).sum(axis=(1, 2)) / (
        scaled**2).sum(axis=(1, 2))

    theta = np.zeros((n, len(geometry.patches)))
    capacitance = np.zeros(len(geometry.patches))
    for i, (p, (_, _, z_m, eta)) in enumerate(zip(geometry.patches, sections)):
        # Theta per mass-normalised mode, referred to the peak point: A = Theta / phi_peak;
        # the bond passes eta of the piezo's moment on (shear lag, reciprocal to its stiffening).
        theta[:, i] = piezo.plate_e31_c_per_m2 * z_m * eta * patch_laplacians[:, i]
        capacitance[i] = clamped_capacitance_f(piezo, p)
    plate_mass = (resonator.density_kg_m3 * geometry.thickness_m * geometry.length_m
                  * geometry.width_m)
    # the patches' added rigidity's energy over the whole, w_K^2 (mass-normalised modes)
    piezo_share = added_energy / np.maximum(eigenvalues, 1e-30)
    kirchhoff = np.sqrt(np.maximum(eigenvalues, 0.0)) / (2 * np.pi)
    frequencies = (np.array([thick_plate_frequency_hz(f, resonator, geometry.thickness_m) for f in kirchhoff])
                   if thick_plate else kirchhoff)
    return PlateModes(
        frequencies_hz=frequencies, x_m=gx, y_m=gy,
        shapes=scaled, modal_mass_kg=1.0 / peak**2, force_factor_n_per_v=theta / peak[:, None],
        clamped_capacitance_f=capacitance,
        powered=np.array([p.powered for p in geometry.patches], dtype=bool),
        plate_mass_kg=plate_mass, uniformity=uniformity, kirchhoff_frequencies_hz=kirchhoff,
        bond_effectiveness=np.array([section[3] for section in sections]),
        piezo_energy_share=piezo_share,
        bond_energy_ratio=np.array([bond_energy_ratio(resonator, geometry.thickness_m, piezo, p.thickness_m, bond,
                                                      p.length_x_m) for p in geometry.patches]),
        # one mode's column: a figure's or a reduced model's face integral's grid has tens of thousands of points
        _probe=lambda p, k: probe(p) @ vectors[:, k], _modal_force=theta, _peak=peak,
        face_integral_m2_per_kg=face_integrals,
        held_bytes=vectors.nbytes + scaled.nbytes + getattr(probe, "held_bytes", 0))


def sign_changes(x: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Where `values` sampled at increasing `x` changes sign, by linear interpolation
    between the two samples either side (a nodal line of a profile along the length)."""
    x, m = np.asarray(x, dtype=float), np.asarray(values, dtype=float)
    i = np.nonzero(np.sign(m[:-1]) * np.sign(m[1:]) < 0)[0]
    return x[i] - m[i] * (x[i + 1] - x[i]) / (m[i + 1] - m[i])


def crossings(x: np.ndarray, y: np.ndarray, level: float) -> list[float]:
    """Where the piecewise-linear curve y(x) takes the value `level`: every sample at it and
    every `sign_changes` of y - level between samples, in order."""
    x, above = np.asarray(x, dtype=float), np.asarray(y, dtype=float) - level
    return sorted([float(v) for v in x[above == 0]] + [float(v) for v in sign_changes(x, above)])


@functools.lru_cache(maxsize=None)
def free_free_beam_roots(count: int) -> tuple[float, ...]:
    """The first `count` roots beta L of cos(bL) cosh(bL) = 1 (free-free beam, elastic modes)."""
    from scipy.optimize import brentq

    f = lambda b: np.cos(b) * np.cosh(b) - 1.0  # noqa: E731
    return tuple(brentq(f, (k + 0.5) * np.pi - 0.6, (k + 0.5) * np.pi + 0.6)
                 for k in range(1, count + 1))


def free_free_beam_shape(beta_l: float, length_m: float, x_m) -> tuple[np.ndarray, np.ndarray]:
    """Closed form: the free-free Euler-Bernoulli mode of root `beta_l` (`free_free_beam_roots`)
    and its slope at `x_m`, w = cosh bx + cos bx - s (sinh bx + sin bx),
    s = (cosh bL - cos bL) / (sinh bL - sin bL), normalised so that integral_0^L w^2 dx = L (|w| = 2 at
    the ends). The hyperbolic part is written with exponentials scaled by e^(bL) / 2, so a mode
    of a few tens of antinodes keeps its digits."""
    b, x = beta_l / length_m, np.asarray(x_m, dtype=float)
    bx, e = b * x, np.exp
    scale = 1.0 - e(-2 * beta_l) - 2 * math.sin(beta_l) * e(-beta_l)   # (sinh bL - sin bL) / (e^bL / 2)
    grow, decay = e(bx - beta_l), e(-bx - beta_l)
    hyperbolic = (e(-bx) - e(bx - 2 * beta_l) - (grow + decay) * math.sin(beta_l)
                  + (grow - decay) * math.cos(beta_l)) / scale
    hyperbolic_slope = (-(e(-bx) + e(bx - 2 * beta_l)) - (grow - decay) * math.sin(beta_l)
                        + (grow + decay) * math.cos(beta_l)) / scale
    s = (math.cosh(beta_l) - math.cos(beta_l)) / (math.sinh(beta_l) - math.sin(beta_l)) if beta_l < 700 else 1.0
    return (hyperbolic + np.cos(bx) - s * np.sin(bx),
            b * (hyperbolic_slope - np.sin(bx) - s * np.cos(bx)))


def free_free_beam_centre_drive(material: Isotropic, thickness_m: float, width_m: float, length_m: float,
                                antinodes: int, patch_x_m: list[tuple[float, float]],
                                patch_width_m: float, moment_per_volt: float) -> tuple[float, float]:
    """Closed form of the plate model's centre-referred modal mass (kg) and force factor (N/V)
    for a plate bending as a free-free beam (`free_free_beam_shape`, the mode of `antinodes`
    antinodes; exact for nu = 0) under piezos too thin to change the mode: M = rho h W L / w(L/2)^2
    and A = sum_i m b [w'(x2_i) - w'(x1_i)] / w(L/2), each patch spanning `patch_x_m`'s (x1, x2),
    `patch_width_m` wide, with bending moment per volt and width `moment_per_volt`
    (e_eff z_m eta, `modes_from_vectors`). What the full solve reduces to where it can."""
    beta_l = free_free_beam_roots(antinodes)[-1]
    centre = float(free_free_beam_shape(beta_l, length_m, length_m / 2)[0])
    slope = lambda x: float(free_free_beam_shape(beta_l, length_m, x)[1])  # noqa: E731
    force = sum(moment_per_volt * patch_width_m * (slope(x2) - slope(x1)) for x1, x2 in patch_x_m) / centre
    return material.density_kg_m3 * thickness_m * width_m * length_m / centre**2, abs(force)


def section_shear_and_rotary(layers: list[tuple[float, float, float, float]]) -> tuple[float, float]:
    """Transverse shear stiffness S (N/m per metre of width, kappa G h for one layer) and rotary
    inertia J (kg per metre: integral of rho (z - z_n)^2) of a layered section bending about its
    neutral axis; `layers` (thickness m, plate modulus Pa, shear modulus Pa, density kg/m^3)
    from one face. S from the shear stress the bending stress gradient carries (Jourawski:
    tau(z) = Q / D integral_0^z E'(z) (z' - z_n) dz') with the shear energy's compliance
    1 / S = integral tau^2 / (G Q^2) dz: 5 h G / 6 for a homogeneous layer (kappa = 5/6), and a
    soft bond carries the whole shear flow across its thickness."""
    tops = np.cumsum([t for t, _, _, _ in layers])
    bottoms = tops - np.array([t for t, _, _, _ in layers])
    moduli = np.array([q for _, q, _, _ in layers])
    thickness = tops - bottoms
    z_n = float((moduli * thickness * (tops + bottoms) / 2).sum() / (moduli * thickness).sum())
    d = float((moduli * (thickness**3 / 12 + thickness * ((tops + bottoms) / 2 - z_n) ** 2)).sum())
    compliance, flow, rotary = 0.0, 0.0, 0.0
    for (t, q, g, rho), z0, z1 in zip(layers, bottoms, tops):
        z = np.linspace(z0, z1, 201)
        shear = (flow + q * ((z - z_n) ** 2 - (z0 - z_n) ** 2) / 2) / d   # tau per unit shear force
        compliance += float(np.trapezoid(shear**2, z)) / g
        flow += q * ((z1 - z_n) ** 2 - (z0 - z_n) ** 2) / 2
        rotary += rho * (t**3 / 12 + t * ((z0 + z1) / 2 - z_n) ** 2)
    return 1.0 / compliance, rotary


def _shear_modulus_pa(material: Isotropic) -> float:
    return material.young_pa / (2.0 * (1.0 + material.poisson))


def beam_frequencies_hz(geometry: PlateGeometry, resonator: Isotropic = ALUMINIUM_TABLE2,
                        piezo: Piezo = NCE41, f_min_hz: float = 1e3, f_max_hz: float = 80e3,
                        step_hz: float = 50.0, bond: Bond = EPOXY, thick: bool = False) -> np.ndarray:
    """Fast cross-check (in the spirit of the paper's ref. 001): the free-free (n, 0)
    frequencies of the plate as a beam along its length, each section's stiffness and mass per
    length summed across the width (plate moduli: a wide plate bends cylindrically), patches
    with their bond (`bonded_section`) included. Euler-Bernoulli (Kirchhoff's frequencies, no
    thick-plate correction), or with `thick` Timoshenko's: every section's own transverse shear
    stiffness and rotary inertia (`section_shear_and_rotary`: the bare plate's, and under a
    patch the laminate's of resonator, bond and piezo), the thick-plate physics the solver
    corrects at the bare plate's only. Transfer matrices expm(A L) of the state (w, theta, M, Q),
    w' = theta - Q / S, theta' = M / EI, M' = Q - w^2 J theta, Q' = w^2 m w per uniform segment
    (S infinite and J = 0: Euler-Bernoulli; `_segment_transfer`); roots of the free-end
    determinant (M = Q = 0 at both ends), bracketed on a `step_hz` grid."""
    from scipy.optimize import brentq

    cuts = sorted({0.0, geometry.length_m, *[min(max(b, 0.0), geometry.length_m)
                                             for p in geometry.patches for b in p.bounds[:2]]})
    h = geometry.thickness_m
    d_bare, m_bare, _ = laminate(resonator, h, piezo, 0.0)
    bare_layer = (h, resonator.plate_modulus_pa, _shear_modulus_pa(resonator), resonator.density_kg_m3)
    s_bare, j_bare = section_shear_and_rotary([bare_layer])
    segments = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        mid = (a + b) / 2
        ei, m, s, j = d_bare * geometry.width_m, m_bare * geometry.width_m, s_bare * geometry.width_m, \
            j_bare * geometry.width_m
        for p in geometry.patches:
            if p.bounds[0] < mid < p.bounds[1]:
                d_lam, m_lam, _, _ = bonded_section(resonator, h, piezo, p.thickness_m, bond, p.length_x_m)
                ei += (d_lam - d_bare) * p.width_y_m
                m += (m_lam - m_bare) * p.width_y_m
                layers = [bare_layer, (bond.thickness_m, 0.0, bond.shear_modulus_pa, bond.density_kg_m3),
                          (p.thickness_m, piezo.plate_modulus_pa, _shear_modulus_pa(piezo), piezo.density_kg_m3)]
                s_lam, j_lam = section_shear_and_rotary([layer for layer in layers if layer[0] > 0])
                s += (s_lam - s_bare) * p.width_y_m
                j += (j_lam - j_bare) * p.width_y_m
        segments.append((b - a, ei, m, s if thick else math.inf, j if thick else 0.0))

    def determinants(f_hz: np.ndarray) -> np.ndarray:
        w2 = (2 * np.pi * f_hz) ** 2
        total = np.broadcast_to(np.eye(4), (len(w2), 4, 4))
        for segment in segments:
            total = _segment_transfer(*segment, w2) @ total
        block = total[:, 2:, :2]
        return np.linalg.det(block / np.abs(block).max(axis=(1, 2))[:, None, None])

    grid = np.arange(f_min_hz, f_max_hz, step_hz)
    values = determinants(grid)
    brackets = np.nonzero(np.sign(values[:-1]) * np.sign(values[1:]) < 0)[0]
    return np.array([brentq(lambda f: float(determinants(np.array([f]))[0]), grid[i], grid[i + 1])
                     for i in brackets])


def _segment_transfer(length_m: float, ei: float, m: float, s: float, j: float, w2: np.ndarray) -> np.ndarray:
    """expm(A L) of a uniform segment of `beam_frequencies_hz` at each w^2 (shape (n, 4, 4)),
    in closed form: A's characteristic polynomial is l^4 + p l^2 + q, p = w^2 (m / S + J / EI),
    q = w^2 m (w^2 J / S - 1) / EI, so with mu_1, mu_2 its roots in l^2 (Cayley-Hamilton,
    Sylvester's formula) expm(A L) = [(mu_1 C_2 - mu_2 C_1) I + (mu_1 S_2 - mu_2 S_1) A
    + (C_1 - C_2) A^2 + (S_1 - S_2) A^3] / (mu_1 - mu_2), C = cosh(sqrt(mu) L) and
    S = sinh(sqrt(mu) L) / sqrt(mu) (cos and sin of sqrt(-mu) L for mu < 0): the same matrix
    as scipy's expm, a thousand frequencies in the time of a few of its calls."""
    n = len(w2)
    a = np.zeros((n, 4, 4))
    a[:, 0, 1], a[:, 0, 3], a[:, 1, 2], a[:, 2, 3] = 1.0, -1.0 / s, 1.0 / ei, 1.0
    a[:, 2, 1], a[:, 3, 0] = -w2 * j, m * w2
    p = w2 * (m / s + j / ei)
    q = w2 * m * (w2 * j / s - 1.0) / ei
    root = np.sqrt(p * p - 4.0 * q + 0j)
    mu_1, mu_2 = (-p + root) / 2.0, (-p - root) / 2.0
    k_1, k_2 = np.sqrt(mu_1), np.sqrt(mu_2)
    c_1, c_2 = np.cosh(k_1 * length_m), np.cosh(k_2 * length_m)
    s_1, s_2 = np.sinh(k_1 * length_m) / k_1, np.sinh(k_2 * length_m) / k_2
    coefficients = np.real([mu_1 * c_2 - mu_2 * c_1, mu_1 * s_2 - mu_2 * s_1, c_1 - c_2, s_1 - s_2]
                           / (mu_1 - mu_2))
    power, total = np.broadcast_to(np.eye(4), (n, 4, 4)), 0.0
    for coefficient in coefficients:
        total = total + coefficient[:, None, None] * power
        power = power @ a
    return total
