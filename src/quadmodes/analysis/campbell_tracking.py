"""Branch tracking of a Campbell sweep (:mod:`quadmodes.analysis.campbell`): which root of one
spin rate continues which branch of the previous one.

* **MAC** of the state eigenvectors in the energy inner product ``xᴴ W y`` (kinetic 𝕄 on
  velocities plus |Λ − ωᵀJ2ω| on displacements; the displacement and velocity overlaps are
  added in modulus, so a root turning real at the onset of divergence stays on its branch,
  :func:`mac`), assigned optimally
  (:func:`scipy.optimize.linear_sum_assignment`) — never by sorting frequencies, so crossing
  branches keep their identity.
* **Degenerate roots by subspace.** Roots closer than :data:`NEAR_RTOL` (relative) form a
  cluster (flap/lag of a symmetric rotor at rest, the n = 1 pairs of an axisymmetric body): its
  eigenvectors are not unique, so a cluster is compared by the span of its vectors — the
  smallest squared cosine of the principal angles between the cluster's span at one spin rate
  and the span of the roots assigned to it at the next (:func:`span_mac`), which is the MAC for a
  single root. Where roots are equal to :data:`EXACT_RTOL` (any combination is an eigenvector)
  the basis is also rotated onto the previous one (orthogonal Procrustes,
  :func:`align_degenerate`), so a persistent pair keeps one member per branch instead of an
  arbitrary basis per spin rate.
* **Spin-free comparison.** An eigenvector has δṡ = λ δs, so its velocity block grows with
  |λ| against its displacement block; where every frequency scales with the spin (a membrane
  held taut by its spin alone) the same mode at two far-apart spins would compare with a MAC
  near ½ (and so would a degenerate pair's span). For such a body, before matching, each
  vector's displacement and velocity blocks are scaled to equal energy (:func:`balanced`): the
  same shape at any |λ| then compares as 1. (Not for a body stiff at rest: its gyroscopic
  roots do not split their energy equally, and the plain MAC tracks them.)
* **Poor matches are refused.** A match is accepted when its (span) MAC is at least
  :data:`MAC_ACCEPT` and every competitor is :data:`MAC_MARGIN` below it; otherwise the spin
  step is halved (:mod:`quadmodes.analysis.campbell`). A branch whose smallest MAC along the
  halved steps stays below :data:`MAC_REFUSE` ends there, and the root that would have
  continued it starts a new branch with its own label: labels stay with their branch.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

#: Roots closer than this (relative to the frequency scale plus |λ|) are one cluster for the
#: acceptance test (compared by span).
NEAR_RTOL = 1e-4
#: Roots closer than this are exactly degenerate: their basis is rotated onto the previous one.
EXACT_RTOL = 1e-7
#: Accept a match at or above this (span) MAC without halving the step.
MAC_ACCEPT = 0.9
#: Every competitor of an accepted match must be this far below it.
MAC_MARGIN = 0.5
#: A branch whose smallest MAC along the halved steps is below this ends (a new one starts).
MAC_REFUSE = 0.8


def normalise(vec: np.ndarray, wgt: np.ndarray) -> np.ndarray:
    """Columns of ``vec`` (m, k) scaled to unit energy ``vᴴ W v = 1``."""
    norms = np.sqrt(np.maximum(np.einsum("ik,ij,jk->k", vec.conj(), wgt, vec).real, 1e-300))
    return vec / norms


def balanced(vec: np.ndarray, wgt: np.ndarray, disp: np.ndarray) -> np.ndarray:
    """Columns of ``vec`` (m, k) with the displacement entries ``disp`` (m,) bool and the others
    (velocities, and δω of a free body) each scaled to energy ½ in ``W`` (W has no
    displacement–velocity coupling); a block below 1e-12 of its column's energy (a root at
    λ = 0: no velocity) is left as it is and the other block scaled to energy 1. The span of
    a cluster of equal roots is kept (both blocks scale alike across it)."""
    d = np.asarray(disp, bool)
    out = np.array(vec, dtype=complex)
    e_d = np.einsum("ik,ij,jk->k", out[d].conj(), wgt[np.ix_(d, d)], out[d]).real
    e_v = np.einsum("ik,ij,jk->k", out[~d].conj(), wgt[np.ix_(~d, ~d)], out[~d]).real
    total = np.maximum(e_d + e_v, 1e-300)
    for blk, e, other in ((d, e_d, e_v), (~d, e_v, e_d)):
        live = e > 1e-12 * total
        alone = live & (other <= 1e-12 * total)
        scale = np.where(alone, 1.0, 0.5) / np.maximum(e, 1e-300)
        out[np.ix_(blk, live)] *= np.sqrt(scale[live])
    return out


def mac(a: np.ndarray, b: np.ndarray, wgt: np.ndarray, disp: np.ndarray | None = None):
    """MAC matrix (ka, kb) of columns of a and b in the inner product ``xᴴ W y``; with ``disp``
    (m,) bool (the displacement entries; W has no displacement–velocity coupling) the moduli of
    the displacement and velocity overlaps are added, ``(|x_sᴴW y_s| + |x_vᴴW y_v|)²``, so the
    relative phase of velocity and displacement does not count: a root that turns real at the
    onset of divergence (δṡ = λ δs with λ from iω to real) stays on its branch."""
    if disp is None:
        cross = np.abs(a.conj().T @ wgt @ b)
    else:
        d, v = np.asarray(disp, bool), ~np.asarray(disp, bool)
        cross = np.abs(a[d].conj().T @ wgt[np.ix_(d, d)] @ b[d])
        cross = cross + np.abs(a[v].conj().T @ wgt[np.ix_(v, v)] @ b[v])
    na = np.sqrt(np.maximum(np.einsum("ik,ij,jk->k", a.conj(), wgt, a).real, 1e-300))
    nb = np.sqrt(np.maximum(np.einsum("ik,ij,jk->k", b.conj(), wgt, b).real, 1e-300))
    # normalised before squaring: near a divergence the weight grows without bound and the
    # squared overlap would overflow; a non-finite overlap is no match at all
    with np.errstate(over="ignore", invalid="ignore"):
        ratio = (cross / na[:, None]) / nb[None, :]
    return np.nan_to_num(ratio**2, nan=0.0, posinf=0.0, neginf=0.0)


def _orthonormal(vec: np.ndarray, wgt: np.ndarray) -> np.ndarray:
    """A W-orthonormal basis (m, k) of the span of the columns of ``vec`` (m, k)."""
    g = vec.conj().T @ wgt @ vec
    lam, u = np.linalg.eigh(0.5 * (g + g.conj().T))
    keep = lam > 1e-12 * max(float(lam.max(initial=0.0)), 1e-300)
    return vec @ (u[:, keep] / np.sqrt(lam[keep]))


def span_mac(a: np.ndarray, b: np.ndarray, wgt: np.ndarray) -> float:
    """Smallest squared cosine of the principal angles between the spans of the columns of a
    (m, k) and b (m, k) in the W inner product (1: the same span; the MAC for k = 1)."""
    qa, qb = _orthonormal(a, wgt), _orthonormal(b, wgt)
    if qa.shape[1] != a.shape[1] or qb.shape[1] != b.shape[1]:
        return 0.0
    sv = np.linalg.svd(qa.conj().T @ wgt @ qb, compute_uv=False)
    return float(min(sv.min(initial=1.0), 1.0) ** 2)


def clusters(lam: np.ndarray, scale: float, rtol: float) -> list[list[int]]:
    """Indices of the roots ``lam`` (k,) grouped into clusters of roots closer than
    ``rtol (scale + |λ|)`` (chained), singletons included."""
    parent = list(range(lam.size))

    def root(i: int) -> int:
        while parent[i] != i:
            i = parent[i]
        return i

    for i in range(lam.size):
        for j in range(i + 1, lam.size):
            if abs(lam[i] - lam[j]) <= rtol * (scale + abs(lam[i])):
                parent[root(j)] = root(i)
    groups: dict[int, list[int]] = {}
    for i in range(lam.size):
        groups.setdefault(root(i), []).append(i)
    return list(groups.values())


def align_degenerate(
    v0: np.ndarray, v1: np.ndarray, lam1: np.ndarray, wgt: np.ndarray, scale: float
) -> np.ndarray:
    """``v1`` (m, k) with the basis of every exactly degenerate cluster of ``lam1`` rotated
    (W-orthonormalised, then the unitary polar factor of its overlap with the ``v0`` columns it
    resembles most) onto ``v0`` (m, k); unit energy columns."""
    out = v1.astype(complex)
    for group in clusters(lam1, scale, EXACT_RTOL):
        if len(group) < 2:
            continue
        q1 = _orthonormal(out[:, group], wgt)
        if q1.shape[1] != len(group):
            continue  # defective: leave it
        share = np.sum(mac(v0, q1, wgt), axis=1)  # share of each v0 vector in the span
        near = np.argsort(-share)[: len(group)]
        u, _, vh = np.linalg.svd(q1.conj().T @ wgt @ v0[:, near])
        out[:, group] = q1 @ (u @ vh)
    return normalise(out, wgt)


def _linked(lam0: np.ndarray, lam1: np.ndarray, order: np.ndarray, scale: float):
    """Clusters of branches (lists of p0 indices) that are near-degenerate at either end."""
    joined = np.concatenate([lam0, lam1[order]])
    n = lam0.size
    merged = clusters(joined, scale, NEAR_RTOL)
    parent = list(range(n))

    def root(i: int) -> int:
        while parent[i] != i:
            i = parent[i]
        return i

    for g in merged:
        idx = [i % n for i in g]
        for i in idx[1:]:
            parent[root(i)] = root(idx[0])
    groups: dict[int, list[int]] = {}
    for i in range(n):
        groups.setdefault(root(i), []).append(i)
    return list(groups.values())


def match(v0, lam0, v1, lam1, wgt, scale, disp=None, balance=False):
    """Assignment of roots 1 to branches 0: ``(order (k,) index into roots 1 per branch, span
    MAC (k,) of each branch's cluster, ok)``; ``ok``: every match clear (module docstring).
    ``v*`` (m, k) unit-energy eigenvectors, ``lam*`` (k,) roots, ``wgt`` (m, m) the energy
    weight, ``scale`` (1/s) the frequency scale, ``disp`` (m,) bool the displacement entries
    (:func:`mac`; single roots only, clusters by span); ``balance``: both compared
    :func:`balanced` (a body stiffened by its spin alone)."""
    if disp is not None and balance:
        v0, v1 = balanced(v0, wgt, disp), balanced(v1, wgt, disp)
    m = mac(v0, v1, wgt, disp)
    dist = np.abs(lam0[:, None] - lam1[None, :]) / scale
    rows, cols = linear_sum_assignment(-(m - 1e-3 * dist))
    order = np.empty(len(rows), int)
    order[rows] = cols
    measure = np.empty(len(rows))
    runner = np.full(len(rows), -np.inf)
    for group in _linked(lam0, lam1, order, scale):
        targets = order[group]
        measure[group] = (
            span_mac(v0[:, group], v1[:, targets], wgt) if len(group) > 1 else m[group[0], targets[0]]
        )
        others_1 = np.setdiff1d(np.arange(len(rows)), targets)
        others_0 = np.setdiff1d(np.arange(len(rows)), group)
        for i in group:
            best = m[i, others_1].max(initial=-np.inf)
            rival = m[others_0, order[i]].max(initial=-np.inf)
            runner[i] = max(best, rival)
    ok = bool(np.all(measure >= MAC_ACCEPT) and np.all(runner <= measure - MAC_MARGIN))
    return order, measure, ok
