"""Radial membrane strips (heliogyro blades) spinning about the normal of their plane, clamped
at their roots to a held hub: flap and twist frequencies in the rotating frame (no quadmodes
code).

A strip of width w along x ∈ [b, R] (R = b + L) spinning at Ω: away from its root, the
centrifugal load is carried by the axial resultant T(x) = ∫N_x dy = ρ t w Ω² (R² − x²)/2 (the
free long edges carry no N_y beyond the small ``ρ t Ω² (w²/4 − y²)/2`` of the load across the
width). Out-of-plane motion meets no Coriolis or centrifugal force (both in the plane), so

* **flap** w = W(x): ``ρ t w ω² W = −(T W')'``, i.e. with λ = ω²/Ω²,
  ``−(½ (R² − x²) W')' = λ W``, W(b) = 0 (clamped root; the free tip x = R, where T = 0, is a
  regular singular point: the collocated equation is its boundedness condition);
* **twist** w = θ(x) y: ``ρ t w³/12 ω² θ = −(T w²/12 θ')' + (∫N_y dy) θ`` and ∫N_y dy = ρ t Ω²
  w³/12 (the membrane's propeller moment), so ω²/Ω² = λ_flap + 1 mode by mode.

Hinged at the axis (b = 0) the flap roots are λ = k(2k − 1) (Legendre; a check of the
collocation). Chebyshev collocation on [b, R] (Trefethen's cheb), roots kept where two
resolutions agree to 1e-8.
"""

import numpy as np
import scipy.linalg as la


def _cheb(n: int, lo: float, hi: float):
    k = np.arange(n + 1)
    t = np.cos(np.pi * k / n)
    c = np.where((k == 0) | (k == n), 2.0, 1.0) * (-1.0) ** k
    dt = t[:, None] - t[None, :]
    d = np.outer(c, 1.0 / c) / (dt + np.eye(n + 1))
    d -= np.diag(d.sum(axis=1))
    scale = 2.0 / (hi - lo)
    return lo + (t + 1.0) / scale, d * scale


def _flap(b: float, r: float, points: int) -> np.ndarray:
    x, d = _cheb(points, b, r)
    tension = 0.5 * (r * r - x * x)
    op = -(tension[:, None] * (d @ d) - x[:, None] * d)  # −(T W')' with T' = −x
    keep = np.arange(points)  # W(b) = 0: the last point
    lam = la.eigvals(op[np.ix_(keep, keep)])
    lam = lam[np.isfinite(lam) & (np.abs(lam.imag) < 1e-8 * np.maximum(1, np.abs(lam)))].real
    return np.sort(lam[lam > 1e-9])


def flap_ratios(inner: float, length: float, count: int, points: int = 48) -> np.ndarray:
    """ω/Ω of the lowest ``count`` flap modes of a strip from ``inner`` to ``inner + length``
    (m) held at its root, W(b) = 0 (a string has no slope condition: clamped = hinged)."""
    r = inner + length
    coarse = _flap(inner, r, points)
    fine = _flap(inner, r, int(1.5 * points))
    kept = [v for v in coarse if np.min(np.abs(fine - v)) < 1e-8 * max(1.0, v)]
    return np.sqrt(np.array(kept[:count]))


def twist_ratios(inner: float, length: float, count: int) -> np.ndarray:
    """ω/Ω of the lowest ``count`` twist modes (module docstring: λ_flap + 1)."""
    return np.sqrt(flap_ratios(inner, length, count) ** 2 + 1.0)
