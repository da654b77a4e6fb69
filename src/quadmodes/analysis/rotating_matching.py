"""Identification of full-order rotating-frame roots (:mod:`quadmodes.analysis.rotating_modes`)
with reduced-model branches (:mod:`quadmodes.analysis.campbell`): both are reduced to
energy-weighted vectors ``(Lᵀδω, Λ^{1/2} δs, λ δs)`` — kinetic energy of rotation, strain and
kinetic energy of the retained modes — compared by MAC and assigned optimally
(:func:`match_branches`)."""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from quadmodes.analysis.rotating_modes import RotatingRoots
from quadmodes.fe.model import Structure, mass_matrix, rigid_body_modes
from quadmodes.rotations import unit_axis


def rotation_and_modal_parts(
    structure: Structure, x: np.ndarray, phi: np.ndarray, shapes: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Best-fit (mass-weighted) rigid rotation θ (k, 3) about the centre of mass of ``x`` and the
    modal coordinates ``a = Φᵀ M (q − Ψθ)`` (k, N) (√kg·m per unit q) of full-order shapes
    (k, n, 3); ``phi`` (N, n, 3) the retained (mass-normalised) modes. θ is zero for a clamped
    body."""
    m = mass_matrix(structure)
    q = shapes.reshape(shapes.shape[0], -1).T  # (3n, k)
    if structure.is_free:
        psi = rigid_body_modes(structure, x)
        mpsi = m @ psi
        coef = np.linalg.solve(psi.T @ mpsi, mpsi.T @ q)
        theta = coef[3:]
        q = q - psi[:, 3:] @ theta
    else:
        theta = np.zeros((3, q.shape[1]), complex)
    a = phi.reshape(phi.shape[0], -1) @ (m @ q)
    return theta.T, a.T


def comparison_vectors(
    lam: np.ndarray, delta_omega: np.ndarray, ds: np.ndarray, inertia: np.ndarray, lam_modes
) -> np.ndarray:
    """Energy-weighted vectors (k, 3 + 2N) ``(Lᵀδω, Λ^{1/2} δs, λ δs)`` used for the MAC between
    full-order and reduced roots (``inertia`` = L Lᵀ (3, 3) kg m², ``lam_modes`` (N,) ω_k² 1/s²):
    kinetic energy of rotation, strain and kinetic energy of the retained modes."""
    chol = np.linalg.cholesky(0.5 * (inertia + inertia.T))
    return np.concatenate(
        [delta_omega @ chol, ds * np.sqrt(np.maximum(lam_modes, 0.0)), lam[:, None] * ds], axis=1
    )


def full_order_comparison_vectors(
    structure: Structure, x: np.ndarray, roots: RotatingRoots, model, axis
) -> tuple[np.ndarray, np.ndarray]:
    """Comparison vectors (k, 3 + 2N) of full-order roots, and the share of each root's kinetic
    energy that the reduced coordinates (δω, s) capture (k,).

    The frame of the reduced model turns with the body (mean axes), so a best-fit rotation θ of
    the full-order shape appears there as ``δω = (λ + Ω[e]×) θ`` (linearised ``ω = Rᵀ(Ωe) + θ̇``)."""
    theta, a = rotation_and_modal_parts(structure, x, model.Phi, roots.shapes)
    e = unit_axis(axis)
    dw = roots.lam[:, None] * theta + roots.spin * np.cross(e, theta)
    vec = comparison_vectors(roots.lam, dw, a, model.J0, np.diag(model.Lam))
    # kinetic energy captured: |λ|²(θᵀJθ + |a|²) against |λ|² qᴴMq = |λ|² (mass-normalised q)
    jt = np.einsum("ka,ab,kb->k", theta.conj(), model.J0, theta).real
    captured = (jt + np.sum(np.abs(a) ** 2, axis=1)).real
    return vec, captured


#: Largest share of a full-order root's kinetic energy the reduced coordinates may capture. The
#: share is a mass-weighted projection, ≤ 1 when the reduced model's inertia J0 and modes are
#: the full order's; the margin covers their difference between the reduced model's reference
#: and the spinning state (measured: at most 1.006, the paper membrane at 41 Hz about its state at rest).
CAPTURE_LIMIT = 1.05


class CaptureError(ValueError):
    """A full-order root carries more kinetic energy in the reduced coordinates than in itself:
    the reduced model's rigid body or modes are not the full order's."""


def check_capture(captured: np.ndarray, frequency_hz: np.ndarray, spin_hz: float) -> None:
    """Raise :class:`CaptureError` if a root's captured share (k,) exceeds
    :data:`CAPTURE_LIMIT` (``frequency_hz`` (k,) its rotating-frame frequencies, Hz)."""
    bad = np.flatnonzero(np.asarray(captured) > CAPTURE_LIMIT)
    if bad.size:
        j = int(bad[np.argmax(np.asarray(captured)[bad])])
        raise CaptureError(
            f"capture check failed at {spin_hz:g} Hz: the full-order root at "
            f"{frequency_hz[j]:.4g} Hz has {captured[j]:.4g} times its kinetic energy in the "
            f"reduced coordinates (must be ≤ 1): the reduced model's rigid body or modes are not "
            "the full order's (a hub too soft for its booms: raise [hub] rigidity; or a model "
            "of another case)"
        )


def mac_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """MAC matrix (ka, kb) of the rows of ``a`` and ``b`` (Euclidean inner product)."""
    cross = a.conj() @ b.T
    na = np.sum(np.abs(a) ** 2, axis=1)
    nb = np.sum(np.abs(b) ** 2, axis=1)
    return np.abs(cross) ** 2 / np.maximum(np.outer(na, nb), 1e-300)


def match_branches(
    rom_vectors: np.ndarray,
    rom_lam: np.ndarray,
    full_vectors: np.ndarray,
    full_lam: np.ndarray,
    eligible: np.ndarray,
    captured: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Optimal assignment of reduced-model roots (nb) to eligible full-order roots by MAC of the
    comparison vectors, with a small frequency-distance tie-break. Returns ``(index (nb,) into the
    full-order roots, or −1; MAC (nb,))``. ``captured`` (k,): the share of each full-order root's
    kinetic energy in the reduced coordinates; its MAC counts only in that proportion in the
    assignment (a root outside the basis has a near-zero comparison vector whose MAC is
    round-off, e.g. a mode above the retained ones next to an exactly degenerate pair)."""
    idx = np.flatnonzero(eligible)
    nb = rom_vectors.shape[0]
    out, macs = np.full(nb, -1), np.zeros(nb)
    if idx.size == 0:
        return out, macs
    mac = mac_matrix(rom_vectors, full_vectors[idx])
    scale = max(float(np.abs(rom_lam).max(initial=1.0)), 1.0)
    dist = np.abs(rom_lam[:, None] - full_lam[idx][None, :]) / scale
    weight = 1.0 if captured is None else np.clip(captured[idx], 0.0, 1.0)[None, :]
    rows, cols = linear_sum_assignment(-(mac * weight - 0.1 * dist))
    out[rows] = idx[cols]
    macs[rows] = mac[rows, cols]
    return out, macs
