"""Rotating-frame linearisation of the reduced modal equation about steady rotation (s = 0)::

    μ s̈ + (Γ + C) ṡ + (Λ − ωᵀJ2ω) s = ½ ωᵀJ1ω,     Γ_km = ω·(D_mk − D_km)

its matrices, the positivity of its stiffness (stable spin) and its eigenvalues (the
rotating-frame, Campbell, frequencies). The arrays are those of :mod:`quadmodes.rom.system`;
ω in rad/s, frequencies in 1/s.
"""

from __future__ import annotations

import numpy as np

from quadmodes.rom.system import ReducedSystem, reduced_system


def _as_system(model, formulation: str) -> ReducedSystem:
    """``model`` itself if a ReducedSystem, else its system for ``formulation``."""
    if isinstance(model, ReducedSystem):
        return model
    return reduced_system(model, formulation)


def rotating_frame_matrices(model, omega_vec, formulation: str = "Q"):
    """Linearised modal equation about steady rotation ω (3,) rad/s and s = 0::

        μ s̈ + (Γ + C) ṡ + (Λ − ωᵀJ2ω) s = ½ ωᵀJ1ω      (constant forcing not returned)

    Returns ``(μ, Γ + C, Λ − ωᵀJ2ω)``, each (N,N); Γ_km = ω·(D_mk − D_km) is antisymmetric
    (gyroscopic), the stiffness symmetric. ``model``: ReducedModel or ReducedSystem. For "L" the
    spin stiffening (J2g) is absent, so the stiffness softens as Λ − ωᵀJ2uω."""
    sys = _as_system(model, formulation)
    n = sys.n_modes
    w = np.asarray(omega_vec, float)
    gam = -(sys.flat.Dsk @ w).reshape(n, n)
    k = sys.Lam - (sys.flat.J2w @ np.outer(w, w).ravel()).reshape(n, n)
    return sys.mu.copy(), gam + sys.C, 0.5 * (k + k.T)


def rotating_stiffness_is_positive(model, omega_vec, formulation: str = "Q") -> bool:
    """True if the rotating-frame stiffness Λ − ωᵀJ2ω is positive definite (stable spin)."""
    k = rotating_frame_matrices(model, omega_vec, formulation)[2]
    return bool(k.shape[0] == 0 or np.linalg.eigvalsh(k).min() > 0.0)


def rotating_eigenvalues(model, omega_vec, formulation: str = "Q", damped: bool = False):
    """Eigenvalues λ (2N,) 1/s of the rotating-frame quadratic problem
    ``(λ²μ + λ(Γ + C) + K) φ = 0`` (C included if ``damped``), sorted by |Im λ| then Re λ.
    Undamped, positive-definite K: λ = ±iω_r, the rotating-frame (Campbell) frequencies."""
    m, g, k = rotating_frame_matrices(model, omega_vec, formulation)
    if not damped:
        sys = _as_system(model, formulation)
        g = g - sys.C
    n = m.shape[0]
    minv = np.linalg.inv(m)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ k, -minv @ g]])
    lam = np.linalg.eigvals(a)
    return lam[np.lexsort((lam.real, np.abs(lam.imag)))]
