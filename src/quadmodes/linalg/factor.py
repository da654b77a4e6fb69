"""Sparse LU factorisations (SuperLU, always installed) and rank-one updates of their solves.

Orderings: a matrix with a symmetric pattern whose diagonal pivots are acceptable (the tangent
stiffness of a conservative model, bordered by constraint columns; a shifted ``K − σM``) is
ordered by minimum degree on ``A + Aᵀ`` with diagonal pivoting preferred (SuperLU's
``SymmetricMode``, ``diag_pivot_thresh`` 0.01: an off-diagonal pivot is taken only when the
diagonal one is a hundred times smaller than the largest of its column). On the bordered
inflation tangent of ``paper-membrane`` this keeps 43–45 % less fill than COLAMD (3k and 20k
nodes, docs/performance.md). Other matrices use COLAMD with partial pivoting. Both give the
solution to round-off; only the cost differs.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

Solve = Callable[[np.ndarray], np.ndarray]

#: SuperLU options for symmetric-pattern matrices with usable diagonal pivots.
SYMMETRIC_OPTIONS = {"permc_spec": "MMD_AT_PLUS_A", "diag_pivot_thresh": 0.01,
                     "options": {"SymmetricMode": True}}  # fmt: skip
#: SuperLU options for general sparse matrices.
GENERAL_OPTIONS = {"permc_spec": "COLAMD"}


def lu_factor(a: sp.spmatrix, symmetric: bool = True) -> spla.SuperLU:
    """SuperLU factorisation of the square sparse matrix ``a`` (real or complex).

    symmetric: ``a`` has a symmetric sparsity pattern and acceptable diagonal pivots (use
    :data:`SYMMETRIC_OPTIONS`); if that factorisation finds an exactly singular pivot it is
    redone with :data:`GENERAL_OPTIONS` (full partial pivoting) before giving up."""
    a = sp.csc_matrix(a)
    if not symmetric:
        return spla.splu(a, **GENERAL_OPTIONS)
    try:
        return spla.splu(a, **SYMMETRIC_OPTIONS)
    except RuntimeError:  # "Factor is exactly singular": let partial pivoting decide
        return spla.splu(a, **GENERAL_OPTIONS)


def with_rank_one_terms(solve: Solve, low_rank: Sequence[tuple[float, np.ndarray]]) -> Solve:
    """Solve with ``A + Σ c v vᵀ`` given the solve with ``A`` (Sherman–Morrison, one term after
    the other). low_rank: ``(c, v)`` pairs, ``v`` of the solve's length; empty: ``solve`` itself."""
    if not low_rank:
        return solve
    terms = []
    for coef, vec in low_rank:
        terms.append((coef, vec, _updated(solve, terms)(vec)))

    return _updated(solve, terms)


def _updated(solve: Solve, terms: list) -> Solve:
    def updated(rhs: np.ndarray) -> np.ndarray:
        y = solve(rhs)
        for coef, vec, kv in terms:
            y = y - kv * (coef * (vec @ y) / (1.0 + coef * (vec @ kv)))
        return y

    return updated
