"""A reduced model of one plate for sweeps of its piezo layouts, checked against the full solve.

Every layout of a sweep is the same plate with other patches; the full solve
(`plate_modes.solve_plate`) builds a mesh, a basis and an eigenproblem of thousands of
degrees of freedom for each (about 0.9 s for the large plate). Here the bare plate is
solved once on its own mesh (`plate_modes.mesh_lines` of the plate without patches), and
its mass-normalised modes in a band about the drive, phi_1..phi_r (K0 phi = w^2 M0 phi),
are the Ritz basis of every layout. A patch changes the rigidity and the mass per area on
its rectangle by dD and dm (`plate_modes.patch_sections`: the bonded laminate, its bond's
shear lag and mass, whatever that physics is), so
in that basis (Rayleigh-Ritz, the bilinear forms of `plate_modes.stiffness_and_mass`)

    K_ab = w_a^2 delta_ab + sum_patches dD \\int_patch [(1 - nu) phi_a,ij phi_b,ij + nu lap phi_a lap phi_b] dA
    M_ab = delta_ab       + sum_patches dm \\int_patch phi_a phi_b dA

and the coupling integral of `plate_modes` is \\int_patch lap phi dA of the Ritz modes. Like
the full solve this is Kirchhoff's eigenproblem (about the drive's Kirchhoff frequency,
`plate_modes.eigenproblem_hz`); `plate_modes.modes_from_vectors` then applies the same
thick-plate correction, bond effectiveness and strain-energy shares to its eigenpairs. The
integrals over a patch are exact for any rectangle, on or off the mesh lines: each triangle
the patch covers is clipped to it and integrated with the full solve's quadrature on the
pieces, so a patch may sit anywhere on the plate. They depend only on the rectangle, so a
sweep computes each once, as local forms: the patch's stiffness per unit dD, mass per unit
dm and \\int lap N dA on the few degrees of freedom its elements carry (`local_forms`).

A Ritz basis of smooth bare modes cannot bend more softly under a stiff patch, so the
working-mode candidates are refined by Davidson steps (Morgan and Scott, SIAM J. Sci.
Stat. Comput. 7, 1986: each step adds (K0 - sigma M0)^-1 of their residuals, with one
factorisation for the whole sweep); a patch's part of a residual or of the grown Ritz
matrices is its local forms times the basis vectors' rows on its degrees of freedom, so a
step multiplies no global matrix but its new vectors. It is still a model on the sweep's
mesh, not each layout's full solve on its own: `check` compares it with full solves of a
sample of the sweep's layouts (frequency within `FREQUENCY_TOLERANCE_REL`, force factor
within `FORCE_TOLERANCE_REL`), and a sweep whose sample misses is solved in full
(`squeezebench.designing.workflow`).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, replace

import numpy as np
from scipy.linalg import eigh
from scipy.sparse.linalg import eigsh

from squeezebench.plates import plate_modes
from squeezebench.plates.plate_modes import Bond, Isotropic, Piezo, PlateGeometry
from squeezebench.lru import RecentlyUsed

#: The reduced model answers for a layout if its working mode's frequency is within 0.2 %
#: of the full solve's and its force factor within 2 % (issue 51).
FREQUENCY_TOLERANCE_REL = 0.002
FORCE_TOLERANCE_REL = 0.02
#: The Ritz basis: the bare plate's modes within this whole band (relative) about the
#: drive; patches move the working mode by a few per cent and mix it with its neighbours.
BASIS_BAND_REL = 0.2
#: The full solve's quadrature order (`plate_modes._discretisation`), used on the clipped pieces.
QUADRATURE_ORDER = 8
#: Patch edges closer than this share of an element are meshed as one line. Slivers cost
#: accuracy, not only time: at 1/8 of an element the sweep mesh's own answer was off the
#: layouts' full solves by up to 4.7 % in force factor on the 3,024-layout sweep's sample;
#: at half an element, 1.5 % (and the mesh has a third of the lines across the length).
MIN_EDGE_GAP = 0.5
#: Davidson refinement of the working-mode candidates (modes this even across the width):
#: done when their w^2 and coupling integrals move by less than `SETTLED_REL` in a step.
CANDIDATE_UNIFORMITY = 0.5
SETTLED_REL = 1e-3
MAX_STEPS = 30
#: Patches whose local forms a model keeps (two l x l matrices, l the dofs a patch's
#: elements carry): a sweep's chunk in grid order needs a few tens at a time.
PATCHES_KEPT = 96


@dataclass(frozen=True)
class BarePlate:
    """What a sweep's layouts share: the plate, its materials, the drive and the mesh size
    (the arguments of `plate_modes.solve_plate` but the patches)."""

    length_m: float
    width_m: float
    thickness_m: float
    resonator: Isotropic
    piezo: Piezo
    near_hz: float
    band_rel: float
    elements_per_half_wave: float = 1.5
    mesh_half_wave_m: float | None = None
    bond: Bond = plate_modes.EPOXY
    thick_plate: bool = True
    x_edges_m: tuple[float, ...] = ()
    y_edges_m: tuple[float, ...] = ()

    def with_edges_of(self, geometries) -> "BarePlate":
        """This plate meshed with a line on every patch edge of `geometries` (a sweep's
        layouts), edges closer than `MIN_EDGE_GAP` of an element apart taken as one: a
        patch then covers whole elements, as in its full solve, and no element is a sliver."""
        gap = MIN_EDGE_GAP * (self.mesh_half_wave_m or plate_modes.flexural_half_wavelength_m(
            self.resonator, self.thickness_m, self.near_hz)) / self.elements_per_half_wave
        return replace(self, x_edges_m=_spread({b for g in geometries for p in g.patches for b in p.bounds[:2]}, gap),
                       y_edges_m=_spread({b for g in geometries for p in g.patches for b in p.bounds[2:]}, gap))

    @property
    def geometry(self) -> PlateGeometry:
        return PlateGeometry(self.length_m, self.width_m, self.thickness_m)

    def fits(self, geometry: PlateGeometry) -> bool:
        return (geometry.length_m, geometry.width_m, geometry.thickness_m) == (
            self.length_m, self.width_m, self.thickness_m)


def _spread(edges, gap: float) -> tuple[float, ...]:
    """The sorted `edges` less each one within `gap` of the last one kept."""
    kept: list[float] = []
    for edge in sorted(edges):
        if not kept or edge - kept[-1] >= gap:
            kept.append(float(edge))
    return tuple(kept)


def clip_to_rectangle(polygon: np.ndarray, x0: float, x1: float, y0: float, y1: float) -> np.ndarray:
    """The convex `polygon` (k, 2) cut to the rectangle [x0, x1] x [y0, y1]
    (Sutherland-Hodgman, one half-plane at a time); (0, 2) if they do not overlap."""
    for axis, bound, keep_above in ((0, x0, True), (0, x1, False), (1, y0, True), (1, y1, False)):
        if len(polygon) == 0:
            break
        side = (polygon[:, axis] - bound) * (1 if keep_above else -1)
        out = []
        for i in range(len(polygon)):
            a, b, sa, sb = polygon[i - 1], polygon[i], side[i - 1], side[i]
            if sb >= 0:
                if sa < 0:
                    out.append(a + (b - a) * sa / (sa - sb))
                out.append(b)
            elif sa >= 0:
                out.append(a + (b - a) * sa / (sa - sb))
        polygon = np.array(out).reshape(-1, 2)
    return polygon


@dataclass(frozen=True)
class PatchForms:
    """A rectangle's bilinear forms on the degrees of freedom `dofs` (l) its elements carry:
    stiffness per unit dD `local_stiffness` (l, l), mass per unit dm `local_mass` (l, l)
    and \\int lap N dA `local_laplacian` (l); and the same on the bare modes: `stiffness`
    (r, r), `mass` (r, r) and `laplacian` (r), \\int lap phi dA."""

    dofs: np.ndarray
    local_stiffness: np.ndarray
    local_mass: np.ndarray
    local_laplacian: np.ndarray
    stiffness: np.ndarray
    mass: np.ndarray
    laplacian: np.ndarray


def local_forms(weights: np.ndarray, values: np.ndarray, hessians: np.ndarray, poisson: float,
                local: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The bilinear forms of `plate_modes.stiffness_and_mass` over quadrature points with
    `weights` (Q), where the basis functions have `values` (functions, Q) and `hessians`
    (functions, 2, 2, Q) and are the degrees of freedom `local` (functions, Q) of `size`:
    D [(1 - nu) w,ij v,ij + nu lap w lap v] per unit D and w v per unit mass (size, size),
    and \\int lap N dA (size), each point's 21 x 21 block added where its dofs are."""
    laplacian = hessians[:, 0, 0] + hessians[:, 1, 1]
    stiffness = ((1 - poisson) * np.einsum("aijq,bijq->qab", hessians, hessians)
                 + poisson * np.einsum("aq,bq->qab", laplacian, laplacian)) * weights[:, None, None]
    mass = np.einsum("aq,bq->qab", values, values) * weights[:, None, None]
    where = (local.T[:, :, None] * size + local.T[:, None, :]).ravel()   # (Q, a, b) in the flat (size, size)

    def assemble(terms):
        return np.bincount(where, terms.ravel(), minlength=size * size).reshape(size, size)

    return assemble(stiffness), assemble(mass), np.bincount(local.ravel(), (laplacian * weights).ravel(),
                                                            minlength=size)


class ReducedPlate:
    """The bare plate's Ritz basis and the patch integrals computed so far; `solve(geometry)`
    answers as `plate_modes.solve_plate` does, for any patches on this plate."""

    def __init__(self, bare: BarePlate):
        from scipy.sparse.linalg import LinearOperator

        self.bare = bare
        eigenproblem_hz = plate_modes.eigenproblem_hz(bare.near_hz, bare.resonator, bare.thickness_m,
                                                      bare.thick_plate)
        x, y, gx, gy = plate_modes.mesh_lines(bare.geometry, bare.resonator, eigenproblem_hz,
                                              bare.elements_per_half_wave, bare.mesh_half_wave_m,
                                              bare.x_edges_m, bare.y_edges_m)
        self._gx, self._gy = gx, gy
        self.mesh, basis, self.grid_probe, self.probe = plate_modes._discretisation(
            *(tuple(a.tolist()) for a in (x, y, gx, gy)))
        self.basis = basis()
        d0, m0, _ = plate_modes.laminate(bare.resonator, bare.thickness_m, bare.piezo, 0.0)
        self.stiffness, self.mass = plate_modes.stiffness_and_mass(
            self.basis, np.full(self.mesh.nelements, d0), np.full(self.mesh.nelements, m0), bare.resonator.poisson)
        self.sigma = (2 * np.pi * eigenproblem_hz) ** 2
        count = plate_modes.mode_count(bare.geometry, bare.resonator, bare.piezo, bare.near_hz, BASIS_BAND_REL)
        count = min(count, self.stiffness.shape[0] - 2)
        # one factorisation of K0 - sigma M0 for the bare modes' shift-invert and every Davidson step
        self._shifted = shifted_factor(self.stiffness - self.sigma * self.mass)
        size = self.stiffness.shape[0]
        eigenvalues, vectors = eigsh(self.stiffness, k=count, M=self.mass, sigma=self.sigma, which="LM",
                                     tol=1e-9, v0=np.ones(size),
                                     OPinv=LinearOperator((size, size), matvec=self._shifted.solve, dtype=float))
        order = np.argsort(eigenvalues)
        self.eigenvalues, self.vectors = eigenvalues[order], vectors[:, order]
        self._mass_vectors = self.mass @ self.vectors   # M0 phi; K0 phi = M0 phi w^2
        self._grid_modes = self.grid_probe @ self.vectors
        # their Gram matrices on the shape grid, of the values and of the means across the width:
        # a mode's share of deflection even across the width (`PlateModes.uniformity`) is the
        # ratio of its quadratic forms in the second and the first
        self._grid_means = self._width_means(self._grid_modes)
        self._grid_grams = (self._grid_modes.T @ self._grid_modes, self._grid_means.T @ self._grid_means)
        self.n_modes = plate_modes.mode_count(bare.geometry, bare.resonator, bare.piezo, bare.near_hz,
                                              bare.band_rel)
        self._patches: RecentlyUsed[PatchForms] = RecentlyUsed(PATCHES_KEPT)

    def _width_means(self, grid: np.ndarray) -> np.ndarray:
        """Basis vectors' values on the shape grid (points, vectors) averaged across the
        width, times the square root of its points (lengthwise points, vectors)."""
        return np.sqrt(len(self._gy)) * grid.reshape(len(self._gx), len(self._gy), -1).mean(axis=1)

    def patch_forms(self, bounds: tuple[float, float, float, float]) -> PatchForms:
        """The bilinear forms of the rectangle `bounds` (x0, x1, y0, y1), kept for the sweep."""
        return self._patches.get(bounds, lambda: self._integrate(*bounds))

    def _quadrature(self, x0: float, x1: float, y0: float, y1: float):
        """Points (2, Q), weights (Q) and elements (Q) of the rectangle cut into the triangles
        it covers: each piece fanned into triangles, each with the full solve's rule."""
        from skfem.quadrature import get_quadrature
        from skfem.refdom import RefTri

        reference, reference_weights = get_quadrature(RefTri, QUADRATURE_ORDER)
        corners = self.mesh.p[:, self.mesh.t]   # (2, 3, elements)
        low, high = corners.min(axis=1), corners.max(axis=1)
        near = np.nonzero((low[0] < x1) & (high[0] > x0) & (low[1] < y1) & (high[1] > y0))[0]
        points, weights, cells = [], [], []
        for element in near:
            piece = clip_to_rectangle(corners[:, :, element].T, x0, x1, y0, y1)
            for b, c in zip(piece[1:-1], piece[2:]):
                a = piece[0]
                jacobian = abs((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]))
                if jacobian <= 0:
                    continue
                points.append(a[:, None] + np.outer(b - a, reference[0]) + np.outer(c - a, reference[1]))
                weights.append(reference_weights * jacobian)
                cells.append(np.full(reference.shape[1], element))
        if not points:
            raise ValueError(f"a patch [{x0:.4g}, {x1:.4g}] x [{y0:.4g}, {y1:.4g}] m is off the plate")
        return np.hstack(points), np.concatenate(weights), np.concatenate(cells)

    def _integrate(self, x0: float, x1: float, y0: float, y1: float) -> PatchForms:
        points, weights, cells = self._quadrature(x0, x1, y0, y1)
        basis, mapping = self.basis, self.basis.mapping
        local = mapping.invF(points[:, :, None], tind=cells)
        fields = [basis.elem.gbasis(mapping, local, k, tind=cells)[0] for k in range(basis.Nbfun)]
        values = np.array([f.get(0)[:, 0] for f in fields])
        hessians = np.array([f.hess[..., 0] for f in fields])
        dofs, where = np.unique(basis.element_dofs[:, cells], return_inverse=True)
        stiffness, mass, laplacian = local_forms(weights, values, hessians, self.bare.resonator.poisson,
                                                 where.reshape(values.shape), len(dofs))
        modes = self.vectors[dofs]
        return PatchForms(dofs, stiffness, mass, laplacian, modes.T @ stiffness @ modes, modes.T @ mass @ modes,
                          laplacian @ modes)

    def solve(self, geometry: PlateGeometry) -> plate_modes.PlateModes:
        """The modes of `geometry` (this plate with its patches) nearest the drive, as
        `plate_modes.solve_plate` gives them: Rayleigh-Ritz in the bare modes, then the
        working-mode candidates (nodal lines nearly straight across the width) refined by
        Davidson steps on the plate with its patches, (K0 - sigma M0)^-1 of their residuals
        added to the basis until their frequencies and coupling integrals settle; raises
        `NotConverged` if they do not in `MAX_STEPS`."""
        if not self.bare.fits(geometry):
            raise ValueError("the reduced model is of another plate")
        bare = self.bare
        d0, m0, _ = plate_modes.laminate(bare.resonator, bare.thickness_m, bare.piezo, 0.0)
        sections = plate_modes.patch_sections(geometry, bare.resonator, bare.piezo, bare.bond)
        parts = [(self.patch_forms(tuple(float(b) for b in patch.bounds)), d - d0, m - m0)
                 for patch, (d, m, _, _) in zip(geometry.patches, sections)]
        r = len(self.eigenvalues)
        # the Ritz matrices, grown by each step's new vectors (M0-orthonormal to all before,
        # so the bare plate's parts of their blocks are the identity and W^T K0 W)
        # the patches' part of K apart too: their share of each mode's strain energy
        added_stiffness = sum((dd * p.stiffness for p, dd, _ in parts), np.zeros((r, r)))
        stiffness = np.diag(self.eigenvalues) + added_stiffness
        mass = np.eye(r) + sum(dm * p.mass for p, _, dm in parts)
        laplacians = np.array([p.laplacian for p, _, _ in parts]).reshape(len(parts), r)
        rows = [self.vectors[p.dofs] for p, _, _ in parts]   # every basis vector on each patch's dofs
        added = np.zeros((self.stiffness.shape[0], 0))
        mass_added, stiffness_added = added, added   # M0 and K0 times the added vectors
        grid_basis, grid_means = self._grid_modes, self._grid_means   # the basis on the shape grid
        grid_gram, mean_gram = self._grid_grams
        previous = None
        for step in range(MAX_STEPS + 1):
            eigenvalues, coefficients = eigh(stiffness, mass)
            n = min(self.n_modes, len(eigenvalues))
            nearest = np.sort(np.argsort(abs(eigenvalues - self.sigma))[:n])
            eigenvalues, coefficients = eigenvalues[nearest], coefficients[:, nearest]
            coupling = (laplacians @ coefficients).T
            added_energy = np.einsum("ij,ij->j", coefficients, added_stiffness @ coefficients)
            if not parts:
                break
            # each mode's share of deflection even across the width (`_grid_grams`)
            uniformity = (np.einsum("ij,ij->j", coefficients, mean_gram @ coefficients)
                          / np.einsum("ij,ij->j", coefficients, grid_gram @ coefficients))
            targets = np.nonzero(uniformity >= CANDIDATE_UNIFORMITY)[0]
            if targets.size == 0:
                targets = np.array([int(np.argmin(abs(eigenvalues - self.sigma)))])
            figures = np.concatenate([eigenvalues[targets], np.abs(coupling[targets]).sum(axis=1)])
            if previous is not None and previous.shape == figures.shape and np.all(
                    abs(figures - previous) <= SETTLED_REL * abs(previous)):
                break
            if step == MAX_STEPS:
                raise NotConverged(f"the reduced model did not settle in {MAX_STEPS} steps")
            previous = figures
            # residuals on the plate with its patches, (K - lambda M) x, less their bare modes' part
            # M0 phi (w^2 - lambda) c: (K0 - sigma M0)^-1 takes that to phi (w^2 - lambda) / (w^2 - sigma) c,
            # which the projection below removes. K0 x and M0 x of the added vectors from the
            # products kept (no product with the global matrices), the patches' part on their dofs
            lam, added_part = eigenvalues[targets], coefficients[r:, targets]
            residual = stiffness_added @ added_part - (mass_added @ added_part) * lam
            for (p, dd, dm), there in zip(parts, rows):
                x = there @ coefficients[:, targets]
                residual[p.dofs] += dd * (p.local_stiffness @ x) - dm * (p.local_mass @ x) * lam
            direction = self._shifted.solve(residual)
            for _ in range(2):   # twice: orthogonal to roundoff
                direction -= self.vectors @ (self._mass_vectors.T @ direction) + added @ (mass_added.T @ direction)
            mass_direction = self.mass @ direction
            size, rotation = np.linalg.eigh(direction.T @ mass_direction)
            keep = size > 1e-12 * max(size.max(), 1e-300)
            if not keep.any():
                break
            scale = rotation[:, keep] / np.sqrt(size[keep])
            direction, mass_direction = direction @ scale, mass_direction @ scale
            stiffness_direction = self.stiffness @ direction
            stiffness_k = direction.T @ stiffness_direction
            cross_k = np.vstack([np.zeros((r, direction.shape[1])), added.T @ stiffness_direction])
            cross_m, mass_k = np.zeros_like(cross_k), np.eye(direction.shape[1])
            cross_added, own_added = np.zeros_like(cross_k), np.zeros_like(stiffness_k)
            new_laplacians = np.zeros((len(parts), direction.shape[1]))
            for i, (p, dd, dm) in enumerate(parts):
                new = direction[p.dofs]
                k_new, m_new = p.local_stiffness @ new, p.local_mass @ new
                k, m = rows[i].T @ k_new, rows[i].T @ m_new
                own_k, own_m = new.T @ k_new, new.T @ m_new
                cross_k, cross_m, cross_added = cross_k + dd * k, cross_m + dm * m, cross_added + dd * k
                stiffness_k, mass_k, own_added = stiffness_k + dd * own_k, mass_k + dm * own_m, own_added + dd * own_k
                rows[i] = np.hstack([rows[i], new])
                new_laplacians[i] = p.local_laplacian @ new
            stiffness = np.block([[stiffness, cross_k], [cross_k.T, stiffness_k]])
            mass = np.block([[mass, cross_m], [cross_m.T, mass_k]])
            added_stiffness = np.block([[added_stiffness, cross_added], [cross_added.T, own_added]])
            laplacians = np.hstack([laplacians, new_laplacians])
            added = np.hstack([added, direction])
            mass_added = np.hstack([mass_added, mass_direction])
            stiffness_added = np.hstack([stiffness_added, stiffness_direction])
            grid_direction = self.grid_probe @ direction
            mean_direction = self._width_means(grid_direction)
            cross_grid, cross_mean = grid_basis.T @ grid_direction, grid_means.T @ mean_direction
            grid_gram = np.block([[grid_gram, cross_grid], [cross_grid.T, grid_direction.T @ grid_direction]])
            mean_gram = np.block([[mean_gram, cross_mean], [cross_mean.T, mean_direction.T @ mean_direction]])
            grid_basis, grid_means = np.hstack([grid_basis, grid_direction]), np.hstack([grid_means, mean_direction])
        vectors = self.vectors @ coefficients[:r] + added @ coefficients[r:]
        return plate_modes.modes_from_vectors(geometry, bare.resonator, bare.piezo, bare.bond, bare.thick_plate,
                                              sections, eigenvalues, vectors, self._gx, self._gy, self.grid_probe,
                                              self.probe, coupling, added_energy)


def shifted_factor(matrix):
    """The LU factors of the symmetric `matrix` (K0 - sigma M0) for its solves: SuperLU in its
    symmetric mode (a minimum-degree ordering of A + A^T, pivots on the diagonal), whose
    factors of the large plate's sweep mesh have 2/3 of the default's entries and solve
    twice as fast (the default's column ordering and pivoting do not keep the symmetry)."""
    from scipy.sparse.linalg import splu

    return splu(matrix.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                options={"SymmetricMode": True})


class NotConverged(ValueError):
    """The reduced model's refinement did not settle: the layout needs the full solve."""


@functools.lru_cache(maxsize=2)   # a sweep's plate, and one more: a worker serves one sweep at a time
def reduced_plate(bare: BarePlate) -> ReducedPlate:
    return ReducedPlate(bare)


class Solver:
    """A stand-in for `plate_modes.solve_plate` that answers from the reduced model of
    `bare` for plates it is (same plate, materials, drive and mesh) and by the full solve
    for any other (a tolerance's moved materials) or where the model does not settle;
    `full_solves` counts those. The last plate answered by the model is kept: a sweep asks
    for a sampled layout's working point right after its row."""

    def __init__(self, bare: BarePlate):
        self.bare = bare
        self.full_solves = 0
        self._last: tuple[PlateGeometry, plate_modes.PlateModes] | None = None

    def __call__(self, geometry: PlateGeometry, resonator: Isotropic = plate_modes.ALUMINIUM_TABLE2,
                 piezo: Piezo = plate_modes.NCE41, near_hz: float = 40e3, n_modes: int | None = None,
                 elements_per_half_wave: float = 1.5, mesh_half_wave_m: float | None = None,
                 band_rel: float = 0.16, bond: Bond = plate_modes.EPOXY,
                 thick_plate: bool = True) -> plate_modes.PlateModes:
        wanted = replace(self.bare, length_m=geometry.length_m, width_m=geometry.width_m,
                         thickness_m=geometry.thickness_m, resonator=resonator, piezo=piezo, near_hz=near_hz,
                         band_rel=band_rel, elements_per_half_wave=elements_per_half_wave,
                         mesh_half_wave_m=mesh_half_wave_m, bond=bond, thick_plate=thick_plate)
        if wanted == self.bare and n_modes is None:
            if self._last is not None and self._last[0] == geometry:
                return self._last[1]
            try:
                self._last = (geometry, reduced_plate(self.bare).solve(geometry))
                return self._last[1]
            except NotConverged:
                pass
        self.full_solves += 1
        return plate_modes.solve_plate(geometry, resonator, piezo, near_hz, n_modes, elements_per_half_wave,
                                       mesh_half_wave_m, band_rel, bond, thick_plate)
