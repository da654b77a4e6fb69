"""A spinning membrane annulus clamped at its inner edge to a rigid hub: the plane-stress
centrifugal equilibrium in closed form and the out-of-plane frequencies in the rotating frame by
Chebyshev collocation (no quadmodes code).

**Equilibrium (plane stress, small strain).** An annulus b ≤ r ≤ a (density ρ, Young's modulus
E, Poisson's ratio ν) spinning at Ω about its normal, with the radial displacement u(r):
equilibrium ``σ_r' + (σ_r − σ_θ)/r + ρΩ² r = 0`` and Hooke's law give the Lamé-type solution

    u   = C₁ r + C₂ / r − (1 − ν²) ρΩ² r³ / (8E),
    σ_r = A − B / r² − (3 + ν)/8 · ρΩ² r²,     A = E C₁ / (1 − ν),
    σ_θ = A + B / r² − (1 + 3ν)/8 · ρΩ² r²,    B = E C₂ / (1 + ν),

(the particular part ``−k r³`` gives ``σ_r = −(3 + ν)ρΩ²r²/8``, ``σ_θ = −(1 + 3ν)ρΩ²r²/8``,
which satisfy the equilibrium). A rigid hub holds ``u(b) = 0``; the outer edge is free,
``σ_r(a) = 0``: with ``β = b/a`` and stresses in units of ρΩ²a²,

    A − B = (3 + ν)/8,     (1 − ν) A + (1 + ν) B / β² = (1 − ν²) β² / 8.

(β → 0 gives B → 0, A = (3 + ν)/8: the free disc of Lamb & Southwell.)

**Out-of-plane motion in the rotating frame.** The membrane's deflection w along the axis meets
neither a Coriolis nor a centrifugal force (both lie in the plane), so with w = W(r) cos nθ,

    σ_r W'' + (σ_r' + σ_r / r) W' − n² σ_θ W / r² + ρ ω² W = 0       (stress from above),

i.e. in x = r/a and λ = ω²/Ω² the operator ``L W = −λ W``. At the free edge σ_r = 0 (a
regular singular point: the collocated equation itself is the boundedness condition). At the
hub, W(b) follows the hub:

* **held hub** (or infinitely massive): W(b) = 0, every n;
* **n = 0, free hub** of mass m_h: W(b) = c, the hub's axial displacement, whose equation is
  ``−ω² m_h c = 2π b t σ_r(b) W'(b)`` (the membrane's pull along its own slope), i.e.
  ``2π β σ̂_r W'(β) = −λ μ W(β)`` with ``μ = m_h / (ρ t a²)``; λ = 0 (the translation) left out;
* **n = 1, free hub** with inertia I_t (about an in-plane axis) and I_z (axial): W(b) = b q
  (q the hub's tilt), whose equation in the rotating frame, the hub's kinetic energy
  ``½ Σ S_i |ȧ_i + Ω e × a_i|²`` linearised (S_i = ½ tr I − I_ii, its principal second
  moments), is, for a tilt ψ = φ_x + i φ_y ∝ e^{iωt} (ω signed: forward > 0),

      (Ω² (I_z − I_t) − ω² I_t − 2 S₃ Ω ω) ψ = π b² t σ_r(b) (W'(b) − W(b)/b),
      S₃ = I_t − I_z / 2,

  (the membrane's pull on the hub's rim point ρ′ = ρ + θ × ρ is ``N_r (e_r + W' e_z)``; its
  moment ``ρ′ × f`` has the slope's part and the in-plane tension's arm w, so a rigid tilt
  W = q r, where W' = W/b, loads the hub with no moment),

  without Coriolis (the modes of the rotating-frame stiffness, ``quadmodes modes``) the
  ``2 S₃ Ω ω`` term drops. (W = q r solves the membrane's equation at λ = 1, since
  ``σ_r' + (σ_r − σ_θ)/r = −ρΩ²r``; with it the hub's row holds at ω = −Ω: the whole body's
  tilt, fixed in space, seen from the frame.) The membrane (no Coriolis out of its plane) answers each circular
  component with the same equation; with it the problem is quadratic in ω, solved by its
  companion linearisation.

Collocation on the Gauss–Lobatto points of [β, 1] (Trefethen, *Spectral methods in MATLAB*,
cheb), the hub's row replaced by its condition; ``scipy.linalg.eig``; spurious (complex or
unconverged) roots are left out by requiring two resolutions to agree.
"""

import math

import numpy as np
import scipy.linalg as la


def lame_constants(beta: float, nu: float) -> tuple[float, float]:
    """``(A, B)`` in units of ρΩ²a² (and ρΩ²a⁴ for B) of the annulus clamped at x = β."""
    m = np.array([[1.0, -1.0], [1.0 - nu, (1.0 + nu) / beta**2]])
    rhs = np.array([(3.0 + nu) / 8.0, (1.0 - nu * nu) * beta**2 / 8.0])
    a, b = np.linalg.solve(m, rhs)
    return float(a), float(b)


def stresses(r, outer: float, inner: float, density: float, spin: float, nu: float):
    """``(σ_r, σ_θ)`` (Pa) at radii ``r`` (m) of the annulus ``inner``–``outer`` (m) clamped at
    ``inner``, ``density`` (kg/m³), ``spin`` (rad/s)."""
    x = np.asarray(r, float) / outer
    a, b = lame_constants(inner / outer, nu)
    scale = density * spin**2 * outer**2
    sr = a - b / x**2 - (3.0 + nu) / 8.0 * x**2
    st = a + b / x**2 - (1.0 + 3.0 * nu) / 8.0 * x**2
    return scale * sr, scale * st


def radial_displacement(r, outer, inner, density, spin, nu, youngs):
    """u (m) at radii ``r`` (m) of the clamped annulus (module docstring), E = ``youngs`` Pa."""
    x = np.asarray(r, float) / outer
    a, b = lame_constants(inner / outer, nu)
    # u = C₁ r + C₂/r − k r³ with C₁ = (1 − ν)A/E, C₂ = (1 + ν)B/E (A, B in Pa, Pa m²)
    scale = density * spin**2 * outer**2 * outer / youngs
    return scale * ((1.0 - nu) * a * x + (1.0 + nu) * b / x - (1.0 - nu * nu) / 8.0 * x**3)


def _cheb(n: int, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Lobatto points ``(n+1,)`` on [lo, hi] (x[0] = hi) and the differentiation matrix."""
    k = np.arange(n + 1)
    t = np.cos(np.pi * k / n)
    c = np.where((k == 0) | (k == n), 2.0, 1.0) * (-1.0) ** k
    dt = t[:, None] - t[None, :]
    d = np.outer(c, 1.0 / c) / (dt + np.eye(n + 1))
    d -= np.diag(d.sum(axis=1))
    scale = 2.0 / (hi - lo)
    return lo + (t + 1.0) / scale, d * scale


def _operator(n_diam: int, beta: float, nu: float, points: int):
    """``(x, D, L)``: the operator L of ``L W = −λ W`` on the collocation points."""
    x, d = _cheb(points, beta, 1.0)
    a, b = lame_constants(beta, nu)
    sr = a - b / x**2 - (3.0 + nu) / 8.0 * x**2
    dsr = 2.0 * b / x**3 - (3.0 + nu) / 4.0 * x
    st = a + b / x**2 - (1.0 + 3.0 * nu) / 8.0 * x**2
    op = sr[:, None] * (d @ d) + (dsr + sr / x)[:, None] * d - np.diag(n_diam**2 * st / x**2)
    return x, d, op, sr


def _roots(n_diam, beta, nu, points, hub) -> np.ndarray:
    """Sorted frequency ratios ω/Ω (ω > 0, or signed for the gyroscopic n = 1) at one
    resolution; ``hub``: None (held) or ``(kind, parameters)``."""
    x, d, op, sr = _operator(n_diam, beta, nu, points)
    last = points  # the row of x = β
    eye = np.eye(points + 1)
    if hub is None:
        keep = np.arange(points)
        lam = la.eigvals(-op[np.ix_(keep, keep)])
        return _clean(lam)
    kind, p = hub
    a_mat, b_mat = -op.copy(), eye.copy()
    if kind == "axial":
        a_mat[last] = 2.0 * np.pi * beta * sr[last] * d[last]
        b_mat[last] = 0.0
        b_mat[last, last] = -p["mu"]
        return _clean(la.eigvals(a_mat, b_mat))
    # tilt: row π β² σ̂_r (W'(β) − W(β)/β) − (ΔI − ν² I_t − 2 S₃ ν) W(β)/β = 0:
    # A0 + ν A1 + ν² A2 = 0 by its companion pencil
    a0, a1, a2 = op.copy(), np.zeros_like(op), eye.copy()
    a0[last] = np.pi * beta**2 * sr[last] * d[last]
    a0[last, last] -= p["dI"] / beta + np.pi * beta * sr[last]
    a2[last] = 0.0
    a2[last, last] = p["It"] / beta
    a1[last, last] = 2.0 * p["S3"] / beta * p["gyro"]
    m = len(op)
    z = np.zeros((m, m))
    left = np.block([[z, eye], [a0, a1]])
    right = np.block([[eye, z], [z, -a2]])
    nu_roots = la.eigvals(left, right)
    ok = np.isfinite(nu_roots) & (np.abs(nu_roots.imag) < 1e-8 * np.maximum(1, np.abs(nu_roots)))
    return np.sort(nu_roots[ok].real)


def _clean(lam: np.ndarray) -> np.ndarray:
    """ω/Ω of the finite, real, positive eigenvalues λ = ω²/Ω², ascending."""
    ok = np.isfinite(lam) & (np.abs(lam.imag) < 1e-8 * np.maximum(1, np.abs(lam)))
    lam = lam[ok].real
    return np.sort(np.sqrt(lam[lam > 1e-9]))


def frequency_ratios(n_diam: int, beta: float, nu: float, below: float, hub=None,
                     points: int = 48) -> np.ndarray:  # fmt: skip
    """ω/Ω (ascending) of the out-of-plane modes with ``n_diam`` nodal diameters below ``below``
    of the annulus clamped at x = β (module docstring); ``hub``: None (held), ``("axial",
    {"mu": m_h/(ρ t a²)})`` for n = 0, ``("tilt", {"It": I_t, "dI": I_z − I_t, "S3": I_t −
    I_z/2, "gyro": 0 or 1})`` (inertias over ρ t a⁴) for n = 1 — then ω/Ω is signed, forward
    positive, and with ``gyro = 0`` only the non-negative roots are returned. Only roots that
    two resolutions (``points`` and 1.5 ×) give to 1e-8 are kept."""
    fine = _roots(n_diam, beta, nu, int(1.5 * points), hub)
    coarse = _roots(n_diam, beta, nu, points, hub)
    kept = [r for r in coarse if abs(r) < below and np.min(np.abs(fine - r)) < 1e-8 * max(1, abs(r))]
    if hub is not None and hub[0] == "tilt" and not hub[1]["gyro"]:
        kept = [r for r in kept if r > 1e-9]
    return np.array(kept)


def hub_parameters(mass, inertia_t, inertia_z, density, thickness, outer) -> dict:
    """The hub's nondimensional parameters (module docstring) of a hub of ``mass`` (kg) and
    moments ``inertia_t`` (about an in-plane axis), ``inertia_z`` (kg m²)."""
    unit_m = density * thickness * outer**2
    unit_i = unit_m * outer**2
    it, iz = inertia_t / unit_i, inertia_z / unit_i
    return {"mu": mass / unit_m, "It": it, "dI": iz - it, "S3": it - 0.5 * iz}


def lamb_southwell(n: int, s: int, nu: float) -> float:
    """ω/Ω of the free disc (the β → 0 limit for n ≥ 2; Lamb & Southwell 1921)."""
    return math.sqrt((3.0 + nu) / 8.0 * (n + 2 * s) * (n + 2 * s + 2) - (1.0 + 3.0 * nu) / 8.0 * n * n)
