"""Tension-field (wrinkling) relaxation of the St Venant–Kirchhoff plane-stress membrane law.

A membrane has no bending stiffness: it cannot carry compression, it wrinkles. Tension-field
theory (Stein & Hedgepeth, NASA TR R-309, 1961; the relaxed energy of Pipkin 1986) replaces
the strain energy density by its relaxation, with the principal Green strains ``ε₁ ≥ ε₂`` of
the 2×2 strain tensor ``E``:

* **taut** (both principal stresses positive, ``ε₂ > −ν ε₁``): ``W = ½ E:D:E`` (SVK);
* **wrinkled** (``ε₁ > 0``, ``ε₂ ≤ −ν ε₁``): uniaxial tension along the major principal
  direction ``n₁``, ``W = ½ Y ε₁²``, ``S = Y ε₁ n₁⊗n₁`` (the wrinkles take up the
  contraction, so the minor principal stress is zero);
* **slack** (``ε₁ ≤ 0``): ``W = 0``, ``S = 0``.

The relaxed energy is C¹ (W and S are continuous across the three states), convex in the
compressed region, and equal to SVK wherever the membrane is taut — so every Taylor
coefficient about a taut reference state (modes, quadratic modes, Q4) is unchanged. The
tangent is discontinuous across the state boundaries.

All functions act on arrays of strain tensors ``(ne, 2, 2)`` in the element's orthonormal
reference frame; stresses are 2nd Piola–Kirchhoff (Pa), tangents Voigt ``(ne, 3, 3)`` on
``[E11, E22, 2E12]`` like :func:`quadmodes.fe.membrane.plane_stress_matrix`.
"""

from __future__ import annotations

import numpy as np

#: Strain-space denominator below which the discrete-gradient correction is skipped.
_DG_TINY = 1e-300


def principal_strains(strain: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(ε₁, ε₂, n₁, n₂)``: principal strains ``(ne,)`` with ``ε₁ ≥ ε₂`` and their unit
    directions ``(ne, 2)`` in the element frame."""
    a, b, c = strain[:, 0, 0], strain[:, 1, 1], strain[:, 0, 1]
    mean = 0.5 * (a + b)
    radius = np.hypot(0.5 * (a - b), c)
    theta = 0.5 * np.arctan2(2.0 * c, a - b)
    n1 = np.stack([np.cos(theta), np.sin(theta)], -1)
    n2 = np.stack([-n1[:, 1], n1[:, 0]], -1)
    return mean + radius, mean - radius, n1, n2


def states(e1: np.ndarray, e2: np.ndarray, poisson_ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """Boolean masks ``(wrinkled, slack)`` ``(ne,)``; the rest is taut."""
    slack = e1 <= 0.0
    wrinkled = ~slack & (e2 <= -poisson_ratio * e1)
    return wrinkled, slack


def _voigt(strain: np.ndarray) -> np.ndarray:
    return np.stack([strain[:, 0, 0], strain[:, 1, 1], 2.0 * strain[:, 0, 1]], -1)


def _tensor(sv: np.ndarray) -> np.ndarray:
    return np.stack([np.stack([sv[:, 0], sv[:, 2]], -1), np.stack([sv[:, 2], sv[:, 1]], -1)], -2)


def energy_density(d: np.ndarray, youngs_modulus: float, poisson_ratio: float,
                   strain: np.ndarray) -> np.ndarray:  # fmt: skip
    """Relaxed strain energy per unit reference volume ``W`` ``(ne,)`` (J/m³)."""
    ev = _voigt(strain)
    w = 0.5 * np.einsum("ep,pq,eq->e", ev, d, ev)
    e1, e2, _, _ = principal_strains(strain)
    wrinkled, slack = states(e1, e2, poisson_ratio)
    w[wrinkled] = 0.5 * youngs_modulus * e1[wrinkled] ** 2
    w[slack] = 0.0
    return w


def stress(d: np.ndarray, youngs_modulus: float, poisson_ratio: float,
           strain: np.ndarray) -> np.ndarray:  # fmt: skip
    """Relaxed 2nd Piola–Kirchhoff stress ``S = ∂W/∂E`` ``(ne, 2, 2)`` (Pa)."""
    s = _tensor(_voigt(strain) @ d.T)
    e1, e2, n1, _ = principal_strains(strain)
    wrinkled, slack = states(e1, e2, poisson_ratio)
    w = np.flatnonzero(wrinkled)
    s[w] = (youngs_modulus * e1[w])[:, None, None] * np.einsum("ei,ej->eij", n1[w], n1[w])
    s[slack] = 0.0
    return s


def tangent(d: np.ndarray, youngs_modulus: float, poisson_ratio: float,
            strain: np.ndarray) -> np.ndarray:  # fmt: skip
    """Voigt tangent ``∂S/∂E`` ``(ne, 3, 3)`` (Pa) of the relaxed law.

    Wrinkled: ``Y a aᵀ + Y ε₁/(2(ε₁ − ε₂)) b bᵀ`` with ``a = n₁⊗n₁`` and ``b = n₁⊗n₂ + n₂⊗n₁``
    in Voigt stress form; the second term is the rotation of the tension direction with the
    strain (``ε₁ − ε₂ ≥ (1 + ν) ε₁ > 0`` there, so it stays bounded)."""
    out = np.broadcast_to(d, (len(strain), 3, 3)).copy()
    e1, e2, n1, n2 = principal_strains(strain)
    wrinkled, slack = states(e1, e2, poisson_ratio)
    w = np.flatnonzero(wrinkled)
    p, q = n1[w], n2[w]
    a = np.stack([p[:, 0] ** 2, p[:, 1] ** 2, p[:, 0] * p[:, 1]], -1)
    b = np.stack([2 * p[:, 0] * q[:, 0], 2 * p[:, 1] * q[:, 1], p[:, 0] * q[:, 1] + p[:, 1] * q[:, 0]], -1)
    rot = 0.5 * e1[w] / (e1[w] - e2[w])
    out[w] = youngs_modulus * (np.einsum("ep,eq->epq", a, a)
                               + rot[:, None, None] * np.einsum("ep,eq->epq", b, b))  # fmt: skip
    out[slack] = 0.0
    return out


def relaxed_in_step(poisson_ratio: float, strain0: np.ndarray, strain1: np.ndarray) -> np.ndarray:
    """Indices ``(k,)`` of the elements wrinkled or slack at the start, the end or the midpoint
    of a step (strains ``(ne, 2, 2)``); elsewhere the step is SVK's."""
    ends = [principal_strains(e)[:2] for e in (strain0, strain1, 0.5 * (strain0 + strain1))]
    return np.flatnonzero(np.any([np.any(states(a, b, poisson_ratio), axis=0)
                                  for a, b in ends], axis=0))  # fmt: skip


def discrete_gradient_stress(d: np.ndarray, youngs_modulus: float, poisson_ratio: float,
                             strain0: np.ndarray, strain1: np.ndarray) -> np.ndarray:  # fmt: skip
    """Step stress ``S̄`` ``(ne, 2, 2)`` (Pa) with ``S̄ : (E₁ − E₀) = W(E₁) − W(E₀)`` exactly.

    Gonzalez's discrete gradient in strain space: the stress of the averaged strain plus the
    correction along ``ΔE`` that makes the work exact. It is applied only to elements wrinkled
    or slack at an end or at the midpoint; elsewhere (taut at all three: W is quadratic there
    to the step's order) ``S̄`` is the Simo–Tarnow average ``S((E₀ + E₁)/2)`` bit for bit, so a
    membrane that never wrinkles steps exactly as without the relaxation."""
    mid = stress(d, youngs_modulus, poisson_ratio, 0.5 * (strain0 + strain1))
    relaxed = relaxed_in_step(poisson_ratio, strain0, strain1)
    if len(relaxed) == 0:
        return mid
    e0, e1 = strain0[relaxed], strain1[relaxed]
    de = e1 - e0
    work = (energy_density(d, youngs_modulus, poisson_ratio, e1)
            - energy_density(d, youngs_modulus, poisson_ratio, e0))  # fmt: skip
    norm2 = np.einsum("eij,eij->e", de, de)
    defect = work - np.einsum("eij,eij->e", mid[relaxed], de)
    scale = np.where(norm2 > _DG_TINY, defect / np.where(norm2 > _DG_TINY, norm2, 1.0), 0.0)
    mid[relaxed] += scale[:, None, None] * de
    return mid


def discrete_gradient_tangent(d: np.ndarray, youngs_modulus: float, poisson_ratio: float,
                              strain0: np.ndarray, strain1: np.ndarray) -> np.ndarray:  # fmt: skip
    """``∂S̄/∂E₁`` ``(ne, 3, 3)`` (Pa, Voigt on ``[E11, E22, 2E12]``) of
    :func:`discrete_gradient_stress`, for the Newton matrix of a step.

    Taut at both ends and the midpoint: ``½ D``. Elsewhere by central differences (step 1e-6
    of the strain scale): the correction term's derivative matters for nearly slack elements,
    whose strain changes within a step are comparable with the strain itself, and without it
    the iteration stalls."""
    out = np.broadcast_to(0.5 * d, (len(strain0), 3, 3)).copy()
    relaxed = relaxed_in_step(poisson_ratio, strain0, strain1)
    if len(relaxed) == 0:
        return out
    e0, e1 = strain0[relaxed], strain1[relaxed]
    h = 1e-6 * np.maximum(np.max(np.abs(np.stack([e0, e1])), axis=(0, 2, 3)), 1e-9)
    for col, (i, j, f) in enumerate(((0, 0, 1.0), (1, 1, 1.0), (0, 1, 0.5))):
        de = np.zeros_like(e1)
        de[:, i, j] = de[:, j, i] = f * h  # Voigt column: 2E12 changes by h
        ds = (discrete_gradient_stress(d, youngs_modulus, poisson_ratio, e0, e1 + de)
              - discrete_gradient_stress(d, youngs_modulus, poisson_ratio, e0, e1 - de))  # fmt: skip
        ds /= (2.0 * h)[:, None, None]
        out[relaxed, :, col] = np.stack([ds[:, 0, 0], ds[:, 1, 1], ds[:, 0, 1]], -1)
    return out
