"""A reduced model of the wrinkling structure: the quadratic-mode chart augmented with snapshot
coordinates that carry mass, and the exact FE potential on it.

Condensing the wrinkled hinge as massless unknowns (:mod:`quadmodes.rom.condensed_potential`)
is not enough on the paper membrane: the condensed displacement ``y`` at 0.5–1 in of bending
moves the heavy front end body, ``‖y‖²_M / ‖s‖² ≈ 0.18–0.20`` (measured on
paper-membrane-coarse-tf), so a fifth of the kinetic energy of the motion would be left out.
Here the snapshot directions are generalised coordinates of their own::

    x(s, q) = x0 + Φs + Σ_mn s_m s_n g^{mn} + B q,      z = (s, q)  (N + p)

with ``B`` ``(m, p)`` the M-orthonormal POD of the FE model's condensed minimisers ``W_c`` at
training points, M-orthogonal to the retained and rigid modes (so the mean-axis frame of the
reduced model is kept). The kinetic integrals are those of the quadratic modes
(:func:`quadmodes.rom.reduced.reduce`) with ``B`` as further linear shapes whose quadratic modes
are zero; the potential is the exact FE total potential ``Π̃(x(z))`` (strain energy with the
tension-field law, pressure, ties), split as ``½ zᵀH0 z`` (``Λ`` of the model) plus the
nonlinear part a :class:`~quadmodes.rom.system.ReducedSystem` takes as its
``nonlinear_potential`` (:class:`ExactPotential`). Bounded below wherever Π is; a Galerkin
model of the FE structure on the chart, so every conservation law of the midpoint holds.
Damping: modal, ζ on every mode of ``(H0, μ)`` below a cutoff, as the full order's
independent damping does on the FE modes.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.linalg as sla

from quadmodes.rom import manifold_energy as me
from quadmodes.rom.condensed_potential import manifold_jacobian
from quadmodes.rom.manifold_energy import EnergyContext
from quadmodes.rom.reduced import ReducedModel, cross_form, inertia_form, mass_product


def pod_of_minimisers(ctx: EnergyContext, snapshots: np.ndarray, tol: float = 1e-6,
                      max_vectors: int = 20) -> tuple[np.ndarray, float]:  # fmt: skip
    """``(B, captured)``: the M-orthonormal POD ``(m, p)`` of snapshot displacements ``(k, m)``
    (m) after their M-projection on ``[Φ Ψ]`` is removed; the fewest vectors whose discarded
    eigenvalues sum to at most ``tol`` of the total, at most ``max_vectors``."""
    mass, basis = ctx.mass, ctx.basis
    y = np.asarray(snapshots, float).T
    y = y - basis @ np.linalg.solve(basis.T @ (mass @ basis), basis.T @ (mass @ y))
    lam, vec = np.linalg.eigh(y.T @ (mass @ y))
    lam, vec = np.maximum(lam[::-1], 0.0), vec[:, ::-1]
    tail = lam.sum() - np.cumsum(lam)
    p = min(int(np.argmax(tail <= tol * lam.sum())) + 1, int(max_vectors),
            int(np.sum(lam > 1e-12 * lam[0])))  # fmt: skip
    modes = y @ (vec[:, :p] / np.sqrt(lam[:p]))
    modes = modes - basis @ np.linalg.solve(basis.T @ (mass @ basis), basis.T @ (mass @ modes))
    return me.m_orthonormal(mass, modes), float(lam[:p].sum() / lam.sum())


class ExactPotential:
    """``N(z) = Π̃(x(z)) − ½ zᵀH0 z`` (J) on the augmented chart ``z = (s, q)`` of ``ctx`` (the
    reduced model's quadratic modes) and ``basis`` B ``(m, p)``; ``H0`` ``(N+p, N+p)`` the
    Hessian of ``Π̃(x(z))`` at z = 0 (:meth:`hessian`).

    Cache (the only state): the FE evaluation (energy, force, tangent) at the last z, which
    energy, force and Hessian at the same z share."""

    def __init__(self, ctx: EnergyContext, basis: np.ndarray):
        self.ctx, self.basis = ctx, np.asarray(basis, float)
        self.n = ctx.phi.shape[0]
        self._z = None
        self._h0 = None
        self.h0 = self.hessian(np.zeros(self.n + self.basis.shape[1]))
        self._h0 = self.h0

    def _at(self, z: np.ndarray) -> dict:
        z = np.asarray(z, float)
        if self._z is None or not np.array_equal(z, self._z["z"]):
            s, q = z[: self.n], z[self.n :]
            u = me.manifold_displacement(self.ctx, s) + self.basis @ q
            self._z = {"z": z.copy(), "u": u, "s": s}
        return self._z

    def energy(self, z: np.ndarray) -> float:
        """``Π̃(x(z))`` (J)."""
        c = self._at(z)
        if "e" not in c:
            c["e"] = me.total_potential(self.ctx, c["u"])
        return c["e"]

    def _force(self, c: dict) -> np.ndarray:
        if "f" not in c:
            c["f"] = me.potential_force(self.ctx, c["u"])
        return c["f"]

    def _jacobian(self, c: dict) -> np.ndarray:
        """``∂x/∂z`` ``(m, N+p)``."""
        if "j" not in c:
            c["j"] = np.hstack([manifold_jacobian(self.ctx, c["s"]), self.basis])
        return c["j"]

    def gradient(self, z: np.ndarray) -> np.ndarray:
        """``∂Π̃/∂z = (∂x/∂z)ᵀ ∇Π̃`` (N+p,)."""
        c = self._at(z)
        return self._jacobian(c).T @ self._force(c)

    def hessian(self, z: np.ndarray) -> np.ndarray:
        """``∂²Π̃/∂z²`` (N+p, N+p): ``JᵀK̂J`` plus ``∇Π̃·(g^{kl} + g^{lk})`` in the s block (K̂
        the tangent with its rank-one terms; one-sided where a tension-field element changes
        state)."""
        c = self._at(z)
        jac = self._jacobian(c)
        k, low = me._tangent(self.ctx, c["u"])
        h = jac.T @ (k @ jac)
        for coef, v in low:
            jv = jac.T @ v
            h += coef * np.outer(jv, jv)
        g2 = self.ctx.g + np.swapaxes(self.ctx.g, 0, 1)
        h[: self.n, : self.n] += np.einsum("kli,i->kl", g2, self._force(c))
        return 0.5 * (h + h.T)

    def nonlinear_energy(self, z: np.ndarray) -> float:
        z = np.asarray(z, float)
        return self.energy(z) - 0.5 * float(z @ self.h0 @ z)

    def nonlinear_force(self, z: np.ndarray) -> np.ndarray:
        return self.gradient(z) - self.h0 @ np.asarray(z, float)

    def nonlinear_hessian(self, z: np.ndarray) -> np.ndarray:
        return self.hessian(z) - self.h0


def modal_damping(stiffness: np.ndarray, mass: np.ndarray, zeta: float, cutoff_hz: float):
    """``C = μ V diag(2ζω) Vᵀ μ`` (1/s) on the eigenpairs ``(ω², V)`` of ``(stiffness, mass)``
    with ω/2π below ``cutoff_hz`` (V μ-normalised), and the frequencies (Hz) of the pencil."""
    w2, v = sla.eigh(0.5 * (stiffness + stiffness.T), 0.5 * (mass + mass.T))
    w = np.sqrt(np.maximum(w2, 0.0))
    keep = w < 2.0 * np.pi * cutoff_hz
    mv = mass @ v[:, keep]
    return mv @ np.diag(2.0 * zeta * w[keep]) @ mv.T, w / (2.0 * np.pi)


def augmented_model(model: ReducedModel, structure, basis: np.ndarray, lam: np.ndarray,
                    zeta: float, cutoff_hz: float) -> ReducedModel:  # fmt: skip
    """``model`` with the columns of ``basis`` ``(m, p)`` as further coordinates: kinetic
    integrals of the shapes ``[Φ; B]`` with quadratic modes ``[[g, 0], [0, 0]]``, ``Λ = lam``
    ``(N+p, N+p)`` (e.g. :attr:`ExactPotential.h0`), modal damping ``zeta`` below
    ``cutoff_hz`` (:func:`modal_damping`); F1 padded with zeros, no Q4 tensors."""
    n, p = model.n_modes, basis.shape[1]
    nodes = model.X.shape[0]
    extra = basis.T.reshape(p, nodes, 3)
    shapes = np.concatenate([np.asarray(model.Phi, float), extra])
    g = np.zeros((n + p, n + p, nodes, 3))
    g[:n, :n] = model.G
    ms = structure.mass_scalar
    xr = np.asarray(model.X, float)
    p_x_u = np.swapaxes(mass_product(ms, shapes, xr), -1, -2)
    p_uu = np.einsum("mia,nib->mnab", shapes, np.stack([ms @ s for s in shapes]))
    p_xg = np.swapaxes(mass_product(ms, g, xr), -1, -2)
    flat = shapes.reshape(n + p, -1).T
    mu = flat.T @ (me.mass_matrix(structure) @ flat)
    damping, _ = modal_damping(lam, mu, zeta, cutoff_hz)
    w = np.asarray(model.weights, float)
    own = np.sqrt(np.maximum(np.diag(lam)[n:] / np.diag(mu)[n:], 0.0)) / (2.0 * np.pi)
    return dataclasses.replace(
        model, frequencies_hz=np.concatenate([np.asarray(model.frequencies_hz, float), own]), damping_ratio=np.full(n + p, zeta),
        labels=tuple(model.labels) + tuple(f"snapshot {k + 1}" for k in range(p)),
        J1=2.0 * inertia_form(p_x_u), J2u=inertia_form(p_uu), J2g=2.0 * inertia_form(p_xg),
        c=cross_form(p_x_u), Cuu=cross_form(p_uu), Cxg=cross_form(p_xg),
        S1=np.einsum("i,kia->ka", w, shapes), S2=np.einsum("i,mnia->mna", w, g), mu=mu,
        Lam=np.asarray(lam, float), C=damping, Phi=shapes, G=g, V3=None, V4=None,
        manifold_potential=False, F1=np.concatenate([np.asarray(model.F1, float), np.zeros(p)]),
    )  # fmt: skip


def augmented_context(ctx: EnergyContext, dynamic: np.ndarray) -> EnergyContext:
    """``ctx`` with the columns of ``dynamic`` ``(m, p)`` as further linear coordinates of the
    chart (their quadratic modes zero): ``x(z) = x0 + Φs + Σ ss g + B_d q`` for z = (s, q), and
    ``[Φ B_d Ψ]`` as the directions a condensed correction must be M-orthogonal to."""
    n, p = ctx.phi.shape[0], dynamic.shape[1]
    g = np.zeros((n + p, n + p, ctx.g.shape[2]))
    g[:n, :n] = ctx.g
    n_rigid = ctx.basis.shape[1] - n
    basis = np.hstack([ctx.phi.T, dynamic, ctx.basis[:, n : n + n_rigid]])
    return dataclasses.replace(ctx, phi=np.vstack([ctx.phi, dynamic.T]), g=g, basis=basis)


def split_basis(mass, full: np.ndarray, dynamic: np.ndarray) -> np.ndarray:
    """An M-orthonormal basis of ``full``'s span with ``dynamic``'s span M-projected out."""
    rest = full - dynamic @ (dynamic.T @ (mass @ full))
    return me.m_orthonormal(mass, rest, rtol=1e-8)
