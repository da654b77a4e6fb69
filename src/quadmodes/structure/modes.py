"""Modal stage: free-free (or clamped) eigenmodes of the prestressed structure.

Sparse shift-invert Lanczos (``eigsh``) on ``K φ = ω² M φ`` with ``K`` the full tangent (material +
geometric + pressure load stiffness) at the prestressed equilibrium. For a free body the six
rigid-body modes are identified by their mass-weighted overlap with the exact rigid motions and
reported separately; elastic modes are M-orthogonalised against the rigid motions (so the centre of
mass and mean-axis conditions hold to round-off), mass-normalised, and degenerate sets are kept
whole.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from quadmodes.fe.model import (
    Structure,
    mass_matrix,
    rigid_body_modes,
    tangent_low_rank,
    tangent_stiffness,
)
from quadmodes.structure.bordered import bordered_solver


@dataclass(frozen=True)
class ModalResult:
    """Eigen-solution about state ``x``.

    frequencies_hz: ``(N,)`` elastic natural frequencies, ascending.
    shapes: ``(N, n, 3)`` mass-normalised elastic modes (``φᵀ M φ = 1``, 1/√kg).
    rigid_frequencies_hz: ``(6,)`` signed ``sign(λ)√|λ|/2π`` of the rigid-body modes (0 for a clamped
    body). rigid_overlap: ``(N,)`` largest mass-weighted rigid fraction left in each elastic mode
    before projection (a quality check).
    """

    frequencies_hz: np.ndarray
    shapes: np.ndarray
    rigid_frequencies_hz: np.ndarray
    rigid_overlap: np.ndarray

    @property
    def omega(self) -> np.ndarray:
        """Circular frequencies (rad/s)."""
        return 2.0 * np.pi * self.frequencies_hz


def rigid_projector_basis(
    structure: Structure, x: np.ndarray, mass: sp.spmatrix | None = None
) -> np.ndarray:
    """M-orthonormal rigid-body basis ``(3n, r)``; ``r < 6`` when a rigid motion carries no mass
    (e.g. spin of a line beam about its own axis). mass: ``mass_matrix(structure)`` if known."""
    psi = rigid_body_modes(structure, x)
    m = mass_matrix(structure) if mass is None else mass
    gram = psi.T @ (m @ psi)
    lam, vec = sla.eigh(gram)
    keep = lam > 1e-10 * lam.max()
    return psi @ (vec[:, keep] / np.sqrt(lam[keep]))


def remove_rigid_part(
    structure: Structure, x: np.ndarray, vectors: np.ndarray, mass: sp.spmatrix | None = None
) -> np.ndarray:
    """``v − Ψ (ΨᵀMΨ)⁻¹ ΨᵀM v`` for columns of ``vectors`` ``(3n, k)``."""
    m = mass_matrix(structure) if mass is None else mass
    q = rigid_projector_basis(structure, x, m)
    return vectors - q @ (q.T @ (m @ vectors))


def compute_modes(
    structure: Structure,
    x: np.ndarray,
    count: int,
    degeneracy_rtol: float = 2e-3,
    shift_hz: float | None = None,
    softening: sp.spmatrix | None = None,
) -> ModalResult:
    """Lowest ``count`` elastic modes about state ``x`` (plus partners of a split degenerate set).

    ``shift_hz``: shift-invert point (negative shift ``−(2π f)²``); default 1 % of a crude estimate
    is not needed: a shift of −(2π·1 Hz)² keeps ``K − σM`` non-singular for a free body.
    ``softening`` (3n, 3n) N/m: a symmetric matrix subtracted from the tangent, e.g. the
    centrifugal softening ``Ω² M P̂`` of :func:`quadmodes.structure.spinning.centrifugal_softening`
    for the modes of a spinning state. Rigid motions are then no longer eigenvectors (the
    transverse ones meet the centrifugal load), so a free body's eigenproblem is solved on the
    subspace ``Ψᵀ M φ = 0`` (bordered shift-invert) and no rigid modes are reported.
    """
    if softening is not None:
        return _constrained_modes(structure, x, count, degeneracy_rtol, shift_hz, softening)
    free = structure.free_dofs
    mfull = mass_matrix(structure)
    q = rigid_projector_basis(structure, x, mfull) if structure.is_free else None
    n_rigid = q.shape[1] if structure.is_free else 0
    k = tangent_stiffness(structure, x)[free][:, free]
    m = mfull[free][:, free]
    sigma = -((2.0 * np.pi * (shift_hz if shift_hz is not None else 1.0)) ** 2)
    low_rank = [(c, v[free]) for c, v in tangent_low_rank(structure, x)]
    solve = bordered_solver((k - sigma * m).tocsr(), None, low_rank, free // 3)
    op_inv = spla.LinearOperator(k.shape, matvec=solve, dtype=float)
    n_total = k.shape[0]
    n_request = min(count + n_rigid + 4, n_total - 1)
    k_op = k
    if low_rank:

        def k_mat(v):
            out = k @ v
            for c, w in low_rank:
                out = out + c * w * (w @ v)
            return out

        k_op = spla.LinearOperator(k.shape, matvec=k_mat, dtype=float)
    lam, vec = spla.eigsh(k_op, k=n_request, M=m, sigma=sigma, which="LM", OPinv=op_inv, tol=1e-12,
                          v0=_start_vector(n_total))  # fmt: skip
    order = np.argsort(lam)
    lam, vec = lam[order], vec[:, order]
    full = np.zeros((3 * structure.n, vec.shape[1]))
    full[free] = vec
    if n_rigid:
        overlap = np.sum((q.T @ (mfull @ full)) ** 2, axis=0) / np.einsum(
            "ik,ik->k", full, mfull @ full
        )
        rigid_idx = np.sort(np.argsort(-overlap)[:n_rigid])
        elastic_idx = np.setdiff1d(np.arange(len(lam)), rigid_idx)
        rigid_lam = lam[rigid_idx]
        elastic = full[:, elastic_idx]
        elastic = elastic - q @ (q.T @ (mfull @ elastic))
        overlap_e = overlap[elastic_idx]
        lam_e = lam[elastic_idx]
    else:
        rigid_lam = np.zeros(0)
        elastic, lam_e, overlap_e = full, lam, np.zeros(len(lam))
    return _modal_result(structure, elastic, lam_e, rigid_lam, overlap_e, count, degeneracy_rtol,
                         mfull)  # fmt: skip


def _start_vector(size: int) -> np.ndarray:
    """A fixed pseudo-random Lanczos start ``(size,)``: the same eigenpairs on every run (ARPACK's
    own random start makes two runs differ at its tolerance, ~1e-9 relative)."""
    return np.random.default_rng(20261202).standard_normal(size)


def _modal_result(structure, elastic, lam_e, rigid_lam, overlap_e, count, degeneracy_rtol,
                  mfull=None):  # fmt: skip
    """:class:`ModalResult` of the ascending eigenpairs ``(lam_e (k,) 1/s², elastic (3n, k))``:
    the lowest ``count`` plus the degenerate partners of the last one, mass-normalised."""
    n_keep = min(count, len(lam_e))
    while n_keep < len(lam_e) and abs(
        lam_e[n_keep] - lam_e[n_keep - 1]
    ) <= 2 * degeneracy_rtol * abs(lam_e[n_keep - 1]):
        n_keep += 1
    elastic, lam_e, overlap_e = elastic[:, :n_keep], lam_e[:n_keep], overlap_e[:n_keep]
    mfull = mass_matrix(structure) if mfull is None else mfull
    norms = np.sqrt(np.einsum("ik,ik->k", elastic, mfull @ elastic))
    elastic = elastic / norms
    freqs = np.sign(lam_e) * np.sqrt(np.abs(lam_e)) / (2.0 * np.pi)
    rigid_f = np.sign(rigid_lam) * np.sqrt(np.abs(rigid_lam)) / (2.0 * np.pi)
    return ModalResult(
        frequencies_hz=freqs,
        shapes=elastic.T.reshape(n_keep, structure.n, 3),
        rigid_frequencies_hz=rigid_f,
        rigid_overlap=overlap_e,
    )


def _constrained_modes(structure, x, count, degeneracy_rtol, shift_hz, softening) -> ModalResult:
    """Modes of ``K_T(x) − softening`` with a free body's frame conditions ``Ψᵀ M φ = 0`` imposed
    in the shift-invert operator (its null space is then the rigid motions, whose eigenvalues
    move to infinity and are never returned)."""
    free = structure.free_dofs
    k = (tangent_stiffness(structure, x) - softening).tocsr()[free][:, free]
    m = mass_matrix(structure)[free][:, free]
    sigma = -((2.0 * np.pi * (shift_hz if shift_hz is not None else 1.0)) ** 2)
    low_rank = [(c, v[free]) for c, v in tangent_low_rank(structure, x)]
    constraint = None
    if structure.is_free:
        constraint = (mass_matrix(structure) @ rigid_projector_basis(structure, x))[free]
    solve = bordered_solver((k - sigma * m).tocsr(), constraint, low_rank, free // 3)
    op_inv = spla.LinearOperator(k.shape, matvec=solve, dtype=float)
    n_request = min(count + 4, k.shape[0] - 1)
    lam, vec = spla.eigsh(k, k=n_request, M=m, sigma=sigma, which="LM", OPinv=op_inv, tol=1e-12,
                          v0=_start_vector(k.shape[0]))  # fmt: skip
    order = np.argsort(lam)
    full = np.zeros((3 * structure.n, len(lam)))
    full[free] = vec[:, order]
    if structure.is_free:  # the frame conditions to round-off
        full = remove_rigid_part(structure, x, full)
    return _modal_result(structure, full, lam[order], np.zeros(0), np.zeros(len(lam)), count,
                         degeneracy_rtol)  # fmt: skip
