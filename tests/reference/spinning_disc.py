"""The free spinning membrane disc (Lamb & Southwell 1921): its plane-stress centrifugal
equilibrium and the out-of-plane frequencies in the rotating frame, in closed form (no quadmodes
code).

**Equilibrium (plane stress, small strain).** A free solid disc of radius ``a``, density ρ,
Young's modulus E and Poisson's ratio ν spinning at Ω about its normal: with the radial
displacement ``u(r)`` the equilibrium ``(r σ_r)' − σ_θ + ρΩ² r² = 0`` and Hooke's law in plane
stress give the Lamé-type solution regular at r = 0 with ``σ_r(a) = 0`` (Timoshenko & Goodier §32):

    σ_r = (3 + ν)/8 · ρΩ² (a² − r²),
    σ_θ = ρΩ²/8 · [(3 + ν) a² − (1 + 3ν) r²],
    u   = (1 − ν) ρΩ² r / (8E) · [(3 + ν) a² − (1 + ν) r²].

**Out-of-plane motion in the rotating frame.** A membrane (no bending stiffness) of thickness h
deflected by w(r, θ, t) along the spin axis: the Coriolis force 2Ω e × ẇ e vanishes and the
centrifugal force has no axial part, so the only out-of-plane stiffness is the prestress
(N = hσ, N_rθ = 0 by symmetry):

    ρh w_tt = (1/r) ∂_r (r N_r ∂_r w) + N_θ / r² ∂²_θ w.

With ``w = W(x) cos nθ cos ωt``, ``x = r/a``, ``λ = ω²/Ω²`` and ``c = (1 + 3ν)/(3 + ν)``, dividing
by ρhΩ²a² (3 + ν)/8:

    (1/x) (x (1 − x²) W')' − n² (1 − c x²)/x² W + μ W = 0,   μ = 8λ/(3 + ν),

i.e. ``L₀W + Λ W = 0`` with ``L₀W = (1/x)(x(1 − x²)W')' − n²W/x²`` and ``Λ = μ + n² c``. On
powers, ``L₀ x^m = (m² − n²) x^{m−2} − m(m + 2) x^m``, so ``W = Σ_k a_k x^{n+2k}`` (regular at
x = 0) needs

    a_{k+1} [(n + 2k + 2)² − n²] = a_k [(n + 2k)(n + 2k + 2) − Λ].

With t = x² this is a hypergeometric equation whose exponents at the free edge t = 1 are both 0:
a series that does not terminate diverges logarithmically there (the free edge, where σ_r = 0,
is a singular point and the solution must stay bounded). It terminates after s terms (s nodal
circles inside the disc) iff ``Λ = (n + 2s)(n + 2s + 2)``:

    ω²/Ω² = (3 + ν)/8 · (n + 2s)(n + 2s + 2) − (1 + 3ν)/8 · n²        (Lamb & Southwell 1921)

which depends on (n, s) and ν only (not on E, ρ, h, a or Ω). Checks: (n, s) = (0, 0) gives 0
(translation along the axis), (1, 0) gives ω = Ω (the rigid tilt, fixed in space, seen from the
rotating frame), (2, 0) gives (5 − ν)/2, (0, 1) gives 3 + ν.
"""

import math

import numpy as np


def radial_stress(r, radius: float, density: float, spin: float, nu: float):
    """σ_r (Pa) at radius ``r`` (m) of the free disc of ``radius`` (m), ``density`` (kg/m³)
    spinning at ``spin`` (rad/s) (module docstring)."""
    r = np.asarray(r, float)
    return (3.0 + nu) / 8.0 * density * spin**2 * (radius**2 - r**2)


def hoop_stress(r, radius: float, density: float, spin: float, nu: float):
    """σ_θ (Pa) at radius ``r`` (m) of the spinning free disc (module docstring)."""
    r = np.asarray(r, float)
    return density * spin**2 / 8.0 * ((3.0 + nu) * radius**2 - (1.0 + 3.0 * nu) * r**2)


def radial_displacement(r, radius: float, density: float, spin: float, nu: float, youngs: float):
    """u (m) at radius ``r`` (m) of the spinning free disc, Young's modulus ``youngs`` (Pa)."""
    r = np.asarray(r, float)
    k = (1.0 - nu) * density * spin**2 / (8.0 * youngs)
    return k * r * ((3.0 + nu) * radius**2 - (1.0 + nu) * r**2)


def frequency_ratio(n: int, s: int, nu: float) -> float:
    """ω/Ω of the out-of-plane mode with ``n`` nodal diameters and ``s`` nodal circles of the free
    spinning membrane disc, in the rotating frame (Lamb & Southwell; module docstring)."""
    lam = (3.0 + nu) / 8.0 * (n + 2 * s) * (n + 2 * s + 2) - (1.0 + 3.0 * nu) / 8.0 * n * n
    return math.sqrt(lam)


def mode_shape(n: int, s: int, x):
    """Radial shape W(x) of mode (n, s) at ``x = r/a`` (the terminating series; W(1) = 1)."""
    lam_cap = (n + 2 * s) * (n + 2 * s + 2)
    coef = [1.0]
    for k in range(s):
        m = n + 2 * k
        coef.append(coef[-1] * (m * (m + 2) - lam_cap) / ((m + 2) ** 2 - n * n))
    x = np.asarray(x, float)
    w = sum(c * x ** (n + 2 * k) for k, c in enumerate(coef))
    return w / sum(coef)


def spectrum(nu: float, below: float) -> list[tuple[float, int, int]]:
    """``(ω/Ω, n, s)`` of every elastic out-of-plane mode with ω/Ω < ``below``, ascending; modes
    with n > 0 are double (cos nθ and sin nθ) and listed once. The rigid (0, 0) and (1, 0) are
    left out."""
    out = []
    for n in range(0, 200):
        if frequency_ratio(n, 0, nu) >= below:
            break
        for s in range(0, 200):
            if (n, s) in ((0, 0), (1, 0)):
                continue
            ratio = frequency_ratio(n, s, nu)
            if ratio >= below:
                break
            out.append((ratio, n, s))
    return sorted(out)
