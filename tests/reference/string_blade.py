"""Spin-stiffened string blades on a rigid hub of finite radius: rotating-frame flap and lag
frequencies in closed form (no quadmodes code).

**The blade.** A string (no bending stiffness) of mass μ per length from the hub's rim r₀ to
R = r₀ + L, spinning at Ω about the hub axis e normal to it, carries the centrifugal tension
``T(r) = μΩ²(R² − r²)/2`` (free tip). In the frame turning with it, the flap w (along e) meets
no Coriolis force (e × ẇe = 0) and no centrifugal force, the lag v (in the plane, normal to the
blade) meets the centrifugal softening μΩ²v; the Coriolis force of v̇ is radial and only changes
the tension at first order, which acts on v at second order (the blade is straight), so

    μ ẅ = (T w')',            μ v̈ = (T v')' + μΩ² v.

With ``ξ = r/R`` and ``λ = ω²/Ω²`` both are Legendre's equation ``((1 − ξ²) y')' + ν(ν + 1) y = 0``
with ``ν(ν + 1) = 2λ`` (flap) and ``2(λ + 1)`` (lag); the solution bounded at the free tip ξ = 1
(a regular singular point with exponents 0, 0) is ``P_ν(ξ) = ₂F₁(−ν, ν + 1; 1; (1 − ξ)/2)``.

**Hinged at a fixed rim** (a hub of infinite inertia): ``P_ν(ξ₀) = 0``, ξ₀ = r₀/R; flap
λ = ν(ν + 1)/2, lag λ = ν(ν + 1)/2 − 1. For r₀ → 0 the roots are the odd degrees, the classical
``ω²/Ω² = k(2k − 1)`` (1, 6, 15, …) in flap and ``k(2k − 1) − 1`` (0, 5, 14, …) in lag: the
first lag of a blade hinged on the axis is the neutral rotation of the blade about the axis.

**On a free rigid hub** (mass m_h, moments I_x, I_y, I_z about its centre; thin, so that its
own out-of-plane motion meets no Coriolis force) with two blades along ±x, three families
involve one hub motion each, by the symmetry of the two blades (T₀ = T(r₀)):

* collective flap (w_A = w_B, hub translation z along e): ``w(r₀) = z`` and
  ``m_h z̈ = 2 T₀ w'(r₀)``;
* cyclic flap (w_A = −w_B, hub tilt θ about y): ``w(r₀) = −r₀θ`` and
  ``I_y θ̈ + (Ω² I_y + 2T₀ r₀) θ = −2 r₀ T₀ w'(r₀)`` — the rigid-body centrifugal moment Ω²I_yθ
  of the thin hub and the work of the root tension as the rim point moves in by r₀θ²/2;
* collective lag (v_A = v_B, hub rotation ψ about e): ``v(r₀) = r₀ψ`` and
  ``I_z ψ̈ = 2 r₀ T₀ v'(r₀) − 2 T₀ r₀ ψ``.

With ``y = C P_ν(ξ)`` each is one transcendental equation in ν (``characteristic``); the rigid
motions are roots (ν = 1: the tilt at λ = 1, i.e. the nutation of a flat body at exactly the
spin; the rotation about e at λ = 0), which checks the hub terms. The cyclic lag couples the
hub's translation in the plane (with its Coriolis force) to the blades' axial motion and is not
given here.
"""

import numpy as np
from scipy.optimize import brentq
from scipy.special import hyp2f1


def legendre(nu: float, x: float) -> tuple[float, float]:
    """``(P_ν(x), P_ν'(x))`` for real degree ν ≥ 0 and −1 < x ≤ 1 (the solution of Legendre's
    equation regular at x = 1), from ₂F₁ and its derivative d/dz ₂F₁(a, b; c; z) = ab/c
    ₂F₁(a + 1, b + 1; c + 1; z), z = (1 − x)/2."""
    z = 0.5 * (1.0 - x)
    p = hyp2f1(-nu, nu + 1.0, 1.0, z)
    dp = 0.5 * nu * (nu + 1.0) * hyp2f1(1.0 - nu, nu + 2.0, 2.0, z)
    return float(p), float(dp)


def _lam(nu: float, family: str) -> float:
    """λ = ω²/Ω² of degree ν: ν(ν+1)/2 in flap, ν(ν+1)/2 − 1 in lag."""
    return 0.5 * nu * (nu + 1.0) - (1.0 if family == "lag" else 0.0)


def characteristic(nu: float, kind: str, r0: float, radius: float, mu: float,
                   hub: tuple[float, float, float, float] | None) -> float:  # fmt: skip
    """The frequency equation in the degree ν (zero at a root), per Ω² (so independent of Ω).
    ``kind``: "hinged-flap", "hinged-lag", "collective-flap", "cyclic-flap", "collective-lag";
    ``hub = (m_h, I_x, I_y, I_z)`` (kg, kg m²) for the free-hub kinds."""
    x0 = r0 / radius
    p, dp = legendre(nu, x0)
    if kind.startswith("hinged"):
        return p
    m_h, _, i_y, i_z = hub
    t0 = mu * (radius**2 - r0**2) / 2.0  # T₀/Ω² (kg m)
    lam = _lam(nu, "lag" if kind.endswith("lag") else "flap")
    if kind == "collective-flap":
        return -lam * m_h * p - 2.0 * t0 * dp / radius
    if kind == "cyclic-flap":
        return (i_y * (1.0 - lam) + 2.0 * t0 * r0) * p - 2.0 * r0**2 * t0 * dp / radius
    if kind == "collective-lag":
        return -lam * i_z * p / r0 - 2.0 * t0 * (r0 * dp / radius - p)
    raise ValueError(kind)


def string_blade_ratios(kind: str, r0: float, length: float, mu: float,
                        hub: tuple[float, float, float, float] | None = None, count: int = 4,
                        nu_max: float = 40.0) -> np.ndarray:  # fmt: skip
    """The lowest ``count`` rotating-frame frequency ratios ω/Ω ``(count,)`` of ``kind`` (see
    :func:`characteristic`) for blades from r₀ to r₀ + ``length`` (m), μ (kg/m); the rigid
    motions (the rotation about e, λ = 0) are left out, the tilt/nutation (λ = 1) kept."""
    radius = r0 + length
    grid = np.linspace(0.3, nu_max, 4000)
    vals = [characteristic(v, kind, r0, radius, mu, hub) for v in grid]
    out = []
    for a, b, fa, fb in zip(grid[:-1], grid[1:], vals[:-1], vals[1:], strict=True):
        if fa == 0.0 or fa * fb < 0.0:
            nu = brentq(characteristic, a, b, args=(kind, r0, radius, mu, hub), xtol=1e-14)
            lam = _lam(nu, "lag" if kind.endswith("lag") else "flap")
            if lam > 1e-9:
                out.append(np.sqrt(lam))
        if len(out) == count:
            break
    return np.array(out)
