"""Bordered sparse solves shared by the statics, modal, reduction and rotating-frame stages.

``[[K + Σ c v vᵀ, C], [Cᵀ, 0]] [u; λ] = [r; 0]``: a sparse matrix ``K`` with optional linear
constraints ``Cᵀ u = 0`` (e.g. the mass-weighted rigid-motion frame conditions ``Ψᵀ M u = 0``
of a free body, with multipliers ``λ``) and optional rank-one terms (the gas-law pressure
stiffness), applied by Sherman–Morrison on top of one sparse LU factorisation
(:mod:`quadmodes.linalg.factor`; ``K`` is taken to be symmetric, as every caller's is).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import scipy.sparse as sp

from quadmodes.linalg.factor import Solve, factorize, with_rank_one_terms


def bordered_matrix(k: sp.spmatrix, constraint: np.ndarray | None) -> sp.csc_matrix:
    """``[[K, C], [Cᵀ, 0]]`` (CSC, ``(m + r, m + r)``), or ``K`` itself without constraints.

    k: ``(m, m)`` sparse matrix. constraint: ``(m, r)`` constraint columns ``C``, or None."""
    if constraint is None:
        return sp.csc_matrix(k)
    c = sp.csc_matrix(constraint)
    return sp.bmat([[k, c], [c.T, None]], format="csc")


def padded_low_rank(low_rank: Sequence[tuple[float, np.ndarray]], size: int) -> list:
    """The rank-one terms ``(c, v)`` with ``v`` padded by zeros to ``size`` (the multipliers'
    rows of a bordered matrix)."""
    out = []
    for coef, vec in low_rank:
        full = np.zeros(size)
        full[: vec.size] = vec
        out.append((coef, full))
    return out


def bordered_full_solver(
    a: sp.spmatrix, low_rank: Sequence[tuple[float, np.ndarray]], border: int = 0,
    single: bool = False, nodes: np.ndarray | None = None,
) -> Solve:
    """Factorise the bordered matrix ``a`` (from :func:`bordered_matrix`) plus rank-one terms
    (``v`` of the unbordered size) and return ``rhs (m + r,) -> solution (m + r,)``,
    multipliers included. border: the number of constraint columns of ``a``. nodes:
    ``(m,)`` node of each unconstrained row, for a fast ordering (see
    :func:`quadmodes.linalg.factor.lu_factor`), or None. single: a single-precision factorisation (an approximate inverse,
    to about 1e-7 cond(a) relative, for a Krylov iteration; see
    :func:`quadmodes.linalg.factor.factorize`)."""
    lu = factorize(a, symmetric=True, single=single, border=border, nodes=nodes)
    return with_rank_one_terms(lu.solve, padded_low_rank(low_rank, a.shape[0]))


def bordered_operator(a: sp.spmatrix, low_rank: Sequence[tuple[float, np.ndarray]]) -> Solve:
    """``v (m + r,) -> (a + Σ c v vᵀ) v`` for the bordered matrix ``a`` and rank-one terms
    (``v`` of the unbordered size)."""
    terms = padded_low_rank(low_rank, a.shape[0])

    def apply(v: np.ndarray) -> np.ndarray:
        out = a @ v
        for coef, vec in terms:
            out = out + coef * vec * (vec @ v)
        return out

    return apply


def bordered_solver(
    k: sp.spmatrix,
    constraint: np.ndarray | None,
    low_rank: Sequence[tuple[float, np.ndarray]],
    nodes: np.ndarray | None = None,
) -> Callable[[np.ndarray], np.ndarray]:
    """Factorise ``[[K + Σ c v vᵀ, C], [Cᵀ, 0]]`` and return ``rhs (m,) -> solution (m,)``.

    k: ``(m, m)`` sparse matrix. constraint: ``(m, r)`` constraint columns ``C``, or None.
    low_rank: ``(c, v)`` pairs of rank-one terms ``c v vᵀ`` with ``v`` of shape ``(m,)``; empty
    for none. nodes: ``(m,)`` node of each row of ``k``, for a fast ordering, or None. The
    multipliers are dropped from the solution.
    """
    n = k.shape[0]
    a = bordered_matrix(k, constraint)
    m = a.shape[0]
    lu = factorize(a, symmetric=True, border=m - n, nodes=nodes)  # $QUADMODES_LINALG

    def base(rhs: np.ndarray) -> np.ndarray:
        full = np.zeros(m)
        full[:n] = rhs
        return lu.solve(full)[:n]

    return with_rank_one_terms(base, low_rank)
