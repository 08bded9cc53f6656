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
        if tind is None:
            tind = np.arange(mapping.mesh.t.shape[1])
        if self.V is None:   # as ElementGlobal.gbasis: the inverse Vandermonde matrix per element
            self._pbasis_init(self.maxdeg, self.dim, self.derivatives, self.tensorial_basis)
            self.V = np.linalg.inv(self._eval_dofs(mapping.mesh))
        # (monomial, function, element, 1): each monomial's coefficients, contiguous
        inverse = np.ascontiguousarray(self.V[tind].transpose(1, 2, 0))[..., None]
        x = mapping.F(X, tind=tind)            # (dim, elements, points)
        n_functions = inverse.shape[1]
        term = np.empty((n_functions,) + x[0].shape)
        per_order = []
        for k in range(self.derivatives + 1):
            derivatives = []
            for diff in itertools.product(range(self.dim), repeat=k):
                total = np.zeros_like(term)
                for coefficients, power in zip(inverse, self._pbasis[diff]):
                    values = power(*x)
                    if values.any():   # a monomial differentiated away adds exact zeros
                        total += np.multiply(coefficients, values, out=term)
                derivatives.append(total)
            per_order.append(np.stack(derivatives, axis=1).reshape(
                (n_functions,) + (self.dim,) * k + x[0].shape))
        return [(DiscreteField(value=per_order[0][j], grad=per_order[1][j], hess=per_order[2][j],
                               **{f"grad{k + 3}": per_order[k + 3][j]
                                  for k in range(self.derivatives - 2)}),)
                for j in range(n_functions)]
