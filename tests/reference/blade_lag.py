"""Quasi-static lag of a blade under a constant spin acceleration (no quadmodes code).

A blade of mass μ per length from the hub's rim r = b to its tip R turns with the hub at Ω and
accelerates at α = Ω̇ (both about the hub's axis). In the hub's frame each element feels the
Euler force −μ α r along the direction of rotation (a spin-up makes the blade lag: v < 0), the
centrifugal tension T(r) = μΩ²(R² − r²)/2 and, for a lateral displacement v in the plane of
rotation, the centrifugal force μΩ²v. Quasi-statically (the spin's change slow against the lag
frequency)

    EI v'''' − (T v')' − μΩ² v = −μ α r,      v(b) = 0 (and v'(b) = 0 with EI > 0).

**String** (EI = 0, hinged at the rim): with ξ = r/R, β = b/R and v = −(αR/Ω²) V(ξ),
((1 − ξ²)V')' + 2V = 2ξ. Reduction of order V = ξu gives ξ(1 − ξ²)u'' + (2 − 4ξ²)u' = 2ξ, whose
integrating factor is ξ²(1 − ξ²): u' = (2ξ³/3 + C)/(ξ²(1 − ξ²)); V bounded at the tip needs
C = −2/3, so u' = −(2/3)(1/ξ² + 1/(1 + ξ)) and

    V(ξ) = (2/3) [1 − ξ ln(1 + ξ) − (ξ/β)(1 − β ln(1 + β))],

and v = (αR/Ω²) V (V(1) < 0: the tip lags; :func:`string_tip_lag`). The root
slope satisfies the moment balance b T(b) v'(b) = −α ∫ μ r² dr (the hub's torque on the blade
accelerates its moment of inertia about the axis), a check of the algebra.

**Beam-string** (EI > 0, clamped at the rim, free tip: v'' = 0 and EI v''' − T v' = 0 with
T(R) = 0): solved by Chebyshev collocation (:func:`beam_string_tip_lag`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.polynomial import chebyshev as C


def string_lag_shape(xi, beta: float) -> np.ndarray:
    """V(ξ) of the hinged string (dimensionless; v = (α R / Ω²) V, V < 0: a lag)."""
    xi = np.asarray(xi, float)
    return (2.0 / 3.0) * (1.0 - xi * np.log1p(xi) - (xi / beta) * (1.0 - beta * math.log1p(beta)))


def string_tip_lag(alpha: float, spin: float, root: float, tip: float) -> float:
    """Quasi-static in-plane tip deflection v(R) (m, negative: lag) of a string hinged at
    ``root`` (m) reaching ``tip`` (m, from the axis) on a hub accelerating at ``alpha`` (rad/s²)
    while spinning at ``spin`` (rad/s)."""
    return (alpha * tip / spin**2) * float(string_lag_shape(1.0, root / tip))


def string_root_slope(alpha: float, spin: float, root: float, tip: float) -> float:
    """v'(b) of the hinged string: (α/Ω²) dV/dξ at β of the shape above (dimensionless), i.e.
    −(2α/3Ω²)(1/β + β/(1 + β))."""
    beta = root / tip
    return -(2.0 * alpha / (3.0 * spin**2)) * (1.0 / beta + beta / (1.0 + beta))


def beam_string_tip_lag(alpha: float, spin: float, root: float, tip: float, mu: float,
                        ei: float, n: int = 48) -> float:  # fmt: skip
    """Quasi-static tip deflection (m) of a beam of bending stiffness ``ei`` (N m²) and mass
    ``mu`` (kg/m) clamped at ``root`` (m), free at ``tip`` (m), under the Euler load and the
    centrifugal tension of the module docstring; Chebyshev collocation of degree ``n``."""
    half, mid = 0.5 * (tip - root), 0.5 * (tip + root)
    x = np.cos(np.pi * np.arange(n + 1) / n)  # Gauss–Lobatto points on [−1, 1]
    r = mid + half * x
    eye = np.eye(n + 1)

    def d(k):  # k-th derivative in r of each basis polynomial at the points: (n+1, n+1)
        return np.stack([C.chebval(x, C.chebder(eye[j], k)) / half**k for j in range(n + 1)], 1)

    d0, d1, d2, d3, d4 = (d(k) for k in range(5))
    t = 0.5 * mu * spin**2 * (tip**2 - r**2)
    dt = -mu * spin**2 * r
    a = ei * d4 - (t[:, None] * d2 + dt[:, None] * d1) - mu * spin**2 * d0
    rhs = -mu * alpha * r
    root_i, tip_i = n, 0  # x = −1 is r = root; x = 1 is the tip
    rows = [(root_i, d0[root_i], 0.0), (root_i - 1, d1[root_i], 0.0),
            (tip_i, d2[tip_i], 0.0), (tip_i + 1, ei * d3[tip_i] - t[tip_i] * d1[tip_i], 0.0)]
    for i, row, val in rows:  # boundary conditions replace the equations next to the ends
        a[i], rhs[i] = row, val
    coef = np.linalg.solve(a, rhs)
    return float(C.chebval(1.0, coef))
