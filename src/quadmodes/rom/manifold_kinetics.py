"""The exact kinetic energy of the quadratic manifold and its Rayleigh damping: the arrays of
formulation "QM" (issue 29; the research prototype is
:mod:`quadmodes.experimental.manifold_lagrangian`, the derivation docs/path-validity.md
"A consistent fourth-order Lagrangian", the product's state docs/manifold-formulation.md).

The body-frame field of the manifold is r(s) = X + Φs + Σ_mn s_m s_n g^{mn} (n nodes, scalar
mass matrix M, the same for the three components). Its kinetic energy
T = ½ Σ M |ω × r + ṙ|² only needs the M-inner products of the node functions (one scalar field per
node for each component of X, Φ_k and g^{mn}). Written in an M-orthonormal basis Q (n, R) of
those node functions, each field becomes R coefficients and the body becomes **R unit-mass
pseudo-particles** at w_ρ(s) = X̃_ρ + Φ̃_ρ s + Σ s_m s_n g̃_ρ^{mn} ∈ R³ (ρ = 1..R)::

    T = ½ Σ_ρ |ω × w_ρ + E_ρ ṡ|²,   E_ρ(s) = ∂w_ρ/∂s = Φ̃_ρ + 2 Σ_n s_n g̃_ρ^{·n}   (3, N)

so J(s) = Σ_ρ (|w_ρ|² I − w_ρ w_ρᵀ), A_k(s) = Σ_ρ w_ρ × E_ρk, μ(s) = Σ_ρ E_ρᵀE_ρ, and every
evaluation costs one contraction E(s) of 3RN² products (the product form O_αβ of the prototype
costs 9K², K = 1 + N + N(N+1)/2). The basis: the node functions of X and Φ exactly (their
M-Gram's range, R₁ ≤ 3(N+1): Q's kinetics and everything linear in s are kept to round-off),
then the part of the g node functions M-orthogonal to them, truncated where the eigenvalues of
its Gram fall below ``tol`` times the largest (``tol = 0``: all of it, the exact manifold).
Truncating keeps an exact Lagrangian (the kinetic energy of the projected manifold), so the step
still conserves R h to round-off and is energy-bounded; the truncation's size is measured in
docs/manifold-formulation.md ("Pseudo-particles").

Damping: the Rayleigh function ½ u̇ᵀ (M Φ_d C_d Φ_dᵀ M) u̇ of modal damping (modes Φ_d, matrix
C_d) on the manifold velocity u̇ = Σ ṡ_k ∂r/∂s_k gives C(s) = B(s)ᵀ C_d B(s),
B(s) = Φ_dᵀM(Φ + 2 Σ_n s_n g^{·n}) = B0 + Σ_n s_n B1_n (affine in s); without damping modes
C(s) is the model's constant C.

The arrays are computed from the model's fields (X, Φ, G) and the structure's scalar mass matrix
(which the model file does not hold), once per model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Default truncation of the quadratic modes' node functions outside the span of X and Φ
#: (eigenvalues of their M-Gram below this fraction of the largest are dropped). On the coarse
#: 45° member (N = 16) 1e-2 keeps R = 51 + 30 particles and moves the kinetic terms by ≤ 4e-6
#: of the quadratic modes' own contribution at 3 × the path's amplitude (docs).
COMPLEMENT_TOL = 1e-2


@dataclass(frozen=True, eq=False)
class ManifoldArrays:
    """The constant arrays of the manifold kinetic energy and damping (module docstring).

    X (R, 3) √kg·m, Phi (R, 3, N) 1, G (R, 3, N, N) 1/(√kg·m) (symmetric in the last two): the
    pseudo-particles; n_linear: R₁, how many of them span X and Φ exactly; C0 (N, N) 1/s: the
    constant damping without damping modes; B0 (D, N), B1 (N, D, N) and Cd (D, D) 1/s: the
    damping on the manifold velocity (D damping modes; None without)."""

    n_modes: int
    X: np.ndarray
    Phi: np.ndarray
    G: np.ndarray
    n_linear: int
    C0: np.ndarray
    B0: np.ndarray | None = None
    B1: np.ndarray | None = None
    Cd: np.ndarray | None = None

    @property
    def rank(self) -> int:
        """R, the number of pseudo-particles."""
        return self.X.shape[0]

    @property
    def gram(self) -> np.ndarray:
        """ΦᵀMΦ (N, N), exact (Φ lies in the kept span)."""
        return np.einsum("rck,rcl->kl", self.Phi, self.Phi)


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


def _orthonormal(f: np.ndarray, mf: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """``(Q (n, r), MQ)``: an M-orthonormal basis of the node functions ``f`` (n, c) (``mf`` =
    M f) from the eigenvectors of their Gram above ``tol`` times the largest eigenvalue."""
    lam, u = np.linalg.eigh(f.T @ mf)
    keep = lam > max(tol, 1e-13) * lam[-1]
    scale = u[:, keep] / np.sqrt(lam[keep])
    return f @ scale, mf @ scale


def _node_functions(x, phi, g) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(linear (n, 3(N+1)), quadratic (n, 3P), pairs (P, 2))``: the node functions of X and
    Φ_k, and of g^{mn} (m ≤ n, P = N(N+1)/2), one column per field and component."""
    n_modes = phi.shape[0]
    pairs = [(a, b) for a in range(n_modes) for b in range(a, n_modes)]
    pairs = np.array(pairs, int).reshape(-1, 2)
    linear = np.concatenate([x, *phi], axis=1)
    quadratic = np.concatenate([g[a, b] for a, b in pairs], axis=1) if len(pairs) else x[:, :0]
    return linear, quadratic, pairs


def manifold_arrays(model, mass_scalar, damping_modes=None,
                    tol: float = COMPLEMENT_TOL) -> ManifoldArrays:  # fmt: skip
    """The :class:`ManifoldArrays` of a reduced ``model`` (fields X (n,3), Phi (N,n,3), G
    (N,N,n,3)) with the structure's scalar mass matrix ``mass_scalar`` (n, n) kg (sparse or
    dense), the truncation ``tol`` of the quadratic modes' complement (module docstring; 0: exact)
    and, optionally, ``damping_modes`` (:class:`ModalDamping` or the full order's
    :class:`~quadmodes.fullorder.damping.DampingModes`)."""
    n = int(model.n_modes)
    x, phi, g = (np.asarray(a, float) for a in (model.X, model.Phi, model.G))
    linear, quadratic, pairs = _node_functions(x, phi, g)
    q1, mq1 = _orthonormal(linear, np.asarray(mass_scalar @ linear), 0.0)
    rest = quadratic - q1 @ (mq1.T @ quadratic)
    rest -= q1 @ (mq1.T @ rest)  # twice is enough (Kahan): the complement to round-off
    basis = [mq1]
    if tol < 1.0 and rest.shape[1]:
        mrest = np.asarray(mass_scalar @ rest)
        basis.append(_orthonormal(rest, mrest, tol)[1])
    mq = np.concatenate(basis, axis=1)  # M Q (n, R)
    c_lin = (mq.T @ linear).reshape(-1, n + 1, 3)  # (R, 1+N, 3)
    c_quad = (mq.T @ quadratic).reshape(mq.shape[1], -1, 3)
    gp = np.zeros((mq.shape[1], 3, n, n))
    gp[:, :, pairs[:, 0], pairs[:, 1]] = c_quad.transpose(0, 2, 1)
    gp[:, :, pairs[:, 1], pairs[:, 0]] = c_quad.transpose(0, 2, 1)
    b0 = b1 = cd = None
    if damping_modes is not None:
        md = np.stack([mass_scalar @ p for p in damping_modes.shapes])
        b0 = np.einsum("dia,kia->dk", md, phi)
        b1 = 2.0 * np.einsum("dia,mnia->ndm", md, g)  # B(s) = B0 + Σ_n s_n B1[n]
        cd = np.asarray(damping_modes.C, float)
    return ManifoldArrays(
        n_modes=n, X=np.ascontiguousarray(c_lin[:, 0]),
        Phi=np.ascontiguousarray(c_lin[:, 1:].transpose(0, 2, 1)), G=np.ascontiguousarray(gp),
        n_linear=q1.shape[1], C0=np.asarray(model.C, float), B0=b0, B1=b1, Cd=cd)  # fmt: skip


def tangents(ma: ManifoldArrays, s: np.ndarray) -> np.ndarray:
    """E(s) = ∂w/∂s (R, 3, N) of the pseudo-particles at s (N,)."""
    return ma.Phi + 2.0 * (ma.G @ s)


def positions(ma: ManifoldArrays, s: np.ndarray, e: np.ndarray) -> np.ndarray:
    """w(s) (R, 3) from E = :func:`tangents` (ma, s): w = X̃ + ½(Φ̃ + E) s (exact: w is quadratic)."""
    return ma.X + 0.5 * ((ma.Phi + e) @ s)


def mass_matrix(ma: ManifoldArrays, s: np.ndarray) -> np.ndarray:
    """𝕄(s) (3+N, 3+N): T = ½ νᵀ𝕄ν, ν = (ω, ṡ) (kg m², √kg·m, 1 blocks)."""
    e = tangents(ma, s)
    w = positions(ma, s, e)
    j = np.sum(w * w) * np.eye(3) - w.T @ w
    a = np.cross(w[:, :, None], e, axis=1).sum(0).T  # Σ w × E_k (N, 3)
    e2 = e.reshape(-1, e.shape[-1])
    mu = e2.T @ e2  # Σ_ρ E_ρᵀE_ρ (a matrix product: einsum's loop was 40× slower)
    return np.block([[j, a.T], [a, mu]])


def kinetic_gradient(ma: ManifoldArrays, s: np.ndarray, nu: np.ndarray,
                     e: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
    """∂T/∂s (N,) at fixed ν = (ω, ṡ): Σ_ρ v_ρ · ∂v_ρ/∂s_j with v = ω × w + E ṡ and
    ∂v/∂s_j = ω × E_j + 2 Σ_n g̃^{jn} ṡ_n (``e``: E(s) when already known)."""
    w_rate, sd = nu[:3], nu[3:]
    e = tangents(ma, s) if e is None else e
    v = np.cross(w_rate, positions(ma, s, e)) + e @ sd
    dv = np.cross(w_rate[None, :, None], e, axis=1) + 2.0 * (ma.G @ sd)
    return np.einsum("rc,rcj->j", v, dv)


def kinetic_difference(ma: ManifoldArrays, sm: np.ndarray, ds: np.ndarray, nu0: np.ndarray,
                       nu1: np.ndarray, e: np.ndarray | None = None) -> float:  # fmt: skip
    """ν₀ᵀ(𝕄(s₁) − 𝕄(s₀))ν₁ (J) with s₀,₁ = sm ∓ ds/2, without cancellation: through the
    particles' differences, exact because w is quadratic and E linear in s:
    Δw = E(sm) Δs, ΔE = 2 g̃ Δs, w̄ = w(sm) + ¼ Δsᵀg̃Δs, Ē = E(sm), and for v(ν) = ω × w + E ṡ
    the product rule v₁(ν₀)·v₁(ν₁) − v₀(ν₀)·v₀(ν₁) = Δv(ν₀)·v̄(ν₁) + v̄(ν₀)·Δv(ν₁) (``e``:
    E(sm) when already known)."""
    e = tangents(ma, sm) if e is None else e
    de = 2.0 * (ma.G @ ds)
    dw = e @ ds
    w_bar = positions(ma, sm, e) + 0.125 * (de @ ds)

    def parts(nu):
        return (np.cross(nu[:3], dw) + de @ nu[3:], np.cross(nu[:3], w_bar) + e @ nu[3:])

    (d0, b0), (d1, b1) = parts(nu0), parts(nu1)
    return float(np.sum(d0 * b1) + np.sum(b0 * d1))


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
