"""The exact kinetic energy of the quadratic manifold and its Rayleigh damping: the arrays of
formulation "QM" (issue 29; the research prototype is
:mod:`quadmodes.experimental.manifold_lagrangian`, the derivation docs/path-validity.md
"A consistent fourth-order Lagrangian", the product's state docs/manifold-formulation.md).

The body-frame field of the manifold r(s) = X + Φs + Σ s_m s_n g^{mn} is written
r = Σ_α z_α(s) Y_α with the fields Y = (X, Φ_k, g^{mn} (m ≤ n, doubled off the diagonal)) and the
monomials z = (1, s_k, s_m s_n), K = 1 + N + N(N+1)/2 of them. With ν = (ω, ṡ) the kinetic
energy T = ½ Σ M |ω × r + ṙ|² = ½ νᵀ𝕄(s)ν has

    J(s) = tr(P) I − P,   P = Σ z_α z_β O_αβ              (quartic in s)
    A_k(s) = Σ M r × T_k = Σ z_α (∂z_β/∂s_k) ×O_αβ        (cubic)
    μ_kl(s) = Σ M T_k·T_l = Σ ∂_k z_α ∂_l z_β tr O_αβ     (quadratic)

with the constant mass-weighted outer products O_αβ = Σ_nodes M Y_α Y_βᵀ (K, K, 3, 3) and
T_k = ∂r/∂s_k. Damping: the Rayleigh function ½ u̇ᵀ (M Φ_d C_d Φ_dᵀ M) u̇ of the full order's
modal damping (modes Φ_d, matrix C_d) on the manifold velocity u̇ = Σ ṡ_k T_k(s) gives
C(s) = B(s)ᵀ C_d B(s), B(s) = Φ_dᵀM(Φ + 2 Σ_n s_n g^{·n}) = B0 + Σ_n s_n B1_n (affine in s);
without damping modes C(s) is the model's constant C.

The arrays are computed from the model's fields (X, Φ, G) and the structure's scalar mass
matrix (which the model file does not hold): O(K² n) work once per model, O(K²) numbers
(N = 10: K = 66, 39 204 numbers).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def cross_part(o: np.ndarray) -> np.ndarray:
    """``Σ M u × v`` (..., 3) from ``o = Σ M u vᵀ`` (..., 3, 3)."""
    return np.stack([o[..., 1, 2] - o[..., 2, 1], o[..., 2, 0] - o[..., 0, 2],
                     o[..., 0, 1] - o[..., 1, 0]], -1)  # fmt: skip


@dataclass(frozen=True, eq=False)
class ManifoldArrays:
    """The constant arrays of the manifold kinetic energy and damping (module docstring).

    O (K, K*9): O_αβ flattened per row α; tr (K, K): tr O_αβ; cr (K, K*3): Σ M Y_α × Y_β;
    pair_a, pair_b (N(N+1)/2,) int: the modes of the quadratic monomials z_{1+N+i} = s_a s_b;
    C0 (N, N) 1/s: the constant damping without damping modes; B0 (D, N), B1 (N, D, N) and
    Cd (D, D) 1/s: the damping on the manifold velocity (D damping modes; None without)."""

    n_modes: int
    O: np.ndarray
    tr: np.ndarray
    cr: np.ndarray
    pair_a: np.ndarray
    pair_b: np.ndarray
    C0: np.ndarray
    B0: np.ndarray | None = None
    B1: np.ndarray | None = None
    Cd: np.ndarray | None = None

    @property
    def size(self) -> int:
        return self.tr.shape[0]


@dataclass(frozen=True, eq=False)
class ModalDamping:
    """Damping modes: shapes (D, n, 3) 1/√kg mass-normalised, C (D, D) 1/s (the fields of
    :class:`~quadmodes.fullorder.damping.DampingModes` that C(s) uses)."""

    shapes: np.ndarray
    C: np.ndarray


def retained_damping(model) -> ModalDamping:
    """The reduced model's own damping (its retained modes Φ and projected C) as damping modes:
    C(0) = ΦᵀMΦ C ΦᵀMΦ = C, and C(s) adds the quadratic modes' velocity, 2 Σ s_n g^{kn} ṡ_k."""
    return ModalDamping(np.asarray(model.Phi, float), np.asarray(model.C, float))


def manifold_arrays(model, mass_scalar, damping_modes=None) -> ManifoldArrays:
    """The :class:`ManifoldArrays` of a reduced ``model`` (fields X (n,3), Phi (N,n,3), G
    (N,N,n,3)) with the structure's scalar mass matrix ``mass_scalar`` (n, n) kg (sparse or
    dense) and, optionally, the full order's ``damping_modes``
    (:class:`~quadmodes.fullorder.damping.DampingModes`)."""
    n = int(model.n_modes)
    x, phi, g = (np.asarray(a, float) for a in (model.X, model.Phi, model.G))
    pairs = np.array([(a, b) for a in range(n) for b in range(a, n)], int).reshape(-1, 2)
    quad = [g[a, b] if a == b else 2.0 * g[a, b] for a, b in pairs]
    fields = np.concatenate([x[None], phi, np.array(quad).reshape(-1, *x.shape)])
    weighted = np.stack([mass_scalar @ f for f in fields])
    o = np.einsum("aib,gic->agbc", fields, weighted, optimize=True)
    o = 0.5 * (o + o.transpose(1, 0, 3, 2))  # symmetric to round-off: O_αβ = O_βαᵀ
    k = o.shape[0]
    b0 = b1 = cd = None
    if damping_modes is not None:
        md = np.stack([mass_scalar @ p for p in damping_modes.shapes])
        b0 = np.einsum("dia,kia->dk", md, phi)
        b1 = 2.0 * np.einsum("dia,mnia->ndm", md, g)  # B(s) = B0 + Σ_n s_n B1[n]
        cd = np.asarray(damping_modes.C, float)
    return ManifoldArrays(
        n_modes=n, O=np.ascontiguousarray(o.reshape(k, k * 9)),
        tr=np.ascontiguousarray(np.einsum("agbb->ag", o)),
        cr=np.ascontiguousarray(cross_part(o).reshape(k, k * 3)),
        pair_a=pairs[:, 0].copy(), pair_b=pairs[:, 1].copy(),
        C0=np.asarray(model.C, float), B0=b0, B1=b1, Cd=cd)  # fmt: skip


def monomials(ma: ManifoldArrays, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(z (K,), ∂z/∂s (N, K))`` at s (N,)."""
    n, a, b = ma.n_modes, ma.pair_a, ma.pair_b
    z = np.concatenate([[1.0], s, s[a] * s[b]])
    d = np.zeros((n, ma.size))
    d[np.arange(n), 1 + np.arange(n)] = 1.0
    cols = 1 + n + np.arange(len(a))
    np.add.at(d, (a, cols), s[b])
    np.add.at(d, (b, cols), s[a])
    return z, d


def mass_matrix(ma: ManifoldArrays, s: np.ndarray) -> np.ndarray:
    """𝕄(s) (3+N, 3+N): T = ½ νᵀ𝕄ν, ν = (ω, ṡ) (kg m², √kg·m, 1 blocks)."""
    k = ma.size
    z, d = monomials(ma, s)
    p = (z @ (z @ ma.O).reshape(k, 9)).reshape(3, 3)
    a = d @ (z @ ma.cr).reshape(k, 3)  # Σ M r × T_k (N, 3)
    j = np.trace(p) * np.eye(3) - p
    return np.block([[j, a.T], [a, d @ ma.tr @ d.T]])


def kinetic_gradient(ma: ManifoldArrays, s: np.ndarray, nu: np.ndarray) -> np.ndarray:
    """∂T/∂s (N,) at fixed ν = (ω, ṡ): ⟨v, ∂v/∂s_j⟩ with v = ω × r + u̇ and
    ∂v/∂s_j = ω × T_j + 2 Σ_n ṡ_n g^{jn}; through z, ⟨v, ω × Y_β⟩ = (A z + B ż)_β and
    ⟨v, Y_β⟩ = (Bᵀz + tr O ż)_β with A = |ω|² tr O − ωᵀOω, B = ω·(Σ M Y_α × Y_β)."""
    k, n = ma.size, ma.n_modes
    w, sd = nu[:3], nu[3:]
    z, d = monomials(ma, s)
    zd = d.T @ sd
    az = (w @ w) * (ma.tr @ z) - (ma.O.reshape(k * k, 9) @ np.outer(w, w).ravel()).reshape(k, k) @ z
    b = (ma.cr.reshape(k * k, 3) @ w).reshape(k, k)
    a_idx, b_idx = ma.pair_a, ma.pair_b
    cols = 1 + n + np.arange(len(a_idx))
    dzd = np.zeros((n, k))  # ∂ż/∂s_j
    np.add.at(dzd, (b_idx, cols), sd[a_idx])
    np.add.at(dzd, (a_idx, cols), sd[b_idx])
    return d @ (az + b @ zd) + dzd @ (b.T @ z + ma.tr @ zd)


def damping_matrix(ma: ManifoldArrays, s: np.ndarray) -> np.ndarray:
    """C(s) (N, N) 1/s: Bᵀ C_d B on the manifold velocity, or the constant C0."""
    if ma.B0 is None:
        return ma.C0
    b = ma.B0 + np.tensordot(s, ma.B1, 1)
    return b.T @ ma.Cd @ b


def manifold_system(model, arrays: ManifoldArrays):
    """The :class:`~quadmodes.rom.system.ReducedSystem` of formulation "QM": the model's Q4
    system (its potential; its Q kinetics serve the Newton matrix) carrying ``arrays``."""
    import dataclasses

    from quadmodes.rom.system import reduced_system

    return dataclasses.replace(reduced_system(model, "Q4"), formulation="QM", manifold=arrays)


def state_momenta(ma: ManifoldArrays, y: np.ndarray) -> np.ndarray:
    """𝕄(s)ν (..., 3+N) = (h, p) of states ``y = [q, ω, s, ṡ]`` (..., 7+2N)."""
    n = ma.n_modes
    rows = np.asarray(y, float).reshape(-1, y.shape[-1])
    nu = rows[:, np.r_[4:7, 7 + n : 7 + 2 * n]]
    out = np.array([mass_matrix(ma, r[7 : 7 + n]) @ v for r, v in zip(rows, nu, strict=True)])
    return out.reshape(*y.shape[:-1], 3 + n)


def state_dissipation(ma: ManifoldArrays, y: np.ndarray) -> np.ndarray:
    """ṡᵀC(s)ṡ (...) W of states ``y`` (..., 7+2N)."""
    n = ma.n_modes
    rows = np.asarray(y, float).reshape(-1, y.shape[-1])
    out = np.array([r[7 + n :] @ damping_matrix(ma, r[7 : 7 + n]) @ r[7 + n :] for r in rows])
    return out.reshape(y.shape[:-1])
