"""scikit-fem's Argyris triangle with its global basis built in one pass.

skfem's `ElementGlobal.gbasis` returns one basis function per call, and each call evaluates
again all 21 monomials of degree <= 5 and their first and second derivatives (147 arrays of
powers) at every quadrature point of every element. They do not depend on which basis
function is asked for, so `Argyris` evaluates them once per point set and combines them with
the inverse Vandermonde matrices for all 21 functions, in skfem's own order of summation: the
numbers are bit-identical (tests/test_plate_modes.py; the 56 of 147 derivatives that are
identically zero are skipped, and adding zero changes no sum), and the large plate's basis
takes about a fifth of the time (benchmarks/bench_modal.py). Imported only where a plate is
solved: importing skfem costs a few tenths of a second.
"""
from __future__ import annotations

import itertools

import numpy as np
from skfem import ElementTriArgyris
from skfem.element.discrete_field import DiscreteField


class Argyris(ElementTriArgyris):
    """`ElementTriArgyris` whose `gbasis` computes every basis function on the first call for
    a point set (Basis and Basis.probes ask for all of them in turn with the same arrays) and
    hands out the kept ones after."""

    _kept: tuple = (None, None, None)  # (X, tind, fields): the arrays, held so their ids stay theirs

    def gbasis(self, mapping, X, i, tind=None):
        points, elements, fields = self._kept
        if fields is None or points is not X or elements is not tind:
            fields = self._all_functions(mapping, X, tind)
            self._kept = (X, tind, fields)
        return fields[i]

    def _all_functions(self, mapping, X, tind) -> list[tuple[DiscreteField]]:
        inverse, x = self._coefficients_and_points(mapping, X, tind)
        n_functions = inverse.shape[1]
        term = np.empty((n_functions,) + x[0].shape)
        per_order = []
        for k in range(self.derivatives + 1):
            derivatives = [self._summed(inverse, x, diff, term)
                           for diff in itertools.product(range(self.dim), repeat=k)]
            per_order.append(np.stack(derivatives, axis=1).reshape(
                (n_functions,) + (self.dim,) * k + x[0].shape))
        return [(DiscreteField(value=per_order[0][j], grad=per_order[1][j], hess=per_order[2][j],
                               **{f"grad{k + 3}": per_order[k + 3][j]
                                  for k in range(self.derivatives - 2)}),)
                for j in range(n_functions)]

    def values(self, mapping, X, tind) -> np.ndarray:
        """Every basis function's value at X (functions, elements, points), the same numbers
        as `gbasis`'s: all a probe needs, without the gradients and Hessians (three quarters
        of `_all_functions`' work)."""
        inverse, x = self._coefficients_and_points(mapping, X, tind)
        return self._summed(inverse, x, (), np.empty((inverse.shape[1],) + x[0].shape))

    def _coefficients_and_points(self, mapping, X, tind) -> tuple[np.ndarray, np.ndarray]:
        """Each monomial's coefficients in every function, (monomial, function, element, 1),
        contiguous, and the points X mapped to the elements, (dim, elements, points)."""
        if tind is None:
            tind = np.arange(mapping.mesh.t.shape[1])
        if self.V is None:   # as ElementGlobal.gbasis: the inverse Vandermonde matrix per element
            self._pbasis_init(self.maxdeg, self.dim, self.derivatives, self.tensorial_basis)
            self.V = np.linalg.inv(self._eval_dofs(mapping.mesh))
        return np.ascontiguousarray(self.V[tind].transpose(1, 2, 0))[..., None], mapping.F(X, tind=tind)

    def _summed(self, inverse: np.ndarray, x: np.ndarray, diff: tuple[int, ...], term: np.ndarray) -> np.ndarray:
        """The derivative `diff` of every function at x, summed over the monomials in skfem's
        order; `term` is scratch space of the result's shape."""
        total = np.zeros_like(term)
        for coefficients, power in zip(inverse, self._pbasis[diff]):
            values = power(*x)
            if values.any():   # a monomial differentiated away adds exact zeros
                total += np.multiply(coefficients, values, out=term)
        return total


def probes(basis, points: np.ndarray, cells: np.ndarray | None = None):
    """skfem's `CellBasis.probes(points)` for a basis of `Argyris` (scalar): the matrix that
    takes a solution vector to its values at points (2, N), bit-identical, from the values
    alone (`Argyris.values`) where skfem builds every derivative too. `cells` are the
    elements the points lie in (skfem's element finder if None)."""
    from scipy.sparse import coo_matrix

    if cells is None:
        cells = basis.mesh.element_finder(mapping=basis.mapping)(*points)
    reference = basis.mapping.invF(points[:, :, np.newaxis], tind=cells)
    phis = basis.elem.values(basis.mapping, reference, cells)
    rows = np.tile(np.arange(points.shape[1], dtype=np.int32), basis.Nbfun)
    return coo_matrix((phis.ravel(), (rows, basis.element_dofs[:, cells].ravel())), shape=(points.shape[1], basis.N))
