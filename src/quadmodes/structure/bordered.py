"""Bordered sparse solves shared by the statics, modal, reduction and rotating-frame stages.

``[[K + Σ c v vᵀ, C], [Cᵀ, 0]] [u; λ] = [r; 0]``: a sparse matrix ``K`` with optional linear
constraints ``Cᵀ u = 0`` (e.g. the mass-weighted rigid-motion frame conditions ``Ψᵀ M u = 0``
of a free body, with multipliers ``λ``) and optional rank-one terms (the gas-law pressure
stiffness), applied by Sherman–Morrison on top of one sparse LU factorisation.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla


def bordered_solver(
    k: sp.spmatrix,
    constraint: np.ndarray | None,
    low_rank: Sequence[tuple[float, np.ndarray]],
    permc_spec: str = "COLAMD",
) -> Callable[[np.ndarray], np.ndarray]:
    """Factorise ``[[K + Σ c v vᵀ, C], [Cᵀ, 0]]`` and return ``rhs (m,) -> solution (m,)``.

    k: ``(m, m)`` sparse matrix. constraint: ``(m, r)`` constraint columns ``C``, or None.
    low_rank: ``(c, v)`` pairs of rank-one terms ``c v vᵀ`` with ``v`` of shape ``(m,)``; empty
    for none. permc_spec: SuperLU column ordering (``"NATURAL"`` is the fastest for a banded
    mesh numbering with a few dense border columns). The multipliers are dropped from the
    solution.
    """
    n = k.shape[0]
    if constraint is None:
        a = k.tocsc()
    else:
        c = sp.csc_matrix(constraint)
        a = sp.bmat([[k, c], [c.T, None]], format="csc")
    lu = spla.splu(a, permc_spec=permc_spec)
    m = a.shape[0]

    def base(rhs: np.ndarray) -> np.ndarray:
        full = np.zeros(m)
        full[:n] = rhs
        return lu.solve(full)[:n]

    if not low_rank:
        return base
    # Sherman–Morrison for the rank-one gas-law terms.
    vecs = [(coef, vec, base(vec)) for coef, vec in low_rank]

    def solve(rhs: np.ndarray) -> np.ndarray:
        y = base(rhs)
        for coef, vec, kv in vecs:
            y = y - kv * (coef * (vec @ y) / (1.0 + coef * (vec @ kv)))
        return y

    return solve
