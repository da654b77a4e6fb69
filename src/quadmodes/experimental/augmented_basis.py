"""A reduced model of the wrinkling structure: the quadratic-mode chart augmented with snapshot
coordinates that carry mass, and the exact FE potential on it.

Condensing the wrinkled hinge as massless unknowns
(:mod:`quadmodes.experimental.condensed_potential`) is not enough on the paper membrane: the
condensed displacement ``y`` at 0.5–1 in of bending moves the heavy front end body, ``‖y‖²_M /
‖s‖² ≈ 0.18–0.20`` (measured on paper-membrane-coarse-tf), so a fifth of the kinetic energy of
the motion would be left out. Here the snapshot directions are generalised coordinates of their
own::

    x(s, q) = x0 + Φs + Σ_mn s_m s_n g^{mn} + B q,      z = (s, q)  (N + p)

with ``B`` ``(m, p)`` the M-orthonormal POD of the FE model's condensed minimisers ``W_c`` at
training points, M-orthogonal to the retained and rigid modes (so the mean-axis frame of the
reduced model is kept). The kinetic integrals are those of the quadratic modes
(:func:`quadmodes.rom.reduced.reduce`) with ``B`` as further linear shapes whose quadratic modes
are zero; the potential is the exact FE total potential ``Π̃(x(z))`` (strain energy with the
tension-field law, pressure, ties), condensed over the remaining snapshot directions
(:func:`augmented_context` with
:class:`~quadmodes.experimental.condensed_potential.CondensedPotential`; with every snapshot
direction dynamic the coordinates reach 68 kHz at the taut state and the midpoint's Newton
fails, so only the leading POD vectors, which carry the mass, are dynamic). Damping: modal, ζ on
every mode of ``(H0, μ)`` below a cutoff, as the full order's independent damping does on the FE
modes.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.linalg as sla

from quadmodes.rom import manifold_energy as me
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
    ``(N+p, N+p)`` (e.g. the condensed potential's ``hessian0``), modal damping ``zeta`` below
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
