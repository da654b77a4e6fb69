"""Full-order rotating-frame eigenproblem: the roots of ``(λ²M + λG + K) q = 0`` linearised
about a relative equilibrium (:mod:`quadmodes.structure.spinning`, whose docstring
derives M, G = 2Ω M Ê and K = K_T − Ω² M P̂).

**Eigenproblem.** ``K`` is indefinite for a free spinning body (−Ω² m on transverse translations,
Ω²(I_e − I_⊥) < 0 on tilts about a minor axis) and singular (rotation about ``e``), so the usual
symmetric form of a gyroscopic system, which needs K ≻ 0, is not available. The roots are found
instead by complex shift-invert Arnoldi (``scipy.sparse.linalg.eigs``) on the companion pencil
``A z = λ B z``, ``z = (q, q̇)``, ``A = [[0, I], [−K, −G]]``, ``B = diag(I, M)``: one sparse complex
LU of ``K + σG + σ²M`` (3n) per shift σ = i·ω_target applies ``(A − σB)⁻¹B``. Rigid roots of the
free body: the translations are an exactly invariant subspace with roots 0 (along e) and the
defective ±iΩ (across e); Arnoldi runs on the mass-weighted complement (centre of mass fixed), where
they do not exist. The tilt about a transverse axis (the equilibrium spinning about a slightly
tilted axis) is the exact root iΩ with a pure rigid-rotation eigenvector; it has no counterpart in
the reduced model (it is a change of attitude, not of ω or s) and is labelled ``"tilt"``; the
rotation about ``e`` and the spin-rate change give a double zero, far from the shifts.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from quadmodes.fe.model import Structure, mass_matrix, rigid_body_modes, tangent_low_rank
from quadmodes.linalg.factor import lu_factor, with_rank_one_terms
from quadmodes.rotations import unit_axis
from quadmodes.structure.spinning import gyroscopic_matrix, rotating_stiffness

#: Relative offset of a shift from its target frequency (keeps K + σG + σ²M regular).
SHIFT_OFFSET = 3e-3


@dataclass(frozen=True)
class RotatingRoots:
    """Roots of ``(λ²M + λG + K) q = 0`` near the requested targets (Im λ > 0 only).

    lam (k,) complex 1/s: eigenvalues, ascending Im λ. shapes (k, n, 3) complex (1/√kg):
    displacement parts, mass-normalised (qᴴMq = 1), zero on clamped components.
    rigid_fraction (k,): mass-weighted share of the rigid motions (about the centre of mass) in q.
    residual (k,): ‖(λ²M + λG + K) q‖ / (|λ|²‖Mq‖ + ‖Kq‖). kind (k,): "elastic", or "tilt" for
    the exact rigid root iΩ of a free body (attitude change, no reduced-model counterpart).
    """

    lam: np.ndarray
    shapes: np.ndarray
    rigid_fraction: np.ndarray
    residual: np.ndarray
    kind: tuple[str, ...]
    spin: float

    @property
    def frequency_hz(self) -> np.ndarray:
        return np.abs(self.lam.imag) / (2.0 * np.pi)


def _complex_solver(q: sp.spmatrix, low_rank) -> Callable:
    """Sparse complex LU of ``Q + Σ c v vᵀ`` (Sherman–Morrison for the gas-law terms)."""
    lu = lu_factor(q, symmetric=False)
    return with_rank_one_terms(lu.solve, [(c, v.astype(complex)) for c, v in low_rank])


@dataclass(frozen=True)
class _Pencil:
    """The quadratic pencil on the free DOFs (nf of them): m, k, g (nf, nf) csr (kg, N/m, kg/s),
    the gas-law rank-one terms ``low`` [(c, v (nf,))] of the stiffness, and ``project``, the
    M-orthogonal removal of the rigid translations (identity for a clamped body)."""

    m: sp.csr_matrix
    k: sp.csr_matrix
    g: sp.csr_matrix
    low: list
    project: Callable[[np.ndarray], np.ndarray]

    @property
    def nf(self) -> int:
        return self.m.shape[0]

    def stiffness_times(self, v: np.ndarray) -> np.ndarray:
        """``(K + Σ c w wᵀ) v`` for a vector v (nf,)."""
        out = self.k @ v
        for c, w in self.low:
            out = out + c * w * (w @ v)
        return out


def _translation_projector(structure: Structure, x: np.ndarray, m: sp.csr_matrix) -> Callable:
    """``v ↦ v − T (TᵀMT)⁻¹ TᵀM v`` on the free DOFs (centre of mass fixed) for a free body,
    the identity for a clamped one."""
    if not structure.is_free:
        return lambda v: v
    t = rigid_body_modes(structure, x)[structure.free_dofs][:, :3]
    mt = m @ t
    # complex, contiguous copies: mixed real/complex products fall off the BLAS fast path
    left = np.ascontiguousarray(t, dtype=complex)
    right = np.ascontiguousarray(np.linalg.solve(t.T @ mt, mt.T), dtype=complex)
    return lambda v: v - left @ (right @ v)


def _pencil(structure: Structure, x: np.ndarray, spin: float, e: np.ndarray) -> _Pencil:
    """M, K, G of the rotating-frame linearisation about ``x`` at ``spin`` (rad/s) about ``e``
    (3,), restricted to the free DOFs."""
    free = structure.free_dofs
    m = mass_matrix(structure)[free][:, free].tocsr()
    k = rotating_stiffness(structure, x, spin, e)[free][:, free].tocsr()
    g = gyroscopic_matrix(structure, spin, e)[free][:, free].tocsr()
    low = [(c, v[free]) for c, v in tangent_low_rank(structure, x)]
    return _Pencil(m, k, g, low, _translation_projector(structure, x, m))


def shift_clusters(targets_hz: Sequence[float], merge_rtol: float) -> list[list[float]]:
    """Targets (Hz, |f| floored at 0.05 Hz, ascending) grouped into clusters spanning at most a
    factor ``1 + merge_rtol``; each cluster gets one shift."""
    clusters: list[list[float]] = []
    for f in sorted(max(abs(float(f)), 0.05) for f in targets_hz):
        if clusters and f <= clusters[-1][0] * (1.0 + merge_rtol):
            clusters[-1].append(f)
        else:
            clusters.append([f])
    return clusters


def _roots_near_shift(
    p: _Pencil, cluster: list[float], per_target: int, tol: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Shift-invert Arnoldi about the shift of one cluster: ``(λ (k,) complex 1/s, q (k, nf))``.

    A shift exactly on a root makes K + σG + σ²M singular (at Ω = 0 the targets are the roots),
    so it sits SHIFT_OFFSET above the cluster centre; a zero target (divergence) is searched just
    above the real axis. The number of roots grows until every target lies well inside the disc
    of roots found around σ, so that the roots nearest to it are all among them."""
    nf, project, m, g = p.nf, p.project, p.m, p.g
    centre_hz = 0.5 * (cluster[0] + cluster[-1]) * (1.0 + SHIFT_OFFSET)
    sigma = 2j * np.pi * centre_hz
    solve = _complex_solver((p.k + sigma * g + sigma**2 * m).astype(complex), p.low)

    def op(z):
        z1, z2 = project(z[:nf]), project(z[nf:])
        y1 = project(-solve(m @ z2 + g @ z1 + sigma * (m @ z1)))
        return np.concatenate([y1, z1 + sigma * y1])

    a = spla.LinearOperator((2 * nf, 2 * nf), matvec=op, dtype=complex)
    v0 = rng.standard_normal(2 * nf) + 1j * rng.standard_normal(2 * nf)
    v0 = np.concatenate([project(v0[:nf]), project(v0[nf:])])
    reach = 2.0 * np.pi * max(abs(f - centre_hz) for f in cluster)
    kk = per_target + 2 * len(cluster)
    while True:
        kk = min(kk, 2 * nf - 2)
        ncv = min(2 * nf, max(2 * kk + 1, 20))
        nu, vec = spla.eigs(a, k=kk, which="LM", v0=v0, tol=tol, ncv=ncv)
        lam = sigma + 1.0 / nu
        if reach <= 0.6 * np.abs(lam - sigma).max() or kk >= 2 * nf - 2:
            return lam, vec[:nf].T
        kk *= 2


def _residuals_and_normalise(p: _Pencil, lam: np.ndarray, qs: np.ndarray):
    """Relative residuals (k,) ``‖(λ²M + λG + K) q‖ / (|λ|²‖Mq‖ + ‖Kq‖)`` of roots λ (k,) with
    vectors qs (k, nf), and the mass-normalised ``(q (k, nf), Mq (k, nf))``."""
    mq = (p.m @ qs.T).T
    kq = np.stack([p.stiffness_times(q) for q in qs]) if qs.size else qs
    gq = (p.g @ qs.T).T
    res = lam[:, None] ** 2 * mq + lam[:, None] * gq + kq
    resid = np.linalg.norm(res, axis=1) / (
        np.abs(lam) ** 2 * np.linalg.norm(mq, axis=1) + np.linalg.norm(kq, axis=1)
    )
    norms = np.sqrt(np.einsum("ki,ki->k", qs.conj(), mq).real)
    return resid, qs / norms[:, None], mq / norms[:, None]


def _distinct_roots(lam: np.ndarray, qs: np.ndarray, mq: np.ndarray, resid: np.ndarray) -> list:
    """Indices of the distinct roots, ascending Im λ. A root found by several shifts keeps its
    most accurate copy (the nearest shift's); two roots are the same if the eigenvalues agree to
    1e-6 and the shapes are parallel (so an exactly degenerate pair keeps both members)."""
    uniq: list[int] = []
    for i in np.argsort(resid):
        same = [
            j
            for j in uniq
            if abs(lam[i] - lam[j]) <= 1e-6 * abs(lam[i]) and abs(qs[j].conj() @ mq[i]) ** 2 > 0.9
        ]
        if not same:
            uniq.append(int(i))
    return sorted(uniq, key=lambda i: lam[i].imag)


def _root_kinds(
    structure: Structure, spin: float, lam: np.ndarray, rigid: np.ndarray
) -> tuple[str, ...]:
    """Kind of each root: "tilt" for the exact rigid root iΩ of a spinning free body, else
    "elastic"."""
    return tuple(
        "tilt"
        if structure.is_free
        and spin != 0.0
        and rigid[i] > 0.99
        and abs(lam[i].imag - abs(spin)) <= 1e-6 * abs(spin)
        else "elastic"
        for i in range(lam.size)
    )


def rotating_roots(
    structure: Structure,
    x: np.ndarray,
    spin: float,
    axis,
    targets_hz: Sequence[float],
    per_target: int = 6,
    tol: float = 1e-12,
    merge_rtol: float = 0.25,
    seed: int = 0,
) -> RotatingRoots:
    """Roots of the rotating-frame linearisation about ``x`` (an equilibrium at ``spin`` rad/s
    about ``axis``) nearest to each of ``targets_hz`` (Hz, rotating frame).

    Complex shift-invert Arnoldi on the companion pencil, one LU of ``K + σG + σ²M`` per shift
    σ = 2πi f (targets closer than ``merge_rtol`` share a shift), ``per_target`` roots per shift;
    for a free body the Krylov space is kept on the centre-of-mass-free subspace (module
    docstring). Roots found by several shifts are merged."""
    p = _pencil(structure, x, spin, unit_axis(axis))
    rng = np.random.default_rng(seed)
    found = [
        _roots_near_shift(p, cluster, per_target, tol, rng)
        for cluster in shift_clusters(targets_hz, merge_rtol)
    ]
    lam = np.concatenate([f[0] for f in found])
    qs = np.concatenate([f[1] for f in found])
    keep = lam.imag > 1e-9 * max(1.0, np.abs(lam).max())
    lam, qs = lam[keep], qs[keep]
    resid, qs, mq = _residuals_and_normalise(p, lam, qs)
    uniq = _distinct_roots(lam, qs, mq, resid)
    lam, qs, resid = lam[uniq], qs[uniq], resid[uniq]
    full = np.zeros((lam.size, 3 * structure.n), complex)
    full[:, structure.free_dofs] = qs
    rigid = _rigid_fraction(structure, x, full)
    return RotatingRoots(
        lam=lam,
        shapes=full.reshape(lam.size, structure.n, 3),
        rigid_fraction=rigid,
        residual=resid,
        kind=_root_kinds(structure, spin, lam, rigid),
        spin=float(spin),
    )


def _rigid_fraction(structure: Structure, x: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Mass-weighted rigid share (k,) of complex vectors (k, 3n); 0 for a clamped body."""
    if not structure.is_free or vectors.size == 0:
        return np.zeros(vectors.shape[0])
    psi = rigid_body_modes(structure, x)
    m = mass_matrix(structure)
    mpsi = m @ psi
    coef = np.linalg.solve(psi.T @ mpsi, mpsi.T @ vectors.T)  # (6, k)
    rig = np.einsum("ik,ij,jk->k", coef.conj(), psi.T @ mpsi, coef).real
    tot = np.einsum("ki,ki->k", vectors.conj(), (m @ vectors.T).T).real
    return rig / np.maximum(tot, 1e-300)
