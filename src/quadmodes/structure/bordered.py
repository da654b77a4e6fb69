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

from quadmodes.linalg.factor import lu_factor, with_rank_one_terms


def bordered_solver(
    k: sp.spmatrix,
    constraint: np.ndarray | None,
    low_rank: Sequence[tuple[float, np.ndarray]],
) -> Callable[[np.ndarray], np.ndarray]:
    """Factorise ``[[K + Σ c v vᵀ, C], [Cᵀ, 0]]`` and return ``rhs (m,) -> solution (m,)``.

    k: ``(m, m)`` sparse matrix. constraint: ``(m, r)`` constraint columns ``C``, or None.
    low_rank: ``(c, v)`` pairs of rank-one terms ``c v vᵀ`` with ``v`` of shape ``(m,)``; empty
    for none. The multipliers are dropped from the solution.
    """
    n = k.shape[0]
    if constraint is None:
        a = k.tocsc()
    else:
        c = sp.csc_matrix(constraint)
        a = sp.bmat([[k, c], [c.T, None]], format="csc")
    lu = lu_factor(a, symmetric=True)
    m = a.shape[0]

    def base(rhs: np.ndarray) -> np.ndarray:
        full = np.zeros(m)
        full[:n] = rhs
        return lu.solve(full)[:n]

    return with_rank_one_terms(base, low_rank)
